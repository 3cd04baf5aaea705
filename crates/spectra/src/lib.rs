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
pub use spectrum::{EmissionLine, MAX_LINES, Spectrum};

/// A number for a message: as Rust writes it for ordinary magnitudes, in
/// exponent form past them (`1e300`, `1e-300`), where `{}` writes 301
/// digits (issue 46: `--gain 1e300`, `--lat 1e300`, `--target-error
/// 1e-300` each printed a line of zeros).
pub fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e7).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// The README's Rust example, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
