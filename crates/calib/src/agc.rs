//! AGC linearisation: a radiance staircase up and back down, once with AGC
//! on and once with the gain overridden.
//!
//! Per step with AGC on, the reported gain's transition gives the settling
//! time (10 → 90 % of the change, frames and µs from frame timestamps) and
//! the overshoot (% of the change beyond the final value); a step is settled
//! when the gain over its last quarter spans no more than `settle_tolerance`
//! of its final value. Hysteresis compares the settled output at the same
//! radiance going up and coming down (% of the output span). Linearity
//! error is the largest deviation of the overridden (fixed-gain) settled
//! means from their straight line, % of span. With a LUT, every settled AGC
//! frame is linearised through the LUT for its reported gain and compared
//! with the true band radiance. The LUT must be this camera's, for its bit
//! depth (checked on the first frame, before the staircase is spent) and
//! span the gains the AGC visits (checked after: the AGC chooses them);
//! when most settled frames lie outside its gains the run is refused, since
//! a residual over the few inside would not describe the AGC.

use gloam_grabber::FrameGrabber;
use serde::Serialize;

use crate::apply::{camera_identity, check_lut_fits_camera, lut_gain_range};
use crate::capture::{frame_mean, grab_good};
use crate::error::CalibError;
use crate::radiance::Lut;
use crate::source::CalibrationSource;
use crate::stats::weighted_linear_fit;

#[derive(Clone, Debug)]
pub struct AgcOptions {
    /// Gain used for the overridden (fixed) run; `None`: the camera's
    /// current gain with AGC off.
    pub fixed_gain: Option<f64>,
    /// Frames captured per staircase step.
    pub frames_per_step: usize,
    /// Relative tolerance on the final gain for "settled".
    pub settle_tolerance: f64,
    /// Return the report even if steps do not settle (else an error).
    pub allow_unsettled: bool,
}

/// Frames per staircase step (the CLI's and Python's default).
pub const DEFAULT_FRAMES_PER_STEP: usize = 60;

impl Default for AgcOptions {
    fn default() -> Self {
        Self {
            fixed_gain: None,
            frames_per_step: DEFAULT_FRAMES_PER_STEP,
            settle_tolerance: 0.02,
            allow_unsettled: false,
        }
    }
}

/// One frame of the time series.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AgcSample {
    pub step: usize,
    pub timestamp_us: u64,
    pub band_radiance_w_m2_sr: f64,
    pub mean_dn: f64,
    pub gain: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AgcStep {
    pub step: usize,
    pub band_radiance_w_m2_sr: f64,
    pub direction: String,
    pub settled: bool,
    pub settling_frames: Option<f64>,
    pub settling_time_us: Option<f64>,
    pub overshoot_percent: Option<f64>,
    pub final_gain: f64,
    pub settled_mean_dn: f64,
    pub fixed_mean_dn: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AgcReport {
    pub steps: Vec<AgcStep>,
    pub all_settled: bool,
    pub max_settling_time_us: Option<f64>,
    pub max_overshoot_percent: Option<f64>,
    pub hysteresis_gain_percent: f64,
    pub hysteresis_dn_percent: f64,
    pub linearity_error_percent: f64,
    pub linearised_rms_error_percent: Option<f64>,
    pub linearised_max_error_percent: Option<f64>,
    /// Settled AGC frames linearised through the LUT (0 without one).
    pub frames_linearised: usize,
    pub frames_outside_lut: usize,
    /// Lowest and highest gain the AGC reported over its run.
    pub agc_gain_range: [f64; 2],
    /// Lowest and highest gain the LUT was calibrated at.
    pub lut_gain_range: Option<[f64; 2]>,
    pub agc_series: Vec<AgcSample>,
    pub fixed_series: Vec<AgcSample>,
}

fn staircase(n: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..n).collect();
    v.extend((0..n.saturating_sub(1)).rev());
    v
}

