//! Frames to disk: the `frames.jsonl` record every command writes (one
//! schema for `capture`, `render --sensor` and the calibration flows), and
//! the capture of a render through a simulated camera.

use std::io::Write;
use std::path::{Path, PathBuf};

use gloam_grabber::{Frame, FrameStatus};
use gloam_sensor::Camera;
use gloam_simcam::FrameExposureExt;
use ndarray::Array2;
use serde::Serialize;

use crate::output::{OutputError, png16_bytes, write_atomic};

/// One line of `frames.jsonl`.
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
    /// The stage whose clip the saturated pixels hit (`ccd-full-well`,
    /// `video-clip` or `digitizer-rail`), when the camera reports it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub saturated_by: Option<gloam_sensor::stages::bright::SaturatingStage>,
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
    pub sensor: Option<gloam_sensor::FrameMeta>,
}

impl FrameRecord {
    /// The record of a grabbed frame, with its exposure figures.
    pub fn of_grab(index: u64, file: String, f: &Frame, warnings: Vec<String>) -> Self {
        let exposure = f.exposure();
        Self {
            index,
            file,
            seq: f.meta.seq,
            timestamp: f.meta.timestamp_us,
            gain: f.meta.gain,
            agc: f.meta.agc,
            bits: f.meta.bits,
            width: f.meta.width,
            height: f.meta.height,
            pixels_crc32c: f.meta.pixels_crc32c,
            status: f.meta.status,
            mean_dn: exposure.mean_dn,
            saturated_fraction: exposure.saturated_fraction,
            saturated_at_dn: f
                .meta
                .levels
                .map_or(f64::from((1u32 << f.meta.bits.min(16)) - 1), |l| {
                    l.saturated_at_dn
                }),
            saturated_by: None,
            mcp_compressed_fraction: None,
            warnings,
            sensor: None,
        }
    }
}

impl FrameRecord {
    /// The record of frame `index` of an in-process simulated `camera`
    /// (just captured, so its chain state is the frame's), with its
    /// exposure warnings; `pixels` are the frame's counts in row order.
    pub fn of_sensor_frame(
        index: u64,
        file: String,
        frame: &gloam_sensor::DigitizedFrame,
        pixels: &[u16],
        camera: &Camera,
    ) -> Self {
        let (h, w) = frame.pixels.dim();
        let m = &frame.meta;
        let g = m.gain_in_effect;
        let chain = camera.chain();
        let (black, sat) = (chain.black_dn(g), chain.saturation_dn(g));
        let warnings = gloam_sensor::levels::exposure_warnings(
            m.mean_dn,
            m.saturated_fraction,
            Some(black),
            sat,
        );
        FrameRecord {
            index,
            file,
            seq: m.seq,
            timestamp: (m.time_s * 1e6).round() as u64,
            gain: g,
            agc: m.agc_enabled,
            bits: m.bits,
            width: w as u32,
            height: h as u32,
            pixels_crc32c: gloam_grabber::pixels_crc32c(pixels),
            status: FrameStatus::Ok,
            mean_dn: m.mean_dn,
            saturated_fraction: m.saturated_fraction,
            saturated_at_dn: chain.saturated_threshold_dn(g),
            saturated_by: Some(m.saturation.saturated_by),
            mcp_compressed_fraction: Some(m.saturation.mcp_compressed_fraction),
            warnings,
            sensor: Some(m.clone()),
        }
    }
}

/// Why `frames.jsonl` or a frame was not written, naming the file.
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
    #[error(transparent)]
    Frame(#[from] OutputError),
}

/// Appends records to `frames.jsonl` as frames are written, so an
/// interrupted run keeps every frame it wrote listed.
pub struct FrameLog {
    path: PathBuf,
    file: std::io::BufWriter<std::fs::File>,
}

impl FrameLog {
    /// Creates (truncates) `dir/frames.jsonl`.
    pub fn create(dir: &Path) -> Result<Self, FrameLogError> {
        let path = dir.join("frames.jsonl");
        let file = std::fs::File::create(&path).map_err(|source| FrameLogError::Create {
            path: path.clone(),
            source,
        })?;
        Ok(Self {
            path,
            file: std::io::BufWriter::new(file),
        })
    }

    /// Appends one record and flushes it to the file.
    pub fn append(&mut self, rec: &FrameRecord) -> Result<(), FrameLogError> {
        serde_json::to_writer(&mut self.file, rec).map_err(FrameLogError::Encode)?;
        (self.file.write_all(b"\n"))
            .and_then(|()| self.file.flush())
            .map_err(|source| FrameLogError::Append {
                path: self.path.clone(),
                source,
            })
    }
}

