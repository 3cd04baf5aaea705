//! The parallel render loop, point sources seen directly, and probes.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::DVec3;
use gloam_scene::Scene;
use ndarray::Array3;
use rayon::prelude::*;
use serde::Serialize;

use crate::direct_view::ViewTerm;
use crate::light::Light;
use crate::settings::{LightStrataMode, RenderSettings};
use crate::tracer::{
    LightStrata, PathState, RayCounts, TraceError, Tracer, latin_hypercube, stream,
};

/// A point source seen directly: pixel column and row, band radiances,
/// and its light group (`--layers`).
pub(crate) type Deposit = (u32, u32, Vec<f64>, Option<usize>);

/// Side of the square image tiles handed to rayon.
pub const TILE: u32 = 16;

/// Random-stream domains (so pixels and probes never share a stream).
const DOMAIN_PIXEL: u64 = 1;
const DOMAIN_PROBE: u64 = 2;
const DOMAIN_BATCH: u64 = 3;
const DOMAIN_REPLICATE: u64 = 4;

/// A pixel's running estimate: spectral sum, per band the sum and sum of
/// squares of the per-sample values, and per band the sums of two
/// independently randomised replicates (adaptive renders only).
#[derive(Clone, Debug)]
struct PixelEstimate {
    n: u32,
    spectral: Vec<f64>,
    band_sum: Vec<f64>,
    band_sq: Vec<f64>,
    /// Samples and band sums of replicates A and B (adaptive renders: each
    /// replicate has its own random stream and its own Owen scramble, so
    /// the difference of their means measures the error of a stratified
    /// estimate without the per-sample variance's bias).
    rep_n: [u32; 2],
    rep_sum: [Vec<f64>; 2],
    /// Per band, whether any sample was non-zero (a pixel whose samples
    /// are all zero has no per-sample variance to state an error from).
    band_lit: Vec<bool>,
    /// Whether the pixel shows an emitter's face: its direct-view term
    /// (`direct_view.rs`, decided before any sample) is lit, or a camera
    /// sample met a face left to the samples. The error target leaves such
    /// a pixel out, as the accuracy metric does.
    sees_emitter: bool,
    /// Light groups (`--layers`; 0 without), and per group and band the
    /// sum and sum of squares of the samples' parts (`[g * nb + b]`): the
    /// same samples as the whole, split by the emitter the light came
    /// from.
    groups: usize,
    layer_sum: Vec<f64>,
    layer_sq: Vec<f64>,
}

impl PixelEstimate {
    fn new(nwl: usize, nb: usize, groups: usize) -> Self {
        Self {
            n: 0,
            spectral: vec![0.0; nwl],
            band_sum: vec![0.0; nb],
            band_sq: vec![0.0; nb],
            rep_n: [0; 2],
            rep_sum: [vec![0.0; nb], vec![0.0; nb]],
            band_lit: vec![false; nb],
            sees_emitter: false,
            groups,
            layer_sum: vec![0.0; groups * nb],
            layer_sq: vec![0.0; groups * nb],
        }
    }

    /// Adds group `g`'s part `bands` of the sample just added with
    /// [`PixelEstimate::add`] (a group that added nothing adds zeros, so it
    /// need not be called).
    fn add_layer(&mut self, g: usize, bands: &[f64]) {
        let nb = bands.len();
        for (b, v) in bands.iter().enumerate() {
            self.layer_sum[g * nb + b] += v;
            self.layer_sq[g * nb + b] += v * v;
        }
    }

    /// Group `g`'s band `b`: the mean of its parts and their standard error
    /// from the per-sample variance (as [`PixelEstimate::std_error`]).
    fn layer(&self, g: usize, b: usize) -> (f64, f64) {
        let nb = self.band_sum.len();
        let (sum, sq) = (self.layer_sum[g * nb + b], self.layer_sq[g * nb + b]);
        let n = self.n.max(1) as f64;
        let m = sum / n;
        if self.n < 2 {
            return (m, 0.0);
        }
        let var = ((sq - n * m * m) / (n - 1.0)).max(0.0);
        (m, (var / n).sqrt())
    }

    fn add(&mut self, spectral: &[f64], bands: &[f64], replicate: Option<usize>) {
        self.n += 1;
        self.spectral
            .iter_mut()
            .zip(spectral)
            .for_each(|(a, b)| *a += b);
        for (b, v) in bands.iter().enumerate() {
            self.band_sum[b] += v;
            self.band_sq[b] += v * v;
            self.band_lit[b] |= *v != 0.0;
        }
        if let Some(r) = replicate {
            self.rep_n[r] += 1;
            self.rep_sum[r]
                .iter_mut()
                .zip(bands)
                .for_each(|(a, b)| *a += b);
        }
    }

    /// Whether any band has had a non-zero sample.
    fn lit(&self) -> bool {
        self.band_lit.iter().any(|&l| l)
    }

    fn mean(&self, b: usize) -> f64 {
        self.band_sum[b] / self.n.max(1) as f64
    }

    /// Standard error of the band mean from the per-sample variance (the
    /// samples of a batch are stratified, so this errs on the high side;
    /// adaptive renders scale it by the measured [`stratification`]).
    fn std_error(&self, b: usize) -> f64 {
        if self.n < 2 {
            return 0.0;
        }
        let n = self.n as f64;
        let m = self.band_sum[b] / n;
        let var = ((self.band_sq[b] - n * m * m) / (n - 1.0)).max(0.0);
        (var / n).sqrt()
    }

    /// Per band, the squared half-difference of the two replicates' means
    /// relative to `max(|mean|, floor_b)`²: an unbiased estimate of the
    /// relative variance of the pixel's mean (one degree of freedom), and
    /// the per-sample estimate's relative variance beside it.
    fn replicate_terms(&self, floor: &[f64]) -> Option<(f64, f64)> {
        let [na, nb] = self.rep_n;
        if na == 0 || na != nb || self.n < 4 {
            return None;
        }
        let (mut rep, mut naive) = (0.0, 0.0);
        for (b, &fl) in floor.iter().enumerate() {
            let d = self.mean(b).abs().max(fl);
            if d <= 0.0 {
                continue;
            }
            let half = 0.5 * (self.rep_sum[0][b] - self.rep_sum[1][b]) / na as f64;
            rep += (half / d).powi(2);
            naive += (self.std_error(b) / d).powi(2);
        }
        Some((rep, naive))
    }
}

/// The ratio of the true to the per-sample standard error, measured from
/// the replicates and pooled over pixels of similar sample count and
/// per-sample error: first into classes of sample count (octaves, merged
/// from the top down until a class holds [`MIN_CLASS_PIXELS`]), then
/// within a class into groups by quantile of the per-sample error
/// ([`STRATIFICATION_GROUPS`] at most, [`MIN_POOLED_PIXELS`] each). The
/// count matters: a scrambled sequence's error falls faster than `1/√n`
/// on a penumbra, so pooling a pixel grown to 256 samples with pixels of
/// 8 gave it their ratio and stated ~3× its true error. Each pixel's
/// one-degree-of-freedom replicate estimate is far too noisy on its own.
/// Returns the factor per pixel (1 where nothing was measured) and the
/// image-wide factor.
fn stratification(ests: &[PixelEstimate], floor: &[f64]) -> (Vec<f64>, f64) {
    let terms: Vec<Option<(f64, f64)>> =
        ests.par_iter().map(|e| e.replicate_terms(floor)).collect();
    let mut order: Vec<usize> = (0..ests.len())
        .filter(|&i| terms[i].is_some_and(|(_, v)| v > 0.0))
        .collect();
    let mut factor = vec![1.0; ests.len()];
    let sums = |idx: &[usize]| {
        idx.iter().fold((0.0, 0.0), |(a, b), &i| {
            let (r, v) = terms[i].unwrap_or((0.0, 0.0));
            (a + r, b + v)
        })
    };
    let (sr, sv) = sums(&order);
    if sv <= 0.0 || order.len() < MIN_POOLED_PIXELS {
        return (factor, 1.0);
    }
    let global = (sr / sv).sqrt();
    // Sample-count octave first, per-sample error within it.
    let octave = |i: usize| ests[i].n.max(1).ilog2();
    order.sort_by(|&a, &b| {
        let va = terms[a].map_or(0.0, |t| t.1);
        let vb = terms[b].map_or(0.0, |t| t.1);
        octave(a).cmp(&octave(b)).then(va.total_cmp(&vb))
    });
    // Classes from the top down: the octaves of many samples hold few
    // pixels; a class closes once it has MIN_CLASS_PIXELS, and a short
    // remainder at the bottom joins the class above it.
    let mut classes: Vec<std::ops::Range<usize>> = Vec::new();
    let mut end = order.len();
    while end > 0 {
        let mut start = end;
        while start > 0
            && (end - start < MIN_CLASS_PIXELS || octave(order[start - 1]) == octave(order[start]))
        {
            start -= 1;
        }
        classes.push(start..end);
        end = start;
    }
    if classes.len() > 1 && classes.last().is_some_and(|c| c.len() < MIN_CLASS_PIXELS) {
        let low = classes.pop().map_or(0, |c| c.start);
        if let Some(c) = classes.last_mut() {
            c.start = low;
        }
    }
    for class in classes {
        let members = &order[class];
        let groups = STRATIFICATION_GROUPS
            .min(members.len() / MIN_POOLED_PIXELS)
            .max(1);
        for g in 0..groups {
            let chunk = &members[g * members.len() / groups..(g + 1) * members.len() / groups];
            let (r, v) = sums(chunk);
            let f = if v > 0.0 { (r / v).sqrt() } else { global };
            for &i in chunk {
                factor[i] = f;
            }
        }
    }
    // Pixels without a per-sample variance (all samples equal) keep their
    // zero estimate whatever the factor; give them the image-wide one.
    for (i, t) in terms.iter().enumerate() {
        if !t.is_some_and(|(_, v)| v > 0.0) {
            factor[i] = global;
        }
    }
    (factor, global)
}

