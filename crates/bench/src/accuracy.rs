//! `gloam bench accuracy`: the sweep of the settings that trade accuracy
//! for time, its summary (time to an error, the Pareto front) and its
//! files (`accuracy.csv`, `accuracy.png`, `summary.md`).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use gloam_scene::Scene;
use gloam_trace::{Estimator, RenderSettings, Tracer};
use ndarray::Axis;
use rayon::prelude::*;
use serde::Serialize;

use super::metrics::{error_coverage, errors};
use super::truth::{
    REFERENCE_PIXELS, ReferenceKind, Truth, closed_form_obstacle, closed_form_truth,
    reference_settings, reference_truth,
};
use super::{BenchError, resolution};
use gloam_io::output_set::OutputSet;
use gloam_pipeline::output::write_atomic;

#[derive(Clone, Debug, Serialize)]
pub struct Row {
    estimator: String,
    setting: String,
    value: String,
    spp: u32,
    time_s: f64,
    rel_rms_error: f64,
    max_rel_error: f64,
    /// Per-pixel RMS relative error (see [`Errors`]).
    pixel_rms_error: f64,
    /// The same, each pixel relative to `max(t, dark floor)` as
    /// `--target-error` defines it ([`Errors::pixel_as_targeted`]).
    pixel_rms_error_as_targeted: f64,
    /// Target-error rows: fraction of counted pixels whose actual error is
    /// within 2× the stated target, and within 2× the render's own
    /// per-pixel standard-error estimate.
    within_2x_target: Option<f64>,
    within_2x_estimate: Option<f64>,
    /// Of `time_s`, the part spent preparing (BVH, pilot, radiosity cache).
    prepare_s: f64,
}

/// One planned run.
struct Plan {
    estimator: Estimator,
    setting: &'static str,
    value: String,
    settings: RenderSettings,
    /// Scene variant (line-spectrum source) for the spectral sweep, or
    /// the direct-only copy whose truth is the direct-only reference.
    scene: Option<usize>,
}

/// Spp of the direct-only reference (two halves; direct light is cheap).
const DIRECT_REFERENCE_SPP: u32 = 16384;

/// The direct-light-only rows (the first wave's model, and Mitsuba 3's
/// direct-only figures): an spp ladder and renders to a stated error with
/// `indirect = off`, compared with the direct-only reference (`scene`).
fn direct_only_plans(threads: Option<usize>, scene: usize) -> Vec<Plan> {
    let mut v = Vec::new();
    let mut push = |setting: &'static str, value: String, f: &dyn Fn(&mut RenderSettings)| {
        let mut s = with(Estimator::Analytic, threads, |_| {});
        s.set("indirect", "off").expect("valid");
        f(&mut s);
        v.push(Plan {
            estimator: Estimator::Analytic,
            setting,
            value,
            settings: s,
            scene: Some(scene),
        });
    };
    for spp in [1u32, 4, 16, 64] {
        push("direct_only_spp", spp.to_string(), &|s| s.spp = spp);
    }
    for t in ["0.05", "0.02", "0.01"] {
        push("direct_only_target_error", t.to_string(), &|s| {
            s.set("target_error", t).expect("valid")
        });
    }
    v
}

const LADDER: [u32; 9] = [1, 2, 4, 8, 16, 32, 64, 128, 256];
const ESTIMATORS: [Estimator; 3] = [
    Estimator::Analytic,
    Estimator::SolidAngle,
    Estimator::Dirsig2001,
];

fn with(
    est: Estimator,
    threads: Option<usize>,
    f: impl FnOnce(&mut RenderSettings),
) -> RenderSettings {
    let mut s = RenderSettings {
        estimator: est,
        threads,
        ..Default::default()
    };
    f(&mut s);
    s
}

/// Settings other than spp, around their defaults.
fn other_plans(threads: Option<usize>, line_variant: Option<usize>) -> Vec<Plan> {
    let mut v = Vec::new();
    let mut push = |est: Estimator, setting: &'static str, value: &str, scene: Option<usize>| {
        let mut s = with(est, threads, |_| {});
        s.set(setting, value)
            .expect("benchmark settings are valid keys and values");
        v.push(Plan {
            estimator: est,
            setting,
            value: value.to_string(),
            settings: s,
            scene,
        });
    };
    // First what this sweep is for: the whole light and renders to a
    // stated error; then the finer settings.
    // Interreflection: off (the first wave's default: direct light only),
    // brute-force path tracing truncated at k bounces (the truncation bias
    // against the whole-light reference), the cache read without and with
    // more final-gather rays.
    push(Estimator::Analytic, "indirect", "off", None);
    for x in ["1", "2", "4"] {
        push(Estimator::Analytic, "diffuse_bounces", x, None);
    }
    for x in ["0", "4", "64"] {
        push(Estimator::Analytic, "gather_rays", x, None);
    }
    // Renders to a stated error.
    for x in ["0.1", "0.05", "0.02", "0.01"] {
        push(Estimator::Analytic, "target_error", x, None);
    }
    for x in ["1", "2", "5", "10", "20", "40"] {
        push(Estimator::Analytic, "spectral_step_nm", x, line_variant);
    }
    for x in ["4", "64"] {
        push(Estimator::Analytic, "area_samples", x, None);
        push(Estimator::SolidAngle, "area_samples", x, None);
    }
    push(Estimator::Analytic, "occlusion", "ratio", None);
    for x in ["1", "2", "6"] {
        push(Estimator::Analytic, "recursion", x, None);
    }
    for (key, vals) in [
        ("SAMPLE_AREA_DENSITY", &["4", "16", "64"][..]),
        ("MAX_SAMPLE_POINTS", &["4", "2000"][..]),
        ("MAX_SOURCE_SAMPLES", &["25", "400"][..]),
        ("SOLID_ANGLE_DENSITY", &["250", "4000"][..]),
        ("SOLID_ANGLE_THRESHOLD", &["1e-8", "1e-3"][..]),
        ("IRRADIANCE_THRESHOLD", &["1e-12", "1e-2"][..]),
    ] {
        for x in vals {
            push(Estimator::Dirsig2001, key, x, None);
        }
    }
    v
}

/// A copy of `scene` whose emitters radiate clear mercury (lines on a
/// weak continuum) scaled to the same first-band radiance: the spectral
/// sweep's worst case when the scene's own sources are spectrally smooth.
fn mercury_variant(scene: &Scene) -> Option<Scene> {
    let hg = gloam_spectra::library::get("mercury-clear")?;
    let band = scene.bands.first()?;
    let mut s = scene.clone();
    for m in &mut s.materials {
        if let Some(e) = &mut m.emission {
            let want = e.radiance_w_m2_sr_nm.integrate_band(band.lo_nm, band.hi_nm);
            let have = hg.integrate_band(band.lo_nm, band.hi_nm);
            if have > 0.0 {
                e.radiance_w_m2_sr_nm = hg.scaled(want / have).ok()?;
            }
        }
    }
    Some(s)
}

fn has_lines(scene: &Scene) -> bool {
    scene.materials.iter().any(|m| {
        m.emission
            .as_ref()
            .is_some_and(|e| !e.radiance_w_m2_sr_nm.lines().is_empty())
    })
}

