//! `gloam calibrate …`: radiance LUTs, applying them, AGC linearisation,
//! EMVA 1288 photon transfer and MTF. The arguments and flows are
//! `gloam_calib::cli`'s; here the output set, progress bar and printing.
//! See docs/calibration.md.

use std::io::IsTerminal;
use std::path::Path;

pub use gloam_calib::cli::CalibrateCommand;
use gloam_calib::cli::{Event, run_calibrate};
use gloam_pipeline::{OutputSet, Provenance};

pub fn run(cmd: CalibrateCommand) -> anyhow::Result<()> {
    let mut set = None;
    let mut bar: Option<indicatif::ProgressBar> = None;
    let r = run_calibrate::<anyhow::Error>(
        &cmd,
        &gloam_pipeline::grabbers(),
        &mut |out: &Path, force| {
            let s = OutputSet::begin(out, force, false)?;
            let dir = s.dir().to_path_buf();
            set = Some(s);
            Ok(dir)
        },
        &mut |e| match e {
            Event::Note(line) => match &bar {
                Some(b) => b.suspend(|| eprintln!("{line}")),
                None => eprintln!("{line}"),
            },
            Event::Progress(phase, done, total) => {
                let b = bar.get_or_insert_with(progress_bar);
                b.set_message(phase.to_string());
                b.set_length(total as u64);
                b.set_position(done as u64);
            }
        },
    );
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let outcome = r?;
    if let (Some(set), Some(main_json)) = (set, outcome.main_json) {
        publish(set, main_json)?;
    }
    for line in &outcome.lines {
        eprintln!("{line}");
    }
    Ok(())
}

fn progress_bar() -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(1);
    b.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} {msg} eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}

/// Adds the run's provenance to the set's main JSON and publishes the set.
pub fn publish(set: OutputSet, main_json: &str) -> anyhow::Result<()> {
    let provenance = Provenance::of_this_run();
    gloam_pipeline::output::add_provenance(&set.dir().join(main_json), &provenance)?;
    Ok(set.publish(&provenance, None)?)
}
