//! `gloam bench accuracy … --resolution-scales LIST`: the resolution axis.
//!
//! For each `resolution_scale` of the list, the default render (what
//! `gloam render SCENE` does with no `--spp`/`--target-error`: sampled to
//! [`DEFAULT_TARGET_ERROR`]) at that scale, against a truth at the same
//! scale: the closed form where the scene has one (reflected light on an
//! 8 × 8 grid of sub-pixel hits plus the emitters seen directly, pixels on
//! more than one facet on 256 × 256), else a path-traced reference
//! ([`reference_settings`]: `indirect = path`, 64 diffuse bounces) sampled
//! until its own noise on the mean over the no-emitter pixels is below
//! [`TRUTH_NOISE_ON_MEAN`] (and per pixel below [`TRUTH_PIXEL_NOISE`] when
//! that fits), each pixel's share of the samples set by a pilot (samples
//! ∝ the pilot's spread, up to 1024× the least: the few pixels that see
//! a lamp head's lit inside in part would otherwise set every pixel's
//! spp), cached in the output directory per scale. Reported per scale: the mean bias
//! `mean(render)/mean(truth) − 1` over the pixels that see no emitter
//! ([`no_emitter_mask`]) and over every pixel with a surface (emitters seen
//! directly included), each with its standard error (the render's own
//! per-pixel standard errors, taken as independent, and the truth's noise),
//! the no-emitter bias per sixth of the image (six bands of rows), the
//! fraction of no-emitter pixels within 2× their stated error, and the
//! time. All in the first band.

use std::path::Path;
use std::time::Instant;

use gloam_scene::Scene;
use gloam_trace::{RenderSettings, Tracer};
use ndarray::{Array2, Array3, Axis};
use rayon::prelude::*;
use serde::Serialize;

use super::BenchError;
use super::truth::{
    REFERENCE_PIXELS, closed_form_image, closed_form_obstacle, fnv1a, no_emitter_and_surface_masks,
    read_cached_reference, reference_settings,
};
use gloam_pipeline::DEFAULT_TARGET_ERROR;
use gloam_pipeline::output::write_atomic;

/// The flag, as errors name it.
const FLAG: &str = "--resolution-scales";

/// The largest scale accepted (16× the camera's pixels).
pub const MAX_SCALE: f64 = 4.0;

/// The path-traced truth's relative standard error on its mean over the
/// no-emitter pixels: sampled until below this.
pub const TRUTH_NOISE_ON_MEAN: f64 = 1e-3;

/// The per-pixel RMS relative noise the path-traced truth aims at besides
/// (half the default target, so that `within_2x_stated` measures the
/// render's stated error more than the truth's noise) when that fits in
/// its share of the budget.
pub const TRUTH_PIXEL_NOISE: f64 = 0.5 * DEFAULT_TARGET_ERROR;

/// Parses `--resolution-scales`: comma-separated positive finite numbers,
/// each ≤ [`MAX_SCALE`].
pub fn parse_scales(list: &str) -> Result<Vec<f64>, BenchError> {
    let bad = |why: String| {
        BenchError::Invalid(format!(
            "{FLAG} {list:?}: {why} (give a comma-separated list of scales, each > 0 and ≤ {MAX_SCALE}, e.g. 0.125,0.25,0.5,1)"
        ))
    };
    if list.trim().is_empty() {
        return Err(bad("the list is empty".into()));
    }
    let scales: Vec<(&str, f64)> = list
        .split(',')
        .map(|w| {
            let w = w.trim();
            let x: f64 = w
                .parse()
                .map_err(|_| bad(format!("`{w}` is not a number")))?;
            if !x.is_finite() || x <= 0.0 || x > MAX_SCALE {
                return Err(bad(format!(
                    "`{w}` is not a positive finite scale ≤ {MAX_SCALE}"
                )));
            }
            Ok((w, x))
        })
        .collect::<Result<_, _>>()?;
    // A repeated scale ran the same renders twice, out of the budget the
    // others share (as `bench scale --triangles 1e3,1e3` was refused).
    for (i, (w, x)) in scales.iter().enumerate() {
        if let Some((v, _)) = scales[..i].iter().find(|(_, y)| y == x) {
            return Err(bad(format!(
                "`{v}` and `{w}` are the same scale; give each once"
            )));
        }
    }
    Ok(scales.into_iter().map(|(_, x)| x).collect())
}