#[derive(Serialize)]
pub struct Summary {
    /// Energy-weighted metric (`rel_rms_error`).
    time_to_1pct_s: BTreeMap<String, Option<f64>>,
    time_to_0_1pct_s: BTreeMap<String, Option<f64>>,
    /// Per-pixel metric (`pixel_rms_error`).
    time_to_1pct_pixel_s: BTreeMap<String, Option<f64>>,
    time_to_0_1pct_pixel_s: BTreeMap<String, Option<f64>>,
    /// The `--target-error` rows: time, achieved per-pixel error, where the
    /// time went, and how well the error estimate held.
    target_error: Vec<serde_json::Value>,
    /// Time to 1 % / 0.1 % per-pixel error along the `--target-error` rows
    /// (interpolated log–log as for the spp ladders): what a user asking
    /// for an error pays.
    time_to_1pct_pixel_adaptive_s: Option<f64>,
    time_to_0_1pct_pixel_adaptive_s: Option<f64>,
    /// Direct light only (`indirect = off`) against the direct-only
    /// reference, where the scene has no closed form: time to 1 % per-pixel
    /// error along its spp ladder and its target-error rows, and the rows.
    #[serde(skip_serializing_if = "Option::is_none")]
    direct_only: Option<serde_json::Value>,
    /// Mitsuba 3 side by side: its ladders against the same truths, times
    /// to 1 % and 0.1 % per-pixel error on both sides and their ratio, or
    /// why it did not run.
    mitsuba3: serde_json::Value,
    scene: String,
    truth: String,
    truth_seconds: f64,
    runs: usize,
    skipped_for_budget: usize,
    budget_s: f64,
    elapsed_s: f64,
    /// Seconds past `budget_s` (0 within it): the budget stops the optional
    /// rows, not the ones every sweep needs ([`BUDGET_EXEMPT`]).
    over_budget_s: f64,
    /// Lowest error each estimator's spp ladder reached, and at what time.
    best: BTreeMap<String, Option<(f64, f64)>>,
    effect_plan: Option<serde_json::Value>,
    /// What the `spectral_step_nm` rows were rendered on.
    spectral_sweep: String,
    /// `--resolution-scales`: the default render against a truth at each
    /// scale ([`resolution::ScaleRow`]), and the scales skipped (why).
    #[serde(skip_serializing_if = "Option::is_none")]
    resolution: Option<Vec<resolution::ScaleRow>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    resolution_skipped: Option<Vec<resolution::Skipped>>,
    /// Empty (and left out) with `--resolution-only`.
    #[serde(skip_serializing_if = "String::is_empty")]
    csv: String,
    #[serde(skip_serializing_if = "String::is_empty")]
    png: String,
    summary_md: String,
}

/// Time at which the estimator's spp ladder first reaches `target`,
/// interpolated log–log between the rungs that bracket it; the first rung's
/// time when it is already below (an upper bound); None if never.
fn time_to(rows: &[&Row], target: f64, metric: RowMetric) -> Option<f64> {
    let mut prev: Option<&Row> = None;
    for r in rows {
        if metric(r).is_finite() && metric(r) <= target {
            return Some(match prev {
                Some(p) if metric(p) > 0.0 && metric(r) > 0.0 && p.time_s > 0.0 => {
                    let (lt0, lt1) = (p.time_s.ln(), r.time_s.max(1e-12).ln());
                    let (le0, le1) = (metric(p).ln(), metric(r).ln());
                    if (le1 - le0).abs() < 1e-300 {
                        r.time_s
                    } else {
                        (lt0 + (target.ln() - le0) * (lt1 - lt0) / (le1 - le0)).exp()
                    }
                }
                _ => r.time_s,
            });
        }
        if metric(r).is_finite() {
            prev = Some(r);
        }
    }
    None
}

fn pareto(rows: &[Row]) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| {
            r.rel_rms_error.is_finite()
                && r.time_s > 0.0
                && r.estimator != "sensor"
                && r.estimator != MITSUBA
        })
        .map(|r| (r.time_s, r.rel_rms_error))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for p in pts {
        if p.1 < best {
            best = p.1;
            front.push(p);
        }
    }
    front
}

/// What to sweep, where.
pub struct AccuracyOptions {
    /// The scene file.
    pub scene: PathBuf,
    /// Output directory: accuracy.csv, accuracy.png, summary.md, the cached
    /// reference.
    pub out: PathBuf,
    /// Wall-time budget, seconds: the optional rows stop when it is spent;
    /// what every sweep needs runs whatever it is ([`BUDGET_EXEMPT`]), and
    /// the summary says by how much the run went past it.
    pub budget_s: f64,
    /// Also render with every effect forced on (the effect plan's saving).
    pub all_effects: bool,
    pub threads: Option<usize>,
    /// Render the scene in Mitsuba 3 too, side by side, when `python3`
    /// can import it ([`super::accuracy_mitsuba`]).
    pub mitsuba: bool,
    /// The resolution axis's scales ([`resolution`]), if any.
    pub resolution_scales: Option<Vec<f64>>,
    /// Run only the resolution axis.
    pub resolution_only: bool,
    /// Replace a previous set at `out` (only a gloam output set).
    pub force: bool,
}

/// Longest `--budget-s` (about 11.6 days, as `bench scale --timeout-s`):
/// a wall-time budget, not "forever" (1e300 was accepted and summary.md
/// printed it with 301 digits).
pub const MAX_BUDGET_S: f64 = 1e6;

/// What `--budget-s` does not stop: a sweep without them has no figures.
pub const BUDGET_EXEMPT: &str = "the reference (at least 256 spp), each estimator's first rung and Mitsuba 3 (up to the larger of half the budget and 60 s) run whatever the budget";

/// The sweep's summary, and the same as the Markdown of `summary.md`.
pub struct AccuracyReport {
    pub summary: Summary,
    pub markdown: String,
}

/// Runs the sweep and publishes its files as one output set at
/// `args.out` ([`OutputSet`]: a non-empty `--out` is refused unless
/// `--force`, which replaces only a previous gloam set; a run that fails
/// or is interrupted leaves the previous set as it was). The cached
/// references of the set it replaces are carried into the new one and
/// reused where their key still matches (see the module docs).
pub fn run(
    args: &AccuracyOptions,
    guard: &gloam_io::RunGuard,
) -> Result<AccuracyReport, BenchError> {
    let t_start = Instant::now();
    ensure_valid!(
        args.budget_s.is_finite() && args.budget_s > 0.0 && args.budget_s <= MAX_BUDGET_S,
        "--budget-s {}: must be a positive number of seconds, at most {MAX_BUDGET_S:e}",
        gloam_spectra::num(args.budget_s)
    );
    let scene_path = args.scene.clone();
    // The run's reads: the scene and its files, listed in the manifest.
    let reads = gloam_io::ReadLog::new();
    let scene = gloam_scene::load(&scene_path, &reads)?;
    let provenance = gloam_pipeline::Provenance::of_this_run(&reads);
    let set = OutputSet::begin(&args.out, args.force, false, guard)?;
    carry_cached_references(&args.out, set.dir())?;
    let report = sweep(args, set.dir(), t_start, (&scene_path, &scene), guard)?;
    set.publish(&provenance, None)?;
    Ok(report)
}

