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
//!
//! **Sequences** (`gloam sequence --target-error camera`) render each pose
//! once into light-group layers, and each frame mixes them with its own
//! weights ([`Mixes`]). Frame `i`'s image at a pixel is `M_i = Σ_g w_gi
//! L_g`; its render error is taken as the whole's relative error times
//! `M_i` (exact where one group lights the pixel). Each frame then bounds
//! the whole's standard error by `K √V(E M_i) / (s E) · L / M_i`, which
//! falls as `M_i` grows, so the tightest frame is the brightest one the
//! pixel sees: the bound is that frame's ("sequences use the brightest
//! frame a pixel sees"). A pixel is left unbounded only if it clips in
//! every frame, or no frame weights its light. The camera's level (gain,
//! `--exposure auto`, AGC) is decided once, on frame 0's pose: automatic
//! exposure on frame 0's mix, as the capture chooses it, the AGC on the
//! brightest image.

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

/// Most distinct frame weightings a sequence's goal keeps per pose; beyond
/// them it keeps the groups' largest and smallest weights over the frames
/// (a brighter and a dimmer image than any frame's: a tighter bound).
pub const MAX_MIXES: usize = 4096;

/// The frames that mix one pose's layers: each distinct weighting of the
/// light groups (frame 0's apart, for automatic exposure).
#[derive(Clone, Debug, Default)]
pub struct Mixes {
    distinct: Vec<Vec<f64>>,
    seen: std::collections::HashSet<Vec<u64>>,
    max: Vec<f64>,
    min: Vec<f64>,
    first: Option<Vec<f64>>,
    frames: u64,
    /// More distinct weightings than [`MAX_MIXES`]: the extremes stand in.
    overflow: bool,
}

impl Mixes {
    /// Adds one frame's weights (one per light group, in the scene's
    /// order); frame 0's is the first added.
    pub fn add(&mut self, weights: &[f64]) {
        if self.frames == 0 {
            self.first = Some(weights.to_vec());
            self.max = weights.to_vec();
            self.min = weights.to_vec();
        }
        self.frames += 1;
        for (i, &w) in weights.iter().enumerate() {
            if let Some(m) = self.max.get_mut(i) {
                *m = m.max(w);
            }
            if let Some(m) = self.min.get_mut(i) {
                *m = m.min(w);
            }
        }
        if self.overflow {
            return;
        }
        if self
            .seen
            .insert(weights.iter().map(|w| w.to_bits()).collect())
        {
            self.distinct.push(weights.to_vec());
        }
        if self.seen.len() > MAX_MIXES {
            self.overflow = true;
            self.distinct = Vec::new();
            self.seen = Default::default();
        }
    }

    /// Frames added.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Per pixel of `groups`' images, the brightest and the dimmest frame's
    /// mix and frame 0's (row-major).
    fn images(&self, groups: &[ArrayView2<f64>]) -> Result<[Array2<f64>; 3], String> {
        let Some(shape) = groups.first().map(|g| g.dim()) else {
            return Err("a sequence's goal needs the light groups' images".into());
        };
        let first = self
            .first
            .as_ref()
            .ok_or("a sequence's goal needs its frames")?;
        if first.len() != groups.len() || groups.iter().any(|g| g.dim() != shape) {
            return Err(format!(
                "{} light-group images for frames of {} weights",
                groups.len(),
                first.len()
            ));
        }
        // A weighting of the groups' largest weights bounds every frame
        // from above, of their smallest from below (when the distinct
        // weightings were too many to keep).
        let set: Vec<&Vec<f64>> = match self.overflow {
            true => vec![&self.max, &self.min],
            false => self.distinct.iter().collect(),
        };
        let (mut hi, mut lo) = (Array2::zeros(shape), Array2::zeros(shape));
        let mut f0 = Array2::zeros(shape);
        let mut px = vec![0.0; groups.len()];
        for ((r, c), h) in hi.indexed_iter_mut() {
            for (v, g) in px.iter_mut().zip(groups) {
                *v = g[[r, c]];
            }
            let mix = |w: &[f64]| w.iter().zip(&px).map(|(w, l)| w * l).sum::<f64>();
            let (a, b) = set
                .iter()
                .fold((f64::NEG_INFINITY, f64::INFINITY), |(a, b), w| {
                    let m = mix(w);
                    (a.max(m), b.min(m))
                });
            *h = a;
            lo[[r, c]] = b;
            f0[[r, c]] = mix(first);
        }
        Ok([hi, lo, f0])
    }

