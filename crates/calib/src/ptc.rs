//! Photon transfer after EMVA 1288 Release 4.0, linear module.
//!
//! The sweep: a dark pair, then ≥ 50 (configurable) irradiance levels equally
//! spaced from dark to beyond saturation, two frames A, B at each; then L
//! frames dark and L frames at ~50 % of saturation for the spatial
//! non-uniformities. From the pairs:
//!
//! * `μ_y = mean((A+B)/2)`, `σ²_y = mean((A−B)²)/2 − (μ_A−μ_B)²/2`;
//! * saturation: the level of maximum temporal variance;
//! * system gain K: slope of `σ²_y − σ²_y.dark` on `μ_y − μ_y.dark` over
//!   0–70 % of the saturation signal, a line through the origin (as the EMVA
//!   reference implementation fits it) weighted by `1/σ⁴_y` — the variance of
//!   a pair's variance estimate is `σ⁴_y/N_pixels`, so an unweighted fit
//!   lets the noisiest top points set K (on a 128² scientific CCD that read
//!   K 1.4 % high and η as much low);
//! * responsivity R: slope of `μ_y − μ_y.dark` on `μ_p` (photons per pixel)
//!   over the same range; quantum efficiency `η = R / K`;
//! * temporal dark noise `σ_d = σ_y.dark / K` e⁻, with `σ²_y.dark` pooled
//!   over the dark pair and the L-frame dark stack (quantisation noise is
//!   not subtracted; Release 3.x subtracted 1/12 DN² first — negligible
//!   unless σ_y.dark is below ~1 DN);
//! * saturation capacity `μ_e.sat = (μ_y.sat − μ_y.dark)/K`;
//! * SNR_max = `√μ_e.sat`; absolute sensitivity threshold
//!   `μ_p.min = (½ + √(¼ + σ²_y.dark/K²))/η` (SNR = 1); DR = μ_p.sat/μ_p.min;
//! * linearity error: fit `μ_y − μ_y.dark` on `μ_p` over 5–95 % of the
//!   saturation signal, δ_i = relative deviation in %, LE = (max δ − min δ)/2;
//! * DSNU_1288 = s_y.dark/K e⁻, PRNU_1288 = √(s²_y.50 − s²_y.dark)/(μ_y.50 −
//!   μ_y.dark) %, with `s²` the spatial variance of the L-frame averages less
//!   the residual temporal variance σ²_y/L.
//!
//! On an intensified camera (ICCD, EBCCD) the slope K is not the camera's
//! conversion gain: the gain process adds excess noise, so `K_eff = g ·
//! F_pix` with `g` the DN per photoelectron and `F_pix` the noise factor a
//! pixel sees (`gloam_sensor` `Chain::pixel_noise_factor`: the excess noise
//! factor F of the gain process, reduced by the blur after it). When the
//! `[rig]` names the camera, the report adds `g = K_eff/F_pix` and the QE
//! `R/g` from the camera's declared noise, and says why EMVA's η is not it.
//!
//! Photons per pixel come from the source's spectral radiance and the rig
//! (pixel pitch, f-number, optics transmission, exposure); without a rig the
//! flow still reports K, noise in e⁻, saturation, DSNU and PRNU, and leaves
//! QE, responsivity and the photon-based figures out.

use std::path::Path;

use gloam_grabber::{Frame, FrameGrabber};
use serde::Serialize;

use crate::capture::{grab_frames, stack_stats};
use crate::error::CalibError;
use crate::source::CalibrationSource;
use crate::stats::{weighted_linear_fit, weighted_slope_through_origin};

/// Settings of a photon-transfer run.
#[derive(Clone, Debug)]
pub struct PtcOptions {
    /// Fixed gain for the run (AGC off).
    pub gain: f64,
    pub exposure_s: Option<f64>,
    /// Frames averaged for DSNU/PRNU (EMVA: L ≥ 16 recommended).
    pub spatial_frames: usize,
    /// Write the EMVA 1288 descriptor dataset (images + descriptor file) here.
    pub dataset_dir: Option<std::path::PathBuf>,
}

