#![doc = include_str!("../README.md")]

pub mod band;
#[cfg(feature = "cli")]
pub mod cli;
mod csv;
mod error;
pub mod library;
mod radiometry;
mod spectrum;

pub use band::{BandError, BandIntegral, parse_band};
pub use csv::{data_rows, parse_csv, read_csv};
pub use error::{CsvError, LineRowError, LookupError, SpectrumError};
pub use library::{LibraryEntry, lookup};
pub use radiometry::*;
pub use spectrum::{EmissionLine, Spectrum};

/// The README's Rust example, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
