//! `gloam sweep SWEEP.toml --out DIR [--slurm …]`, `gloam sweep run|status|collect DIR`.
//!
//! The arguments are [`gloam_sweep::cli`] and what the command does
//! [`gloam_sweep::command`]; this file is the progress display and printing.

use std::sync::OnceLock;

pub use gloam_sweep::cli::SweepArgs;
use gloam_sweep::command::{SweepCommandError, SweepUi};

/// A bar over tasks on a terminal, lines on stderr, results on stdout.
#[derive(Default)]
struct Terminal {
    bar: OnceLock<Option<indicatif::ProgressBar>>,
}

impl SweepUi for Terminal {
    fn out(&self, text: &str) -> Result<(), SweepCommandError> {
        use std::io::Write as _;
        writeln!(std::io::stdout(), "{text}").map_err(SweepCommandError::Stdout)
    }
    fn say(&self, line: &str) {
        match self.bar.get().and_then(Option::as_ref) {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }
    fn start(&self, total: u64) -> bool {
        let template = "{bar:40} {pos}/{len} tasks {elapsed}/{eta} {msg}";
        let bar = self
            .bar
            .get_or_init(|| super::progress::bar(template, "█░", total));
        bar.is_some()
    }
    fn inc(&self) {
        if let Some(b) = self.bar.get().and_then(Option::as_ref) {
            b.inc(1);
        }
    }
    fn finish(&self) {
        if let Some(b) = self.bar.get().and_then(Option::as_ref) {
            b.finish_and_clear();
        }
    }
}

pub fn run(args: SweepArgs) -> anyhow::Result<()> {
    match gloam_sweep::command::run(args, &Terminal::default()) {
        // A closed pipe ends the command quietly, as `outln!` does.
        Err(SweepCommandError::Stdout(e)) => Err(crate::StdoutClosed(e).into()),
        r => Ok(r?),
    }
}