    /// The largest weight any frame gives any group.
    fn max_weight(&self) -> f64 {
        self.max.iter().copied().fold(0.0, f64::max)
    }
}

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
    /// A sequence's frames (the render is layered).
    mixes: Option<Mixes>,
}

/// The chain at the gain in effect, and what the bounds need of it.
#[derive(Clone, Debug)]
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
    /// capture's camera (read and checked once, when the run resolved it)
    /// with the capture's gain, AGC and automatic exposure.
    pub fn new(
        prepared: &crate::render::PreparedRender,
        k: f64,
        capture: &crate::frames::FrameCapture<'_>,
    ) -> Self {
        let config = capture.sensor.config().clone();
        Self {
            band: prepared.tracer().wavelengths().band_names.len() - 1,
            k,
            config,
            gain: capture.gain,
            agc: capture.agc,
            auto_exposure: capture.auto_exposure,
            settled: OnceLock::new(),
            mixes: None,
        }
    }

    /// The goal for one pose of a sequence: `prepared` renders its layers,
    /// `config` is the capture's sensor configured for the sequence (frame
    /// rate, exposure window), `mixes` the weightings of the frames that
    /// show this pose, and `settled` the camera's level if an earlier pose
    /// decided it (see the module docs).
    pub fn for_sequence(
        prepared: &crate::render::PreparedRender,
        k: f64,
        capture: &crate::frames::FrameCapture<'_>,
        config: SensorConfig,
        mixes: Mixes,
        settled: Option<Settled>,
    ) -> Self {
        let lock = OnceLock::new();
        if let Some(s) = settled {
            let _ = lock.set(Ok(s));
        }
        Self {
            band: prepared.tracer().wavelengths().band_names.len() - 1,
            k,
            config,
            gain: capture.gain,
            agc: capture.agc,
            auto_exposure: capture.auto_exposure,
            settled: lock,
            mixes: Some(mixes),
        }
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
    pub fn report(&self, rendered: &crate::render::Rendered) -> Option<CameraTarget> {
        let (s, d, se) = (
            self.settled()?,
            rendered.detected.as_ref()?,
            rendered.detected_std_error.as_ref()?,
        );
        let mut v = summary(self.k, s, d, se);
        v.mean_spp = Some(rendered.radiance.error.mean_spp);
        v.trace_seconds = Some(rendered.radiance.stats.trace_seconds);
        Some(v)
    }

    /// `report.json`'s `camera_target` for a sequence's pose rendered to
    /// this goal: [`summary`] at each pixel's brightest frame (the whole's
    /// standard error scaled to that frame's mix), with the samples and
    /// the tracing time spent; `None` before the goal settled.
    pub fn report_layered(
        &self,
        whole: &Array2<f64>,
        std_error: &Array2<f64>,
        groups: &[Array2<f64>],
        mean_spp: f64,
        trace_seconds: f64,
    ) -> Option<CameraTarget> {
        let (s, mixes) = (self.settled()?, self.mixes.as_ref()?);
        let views: Vec<_> = groups.iter().map(|g| g.view()).collect();
        let [hi, _, _] = mixes.images(&views).ok()?;
        let se = ndarray::Zip::from(std_error)
            .and(whole)
            .and(&hi)
            .map_collect(|&se, &w, &m| if w > 0.0 { se * m / w } else { se });
        let mut v = summary(self.k, s, &hi, &se);
        v.mean_spp = Some(mean_spp);
        v.trace_seconds = Some(trace_seconds);
        v.frames = Some(mixes.frames());
        v.at = Some("each pixel's brightest frame of this pose");
        Some(v)
    }

    /// The gain the capture would run at for `detected`.
    fn settle(&self, detected: ArrayView2<f64>) -> Result<Settled, String> {
        self.settle_on(detected, detected)
    }

    /// The gain the capture would run at: automatic exposure chosen on
    /// `exposed` (a sequence's frame 0), the AGC settled on `detected`.
    fn settle_on(
        &self,
        exposed: ArrayView2<f64>,
        detected: ArrayView2<f64>,
    ) -> Result<Settled, String> {
        let mut config = self.config.clone();
        let image: Array2<f64> = detected.mapv(|v| v.max(0.0));
        let mut gain = self.gain;
        if let Some(target) = &self.auto_exposure {
            let exposed: Array2<f64> = exposed.mapv(|v| v.max(0.0));
            let c =
                crate::exposure::choose(&config, &exposed, target).map_err(|e| e.to_string())?;
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
        if self.mixes.is_some() {
            return Err(
                "--target-error camera: a sequence's goal needs a layered render (its light groups' images)".into(),
            );
        }
        let s = self
            .settled
            .get_or_init(|| self.settle(image))
            .as_ref()
            .map_err(|e| format!("--target-error camera: {e}"))?;
        let per_unit = per_unit(s)?;
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

    fn bounds_layered(
        &self,
        whole: ArrayView2<f64>,
        groups: &[ArrayView2<f64>],
    ) -> Result<Vec<f64>, String> {
        let Some(mixes) = &self.mixes else {
            return self.bounds(whole);
        };
        let bad = |e: String| format!("--target-error camera: {e}");
        let [hi, lo, first] = mixes.images(groups).map_err(bad)?;
        let s = self
            .settled
            .get_or_init(|| self.settle_on(first.view(), hi.view()))
            .as_ref()
            .map_err(|e| bad(e.clone()))?;
        let per_unit = per_unit(s)?;
        let w_max = mixes.max_weight();
        let clip = CLIP_MARGIN * s.saturation_pe;
        Ok(ndarray::Zip::from(&whole)
            .and(&hi)
            .and(&lo)
            .map_collect(|&l, &m, &m_lo| {
                if m_lo * s.etendue_m2_sr_s >= clip {
                    // Clipped in every frame.
                    f64::INFINITY
                } else if l <= 0.0 {
                    // Dark so far: the camera's floor, for the frame that
                    // weights the pixel's light most.
                    if w_max > 0.0 {
                        self.k * s.frame_variance_dn2(0.0).sqrt() / per_unit / w_max
                    } else {
                        f64::INFINITY
                    }
                } else if m <= 0.0 {
                    // No frame weights this pixel's light.
                    f64::INFINITY
                } else {
                    // The brightest frame's bound on its mix, as a bound
                    // on the whole (the mix's error is `m / l` of it). A
                    // frame brighter still that clips is held to it too:
                    // tighter, never looser.
                    self.k * s.frame_variance_dn2(m).sqrt() / per_unit * l / m
                }
            })
            .into_raw_vec_and_offset()
            .0)
    }
}

/// DN per unit of detected radiance, or why the camera gives none.
fn per_unit(s: &Settled) -> Result<f64, String> {
    let per_unit = s.dn_per_pe * s.etendue_m2_sr_s;
    if per_unit.is_finite() && per_unit > 0.0 {
        Ok(per_unit)
    } else {
        Err(format!(
            "--target-error camera: the camera gives {per_unit:e} DN per unit of detected radiance at gain {}",
            s.gain
        ))
    }
}

/// Widest trial render [`estimate`] makes, pixels: the pilot's grid (64 ×
/// 48 camera rays) is its size.
pub const ESTIMATE_WIDTH_PX: f64 = 64.0;

/// Most samples a pixel of [`estimate`]'s trial renders takes (the
/// render's `max_spp` if lower): it bounds the estimate's cost (a town
/// of lamps seen 64 pixels wide otherwise sampled its pixels to 1 024).
/// Pixels that stop there are counted (`pixels_at_trial_cap`): where
/// there are many, the estimate is a lower bound.
pub const ESTIMATE_MAX_SPP: u32 = 64;

/// Why [`estimate`] could not run.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
}

/// `gloam plan`'s estimate of a camera run before rendering: two trial
/// renders of `scene` at the pilot's size (at most [`ESTIMATE_WIDTH_PX`]
/// wide, the field of view kept; at most [`ESTIMATE_MAX_SPP`]) through `capture`'s camera with
/// `settings` — one to the camera's noise (`K`, first round 2 spp unless
/// `spp_fixed`), one to the 2 % default
/// ([`crate::render::DEFAULT_TARGET_ERROR`], `spp` as the settings give
/// it) — and what they predict for the full image: samples per pixel
/// (per-pixel targets do not depend on the image size, to the extent a
/// pixel's variance does not), rays and tracing time (scaled by the
/// pixels). A smaller pixel averages less of the scene, so both
/// predictions are low by the same cause; their ratio is the estimate.
pub fn estimate(
    scene: &gloam_scene::Scene,
    settings: &gloam_trace::RenderSettings,
    spp_fixed: bool,
    capture: &crate::frames::FrameCapture<'_>,
    k: f64,
) -> Result<CameraEstimate, EstimateError> {
    let (w, h) = (
        f64::from(scene.camera.width),
        f64::from(scene.camera.height),
    );
    let scale = settings.resolution_scale;
    let full_px = ((w * scale).round().max(1.0)) * ((h * scale).round().max(1.0));
    let mut trial = settings.clone();
    trial.resolution_scale = scale * (ESTIMATE_WIDTH_PX / (w * scale)).min(1.0);
    trial.max_spp = trial.max_spp.min(ESTIMATE_MAX_SPP);
    let run = |s: &gloam_trace::RenderSettings, goal_k: Option<f64>| {
        let job = crate::render::RenderJob {
            camera: Some(capture.sensor),
            ..crate::render::RenderJob::new(scene, s)
        };
        let prepared = job.prepare()?;
        match goal_k {
            Some(k) => {
                let goal = CameraGoal::new(&prepared, k, capture);
                let r = prepared.render_to_goal(&goal, &|_, _| {}, &|| false)?;
                let t = goal.report(&r);
                Ok::<_, EstimateError>((r, t))
            }
            None => Ok((prepared.render(None, &|_, _| {}, &|| false)?, None)),
        }
    };
    let mut cam = trial.clone();
    cam.target_error = None;
    if !spp_fixed {
        cam.spp = 2;
    }
    let (c, target) = run(&cam, Some(k))?;
    let mut rel = trial.clone();
    rel.target_error = Some(crate::render::DEFAULT_TARGET_ERROR);
    let (r, _) = run(&rel, None)?;
    let side = |o: &crate::render::Rendered| {
        let st = &o.radiance.stats;
        let px = f64::from(st.width) * f64::from(st.height);
        let per = full_px / px.max(1.0);
        EstimateSide {
            mean_spp: o.radiance.error.mean_spp,
            rays: st.rays.total() as f64 * per,
            trace_seconds: st.trace_seconds * per,
            pixels_at_trial_cap: o
                .radiance
                .spp
                .iter()
                .filter(|&&n| n >= ESTIMATE_MAX_SPP)
                .count(),
        }
    };
    let (cs, rs) = (side(&c), side(&r));
    let ratio = |a: f64, b: f64| if a > 0.0 { b / a } else { f64::NAN };
    let st = &c.radiance.stats;
    Ok(CameraEstimate {
        k,
        trial_width: st.width,
        trial_height: st.height,
        trial_max_spp: trial.max_spp,
        full_pixels: full_px,
        rays_saving: ratio(cs.rays, rs.rays),
        time_saving: ratio(cs.trace_seconds, rs.trace_seconds),
        camera: cs,
        default_2_percent: rs,
        gain: target.as_ref().map(|t| t.gain),
        added_variance_fraction_p99: target.as_ref().map(|t| t.added_variance_fraction_p99),
        method: "two trial renders at the pilot's size (field of view kept) through the camera, one to its noise and one to the 2 % default; spp as measured, rays and tracing time scaled by the full image's pixels",
    })
}

/// `gloam plan --target-error camera`'s estimate of a camera run's cost
/// (`camera_target_estimate` in `--json`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct CameraEstimate {
    pub k: f64,
    pub trial_width: u32,
    pub trial_height: u32,
    pub trial_max_spp: u32,
    pub full_pixels: f64,
    /// The trial rendered to the camera's noise.
    pub camera: EstimateSide,
    /// The trial rendered to the 2 % default.
    pub default_2_percent: EstimateSide,
    /// Default's rays / camera's rays.
    pub rays_saving: f64,
    /// Default's tracing time / camera's.
    pub time_saving: f64,
    pub gain: Option<f64>,
    pub added_variance_fraction_p99: Option<f64>,
    pub method: &'static str,
}

