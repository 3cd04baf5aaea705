//! Automatic gain control: a first-order loop on the log of the gain,
//! servoing the frame's mean signal to a set-point, with bright-source
//! protection.

use serde::{Deserialize, Serialize};

use crate::config::Agc;

/// What the gain loop is doing for a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AgcState {
    /// No AGC: the configured fixed gain.
    Off,
    /// A manual override fixes the gain.
    Override,
    /// Servoing toward the set-point.
    Tracking,
    /// Wants more gain than its upper limit allows.
    AtMaxGain,
    /// Wants less gain than its lower limit allows.
    AtMinGain,
    /// Bright-source protection is cutting the gain.
    Protecting,
}

/// The loop of `agc` within the hardware gain limits, at one frame per
/// `frame_period_s`.
#[derive(Clone, Debug)]
pub struct AgcLoop {
    pub agc: Agc,
    pub hardware_min_gain: f64,
    pub hardware_max_gain: f64,
    pub frame_period_s: f64,
}

impl AgcLoop {
    /// One step after a frame whose mean signal above black was
    /// `signal_dn` at gain `gain`:
    /// `ln g ← ln g + (1 − e^{−Δt/τ}) (ln set-point − ln signal)`, clamped to
    /// the limits; bright-source protection multiplies g by `protect_factor`
    /// instead when the mean or the saturated fraction passes its threshold.
    /// In the linear range the log-gain error decays as `e^{−t/τ}`.
    pub fn step(&self, gain: f64, signal_dn: f64, sat_frac: f64) -> (f64, AgcState) {
        let a = &self.agc;
        let lo = a
            .min_gain
            .unwrap_or(self.hardware_min_gain)
            .max(self.hardware_min_gain);
        let hi = a
            .max_gain
            .unwrap_or(self.hardware_max_gain)
            .min(self.hardware_max_gain);
        let protect = a.protect_mean_dn.is_some_and(|t| signal_dn > t)
            || (sat_frac > a.protect_saturated_fraction && a.protect_saturated_fraction > 0.0);
        let mut state = AgcState::Tracking;
        let want = if protect {
            state = AgcState::Protecting;
            gain * a.protect_factor
        } else {
            let dt = self.frame_period_s;
            let alpha = 1.0 - (-dt / a.time_constant_s).exp();
            let measured = signal_dn.max(1e-3);
            (gain.ln() + alpha * (a.set_point_dn.ln() - measured.ln())).exp()
        };
        let g = want.clamp(lo, hi);
        if !protect {
            if want > hi {
                state = AgcState::AtMaxGain;
            } else if want < lo {
                state = AgcState::AtMinGain;
            }
        }
        (g, state)
    }
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
            },
            hardware_min_gain: 1.0,
            hardware_max_gain: 1e6,
            frame_period_s: 0.04,
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
            g = l.step(g, g * k, 0.0).0;
        }
        let want = e0 * (-25.0 * 0.04 / 0.5f64).exp();
        assert!(((g / target).ln() - want).abs() < 1e-12, "{g}");
    }

    #[test]
    fn protection_halves_and_limits_report() {
        let l = lp(0.5);
        assert_eq!(l.step(100.0, 50.0, 0.5), (50.0, AgcState::Protecting));
        assert_eq!(l.step(1e6, 1e-9, 0.0).1, AgcState::AtMaxGain);
        assert_eq!(l.step(1.0, 1e9, 0.0), (1.0, AgcState::AtMinGain));
    }
}
