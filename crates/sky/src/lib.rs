//! gloam-sky: Sun/Moon ephemeris, lunar and night-sky spectral irradiance,
//! and a clear-sky single-scattering atmosphere for low-light imaging.
//!
//! Everything is f64 with units in the names; spectra are plain
//! `Vec<(wavelength_nm, value)>` on a 300–1100 nm, 5 nm grid. No function
//! panics on bad input; fallible functions return [`SkyError`] naming the
//! offending parameter.
//!
//! # Entry points
//!
//! * `gloam ephem`: [`UtcInstant::parse_iso8601`], [`Site::new`],
//!   [`ephemeris()`] → [`Ephemeris`] (topocentric apparent elevation/azimuth
//!   of Moon and Sun, distance, elongation, phase angle, illuminated
//!   fraction).
//! * Collection nights: [`find_collection_nights`] with a [`NightSearch`].
//! * `gloam sky`: [`ground_illuminance`] → [`GroundIlluminance`] (lux
//!   components and, on request, spectral irradiance tables).
//! * Ray tracer: [`SkyModel`] — [`SkyModel::moon_direction_enu`],
//!   [`SkyModel::moon_exo_irradiance_w_m2_nm`],
//!   [`SkyModel::moon_direct_normal_w_m2_nm`],
//!   [`SkyModel::sky_radiance_w_m2_sr_nm`] (any direction).
//!
//! # Accuracy (measured)
//!
//! Against PyEphem 4.2.1 over 300 random instants 1900–2100 and sites
//! (`tests/ephem_reference.rs`): Moon elevation ≤ 0.004°, Moon azimuth
//! (× cos el) ≤ 0.004°, Sun elevation/azimuth ≤ 0.008° (Meeus ch. 25 is a
//! 0.01° theory), refracted elevations above 0.5° ≤ 0.008°, topocentric
//! Moon distance ≤ 10 km, elongation/phase angle ≤ 0.011°, illuminated
//! fraction ≤ 0.0001 (vs k from PyEphem's geometry; ≤ 0.003 vs PyEphem's
//! own `moon_phase`).
//!
//! Photometric anchors: full Moon outside the atmosphere at mean distance
//! 0.313 lux without / 0.423 lux with the opposition surge at α = 0,
//! 0.35 lux at α = 3°; quarter (α = 90°) 0.091 of full; a zenith full Moon
//! on the ground at 750 m with 40 km visibility ≈ 0.32 lux (0.28 direct +
//! 0.03 sky); the night sky 1e-3 lux clear, 1e-4 lux overcast.

pub mod atmosphere;
pub mod ephemeris;
pub mod error;
pub mod ground;
pub mod moonlight;
pub mod nights;
pub mod nightsky;
pub mod spectral;
pub mod time;

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