/// One scale's figures (JSON `resolution[…]`).
#[derive(Clone, Debug, Serialize)]
pub struct ScaleRow {
    pub resolution_scale: f64,
    pub width: u32,
    pub height: u32,
    /// `mean(render)/mean(truth) − 1` over the no-emitter pixels the truth
    /// covers (first band), and its standard error.
    pub mean_bias: f64,
    pub mean_bias_std_error: f64,
    /// The same over every pixel with a surface, emitters seen directly
    /// included (a strided subset weighted by its stride for a reference).
    pub mean_bias_all_pixels: f64,
    pub mean_bias_all_pixels_std_error: f64,
    /// `mean_bias` per sixth of the image (six bands of rows, top first;
    /// null where a sixth has no counted pixel), and their standard errors.
    pub sixths: Vec<Option<f64>>,
    pub sixths_std_error: Vec<Option<f64>>,
    /// Fraction of the no-emitter pixels whose error is within 2× their
    /// stated standard error (combined with the truth's noise).
    pub within_2x_stated: f64,
    /// Wall time of the render (preparation included), seconds.
    pub time_s: f64,
    /// Mean samples per pixel of the render.
    pub mean_spp: f64,
    /// Per-pixel RMS error the render stated.
    pub stated_rms_error: Option<f64>,
    /// Samples per pixel of the path-traced truth (null: closed form).
    pub truth_spp: Option<u32>,
    pub truth_kind: &'static str,
    /// The truth's own relative noise on its mean over the no-emitter
    /// pixels and over all pixels with a surface (0 for a closed form).
    pub truth_noise_on_mean: f64,
    pub truth_noise_on_mean_all_pixels: f64,
    /// The truth's per-pixel RMS relative noise (no-emitter pixels, each
    /// against `max(t, the dark floor)`; 0 for a closed form).
    pub truth_pixel_noise: f64,
    /// Pixels counted: no-emitter, all with a surface.
    pub pixels_no_emitter: usize,
    pub pixels_all: usize,
    /// Wall time of the truth (0 when cached).
    pub truth_s: f64,
}

/// A scale that did not run, and why.
#[derive(Clone, Debug, Serialize)]
pub struct Skipped {
    pub resolution_scale: f64,
    pub why: String,
}

/// The axis: the scales run and those skipped.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ResolutionAxis {
    pub rows: Vec<ScaleRow>,
    pub skipped: Vec<Skipped>,
}

/// A truth at one scale.
struct ScaleTruth {
    kind: &'static str,
    /// Band × row × column; NaN off the pixels it covers.
    image: Array3<f64>,
    /// Variance of `image` (zeros for a closed form).
    var: Array3<f64>,
    /// No-emitter pixels it covers.
    mask: Array2<bool>,
    /// Weight of each pixel in the all-pixels mean (0: not counted).
    weight: Array2<f64>,
    spp: Option<u32>,
    /// Per-pixel RMS relative noise over the no-emitter pixels, against
    /// `max(t, the dark floor)` (0 for a closed form): pooled, it stands
    /// for each pixel's noise in `within_2x_stated` (a pixel's own
    /// estimate from two halves has one degree of freedom).
    pixel_noise: f64,
    seconds: f64,
}

/// The scene with its camera's width and height scaled as the tracer's
/// `resolution_scale` does (the field of view kept).
fn scaled_scene(scene: &Scene, scale: f64) -> Scene {
    let mut s = scene.clone();
    let f = |n: u32| ((n as f64 * scale).round() as u32).max(1);
    s.camera.width = f(s.camera.width);
    s.camera.height = f(s.camera.height);
    s
}

