//! The pixel sampler: where a pixel's camera samples take their numbers.
//!
//! A sampler is a value, as in pbrt-v4: made for one pixel (and replicate)
//! and the number of samples it has so far, it hands out each dimension pair
//! a camera sample needs — the position in the pixel, the camera vertex's
//! light samples, the final gather's directions. The gather's directions,
//! the light samples with `light_strata = sobol` (the default) and the
//! positions with `pixel_strata = sobol` are each their own Owen-scrambled
//! Sobol (0,2)-sequence,
//! scrambled by its own hash of the pixel, so the pairs are independent of
//! one another (padded, as pbrt-v4's `PaddedSobolSampler` and `ZSobolSampler`
//! pad) while each is stratified across every sample of the pixel: sample `j`
//! takes index `j` (or the block `j·k …`) whichever adaptive round it comes
//! in, so a round's samples fill the strata the earlier rounds left.
//!
//! pbrt-v4's ZSobol additionally walks one global sequence in Morton order,
//! which spreads neighbouring pixels' errors as blue noise; gloam's metric is
//! each pixel's own error, which the per-pixel sequences already stratify, so
//! the pixels keep independent hashes (which also keeps a tile's pixels
//! identical to the same pixels of the whole image).
//!
//! With `pixel_strata = latin` (the default until 7 December 2026) the
//! positions are a Latin hypercube per batch; with `light_strata = random` the light
//! samples are independent draws.

use rand_pcg::Pcg64Mcg;

use crate::lights::LightStrata;
use crate::sampling::{shuffled_index, sobol_owen_2d};
use crate::tracer::{latin_hypercube, mix64};

/// One pixel's (or replicate's) sample streams, from sample `first` on.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PixelSampler {
    /// Scramble of the position in the pixel (None: Latin hypercube).
    film: Option<u64>,
    /// Scramble of the light samples' sequences (None: independent draws).
    light: Option<u64>,
    /// Scramble of the final gather's directions.
    gather: u64,
    /// Samples the stream already has (earlier rounds).
    first: u32,
}

impl PixelSampler {
    /// The streams of pixel `pixel` (row-major index) under `seed`, for
    /// `replicate` (None: the pixel's own), continuing after `first`
    /// samples; `(positions, light)` from Sobol sequences where `sobol` says.
    pub(crate) fn new(
        seed: u64,
        pixel: u64,
        replicate: Option<usize>,
        first: u32,
        sobol: (bool, bool),
    ) -> Self {
        let salt = replicate.map_or(0, |r| (r as u64 + 1) << 40);
        let gather = mix64(seed ^ mix64(pixel ^ 0x6A7E ^ salt));
        PixelSampler {
            film: sobol.0.then(|| mix64(gather ^ 0x0050_1C57_0F11)),
            light: sobol.1.then(|| mix64(gather ^ 0x005E_ED11_6475)),
            gather,
            first,
        }
    }

    /// Positions in the pixel (`[0,1)²`) of the next `n` samples into
    /// `out`; the Latin hypercube draws from `rng`.
    pub(crate) fn film_positions(&self, n: usize, rng: &mut Pcg64Mcg, out: &mut Vec<[f64; 2]>) {
        out.clear();
        match self.film {
            Some(s) => out.extend((0..n as u32).map(|i| {
                let index = shuffled_index(self.first.wrapping_add(i), s);
                sobol_owen_2d(index, s)
            })),
            None => latin_hypercube(n, rng, out),
        }
    }

    /// The light samples' strata of the `j`-th of the next samples.
    pub(crate) fn light(&self, j: u32) -> Option<LightStrata> {
        self.light.map(|scramble| LightStrata {
            scramble,
            sample: self.first.wrapping_add(j),
        })
    }

    /// The `k` final-gather directions (`[0,1)²`) of the `j`-th of the next
    /// samples into `out`: the block `(first + j)·k …` of the sequence.
    pub(crate) fn gather(&self, j: u32, k: usize, out: &mut Vec<[f64; 2]>) {
        out.clear();
        let start = self.first.wrapping_add(j) as u64 * k as u64;
        out.extend((0..k as u64).map(|i| sobol_owen_2d((start + i) as u32, self.gather)));
    }
}

#[cfg(test)]
mod tests {
    use super::PixelSampler;
    use rand::SeedableRng;
    use rand_pcg::Pcg64Mcg;

    /// Positions drawn over three rounds (4 + 8 + 4 samples) are the first
    /// 16 points of one scrambled (0,2)-sequence: every 4 × 4 cell and every
    /// 2 × 8 / 8 × 2 box holds exactly one, which a batch-by-batch Latin
    /// hypercube does not give.
    #[test]
    fn rounds_continue_one_net() {
        let mut rng = Pcg64Mcg::seed_from_u64(1);
        for pixel in [0u64, 17, 76_799] {
            let mut all = Vec::new();
            let mut first = 0u32;
            for n in [4usize, 8, 4] {
                let s = PixelSampler::new(7, pixel, Some(1), first, (true, true));
                let mut pts = Vec::new();
                s.film_positions(n, &mut rng, &mut pts);
                all.extend(pts);
                first += n as u32;
            }
            for (nx, ny) in [(4usize, 4usize), (2, 8), (8, 2), (16, 1), (1, 16)] {
                let mut seen = [0u32; 16];
                for [x, y] in &all {
                    seen[(x * nx as f64) as usize * ny + (y * ny as f64) as usize] += 1;
                }
                assert!(seen.iter().all(|&k| k == 1), "{nx}×{ny}, pixel {pixel}");
            }
        }
    }

    /// The pairs are scrambled apart: positions, light strata and gather
    /// directions of one pixel differ, and so do two pixels' positions and
    /// the two replicates'.
    #[test]
    fn streams_are_scrambled_apart() {
        let mut rng = Pcg64Mcg::seed_from_u64(1);
        let mut first_point = |pixel, rep| {
            let mut p = Vec::new();
            PixelSampler::new(3, pixel, rep, 0, (true, true)).film_positions(1, &mut rng, &mut p);
            p[0]
        };
        assert_ne!(first_point(5, None), first_point(6, None));
        assert_ne!(first_point(5, Some(0)), first_point(5, Some(1)));
        let s = PixelSampler::new(3, 5, None, 0, (true, true));
        let mut g = Vec::new();
        s.gather(0, 1, &mut g);
        assert_ne!(g[0], first_point(5, None));
        assert_ne!(s.light(0).unwrap().scramble, s.gather);
        assert!(
            PixelSampler::new(3, 5, None, 0, (false, false))
                .light(0)
                .is_none()
        );
    }
}
