//! Electron-bombarded CCD: photoelectrons accelerated straight into a
//! back-thinned CCD, gain `(V − dead layer)/w` with Fano and backscatter
//! noise.

use super::FrameNoise;
use crate::config::{Ebccd, Photocathode};
use crate::noise::{self, Pass};

/// The electron-bombarded gain process and its proximity gap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EbParams {
    /// Fraction b of electrons that backscatter (depositing a uniform
    /// fraction of their energy).
    pub backscatter: f64,
    pub fano: f64,
    /// Cathode–CCD gap, mm, and the transverse emission energy, eV.
    pub gap_mm: f64,
    pub emission_ev: f64,
    /// Dead-layer loss and energy per electron–hole pair, eV.
    pub dead_ev: f64,
    pub pair_ev: f64,
}

impl EbParams {
    pub fn new(p: &Photocathode, e: &Ebccd) -> Self {
        Self {
            backscatter: e.backscatter_fraction,
            fano: e.fano,
            gap_mm: p.gap_mm,
            emission_ev: p.emission_energy_ev,
            dead_ev: e.dead_layer_ev,
            pair_ev: e.pair_energy_ev,
        }
    }

    /// Mean CCD electrons per photoelectron at gain `g`: `G (1 − b/2)`.
    pub fn mean_gain(&self, g: f64) -> f64 {
        g * (1.0 - 0.5 * self.backscatter)
    }

    /// Excess noise factor `((1−b)(1 + f/G) + b/3)/(1 − b/2)²`.
    pub fn excess_noise_factor(&self, g: f64) -> f64 {
        let b = self.backscatter;
        ((1.0 - b) * (1.0 + self.fano / g) + b / 3.0) / (1.0 - 0.5 * b).powi(2)
    }

    /// Accelerating voltage for gain `g`: `V = G w + dead`.
    pub fn voltage_for(&self, g: f64) -> f64 {
        g * self.pair_ev + self.dead_ev
    }
}

/// One frame's electron-bombardment pass: photoelectron means (plus dark
/// emission) in, CCD electrons out.
pub struct EbPass<'a> {
    pub eb: &'a EbParams,
    pub gain: f64,
    pub ebi_pe: f64,
    pub noise: FrameNoise,
}

impl EbPass<'_> {
    /// Row `r` in place: Poisson photoelectrons, each bombarding the CCD.
    #[inline]
    pub fn row(&self, r: usize, row: &mut [f32]) {
        let (g, e) = (self.gain, self.eb);
        let mut rng = self.noise.stream(Pass::Photoelectrons, r);
        let mut events = noise::PoissonRow::new(&mut rng, self.noise.gaussian_above);
        for p in row.iter_mut() {
            let lam = (*p).max(0.0) as f64 + self.ebi_pe;
            *p = if self.noise.enabled {
                let n = events.draw(&mut rng, lam);
                noise::eb_charge(&mut rng, n, g, e.backscatter, e.fano)
            } else {
                lam * g * (1.0 - 0.5 * e.backscatter)
            } as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eb(b: f64) -> EbParams {
        EbParams {
            backscatter: b,
            fano: 0.12,
            gap_mm: 1.0,
            emission_ev: 0.5,
            dead_ev: 1000.0,
            pair_ev: 3.65,
        }
    }

    #[test]
    fn gain_at_a_voltage_is_energy_over_pair_energy() {
        // 8 kV less a 1 keV dead layer at 3.65 eV/pair (Janesick, Scientific
        // CCDs, 2001): G = 7000/3.65 = 1917.8.
        let e = eb(0.0);
        let g = (8000.0 - 1000.0) / 3.65;
        assert!((e.voltage_for(g) - 8000.0).abs() < 1e-9);
        assert!((g - 1917.808).abs() < 1e-3);
    }

    #[test]
    fn pass_moments_match_fano_and_backscatter() {
        // With b = 0 the charge of n photoelectrons is n G with Fano variance
        // f n G: mean λG, variance λG² + fλG (compound Poisson).
        let e = eb(0.0);
        let (lam, g) = (4.0, 500.0);
        let noise = FrameNoise {
            enabled: true,
            seed: 3,
            frame: 0,
            gaussian_above: 12.0,
        };
        let pass = EbPass {
            eb: &e,
            gain: g,
            ebi_pe: 0.0,
            noise,
        };
        let (mean, var) = crate::stages::row_moments(400, |r| {
            let mut row = vec![lam as f32; 250];
            pass.row(r, &mut row);
            row
        });
        assert!((mean / (lam * g) - 1.0).abs() < 0.01, "{mean}");
        let want = lam * g * g + 0.12 * lam * g;
        assert!((var / want - 1.0).abs() < 0.03, "{var} vs {want}");
        // The analytic factor agrees: F = 1 + f/G at b = 0.
        assert!((e.excess_noise_factor(g) - (1.0 + 0.12 / g)).abs() < 1e-15);
    }
}
