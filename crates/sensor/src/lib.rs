#![doc = include_str!("../README.md")]

mod analytic;
pub mod bench;
mod camera;
#[cfg(feature = "cli")]
pub mod cli;
pub mod config;
mod effects;
mod error;
pub mod kernel;
pub mod levels;
pub mod noise;
mod resolved;
pub mod scope;
pub mod stages;

pub use analytic::Description;
pub use bench::{Throughput, throughput, throughput_at};
pub use camera::{AgcState, Camera, DigitizedFrame, SensorMeta};
pub use config::{PRESETS, SensorConfig, SensorKind};
pub use effects::{SensorEffect, sensor_effects};
pub use error::{CaptureError, ConfigError, LineError, ScopeError};
pub use resolved::ResolvedSensor;
pub use stages::agc::median_dn;
pub use stages::{Chain, image_irradiance_per_radiance};

/// A built-in preset or a TOML file (see [`SensorConfig::load_preset_or_file`]).
pub fn load_preset_or_file(
    name_or_path: &str,
    reads: &gloam_io::ReadLog,
) -> Result<SensorConfig, ConfigError> {
    SensorConfig::load_preset_or_file(name_or_path, reads)
}

/// Names and descriptions of the built-in presets.
pub fn presets() -> Vec<(&'static str, String)> {
    PRESETS
        .iter()
        .map(|(n, _)| {
            let d = SensorConfig::preset(n)
                .and_then(|r| r.ok())
                .map(|c| c.description)
                .unwrap_or_default();
            (*n, d)
        })
        .collect()
}
