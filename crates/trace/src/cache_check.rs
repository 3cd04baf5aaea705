//! The radiosity cache's bias, measured by the render itself.
//!
//! The cache + final gather is fast because it reads interreflected light
//! from texels instead of following paths; what a texel cannot hold (light
//! varying inside it, the geometric tail of the bounce series) is a bias
//! the per-pixel noise estimate knows nothing about. After a render that
//! used the cache, a sparse, evenly strided set of pixels that see no
//! emitter is gathered twice at the same camera hit points: once as the
//! render did (cache + final gather) and once by unbiased path tracing
//! (cosine-weighted paths with next-event estimation, Russian roulette,
//! up to [`CHECK_BOUNCES`] diffuse bounces — what `indirect = path` does).
//! The mean difference, relative to the mean radiance of those pixels, is
//! the cache's bias over the image, with its standard error from the spread
//! over pixels; `report.json` states it beside the noise (`error.bias`).

use rayon::prelude::*;
use serde::Serialize;

use crate::indirect::Cache;
use crate::light::Light;
use crate::tracer::{PathState, RayCounts, Tracer, latin_hypercube, stream};

/// Pixels checked (at most; evenly strided over the image).
pub const CHECK_PIXELS: usize = 512;
/// Camera samples per checked pixel.
pub const CHECK_SAMPLES: usize = 4;
/// Path-traced gather directions per camera sample.
pub const CHECK_PATHS: usize = 16;
/// Diffuse bounces of the check's paths (Russian roulette ends most far
/// sooner): the reference's depth.
pub const CHECK_BOUNCES: u32 = 64;

const DOMAIN_CHECK: u64 = 0x00CA_C4EC_4EC4;

/// The cache's measured bias over the image, per band.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct CacheBias {
    /// What was compared.
    pub method: String,
    /// Pixels checked, camera samples and path-traced directions each.
    pub pixels: usize,
    pub samples_per_pixel: usize,
    pub paths_per_sample: usize,
    /// Per band: (cache − path traced) / mean radiance of the checked
    /// pixels (positive: the cache reads too bright), and its standard
    /// error.
    pub bands: Vec<BandBias>,
    /// The largest over bands of |bias| + 2 standard errors: what the bias
    /// could be, as a share of the signal.
    pub relative_bias_bound: f64,
    /// Wall time of the check, seconds.
    pub seconds: f64,
}

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct BandBias {
    pub band: String,
    pub relative_bias: f64,
    pub relative_bias_std_error: f64,
}