/// Groups of pixels (by quantile of their per-sample relative error) over
/// which the replicate estimate is pooled, within a sample-count class.
pub const STRATIFICATION_GROUPS: usize = 64;
/// A group pools at least this many pixels.
const MIN_POOLED_PIXELS: usize = 256;
/// A sample-count class of [`stratification`] holds at least this many
/// pixels (two bands each: ~64 degrees of freedom, the pooled ratio's
/// relative error ~18 %, where one class of every count erred 3× on the
/// pixels of most samples).
const MIN_CLASS_PIXELS: usize = 32;

/// Below this many samples a pixel's per-sample deviation is its 3 × 3
/// neighbourhood's RMS (adaptive renders).
pub const TRUSTED_SPP: u32 = 8;

/// Pixels within this distance (a square window) lend their scale to a
/// neighbour whose samples were all zero.
pub const DARK_NEIGHBOURHOOD: usize = 2;

/// The standard error the render states, per pixel and band (pixel-major:
/// `[i * nb + b]`): the per-sample estimate scaled by the pixel's measured
/// stratification `factor`, or — where every sample of a band was zero
/// (a deep penumbra whose shadow rays all met the occluder) — an upper
/// bound, not zero: the largest mean within [`DARK_NEIGHBOURHOOD`] pixels
/// divided by the pixel's sample count, the error one sample of the
/// neighbours' size would make. Only a pixel with no lit sample in its
/// neighbourhood states zero (it is dark as far as sampling can tell).
/// `bound_dark` is false for fixed-spp renders, which may be tiles (a
/// neighbourhood across a tile edge is not there, and a tiled render must
/// merge bit-identically): they state the per-sample error.
fn stated_std_errors(
    ests: &[PixelEstimate],
    w: usize,
    factor: &[f64],
    floor: &[f64],
    bound_dark: bool,
) -> Vec<f64> {
    let nb = ests.first().map_or(0, |e| e.band_sum.len());
    let h = ests.len() / w.max(1);
    let mut out = vec![0.0; ests.len() * nb];
    // The denominator of a relative error, and each lit pixel's
    // per-sample relative deviation, for the neighbourhood rule below.
    let denom =
        |e: &PixelEstimate, b: usize| e.mean(b).abs().max(floor.get(b).copied().unwrap_or(0.0));
    let dev = |i: usize, b: usize| -> f64 {
        let e = &ests[i];
        let d = denom(e, b);
        if !e.band_lit[b] || d <= 0.0 {
            0.0
        } else {
            e.std_error(b) * factor[i] * (e.n as f64).sqrt() / d
        }
    };
    // Each pixel's entries depend on its neighbours' estimates only:
    // computed in parallel (between adaptive rounds one core would idle).
    out.par_chunks_mut(nb.max(1))
        .enumerate()
        .for_each(|(i, row)| {
            let e = &ests[i];
            for (b, slot) in row.iter_mut().enumerate() {
                *slot = if e.band_lit[b] && bound_dark && e.n < TRUSTED_SPP {
                    // Few samples can all land on one side of a shadow edge
                    // and agree: until a pixel has TRUSTED_SPP, its per-sample
                    // deviation is the RMS over its 3 × 3 neighbourhood (its
                    // own included), which a penumbra's neighbours raise and a
                    // smooth region leaves unbiased.
                    let (sum, count) = window(i, w, h, 1)
                        .map(|j| dev(j, b))
                        .fold((0.0, 0.0), |(s, k), v| (s + v * v, k + 1.0));
                    let near = (sum / f64::max(count, 1.0)).sqrt();
                    near * denom(e, b) / (e.n as f64).sqrt()
                } else if e.band_lit[b] || e.n == 0 || !bound_dark {
                    e.std_error(b) * factor[i]
                } else {
                    let scale = window(i, w, h, DARK_NEIGHBOURHOOD)
                        .map(|j| ests[j].mean(b).abs())
                        .fold(0.0, f64::max);
                    scale / e.n as f64
                };
            }
        });
    out
}

/// Indices of the pixels within `radius` of pixel `i` (a square window,
/// clipped to the `w × h` image, `i` included), row by row.
fn window(i: usize, w: usize, h: usize, radius: usize) -> impl Iterator<Item = usize> {
    let (r, c) = (i / w.max(1), i % w.max(1));
    (r.saturating_sub(radius)..(r + radius + 1).min(h)).flat_map(move |rr| {
        (c.saturating_sub(radius)..(c + radius + 1).min(w)).map(move |cc| rr * w + cc)
    })
}

/// Largest relative stated error over bands, each relative to
/// `max(|mean|, floor_b)`.
fn stated_rel_error(e: &PixelEstimate, se: &[f64], floor: &[f64]) -> f64 {
    se.iter()
        .zip(floor)
        .enumerate()
        .map(|(b, (&s, &fl))| {
            let d = e.mean(b).abs().max(fl);
            if d > 0.0 { s / d } else { 0.0 }
        })
        .fold(0.0, f64::max)
}