/// The cached references (`reference*.npy` and their `.json`) of the
/// previous set at `out`, copied into the new set's `dir`; nothing else
/// is read from it. `OutputSet::begin` has checked that a non-empty
/// `out` is a gloam set.
fn carry_cached_references(out: &Path, dir: &Path) -> Result<(), BenchError> {
    let Ok(entries) = std::fs::read_dir(out) else {
        return Ok(());
    };
    // A set holds a handful of references (one per scale and kind).
    for e in entries
        .flatten()
        .take(gloam_io::output_set::MAX_SET_ENTRIES)
    {
        let name = e.file_name();
        let Some(n) = name.to_str() else { continue };
        let cached = n.starts_with("reference") && (n.ends_with(".npy") || n.ends_with(".json"));
        if cached && e.file_type().is_ok_and(|t| t.is_file()) {
            std::fs::copy(e.path(), dir.join(n))
                .map_err(BenchError::io("copying the cached reference", &e.path()))?;
        }
    }
    Ok(())
}

/// The sweep, its files written into `dir` (the set being written) and
/// named by where they are published (`args.out`).
fn sweep(
    args: &AccuracyOptions,
    dir: &Path,
    t_start: Instant,
    (scene_path, scene): (&Path, &Scene),
    guard: &gloam_io::RunGuard,
) -> Result<AccuracyReport, BenchError> {
    let scene_path = scene_path.to_path_buf();
    let scene = scene.clone();
    let budget = args.budget_s;
    let elapsed = || t_start.elapsed().as_secs_f64();
    // The resolution axis first: all of the budget with
    // --resolution-only, else half of it (the sweep takes what is left).
    let axis = match &args.resolution_scales {
        Some(scales) => {
            let deadline = if args.resolution_only {
                budget
            } else {
                0.5 * budget
            };
            let (out, threads) = (dir, args.threads);
            let axis =
                resolution::run(&scene_path, &scene, out, threads, scales, t_start, deadline)?;
            if args.resolution_only {
                return resolution_only_report(args, dir, &scene_path, axis, elapsed());
            }
            Some(axis)
        }
        None => None,
    };
    let base_tracer = Tracer::new(&scene, &with(Estimator::Analytic, args.threads, |_| {}))?;

    // Scenes: [0] the scene, [1] a line-spectrum variant for the spectral
    // sweep when the scene's own sources are smooth and the truth is exact.
    let obstacle = closed_form_obstacle(&scene);
    let mut scenes = vec![scene.clone()];
    let line_variant = if has_lines(&scene) {
        None
    } else if obstacle.is_none() {
        mercury_variant(&scene).map(|v| {
            scenes.push(v);
            1
        })
    } else {
        None
    };
    let mut truths: Vec<Truth> = Vec::new();
    match &obstacle {
        None => {
            for s in &scenes {
                let t = Tracer::new(s, &with(Estimator::Analytic, args.threads, |_| {}))?;
                truths.push(closed_form_truth(s, &t));
            }
        }
        Some(_) => {
            // Reference spp: about a third of the budget, from a timed
            // pilot of the reference settings on 64 pixels (256 … 16384).
            let t0 = Instant::now();
            let probe = reference_settings(args.threads, 16);
            let t = Tracer::new(&scene, &probe)?;
            let (w, h) = (scene.camera.width, scene.camera.height);
            (0..64u32)
                .into_par_iter()
                .map(|k| t.probe_pixel((k * 37 + 5) % w, (k * 53 + 3) % h))
                .collect::<Result<Vec<_>, _>>()?;
            let per_sample_px = t0.elapsed().as_secs_f64().max(1e-3) / (64.0 * 16.0);
            let spp = ((0.35 * budget / (per_sample_px * REFERENCE_PIXELS as f64)) as u32)
                .clamp(256, 16384)
                / 2
                * 2;
            // The whole-light truth of [0], then that of the direct-only
            // copy (index 1: no line variant here).
            scenes.push(scene.clone());
            let kinds = [
                (spp, ReferenceKind::WholeLight),
                (DIRECT_REFERENCE_SPP, ReferenceKind::DirectOnly),
            ];
            for (spp, kind) in kinds {
                let (out, threads) = (dir, args.threads);
                let truth =
                    reference_truth(&scene_path, &scene, &base_tracer, out, threads, spp, kind);
                truths.push(truth?);
            }
        }
    }
    // The notes name a cached reference where the set is published.
    let (staged, published) = (dir.display().to_string(), args.out.display().to_string());
    for t in &mut truths {
        t.note = t.note.replace(&staged, &published);
    }
    let truth_seconds: f64 = truths.iter().map(|t| t.seconds).sum();
    let mask_px = truths[0].mask.iter().filter(|&&m| m).count();
    ensure_valid!(
        mask_px > 0,
        "no pixel of {} sees a non-emitting surface: nothing to measure",
        scene_path.display()
    );

    let mut rows: Vec<Row> = Vec::new();
    // Time per spp unit, per estimator (predicts the next run's cost).
    let mut cost: BTreeMap<String, f64> = BTreeMap::new();
    // Runs only when `limit` (s since the start) is not predicted to pass.
    let mut exec = |plan: &Plan, rows: &mut Vec<Row>, limit: f64| -> Result<bool, BenchError> {
        let key = plan.estimator.to_string();
        let predicted = cost.get(&key).map_or(0.0, |c| c * plan.settings.spp as f64);
        if elapsed() + predicted > limit {
            return Ok(false);
        }
        let si = plan.scene.unwrap_or(0);
        let (s, truth) = (&scenes[si], &truths[si.min(truths.len() - 1)]);
        let t0 = Instant::now();
        let tracer = Tracer::new(s, &plan.settings)?;
        let prepare_s = t0.elapsed().as_secs_f64();
        let out = tracer.render(&|_, _| {})?;
        let dt = t0.elapsed().as_secs_f64();
        if plan.setting == "spp" {
            cost.insert(key.clone(), dt / plan.settings.spp as f64);
        }
        let e = errors(&out.radiance, truth);
        let (within_2x_target, within_2x_estimate) = match plan.settings.target_error {
            Some(target) => {
                let (a, b) = error_coverage(&out.radiance, &out.std_error, truth, target);
                (Some(a), Some(b))
            }
            None => (None, None),
        };
        rows.push(Row {
            estimator: key,
            setting: plan.setting.to_string(),
            value: plan.value.clone(),
            spp: out.spp.iter().map(|&n| n as u64).sum::<u64>() as u32
                / out.spp.len().max(1) as u32,
            time_s: dt,
            rel_rms_error: e.energy,
            max_rel_error: e.max_rel,
            pixel_rms_error: e.pixel,
            pixel_rms_error_as_targeted: e.pixel_as_targeted,
            within_2x_target,
            within_2x_estimate,
            prepare_s,
        });
        Ok(true)
    };
    let ladder_plan = |est: Estimator, spp: u32| Plan {
        estimator: est,
        setting: "spp",
        value: spp.to_string(),
        settings: with(est, args.threads, |s| s.spp = spp),
        scene: None,
    };
    let mut others = other_plans(args.threads, line_variant);
    if obstacle.is_some() {
        others.extend(direct_only_plans(args.threads, 1));
    }
    let planned = LADDER.len() * ESTIMATORS.len() + others.len() + 2;

    // 1. Each estimator's spp ladder, rung by rung across estimators, within
    //    60 % of the budget; an estimator whose next rung does not fit stops
    //    climbing.
    let mut next_rung = [0usize; 3];
    for (k, spp) in LADDER.iter().enumerate() {
        for (i, est) in ESTIMATORS.iter().enumerate() {
            // Every ladder's first rung runs whatever the budget (a loaded
            // machine can spend it on the truth alone), so each estimator
            // has a figure.
            let limit = if k == 0 { f64::INFINITY } else { 0.6 * budget };
            if next_rung[i] == k && exec(&ladder_plan(*est, *spp), &mut rows, limit)? {
                next_rung[i] = k + 1;
            }
        }
    }
    // 2. The other settings at the default spp.
    for plan in &others {
        exec(plan, &mut rows, budget)?;
    }
    // 3. Sensor noise on/off (the camera chain on the default render).
    if elapsed() < budget {
        rows.extend(sensor_noise_rows(&scene, args.threads, &truths[0])?);
    }
    // 4. The rest of the ladders with what is left.
    for (k, spp) in LADDER.iter().enumerate() {
        for (i, est) in ESTIMATORS.iter().enumerate() {
            if next_rung[i] == k && exec(&ladder_plan(*est, *spp), &mut rows, budget)? {
                next_rung[i] = k + 1;
            }
        }
    }
    let skipped = planned.saturating_sub(rows.len());
    // 4b. Mitsuba 3 side by side, with its own time (it never shortens
    //     gloam's rows).
    let mitsuba3 = mitsuba_rows(
        args,
        dir,
        &scene,
        obstacle.is_some(),
        &truths,
        &mut rows,
        guard,
    );
    // 5. The effect plan against every effect forced on.
    let effect_plan = if args.all_effects {
        Some(effect_plan_saving(&scenes[0], args.threads, &truths[0])?)
    } else {
        None
    };

    // Outputs.
    let csv_path = args.out.join("accuracy.csv");
    let mut csv = String::from(
        "estimator,setting,value,spp,time_s,rel_rms_error,max_rel_error,pixel_rms_error,prepare_s\n",
    );
    for r in &rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{:.6},{:.6e},{:.6e},{:.6e},{:.6}",
            r.estimator,
            r.setting,
            r.value,
            r.spp,
            r.time_s,
            r.rel_rms_error,
            r.max_rel_error,
            r.pixel_rms_error,
            r.prepare_s
        );
    }
    write_atomic(&dir.join("accuracy.csv"), csv.as_bytes())?;

    let ladder = |est: &str| -> Vec<&Row> {
        rows.iter()
            .filter(|r| r.estimator == est && r.setting == "spp")
            .collect()
    };
    let mut t1 = BTreeMap::new();
    let mut t01 = BTreeMap::new();
    let mut p1 = BTreeMap::new();
    let mut p01 = BTreeMap::new();
    let mut best = BTreeMap::new();
    for est in ESTIMATORS {
        let name = est.to_string();
        let l = ladder(&name);
        t1.insert(name.clone(), time_to(&l, 0.01, |r| r.rel_rms_error));
        t01.insert(name.clone(), time_to(&l, 0.001, |r| r.rel_rms_error));
        p1.insert(name.clone(), time_to(&l, 0.01, |r| r.pixel_rms_error));
        p01.insert(name.clone(), time_to(&l, 0.001, |r| r.pixel_rms_error));
        best.insert(
            name,
            l.iter()
                .filter(|r| r.rel_rms_error.is_finite())
                .min_by(|a, b| a.rel_rms_error.total_cmp(&b.rel_rms_error))
                .map(|r| (r.rel_rms_error, r.time_s)),
        );
    }

    let adaptive: Vec<&Row> = rows
        .iter()
        .filter(|r| r.setting == "target_error")
        .collect();
    // gloam's own direct-only rows (Mitsuba's have their own section).
    let direct_spp: Vec<&Row> = rows
        .iter()
        .filter(|r| r.setting == "direct_only_spp" && r.estimator != MITSUBA)
        .collect();
    let direct_adaptive: Vec<&Row> = rows
        .iter()
        .filter(|r| r.setting == "direct_only_target_error")
        .collect();
    let direct_only = (!direct_spp.is_empty() || !direct_adaptive.is_empty()).then(|| {
        serde_json::json!({
            "truth": truths.get(1).map(|t| t.note.clone()),
            "time_to_1pct_pixel_s": time_to(&direct_spp, 0.01, |r| r.pixel_rms_error),
            "time_to_1pct_pixel_adaptive_s": time_to(&direct_adaptive, 0.01, |r| r.pixel_rms_error),
            "time_to_1pct_pixel_floor_s": time_to(&direct_spp, 0.01, |r| r.pixel_rms_error_as_targeted),
            "time_to_1pct_pixel_floor_adaptive_s": time_to(&direct_adaptive, 0.01, |r| r.pixel_rms_error_as_targeted),
            "goal_s_at_0_01": 2.6,
            "mitsuba3_multijitter_s_at_0_01": 5.3,
            "rows": direct_spp.iter().chain(&direct_adaptive).map(|r| serde_json::json!({
                "setting": r.setting,
                "value": r.value,
                "mean_spp": r.spp,
                "time_s": r.time_s,
                "prepare_s": r.prepare_s,
                "pixel_rms_error": r.pixel_rms_error,
                "pixel_rms_error_as_targeted": r.pixel_rms_error_as_targeted,
                "achieved_over_asked": r.setting.ends_with("target_error")
                    .then(|| r.value.parse::<f64>().ok())
                    .flatten()
                    .map(|t| r.pixel_rms_error_as_targeted / t),
                "rel_rms_error": r.rel_rms_error,
                "within_2x_estimate": r.within_2x_estimate,
            })).collect::<Vec<_>>(),
        })
    });
    let png_path = args.out.join("accuracy.png");
    plot(&dir.join("accuracy.png"), &scene_path, &rows)?;

    let md_path = args.out.join("summary.md");
    let summary = Summary {
        time_to_1pct_s: t1,
        time_to_0_1pct_s: t01,
        time_to_1pct_pixel_s: p1,
        time_to_0_1pct_pixel_s: p01,
        target_error: rows
            .iter()
            .filter(|r| r.setting == "target_error")
            .map(|r| {
                serde_json::json!({
                    "target": r.value.parse::<f64>().ok(),
                    "time_s": r.time_s,
                    "prepare_s": r.prepare_s,
                    "sampling_s": r.time_s - r.prepare_s,
                    "mean_spp": r.spp,
                    "pixel_rms_error": r.pixel_rms_error,
                    "pixel_rms_error_as_targeted": r.pixel_rms_error_as_targeted,
                    "achieved_over_asked": r.value.parse::<f64>().ok()
                        .map(|t| r.pixel_rms_error_as_targeted / t),
                    "rel_rms_error": r.rel_rms_error,
                    "within_2x_target": r.within_2x_target,
                    "within_2x_estimate": r.within_2x_estimate,
                    "goal_s_at_0_01": 9.0,
                    "mitsuba3_multijitter_s_at_0_01": 90.0,
                })
            })
            .collect(),
        time_to_1pct_pixel_adaptive_s: time_to(&adaptive, 0.01, |r| r.pixel_rms_error),
        time_to_0_1pct_pixel_adaptive_s: time_to(&adaptive, 0.001, |r| r.pixel_rms_error),
        mitsuba3: side_by_side_summary(mitsuba3, &rows),
        direct_only,
        scene: scene_path.display().to_string(),
        truth: truths[0].note.clone(),
        truth_seconds,
        runs: rows.len(),
        skipped_for_budget: skipped,
        budget_s: budget,
        elapsed_s: elapsed(),
        over_budget_s: (elapsed() - budget).max(0.0),
        best,
        effect_plan,
        spectral_sweep: if line_variant.is_some() {
            "a copy of the scene with its emitters radiating clear mercury (lines), same first-band radiance".into()
        } else {
            "the scene itself".into()
        },
        resolution: axis.as_ref().map(|a| a.rows.clone()),
        resolution_skipped: axis.as_ref().map(|a| a.skipped.clone()),
        csv: csv_path.display().to_string(),
        png: png_path.display().to_string(),
        summary_md: md_path.display().to_string(),
    };
    let mut markdown = summary_markdown(&summary, &rows, truths[0].kind, mask_px);
    if let Some(a) = &axis {
        markdown.push_str(&resolution::markdown(a));
    }
    write_atomic(&dir.join("summary.md"), markdown.as_bytes())?;
    Ok(AccuracyReport { summary, markdown })
}

