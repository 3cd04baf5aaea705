//! CCD: QE, fixed patterns (PRNU, DSNU), dark current, shot and read noise,
//! full well with blooming along columns, charge diffusion.

use gloam_spectra::Spectrum;
use rayon::prelude::*;

use super::FrameNoise;
use super::mtf::{MtfStage, MtfTerm};
use crate::config::Ccd;
use crate::noise::{self, Pass, PoissonRow};

/// The CCD's photon-weighted QE for light of relative spectral power `spd`.
pub fn qe_at_spectrum(spd: &Spectrum, qe: &Spectrum) -> f64 {
    let photons = spd.map_all(|w, x| x * w);
    photons.integrate_weighted(qe) / photons.integral()
}

/// Charge diffusion as a Gaussian MTF stage in pixels of `pitch_ccd_mm`
/// (before the shot noise for a plain CCD, after the gain noise otherwise).
pub fn diffusion_mtf(c: &Ccd, pitch_ccd_mm: f64, after_noise: bool) -> Option<MtfStage> {
    (c.diffusion_um > 0.0).then(|| MtfStage {
        name: "CCD diffusion",
        term: MtfTerm::Gaussian {
            sigma_px: c.diffusion_um * 1e-3 / pitch_ccd_mm,
        },
        after_noise,
    })
}

/// A seeded Gaussian fixed pattern `f(z)`, z ~ N(0, 1) per pixel.
pub fn gaussian_pattern(
    rows: usize,
    cols: usize,
    seed: u64,
    pass: Pass,
    f: &(dyn Fn(f64) -> f32 + Sync),
) -> Vec<f32> {
    let mut v = vec![0f32; rows * cols];
    v.par_chunks_mut(cols).enumerate().for_each(|(r, out)| {
        let mut rng = noise::pattern_rng(seed, pass, r);
        for o in out.iter_mut() {
            *o = f(noise::normal(&mut rng));
        }
    });
    v
}

/// PRNU: the multiplicative gain pattern `max(0, 1 + prnu z)` (None at 0).
pub fn prnu_pattern(c: &Ccd, rows: usize, cols: usize, seed: u64) -> Option<Vec<f32>> {
    let a = c.prnu;
    (a > 0.0).then(|| {
        gaussian_pattern(rows, cols, seed, Pass::Prnu, &|z| {
            (1.0 + a * z).max(0.0) as f32
        })
    })
}

/// DSNU: the additive offset pattern `dsnu z` electrons (None at 0).
pub fn dsnu_pattern(c: &Ccd, rows: usize, cols: usize, seed: u64) -> Option<Vec<f32>> {
    let a = c.dsnu_e;
    (a > 0.0).then(|| gaussian_pattern(rows, cols, seed, Pass::Dsnu, &|z| (a * z) as f32))
}

/// One frame's CCD pass: the charge arriving per pixel (photoelectrons for a
/// plain CCD, MCP output electrons or EB charge otherwise) to CCD electrons
/// with shot, dark and read noise, and full well.
pub struct CcdPass<'a> {
    /// CCD electrons per arriving quantum (the ICCD's screen → CCD gain, else 1).
    pub conversion: f64,
    /// Draw shot noise on the CCD electrons (not for an EBCCD, whose charge
    /// already carries its noise).
    pub shot: bool,
    pub dark_e: f64,
    pub full_well_e: f64,
    pub read_noise_e: f64,
    /// Multiplicative gain pattern (chicken wire × PRNU), row-major.
    pub flat_field: Option<&'a [f32]>,
    /// Additive offset pattern, e⁻, row-major.
    pub dsnu: Option<&'a [f32]>,
    pub noise: FrameNoise,
    cols: usize,
    /// Shot noise is drawn as one Gaussian for `gaussian_above < t < t_gauss`,
    /// where `t + 8√t` stays below full well.
    t_gauss: f64,
}