/// Runs the AGC staircase. `lut` enables the linearisation check.
pub fn agc_linearisation(
    grabber: &mut dyn FrameGrabber,
    source: &mut dyn CalibrationSource,
    opts: &AgcOptions,
    lut: Option<&Lut>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<AgcReport, CalibError> {
    let n = source.levels();
    if n < 2 {
        return Err(CalibError::InsufficientData(format!(
            "an AGC staircase needs at least 2 levels (source has {n})"
        )));
    }
    if opts.frames_per_step < 4 {
        return Err(CalibError::Invalid("frames per step must be ≥ 4".into()));
    }
    let stairs = staircase(n);
    let total = 2 * stairs.len();
    let mut done = 0;
    // The LUT is checked against the camera at the first frame.
    let mut unchecked = lut;
    let mut step_done = || {
        done += 1;
        progress(done, total);
    };
    if let Some(g) = opts.fixed_gain {
        grabber.set_gain(g)?;
    }
    crate::capture::agc_off(grabber)?;
    let fixed = run_staircase(
        grabber,
        source,
        (&stairs, opts),
        &mut unchecked,
        &mut step_done,
    )?;
    grabber.set_agc(true)?;
    let agc = run_staircase(
        grabber,
        source,
        (&stairs, opts),
        &mut unchecked,
        &mut step_done,
    )?;
    crate::capture::agc_off(grabber)?;

    let per = opts.frames_per_step;
    let tail = (per / 4).max(2);
    let mut steps = Vec::new();
    let mut prev_final: Option<f64> = None;
    for s in 0..stairs.len() {
        let a = &agc[s * per..(s + 1) * per];
        let fx = &fixed[s * per..(s + 1) * per];
        let step = step_response(s, a, fx, prev_final, (n, tail), opts);
        prev_final = Some(step.final_gain);
        steps.push(step);
    }
    let all_settled = steps.iter().all(|s| s.settled);
    if !all_settled && !opts.allow_unsettled {
        return Err(not_settled(&steps, opts));
    }
    let (hg, hd, dspan) = hysteresis(&steps, n);
    let lin = overridden_linearity(&steps, dspan)?;
    // Linearisation through the LUT.
    let gains = agc.iter().map(|x| x.gain);
    let agc_gain_range = [
        gains.clone().fold(f64::INFINITY, f64::min),
        gains.fold(f64::NEG_INFINITY, f64::max),
    ];
    let Linearised {
        rms,
        mx,
        outside,
        linearised,
    } = match lut {
        Some(lut) => linearised(lut, grabber, &agc, (per, tail), agc_gain_range)?,
        None => Linearised::default(),
    };
    Ok(AgcReport {
        max_settling_time_us: largest(steps.iter().filter_map(|s| s.settling_time_us)),
        max_overshoot_percent: largest(steps.iter().filter_map(|s| s.overshoot_percent)),
        steps,
        all_settled,
        hysteresis_gain_percent: hg,
        hysteresis_dn_percent: hd,
        linearity_error_percent: lin,
        linearised_rms_error_percent: rms,
        linearised_max_error_percent: mx,
        frames_linearised: linearised,
        frames_outside_lut: outside,
        agc_gain_range,
        lut_gain_range: lut.and_then(lut_gain_range).map(|(a, b)| [a, b]),
        agc_series: agc,
        fixed_series: fixed,
    })
}

/// Why a staircase whose AGC did not settle at every step is refused.
fn not_settled(steps: &[AgcStep], opts: &AgcOptions) -> CalibError {
    let bad: Vec<usize> = steps
        .iter()
        .filter(|s| !s.settled)
        .map(|s| s.step)
        .collect();
    CalibError::NotSettled(format!(
        "the AGC gain was still moving by more than {:.1} % at the end of step(s) {bad:?} ({} frames each): lengthen the steps (--frames) or check the AGC loop",
        100.0 * opts.settle_tolerance,
        opts.frames_per_step
    ))
}

/// The overridden run's linearity error: its largest residual from a
/// straight line through output against radiance, as a percentage of its
/// output span `dspan` (0 with no span).
fn overridden_linearity(steps: &[AgcStep], dspan: f64) -> Result<f64, CalibError> {
    let x: Vec<f64> = steps.iter().map(|s| s.band_radiance_w_m2_sr).collect();
    let y: Vec<f64> = steps.iter().map(|s| s.fixed_mean_dn).collect();
    let fit = weighted_linear_fit(&x, &y, &vec![1.0; x.len()])?;
    Ok(if dspan > 0.0 {
        fit.residuals.iter().map(|r| r.abs()).fold(0.0, f64::max) / dspan * 100.0
    } else {
        0.0
    })
}

/// The largest of `v`, if any.
fn largest(v: impl Iterator<Item = f64>) -> Option<f64> {
    v.fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))
}