/// The report of `--resolution-only`: the resolution axis alone.
fn resolution_only_report(
    args: &AccuracyOptions,
    dir: &Path,
    scene_path: &Path,
    axis: resolution::ResolutionAxis,
    elapsed_s: f64,
) -> Result<AccuracyReport, BenchError> {
    let md_path = args.out.join("summary.md");
    let summary = Summary {
        time_to_1pct_s: BTreeMap::new(),
        time_to_0_1pct_s: BTreeMap::new(),
        time_to_1pct_pixel_s: BTreeMap::new(),
        time_to_0_1pct_pixel_s: BTreeMap::new(),
        target_error: Vec::new(),
        time_to_1pct_pixel_adaptive_s: None,
        time_to_0_1pct_pixel_adaptive_s: None,
        direct_only: None,
        mitsuba3: serde_json::json!({ "ran": false, "why": "--resolution-only" }),
        scene: scene_path.display().to_string(),
        truth: "a truth per resolution scale (see `resolution`)".into(),
        truth_seconds: axis.rows.iter().map(|r| r.truth_s).sum(),
        runs: axis.rows.len(),
        skipped_for_budget: axis.skipped.len(),
        budget_s: args.budget_s,
        elapsed_s,
        over_budget_s: (elapsed_s - args.budget_s).max(0.0),
        best: BTreeMap::new(),
        effect_plan: None,
        spectral_sweep: String::new(),
        resolution: Some(axis.rows.clone()),
        resolution_skipped: Some(axis.skipped.clone()),
        csv: String::new(),
        png: String::new(),
        summary_md: md_path.display().to_string(),
    };
    let mut markdown = format!(
        "# Accuracy against resolution: `{}`\n\n{} of {} scales in {elapsed_s:.1} s of a {:.0} s budget (`--resolution-only`: the rest of the sweep skipped){}.\n",
        summary.scene,
        axis.rows.len(),
        axis.rows.len() + axis.skipped.len(),
        args.budget_s,
        if summary.over_budget_s > 0.05 {
            format!(
                "; {:.1} s past the budget: a scale starts when its predicted time fits what is left, the first (and one after a render too small to predict from) whatever the budget",
                summary.over_budget_s
            )
        } else {
            String::new()
        }
    );
    markdown.push_str(&resolution::markdown(&axis));
    write_atomic(&dir.join("summary.md"), markdown.as_bytes())?;
    Ok(AccuracyReport { summary, markdown })
}

