//! gloam-sky: Sun/Moon ephemeris, lunar and night-sky spectral irradiance,
//! and a clear-sky single-scattering atmosphere for low-light imaging.
//!
//! Everything is f64 with units in the names. No function panics on bad
//! input; fallible functions return [`SkyError`].

pub mod ephemeris;
pub mod error;
pub mod time;

pub use ephemeris::{Ephemeris, HorizontalPosition, Refraction, Site, ephemeris};
pub use error::{Result, SkyError};
pub use time::UtcInstant;
pub mod atmosphere;
pub mod ground;
pub mod moonlight;
pub mod nights;
pub mod nightsky;
pub mod spectral;
