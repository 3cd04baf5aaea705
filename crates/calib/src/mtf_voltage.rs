//! MTF in voltage space, the laboratory way (the seed's §5.9.2): an
//! oscilloscope isolates one video scan line while the camera views the
//! charts.
//!
//! 1. Grey-scale patches of known relative reflectance give the mean
//!    active-line voltage of each — the voltage → reflectance curve
//!    (piecewise linear, so the camera need not be linear).
//! 2. For each sine-wave pattern, V_max and V_min of the line are read
//!    (here: mean ± amplitude of the least-squares fundamental at the
//!    pattern's line frequency ν = f / T_pix, averaged over the scoped
//!    lines and frames — what the scope's cursors read off an averaged,
//!    smooth trace), turned into R_max and R_min through the curve, and
//!    `M = (R_max − R_min)/(R_max + R_min)`; `MTF = M / M_chart`.
//! 3. Frequencies go from the image plane (cycles/pixel at the
//!    photocathode's pixel pitch) to the object plane with the optical
//!    magnification m = image size / object size: `f_obj = m · f_img`.
//!
//! The scope needs the analogue line, so this flow drives a simulated
//! camera ([`gloam_sensor::Camera`]) directly; the digital-count half of
//! the comparison runs the ordinary [`crate::mtf::sine_mtf`] through a
//! grabber on the same camera.

use gloam_grabber::Stimulus;
use gloam_sensor::Camera;
use gloam_sensor::scope::{fundamental, scope_lines};
use gloam_simcam::render_stimulus;
use serde::Serialize;

use crate::error::CalibError;
use crate::mtf::{GREY_STEPS, MtfCurve};

/// Settings of the voltage-space measurement.
#[derive(Clone, Debug)]
pub struct VoltageOptions {
    pub frequencies_cy_per_px: Vec<f64>,
    pub mean_radiance_w_m2_sr: f64,
    pub modulation: f64,
    pub spectrum: String,
    pub frames: usize,
    /// Frame rows whose lines the scope isolates.
    pub rows: Vec<usize>,
    /// Optical magnification, image size / object size.
    pub magnification: f64,
    /// Frame size (width, height).
    pub size: (u32, u32),
}

/// One sine pattern as read off the scope.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VoltagePoint {
    pub cycles_per_pixel: f64,
    /// At the photocathode (the objective's image plane), line pairs/mm.
    pub image_lp_per_mm: f64,
    /// On the chart: image frequency × magnification.
    pub object_lp_per_mm: f64,
    /// On the video line, MHz.
    pub line_frequency_mhz: f64,
    pub v_max: f64,
    pub v_min: f64,
    pub reflectance_max: f64,
    pub reflectance_min: f64,
    pub mtf: f64,
}

/// The voltage-space result: the curve, its points and the grey scale.
#[derive(Clone, Debug, Serialize)]
pub struct VoltageMtf {
    pub curve: MtfCurve,
    pub points: Vec<VoltagePoint>,
    /// `(relative reflectance, mean active-line volts)` per grey patch.
    pub grey_scale: Vec<(f64, f64)>,
    pub pixel_clock_hz: f64,
}

/// Mean active-line volts of the scoped rows (the first and last 2 % of
/// the active line, where the amplifier settles from blanking, left out).
fn mean_line_volts(cam: &Camera, rows: usize) -> Result<f64, CalibError> {
    let lines = scope_lines(cam, rows).map_err(|e| CalibError::Invalid(e.to_string()))?;
    let (mut s, mut n) = (0.0f64, 0usize);
    for l in &lines {
        let t = &l.timing;
        let (lo, hi) = (
            t.active_start_s() + 0.02 * t.active_s(),
            t.active_start_s() + 0.98 * t.active_s(),
        );
        for (&ts, &v) in l.time_s.iter().zip(&l.volts) {
            if ts >= lo && ts < hi {
                s += v;
                n += 1;
            }
        }
    }
    if n == 0 {
        return Err(CalibError::InsufficientData(
            "no active video on the scoped lines".into(),
        ));
    }
    Ok(s / n as f64)
}

