//! `gloam render SCENE --out DIR …`: spectral radiance images of a scene.
//!
//! Writes `DIR/radiance.tiff` (float32, one page per band),
//! `DIR/radiance.npy` (float64, band × row × column, W m⁻² sr⁻¹),
//! `DIR/preview.png` (tone-mapped first band, for people) and
//! `DIR/report.json` (settings, effect plan, timings, rays, rays/s), each
//! atomically.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use gloam_trace::Tracer;

use gloam_pipeline::{OutputSet, Provenance};

use super::output::{write_atomic, write_npy, write_npy_u32, write_preview, write_tiff};

#[derive(Args)]
pub struct RenderArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Camera samples per pixel (default 4).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Seed of every random stream (default 0).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Area-source estimator: analytic (default), solid-angle or dirsig2001.
    #[arg(long)]
    pub estimator: Option<String>,
    /// Any setting, KEY=VALUE (repeatable), e.g. --set recursion=2
    /// --set MAX_SOURCE_SAMPLES=200. See `crates/trace/README.md`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Sample each pixel adaptively until its estimated relative standard
    /// error is below this (e.g. 0.01; dark pixels relative to 5 % of the
    /// band mean). Same as `--set target_error=E`.
    #[arg(long, value_name = "E")]
    pub target_error: Option<f64>,
    /// The effect plan's tolerance (default 0.005 of the band signal).
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Also capture the render through this camera (preset name, see
    /// `gloam sensor list`, or a sensor TOML file). Defaults to the scene's
    /// `sensor` entry, if any. Writes `frame-NNNNNN.png` and `frames.jsonl`.
    #[arg(long, value_name = "PRESET_OR_FILE")]
    pub sensor: Option<String>,
    /// Number of frames to capture (AGC and phosphor lag evolve over them;
    /// default 1, at most 100 000). Needs a camera.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    pub frames: Option<u32>,
    /// Manual (override) tube gain: output linear in input flux.
    #[arg(long, conflicts_with = "agc")]
    pub gain: Option<f64>,
    /// Let the camera's AGC servo the gain.
    #[arg(long)]
    pub agc: bool,
    /// Turn the camera's temporal noise off (deterministic mean response).
    #[arg(long)]
    pub no_noise: bool,
    /// `auto`: choose the gain, gate (or exposure time) and ND filter that
    /// put the frame's 99th percentile at 80 % of the camera's range, and
    /// record the choice (report.json `sensor_capture.exposure`).
    #[arg(long, value_name = "auto", value_parser = ["auto"], conflicts_with_all = ["gain", "agc"])]
    pub exposure: Option<String>,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other files).
    #[arg(long)]
    pub force: bool,
    /// Render only tile K of N: rows ⌊(K−1)H/N⌋ to ⌊KH/N⌋ (horizontal
    /// bands), radiance only, plus `tile.json`; `gloam merge` reassembles
    /// the tiles bit-identically. See docs/sweep.md.
    #[arg(long, value_name = "K/N", conflicts_with = "sensor")]
    pub tile: Option<String>,
}

