//! Local MCP saturation: pore charge depletion under a directly viewed
//! bright source, and its recovery from frame to frame.
//!
//! # Model and sources
//!
//! A channel's cascade draws its electrons from the charge stored on the
//! channel wall; the wall recharges through the channel's own resistance
//! with the time constant `τ = R C` of the plate (per unit area both R and
//! C scale so that τ is the plate's: ~10⁸–10⁹ Ω × ~26 pF for an 18 mm
//! plate gives 3–30 ms; "channel recovery time ~10⁻² s", Wiza, NIM 162
//! (1979) 587; the dead time "diminishes in proportion to the RC time
//! constant", Burle MCP technical brief). The plate stays linear while its
//! output current is below ~10 % of the strip current, which the preset
//! gives as `mcp.output_current_limit_a_cm2` = j. So a pixel's channels
//! hold a reservoir `Q_res = j A_pix τ` they can give up, refilled at
//! `Q_res/τ`.
//!
//! With `s` the fraction of the reservoir left, the gain is proportional to
//! `s` (the wall field that drives the cascade sags with it):
//! `ds/dt = (1 − s)/τ − r s / Q_res` while the cathode is gated on at
//! demanded output rate `r` (the unsaturated charge `Q_d` over the on-time
//! `t_on`), and `ds/dt = (1 − s)/τ` while it is off. Closed form per frame,
//! with `x = r τ / Q_res`, `u = t_on/τ`, `s∞ = 1/(1 + x)`:
//!
//! * `s(t_on) = s∞ + (s₀ − s∞) e^{−(1+x)u}`,
//! * `Q_out/Q_res = x s∞ u + x (s₀ − s∞)(1 − e^{−(1+x)u})/(1 + x)`,
//! * then recovery over the off-time: `1 − s ← (1 − s) e^{−t_off/τ}`.
//!
//! Limits: ungated and bright, `Q_out → j A_pix t` (the output current
//! limit); a short gate on a full reservoir, `Q_out → Q_res (1 − e^{−Q_d/Q_res})`;
//! a dim pixel, `Q_out = Q_d`. The state `s` carries from frame to frame,
//! so a lamp that leaves the field leaves a dimmer patch for a few τ.
//!
//! When this stage runs it replaces the MCP pass's static knee
//! (`Q/√(1+(Q/Q_sat)²)`), which is the same current limit without memory.

use crate::config::McpDepletionConfig;
use crate::stages::photocathode::ELEMENTARY_CHARGE_C;

/// Output compressed by more than this fraction counts as "MCP-compressed"
/// in a frame's saturation account.
pub const COMPRESSED_ABOVE: f64 = 0.1;

/// Pore depletion at one camera's geometry and timing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Depletion {
    /// Reservoir per pixel, MCP output electrons: `j A_pix τ / q`.
    pub reservoir_e: f64,
    /// On-time over τ (gate duty × exposure / τ).
    pub on_over_tau: f64,
    /// `e^{−t_off/τ}`: what is left of a deficit after the off-time.
    pub deficit_kept: f64,
}

impl Depletion {
    /// From the output current limit `limit_a_cm2` over pixels of
    /// `pitch_cathode_mm`, the cathode on for `on_s` of every `period_s`.
    pub fn new(
        c: &McpDepletionConfig,
        limit_a_cm2: Option<f64>,
        pitch_cathode_mm: f64,
        on_s: f64,
        period_s: f64,
    ) -> Option<Self> {
        let j = limit_a_cm2?;
        if !(c.enabled && j > 0.0 && on_s > 0.0) {
            return None;
        }
        let tau = c.recovery_time_s;
        let a_cm2 = (pitch_cathode_mm * 0.1).powi(2);
        Some(Self {
            reservoir_e: j * a_cm2 * tau / ELEMENTARY_CHARGE_C,
            on_over_tau: on_s / tau,
            deficit_kept: (-(period_s - on_s).max(0.0) / tau).exp(),
        })
    }

    /// Output charge for demanded charge `demand_e` from reservoir fraction
    /// `s0`, and the fraction left at the start of the next frame.
    #[inline]
    pub fn step(&self, demand_e: f64, s0: f64) -> (f64, f64) {
        let x = self.load(demand_e);
        self.step_at(x, (-(1.0 + x) * self.on_over_tau).exp(), s0)
    }

    /// Demand over what the reservoir refills in the on-time, `x = Q_d τ /
    /// (Q_res t_on)`.
    #[inline]
    fn load(&self, demand_e: f64) -> f64 {
        let q = demand_e.max(0.0) / self.reservoir_e;
        q / self.on_over_tau
    }

    /// [`Depletion::step`] at load `x` given `decay = e^{−(1+x) t_on/τ}`.
    #[inline]
    fn step_at(&self, x: f64, decay: f64, s0: f64) -> (f64, f64) {
        let u = self.on_over_tau;
        let s_inf = 1.0 / (1.0 + x);
        let s_end = s_inf + (s0 - s_inf) * decay;
        let out = x * s_inf * u + x * (s0 - s_inf) * (1.0 - decay) / (1.0 + x);
        let s_next = 1.0 - (1.0 - s_end) * self.deficit_kept;
        (out * self.reservoir_e, s_next)
    }

