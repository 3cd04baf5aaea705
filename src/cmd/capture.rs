//! `gloam capture`: grab frames from any grabber into frame files (PNG,
//! FITS or a multi-page TIFF, `--frame-format`) + frames.jsonl. The grab
//! arguments and loop are `gloam_calib::cli`'s; here `--frame-format`,
//! the output set, the frame writer, the progress bar and printing.

use std::io::IsTerminal;

use clap::Args;
use gloam_calib::cli::Event;
use gloam_pipeline::frames::{FrameContext, instrument_of_grabber};
use gloam_pipeline::{FrameFormat, FrameRecord, FrameWriter, OutputSet, Provenance};

/// `gloam capture`: the grabber and grab settings, and how the frames are
/// stored.
#[derive(Args)]
// Its own group id: the flattened grab arguments' group is `CaptureArgs`.
#[group(id = "capture-command")]
pub struct CaptureArgs {
    #[command(flatten)]
    pub grab: gloam_calib::cli::CaptureArgs,
    /// How frames are stored: png (16-bit, counts scaled to 16 bits with
    /// sBIT; default), fits (one file per frame, with a header) or tiff
    /// (one multi-page frames.tiff), as `render` and `sequence` store them.
    #[arg(long, value_name = "FORMAT", value_parser = FrameFormat::NAMES)]
    pub frame_format: Option<String>,
}

/// `gloam capture`'s command with `--out`'s help naming what it holds
/// now that the frames need not be PNGs (the flag is `gloam_calib`'s).
pub fn with_out_help(cmd: clap::Command) -> clap::Command {
    cmd.mut_subcommand("capture", |c| {
        c.mut_arg("out", |a| {
            a.help("Output directory: the frames (--frame-format), frames.jsonl, frames-preview.png, camera.json")
        })
    })
}

pub fn run(args: CaptureArgs) -> anyhow::Result<()> {
    let format = gloam_pipeline::cli::frame_format(args.frame_format.as_deref())?;
    let args = args.grab;
    args.check()?;
    let provenance = Provenance::of_this_run();
    // The frames appear at once with manifest.json; Ctrl-C stops the loop
    // and publishes what was captured.
    let set = OutputSet::begin(&args.out, args.force, true)?;
    let dir = set.dir().to_path_buf();
    let bar = progress_bar(args.frames);
    let mut ev = |e: Event<'_>| match e {
        Event::Note(line) => bar.suspend(|| eprintln!("{line}")),
        Event::Progress(status, done, _) => {
            bar.set_message(status.to_string());
            bar.set_position(done as u64);
        }
    };
    // A `sim:…?scene=` camera that cannot fit its scene at any gain says so
    // before its first frame, as `render --sensor` does.
    let fit_bar = bar.clone();
    let grabbers = gloam_pipeline::grabbers_noting(std::sync::Arc::new(move |note: &str| {
        fit_bar.suspend(|| eprintln!("warning: {note}"))
    }));
    let mut g = args.open::<anyhow::Error>(&grabbers, &dir, &mut ev)?;
    // FITS headers name the camera, its URI, the seed and this run.
    let context = FrameContext {
        camera: Some(args.grabber.clone()),
        instrument: Some(instrument_of_grabber(&args.grabber, &g.describe())),
        seed: args.seed,
        provenance: Some(provenance.clone()),
        scene_utc: None,
    };
    // Appended as frames are written: an interrupted capture lists every
    // frame it kept.
    let mut writer = FrameWriter::with_format(&dir, format, context)?;
    let (tally, result) = args.grab::<anyhow::Error, _>(
        g.as_mut(),
        &gloam_pipeline::output_set::interrupted,
        |index, f: &gloam_grabber::Frame, warnings| {
            let rec = FrameRecord::of_grab(index, format.file_name(index), f, warnings);
            Ok(writer.write(&rec, &f.pixels)?)
        },
        &mut ev,
    );
    bar.finish_and_clear();
    // Nothing captured is lost: a run that stopped early publishes its
    // whole frames, marked incomplete in manifest.json.
    if tally.kept > 0 || result.is_ok() {
        let why = result.as_ref().err().map(|e| format!("{e:#}"));
        // The contact sheet of what was kept (frames-preview.png).
        writer.finish()?;
        set.publish(&provenance, why.as_deref())?;
    }
    let (kept, warned) = (tally.kept as usize, tally.frames_warned);
    eprintln!("{}", tally.losses.summary(kept, &args.out, warned));
    result
}

fn progress_bar(frames: u64) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(frames);
    b.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} frames {per_sec} eta {eta} {msg}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}
