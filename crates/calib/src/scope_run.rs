//! `gloam scope`: a simulated camera looks at a rig, one or more scan
//! lines of the frame are put on the oscilloscope (voltage against time,
//! sync and blanking included) and written as CSV, a scope-style PNG and
//! the cursor readings (levels, sync width, line period) as JSON.

use std::path::Path;

use gloam_grabber::{GrabberUri, Stimulus};
use gloam_sensor::scope::{LineReadout, ScopeLine, read_line, scope_lines, to_csv};
use gloam_sensor::stages::video_timing::VideoFormat;
use gloam_sensor::{Camera, SensorConfig};
use gloam_simcam::{SimUri, render_stimulus, rig_stimulus};
use serde::Serialize;

use crate::error::CalibError;

/// What to put on the scope.
#[derive(Clone, Debug)]
pub struct ScopeOptions {
    /// Sensor preset or TOML file.
    pub sensor: String,
    pub seed: u64,
    /// Frame size; default the format's square-pixel size (640×480 RS-170,
    /// 768×574 CCIR: its 575 picture lines hold at most 575 rows).
    pub size: Option<(u32, u32)>,
    /// Frame rows to show (default: the middle row).
    pub rows: Vec<usize>,
    /// Rig: uniform, sine, edge or dark.
    pub rig: String,
    /// Mean signal as a fraction of the range above black.
    pub level_fraction: f64,
    /// Sine rig frequency, cycles/pixel (bars across the line).
    pub frequency_cy_per_px: f64,
    /// Fixed gain (default: the configured one, AGC off).
    pub gain: Option<f64>,
    /// Overrides of the sensor file's video stage.
    pub format: Option<VideoFormat>,
    pub bandwidth_hz: Option<f64>,
    /// Frames captured; the last is shown.
    pub frames: usize,
    /// Where `size` came from, for the error of a frame too tall.
    pub size_from: SizeFrom,
}

/// Where a scope's frame size came from: a frame taller than the format's
/// picture lines is refused saying what to give there instead.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SizeFrom {
    /// The format's own frame (it fits).
    #[default]
    Default,
    /// `--size` (Python's `size=`).
    Flag,
    /// The `size=` of this `sim:` URI.
    Uri(String),
}

/// Refuses a `w`×`h` frame taller than `format`'s picture lines before
/// anything is captured. The sensor's own error ("give a frame of at most
/// 575 rows") said neither where nor how: 768×576, BT.601's CCIR frame, is
/// the usual ask, and the line timing models 575 picture lines.
pub fn check_frame_fits(
    format: VideoFormat,
    (w, h): (u32, u32),
    from: &SizeFrom,
) -> Result<(), CalibError> {
    let lines = gloam_sensor::stages::video_timing::LineTiming::of(format).active_lines;
    if h <= lines {
        return Ok(());
    }
    let give = match from {
        SizeFrom::Default | SizeFrom::Flag => format!("--size {w}x{lines}"),
        SizeFrom::Uri(uri) => format!("size={w}x{lines} in '{uri}'"),
    };
    Err(CalibError::Invalid(format!(
        "a frame of {h} rows does not fit the {lines} picture lines of {}: give {give} (at most {lines} rows)",
        format.label()
    )))
}

/// The lines and what the scope's cursors read off them.
#[derive(Clone, Debug, Serialize)]
pub struct ScopeResult {
    pub sensor: String,
    pub format: String,
    pub width: u32,
    pub height: u32,
    pub gain: f64,
    pub pixel_clock_hz: f64,
    pub bandwidth_hz: Option<f64>,
    pub readouts: Vec<(usize, LineReadout)>,
    #[serde(skip)]
    pub lines: Vec<ScopeLine>,
}

/// `(sensor, rig, seed, size)` of a `sim:` grabber URI.
pub type SimCamera = (String, String, u64, Option<(u32, u32)>);

/// The sensor and seed of a `sim:` grabber URI (rig and size too), for
/// `--grabber`: the scope needs the analogue stage, which only the
/// simulated cameras have.
pub fn sim_uri(uri: &str) -> Result<SimCamera, CalibError> {
    if !gloam_simcam::uri::is_sim(uri) {
        // Still a syntax error first when the URI is not even a transport's.
        GrabberUri::parse(uri)?;
        return Err(CalibError::Invalid(format!(
            "'{uri}' has no analogue video tap: the scope needs a sim: grabber (the wire protocol carries digitised frames only)"
        )));
    }
    match SimUri::parse(uri)? {
        SimUri {
            preset,
            rig,
            seed,
            size,
            scene: None,
        } => Ok((preset, rig, seed, size)),
        SimUri { scene: Some(_), .. } => Err(CalibError::Invalid(
            "the scope looks at rigs; a scene= grabber is not supported yet".into(),
        )),
    }
}

/// The sensor as the scope sees it: its video line in the asked format
/// and bandwidth, and its AGC off (a fixed gain holds the level).
fn video_sensor(
    o: &ScopeOptions,
    reads: &gloam_io::ReadLog,
) -> Result<(SensorConfig, VideoFormat), CalibError> {
    let mut cfg = SensorConfig::load_preset_or_file(&o.sensor, reads)
        .map_err(|e| CalibError::Invalid(e.to_string()))?;
    cfg.noise.seed = o.seed;
    let Some(video) = cfg.video.as_mut() else {
        return Err(CalibError::Invalid(format!(
            "sensor '{}' has a direct digital readout: no analogue video line to show",
            cfg.name
        )));
    };
    if let Some(f) = o.format {
        video.format = f;
    }
    if let Some(b) = o.bandwidth_hz {
        if !(b.is_finite() && b > 0.0) {
            return Err(CalibError::Invalid(format!(
                "--bandwidth-hz {b} must be > 0"
            )));
        }
        video.bandwidth_hz = Some(b);
    }
    let format = video.format;
    if let Some(a) = cfg.agc.as_mut() {
        a.enabled = false;
    }
    Ok((cfg, format))
}

