//! Rust errors as Python exceptions.

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

create_exception!(
    gloam,
    GloamError,
    PyValueError,
    "An error from gloam: bad input (the message names the file, line and field, as the CLI's does), a device or a calibration that failed."
);

/// The CLI's message for an error (`error: {e:#}` there), as a GloamError;
/// a Ctrl-C seen while the call ran wins over the error it caused.
pub fn to_py(e: anyhow::Error) -> PyErr {
    if let Some(pending) = crate::interrupt::take_pending() {
        return pending;
    }
    GloamError::new_err(format!("{e:#}"))
}

/// `Result<T, E: Into<anyhow::Error>>` → `PyResult<T>`.
pub trait OrPy<T> {
    fn or_py(self) -> PyResult<T>;
}

impl<T, E: Into<anyhow::Error>> OrPy<T> for Result<T, E> {
    fn or_py(self) -> PyResult<T> {
        self.map_err(|e| to_py(e.into()))
    }
}