/// Runs the axis over `scales`, stopping each scale that would pass
/// `deadline_s` (seconds since `t_start`).
pub fn run(
    scene_path: &Path,
    scene: &Scene,
    dir: &Path,
    threads: Option<usize>,
    scales: &[f64],
    t_start: Instant,
    deadline_s: f64,
) -> Result<ResolutionAxis, BenchError> {
    let elapsed = || t_start.elapsed().as_secs_f64();
    let closed_form = closed_form_obstacle(scene).is_none();
    let mut axis = ResolutionAxis::default();
    // The last scale's render timing (predicts the next).
    let mut last: Option<RenderTiming> = None;
    for (i, &scale) in scales.iter().enumerate() {
        let scaled = scaled_scene(scene, scale);
        let px = (scaled.camera.width * scaled.camera.height) as f64;
        let (render_guess, trusted) = predict_render_s(last, px);
        let left = deadline_s - elapsed();
        if trusted && render_guess > left {
            axis.skipped.push(Skipped {
                resolution_scale: scale,
                why: format!(
                    "the render would take ~{render_guess:.0} s, {left:.0} s of the budget left"
                ),
            });
            continue;
        }
        eprintln!("bench accuracy: resolution_scale {scale} …");
        let geometry = Tracer::new(&scaled, &RenderSettings::default())?;
        let truth = if closed_form {
            closed_form_scale_truth(&scaled, &geometry)
        } else {
            let truth_deadline = deadline_s - render_guess;
            let left = || truth_deadline - elapsed();
            // The per-pixel goal only within an even share of what is left.
            let share_s = left() / (scales.len() - i) as f64;
            let at = (dir, threads, scale, share_s);
            match reference_scale_truth(scene_path, &scaled, &geometry, at, left)? {
                Ok(t) => t,
                Err(why) => {
                    axis.skipped.push(Skipped {
                        resolution_scale: scale,
                        why,
                    });
                    continue;
                }
            }
        };
        // The default render at this scale.
        let mut settings = RenderSettings {
            threads,
            resolution_scale: scale,
            ..Default::default()
        };
        settings.target_error = Some(DEFAULT_TARGET_ERROR);
        let t0 = Instant::now();
        let out = Tracer::new(scene, &settings)?.render(&|_, _| {})?;
        let time_s = t0.elapsed().as_secs_f64();
        let trace_s = out.stats.trace_seconds.clamp(0.0, time_s);
        last = Some(RenderTiming {
            px,
            fixed_s: time_s - trace_s,
            trace_s,
        });
        ensure_valid!(
            out.radiance.dim() == truth.image.dim(),
            "resolution_scale {scale}: the render is {:?}, the truth {:?} (band × row × column)",
            out.radiance.dim(),
            truth.image.dim()
        );
        axis.rows
            .push(figures(scale, &scaled, &out, &truth, time_s));
    }
    Ok(axis)
}

/// Below this many pixels a render's time is mostly fixed cost (thread
/// start, the adaptive sampler's rounds), so its per-pixel rate
/// extrapolated to a larger scale can be off by orders of magnitude (a
/// 1×1 render's 0.03 s × 768 predicted 21 s for a render of 0.03 s): such
/// a prediction never skips a scale.
pub const MIN_PREDICTING_PIXELS: f64 = 256.0;

/// A render's timing at one scale, what the next scale's is predicted from.
#[derive(Clone, Copy, Debug)]
struct RenderTiming {
    /// The render's pixels.
    px: f64,
    /// Wall time outside sampling (the tracer's preparation and the rest):
    /// taken as fixed, as it does not grow with the pixel count.
    fixed_s: f64,
    /// The render's sampling time (`RenderStats::trace_seconds`): taken as
    /// proportional to the pixel count.
    trace_s: f64,
}

