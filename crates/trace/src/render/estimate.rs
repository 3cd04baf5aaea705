//! A pixel's estimate and the errors a render states: per-sample
//! variance, the pooled stratification correction, the dark floor, and
//! the adaptive allocation of samples.

use super::*;

/// A pixel's running estimate: spectral sum, per band the sum and sum of
/// squares of the per-sample values, and per band the sums of two
/// independently randomised replicates (adaptive renders only).
#[derive(Clone, Debug)]
pub(super) struct PixelEstimate {
    pub(super) n: u32,
    pub(super) spectral: Vec<f64>,
    pub(super) band_sum: Vec<f64>,
    pub(super) band_sq: Vec<f64>,
    /// Samples and band sums of replicates A and B (adaptive renders: each
    /// replicate has its own random stream and its own Owen scramble, so
    /// the difference of their means measures the error of a stratified
    /// estimate without the per-sample variance's bias).
    pub(super) rep_n: [u32; 2],
    pub(super) rep_sum: [Vec<f64>; 2],
    /// Per band, whether any sample was non-zero (a pixel whose samples
    /// are all zero has no per-sample variance to state an error from).
    pub(super) band_lit: Vec<bool>,
    /// Whether the pixel shows an emitter's face: its direct-view term
    /// (`direct_view.rs`, decided before any sample) is lit, or a camera
    /// sample met a face left to the samples. The error target leaves such
    /// a pixel out, as the accuracy metric does.
    pub(super) sees_emitter: bool,
    /// Light groups (`--layers`; 0 without), and per group and band the
    /// sum and sum of squares of the samples' parts (`[g * nb + b]`): the
    /// same samples as the whole, split by the emitter the light came
    /// from.
    pub(super) groups: usize,
    pub(super) layer_sum: Vec<f64>,
    pub(super) layer_sq: Vec<f64>,
}

/// Bytes a render holds per pixel at its peak, for `nwl` wavelength
/// slots, `nb` bands and `groups` light groups (0 without `--layers`):
/// the pixel's [`PixelEstimate`] (its spectrum, band and replicate sums,
/// layer sums — held twice inline while the tiles are gathered), its
/// direct-view term, and the per-band images, error maps and the adaptive
/// rounds' per-pixel errors. Measured (one band, `gloam render` peak RSS
/// less the 48 MB before the render): 1 160 bytes at 61 slots and
/// 3 230 at 301, where this gives 1 248 and 3 184; it was counted as 32
/// bytes per band, and an 8192² render reached 10.6 GB and aborted.
pub(crate) fn render_bytes_per_pixel(nwl: usize, nb: usize, groups: usize) -> u64 {
    let inline = 2 * std::mem::size_of::<PixelEstimate>()
        + std::mem::size_of::<Option<crate::direct_view::ViewTerm>>();
    use gloam_scene::heap_chunk;
    let heap = (heap_chunk(8 * nwl)
        + 4 * heap_chunk(8 * nb)
        + heap_chunk(nb)
        + 2 * heap_chunk(8 * groups * nb)) as u64;
    // Images: radiance and error (f64, then f32 to write), the stated
    // errors and relative errors of the adaptive rounds.
    let images = 64 * nb as u64;
    inline as u64 + heap + images
}

