//! The intensifier's bright-source stages together — [`super::halo`],
//! [`super::mcp_depletion`], [`super::abc`] — and a frame's saturation
//! account.
//!
//! # When they run
//!
//! The halo and the pore depletion act on every pixel, but in a field
//! without a bright source the halo returns the field unchanged and the
//! reservoirs stay full, so they run only when a bright source is in view:
//! the frame's brightest input pixel (photoelectrons, after the optics)
//! exceeds `bright_source.on_above_max_over_mean` (default 10) times the
//! frame mean. A uniform calibration field (ratio ≈ 1), a ramp or an edge
//! target (≤ 2) never switches them on, so photon transfer and the MTF
//! flows see the chain they always did; a lamp covering a few per cent of
//! the frame at ~100× the rest does. The ABC regulates on the mean screen
//! current and acts only above its limit, on any frame.
//!
//! # Saturation account
//!
//! "Saturated" means information lost: the pixel is within noise of the
//! level where the output clips — the CCD's full well, the analogue video
//! clip or the digitizer's top code, whichever is lowest at the frame's
//! gain (`saturated_by` names it). The MCP's pore depletion compresses a
//! highlight softly without clipping it; pixels it compresses by more than
//! 10 % are counted separately (`mcp_compressed_fraction`). The ABC's cut
//! of the tube's throughput and whether it has run out of range (the
//! cathode-current limit reached) are reported per frame. No phosphor
//! saturation is modelled (P43 is linear far beyond the MCP's current
//! limit).

use super::abc::{Abc, luminous_efficacy_lm_w};
use super::halo::Halo;
use super::mcp_depletion::Depletion;
use super::phosphor::Screen;
use super::{Chain, Tube};

pub use gloam_io::frame::{SaturatingStage, SaturationAccount};

/// The bright-source stages of an ICCD.
#[derive(Clone, Debug)]
pub struct BrightStages {
    pub on_above_max_over_mean: f64,
    pub halo: Option<Halo>,
    pub depletion: Option<Depletion>,
    pub abc: Option<Abc>,
}

impl BrightStages {
    /// The stages of `chain` (None unless it is an ICCD).
    pub fn of(chain: &Chain) -> Option<Self> {
        let Tube::Iccd(i) = &chain.tube else {
            return None;
        };
        let cfg = &chain.config;
        let (p, m, ph) = (
            cfg.photocathode.as_ref()?,
            cfg.mcp.as_ref()?,
            cfg.phosphor.as_ref()?,
        );
        let b = &cfg.bright_source;
        let period = 1.0 / cfg.timing.frame_rate_hz;
        let on = cfg.timing.exposure_s * p.gate_duty;
        let screen = Screen::new(ph);
        let photons_per_w_ev = screen
            .spectrum
            .map_all(|w, x| x * w / 1_239.841_984)
            .integral();
        let light_ev_per_e = screen.photons_per_e / photons_per_w_ev;
        Some(Self {
            on_above_max_over_mean: b.on_above_max_over_mean,
            halo: Halo::new(&b.halo, i.mcp.open_area, p.gap_mm, chain.pitch_cathode_mm),
            depletion: Depletion::new(
                &b.mcp_depletion,
                m.output_current_limit_a_cm2,
                chain.pitch_cathode_mm,
                on,
                period,
            ),
            abc: Abc::new(
                &b.abc,
                luminous_efficacy_lm_w(&screen.spectrum),
                light_ev_per_e,
                chain.pitch_cathode_mm,
                period,
                on,
            ),
        })
    }

    /// Is a bright source in view, for an input of this mean and maximum?
    pub fn in_view(&self, mean: f64, max: f64) -> bool {
        source_in_view(self.on_above_max_over_mean, mean, max)
    }
}

/// A bright source is in view when the input's maximum exceeds
/// `on_above_max_over_mean` times its mean (and is not zero).
pub fn source_in_view(on_above_max_over_mean: f64, mean: f64, max: f64) -> bool {
    max > on_above_max_over_mean * mean && max > 0.0
}

impl Chain {
    /// The stage whose limit sets [`Chain::saturation_dn`] at gain `g`.
    pub fn saturating_stage(&self, g: f64) -> SaturatingStage {
        let fw = self.black_dn(g) + self.config.ccd.full_well_e * self.dn_per_ccd_electron(g);
        let clip = self.clip_dn(g);
        if fw <= clip && fw <= self.max_code {
            SaturatingStage::CcdFullWell
        } else if clip <= self.max_code {
            SaturatingStage::VideoClip
        } else {
            SaturatingStage::DigitizerRail
        }
    }

    /// MCP output electrons per pixel per frame that bring the CCD to its
    /// saturation level at gain `g` (ICCD; None otherwise).
    pub fn mcp_e_at_saturation(&self, g: f64) -> Option<f64> {
        let i = self.intensifier()?;
        let dn = self.saturation_dn(g) - self.black_dn(g);
        let per_e = self.dn_per_ccd_electron(g) * i.ccd_e_per_mcp_e;
        (per_e > 0.0).then(|| dn / per_e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SensorConfig;

    #[test]
    fn gen3_limits_and_the_stage_that_clips() {
        let cfg =
            SensorConfig::load_preset_or_file("gen3-gaas-iccd", &gloam_io::ReadLog::off()).unwrap();
        let chain = Chain::new(&cfg).unwrap();
        let b = BrightStages::of(&chain).unwrap();
        let g = chain.reference_gain;
        // Video full scale 12 000 e⁻ clips at 1.05 V < the CCD's 18 000 e⁻
        // full well and below the 1.1 V top of the digitizer's input.
        assert_eq!(chain.saturating_stage(g), SaturatingStage::VideoClip);
        // Reservoir j A τ / q with A = (6.45 µm / 0.611)², τ = 10 ms.
        let a_cm2 = (6.45e-4 / 0.611f64).powi(2);
        let want = 1e-7 * a_cm2 * 0.01 / crate::stages::ELEMENTARY_CHARGE_C;
        let d = b.depletion.unwrap();
        assert!((d.reservoir_e / want - 1.0).abs() < 1e-9);
        assert!(b.halo.is_some() && b.abc.is_some());
        assert!(b.in_view(1.0, 11.0) && !b.in_view(1.0, 9.0) && !b.in_view(0.0, 0.0));
        assert!(
            BrightStages::of(
                &Chain::new(
                    &SensorConfig::load_preset_or_file("scientific-ccd", &gloam_io::ReadLog::off())
                        .unwrap()
                )
                .unwrap()
            )
            .is_none()
        );
    }
}