/// Writes frames as every command does: `frame-NNNNNN.png` (16-bit,
/// atomically) and then its record appended to `frames.jsonl`, so the
/// log never lists a frame that is not on disk.
pub struct FrameWriter {
    dir: PathBuf,
    log: FrameLog,
}

impl FrameWriter {
    /// Creates (truncates) `dir/frames.jsonl`.
    pub fn create(dir: &Path) -> Result<Self, FrameLogError> {
        Ok(Self {
            dir: dir.to_path_buf(),
            log: FrameLog::create(dir)?,
        })
    }

    /// Writes the frame `rec` describes (its file name and size) with its
    /// counts `pixels` in row order, then appends `rec` to the log.
    pub fn write(&mut self, rec: &FrameRecord, pixels: &[u16]) -> Result<(), FrameLogError> {
        let png = png16_bytes(rec.width, rec.height, pixels)?;
        write_atomic(&self.dir.join(&rec.file), &png)?;
        self.log.append(rec)
    }
}

/// Why a capture's options are refused.
#[derive(Debug, thiserror::Error)]
pub enum CaptureOptionsError {
    #[error("--frames must be at least 1")]
    NoFrames,
    #[error("loading sensor '{sensor}'")]
    Sensor {
        sensor: String,
        #[source]
        source: gloam_sensor::ConfigError,
    },
    #[error("--gain")]
    Gain(#[source] gloam_sensor::CaptureError),
}

/// Checks the sensor options of a capture (the sensor loads, `--gain` is
/// in its range, at least one frame) before anything expensive runs.
pub fn check_options(
    sensor: &str,
    gain: Option<f64>,
    frames: u32,
) -> Result<(), CaptureOptionsError> {
    if frames < 1 {
        return Err(CaptureOptionsError::NoFrames);
    }
    let mut camera =
        Camera::from_preset_or_file(sensor).map_err(|source| CaptureOptionsError::Sensor {
            sensor: sensor.to_string(),
            source,
        })?;
    if let Some(g) = gain {
        camera
            .set_override_gain(Some(g))
            .map_err(CaptureOptionsError::Gain)?;
    }
    Ok(())
}

/// Why a capture stopped, naming the step.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    #[error(transparent)]
    Options(#[from] CaptureOptionsError),
    #[error(transparent)]
    Exposure(#[from] crate::exposure::ExposureError),
    #[error(transparent)]
    Camera(#[from] gloam_sensor::ConfigError),
    #[error(transparent)]
    Gain(gloam_sensor::CaptureError),
    #[error("capturing frame {index}")]
    Frame {
        index: u32,
        #[source]
        source: gloam_sensor::CaptureError,
    },
    #[error(transparent)]
    Write(#[from] FrameLogError),
    #[error(transparent)]
    Output(#[from] OutputError),
    #[error("reading {}", path.display())]
    Report {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("encoding the capture's report")]
    Encode(#[source] serde_json::Error),
}

/// Adds `sensor_capture` (per-frame mean, saturated fraction, warnings) to
/// the render's `report.json` in `out`, when there is one.
fn record_in_report(out: &Path, capture: serde_json::Value) -> Result<(), CaptureError> {
    let path = out.join("report.json");
    // The report is this run's output, not an input.
    let Ok(text) = gloam_spectra::input::unrecorded(|| {
        gloam_spectra::input::read_text(&path, gloam_spectra::input::MAX_TEXT_FILE_BYTES)
    }) else {
        return Ok(());
    };
    let mut report: serde_json::Value =
        serde_json::from_str(&text).map_err(|source| CaptureError::Report {
            path: path.clone(),
            source,
        })?;
    if let Some(obj) = report.as_object_mut() {
        obj.insert("sensor_capture".into(), capture);
        let text = serde_json::to_string_pretty(&report).map_err(CaptureError::Encode)?;
        write_atomic(&path, text.as_bytes())?;
    }
    Ok(())
}

/// What to capture and how.
pub struct FrameCapture<'a> {
    pub sensor: &'a str,
    pub frames: u32,
    pub gain: Option<f64>,
    pub agc: bool,
    pub noise: bool,
    pub seed: u64,
    /// `--exposure auto`: choose gain, gate or exposure time and ND for
    /// this scene first ([`crate::exposure`]); the gain is then fixed.
    pub auto_exposure: Option<crate::exposure::ExposureTarget>,
}

/// One frame of a capture, as the camera made it.
pub struct CapturedFrame {
    /// Its line of `frames.jsonl` (file name, size, levels, warnings).
    pub record: FrameRecord,
    /// Its counts in row order.
    pub pixels: Vec<u16>,
    /// The camera's black level at the frame's gain, DN.
    pub black_dn: f64,
}

/// What a capture found besides its frames: what to tell its user and
/// what to record.
#[derive(Clone, Debug)]
pub struct Captured {
    /// Lines for the user: the automatic exposure's choice and each kind
    /// of exposure warning once (the front end prints them).
    pub notes: Vec<String>,
    /// `report.json`'s `sensor_capture`: the exposure chosen, per-frame
    /// levels and the saturation summary.
    pub report: serde_json::Value,
}

impl FrameCapture<'_> {
    /// [`check_options`] of this capture: refuses a sensor that does not
    /// load, a gain outside its range or no frames, before the render.
    pub fn check(&self) -> Result<(), CaptureOptionsError> {
        check_options(self.sensor, self.gain, self.frames)
    }

    /// Captures `frames` frames of the detected-electron radiance
    /// `detected` (e⁻ s⁻¹ m⁻² sr⁻¹, from [`take_detected_band`]), handing
    /// each to `on_frame` as it is made (so a long capture holds one frame
    /// at a time); writes and prints nothing. [`FrameCapture::run`] writes
    /// them; the sweep also keeps their pixels for its noise figures.
    ///
    /// [`take_detected_band`]: crate::take_detected_band
    pub fn capture(
        &self,
        detected: &Array2<f64>,
        on_frame: &mut dyn FnMut(CapturedFrame) -> Result<(), CaptureError>,
    ) -> Result<Captured, CaptureError> {
        if self.frames < 1 {
            return Err(CaptureOptionsError::NoFrames.into());
        }
        let mut config = gloam_sensor::load_preset_or_file(self.sensor).map_err(|source| {
            CaptureOptionsError::Sensor {
                sensor: self.sensor.to_string(),
                source,
            }
        })?;
        config.noise.seed = self.seed;
        let mut notes = Vec::new();
        let exposure = match &self.auto_exposure {
            Some(target) => {
                let c = crate::exposure::choose(&config, detected, target)?;
                crate::exposure::apply(&mut config, &c);
                notes.push(format!(
                    "exposure auto: gain {:.4}, gate duty {}, exposure {:.4e} s, ND {:.2} → p{} at {:.0} DN, median {:.0} DN ({})",
                    c.gain,
                    c.gate_duty.map_or("—".into(), |d| format!("{d:.3e}")),
                    c.exposure_s,
                    c.nd_density,
                    c.target.percentile,
                    c.percentile_dn,
                    c.median_dn,
                    c.note
                ));
                if c.stops_out_of_range != 0.0 {
                    notes.push(format!("warning: {}", c.note));
                }
                Some(c)
            }
            None => None,
        };
        let mut camera = Camera::new(config)?;
        camera.set_noise(self.noise);
        if let Some(g) = self.gain.or(exposure.as_ref().map(|c| c.gain)) {
            camera
                .set_override_gain(Some(g))
                .map_err(CaptureError::Gain)?;
        }
        if self.agc {
            camera.set_agc(true);
        }
        tracing::debug!(sensor = self.sensor, frames = self.frames, "capturing");
        let mut warned = std::collections::BTreeSet::new();
        let mut per_frame = Vec::new();
        let mut summary = SaturationSummary::default();
        for i in 0..self.frames {
            let frame = camera
                .capture_detected(detected.view())
                .map_err(|source| CaptureError::Frame { index: i, source })?;
            let pixels: Vec<u16> = frame.pixels.iter().copied().collect();
            let file = format!("frame-{i:06}.png");
            let m = &frame.meta;
            let g = m.gain_in_effect;
            let chain = camera.chain();
            let (black, sat) = (chain.black_dn(g), chain.saturation_dn(g));
            let args = (m.mean_dn, m.saturated_fraction, Some(black), sat);
            let kinds = gloam_sensor::levels::warning_kinds(args.0, args.1, args.2, args.3);
            let rec = FrameRecord::of_sensor_frame(u64::from(i), file, &frame, &pixels, &camera);
            // The record's warnings are these kinds' messages, in order.
            for (w, k) in rec.warnings.iter().zip(&kinds) {
                if warned.insert(*k) {
                    let by = match k {
                        gloam_sensor::levels::WarningKind::Saturated => format!(
                            " (clipped at the {})",
                            stage_name(m.saturation.saturated_by)
                        ),
                        _ => String::new(),
                    };
                    notes.push(format!("warning: frame {i}: {w}{by}"));
                }
            }
            per_frame.push(serde_json::json!({
                "file": format!("frame-{i:06}.png"),
                "gain": g,
                "mean_dn": m.mean_dn,
                "saturated_fraction": m.saturated_fraction,
                "saturated_by": m.saturation.saturated_by,
                "mcp_compressed_fraction": m.saturation.mcp_compressed_fraction,
                "bright_source_in_view": m.saturation.bright_source_in_view,
                "warnings": kinds,
            }));
            summary.add(&m.saturation);
            tracing::debug!(frame = i, gain = g, mean_dn = m.mean_dn, "captured");
            on_frame(CapturedFrame {
                record: rec,
                pixels,
                black_dn: black,
            })?;
        }
        let report = serde_json::json!({
            "sensor": self.sensor,
            "exposure": exposure,
            "frames": per_frame,
            "saturation": summary,
            "thresholds": {
                "saturated_fraction_warning": gloam_sensor::levels::SATURATED_WARN_FRACTION,
                "near_full_scale_fraction": gloam_sensor::levels::NEAR_FULL_SCALE_FRACTION,
                "near_black_dn": gloam_sensor::levels::NEAR_BLACK_DN,
            },
        });
        Ok(Captured { notes, report })
    }

    /// [`FrameCapture::capture`] into `out`: `frame-NNNNNN.png` and
    /// `frames.jsonl` as frames are made, and `sensor_capture` added to
    /// `out/report.json` when there is one. Returns what its user should
    /// be told, as lines; the front end prints them.
    pub fn run(&self, detected: &Array2<f64>, out: &Path) -> Result<Vec<String>, CaptureError> {
        let mut writer = None;
        let captured = self.capture(detected, &mut |f| {
            let w = match &mut writer {
                Some(w) => w,
                None => writer.insert(FrameWriter::create(out)?),
            };
            Ok(w.write(&f.record, &f.pixels)?)
        })?;
        record_in_report(out, captured.report)?;
        Ok(captured.notes)
    }
}

/// A stage's name in messages.
fn stage_name(s: gloam_sensor::stages::bright::SaturatingStage) -> &'static str {
    use gloam_sensor::stages::bright::SaturatingStage as S;
    match s {
        S::CcdFullWell => "CCD full well",
        S::VideoClip => "analogue video clip",
        S::DigitizerRail => "digitizer rail",
    }
}

/// `report.json`'s summary of a capture's saturation: "saturated" is
/// information lost (a clip at full well, video clip or digitizer rail);
/// the MCP's soft compression is counted apart.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SaturationSummary {
    pub frames: u64,
    /// Worst and mean saturated fraction over the frames.
    pub max_saturated_fraction: f64,
    pub mean_saturated_fraction: f64,
    /// Frames above the 1 % warning fraction.
    pub frames_over_warning: u64,
    /// The stages that clipped, with the frames each set the level in.
    pub saturated_by: std::collections::BTreeMap<String, u64>,
    /// Worst fraction of pixels the MCP compressed by more than 10 %.
    pub max_mcp_compressed_fraction: f64,
    /// Frames with a bright source in view (halo and pore depletion on).
    pub bright_source_frames: u64,
    /// Frames where the tube's ABC cut the gain or the gate.
    pub abc_active_frames: u64,
}

impl SaturationSummary {
    pub fn add(&mut self, s: &gloam_sensor::stages::bright::SaturationAccount) {
        let n = self.frames as f64;
        self.mean_saturated_fraction =
            (self.mean_saturated_fraction * n + s.saturated_fraction) / (n + 1.0);
        self.frames += 1;
        self.max_saturated_fraction = self.max_saturated_fraction.max(s.saturated_fraction);
        if s.saturated_fraction > gloam_sensor::levels::SATURATED_WARN_FRACTION {
            self.frames_over_warning += 1;
        }
        if s.saturated_fraction > 0.0 {
            let key = serde_json::to_value(s.saturated_by)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            *self.saturated_by.entry(key).or_default() += 1;
        }
        self.max_mcp_compressed_fraction = self
            .max_mcp_compressed_fraction
            .max(s.mcp_compressed_fraction);
        self.bright_source_frames += u64::from(s.bright_source_in_view);
        self.abc_active_frames += u64::from(s.abc.gain_factor < 1.0 || s.abc.duty_factor < 1.0);
    }
}
