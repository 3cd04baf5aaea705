//! Automatic exposure (`--exposure auto`): the gain, gate, exposure time
//! and ND filter a lab would set so a scene sits inside the camera's range.
//!
//! The controls form one ladder of throughput, walked from the most to the
//! least sensitive setting in the order a lab uses them: the gain (MCP
//! voltage, or the CCD's system gain) down to its minimum first — it costs
//! no photons — then the photocathode gate (intensified cameras; duty down
//! to a [`GATE_MIN_S`] gate) or the exposure time (CCDs; down to
//! [`EXPOSURE_MIN_S`]), then a neutral-density filter up to
//! [`ND_MAX`]. A bisection on that ladder, with noise-free captures of
//! the scene, puts the chosen percentile of the frame (default the 99th) at
//! the chosen fraction of the range from black to saturation (default
//! 0.8); then, with the camera's noise on (its own seed), the exposure
//! steps down until fewer than 0.5 % of the pixels saturate. A scene too dim at the
//! most sensitive setting, or too bright at the least, is reported with
//! the stops it lacks.

use gloam_sensor::{Camera, SensorConfig};
use ndarray::Array2;
use serde::Serialize;

/// Why no exposure was chosen.
#[derive(Debug, thiserror::Error)]
pub enum ExposureError {
    #[error("exposure percentile {0} is not within 0–100")]
    Percentile(f64),
    #[error("exposure fraction of range {0} is not within (0, 1)")]
    FractionOfRange(f64),
    #[error(transparent)]
    Camera(#[from] gloam_sensor::ConfigError),
    #[error(transparent)]
    Capture(#[from] gloam_sensor::CaptureError),
}

/// Shortest photocathode gate of an autogated power supply, s (Gen II/III
/// autogating supplies gate down to ~100 ns).
pub const GATE_MIN_S: f64 = 100e-9;
/// Shortest CCD exposure, s.
pub const EXPOSURE_MIN_S: f64 = 1e-6;
/// Densest ND filter stack, optical density.
pub const ND_MAX: f64 = 6.0;
/// The median a readable frame should reach, as a fraction of full scale
/// (`2^bits − 1`): the chosen exposure reports what lifting its median
/// there would clip ([`ExposureChoice::median_goal_saturated_fraction`]).
pub const MEDIAN_GOAL_OF_FULL_SCALE: f64 = 0.10;

/// Where the exposure should put the frame.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ExposureTarget {
    /// Percentile of the frame's pixels, 0–100.
    pub percentile: f64,
    /// Fraction of the range from black to saturation for that percentile.
    pub fraction_of_range: f64,
}

impl Default for ExposureTarget {
    fn default() -> Self {
        Self {
            percentile: 99.0,
            fraction_of_range: 0.8,
        }
    }
}

/// The exposure chosen, and what it gives.
#[derive(Clone, Debug, Serialize)]
pub struct ExposureChoice {
    pub target: ExposureTarget,
    /// Gain in effect (override; AGC off).
    pub gain: f64,
    /// Photocathode gate duty (intensified cameras; 1 = ungated).
    pub gate_duty: Option<f64>,
    pub exposure_s: f64,
    pub nd_density: f64,
    /// The noise-free frame at this exposure: the target percentile, the
    /// median, the black and saturation levels (DN); and the saturated
    /// fraction of the frame with noise.
    pub percentile_dn: f64,
    pub median_dn: f64,
    pub black_dn: f64,
    pub saturation_dn: f64,
    pub saturated_fraction: f64,
    /// Median over full scale `2^bits − 1` (noise-free frame).
    pub median_of_full_scale: f64,
    /// (median − black) over full scale: what the frame records and the
    /// fit state, and what [`MEDIAN_GOAL_OF_FULL_SCALE`] is a goal for.
    pub median_above_black_of_full_scale: f64,
    /// The fraction of pixels that would saturate if the exposure were
    /// raised until the median reached [`MEDIAN_GOAL_OF_FULL_SCALE`] (from
    /// the noise-free frame, the chain taken as linear): above 1 % the
    /// scene's highlights (lamps in view) and a readable median do not fit
    /// in one frame of this camera. 0 when the median is already there.
    pub median_goal_saturated_fraction: f64,
    /// Stops of light the scene lacks (positive: too dim at the most
    /// sensitive setting) or has too much of (negative: too bright at the
    /// least sensitive); 0 when the target was reached; infinite (`null`
    /// in report.json) when the scene holds no light the camera detects.
    pub stops_out_of_range: f64,
    pub note: String,
}

/// One point of the throughput ladder, `t` = ln(relative throughput) ≤ 0.
#[derive(Clone, Copy, Debug)]
struct Setting {
    gain: f64,
    duty: Option<f64>,
    exposure_s: f64,
    nd: f64,
}

struct Ladder {
    gain_min: f64,
    gain_max: f64,
    /// Gate duty (intensified) or exposure time (CCD), its maximum and minimum.
    intensified: bool,
    second_max: f64,
    second_min: f64,
}

impl Ladder {
    fn of(config: &SensorConfig, camera: &Camera) -> Self {
        let chain = camera.chain();
        let exposure = config.timing.exposure_s;
        let intensified = config.photocathode.is_some();
        let (second_max, second_min) = if intensified {
            (1.0, (GATE_MIN_S / exposure).min(1.0))
        } else {
            let max = 1.0 / config.timing.frame_rate_hz;
            (max.max(exposure), EXPOSURE_MIN_S.min(exposure))
        };
        Self {
            gain_min: chain.gain_min,
            gain_max: chain.gain_max,
            intensified,
            second_max,
            second_min,
        }
    }

