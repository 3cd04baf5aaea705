//! `frames.jsonl`, the log beside a run's frames: one JSON object per
//! line, one line per frame written. Its one record ([`FrameRecord`],
//! with where the counts are stored, [`FrameStorage`], and a sequence's
//! [`SequenceFrame`]), its one writer ([`FrameLog`]) and its one reader
//! ([`lines`], [`find`]), so its name, its fields, its line numbering and
//! its lookup by file and page are defined once.
//!
//! The reader hands on each line as JSON ([`FrameLine`]): a log may be
//! written by an older gloam or by hand with only some fields (`file` and
//! `gain` are enough for `calibrate apply`), so each reader asks for the
//! fields it needs and says what is missing in its own words; the typed
//! accessors here check what every reader checks the same way.

use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::Value;

use crate::frame::{Frame, FrameStatus, SaturatingStage, SensorMeta, mean_dn, saturated_fraction};

/// The log's file name, beside the frames it lists.
pub const FRAMES_JSONL: &str = "frames.jsonl";

/// The `frames.jsonl` beside a frame file (in its directory).
pub fn beside(frame: &Path) -> PathBuf {
    frame.parent().unwrap_or(Path::new(".")).join(FRAMES_JSONL)
}

/// One line of `frames.jsonl`: the one record every command writes
/// (`capture`, `render --sensor`, `sequence`, the calibration flows, a
/// sweep's tasks).
#[derive(Clone, Debug, Serialize)]
pub struct FrameRecord {
    pub index: u64,
    pub file: String,
    pub seq: u64,
    /// Device clock, µs since the stream started.
    pub timestamp: u64,
    pub gain: f64,
    pub agc: bool,
    pub bits: u8,
    pub width: u32,
    pub height: u32,
    pub pixels_crc32c: u32,
    pub status: FrameStatus,
    pub mean_dn: f64,
    /// Fraction of pixels at or above `saturated_at_dn`.
    pub saturated_fraction: f64,
    /// The camera's saturated level when it reports one (simulated
    /// cameras), else the top code 2^bits − 1.
    pub saturated_at_dn: f64,
    /// The camera's black level (no light) at this frame's gain, DN, when
    /// it reports one (simulated cameras).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub black_dn: Option<f64>,
    /// The camera's mean conversion at this frame's gain, photoelectrons
    /// per DN (1/K of photon transfer: FITS `GAIN`), when it knows it
    /// (simulated cameras; not real cameras over a link).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub electrons_per_dn: Option<f64>,
    /// The ND filter's optical density and the photocathode's gate duty
    /// cycle as configured (before the tube's ABC), for simulated cameras.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nd_density: Option<f64>,
    /// For a grabbed frame, the gate duty in effect (configured duty ×
    /// the tube's autogating), when the camera reports it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gate_duty: Option<f64>,
    /// Exposure of a grabbed frame, µs, when the camera reports it (an
    /// in-process render has it in `sensor.exposure_s`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exposure_us: Option<f64>,
    /// The stage whose clip the saturated pixels hit (`ccd-full-well`,
    /// `video-clip` or `digitizer-rail`), when the camera reports it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub saturated_by: Option<SaturatingStage>,
    /// Fraction of pixels the MCP compressed by more than 10 % (soft, not
    /// saturated: no information lost), when the camera reports it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mcp_compressed_fraction: Option<f64>,
    /// Exposure warnings for this frame (also printed on stderr).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// The simulated camera's own figures, when the frame came from one
    /// in process.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor: Option<SensorMeta>,
    /// How the counts sit in `file` (format, shift, TIFF page); set by
    /// the writer of the frame file (`gloam_pipeline`'s `FrameWriter`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stored: Option<FrameStorage>,
    /// The frame's time and light-group weights, in a sequence
    /// (`gloam sequence`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sequence: Option<SequenceFrame>,
}

