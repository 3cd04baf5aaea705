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
        let cam = &self.camera;
        let npix = cam.width as usize * cam.height as usize;
        let nb = self.wl.band_names.len();
        if npix == 0 || nb == 0 || skip.len() != npix {
            return None;
        }
        let candidates: Vec<usize> = (0..npix).filter(|&i| !skip[i]).collect();
        let stride = candidates.len().div_ceil(CHECK_PIXELS).max(1);
        let picked: Vec<usize> = candidates
            .iter()
            .skip(stride / 2)
            .step_by(stride)
            .copied()
            .collect();
        if picked.len() < 2 {
            return None;
        }
        let nwl = self.wl.len();
        let inv_pi = std::f64::consts::FRAC_1_PI;
        // Per checked pixel and band: cache − path traced, averaged over its
        // samples.
        let diffs: Vec<Vec<f64>> = picked
            .par_iter()
            .map(|&i| {
                let (col, row) = (
                    (i % cam.width as usize) as f64,
                    (i / cam.width as usize) as f64,
                );
                let mut rng = stream(self.settings.seed, DOMAIN_CHECK, i as u64);
                let mut c = RayCounts::default();
                let mut sub = Vec::with_capacity(CHECK_SAMPLES);
                latin_hypercube(CHECK_SAMPLES, &mut rng, &mut sub);
                let mut diff = vec![0.0; nb];
                let mut dirs = Vec::with_capacity(CHECK_PATHS);
                for [sx, sy] in sub {
                    let d = cam.pixel_direction(col + sx, row + sy);
                    let Some(hit) =
                        self.geom
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
                    // By paths: ρ/π ∫ L cos dω = ρ · mean L over cosine-
                    // weighted directions.
                    let mut by_paths = Light::dark(nwl, 0);
                    let thr: Vec<f64> = mat.kd.iter().map(|k| k / CHECK_PATHS as f64).collect();
                    dirs.clear();
                    latin_hypercube(CHECK_PATHS, &mut rng, &mut dirs);
                    let (tx, ty) = crate::sky_light::orthonormal_basis(ns);
                    for &uv in &dirs {
                        let l = crate::sky_light::cosine_hemisphere(uv);
                        let dir = (tx * l.x + ty * l.y + ns * l.z).normalize_or_zero();
                        let state = PathState {
                            diffuse: 1,
                            after_diffuse: true,
                            ..PathState::camera(CHECK_BOUNCES, false)
                        };
                        self.trace(
                            p,
                            dir,
                            f,
                            &thr,
                            state,
                            None,
                            None,
                            &mut rng,
                            &mut c,
                            &mut by_paths,
                        );
                    }
                    let a = self.wl.integrate(&by_cache.whole);
                    let b = self.wl.integrate(&by_paths.whole);
                    for k in 0..nb {
                        diff[k] += (a[k] - b[k]) / CHECK_SAMPLES as f64;
                    }
                }
                diff
            })
            .collect();
        let n = picked.len() as f64;
        let bands = (0..nb)
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
            .collect::<Vec<_>>();
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
}
