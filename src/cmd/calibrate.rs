//! `gloam calibrate …`: radiance LUTs, applying them, AGC linearisation
//! (on a rig's staircase, or on a sequence), EMVA 1288 photon transfer and
//! MTF. The arguments and flows are `gloam_calib::cli`'s over its request
//! types; `gloam_pipeline::cli::calibrate` adds `--sequence`'s render and
//! publishes the set. Here the progress bar and printing. See
//! docs/calibration.md.

pub use gloam_calib::cli::CalibrateCommand;
use gloam_calib::cli::Event;
use gloam_pipeline::cli::calibrate::run_calibrate_command;

use super::progress::Terminal;

pub fn run(cmd: CalibrateCommand, guard: &gloam_io::RunGuard) -> anyhow::Result<()> {
    let mut bar: Option<indicatif::ProgressBar> = None;
    let mut ev = |e: Event<'_>| match e {
        Event::Note(line) => match &bar {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        },
        Event::Progress(phase, done, total) => {
            let template = "{bar:40} {pos}/{len} {msg} eta {eta}";
            let b = bar.get_or_insert_with(|| super::progress::bar_or_hidden(template, 1));
            b.set_message(phase.to_string());
            b.set_length(total as u64);
            b.set_position(done as u64);
        }
    };
    let r = run_calibrate_command(&cmd, &mut ev, &Terminal::default(), guard);
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    for line in r? {
        eprintln!("{line}");
    }
    Ok(())
}