impl FrameRecord {
    /// The record of frame `index` stored in `file`, with its exposure
    /// `warnings`: its settings and levels as its meta says; with the
    /// sensor model's own figures (`meta.sensor`, a frame made in
    /// process) their mean, saturated fraction, clipping stage and MCP
    /// compression, else the mean and saturated fraction of its counts.
    pub fn of_frame(index: u64, file: String, f: &Frame, warnings: Vec<String>) -> Self {
        let m = &f.meta;
        let top = f64::from((1u32 << m.bits.min(16)) - 1);
        let saturated_at_dn = m.levels.map_or(top, |l| l.saturated_at_dn);
        let sensor = m.sensor.as_ref();
        Self {
            index,
            file,
            seq: m.seq,
            timestamp: m.timestamp_us,
            gain: m.gain,
            agc: m.agc,
            bits: m.bits,
            width: m.width,
            height: m.height,
            pixels_crc32c: m.pixels_crc32c,
            status: m.status,
            mean_dn: sensor.map_or_else(|| mean_dn(&f.pixels), |s| s.mean_dn),
            saturated_fraction: sensor.map_or_else(
                || saturated_fraction(&f.pixels, saturated_at_dn),
                |s| s.saturated_fraction,
            ),
            saturated_at_dn,
            black_dn: m.levels.map(|l| l.black_dn),
            electrons_per_dn: m.levels.and_then(|l| l.electrons_per_dn),
            nd_density: m.nd_density,
            gate_duty: m.gate_duty,
            exposure_us: m.exposure_us,
            saturated_by: sensor.map(|s| s.saturation.saturated_by),
            mcp_compressed_fraction: sensor.map(|s| s.saturation.mcp_compressed_fraction),
            warnings,
            sensor: m.sensor.clone(),
            stored: None,
            sequence: None,
        }
    }
}

/// How frames are stored (`--frame-format`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FrameFormat {
    #[default]
    Png,
    Fits,
    Tiff,
}

impl FrameFormat {
    /// The names (`--frame-format`), shared with the readers.
    pub const NAMES: [&'static str; 3] = ["png", "fits", "tiff"];

    /// The file frame `index` is stored in (all frames share one TIFF).
    pub fn file_name(self, index: u64) -> String {
        match self {
            Self::Png => format!("frame-{index:06}.png"),
            Self::Fits => format!("frame-{index:06}.fits"),
            Self::Tiff => TIFF_STACK.to_string(),
        }
    }
}

/// The multi-page TIFF of a capture.
pub const TIFF_STACK: &str = "frames.tiff";

/// A frame format name that is none of [`FrameFormat::NAMES`].
#[derive(Debug, thiserror::Error)]
#[error("frame format '{0}' is none of png, fits, tiff")]
pub struct UnknownFrameFormat(pub String);

impl std::str::FromStr for FrameFormat {
    type Err = UnknownFrameFormat;
    fn from_str(s: &str) -> Result<Self, UnknownFrameFormat> {
        match s {
            "png" => Ok(Self::Png),
            "fits" => Ok(Self::Fits),
            "tiff" => Ok(Self::Tiff),
            other => Err(UnknownFrameFormat(other.to_string())),
        }
    }
}
/// How one frame's counts sit in its file (`frames.jsonl`'s `stored`):
/// counts = stored sample >> `sample_shift` (FITS after BZERO).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameStorage {
    pub format: FrameFormat,
    pub sample_shift: u8,
    /// The page of `frames.tiff` (from 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub page: Option<u64>,
}

/// One frame's place in a sequence (`gloam sequence`; its line's
/// `sequence`).
#[derive(Clone, Debug, Serialize)]
pub struct SequenceFrame {
    /// Start of the frame's exposure window, s from the sequence's start.
    pub time_s: f64,
    /// The window's length, s (the camera's exposure time).
    pub window_s: f64,
    /// Each light group's mean relative intensity over the window.
    pub light_groups: std::collections::BTreeMap<String, f64>,
    /// With a `[sky]` clock: the sky at mid-exposure.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky: Option<SkyAtFrame>,
    /// With a `[sky]` clock: the frame's median count above black, DN
    /// (what a median-metering AGC holds; the record's `mean_dn` beside).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub median_above_black_dn: Option<f64>,
}

/// The sky a frame saw (a sequence with a `[sky]` clock).
#[derive(Clone, Debug, Serialize)]
pub struct SkyAtFrame {
    /// The sky's instant at mid-exposure, ISO 8601.
    pub utc: String,
    /// The Sun's geometric elevation then, degrees (linear between the
    /// renders' instants).
    pub sun_elevation_deg: f64,
    /// The site's horizontal illuminance the photocells see, lux.
    pub horizontal_lux: f64,
    /// The two sky renders this frame's image lies between and how far
    /// towards the second (each pixel `a^{1−f} b^f`).
    pub renders: [usize; 2],
    pub fraction: f64,
}

/// Why `frames.jsonl` was not written, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum FrameLogError {
    #[error("creating {}", path.display())]
    Create {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("writing {}", path.display())]
    Append {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("writing frames.jsonl")]
    Encode(#[source] serde_json::Error),
}

