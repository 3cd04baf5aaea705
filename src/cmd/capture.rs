//! `gloam capture`: grab frames from any grabber into PNGs + frames.jsonl.
//! The arguments and the grab loop are `gloam_calib::cli`'s; here the
//! output set, the frame writer, the progress bar and printing.

use std::io::IsTerminal;

pub use gloam_calib::cli::CaptureArgs;
use gloam_calib::cli::Event;
use gloam_pipeline::{FrameRecord, FrameWriter, OutputSet, Provenance};

pub fn run(args: CaptureArgs) -> anyhow::Result<()> {
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
    // Appended as frames are written: an interrupted capture lists every
    // frame it kept.
    let mut writer = FrameWriter::create(&dir)?;
    let (tally, result) = args.grab::<anyhow::Error, _>(
        g.as_mut(),
        &gloam_pipeline::output_set::interrupted,
        |index, f: &gloam_grabber::Frame, warnings| {
            let rec = FrameRecord::of_grab(index, format!("frame-{index:06}.png"), f, warnings);
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
