//! Radiance calibration: per gain, a radiance staircase → `L = g·DC + b`
//! fitted over the linear range, saved as a look-up table across gains, and
//! applied to digital-count images.

use gloam_grabber::FrameGrabber;
use serde::{Deserialize, Serialize};

use crate::capture::{grab_frames, stack_stats};
use crate::error::CalibError;
use crate::source::CalibrationSource;
use crate::stats::weighted_linear_fit;

/// Settings of a radiance calibration run.
#[derive(Clone, Debug)]
pub struct RadianceOptions {
    /// Gains to calibrate (each set with AGC off).
    pub gains: Vec<f64>,
    /// Frames captured per level.
    pub frames: usize,
    /// Exposure to set, s (`None`: leave the grabber's).
    pub exposure_s: Option<f64>,
    /// A level counts as saturated when more than this fraction of its pixel
    /// samples sit at the digitizer maximum.
    pub clip_tolerance: f64,
    /// A level is past the knee when its step slope (ΔDN/ΔL) falls below
    /// this fraction of the mean slope from dark to the previous level.
    pub knee_slope_ratio: f64,
}

/// Frames averaged per level (the CLI's and Python's default).
pub const DEFAULT_FRAMES: usize = 8;

impl Default for RadianceOptions {
    fn default() -> Self {
        Self {
            gains: vec![1.0],
            frames: DEFAULT_FRAMES,
            exposure_s: None,
            clip_tolerance: 1e-3,
            knee_slope_ratio: 0.9,
        }
    }
}

/// One measured level.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LevelPoint {
    pub label: String,
    pub band_radiance_w_m2_sr: f64,
    pub mean_dn: f64,
    pub temporal_std_dn: f64,
    pub clipped_fraction: f64,
    /// Used in the fit (inside the linear range).
    pub in_fit: bool,
    /// `L_measured − (g·DC + b)`, W m⁻² sr⁻¹ (fitted points only).
    pub residual_w_m2_sr: Option<f64>,
}

/// The calibration of one gain: `L = g·DC + b`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GainCalibration {
    /// Gain actually applied, as the grabber reported it.
    pub gain: f64,
    pub g_w_m2_sr_per_dn: f64,
    pub b_w_m2_sr: f64,
    pub r_squared: f64,
    /// Lowest and highest mean DC in the fit.
    pub fit_range_dn: [f64; 2],
    pub dark_dn: f64,
    pub dark_std_dn: f64,
    /// Mean DC of the first saturated level, if one was reached.
    pub saturation_dn: Option<f64>,
    pub n_fit_points: usize,
    pub max_abs_residual_percent: f64,
    pub levels: Vec<LevelPoint>,
    /// Anything the operator should know (e.g. "only 2 points").
    pub warnings: Vec<String>,
}

/// A radiance look-up table across gains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lut {
    pub grabber: String,
    pub source: String,
    pub band_nm: [f64; 2],
    pub digitizer_max_dn: f64,
    pub gains: Vec<GainCalibration>,
}

