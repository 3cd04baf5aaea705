//! Frames to disk: the `frames.jsonl` record every command writes (one
//! schema for `capture`, `render --sensor` and the calibration flows), and
//! the capture of a render through a simulated camera.

use std::path::{Path, PathBuf};

use gloam_grabber::FrameStatus;
use gloam_sensor::Camera;
use ndarray::Array2;
use serde::Serialize;

use crate::frame_files::{ContactSheet, FrameFormat, FrameStorage, PREVIEW, TIFF_STACK};
use crate::output::{OutputError, write_atomic};
use gloam_io::fits::{FitsCard, FitsValue, fits_frame_bytes};
use gloam_io::frames::FrameLog;
use gloam_io::png::png_frame_bytes;
use gloam_io::tiff::TiffStack;

pub use gloam_io::frames::FrameRecord;

/// The record of frame `index` of an in-process simulated `camera`
/// (just captured, so its chain state is the frame's), with its
/// exposure warnings; `pixels` are the frame's counts in row order.
pub fn record_of_sensor_frame(
    index: u64,
    file: String,
    frame: &gloam_sensor::DigitizedFrame,
    pixels: &[u16],
    camera: &Camera,
) -> FrameRecord {
    let (h, w) = frame.pixels.dim();
    let m = &frame.meta;
    let g = m.gain_in_effect;
    let chain = camera.chain();
    let (black, sat) = (chain.black_dn(g), chain.saturation_dn(g));
    let warnings =
        gloam_sensor::levels::exposure_warnings(m.mean_dn, m.saturated_fraction, Some(black), sat);
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
        black_dn: Some(black),
        electrons_per_dn: Some(1.0 / chain.mean_dn_per_photoelectron(g)),
        nd_density: Some(camera.config().optics.nd_density),
        // The duty in effect: the configured gate times the tube's and
        // the AGC's cuts (as the simulated grabber records it).
        gate_duty: (camera.config().photocathode.as_ref())
            .map(|p| p.gate_duty * m.saturation.abc.duty_factor),
        exposure_us: None,
        saturated_by: Some(m.saturation.saturated_by),
        mcp_compressed_fraction: Some(m.saturation.mcp_compressed_fraction),
        warnings,
        sensor: Some(m.clone()),
        stored: None,
        sequence: None,
    }
}

