//! AGC linearisation over a sequence: a night that changes (a lamp
//! switching on), captured by a simulated camera whose AGC runs across the
//! frames, each frame linearised through a radiance LUT at the gain in
//! effect (its `frames.jsonl` line) and compared with the radiance the
//! camera really saw — known exactly, because a sequence's frame is the
//! light groups' layers mixed with the sequence's weights.
//!
//! Units. The LUT maps counts to the *rig's* band radiance (W m⁻² sr⁻¹ of
//! the calibration lamp over the camera band). A camera only knows the
//! electrons it detects, so the radiance a LUT can recover from a scene of
//! another spectrum is the rig-equivalent radiance: the scene's detected
//! radiance (e⁻ s⁻¹ m⁻² sr⁻¹, what the layers hold) divided by the rig's
//! detected radiance per unit band radiance ([`detected_per_band_radiance`]).
//! That is the true radiance here, so the comparison measures the
//! linearisation, not the lamp's spectral mismatch.
//!
//! Metric, per frame. The pixels compared are chosen by their *true*
//! radiance, never by their counts (choosing by counts would drop upward
//! noise at the top and bias a noisy intensified frame low): those above
//! the noise floor (`noise_floor_sigma` × the LUT's dark σ in radiance at
//! the frame's gain) whose counts, by the LUT's line, fall inside its
//! linear range at that gain. Each is linearised with the LUT's line at the
//! gain in effect (`Lut::coefficients`, as `calibrate apply` and the
//! staircase use it). The frame's `residual_percent` is
//! 100 (Σ linearised / Σ true − 1) over those pixels: a pixel's noise
//! averages out over thousands, a wrong gain or LUT does not. The median
//! per-pixel ratio and the per-pixel RMS residual (noise and blur
//! included) are reported beside it. Frames fall in three phases:
//! `transient` (starting within `transient_time_constants` AGC time
//! constants after a switch — a frame whose true mean changes by more than
//! `switch_threshold` from the previous one), `acquiring` (as long after
//! the start, while the loop leaves its power-up gain) and `steady` (the
//! rest). The figure of merit is the RMS of `residual_percent` over the
//! transient frames against that over the steady frames.

use std::path::{Path, PathBuf};

use gloam_grabber::Stimulus;
use ndarray::Array2;
use serde::Serialize;

use crate::apply::{check_lut_fits_camera, lut_gain_range};
use crate::error::CalibError;
use crate::radiance::Lut;
use crate::source::CalibrationSource;

/// Settings of the per-frame comparison.
#[derive(Clone, Debug)]
pub struct AgcSequenceOptions {
    /// Pixels whose true radiance is below this many dark-noise σ (in
    /// radiance, at the frame's gain) are left out.
    pub noise_floor_sigma: f64,
    /// Frames starting within this many AGC time constants after a switch
    /// (or after the start) are transient (acquiring).
    pub transient_time_constants: f64,
    /// A frame whose true mean changes by more than this fraction from the
    /// previous frame's marks a switch.
    pub switch_threshold: f64,
    /// The camera's AGC loop time constant, s.
    pub agc_time_constant_s: f64,
    /// Pixels whose counts, by the LUT's line, would exceed this fraction
    /// of the frame's clip are not compared (an intensified pixel's noise
    /// is some 40 % of its signal: at half the clip, +2σ stays below it).
    pub top_fraction: f64,
    /// How far the camera spreads a pixel's light, pixels. A pixel is not
    /// compared when the light of the pixels beyond the compared range
    /// within this radius (a square), spread evenly over it, would exceed
    /// `spread_tolerance` of its own: a bright source's halo lands there.
    pub spread_radius_px: usize,
    /// See [`AgcSequenceOptions::spread_radius_px`].
    pub spread_tolerance: f64,
    /// The camera's configured photocathode gate duty (1 without one): a
    /// frame whose recorded duty is below it was gated (autogating, the
    /// tube's ABC) and its linearised radiance is divided by the ratio.
    pub gate_duty: f64,
}

impl AgcSequenceOptions {
    /// The defaults for `sensor`: its AGC time constant (`None` without
    /// an AGC) and its spread radius ([`spread_radius_px`]).
    pub fn for_sensor(sensor: &gloam_sensor::SensorConfig) -> Result<Option<Self>, CalibError> {
        let Some(agc) = &sensor.agc else {
            return Ok(None);
        };
        Ok(Some(Self {
            noise_floor_sigma: 3.0,
            transient_time_constants: 3.0,
            switch_threshold: 0.1,
            top_fraction: 0.5,
            spread_tolerance: 0.01,
            agc_time_constant_s: agc.time_constant_s,
            spread_radius_px: spread_radius_px(sensor)?,
            gate_duty: sensor.photocathode.as_ref().map_or(1.0, |p| p.gate_duty),
        }))
    }
}

/// Most pixels [`spread_radius_px`] returns.
pub const MAX_SPREAD_RADIUS_PX: usize = 256;

