//! Automatic gain control: a first-order loop on the log of the gain,
//! servoing the frame's mean signal to a set-point, with bright-source
//! protection.

use crate::config::Agc;

pub use gloam_io::frame::AgcState;

/// The loop of `agc` within the hardware gain limits, at one frame per
/// `frame_period_s`.
#[derive(Clone, Debug)]
pub struct AgcLoop {
    pub agc: Agc,
    pub hardware_min_gain: f64,
    pub hardware_max_gain: f64,
    pub frame_period_s: f64,
    /// With autogating, the shortest gate over the exposure (the least
    /// duty factor); `None`: gain only.
    pub min_duty: Option<f64>,
}

/// What the loop sets for the next frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AgcSetting {
    pub gain: f64,
    /// The gate's duty factor, ≤ 1 (1 without autogating).
    pub duty: f64,
    pub state: AgcState,
}

impl AgcLoop {
    /// One step after a frame whose mean signal above black was
    /// `signal_dn` at gain `gain` and gate duty `duty`: on the log of the
    /// throughput `T = g·d`,
    /// `ln T ← ln T + (1 − e^{−Δt/τ}) (ln set-point − ln signal)`; the
    /// gain takes `T` within its limits and, with autogating, the gate
    /// what remains below the least gain (the gate opens fully before the
    /// gain rises: more photoelectrons, less noise). Bright-source
    /// protection multiplies `T` by `protect_factor` instead when the mean
    /// or the saturated fraction passes its threshold. In the linear range
    /// the log error decays as `e^{−t/τ}`.
    pub fn step(&self, gain: f64, duty: f64, signal_dn: f64, sat_frac: f64) -> AgcSetting {
        self.step_metered(gain, duty, signal_dn, signal_dn, sat_frac)
    }

    /// [`AgcLoop::step`] servoing `metered_dn` (the frame's mean or
    /// median above black, as `agc.metering` says) while bright-source
    /// protection still compares the frame's mean, `mean_dn`, with
    /// `protect_mean_dn`: under median metering a lamp filling a third of
    /// the frame moved the median not at all, and the threshold named a
    /// mean never tripped.
    pub fn step_metered(
        &self,
        gain: f64,
        duty: f64,
        metered_dn: f64,
        mean_dn: f64,
        sat_frac: f64,
    ) -> AgcSetting {
        let signal_dn = metered_dn;
        let a = &self.agc;
        let lo = a
            .min_gain
            .unwrap_or(self.hardware_min_gain)
            .max(self.hardware_min_gain);
        let hi = a
            .max_gain
            .unwrap_or(self.hardware_max_gain)
            .min(self.hardware_max_gain);
        let protect = a.protect_mean_dn.is_some_and(|t| mean_dn > t)
            || (sat_frac > a.protect_saturated_fraction && a.protect_saturated_fraction > 0.0);
        let through = gain * duty;
        let mut state = AgcState::Tracking;
        let want = if protect {
            state = AgcState::Protecting;
            through * a.protect_factor
        } else {
            let dt = self.frame_period_s;
            let alpha = 1.0 - (-dt / a.time_constant_s).exp();
            let measured = signal_dn.max(1e-3);
            (through.ln() + alpha * (a.set_point_dn.ln() - measured.ln())).exp()
        };
        let g = want.clamp(lo, hi);
        let least_duty = self.min_duty.unwrap_or(1.0).min(1.0);
        let d = (want / g).clamp(least_duty, 1.0);
        if !protect {
            if want > hi {
                state = AgcState::AtMaxGain;
            } else if want < lo * least_duty {
                state = AgcState::AtMinGain;
            }
        }
        AgcSetting {
            gain: g,
            duty: d,
            state,
        }
    }
}