/// Sensor noise on/off: the Gen III ICCD chain on the default render scaled
/// to starlight (5 pe/pixel/frame at the brightest counted pixel). The
/// error is that of the frame against the noise-free frame, relative to
/// the mean signal above black.
fn sensor_noise_rows(
    scene: &Scene,
    threads: Option<usize>,
    truth: &Truth,
) -> Result<Vec<Row>, BenchError> {
    let out =
        Tracer::new(scene, &with(Estimator::Analytic, threads, |_| {}))?.render(&|_, _| {})?;
    let img = out.radiance.index_axis(Axis(0), 0);
    let max = img
        .indexed_iter()
        .filter(|(ix, _)| truth.mask[*ix])
        .map(|(_, &v)| v)
        .fold(0.0, f64::max)
        .max(1e-300);
    // (The analytic estimator's control variate can leave a pixel slightly
    // negative in penumbra; the sensor takes no negative input.)
    let pe = img.mapv(|v| (v / max * 5.0).clamp(0.0, 50.0));
    let mut frames = Vec::new();
    let mut times = Vec::new();
    for noise in [false, true] {
        let mut cam =
            gloam_sensor::Camera::from_preset_or_file("gen3-gaas-iccd", &gloam_io::ReadLog::off())?;
        cam.set_override_gain(Some(30.0))?;
        cam.set_noise(noise);
        let t0 = Instant::now();
        let f = cam.capture_photoelectrons(pe.view())?;
        times.push(t0.elapsed().as_secs_f64());
        let black = cam.chain().black_dn(30.0);
        frames.push((f, black));
    }
    let (clean, black) = &frames[0];
    let (noisy, _) = &frames[1];
    let mut se = 0.0;
    let mut sig = 0.0;
    let mut max_rel: f64 = 0.0;
    let mut n = 0usize;
    for ((ix, &m), (&a, &b)) in truth
        .mask
        .indexed_iter()
        .zip(clean.pixels.iter().zip(noisy.pixels.iter()))
    {
        let _ = ix;
        if !m {
            continue;
        }
        let s = a as f64 - black;
        se += (b as f64 - a as f64).powi(2);
        sig += s;
        n += 1;
        if s > 1.0 {
            max_rel = max_rel.max((b as f64 - a as f64).abs() / s);
        }
    }
    let mean_sig = (sig / n.max(1) as f64).max(1e-300);
    let rms = (se / n.max(1) as f64).sqrt() / mean_sig;
    Ok(vec![
        Row {
            estimator: "sensor".into(),
            setting: "noise".into(),
            value: "off".into(),
            spp: out.settings.spp,
            time_s: times[0],
            rel_rms_error: 0.0,
            max_rel_error: 0.0,
            pixel_rms_error: 0.0,
            pixel_rms_error_as_targeted: 0.0,
            within_2x_target: None,
            within_2x_estimate: None,
            prepare_s: 0.0,
        },
        Row {
            estimator: "sensor".into(),
            setting: "noise".into(),
            value: "on".into(),
            spp: out.settings.spp,
            time_s: times[1],
            rel_rms_error: rms,
            max_rel_error: max_rel,
            pixel_rms_error: rms,
            pixel_rms_error_as_targeted: rms,
            within_2x_target: None,
            within_2x_estimate: None,
            prepare_s: 0.0,
        },
    ])
}