/// The radius over which `sensor` spreads a bright pixel's light: an
/// intensifier's halo (electrons bouncing off the MCP land within twice
/// the cathode–MCP gap, in cathode pixels) plus 2 pixels for the blur of
/// the screen, fibres and CCD; 2 pixels without a photocathode.
pub fn spread_radius_px(sensor: &gloam_sensor::SensorConfig) -> Result<usize, CalibError> {
    let halo = match &sensor.photocathode {
        Some(p) => {
            let chain = gloam_sensor::Chain::new(sensor)?;
            (2.0 * p.gap_mm / chain.pitch_cathode_mm).ceil()
        }
        None => 0.0,
    };
    Ok((halo.clamp(0.0, MAX_SPREAD_RADIUS_PX as f64) as usize + 2).min(MAX_SPREAD_RADIUS_PX))
}

/// The mean of `v` over the square of half-width `r` around each pixel
/// (clipped at the image's edges, divided by the full square's area).
fn box_mean(v: &[f64], rows: usize, cols: usize, r: usize) -> Vec<f64> {
    let pass = |m: &[f64], len: usize, stride: usize, lines: usize, step: usize| {
        let mut out = vec![0.0; m.len()];
        let mut prefix = vec![0.0f64; len + 1];
        for line in 0..lines {
            let at = |i: usize| line * step + i * stride;
            for i in 0..len {
                prefix[i + 1] = prefix[i] + m[at(i)];
            }
            for i in 0..len {
                let (a, b) = (i.saturating_sub(r), (i + r + 1).min(len));
                out[at(i)] = (prefix[b] - prefix[a]).max(0.0);
            }
        }
        out
    };
    let h = pass(v, cols, 1, rows, cols);
    let area = ((2 * r + 1) * (2 * r + 1)) as f64;
    let mut out = pass(&h, rows, cols, cols, 1);
    out.iter_mut().for_each(|x| *x /= area);
    out
}

/// Where a frame sits relative to the AGC's changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// Within the window after the sequence's start.
    Acquiring,
    /// Within the window after a switch.
    Transient,
    Steady,
}

/// One frame's linearised radiance against the true radiance.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AgcSequenceFrame {
    pub index: u64,
    pub file: String,
    /// Start of the frame's exposure window, s.
    pub time_s: f64,
    /// The gain in effect (`frames.jsonl`).
    pub gain: f64,
    pub phase: Phase,
    /// Mean true (rig-equivalent) radiance over the whole frame, W m⁻² sr⁻¹.
    pub true_frame_mean_w_m2_sr: f64,
    /// Pixels compared: their true radiance lies above the noise floor and
    /// puts their counts inside the compared range.
    pub valid_pixels: usize,
    /// Pixels whose true radiance would put their counts above
    /// `top_fraction` of the frame's clip.
    pub beyond_lut_range_pixels: usize,
    /// Pixels not compared because the light of those beyond the range
    /// within the camera's spread radius could reach them (see
    /// [`AgcSequenceOptions::spread_radius_px`]).
    pub near_beyond_pixels: usize,
    /// Compared pixels whose counts sat at the frame's clip anyway (noise).
    pub clipped_pixels: usize,
    /// Pixels whose true radiance is below the noise floor.
    pub below_floor_pixels: usize,
    /// Mean true and linearised radiance over the compared pixels.
    pub true_mean_w_m2_sr: Option<f64>,
    pub linearised_mean_w_m2_sr: Option<f64>,
    /// Median over the compared pixels of linearised / true.
    pub median_ratio: Option<f64>,
    /// Σ linearised / Σ true over the compared pixels.
    pub mean_ratio: Option<f64>,
    /// RMS over the compared pixels of 100 (linearised / true − 1).
    pub rms_relative_residual_percent: Option<f64>,
    /// 100 (mean_ratio − 1): the frame's figure.
    pub residual_percent: Option<f64>,
    /// True when the frame's gain lies outside the LUT's gains (not
    /// linearised).
    pub outside_lut: bool,
    /// The same frame linearised at the settled gain (the last frame's)
    /// instead of the gain in effect: what a LUT applied without the
    /// AGC's time series would give.
    pub residual_at_settled_gain_percent: Option<f64>,
}

/// The residual over one phase's frames.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PhaseSummary {
    /// Frames of the phase with a residual.
    pub frames: usize,
    /// RMS of the frames' `residual_percent`.
    pub rms_residual_percent: Option<f64>,
    /// Largest |`residual_percent`|.
    pub max_abs_residual_percent: Option<f64>,
    /// Mean of the frames' `residual_percent` (the bias).
    pub mean_residual_percent: Option<f64>,
    /// RMS of the frames' `residual_at_settled_gain_percent`.
    pub rms_residual_at_settled_gain_percent: Option<f64>,
}

