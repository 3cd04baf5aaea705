//! The capture of a render through a simulated camera: the options
//! checked before the render, the camera run frame by frame with its
//! automatic exposure and fit, each frame's `frames.jsonl` record, and the
//! saturation summary `report.json` gets. [`crate::frames`] writes the
//! frames.

use std::path::{Path, PathBuf};

use gloam_sensor::{Camera, Frame};
use gloam_simcam::FrameExposureExt;
use ndarray::Array2;
use serde::Serialize;

use crate::frame_files::FrameFormat;
use crate::frames::{FrameContext, FrameLogError, FrameRecord, FrameWriter};
use crate::output::OutputError;
use gloam_sensor::ResolvedSensor;

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
    /// The scene's own `sensor` entry names no camera gloam can read.
    #[error("{at}: sensor")]
    SceneSensor {
        /// `scene.toml:LINE`.
        at: String,
        #[source]
        source: Box<CaptureOptionsError>,
    },
}

/// [`resolve_sensor`] of the camera a render of `scene` (read from
/// `scene_path`) is made for: `given` (`--sensor`), else the scene's own
/// `sensor` entry, whose error is placed at that entry's line (an unknown
/// preset in a scene was refused without naming the scene).
pub fn resolve_scene_sensor(
    given: Option<&str>,
    scene: &gloam_scene::Scene,
    scene_path: &std::path::Path,
    reads: &gloam_io::ReadLog,
) -> Result<Option<ResolvedSensor>, CaptureOptionsError> {
    let Some(name) = crate::render::camera_of(given, scene) else {
        return Ok(None);
    };
    resolve_sensor(name, reads).map(Some).map_err(|e| {
        if given.is_some() {
            return e;
        }
        // Read again only on this error, for the entry's line.
        let line = gloam_io::read_text(
            scene_path,
            gloam_io::MAX_TEXT_FILE_BYTES,
            &gloam_io::ReadLog::off(),
        )
        .map_or(1, |text| {
            gloam_io::toml_place::line_of_field(&text, "sensor")
        });
        CaptureOptionsError::SceneSensor {
            at: format!("{}:{line}", scene_path.display()),
            source: Box::new(e),
        }
    })
}

/// Reads the sensor `name` (a preset or sensor TOML) once for a run
/// ([`ResolvedSensor`]), an error naming it; `reads` notes a sensor file.
pub fn resolve_sensor(
    name: &str,
    reads: &gloam_io::ReadLog,
) -> Result<ResolvedSensor, CaptureOptionsError> {
    ResolvedSensor::load(name, reads).map_err(|source| CaptureOptionsError::Sensor {
        sensor: name.to_string(),
        source,
    })
}