impl PixelEstimate {
    pub(super) fn new(nwl: usize, nb: usize, groups: usize) -> Self {
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
    pub(super) fn add_layer(&mut self, g: usize, bands: &[f64]) {
        let nb = bands.len();
        for (b, v) in bands.iter().enumerate() {
            self.layer_sum[g * nb + b] += v;
            self.layer_sq[g * nb + b] += v * v;
        }
    }

    /// Group `g`'s band `b`: the mean of its parts and their standard error
    /// from the per-sample variance (as [`PixelEstimate::std_error`]).
    pub(super) fn layer(&self, g: usize, b: usize) -> (f64, f64) {
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

    pub(super) fn add(&mut self, spectral: &[f64], bands: &[f64], replicate: Option<usize>) {
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
    pub(super) fn lit(&self) -> bool {
        self.band_lit.iter().any(|&l| l)
    }

    pub(super) fn mean(&self, b: usize) -> f64 {
        self.band_sum[b] / self.n.max(1) as f64
    }

    /// Standard error of the band mean from the per-sample variance (the
    /// samples of a batch are stratified, so this errs on the high side;
    /// adaptive renders scale it by the measured [`stratification`]).
    pub(super) fn std_error(&self, b: usize) -> f64 {
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
    pub(super) fn replicate_terms(&self, floor: &[f64]) -> Option<(f64, f64)> {
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
pub(super) fn stratification(ests: &[PixelEstimate], floor: &[f64]) -> (Vec<f64>, f64) {
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
pub(super) fn stated_std_errors(
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
pub(super) fn window(i: usize, w: usize, h: usize, radius: usize) -> impl Iterator<Item = usize> {
    let (r, c) = (i / w.max(1), i % w.max(1));
    (r.saturating_sub(radius)..(r + radius + 1).min(h)).flat_map(move |rr| {
        (c.saturating_sub(radius)..(c + radius + 1).min(w)).map(move |cc| rr * w + cc)
    })
}

/// Largest relative stated error over bands, each relative to
/// `max(|mean|, floor_b)`.
pub(super) fn stated_rel_error(e: &PixelEstimate, se: &[f64], floor: &[f64]) -> f64 {
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
///
/// `decay`: how a pixel's variance falls with its samples, `n^-decay`
/// ([`variance_decay`]), for the prediction that sets the multiplier.
pub(super) fn allocate(
    ests: &[PixelEstimate],
    rel: &[f64],
    target: f64,
    cap: u32,
    decay: f64,
) -> Vec<(usize, u32)> {
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
            decay,
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
            let add = even_add(e.n, goal as u32, cap);
            (add > 0).then_some((i, add))
        })
        .collect()
}

/// Samples to add to a pixel of `n` to reach `goal` (≤ `cap`): replicated
/// batches add an even count (half to each replicate), never past `cap`.
pub(super) fn even_add(n: u32, goal: u32, cap: u32) -> u32 {
    let add = goal.saturating_sub(n).div_ceil(2) * 2;
    if n + add > cap {
        add.saturating_sub(2)
    } else {
        add
    }
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
pub(super) fn aggregate_lambda(
    ests: &[PixelEstimate],
    dev: &[f64],
    target: f64,
    npix: f64,
    free: impl Fn(&PixelEstimate) -> bool,
    cap_of: impl Fn(&PixelEstimate) -> u32,
    min: u32,
    free_dev: f64,
    decay: f64,
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
                d * d / n * (n / grown).powf(decay)
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

/// How a pixel estimate's variance falls with its sample count `n`, as
/// `n^-decay`: 1 for positions drawn independently of each other (a Latin
/// hypercube per batch: within a batch they are stratified, across
/// batches not); 1.5 for one Owen-scrambled (0,2)-sequence continued
/// across the rounds, the rate of a scrambled net on an integrand with
/// discontinuities along curves — a pixel crossed by an edge or a
/// penumbra (Owen 1997). Predicted with 1, a Sobol render of the panel's
/// smooth floor stopped at 0.69× the target asked (0.004); with 1.5 at
/// 0.92×, office direct light at 1 % unchanged (8.57 spp).
pub(super) fn variance_decay(strata: crate::settings::PixelStrata) -> f64 {
    match strata {
        crate::settings::PixelStrata::Latin => 1.0,
        crate::settings::PixelStrata::Sobol => 1.5,
    }
}

/// A pixel whose samples have all been zero stops at this many (or
/// `max_spp` if lower): its stated error is then the neighbourhood bound
/// of [`stated_std_errors`], which falls only as 1/n — sampling an umbra to
/// `max_spp` would double a direct-light render for pixels that are, as
/// far as 64 samples tell, dark. The report counts them.
pub const DARK_MAX_SPP: u32 = 64;

/// The sample cap of pixel `e`: `max_spp`, or [`DARK_MAX_SPP`] while every
/// sample has been zero.
pub(super) fn pixel_cap(e: &PixelEstimate, cap: u32) -> u32 {
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

/// [`DARK_FLOOR`] × each band's image mean, the emitters seen directly
/// (computed apart, `views`) included as in the image.
pub(super) fn band_floor(
    ests: &[PixelEstimate],
    views: &[Option<ViewTerm>],
    nb: usize,
) -> Vec<f64> {
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

pub(super) fn error_summary(
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

#[cfg(test)]
mod bytes_tests {
    /// The estimate against the peak RSS `gloam render` measured for the
    /// 2-facet base scene at 1024² (one band, less the 48 MB before the
    /// render): 1 160 bytes a pixel at 61 slots, 3 230 at 301.
    #[test]
    fn render_bytes_per_pixel_matches_the_measured_peak() {
        for (nwl, measured) in [(61, 1160.0), (301, 3230.0)] {
            let est = super::render_bytes_per_pixel(nwl, 1, 0) as f64;
            assert!(
                (est / measured - 1.0).abs() < 0.1,
                "{nwl} slots: {est} vs {measured}"
            );
        }
        // Bands and groups add their sums.
        assert!(super::render_bytes_per_pixel(61, 3, 2) > super::render_bytes_per_pixel(61, 3, 0));
    }
}