/// Why `frames.jsonl` or a frame was not written, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum FrameLogError {
    #[error(transparent)]
    Log(#[from] gloam_io::frames::FrameLogError),
    #[error(transparent)]
    Frame(#[from] OutputError),
}

impl From<gloam_io::EncodeError> for FrameLogError {
    fn from(e: gloam_io::EncodeError) -> Self {
        FrameLogError::Frame(e.into())
    }
}

/// What a frame file's header names besides the frame's own record: the
/// camera, the noise seed and the run's provenance (FITS only).
#[derive(Clone, Debug, Default)]
pub struct FrameContext {
    /// The camera: preset name, sensor file or grabber URI.
    pub camera: Option<String>,
    /// FITS `INSTRUME`: the camera model ([`instrument_of_grabber`] for
    /// a grabber); `None` takes the preset or sensor file name of
    /// `camera`.
    pub instrument: Option<String>,
    pub seed: Option<u64>,
    pub provenance: Option<crate::Provenance>,
    /// The scene's time (`[sky] utc`) at the start of frame 0, for
    /// simulated frames of a scene that has one: `DATE-OBS` is it plus
    /// the frame's start. Without it `DATE-OBS` is the host's clock.
    pub scene_utc: Option<gloam_sky::time::UtcInstant>,
}

/// FITS `INSTRUME` of a grabber opened from `uri` that describes itself
/// as `describe`: `sim:PRESET` (the preset's or sensor file's name) for a
/// simulated camera, `genicam:VENDOR MODEL` for a GenICam camera, else
/// the URI's scheme and the device's description up to its details
/// (`serial:gloam protocol 1.0 device #7`).
pub fn instrument_of_grabber(uri: &str, describe: &str) -> String {
    let scheme = uri.split_once(':').map_or(uri, |(s, _)| s);
    if let Ok(gloam_simcam::SimUri { preset, .. }) = gloam_simcam::SimUri::parse(uri) {
        return format!("sim:{}", sensor_name(&preset));
    }
    let model = describe.strip_prefix("GenICam ").unwrap_or(describe);
    let model = model.split(" (").next().unwrap_or(model);
    let model = model.split(" over ").next().unwrap_or(model);
    format!("{scheme}:{}", model.trim())
}

/// The time of `scene` (its `[sky] utc`), if it has one: the start of
/// frame 0 of its simulated captures ([`FrameContext::scene_utc`]).
pub fn scene_utc(scene: &gloam_scene::Scene) -> Option<gloam_sky::time::UtcInstant> {
    scene.sky.as_ref().map(|sky| sky.instant)
}

/// A sensor preset's name as it is, a sensor file's by its file name.
fn sensor_name(sensor: &str) -> String {
    Path::new(sensor)
        .file_name()
        .map_or(sensor.to_string(), |n| n.to_string_lossy().into_owned())
}

/// A UTC instant as FITS dates are written: ISO-8601 without the zone
/// letter (FITS 4.0 §4.4.2.1: UTC unless `TIMESYS` says otherwise).
fn fits_date(t: &gloam_sky::time::UtcInstant) -> String {
    t.to_iso8601().trim_end_matches('Z').to_string()
}

/// The host's clock now.
fn utc_now() -> Option<gloam_sky::time::UtcInstant> {
    let unix_s = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .ok()?
        .as_secs_f64();
    // JD 2440587.5 is the Unix epoch.
    gloam_sky::time::UtcInstant::from_julian_date(unix_s / 86_400.0 + 2_440_587.5).ok()
}

/// The most frames [`FrameWriter`]'s contact sheet shows.
pub const PREVIEW_FRAMES: usize = 16;

/// Writes frames as every command does: each frame's file in the chosen
/// [`FrameFormat`] (PNG and FITS atomically, one file per frame; TIFF as
/// pages appended to `frames.tiff`), then its record appended to
/// `frames.jsonl`, so the log never lists a frame that is not on disk;
/// [`FrameWriter::finish`] adds the contact sheet `frames-preview.png`.
pub struct FrameWriter {
    dir: PathBuf,
    log: FrameLog,
    format: FrameFormat,
    context: FrameContext,
    tiff: Option<TiffStack>,
    sheet: ContactSheet,
}

impl FrameWriter {
    /// PNG frames; creates (truncates) `dir/frames.jsonl`.
    pub fn create(dir: &Path) -> Result<Self, FrameLogError> {
        Self::with_format(dir, FrameFormat::Png, FrameContext::default())
    }

    /// Frames in `format`, FITS headers naming `context`.
    pub fn with_format(
        dir: &Path,
        format: FrameFormat,
        context: FrameContext,
    ) -> Result<Self, FrameLogError> {
        Ok(Self {
            dir: dir.to_path_buf(),
            log: FrameLog::create(dir)?,
            format,
            context,
            tiff: None,
            sheet: ContactSheet::new(PREVIEW_FRAMES),
        })
    }

    /// Writes the frame `rec` describes (its index and size) with its
    /// counts `pixels` in row order, then appends `rec` to the log with
    /// its `file` and `stored` set to where and how the counts went.
    pub fn write(&mut self, rec: &FrameRecord, pixels: &[u16]) -> Result<(), FrameLogError> {
        let mut rec = rec.clone();
        rec.file = self.format.file_name(rec.index);
        let (w, h) = (rec.width, rec.height);
        let stored = match self.format {
            FrameFormat::Png => {
                let (png, shift) = png_frame_bytes(w, h, rec.bits, pixels)?;
                write_atomic(&self.dir.join(&rec.file), &png)?;
                FrameStorage {
                    format: self.format,
                    sample_shift: shift,
                    page: None,
                }
            }
            FrameFormat::Fits => {
                let cards = fits_cards(&rec, &self.context, utc_now());
                write_atomic(
                    &self.dir.join(&rec.file),
                    &fits_frame_bytes(w, h, pixels, &cards),
                )?;
                FrameStorage {
                    format: self.format,
                    sample_shift: 0,
                    page: None,
                }
            }
            FrameFormat::Tiff => {
                let stack = match &mut self.tiff {
                    Some(t) => t,
                    None => self
                        .tiff
                        .insert(TiffStack::create(&self.dir.join(TIFF_STACK))?),
                };
                let (page, shift) = stack.append(w, h, rec.bits, pixels)?;
                FrameStorage {
                    format: self.format,
                    sample_shift: shift,
                    page: Some(page),
                }
            }
        };
        rec.stored = Some(stored);
        let black = rec.black_dn.unwrap_or(0.0);
        (self.sheet).add(rec.index, w, h, pixels, black, rec.saturated_at_dn);
        Ok(self.log.append(&rec)?)
    }

    /// Writes `frames-preview.png` (the contact sheet) and closes the TIFF.
    pub fn finish(self) -> Result<(), FrameLogError> {
        drop(self.tiff);
        if let Some(png) = self.sheet.png()? {
            write_atomic(&self.dir.join(PREVIEW), &png)?;
        }
        Ok(())
    }
}

/// A frame's FITS header cards after the mandatory ones: the frame's
/// time, settings and levels from its record, then the context's camera,
/// seed and provenance; `now` is the host's clock as the frame is written
/// (`DATE-OBS` of a frame with no scene time).
fn fits_cards(
    rec: &FrameRecord,
    ctx: &FrameContext,
    now: Option<gloam_sky::time::UtcInstant>,
) -> Vec<FitsCard> {
    use FitsValue::{Bool, Float, Int, Str};
    let mut c = vec![
        FitsCard::new("BUNIT", Str("DN".into()), "digital counts"),
        FitsCard::new("FRAME", Int(rec.index.into()), "index in this capture"),
        FitsCard::new("SEQ", Int(rec.seq.into()), "camera frame number"),
        FitsCard::new(
            "TSTAMPUS",
            Int(rec.timestamp.into()),
            "frame start, us from stream start",
        ),
    ];
    // A simulated frame of a scene with a time: that time plus the frame's
    // start (a sequence's exposure start, else seq / frame rate).
    let scene_time = match (&rec.sensor, ctx.scene_utc) {
        (Some(m), Some(t0)) => {
            Some(t0.plus_seconds(rec.sequence.as_ref().map_or(m.time_s, |s| s.time_s)))
        }
        _ => None,
    };
    let date_obs = match (scene_time, now) {
        (Some(t), _) => Some((t, "UTC, scene [sky] utc + frame start")),
        (None, Some(t)) if rec.sensor.is_some() => {
            Some((t, "UTC, host clock at capture (no scene time)"))
        }
        (None, Some(t)) => Some((t, "UTC, host clock when the frame arrived")),
        (None, None) => None,
    };
    if let Some((t, why)) = date_obs {
        c.push(FitsCard::new("DATE-OBS", Str(fits_date(&t)), why));
    }
    let instrument = (ctx.instrument.clone()).or_else(|| ctx.camera.as_deref().map(sensor_name));
    if let Some(i) = instrument {
        c.push(FitsCard::new("INSTRUME", Str(i), "camera"));
    }
    if let Some(m) = &rec.sensor {
        c.push(FitsCard::new(
            "EXPTIME",
            Float(m.exposure_s),
            "exposure time, s",
        ));
    } else if let Some(us) = rec.exposure_us {
        c.push(FitsCard::new(
            "EXPTIME",
            Float(us / 1e6),
            "exposure time, s",
        ));
    }
    if let Some(d) = rec.gate_duty {
        c.push(FitsCard::new(
            "GATEDUTY",
            Float(d),
            "photocathode gate duty cycle",
        ));
    }
    if let Some(nd) = rec.nd_density {
        c.push(FitsCard::new(
            "NDDENS",
            Float(nd),
            "ND filter optical density",
        ));
    }
    c.extend([
        FitsCard::new(
            "TUBEGAIN",
            Float(rec.gain),
            "tube or system gain in effect, linear",
        ),
        FitsCard::new("AGC", Bool(rec.agc), "gain set by the AGC"),
        FitsCard::new("BITS", Int(rec.bits.into()), "digitizer bits"),
    ]);
    // ccdproc's and astropy's GAIN: electrons per DN. Only a camera that
    // knows its conversion says; a real camera's is not guessed.
    if let Some(k) = rec.electrons_per_dn.filter(|k| k.is_finite() && *k > 0.0) {
        c.push(FitsCard::new(
            "GAIN",
            Float(k),
            "e-/DN, photoelectrons per DN at TUBEGAIN",
        ));
    }
    if let Some(b) = rec.black_dn {
        c.push(FitsCard::new("BLACKDN", Float(b), "black level, DN"));
    }
    c.extend([
        FitsCard::new(
            "SATDN",
            Float(rec.saturated_at_dn),
            "saturated at or above, DN",
        ),
        FitsCard::new("MEANDN", Float(rec.mean_dn), "mean count, DN"),
        FitsCard::new(
            "SATFRAC",
            Float(rec.saturated_fraction),
            "saturated fraction",
        ),
    ]);
    if let Some(cam) = &ctx.camera {
        c.push(FitsCard::new(
            "CAMERA",
            Str(cam.clone()),
            "sensor preset, file or URI",
        ));
    }
    if let Some(seed) = ctx.seed {
        c.push(FitsCard::new("SEED", Int(seed.into()), "noise seed"));
    }
    c.push(FitsCard::new(
        "GLOAMVER",
        Str(crate::provenance::VERSION_WITH_COMMIT.into()),
        "software",
    ));
    if let Some(p) = &ctx.provenance {
        // FITS dates are UTC without a zone letter.
        let utc = p.utc.trim_end_matches('Z').to_string();
        c.push(FitsCard::new("DATE", Str(utc), "run start, UTC"));
        const KEYS: [(&str, &str); 4] = [
            ("INPUT1", "ISHA1"),
            ("INPUT2", "ISHA2"),
            ("INPUT3", "ISHA3"),
            ("INPUT4", "ISHA4"),
        ];
        for (f, (k, h)) in p.inputs.iter().zip(KEYS) {
            c.push(FitsCard::new(k, Str(f.path.clone()), "input file"));
            c.push(FitsCard::new(h, Str(f.sha256.clone()), "its SHA-256"));
        }
    }
    c
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
    let Ok(text) =
        gloam_io::unrecorded(|| gloam_io::read_text(&path, gloam_io::MAX_TEXT_FILE_BYTES))
    else {
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
    /// How [`FrameCapture::run`] stores the frames (`--frame-format`).
    pub frame_format: FrameFormat,
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
        self.capture_changing(detected, None, &mut |_| Ok(()), on_frame)
    }

    /// [`FrameCapture::capture`] of a scene that changes: frame `i` sees
    /// `image(i)` (a sequence's mix of light-group layers), the camera's
    /// AGC and lag running across frames; `configure` adjusts the camera
    /// first (a sequence sets its frame rate). The fit and any automatic
    /// exposure judge `first`, the first frame's image.
    pub fn capture_changing(
        &self,
        first: &Array2<f64>,
        image: Option<&mut dyn FnMut(u32) -> Array2<f64>>,
        configure: &mut dyn FnMut(&mut gloam_sensor::SensorConfig) -> Result<(), CaptureError>,
        on_frame: &mut dyn FnMut(CapturedFrame) -> Result<(), CaptureError>,
    ) -> Result<Captured, CaptureError> {
        let mut config = gloam_sensor::load_preset_or_file(self.sensor).map_err(|source| {
            CaptureOptionsError::Sensor {
                sensor: self.sensor.to_string(),
                source,
            }
        })?;
        configure(&mut config)?;
        self.capture_configured(config, first, image, on_frame)
    }

    /// [`FrameCapture::capture_changing`] with the sensor already loaded
    /// (from `self.sensor`) and configured: a caller that needs the
    /// configuration before the first image (a sequence's exposure
    /// window) loads it once.
    pub fn capture_configured(
        &self,
        mut config: gloam_sensor::SensorConfig,
        first: &Array2<f64>,
        mut image: Option<&mut dyn FnMut(u32) -> Array2<f64>>,
        on_frame: &mut dyn FnMut(CapturedFrame) -> Result<(), CaptureError>,
    ) -> Result<Captured, CaptureError> {
        let detected = first;
        if self.frames < 1 {
            return Err(CaptureOptionsError::NoFrames.into());
        }
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
        // Before the first frame: can this camera see this scene at any
        // gain it reaches? (`--exposure auto` has already chosen its fit.)
        let start_gain = self.gain.or(exposure.as_ref().map(|c| c.gain));
        let fit = crate::fit::predict(&config, detected, start_gain)?;
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
        tracing::debug!(sensor = self.sensor, frames = self.frames, "capturing");
        let mut warned = std::collections::BTreeSet::new();
        let mut per_frame = Vec::new();
        let mut summary = SaturationSummary::default();
        for i in 0..self.frames {
            let changed = image.as_mut().map(|f| f(i));
            let frame = camera
                .capture_detected(changed.as_ref().unwrap_or(detected).view())
                .map_err(|source| CaptureError::Frame { index: i, source })?;
            let pixels: Vec<u16> = frame.pixels.iter().copied().collect();
            let file = self.frame_format.file_name(u64::from(i));
            let m = &frame.meta;
            let g = m.gain_in_effect;
            let chain = camera.chain();
            let (black, sat) = (chain.black_dn(g), chain.saturation_dn(g));
            let args = (m.mean_dn, m.saturated_fraction, Some(black), sat);
            let kinds = gloam_sensor::levels::warning_kinds(args.0, args.1, args.2, args.3);
            let rec = record_of_sensor_frame(u64::from(i), file.clone(), &frame, &pixels, &camera);
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
            let median = median_dn(&pixels);
            per_frame.push(serde_json::json!({
                "file": file,
                "gain": g,
                "mean_dn": m.mean_dn,
                "median_dn": median,
                "median_above_black_of_full_scale": (median - black) / chain.max_code,
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
        let report = serde_json::json!({
            "sensor": self.sensor,
            "fit": fit,
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

    /// [`FrameCapture::capture`] into `out`: the frames in
    /// `frame_format` and `frames.jsonl` as frames are made, then
    /// `frames-preview.png`, and `sensor_capture` added to
    /// `out/report.json` when there is one; FITS headers carry
    /// `provenance` and date frames from `scene_utc` (the scene's
    /// `[sky] utc`) when given. Returns what its user should be told, as
    /// lines; the front end prints them.
    pub fn run(
        &self,
        detected: &Array2<f64>,
        out: &Path,
        provenance: Option<&crate::Provenance>,
        scene_utc: Option<gloam_sky::time::UtcInstant>,
    ) -> Result<Vec<String>, CaptureError> {
        let mut writer = None;
        let context = FrameContext {
            camera: Some(self.sensor.to_string()),
            seed: Some(self.seed),
            provenance: provenance.cloned(),
            scene_utc,
            ..FrameContext::default()
        };
        let captured = self.capture(detected, &mut |f| {
            let w = match &mut writer {
                Some(w) => w,
                None => writer.insert(FrameWriter::with_format(
                    out,
                    self.frame_format,
                    context.clone(),
                )?),
            };
            Ok(w.write(&f.record, &f.pixels)?)
        })?;
        if let Some(w) = writer {
            w.finish()?;
        }
        record_in_report(out, captured.report)?;
        Ok(captured.notes)
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
    use gloam_grabber::Frame;

    #[test]
    fn instruments_name_the_camera_model() {
        assert_eq!(
            instrument_of_grabber("sim:gen3-gaas-iccd?rig=edge&seed=2", "simulated …"),
            "sim:gen3-gaas-iccd"
        );
        assert_eq!(
            instrument_of_grabber("sim:my/cams/cam.toml", ""),
            "sim:cam.toml"
        );
        assert_eq!(
            instrument_of_grabber(
                "genicam:127.0.0.1?resend=always",
                "GenICam Aravis Fake (Fake_1) via Aravis, software trigger"
            ),
            "genicam:Aravis Fake"
        );
        assert_eq!(
            instrument_of_grabber(
                "serial:/dev/pts/3",
                "gloam protocol 1.0 device #7 (firmware 1.2.3, 640×480 max) over serial /dev/pts/3 @ 115200 baud"
            ),
            "serial:gloam protocol 1.0 device #7"
        );
    }

    fn grabbed(levels: Option<gloam_grabber::DnLevels>) -> FrameRecord {
        let f = Frame {
            meta: gloam_grabber::FrameMeta {
                seq: 4,
                timestamp_us: 160_000,
                gain: 25.0,
                agc: false,
                bits: 12,
                width: 2,
                height: 1,
                pixels_crc32c: 0,
                status: FrameStatus::Ok,
                levels,
                exposure_us: None,
                gate_duty: None,
            },
            pixels: vec![100, 200],
        };
        FrameRecord::of_grab(4, String::new(), &f, Vec::new())
    }

    fn card<'a>(cards: &'a [FitsCard], key: &str) -> Option<&'a FitsCard> {
        cards.iter().find(|c| c.key == key)
    }

    /// GAIN only from a camera that knows its conversion; the tube's
    /// gain always under TUBEGAIN; DATE-OBS the host clock for a grab.
    #[test]
    fn a_grabbed_frame_has_gain_only_when_the_camera_knows_it() {
        let now = gloam_sky::time::UtcInstant::parse_iso8601("2026-01-02T03:04:05.5Z").unwrap();
        let ctx = FrameContext {
            instrument: Some("serial:gloam protocol 1.0 device #7".into()),
            ..FrameContext::default()
        };
        let c = fits_cards(&grabbed(None), &ctx, Some(now));
        assert!(card(&c, "GAIN").is_none());
        assert_eq!(card(&c, "TUBEGAIN").unwrap().value, FitsValue::Float(25.0));
        let d = card(&c, "DATE-OBS").unwrap();
        assert_eq!(d.value, FitsValue::Str("2026-01-02T03:04:05.500".into()));
        assert!(d.comment.contains("host clock when the frame arrived"));
        assert_eq!(
            card(&c, "INSTRUME").unwrap().value,
            FitsValue::Str("serial:gloam protocol 1.0 device #7".into())
        );
        let levels = gloam_grabber::DnLevels {
            black_dn: 0.0,
            saturation_dn: 4095.0,
            saturated_at_dn: 4090.0,
            electrons_per_dn: Some(0.25),
        };
        let c = fits_cards(&grabbed(Some(levels)), &ctx, Some(now));
        assert_eq!(card(&c, "GAIN").unwrap().value, FitsValue::Float(0.25));
        assert!(c.iter().all(|c| c.key.len() <= 8));
    }

    /// The median is the lower middle count, found without sorting.
    #[test]
    fn median_is_the_middle_count() {
        assert_eq!(median_dn(&[5, 1, 3, 4, 2]), 3.0);
        assert_eq!(median_dn(&[4095, 0, 7, 9]), 7.0);
        assert_eq!(median_dn(&[]), 0.0);
    }
}
