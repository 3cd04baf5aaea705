//! Radiometric core of gloam: spectra as a sampled continuum plus discrete
//! emission lines, band integration, Planck's law, photometric and
//! photon-count conversion, CSV loading, and the built-in library.
//!
//! Units: wavelengths in nm; spectral densities per nm; integrals of a
//! per-nm spectrum over wavelength give the band quantity (W, W m⁻², …).
//! Everything is f64.

mod csv;
mod error;
pub mod input;
pub mod library;
mod radiometry;
mod spectrum;

pub use csv::{parse_csv, read_csv};
pub use error::{CsvError, LookupError, SpectrumError};
pub use library::{LibraryEntry, lookup};
pub use radiometry::*;
pub use spectrum::{EmissionLine, Spectrum};

/// The README's Rust example, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
