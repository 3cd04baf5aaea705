//! Microchannel plate: power-law gain, open-area loss, gamma-distributed
//! cascades, a soft output-current knee and channel sampling.

use super::FrameNoise;
use super::mtf::{MtfStage, MtfTerm};
use super::photocathode::ELEMENTARY_CHARGE_C;
use crate::config;
use crate::noise::{self, GammaSums, Pass};

/// The plate's cascade statistics and saturation.
#[derive(Clone, Debug, PartialEq)]
pub struct Mcp {
    /// Fraction η of photoelectrons that start a cascade.
    pub open_area: f64,
    /// Gamma shape s of the single-electron gain.
    pub gain_shape: f64,
    /// Charge per pixel per frame at the output current limit, e⁻ (None =
    /// no saturation).
    pub saturation_e: Option<f64>,
    saturation_inv: f64,
}

impl Mcp {
    /// The plate of `m` behind pixels `pitch_cathode_mm` wide, integrating
    /// for `exposure_s`: `Q_sat = j A_pix t / q`.
    pub fn new(m: &config::Mcp, pitch_cathode_mm: f64, exposure_s: f64) -> Self {
        let saturation_e = m
            .output_current_limit_a_cm2
            .map(|j| j * (pitch_cathode_mm * 0.1).powi(2) * exposure_s / ELEMENTARY_CHARGE_C);
        Self {
            open_area: m.open_area_fraction,
            gain_shape: m.gain_shape,
            saturation_e,
            saturation_inv: saturation_e.map_or(0.0, |s| 1.0 / s),
        }
    }

    /// The same plate without its static knee (when the pore-depletion
    /// stage, [`super::mcp_depletion`], models the saturation instead).
    pub fn without_knee(&self) -> Self {
        Self {
            saturation_e: None,
            saturation_inv: 0.0,
            ..self.clone()
        }
    }

    /// The soft knee `Q' = Q / √(1 + (Q/Q_sat)²)` of a charge `q` (e⁻).
    #[inline]
    pub fn compress(&self, q: f64) -> f64 {
        match self.saturation_e {
            Some(_) => {
                let x = q * self.saturation_inv;
                let x2 = x * x;
                if x2 < 1e-3 {
                    // Series of 1/√(1+x²); error < 4e-7 relative.
                    q * (1.0 - 0.5 * x2)
                } else {
                    q / (1.0 + x2).sqrt()
                }
            }
            None => q,
        }
    }

    /// Channel-sampling MTF `2 J1(π p ν)/(π p ν)` for pore pitch p.
    pub fn pore_mtf(m: &config::Mcp, pitch_cathode_mm: f64) -> Option<MtfStage> {
        (m.pore_pitch_um > 0.0).then(|| MtfStage {
            name: "MCP channels",
            term: MtfTerm::Jinc {
                diameter_px: m.pore_pitch_um * 1e-3 / pitch_cathode_mm,
            },
            after_noise: false,
        })
    }
}

/// Per-thread buffers of the MCP pass, reused from row to row.
#[derive(Default)]
pub struct RowScratch {
    /// Mean events per pixel.
    lams: Vec<f64>,
    /// Event counts.
    counts: Vec<f64>,
    /// Columns with at least one event.
    hits: Vec<u32>,
    /// e^{-λ} for the Poisson inversion.
    exps: Vec<f64>,
}

/// One frame's MCP pass: photoelectron means (plus dark emission) in,
/// output charge per pixel out.
pub struct McpPass<'a> {
    pub mcp: &'a Mcp,
    /// Mean gain G at this frame.
    pub gain: f64,
    /// Dark-emission photoelectrons per pixel per frame.
    pub ebi_pe: f64,
    pub noise: FrameNoise,
    gamma: GammaSums,
}

impl<'a> McpPass<'a> {
    pub fn new(mcp: &'a Mcp, gain: f64, ebi_pe: f64, noise: FrameNoise) -> Self {
        Self {
            mcp,
            gain,
            ebi_pe,
            noise,
            gamma: GammaSums::new(mcp.gain_shape),
        }
    }