/// Fixed gain of the sweep (the CLI's and Python's default).
pub const DEFAULT_GAIN: f64 = 1.0;
/// Frames averaged for DSNU/PRNU (EMVA 1288 recommends L ≥ 16).
pub const DEFAULT_SPATIAL_FRAMES: usize = 16;
/// Irradiance levels when the source file lists none (EMVA 1288: ≥ 50).
pub const DEFAULT_LEVELS: usize = 50;

impl Default for PtcOptions {
    fn default() -> Self {
        Self {
            gain: DEFAULT_GAIN,
            exposure_s: None,
            spatial_frames: DEFAULT_SPATIAL_FRAMES,
            dataset_dir: None,
        }
    }
}

/// One point of the photon-transfer sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PtcPoint {
    pub band_radiance_w_m2_sr: f64,
    /// Mean photons per pixel, if a rig was given.
    pub photons_per_pixel: Option<f64>,
    pub mean_dn: f64,
    pub temporal_var_dn2: f64,
}

/// EMVA 1288 figures (keys are the CLI's `ptc.json` contract).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PtcResult {
    pub gain: f64,
    pub system_gain_dn_per_e: f64,
    pub quantum_efficiency: Option<f64>,
    pub responsivity_dn_per_photon: Option<f64>,
    pub dark_noise_e: f64,
    pub dark_noise_dn: f64,
    pub dark_mean_dn: f64,
    pub saturation_capacity_e: f64,
    pub saturation_dn: f64,
    /// False when the variance was still rising at the last level: the
    /// saturation figures are then lower bounds.
    pub saturation_reached: bool,
    pub snr_max: f64,
    pub snr_max_db: f64,
    pub absolute_sensitivity_threshold_photons: Option<f64>,
    pub absolute_sensitivity_threshold_e: f64,
    pub dynamic_range: f64,
    pub dynamic_range_db: f64,
    pub linearity_error_percent: Option<f64>,
    pub dsnu_e: f64,
    pub dsnu_dn: f64,
    pub prnu_percent: f64,
    pub k_fit_points: usize,
    /// The variance/mean slope again, named for what it is on an intensified
    /// camera: `K_eff = g · F_pix`, excess noise included (= K on a CCD).
    pub effective_system_gain_dn_per_e: f64,
    /// The camera the `[rig]` names, whose declared noise gives the next
    /// figures (`None`: no camera named, so none of them).
    pub declared_camera: Option<String>,
    /// That camera's excess noise factor F of the gain process at `gain`
    /// (variance factor, referred to photoelectrons; 1 for a CCD).
    pub excess_noise_factor: Option<f64>,
    /// The noise factor a pixel sees, `F_pix = K_eff / g` (F reduced by
    /// the blur after the gain process).
    pub pixel_noise_factor: Option<f64>,
    /// Conversion gain `g = K_eff / F_pix`, DN per photoelectron.
    pub conversion_gain_dn_per_pe: Option<f64>,
    /// QE from the conversion gain, `R / g` (needs photon counts).
    pub quantum_efficiency_from_conversion_gain: Option<f64>,
    /// The relation with this run's numbers, and the EMVA 1288 caveat.
    pub excess_noise_relation: Option<String>,
    /// The pixel and optics geometry the photon counts came from.
    pub rig: Option<crate::source::Rig>,
    /// Relative deviations (%) of the linearity fit at each point used.
    pub linearity_residuals_percent: Vec<(f64, f64)>,
    pub points: Vec<PtcPoint>,
    pub warnings: Vec<String>,
}

