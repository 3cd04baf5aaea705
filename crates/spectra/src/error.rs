//! Errors of the spectra crate: each names what was wrong and where.

use std::path::PathBuf;

/// A spectrum that cannot be built from the given numbers.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SpectrumError {
    #[error("{wavelengths} wavelengths but {values} values")]
    LengthMismatch { wavelengths: usize, values: usize },
    #[error("entry {index}: wavelength {wavelength_nm} nm is not a finite positive number")]
    BadWavelength { index: usize, wavelength_nm: f64 },
    #[error("entry {index}: wavelength {wavelength_nm} nm repeats the previous one")]
    DuplicateWavelength { index: usize, wavelength_nm: f64 },
    #[error(
        "entry {index}: wavelength {wavelength_nm} nm is below the previous {previous_nm} nm (wavelengths must increase)"
    )]
    NotIncreasing {
        index: usize,
        previous_nm: f64,
        wavelength_nm: f64,
    },
    #[error("entry {index}: value {value} is not finite")]
    NonFiniteValue { index: usize, value: f64 },
    #[error("entry {index}: value {value} is negative (spectra are physical, non-negative)")]
    NegativeValue { index: usize, value: f64 },
    #[error(
        "emission line {index}: a line at {wavelength_nm} nm is already present (give each line's wavelength once, with the summed value)"
    )]
    DuplicateLine { index: usize, wavelength_nm: f64 },
    #[error("{count} emission lines: at most {limit} in one spectrum")]
    TooManyLines { count: usize, limit: usize },
    #[error(
        "the spectrum integrates to zero over {lo_nm}–{hi_nm} nm, so it cannot be normalised there"
    )]
    ZeroInBand { lo_nm: f64, hi_nm: f64 },
}

/// A spectrum file that could not be read; always names the file and, where
/// there is one, the 1-based line.
#[derive(Debug, thiserror::Error)]
pub enum CsvError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}:{line}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{path}: no data rows (the file is empty or holds only comments and a header)")]
    Empty { path: PathBuf },
}

/// An emission line row (`line,wavelength_nm,value`) whose fields are
/// wrong; [`CsvError::Parse`] adds the file and line.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum LineRowError {
    #[error("an emission line row is 'line,wavelength_nm,value', found {found} columns")]
    Columns { found: usize },
    #[error("emission line {field} '{text}' is not a number")]
    NotANumber { field: &'static str, text: String },
    #[error("emission line wavelength_nm {wavelength_nm} is not a finite positive number")]
    BadWavelength { wavelength_nm: f64 },
    #[error("emission line value {value} at {wavelength_nm} nm is not finite")]
    NonFiniteValue { value: f64, wavelength_nm: f64 },
    #[error("emission line value {value} at {wavelength_nm} nm is negative")]
    NegativeValue { value: f64, wavelength_nm: f64 },
}

/// A name that is neither in the built-in library nor a readable file.
#[derive(Debug, thiserror::Error)]
pub enum LookupError {
    #[error(
        "unknown spectrum '{name}' (not a built-in name — see `gloam spectra list` — and no such file)"
    )]
    Unknown { name: String },
    #[error(transparent)]
    Csv(#[from] CsvError),
    /// An integral that overflows (values near the largest float).
    #[error(
        "the integral of {spectrum} over {}:{} nm is past the largest number (1.8e308): its values are too large to integrate",
        crate::num(*lo),
        crate::num(*hi)
    )]
    Overflow { spectrum: String, lo: f64, hi: f64 },
}