/// Captures the staircase once: `frames_per_step` frames at each level
/// in turn, checking `unchecked` (then cleared) against the camera at
/// the first frame.
fn run_staircase(
    grabber: &mut dyn FrameGrabber,
    source: &mut dyn CalibrationSource,
    (stairs, opts): (&[usize], &AgcOptions),
    unchecked: &mut Option<&Lut>,
    step_done: &mut dyn FnMut(),
) -> Result<Vec<AgcSample>, CalibError> {
    let mut out = Vec::new();
    for (s, &lvl) in stairs.iter().enumerate() {
        let lv = source.set_level(lvl)?;
        grabber.present(&lv.stimulus)?;
        for _ in 0..opts.frames_per_step {
            let f = grab_good(grabber)?;
            if let Some(lut) = unchecked.take() {
                check_lut_fits_camera(lut, &grabber.describe(), f.meta.bits)?;
            }
            out.push(AgcSample {
                step: s,
                timestamp_us: f.meta.timestamp_us,
                band_radiance_w_m2_sr: lv.band_radiance_w_m2_sr,
                mean_dn: frame_mean(&f),
                gain: f.meta.gain,
            });
        }
        step_done();
    }
    Ok(out)
}

/// One step of the staircase under the AGC: its settled gain and output,
/// whether it settled (the gain's spread over the last `tail` frames
/// within the tolerance), its 10–90 % settling time from the previous
/// step's gain, and its overshoot; `fx` is the same step overridden.
fn step_response(
    s: usize,
    a: &[AgcSample],
    fx: &[AgcSample],
    prev_final: Option<f64>,
    (n, tail): (usize, usize),
    opts: &AgcOptions,
) -> AgcStep {
    let per = a.len();
    let last = &a[per - tail..];
    let final_gain = last.iter().map(|x| x.gain).sum::<f64>() / tail as f64;
    // Settled: over the last quarter the gain spans no more than the
    // tolerance (a slow drift that stays near its mean is not settled).
    let (gmin, gmax) = last
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x.gain), b.max(x.gain))
        });
    let settled = gmax - gmin <= opts.settle_tolerance * final_gain.abs();
    let start = prev_final.unwrap_or(a[0].gain);
    let delta = final_gain - start;
    let (mut t10, mut t90, mut over) = (None, None, None);
    if settled && delta.abs() > opts.settle_tolerance * final_gain.abs() {
        let frac = |g: f64| (g - start) / delta;
        for (i, x) in a.iter().enumerate() {
            if t10.is_none() && frac(x.gain) >= 0.1 {
                t10 = Some(i);
            }
            if t90.is_none() && frac(x.gain) >= 0.9 {
                t90 = Some(i);
            }
        }
        let peak = a
            .iter()
            .map(|x| frac(x.gain))
            .fold(f64::NEG_INFINITY, f64::max);
        over = Some(100.0 * (peak - 1.0).max(0.0));
    } else if settled {
        over = Some(0.0);
    }
    let (sf, st) = match (t10, t90) {
        (Some(a10), Some(a90)) => (
            Some(a90 as f64 - a10 as f64),
            Some(a[a90].timestamp_us as f64 - a[a10].timestamp_us as f64),
        ),
        _ if settled => (Some(0.0), Some(0.0)),
        _ => (None, None),
    };
    AgcStep {
        step: s,
        band_radiance_w_m2_sr: a[0].band_radiance_w_m2_sr,
        direction: if s < n { "up".into() } else { "down".into() },
        settled,
        settling_frames: sf,
        settling_time_us: st,
        overshoot_percent: over,
        final_gain,
        settled_mean_dn: last.iter().map(|x| x.mean_dn).sum::<f64>() / tail as f64,
        fixed_mean_dn: fx[per - tail..].iter().map(|x| x.mean_dn).sum::<f64>() / tail as f64,
    }
}

