//! `gloam capture`: grab frames from any grabber into frame files (PNG,
//! FITS or a multi-page TIFF, `--frame-format`) + frames.jsonl. The
//! arguments make a [`gloam_pipeline::capture_request::CaptureRequest`]
//! (the grab is `gloam_calib`'s); here the progress bar and printing.

use std::io::IsTerminal;
use std::sync::Arc;

use clap::Args;
use gloam_calib::cli::Event;
use gloam_pipeline::FrameFormat;
use gloam_pipeline::capture_request::CaptureRequest;
use gloam_pipeline::request::OutputDir;

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
            a.help("Output directory: the frames (--frame-format), frames.jsonl, frames-preview.png, camera.json, report.json")
        })
    })
}

pub fn run(args: CaptureArgs) -> anyhow::Result<()> {
    let request = CaptureRequest {
        grab: args.grab.request(),
        frame_format: args.frame_format,
        out: OutputDir {
            path: args.grab.out.clone(),
            force: args.grab.force,
        },
    };
    let valid = request.validate()?;
    let bar = progress_bar(args.grab.frames);
    let mut ev = |e: Event<'_>| match e {
        Event::Note(line) => bar.suspend(|| eprintln!("{line}")),
        Event::Progress(status, done, _) => {
            bar.set_message(status.to_string());
            bar.set_position(done as u64);
        }
    };
    let fit_bar = bar.clone();
    let fit_note = Arc::new(move |note: &str| fit_bar.suspend(|| eprintln!("warning: {note}")));
    let done = valid.run(&mut ev, fit_note);
    bar.finish_and_clear();
    let done = done?;
    for line in &done.lines {
        eprintln!("{line}");
    }
    done.stopped.map_or(Ok(()), |e| Err(e.into()))
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