    /// ln of the least throughput (the most sensitive setting is t = 0).
    fn t_min(&self) -> f64 {
        (self.gain_min / self.gain_max).ln() + (self.second_min / self.second_max).ln()
            - ND_MAX * std::f64::consts::LN_10
    }

    /// The ladder point of a setting (inverse of [`Ladder::at`]).
    fn t_of(&self, s: &Setting) -> f64 {
        let second = match s.duty {
            Some(d) => d,
            None => s.exposure_s,
        };
        (s.gain / self.gain_max).ln() + (second / self.second_max).ln()
            - s.nd * std::f64::consts::LN_10
    }

    fn at(&self, t: f64, base_exposure_s: f64) -> Setting {
        let lg = (self.gain_min / self.gain_max).ln();
        let ls = (self.second_min / self.second_max).ln();
        let gain = self.gain_max * t.max(lg).exp();
        let r = (t - lg).min(0.0);
        let second = self.second_max * r.max(ls).exp();
        // (+ 0.0 turns −0 into 0.)
        let nd = -((r - ls).min(0.0)) / std::f64::consts::LN_10 + 0.0;
        let (duty, exposure_s) = if self.intensified {
            (Some(second), base_exposure_s)
        } else {
            (None, second)
        };
        Setting {
            gain: gain.clamp(self.gain_min, self.gain_max),
            duty,
            exposure_s,
            nd,
        }
    }
}

/// Applies an exposure to a sensor configuration.
pub fn apply(config: &mut SensorConfig, c: &ExposureChoice) {
    config.optics.nd_density = c.nd_density;
    config.timing.exposure_s = c.exposure_s;
    if let (Some(p), Some(d)) = (config.photocathode.as_mut(), c.gate_duty) {
        p.gate_duty = d;
    }
}

/// A percentile (0–100) of `v` (sorted in place), nearest rank.
fn percentile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let k = ((p / 100.0) * (v.len() - 1) as f64).round() as usize;
    v[k.min(v.len() - 1)]
}

/// Frame figures at one setting, DN.
#[derive(Clone, Copy, Debug)]
struct Measured {
    percentile: f64,
    median: f64,
    saturated_fraction: f64,
    black: f64,
    saturation: f64,
    max_code: f64,
    median_goal_saturated_fraction: f64,
}

