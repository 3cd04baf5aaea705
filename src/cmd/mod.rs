//! One module per subcommand. Each exposes its clap arguments and a
//! `run(args) -> anyhow::Result<()>`.

pub mod bench;
pub mod calibrate;
pub mod capture;
pub mod compare;
pub mod device;
pub mod ephem;
pub mod grabbers;
pub mod merge;
pub mod plan;
pub mod probe;
pub mod progress;
pub mod render;
pub mod scope;
pub mod sensor;
pub mod sequence;
pub mod sky;
pub mod spectra;
pub mod sweep;

/// Prints a value as pretty JSON on stdout.
pub fn print_json(value: &impl serde::Serialize) -> anyhow::Result<()> {
    outln!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}
