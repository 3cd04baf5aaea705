//! Printing for subcommands; the file writers live in
//! [`gloam_pipeline::output`] and are re-exported here.

pub use gloam_pipeline::output::*;

/// Prints a value as pretty JSON on stdout.
pub fn print_json(value: &impl serde::Serialize) -> anyhow::Result<()> {
    outln!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}