/// What `gloam calibrate agc --sequence` reports (`agc_sequence.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AgcSequenceReport {
    pub camera: String,
    /// The LUT's source and gains.
    pub lut_source: String,
    pub lut_gain_range: Option<[f64; 2]>,
    /// Largest fit residual of the LUT's gains, % of the top radiance.
    pub lut_max_fit_residual_percent: f64,
    /// The rig's detected radiance per unit band radiance, e⁻ J⁻¹: true
    /// radiance = the layers' detected radiance / this.
    pub detected_per_band_radiance_e_per_j: f64,
    pub agc_time_constant_s: f64,
    pub transient_window_s: f64,
    pub noise_floor_sigma: f64,
    /// The noise floor in radiance, W m⁻² sr⁻¹ (rig-equivalent).
    pub noise_floor_w_m2_sr: f64,
    pub top_fraction: f64,
    pub spread_radius_px: usize,
    /// See [`AgcSequenceOptions::spread_radius_px`].
    pub spread_tolerance: f64,
    /// Start times of the frames that mark a switch, s.
    pub switches_s: Vec<f64>,
    /// The gain the `residual_at_settled_gain_percent` figures use (the
    /// last frame's).
    pub settled_gain: f64,
    pub steady: PhaseSummary,
    pub transient: PhaseSummary,
    pub acquiring: PhaseSummary,
    /// transient RMS / steady RMS.
    pub transient_over_steady: Option<f64>,
    pub frames_outside_lut: usize,
    /// Lowest and highest gain in effect.
    pub gain_range: [f64; 2],
    pub frames: Vec<AgcSequenceFrame>,
}

/// The light the camera saw: each light group's detected-radiance layer
/// (e⁻ s⁻¹ m⁻² sr⁻¹), in the order of `groups`.
pub struct SequenceLayers<'a> {
    pub groups: &'a [String],
    pub layers: &'a [Array2<f64>],
    /// With a `[sky]` clock, each sky render's layers: a frame's truth is
    /// its recorded `sequence.sky.renders` taken geometrically at its
    /// `fraction` between them ([`gloam_simcam::layers_between`]).
    pub sky: &'a [Vec<Array2<f64>>],
}

/// The rig's detected radiance per unit of the band radiance its LUT is
/// in, e⁻ J⁻¹: a simulated camera detects `∫ L QE λ/hc dλ` of the
/// stimulus (its lamp's shape over the stimulus band, as
/// [`gloam_simcam::render_stimulus`] gives it), the LUT maps to the level's
/// band radiance. Taken at the source's brightest level; a source whose
/// levels do not share one spectrum (a measured ND curve) gives the ratio
/// of that level.
pub fn detected_per_band_radiance(
    source: &mut dyn CalibrationSource,
    sensor: &gloam_sensor::SensorConfig,
) -> Result<f64, CalibError> {
    let n = source.levels();
    if n == 0 {
        return Err(CalibError::InsufficientData(
            "the source has no illuminated level to take its spectrum from".into(),
        ));
    }
    let level = source.set_level(n - 1)?;
    let Stimulus::Uniform { .. } = &level.stimulus else {
        return Err(CalibError::Source(
            "the source's levels are not uniform stimuli".into(),
        ));
    };
    let (img, shape) = gloam_simcam::render_stimulus(&level.stimulus, 1, 1)?;
    let chain = gloam_sensor::Chain::new(sensor)?;
    let per_j = shape.integrate_weighted(&chain.detected_response_e_per_j()) / shape.integral();
    let k = img[(0, 0)] * per_j / level.band_radiance_w_m2_sr;
    if !(k.is_finite() && k > 0.0) {
        return Err(CalibError::Source(format!(
            "the source's brightest level ({}) gives no detected signal per band radiance ({k})",
            level.label
        )));
    }
    Ok(k)
}

/// The gains to measure a LUT at so it spans `[lo, hi]`: geometric steps
/// of at most `ratio`, the ends rounded outwards to the 0.001 a simulated
/// camera sets (at most 24 gains).
pub fn lut_gains_spanning(lo: f64, hi: f64, ratio: f64) -> Vec<f64> {
    // A gain within a relative GAIN_MATCH_TOLERANCE of a setting is that
    // setting (the AGC's floor 14.5519 is the setting 14.552): rounding it
    // outwards would ask for a gain below the camera's range (14.551).
    let outward = |v: f64, round: fn(f64) -> f64| {
        let near = (v * 1000.0).round() / 1000.0;
        if (near - v).abs() <= crate::radiance::GAIN_MATCH_TOLERANCE * v.abs() {
            near
        } else {
            round(v * 1000.0) / 1000.0
        }
    };
    let lo = outward(lo, f64::floor);
    let hi = outward(hi, f64::ceil);
    if !(lo > 0.0 && hi > lo && ratio > 1.0) {
        return vec![lo.max(hi)];
    }
    let steps = ((hi / lo).ln() / ratio.ln()).ceil().clamp(1.0, 23.0) as usize;
    let mut g: Vec<f64> = (0..=steps)
        .map(|i| {
            let v = lo * (hi / lo).powf(i as f64 / steps as f64);
            (v * 1000.0).round() / 1000.0
        })
        .collect();
    g[0] = lo;
    g[steps] = hi;
    g.dedup();
    g
}