fn pair_stats(a: &Frame, b: &Frame) -> (f64, f64) {
    let n = a.pixels.len() as f64;
    let (mut sa, mut sb, mut sd2) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.pixels.iter().zip(&b.pixels) {
        let (x, y) = (x as f64, y as f64);
        sa += x;
        sb += y;
        sd2 += (x - y) * (x - y);
    }
    let (ma, mb) = (sa / n, sb / n);
    let mean = 0.5 * (ma + mb);
    let var = 0.5 * (sd2 / n - (ma - mb) * (ma - mb));
    (mean, var.max(0.0))
}

fn spatial_var(avg: &[f64], temporal_var: f64, frames: usize) -> f64 {
    let n = avg.len() as f64;
    let m = avg.iter().sum::<f64>() / n;
    let s2 = avg.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (s2 - temporal_var / frames as f64).max(0.0)
}

/// Runs the EMVA 1288 sweep over the source's levels (give it ≥ 50 levels,
/// linear in radiance, reaching past saturation).
pub fn photon_transfer(
    grabber: &mut dyn FrameGrabber,
    source: &mut dyn CalibrationSource,
    opts: &PtcOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<PtcResult, CalibError> {
    let n = source.levels();
    if n == 0 {
        return Err(CalibError::InsufficientData(
            "a dark-only capture has no photon transfer: the source has no illuminated levels"
                .into(),
        ));
    }
    crate::capture::agc_off(grabber)?;
    let gain = grabber.set_gain(opts.gain)?;
    if let Some(t) = opts.exposure_s {
        grabber.set_exposure_s(t)?;
    }
    let total = n + 3;
    let mut warnings = Vec::new();
    if n < 50 {
        warnings.push(format!(
            "{n} levels: EMVA 1288 asks for at least 50 equally spaced levels"
        ));
    }
    let mut dataset = opts
        .dataset_dir
        .as_deref()
        .map(DatasetWriter::new)
        .transpose()?;
    let dark = source.set_dark()?;
    grabber.present(&dark.stimulus)?;
    let dp = grab_frames(grabber, 2)?;
    let (dark_mean, dark_var) = pair_stats(&dp[0], &dp[1]);
    if let Some(d) = dataset.as_mut() {
        d.add_block('d', None, &dp)?;
    }
    progress(1, total);
    let rig = source.rig().cloned();
    let rig_used = rig.clone();
    let band = source.camera().band_nm;
    let mut points = Vec::new();
    let mut levels = Vec::new();
    for i in 0..n {
        let lv = source.set_level(i)?;
        grabber.present(&lv.stimulus)?;
        let fr = grab_frames(grabber, 2)?;
        let (m, v) = pair_stats(&fr[0], &fr[1]);
        let mu_p = rig
            .as_ref()
            .map(|r| r.photons_per_pixel(&lv.spectral_radiance, band));
        if let Some(d) = dataset.as_mut() {
            d.add_block('b', Some(mu_p.unwrap_or(f64::NAN)), &fr)?;
        }
        points.push(PtcPoint {
            band_radiance_w_m2_sr: lv.band_radiance_w_m2_sr,
            photons_per_pixel: mu_p,
            mean_dn: m,
            temporal_var_dn2: v,
        });
        levels.push(lv);
        progress(i + 2, total);
    }
    // Saturation: maximum temporal variance.
    let (isat, _) = points
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.temporal_var_dn2.total_cmp(&b.1.temporal_var_dn2))
        .expect("n > 0");
    let saturation_reached = isat + 1 < points.len();
    if !saturation_reached {
        warnings.push(
            "the variance still rises at the last level: saturation not reached, saturation figures are lower bounds"
                .into(),
        );
    }
    let sat_sig = points[isat].mean_dn - dark_mean;
    if !(sat_sig > 0.0) {
        return Err(CalibError::InsufficientData(
            "no level rises above the dark signal: nothing to fit (is the source on?)".into(),
        ));
    }
    // K over 0–70 % of saturation.
    let sel: Vec<usize> = (0..=isat)
        .filter(|&i| {
            let s = points[i].mean_dn - dark_mean;
            s > 0.0 && s <= 0.7 * sat_sig
        })
        .collect();
    if sel.len() < 3 {
        return Err(CalibError::InsufficientData(format!(
            "the sweep saturates early: {} level(s) lie below 70 % of saturation (level {} of {n}); EMVA 1288 fits need more — use finer levels or less light",
            sel.len(),
            isat + 1
        )));
    }
    // Spatial dark stack (L frames) now: its temporal variance, pooled with
    // the dark pair's, is the σ²_y.dark the K fit subtracts.
    let l = opts.spatial_frames.max(2);
    grabber.present(&dark.stimulus)?;
    let dframes = grab_frames(grabber, l)?;
    let ds = stack_stats(&dframes)?;
    progress(n + 2, total);
    // Temporal dark variance pooled over the dark pair (1 degree of freedom
    // per pixel) and the L-frame dark stack (L − 1): same quantity, less
    // sampling noise than the pair alone.
    let pooled_dark_var = (dark_var + ds.temporal_std_dn.powi(2) * (l as f64 - 1.0)) / l as f64;
    let xs: Vec<f64> = sel.iter().map(|&i| points[i].mean_dn - dark_mean).collect();
    let ys: Vec<f64> = sel
        .iter()
        .map(|&i| points[i].temporal_var_dn2 - pooled_dark_var)
        .collect();
    let kw: Vec<f64> = sel
        .iter()
        .map(|&i| 1.0 / points[i].temporal_var_dn2.max(1e-12).powi(2))
        .collect();
    let k = weighted_slope_through_origin(&xs, &ys, &kw)?;
    if !(k > 0.0) {
        return Err(CalibError::SingularFit(format!(
            "the photon transfer slope K = {k} DN/e⁻ is not positive"
        )));
    }
    // Responsivity & QE.
    let (resp, qe, lin_err, lin_res) = match rig {
        Some(_) => {
            let px: Vec<f64> = sel
                .iter()
                .map(|&i| points[i].photons_per_pixel.unwrap_or(0.0))
                .collect();
            let rfit = weighted_linear_fit(&px, &xs, &vec![1.0; px.len()])?;
            let r = rfit.slope;
            // Linearity over 5–95 %.
            let lsel: Vec<usize> = (0..=isat)
                .filter(|&i| {
                    let s = points[i].mean_dn - dark_mean;
                    s >= 0.05 * sat_sig && s <= 0.95 * sat_sig
                })
                .collect();
            let (le, res) = if lsel.len() >= 3 {
                let lx: Vec<f64> = lsel
                    .iter()
                    .map(|&i| points[i].photons_per_pixel.unwrap_or(0.0))
                    .collect();
                let ly: Vec<f64> = lsel
                    .iter()
                    .map(|&i| points[i].mean_dn - dark_mean)
                    .collect();
                let f = weighted_linear_fit(&lx, &ly, &vec![1.0; lx.len()])?;
                let d: Vec<(f64, f64)> = lx
                    .iter()
                    .zip(&ly)
                    .map(|(&x, &y)| {
                        let m = f.slope * x + f.intercept;
                        (x, 100.0 * (y - m) / m)
                    })
                    .collect();
                let mx = d.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
                let mn = d.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
                (Some((mx - mn) / 2.0), d)
            } else {
                warnings
                    .push("fewer than 3 levels in 5–95 % of saturation: no linearity error".into());
                (None, Vec::new())
            };
            (Some(r), Some(r / k), le, res)
        }
        None => {
            warnings.push(
                "no [rig] in the source file: photon counts unknown, so no QE, responsivity, linearity error or photon-based DR".into(),
            );
            (None, None, None, Vec::new())
        }
    };
    let declared = match declared_noise(rig_used.as_ref(), gain, k, resp) {
        Ok(d) => d,
        Err(NoDeclaredFigures(w)) => {
            warnings.push(w);
            None
        }
    };
    if let Some(d) = &declared
        && (d.excess_noise_factor > 1.0 || d.other_camera)
    {
        warnings.push(d.relation.clone());
    }
    let dark_noise_dn = pooled_dark_var.sqrt();
    let sigma_d_e = dark_noise_dn / k;
    let mu_e_sat = sat_sig / k;
    let mu_e_min = 0.5 + (0.25 + sigma_d_e * sigma_d_e).sqrt();
    let snr_max = mu_e_sat.sqrt();
    let dr = mu_e_sat / mu_e_min;
    let i50 = (0..=isat)
        .min_by(|&a, &b| {
            let da = (points[a].mean_dn - dark_mean - 0.5 * sat_sig).abs();
            let db = (points[b].mean_dn - dark_mean - 0.5 * sat_sig).abs();
            da.total_cmp(&db)
        })
        .expect("non-empty");
    let lv50 = source.set_level(i50)?;
    grabber.present(&lv50.stimulus)?;
    let bframes = grab_frames(grabber, l)?;
    let bs = stack_stats(&bframes)?;
    progress(n + 3, total);
    if let Some(d) = dataset.as_mut() {
        d.add_block(
            'b',
            Some(points[i50].photons_per_pixel.unwrap_or(f64::NAN)),
            &bframes,
        )?;
        d.add_block('d', None, &dframes)?;
        // The exposure the photon counts were made with: the run's, else
        // the rig's (the descriptor's `b`/`d` lines carry it in ns).
        let texp = opts.exposure_s.or(rig_used.as_ref().map(|r| r.exposure_s));
        if texp.is_none() {
            warnings.push(
                "no exposure given and no [rig]: the EMVA 1288 descriptor records exposure 0"
                    .into(),
            );
        }
        // Levels past saturation add nothing but, in the dataset, trip the
        // reference implementation's backward search for the variance
        // maximum (a plateau of read-noise variance is a run of local
        // maxima): keep two levels beyond the maximum.
        d.finish(
            ds.width,
            ds.height,
            bframes[0].meta.bits,
            texp,
            (isat + 3).min(n),
        )?;
    }
    let s2_dark = spatial_var(&ds.mean_image, ds.temporal_std_dn.powi(2), l);
    let s2_50 = spatial_var(&bs.mean_image, bs.temporal_std_dn.powi(2), l);
    let dsnu_dn = s2_dark.sqrt();
    let prnu = 100.0 * (s2_50 - s2_dark).max(0.0).sqrt() / (bs.mean_dn - ds.mean_dn);
    Ok(PtcResult {
        gain,
        system_gain_dn_per_e: k,
        quantum_efficiency: qe,
        responsivity_dn_per_photon: resp,
        dark_noise_e: sigma_d_e,
        dark_noise_dn,
        dark_mean_dn: dark_mean,
        saturation_capacity_e: mu_e_sat,
        saturation_dn: points[isat].mean_dn,
        saturation_reached,
        snr_max,
        snr_max_db: 20.0 * snr_max.log10(),
        absolute_sensitivity_threshold_photons: qe.map(|q| mu_e_min / q),
        absolute_sensitivity_threshold_e: mu_e_min,
        dynamic_range: dr,
        dynamic_range_db: 20.0 * dr.log10(),
        linearity_error_percent: lin_err,
        dsnu_e: dsnu_dn / k,
        dsnu_dn,
        prnu_percent: prnu,
        k_fit_points: sel.len(),
        effective_system_gain_dn_per_e: k,
        declared_camera: declared.as_ref().map(|d| d.camera.clone()),
        excess_noise_factor: declared.as_ref().map(|d| d.excess_noise_factor),
        pixel_noise_factor: declared.as_ref().map(|d| d.pixel_noise_factor),
        conversion_gain_dn_per_pe: declared.as_ref().map(|d| d.conversion_gain),
        quantum_efficiency_from_conversion_gain: declared.as_ref().and_then(|d| d.qe),
        excess_noise_relation: declared.map(|d| d.relation),
        rig: rig_used,
        linearity_residuals_percent: lin_res,
        points,
        warnings,
    })
}