impl Measured {
    /// Signal above black at the percentile.
    fn signal(&self) -> f64 {
        self.percentile - self.black
    }
}

/// The frame at one setting (noise off: the scene's own signal).
fn measure(
    config: &SensorConfig,
    s: Setting,
    detected: &Array2<f64>,
    target: &ExposureTarget,
    noise: bool,
) -> Result<Measured, ExposureError> {
    let mut cfg = config.clone();
    cfg.optics.nd_density = s.nd;
    cfg.timing.exposure_s = s.exposure_s;
    if let (Some(p), Some(d)) = (cfg.photocathode.as_mut(), s.duty) {
        p.gate_duty = d;
    }
    let mut cam = Camera::new(cfg)?;
    cam.set_noise(noise);
    cam.set_override_gain(Some(s.gain))?;
    let f = cam.capture_detected(detected.view())?;
    let chain = cam.chain();
    let (black, sat, at) = (
        chain.black_dn(s.gain),
        chain.saturation_dn(s.gain),
        chain.saturated_threshold_dn(s.gain),
    );
    let mut v: Vec<f64> = f.pixels.iter().map(|&p| f64::from(p)).collect();
    let saturated = v.iter().filter(|&&p| p >= at).count() as f64 / v.len().max(1) as f64;
    let pc = percentile(&mut v, target.percentile);
    let median = percentile(&mut v, 50.0);
    let max_code = chain.max_code;
    // Lift the median to its goal above black (linearly), as the fit and
    // the frame records count it: which pixels would clip?
    let goal = MEDIAN_GOAL_OF_FULL_SCALE * max_code;
    let lift = if median - black >= goal || goal <= 0.0 {
        0.0
    } else {
        let k = goal / (median - black).max(0.5);
        let clip = (at - black) / k;
        v.iter().filter(|&&p| p - black >= clip).count() as f64 / v.len().max(1) as f64
    };
    Ok(Measured {
        percentile: pc,
        median,
        saturated_fraction: saturated,
        black,
        saturation: sat,
        max_code,
        median_goal_saturated_fraction: lift,
    })
}

impl ExposureTarget {
    /// The percentile within 0–100 and the fraction of range within (0, 1).
    fn check(&self) -> Result<(), ExposureError> {
        if !(self.percentile.is_finite() && (0.0..=100.0).contains(&self.percentile)) {
            return Err(ExposureError::Percentile(self.percentile));
        }
        if !(self.fraction_of_range > 0.0 && self.fraction_of_range < 1.0) {
            return Err(ExposureError::FractionOfRange(self.fraction_of_range));
        }
        Ok(())
    }
}

/// The chosen setting measured again with the camera's noise (its own
/// seed): at high gain the noise alone can push pixels past saturation,
/// as the frames will, so step down the ladder (not below `t_lo`) until at
/// most half the warning fraction saturates. Returns the setting, its
/// measurement (with the noisy saturated fraction) and whether it was
/// lowered.
fn lower_for_noise(
    config: &SensorConfig,
    detected: &Array2<f64>,
    target: &ExposureTarget,
    (ladder, t_lo): (&Ladder, f64),
    (mut setting, mut m): (Setting, Measured),
) -> Result<(Setting, Measured, bool), ExposureError> {
    let base_exposure = config.timing.exposure_s;
    let mut lowered = false;
    let mut t = ladder.t_of(&setting);
    for _ in 0..64 {
        let noisy = measure(config, setting, detected, target, true)?;
        if noisy.saturated_fraction <= 0.5 * gloam_sensor::levels::SATURATED_WARN_FRACTION
            || t <= t_lo
        {
            m.saturated_fraction = noisy.saturated_fraction;
            break;
        }
        t = (t - 0.1).max(t_lo);
        setting = ladder.at(t, base_exposure);
        m = measure(config, setting, detected, target, false)?;
        lowered = true;
    }
    Ok((setting, m, lowered))
}

