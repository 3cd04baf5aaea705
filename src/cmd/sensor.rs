//! `gloam sensor list|describe`.

use clap::{Args, Subcommand};
use gloam_sensor::{CaptureError, Chain, SensorConfig, presets};
use serde::Serialize;

use super::output::print_json;

#[derive(Subcommand)]
pub enum SensorCommand {
    /// List the built-in sensor presets.
    List {
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Derived figures of a preset or sensor TOML file at a gain.
    Describe(DescribeArgs),
}

#[derive(Args)]
pub struct DescribeArgs {
    /// A built-in preset (see `gloam sensor list`) or a sensor TOML file.
    pub sensor: String,
    /// Tube gain (MCP gain, EB gain, or analogue gain for a plain CCD);
    /// default: the configured fixed gain.
    #[arg(long)]
    pub gain: Option<f64>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct PresetRow {
    name: &'static str,
    kind: gloam_sensor::SensorKind,
    description: String,
    sources: Vec<String>,
}

pub fn run(cmd: SensorCommand) -> anyhow::Result<()> {
    match cmd {
        SensorCommand::List { json } => {
            let rows: Vec<PresetRow> = presets()
                .into_iter()
                .filter_map(|(name, _)| {
                    let c = SensorConfig::preset(name)?.ok()?;
                    Some(PresetRow {
                        name,
                        kind: c.kind,
                        description: c.description,
                        sources: c.sources,
                    })
                })
                .collect();
            if json {
                print_json(&rows)?;
            } else {
                for r in rows {
                    outln!(
                        "{:<16} {:<6} {}",
                        r.name,
                        format!("{:?}", r.kind),
                        r.description
                    );
                }
            }
            Ok(())
        }
        SensorCommand::Describe(a) => {
            let cfg = SensorConfig::load_preset_or_file(&a.sensor)?;
            let d = match Chain::new(&cfg)?.describe_checked(a.gain) {
                Err(CaptureError::GainOutOfRange { gain, min, max, .. }) => {
                    anyhow::bail!(
                        "--gain {gain} is outside {}'s range {min:.4}–{max:.4}",
                        cfg.name
                    )
                }
                d => d?,
            };
            if a.json {
                print_json(&d)?;
            } else {
                outln!("{d}");
            }
            Ok(())
        }
    }
}
