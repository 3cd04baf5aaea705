//! `--target-error camera[:K]` (issue 45): render each pixel only as well as
//! the camera can see it.
//!
//! An intensified camera's frame at 1–10 photoelectrons a pixel is 30–100 %
//! noise of its own; a render error far below that is time no frame can
//! show. So each pixel's Monte Carlo bound is set from the camera's own
//! temporal noise at that pixel, for the gain, gate, exposure and ND in
//! effect: the render's variance, carried through the chain's transfer, must
//! stay below `K²` of the frame's temporal variance (`K` = 0.3 by default:
//! under 10 % added frame variance). With the render's detected-band
//! standard error `σ` (e⁻ s⁻¹ m⁻² sr⁻¹), the étendue·time `E` (m² sr s),
//! the mean DN per photoelectron `s` and the frame's temporal variance
//! `V(pe)` (DN², [`gloam_sensor::Chain::temporal_variance_dn2_from_pe`]:
//! shot × excess noise, EBI, CCD shot and dark noise, read noise,
//! quantisation) at `pe = E · L` photoelectrons, the bound is
//!
//! `σ ≤ K · √V(E L) / (s E)`.
//!
//! Conservative choices: the blur of the optics and the tube, which averages
//! a render's per-pixel errors more than it does the frame's shot noise, is
//! left out, and so is the MCP's compression (linear range; pixels the
//! frame clips have no bound: their render error is never seen); vignetting is
//! left out too (it would lower `pe` at the corners, and with it their
//! bound, by at most √cos⁴θ). The gain is the one the capture uses: fixed
//! (`--gain`), chosen by `--exposure auto` on the estimate so far, or — with
//! AGC — the level the loop settles to on that estimate (noise-free frames,
//! at most [`AGC_SETTLE_FRAMES`]). That decision is made once, on the first
//! round's image; the bounds follow each round's estimate.

use std::sync::OnceLock;

use gloam_sensor::{Camera, SensorConfig};
use ndarray::{Array2, ArrayView2};

use crate::exposure::ExposureTarget;

/// `K` of `--target-error camera`: render variance under `K²` = 9 % of the
/// frame's temporal variance.
pub const DEFAULT_CAMERA_K: f64 = 0.3;

/// Least `K` of `--target-error camera:K`: render variance under 10⁻⁴ of
/// the camera's. Below it the bound is no camera's noise (1e-300 squared
/// to 0, and the summary said "under 0 %").
pub const MIN_CAMERA_K: f64 = 0.01;

/// A pixel needs no bound once its estimate is this many times the
/// photoelectrons that clip the frame.
pub const CLIP_MARGIN: f64 = 2.0;

/// Most noise-free frames the AGC is run for to find where it settles.
pub const AGC_SETTLE_FRAMES: u32 = 200;

/// A render's error target: relative per pixel, or the camera's noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TargetError {
    /// `--target-error E`: relative standard error per pixel.
    Relative(f64),
    /// `--target-error camera[:K]`.
    Camera { k: f64 },
}

/// Why `--target-error` was not understood.
#[derive(Debug, thiserror::Error)]
#[error(
    "--target-error {0:?}: expected a relative error (e.g. 0.02), `camera` or `camera:K` with K in [0.01, 1] (render variance under K² of the camera's frame variance)"
)]
pub struct BadTargetError(pub String);

impl std::str::FromStr for TargetError {
    type Err = BadTargetError;
    fn from_str(s: &str) -> Result<Self, BadTargetError> {
        let bad = || BadTargetError(s.to_string());
        let t = s.trim();
        let lower = t.to_ascii_lowercase();
        if lower == "camera" {
            return Ok(Self::Camera {
                k: DEFAULT_CAMERA_K,
            });
        }
        if let Some(k) = lower.strip_prefix("camera:") {
            let k: f64 = k.trim().parse().map_err(|_| bad())?;
            return if (MIN_CAMERA_K..=1.0).contains(&k) {
                Ok(Self::Camera { k })
            } else {
                Err(bad())
            };
        }
        t.parse().map(Self::Relative).map_err(|_| bad())
    }
}

/// The camera as the capture will run it, for the bounds.
pub struct CameraGoal {
    band: usize,
    k: f64,
    config: SensorConfig,
    gain: Option<f64>,
    agc: bool,
    auto_exposure: Option<ExposureTarget>,
    settled: OnceLock<Result<Settled, String>>,
}