/// Checks the sensor options of a capture (`--gain` is in the sensor's
/// range, at least one frame) before anything expensive runs; the sensor
/// itself was checked when it was read ([`resolve_sensor`]).
pub fn check_options(
    sensor: &ResolvedSensor,
    gain: Option<f64>,
    frames: u32,
) -> Result<(), CaptureOptionsError> {
    if frames < 1 {
        return Err(CaptureOptionsError::NoFrames);
    }
    if let Some(g) = gain {
        let camera = sensor
            .camera()
            .map_err(|source| CaptureOptionsError::Sensor {
                sensor: sensor.name().to_string(),
                source,
            });
        camera?
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
    /// The camera's frame came without its own figures (`meta.sensor`),
    /// which every in-process frame carries.
    #[error("frame {index}: the camera gave no figures of its own")]
    NoFigures { index: u32 },
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

/// What to capture and how.
pub struct FrameCapture<'a> {
    /// The camera, read once by the request ([`ResolvedSensor`]).
    pub sensor: &'a ResolvedSensor,
    pub frames: u32,
    pub gain: Option<f64>,
    pub agc: bool,
    pub noise: bool,
    pub seed: u64,
    /// `--exposure auto`: choose gain, gate or exposure time and ND for
    /// this scene first ([`crate::exposure`]); the gain is then fixed.
    pub auto_exposure: Option<crate::exposure::ExposureTarget>,
    /// How [`FrameCapture::run`] stores the frames (`--frame-format`).
    pub frame_format: FrameFormat,
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
    pub report: SensorCaptureReport,
}

/// `report.json`'s `sensor_capture`: what the camera made of the scene.
#[derive(Clone, Debug, Serialize)]
pub struct SensorCaptureReport {
    /// The sensor preset or file, as given.
    pub sensor: String,
    /// The fit predicted before the first frame.
    pub fit: crate::fit::Fit,
    /// `--exposure auto`'s choice (null without it).
    pub exposure: Option<crate::exposure::ExposureChoice>,
    /// Each frame's levels.
    pub frames: Vec<FrameLevels>,
    pub saturation: SaturationSummary,
    /// The levels the warnings are judged against.
    pub thresholds: LevelThresholds,
}

/// One captured frame's levels in `sensor_capture.frames`.
#[derive(Clone, Debug, Serialize)]
pub struct FrameLevels {
    pub file: String,
    pub gain: f64,
    pub mean_dn: f64,
    pub median_dn: f64,
    /// (median − black) over the top code.
    pub median_above_black_of_full_scale: f64,
    pub saturated_fraction: f64,
    pub saturated_by: gloam_io::frame::SaturatingStage,
    pub mcp_compressed_fraction: f64,
    pub bright_source_in_view: bool,
    pub warnings: Vec<gloam_sensor::levels::WarningKind>,
}

/// The thresholds of the exposure warnings (`gloam_sensor::levels`).
#[derive(Clone, Debug, Serialize)]
pub struct LevelThresholds {
    pub saturated_fraction_warning: f64,
    pub near_full_scale_fraction: f64,
    pub near_black_dn: f64,
}

impl LevelThresholds {
    /// The thresholds this build judges frames by.
    fn current() -> Self {
        use gloam_sensor::levels::*;
        Self {
            saturated_fraction_warning: SATURATED_WARN_FRACTION,
            near_full_scale_fraction: NEAR_FULL_SCALE_FRACTION,
            near_black_dn: NEAR_BLACK_DN,
        }
    }
}

impl FrameCapture<'_> {
    /// [`check_options`] of this capture: refuses a gain outside the
    /// sensor's range or no frames, before the render.
    pub fn check(&self) -> Result<(), CaptureOptionsError> {
        check_options(self.sensor, self.gain, self.frames)
    }

    /// Starts capturing `frames` frames of the detected-electron radiance
    /// `first` (e⁻ s⁻¹ m⁻² sr⁻¹, from [`take_detected_band`]) through the
    /// request's camera: automatic exposure and the fit judge `first`.
    /// The caller asks for each frame in turn ([`Capturing::next_frame`]),
    /// so a long capture holds one frame at a time and the caller keeps
    /// frames where it needs them (files, a sweep's noise figures); writes
    /// and prints nothing. [`FrameCapture::run`] writes them.
    ///
    /// [`take_detected_band`]: crate::take_detected_band
    pub fn start<'c>(&'c self, first: &'c Array2<f64>) -> Result<Capturing<'c>, CaptureError> {
        self.start_configured(self.sensor.config().clone(), first)
    }

    /// [`FrameCapture::start`] with the sensor already configured: a
    /// caller that needs the configuration before the first image (a
    /// sequence's exposure window) adjusts `self.sensor`'s.
    pub fn start_configured<'c>(
        &'c self,
        mut config: gloam_sensor::SensorConfig,
        first: &'c Array2<f64>,
    ) -> Result<Capturing<'c>, CaptureError> {
        if self.frames < 1 {
            return Err(CaptureOptionsError::NoFrames.into());
        }
        config.noise.seed = self.seed;
        let mut notes = Vec::new();
        let exposure = self.auto_expose(&mut config, first, &mut notes)?;
        // Before the first frame: can this camera see this scene at any
        // gain it reaches? (`--exposure auto` has already chosen its fit.)
        let start_gain = self.gain.or(exposure.as_ref().map(|c| c.gain));
        let fit = crate::fit::predict(&config, first, start_gain)?;
        let fixable_by_agc = matches!(
            fit.verdict,
            crate::fit::FitVerdict::SaturatesAtThisGain
                | crate::fit::FitVerdict::InTheNoiseAtThisGain
        ) && self.agc;
        if self.auto_exposure.is_none() && !fit.note.is_empty() && !fixable_by_agc {
            notes.push(format!("warning: {}", fit.note));
        }
        let mut camera = Camera::new(config)?;
        camera.set_noise(self.noise);
        if let Some(g) = start_gain {
            camera
                .set_override_gain(Some(g))
                .map_err(CaptureError::Gain)?;
        }
        if self.agc {
            camera.set_agc(true);
        }
        tracing::debug!(
            sensor = self.sensor.name(),
            frames = self.frames,
            "capturing"
        );
        Ok(Capturing {
            request: self,
            first,
            camera,
            fit,
            exposure,
            notes,
            tally: FrameTally::default(),
            next: 0,
        })
    }

    /// `--exposure auto`'s choice of gain, gate, exposure time and ND for
    /// `detected`, applied to `config`, with its note (and a warning
    /// when the scene is out of the camera's range) in `notes`; `None`
    /// without it.
    fn auto_expose(
        &self,
        config: &mut gloam_sensor::SensorConfig,
        detected: &Array2<f64>,
        notes: &mut Vec<String>,
    ) -> Result<Option<crate::exposure::ExposureChoice>, CaptureError> {
        let Some(target) = &self.auto_exposure else {
            return Ok(None);
        };
        let c = crate::exposure::choose(config, detected, target)?;
        crate::exposure::apply(config, &c);
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
        Ok(Some(c))
    }

    /// [`FrameCapture::start`]'s frames into `out`: the frames in
    /// `frame_format` and `frames.jsonl` as frames are made, then
    /// `frames-preview.png`; FITS headers carry `provenance` and date
    /// frames from `scene_utc` (the scene's `[sky] utc`) when given.
    /// Returns what its user should be told and `report.json`'s
    /// `sensor_capture`, for the caller's report.
    pub fn run(
        &self,
        detected: &Array2<f64>,
        out: &Path,
        provenance: Option<&crate::Provenance>,
        scene_utc: Option<gloam_sky::time::UtcInstant>,
    ) -> Result<Captured, CaptureError> {
        let mut writer = None;
        let context = FrameContext {
            camera: Some(self.sensor.name().to_string()),
            seed: Some(self.seed),
            provenance: provenance.cloned(),
            scene_utc,
            ..FrameContext::default()
        };
        let mut capturing = self.start(detected)?;
        // Bounded: `frames` of them.
        while let Some((f, rec)) = capturing.next_frame(None)? {
            let w = match &mut writer {
                Some(w) => w,
                None => writer.insert(FrameWriter::with_format(
                    out,
                    self.frame_format,
                    context.clone(),
                )?),
            };
            w.write(&rec, &f.pixels)?;
        }
        let captured = capturing.finish();
        if let Some(w) = writer {
            w.finish()?;
        }
        Ok(captured)
    }
}

