//! `gloam capture`: grab frames from any grabber into frame files (PNG,
//! FITS or a multi-page TIFF, `--frame-format`) + frames.jsonl. The
//! arguments ([`gloam_pipeline::cli::capture`]) make a `CaptureRequest`
//! (the grab is `gloam_calib`'s); here the progress bar and printing.

use std::sync::Arc;

use gloam_calib::cli::Event;
pub use gloam_pipeline::cli::capture::{CaptureArgs, with_out_help};

pub fn run(args: CaptureArgs, guard: &gloam_io::RunGuard) -> anyhow::Result<()> {
    let valid = args.request().validate(&gloam_io::ReadLog::new())?;
    let template = "{bar:40} {pos}/{len} frames {per_sec} eta {eta} {msg}";
    let bar = super::progress::bar_or_hidden(template, args.grab.frames);
    let mut ev = |e: Event<'_>| match e {
        Event::Note(line) => bar.suspend(|| eprintln!("{line}")),
        Event::Progress(status, done, _) => {
            bar.set_message(status.to_string());
            bar.set_position(done as u64);
        }
    };
    let fit_bar = bar.clone();
    let fit_note = Arc::new(move |note: &str| fit_bar.suspend(|| eprintln!("warning: {note}")));
    let done = valid.run(&mut ev, fit_note, guard);
    bar.finish_and_clear();
    let done = done?;
    for line in &done.lines {
        eprintln!("{line}");
    }
    done.stopped.map_or(Ok(()), |e| Err(e.into()))
}