/// Hysteresis: step s (up) against its mirror 2(n−1)−s (down), the
/// largest difference as a percentage of the span, for the AGC's settled
/// gain and for the overridden run's output; and that output's span.
fn hysteresis(steps: &[AgcStep], n: usize) -> (f64, f64, f64) {
    let mut hg: f64 = 0.0;
    let mut hd: f64 = 0.0;
    let gspan = steps
        .iter()
        .map(|s| s.final_gain)
        .fold(f64::NEG_INFINITY, f64::max)
        - steps
            .iter()
            .map(|s| s.final_gain)
            .fold(f64::INFINITY, f64::min);
    let dspan = steps
        .iter()
        .map(|s| s.fixed_mean_dn)
        .fold(f64::NEG_INFINITY, f64::max)
        - steps
            .iter()
            .map(|s| s.fixed_mean_dn)
            .fold(f64::INFINITY, f64::min);
    for s in 0..n - 1 {
        let m = 2 * (n - 1) - s;
        if gspan > 0.0 {
            hg = hg.max((steps[s].final_gain - steps[m].final_gain).abs() / gspan * 100.0);
        }
        if dspan > 0.0 {
            hd = hd.max((steps[s].fixed_mean_dn - steps[m].fixed_mean_dn).abs() / dspan * 100.0);
        }
    }
    (hg, hd, dspan)
}

/// The AGC run read through the LUT: errors of the linearised radiance on
/// the settled frames, and how many frames fell outside its gains.
#[derive(Default)]
struct Linearised {
    rms: Option<f64>,
    mx: Option<f64>,
    outside: usize,
    linearised: usize,
}

/// Reads each settled AGC frame (the last `tail` of each step of `per`)
/// through the LUT at the gain it was taken at; a LUT that misses most
/// of them is for another camera (or other gains).
fn linearised(
    lut: &Lut,
    grabber: &mut dyn FrameGrabber,
    agc: &[AgcSample],
    (per, tail): (usize, usize),
    agc_gain_range: [f64; 2],
) -> Result<Linearised, CalibError> {
    let (mut rms, mut mx, mut outside) = (None, None, 0usize);
    let mut errs = Vec::new();
    for s in 0..agc.len() / per {
        for x in &agc[s * per + per - tail..(s + 1) * per] {
            if x.band_radiance_w_m2_sr <= 0.0 {
                continue;
            }
            match lut.coefficients(x.gain) {
                Ok((g, b)) => {
                    let l = g * x.mean_dn + b;
                    errs.push(100.0 * (l - x.band_radiance_w_m2_sr) / x.band_radiance_w_m2_sr)
                }
                Err(_) => outside += 1,
            }
        }
    }
    let linearised = errs.len();
    if outside > 0 && outside >= linearised {
        let [lo, hi] = agc_gain_range;
        // Gains as the other messages print them (not in 17 digits).
        let (lo, hi) = (crate::error::gain_text(lo), crate::error::gain_text(hi));
        let lut_gains = crate::apply::lut_gains_text(lut);
        return Err(CalibError::LutNotForCamera {
            lut_camera: camera_identity(&lut.grabber).to_string(),
            camera: camera_identity(&grabber.describe()).to_string(),
            reason: format!(
                "{outside} of {} settled AGC frames were taken at gains outside its calibrated gains {lut_gains} (the AGC visited {lo}–{hi})",
                outside + linearised
            ),
            gains: format!("gains spanning {lo}–{hi} (e.g. --gains {lo},{hi} and some between)"),
        });
    }
    if !errs.is_empty() {
        rms = Some((errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt());
        mx = Some(errs.iter().map(|e| e.abs()).fold(0.0, f64::max));
    }
    Ok(Linearised {
        rms,
        mx,
        outside,
        linearised,
    })
}