/// Renders with the effect plan and with every effect forced on (the
/// tracer's `all_effects` setting), checks that the images agree
/// within noise and reports the time the plan saves.
fn effect_plan_saving(
    scene: &Scene,
    threads: Option<usize>,
    truth: &Truth,
) -> Result<serde_json::Value, BenchError> {
    let plan = with(Estimator::Analytic, threads, |_| {});
    let mut forced = plan.clone();
    if let Err(e) = forced.set("all_effects", "true") {
        return Ok(serde_json::json!({
            "available": false,
            "reason": format!("gloam-trace has no setting to force every effect on ({e})"),
        }));
    }
    let t0 = Instant::now();
    let a = Tracer::new(scene, &plan)?.render(&|_, _| {})?;
    let ta = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let b = Tracer::new(scene, &forced)?.render(&|_, _| {})?;
    let tb = t0.elapsed().as_secs_f64();
    let ea = errors(&a.radiance, truth).energy;
    let eb = errors(&b.radiance, truth).energy;
    // Agreement: the two renders differ by no more than their own errors
    // (3× the larger, plus 1e-9 for exact renders).
    let diff = {
        let t = Truth {
            kind: "plan",
            image: a.radiance.clone(),
            mask: truth.mask.clone(),
            noise_var: None,
            seconds: 0.0,
            note: String::new(),
        };
        errors(&b.radiance, &t).energy
    };
    let agree = diff <= 3.0 * ea.max(eb) * std::f64::consts::SQRT_2 + 1e-9;
    Ok(serde_json::json!({
        "available": true,
        "plan_s": ta,
        "all_effects_s": tb,
        "saved_s": tb - ta,
        "saved_fraction": 1.0 - ta / tb.max(1e-12),
        "rel_rms_difference": diff,
        "rel_rms_error_plan": ea,
        "rel_rms_error_all_effects": eb,
        "agree_within_noise": agree,
    }))
}

/// The estimator name of the Mitsuba 3 rows.
const MITSUBA: &str = "mitsuba3";

/// Runs the Mitsuba 3 side (when asked, importable and the scene can go
/// over), appends its rungs to `rows` (estimator `mitsuba3`, setting `spp`
/// for the whole light, `direct_only_spp` for direct light only), and
/// returns its note or why it did not run.
fn mitsuba_rows(
    args: &AccuracyOptions,
    dir: &Path,
    scene: &Scene,
    referenced: bool,
    truths: &[Truth],
    rows: &mut Vec<Row>,
    guard: &gloam_io::RunGuard,
) -> serde_json::Value {
    use super::accuracy_mitsuba as mi;
    let skip = |why: String| serde_json::json!({ "ran": false, "why": why });
    if !args.mitsuba {
        return skip("--no-mitsuba".into());
    }
    if let Some(why) = mi::obstacle(scene) {
        return skip(format!("the scene has {why}"));
    }
    if !super::child::mitsuba_importable() {
        return skip("`python3 -c 'import mitsuba'` failed".into());
    }
    // With a path-traced truth, [1] is the direct-only reference; with a
    // closed form, [1] is the line-spectrum variant's.
    let direct = referenced.then(|| truths.get(1)).flatten();
    let limit_s = (0.5 * args.budget_s).max(60.0);
    eprintln!("bench accuracy: Mitsuba 3 side by side (up to {limit_s:.0} s) …");
    match mi::side_by_side(
        scene,
        &dir.join("mitsuba3"),
        (&truths[0], direct),
        limit_s,
        guard,
    ) {
        Ok(side) => {
            for r in &side.rungs {
                let direct_only = r.max_depth == mi::DIRECT_ONLY_DEPTH;
                rows.push(Row {
                    estimator: MITSUBA.into(),
                    setting: if direct_only {
                        "direct_only_spp"
                    } else {
                        "spp"
                    }
                    .into(),
                    value: r.spp.to_string(),
                    spp: r.spp,
                    time_s: r.render_s,
                    rel_rms_error: r.errors.energy,
                    max_rel_error: r.errors.max_rel,
                    pixel_rms_error: r.errors.pixel,
                    pixel_rms_error_as_targeted: r.errors.pixel_as_targeted,
                    within_2x_target: None,
                    within_2x_estimate: None,
                    prepare_s: 0.0,
                });
            }
            serde_json::json!({ "ran": true, "note": side.note })
        }
        Err(e) => skip(gloam_io::output_set::chain(&e)),
    }
}

/// Time to `target` along `rows` (interpolated), or extrapolated from the
/// lowest-error row as error ∝ 1/√time (the Monte Carlo rate); the flag
/// says which.
fn time_to_or_extrapolated(rows: &[&Row], target: f64, metric: RowMetric) -> Option<(f64, bool)> {
    if let Some(t) = time_to(rows, target, metric) {
        return Some((t, false));
    }
    let best = rows
        .iter()
        .filter(|r| metric(r).is_finite() && metric(r) > 0.0)
        .min_by(|a, b| metric(a).total_cmp(&metric(b)))?;
    Some((best.time_s * (metric(best) / target).powi(2), true))
}

/// One error of a row.
type RowMetric = fn(&Row) -> f64;

/// The two per-pixel metrics both ladders are timed on: the plain relative
/// error (`pixel`), which a pixel lit by a sliver no renderer resolves at
/// these sample counts can hold up on its own (the office's direct light
/// has pixels at 0.04 % of the mean), and the error as `--target-error`
/// defines it (`pixel_floor`: each pixel against `max(t, 5 % of the band
/// mean)`, relMSE's ε), the metric the target promises.
/// Each with the name in its time keys (`…_{key}_s`), the suffix of its
/// ratio and extrapolation keys (the plain metric keeps the original
/// keys), and its label in `summary.md`.
const PIXEL_METRICS: [PixelMetric; 2] = [
    PixelMetric {
        key: "pixel",
        suffix: "",
        label: "plain",
        of: |r| r.pixel_rms_error,
    },
    PixelMetric {
        key: "pixel_floor",
        suffix: "_floor",
        label: "dark floor (as targeted)",
        of: |r| r.pixel_rms_error_as_targeted,
    },
];

/// A per-pixel metric of [`PIXEL_METRICS`].
struct PixelMetric {
    key: &'static str,
    suffix: &'static str,
    label: &'static str,
    of: RowMetric,
}

/// Both ladders' times to 1 % and 0.1 % per-pixel error and the ratio
/// Mitsuba / gloam, whole light and direct only.
fn side_by_side_summary(mut side: serde_json::Value, rows: &[Row]) -> serde_json::Value {
    if side["ran"] != serde_json::Value::Bool(true) {
        return side;
    }
    let pick = |est: &str, setting: &str| -> Vec<&Row> {
        rows.iter()
            .filter(|r| r.estimator == est && r.setting == setting)
            .collect()
    };
    let analytic = Estimator::Analytic.to_string();
    for (key, mitsuba, gloam_adaptive, gloam_spp) in [
        (
            "whole_light",
            pick(MITSUBA, "spp"),
            pick(&analytic, "target_error"),
            pick(&analytic, "spp"),
        ),
        (
            "direct_only",
            pick(MITSUBA, "direct_only_spp"),
            pick(&analytic, "direct_only_target_error"),
            pick(&analytic, "direct_only_spp"),
        ),
    ] {
        if mitsuba.is_empty() {
            continue;
        }
        let mut v = serde_json::Map::new();
        for ((target, label), metric) in [(0.01, "1pct"), (0.001, "0_1pct")]
            .into_iter()
            .flat_map(|t| PIXEL_METRICS.iter().map(move |m| (t, m)))
        {
            let (name, sfx) = (metric.key, metric.suffix);
            let metric = metric.of;
            let m = time_to_or_extrapolated(&mitsuba, target, metric);
            // gloam's best of its two ways to an error: asking for it
            // (target-error rows) or a fixed spp ladder.
            let g = [
                time_to_or_extrapolated(&gloam_adaptive, target, metric),
                time_to_or_extrapolated(&gloam_spp, target, metric),
            ]
            .into_iter()
            .flatten()
            .min_by(|a, b| a.0.total_cmp(&b.0));
            for (side, t) in [("mitsuba3", m), ("gloam", g)] {
                let (secs, extrapolated) = (t.map(|x| x.0), t.map(|x| x.1));
                v.insert(format!("{side}_time_to_{label}_{name}_s"), secs.into());
                v.insert(
                    format!("{side}_{label}{sfx}_extrapolated"),
                    extrapolated.into(),
                );
            }
            let ratio = m.zip(g).map(|(m, g)| m.0 / g.0.max(1e-12));
            v.insert(format!("ratio_{label}{sfx}"), ratio.into());
        }
        v.insert(
            "ladder".into(),
            mitsuba
                .iter()
                .map(|r| {
                    serde_json::json!({
                        "spp": r.spp,
                        "render_s": r.time_s,
                        "pixel_rms_error": r.pixel_rms_error,
                        "pixel_rms_error_as_targeted": r.pixel_rms_error_as_targeted,
                        "rel_rms_error": r.rel_rms_error,
                    })
                })
                .collect(),
        );
        side[key] = serde_json::Value::Object(v);
    }
    side
}