/// The largest frame side the scope takes, as `--size` and `sim:` URIs.
pub const MAX_SCOPE_SIDE: u32 = 4096;

/// Captures and scopes the lines.
pub fn run_scope(o: &ScopeOptions, reads: &gloam_io::ReadLog) -> Result<ScopeResult, CalibError> {
    let (cfg, format) = video_sensor(o, reads)?;
    let mut cam = Camera::new(cfg).map_err(|e| CalibError::Invalid(e.to_string()))?;
    if let Some(g) = o.gain {
        cam.set_override_gain(Some(g))
            .map_err(|e| CalibError::Invalid(e.to_string()))?;
    }
    let g = cam.gain();
    let (w, h) = o.size.unwrap_or(match format {
        VideoFormat::Rs170 => (640, 480),
        // 576 rows (BT.601's frame) do not fit the 575 picture lines the
        // line timing models: the default was refused, "a frame of 576
        // rows does not fit", on every CCIR camera.
        VideoFormat::Ccir => (768, 574),
    });
    // The CLI's `--size` parser held this, Python's `size=` did not:
    // (100000, 100000) aborted the interpreter allocating 80 GB, and (0, 0)
    // was "row 0 is outside the 0-row frame".
    let side = 1..=MAX_SCOPE_SIDE;
    if !(side.contains(&w) && side.contains(&h)) {
        return Err(CalibError::Invalid(format!(
            "size {w}x{h}: each side of the frame must be 1 to {MAX_SCOPE_SIDE} pixels"
        )));
    }
    check_frame_fits(format, (w, h), &o.size_from)?;
    let rows = if o.rows.is_empty() {
        vec![h as usize / 2]
    } else {
        o.rows.clone()
    };
    if let Some(r) = rows.iter().find(|&&r| r >= h as usize) {
        return Err(CalibError::Invalid(format!(
            "row {r} is outside the {h}-row frame"
        )));
    }
    if !(o.level_fraction.is_finite() && o.level_fraction >= 0.0 && o.level_fraction <= 1.0) {
        return Err(CalibError::Invalid(format!(
            "level {} must be a fraction of the range, 0–1",
            o.level_fraction
        )));
    }
    // The rig's mean radiance for the asked signal level.
    let probe = rig_stimulus("uniform", 1.0)?;
    let (_, shape) = render_stimulus(&probe, 2, 2)?;
    let ch = cam.chain();
    let per_radiance = ch.pe_per_radiance(&shape).unwrap_or(0.0) * ch.mean_dn_per_photoelectron(g);
    if !(per_radiance > 0.0 && per_radiance.is_finite()) {
        return Err(CalibError::Invalid(
            "the camera does not respond to the rig's light".into(),
        ));
    }
    let level = o.level_fraction * (ch.saturation_dn(g) - ch.black_dn(g)) / per_radiance;
    let mut stimulus = rig_stimulus(&o.rig, level)?;
    if let Stimulus::Sine {
        cycles_per_pixel,
        angle_deg,
        ..
    } = &mut stimulus
    {
        if !(o.frequency_cy_per_px > 0.0 && o.frequency_cy_per_px <= 0.5) {
            return Err(CalibError::Invalid(format!(
                "--frequency {} must lie in (0, 0.5] cycles/pixel",
                o.frequency_cy_per_px
            )));
        }
        *cycles_per_pixel = o.frequency_cy_per_px;
        *angle_deg = 0.0;
    }
    let (img, shape) = render_stimulus(&stimulus, w, h)?;
    cam.set_scope_rows(rows);
    for _ in 0..o.frames.max(1) {
        cam.capture_mono(img.view(), &shape)
            .map_err(|e| CalibError::Invalid(format!("capture: {e}")))?;
    }
    let lines = scope_lines(&cam, h as usize).map_err(|e| CalibError::Invalid(e.to_string()))?;
    let readouts = lines
        .iter()
        .filter_map(|l| read_line(l).map(|r| (l.row, r)))
        .collect();
    let timing = cam
        .chain()
        .line_timing()
        .expect("video stage checked above");
    Ok(ScopeResult {
        sensor: cam.config().name.clone(),
        format: format.label().into(),
        width: w,
        height: h,
        gain: g,
        pixel_clock_hz: 1.0 / timing.pixel_period_s(w as usize),
        bandwidth_hz: cam.chain().amplifier().map(|a| a.bandwidth_hz),
        readouts,
        lines,
    })
}

/// Writes `scope.csv`, `scope.png` and `scope.json` into `dir`.
pub fn write_scope(dir: &Path, r: &ScopeResult) -> Result<(), CalibError> {
    crate::report::write_bytes(&dir.join("scope.csv"), to_csv(&r.lines).as_bytes())?;
    let title = format!(
        "{} — {}, {}",
        r.sensor,
        r.format,
        match r.bandwidth_hz {
            Some(b) => format!("{:.2} MHz video", b / 1e6),
            None => "flat video amplifier".into(),
        }
    );
    crate::scope_plot::scope_plot(&dir.join("scope.png"), &title, &r.lines, true)?;
    crate::report::write_json(&dir.join("scope.json"), r)
}