/// One `frames.jsonl` line, as this flow reads it.
struct Record {
    index: u64,
    file: String,
    gain: f64,
    bits: u8,
    clip_dn: f64,
    time_s: f64,
    weights: Vec<f64>,
    /// Its recorded gate duty in effect (`gate_duty`), if any.
    gate_duty: Option<f64>,
    /// With a `[sky]` clock: the two sky renders around it and how far
    /// towards the second (`sequence.sky.renders`, `fraction`).
    sky: Option<([usize; 2], f64)>,
    /// Its line (number, and `pixels_crc32c` checked against the counts).
    record: crate::io::FrameLine,
    /// How its counts are stored (`stored`: TIFF page, sample shift).
    at: crate::io::StoredAt,
}

fn read_records(dir: &Path, groups: &[String]) -> Result<Vec<Record>, CalibError> {
    use gloam_io::frames::FramesReadError as E;
    let jl = dir.join(gloam_io::frames::FRAMES_JSONL);
    // The run's own frames (its staging directory), not inputs: unlogged.
    let lines = gloam_io::frames::lines(&jl, &gloam_io::ReadLog::off()).map_err(|e| match e {
        E::Open { path, source } => CalibError::Read { path, source },
        e => crate::io::frames_read_error(e, ""),
    })?;
    let mut out = Vec::new();
    for l in lines {
        let l = l.map_err(|e| match e {
            E::Json { path, line, source } => CalibError::Line {
                path,
                line,
                message: source.to_string(),
            },
            e => crate::io::frames_read_error(e, ""),
        })?;
        out.push(record_of(&jl, l, groups)?);
    }
    Ok(out)
}

/// One line as this flow needs it, or what it lacks.
fn record_of(jl: &Path, l: crate::io::FrameLine, groups: &[String]) -> Result<Record, CalibError> {
    let at = |m: String| CalibError::Line {
        path: jl.to_path_buf(),
        line: l.line,
        message: m,
    };
    let num = |k: &str| l.number(k).ok_or_else(|| at(format!("no numeric \"{k}\"")));
    let seq = l
        .get("sequence")
        .ok_or_else(|| at("no \"sequence\": not a frame of a sequence".into()))?;
    let lg = seq.get("light_groups");
    let weights = groups
        .iter()
        .map(|g| {
            lg.and_then(|l| l.get(g))
                .and_then(serde_json::Value::as_f64)
                .ok_or_else(|| at(format!("no weight for light group '{g}'")))
        })
        .collect::<Result<Vec<f64>, _>>()?;
    Ok(Record {
        index: num("index")? as u64,
        file: l
            .file()
            .ok_or_else(|| at("no \"file\"".into()))?
            .to_string(),
        gain: num("gain")?,
        bits: num("bits")?.clamp(1.0, 16.0) as u8,
        clip_dn: num("saturated_at_dn")?,
        time_s: seq
            .get("time_s")
            .and_then(serde_json::Value::as_f64)
            .ok_or_else(|| at("no numeric \"sequence.time_s\"".into()))?,
        weights,
        gate_duty: l.number("gate_duty"),
        sky: match seq.get("sky") {
            None => None,
            Some(sky) => {
                let r = |k: usize| {
                    sky.get("renders")
                        .and_then(|r| r.get(k))
                        .and_then(serde_json::Value::as_u64)
                        .map(|x| x as usize)
                };
                let f = sky.get("fraction").and_then(serde_json::Value::as_f64);
                match (r(0), r(1), f) {
                    (Some(a), Some(b), Some(f)) if (0.0..=1.0).contains(&f) => Some(([a, b], f)),
                    _ => {
                        return Err(at(
                            "\"sequence.sky\" needs \"renders\" [a, b] and a \"fraction\" in [0, 1]"
                                .into(),
                        ));
                    }
                }
            }
        },
        at: l.stored(),
        record: l,
    })
}

/// The gains in effect of a captured sequence's frames (`dir`'s
/// `frames.jsonl`) that start `from_s` or more after the first.
pub fn gains_in_effect(dir: &Path, from_s: f64) -> Result<Vec<f64>, CalibError> {
    let r = read_records(dir, &[])?;
    let t0 = r.first().map_or(0.0, |x| x.time_s);
    let g: Vec<f64> = (r.iter())
        .filter(|x| x.time_s >= t0 + from_s)
        .map(|x| x.gain)
        .collect();
    if g.is_empty() {
        return Err(CalibError::InsufficientData(format!(
            "{}: no frame starts {from_s} s or more after the first (the AGC's acquisition); lengthen the sequence",
            dir.join("frames.jsonl").display()
        )));
    }
    Ok(g)
}

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

fn summary(frames: &[AgcSequenceFrame], phase: Phase) -> PhaseSummary {
    let r: Vec<f64> = frames
        .iter()
        .filter(|f| f.phase == phase)
        .filter_map(|f| f.residual_percent)
        .collect();
    if r.is_empty() {
        return PhaseSummary::default();
    }
    let n = r.len() as f64;
    PhaseSummary {
        frames: r.len(),
        rms_residual_percent: Some((r.iter().map(|x| x * x).sum::<f64>() / n).sqrt()),
        max_abs_residual_percent: Some(r.iter().map(|x| x.abs()).fold(0.0, f64::max)),
        mean_residual_percent: Some(r.iter().sum::<f64>() / n),
        rms_residual_at_settled_gain_percent: {
            let q: Vec<f64> = (frames.iter())
                .filter(|f| f.phase == phase)
                .filter_map(|f| f.residual_at_settled_gain_percent)
                .collect();
            (!q.is_empty()).then(|| (q.iter().map(|x| x * x).sum::<f64>() / q.len() as f64).sqrt())
        },
    }
}

