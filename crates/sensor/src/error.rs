//! Errors of the sensor crate. Each names the configuration field or input
//! that was wrong.

/// A sensor configuration that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// A field has a value outside its physical range (NaN, negative, …).
    #[error("sensor config field `{field}`: {message}")]
    Invalid { field: String, message: String },
    /// A field required by the configured stages is absent.
    #[error("sensor config: missing field `{field}` ({why})")]
    Missing { field: String, why: String },
    /// The TOML text does not parse or does not match the schema (missing
    /// fields and unknown keys are reported here with their path).
    #[error("sensor config {origin}: {message}")]
    Parse { origin: String, message: String },
    /// A spectrum named by the configuration could not be found or read.
    #[error("sensor config field `{field}`: {message}")]
    Spectrum { field: String, message: String },
    /// A validation error located in its file: `origin:line: …`.
    #[error("{origin}:{line}: {inner}")]
    At {
        origin: String,
        line: usize,
        inner: Box<ConfigError>,
    },
    /// Neither a built-in preset nor a readable file.
    #[error(
        "unknown sensor '{name}': not a built-in preset (see `gloam sensor list`) and not a readable file ({message})"
    )]
    Unknown { name: String, message: String },
}

impl ConfigError {
    pub(crate) fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// An input that a camera cannot turn into a frame.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    #[error("radiance input has {bands} bands but {spectra} band spectra were given")]
    BandMismatch { bands: usize, spectra: usize },
    #[error("band {band}: the spectral shape integrates to zero or is not finite")]
    EmptyBand { band: usize },
    #[error("radiance input is empty ({rows} × {cols})")]
    EmptyImage { rows: usize, cols: usize },
    #[error("radiance at band {band}, row {row}, column {col} is {value} (must be finite and ≥ 0)")]
    BadRadiance {
        band: usize,
        row: usize,
        col: usize,
        value: f64,
    },
    #[error(
        "gain {} is outside the range of '{camera}': {min:.3}–{max:.3}; the camera is not run at a clamped gain",
        gloam_spectra::num(*gain)
    )]
    GainOutOfRange {
        gain: f64,
        min: f64,
        max: f64,
        camera: String,
    },
}

/// A frame row that has no place on a broadcast video line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LineError {
    #[error(
        "a frame of {rows} rows does not fit the {picture_lines} picture lines of {format}: give a frame of at most {picture_lines} rows"
    )]
    FrameTooTall {
        rows: usize,
        picture_lines: u32,
        format: &'static str,
    },
    #[error("row {row} is outside the frame's {rows} rows")]
    RowOutside { row: usize, rows: usize },
}

/// Why the camera's video line cannot be shown on the scope.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ScopeError {
    #[error("sensor '{sensor}' has a direct digital readout: no analogue video line to show")]
    NoVideo { sensor: String },
    #[error("no scan line was kept: set the rows, then capture a frame")]
    NoLineKept,
    #[error(transparent)]
    Line(#[from] LineError),
}