    /// Row in place: `row` holds demanded charge and becomes the output;
    /// `state` the reservoir fractions. Returns the pixels compressed by
    /// more than [`COMPRESSED_ABOVE`]. Most pixels of a dim frame had no
    /// cascade (no demand): their decay is the same number, computed once.
    #[inline]
    pub fn row(&self, row: &mut [f32], state: &mut [f32]) -> usize {
        let decay_dark = (-(1.0 + 0.0f64) * self.on_over_tau).exp();
        let mut n = 0;
        for (q, s) in row.iter_mut().zip(state.iter_mut()) {
            let d = *q as f64;
            let x = self.load(d);
            let decay = if x == 0.0 {
                decay_dark
            } else {
                (-(1.0 + x) * self.on_over_tau).exp()
            };
            let (out, next) = self.step_at(x, decay, *s as f64);
            n += (out < (1.0 - COMPRESSED_ABOVE) * d) as usize;
            *q = out as f32;
            *s = next as f32;
        }
        n
    }

    /// The compression `1 − Q_out/Q_d` of a steady pixel demanding
    /// `demand_e` per frame (reservoir in equilibrium).
    pub fn steady_compression(&self, demand_e: f64) -> f64 {
        if demand_e.is_nan() || demand_e <= 0.0 {
            return 0.0;
        }
        let mut s = 1.0;
        let mut out = demand_e;
        for _ in 0..200 {
            let (o, n) = self.step(demand_e, s);
            if (n - s).abs() < 1e-12 {
                out = o;
                break;
            }
            (out, s) = (o, n);
        }
        1.0 - out / demand_e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dep(on_s: f64, period_s: f64) -> Depletion {
        let c = McpDepletionConfig {
            enabled: true,
            recovery_time_s: 0.01,
        };
        Depletion::new(&c, Some(1e-7), 0.01056, on_s, period_s).unwrap()
    }

    /// The closed form against a fourth-order Runge–Kutta integration of
    /// `ds/dt = (1 − s)/τ − r s/Q`, `dQ_out/dt = r s`.
    /// The row pass (its shared decay for pixels without demand) gives
    /// pixel by pixel what [`Depletion::step`] gives, to the bit.
    #[test]
    fn row_is_step_per_pixel() {
        let d = dep(0.04, 0.04);
        let demand = [0.0f32, 0.0, 1e3, 3e6, 0.0, -2.0, 5e7, 0.0];
        let state0 = [1.0f32, 0.4, 1.0, 0.7, 0.95, 1.0, 0.2, 0.0];
        let (mut row, mut state) = (demand, state0);
        d.row(&mut row, &mut state);
        for i in 0..demand.len() {
            let (out, next) = d.step(demand[i] as f64, state0[i] as f64);
            assert_eq!(row[i].to_bits(), (out as f32).to_bits(), "pixel {i}");
            assert_eq!(state[i].to_bits(), (next as f32).to_bits(), "pixel {i}");
        }
    }

    #[test]
    fn closed_form_matches_integrating_the_reservoir() {
        for &(on, demand, s0) in &[
            (0.04, 3e4, 1.0),
            (0.04, 2e5, 0.6),
            (1e-4, 5e3, 1.0),
            (2e-3, 1e5, 0.3),
            (0.04, 10.0, 1.0),
        ] {
            let d = dep(on, 0.04);
            let (tau, qres) = (0.01, d.reservoir_e);
            let r = demand / on;
            let f = |s: f64| ((1.0 - s) / tau - r * s / qres, r * s);
            let steps = 20_000;
            let h = on / steps as f64;
            let (mut s, mut out) = (s0, 0.0);
            for _ in 0..steps {
                let k1 = f(s);
                let k2 = f(s + 0.5 * h * k1.0);
                let k3 = f(s + 0.5 * h * k2.0);
                let k4 = f(s + h * k3.0);
                s += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
                out += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
            }
            let (got, next) = d.step(demand, s0);
            assert!(
                (got / out - 1.0).abs() < 1e-6,
                "{on} {demand}: {got} vs {out}"
            );
            let want_next = 1.0 - (1.0 - s) * (-(0.04 - on) / tau).exp();
            assert!((next - want_next).abs() < 1e-6);
        }
    }

    #[test]
    fn limits_current_limit_reservoir_and_linear() {
        // Ungated and very bright: the output current limit j A t / q.
        let d = dep(0.04, 0.04);
        let limit = 1e-7 * (0.001056f64).powi(2) * 0.04 / ELEMENTARY_CHARGE_C;
        let mut s = 1.0;
        let mut out = 0.0;
        for _ in 0..50 {
            (out, s) = d.step(1e12, s);
        }
        assert!((out / limit - 1.0).abs() < 1e-3, "{out} vs {limit}");
        // A 100 ns gate on a full reservoir: Q_res (1 − e^{−Q_d/Q_res}).
        let g = dep(100e-9, 0.04);
        let qd = 2.0 * g.reservoir_e;
        let want = g.reservoir_e * (1.0 - (-2.0f64).exp());
        assert!((g.step(qd, 1.0).0 / want - 1.0).abs() < 1e-4);
        // Dim: linear, compressed by less than Q_d over the limit.
        let c = 1.0 - d.step(1.0, 1.0).0;
        assert!(c > 0.0 && c < 1.0 / limit, "{c}");
    }

    #[test]
    fn a_deficit_recovers_as_exp_minus_t_over_tau() {
        // Gated for 1 ms of a 40 ms frame: 39 ms off, so e^{−3.9} of a
        // deficit is left; a dark frame after a bright one shows it.
        let d = dep(1e-3, 0.04);
        let (_, s) = d.step(1e6, 1.0);
        let s_end = 1.0 - (1.0 - s) / (-3.9f64).exp();
        assert!(s_end < 0.1, "deep depletion {s_end}");
        let (_, s2) = d.step(0.0, s);
        // No demand during the next on-time: recovery through on and off.
        let want = 1.0 - (1.0 - s) * (-4.0f64).exp();
        assert!((s2 - want).abs() < 1e-9, "{s2} vs {want}");
    }
}
