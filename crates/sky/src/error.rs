//! Error type of gloam-sky: every variant names the input that was wrong.

use thiserror::Error;

/// Errors from gloam-sky. No function in this crate panics on bad input;
/// it returns one of these instead.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SkyError {
    /// A timestamp string could not be parsed as ISO 8601.
    #[error("invalid ISO-8601 timestamp {input:?}: {reason}")]
    InvalidTimestamp {
        /// The text that was given.
        input: String,
        /// What was wrong with it.
        reason: String,
    },
    /// A numeric input was NaN or infinite.
    #[error("{name} must be a finite number, got {value}")]
    NotFinite {
        /// Name of the parameter (with its unit).
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A numeric input was outside its valid range.
    #[error("{name} = {} is outside the valid range [{min}, {max}]", gloam_spectra::num(*value))]
    OutOfRange {
        /// Name of the parameter (with its unit).
        name: &'static str,
        /// The value given.
        value: f64,
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
    },
    /// Two inputs were inconsistent with each other (e.g. `from` after `to`).
    #[error("invalid input: {0}")]
    Invalid(String),
}

/// Result alias for this crate.
pub type Result<T> = std::result::Result<T, SkyError>;

/// Check that `value` is finite and within `[min, max]`.
pub(crate) fn check_range(name: &'static str, value: f64, min: f64, max: f64) -> Result<f64> {
    if !value.is_finite() {
        return Err(SkyError::NotFinite { name, value });
    }
    if value < min || value > max {
        return Err(SkyError::OutOfRange {
            name,
            value,
            min,
            max,
        });
    }
    Ok(value)
}