impl<'a> CcdPass<'a> {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        conversion: f64,
        shot: bool,
        dark_e: f64,
        full_well_e: f64,
        read_noise_e: f64,
        flat_field: Option<&'a [f32]>,
        dsnu: Option<&'a [f32]>,
        noise: FrameNoise,
        cols: usize,
    ) -> Self {
        Self {
            conversion,
            shot,
            dark_e,
            full_well_e,
            read_noise_e,
            flat_field,
            dsnu,
            noise,
            cols,
            t_gauss: ((16.0 + full_well_e).sqrt() - 4.0).powi(2),
        }
    }

    /// Mean CCD electrons of row `r` into `m` (whole-row passes vectorise).
    #[inline]
    pub fn mean_row(&self, r: usize, row: &[f32], m: &mut Vec<f64>) {
        let (conv, cols) = (self.conversion, self.cols);
        m.clear();
        m.extend(row.iter().map(|&p| p.max(0.0) as f64 * conv));
        if let Some(ff) = self.flat_field {
            for (x, &f) in m.iter_mut().zip(&ff[r * cols..(r + 1) * cols]) {
                *x *= f as f64;
            }
        }
    }

    /// Shot, dark and read noise on the means `m` of row `r`, in place, when
    /// no charge moves between pixels: one Gaussian `N(t, t + σ_read²)` where
    /// the shot noise is Gaussian and full well is out of reach.
    #[inline]
    pub fn noise_row(&self, r: usize, m: &mut [f64]) {
        let (dark, fw, ga, read) = (
            self.dark_e,
            self.full_well_e,
            self.noise.gaussian_above,
            self.read_noise_e,
        );
        let read_var = read * read;
        let mut rng = self.noise.stream(Pass::Ccd, r);
        let mut events = PoissonRow::new(&mut rng, ga);
        for x in m.iter_mut() {
            *x = if !self.noise.enabled {
                (*x + dark).min(fw)
            } else if self.shot {
                let t = *x + dark;
                if t > ga && t < self.t_gauss {
                    t + (t + read_var).sqrt() * noise::normal(&mut rng)
                } else {
                    events.draw(&mut rng, t).min(fw) + read * noise::normal(&mut rng)
                }
            } else {
                (*x + events.draw(&mut rng, dark)).min(fw) + read * noise::normal(&mut rng)
            };
        }
    }

    /// Shot and dark noise of row `r` into `row` as electrons, no full well
    /// yet (the blooming path: [`bloom`] then [`CcdPass::read_row`]).
    #[inline]
    pub fn collect_row(&self, r: usize, row: &mut [f32], m: &[f64]) {
        let dark = self.dark_e;
        let mut rng = self.noise.stream(Pass::Ccd, r);
        let mut events = PoissonRow::new(&mut rng, self.noise.gaussian_above);
        for (p, &m) in row.iter_mut().zip(m.iter()) {
            let e = if !self.noise.enabled {
                m + dark
            } else if self.shot {
                events.draw(&mut rng, m + dark)
            } else {
                m + events.draw(&mut rng, dark)
            };
            *p = e as f32;
        }
    }

    /// Read noise on row `r` of collected electrons into `v`.
    #[inline]
    pub fn read_row(&self, r: usize, row: &[f32], v: &mut Vec<f64>) {
        let mut rng = self.noise.stream(Pass::Read, r);
        v.clear();
        v.extend(row.iter().map(|&e| e as f64));
        if self.noise.enabled && self.read_noise_e > 0.0 {
            for x in v.iter_mut() {
                *x += self.read_noise_e * noise::normal(&mut rng);
            }
        }
    }

    /// The DSNU offsets of row `r` added to electrons `v`.
    #[inline]
    pub fn add_dsnu(&self, r: usize, v: &mut [f64]) {
        let cols = self.cols;
        if let Some(d) = self.dsnu {
            for (x, &d) in v.iter_mut().zip(&d[r * cols..(r + 1) * cols]) {
                *x += d as f64;
            }
        }
    }
}

