//! gloam-sensor: the low-light camera chain.
//!
//! A camera is a chain of stages in physical units — optics, photocathode,
//! MCP, proximity focus, phosphor, coupling (fibre or relay), EBCCD, CCD,
//! AGC, video and digitizer — each skipped when the configuration does not
//! call for it. Input is per-band radiance (band × row × col, W m⁻² sr⁻¹)
//! with each band's spectral shape; output is digital counts with the
//! settings in effect ([`Frame`], [`FrameMeta`]). Frames form a time
//! sequence: AGC and phosphor persistence have memory. Noise comes from
//! explicit seeds, one PCG stream per (seed, frame, pass, row), so results
//! are bit-identical whatever the thread count.
//!
//! The stage models and their sources are documented in [`stages`]; the
//! presets in `sims/sensors/`.

mod analytic;
pub mod bench;
mod camera;
pub mod config;
mod effects;
mod error;
pub mod kernel;
pub mod levels;
pub mod noise;
pub mod stages;

pub use analytic::Description;
pub use bench::{Throughput, throughput, throughput_at};
pub use camera::{AgcState, Camera, Frame, FrameMeta};
pub use config::{PRESETS, SensorConfig, SensorKind};
pub use effects::sensor_effects;
pub use error::{CaptureError, ConfigError};
pub use stages::{Chain, image_irradiance_per_radiance};

/// A built-in preset or a TOML file (see [`SensorConfig::load_preset_or_file`]).
pub fn load_preset_or_file(name_or_path: &str) -> Result<SensorConfig, ConfigError> {
    SensorConfig::load_preset_or_file(name_or_path)
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