/// The next round of an adaptive render: `(pixel, samples to add)`, or
/// nothing once the image's RMS of stated relative errors `rel` is at the
/// target. The target is the per-pixel RMS error of the image, so samples
/// go where they buy the most: with per-sample relative deviation
/// `s_i = rel_i √n_i`, the fewest samples giving RMS E are
/// `n_i = s_i · Σ s_j / (N E²)` (a Lagrange multiplier), each pixel growing
/// at most 4× per round (its error estimate improves as it grows) and
/// never past `cap`; every pixel first gets [`MIN_ADAPTIVE_SPP`].
///
/// Pixels whose samples have all been zero are not in that sum: their
/// stated error is the neighbourhood bound of [`stated_std_errors`], which
/// falls as 1/n, not 1/√n, and may be many times the target while they
/// are few — letting it set the multiplier would oversample every lit
/// pixel for the sake of a few umbra pixels. They grow on their own (4×
/// per round while their bound is above the target) until a sample lands
/// or [`DARK_MAX_SPP`] stops them. Pixels that see an emitter's face keep
/// [`MIN_ADAPTIVE_SPP`]: their error is the emitter edge's (the accuracy
/// metric leaves them out too), and chasing it would cost more than the
/// rest of the image.
fn allocate(ests: &[PixelEstimate], rel: &[f64], target: f64, cap: u32) -> Vec<(usize, u32)> {
    // Pixels at their cap keep their error (the report counts them); the
    // target holds for the rest.
    let cap_of = |e: &PixelEstimate| pixel_cap(e, cap);
    let free = |e: &PixelEstimate| e.n < cap_of(e) && e.lit() && !e.sees_emitter;
    let nfree = ests.iter().filter(|e| free(e)).count();
    let npix = nfree.max(1) as f64;
    let rms = (ests
        .iter()
        .zip(rel)
        .filter(|(e, _)| free(e))
        .map(|(_, r)| r * r)
        .sum::<f64>()
        / npix)
        .sqrt();
    let min = MIN_ADAPTIVE_SPP.min(cap);
    let below_min = ests.iter().any(|e| e.n < min);
    let dark_open = ests
        .iter()
        .zip(rel)
        .any(|(e, &r)| !e.lit() && e.n < cap_of(e) && r > target);
    if rms <= target && !below_min && !dark_open {
        return Vec::new();
    }
    let dev: Vec<f64> = ests
        .iter()
        .zip(rel)
        .map(|(e, r)| r * (e.n as f64).sqrt())
        .collect();
    let free_dev: f64 = ests
        .iter()
        .zip(&dev)
        .filter(|(e, _)| free(e))
        .map(|(_, d)| d)
        .sum();
    let lambda = if rms > target {
        aggregate_lambda(
            ests,
            &dev,
            target,
            npix,
            |e| free(e),
            |e| cap_of(e),
            min,
            free_dev,
        )
    } else {
        0.0
    };
    ests.iter()
        .enumerate()
        .filter_map(|(i, e)| {
            let want = if e.sees_emitter {
                0.0
            } else if e.lit() {
                (lambda * dev[i]).ceil()
            } else if rel[i] > target {
                f64::INFINITY
            } else {
                0.0
            };
            let want = if want.is_finite() {
                want.min(u32::MAX as f64) as u64
            } else {
                u64::MAX
            };
            let cap = cap_of(e);
            let goal = want
                .min(4 * e.n.max(1) as u64)
                .max(min as u64)
                .min(cap as u64);
            if goal <= e.n as u64 {
                return None;
            }
            // Replicated batches add an even count (half to each
            // replicate) without passing the cap.
            let add = (goal - e.n as u64) as u32;
            let add = add.div_ceil(2) * 2;
            let add = if e.n + add > cap { add - 2 } else { add };
            (add > 0).then_some((i, add))
        })
        .collect()
}

/// The multiplier `λ` of [`allocate`] (`n_i = λ s_i`) that brings the
/// predicted RMS of the free pixels exactly to `target` once each pixel
/// gets `max(n_i, min(λ s_i, 4 n_i, cap))` samples. The closed form
/// `Σ s_j / (N E²)` assumes every pixel moves to its optimum; pixels that
/// already hold more samples than that (grown in earlier rounds on a
/// noisier estimate) err less than it assumes, so it overshoots — 0.02
/// asked gave 0.0156 stated. Found by bisection on `log λ` (bounded: 64
/// steps), starting from the closed form.
#[allow(clippy::too_many_arguments)]
fn aggregate_lambda(
    ests: &[PixelEstimate],
    dev: &[f64],
    target: f64,
    npix: f64,
    free: impl Fn(&PixelEstimate) -> bool,
    cap_of: impl Fn(&PixelEstimate) -> u32,
    min: u32,
    free_dev: f64,
) -> f64 {
    // The free pixels' (n, s, cap), gathered once: the bisection passes
    // over them a dozen times, in the same order as the pixels.
    let items: Vec<(f64, f64, f64)> = ests
        .iter()
        .zip(dev)
        .filter(|(e, _)| free(e))
        .map(|(e, &d)| (e.n.max(1) as f64, d, cap_of(e) as f64))
        .collect();
    let predicted = |lambda: f64| -> f64 {
        items
            .iter()
            .map(|&(n, d, cap)| {
                let grown = (lambda * d).min(4.0 * n).min(cap).max(min as f64).max(n);
                d * d / grown
            })
            .sum::<f64>()
            / npix
    };
    let goal = target * target;
    let closed = free_dev / (npix * goal);
    if !(closed.is_finite() && closed > 0.0) || predicted(closed) > goal {
        // The closed form does not reach the target this round (growth
        // limits): ask for it; later rounds go on.
        return closed;
    }
    let (mut lo, mut hi) = (closed * 1e-6, closed);
    for _ in 0..64 {
        let mid = (lo * hi).sqrt();
        if predicted(mid) > goal {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi / lo < 1.001 {
            break;
        }
    }
    hi
}

/// A pixel whose samples have all been zero stops at this many (or
/// `max_spp` if lower): its stated error is then the neighbourhood bound
/// of [`stated_std_errors`], which falls only as 1/n — sampling an umbra to
/// `max_spp` would double a direct-light render for pixels that are, as
/// far as 64 samples tell, dark. The report counts them.
pub const DARK_MAX_SPP: u32 = 64;

/// The sample cap of pixel `e`: `max_spp`, or [`DARK_MAX_SPP`] while every
/// sample has been zero.
fn pixel_cap(e: &PixelEstimate, cap: u32) -> u32 {
    if e.lit() { cap } else { cap.min(DARK_MAX_SPP) }
}

/// Adaptive sampling: a pixel needs at least this many samples before its
/// error estimate is trusted.
pub const MIN_ADAPTIVE_SPP: u32 = 4;
/// The dark-pixel floor of `target_error`: a pixel's error is taken
/// relative to `max(|mean|, DARK_FLOOR × the band's image mean)`.
pub const DARK_FLOOR: f64 = 0.05;

/// What adaptive sampling achieved (in `report.json`).
#[derive(Clone, Debug, Serialize, Default)]
pub struct ErrorSummary {
    /// The requested relative standard error (None: fixed spp).
    pub target: Option<f64>,
    pub dark_floor_fraction_of_mean: f64,
    /// Percentiles of the per-pixel estimated relative standard error
    /// (largest over bands, relative to max(|mean|, floor)).
    pub rel_std_error_p50: f64,
    pub rel_std_error_p90: f64,
    pub rel_std_error_p99: f64,
    pub rel_std_error_max: f64,
    /// RMS over pixels of the estimated relative standard error.
    pub rel_std_error_rms: f64,
    /// Adaptive renders: the same RMS over the pixels the target governs —
    /// those with a lit sample that see no emitter's face — and their
    /// count: what `target_error` promises.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rel_std_error_rms_target_pixels: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target_pixels: Option<usize>,
    /// Pixels that show an emitter's face (left out of the target; they
    /// keep the minimum sample count).
    pub pixels_seeing_emitters: usize,
    /// Pixels whose every sample was zero and whose stated error is the
    /// neighbourhood bound (not zero) — deep penumbrae, or dark.
    pub pixels_all_zero_bounded: usize,
    /// Fraction of pixels at or below the target.
    pub fraction_meeting_target: Option<f64>,
    /// Adaptive renders: the measured ratio of the true standard error to
    /// the per-sample one, pooled over the image (the two replicates'
    /// spread; below 1 where stratification pays). The per-pixel estimates
    /// use the factor of their group (see `stratification`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stratification_factor: Option<f64>,
    /// Adaptive renders: pixels that reached `max_spp` with their stated
    /// error still above the target (`spp.npy` shows which), and the box
    /// `[col0, row0, col1, row1]` (inclusive) holding them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pixels_stopped_at_max_spp: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stopped_at_max_spp_box: Option<[usize; 4]>,
    pub mean_spp: f64,
    pub max_spp: u32,
    pub rounds: u32,
    /// The radiosity cache's bias over the image, measured by the render
    /// against path tracing at a sparse set of pixels (whole-image renders
    /// that read the cache; see [`crate::cache_check`]). The per-pixel
    /// errors above are noise only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias: Option<crate::cache_check::CacheBias>,
    /// With `bias`: the stated error with the bias in, √(RMS noise² +
    /// bias bound²), relative (the noise is the target pixels' RMS).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rel_error_rms_with_bias: Option<f64>,
}

/// Timings and ray counts of a render.
#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    pub width: u32,
    pub height: u32,
    pub bands: usize,
    /// Wavelength slots carried (continuum nodes + emission lines).
    pub wavelengths: usize,
    pub emission_lines: usize,
    pub triangles: usize,
    pub area_sources: usize,
    pub point_sources: usize,
    pub threads: usize,
    pub prepare_seconds: f64,
    pub trace_seconds: f64,
    pub rays: RayCounts,
    pub rays_per_second: f64,
    /// How interreflection was decided and computed.
    pub interreflection: crate::plan::InterreflectionDecision,
    /// What the render took from the `[sky]` block (None: no sky light).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky: Option<crate::sky_light::SkySummary>,
    /// The scene's size and each preparation step's time and peak memory.
    pub preparation: crate::prep::Preparation,
}