/// Spills charge above `fw` along each column: half up, half down, filling
/// neighbours until it is absorbed (charge off the ends is lost to the drain).
///
/// The columns holding charge above full well are found in one row-major
/// pass (a column-wise scan of the whole frame misses the cache on every
/// pixel); only those are walked.
pub fn bloom(img: &mut [f32], rows: usize, cols: usize, fw: f32) {
    let over = img
        .par_chunks(cols)
        .fold(
            || vec![false; cols],
            |mut over, row| {
                for (o, &v) in over.iter_mut().zip(row) {
                    *o |= v > fw;
                }
                over
            },
        )
        .reduce(
            || vec![false; cols],
            |mut a, b| {
                for (a, b) in a.iter_mut().zip(b) {
                    *a |= b;
                }
                a
            },
        );
    let mut down = vec![0f32; rows];
    for c in (0..cols).filter(|&c| over[c]) {
        down.fill(0.0);
        for r in 0..rows {
            let v = &mut img[r * cols + c];
            if *v > fw {
                let ex = *v - fw;
                *v = fw;
                down[r] = 0.5 * ex;
                // the other half goes up
                let mut carry = 0.5 * ex;
                let mut rr = r;
                while carry > 0.0 && rr > 0 {
                    rr -= 1;
                    let w = &mut img[rr * cols + c];
                    let room = (fw - *w).max(0.0);
                    let take = room.min(carry);
                    *w += take;
                    carry -= take;
                }
            }
        }
        let mut carry = 0f32;
        for (r, d) in down.iter().enumerate() {
            let v = &mut img[r * cols + c];
            if carry > 0.0 {
                let room = (fw - *v).max(0.0);
                let take = room.min(carry);
                *v += take;
                carry -= take;
            }
            carry += d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blooming_conserves_charge_away_from_the_ends() {
        // One column of 21 pixels, full well 100, 450 e⁻ in the middle: the
        // 350 excess fills neighbours, nothing reaches the ends, so the total
        // (a conservation law) and the cap both hold.
        let mut img = vec![10f32; 21];
        img[10] = 450.0;
        let before: f64 = img.iter().map(|&v| v as f64).sum();
        bloom(&mut img, 21, 1, 100.0);
        let after: f64 = img.iter().map(|&v| v as f64).sum();
        assert!((before - after).abs() < 1e-3, "{before} → {after}");
        assert!(img.iter().all(|&v| v <= 100.0));
        // Symmetric: 175 e⁻ each way and 90 e⁻ of room per pixel, so the
        // first neighbour fills and the next takes the other 85.
        assert_eq!(img[9], 100.0);
        assert_eq!(img[11], 100.0);
        assert_eq!(img[8], 95.0);
        assert_eq!(img[12], 95.0);
    }

    #[test]
    fn dark_noise_is_poisson() {
        // No signal, dark 5 e⁻/frame, no read noise: mean = variance = 5.
        let noise = FrameNoise {
            enabled: true,
            seed: 9,
            frame: 2,
            gaussian_above: 12.0,
        };
        let pass = CcdPass::new(1.0, true, 5.0, 1e5, 0.0, None, None, noise, 500);
        let (mut s1, mut s2, mut n) = (0f64, 0f64, 0f64);
        let mut m = Vec::new();
        for r in 0..200 {
            pass.mean_row(r, &[0.0; 500], &mut m);
            pass.noise_row(r, &mut m);
            for &x in &m {
                s1 += x;
                s2 += x * x;
                n += 1.0;
            }
        }
        let mean = s1 / n;
        let var = s2 / n - mean * mean;
        assert!(
            (mean - 5.0).abs() < 0.03 && (var / 5.0 - 1.0).abs() < 0.03,
            "{mean} {var}"
        );
    }
}