/// Settings from `--set` pairs, then the dedicated flags (shared with the
/// Python package).
pub use gloam_pipeline::render::settings_from;

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let mut provenance = Provenance::of_this_run();
    // Refused up front when --out is in use; the files appear at once.
    let set = OutputSet::begin(&args.out, args.force, false)?;
    let dir = set.dir().to_path_buf();
    let t_load = Instant::now();
    let scene = gloam_scene::load(&args.scene)?;
    let load_s = t_load.elapsed().as_secs_f64();
    let settings = settings_from(
        &args.set,
        args.spp,
        args.seed,
        args.estimator.as_deref(),
        args.threads,
    )?;
    let mut settings = settings;
    for (key, flag, given) in [
        (
            "target_error",
            "--target-error",
            args.target_error.is_some(),
        ),
        ("tolerance", "--tolerance", args.tolerance.is_some()),
    ] {
        if given {
            gloam_pipeline::render::refuse_both(&args.set, key, flag)?;
        }
    }
    if let Some(e) = args.target_error {
        settings.set("target_error", &e.to_string())?;
    }
    if let Some(t) = args.tolerance {
        settings.set("tolerance", &t.to_string())?;
    }
    let mut plan = gloam_scene::plan::plan(&scene);
    // With a camera, the render also carries its detector-weighted band.
    let tile = (args.tile.as_deref())
        .map(gloam_sweep::TileSpec::parse)
        .transpose()
        .map_err(anyhow::Error::msg)?;
    // A tile is radiance only (the scene's own camera is not captured),
    // but it is traced with the camera's band all the same: the effect
    // plan weighs every band, so a tile must make the whole render's
    // decisions to be bit-identical to it.
    let camera = args.sensor.clone().or_else(|| scene.sensor.clone());
    let frames = args.frames.unwrap_or(1);
    let sensor = camera.clone().filter(|_| tile.is_none());
    // Refuse bad sensor options now, not after the whole trace.
    if let Some(s) = &sensor {
        gloam_pipeline::check_options(s, args.gain, frames)?;
    } else {
        // Camera flags without a camera would be silently ignored.
        let given = [
            ("--frames", args.frames.is_some()),
            ("--gain", args.gain.is_some()),
            ("--agc", args.agc),
            ("--no-noise", args.no_noise),
            ("--exposure", args.exposure.is_some()),
        ];
        if let Some((flag, _)) = given.iter().find(|(_, g)| *g) {
            anyhow::bail!(
                "{flag} needs a camera: give --sensor or a `sensor` entry in the scene{}",
                if tile.is_some() {
                    " (a --tile render captures no frames)"
                } else {
                    ""
                }
            );
        }
    }
    let traced = match &camera {
        Some(s) => gloam_pipeline::with_detected_band(&scene, s)?,
        None => scene.clone(),
    };
    let tracer =
        Tracer::prepare_observed(&traced, &settings, true, super::progress::prep_spinner())?;
    plan.extend([gloam_trace::plan::interreflection_effect(
        &tracer.interreflection,
    )]);
    gloam_trace::plan::annotate_shares(&mut plan, &tracer.interreflection);

    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} rendering [{bar:40}] {pos}/{len} tiles {elapsed}/{eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        b
    });
    let progress = |done: u64, total: u64| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(done);
        }
    };
    let (full, mut rows) = (tracer.image_size(), 0..tracer.image_size().1);
    if let Some(t) = tile {
        rows = t.rows(full.1).map_err(anyhow::Error::msg)?;
    }
    let mut out = tracer.render_rows(rows.clone(), &progress)?;
    let detected = match &camera {
        Some(_) => Some(gloam_pipeline::take_detected_band(&mut out)?),
        None => None,
    }
    .filter(|_| sensor.is_some());
    if let Some(b) = &bar {
        b.finish_and_clear();
    }

    let t_write = Instant::now();
    write_tiff(&dir.join("radiance.tiff"), &out.radiance)?;
    write_npy(&dir.join("radiance.npy"), &out.radiance)?;
    write_tiff(&dir.join("stderr.tiff"), &out.std_error)?;
    write_npy(&dir.join("stderr.npy"), &out.std_error)?;
    write_npy_u32(&dir.join("spp.npy"), &out.spp)?;
    write_preview(&dir.join("preview.png"), &out.radiance)?;
    if let Some(t) = tile {
        gloam_sweep::tile::write_tile_info(&dir, t, rows, full, &args.scene, &out)?;
    }
    let write_s = t_write.elapsed().as_secs_f64();
    let mut report =
        gloam_pipeline::render::report_json(&args.scene, &scene, &plan, &out, load_s, write_s);
    // The scene's OBJ, spectrum and instance files were read after the
    // provenance was first taken.
    provenance.add_inputs_read();
    report["provenance"] = serde_json::to_value(&provenance)?;
    write_atomic(
        &dir.join("report.json"),
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    if let (Some(sensor), Some(detected)) = (sensor, detected) {
        let capture = gloam_pipeline::FrameCapture {
            sensor: &sensor,
            frames,
            gain: args.gain,
            agc: args.agc,
            noise: !args.no_noise,
            seed: settings.seed,
            auto_exposure: args
                .exposure
                .as_ref()
                .map(|_| gloam_pipeline::exposure::ExposureTarget::default()),
        };
        capture.run(&detected, &dir)?;
    }
    set.publish(&provenance, None)?;
    eprintln!(
        "rendered {}×{}×{} bands in {:.2} s ({} rays, {:.3e} rays/s) → {}",
        out.stats.width,
        out.stats.height,
        out.stats.bands,
        out.stats.trace_seconds,
        out.stats.rays.total(),
        out.stats.rays_per_second,
        args.out.display()
    );
    Ok(())
}