/// The chain at the gain in effect, and what the bounds need of it.
pub struct Settled {
    /// The frame's temporal variance at no light and its growth per
    /// photoelectron, DN² (affine in the photoelectrons in the linear
    /// range: every term is shot noise of the signal or a constant).
    variance_dn2_at_zero: f64,
    variance_dn2_per_pe: f64,
    /// Photoelectrons per pixel per frame that clip the output: a pixel
    /// above them shows no render error at all.
    saturation_pe: f64,
    /// Gain in effect.
    pub gain: f64,
    /// Étendue × exposure, m² sr s: photoelectrons per detected unit.
    pub etendue_m2_sr_s: f64,
    /// Mean DN per photoelectron.
    pub dn_per_pe: f64,
}

impl Settled {
    /// Frame temporal variance (DN²) at detected radiance `detected`.
    pub fn frame_variance_dn2(&self, detected: f64) -> f64 {
        let pe = detected.max(0.0) * self.etendue_m2_sr_s;
        self.variance_dn2_at_zero + self.variance_dn2_per_pe * pe
    }

    /// The render's detected-band variance as frame variance, DN².
    pub fn render_variance_dn2(&self, std_error: f64) -> f64 {
        (self.dn_per_pe * self.etendue_m2_sr_s * std_error).powi(2)
    }
}

impl CameraGoal {
    /// The goal for `prepared`'s detected band (its last) through the
    /// capture's camera: `sensor` (preset or TOML) with the capture's gain,
    /// AGC and automatic exposure.
    pub fn new(
        prepared: &crate::render::PreparedRender,
        k: f64,
        capture: &crate::frames::FrameCapture<'_>,
    ) -> Result<Self, gloam_sensor::ConfigError> {
        let config = gloam_sensor::load_preset_or_file(capture.sensor)?;
        Ok(Self {
            band: prepared.tracer().wavelengths().band_names.len() - 1,
            k,
            config,
            gain: capture.gain,
            agc: capture.agc,
            auto_exposure: capture.auto_exposure,
            settled: OnceLock::new(),
        })
    }

    /// `K`: the render's standard error under K × the frame's.
    pub fn k(&self) -> f64 {
        self.k
    }

    /// The chain as settled on the first image the render gave (None until
    /// the render asked for bounds).
    pub fn settled(&self) -> Option<&Settled> {
        self.settled.get().and_then(|s| s.as_ref().ok())
    }

    /// `report.json`'s `camera_target` for `rendered` (rendered to this
    /// goal): [`summary`] with the samples and the tracing time spent;
    /// `None` before the goal settled or without the detected band.
    pub fn report(&self, rendered: &crate::render::Rendered) -> Option<serde_json::Value> {
        let (s, d, se) = (
            self.settled()?,
            rendered.detected.as_ref()?,
            rendered.detected_std_error.as_ref()?,
        );
        let mut v = summary(self.k, s, d, se);
        v["mean_spp"] = rendered.radiance.error.mean_spp.into();
        v["trace_seconds"] = rendered.radiance.stats.trace_seconds.into();
        Some(v)
    }

    /// The gain the capture would run at for `detected`.
    fn settle(&self, detected: ArrayView2<f64>) -> Result<Settled, String> {
        let mut config = self.config.clone();
        let image: Array2<f64> = detected.mapv(|v| v.max(0.0));
        let mut gain = self.gain;
        if let Some(target) = &self.auto_exposure {
            let c = crate::exposure::choose(&config, &image, target).map_err(|e| e.to_string())?;
            crate::exposure::apply(&mut config, &c);
            gain = gain.or(Some(c.gain));
        }
        config.noise.seed = 0;
        let mut camera = Camera::new(config).map_err(|e| e.to_string())?;
        camera.set_noise(false);
        if let Some(g) = gain {
            camera
                .set_override_gain(Some(g))
                .map_err(|e| e.to_string())?;
        }
        if self.agc && self.gain.is_none() {
            camera.set_agc(true);
            let mut last = camera.gain();
            for _ in 0..AGC_SETTLE_FRAMES {
                camera
                    .capture_detected(image.view())
                    .map_err(|e| e.to_string())?;
                let g = camera.gain();
                let settled = (g - last).abs() <= 1e-4 * g.abs().max(1e-300);
                last = g;
                if settled {
                    break;
                }
            }
        }
        let g = camera.gain();
        let chain = camera.chain();
        // The chain's variance is affine in photoelectrons: two points of
        // it (each builds the post-noise blur's kernel, so not per pixel).
        let at_zero = chain.temporal_variance_dn2_from_pe(0.0, g);
        let at_1000 = chain.temporal_variance_dn2_from_pe(1000.0, g);
        let dn_per_pe = chain.mean_dn_per_photoelectron(g);
        let saturation_pe = (chain.saturation_dn(g) - chain.expected_mean_dn_from_pe(0.0, g))
            / dn_per_pe.max(1e-300);
        Ok(Settled {
            saturation_pe,
            variance_dn2_at_zero: at_zero,
            variance_dn2_per_pe: (at_1000 - at_zero) / 1000.0,
            gain: g,
            etendue_m2_sr_s: chain.etendue_m2_sr_s,
            dn_per_pe,
        })
    }
}

