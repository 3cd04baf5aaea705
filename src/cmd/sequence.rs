//! `gloam sequence SEQ --out DIR …`: a night that changes, through a camera.
//!
//! The arguments ([`gloam_pipeline::cli::SequenceArgs`]) make a
//! [`gloam_pipeline::SequenceRequest`], which checks them, renders the
//! sequence's layers, captures its frames and writes the output set; this
//! file only draws progress and prints.

pub use gloam_pipeline::cli::SequenceArgs;

use super::progress::Terminal;

pub fn run(args: SequenceArgs, guard: &gloam_io::RunGuard) -> anyhow::Result<()> {
    let terminal = Terminal::default();
    let done = (args
        .request()
        .validate(&gloam_io::ReadLog::new(), &terminal)?)
    .run(&terminal, guard)?;
    for line in &done.lines {
        eprintln!("{line}");
    }
    Ok(())
}