/// Appends records to `frames.jsonl` as frames are written, each flushed
/// at once, so an interrupted run keeps every frame it wrote listed.
pub struct FrameLog {
    path: PathBuf,
    file: std::io::BufWriter<std::fs::File>,
}

impl FrameLog {
    /// Creates (truncates) `dir/frames.jsonl`.
    pub fn create(dir: &Path) -> Result<Self, FrameLogError> {
        let path = dir.join(FRAMES_JSONL);
        let file = std::fs::File::create(&path).map_err(|source| FrameLogError::Create {
            path: path.clone(),
            source,
        })?;
        Ok(Self {
            path,
            file: std::io::BufWriter::new(file),
        })
    }

    /// Appends one record as one line and flushes it to the file.
    pub fn append<R: Serialize + ?Sized>(&mut self, rec: &R) -> Result<(), FrameLogError> {
        serde_json::to_writer(&mut self.file, rec).map_err(FrameLogError::Encode)?;
        (self.file.write_all(b"\n"))
            .and_then(|()| self.file.flush())
            .map_err(|source| FrameLogError::Append {
                path: self.path.clone(),
                source,
            })
    }
}

/// Why `frames.jsonl` could not be read; each reader words it its own way.
#[derive(Debug, thiserror::Error)]
pub enum FramesReadError {
    /// The file does not open (missing, not a regular file, too large).
    #[error("{}: {source}", path.display())]
    Open {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A line could not be read (not UTF-8, an I/O error).
    #[error("{}: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A line is not JSON.
    #[error("{}:{line}: {source}", path.display())]
    Json {
        path: PathBuf,
        line: usize,
        #[source]
        source: serde_json::Error,
    },
    /// A byte-order mark past the file's start (two logs joined with
    /// `cat`, say): named, not a JSON error at column 1.
    #[error(
        "{}:{line}: starts with a byte-order mark (U+FEFF); only the file's first line may",
        path.display()
    )]
    Bom { path: PathBuf, line: usize },
    /// A second line for one frame (one file, one page): refused, never
    /// resolved by order.
    #[error(
        "{}:{line}: records {name}{} again (first at line {first}): one frame, two records",
        path.display(),
        page.map_or(String::new(), |p| format!(" page {p}"))
    )]
    Twice {
        path: PathBuf,
        line: usize,
        name: String,
        page: Option<u64>,
        first: usize,
    },
}

/// A field of a line that is there but not what the log's schema says.
#[derive(Debug, thiserror::Error)]
#[error("\"{key}\" {value} is not {expected}")]
pub struct FieldError {
    pub key: &'static str,
    pub value: Value,
    pub expected: &'static str,
}

/// Where one frame's counts sit in its file, as its line's `stored` says
/// (`{"format", "sample_shift", "page"}`); unknown fields stay `None` and
/// are then read from the file itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StoredAt {
    /// The page of a multi-page TIFF (from 0).
    pub page: Option<u64>,
    /// counts = sample >> shift (PNG and TIFF frames).
    pub sample_shift: Option<u8>,
}

/// One line of `frames.jsonl`: its 1-based number (blank lines counted)
/// and its JSON.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameLine {
    pub line: usize,
    pub value: Value,
}

impl FrameLine {
    /// The field `key`, if there.
    pub fn get(&self, key: &str) -> Option<&Value> {
        self.value.get(key)
    }

    /// The frame's file name (`file`), if a string.
    pub fn file(&self) -> Option<&str> {
        self.get("file").and_then(Value::as_str)
    }

    /// The numeric field `key`, if a number.
    pub fn number(&self, key: &str) -> Option<f64> {
        self.get(key).and_then(Value::as_f64)
    }

    /// Its `stored` object (absent or not numbers: `None`s).
    pub fn stored(&self) -> StoredAt {
        let s = self.get("stored");
        let field = |k: &str| s.and_then(|s| s.get(k)).and_then(Value::as_u64);
        StoredAt {
            page: field("page"),
            sample_shift: field("sample_shift").and_then(|v| u8::try_from(v).ok()),
        }
    }

    /// Its `pixels_crc32c` (of the counts as little-endian `u16`), `None`
    /// when it records none.
    pub fn pixels_crc32c(&self) -> Result<Option<u32>, FieldError> {
        let Some(v) = self.get("pixels_crc32c") else {
            return Ok(None);
        };
        (v.as_u64().and_then(|c| u32::try_from(c).ok()))
            .map(Some)
            .ok_or_else(|| FieldError {
                key: "pixels_crc32c",
                value: v.clone(),
                expected: "a CRC-32C (a whole number below 2^32)",
            })
    }