/// A capture under way ([`FrameCapture::start`]): the camera, its fit and
/// exposure, and what the frames so far told.
pub struct Capturing<'c> {
    request: &'c FrameCapture<'c>,
    first: &'c Array2<f64>,
    camera: Camera,
    fit: crate::fit::Fit,
    exposure: Option<crate::exposure::ExposureChoice>,
    notes: Vec<String>,
    tally: FrameTally,
    next: u32,
}

impl Capturing<'_> {
    /// The next frame and its record, of `image` (a sequence's mix of
    /// light-group layers at this frame; `None`: the first image), the
    /// camera's AGC and lag running across frames; `None` once every frame
    /// asked for was made.
    pub fn next_frame(
        &mut self,
        image: Option<&Array2<f64>>,
    ) -> Result<Option<(Frame, FrameRecord)>, CaptureError> {
        let i = self.next;
        if i >= self.request.frames {
            return Ok(None);
        }
        self.next += 1;
        let frame = (self.camera)
            .capture_detected(image.unwrap_or(self.first).view())
            .map_err(|source| CaptureError::Frame { index: i, source })?;
        let file = self.request.frame_format.file_name(u64::from(i));
        let judged = frame.exposure();
        let rec = FrameRecord::of_frame(u64::from(i), file, &frame, judged.warnings);
        let max_code = self.camera.chain().max_code;
        let kinds = judged.warning_kinds;
        (self.tally).add(i, &frame, &rec, kinds, max_code, &mut self.notes)?;
        Ok(Some((frame, rec)))
    }

    /// The index of the frame [`Self::next_frame`] makes next.
    pub fn next_index(&self) -> u32 {
        self.next
    }

    /// What the capture found besides its frames.
    pub fn finish(self) -> Captured {
        let Capturing {
            request,
            fit,
            exposure,
            mut notes,
            tally,
            ..
        } = self;
        let FrameTally {
            per_frame, summary, ..
        } = tally;
        if summary.frames > 1 && summary.frames_over_warning > 0 {
            notes.push(format!(
                "warning: {} of {} frames saturated more than {} % of their pixels (worst {:.2} %, mean {:.2} %)",
                summary.frames_over_warning,
                summary.frames,
                100.0 * gloam_sensor::levels::SATURATED_WARN_FRACTION,
                100.0 * summary.max_saturated_fraction,
                100.0 * summary.mean_saturated_fraction
            ));
        }
        let report = SensorCaptureReport {
            sensor: request.sensor.name().to_string(),
            fit,
            exposure,
            frames: per_frame,
            saturation: summary,
            thresholds: LevelThresholds::current(),
        };
        Captured { notes, report }
    }
}