/// Chooses the exposure for `detected` (e⁻ s⁻¹ m⁻² sr⁻¹, the render's
/// detected band) through the camera `config` (see the module docs).
pub fn choose(
    config: &SensorConfig,
    detected: &Array2<f64>,
    target: &ExposureTarget,
) -> Result<ExposureChoice, ExposureError> {
    target.check()?;
    let camera = Camera::new(config.clone())?;
    let ladder = Ladder::of(config, &camera);
    let base_exposure = config.timing.exposure_s;
    let goal = |black: f64, sat: f64| black + target.fraction_of_range * (sat - black);
    // The frame at ladder point t.
    let eval = |t: f64| -> Result<(Setting, Measured), ExposureError> {
        let s = ladder.at(t, base_exposure);
        Ok((s, measure(config, s, detected, target, false)?))
    };
    let (t_lo, t_hi) = (ladder.t_min(), 0.0);
    let (s_hi, m_hi) = eval(t_hi)?;
    let (s_lo, m_lo) = eval(t_lo)?;
    let signal = |m: &Measured| m.signal();
    let want = |m: &Measured| goal(m.black, m.saturation) - m.black;
    let (setting, m, stops, note) = if !detected.iter().any(|&v| v > 0.0) {
        // No light at all: the frame is the camera's own background, and
        // a stop count (0.9 for a black scene on gen3-gaas-iccd) would
        // measure that background, not the scene. Infinitely short of
        // light: `null` in report.json.
        (
            s_hi,
            m_hi,
            f64::INFINITY,
            format!(
                "the scene holds no light in this camera's band (its detected radiance is 0 at every pixel): nothing to expose for; the camera is left at its most sensitive setting (gain {:.4}, ungated, no ND), whose frame is its own background",
                s_hi.gain
            ),
        )
    } else if signal(&m_hi) < want(&m_hi) {
        // Too dim even at the most sensitive setting.
        let stops = (want(&m_hi) / signal(&m_hi).max(1e-9)).log2();
        (
            s_hi,
            m_hi,
            stops,
            format!(
                "the scene is {stops:.1} stops too dim for this camera at its most sensitive setting (gain {:.4}, ungated, no ND)",
                s_hi.gain
            ),
        )
    } else if signal(&m_lo) > want(&m_lo) {
        let stops = -(signal(&m_lo) / want(&m_lo).max(1e-9)).log2();
        (
            s_lo,
            m_lo,
            stops,
            format!(
                "the scene is {:.1} stops too bright for this camera at its least sensitive setting (gain {:.4}, ND {ND_MAX})",
                -stops, s_lo.gain
            ),
        )
    } else {
        // Bisection on t: the percentile rises with the throughput.
        let (mut a, mut b) = (t_lo, t_hi);
        let mut best = (s_hi, m_hi);
        for _ in 0..48 {
            let mid = 0.5 * (a + b);
            let (s, m) = eval(mid)?;
            if signal(&m) > want(&m) {
                b = mid;
            } else {
                a = mid;
                best = (s, m);
            }
            if b - a < 1e-3 {
                break;
            }
        }
        (best.0, best.1, 0.0, "target reached".to_string())
    };
    let (setting, m, lowered) =
        lower_for_noise(config, detected, target, (&ladder, t_lo), (setting, m))?;
    let note = if lowered {
        format!("{note}; then lowered until the frame with noise saturates < 0.5 % of its pixels")
    } else {
        note
    };
    let note = if m.median_goal_saturated_fraction > gloam_sensor::levels::SATURATED_WARN_FRACTION {
        format!(
            "{note}; the median is {:.1} % of full scale above black, and lifting it to {:.0} % would saturate {:.1} % of the pixels: the scene's highlights and a readable median do not fit in one frame of this camera",
            100.0 * (m.median - m.black) / m.max_code,
            100.0 * MEDIAN_GOAL_OF_FULL_SCALE,
            100.0 * m.median_goal_saturated_fraction
        )
    } else {
        note
    };
    Ok(ExposureChoice {
        target: *target,
        gain: setting.gain,
        gate_duty: setting.duty,
        exposure_s: setting.exposure_s,
        nd_density: setting.nd,
        percentile_dn: m.percentile,
        median_dn: m.median,
        saturated_fraction: m.saturated_fraction,
        black_dn: m.black,
        saturation_dn: m.saturation,
        median_of_full_scale: m.median / m.max_code,
        median_above_black_of_full_scale: (m.median - m.black) / m.max_code,
        median_goal_saturated_fraction: m.median_goal_saturated_fraction,
        stops_out_of_range: stops,
        note,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chosen percentile lands on its goal; and on the gated part of
    /// the ladder, where the tube is linear in the light (gain at its
    /// minimum, gate duty and ND scale photocathode current and EBI
    /// alike), a scene 16× brighter gets 1/16 of the throughput and the
    /// same frame.
    #[test]
    fn a_brighter_scene_gets_proportionally_less_exposure() {
        let config =
            gloam_sensor::load_preset_or_file("gen3-gaas-iccd", &gloam_io::ReadLog::off()).unwrap();
        let target = ExposureTarget::default();
        let ramp = Array2::from_shape_fn((32, 32), |(r, c)| {
            1e17 * (1.0 + (r * 32 + c) as f64 / 1024.0)
        });
        let a = choose(&config, &ramp, &target).unwrap();
        assert_eq!(a.stops_out_of_range, 0.0, "{}", a.note);
        let goal = a.black_dn + target.fraction_of_range * (a.saturation_dn - a.black_dn);
        assert!(
            (a.percentile_dn - goal).abs() <= 0.01 * (goal - a.black_dn) + 1.0,
            "{a:?}"
        );
        assert!(a.saturated_fraction < 0.01);
        let b = choose(&config, &ramp.mapv(|v| v * 16.0), &target).unwrap();
        let gain_min = Camera::new(config.clone()).unwrap().chain().gain_min;
        assert!(
            (a.gain / gain_min - 1.0).abs() < 1e-9 && a.gate_duty < Some(1.0),
            "not on the gated part of the ladder: {a:?}"
        );
        let through = |c: &ExposureChoice| c.gate_duty.unwrap() * 10f64.powf(-c.nd_density);
        let ratio = through(&a) / through(&b);
        assert!(
            (ratio / 16.0 - 1.0).abs() < 0.01,
            "throughput ratio {ratio}"
        );
        assert!((b.percentile_dn - a.percentile_dn).abs() <= 0.01 * (goal - a.black_dn) + 2.0);
    }

    /// A black scene holds no light: no stop count (the tube's equivalent
    /// background illumination alone lifts the frame, and round 12 of
    /// issue 46 found that called "0.9 stops too dim"). A scene with a
    /// little light is too dim by a finite count of stops.
    #[test]
    fn a_black_scene_holds_no_light_and_a_dim_one_is_too_dim() {
        let config =
            gloam_sensor::load_preset_or_file("gen3-gaas-iccd", &gloam_io::ReadLog::off()).unwrap();
        let dark = Array2::from_elem((16, 16), 0.0);
        let c = choose(&config, &dark, &ExposureTarget::default()).unwrap();
        assert!(c.stops_out_of_range.is_infinite(), "{c:?}");
        assert_eq!(c.gate_duty, Some(1.0));
        assert!(c.note.contains("holds no light"), "{}", c.note);
        let v = serde_json::to_value(&c).unwrap();
        assert!(v["stops_out_of_range"].is_null(), "{v}");
        let mut dim = dark;
        dim[[3, 3]] = 1e-3;
        let c = choose(&config, &dim, &ExposureTarget::default()).unwrap();
        assert!(
            c.stops_out_of_range.is_finite() && c.stops_out_of_range > 0.0,
            "{c:?}"
        );
        assert!(c.note.contains("too dim"), "{}", c.note);
    }
}
