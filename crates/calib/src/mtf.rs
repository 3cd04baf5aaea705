//! Modulation transfer: sine-wave targets, USAF 1951 bar targets with
//! Coltman's square→sine conversion, and the ISO 12233 slanted edge.
//! Frequencies are in cycles per pixel (Nyquist = 0.5).

use gloam_grabber::{FrameGrabber, Stimulus};
use serde::Serialize;

use crate::capture::{grab_frames, stack_stats};
use crate::error::CalibError;

/// MTF samples with the summary frequencies.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MtfCurve {
    pub method: String,
    pub frequencies_cy_per_px: Vec<f64>,
    pub mtf: Vec<f64>,
    /// Frequency where the MTF first falls to 0.5 (None: never, in range).
    pub mtf50: Option<f64>,
    /// Limiting resolution: where the MTF first falls to 0.1.
    pub mtf10: Option<f64>,
}

impl MtfCurve {
    pub fn new(method: &str, f: Vec<f64>, m: Vec<f64>) -> Self {
        let mtf50 = crossing(&f, &m, 0.5);
        let mtf10 = crossing(&f, &m, 0.1);
        Self {
            method: method.into(),
            frequencies_cy_per_px: f,
            mtf: m,
            mtf50,
            mtf10,
        }
    }
}

/// First frequency where `m` falls to `level`, linearly interpolated.
pub fn crossing(f: &[f64], m: &[f64], level: f64) -> Option<f64> {
    for i in 1..f.len().min(m.len()) {
        if m[i - 1] >= level && m[i] < level {
            let t = (m[i - 1] - level) / (m[i - 1] - m[i]);
            return Some(f[i - 1] + t * (f[i] - f[i - 1]));
        }
    }
    None
}

/// USAF 1951 resolving power of a group and element, line pairs per mm:
/// `2^(group + (element − 1)/6)`.
pub fn usaf_lp_per_mm(group: i32, element: i32) -> f64 {
    2f64.powf(group as f64 + (element as f64 - 1.0) / 6.0)
}

fn factorize_squarefree(mut k: u64) -> Option<u32> {
    // Number of prime factors of k, or None when one repeats.
    let mut count = 0;
    let mut p = 2;
    while p * p <= k {
        if k % p == 0 {
            k /= p;
            if k % p == 0 {
                return None;
            }
            count += 1;
        }
        p += 1;
    }
    if k > 1 {
        count += 1;
    }
    Some(count)
}

/// Coefficient of `C(kf)/k` in Coltman's inversion (k odd):
/// `0` when k has a repeated prime factor, else `(−1)^m (−1)^((k−1)/2)` with
/// m the number of prime factors. Gives + + − + 0 + − − − + + for k = 1, 3, 5,
/// 7, 9, 11, 13, 15, 17, 19, 21.
pub fn coltman_coefficient(k: u64) -> i32 {
    if k % 2 == 0 {
        return 0;
    }
    if k == 1 {
        return 1;
    }
    match factorize_squarefree(k) {
        None => 0,
        Some(m) => {
            let a = if m % 2 == 0 { 1 } else { -1 };
            let b = if ((k - 1) / 2) % 2 == 0 { 1 } else { -1 };
            a * b
        }
    }
}

/// Square-wave response (CTF) of a system with sine MTF `mtf`, by Coltman's
/// forward series `C(f) = (4/π) Σ_{k odd} (−1)^((k−1)/2) M(kf)/k`, summed
/// while `kf ≤ f_max` (above it the MTF is taken as zero).
pub fn coltman_square_from_sine(f: f64, mtf: impl Fn(f64) -> f64, f_max: f64) -> f64 {
    let mut s = 0.0;
    let mut k = 1u64;
    while (k as f64) * f <= f_max && k < 100_000 {
        let sign = if ((k - 1) / 2) % 2 == 0 { 1.0 } else { -1.0 };
        s += sign * mtf(k as f64 * f) / k as f64;
        k += 2;
    }
    4.0 / std::f64::consts::PI * s
}

