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

use gloam_pipeline::exposure::ExposureTarget;
use gloam_pipeline::render::{self, RenderJob, SettingArgs};
use gloam_pipeline::{FrameCapture, OutputSet, Provenance};

use super::output::write_atomic;

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
    /// `sensor` entry, if any; `none` renders radiance only. Writes the
    /// frames, `frames.jsonl` and `frames-preview.png`.
    #[arg(long, value_name = "PRESET_OR_FILE")]
    pub sensor: Option<String>,
    /// How frames are stored: png (16-bit, counts scaled to 16 bits with
    /// sBIT; default), fits (one file per frame, with a header) or tiff
    /// (one multi-page frames.tiff). Needs a camera.
    #[arg(long, value_name = "FORMAT", value_parser = gloam_pipeline::FrameFormat::NAMES)]
    pub frame_format: Option<String>,
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

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let mut provenance = Provenance::of_this_run();
    // Refused up front when --out is in use; the files appear at once.
    let set = OutputSet::begin(&args.out, args.force, false)?;
    let dir = set.dir().to_path_buf();
    let t_load = Instant::now();
    let scene = gloam_scene::load(&args.scene)?;
    let load_s = t_load.elapsed().as_secs_f64();
    let settings = SettingArgs {
        set: args.set.clone(),
        spp: args.spp,
        seed: args.seed,
        estimator: args.estimator.clone(),
        threads: args.threads,
        target_error: args.target_error,
        tolerance: args.tolerance,
    }
    .settings()?;
    let tile = (args.tile.as_deref())
        .map(gloam_sweep::TileSpec::parse)
        .transpose()
        .map_err(anyhow::Error::msg)?;
    // A tile is radiance only (the scene's own camera is not captured),
    // but it is traced with the camera's band all the same: the effect
    // plan weighs every band, so a tile must make the whole render's
    // decisions to be bit-identical to it.
    let camera = render::camera_of(args.sensor.as_deref(), &scene);
    let frame_format = (args.frame_format.as_deref().map(str::parse))
        .transpose()
        .map_err(anyhow::Error::msg)?
        .unwrap_or_default();
    let capture = camera
        .filter(|_| tile.is_none())
        .map(|sensor| FrameCapture {
            sensor,
            frames: args.frames.unwrap_or(1),
            gain: args.gain,
            agc: args.agc,
            noise: !args.no_noise,
            seed: settings.seed,
            auto_exposure: (args.exposure.as_ref()).map(|_| ExposureTarget::default()),
            frame_format,
        });
    // Refuse bad sensor options now, not after the whole trace.
    if let Some(c) = &capture {
        c.check()?;
    } else {
        // Camera flags without a camera would be silently ignored.
        let given = [
            ("--frames", args.frames.is_some()),
            ("--gain", args.gain.is_some()),
            ("--agc", args.agc),
            ("--no-noise", args.no_noise),
            ("--exposure", args.exposure.is_some()),
            ("--frame-format", args.frame_format.is_some()),
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
    let job = RenderJob {
        camera,
        observer: super::progress::prep_spinner(),
        ..RenderJob::new(&scene, &settings)
    };
    let prepared = job.prepare()?;
    let full = prepared.image_size();
    let rows = tile
        .map(|t| t.rows(full.1))
        .transpose()
        .map_err(anyhow::Error::msg)?;

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
    let rendered = prepared.render(rows, &progress, &|| false)?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }

    let t_write = Instant::now();
    rendered.write_images(&dir)?;
    if let Some(t) = tile {
        let (rows, out) = (rendered.rows.clone(), &rendered.radiance);
        gloam_sweep::tile::write_tile_info(&dir, t, rows, full, &args.scene, out)?;
    }
    let write_s = t_write.elapsed().as_secs_f64();
    let mut report = rendered.report_json(&args.scene, &scene, load_s, write_s);
    // The scene's OBJ, spectrum and instance files were read after the
    // provenance was first taken.
    provenance.add_inputs_read();
    report["provenance"] = serde_json::to_value(&provenance)?;
    write_atomic(
        &dir.join("report.json"),
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    if let (Some(capture), Some(detected)) = (&capture, &rendered.detected) {
        for line in capture.run(detected, &dir, Some(&provenance))? {
            eprintln!("{line}");
        }
        // No path: `dir` is the command's hidden staging directory until
        // the set is published (the line below names the published one).
        eprintln!(
            "captured {} frame(s) through '{}'",
            capture.frames, capture.sensor
        );
    }
    set.publish(&provenance, None)?;
    let s = &rendered.radiance.stats;
    eprintln!(
        "rendered {}×{}×{} bands in {:.2} s ({} rays, {:.3e} rays/s) → {}",
        s.width,
        s.height,
        s.bands,
        s.trace_seconds,
        s.rays.total(),
        s.rays_per_second,
        args.out.display()
    );
    Ok(())
}
