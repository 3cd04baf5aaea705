//! `gloam capture`: grab frames from any grabber into PNGs + frames.jsonl.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use gloam_calib::apply::CAMERA_FILE;
use gloam_calib::capture::FrameLosses;
use gloam_grabber::OpenOptions;
use gloam_simcam::FrameExposureExt;

use gloam_pipeline::{FrameLog, FrameRecord, OutputSet, Provenance};

use super::output::{png16_bytes, write_atomic};

#[derive(Args)]
pub struct CaptureArgs {
    /// Grabber URI: sim:PRESET_OR_RIG[?rig=R&seed=S&size=WxH],
    /// serial:PATH[?baud=N], usb:VID:PID[:SERIAL].
    #[arg(long)]
    pub grabber: String,
    /// Good frames to capture.
    #[arg(long, default_value_t = 1)]
    /// At most 1 000 000 (nine hours at 30 frames/s; split longer runs).
    #[arg(value_parser = clap::value_parser!(u64).range(0..=1_000_000))]
    pub frames: u64,
    /// Output directory (frame-NNNNNN.png + frames.jsonl).
    #[arg(long)]
    pub out: PathBuf,
    /// Fixed gain (turns AGC off).
    #[arg(long, conflicts_with = "agc")]
    pub gain: Option<f64>,
    /// Turn AGC on.
    #[arg(long)]
    pub agc: bool,
    /// Digitizer bit depth.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["8", "12", "16"]))]
    pub bits: Option<String>,
    /// Exposure / gate time, seconds.
    #[arg(long)]
    pub exposure_s: Option<f64>,
    /// Noise seed for sim: grabbers (the emulator takes its own --seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Give up after this many lost/damaged frames in a row.
    #[arg(long, default_value_t = 1000)]
    pub max_consecutive_failures: u64,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other files).
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: CaptureArgs) -> anyhow::Result<()> {
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let provenance = Provenance::of_this_run();
    // The frames appear at once with manifest.json; Ctrl-C stops the loop
    // and publishes what was captured.
    let set = OutputSet::begin(&args.out, args.force, true)?;
    let dir = set.dir().to_path_buf();
    let opts = OpenOptions {
        seed: args.seed,
        ..OpenOptions::default()
    };
    let mut g = gloam_pipeline::grabbers()
        .open(&args.grabber, &opts)
        .with_context(|| format!("opening {}", args.grabber))?;
    eprintln!("capturing from {}", g.describe());
    // Which camera took the frames: `calibrate apply` checks a LUT against it.
    super::output::write_atomic(
        &dir.join(CAMERA_FILE),
        serde_json::to_string_pretty(&serde_json::json!({
            "camera": g.describe(),
            "grabber": args.grabber,
        }))?
        .as_bytes(),
    )?;
    if let Some(b) = &args.bits {
        g.set_bits(b.parse().expect("validated"))?;
    }
    if let Some(e) = args.exposure_s {
        g.set_exposure_s(e)?;
    }
    if let Some(gain) = args.gain {
        let applied = g.set_gain(gain)?;
        if (applied - gain).abs() > 1e-9 * gain.abs().max(1.0) {
            eprintln!("note: gain {gain} applied as {applied}");
        }
    }
    if args.agc {
        g.set_agc(true)?;
    }
    let bar = if std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(args.frames);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} frames {per_sec} eta {eta} {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let mut records = Vec::new();
    let mut losses = FrameLosses::default();
    let mut consecutive = 0u64;
    let mut warned = std::collections::BTreeSet::new();
    let mut frames_warned = 0u64;
    // Appended as frames are written: an interrupted capture lists every
    // frame it kept.
    let mut log = FrameLog::create(&dir)?;
    let result: anyhow::Result<()> = (|| {
        while (records.len() as u64) < args.frames {
            if gloam_pipeline::output_set::interrupted() {
                bail!("interrupted (Ctrl-C)");
            }
            match g.grab() {
                Ok(f) => {
                    consecutive = 0;
                    let index = records.len() as u64;
                    let file = format!("frame-{index:06}.png");
                    write_atomic(
                        &dir.join(&file),
                        &png16_bytes(f.meta.width, f.meta.height, f.meta.bits, &f.pixels)?,
                    )?;
                    let exposure = f.exposure();
                    for (w, k) in exposure.warnings.iter().zip(&exposure.warning_kinds) {
                        // Each kind once on stderr (every frame keeps its own in frames.jsonl).
                        if warned.insert(*k) {
                            bar.suspend(|| eprintln!("warning: frame {index}: {w}"));
                        }
                    }
                    if !exposure.warnings.is_empty() {
                        frames_warned += 1;
                    }
                    let rec = FrameRecord::of_grab(index, file, &f, exposure.warnings);
                    log.append(&rec)?;
                    records.push(rec);
                    bar.inc(1);
                }
                Err(e) if losses.count(&e) => {
                    consecutive += 1;
                    bar.suspend(|| eprintln!("warning: {e}"));
                    bar.set_message(format!("{} damaged, {} lost", losses.damaged, losses.lost));
                    if consecutive >= args.max_consecutive_failures {
                        bail!("{consecutive} lost or damaged frames in a row; giving up");
                    }
                }
                Err(e) => return Err(e).context("grabbing"),
            }
        }
        Ok(())
    })();
    bar.finish_and_clear();
    // Nothing captured is lost: a run that stopped early publishes its
    // whole frames, marked incomplete in manifest.json.
    if !records.is_empty() || result.is_ok() {
        let why = result.as_ref().err().map(|e| format!("{e:#}"));
        drop(log);
        set.publish(&provenance, why.as_deref())?;
    }
    eprintln!(
        "{}",
        losses.summary(records.len(), &args.out, frames_warned)
    );
    result
}