/// A rendered radiance image.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Band radiance at the entrance pupil, W m⁻² sr⁻¹, band × row × column.
    pub radiance: Array3<f64>,
    /// Estimated standard error of each pixel's radiance, same units and
    /// shape (from the per-sample variance; point sources seen directly
    /// are exact and add none).
    pub std_error: Array3<f64>,
    /// Camera samples each pixel got.
    pub spp: ndarray::Array2<u32>,
    /// What the sampling achieved.
    pub error: ErrorSummary,
    pub band_names: Vec<String>,
    pub settings: RenderSettings,
    pub stats: RenderStats,
}

/// What `gloam probe --point` reports.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ProbeResult {
    pub band: String,
    pub irradiance_w_m2: f64,
    pub std_error_w_m2: f64,
    /// The radiance the surface at the point reflects (Lambertian part,
    /// of the same light as `irradiance_w_m2`), when the point lies on a
    /// facet.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radiance_w_m2_sr: Option<f64>,
    /// The direct part of `irradiance_w_m2`.
    pub direct_irradiance_w_m2: f64,
    /// The interreflected part, when the render would simulate it (the
    /// effect plan's decision).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub indirect_irradiance_w_m2: Option<f64>,
    /// Which light terms the figures include, in words.
    pub terms: String,
}

/// Gather directions per probe repetition for interreflection (at least).
pub const PROBE_GATHER_RAYS: usize = 64;

/// Renders `scene` with `settings` (see [`Tracer::render`]).
pub fn render(scene: &Scene, settings: &RenderSettings) -> Result<RenderOutput, TraceError> {
    Tracer::new(scene, settings)?.render(&|_, _| {})
}

/// Irradiance at a world-space point (see [`Tracer::probe_point`]).
pub fn probe_point(
    scene: &Scene,
    settings: &RenderSettings,
    point: DVec3,
    normal: DVec3,
    band: Option<&str>,
    samples: u32,
) -> Result<ProbeResult, TraceError> {
    Tracer::new(scene, settings)?.probe_point(point, normal, band, samples)
}

fn with_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> T {
    match threads {
        Some(n) => match rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
        {
            Ok(pool) => pool.install(f),
            Err(_) => f(),
        },
        None => f(),
    }
}

/// [`DARK_FLOOR`] × each band's image mean, the emitters seen directly
/// (computed apart, `views`) included as in the image.
fn band_floor(ests: &[PixelEstimate], views: &[Option<ViewTerm>], nb: usize) -> Vec<f64> {
    (0..nb)
        .map(|b| {
            let s: f64 = ests
                .iter()
                .zip(views)
                .map(|(e, v)| (e.mean(b) + v.as_ref().map_or(0.0, |v| v.bands[b])).abs())
                .sum();
            DARK_FLOOR * s / ests.len().max(1) as f64
        })
        .collect()
}