impl gloam_trace::PixelGoal for CameraGoal {
    fn band(&self) -> usize {
        self.band
    }

    fn bounds(&self, image: ArrayView2<f64>) -> Result<Vec<f64>, String> {
        let s = self
            .settled
            .get_or_init(|| self.settle(image))
            .as_ref()
            .map_err(|e| format!("--target-error camera: {e}"))?;
        let per_unit = s.dn_per_pe * s.etendue_m2_sr_s;
        if !(per_unit.is_finite() && per_unit > 0.0) {
            return Err(format!(
                "--target-error camera: the camera gives {per_unit:e} DN per unit of detected radiance at gain {}",
                s.gain
            ));
        }
        Ok(image
            .iter()
            .map(|&l| {
                if l * s.etendue_m2_sr_s >= CLIP_MARGIN * s.saturation_pe {
                    // Clipped in every frame: its render error is not seen.
                    // (With a margin: an estimate of few samples near the
                    // clip may yet fall below it.)
                    f64::INFINITY
                } else {
                    self.k * s.frame_variance_dn2(l).sqrt() / per_unit
                }
            })
            .collect())
    }
}

/// What `report.json`'s `camera_target` states: the chosen K, the gain the
/// bounds were set at, and the render's variance as a fraction of the
/// frame's temporal variance per pixel (median, 99th percentile, largest)
/// over the pixels the frame does not clip and that some sample lit, and
/// how many it clips and how many are dark (every sample zero: their
/// stated error is a bound borrowed from their neighbours, and they stop
/// at `DARK_MAX_SPP` samples).
pub fn summary(
    k: f64,
    s: &Settled,
    detected: &Array2<f64>,
    std_error: &Array2<f64>,
) -> serde_json::Value {
    let mut f: Vec<f64> = detected
        .iter()
        .zip(std_error.iter())
        .filter(|(l, _)| **l > 0.0 && **l * s.etendue_m2_sr_s < s.saturation_pe)
        .map(|(&l, &se)| {
            let v = s.frame_variance_dn2(l);
            if v > 0.0 {
                s.render_variance_dn2(se) / v
            } else {
                0.0
            }
        })
        .collect();
    f.sort_by(f64::total_cmp);
    let q = |p: f64| crate::fit::quantile_sorted(&f, p);
    serde_json::json!({
        "k": k,
        "asked_added_variance_fraction": k * k,
        "gain": s.gain,
        "added_variance_fraction_median": q(0.5),
        "added_variance_fraction_p99": q(0.99),
        "added_variance_fraction_max": f.last().copied().unwrap_or(0.0),
        "clipped_pixels": detected
            .iter()
            .filter(|&&l| l * s.etendue_m2_sr_s >= s.saturation_pe)
            .count(),
        "dark_pixels": detected.iter().filter(|&&l| l <= 0.0).count(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn target_error_words() {
        let p = |s: &str| s.parse::<TargetError>();
        assert_eq!(p("0.02").unwrap(), TargetError::Relative(0.02));
        assert_eq!(p("camera").unwrap(), TargetError::Camera { k: 0.3 });
        assert_eq!(p("Camera:0.5").unwrap(), TargetError::Camera { k: 0.5 });
        assert_eq!(p("camera:0.01").unwrap(), TargetError::Camera { k: 0.01 });
        for bad in [
            "camera:0",
            "camera:-1",
            "camera:2",
            "camera:x",
            "cam",
            "camera:nan",
            "camera:1e-300",
            "camera:0.00999",
        ] {
            let e = p(bad).unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains("camera:K"), "{e}");
        }
    }
}