/// One trial render of [`CameraEstimate`], scaled to the full image.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct EstimateSide {
    pub mean_spp: f64,
    pub rays: f64,
    pub trace_seconds: f64,
    pub pixels_at_trial_cap: usize,
}

/// `report.json`'s `camera_target` ([`summary`], with what the render
/// spent).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CameraTarget {
    pub k: f64,
    pub asked_added_variance_fraction: f64,
    pub gain: f64,
    pub added_variance_fraction_median: f64,
    pub added_variance_fraction_p99: f64,
    pub added_variance_fraction_max: f64,
    pub clipped_pixels: usize,
    pub dark_pixels: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_spp: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trace_seconds: Option<f64>,
    /// A sequence's pose: how many frames its bound covers.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frames: Option<u64>,
    /// A sequence's pose: where the fractions were taken.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub at: Option<&'static str>,
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
) -> CameraTarget {
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
    CameraTarget {
        k,
        asked_added_variance_fraction: k * k,
        gain: s.gain,
        added_variance_fraction_median: q(0.5),
        added_variance_fraction_p99: q(0.99),
        added_variance_fraction_max: f.last().copied().unwrap_or(0.0),
        clipped_pixels: detected
            .iter()
            .filter(|&&l| l * s.etendue_m2_sr_s >= s.saturation_pe)
            .count(),
        dark_pixels: detected.iter().filter(|&&l| l <= 0.0).count(),
        mean_spp: None,
        trace_seconds: None,
        frames: None,
        at: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sequence's bound at each pixel is the tightest of its frames'
    /// bounds, each computed here frame by frame (every frame, duplicates
    /// and all) from the chain's variance as the still's goal computes it:
    /// the frame's mix `M_i`, its bound `K √V(M_i) / (s E)` scaled to the
    /// whole image's error by `L / M_i`. The Gen III camera at a fixed
    /// gain 100; two light groups; five frames (one repeated, one with
    /// both groups off, one with the lamp at twice its intensity).
    #[test]
    fn a_sequence_s_bound_is_its_tightest_frame_s() {
        use gloam_trace::PixelGoal;
        let weights = [[1.0, 0.0], [1.0, 1.0], [0.5, 2.0], [0.0, 0.0], [1.0, 1.0]];
        let mut mixes = Mixes::default();
        for w in &weights {
            mixes.add(w);
        }
        assert_eq!((mixes.frames(), mixes.distinct.len()), (5, 4));
        let goal = CameraGoal {
            band: 0,
            k: 0.3,
            config: gloam_sensor::load_preset_or_file("gen3-gaas-iccd", &gloam_io::ReadLog::off())
                .unwrap(),
            gain: Some(100.0),
            agc: false,
            auto_exposure: None,
            settled: OnceLock::new(),
            mixes: Some(mixes),
        };
        // Detected radiance per group, set in photoelectrons a frame (at
        // gain 100 the CCD clips at ~7): moonlight and a lamp, from the
        // read noise's range to the shot noise's, and one pixel lit by
        // neither.
        let pre = goal.settle(Array2::zeros((1, 1)).view()).unwrap();
        let per_pe = 1.0 / pre.etendue_m2_sr_s;
        let moon = Array2::from_shape_fn((3, 4), |(r, c)| match (r, c) {
            (0, 0) => 0.0,
            _ => 0.002 * ((1 + r * 4 + c) as f64).powi(2) * per_pe,
        });
        let lamp = Array2::from_shape_fn((3, 4), |(r, c)| match (r, c) {
            (0, _) => 0.0,
            _ => 0.5 * (r * 4 + c) as f64 / (1 + c) as f64 * per_pe,
        });
        let whole = &moon + &lamp;
        let got = goal
            .bounds_layered(whole.view(), &[moon.view(), lamp.view()])
            .unwrap();
        let s = goal.settled().unwrap().clone();
        let (e, k) = (s.etendue_m2_sr_s, 0.3);
        let per_unit = s.dn_per_pe * e;
        assert!(per_unit > 0.0 && s.saturation_pe > 0.0);
        // Every pixel's light stays below the clip in every frame here
        // (checked), so no frame leaves a pixel unbounded.
        let mut bright = 0;
        for ((r, c), &l) in whole.indexed_iter() {
            let (m, p) = (moon[[r, c]], lamp[[r, c]]);
            let per_frame = weights.iter().map(|w| {
                let mix = w[0] * m + w[1] * p;
                assert!(mix * e < CLIP_MARGIN * s.saturation_pe);
                if l <= 0.0 {
                    // A dark pixel: the camera's floor on the mix, whose
                    // error is the largest weight's times the whole's.
                    let w_max = w[0].max(w[1]);
                    k * s.frame_variance_dn2(0.0).sqrt() / per_unit / w_max
                } else if mix <= 0.0 {
                    f64::INFINITY
                } else {
                    k * s.frame_variance_dn2(mix).sqrt() / per_unit * l / mix
                }
            });
            let want = per_frame.fold(f64::INFINITY, f64::min);
            let g = got[r * 4 + c];
            assert!(want.is_finite(), "({r}, {c})");
            assert!((g / want - 1.0).abs() < 1e-12, "({r}, {c}): {g} vs {want}");
            bright += usize::from(s.variance_dn2_per_pe * l * e > 10.0 * s.variance_dn2_at_zero);
        }
        // The test spans the shot-noise range, not only the read noise.
        assert!((3..11).contains(&bright), "{bright}");
        // A still's goal at the same gain on the brightest frame's image
        // gives the same bound on that frame's mix.
        let still = CameraGoal {
            mixes: None,
            settled: OnceLock::new(),
            ..goal
        };
        let brightest = ndarray::Zip::from(&moon)
            .and(&lamp)
            .map_collect(|&m, &p| (m + p).max(0.5 * m + 2.0 * p));
        let one = still.bounds(brightest.view()).unwrap();
        let (l, b) = (whole[[2, 3]], brightest[[2, 3]]);
        assert!((one[11] * l / b / got[11] - 1.0).abs() < 1e-12);
        // Light no frame shows is not bounded; light clipped in every
        // frame neither.
        let mut off = Mixes::default();
        off.add(&[1.0, 0.0]);
        let clip = s.saturation_pe / e * 3.0;
        let goal = CameraGoal {
            mixes: Some(off),
            settled: OnceLock::new(),
            ..still
        };
        let g = Array2::from_elem((1, 2), 0.0);
        let lamp_only = Array2::from_shape_vec((1, 2), vec![1e12, 0.0]).unwrap();
        let moon_clip = Array2::from_shape_vec((1, 2), vec![0.0, clip]).unwrap();
        let whole = &lamp_only + &moon_clip + &g;
        let b = goal
            .bounds_layered(whole.view(), &[moon_clip.view(), lamp_only.view()])
            .unwrap();
        assert_eq!(b, [f64::INFINITY, f64::INFINITY]);
    }

    /// Past [`MAX_MIXES`] distinct weightings the groups' extremes stand
    /// in: a brighter image than any frame's, never a dimmer one.
    #[test]
    fn too_many_weightings_keep_the_extremes() {
        let mut m = Mixes::default();
        for i in 0..=MAX_MIXES {
            let t = i as f64 / MAX_MIXES as f64;
            m.add(&[t, 1.0 - t]);
        }
        assert!(m.overflow && m.distinct.is_empty());
        let a = Array2::from_elem((1, 1), 2.0);
        let b = Array2::from_elem((1, 1), 3.0);
        let [hi, lo, first] = m.images(&[a.view(), b.view()]).unwrap();
        assert_eq!((hi[[0, 0]], lo[[0, 0]], first[[0, 0]]), (5.0, 0.0, 3.0));
    }

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