/// The predicted wall time of a render of `px` pixels after `last`:
/// `fixed + sampling per pixel × px` (so the fixed cost is not scaled by
/// the pixel ratio), and whether it may skip the scale — only when `last`
/// had at least [`MIN_PREDICTING_PIXELS`]. Without a trusted prediction
/// the time reserved is the last render's own (0 before the first).
fn predict_render_s(last: Option<RenderTiming>, px: f64) -> (f64, bool) {
    let Some(t) = last else {
        return (0.0, false);
    };
    if t.px < MIN_PREDICTING_PIXELS {
        return (t.fixed_s + t.trace_s, false);
    }
    (t.fixed_s + t.trace_s / t.px.max(1.0) * px, true)
}

/// Weighted sums over the pixels `weight` counts (first band): render,
/// truth, and their variances.
#[derive(Default, Clone, Copy)]
struct Sums {
    x: f64,
    t: f64,
    vx: f64,
    vt: f64,
    n: usize,
}

impl Sums {
    fn add(&mut self, w: f64, x: f64, s: f64, t: f64, vt: f64) {
        self.x += w * x;
        self.t += w * t;
        self.vx += w * w * s * s;
        self.vt += w * w * vt;
        self.n += 1;
    }
    /// (bias, its standard error, the truth's relative noise on its mean).
    fn bias(&self) -> (f64, f64, f64) {
        if self.n == 0 || self.t <= 0.0 {
            return (f64::NAN, f64::NAN, f64::NAN);
        }
        let r = self.x / self.t;
        let rel_t = self.vt.sqrt() / self.t;
        let rel_x = if self.x != 0.0 {
            self.vx.sqrt() / self.x.abs()
        } else {
            0.0
        };
        (r - 1.0, r.abs() * rel_x.hypot(rel_t), rel_t)
    }
}