/// What a capture keeps of its frames for `report.json` and its user:
/// each frame's levels, the saturation summary, and which kinds of
/// exposure warning it has told.
#[derive(Default)]
struct FrameTally {
    per_frame: Vec<FrameLevels>,
    summary: SaturationSummary,
    warned: std::collections::BTreeSet<gloam_sensor::levels::WarningKind>,
}

impl FrameTally {
    /// Adds frame `i`, recorded as `rec` with warnings of `kinds` (in the
    /// record's order), from a camera whose top code is `max_code`; the
    /// first warning of each kind goes to `notes`.
    fn add(
        &mut self,
        i: u32,
        frame: &Frame,
        rec: &FrameRecord,
        kinds: Vec<gloam_sensor::levels::WarningKind>,
        max_code: f64,
        notes: &mut Vec<String>,
    ) -> Result<(), CaptureError> {
        let Some(m) = frame.sensor() else {
            return Err(CaptureError::NoFigures { index: i });
        };
        for (w, k) in rec.warnings.iter().zip(&kinds) {
            if self.warned.insert(*k) {
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
        let (g, black) = (rec.gain, rec.black_dn.unwrap_or(0.0));
        let median = median_dn(&frame.pixels);
        self.per_frame.push(FrameLevels {
            file: rec.file.clone(),
            gain: g,
            mean_dn: m.mean_dn,
            median_dn: median,
            median_above_black_of_full_scale: (median - black) / max_code,
            saturated_fraction: m.saturated_fraction,
            saturated_by: m.saturation.saturated_by,
            mcp_compressed_fraction: m.saturation.mcp_compressed_fraction,
            bright_source_in_view: m.saturation.bright_source_in_view,
            warnings: kinds,
        });
        self.summary.add(&m.saturation);
        tracing::debug!(frame = i, gain = g, mean_dn = m.mean_dn, "captured");
        Ok(())
    }
}

/// The median count of a frame (0 for no pixels), by a histogram of the
/// 16-bit codes: one pass, no sort.
fn median_dn(pixels: &[u16]) -> f64 {
    if pixels.is_empty() {
        return 0.0;
    }
    let mut hist = vec![0u32; 1 << 16];
    for &p in pixels {
        hist[usize::from(p)] += 1;
    }
    let half = (pixels.len() as u64 - 1) / 2;
    let mut seen = 0u64;
    for (code, &n) in hist.iter().enumerate() {
        seen += u64::from(n);
        if seen > half {
            return code as f64;
        }
    }
    0.0
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The median is the lower middle count, found without sorting.
    #[test]
    fn median_is_the_middle_count() {
        assert_eq!(median_dn(&[5, 1, 3, 4, 2]), 3.0);
        assert_eq!(median_dn(&[4095, 0, 7, 9]), 7.0);
        assert_eq!(median_dn(&[]), 0.0);
    }
}
