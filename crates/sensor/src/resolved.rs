//! A sensor resolved once per run.
//!
//! A render with `--sensor NAME` needs the sensor in four places: the
//! detected band the tracer carries, the camera goal of `--target-error
//! camera`, the capture's checks and the capture itself (a calibration
//! rehearsal's sequence likewise in its capture and its checks). Reading
//! the preset or TOML file at each would let a file edited mid-run give
//! different cameras (and list the file once per read in the run's
//! provenance), so a run reads it once, here, and shares it.

use crate::{Camera, ConfigError, SensorConfig};

/// A sensor as the user named it (a preset or a sensor TOML file) and its
/// configuration, read and checked once.
#[derive(Clone, Debug)]
pub struct ResolvedSensor {
    name: String,
    config: SensorConfig,
}

impl ResolvedSensor {
    /// Reads the preset or file `name` and checks that a camera can be
    /// built from it (the chain's ranges), so later steps cannot fail on it.
    /// `reads` notes a sensor file and the spectrum files it names.
    pub fn load(name: &str, reads: &gloam_io::ReadLog) -> Result<Self, ConfigError> {
        let config = SensorConfig::load_preset_or_file(name, reads)?;
        Camera::new(config.clone())?;
        Ok(Self {
            name: name.to_string(),
            config,
        })
    }

    /// The name as given (reports and messages quote it).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The configuration as read.
    pub fn config(&self) -> &SensorConfig {
        &self.config
    }

    /// A fresh camera of this configuration (frame counter at zero).
    pub fn camera(&self) -> Result<Camera, ConfigError> {
        Camera::new(self.config.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_preset_resolves_to_the_same_configuration_as_its_name() {
        let r = ResolvedSensor::load("gen3-gaas-iccd", &gloam_io::ReadLog::off()).unwrap();
        assert_eq!(r.name(), "gen3-gaas-iccd");
        assert_eq!(
            r.config(),
            &SensorConfig::load_preset_or_file("gen3-gaas-iccd", &gloam_io::ReadLog::off())
                .unwrap()
        );
    }

    #[test]
    fn an_unknown_name_is_refused_when_resolved() {
        let e = ResolvedSensor::load("no-such-sensor", &gloam_io::ReadLog::off()).unwrap_err();
        assert!(e.to_string().contains("no-such-sensor"), "{e}");
    }
}