    /// Its digitizer depth `bits`, `None` when it records none.
    pub fn bits(&self) -> Result<Option<u8>, FieldError> {
        let Some(v) = self.get("bits") else {
            return Ok(None);
        };
        (v.as_u64().filter(|b| (1..=16).contains(b)))
            .map(|b| Some(b as u8))
            .ok_or_else(|| FieldError {
                key: "bits",
                value: v.clone(),
                expected: "a digitizer depth (1..=16)",
            })
    }
}

/// The lines of the `frames.jsonl` at `path` in order, blank lines
/// skipped, read within [`crate::MAX_TEXT_FILE_BYTES`]; the first line
/// that does not read or parse ends them with its error; `reads` notes the
/// file.
pub fn lines(path: &Path, reads: &crate::ReadLog) -> Result<Lines, FramesReadError> {
    let f = crate::open_bounded(path, crate::MAX_TEXT_FILE_BYTES, reads).map_err(|source| {
        FramesReadError::Open {
            path: path.to_path_buf(),
            source,
        }
    })?;
    Ok(Lines {
        path: path.to_path_buf(),
        lines: std::io::BufReader::new(f).lines().enumerate(),
        failed: false,
    })
}

/// The lines of one `frames.jsonl` ([`lines`]).
pub struct Lines {
    path: PathBuf,
    lines: std::iter::Enumerate<std::io::Lines<std::io::BufReader<std::io::Take<std::fs::File>>>>,
    failed: bool,
}

impl Lines {
    /// The file read.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Iterator for Lines {
    type Item = Result<FrameLine, FramesReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        // Bounded: the file was opened within its size limit.
        for (i, line) in self.lines.by_ref() {
            let parsed = line
                .map_err(|source| FramesReadError::Read {
                    path: self.path.clone(),
                    source,
                })
                .and_then(|line| {
                    // A BOM at the file's start is taken, as in every CSV
                    // reader (an editor may save one); elsewhere it is named.
                    let line = match line.strip_prefix('\u{feff}') {
                        Some(rest) if i == 0 => rest,
                        Some(_) => {
                            return Err(FramesReadError::Bom {
                                path: self.path.clone(),
                                line: i + 1,
                            });
                        }
                        None => &line,
                    };
                    if line.trim().is_empty() {
                        return Ok(None);
                    }
                    crate::json::parse_value(line)
                        .map(|value| Some(FrameLine { line: i + 1, value }))
                        .map_err(|source| FramesReadError::Json {
                            path: self.path.clone(),
                            line: i + 1,
                            source,
                        })
                });
            match parsed {
                Ok(None) => continue,
                Ok(Some(l)) => return Some(Ok(l)),
                Err(e) => {
                    self.failed = true;
                    return Some(Err(e));
                }
            }
        }
        None
    }
}

