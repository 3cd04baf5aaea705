#![doc = include_str!("../README.md")]

pub mod atmosphere;
#[cfg(feature = "cli")]
pub mod cli;
pub mod ephemeris;
pub mod error;
pub mod ground;
pub mod moonlight;
pub mod nights;
pub mod nightsky;
pub mod quadrature;
pub mod report;
pub mod spectral;
pub mod time;
pub mod twilight;
pub mod twilight_data;
pub mod twilight_times;

pub use atmosphere::{AirmassModel, Atmosphere, EnergyBudget, SingleScattering};
pub use ephemeris::{Ephemeris, HorizontalPosition, Refraction, Site, ephemeris};
pub use error::{Result, SkyError};
pub use ground::{
    Cloud, GroundIlluminance, GroundSpectra, IlluminanceLux, SkyConditions, SkyModel,
    ground_illuminance,
};
pub use moonlight::MoonlightOptions;
pub use nights::{Night, NightSearch, PhaseTarget, find_collection_nights};
pub use spectral::Samples;
pub use time::UtcInstant;
pub use twilight::{TwilightOptions, TwilightSky};
pub use twilight_times::{TwilightTimes, twilight_times};