/// Reflectance for a voltage on the grey-scale curve (piecewise linear,
/// extrapolated from the end segments).
fn reflectance(grey: &[(f64, f64)], v: f64) -> f64 {
    let n = grey.len();
    let j = grey.partition_point(|g| g.1 < v).clamp(1, n - 1);
    let (r0, v0) = grey[j - 1];
    let (r1, v1) = grey[j];
    r0 + (v - v0) / (v1 - v0) * (r1 - r0)
}

/// Runs the §5.9.2 procedure on `cam` (AGC off, gain as set by the caller).
pub fn voltage_sine_mtf(
    cam: &mut Camera,
    opts: &VoltageOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<VoltageMtf, CalibError> {
    check_options(opts)?;
    let (w, h) = opts.size;
    let rows = h as usize;
    let timing = cam.chain().line_timing().ok_or_else(|| {
        CalibError::Invalid(format!(
            "sensor '{}' has a direct digital readout: no video line to put a scope on",
            cam.config().name
        ))
    })?;
    let tp = timing.pixel_period_s(w as usize);
    let frames = opts.frames.max(1);
    cam.set_scope_rows(opts.rows.clone());
    let total = GREY_STEPS.len() + opts.frequencies_cy_per_px.len();

    let grey = grey_scale(cam, opts, &mut |i| progress(i, total))?;

    // 2. Sine patterns: V_max, V_min of the fundamental on the line.
    let pitch_mm = cam.chain().pitch_cathode_mm;
    let mut points = Vec::new();
    for (i, &f) in opts.frequencies_cy_per_px.iter().enumerate() {
        if !(f > 0.0 && f < 0.5) {
            return Err(CalibError::Invalid(format!(
                "sine frequency {f} cy/px must lie in (0, 0.5)"
            )));
        }
        let s = Stimulus::Sine {
            mean_radiance_w_m2_sr: opts.mean_radiance_w_m2_sr,
            modulation: opts.modulation,
            cycles_per_pixel: f,
            angle_deg: 0.0,
            spectrum: opts.spectrum.clone(),
        };
        let nu = f / tp;
        let (mut mean, mut amp, mut n) = (0.0, 0.0, 0usize);
        for _ in 0..frames {
            capture(cam, &s, w, h)?;
            for l in scope_lines(cam, rows).map_err(|e| CalibError::Invalid(e.to_string()))? {
                let (m, a) = fundamental(&l, nu).ok_or_else(|| {
                    CalibError::SingularFit(format!("sine at {f} cy/px on row {}", l.row))
                })?;
                mean += m;
                amp += a;
                n += 1;
            }
        }
        let (mean, amp) = (mean / n as f64, amp / n as f64);
        let (v_max, v_min) = (mean + amp, mean - amp);
        let (r_max, r_min) = (reflectance(&grey, v_max), reflectance(&grey, v_min));
        let m = (r_max - r_min) / (r_max + r_min);
        let img = f / pitch_mm;
        points.push(VoltagePoint {
            cycles_per_pixel: f,
            image_lp_per_mm: img,
            object_lp_per_mm: img * opts.magnification,
            line_frequency_mhz: nu / 1e6,
            v_max,
            v_min,
            reflectance_max: r_max,
            reflectance_min: r_min,
            mtf: crate::mtf::held_to_physics(f, m / opts.modulation)?,
        });
        progress(GREY_STEPS.len() + i + 1, total);
    }
    cam.set_scope_rows(Vec::new());
    let curve = MtfCurve::new(
        "voltage (scope, grey-scale curve)",
        points.iter().map(|p| p.cycles_per_pixel).collect(),
        points.iter().map(|p| p.mtf).collect(),
    );
    Ok(VoltageMtf {
        curve,
        points,
        grey_scale: grey,
        pixel_clock_hz: 1.0 / tp,
    })
}

/// The options a run needs: a modulation the sine can carry, a positive
/// magnification, and scope rows inside the frame.
fn check_options(opts: &VoltageOptions) -> Result<(), CalibError> {
    if !(opts.modulation > 0.0 && opts.modulation <= 0.9) {
        return Err(CalibError::Invalid(
            "modulation must lie in (0, 0.9]".into(),
        ));
    }
    if !(opts.magnification.is_finite() && opts.magnification > 0.0) {
        return Err(CalibError::Invalid(format!(
            "magnification {} must be a positive number",
            opts.magnification
        )));
    }
    let rows = opts.size.1 as usize;
    if let Some(r) = opts.rows.iter().find(|&&r| r >= rows) {
        return Err(CalibError::Invalid(format!(
            "scope row {r} is outside the {rows}-row frame"
        )));
    }
    if opts.rows.is_empty() {
        return Err(CalibError::Invalid("no rows to scope".into()));
    }
    Ok(())
}

/// Renders `s` at `w` × `h` and captures one frame of it.
fn capture(cam: &mut Camera, s: &Stimulus, w: u32, h: u32) -> Result<(), CalibError> {
    let (img, shape) = render_stimulus(s, w, h)?;
    cam.capture_mono(img.view(), &shape)
        .map_err(|e| CalibError::Invalid(format!("capture: {e}")))?;
    Ok(())
}

/// The grey scale: the line's mean voltage at each grey patch against its
/// relative reflectance, which must rise patch by patch (the sine's
/// voltages are read back through it).
fn grey_scale(
    cam: &mut Camera,
    opts: &VoltageOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<Vec<(f64, f64)>, CalibError> {
    let (w, h) = opts.size;
    let rows = h as usize;
    let frames = opts.frames.max(1);
    let top = GREY_STEPS[GREY_STEPS.len() - 1];
    let mut grey: Vec<(f64, f64)> = Vec::new();
    for (i, &k) in GREY_STEPS.iter().enumerate() {
        let s = if k == 0.0 {
            Stimulus::Dark
        } else {
            Stimulus::Uniform {
                radiance_w_m2_sr: k * opts.mean_radiance_w_m2_sr,
                spectrum: opts.spectrum.clone(),
            }
        };
        let mut v = 0.0;
        for _ in 0..frames {
            capture(cam, &s, w, h)?;
            v += mean_line_volts(cam, rows)?;
        }
        let v = v / frames as f64;
        if let Some(&(_, prev)) = grey.last()
            && !(v > prev)
        {
            return Err(CalibError::InsufficientData(format!(
                "the line voltage does not rise between grey patches ({prev:.4} → {v:.4} V): raise the radiance or the gain"
            )));
        }
        grey.push((k / top, v));
        progress(i + 1);
    }
    Ok(grey)
}

/// The chain's analytic horizontal MTF at `freqs` for frames `columns`
/// wide at gain `g`: on the line (stages × |H| × held-step sinc) and
/// digitised (stages × the sampled line).
pub fn analytic_curves(cam: &Camera, freqs: &[f64], g: f64, columns: usize) -> Vec<MtfCurve> {
    let ch = cam.chain();
    let on_line: Vec<f64> = freqs
        .iter()
        .map(|&f| ch.mtf_on_line(f, g, columns).unwrap_or(f64::NAN))
        .collect();
    let digitised: Vec<f64> = freqs
        .iter()
        .map(|&f| ch.mtf_horizontal(f, g, columns))
        .collect();
    vec![
        MtfCurve::new("analytic on the line", freqs.to_vec(), on_line),
        MtfCurve::new("analytic digitised", freqs.to_vec(), digitised),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflectance_inverts_the_grey_curve() {
        let g = [(0.0, 0.3), (0.5, 0.6), (1.0, 1.0)];
        assert!((reflectance(&g, 0.45) - 0.25).abs() < 1e-12);
        assert!((reflectance(&g, 0.8) - 0.75).abs() < 1e-12);
        // Extrapolated from the end segment.
        assert!((reflectance(&g, 1.2) - 1.25).abs() < 1e-12);
    }
}