/// Runs the radiance calibration. `progress(done, total)` is called after
/// every captured level.
pub fn calibrate_radiance(
    grabber: &mut dyn FrameGrabber,
    source: &mut dyn CalibrationSource,
    opts: &RadianceOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Lut, CalibError> {
    if opts.gains.is_empty() {
        return Err(CalibError::Invalid("no gains given".into()));
    }
    if opts.frames == 0 {
        return Err(CalibError::Invalid("frames per level must be ≥ 1".into()));
    }
    let n_levels = source.levels();
    if n_levels == 0 {
        return Err(CalibError::InsufficientData(
            "the source has no illuminated levels: a dark-only capture cannot calibrate radiance"
                .into(),
        ));
    }
    crate::capture::agc_off(grabber)?;
    if let Some(t) = opts.exposure_s {
        grabber.set_exposure_s(t)?;
    }
    let total = opts.gains.len() * (n_levels + 1);
    let mut done = 0;
    let mut out = Vec::new();
    let mut max_dn = 0.0;
    for &g_req in &opts.gains {
        let gain = grabber.set_gain(g_req)?;
        let dark = source.set_dark()?;
        grabber.present(&dark.stimulus)?;
        let ds = stack_stats(&grab_frames(grabber, opts.frames)?)?;
        max_dn = ds.max_dn;
        done += 1;
        progress(done, total);
        let mut pts = Vec::new();
        for i in 0..n_levels {
            let lv = source.set_level(i)?;
            grabber.present(&lv.stimulus)?;
            let st = stack_stats(&grab_frames(grabber, opts.frames)?)?;
            pts.push(LevelPoint {
                label: lv.label,
                band_radiance_w_m2_sr: lv.band_radiance_w_m2_sr,
                mean_dn: st.mean_dn,
                temporal_std_dn: st.temporal_std_dn,
                clipped_fraction: st.clipped_fraction,
                in_fit: false,
                residual_w_m2_sr: None,
            });
            done += 1;
            progress(done, total);
        }
        out.push(fit_gain(
            gain,
            ds.mean_dn,
            ds.temporal_std_dn,
            pts,
            opts,
            opts.frames,
            ds.mean_image.len(),
        )?);
    }
    let band = source.camera().band_nm;
    Ok(Lut {
        grabber: grabber.describe(),
        source: source.describe(),
        band_nm: [band.0, band.1],
        digitizer_max_dn: max_dn,
        gains: out,
    })
}

/// Chooses the linear range of one gain's staircase and fits it.
///
/// The dark point (L = 0) is always in the fit. Walking up the staircase,
/// the linear range ends at the first level that is clipped (more than
/// `clip_tolerance` of samples at the digitizer max), no longer rises, has
/// a step slope below `knee_slope_ratio` of the mean slope so far, or whose
/// temporal variance collapses (full-well saturation below the digitizer
/// max); that level's DC is reported as `saturation_dn`.
pub fn fit_gain(
    gain: f64,
    dark_dn: f64,
    dark_std_dn: f64,
    mut pts: Vec<LevelPoint>,
    opts: &RadianceOptions,
    frames: usize,
    pixels: usize,
) -> Result<GainCalibration, CalibError> {
    let mut warnings = Vec::new();
    // Sort by radiance so "from the top" is meaningful.
    pts.sort_by(|a, b| a.band_radiance_w_m2_sr.total_cmp(&b.band_radiance_w_m2_sr));
    let Knee {
        saturation_dn,
        last_ok,
        flat_after,
    } = knee(&pts, dark_dn, dark_std_dn, opts, frames * pixels);
    let n_ok = last_ok.map_or(0, |i| i + 1);
    // Levels with zero radiance add nothing beyond the dark point.
    let lit: Vec<usize> = (0..n_ok)
        .filter(|&i| pts[i].band_radiance_w_m2_sr > 0.0)
        .collect();
    if lit.is_empty() {
        return Err(CalibError::InsufficientData(format!(
            "gain {gain}: no illuminated level below saturation (the first level already saturates{}); lower the radiance or the gain",
            saturation_dn.map_or(String::new(), |d| format!(" at {d:.1} DN"))
        )));
    }
    if lit.len() == 1 && flat_after {
        return Err(CalibError::InsufficientData(format!(
            "gain {gain}: the output stops rising after the first illuminated level, so that level may already be saturated and no linear range can be established; lower the radiance or the gain"
        )));
    }
    if lit.len() < 2 {
        warnings.push(format!(
            "only {} illuminated level in the linear range: the line is fixed by it and the dark point, so R² says nothing",
            lit.len()
        ));
    }
    if saturation_dn.is_some_and(|_| n_ok < pts.len() / 2) {
        warnings.push(format!(
            "the sweep saturates early: only {n_ok} of {} levels are linear",
            pts.len()
        ));
    }
    // Fit L = g·DC + b with weights 1/σ²(DC mean) (in DC; the line is
    // regressed on DC, so the weights follow the DC noise of each point).
    let mut x = vec![dark_dn];
    let mut y = vec![0.0];
    let sem = |s: f64| (s * s / (frames * pixels).max(1) as f64).max(1e-12);
    let mut w = vec![1.0 / sem(dark_std_dn)];
    for &i in &lit {
        x.push(pts[i].mean_dn);
        y.push(pts[i].band_radiance_w_m2_sr);
        w.push(1.0 / sem(pts[i].temporal_std_dn));
    }
    // Normalise weights for conditioning.
    let wmax = w.iter().cloned().fold(0.0, f64::max);
    w.iter_mut().for_each(|v| *v /= wmax);
    let fit = weighted_linear_fit(&x, &y, &w).map_err(|e| match e {
        CalibError::SingularFit(m) => CalibError::SingularFit(format!(
            "gain {gain}: {m} (the camera's output does not change with radiance)"
        )),
        e => e,
    })?;
    if !(fit.slope > 0.0) {
        return Err(CalibError::SingularFit(format!(
            "gain {gain}: the fitted g = {} W m⁻² sr⁻¹/DN is not positive (output falls with radiance)",
            fit.slope
        )));
    }
    let top = x.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let lmax = y.iter().cloned().fold(0.0, f64::max);
    let mut max_res = 0.0f64;
    for (k, &i) in lit.iter().enumerate() {
        let r = fit.residuals[k + 1];
        pts[i].in_fit = true;
        pts[i].residual_w_m2_sr = Some(r);
        max_res = max_res.max((r / lmax).abs() * 100.0);
    }
    Ok(GainCalibration {
        gain,
        g_w_m2_sr_per_dn: fit.slope,
        b_w_m2_sr: fit.intercept,
        r_squared: fit.r_squared,
        fit_range_dn: [dark_dn, top],
        dark_dn,
        dark_std_dn,
        saturation_dn,
        n_fit_points: x.len(),
        max_abs_residual_percent: max_res,
        levels: pts,
        warnings,
    })
}

/// Where the linear range of a sweep (sorted by radiance) ends.
struct Knee {
    /// The mean output of the first level past the linear range.
    saturation_dn: Option<f64>,
    /// The last illuminated level in the linear range.
    last_ok: Option<usize>,
    /// The output stopped rising (rather than clipping or bending).
    flat_after: bool,
}

/// Walks the levels up from dark until one clips, stops rising above the
/// noise of `samples` averaged values, or bends at the knee.
fn knee(
    pts: &[LevelPoint],
    dark_dn: f64,
    dark_std_dn: f64,
    opts: &RadianceOptions,
    samples: usize,
) -> Knee {
    let mut saturation_dn = None;
    let mut last_ok = None;
    let mut prev_dn = dark_dn;
    let noise_floor = 3.0 * dark_std_dn / (samples.max(1) as f64).sqrt();
    let mut prev_l = 0.0;
    let mut flat_after = false;
    let mut prev_var = dark_std_dn * dark_std_dn;
    for (i, p) in pts.iter().enumerate() {
        let clipped = p.clipped_fraction > opts.clip_tolerance;
        let not_rising =
            p.band_radiance_w_m2_sr > 0.0 && i > 0 && p.mean_dn <= prev_dn + noise_floor;
        // The knee: the step's slope falls below `knee_slope_ratio` of the
        // average slope from dark to the previous good level, or the
        // temporal variance collapses (full well reached below the
        // digitizer maximum).
        let knee = last_ok.is_some() && {
            let avg = (prev_dn - dark_dn) / prev_l;
            let step = (p.mean_dn - prev_dn) / (p.band_radiance_w_m2_sr - prev_l);
            let var = p.temporal_std_dn * p.temporal_std_dn;
            (p.band_radiance_w_m2_sr > prev_l && avg > 0.0 && step < opts.knee_slope_ratio * avg)
                || (prev_var > 0.0 && var < 0.5 * prev_var)
        };
        if clipped || knee || (not_rising && last_ok.is_some()) {
            saturation_dn = Some(p.mean_dn);
            flat_after = not_rising;
            break;
        }
        if p.band_radiance_w_m2_sr > 0.0 {
            last_ok = Some(i);
            prev_dn = p.mean_dn;
            prev_l = p.band_radiance_w_m2_sr;
            prev_var = p.temporal_std_dn * p.temporal_std_dn;
        }
    }
    Knee {
        saturation_dn,
        last_ok,
        flat_after,
    }
}

/// Largest band radiance a LUT may give a count, W m⁻² sr⁻¹ (the scene's
/// emission limit): a slope or offset beyond it is not a camera's.
pub const MAX_LUT_RADIANCE_W_M2_SR: f64 = 1e20;
/// Two gains within this relative difference are one setting: a camera
/// sets gains in thousandths, so the AGC's floor of 14.5519 (Gen III's MCP
/// at 500 V) is the setting 14.552 a LUT is measured at.
pub const GAIN_MATCH_TOLERANCE: f64 = 1e-4;
/// How far (relative) a LUT's responsivity `1/g` may fall from one gain to
/// the next higher one before the LUT counts as reversed: a camera's
/// counts per radiance rise with its gain; fit noise between two close
/// gains is far below this.
pub const RESPONSIVITY_FALL_TOLERANCE: f64 = 0.01;

/// What is wrong with a LUT: the JSON key (of `gains[index]`, or of the
/// LUT itself) and why.
#[derive(Clone, Debug, PartialEq)]
pub struct LutProblem {
    pub gain_index: Option<usize>,
    pub key: &'static str,
    pub message: String,
}

impl LutProblem {
    /// The 1-based line of `text` (the LUT's JSON) holding the key: its
    /// `gain_index + 1`-th occurrence (each `gains` entry has each key
    /// once), else line 1.
    pub fn line_in(&self, text: &str) -> usize {
        let needle = format!("\"{}\"", self.key);
        let nth = self.gain_index.unwrap_or(0);
        text.match_indices(&needle)
            .nth(nth)
            .map_or(1, |(at, _)| text[..at].matches('\n').count() + 1)
    }
}

impl std::fmt::Display for LutProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.gain_index {
            Some(i) => write!(f, "gains[{i}].{}: {}", self.key, self.message),
            None => write!(f, "{}: {}", self.key, self.message),
        }
    }
}