/// `; N s past the budget: …` when the run went past it, else nothing.
fn over_budget_note(over_s: f64) -> String {
    if over_s > 0.05 {
        format!("; {over_s:.1} s past the budget: {BUDGET_EXEMPT}")
    } else {
        String::new()
    }
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or("not reached".into(), |t| format!("{t:.3} s"))
}

fn summary_markdown(s: &Summary, rows: &[Row], truth_kind: &str, mask_px: usize) -> String {
    let mut m = String::new();
    let _ = writeln!(m, "# Accuracy against time: `{}`\n", s.scene);
    let _ = writeln!(
        m,
        "Truth: {} ({truth_kind}; {:.1} s). Error over {mask_px} pixels that see non-emitting surfaces: \
         `rel_rms = sqrt(Σ(x−t)²/Σt²)`, `max_rel` over pixels above 1 % of the band mean. \
         {} runs in {:.1} s of a {:.0} s budget ({} skipped for the budget){}.\n",
        s.truth,
        s.truth_seconds,
        s.runs,
        s.elapsed_s,
        s.budget_s,
        s.skipped_for_budget,
        over_budget_note(s.over_budget_s)
    );
    let _ = writeln!(
        m,
        "## Time to reach an RMS error (spp ladder, log–log interpolation)\n"
    );
    let _ = writeln!(
        m,
        "| estimator | 1 % energy | 0.1 % energy | 1 % per pixel | 0.1 % per pixel | lowest rel RMS error (at time) |"
    );
    let _ = writeln!(m, "|---|---|---|---|---|---|");
    for est in ESTIMATORS {
        let e = est.to_string();
        let best = s.best.get(&e).copied().flatten();
        let _ = writeln!(
            m,
            "| {e} | {} | {} | {} | {} | {} |",
            fmt_opt(s.time_to_1pct_s.get(&e).copied().flatten()),
            fmt_opt(s.time_to_0_1pct_s.get(&e).copied().flatten()),
            fmt_opt(s.time_to_1pct_pixel_s.get(&e).copied().flatten()),
            fmt_opt(s.time_to_0_1pct_pixel_s.get(&e).copied().flatten()),
            best.map_or("–".into(), |(err, t)| format!("{err:.3e} ({t:.3} s)"))
        );
    }
    if !s.target_error.is_empty() {
        let _ = writeln!(
            m,
            "\n## Renders to a stated error (`--target-error`)\n\n\
             | target | time (s) | of which prepare (s) | mean spp | per-pixel RMS error | as targeted (floor) | achieved / asked | energy RMS error | within 2× target | within 2× own estimate |\n|---|---|---|---|---|---|---|---|---|---|"
        );
        for t in &s.target_error {
            let f = |k: &str| t[k].as_f64().unwrap_or(f64::NAN);
            let _ = writeln!(
                m,
                "| {} | {:.2} | {:.2} | {} | {:.3e} | {:.3e} | {:.2} | {:.3e} | {:.1} % | {:.1} % |",
                f("target"),
                f("time_s"),
                f("prepare_s"),
                t["mean_spp"],
                f("pixel_rms_error"),
                f("pixel_rms_error_as_targeted"),
                f("achieved_over_asked"),
                f("rel_rms_error"),
                100.0 * f("within_2x_target"),
                100.0 * f("within_2x_estimate")
            );
        }
        let _ = writeln!(
            m,
            "\nTime to 1 % per-pixel error along these rows: {}. Goal on the office room, 2 threads: ≤ 9 s (Mitsuba 3 multijitter: ~90 s); achieved / asked within 0.8–1.2, the error as targeted (each pixel against max(t, the dark floor)).",
            fmt_opt(s.time_to_1pct_pixel_adaptive_s)
        );
    }
    if let Some(d) = &s.direct_only {
        let _ = writeln!(
            m,
            "\n## Direct light only (`indirect = off`, against the direct-only reference)\n\n\
             | setting | value | mean spp | time (s) | per-pixel RMS error | as targeted (floor) | achieved / asked | energy RMS error | within 2× own estimate |\n|---|---|---|---|---|---|---|---|---|"
        );
        for r in d["rows"].as_array().into_iter().flatten() {
            let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
            let _ = writeln!(
                m,
                "| {} | {} | {} | {:.2} | {:.3e} | {:.3e} | {} | {:.3e} | {} |",
                r["setting"].as_str().unwrap_or(""),
                r["value"].as_str().unwrap_or(""),
                r["mean_spp"],
                f("time_s"),
                f("pixel_rms_error"),
                f("pixel_rms_error_as_targeted"),
                r["achieved_over_asked"]
                    .as_f64()
                    .map_or("–".into(), |x| format!("{x:.2}")),
                f("rel_rms_error"),
                r["within_2x_estimate"]
                    .as_f64()
                    .map_or("–".into(), |x| format!("{:.1} %", 100.0 * x))
            );
        }
        let _ = writeln!(
            m,
            "\nTime to 1 % per-pixel error: {} along the spp ladder, {} along the target-error rows; with the dark floor (as targeted): {} and {}. Goal: ≤ 2.6 s (Mitsuba 3 multijitter: 5.3 s).",
            fmt_opt(d["time_to_1pct_pixel_s"].as_f64()),
            fmt_opt(d["time_to_1pct_pixel_adaptive_s"].as_f64()),
            fmt_opt(d["time_to_1pct_pixel_floor_s"].as_f64()),
            fmt_opt(d["time_to_1pct_pixel_floor_adaptive_s"].as_f64())
        );
    }
    mitsuba_markdown(&mut m, &s.mitsuba3);
    let a = s.time_to_1pct_s.get("analytic").copied().flatten();
    let d = s.time_to_1pct_s.get("dirsig2001").copied().flatten();
    let _ = writeln!(
        m,
        "\n1 % RMS: analytic (default) vs dirsig2001 at its defaults: {}\n",
        match (a, d) {
            (Some(a), Some(d)) => format!("{:.1}× faster", d / a),
            (Some(_), None) => "dirsig2001 never reached 1 % within its spp ladder/budget".into(),
            _ => "analytic did not reach 1 %".into(),
        }
    );
    if let Some(p) = &s.effect_plan {
        let _ = writeln!(
            m,
            "## Effect plan\n\n```json\n{}\n```\n",
            serde_json::to_string_pretty(p).unwrap_or_default()
        );
    }
    let _ = writeln!(m, "## All runs\n");
    let _ = writeln!(
        m,
        "| estimator | setting | value | spp | time (s) | rel RMS error | per-pixel RMS error | max rel error |"
    );
    let _ = writeln!(m, "|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            m,
            "| {} | {} | {} | {} | {:.3} | {:.3e} | {:.3e} | {:.3e} |",
            r.estimator,
            r.setting,
            r.value,
            r.spp,
            r.time_s,
            r.rel_rms_error,
            r.pixel_rms_error,
            r.max_rel_error
        );
    }
    let _ = writeln!(m, "\nFiles: `{}`, `{}`.", s.csv, s.png);
    m
}

