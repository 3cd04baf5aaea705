//! Errors of the calibration flows: each says what went wrong and, where it
//! helps, what to change.

use std::path::PathBuf;

use gloam_grabber::GrabError;

/// Everything a calibration flow can fail with.
#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    #[error("grabber: {0}")]
    Grab(#[from] GrabError),
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    #[error("source: {0}")]
    Source(String),
    #[error("singular fit: {0}")]
    SingularFit(String),
    #[error("not enough data: {0}")]
    InsufficientData(String),
    #[error("AGC did not settle: {0}")]
    NotSettled(String),
    #[error("invalid input: {0}")]
    Invalid(String),
    #[error("aborted by the operator at {0}")]
    Aborted(String),
    #[error("I/O: {0}")]
    Io(String),
}

impl CalibError {
    pub(crate) fn file(path: impl Into<PathBuf>, message: impl std::fmt::Display) -> Self {
        CalibError::File {
            path: path.into(),
            message: message.to_string(),
        }
    }
}