/// One gain's entry: a positive gain; slope, offset and fit range within
/// the LUT's limits; dark level, noise and saturation as counts.
fn check_entry(c: &GainCalibration, i: usize, top: f64) -> Result<(), LutProblem> {
    let bad = |i: Option<usize>, key: &'static str, message: String| {
        Err(LutProblem {
            gain_index: i,
            key,
            message,
        })
    };
    let max = MAX_LUT_RADIANCE_W_M2_SR;
    let at = Some(i);
    if !(c.gain > 0.0 && c.gain.is_finite()) {
        return bad(at, "gain", format!("{} is not a positive gain", c.gain));
    }
    let g = c.g_w_m2_sr_per_dn;
    if !(g > 0.0) {
        return bad(
            at,
            "g_w_m2_sr_per_dn",
            format!(
                "slope {g} W m⁻² sr⁻¹/DN at gain {} is not positive: radiance must rise with the counts",
                c.gain
            ),
        );
    }
    // A subnormal slope is positive, but its counts per radiance (1/g)
    // overflow: the reversed-LUT check then blamed the next gain's entry.
    if !(1.0 / g).is_finite() {
        return bad(
            at,
            "g_w_m2_sr_per_dn",
            format!(
                "slope {g:e} W m⁻² sr⁻¹/DN at gain {} is too small: its counts per radiance (1/g) overflow",
                c.gain
            ),
        );
    }
    if !(g * top <= max) {
        return bad(
            at,
            "g_w_m2_sr_per_dn",
            format!(
                "slope {g:e} W m⁻² sr⁻¹/DN at gain {} gives {:e} W m⁻² sr⁻¹ at the top code {top} DN, above {max:e}",
                c.gain,
                g * top
            ),
        );
    }
    if !(c.b_w_m2_sr.abs() <= max) {
        return bad(
            at,
            "b_w_m2_sr",
            format!(
                "offset {:e} W m⁻² sr⁻¹ at gain {} is not finite within ±{max:e}",
                c.b_w_m2_sr, c.gain
            ),
        );
    }
    let [lo, hi] = c.fit_range_dn;
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return bad(
            at,
            "fit_range_dn",
            format!(
                "[{lo}, {hi}] at gain {} is not a range of positive width (dark to top of the fit, rising)",
                c.gain
            ),
        );
    }
    if !(c.dark_dn.is_finite() && (0.0..=top).contains(&c.dark_dn)) {
        return bad(
            at,
            "dark_dn",
            format!(
                "dark level {} DN at gain {} is not a count in 0..={top}",
                c.dark_dn, c.gain
            ),
        );
    }
    if !(c.dark_std_dn.is_finite() && c.dark_std_dn >= 0.0) {
        return bad(
            at,
            "dark_std_dn",
            format!(
                "dark noise {} DN at gain {} is not a standard deviation (finite, ≥ 0)",
                c.dark_std_dn, c.gain
            ),
        );
    }
    // Counts at or above it become NaN: one at or below the dark
    // level would blank every pixel, one past the top code none.
    if let Some(s) = c.saturation_dn
        && !(s.is_finite() && s > c.dark_dn && s <= top)
    {
        return bad(
            at,
            "saturation_dn",
            format!(
                "{s} DN at gain {} is not a saturation level between the dark level {} DN and the top code {top} DN",
                c.gain, c.dark_dn
            ),
        );
    }
    Ok(())
}