impl Tracer {
    /// Measures the cache's bias at up to [`CHECK_PIXELS`] pixels of a
    /// whole-image render (`radiance` band × pixel, row-major; `skip` marks
    /// the pixels that see an emitter). None without a cache.
    pub(crate) fn cache_bias(&self, radiance: &[Vec<f64>], skip: &[bool]) -> Option<CacheBias> {
        let cache = self.cache.as_ref()?;
        let t0 = std::time::Instant::now();
        let npix = self.camera.width as usize * self.camera.height as usize;
        let nb = self.wl.band_names.len();
        if npix == 0 || nb == 0 || skip.len() != npix {
            return None;
        }
        let picked = checked_pixels(skip);
        if picked.len() < 2 {
            return None;
        }
        // Per checked pixel and band: cache − path traced, averaged over its
        // samples.
        let diffs: Vec<Vec<f64>> = picked
            .par_iter()
            .map(|&i| self.pixel_cache_difference(cache, i))
            .collect();
        let bands = self.band_biases(radiance, &picked, &diffs);
        let bound = bands
            .iter()
            .map(|b| b.relative_bias.abs() + 2.0 * b.relative_bias_std_error)
            .fold(0.0, f64::max);
        Some(CacheBias {
            method: format!(
                "cache + final gather against path tracing ({CHECK_BOUNCES} diffuse bounces, next-event estimation) at the same camera hit points of pixels that see no emitter"
            ),
            pixels: picked.len(),
            samples_per_pixel: CHECK_SAMPLES,
            paths_per_sample: CHECK_PATHS,
            bands,
            relative_bias_bound: bound,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// One checked pixel's cache − path-traced radiance per band, averaged
    /// over its [`CHECK_SAMPLES`] camera samples (its own random stream).
    fn pixel_cache_difference(&self, cache: &Cache, i: usize) -> Vec<f64> {
        let cam = &self.camera;
        let nb = self.wl.band_names.len();
        let nwl = self.wl.len();
        let inv_pi = std::f64::consts::FRAC_1_PI;
        let (col, row) = (
            (i % cam.width as usize) as f64,
            (i / cam.width as usize) as f64,
        );
        let mut rng = stream(self.settings.seed, DOMAIN_CHECK, i as u64);
        let mut c = RayCounts::default();
        let mut sub = Vec::with_capacity(CHECK_SAMPLES);
        latin_hypercube(CHECK_SAMPLES, &mut rng, &mut sub);
        let mut diff = vec![0.0; nb];
        for [sx, sy] in sub {
            let d = cam.pixel_direction(col + sx, row + sy);
            let Some(hit) = self
                .geom
                .intersect(cam.position, d, 0.0, f64::INFINITY, u32::MAX)
            else {
                continue;
            };
            let f = hit.facet;
            let mat = self.mat_of(f);
            if !mat.has_diffuse {
                continue;
            }
            let p = cam.position + d * hit.t;
            let ng = self.normal_of(f);
            let front = d.dot(ng) < 0.0;
            let ns = if front { ng } else { -ng };
            // As the render reads it.
            let mut by_cache = Light::dark(nwl, 0);
            let scale: Vec<f64> = mat.kd.iter().map(|k| k * inv_pi).collect();
            self.cached_indirect(
                cache,
                p,
                ns,
                f,
                front,
                &scale,
                None,
                &mut rng,
                &mut c,
                &mut by_cache,
            );
            let by_paths = self.path_traced_diffuse(p, ns, f, &mat.kd, &mut rng, &mut c);
            let a = self.wl.integrate(&by_cache.whole);
            let b = self.wl.integrate(&by_paths.whole);
            for k in 0..nb {
                diff[k] += (a[k] - b[k]) / CHECK_SAMPLES as f64;
            }
        }
        diff
    }

    /// The diffuse reflected radiance at `p` by [`CHECK_PATHS`] unbiased
    /// paths: ρ/π ∫ L cos dω = ρ · mean L over cosine-weighted directions.
    fn path_traced_diffuse(
        &self,
        p: glam::DVec3,
        ns: glam::DVec3,
        f: u32,
        kd: &[f64],
        rng: &mut rand_pcg::Pcg64Mcg,
        c: &mut RayCounts,
    ) -> Light {
        let mut by_paths = Light::dark(self.wl.len(), 0);
        let thr: Vec<f64> = kd.iter().map(|k| k / CHECK_PATHS as f64).collect();
        let mut dirs = Vec::with_capacity(CHECK_PATHS);
        latin_hypercube(CHECK_PATHS, rng, &mut dirs);
        let (tx, ty) = crate::sky_light::orthonormal_basis(ns);
        for &uv in &dirs {
            let l = crate::sky_light::cosine_hemisphere(uv);
            let dir = (tx * l.x + ty * l.y + ns * l.z).normalize_or_zero();
            let state = PathState {
                diffuse: 1,
                after_diffuse: true,
                ..PathState::camera(CHECK_BOUNCES, false)
            };
            self.trace(p, dir, f, &thr, state, None, None, rng, c, &mut by_paths);
        }
        by_paths
    }

    /// Per band: the mean difference relative to the checked pixels' mean
    /// radiance, and its standard error from the spread over pixels.
    fn band_biases(
        &self,
        radiance: &[Vec<f64>],
        picked: &[usize],
        diffs: &[Vec<f64>],
    ) -> Vec<BandBias> {
        let n = picked.len() as f64;
        (0..self.wl.band_names.len())
            .map(|b| {
                let mean_l: f64 = picked.iter().map(|&i| radiance[b][i]).sum::<f64>() / n;
                let m = diffs.iter().map(|d| d[b]).sum::<f64>() / n;
                let var = diffs.iter().map(|d| (d[b] - m).powi(2)).sum::<f64>() / (n - 1.0);
                let (rel, se) = if mean_l > 0.0 {
                    (m / mean_l, (var / n).sqrt() / mean_l)
                } else {
                    (0.0, 0.0)
                };
                BandBias {
                    band: self.wl.band_names[b].clone(),
                    relative_bias: rel,
                    relative_bias_std_error: se,
                }
            })
            .collect()
    }
}

/// Up to [`CHECK_PIXELS`] pixels that see no emitter, evenly strided.
fn checked_pixels(skip: &[bool]) -> Vec<usize> {
    let candidates: Vec<usize> = (0..skip.len()).filter(|&i| !skip[i]).collect();
    let stride = candidates.len().div_ceil(CHECK_PIXELS).max(1);
    candidates
        .iter()
        .skip(stride / 2)
        .step_by(stride)
        .copied()
        .collect()
}
