//! Errors of the calibration flows: each says what went wrong and, where it
//! helps, what to change.

use std::path::PathBuf;

use gloam_grabber::GrabError;

/// Everything a calibration flow can fail with.
#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    /// The grabber's error is the source: the message read "grabber: X: X"
    /// when it was also in this one's text.
    #[error("grabber")]
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
    /// Standard input closed at a prompt: nobody typed q.
    #[error(
        "end of input at {0}: standard input closed before an answer (run at a terminal, or give one line per prompt)"
    )]
    EndOfInput(String),
    #[error("I/O: {0}")]
    Io(String),
    /// A file that could not be read (missing, not a regular file, too
    /// large, not UTF-8).
    #[error("reading {path}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A bad line of a text input file (1-based).
    #[error("{path}:{line}: {message}")]
    Line {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// A JSON file that does not parse as what it should hold.
    #[error("{path}: not a gloam {what}")]
    NotJson {
        path: PathBuf,
        what: &'static str,
        #[source]
        source: serde_json::Error,
    },
    /// An explicit gain that contradicts the one recorded for the frame.
    #[error("--gain {g}: {}:{line} records gain {} for {}; the frame was not taken at gain {g} (omit --gain to use the recorded gain)", frames_jsonl.display(), gloam_spectra::num(*recorded), frame.display(), g = gloam_spectra::num(*gain))]
    GainMismatch {
        gain: f64,
        recorded: f64,
        frames_jsonl: PathBuf,
        line: usize,
        frame: PathBuf,
    },
    /// A LUT made with another camera than the one that took the frame.
    #[error("{}: made with camera '{lut_camera}', but {} was captured with '{frame_camera}' ({}); calibrate that camera, or apply its own LUT", lut.display(), frame.display(), camera_file.display())]
    LutCamera {
        lut: PathBuf,
        lut_camera: String,
        frame: PathBuf,
        frame_camera: String,
        camera_file: PathBuf,
    },
    /// A LUT made for another digitizer bit depth than the frame's.
    #[error("{}: made for a digitizer whose top code is {lut_max_dn} DN, but {}:{line} records {} as {bits}-bit (top code {frame_max_dn} DN); apply a LUT of this bit depth", lut.display(), frames_jsonl.display(), frame.display())]
    LutBitDepth {
        lut: PathBuf,
        lut_max_dn: f64,
        frames_jsonl: PathBuf,
        line: usize,
        frame: PathBuf,
        bits: u64,
        frame_max_dn: f64,
    },
    /// A LUT that cannot linearise a camera's frames: made on another
    /// camera, for another bit depth, or over gains the frames were not
    /// taken at. Converting anyway would give wrong radiances silently.
    #[error("{}", lut_not_for_camera(.lut_camera, .camera, .reason, .gains))]
    LutNotForCamera {
        lut_camera: String,
        camera: String,
        reason: String,
        /// The gains to calibrate (a `--gains` list or what it must span).
        gains: String,
    },
    /// A frame holding counts the LUT's digitizer cannot produce.
    #[error("{}: holds {top_dn} DN, above the top code {lut_max_dn} DN of the camera {} was made for; the frame is from another camera or bit depth", frame.display(), lut.display())]
    CountsAboveLut {
        frame: PathBuf,
        top_dn: u16,
        lut_max_dn: f64,
        lut: PathBuf,
    },
    /// A frame whose counts do not match the CRC-32C recorded for it.
    #[error("{}: its counts have CRC-32C {actual:#010x}, but {}:{line} records {recorded:#010x} for it; the frame was altered or is another frame's file under its name (another gain's?), so its recorded gain and settings are not its own", frame.display(), frames_jsonl.display())]
    FrameCrc {
        frame: PathBuf,
        frames_jsonl: PathBuf,
        line: usize,
        recorded: u32,
        actual: u32,
    },
    /// An output path that is one of the run's inputs.
    #[error("{flag} {}: is the same file as {input_flag} {}; gloam never writes over its own inputs — choose another output", output.display(), input.display())]
    OutputIsInput {
        flag: &'static str,
        output: PathBuf,
        input_flag: &'static str,
        input: PathBuf,
    },
    /// A missing or contradictory command-line option, said as the option.
    #[error("{0}")]
    Usage(String),
    /// A grabber that would not open, naming its URI.
    #[error("opening {uri}")]
    Open {
        uri: String,
        #[source]
        source: Box<GrabError>,
    },
    /// A grab that failed for another reason than a lost or damaged frame.
    #[error("grabbing")]
    Grabbing(#[source] Box<GrabError>),
    /// A sensor preset or file that does not load.
    #[error(transparent)]
    SensorConfig(#[from] gloam_sensor::ConfigError),
    /// A simulated camera refusing a setting (e.g. a gain outside its range).
    #[error(transparent)]
    SensorCapture(#[from] gloam_sensor::CaptureError),
    /// An `--out` output set refused or not opened, naming the path.
    #[error(transparent)]
    OutputSet(#[from] gloam_io::OutputSetError),
}

impl From<gloam_io::FileError> for CalibError {
    fn from(e: gloam_io::FileError) -> Self {
        CalibError::File {
            path: e.path,
            message: e.message,
        }
    }
}

impl CalibError {
    pub(crate) fn file(path: impl Into<PathBuf>, message: impl std::fmt::Display) -> Self {
        CalibError::File {
            path: path.into(),
            message: message.to_string(),
        }
    }

    /// A TOML error of `text`, read from `origin`, at its line and field
    /// (`origin:LINE: field `f`: message`, `gloam_io::toml_place`).
    pub(crate) fn toml(origin: impl std::fmt::Display, text: &str, e: &toml::de::Error) -> Self {
        let (line, message) = gloam_io::toml_place::place(text, e);
        Self::file(format!("{origin}:{line}"), message)
    }
}

/// [`CalibError::LutNotForCamera`]'s text: the camera named twice only
/// when the LUT's is another ("a LUT made with X cannot linearise frames
/// of X" said of a gain range read as a camera mismatch).
fn lut_not_for_camera(lut_camera: &str, camera: &str, reason: &str, gains: &str) -> String {
    let lead = if lut_camera == camera {
        format!("this LUT of '{camera}' cannot linearise these frames")
    } else {
        format!("a LUT made with '{lut_camera}' cannot linearise frames of '{camera}'")
    };
    format!("{lead}: {reason}; make one on this camera with `gloam calibrate radiance` at {gains}")
}

/// A gain as messages print it: four decimals at most, no trailing zeros
/// (14.5519, 40), not the 17 digits of a float's shortest form.
pub(crate) fn gain_text(g: f64) -> String {
    let s = format!("{g:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grabber's error reads once in the chain the command line prints
    /// ("grabber: X", not "grabber: X: X").
    #[test]
    fn a_grabber_error_is_said_once() {
        let e = CalibError::from(GrabError::Unsupported("no such camera".into()));
        assert_eq!(gloam_io::output_set::chain(&e), "grabber: no such camera");
    }
}
