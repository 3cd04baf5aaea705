//! One module per subcommand. Each exposes its clap arguments and a
//! `run(args) -> anyhow::Result<()>`.

pub mod ephem;
pub mod output;
pub mod plan;
pub mod sky;
pub mod spectra;