/// The median of a frame's counts, DN (the lower middle value of an even
/// count): O(n) by selection on a copy.
pub fn median_dn<'a>(pixels: impl IntoIterator<Item = &'a u16>) -> f64 {
    let mut v: Vec<u16> = pixels.into_iter().copied().collect();
    if v.is_empty() {
        return 0.0;
    }
    let mid = (v.len() - 1) / 2;
    f64::from(*v.select_nth_unstable(mid).1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lp(tau: f64) -> AgcLoop {
        AgcLoop {
            agc: Agc {
                enabled: true,
                set_point_dn: 100.0,
                time_constant_s: tau,
                min_gain: None,
                max_gain: None,
                protect_mean_dn: None,
                protect_saturated_fraction: 0.02,
                protect_factor: 0.5,
                gate_min_s: None,
                metering: crate::config::Metering::Mean,
            },
            hardware_min_gain: 1.0,
            hardware_max_gain: 1e6,
            frame_period_s: 0.04,
            min_duty: None,
        }
    }

    #[test]
    fn log_gain_error_decays_as_exp_minus_t_over_tau() {
        // A linear camera (signal = gain × 0.1 DN): after n frames the
        // log-gain error is e^{−n Δt/τ} of the start (first-order loop).
        let (l, k) = (lp(0.5), 0.1);
        let target = 100.0 / k;
        let mut g: f64 = 10.0;
        let e0 = (g / target).ln();
        for _ in 0..25 {
            g = l.step(g, 1.0, g * k, 0.0).gain;
        }
        let want = e0 * (-25.0 * 0.04 / 0.5f64).exp();
        assert!(((g / target).ln() - want).abs() < 1e-12, "{g}");
    }

    #[test]
    fn median_metering_still_protects_on_the_mean() {
        // A lamp over a third of the frame: the median (the road, 20 DN)
        // is low, the mean (300 DN) past protect_mean_dn. The loop servos
        // the median but protection named a mean and once never tripped.
        let mut l = lp(0.5);
        l.agc.protect_mean_dn = Some(200.0);
        l.agc.metering = crate::config::Metering::Median;
        let s = l.step_metered(100.0, 1.0, 20.0, 300.0, 0.0);
        assert_eq!((s.gain, s.state), (50.0, AgcState::Protecting));
        let s = l.step_metered(100.0, 1.0, 20.0, 150.0, 0.0);
        assert_eq!(s.state, AgcState::Tracking);
        assert!(s.gain > 100.0, "servoing the median up: {}", s.gain);
    }

    #[test]
    fn protection_halves_and_limits_report() {
        let l = lp(0.5);
        let s = l.step(100.0, 1.0, 50.0, 0.5);
        assert_eq!((s.gain, s.duty, s.state), (50.0, 1.0, AgcState::Protecting));
        assert_eq!(l.step(1e6, 1.0, 1e-9, 0.0).state, AgcState::AtMaxGain);
        let s = l.step(1.0, 1.0, 1e9, 0.0);
        assert_eq!((s.gain, s.duty, s.state), (1.0, 1.0, AgcState::AtMinGain));
    }

    #[test]
    fn autogating_carries_the_loop_below_the_least_gain_and_opens_first() {
        // A linear camera whose signal is g·d·L·0.1 DN, under light 10⁵×
        // what the least gain can hold at the set point: with a gate down
        // to 10⁻⁶ of the exposure the loop settles at the least gain and
        // duty 10⁻⁵ (throughput = set point / (L·k)), the log error
        // decaying as e^{−t/τ} as with gain alone.
        let mut l = lp(0.5);
        l.min_duty = Some(1e-6);
        let (k, light) = (0.1, 1e5 * 100.0 / 0.1);
        let (mut g, mut d) = (1.0f64, 1.0f64);
        let target = 100.0 / (light * k);
        let e0 = (g * d / target).ln();
        for _ in 0..500 {
            let s = l.step(g, d, g * d * light * k, 0.0);
            (g, d) = (s.gain, s.duty);
            assert_eq!(s.gain, 1.0, "the gain stays at its least while gated");
        }
        let want = e0 * (-500.0 * 0.04 / 0.5f64).exp();
        assert!(((g * d / target).ln() - want).abs() < 1e-9, "{g} {d}");
        assert!((d / 1e-5 - 1.0).abs() < 1e-9);
        // Darkness returns: the gate opens fully before the gain rises.
        let mut seen_gain_rise_with_gate_closed = false;
        for _ in 0..2000 {
            let s = l.step(g, d, g * d * 1.0 * k, 0.0);
            seen_gain_rise_with_gate_closed |= s.gain > 1.0 && s.duty < 1.0;
            (g, d) = (s.gain, s.duty);
        }
        assert!(!seen_gain_rise_with_gate_closed);
        assert!((d - 1.0).abs() < 1e-15 && g > 100.0, "{g} {d}");
        // At the shortest gate the loop says so.
        let s = l.step(1.0, 1e-6, 1e9, 0.0);
        assert_eq!((s.duty, s.state), (1e-6, AgcState::AtMinGain));
    }

    #[test]
    fn the_median_is_the_middle_count() {
        let a = ndarray::Array2::from_shape_vec((2, 3), vec![9u16, 1, 7, 3, 5, 100]).unwrap();
        // Sorted 1 3 5 7 9 100: the lower middle is 5.
        assert_eq!(median_dn(&a), 5.0);
        let b = ndarray::Array2::from_shape_vec((1, 3), vec![4u16, 4000, 2]).unwrap();
        assert_eq!(median_dn(&b), 4.0);
    }
}
