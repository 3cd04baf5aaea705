//! `gloam render SCENE --out DIR …`: spectral radiance images of a scene.
//!
//! Writes `DIR/radiance.tiff` (float32, one page per band),
//! `DIR/radiance.npy` (float64, band × row × column, W m⁻² sr⁻¹),
//! `DIR/preview.png` (tone-mapped first band, for people) and
//! `DIR/report.json` (settings, effect plan, timings, rays, rays/s, and
//! `target_error_source`: `"default"` when no sampling was named and the
//! render sampled to [`DEFAULT_TARGET_ERROR`], `"given"`, or null for a
//! fixed spp), each atomically. The arguments and their checks are
//! [`gloam_pipeline::cli::RenderArgs`]; the render is [`RenderJob`].

use std::time::Instant;

use gloam_pipeline::camera_goal::CameraGoal;
pub use gloam_pipeline::cli::RenderArgs;
use gloam_pipeline::frames::scene_utc;
use gloam_pipeline::render::RenderJob;
use gloam_pipeline::{DEFAULT_TARGET_ERROR, OutputSet, Provenance, TargetErrorSource};

use super::output::write_atomic;

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    // The wall time the user waits, preparation and writing included.
    let t_start = Instant::now();
    let mut provenance = Provenance::of_this_run();
    // Refused up front when --out is in use; the files appear at once.
    let set = OutputSet::begin(&args.out, args.force, false)?;
    let dir = set.dir().to_path_buf();
    let t_load = Instant::now();
    let scene = gloam_scene::load(&args.scene)?;
    let load_s = t_load.elapsed().as_secs_f64();
    let tile = (args.tile.as_deref())
        .map(gloam_sweep::TileSpec::parse)
        .transpose()?;
    let settings = args.settings.settings()?;
    let (camera, capture) = args.camera.capture(&scene, settings.seed, tile.is_some())?;
    // `--target-error camera[:K]`: each pixel to the camera's own noise.
    let camera_k = args.settings.camera_target();
    if camera_k.is_some() && (capture.is_none() || args.layers) {
        anyhow::bail!(
            "--target-error camera needs a camera (--sensor NAME, or the scene's sensor), the whole image (no --tile) and no --layers"
        );
    }
    // Frames without temporal noise hide no render error: the bound would
    // be the noisy camera's, so the render's noise would show (it was
    // accepted and reported as within the camera's).
    if camera_k.is_some() && capture.as_ref().is_some_and(|c| !c.noise) {
        anyhow::bail!(
            "--target-error camera with --no-noise: frames without temporal noise hide no render error; give --target-error E (a relative error) or --spp N"
        );
    }
    // A tile or a capture keeps the fixed default spp (see with_default_error).
    let whole_image = tile.is_none() && capture.is_none();
    let (settings, target_error_source) = args.settings.with_default_error(settings, whole_image);
    let job = RenderJob {
        camera,
        observer: super::progress::prep_spinner(),
        layers: args.layers,
        ..RenderJob::new(&scene, &settings)
    };
    let prepared = job.prepare()?;
    let prep_s = t_start.elapsed().as_secs_f64();
    let full = prepared.image_size();
    let rows = tile.map(|t| t.rows(full.1)).transpose()?;
    let goal = match (camera_k, &capture) {
        (Some(k), Some(c)) => Some(CameraGoal::new(&prepared, k, c)?),
        _ => None,
    };
    let rendered = match &goal {
        Some(g) => super::progress::render_goal_with_bar(prepared, g)?,
        None => super::progress::render_with_bar(prepared, rows)?,
    };

    let t_write = Instant::now();
    rendered.write_images(&dir)?;
    if let Some(t) = tile {
        let (rows, out) = (rendered.rows.clone(), &rendered.radiance);
        gloam_sweep::tile::write_tile_info(&dir, t, rows, full, &args.scene, out)?;
    }
    let write_s = t_write.elapsed().as_secs_f64();
    let mut report = rendered.report_json(&args.scene, &scene, load_s, write_s);
    report["target_error_source"] = serde_json::to_value(target_error_source)?;
    let camera_target = goal.as_ref().and_then(|g| g.report(&rendered));
    if let Some(t) = &camera_target {
        report["camera_target"] = t.clone();
    }
    // The scene's OBJ, spectrum and instance files were read after the
    // provenance was first taken.
    provenance.add_inputs_read();
    report["provenance"] = serde_json::to_value(&provenance)?;
    let report = serde_json::to_string_pretty(&report)?;
    write_atomic(&dir.join("report.json"), report.as_bytes())?;
    if let Some(layers) = &rendered.layers {
        let mut index = layers.json(settings.seed);
        index["provenance"] = serde_json::to_value(&provenance)?;
        let index = serde_json::to_string_pretty(&index)?;
        write_atomic(&dir.join("layers.json"), index.as_bytes())?;
    }
    if let (Some(capture), Some(detected)) = (&capture, &rendered.detected) {
        for line in capture.run(detected, &dir, Some(&provenance), scene_utc(&scene))? {
            eprintln!("{line}");
        }
        // No path: `dir` is the command's hidden staging directory until
        // the set is published (the line below names the published one).
        let (n, sensor) = (capture.frames, capture.sensor);
        eprintln!("captured {n} frame(s) through '{sensor}'");
    }
    set.publish(&provenance, None)?;
    if target_error_source == Some(TargetErrorSource::Default) {
        let e = &rendered.radiance.error;
        eprintln!(
            "no --spp or --target-error: sampled to the default per-pixel error {:.0} % (--target-error {DEFAULT_TARGET_ERROR}): estimated RMS {:.2} %, mean {:.1} spp; --spp N renders a fixed count",
            100.0 * DEFAULT_TARGET_ERROR,
            100.0
                * e.rel_std_error_rms_target_pixels
                    .unwrap_or(e.rel_std_error_rms),
            e.mean_spp,
        );
    }
    if let Some(t) = &camera_target {
        let f = |k: &str| t[k].as_f64().unwrap_or(f64::NAN);
        eprintln!(
            "--target-error camera:{}: each pixel rendered until its variance is under {:.0} % of the camera's frame variance at gain {:.4}: added {:.1} % (median), {:.1} % (99th percentile); mean {:.1} spp",
            f("k"),
            100.0 * f("asked_added_variance_fraction"),
            f("gain"),
            100.0 * f("added_variance_fraction_median"),
            100.0 * f("added_variance_fraction_p99"),
            f("mean_spp"),
        );
    }
    if let Some(b) = &rendered.radiance.error.bias
        && let Some(band) = b.bands.first()
    {
        eprintln!(
            "radiosity cache bias ({}): {:+.2} % ± {:.2} % of the signal, measured against path tracing at {} pixels (report.json: error.bias); the per-pixel errors above and in stderr.npy are noise only",
            band.band,
            100.0 * band.relative_bias,
            100.0 * band.relative_bias_std_error,
            b.pixels
        );
    }
    let s = &rendered.radiance.stats;
    let total_s = t_start.elapsed().as_secs_f64();
    eprintln!(
        "rendered {}×{}×{} bands in {:.2} s ({} rays, {:.3e} rays/s); {:.2} s in all, {:.2} s ({:.0} %) of it preparation (scene, BVH, pilot, cache) → {}",
        s.width,
        s.height,
        s.bands,
        s.trace_seconds,
        s.rays.total(),
        s.rays_per_second,
        total_s,
        prep_s,
        100.0 * prep_s / total_s.max(1e-9),
        args.out.display()
    );
    Ok(())
}
