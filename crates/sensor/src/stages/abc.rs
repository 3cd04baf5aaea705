//! Automatic brightness control (ABC) and bright-source protection (BSP)
//! of the tube's power supply: the screen-current limit and its time
//! constant, regulated first by the MCP voltage and then by gating the
//! photocathode.
//!
//! # Model and sources
//!
//! Gen II/III tube supplies hold the screen's output brightness to a few
//! foot-lamberts (2–5 fL ≈ 7–17 cd m⁻², MIL-PRF-49052-class tubes; the
//! preset default 10 cd m⁻² is assumed within that range) by sensing the
//! screen (MCP output) current: above the limit they lower the MCP voltage,
//! and once the MCP is at its lowest voltage the autogating supply shortens
//! the photocathode's duty cycle (down to a ~100 ns gate), which also
//! protects the cathode from a bright source. That is the order here:
//! gain first, then duty. The regulation is a first-order loop on the log
//! of the throughput cut `F ≤ 1`, with time constant τ (assumed 0.1 s;
//! tube ABC settles in tens to hundreds of ms):
//! `ln F ← min(0, ln F + (1 − e^{−Δt/τ}) (ln j_lim − ln j))`,
//! `j` the frame's mean screen current. The limit follows from the screen's
//! luminance: a Lambertian screen of luminous efficacy K (lm W⁻¹ of its
//! emission) putting out `E` eV of light per electron is at luminance
//! `L = K E j / π`, so `j_lim = π L_lim / (K E)`.
//!
//! This is the tube's own loop; the camera's AGC ([`super::agc`]) acts on
//! the set gain outside it.

use gloam_spectra::{KM_PHOTOPIC_LM_W, Spectrum, library};

use super::photocathode::ELEMENTARY_CHARGE_C;
use crate::config::AbcConfig;

/// The regulation at one camera's geometry and timing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Abc {
    /// Screen-current limit, A cm⁻².
    pub limit_a_cm2: f64,
    /// The limit as mean MCP output electrons per pixel per frame.
    pub limit_e_per_pixel: f64,
    /// `1 − e^{−Δt/τ}`.
    pub alpha: f64,
    /// Shortest gate over the exposure (the lowest duty factor).
    pub min_duty_factor: f64,
}

/// Luminous efficacy of an emission spectrum, lm W⁻¹: `K_m ∫V S / ∫S`.
pub fn luminous_efficacy_lm_w(spectrum: &Spectrum) -> f64 {
    let total = spectrum.integral();
    if total.is_nan() || total <= 0.0 {
        return 0.0;
    }
    KM_PHOTOPIC_LM_W * spectrum.integrate_weighted(library::photopic_v()) / total
}

pub use gloam_io::frame::AbcSetting;

impl Abc {
    /// From the screen: `light_ev_per_e` of light per electron at
    /// efficacy `efficacy_lm_w`; pixels `pitch_cathode_mm` wide, frames
    /// every `period_s` with the cathode gated on for `on_s`.
    pub fn new(
        c: &AbcConfig,
        efficacy_lm_w: f64,
        light_ev_per_e: f64,
        pitch_cathode_mm: f64,
        period_s: f64,
        on_s: f64,
    ) -> Option<Self> {
        if !(c.enabled && efficacy_lm_w > 0.0 && light_ev_per_e > 0.0) {
            return None;
        }
        // A m⁻² → A cm⁻².
        let limit_a_cm2 = std::f64::consts::PI * c.output_luminance_limit_cd_m2
            / (efficacy_lm_w * light_ev_per_e)
            * 1e-4;
        let a_cm2 = (pitch_cathode_mm * 0.1).powi(2);
        Some(Self {
            limit_a_cm2,
            limit_e_per_pixel: limit_a_cm2 * a_cm2 * period_s / ELEMENTARY_CHARGE_C,
            alpha: 1.0 - (-period_s / c.time_constant_s).exp(),
            min_duty_factor: (c.gate_min_s / on_s).min(1.0),
        })
    }