fn error_summary(
    ests: &[PixelEstimate],
    floor: &[f64],
    stated: &[f64],
    stratification_factor: Option<f64>,
    adaptive: Option<(f64, u32)>,
    rounds: u32,
    w: usize,
) -> ErrorSummary {
    let target = adaptive.map(|(t, _)| t);
    let mut rel: Vec<f64> = ests
        .iter()
        .zip(stated.chunks(floor.len().max(1)))
        .map(|(e, se)| stated_rel_error(e, se, floor))
        .collect();
    // Pixels the cap stopped above the target, and the box holding them.
    let capped = adaptive.map(|(t, cap)| {
        let mut count = 0usize;
        let mut bbox = [usize::MAX, usize::MAX, 0, 0];
        for (i, (e, &r)) in ests.iter().zip(&rel).enumerate() {
            if e.n >= pixel_cap(e, cap) && r > t {
                count += 1;
                let (row, col) = (i / w.max(1), i % w.max(1));
                bbox = [
                    bbox[0].min(col),
                    bbox[1].min(row),
                    bbox[2].max(col),
                    bbox[3].max(row),
                ];
            }
        }
        (count, (count > 0).then_some(bbox))
    });
    let governed = |e: &PixelEstimate| e.lit() && !e.sees_emitter;
    let (sq, count) = ests
        .iter()
        .zip(&rel)
        .filter(|(e, _)| governed(e))
        .fold((0.0, 0usize), |(s, k), (_, r)| (s + r * r, k + 1));
    let nb = floor.len().max(1);
    let bounded = ests
        .iter()
        .enumerate()
        .filter(|(i, e)| !e.lit() && stated[i * nb..(i + 1) * nb].iter().any(|&v| v > 0.0))
        .count();
    rel.sort_by(f64::total_cmp);
    let q = |p: f64| {
        if rel.is_empty() {
            0.0
        } else {
            rel[((p * (rel.len() - 1) as f64).round() as usize).min(rel.len() - 1)]
        }
    };
    let n = rel.len().max(1) as f64;
    ErrorSummary {
        target,
        dark_floor_fraction_of_mean: DARK_FLOOR,
        rel_std_error_p50: q(0.5),
        rel_std_error_p90: q(0.9),
        rel_std_error_p99: q(0.99),
        rel_std_error_max: rel.last().copied().unwrap_or(0.0),
        rel_std_error_rms: (rel.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
        rel_std_error_rms_target_pixels: target.map(|_| (sq / count.max(1) as f64).sqrt()),
        target_pixels: target.map(|_| count),
        pixels_seeing_emitters: ests.iter().filter(|e| e.sees_emitter).count(),
        pixels_all_zero_bounded: bounded,
        fraction_meeting_target: target.map(|t| rel.iter().filter(|&&x| x <= t).count() as f64 / n),
        stratification_factor,
        pixels_stopped_at_max_spp: capped.map(|c| c.0),
        stopped_at_max_spp_box: capped.and_then(|c| c.1),
        mean_spp: ests.iter().map(|e| e.n as f64).sum::<f64>() / n,
        max_spp: ests.iter().map(|e| e.n).max().unwrap_or(0),
        rounds,
        bias: None,
        rel_error_rms_with_bias: None,
    }
}

impl Tracer {
    /// Spectral radiance of pixel `(col, row)` averaged over `spp` camera
    /// samples (without point sources seen directly): the first batch of
    /// [`Tracer::render`].
    fn pixel_spectral(&self, col: u32, row: u32, c: &mut RayCounts) -> Vec<f64> {
        let mut est = PixelEstimate::new(self.wl.len(), self.wl.band_names.len(), 0);
        self.pixel_batch(
            col,
            row,
            0,
            self.settings.spp.max(1) as usize,
            false,
            &mut est,
            c,
        );
        let inv = 1.0 / est.n.max(1) as f64;
        est.spectral.iter().map(|a| a * inv).collect()
    }

    /// Adds batch `batch` of `n` camera samples (Latin-hypercube stratified
    /// in the pixel) to the pixel's estimate. Each batch has its own random
    /// stream, so a pixel's result depends only on which batches it got.
    /// `replicated` (adaptive renders) splits the batch into two halves of
    /// `⌈n/2⌉` samples, replicates A and B, each with its own streams and
    /// Sobol scramble (see [`stratification`]).
    #[allow(clippy::too_many_arguments)]
    fn pixel_batch(
        &self,
        col: u32,
        row: u32,
        batch: u32,
        n: usize,
        replicated: bool,
        est: &mut PixelEstimate,
        c: &mut RayCounts,
    ) {
        if replicated {
            for r in 0..2 {
                self.pixel_samples(col, row, batch, n.div_ceil(2), Some(r), est, c);
            }
        } else {
            self.pixel_samples(col, row, batch, n, None, est, c);
        }
    }

    /// `n` samples of batch `batch` for one stream: the pixel's own
    /// (`replicate` None) or replicate A/B's.
    #[allow(clippy::too_many_arguments)]
    fn pixel_samples(
        &self,
        col: u32,
        row: u32,
        batch: u32,
        n: usize,
        replicate: Option<usize>,
        est: &mut PixelEstimate,
        c: &mut RayCounts,
    ) {
        let cam = &self.camera;
        let idx = row as u64 * cam.width as u64 + col as u64;
        let domain = match replicate {
            None if batch == 0 => DOMAIN_PIXEL,
            None => DOMAIN_BATCH ^ ((batch as u64) << 32),
            Some(r) => DOMAIN_REPLICATE ^ ((r as u64 + 1) << 8) ^ ((batch as u64) << 32),
        };
        let mut rng = stream(self.settings.seed, domain, idx);
        let mut sub = Vec::with_capacity(n);
        latin_hypercube(n, &mut rng, &mut sub);
        let mut acc = Light::dark(self.wl.len(), est.groups);
        // Final-gather directions: one Owen-scrambled Sobol sequence per
        // pixel (per replicate), continued across batches (the samples it
        // has so far), each sample taking the next block of `gather_rays`
        // points. (Only when there is a cache to gather from.)
        let k = if self.cache.is_some() {
            self.settings.gather_rays as usize
        } else {
            0
        };
        let salt = replicate.map_or(0, |r| (r as u64 + 1) << 40);
        let scramble =
            crate::tracer::mix64(self.settings.seed ^ crate::tracer::mix64(idx ^ 0x6A7E ^ salt));
        let mut pts: Vec<[f64; 2]> = Vec::with_capacity(k);
        // The camera vertex's light samples: their own scramble per pixel
        // (and replicate), the sample index continuing across batches.
        let strata = (self.settings.light_strata == LightStrataMode::Sobol)
            .then(|| crate::tracer::mix64(scramble ^ 0x005E_ED11_6475));
        for [sx, sy] in sub {
            acc.clear();
            pts.clear();
            let so_far = replicate.map_or(est.n, |r| est.rep_n[r]);
            let first = so_far as u64 * k as u64;
            pts.extend(
                (0..k as u64).map(|i| crate::sampling::sobol_owen_2d((first + i) as u32, scramble)),
            );
            let d = cam.pixel_direction(col as f64 + sx, row as f64 + sy);
            c.primary += 1;
            est.sees_emitter |= self.trace(
                cam.position,
                d,
                u32::MAX,
                &self.ones,
                PathState::camera(self.settings.diffuse_bounces, true),
                (k > 0).then_some(pts.as_slice()),
                strata.map(|scramble| LightStrata {
                    scramble,
                    sample: so_far,
                }),
                &mut rng,
                c,
                &mut acc,
            );
            est.add(&acc.whole, &self.wl.integrate(&acc.whole), replicate);
            for g in 0..est.groups {
                if let Some(part) = acc.part(g) {
                    est.add_layer(g, &self.wl.integrate(part));
                }
            }
        }
    }

    /// The pixels that show a point source directly (unoccluded, facing
    /// the camera, in the field of view): emitters for every mask of
    /// pixels "that see no emitter" (the pilot's share, `gloam bench`).
    pub fn point_source_pixels(&self) -> Vec<(u32, u32)> {
        let mut c = RayCounts::default();
        self.point_deposits(&mut c)
            .into_iter()
            .map(|(col, row, _, _)| (col, row))
            .collect()
    }

    /// Point sources seen directly: `(col, row, band radiances, light
    /// group)` for each unoccluded source in the field of view (see the
    /// crate docs).
    pub(crate) fn point_deposits(&self, c: &mut RayCounts) -> Vec<Deposit> {
        let cam = &self.camera;
        let (_, _, fwd) = cam.basis();
        let mut out = Vec::new();
        for l in &self.points {
            let Some((px, py)) = cam.project(l.pos) else {
                continue;
            };
            if !(px >= 0.0 && py >= 0.0 && px < cam.width as f64 && py < cam.height as f64) {
                continue;
            }
            let v = cam.position - l.pos;
            let r = v.length();
            if r <= 0.0 {
                continue;
            }
            let w = v / r;
            let shape = l.shape_toward(w);
            if shape == 0.0 {
                continue;
            }
            // Towards the lamp from the camera.
            let vis = self.shadow(cam.position, -w, r, [u32::MAX, u32::MAX], c);
            let Some(tau) = vis else { continue };
            // The exact solid angle of that pixel: its corners on the
            // unit-distance image plane.
            let (c0, r0) = (px.floor(), py.floor());
            let corner = |x: f64, y: f64| {
                let d = cam.pixel_direction(x, y);
                cam.position + d / d.dot(fwd)
            };
            let quad = [
                corner(c0, r0),
                corner(c0 + 1.0, r0),
                corner(c0 + 1.0, r0 + 1.0),
                corner(c0, r0 + 1.0),
            ];
            let omega = crate::closed_form::polygon_solid_angle(cam.position, &quad);
            if omega.is_nan() || omega <= 0.0 {
                continue;
            }
            let r_m = r * self.mpu;
            let g = shape / (r_m * r_m * omega);
            let spec: Vec<f64> = match tau {
                None => l.intensity.iter().map(|i| g * i).collect(),
                Some(t) => l.intensity.iter().zip(&t).map(|(i, t)| g * i * t).collect(),
            };
            out.push((px as u32, py as u32, self.wl.integrate(&spec), l.group));
        }
        out
    }

    /// Renders the whole image. `progress(done, total)` is called as tiles
    /// finish (from worker threads); with `target_error`, further rounds
    /// report on the pixels still sampling.
    ///
    /// Every pixel first gets one batch of `spp` samples. With
    /// `target_error = E`, pixels whose estimated relative standard error
    /// (see [`ErrorSummary`]) exceeds `E` get further batches, sized from
    /// the error so far (at most 4× their count per round, at least
    /// [`MIN_ADAPTIVE_SPP`] in all, at most `max_spp`), until every pixel
    /// meets `E` or its cap. Batches have their own random streams, so the
    /// image is bit-identical at any thread count.
    pub fn render(&self, progress: &(dyn Fn(u64, u64) + Sync)) -> Result<RenderOutput, TraceError> {
        self.render_rows(0..self.camera.height, progress)
    }

    /// The image size `(width, height)` in pixels (after `resolution_scale`).
    pub fn image_size(&self) -> (u32, u32) {
        (self.camera.width, self.camera.height)
    }

    /// Renders only image rows `rows` (all columns): the output arrays hold
    /// those rows, and every pixel is bit-identical to the same pixel of
    /// [`Tracer::render`], because each pixel's random streams are keyed by
    /// its index in the whole image. So separately rendered row bands
    /// reassemble into the untiled image exactly. Adaptive sampling
    /// (`target_error`) scales its dark-pixel floor by the image mean, which
    /// a band does not know, so it is refused for a partial image.
    pub fn render_rows(
        &self,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<RenderOutput, TraceError> {
        self.render_rows_until(rows, progress, &|| false)
    }

    /// [`Tracer::render_rows`] that a caller can stop: `stop()` is polled
    /// before every tile and every adaptive round (from worker threads);
    /// once it returns true the remaining work is skipped and the render
    /// returns [`TraceError::Interrupted`] (so a host such as the Python
    /// package can honour Ctrl-C within one tile's time). A render that
    /// is not stopped is bit-identical to [`Tracer::render_rows`].
    pub fn render_rows_until(
        &self,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<RenderOutput, TraceError> {
        Ok(self.render_split(rows, progress, stop, 0)?.0)
    }

    /// [`Tracer::render_rows_until`], and with `groups` > 0 (`--layers`,
    /// the emitters' groups assigned) one output per light group from the
    /// same samples: each pixel's samples split by the group of the
    /// emitter each term came from (`light.rs`). The whole is bit-identical
    /// to an unsplit render; the sample counts (adaptive or not) are the
    /// whole's. A layer's standard error is its per-sample one (times the
    /// whole's measured stratification factor, adaptive renders); its spp,
    /// error summary and statistics are the whole's.
    pub(crate) fn render_split(
        &self,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
        groups: usize,
    ) -> Result<(RenderOutput, Vec<RenderOutput>), TraceError> {
        let stopped = std::sync::atomic::AtomicBool::new(false);
        let halt = || {
            if stopped.load(Ordering::Relaxed) || stop() {
                stopped.store(true, Ordering::Relaxed);
                return true;
            }
            false
        };
        let cam = &self.camera;
        let (w, full_h) = (cam.width, cam.height);
        if rows.start >= rows.end || rows.end > full_h {
            return Err(TraceError::BadInput(format!(
                "rows {}..{} are not a non-empty part of the image's 0..{full_h}",
                rows.start, rows.end
            )));
        }
        let partial = rows.start != 0 || rows.end != full_h;
        if partial && self.settings.target_error.is_some() {
            return Err(TraceError::BadInput(
                "target_error needs the whole image (its dark-pixel floor is relative to the image mean); render a tile at a fixed spp".into(),
            ));
        }
        let row0 = rows.start;
        let h = rows.end - rows.start;
        let nb = self.wl.band_names.len();
        let nwl = self.wl.len();
        let npix = w as usize * h as usize;
        let t0 = Instant::now();
        let threads = self.settings.threads;
        let spp = self.settings.spp.max(1);
        // Adaptive renders sample in two replicates, so their error
        // estimate is measured rather than assumed (see `stratification`).
        let replicated = self.settings.target_error.is_some();
        let done = AtomicU64::new(0);
        let (ests, views, rays, rounds, threads_used) = with_pool(threads, || {
            // Round 0: every pixel, one batch of spp, tile by tile.
            let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE))
                .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, row0 + ty * TILE)))
                .collect();
            let total = tiles.len() as u64;
            type Pixel = (usize, PixelEstimate, Option<ViewTerm>);
            let res: Vec<(Vec<Pixel>, RayCounts)> = tiles
                .par_iter()
                .map(|&(x0, y0)| {
                    if halt() {
                        return (Vec::new(), RayCounts::default());
                    }
                    let x1 = (x0 + TILE).min(w);
                    let y1 = (y0 + TILE).min(rows.end);
                    let mut c = RayCounts::default();
                    let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                    for row in y0..y1 {
                        if row > y0 && halt() {
                            break;
                        }
                        for col in x0..x1 {
                            let mut e = PixelEstimate::new(nwl, nb, groups);
                            // Emitters seen directly: computed apart, and
                            // whether the pixel sees one decided by them,
                            // not by its samples (`direct_view.rs`).
                            let view = self.view_term(col, row, &mut c);
                            e.sees_emitter = view
                                .as_ref()
                                .is_some_and(|v| v.bands.iter().any(|&x| x > 0.0));
                            self.pixel_batch(col, row, 0, spp as usize, replicated, &mut e, &mut c);
                            out.push(((row - row0) as usize * w as usize + col as usize, e, view));
                        }
                    }
                    let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(n, total);
                    (out, c)
                })
                .collect();
            let mut rays = RayCounts::default();
            let mut ests: Vec<Option<PixelEstimate>> = vec![None; npix];
            let mut views: Vec<Option<ViewTerm>> = (0..npix).map(|_| None).collect();
            for (tile, c) in res {
                rays.add(&c);
                for (i, e, v) in tile {
                    ests[i] = Some(e);
                    views[i] = v;
                }
            }
            let mut ests: Vec<PixelEstimate> = ests
                .into_iter()
                .map(|e| e.unwrap_or_else(|| PixelEstimate::new(nwl, nb, groups)))
                .collect();
            let mut rounds = 1u32;
            if let Some(target) = self.settings.target_error {
                let floor = band_floor(&ests, &views, nb);
                let cap = self.settings.max_spp.max(spp);
                loop {
                    if halt() {
                        break;
                    }
                    let (factor, _) = stratification(&ests, &floor);
                    let stated = stated_std_errors(&ests, w as usize, &factor, &floor, true);
                    let rel: Vec<f64> = ests
                        .par_iter()
                        .enumerate()
                        .map(|(i, e)| stated_rel_error(e, &stated[i * nb..(i + 1) * nb], &floor))
                        .collect();
                    let work = allocate(&ests, &rel, target, cap);
                    if work.is_empty() {
                        break;
                    }
                    let total = work.len() as u64;
                    let done = AtomicU64::new(0);
                    let batch = rounds;
                    let updated: Vec<(usize, PixelEstimate, RayCounts)> = work
                        .par_iter()
                        .map(|&(i, add)| {
                            let mut c = RayCounts::default();
                            let mut e = ests[i].clone();
                            let (col, row) =
                                ((i % w as usize) as u32, row0 + (i / w as usize) as u32);
                            self.pixel_batch(col, row, batch, add as usize, true, &mut e, &mut c);
                            let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                            if n % 1024 == 0 || n == total {
                                progress(n, total);
                            }
                            (i, e, c)
                        })
                        .collect();
                    for (i, e, c) in updated {
                        ests[i] = e;
                        rays.add(&c);
                    }
                    rounds += 1;
                    if rounds > 64 {
                        break;
                    }
                }
            }
            (ests, views, rays, rounds, rayon::current_num_threads())
        });
        if stopped.load(Ordering::Relaxed) {
            return Err(TraceError::Interrupted);
        }
        let mut rays = rays;
        let mut radiance = Array3::<f64>::zeros((nb, h as usize, w as usize));
        let mut std_error = Array3::<f64>::zeros((nb, h as usize, w as usize));
        let mut spp_map = ndarray::Array2::<u32>::zeros((h as usize, w as usize));
        let floor = band_floor(&ests, &views, nb);
        let (factor, pooled) = if replicated {
            let (f, g) = stratification(&ests, &floor);
            (f, Some(g))
        } else {
            (vec![1.0; ests.len()], None)
        };
        let stated = stated_std_errors(&ests, w as usize, &factor, &floor, replicated);
        for (i, e) in ests.iter().enumerate() {
            let (row, col) = (i / w as usize, i % w as usize);
            let inv = 1.0 / e.n.max(1) as f64;
            let mean: Vec<f64> = e.spectral.iter().map(|a| a * inv).collect();
            let view = views[i].as_ref();
            for (b, v) in self.wl.integrate(&mean).into_iter().enumerate() {
                let (add, se) = view.map_or((0.0, 0.0), |t| (t.bands[b], t.std_error[b]));
                radiance[[b, row, col]] = v + add;
                std_error[[b, row, col]] = stated[i * nb + b].hypot(se);
            }
            spp_map[[row, col]] = e.n;
        }
        let adaptive = self
            .settings
            .target_error
            .map(|t| (t, self.settings.max_spp.max(spp)));
        let mut error = error_summary(&ests, &floor, &stated, pooled, adaptive, rounds, w as usize);
        if !partial && !halt() {
            let skip: Vec<bool> = ests.iter().map(|e| e.sees_emitter).collect();
            let by_band: Vec<Vec<f64>> = (0..nb)
                .map(|b| {
                    radiance
                        .index_axis(ndarray::Axis(0), b)
                        .iter()
                        .copied()
                        .collect()
                })
                .collect();
            error.bias = with_pool(threads, || self.cache_bias(&by_band, &skip));
            let noise = error
                .rel_std_error_rms_target_pixels
                .unwrap_or(error.rel_std_error_rms);
            error.rel_error_rms_with_bias = error
                .bias
                .as_ref()
                .map(|b| noise.hypot(b.relative_bias_bound));
        }
        let mut c = RayCounts::default();
        let deposits = if self.settings.drop.direct_view {
            Vec::new()
        } else {
            self.point_deposits(&mut c)
        };
        let deposit = |radiance: &mut Array3<f64>, group: Option<Option<usize>>| {
            for (col, row, vals, g) in &deposits {
                if !rows.contains(row) || group.is_some_and(|want| want != *g) {
                    continue;
                }
                for (b, v) in vals.iter().enumerate() {
                    radiance[[b, (row - row0) as usize, *col as usize]] += v;
                }
            }
        };
        deposit(&mut radiance, None);
        let layers: Vec<(Array3<f64>, Array3<f64>)> = (0..groups)
            .map(|g| {
                let mut radiance = Array3::<f64>::zeros((nb, h as usize, w as usize));
                let mut std_error = Array3::<f64>::zeros((nb, h as usize, w as usize));
                for (i, e) in ests.iter().enumerate() {
                    let (row, col) = (i / w as usize, i % w as usize);
                    let view = views[i]
                        .as_ref()
                        .and_then(|t| t.light.part(g))
                        .map(|part| self.wl.integrate(part));
                    for b in 0..nb {
                        let (m, se) = e.layer(g, b);
                        let add = view.as_ref().map_or(0.0, |v| v[b]);
                        radiance[[b, row, col]] = m + add;
                        std_error[[b, row, col]] = se * factor[i];
                    }
                }
                deposit(&mut radiance, Some(Some(g)));
                (radiance, std_error)
            })
            .collect();
        rays.add(&c);
        let trace_seconds = t0.elapsed().as_secs_f64();
        let lines = self.wl.len() - self.wl.n_continuum;
        let whole = RenderOutput {
            radiance,
            std_error,
            spp: spp_map,
            error,
            band_names: self.wl.band_names.clone(),
            settings: self.settings.clone(),
            stats: RenderStats {
                width: w,
                height: h,
                bands: nb,
                wavelengths: self.wl.len(),
                emission_lines: lines,
                triangles: self.geom.triangle_count(),
                area_sources: self.area.len(),
                point_sources: self.points.len(),
                threads: threads_used,
                prepare_seconds: self.build_seconds,
                preparation: self.preparation.clone(),
                trace_seconds,
                rays,
                rays_per_second: rays.total() as f64 / trace_seconds.max(1e-9),
                sky: self.sky_summary().cloned(),
                interreflection: self.interreflection.clone(),
            },
        };
        let layers = layers
            .into_iter()
            .map(|(radiance, std_error)| RenderOutput {
                radiance,
                std_error,
                spp: whole.spp.clone(),
                error: whole.error.clone(),
                band_names: whole.band_names.clone(),
                settings: whole.settings.clone(),
                stats: whole.stats.clone(),
            })
            .collect();
        Ok((whole, layers))
    }

    /// Band radiances of one pixel, bit-identical to the same pixel of
    /// [`Tracer::render`] (same random stream, point sources included).
    pub fn probe_pixel(&self, col: u32, row: u32) -> Result<Vec<f64>, TraceError> {
        let cam = &self.camera;
        if col >= cam.width || row >= cam.height {
            return Err(TraceError::PixelOutside(col, row, cam.width, cam.height));
        }
        let mut c = RayCounts::default();
        let mut v = self.wl.integrate(&self.pixel_spectral(col, row, &mut c));
        if let Some(t) = self.view_term(col, row, &mut c) {
            v.iter_mut().zip(&t.bands).for_each(|(a, b)| *a += b);
        }
        for (x, y, vals, _) in self.point_deposits(&mut c) {
            if (x, y) == (col, row) {
                v.iter_mut().zip(&vals).for_each(|(a, b)| *a += b);
            }
        }
        Ok(v)
    }

    /// Irradiance at world-space `point` on a receiver with `normal`, in
    /// `band` (the first band for `None`): the mean of `samples`
    /// independent estimates (each with `area_samples` shadow rays per area
    /// source) and its standard error. When the point lies on a facet, also
    /// the radiance that facet's Lambertian part reflects, `ρ_d E / π`.
    pub fn probe_point(
        &self,
        point: DVec3,
        normal: DVec3,
        band: Option<&str>,
        samples: u32,
    ) -> Result<ProbeResult, TraceError> {
        let b = self.band_index(band)?;
        let n = normal
            .try_normalize()
            .ok_or_else(|| TraceError::BadInput("the normal must be a non-zero vector".into()))?;
        if !point.is_finite() {
            return Err(TraceError::BadInput("the point must be finite".into()));
        }
        // The scene's own coordinate limit: beyond it the centred offset
        // loses every digit and the answer would be a silent 0 ± 0.
        let lim = gloam_scene::MAX_COORDINATE;
        if point.abs().max_element() > lim {
            return Err(TraceError::BadInput(format!(
                "the point {},{},{} is out of range (|x| ≤ {lim:e} scene units, as scene coordinates)",
                point.x, point.y, point.z
            )));
        }
        let p = point - self.geom.origin;
        let facet = self.facet_at(p);
        let ignore = facet.unwrap_or(u32::MAX);
        let k = samples.max(1);
        let mut es = Vec::with_capacity(k as usize);
        let mut ls = Vec::with_capacity(k as usize);
        let (mut direct_sum, mut indirect_sum) = (0.0, 0.0);
        let mut c = RayCounts::default();
        let indirect = self.probe_indirect_method();
        for i in 0..k {
            let mut rng = stream(self.settings.seed, DOMAIN_PROBE, i as u64);
            let mut e = Light::dark(self.wl.len(), 0);
            self.irradiance(p, n, ignore, &mut rng, &mut c, &mut e);
            let mut e = e.into_whole();
            direct_sum += self.wl.integrate(&e)[b];
            if indirect.is_some() {
                let mut ei = Light::dark(self.wl.len(), 0);
                self.probe_indirect(p, n, ignore, &mut rng, &mut c, &mut ei);
                let ei = ei.into_whole();
                indirect_sum += self.wl.integrate(&ei)[b];
                e.iter_mut().zip(&ei).for_each(|(a, b)| *a += b);
            }
            es.push(self.wl.integrate(&e)[b]);
            if let Some(f) = facet {
                let l: Vec<f64> = e
                    .iter()
                    .zip(self.kd(f))
                    .map(|(e, k)| e * k * std::f64::consts::FRAC_1_PI)
                    .collect();
                ls.push(self.wl.integrate(&l)[b]);
            }
        }
        let mean = es.iter().sum::<f64>() / k as f64;
        let se = if k > 1 {
            let var = es.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
            (var / k as f64).sqrt()
        } else {
            0.0
        };
        Ok(ProbeResult {
            band: self.wl.band_names[b].clone(),
            irradiance_w_m2: mean,
            std_error_w_m2: se,
            radiance_w_m2_sr: facet.map(|_| ls.iter().sum::<f64>() / k as f64),
            direct_irradiance_w_m2: direct_sum / k as f64,
            indirect_irradiance_w_m2: indirect.map(|_| indirect_sum / k as f64),
            terms: match indirect {
                Some(m) => format!("direct light and interreflection ({m}), as a render"),
                None => format!(
                    "direct light only, as a render ({})",
                    self.interreflection.reason
                ),
            },
        })
    }

    /// How a probe adds interreflection: as the render would (the plan's
    /// decision), or `None` when the render has none.
    fn probe_indirect_method(&self) -> Option<&'static str> {
        if self.cache.is_some() {
            Some("radiosity cache, final gather")
        } else if self.settings.diffuse_bounces > 0 {
            Some("path tracing")
        } else {
            None
        }
    }

    /// Interreflected irradiance at `p` (normal `n`), added to `out`: a
    /// final gather from the cache, or cosine-weighted diffuse paths
    /// (`E = π/K Σ L(ω_j)`), with [`PROBE_GATHER_RAYS`] directions.
    fn probe_indirect(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        rng: &mut rand_pcg::Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let k = (self.settings.gather_rays as usize).max(PROBE_GATHER_RAYS);
        if let Some(cache) = &self.cache {
            self.final_gather(cache, p, n, ignore, k, None, &self.ones, rng, c, out);
            return;
        }
        let mut u = Vec::with_capacity(k);
        latin_hypercube(k, rng, &mut u);
        let (tx, ty) = crate::sky_light::orthonormal_basis(n);
        let thr = vec![std::f64::consts::PI / k as f64; out.len()];
        for uv in u {
            let l = crate::sky_light::cosine_hemisphere(uv);
            let d = (tx * l.x + ty * l.y + n * l.z).normalize_or_zero();
            let state = PathState {
                diffuse: 1,
                after_diffuse: true,
                ..PathState::camera(self.settings.diffuse_bounces, false)
            };
            self.trace(p, d, ignore, &thr, state, None, None, rng, c, out);
        }
    }

    /// The camera ray through continuous pixel coordinates `(px, py)`:
    /// origin and unit direction in the tracer's centred frame (see
    /// [`crate::geometry`]), ready for `self.geom`.
    pub fn camera_ray(&self, px: f64, py: f64) -> (DVec3, DVec3) {
        (self.camera.position, self.camera.pixel_direction(px, py))
    }

    /// Centroids of the emitting facets, in the centred frame.
    pub fn emitter_centroids(&self) -> Vec<DVec3> {
        self.area_centroids()
    }

    /// Continuous pixel coordinates of a world-space point (None behind the camera).
    pub fn project(&self, point: DVec3) -> Option<(f64, f64)> {
        self.camera.project(point - self.geom.origin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// `m` jittered (stratified) samples of f(u) = u into replicate `r`.
    fn stratified(e: &mut PixelEstimate, m: usize, r: usize, rng: &mut rand_pcg::Pcg64Mcg) {
        for k in 0..m {
            let u = (k as f64 + rng.random::<f64>()) / m as f64;
            e.add(&[u], &[u], Some(r));
        }
    }

    /// Stratified samples of f(u) = u: each of two replicates of `m`
    /// jittered samples has var(mean) = 1/(12 m³), so the pixel's mean (n =
    /// 2m) has v = 1/(24 m³), while the per-sample estimate expects
    /// s²/n with E[s²] = n/(n−1) · (1/12 − v) for these samples. The
    /// replicates must measure the ratio sqrt(v / (E[s²]/n)) (≈ 1/m).
    #[test]
    fn replicates_measure_the_stratification_gain() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
        for m in [4usize, 8, 16] {
            let ests: Vec<PixelEstimate> = (0..4096)
                .map(|_| {
                    let mut e = PixelEstimate::new(1, 1, 0);
                    stratified(&mut e, m, 0, &mut rng);
                    stratified(&mut e, m, 1, &mut rng);
                    e
                })
                .collect();
            let (factor, global) = stratification(&ests, &[0.0]);
            let (n, v) = (2.0 * m as f64, 1.0 / (24.0 * (m as f64).powi(3)));
            let want = (v / (n / (n - 1.0) * (1.0 / 12.0 - v) / n)).sqrt();
            assert!(
                (global / want - 1.0).abs() < 0.06,
                "m {m}: {global} vs {want}"
            );
            assert!(factor.iter().all(|f| (f / want - 1.0).abs() < 0.2));
        }
    }

    /// Pixels grown to many samples get the ratio measured on pixels of
    /// their own sample count, not the ratio of the many pixels with few
    /// (4 096 pixels of 2 × 4 jittered samples of f(u) = u beside 64 of
    /// 2 × 64: the closed form of the test above gives ratios ≈ 1/4 and
    /// ≈ 1/64; pooled together the 64-sample pixels stated ~10× their
    /// error).
    #[test]
    fn pixels_of_many_samples_get_their_own_ratio() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        let want = |m: usize| {
            let (n, v) = (2.0 * m as f64, 1.0 / (24.0 * (m as f64).powi(3)));
            (v / (n / (n - 1.0) * (1.0 / 12.0 - v) / n)).sqrt()
        };
        let ests: Vec<PixelEstimate> = (0..4096 + 64)
            .map(|i| {
                let m = if i < 4096 { 4 } else { 64 };
                let mut e = PixelEstimate::new(1, 1, 0);
                stratified(&mut e, m, 0, &mut rng);
                stratified(&mut e, m, 1, &mut rng);
                e
            })
            .collect();
        let (factor, _) = stratification(&ests, &[0.0]);
        for (i, f) in factor.iter().enumerate() {
            let w = want(if i < 4096 { 4 } else { 64 });
            assert!((f / w - 1.0).abs() < 0.35, "pixel {i}: {f} vs {w}");
        }
    }

    /// A pixel whose samples were all zero states the error one sample of
    /// its brightest neighbour's size would make (mean / n), not zero; one
    /// with no lit neighbour within the window states zero.
    #[test]
    fn all_zero_pixels_state_an_upper_bound() {
        let w = 8;
        let mut ests: Vec<PixelEstimate> =
            (0..w * w).map(|_| PixelEstimate::new(1, 1, 0)).collect();
        for e in ests.iter_mut() {
            for _ in 0..16 {
                e.add(&[0.0], &[0.0], None);
            }
        }
        // Pixel (row 0, col 0) is lit: mean 2.0 (half its samples 4.0).
        let mut lit = PixelEstimate::new(1, 1, 0);
        for k in 0..16 {
            let v = if k % 2 == 0 { 4.0 } else { 0.0 };
            lit.add(&[v], &[v], None);
        }
        ests[0] = lit;
        let se = stated_std_errors(&ests, w, &vec![1.0; w * w], &[0.0], true);
        // Within DARK_NEIGHBOURHOOD (2) of (0, 0): 2.0 / 16.
        assert_eq!(se[2 * w + 2], 2.0 / 16.0);
        assert_eq!(se[1], 2.0 / 16.0);
        // Outside it: provably nothing to scale by.
        assert_eq!(se[3 * w + 3], 0.0);
        assert_eq!(se[7], 0.0);
        // The lit pixel keeps its per-sample standard error: sd 2·sqrt(16/15), /4.
        assert!((se[0] - 2.0 * (16.0f64 / 15.0).sqrt() / 4.0).abs() < 1e-12);
    }

    /// `n` samples alternating between `lo` and `hi` (mean (lo+hi)/2,
    /// per-sample sd |hi−lo|/2·√(n/(n−1))).
    fn two_level(n: u32, lo: f64, hi: f64) -> PixelEstimate {
        let mut e = PixelEstimate::new(1, 1, 0);
        for k in 0..n {
            let v = if k % 2 == 0 { hi } else { lo };
            e.add(&[v], &[v], None);
        }
        e
    }

    /// The Lagrange multiplier comes from the lit pixels that see no
    /// emitter: with them at the target, an all-zero pixel whose bound is
    /// far above it grows on its own (4×) and nothing else gets samples;
    /// an emitter pixel never does. The lit pixels' counts follow
    /// n_i = s_i Σs_j / (N E²) when they are above it.
    #[test]
    fn allocation_leaves_dark_and_emitter_pixels_out_of_the_multiplier() {
        // Lit pixels: 16 samples of 0.9/1.1, relative error 0.1/√15·√… —
        // use their stated rel directly.
        let mut ests: Vec<PixelEstimate> = (0..8).map(|_| two_level(16, 0.9, 1.1)).collect();
        ests.push(two_level(16, 0.0, 0.0)); // all zero
        let mut em = two_level(4, 0.0, 1000.0);
        em.sees_emitter = true;
        ests.push(em);
        let rel_lit = ests[0].std_error(0) / ests[0].mean(0);
        // The dark pixel's bound: 5× the target; the emitter pixel's: huge.
        let target = rel_lit;
        let mut rel = vec![rel_lit; 8];
        rel.push(5.0 * target);
        rel.push(10.0);
        let work = allocate(&ests, &rel, target, 1024);
        assert_eq!(work, vec![(8, 48)]); // 16 → 64 = DARK_MAX_SPP
        // Lit pixels at twice the target: each wants λ s_i with
        // λ = Σ s / (N E²), i.e. 4× its samples (capped at 4× per round).
        let rel2: Vec<f64> = rel
            .iter()
            .take(8)
            .map(|r| 2.0 * r)
            .chain([0.0, 10.0])
            .collect();
        let work = allocate(&ests, &rel2, target, 1024);
        let want = (4.0f64 * 16.0 * 1.05).ceil().min(64.0) as u32 - 16;
        assert_eq!(work.len(), 8);
        assert!(
            work.iter().all(|&(i, add)| i < 8 && add == want),
            "{work:?}"
        );
    }

    /// A pixel with fewer than TRUSTED_SPP samples that all agree (a
    /// penumbra pixel whose few shadow rays fell on one side) states the
    /// RMS per-sample deviation of its 3 × 3 neighbourhood, not ~0; with
    /// TRUSTED_SPP samples it states its own.
    #[test]
    fn few_agreeing_samples_borrow_the_neighbourhoods_deviation() {
        let w = 3;
        let mut ests: Vec<PixelEstimate> = (0..9).map(|_| two_level(4, 0.0, 2.0)).collect();
        ests[4] = two_level(4, 1.0, 1.0);
        let se = stated_std_errors(&ests, w, &[1.0; 9], &[0.0], true);
        // Neighbours: mean 1, per-sample sd √(4/3); RMS over the 9 pixels
        // (the centre's own is 0) = √(8/9 · 4/3); stated = that / √4.
        let want = (8.0 / 9.0 * 4.0 / 3.0f64).sqrt() / 2.0;
        assert!((se[4] - want).abs() < 1e-12, "{} vs {want}", se[4]);
        ests[4] = two_level(TRUSTED_SPP, 1.0, 1.0);
        let se = stated_std_errors(&ests, w, &[1.0; 9], &[0.0], true);
        assert_eq!(se[4], 0.0);
    }
}