/// The camera's own noise figures at the run's gain, from the sensor preset
/// or file the `[rig]` names.
struct Declared {
    camera: String,
    excess_noise_factor: f64,
    pixel_noise_factor: f64,
    conversion_gain: f64,
    qe: Option<f64>,
    relation: String,
    /// The measured K_eff is > 10 % from the declared camera's own.
    other_camera: bool,
}

/// Why the rig's camera gives no declared noise figures: a warning for
/// the report.
struct NoDeclaredFigures(String);

/// Conversion gain and QE from the measured `K_eff` and the declared pixel
/// noise factor: `Ok(None)` without a camera in the rig, `Err(warning)` when
/// the named camera won't load or has no such gain (so it is not the camera
/// behind the grabber).
fn declared_noise(
    rig: Option<&crate::source::Rig>,
    gain: f64,
    k_eff: f64,
    responsivity: Option<f64>,
) -> Result<Option<Declared>, NoDeclaredFigures> {
    let Some(camera) = rig.and_then(|r| r.camera.clone()) else {
        return Ok(None);
    };
    let no_figures = |e: &dyn std::fmt::Display| {
        NoDeclaredFigures(format!(
            "no conversion gain or excess noise: the [rig]'s camera '{camera}' gives none at gain {gain} ({e}); name the camera behind the grabber in [rig]"
        ))
    };
    // The source file's check noted a rig camera's file (`source.rs`).
    let cam = gloam_sensor::Camera::from_preset_or_file(&camera, &gloam_io::ReadLog::off())
        .map_err(|e| no_figures(&e))?;
    let chain = cam.chain();
    chain
        .describe_checked(Some(gain))
        .map_err(|e| no_figures(&e))?;
    let f = chain.excess_noise_factor(gain);
    let f_pix = chain.pixel_noise_factor(gain);
    let g = k_eff / f_pix;
    let qe = responsivity.map(|r| r / g);
    // The declared camera's own K_eff: far from the measured one, the rig
    // names another camera than the one behind the grabber.
    let k_declared = chain.mean_dn_per_photoelectron(gain) * f_pix;
    let other_camera = (k_eff / k_declared - 1.0).abs() > 0.1;
    let mismatch = if other_camera {
        format!(
            " (but {camera} at gain {gain} predicts K_eff = {k_declared:.5} DN/e⁻, {:+.0} % from the measured one: is it the camera behind the grabber?)",
            100.0 * (k_declared / k_eff - 1.0)
        )
    } else {
        String::new()
    };
    let relation = if f <= 1.0 {
        format!(
            "K_eff = g·F_pix with F_pix = 1: {camera} has no gain process, so K = {k_eff:.5} DN/e⁻ is its conversion gain{mismatch}"
        )
    } else {
        format!(
            "EMVA 1288 assumes a camera whose temporal noise is the photon shot noise of its \
         electrons; on this intensified camera ({camera} at gain {gain}) the gain process adds \
         excess noise, so the variance/mean slope is K_eff = g·F_pix = {k_eff:.5} DN/e⁻, not \
         the conversion gain. With the camera's declared excess noise factor F = {f:.4}, seen \
         per pixel as F_pix = {f_pix:.4} (F less the CCD shot term, times the post-gain blur's \
         Σh² and the phosphor's (1−p)/(1+p)), the conversion gain is g = K_eff/F_pix = {g:.5} \
         DN per photoelectron{}; EMVA's η, saturation and noise in e⁻ are per \
         'K_eff electron' (η_EMVA = QE/F_pix){mismatch}.",
            qe.map_or(String::new(), |q| format!(" and the QE R/g = {q:.4}"))
        )
    };
    Ok(Some(Declared {
        camera,
        excess_noise_factor: f,
        pixel_noise_factor: f_pix,
        conversion_gain: g,
        qe,
        relation,
        other_camera,
    }))
}