/// Sine MTF from a square-wave response by Coltman's inversion
/// `M(f) = (π/4) Σ_{k odd} B_k C(kf)/k`, summed while `kf ≤ f_max`.
pub fn coltman_sine_from_square(f: f64, ctf: impl Fn(f64) -> f64, f_max: f64) -> f64 {
    let mut s = 0.0;
    let mut k = 1u64;
    while (k as f64) * f <= f_max && k < 100_000 {
        let b = coltman_coefficient(k);
        if b != 0 {
            s += b as f64 * ctf(k as f64 * f) / k as f64;
        }
        k += 2;
    }
    std::f64::consts::PI / 4.0 * s
}

/// Coltman's inversion over measured CTF samples (frequencies increasing):
/// C between samples is interpolated linearly and taken as zero above the
/// highest measured frequency (bars finer than that were not resolved).
pub fn coltman_sine_from_square_samples(f: &[f64], ctf: &[f64]) -> Result<Vec<f64>, CalibError> {
    if f.len() != ctf.len() || f.is_empty() {
        return Err(CalibError::InsufficientData(
            "CTF samples are empty or uneven".into(),
        ));
    }
    if f.windows(2).any(|w| !(w[1] > w[0])) || f.iter().chain(ctf).any(|v| !v.is_finite()) {
        return Err(CalibError::Invalid(
            "CTF frequencies must increase and be finite".into(),
        ));
    }
    let fmax = *f.last().expect("non-empty");
    let interp = |x: f64| -> f64 {
        if x > fmax {
            return 0.0;
        }
        if x <= f[0] {
            return ctf[0];
        }
        let j = f.partition_point(|&v| v < x).min(f.len() - 1);
        let t = (x - f[j - 1]) / (f[j] - f[j - 1]);
        ctf[j - 1] + t * (ctf[j] - ctf[j - 1])
    };
    Ok(f.iter()
        .map(|&x| coltman_sine_from_square(x, interp, fmax))
        .collect())
}

/// Settings of the sine-target measurement.
#[derive(Clone, Debug)]
pub struct SineOptions {
    pub frequencies_cy_per_px: Vec<f64>,
    pub mean_radiance_w_m2_sr: f64,
    pub modulation: f64,
    pub angle_deg: f64,
    pub spectrum: String,
    pub frames: usize,
}

/// Grey-scale steps of the sine flow, as multiples of the target's mean
/// radiance (cover `mean·(1 ± modulation)` for modulation up to 0.9).
pub const GREY_STEPS: [f64; 9] = [0.0, 0.1, 0.3, 0.6, 1.0, 1.3, 1.6, 1.8, 1.95];

/// A measured grey scale: mean DN at known uniform radiances, increasing.
#[derive(Clone, Debug, PartialEq)]
pub struct GreyScale {
    pub dn: Vec<f64>,
    pub radiance_w_m2_sr: Vec<f64>,
    /// The brightest step's mean image (DN per pixel): a flat field at the
    /// top radiance, which the slanted edge needs and need not capture again.
    pub top_image_dn: Vec<f64>,
}

