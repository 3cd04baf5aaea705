//! The film: the pixels' estimates developed into band radiance, stated
//! standard errors and spp — the whole image and one image per light group
//! from the same samples — with the emitters seen directly added, the
//! point sources' deposits, and the cache's bias stated beside the noise.

use super::adaptive::{Region, Samples};
use super::*;

/// One developed image: band radiance and its stated standard error.
pub(super) struct Image {
    pub(super) radiance: Array3<f64>,
    pub(super) std_error: Array3<f64>,
}

impl Image {
    fn zeros(nb: usize, region: &Region) -> Self {
        let shape = (nb, region.h as usize, region.w as usize);
        Self {
            radiance: Array3::zeros(shape),
            std_error: Array3::zeros(shape),
        }
    }

    /// Adds the point sources seen directly that fall in `region` (of
    /// light group `group`, or all of them with `None`).
    pub(super) fn deposit(&mut self, deposits: &[Deposit], region: &Region, group: Option<usize>) {
        for (col, row, vals, g) in deposits {
            if !region.rows.contains(row) || group.is_some_and(|want| Some(want) != *g) {
                continue;
            }
            for (b, v) in vals.iter().enumerate() {
                self.radiance[[b, (row - region.row0()) as usize, *col as usize]] += v;
            }
        }
    }
}

/// The whole image developed, with its spp map, the errors it states and
/// each pixel's stratification factor (which its layers share).
pub(super) struct Film {
    pub(super) image: Image,
    pub(super) spp: ndarray::Array2<u32>,
    pub(super) error: ErrorSummary,
    factor: Vec<f64>,
}

impl Tracer {
    /// The whole image from `s`: each pixel's mean plus what it sees
    /// directly, its stated error (the samples' and the direct view's in
    /// quadrature), and the error summary.
    pub(super) fn develop(&self, s: &Samples, region: &Region) -> Film {
        let (w, nb) = (region.w as usize, self.wl.band_names.len());
        let replicated = s.replicated;
        let mut image = Image::zeros(nb, region);
        let mut spp = ndarray::Array2::<u32>::zeros((region.h as usize, w));
        let floor = band_floor(&s.ests, &s.views, nb);
        let (factor, pooled) = if replicated {
            let (f, g) = stratification(&s.ests, &floor);
            (f, Some(g))
        } else {
            (vec![1.0; s.ests.len()], None)
        };
        let stated = stated_std_errors(&s.ests, w, &factor, &floor, replicated);
        for (i, e) in s.ests.iter().enumerate() {
            let (row, col) = (i / w, i % w);
            let inv = 1.0 / e.n.max(1) as f64;
            let mean: Vec<f64> = e.spectral.iter().map(|a| a * inv).collect();
            let view = s.views[i].as_ref();
            for (b, v) in self.wl.integrate(&mean).into_iter().enumerate() {
                let (add, se) = view.map_or((0.0, 0.0), |t| (t.bands[b], t.std_error[b]));
                image.radiance[[b, row, col]] = v + add;
                image.std_error[[b, row, col]] = stated[i * nb + b].hypot(se);
            }
            spp[[row, col]] = e.n;
        }
        let adaptive = self.settings.target_error.map(|t| (t, self.spp_cap()));
        let error = error_summary(&s.ests, &floor, &stated, pooled, adaptive, s.rounds, w);
        Film {
            image,
            spp,
            error,
            factor,
        }
    }

    /// Light group `g`'s image from the same samples: its part of each
    /// pixel's samples and of what the pixel sees directly; its error is
    /// the per-sample one times the whole's stratification factor.
    pub(super) fn develop_layer(
        &self,
        s: &Samples,
        region: &Region,
        film: &Film,
        g: usize,
    ) -> Image {
        let (w, nb) = (region.w as usize, self.wl.band_names.len());
        let mut image = Image::zeros(nb, region);
        for (i, e) in s.ests.iter().enumerate() {
            let (row, col) = (i / w, i % w);
            let view = s.views[i]
                .as_ref()
                .and_then(|t| t.light.part(g))
                .map(|part| self.wl.integrate(part));
            for b in 0..nb {
                let (m, se) = e.layer(g, b);
                let add = view.as_ref().map_or(0.0, |v| v[b]);
                image.radiance[[b, row, col]] = m + add;
                image.std_error[[b, row, col]] = se * film.factor[i];
            }
        }
        image
    }

    /// States the radiosity cache's bias on the whole image (pixels
    /// seeing an emitter left out, as in the error), and the error with
    /// the bias and the noise together.
    pub(super) fn state_cache_bias(&self, film: &mut Film, s: &Samples) -> Result<(), TraceError> {
        let skip: Vec<bool> = s.ests.iter().map(|e| e.sees_emitter).collect();
        let by_band: Vec<Vec<f64>> = film
            .image
            .radiance
            .outer_iter()
            .map(|band| band.iter().copied().collect())
            .collect();
        let error = &mut film.error;
        error.bias = with_pool(self.settings.threads, || self.cache_bias(&by_band, &skip))?;
        let noise = error
            .rel_std_error_rms_target_pixels
            .unwrap_or(error.rel_std_error_rms);
        error.rel_error_rms_with_bias = error
            .bias
            .as_ref()
            .map(|b| noise.hypot(b.relative_bias_bound));
        Ok(())
    }
}