/// The line of the `frames.jsonl` at `path` that records the frame file
/// `name` (and, with `page`, whose `stored.page` is it: the frames of a
/// TIFF stack share one file; a line without a page is page 0). Every
/// line is read: a second line for the same frame is refused
/// ([`FramesReadError::Twice`]).
pub fn find(
    path: &Path,
    name: &str,
    page: Option<u64>,
    reads: &crate::ReadLog,
) -> Result<Option<FrameLine>, FramesReadError> {
    let mut found: Option<(FrameLine, Option<u64>)> = None;
    for l in lines(path, reads)? {
        let l = l?;
        if l.file() != Some(name) {
            continue;
        }
        let at_page = l.stored().page;
        match &found {
            Some((first, first_page)) if *first_page == at_page => {
                return Err(FramesReadError::Twice {
                    path: path.to_path_buf(),
                    line: l.line,
                    name: name.to_string(),
                    page: at_page,
                    first: first.line,
                });
            }
            Some(_) => {}
            None if page.is_none_or(|p| at_page.unwrap_or(0) == p) => found = Some((l, at_page)),
            None => {}
        }
    }
    Ok(found.map(|(l, _)| l))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct Rec<'a> {
        file: &'a str,
        gain: f64,
    }

    /// What the log writes, the reader reads back, line by line.
    #[test]
    fn a_written_log_reads_back() {
        let d = tempfile::tempdir().unwrap();
        let mut log = FrameLog::create(d.path()).unwrap();
        log.append(&Rec {
            file: "a.png",
            gain: 2.5,
        })
        .unwrap();
        log.append(&Rec {
            file: "b.png",
            gain: 7.0,
        })
        .unwrap();
        drop(log);
        let path = d.path().join(FRAMES_JSONL);
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(
            text,
            "{\"file\":\"a.png\",\"gain\":2.5}\n{\"file\":\"b.png\",\"gain\":7.0}\n"
        );
        let got: Vec<FrameLine> = lines(&path, &crate::ReadLog::off())
            .unwrap()
            .map(Result::unwrap)
            .collect();
        assert_eq!(got.len(), 2);
        assert_eq!(
            (got[1].line, got[1].file(), got[1].number("gain")),
            (2, Some("b.png"), Some(7.0))
        );
    }

    /// A number reads back as the very float written: without
    /// serde_json's `float_roundtrip`, 0.4601718756336968 (a pilot's share
    /// in report.json) came back one ulp off.
    #[test]
    fn numbers_read_back_to_the_bit() {
        let d = tempfile::tempdir().unwrap();
        let mut log = FrameLog::create(d.path()).unwrap();
        let hard = [0.4601718756336968, 0.46017187563369677, 1.0e-310, 5e-324];
        for g in hard {
            log.append(&Rec { file: "a", gain: g }).unwrap();
        }
        drop(log);
        let path = d.path().join(FRAMES_JSONL);
        let got: Vec<f64> = lines(&path, &crate::ReadLog::off())
            .unwrap()
            .map(|l| l.unwrap().number("gain").unwrap())
            .collect();
        let bits = |v: &[f64]| v.iter().map(|g| g.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&got), bits(&hard));
    }

    /// Blank lines count in the numbering; a bad line names its number.
    #[test]
    fn lines_are_numbered_as_in_the_file() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join(FRAMES_JSONL);
        std::fs::write(&path, "\n{\"file\":\"a\"}\n\nnot json\n{}\n").unwrap();
        let mut it = lines(&path, &crate::ReadLog::off()).unwrap();
        assert_eq!(it.next().unwrap().unwrap().line, 2);
        match it.next().unwrap() {
            Err(FramesReadError::Json { line: 4, .. }) => {}
            other => panic!("{other:?}"),
        }
        assert!(it.next().is_none(), "a failed read ends the lines");
    }

    /// A BOM before the first line is taken (as the CSV readers take
    /// one); one before a later line is named at its line.
    #[test]
    fn a_bom_is_taken_at_the_start_only() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join(FRAMES_JSONL);
        std::fs::write(
            &path,
            "\u{feff}{\"file\":\"a\"}\n\u{feff}{\"file\":\"b\"}\n",
        )
        .unwrap();
        let mut it = lines(&path, &crate::ReadLog::off()).unwrap();
        assert_eq!(it.next().unwrap().unwrap().file(), Some("a"));
        let e = it.next().unwrap().unwrap_err();
        assert!(matches!(e, FramesReadError::Bom { line: 2, .. }), "{e:?}");
        assert!(
            e.to_string().ends_with(
                ":2: starts with a byte-order mark (U+FEFF); only the file's first line may"
            ),
            "{e}"
        );
    }

    /// One frame, one line: a TIFF stack's pages are told apart, a
    /// second line for the frame looked for is refused naming both lines.
    #[test]
    fn find_picks_the_page_and_refuses_a_second_line() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join(FRAMES_JSONL);
        let page = |p: u64, g: u32| {
            format!("{{\"file\":\"s.tiff\",\"gain\":{g},\"stored\":{{\"page\":{p}}}}}\n")
        };
        std::fs::write(&path, page(0, 1) + &page(1, 2)).unwrap();
        let l = find(&path, "s.tiff", Some(1), &crate::ReadLog::off())
            .unwrap()
            .unwrap();
        assert_eq!((l.line, l.number("gain")), (2, Some(2.0)));
        assert!(
            find(&path, "t.tiff", None, &crate::ReadLog::off())
                .unwrap()
                .is_none()
        );
        std::fs::write(&path, page(0, 1) + &page(1, 2) + &page(1, 3)).unwrap();
        assert_eq!(
            find(&path, "s.tiff", Some(0), &crate::ReadLog::off())
                .unwrap()
                .unwrap()
                .line,
            1
        );
        let e = find(&path, "s.tiff", Some(1), &crate::ReadLog::off()).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{}:3: records s.tiff page 1 again (first at line 2): one frame, two records",
                path.display()
            )
        );
    }

    /// The checked fields refuse what is not their type, quoting it.
    #[test]
    fn fields_are_checked() {
        let l = |v: Value| FrameLine { line: 1, value: v };
        let v = serde_json::json!({"pixels_crc32c": -1, "bits": 17});
        assert_eq!(
            l(v.clone()).pixels_crc32c().unwrap_err().to_string(),
            "\"pixels_crc32c\" -1 is not a CRC-32C (a whole number below 2^32)"
        );
        assert_eq!(
            l(v).bits().unwrap_err().to_string(),
            "\"bits\" 17 is not a digitizer depth (1..=16)"
        );
        let ok = l(
            serde_json::json!({"pixels_crc32c": 7, "bits": 12, "stored": {"page": 3, "sample_shift": 4}}),
        );
        assert_eq!(ok.pixels_crc32c().unwrap(), Some(7));
        assert_eq!(ok.bits().unwrap(), Some(12));
        assert_eq!(
            ok.stored(),
            StoredAt {
                page: Some(3),
                sample_shift: Some(4)
            }
        );
        assert_eq!(l(serde_json::json!({})).pixels_crc32c().unwrap(), None);
    }

    fn frame(sensor: Option<SensorMeta>) -> Frame {
        use crate::frame::{DnLevels, FrameMeta};
        Frame {
            meta: FrameMeta {
                seq: 3,
                timestamp_us: 120_000,
                gain: 40.0,
                agc: false,
                bits: 12,
                width: 2,
                height: 2,
                pixels_crc32c: 9,
                status: FrameStatus::Ok,
                levels: Some(DnLevels {
                    black_dn: 10.0,
                    saturation_dn: 4095.0,
                    saturated_at_dn: 4000.0,
                    electrons_per_dn: Some(0.5),
                }),
                exposure_us: None,
                gate_duty: Some(0.25),
                nd_density: Some(1.5),
                sensor,
            },
            pixels: vec![0, 100, 4000, 4095],
        }
    }

    /// A frame's record is its meta; its mean and saturated fraction are
    /// its counts' (4195 / 2 of 4 at or above 4000) unless the sensor
    /// model's own figures come with it, which it then takes whole.
    #[test]
    fn a_record_is_its_frames_meta() {
        use crate::frame::{AgcState, SaturationAccount};
        let r = FrameRecord::of_frame(7, "f.png".into(), &frame(None), vec!["w".into()]);
        assert_eq!((r.index, r.seq, r.timestamp, r.gain), (7, 3, 120_000, 40.0));
        assert_eq!((r.width, r.height, r.pixels_crc32c), (2, 2, 9));
        assert_eq!((r.mean_dn, r.saturated_fraction), (2048.75, 0.5));
        assert_eq!((r.saturated_at_dn, r.black_dn), (4000.0, Some(10.0)));
        assert_eq!((r.electrons_per_dn, r.gate_duty), (Some(0.5), Some(0.25)));
        assert_eq!((r.nd_density, r.warnings.len()), (Some(1.5), 1));
        assert!(r.sensor.is_none() && r.saturated_by.is_none());
        let sensor = SensorMeta {
            seq: 3,
            time_s: 0.12,
            exposure_s: 0.04,
            gain_in_effect: 40.0,
            mcp_voltage_v: None,
            control_voltage_v: None,
            agc_enabled: false,
            agc_state: AgcState::Off,
            bits: 12,
            width: 2,
            height: 2,
            mean_dn: 2000.0,
            saturated_fraction: 0.75,
            noise: true,
            saturation: SaturationAccount {
                mcp_compressed_fraction: 0.125,
                saturated_by: SaturatingStage::VideoClip,
                ..SaturationAccount::default()
            },
            median_dn: None,
        };
        let r = FrameRecord::of_frame(7, "f.png".into(), &frame(Some(sensor.clone())), vec![]);
        assert_eq!((r.mean_dn, r.saturated_fraction), (2000.0, 0.75));
        assert_eq!(r.saturated_by, Some(SaturatingStage::VideoClip));
        assert_eq!(r.mcp_compressed_fraction, Some(0.125));
        assert_eq!(r.sensor, Some(sensor));
    }

    /// The 2-D view is rows first; counts that do not fill the frame are
    /// an error naming both sizes.
    #[test]
    fn a_frame_views_as_rows_and_columns() {
        let mut f = frame(None);
        assert_eq!(f.view().unwrap()[[1, 0]], 4000);
        f.meta.width = 3;
        assert_eq!(
            f.view().unwrap_err().to_string(),
            "frame of 3×2 carries 4 counts"
        );
    }
}