impl GreyScale {
    /// Uniform fields at [`GREY_STEPS`] × `unit` radiance (step 0 = dark).
    /// Errors when a step clips or the scale does not rise.
    pub fn measure(
        grabber: &mut dyn FrameGrabber,
        unit_w_m2_sr: f64,
        spectrum: &str,
        frames: usize,
        progress: &mut dyn FnMut(usize),
    ) -> Result<Self, CalibError> {
        let mut dn: Vec<f64> = Vec::new();
        let mut rad = Vec::new();
        let mut top_image_dn = Vec::new();
        for (i, &k) in GREY_STEPS.iter().enumerate() {
            let l = k * unit_w_m2_sr;
            if k == 0.0 {
                grabber.present(&Stimulus::Dark)?;
            } else {
                grabber.present(&Stimulus::Uniform {
                    radiance_w_m2_sr: l,
                    spectrum: spectrum.to_string(),
                })?;
            }
            let st = stack_stats(&grab_frames(grabber, frames)?)?;
            if st.clipped_fraction > 0.0 {
                return Err(CalibError::InsufficientData(format!(
                    "the grey-scale step at {l:.4e} W m⁻² sr⁻¹ clips: lower the radiance or the gain"
                )));
            }
            let sem = st.temporal_std_dn / ((frames * st.mean_image.len()) as f64).sqrt();
            if let Some(&prev) = dn.last()
                && !(st.mean_dn > prev + 3.0 * sem.max(1e-9))
            {
                return Err(CalibError::InsufficientData(format!(
                    "the grey scale does not rise between {:.4e} and {l:.4e} W m⁻² sr⁻¹ ({prev:.3} → {:.3} DN): raise the radiance",
                    rad.last().copied().unwrap_or(0.0),
                    st.mean_dn
                )));
            }
            dn.push(st.mean_dn);
            rad.push(l);
            top_image_dn = st.mean_image;
            progress(i + 1);
        }
        Ok(Self {
            dn,
            radiance_w_m2_sr: rad,
            top_image_dn,
        })
    }

    /// Radiance for a DN: piecewise linear, extrapolated from the end segments.
    pub fn radiance(&self, dn: f64) -> f64 {
        let n = self.dn.len();
        let j = self.dn.partition_point(|&d| d < dn).clamp(1, n - 1);
        let t = (dn - self.dn[j - 1]) / (self.dn[j] - self.dn[j - 1]);
        self.radiance_w_m2_sr[j - 1] + t * (self.radiance_w_m2_sr[j] - self.radiance_w_m2_sr[j - 1])
    }
}