impl Lut {
    /// Checks the LUT against physics before it converts a count: a top
    /// code that is a 16-bit count, at least one gain, each gain positive,
    /// its slope `g` positive and its line within
    /// [`MAX_LUT_RADIANCE_W_M2_SR`] up to the top code, its fit range of
    /// positive width, no gain twice, and counts per radiance (`1/g`) that
    /// do not fall as the gain rises (a reversed LUT).
    pub fn check(&self) -> Result<(), LutProblem> {
        let bad = |i: Option<usize>, key: &'static str, message: String| {
            Err(LutProblem {
                gain_index: i,
                key,
                message,
            })
        };
        let top = self.digitizer_max_dn;
        if !((1.0..=65_535.0).contains(&top) && top.fract() == 0.0) {
            return bad(
                None,
                "digitizer_max_dn",
                format!("{top} is not a digitizer's top code (a whole count in 1..=65535)"),
            );
        }
        if self.gains.is_empty() {
            return bad(None, "gains", "no calibrated gain".into());
        }
        for (i, c) in self.gains.iter().enumerate() {
            check_entry(c, i, top)?;
        }
        self.check_order()
    }

    /// No gain twice, and the responsivity never falls as the gain rises.
    fn check_order(&self) -> Result<(), LutProblem> {
        let bad = |i: Option<usize>, key: &'static str, message: String| {
            Err(LutProblem {
                gain_index: i,
                key,
                message,
            })
        };
        let mut order: Vec<usize> = (0..self.gains.len()).collect();
        order.sort_by(|&a, &b| self.gains[a].gain.total_cmp(&self.gains[b].gain));
        for w in order.windows(2) {
            let (a, b) = (&self.gains[w[0]], &self.gains[w[1]]);
            if (b.gain - a.gain).abs() <= GAIN_MATCH_TOLERANCE * a.gain {
                // Named at the later entry in the file.
                let (first, again) = (w[0].min(w[1]), w[0].max(w[1]));
                return bad(
                    Some(again),
                    "gain",
                    format!(
                        "gain {} repeats gains[{first}] (gain {}): one setting, two lines",
                        self.gains[again].gain, self.gains[first].gain
                    ),
                );
            }
            // Responsivity 1/g must not fall as the gain rises.
            let (ra, rb) = (1.0 / a.g_w_m2_sr_per_dn, 1.0 / b.g_w_m2_sr_per_dn);
            if rb < ra * (1.0 - RESPONSIVITY_FALL_TOLERANCE) {
                return bad(
                    Some(w[1]),
                    "g_w_m2_sr_per_dn",
                    format!(
                        "at gain {} the counts per radiance (1/g = {rb:.6e} DN per W m⁻² sr⁻¹) fall below gains[{}]'s at the lower gain {} ({ra:.6e}): the LUT is reversed or its entries mixed up",
                        b.gain, w[0], a.gain
                    ),
                );
            }
        }
        Ok(())
    }

    /// Slope and offset for `gain`: exact at a calibrated gain; between two
    /// calibrated gains the responsivity `1/g` (DN per radiance) and the
    /// dark level `−b/g` are interpolated linearly in gain (they are what a
    /// camera's gain changes linearly). Outside the calibrated range → error.
    pub fn coefficients(&self, gain: f64) -> Result<(f64, f64), CalibError> {
        let mut g: Vec<&GainCalibration> = self.gains.iter().collect();
        g.sort_by(|a, b| a.gain.total_cmp(&b.gain));
        let tol = |a: f64| GAIN_MATCH_TOLERANCE * a.abs().max(1e-12);
        if let Some(c) = g.iter().find(|c| (c.gain - gain).abs() <= tol(c.gain)) {
            return Ok((c.g_w_m2_sr_per_dn, c.b_w_m2_sr));
        }
        let hi = g.iter().position(|c| c.gain > gain);
        match hi {
            Some(j) if j > 0 => {
                let (a, b) = (g[j - 1], g[j]);
                let t = (gain - a.gain) / (b.gain - a.gain);
                let ra = 1.0 / a.g_w_m2_sr_per_dn;
                let rb = 1.0 / b.g_w_m2_sr_per_dn;
                let da = -a.b_w_m2_sr / a.g_w_m2_sr_per_dn;
                let db = -b.b_w_m2_sr / b.g_w_m2_sr_per_dn;
                let r = ra + t * (rb - ra);
                let d = da + t * (db - da);
                Ok((1.0 / r, -d / r))
            }
            _ => Err(CalibError::Invalid(format!(
                "gain {} lies outside the calibrated gains {:?}; calibrate it or pass a calibrated gain",
                gloam_spectra::num(gain),
                g.iter().map(|c| c.gain).collect::<Vec<_>>()
            ))),
        }
    }

    /// Converts digital counts to band radiance (W m⁻² sr⁻¹) with the LUT
    /// for `gain`. Pixels at or above the saturation level of the nearest
    /// calibrated gain (or the digitizer maximum) become NaN: their radiance
    /// is unknown.
    pub fn apply(&self, gain: f64, pixels: &[u16]) -> Result<Vec<f32>, CalibError> {
        self.check()
            .map_err(|p| CalibError::Invalid(format!("LUT {p}")))?;
        let (g, b) = self.coefficients(gain)?;
        let nearest = self
            .gains
            .iter()
            .min_by(|a, c| (a.gain - gain).abs().total_cmp(&(c.gain - gain).abs()));
        let sat = nearest
            .and_then(|c| c.saturation_dn)
            .unwrap_or(f64::INFINITY)
            .min(if self.digitizer_max_dn > 0.0 {
                self.digitizer_max_dn
            } else {
                f64::INFINITY
            });
        Ok(pixels
            .iter()
            .map(|&p| {
                let v = p as f64;
                if v >= sat {
                    f32::NAN
                } else {
                    (g * v + b) as f32
                }
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gain(gain: f64, g: f64) -> GainCalibration {
        GainCalibration {
            gain,
            g_w_m2_sr_per_dn: g,
            b_w_m2_sr: -1e-5,
            r_squared: 1.0,
            fit_range_dn: [500.0, 40_000.0],
            dark_dn: 500.0,
            dark_std_dn: 3.0,
            saturation_dn: Some(60_000.0),
            n_fit_points: 6,
            max_abs_residual_percent: 0.1,
            levels: Vec::new(),
            warnings: Vec::new(),
        }
    }

    fn lut() -> Lut {
        Lut {
            grabber: "simulated scientific-ccd".into(),
            source: "sphere".into(),
            band_nm: [400.0, 900.0],
            digitizer_max_dn: 65_535.0,
            gains: vec![gain(1.0, 2.5e-8), gain(2.0, 1.25e-8)],
        }
    }

    fn problem(l: &Lut) -> String {
        l.check().unwrap_err().to_string()
    }

    #[test]
    fn a_lut_outside_physics_is_refused_naming_the_key() {
        assert_eq!(lut().check(), Ok(()));
        let mut l = lut();
        l.gains[1].g_w_m2_sr_per_dn = -1.25e-8;
        assert_eq!(
            problem(&l),
            "gains[1].g_w_m2_sr_per_dn: slope -0.0000000125 W m⁻² sr⁻¹/DN at gain 2 is not positive: radiance must rise with the counts"
        );
        l.gains[1].g_w_m2_sr_per_dn = 0.0;
        assert!(problem(&l).contains("slope 0 W"), "{}", problem(&l));
        l.gains[1].g_w_m2_sr_per_dn = 1e308;
        assert!(
            problem(&l).starts_with(
                "gains[1].g_w_m2_sr_per_dn: slope 1e308 W m⁻² sr⁻¹/DN at gain 2 gives inf"
            ),
            "{}",
            problem(&l)
        );
        l.gains[1].g_w_m2_sr_per_dn = f64::NAN;
        assert!(problem(&l).contains("slope NaN"), "{}", problem(&l));
        // Up to the limit is accepted: 1e20 W m⁻² sr⁻¹ at the top code.
        l.gains[1].g_w_m2_sr_per_dn = 1e20 / 65_535.0;
        l.gains[0].g_w_m2_sr_per_dn = 1e20 / 65_535.0;
        assert_eq!(l.check(), Ok(()));
        let mut l = lut();
        l.gains[0].b_w_m2_sr = -1e300;
        assert!(problem(&l).starts_with("gains[0].b_w_m2_sr: offset"));
        let mut l = lut();
        l.gains[0].fit_range_dn = [500.0, 500.0];
        assert!(
            problem(&l).starts_with(
                "gains[0].fit_range_dn: [500, 500] at gain 1 is not a range of positive width"
            ),
            "{}",
            problem(&l)
        );
        l.gains[0].g_w_m2_sr_per_dn = 5e-324;
        assert!(
            problem(&l).starts_with(
                "gains[0].g_w_m2_sr_per_dn: slope 5e-324 W m⁻² sr⁻¹/DN at gain 1 is too small"
            ),
            "{}",
            problem(&l)
        );
        l.gains[0].g_w_m2_sr_per_dn = 2.5e-8;
        l.gains[0].fit_range_dn = [40_000.0, 500.0];
        assert!(problem(&l).starts_with("gains[0].fit_range_dn: [40000, 500]"));
        for top in [0.0, -1.0, 4095.5, 65_536.0, f64::INFINITY] {
            let mut l = lut();
            l.digitizer_max_dn = top;
            assert!(
                problem(&l).starts_with(&format!("digitizer_max_dn: {top} is not")),
                "{}",
                problem(&l)
            );
        }
        let mut l = lut();
        l.gains.clear();
        assert_eq!(problem(&l), "gains: no calibrated gain");
        let mut l = lut();
        l.gains[0].gain = 0.0;
        assert!(problem(&l).starts_with("gains[0].gain: 0 is not a positive gain"));
        // Apply refuses it too, not only loading.
        assert!(l.apply(1.0, &[1]).is_err());
    }

    #[test]
    fn a_reversed_or_repeated_lut_is_refused() {
        // Counts per radiance falling as the gain rises: reversed.
        let mut l = lut();
        l.gains.swap(0, 1);
        l.gains[0].gain = 1.0;
        l.gains[1].gain = 2.0;
        let p = problem(&l);
        assert!(
            p.starts_with("gains[1].g_w_m2_sr_per_dn: at gain 2 the counts per radiance"),
            "{p}"
        );
        assert!(p.contains("reversed"), "{p}");
        // Within 1 % (fit noise between close gains) is accepted.
        let mut l = lut();
        l.gains[1].g_w_m2_sr_per_dn = 2.5e-8 * 1.009;
        assert_eq!(l.check(), Ok(()));
        l.gains[1].g_w_m2_sr_per_dn = 2.5e-8 * 1.011;
        assert!(problem(&l).contains("reversed"));
        // One setting twice: the AGC's floor and the setting it is.
        let mut l = lut();
        l.gains[0].gain = 14.552;
        l.gains[1].gain = 1000.0 * 0.625f64.powi(9);
        assert!(
            problem(&l).starts_with(
                "gains[1].gain: gain 14.551915228366852 repeats gains[0] (gain 14.552)"
            ),
            "{}",
            problem(&l)
        );
    }

    #[test]
    fn a_problem_names_the_line_of_its_key() {
        let text = serde_json::to_string_pretty(&lut()).unwrap();
        let mut l = lut();
        l.gains[1].g_w_m2_sr_per_dn = -1.0;
        let p = l.check().unwrap_err();
        let line = p.line_in(&text);
        let at = text.lines().nth(line - 1).unwrap();
        assert!(at.contains("\"g_w_m2_sr_per_dn\": 1.25e-8"), "{line}: {at}");
        let p = LutProblem {
            gain_index: None,
            key: "digitizer_max_dn",
            message: String::new(),
        };
        assert!(
            text.lines()
                .nth(p.line_in(&text) - 1)
                .unwrap()
                .contains("65535")
        );
    }
}
