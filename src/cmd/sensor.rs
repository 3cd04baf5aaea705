//! `gloam sensor list|describe` (arguments: [`gloam_sensor::cli`]).

pub use gloam_sensor::cli::SensorCommand;
use gloam_sensor::cli::preset_rows;
use gloam_sensor::{CaptureError, Chain, SensorConfig};

use super::print_json;

pub fn run(cmd: SensorCommand) -> anyhow::Result<()> {
    match cmd {
        SensorCommand::List { json: true } => print_json(&preset_rows())?,
        SensorCommand::List { json: false } => {
            for r in preset_rows() {
                let kind = format!("{:?}", r.kind);
                outln!("{:<16} {kind:<6} {}", r.name, r.description);
            }
        }
        SensorCommand::Describe(a) => {
            let cfg = SensorConfig::load_preset_or_file(&a.sensor, &gloam_io::ReadLog::off())?;
            let d = match Chain::new(&cfg)?.describe_checked(a.gain) {
                Err(CaptureError::GainOutOfRange { gain, min, max, .. }) => {
                    let (name, gain) = (&cfg.name, gloam_spectra::num(gain));
                    anyhow::bail!("--gain {gain} is outside {name}'s range {min:.4}–{max:.4}")
                }
                d => d?,
            };
            if a.json {
                return print_json(&d);
            }
            outln!("{d}");
        }
    }
    Ok(())
}