/// Linearises the frames of a captured sequence in `dir` (its
/// `frames.jsonl` and frame files, as `gloam sequence` writes them) through
/// `lut` at each frame's gain in effect and compares them with the true
/// radiance: `layers` mixed with the frame's recorded weights, divided by
/// `detected_per_radiance` ([`detected_per_band_radiance`]). `camera` is
/// the camera's description (checked against the LUT's).
pub fn linearise_sequence(
    dir: &Path,
    lut: &Lut,
    camera: &str,
    truth: &SequenceLayers<'_>,
    detected_per_radiance: f64,
    opts: &AgcSequenceOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<AgcSequenceReport, CalibError> {
    if truth.layers.len() != truth.groups.len() {
        return Err(CalibError::Invalid(format!(
            "{} layers for {} light groups",
            truth.layers.len(),
            truth.groups.len()
        )));
    }
    let Some(shape) = truth.layers.first().map(Array2::dim) else {
        return Err(CalibError::Invalid("the scene has no light group".into()));
    };
    let records = read_records(dir, truth.groups)?;
    if records.is_empty() {
        return Err(CalibError::InsufficientData(format!(
            "{}: no frames",
            dir.join("frames.jsonl").display()
        )));
    }
    check_lut_fits_camera(lut, camera, records[0].bits)?;
    let mut mixed = Array2::<f64>::zeros(shape);
    let mut between: Vec<Array2<f64>> = Vec::new();
    let mut frames = Vec::with_capacity(records.len());
    let total = records.len();
    let mut prev_mean: Option<f64> = None;
    let mut switches: Vec<f64> = Vec::new();
    let window_s = opts.transient_time_constants * opts.agc_time_constant_s;
    let settled_gain = records[records.len() - 1].gain;
    let settled = lut.coefficients(settled_gain).ok();
    // A gated frame saw this fraction of the light the LUT's (ungated)
    // line answers for.
    let relative_duty = |r: &Record| {
        (r.gate_duty.unwrap_or(opts.gate_duty) / opts.gate_duty).clamp(f64::MIN_POSITIVE, 1.0)
    };
    let settled_duty = relative_duty(&records[records.len() - 1]);
    // One noise floor for the whole sequence, the noisiest calibrated
    // gain's (dark σ in radiance), so the pixels compared do not change
    // with the gain from frame to frame.
    let floor = opts.noise_floor_sigma
        * (lut.gains.iter())
            .map(|c| c.dark_std_dn * c.g_w_m2_sr_per_dn)
            .fold(0.0, f64::max);
    // A TIFF stack (`--frame-format tiff`) is opened once and read page
    // by page.
    let mut stack: Option<(PathBuf, crate::io::TiffPages)> = None;
    // The frames this run captured, not its inputs: unlogged.
    let own_frames = gloam_io::ReadLog::off();
    for (n, r) in records.iter().enumerate() {
        let path = dir.join(&r.file);
        let (w, h, px) = match (r.at.page, &mut stack) {
            (Some(_), Some((p, pages))) if *p == path => pages.counts(&r.at)?,
            (Some(_), _) => {
                let mut pages = crate::io::TiffPages::open(&path, &own_frames)?;
                let counts = pages.counts(&r.at)?;
                stack = Some((path.clone(), pages));
                counts
            }
            (None, _) => crate::io::read_frame_counts(&path, &r.at, &own_frames)?,
        };
        crate::io::check_frame_crc(&path, &dir.join("frames.jsonl"), &r.record, &px)?;
        if (h, w) != shape {
            return Err(CalibError::file(
                &path,
                format!(
                    "{w}×{h} frame, but the layers are {}×{}: the frames are not of this scene",
                    shape.1, shape.0
                ),
            ));
        }
        // A moving sky: this frame's layers lie between two renders.
        let layers = match r.sky {
            None => truth.layers,
            Some(([a, b], f)) => {
                let (Some(la), Some(lb)) = (truth.sky.get(a), truth.sky.get(b)) else {
                    return Err(CalibError::Line {
                        path: dir.join("frames.jsonl"),
                        line: r.record.line,
                        message: format!(
                            "sky renders {a} and {b}, but the sequence's renders are 0…{}",
                            truth.sky.len().saturating_sub(1)
                        ),
                    });
                };
                if la.len() != truth.groups.len() || lb.len() != truth.groups.len() {
                    return Err(CalibError::Invalid(format!(
                        "sky renders {a} and {b} carry {} and {} layers for {} light groups",
                        la.len(),
                        lb.len(),
                        truth.groups.len()
                    )));
                }
                gloam_simcam::layers_between(la, lb, f, &mut between);
                &between[..]
            }
        };
        gloam_simcam::mix_layers(layers, &r.weights, &mut mixed);
        let duty = relative_duty(r);
        let truth_px: Vec<f64> = mixed.iter().map(|d| d / detected_per_radiance).collect();
        let frame_mean = truth_px.iter().sum::<f64>() / truth_px.len().max(1) as f64;
        if let Some(p) = prev_mean
            && (frame_mean - p).abs() > opts.switch_threshold * p.abs().max(f64::MIN_POSITIVE)
        {
            switches.push(r.time_s);
        }
        prev_mean = Some(frame_mean);
        let phase = if switches.last().is_some_and(|&t| r.time_s < t + window_s) {
            Phase::Transient
        } else if r.time_s < records[0].time_s + window_s {
            Phase::Acquiring
        } else {
            Phase::Steady
        };
        let mut frame = AgcSequenceFrame {
            index: r.index,
            file: r.file.clone(),
            time_s: r.time_s,
            gain: r.gain,
            phase,
            true_frame_mean_w_m2_sr: frame_mean,
            valid_pixels: 0,
            beyond_lut_range_pixels: 0,
            near_beyond_pixels: 0,
            clipped_pixels: 0,
            below_floor_pixels: 0,
            true_mean_w_m2_sr: None,
            linearised_mean_w_m2_sr: None,
            median_ratio: None,
            mean_ratio: None,
            rms_relative_residual_percent: None,
            residual_percent: None,
            outside_lut: false,
            residual_at_settled_gain_percent: None,
        };
        let Ok((g, b)) = lut.coefficients(r.gain) else {
            frame.outside_lut = true;
            frames.push(frame);
            progress(n + 1, total);
            continue;
        };
        // The top of the range compared: a fraction of the frame's clip,
        // so a pixel's upward noise stays below it.
        let mut clip_dn = r.clip_dn;
        if lut.digitizer_max_dn > 0.0 {
            clip_dn = clip_dn.min(lut.digitizer_max_dn);
        }
        let top_dn = opts.top_fraction * clip_dn;
        // Pixels are chosen by their true radiance (the counts the LUT's
        // line predicts for it), never by their measured counts: choosing
        // by counts would drop a pixel's upward noise at the top and bias
        // the frame low.
        let beyond: Vec<f64> = (truth_px.iter())
            .map(|&t| if (t * duty - b) / g >= top_dn { t } else { 0.0 })
            .collect();
        frame.beyond_lut_range_pixels = beyond.iter().filter(|&&x| x > 0.0).count();
        let spread = box_mean(&beyond, shape.0, shape.1, opts.spread_radius_px);
        let mut ratios = Vec::with_capacity(px.len());
        let (mut st, mut sl, mut ss, mut sl_settled) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (((&t, &c), &spread), &over) in truth_px.iter().zip(&px).zip(&spread).zip(&beyond) {
            // Were all the light of the pixels beyond the range within the
            // spread radius spread evenly over it, would it reach
            // `spread_tolerance` of this pixel's own?
            if over > 0.0 {
                // Counted in `beyond_lut_range_pixels`.
            } else if spread > opts.spread_tolerance * t {
                frame.near_beyond_pixels += 1;
            } else if !(t * duty > floor) || !(t > 0.0) {
                frame.below_floor_pixels += 1;
            } else {
                let l = (g * f64::from(c) + b) / duty;
                if f64::from(c) >= r.clip_dn {
                    frame.clipped_pixels += 1;
                }
                let q = l / t;
                ratios.push(q);
                st += t;
                sl += l;
                if let Some((gs, bs)) = settled {
                    sl_settled += (gs * f64::from(c) + bs) / settled_duty;
                }
                ss += (q - 1.0) * (q - 1.0);
            }
        }
        let k = ratios.len();
        frame.valid_pixels = k;
        if k > 0 {
            frame.true_mean_w_m2_sr = Some(st / k as f64);
            frame.linearised_mean_w_m2_sr = Some(sl / k as f64);
            frame.mean_ratio = Some(sl / st);
            frame.rms_relative_residual_percent = Some(100.0 * (ss / k as f64).sqrt());
            frame.median_ratio = median(&mut ratios);
            frame.residual_percent = Some(100.0 * (sl / st - 1.0));
            frame.residual_at_settled_gain_percent =
                settled.map(|_| 100.0 * (sl_settled / st - 1.0));
        }
        frames.push(frame);
        progress(n + 1, total);
    }
    let outside = frames.iter().filter(|f| f.outside_lut).count();
    let gains = records.iter().map(|r| r.gain);
    let gain_range = [
        gains.clone().fold(f64::INFINITY, f64::min),
        gains.fold(f64::NEG_INFINITY, f64::max),
    ];
    if outside * 2 >= frames.len() {
        let [lo, hi] = gain_range;
        // Gains as the other messages print them (not in 17 digits).
        let (lo, hi) = (crate::error::gain_text(lo), crate::error::gain_text(hi));
        let lut_gains = crate::apply::lut_gains_text(lut);
        return Err(CalibError::LutNotForCamera {
            lut_camera: crate::apply::camera_identity(&lut.grabber).to_string(),
            camera: crate::apply::camera_identity(camera).to_string(),
            reason: format!(
                "{outside} of {} frames were taken at gains outside its calibrated gains {lut_gains} (the AGC visited {lo}–{hi})",
                frames.len()
            ),
            gains: format!("gains spanning {lo}–{hi}"),
        });
    }
    // No frame with a pixel to compare: said with the pixels' reasons, not
    // as the plot's "nothing to plot" after the run (every frame of a
    // sunlit sequence saturated the camera).
    if frames.iter().all(|f| f.valid_pixels == 0) {
        let sum = |g: &dyn Fn(&AgcSequenceFrame) -> usize| frames.iter().map(g).sum::<usize>();
        return Err(CalibError::InsufficientData(format!(
            "none of the sequence's {} frames had a pixel to compare with its true radiance (over all frames: {} pixels above the LUT's range, {} within their spread, {} at the frame's clip, {} below the noise floor); light or darken the sequence's scene for the camera",
            frames.len(),
            sum(&|f| f.beyond_lut_range_pixels),
            sum(&|f| f.near_beyond_pixels),
            sum(&|f| f.clipped_pixels),
            sum(&|f| f.below_floor_pixels),
        )));
    }
    let steady = summary(&frames, Phase::Steady);
    let transient = summary(&frames, Phase::Transient);
    Ok(AgcSequenceReport {
        camera: camera.to_string(),
        lut_source: lut.source.clone(),
        lut_gain_range: lut_gain_range(lut).map(|(a, b)| [a, b]),
        lut_max_fit_residual_percent: lut
            .gains
            .iter()
            .map(|c| c.max_abs_residual_percent)
            .fold(0.0, f64::max),
        detected_per_band_radiance_e_per_j: detected_per_radiance,
        agc_time_constant_s: opts.agc_time_constant_s,
        transient_window_s: window_s,
        noise_floor_sigma: opts.noise_floor_sigma,
        noise_floor_w_m2_sr: floor,
        top_fraction: opts.top_fraction,
        settled_gain,
        spread_radius_px: opts.spread_radius_px,
        spread_tolerance: opts.spread_tolerance,
        switches_s: switches,
        transient_over_steady: match (transient.rms_residual_percent, steady.rms_residual_percent) {
            (Some(t), Some(s)) if s > 0.0 => Some(t / s),
            _ => None,
        },
        acquiring: summary(&frames, Phase::Acquiring),
        steady,
        transient,
        frames_outside_lut: outside,
        gain_range,
        frames,
    })
}

/// Writes `agc_sequence.json`, `agc_sequence.png` (linearised and true
/// mean radiance over the compared pixels against time) and
/// `agc_sequence_residual.png` (each frame's residual) into `dir`.
pub fn write_agc_sequence_report(dir: &Path, r: &AgcSequenceReport) -> Result<(), CalibError> {
    crate::report::write_json(&dir.join("agc_sequence.json"), r)?;
    use crate::plot::{Mark, Scale, Series, xy_plot_scaled};
    let pts = |f: &dyn Fn(&AgcSequenceFrame) -> Option<f64>| {
        r.frames
            .iter()
            .filter_map(|x| Some((x.time_s, f(x)?)))
            .collect::<Vec<_>>()
    };
    xy_plot_scaled(
        &dir.join("agc_sequence.png"),
        "linearised vs true radiance (mean over the compared pixels)",
        ("time, s", Scale::Linear),
        ("radiance, W m⁻² sr⁻¹ (rig-equivalent)", Scale::Log10),
        &[
            Series::new("true", pts(&|x| x.true_mean_w_m2_sr), Mark::Line),
            Series::new(
                "linearised",
                pts(&|x| x.linearised_mean_w_m2_sr),
                Mark::Points,
            ),
        ],
    )?;
    xy_plot_scaled(
        &dir.join("agc_sequence_residual.png"),
        "median linearised/true − 1 per frame",
        ("time, s", Scale::Linear),
        ("residual, %", Scale::Linear),
        &[Series::new(
            "residual %",
            pts(&|x| x.residual_percent),
            Mark::LinePoints,
        )],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lut_gains_span_the_range_in_bounded_steps() {
        let g = lut_gains_spanning(129.8244, 176.51, 1.25);
        assert_eq!(g.first(), Some(&129.824));
        assert_eq!(g.last(), Some(&176.51));
        assert!(g.len() >= 3, "{g:?}");
        for w in g.windows(2) {
            assert!(w[1] / w[0] <= 1.25 + 1e-9 && w[1] > w[0], "{g:?}");
        }
        assert_eq!(lut_gains_spanning(50.0, 50.0, 1.25), vec![50.0]);
    }

    #[test]
    fn the_agc_floor_is_the_lowest_setting_not_one_below_it() {
        // Gen III's MCP at 500 V: 1000 (500/800)^9 = 14.5519…, which the
        // camera sets as 14.552 (its lowest setting); flooring it asked
        // for 14.551 and the camera refused a gain nobody wanted.
        let floor = 1000.0 * 0.625f64.powi(9);
        assert!((floor - 14.551_915_228_366_852).abs() < 1e-12);
        let g = lut_gains_spanning(floor, 30.012, 1.25);
        assert_eq!(g.first(), Some(&14.552), "{g:?}");
        assert_eq!(g.last(), Some(&30.012), "{g:?}");
        // Farther than the tolerance from a setting still rounds outwards.
        let g = lut_gains_spanning(1.0006, 2.0004, 1.25);
        assert_eq!((g[0], g[g.len() - 1]), (1.0, 2.001), "{g:?}");
        // And a LUT measured at the setting linearises frames at the floor.
        let lut = crate::radiance::Lut {
            grabber: "simulated gen3-gaas-iccd".into(),
            source: "sphere".into(),
            band_nm: [400.0, 900.0],
            digitizer_max_dn: 4095.0,
            gains: [14.552, 20.0]
                .iter()
                .map(|&gain| crate::radiance::GainCalibration {
                    gain,
                    g_w_m2_sr_per_dn: 1e-6 / gain,
                    b_w_m2_sr: 0.0,
                    r_squared: 1.0,
                    fit_range_dn: [10.0, 2000.0],
                    dark_dn: 10.0,
                    dark_std_dn: 1.0,
                    saturation_dn: None,
                    n_fit_points: 5,
                    max_abs_residual_percent: 0.1,
                    levels: Vec::new(),
                    warnings: Vec::new(),
                })
                .collect(),
        };
        assert_eq!(lut.coefficients(floor).unwrap(), (1e-6 / 14.552, 0.0));
        assert!(lut.coefficients(14.55).is_err());
    }

    #[test]
    fn a_sequence_frame_not_matching_its_recorded_crc_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let px: Vec<u16> = vec![100, 200, 300, 400];
        image::ImageBuffer::<image::Luma<u16>, _>::from_raw(2, 2, px.clone())
            .unwrap()
            .save(d.path().join("f.png"))
            .unwrap();
        let line = |crc: u32| {
            format!(
                "{{\"index\":0,\"file\":\"f.png\",\"gain\":1.0,\"bits\":16,\"saturated_at_dn\":60000,\"pixels_crc32c\":{crc},\"sequence\":{{\"time_s\":0.0,\"light_groups\":{{\"lamp\":1.0}}}}}}\n"
            )
        };
        let lut = crate::radiance::Lut {
            grabber: "simulated x".into(),
            source: "s".into(),
            band_nm: [400.0, 900.0],
            digitizer_max_dn: 65535.0,
            gains: vec![crate::radiance::GainCalibration {
                gain: 1.0,
                g_w_m2_sr_per_dn: 1e-6,
                b_w_m2_sr: 0.0,
                r_squared: 1.0,
                fit_range_dn: [0.0, 1000.0],
                dark_dn: 0.0,
                dark_std_dn: 1.0,
                saturation_dn: None,
                n_fit_points: 3,
                max_abs_residual_percent: 0.0,
                levels: Vec::new(),
                warnings: Vec::new(),
            }],
        };
        let groups = ["lamp".to_string()];
        let layers = [Array2::from_elem((2, 2), 1e-4)];
        let truth = SequenceLayers {
            groups: &groups,
            layers: &layers,
            sky: &[],
        };
        let opts = AgcSequenceOptions {
            noise_floor_sigma: 3.0,
            transient_time_constants: 3.0,
            switch_threshold: 0.1,
            agc_time_constant_s: 0.1,
            top_fraction: 0.5,
            spread_radius_px: 0,
            spread_tolerance: 0.01,
            gate_duty: 1.0,
        };
        let run = || {
            linearise_sequence(
                d.path(),
                &lut,
                "simulated x",
                &truth,
                1.0,
                &opts,
                &mut |_, _| {},
            )
        };
        let good = gloam_grabber::pixels_crc32c(&px);
        std::fs::write(d.path().join("frames.jsonl"), line(good)).unwrap();
        run().unwrap();
        std::fs::write(d.path().join("frames.jsonl"), line(good ^ 1)).unwrap();
        let e = run().unwrap_err().to_string();
        assert!(
            e.starts_with(&format!(
                "{}: its counts have CRC-32C {good:#010x}, but {}:1 records {:#010x}",
                d.path().join("f.png").display(),
                d.path().join("frames.jsonl").display(),
                good ^ 1
            )),
            "{e}"
        );
    }

    #[test]
    fn the_box_mean_spreads_a_pixel_over_its_square() {
        let (rows, cols) = (7, 9);
        let mut m = vec![0.0; rows * cols];
        m[3 * cols + 4] = 25.0;
        let d = box_mean(&m, rows, cols, 2);
        for r in 0..rows {
            for c in 0..cols {
                let inside = r.abs_diff(3) <= 2 && c.abs_diff(4) <= 2;
                let want = if inside { 1.0 } else { 0.0 };
                assert!((d[r * cols + c] - want).abs() < 1e-12, "{r},{c}");
            }
        }
        assert_eq!(box_mean(&m, rows, cols, 0), m);
    }

    #[test]
    fn the_median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), Some(2.5));
        assert_eq!(median(&mut []), None);
    }
}