/// The side-by-side section of `summary.md`: both ladders' times to 1 %
/// and 0.1 % per-pixel error and the ratio.
fn mitsuba_markdown(m: &mut String, side: &serde_json::Value) {
    let _ = writeln!(m, "\n## Side by side with Mitsuba 3\n");
    if side["ran"] != serde_json::Value::Bool(true) {
        let _ = writeln!(m, "Not run: {}.", side["why"].as_str().unwrap_or("unknown"));
        return;
    }
    let _ = writeln!(m, "{}.\n", side["note"].as_str().unwrap_or(""));
    let secs = |v: &serde_json::Value, k: &str, x: &str| -> String {
        let t = v[k].as_f64();
        let ex = v[x].as_bool() == Some(true);
        t.map_or("–".into(), |t| {
            format!("{t:.2} s{}", if ex { " (extrapolated)" } else { "" })
        })
    };
    let _ = writeln!(
        m,
        "| light | per-pixel metric | Mitsuba 3 to 1 % | gloam to 1 % | ratio | Mitsuba 3 to 0.1 % | gloam to 0.1 % | ratio |\n|---|---|---|---|---|---|---|---|"
    );
    for key in ["whole_light", "direct_only"] {
        let v = &side[key];
        if v.is_null() {
            continue;
        }
        let ratio = |k: &str| v[k].as_f64().map_or("–".into(), |r| format!("{r:.1}×"));
        for PixelMetric {
            key: metric,
            suffix: sfx,
            label: what,
            ..
        } in &PIXEL_METRICS
        {
            let k = |side: &str, label: &str| format!("{side}_time_to_{label}_{metric}_s");
            let x = |side: &str, label: &str| format!("{side}_{label}{sfx}_extrapolated");
            let _ = writeln!(
                m,
                "| {key} | {what} | {} | {} | {} | {} | {} | {} |",
                secs(v, &k("mitsuba3", "1pct"), &x("mitsuba3", "1pct")),
                secs(v, &k("gloam", "1pct"), &x("gloam", "1pct")),
                ratio(&format!("ratio_1pct{sfx}")),
                secs(v, &k("mitsuba3", "0_1pct"), &x("mitsuba3", "0_1pct")),
                secs(v, &k("gloam", "0_1pct"), &x("gloam", "0_1pct")),
                ratio(&format!("ratio_0_1pct{sfx}")),
            );
        }
    }
    let _ = writeln!(
        m,
        "\nMitsuba 3's ladders (render time only; per-pixel RMS relative error against the same truth as gloam's rows, the truth's noise subtracted, plain and with the dark floor):\n\n| light | spp | time (s) | per-pixel RMS error | as targeted (floor) | energy RMS error |\n|---|---|---|---|---|---|"
    );
    for key in ["whole_light", "direct_only"] {
        for r in side[key]["ladder"].as_array().into_iter().flatten() {
            let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
            let _ = writeln!(
                m,
                "| {key} | {} | {:.2} | {:.3e} | {:.3e} | {:.3e} |",
                r["spp"],
                f("render_s"),
                f("pixel_rms_error"),
                f("pixel_rms_error_as_targeted"),
                f("rel_rms_error")
            );
        }
    }
    let _ = writeln!(
        m,
        "\ngloam's time to an error is the better of its target-error rows and its analytic spp ladder (whole light), or of the direct-only rows; a time not reached within the ladder is extrapolated from its lowest-error row as error ∝ 1/√time."
    );
}

/// Error against time, log–log, one curve per estimator's spp ladder, the
/// other settings as points, the Pareto front marked.
fn plot(path: &Path, scene: &Path, rows: &[Row]) -> Result<(), BenchError> {
    use gloam_calib::plot::{Mark, Scale, Series, xy_plot_scaled};
    // An exact result (error 0) is drawn at 1e-9 rather than dropped.
    let lg = |r: &Row| (r.time_s.max(1e-6), r.rel_rms_error.max(1e-9));
    let mut series = Vec::new();
    for est in ESTIMATORS {
        let e = est.to_string();
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.estimator == e && r.setting == "spp" && r.rel_rms_error.is_finite())
            .map(lg)
            .collect();
        if !pts.is_empty() {
            series.push(Series::new(
                &format!("{e} (spp ladder)"),
                pts,
                Mark::LinePoints,
            ));
        }
    }
    let others: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.setting != "spp" && r.estimator != "sensor" && r.rel_rms_error.is_finite())
        .map(lg)
        .collect();
    if !others.is_empty() {
        series.push(Series::new("other settings", others, Mark::Points));
    }
    let front: Vec<(f64, f64)> = pareto(rows)
        .into_iter()
        .map(|(t, e)| (t.max(1e-6), e.max(1e-9)))
        .collect();
    if !front.is_empty() {
        series.push(Series::new("Pareto front", front, Mark::Line));
    }
    let name = scene
        .parent()
        .and_then(|p| p.file_name())
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| scene.display().to_string());
    xy_plot_scaled(
        path,
        &format!("accuracy vs time: {name}"),
        ("wall time (s)", Scale::Log10),
        ("relative RMS error", Scale::Log10),
        &series,
    )
    .map_err(|e| BenchError::Plot {
        path: path.to_path_buf(),
        why: e.to_string(),
    })
}

#[cfg(test)]
mod set_tests {
    use super::carry_cached_references;

    /// Only the cached references move into the new set, byte for byte:
    /// not the previous sweep's other files, not directories.
    #[test]
    fn the_cached_references_and_nothing_else_are_carried_over() {
        let d = tempfile::tempdir().unwrap();
        let (out, staged) = (d.path().join("out"), d.path().join("staged"));
        std::fs::create_dir_all(out.join("reference-dir.json")).unwrap();
        std::fs::create_dir(&staged).unwrap();
        let files = [
            ("reference.npy", "a"),
            ("reference.json", "b"),
            ("reference-direct.json", "c"),
            ("reference-scale-0.5.npy", "d"),
            ("accuracy.csv", "e"),
            ("reference.txt", "f"),
        ];
        for (n, t) in files {
            std::fs::write(out.join(n), t).unwrap();
        }
        carry_cached_references(&out, &staged).unwrap();
        let mut got: Vec<(String, String)> = std::fs::read_dir(&staged)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                let n = e.file_name().into_string().unwrap();
                (n, std::fs::read_to_string(e.path()).unwrap())
            })
            .collect();
        got.sort();
        let mut want: Vec<(String, String)> = files[..4]
            .iter()
            .map(|(n, t)| (n.to_string(), t.to_string()))
            .collect();
        want.sort();
        assert_eq!(got, want);
        // No previous set: nothing to carry.
        carry_cached_references(&d.path().join("none"), &staged).unwrap();
    }
}