/// Writes frames as 16-bit TIFFs and an EMVA 1288 descriptor file
/// (`emva1288_descriptor.txt`) in the syntax of the EMVA reference
/// implementation: `v`, `n bits width height`, then blocks `b exposure_ns
/// photons` / `d exposure_ns` each followed by `i image` lines (2 images =
/// temporal, more = spatial).
struct DatasetWriter {
    dir: std::path::PathBuf,
    blocks: Vec<(char, Option<f64>, Vec<String>)>,
    counter: usize,
}

impl DatasetWriter {
    fn new(dir: &Path) -> Result<Self, CalibError> {
        std::fs::create_dir_all(dir.join("images")).map_err(|e| CalibError::file(dir, e))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            blocks: Vec::new(),
            counter: 0,
        })
    }

    fn add_block(
        &mut self,
        kind: char,
        photons: Option<f64>,
        frames: &[Frame],
    ) -> Result<(), CalibError> {
        let mut names = Vec::new();
        for f in frames {
            let name = format!("images/{kind}_{:04}.tif", self.counter);
            self.counter += 1;
            let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(
                f.meta.width,
                f.meta.height,
                f.pixels.clone(),
            )
            .ok_or_else(|| CalibError::Invalid("frame size does not match its pixels".into()))?;
            let p = self.dir.join(&name);
            let mut tif = std::io::Cursor::new(Vec::new());
            img.write_to(&mut tif, image::ImageFormat::Tiff)
                .map_err(|e| CalibError::file(&p, e))?;
            crate::report::write_bytes(&p, tif.get_ref())?;
            names.push(name);
        }
        self.blocks.push((kind, photons, names));
        Ok(())
    }

    /// The descriptor, with the temporal levels after the first
    /// `temporal_levels` left out (and their images removed).
    fn finish(
        &self,
        w: usize,
        h: usize,
        bits: u8,
        exposure_s: Option<f64>,
        temporal_levels: usize,
    ) -> Result<(), CalibError> {
        let texp_ns = exposure_s.unwrap_or(0.0) * 1e9;
        // Block 0 is the dark pair, 1..=levels the temporal levels, then the
        // spatial stacks.
        let dropped = |i: usize, names: &[String]| names.len() == 2 && i > temporal_levels;
        for (i, (_, _, names)) in self.blocks.iter().enumerate() {
            if dropped(i, names) {
                for n in names {
                    let p = self.dir.join(n);
                    std::fs::remove_file(&p).map_err(|e| CalibError::file(&p, e))?;
                }
            }
        }
        let mut s = String::new();
        s.push_str("# EMVA 1288 dataset written by gloam calibrate ptc\n");
        s.push_str("# Release 4.0 linear module; descriptor syntax of the EMVA 1288 reference implementation\n");
        s.push_str("# irradiance sweep at constant exposure; photons = mean photons per pixel\n");
        s.push_str("v 3.1\n");
        s.push_str(&format!("n {bits} {w} {h}\n"));
        for (i, (kind, photons, names)) in self.blocks.iter().enumerate() {
            if dropped(i, names) {
                continue;
            }
            match kind {
                'b' => s.push_str(&format!(
                    "b {texp_ns:.1} {:.6}\n",
                    photons.unwrap_or(f64::NAN)
                )),
                _ => s.push_str(&format!("d {texp_ns:.1}\n")),
            }
            for n in names {
                s.push_str(&format!("i {n}\n"));
            }
        }
        crate::report::write_text(&self.dir.join("emva1288_descriptor.txt"), &s)
    }
}