/// Sine-target MTF. A grey-scale calibration — uniform fields at
/// [`GREY_STEPS`] × the target's mean radiance — gives a monotone,
/// piecewise-linear map from DN to radiance (the camera need not be
/// linear); each target's averaged frame is mapped to radiance and fitted
/// with `a + b cos(2πf x') + c sin(2πf x')`, and
/// `MTF = √(b²+c²)/a / modulation`.
pub fn sine_mtf(
    grabber: &mut dyn FrameGrabber,
    opts: &SineOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<MtfCurve, CalibError> {
    if !(opts.modulation > 0.0 && opts.modulation <= 0.9) {
        return Err(CalibError::Invalid(
            "modulation must lie in (0, 0.9]".into(),
        ));
    }
    let frames = opts.frames.max(1);
    let total = opts.frequencies_cy_per_px.len() + GREY_STEPS.len();
    let grey = GreyScale::measure(
        grabber,
        opts.mean_radiance_w_m2_sr,
        &opts.spectrum,
        frames,
        &mut |i| progress(i, total),
    )?;
    let to_l = |dn: f64| grey.radiance(dn);
    let (ca, sa) = {
        let a = opts.angle_deg.to_radians();
        (a.cos(), a.sin())
    };
    let mut out = Vec::new();
    for (i, &f) in opts.frequencies_cy_per_px.iter().enumerate() {
        grabber.present(&Stimulus::Sine {
            mean_radiance_w_m2_sr: opts.mean_radiance_w_m2_sr,
            modulation: opts.modulation,
            cycles_per_pixel: f,
            angle_deg: opts.angle_deg,
            spectrum: opts.spectrum.clone(),
        })?;
        let st = stack_stats(&grab_frames(grabber, frames)?)?;
        let (w, h) = (st.width, st.height);
        // Normal equations for [1, cos, sin].
        let mut ata = [[0.0f64; 3]; 3];
        let mut aty = [0.0f64; 3];
        for r in 0..h {
            for c in 0..w {
                let x = c as f64 * ca + r as f64 * sa;
                let ph = 2.0 * std::f64::consts::PI * f * x;
                let v = [1.0, ph.cos(), ph.sin()];
                let y = to_l(st.mean_image[r * w + c]);
                for p in 0..3 {
                    aty[p] += v[p] * y;
                    for q in 0..3 {
                        ata[p][q] += v[p] * v[q];
                    }
                }
            }
        }
        let sol = gloam_sensor::scope::solve3(ata, aty).ok_or_else(|| {
            CalibError::SingularFit(format!(
                "sine target at {f} cy/px cannot be fitted (frequency 0 or exactly aliased onto the pixel grid)"
            ))
        })?;
        let m_out = (sol[1] * sol[1] + sol[2] * sol[2]).sqrt() / sol[0];
        let m = m_out / opts.modulation;
        out.push(held_to_physics(f, m)?);
        progress(i + 3, total);
    }
    Ok(MtfCurve::new(
        "sine",
        opts.frequencies_cy_per_px.clone(),
        out,
    ))
}

/// A sine target's measured MTF `m` at `f` cy/px, held to [0, 1.05]
/// ([`crate::mtf_flow::MAX_MTF`]): an MTF is at most 1 (plus noise), so
/// beyond it the grey scale did not linearise the camera at this target.
/// Both sine flows (digitised and on the scope's line) go through it.
pub(crate) fn held_to_physics(f: f64, m: f64) -> Result<f64, CalibError> {
    if (0.0..=crate::mtf_flow::MAX_MTF).contains(&m) {
        return Ok(m);
    }
    Err(CalibError::InsufficientData(format!(
        "the sine target at {f} cy/px measures MTF {m:.4}, outside [0, {}]: the grey-scale map does not linearise the camera there (clipping, or the light changed between the grey scale and the targets); lower the radiance or the gain",
        crate::mtf_flow::MAX_MTF
    )))
}

/// Settings of the slanted-edge measurement.
#[derive(Clone, Debug)]
pub struct EdgeOptions {
    pub dark_radiance_w_m2_sr: f64,
    pub bright_radiance_w_m2_sr: f64,
    pub angle_deg: f64,
    pub spectrum: String,
    pub frames: usize,
}

/// ISO 12233 slanted-edge MTF from a grabber: a grey scale up to the bright
/// radiance (the OECF) linearises the edge image, then [`slanted_edge_mtf`].
pub fn edge_mtf(
    grabber: &mut dyn FrameGrabber,
    opts: &EdgeOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<MtfCurve, CalibError> {
    let frames = opts.frames.max(1);
    if !(opts.bright_radiance_w_m2_sr > opts.dark_radiance_w_m2_sr
        && opts.dark_radiance_w_m2_sr >= 0.0)
    {
        return Err(CalibError::Invalid(
            "the edge needs bright radiance > dark radiance ≥ 0".into(),
        ));
    }
    let total = GREY_STEPS.len() + 2;
    // OECF: a grey scale up to the bright side linearises the edge image.
    let unit = opts.bright_radiance_w_m2_sr / GREY_STEPS[GREY_STEPS.len() - 1];
    let grey = GreyScale::measure(grabber, unit, &opts.spectrum, frames, &mut |i| {
        progress(i, total)
    })?;
    grabber.present(&Stimulus::Edge {
        dark_radiance_w_m2_sr: opts.dark_radiance_w_m2_sr,
        bright_radiance_w_m2_sr: opts.bright_radiance_w_m2_sr,
        angle_deg: opts.angle_deg,
        spectrum: opts.spectrum.clone(),
    })?;
    let st = stack_stats(&grab_frames(grabber, frames)?)?;
    if st.clipped_fraction > 0.0 {
        return Err(CalibError::InsufficientData(
            "the edge image clips: lower the bright radiance or the gain".into(),
        ));
    }
    // Flat fields at the edge's two radiances: each pixel is normalised
    // between its own dark and bright response. An intensifier's fixed
    // pattern (a Gen III tube's fibre-bundle boundaries: 16 % rms on the
    // bright side after 8 frames) otherwise runs through the edge profile
    // — a 5° edge on gen3-gaas-iccd at 256×192 measured MTF 0.34 at 0.1
    // cy/px and 0.81 at 0.2 (the sine targets: 0.88, 0.60). The bright
    // field is the grey scale's top step; the dark one is captured here.
    let (lo, hi) = (opts.dark_radiance_w_m2_sr, opts.bright_radiance_w_m2_sr);
    grabber.present(&Stimulus::Uniform {
        radiance_w_m2_sr: lo,
        spectrum: opts.spectrum.clone(),
    })?;
    let to_radiance =
        |image: &[f64]| -> Vec<f64> { image.iter().map(|&v| grey.radiance(v)).collect() };
    let dark = to_radiance(&stack_stats(&grab_frames(grabber, frames)?)?.mean_image);
    let bright = to_radiance(&grey.top_image_dn);
    if bright.len() != st.mean_image.len() || dark.len() != st.mean_image.len() {
        return Err(CalibError::InsufficientData(format!(
            "the grabber's frame size changed during the edge measurement (grey scale {} pixels, edge {}, dark field {})",
            bright.len(),
            st.mean_image.len(),
            dark.len()
        )));
    }
    progress(total, total);
    let img: Vec<f64> = (st.mean_image.iter().zip(dark.iter().zip(&bright)))
        .map(|(&v, (&d, &b))| {
            let l = grey.radiance(v);
            let span = b - d;
            // A pixel that does not respond (span ≤ 0) keeps the global map.
            if span > 1e-9 * (hi - lo) && span.is_finite() {
                lo + (hi - lo) * (l - d) / span
            } else {
                l
            }
        })
        .collect();
    slanted_edge_mtf(&img, st.width, st.height)
}

/// ISO 12233 slanted-edge analysis of a linear (dark-subtracted) image of a
/// near-vertical edge:
/// 1. per row, the centroid of the derivative along the row locates the edge;
/// 2. a line `x = a + b·row` is fitted to the centroids;
/// 3. every pixel is projected onto the edge normal (perpendicular distance,
///    so the frequencies are along the normal) and binned at 1/4 pixel into
///    the edge-spread function;
/// 4. its central difference is Hamming-windowed and Fourier transformed;
///    the transform is normalised at zero frequency and divided by the
///    central difference's own response `sinc(2fΔ)`.
pub fn slanted_edge_mtf(img: &[f64], w: usize, h: usize) -> Result<MtfCurve, CalibError> {
    if w < 8 || h < 8 || img.len() != w * h {
        return Err(CalibError::Invalid(format!(
            "edge image {w}×{h} is too small (need ≥ 8×8)"
        )));
    }
    let (a, b) = edge_line(img, w, h)?;
    let (a, b) = banded_line(img, w, h, (a, b));
    // The quarter-pixel profile needs the rows to sample every phase of
    // the pixel grid: an edge that drifts less than a pixel over the image
    // leaves bins empty (interpolated) and its MTF aliased — a square edge
    // (0°) gave MTF50 0.20 cy/px where the 5° edge of the same camera gave
    // 0.19 by chance, 2° 0.08.
    let drift_px = b.abs() * (h - 1) as f64;
    if drift_px < 1.0 {
        return Err(CalibError::InsufficientData(format!(
            "the edge drifts {drift_px:.2} pixel across the {h} rows: tilt it (ISO 12233 slants it about 5°, e.g. --angle-deg 5) so its rows sample every phase of the pixel grid"
        )));
    }
    // Quarter-pixel bins over ±16 px (or the half width) across the edge.
    let dx = 0.25;
    let half = (w as f64 / 2.0).min(16.0);
    let esf = oversampled_esf(img, w, h, (a, b), dx, half)?;
    let (lsf, cen) = windowed_lsf(&esf)?;
    let (freqs, mtf) = lsf_mtf(&lsf, cen, dx);
    Ok(MtfCurve::new("slanted-edge", freqs, mtf))
}

/// The edge's line, column = a + b·row, from each row's derivative
/// centroid; refused when no near-vertical edge stands out of the noise.
/// Only a starting point: noise far from the edge pulls whole-row
/// centroids toward the row centre, and [`banded_line`] refits the line
/// within ±16 px of this one. (Two passes of centroids within ±8 px used
/// to sit between them; with the banded refit they changed MTF50 by at
/// most 0.007 cy/px from 2° to 20° on three cameras, and at 30° on
/// gen3-gaas-iccd they cost 0.03: 0.175 with them, 0.208 without, sine
/// targets 0.23.)
fn edge_line(img: &[f64], w: usize, h: usize) -> Result<(f64, f64), CalibError> {
    let mut rows = Vec::new();
    let mut cents = Vec::new();
    let mut contrast = 0.0f64;
    for r in 0..h {
        let row = &img[r * w..(r + 1) * w];
        let d: Vec<f64> = (0..w - 1).map(|c| row[c + 1] - row[c]).collect();
        let s: f64 = d.iter().sum();
        contrast = contrast.max(s.abs());
        if s.abs() <= 0.0 {
            continue;
        }
        let cm: f64 = d
            .iter()
            .enumerate()
            .map(|(c, v)| (c as f64 + 0.5) * v)
            .sum::<f64>()
            / s;
        if cm.is_finite() && cm > 1.0 && cm < (w - 2) as f64 {
            rows.push(r as f64);
            cents.push(cm);
        }
    }
    let noise = {
        let m = img.iter().sum::<f64>() / img.len() as f64;
        img.iter().map(|v| (v - m).abs()).fold(0.0, f64::max)
    };
    if rows.len() < h / 2 || contrast <= 1e-9 * noise.max(1e-300) || contrast == 0.0 {
        return Err(CalibError::InsufficientData(
            "no edge found in the image (flat field, or the edge is not near-vertical)".into(),
        ));
    }
    let fit = crate::stats::weighted_linear_fit(&rows, &cents, &vec![1.0; rows.len()])?;
    Ok((fit.intercept, fit.slope))
}

/// The edge's line refitted from bands of rows: each band's mean profile
/// (rows averaged, a 5-pixel running mean) is cut at the level halfway
/// between its dark and bright sides within ±`reach` px of the current
/// line, and a line is fitted through the cuts at the bands' middle rows.
/// Row centroids alone cannot place a noisy edge: on an intensified camera
/// (16 % rms per pixel) each row's centroid strays by pixels, and a 5°
/// edge was fitted at 7.2° — its profile smeared to MTF50 0.07 cy/px
/// against the sine targets' 0.23. A band of 24 rows cut at its midpoint
/// strays by about 0.05 px. Bounded: one pass over the image a round.
fn banded_line(img: &[f64], w: usize, h: usize, (a, b): (f64, f64)) -> (f64, f64) {
    let band = (h / 8).clamp(4, 32);
    let mut line = (a, b);
    for reach in [16.0f64, 8.0] {
        let (mut rows, mut cuts) = (Vec::new(), Vec::new());
        for r0 in (0..h.saturating_sub(band - 1)).step_by(band) {
            let mid_row = r0 as f64 + (band as f64 - 1.0) / 2.0;
            let xe = line.0 + line.1 * mid_row;
            let lo = (xe - reach - 2.0).floor().max(0.0) as usize;
            let hi = ((xe + reach + 2.0).ceil() as usize).min(w - 1);
            if hi < lo + 8 {
                continue;
            }
            let profile: Vec<f64> = (lo..=hi)
                .map(|c| (r0..r0 + band).map(|r| img[r * w + c]).sum::<f64>() / band as f64)
                .collect();
            let smooth: Vec<f64> = (0..profile.len())
                .map(|k| {
                    let (s, e) = (k.saturating_sub(2), (k + 3).min(profile.len()));
                    profile[s..e].iter().sum::<f64>() / (e - s) as f64
                })
                .collect();
            let n = smooth.len();
            let (left, right) = (smooth[..n / 4].to_vec(), smooth[n - n / 4..].to_vec());
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
            let (l, rt) = (mean(&left), mean(&right));
            let level = (l + rt) / 2.0;
            let sign = if rt >= l { 1.0 } else { -1.0 };
            // The cut nearest the expected position.
            let expect = xe - lo as f64;
            let cut = (0..n - 1)
                .filter(|&k| {
                    sign * (smooth[k] - level) < 0.0 && sign * (smooth[k + 1] - level) >= 0.0
                })
                .map(|k| k as f64 + (level - smooth[k]) / (smooth[k + 1] - smooth[k]))
                .min_by(|x, y| (x - expect).abs().total_cmp(&(y - expect).abs()));
            if let Some(c) = cut.filter(|c| c.is_finite()) {
                rows.push(mid_row);
                cuts.push(lo as f64 + c);
            }
        }
        if rows.len() < 3 {
            break;
        }
        match crate::stats::weighted_linear_fit(&rows, &cuts, &vec![1.0; rows.len()]) {
            Ok(fit) if fit.intercept.is_finite() && fit.slope.is_finite() => {
                line = (fit.intercept, fit.slope);
            }
            _ => break,
        }
    }
    line
}

/// The edge-spread function: every pixel binned by its distance across the
/// edge (`dx`-wide bins over ±`half` px), empty bins interpolated between
/// filled neighbours.
fn oversampled_esf(
    img: &[f64],
    w: usize,
    h: usize,
    (a, b): (f64, f64),
    dx: f64,
    half: f64,
) -> Result<Vec<f64>, CalibError> {
    let cos = 1.0 / (1.0 + b * b).sqrt();
    let nb = (2.0 * half / dx) as usize;
    let mut sum = vec![0.0; nb];
    let mut cnt = vec![0usize; nb];
    for r in 0..h {
        let xe = a + b * r as f64;
        for c in 0..w {
            let d = (c as f64 - xe) * cos;
            let k = ((d + half) / dx).floor();
            if k >= 0.0 && (k as usize) < nb {
                sum[k as usize] += img[r * w + c];
                cnt[k as usize] += 1;
            }
        }
    }
    // Fill empty bins by linear interpolation between filled neighbours.
    let filled: Vec<usize> = (0..nb).filter(|&i| cnt[i] > 0).collect();
    if filled.len() < nb / 2 {
        return Err(CalibError::InsufficientData(
            "the edge is too close to vertical or horizontal to oversample (use ~5°)".into(),
        ));
    }
    let mut esf = vec![0.0; nb];
    for i in 0..nb {
        if cnt[i] > 0 {
            esf[i] = sum[i] / cnt[i] as f64;
        }
    }
    for i in 0..nb {
        if cnt[i] == 0 {
            let lo = filled.iter().rev().find(|&&j| j < i);
            let hi = filled.iter().find(|&&j| j > i);
            esf[i] = match (lo, hi) {
                (Some(&l), Some(&u)) => {
                    esf[l] + (esf[u] - esf[l]) * (i - l) as f64 / (u - l) as f64
                }
                (Some(&l), None) => esf[l],
                (None, Some(&u)) => esf[u],
                _ => 0.0,
            };
        }
    }
    Ok(esf)
}

/// The line-spread function (central differences of the ESF) under a
/// Hamming window centred on its centroid; the centroid, in bins.
fn windowed_lsf(esf: &[f64]) -> Result<(Vec<f64>, f64), CalibError> {
    let nb = esf.len();
    // LSF by central difference.
    let mut lsf = vec![0.0; nb];
    for i in 1..nb - 1 {
        lsf[i] = (esf[i + 1] - esf[i - 1]) / 2.0;
    }
    // Hamming window centred on the LSF centroid.
    let tot: f64 = lsf.iter().sum();
    if tot.abs() <= 0.0 {
        return Err(CalibError::InsufficientData(
            "the edge-spread function is flat".into(),
        ));
    }
    let cen = lsf
        .iter()
        .enumerate()
        .map(|(i, v)| i as f64 * v)
        .sum::<f64>()
        / tot;
    let hw = (cen.min(nb as f64 - 1.0 - cen)).max(4.0);
    for (i, v) in lsf.iter_mut().enumerate() {
        let t = (i as f64 - cen) / hw;
        *v *= if t.abs() <= 1.0 {
            0.54 + 0.46 * (std::f64::consts::PI * t).cos()
        } else {
            0.0
        };
    }
    Ok((lsf, cen))
}

/// The MTF up to 1 cy/px: the LSF's DFT about its centroid, normalised
/// to DC and divided by the bin's own sinc.
fn lsf_mtf(lsf: &[f64], cen: f64, dx: f64) -> (Vec<f64>, Vec<f64>) {
    let nb = lsf.len();
    // DFT up to 1 cy/px.
    let n = nb as f64;
    let mut freqs = Vec::new();
    let mut mtf = Vec::new();
    let dc: f64 = lsf.iter().sum();
    let mut k = 0usize;
    loop {
        let f = k as f64 / (n * dx);
        if f > 1.0 {
            break;
        }
        let (mut re, mut im) = (0.0, 0.0);
        for (i, v) in lsf.iter().enumerate() {
            let ph = -2.0 * std::f64::consts::PI * k as f64 * (i as f64 - cen) / n;
            re += v * ph.cos();
            im += v * ph.sin();
        }
        let x = 2.0 * std::f64::consts::PI * f * dx;
        let corr = if x > 1e-12 { x.sin() / x } else { 1.0 };
        freqs.push(f);
        mtf.push((re * re + im * im).sqrt() / dc.abs() / corr.max(0.1));
        k += 1;
    }
    (freqs, mtf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn usaf_values() {
        assert_eq!(usaf_lp_per_mm(0, 1), 1.0);
        assert!((usaf_lp_per_mm(2, 3) - 2f64.powf(2.0 + 2.0 / 6.0)).abs() < 1e-12);
        assert!((usaf_lp_per_mm(-2, 1) - 0.25).abs() < 1e-12);
        assert!((usaf_lp_per_mm(7, 6) - 228.0).abs() < 0.1);
    }

    #[test]
    fn coltman_signs() {
        let got: Vec<i32> = (0..10).map(|i| coltman_coefficient(2 * i + 1)).collect();
        // k = 1 3 5 7 9 11 13 15 17 19
        assert_eq!(got, vec![1, 1, -1, 1, 0, 1, -1, -1, -1, 1]);
        assert_eq!(coltman_coefficient(21), 1); // 3·7: m = 2, (k−1)/2 = 10
        assert_eq!(coltman_coefficient(25), 0);
        assert_eq!(coltman_coefficient(45), 0);
    }

    #[test]
    fn coltman_inverts_forward_series() {
        let m = |f: f64| (-2.0 * std::f64::consts::PI.powi(2) * 0.49 * f * f).exp();
        let fmax = 50.0;
        let ctf = |f: f64| coltman_square_from_sine(f, m, fmax);
        for f in [0.02, 0.05, 0.1, 0.2, 0.3, 0.45] {
            let back = coltman_sine_from_square(f, ctf, fmax);
            assert!((back - m(f)).abs() < 1e-6, "f {f}: {back} vs {}", m(f));
            // A square wave's response exceeds the sine's at low frequency.
            assert!(ctf(f) >= m(f) - 1e-12);
        }
    }

    #[test]
    fn sine_mtf_held_to_0_1_05() {
        assert_eq!(held_to_physics(0.1, 1.05).unwrap(), 1.05);
        assert_eq!(held_to_physics(0.1, 0.0).unwrap(), 0.0);
        for m in [1.0501, 1.3, -0.01, f64::NAN, f64::INFINITY] {
            let e = held_to_physics(0.25, m).unwrap_err().to_string();
            assert!(
                e.contains("the sine target at 0.25 cy/px measures MTF"),
                "{e}"
            );
            assert!(e.contains("outside [0, 1.05]"), "{e}");
        }
    }

    #[test]
    fn crossing_interpolates() {
        assert_eq!(crossing(&[0.0, 1.0], &[1.0, 0.0], 0.5), Some(0.5));
        assert_eq!(crossing(&[0.0, 1.0], &[1.0, 0.9], 0.5), None);
    }
}