fn figures(
    scale: f64,
    scaled: &Scene,
    out: &gloam_trace::RenderOutput,
    truth: &ScaleTruth,
    time_s: f64,
) -> ScaleRow {
    let h = scaled.camera.height as usize;
    let (x, s) = (
        out.radiance.index_axis(Axis(0), 0),
        out.std_error.index_axis(Axis(0), 0),
    );
    let (t, vt) = (
        truth.image.index_axis(Axis(0), 0),
        truth.var.index_axis(Axis(0), 0),
    );
    let floor = {
        let v: Vec<f64> = (truth.mask.indexed_iter())
            .filter(|(ix, m)| **m && t[*ix].is_finite())
            .map(|(ix, _)| t[ix])
            .collect();
        gloam_trace::render::DARK_FLOOR * v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let (mut masked, mut all) = (Sums::default(), Sums::default());
    let mut sixths = [Sums::default(); 6];
    let (mut within, mut counted) = (0usize, 0usize);
    for ((r, c), &w) in truth.weight.indexed_iter() {
        let ix = [r, c];
        if !t[ix].is_finite() {
            continue;
        }
        if w > 0.0 {
            all.add(w, x[ix], s[ix], t[ix], vt[ix]);
        }
        if truth.mask[ix] {
            masked.add(1.0, x[ix], s[ix], t[ix], vt[ix]);
            sixths[(6 * r / h).min(5)].add(1.0, x[ix], s[ix], t[ix], vt[ix]);
            counted += 1;
            let vt_pooled = (truth.pixel_noise * t[ix].max(floor)).powi(2);
            if (x[ix] - t[ix]).abs() <= 2.0 * (s[ix] * s[ix] + vt_pooled).sqrt() {
                within += 1;
            }
        }
    }
    let (mb, mbse, noise) = masked.bias();
    let (ab, abse, noise_all) = all.bias();
    let finite = |v: f64| v.is_finite().then_some(v);
    let spp = &out.spp;
    ScaleRow {
        resolution_scale: scale,
        width: scaled.camera.width,
        height: scaled.camera.height,
        mean_bias: mb,
        mean_bias_std_error: mbse,
        mean_bias_all_pixels: ab,
        mean_bias_all_pixels_std_error: abse,
        sixths: sixths.iter().map(|s| finite(s.bias().0)).collect(),
        sixths_std_error: sixths.iter().map(|s| finite(s.bias().1)).collect(),
        within_2x_stated: within as f64 / counted.max(1) as f64,
        time_s,
        mean_spp: spp.iter().map(|&n| n as f64).sum::<f64>() / spp.len().max(1) as f64,
        stated_rms_error: out.error.rel_std_error_rms_target_pixels,
        truth_spp: truth.spp,
        truth_kind: truth.kind,
        truth_noise_on_mean: noise,
        truth_noise_on_mean_all_pixels: noise_all,
        truth_pixel_noise: truth.pixel_noise,
        pixels_no_emitter: masked.n,
        pixels_all: all.n,
        truth_s: truth.seconds,
    }
}

/// The closed form at this scale: reflected light plus the emitters seen
/// directly, every pixel with a surface.
fn closed_form_scale_truth(scaled: &Scene, geometry: &Tracer) -> ScaleTruth {
    let t0 = Instant::now();
    let image = closed_form_image(scaled, geometry, true);
    let (mask, surface) = no_emitter_and_surface_masks(scaled, geometry, 4);
    ScaleTruth {
        kind: "closed-form",
        var: Array3::zeros(image.dim()),
        image,
        mask,
        weight: surface.mapv(|b| if b { 1.0 } else { 0.0 }),
        spp: None,
        pixel_noise: 0.0,
        seconds: t0.elapsed().as_secs_f64(),
    }
}

/// Which pixels a scale's reference covers: a strided subset of at most
/// [`REFERENCE_PIXELS`] of the no-emitter pixels and as many of the other
/// pixels with a surface, each weighted by its stride in the all-pixels
/// mean.
fn reference_pixels(
    mask: &Array2<bool>,
    surface: &Array2<bool>,
) -> (Vec<(usize, usize)>, Array2<f64>) {
    let mut weight = Array2::zeros(mask.dim());
    let mut subset = Vec::new();
    for stratum in [true, false] {
        let px: Vec<(usize, usize)> = surface
            .indexed_iter()
            .filter(|(rc, s)| **s && mask[*rc] == stratum)
            .map(|(rc, _)| rc)
            .collect();
        let stride = px.len().div_ceil(REFERENCE_PIXELS).max(1);
        for rc in px.into_iter().step_by(stride) {
            weight[rc] = stride as f64;
            subset.push(rc);
        }
    }
    (subset, weight)
}

/// The path-traced truth at one scale, cached in `dir`: sampled in two
/// independent halves (their difference gives its noise per pixel), the
/// spp raised until its noise on the no-emitter mean is below
/// [`TRUTH_NOISE_ON_MEAN`] and, when that fits in `share_s` seconds, its
/// per-pixel RMS noise below [`TRUTH_PIXEL_NOISE`]. `Ok(Err(why))` when
/// the first would not fit in `left()` seconds.
fn reference_scale_truth(
    scene_path: &Path,
    scaled: &Scene,
    geometry: &Tracer,
    (dir, threads, scale, share_s): (&Path, Option<usize>, f64, f64),
    left: impl Fn() -> f64,
) -> Result<Result<ScaleTruth, String>, BenchError> {
    let t0 = Instant::now();
    let text = gloam_io::read_bounded(
        scene_path,
        gloam_io::MAX_TEXT_FILE_BYTES,
        &crate::unlisted(),
    )
    .map_err(BenchError::io("reading", scene_path))?;
    let (mask_all, surface) = no_emitter_and_surface_masks(scaled, geometry, 4);
    let (subset, weight) = reference_pixels(&mask_all, &surface);
    let (nb, h, w) = (
        scaled.bands.len(),
        scaled.camera.height as usize,
        scaled.camera.width as usize,
    );
    let key = format!(
        "{:016x}-{:016x}-scale-{scale}-{w}x{h}-noise-{TRUTH_NOISE_ON_MEAN}-v2",
        fnv1a(&text),
        fnv1a(serde_json::to_string(&reference_settings(None, 0))?.as_bytes())
    );
    let stem = format!("reference-scale-{scale}");
    let npy = dir.join(format!("{stem}.npy"));
    let meta = dir.join(format!("{stem}.json"));
    let finish = |stack: ndarray::Array4<f64>, spp: u32, pixel_noise: f64, seconds: f64| {
        let image = stack.index_axis(Axis(0), 0).to_owned();
        let var = stack.index_axis(Axis(0), 1).to_owned();
        let mask = Array2::from_shape_fn((h, w), |(r, c)| {
            mask_all[[r, c]] && image[[0, r, c]].is_finite()
        });
        ScaleTruth {
            kind: "reference",
            image,
            var,
            mask,
            weight: weight.clone(),
            spp: Some(spp),
            pixel_noise,
            seconds,
        }
    };
    if let Some((m, stack)) = read_cached_reference(&meta, &npy, &key, (2, nb, h, w)) {
        let spp = m["spp"].as_u64().unwrap_or(0) as u32;
        let pixel_noise = m["pixel_noise"].as_f64().unwrap_or(f64::NAN);
        return Ok(Ok(finish(stack, spp, pixel_noise, 0.0)));
    }
    // Both halves at `spp` × each pixel's multiplier (each half spp/2):
    // the stack of mean and variance, the relative noise on the no-emitter
    // mean and the per-pixel RMS relative noise there. `seeds`: the
    // halves' seeds (the pilot's apart from the rest, so the multipliers
    // it sets do not depend on the samples they multiply).
    let render = |spp: u32,
                  mult: &[u32],
                  seeds: (u64, u64)|
     -> Result<(ndarray::Array4<f64>, f64, f64), BenchError> {
        let half = |seed: u64| -> Result<Vec<Vec<f64>>, BenchError> {
            let mut v = vec![Vec::new(); subset.len()];
            let mut classes: Vec<u32> = mult.to_vec();
            classes.sort_unstable();
            classes.dedup();
            for m in classes {
                let n = (spp / 2)
                    .max(1)
                    .saturating_mul(m)
                    .min(gloam_trace::settings::MAX_SPP);
                let s = RenderSettings {
                    seed,
                    spp: n,
                    ..reference_settings(threads, n)
                };
                let t = Tracer::new(scaled, &s)?;
                let picked: Vec<usize> = (0..subset.len()).filter(|&k| mult[k] == m).collect();
                let got: Result<Vec<Vec<f64>>, _> = picked
                    .par_iter()
                    .map(|&k| t.probe_pixel(subset[k].1 as u32, subset[k].0 as u32))
                    .collect();
                for (k, x) in picked.into_iter().zip(got?) {
                    v[k] = x;
                }
            }
            Ok(v)
        };
        let (a, b) = (half(seeds.0)?, half(seeds.1)?);
        let mut stack = ndarray::Array4::<f64>::from_elem((2, nb, h, w), f64::NAN);
        let mut tv = Vec::new();
        for (k, &(r, c)) in subset.iter().enumerate() {
            for bi in 0..nb {
                stack[[0, bi, r, c]] = 0.5 * (a[k][bi] + b[k][bi]);
                // Var(mean of two) = E[(a − b)²] / 4.
                stack[[1, bi, r, c]] = (a[k][bi] - b[k][bi]).powi(2) / 4.0;
            }
            if mask_all[[r, c]] {
                tv.push((stack[[0, 0, r, c]], stack[[1, 0, r, c]]));
            }
        }
        let (on_mean, per_pixel) = noise_of(&tv);
        Ok((stack, on_mean, per_pixel))
    };
    // A pilot at 16 spp sets each pixel's share of the samples (a few
    // pixels — the inside of a lamp's head seen partly — can hold most of
    // the mean's noise); then the spp its noise asks for (with a tenth to
    // spare), checked and raised again if the noise is still above.
    let mut spp = 16u32;
    let flat = vec![1u32; subset.len()];
    let (pilot, ..) = render(spp, &flat, (1_000_001, 1_000_002))?;
    let mult = multipliers(&pilot, &subset);
    let mean_mult = mult.iter().map(|&m| m as f64).sum::<f64>() / mult.len().max(1) as f64;
    let mut pixel_goal = true;
    let (stack, noise, pixel_noise) = loop {
        let t1 = Instant::now();
        let (stack, noise, pixel_noise) = render(spp, &mult, (1_000_003, 1_000_004))?;
        let dt = t1.elapsed().as_secs_f64();
        let per_spp = dt / spp as f64;
        let spp_for = |ratio: f64| {
            ((spp as f64 * ratio.powi(2) * 1.1).ceil() as u32)
                .max(2 * spp)
                .div_ceil(2)
                * 2
        };
        let mean_ok = noise < TRUTH_NOISE_ON_MEAN;
        let pixel_ok = !pixel_goal || pixel_noise < TRUTH_PIXEL_NOISE;
        if mean_ok && pixel_ok {
            break (stack, noise, pixel_noise);
        }
        if pixel_goal && !pixel_ok {
            let next = spp_for((pixel_noise / TRUTH_PIXEL_NOISE).max(noise / TRUTH_NOISE_ON_MEAN));
            if per_spp * next as f64 <= share_s.min(left()) {
                spp = next;
                continue;
            }
            // Not in its share: the mean's goal alone.
            pixel_goal = false;
            if mean_ok {
                break (stack, noise, pixel_noise);
            }
        }
        let next = spp_for(noise / TRUTH_NOISE_ON_MEAN);
        let need_s = per_spp * next as f64;
        let left_s = left();
        if need_s > left_s {
            return Ok(Err(format!(
                "its truth would need ~{next} spp (~{need_s:.0} s) for a noise on the mean below {:.1} %, {left_s:.0} s of the budget left",
                100.0 * TRUTH_NOISE_ON_MEAN
            )));
        }
        spp = next;
    };
    let mean_spp = (spp as f64 * mean_mult).round() as u32;
    std::fs::create_dir_all(dir).map_err(BenchError::io("creating", dir))?;
    gloam_pipeline::output::write_npy(&npy, &stack)?;
    let seconds = t0.elapsed().as_secs_f64();
    write_atomic(
        &meta,
        serde_json::to_string_pretty(&serde_json::json!({
            "key": key,
            "scene": scene_path.display().to_string(),
            "resolution_scale": scale,
            "settings": reference_settings(None, spp),
            "spp": mean_spp,
            "base_spp": spp,
            "max_multiplier": mult.iter().max().copied().unwrap_or(1),
            "pixels": subset.len(),
            "noise_on_mean": noise,
            "pixel_noise": pixel_noise,
            "seconds": seconds,
        }))?
        .as_bytes(),
    )?;
    Ok(Ok(finish(stack, mean_spp, pixel_noise, seconds)))
}

/// Most samples one pixel of a truth gets, as a multiple of the least.
const MAX_MULTIPLIER: u32 = 1024;

/// Each subset pixel's sample multiplier from a pilot `stack` (mean and
/// variance of the mean): the pilot's per-sample spread over the median
/// spread of the pixels, as a power of two in 1..=[`MAX_MULTIPLIER`] —
/// Neyman's allocation (samples ∝ σ) for the noise on the mean, floored
/// so no pixel gets fewer samples than a uniform truth would.
fn multipliers(stack: &ndarray::Array4<f64>, subset: &[(usize, usize)]) -> Vec<u32> {
    let sd: Vec<f64> = subset
        .iter()
        .map(|&(r, c)| stack[[1, 0, r, c]].max(0.0).sqrt())
        .collect();
    let mut lit: Vec<f64> = sd
        .iter()
        .copied()
        .filter(|x| *x > 0.0 && x.is_finite())
        .collect();
    if lit.is_empty() {
        return vec![1; subset.len()];
    }
    lit.sort_by(f64::total_cmp);
    let median = lit[lit.len() / 2];
    sd.iter()
        .map(|&x| {
            let ratio = if x.is_finite() { x / median } else { 1.0 };
            let m = ratio.clamp(1.0, MAX_MULTIPLIER as f64);
            1u32 << (m.log2().floor() as u32)
        })
        .collect()
}

/// Of a truth's (value, variance) over the no-emitter pixels (first band):
/// its relative noise on the mean, and its per-pixel RMS relative noise
/// as `--target-error` counts it (each pixel against `max(t, the dark
/// floor)`).
fn noise_of(tv: &[(f64, f64)]) -> (f64, f64) {
    let sum: f64 = tv.iter().map(|p| p.0).sum();
    let var: f64 = tv.iter().map(|p| p.1).sum();
    let floor = gloam_trace::render::DARK_FLOOR * sum / tv.len().max(1) as f64;
    let rel2: f64 = tv.iter().map(|&(t, v)| v / t.max(floor).powi(2)).sum();
    let on_mean = if sum > 0.0 { var.sqrt() / sum } else { 0.0 };
    (on_mean, (rel2 / tv.len().max(1) as f64).sqrt())
}

/// `summary.md`'s section.
pub fn markdown(axis: &ResolutionAxis) -> String {
    use std::fmt::Write as _;
    let mut m = String::new();
    let _ = writeln!(
        m,
        "\n## Resolution axis (default render, `--target-error {DEFAULT_TARGET_ERROR}`, against a truth at the same scale; first band)\n\n\
         | scale | pixels | mean bias, no-emitter (± s.e.) | mean bias, all pixels (± s.e.) | bias per sixth (top → bottom) | within 2× stated | time (s) | mean spp | truth | truth spp | truth noise: on mean, per pixel |\n\
         |---|---|---|---|---|---|---|---|---|---|---|"
    );
    let pct = |v: f64| format!("{:+.2} %", 100.0 * v);
    for r in &axis.rows {
        let sixths: Vec<String> = r
            .sixths
            .iter()
            .map(|s| s.map_or("–".into(), |v| format!("{:+.1}", 100.0 * v)))
            .collect();
        let _ = writeln!(
            m,
            "| {} | {}×{} | {} ± {:.2} % | {} ± {:.2} % | {} % | {:.1} % | {:.2} | {:.1} | {} | {} | {:.3} %, {:.2} % |",
            r.resolution_scale,
            r.width,
            r.height,
            pct(r.mean_bias),
            100.0 * r.mean_bias_std_error,
            pct(r.mean_bias_all_pixels),
            100.0 * r.mean_bias_all_pixels_std_error,
            sixths.join(" / "),
            100.0 * r.within_2x_stated,
            r.time_s,
            r.mean_spp,
            r.truth_kind,
            r.truth_spp.map_or("–".into(), |n| n.to_string()),
            100.0 * r.truth_noise_on_mean,
            100.0 * r.truth_pixel_noise
        );
    }
    for s in &axis.skipped {
        let _ = writeln!(
            m,
            "\nresolution_scale {} skipped: {}.",
            s.resolution_scale, s.why
        );
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prediction_does_not_scale_the_fixed_cost() {
        // Round 13: a 1×1 render of 0.03 s (mostly fixed cost) predicted
        // scale 1 (768 pixels) at ~21 s and skipped it.
        let tiny = RenderTiming {
            px: 1.0,
            fixed_s: 0.025,
            trace_s: 0.005,
        };
        let (s, trusted) = predict_render_s(Some(tiny), 768.0);
        assert!(!trusted, "a 1-pixel render must not skip a scale");
        assert!(s < 0.1, "{s}");
        // From a render large enough to trust: fixed + per-pixel.
        let big = RenderTiming {
            px: 1024.0,
            fixed_s: 2.0,
            trace_s: 1.0,
        };
        let (s, trusted) = predict_render_s(Some(big), 4096.0);
        assert!(trusted);
        assert!((s - 6.0).abs() < 1e-12, "{s}");
        assert_eq!(predict_render_s(None, 4096.0), (0.0, false));
    }
}
