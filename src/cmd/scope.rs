//! `gloam scope`: scan lines of a simulated camera's video as an
//! oscilloscope shows them (CSV, PNG, cursor readings) — a thin wrapper
//! over `gloam_calib::scope_run`. See docs/video.md.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};

use gloam_calib::scope_run::{ScopeOptions, run_scope, sim_uri, write_scope};
use gloam_pipeline::{OutputSet, Provenance};
use gloam_sensor::stages::video_timing::VideoFormat;

#[derive(Clone, Copy, ValueEnum)]
pub enum Format {
    #[value(name = "rs-170")]
    Rs170,
    Ccir,
}

#[derive(Args)]
pub struct ScopeArgs {
    /// Sensor preset or TOML file (or give --grabber sim:…).
    #[arg(long, conflicts_with = "grabber")]
    pub sensor: Option<String>,
    /// A sim: grabber URI (sensor, rig, seed, size from it).
    #[arg(long)]
    pub grabber: Option<String>,
    /// Rig the camera looks at: uniform, sine, edge, dark (default sine).
    #[arg(long)]
    pub rig: Option<String>,
    /// Sine bars across the line, cycles/pixel.
    #[arg(long, default_value_t = 0.05)]
    pub frequency: f64,
    /// Mean signal, fraction of the range above black.
    #[arg(long, default_value_t = 0.4)]
    pub level: f64,
    /// Frame rows to show, comma-separated (default: the middle row).
    #[arg(long, value_delimiter = ',')]
    pub rows: Vec<usize>,
    /// Frame size WxH (default: 640x480 RS-170, 768x576 CCIR).
    #[arg(long)]
    pub size: Option<String>,
    #[arg(long)]
    pub seed: Option<u64>,
    /// Fixed gain (AGC off).
    #[arg(long)]
    pub gain: Option<f64>,
    /// Override the sensor file's line format.
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// Override the video amplifier's −3 dB bandwidth, Hz.
    #[arg(long)]
    pub bandwidth_hz: Option<f64>,
    /// Frames captured before the one shown.
    #[arg(long, default_value_t = 1)]
    pub frames: usize,
    /// Output directory: scope.csv, scope.png, scope.json.
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long)]
    pub force: bool,
}

pub fn run(a: ScopeArgs) -> anyhow::Result<()> {
    let (sensor, rig, seed, size) = match (&a.sensor, &a.grabber) {
        (Some(s), _) => (s.clone(), "sine".to_string(), 0, None),
        (None, Some(u)) => sim_uri(u)?,
        (None, None) => anyhow::bail!("give --sensor PRESET_OR_FILE or --grabber sim:…"),
    };
    let size = match &a.size {
        Some(s) => Some(
            gloam_grabber::uri::parse_size(s)
                .with_context(|| format!("--size '{s}' is not WxH (1..4096)"))?,
        ),
        None => size,
    };
    let opts = ScopeOptions {
        sensor,
        seed: a.seed.unwrap_or(seed),
        size,
        rows: a.rows.clone(),
        rig: a.rig.clone().unwrap_or(rig),
        level_fraction: a.level,
        frequency_cy_per_px: a.frequency,
        gain: a.gain,
        format: a.format.map(|f| match f {
            Format::Rs170 => VideoFormat::Rs170,
            Format::Ccir => VideoFormat::Ccir,
        }),
        bandwidth_hz: a.bandwidth_hz,
        frames: a.frames,
    };
    let set = OutputSet::begin(&a.out, a.force, false)?;
    let r = run_scope(&opts)?;
    write_scope(set.dir(), &r)?;
    let provenance = Provenance::of_this_run();
    gloam_pipeline::output::add_provenance(&set.dir().join("scope.json"), &provenance)?;
    set.publish(&provenance, None)?;
    for (row, l) in &r.readouts {
        outln!(
            "row {row}: sync {:.3} V, blanking {:.3} V, active {:.3}–{:.3} V, sync {:.3} µs, line {:.3} µs",
            l.sync_tip_v,
            l.blanking_v,
            l.active_min_v,
            l.active_max_v,
            l.sync_width_s * 1e6,
            l.line_period_s * 1e6
        );
    }
    eprintln!(
        "{} ({}, {:.2} MHz pixel clock): wrote {}",
        r.sensor,
        r.format,
        r.pixel_clock_hz / 1e6,
        a.out.join("scope.png").display()
    );
    Ok(())
}
