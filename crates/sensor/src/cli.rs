//! The command line's arguments for `gloam sensor` (feature `cli`) and the
//! preset listing it prints.

use clap::builder::{OsStringValueParser, TypedValueParser};
use clap::{Args, Subcommand};
use serde::Serialize;

use crate::{SensorConfig, SensorKind, presets};

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
    #[arg(value_parser = preset_or_file())]
    pub sensor: String,
    /// Tube gain (MCP gain, EB gain, or analogue gain for a plain CCD);
    /// default: the configured fixed gain.
    #[arg(long)]
    pub gain: Option<f64>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// The value parser of every `--sensor` (and `sensor describe`'s
/// argument): a preset name or a sensor file's path, kept as text because
/// the name is recorded in reports. A path that is not UTF-8 was clap's
/// bare "invalid UTF-8 was detected in one or more arguments"; this names
/// the flag (clap adds it), the path's bytes and what to do.
pub fn preset_or_file() -> impl TypedValueParser<Value = String> {
    OsStringValueParser::new().try_map(|os| {
        os.into_string().map_err(|os| {
            format!(
                "the sensor file path {os:?} is not UTF-8 (a sensor is named in reports as text): rename the file or link to it by a UTF-8 name"
            )
        })
    })
}

/// One line of `gloam sensor list`.
#[derive(Serialize)]
pub struct PresetRow {
    pub name: &'static str,
    pub kind: SensorKind,
    pub description: String,
    pub sources: Vec<String>,
}

/// The built-in presets that load, in their order.
pub fn preset_rows() -> Vec<PresetRow> {
    presets()
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
        .collect()
}