    /// The cut after a frame whose mean screen charge was `mean_e` per
    /// pixel, from the cut `f` in effect.
    pub fn step(&self, f: f64, mean_e: f64) -> f64 {
        let err = self.limit_e_per_pixel.ln() - mean_e.max(1e-300).ln();
        (f.ln() + self.alpha * err).min(0.0).exp()
    }

    /// Splits a cut `f` into gain then duty: the MCP voltage down to the
    /// plate's minimum gain (`gain_floor` = minimum over set gain), then
    /// the gate down to its shortest. Returns the setting and whether the
    /// supply has run out of range.
    pub fn split(&self, f: f64, gain_floor: f64) -> (AbcSetting, bool) {
        let gain_factor = f.max(gain_floor.min(1.0));
        let want_duty = f / gain_factor;
        let duty_factor = want_duty.max(self.min_duty_factor);
        (
            AbcSetting {
                gain_factor,
                duty_factor,
            },
            want_duty < self.min_duty_factor,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn abc() -> Abc {
        let spectrum = super::super::phosphor::phosphor_spectrum(crate::config::PhosphorType::P43);
        let k = luminous_efficacy_lm_w(&spectrum);
        Abc::new(&AbcConfig::default(), k, 320.0, 0.01056, 0.04, 0.04).unwrap()
    }

    #[test]
    fn p43_efficacy_from_its_lines_and_the_limit_from_luminance() {
        // Independent: K_m Σ wᵢ V(λᵢ) over the P43 lines with CIE 1924 V
        // at 489/545/586/622 nm (0.1994, 0.9803, 0.8048, 0.3568 by linear
        // interpolation of the 5 nm table).
        let k = abc();
        let spectrum = super::super::phosphor::phosphor_spectrum(crate::config::PhosphorType::P43);
        let eff = luminous_efficacy_lm_w(&spectrum);
        let want =
            KM_PHOTOPIC_LM_W * (0.15 * 0.19942 + 0.60 * 0.9803 + 0.15 * 0.8048 + 0.10 * 0.35683);
        assert!((eff / want - 1.0).abs() < 0.01, "{eff} vs {want}");
        // L = K E j / π at the limit gives back 10 cd/m².
        let l = eff * 320.0 * k.limit_a_cm2 * 1e4 / std::f64::consts::PI;
        assert!((l - 10.0).abs() < 1e-9);
    }

    #[test]
    fn loop_settles_on_the_limit_as_exp_minus_t_over_tau() {
        // Screen charge proportional to the cut: 20× the limit uncut.
        let a = abc();
        let over = 20.0 * a.limit_e_per_pixel;
        let mut f: f64 = 1.0;
        for _ in 0..25 {
            f = a.step(f, over * f);
        }
        // ln F → ln(1/20) with error e^{−n Δt/τ}: 25 frames of 40 ms, τ 0.1 s.
        let want = (1.0f64 / 20.0).ln() * (1.0 - (-25.0 * 0.04 / 0.1f64).exp());
        assert!((f.ln() - want).abs() < 1e-9, "{f}");
        // Below the limit nothing is cut.
        assert_eq!(a.step(1.0, 0.5 * a.limit_e_per_pixel), 1.0);
    }

    #[test]
    fn gain_goes_first_then_the_gate() {
        let a = abc();
        let (s, out) = a.split(0.5, 0.1);
        assert_eq!((s.gain_factor, s.duty_factor, out), (0.5, 1.0, false));
        let (s, out) = a.split(1e-3, 0.1);
        assert!((s.gain_factor - 0.1).abs() < 1e-15 && (s.duty_factor - 1e-2).abs() < 1e-15);
        assert!(!out);
        let (s, out) = a.split(1e-9, 0.1);
        assert!((s.duty_factor - 100e-9 / 0.04).abs() < 1e-18 && out);
    }
}