    /// Row `r` in place. Without noise, the compressed mean `η λ G`; with
    /// noise, Poisson event counts for the whole row first, then one
    /// `Gamma(n s, G/s)` draw for each pixel with events, listed without a
    /// data-dependent branch: tight loops that predict well.
    #[inline]
    pub fn row(&self, r: usize, row: &mut [f32], scratch: &mut RowScratch) {
        let RowScratch {
            lams,
            counts,
            hits,
            exps,
        } = scratch;
        let (eta, ebi, g) = (self.mcp.open_area, self.ebi_pe, self.gain);
        let lam = |p: f32| eta * (p.max(0.0) as f64 + ebi);
        if !self.noise.enabled {
            for p in row.iter_mut() {
                *p = self.mcp.compress(lam(*p) * g) as f32;
            }
            return;
        }
        let mut rng = self.noise.stream(Pass::Photoelectrons, r);
        let mut events = noise::PoissonRow::new(&mut rng, self.noise.gaussian_above);
        lams.clear();
        lams.extend(row.iter().map(|&p| lam(p)));
        events.draw_row(&mut rng, lams, counts, exps);
        hits.clear();
        hits.resize(row.len(), 0);
        let mut k = 0;
        for (c, &n) in counts.iter().enumerate() {
            hits[k] = c as u32;
            k += (n > 0.0) as usize;
        }
        row.fill(0.0);
        for &c in &hits[..k] {
            let q = self.gamma.sample(&mut rng, counts[c as usize], g);
            row[c as usize] = self.mcp.compress(q) as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plate(limit: Option<f64>) -> config::Mcp {
        config::Mcp {
            gain_ref: 1000.0,
            voltage_ref_v: 800.0,
            exponent: 9.0,
            voltage_v: 800.0,
            min_voltage_v: 500.0,
            max_voltage_v: 1000.0,
            gain_shape: 1.5,
            open_area_fraction: 0.6,
            output_current_limit_a_cm2: limit,
            pore_pitch_um: 6.0,
        }
    }

    #[test]
    fn knee_gives_one_over_root_two_at_the_saturation_charge() {
        let m = Mcp::new(&plate(Some(1e-7)), 0.01, 0.04);
        // Q_sat = 1e-7 A/cm² × (1e-3 cm)² × 0.04 s / q = 24 966 e⁻.
        let qs = m.saturation_e.unwrap();
        assert!((qs - 1e-7 * 1e-6 * 0.04 / ELEMENTARY_CHARGE_C).abs() < 1e-9 * qs);
        assert!((m.compress(qs) / qs - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-15);
        // Far below the knee the plate is linear.
        assert!((m.compress(1.0) - 1.0).abs() < 1e-8);
        assert_eq!(Mcp::new(&plate(None), 0.01, 0.04).compress(1e12), 1e12);
    }

    #[test]
    fn pass_mean_and_variance_follow_the_excess_noise_model() {
        // Independent moments of a compound Poisson–gamma sum: mean η λ G,
        // variance η λ G² (1 + 1/s) (the Eberhardt excess noise factor).
        let m = Mcp::new(&plate(None), 0.01, 0.04);
        let (lam, g) = (3.0, 200.0);
        let mut scratch = RowScratch::default();
        let noise = FrameNoise {
            enabled: true,
            seed: 5,
            frame: 0,
            gaussian_above: 12.0,
        };
        let pass = McpPass::new(&m, g, 0.0, noise);
        let (mean, var) = crate::stages::row_moments(400, |r| {
            let mut row = vec![lam as f32; 250];
            pass.row(r, &mut row, &mut scratch);
            row
        });
        let want_mean = 0.6 * lam * g;
        let want_var = 0.6 * lam * g * g * (1.0 + 1.0 / 1.5);
        assert!(
            (mean / want_mean - 1.0).abs() < 0.01,
            "{mean} vs {want_mean}"
        );
        assert!((var / want_var - 1.0).abs() < 0.03, "{var} vs {want_var}");
    }
}
