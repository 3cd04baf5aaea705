//! One render, written once: the settings from a front end's arguments,
//! then scene → effect plan → detected band → tracer → rows → the
//! camera's detected radiance, and the `report.json` document. The CLI's
//! `gloam render` and the Python package run [`RenderJob`] (and a sweep can), so
//! a render makes the same decisions and reports the same figures
//! whichever way it was started.

use std::ops::Range;
use std::path::Path;

use gloam_scene::Scene;
use gloam_scene::plan::{Effect, EffectPlan, names};
use gloam_trace::{
    LayerError, LayerMap, PrepObserver, RenderOutput, RenderSettings, SettingsError, TraceError,
    Tracer,
};
use ndarray::Array2;

use crate::detected::{DetectedError, take_detected_band, with_detected_band};

/// Why a render could not run.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A setting given twice, as `--set KEY=…` and as its own flag (or
    /// keyword): which one wins would be a guess.
    #[error("`--set {pair}` and `{flag}` both set {key}: give one")]
    GivenTwice {
        pair: String,
        flag: String,
        key: String,
    },
    #[error("--threads must be at least 1")]
    NoThreads,
    #[error(transparent)]
    Settings(#[from] SettingsError),
    #[error(transparent)]
    Detected(#[from] DetectedError),
    #[error(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    Layers(#[from] LayerError),
    #[error("rows {start}..{end} are not rows of the {height}-row image")]
    Rows { start: u32, end: u32, height: u32 },
    // What a render request (`crate::request`) refuses or fails at.
    #[error(transparent)]
    Scene(#[from] gloam_scene::SceneError),
    #[error(transparent)]
    Tile(#[from] crate::tile::TileError),
    #[error("{a} and {b} exclude each other: give one")]
    Conflict { a: &'static str, b: &'static str },
    #[error("--frame-format `{value}`: expected png, fits or tiff")]
    FrameFormat {
        value: String,
        #[source]
        source: crate::frame_files::UnknownFrameFormat,
    },
    /// A camera flag given to a render without a camera would be ignored.
    #[error("{flag} needs a camera: give --sensor or a `sensor` entry in the scene{}",
        if *.tile { " (a --tile render captures no frames)" } else { "" })]
    NeedsCamera { flag: &'static str, tile: bool },
    #[error(transparent)]
    CaptureOptions(#[from] crate::CaptureOptionsError),
    /// `--target-error camera` where the render cannot meet it.
    #[error("{0}")]
    CameraTarget(&'static str),
    #[error(transparent)]
    OutputSet(#[from] gloam_io::OutputSetError),
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("encoding report.json")]
    Encode(#[source] serde_json::Error),
    #[error(transparent)]
    Capture(#[from] crate::CaptureError),
    /// `max_spp` that would not bound the render it was given to.
    #[error("`--set {pair}`: {why}")]
    MaxSpp { pair: String, why: String },
}

/// The render settings a front end was given: `KEY=VALUE` pairs (`--set`,
/// or the Python `settings` dict) and the flags that name one setting each.
/// With the `cli` feature these are `gloam render`'s flags, in this order.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct SettingArgs {
    /// Camera samples per pixel, fixed. Without it (or --target-error) a
    /// whole-image render without a camera capture samples to
    /// --target-error 0.02; tiles, sweeps, sequences and captures take 4.
    #[cfg_attr(feature = "cli", arg(long))]
    pub spp: Option<u32>,
    /// Seed of every random stream (default 0).
    #[cfg_attr(feature = "cli", arg(long))]
    pub seed: Option<u64>,
    /// Area-source estimator: analytic (default), solid-angle or dirsig2001.
    #[cfg_attr(feature = "cli", arg(long))]
    pub estimator: Option<String>,
    /// Any setting, KEY=VALUE (repeatable), e.g. --set recursion=2
    /// --set MAX_SOURCE_SAMPLES=200. See `crates/trace/README.md`.
    #[cfg_attr(feature = "cli", arg(long = "set", value_name = "KEY=VALUE"))]
    pub set: Vec<String>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[cfg_attr(feature = "cli", arg(long))]
    pub threads: Option<usize>,
    /// Sample each pixel adaptively until its estimated relative standard
    /// error is below this (e.g. 0.01; dark pixels relative to 5 % of the
    /// band mean; same as `--set target_error=E`), or with `camera[:K]`
    /// (a render with a camera) until the render's variance is under K²
    /// (default 0.3² = 9 %) of the camera's own frame variance at each pixel.
    #[cfg_attr(feature = "cli", arg(long, value_name = "E|camera[:K]"))]
    pub target_error: Option<crate::camera_goal::TargetError>,
    /// The effect plan's tolerance (default 0.005 of the band signal).
    #[cfg_attr(feature = "cli", arg(long))]
    pub tolerance: Option<f64>,
}

impl SettingArgs {
    /// The settings: defaults, then the pairs in order, then the flags. A
    /// setting given both as a pair and as its flag is refused.
    pub fn settings(&self) -> Result<RenderSettings, RenderError> {
        let refuse = |pairs: &[(&str, &str, bool)]| {
            pairs
                .iter()
                .filter(|(_, _, given)| *given)
                .try_for_each(|(key, flag, _)| refuse_both(&self.set, key, flag))
        };
        refuse(&[
            ("spp", "--spp", self.spp.is_some()),
            ("seed", "--seed", self.seed.is_some()),
            ("estimator", "--estimator", self.estimator.is_some()),
        ])?;
        // One key twice in `--set` (`spp=1` and `spp=2`): the last won
        // unseen. Refused, as a setting given by `--set` and its flag is.
        for (i, pair) in self.set.iter().enumerate() {
            let Some((key, _)) = pair.split_once('=') else {
                continue;
            };
            if let Some(first) = pair_setting(&self.set[..i], key.trim()) {
                return Err(RenderError::GivenTwice {
                    pair: pair.clone(),
                    flag: format!("--set {first}"),
                    key: key.trim().to_string(),
                });
            }
        }
        let mut s = RenderSettings::default();
        for pair in &self.set {
            s.set_pair(pair)?;
        }
        if let Some(v) = self.spp {
            s.set("spp", &v.to_string())?;
        }
        if let Some(v) = self.seed {
            s.seed = v;
        }
        if let Some(e) = &self.estimator {
            s.estimator = e.parse()?;
        }
        if let Some(t) = self.threads {
            if t < 1 {
                return Err(RenderError::NoThreads);
            }
            s.threads = Some(t);
        }
        refuse(&[
            (
                "target_error",
                "--target-error",
                self.target_error.is_some(),
            ),
            ("tolerance", "--tolerance", self.tolerance.is_some()),
        ])?;
        if let Some(crate::camera_goal::TargetError::Relative(e)) = self.target_error {
            // `{:?}`: `1e-300` stays short in the error (`{}` wrote 300 digits).
            s.set("target_error", &format!("{e:?}"))?;
        }
        if let Some(t) = self.tolerance {
            s.set("tolerance", &format!("{t:?}"))?;
        }
        Ok(s)
    }
}

/// The per-pixel error a whole-image render samples to when its front end
/// names neither a sample count nor an error target: a user asks for an
/// accuracy, not a count. 2 %: seconds on the office room (≈ 9 spp on
/// average, about twice the time of 4 spp) for 1.6–1.9 % achieved per-pixel
/// error against the converged reference, where 4 spp gives 3.3–3.9 %; 1 %
/// would take about four times as long again.
pub const DEFAULT_TARGET_ERROR: f64 = 0.02;

/// Where a render's error target came from (report.json
/// `target_error_source`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TargetErrorSource {
    /// `--target-error` or `--set target_error=…` (also `none`).
    Given,
    /// Nothing named the sampling: [`DEFAULT_TARGET_ERROR`].
    Default,
}

impl SettingArgs {
    /// `K` of `--target-error camera[:K]`, if given.
    pub fn camera_target(&self) -> Option<f64> {
        match self.target_error {
            Some(crate::camera_goal::TargetError::Camera { k }) => Some(k),
            _ => None,
        }
    }

    /// Whether the arguments fix the sample count (`--spp` or `spp=`).
    pub fn names_spp(&self) -> bool {
        self.spp.is_some() || pair_setting(&self.set, "spp").is_some()
    }

    /// Whether the arguments name the sampling: `--spp`, `--target-error`,
    /// or `spp`/`target_error` as a pair.
    pub fn names_sampling(&self) -> bool {
        let pair = |key| pair_setting(&self.set, key).is_some();
        self.spp.is_some() || self.target_error.is_some() || pair("spp") || pair("target_error")
    }

    /// A render's `settings` (from [`settings`](Self::settings)) and where
    /// its error target came from: for a `whole_image` render (one that
    /// nothing else must match bit for bit) whose arguments name no
    /// sampling, [`DEFAULT_TARGET_ERROR`]. Only `gloam render`
    /// without `--tile` and without a camera capture, and the Python
    /// `render` without a camera, take this. Every other caller of
    /// [`settings`](Self::settings) keeps the fixed default `spp`: an
    /// adaptive render's dark-pixel floor and pooled error estimate are
    /// image-wide, so tiles (`--tile`/`merge`, sweeps, Slurm) would not merge
    /// bit-identically; sequences, calibration and captures must give the
    /// same radiance for a frame whichever command rendered it; and
    /// `plan`/`probe` take no samples per pixel.
    pub fn with_default_error(
        &self,
        mut s: RenderSettings,
        whole_image: bool,
    ) -> Result<(RenderSettings, Option<TargetErrorSource>), RenderError> {
        // `--target-error camera[:K]`: the first round is one sample per
        // replicate unless the count is fixed (a camera's noise mostly asks
        // for no more; see camera_goal.rs).
        let source = if self.camera_target().is_some() {
            if !self.names_spp() {
                s.spp = 2;
            }
            Some(TargetErrorSource::Given)
        } else if self.names_sampling() || !whole_image {
            s.target_error.map(|_| TargetErrorSource::Given)
        } else {
            s.target_error = Some(DEFAULT_TARGET_ERROR);
            Some(TargetErrorSource::Default)
        };
        self.hold_to_max_spp(&mut s, source.is_some())?;
        Ok((s, source))
    }

    /// A `max_spp` the user gave, held to what it can mean: it caps an
    /// adaptive render's samples, first round included (that round's
    /// default count is lowered to it; a fixed `spp` above it is refused,
    /// as is a `max_spp` beside a fixed-count render, which would ignore
    /// it). At least 2: an adaptive render measures its error from two
    /// replicates.
    fn hold_to_max_spp(&self, s: &mut RenderSettings, adaptive: bool) -> Result<(), RenderError> {
        let Some(pair) = pair_setting(&self.set, "max_spp") else {
            return Ok(());
        };
        let refuse = |why: String| {
            Err(RenderError::MaxSpp {
                pair: pair.clone(),
                why,
            })
        };
        if !adaptive {
            return refuse(format!(
                "max_spp caps an adaptive render's samples (--target-error); this render takes a fixed {} per pixel: give --spp alone, or --target-error beside max_spp",
                s.spp
            ));
        }
        if s.max_spp < 2 {
            return refuse(
                "an adaptive render takes at least 2 samples a pixel (two replicates measure its error)"
                    .into(),
            );
        }
        // The first round samples two replicates of ⌈spp/2⌉ each.
        let first_round = s.spp.div_ceil(2) * 2;
        if first_round > s.max_spp {
            if self.names_spp() {
                return refuse(format!(
                    "max_spp {} is below spp {}, the samples every pixel takes in the first round ({first_round}: two replicates of {}): give max_spp ≥ {first_round}",
                    s.max_spp,
                    s.spp,
                    first_round / 2
                ));
            }
            s.spp = s.max_spp / 2 * 2;
        }
        Ok(())
    }
}

/// The `--set` pair that sets `key` (case-insensitive), if any.
fn pair_setting<'a>(set: &'a [String], key: &str) -> Option<&'a String> {
    set.iter().find(|p| {
        p.split_once('=')
            .is_some_and(|(k, _)| k.trim().eq_ignore_ascii_case(key))
    })
}

/// Refuses a setting given twice, as `--set KEY=…` and as its own flag.
fn refuse_both(set: &[String], key: &str, flag: &str) -> Result<(), RenderError> {
    match pair_setting(set, key) {
        Some(pair) => Err(RenderError::GivenTwice {
            pair: pair.clone(),
            flag: flag.to_string(),
            key: key.to_string(),
        }),
        None => Ok(()),
    }
}

/// The camera a render of `scene` is made for: the one the caller names,
/// else the scene's own `sensor` entry. Every front end takes it so: the
/// effect plan weighs every band, the camera's detected band included, so
/// a render for a camera and one without are not bit-identical.
/// [`NO_CAMERA`] (`--sensor none`) asks for radiance only, even when the
/// scene names a camera.
pub fn camera_of<'a>(given: Option<&'a str>, scene: &'a Scene) -> Option<&'a str> {
    match given {
        Some(NO_CAMERA) => None,
        Some(g) => Some(g),
        None => scene.sensor.as_deref(),
    }
}

/// The plan's `sensor` effect for a render whose camera (`--sensor`) is not
/// the scene's own: the report names the camera the frames come from and
/// no other, one name everywhere.
fn camera_effect(camera: Option<&str>, scene_sensor: Option<&str>) -> Effect {
    let instead = match scene_sensor {
        Some(_) => "in place of the scene's own",
        None => "the scene names none",
    };
    match camera {
        Some(c) => Effect::new(
            names::SENSOR,
            true,
            format!(
                "sensor '{c}' (--sensor, {instead}; its stages are planned by the sensor crate)"
            ),
        ),
        None => Effect::new(
            names::SENSOR,
            false,
            format!(
                "--sensor {NO_CAMERA}: the output is at-aperture radiance, the scene's camera unused"
            ),
        ),
    }
}

/// The camera name that means "no camera: radiance only".
pub const NO_CAMERA: &str = "none";

/// A render to run: the scene, its settings and the camera it is for.
pub struct RenderJob<'a> {
    /// The scene as loaded (without the camera's band).
    pub scene: &'a Scene,
    pub settings: &'a RenderSettings,
    /// The camera whose detected band the render carries; see
    /// [`camera_of`].
    pub camera: Option<&'a crate::ResolvedSensor>,
    /// Told as preparation steps begin and end (a progress display).
    pub observer: Option<PrepObserver>,
    /// Also render one layer per light group (`--layers`, `layers.rs` in
    /// gloam-trace).
    pub layers: bool,
}

impl<'a> RenderJob<'a> {
    /// A job for `scene` with `settings`, no camera and no observer.
    pub fn new(scene: &'a Scene, settings: &'a RenderSettings) -> Self {
        Self {
            scene,
            settings,
            camera: None,
            observer: None,
            layers: false,
        }
    }

    /// Adds the camera's detected band and prepares the tracer (BVH,
    /// sources, pilot, cache) and the effect plan it runs.
    pub fn prepare(&self) -> Result<PreparedRender, RenderError> {
        let banded;
        let traced = match self.camera {
            Some(c) => {
                banded = with_detected_band(self.scene, c)?;
                &banded
            }
            None => self.scene,
        };
        let map = self.layers.then(|| LayerMap::of(self.scene));
        let observer = self.observer.clone();
        let tracer = match &map {
            // Layers: the emitters carry their groups and the cache is
            // solved per group at preparation (`layers.rs` in gloam-trace).
            Some(map) => Tracer::prepare_layered(traced, self.settings, observer, map)?,
            None => Tracer::prepare_observed(traced, self.settings, true, observer)?,
        };
        let mut plan = tracer.effect_plan(self.scene);
        let camera = self.camera.map(|c| c.name());
        if camera != self.scene.sensor.as_deref() {
            plan.extend([camera_effect(camera, self.scene.sensor.as_deref())]);
        }
        Ok(PreparedRender {
            tracer,
            plan,
            camera: self.camera.is_some(),
            layers: map.map(|m| (m, self.scene.light_groups.groups.clone())),
        })
    }

    /// [`RenderJob::prepare`], then the whole image.
    pub fn run(
        &self,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Rendered, RenderError> {
        self.prepare()?.render(None, progress, stop)
    }
}

/// A prepared render: the tracer and the effect plan it runs.
pub struct PreparedRender {
    tracer: Tracer,
    plan: EffectPlan,
    camera: bool,
    layers: Option<(LayerMap, Vec<gloam_scene::LightGroup>)>,
}

impl PreparedRender {
    /// The whole image's size `(width, height)` in pixels (after
    /// `resolution_scale`), which a tile's rows are taken from.
    pub fn image_size(&self) -> (u32, u32) {
        self.tracer.image_size()
    }

    pub fn tracer(&self) -> &Tracer {
        &self.tracer
    }

    pub fn plan(&self) -> &EffectPlan {
        &self.plan
    }

    /// Traces image rows `rows` (all for `None`; each pixel bit-identical
    /// to the whole image's) and splits the camera's detected band off.
    /// `progress(done, total)` is told per tile; once `stop()` returns
    /// true the render ends with [`TraceError::Interrupted`].
    pub fn render(
        mut self,
        rows: Option<Range<u32>>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Rendered, RenderError> {
        let image_size = self.image_size();
        let rows = rows.unwrap_or(0..image_size.1);
        if rows.start > rows.end || rows.end > image_size.1 {
            return Err(RenderError::Rows {
                start: rows.start,
                end: rows.end,
                height: image_size.1,
            });
        }
        // With layers, one pass gives the ordinary image (bit-identical)
        // and the layers.
        let t0 = std::time::Instant::now();
        let (radiance, layered) = match &self.layers {
            Some((map, _)) => {
                let (whole, layers) =
                    self.tracer
                        .render_layered(map, rows.clone(), progress, stop)?;
                (whole, Some(layers))
            }
            None => (
                self.tracer
                    .render_rows_until(rows.clone(), progress, stop)?,
                None,
            ),
        };
        let seconds = t0.elapsed().as_secs_f64();
        let layers = match (self.layers.take(), layered) {
            (Some((_, groups)), Some(outputs)) => Some(self.layers_from(groups, outputs, seconds)?),
            _ => None,
        };
        self.finish(radiance, layers, rows, image_size)
    }

    /// The whole image rendered to a per-pixel `goal` on the camera's
    /// detected band (`--target-error camera`, [`crate::camera_goal`]);
    /// otherwise as [`PreparedRender::render`]. Not with layers.
    pub fn render_to_goal(
        self,
        goal: &dyn gloam_trace::PixelGoal,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Rendered, RenderError> {
        if self.layers.is_some() || !self.camera {
            return Err(RenderError::Trace(TraceError::BadInput(
                "--target-error camera needs a render with a camera (--sensor NAME or the scene's sensor) and without --layers".into(),
            )));
        }
        let image_size = self.image_size();
        let radiance = self.tracer.render_to_goal(goal, progress, stop)?;
        self.finish(radiance, None, 0..image_size.1, image_size)
    }

    /// Splits the camera's detected band (and its standard error) off.
    fn finish(
        self,
        mut radiance: RenderOutput,
        layers: Option<Layers>,
        rows: Range<u32>,
        image_size: (u32, u32),
    ) -> Result<Rendered, RenderError> {
        let (detected, detected_std_error) = match self.camera {
            true => {
                let last = radiance.std_error.dim().0.saturating_sub(1);
                let se = radiance
                    .std_error
                    .index_axis(ndarray::Axis(0), last)
                    .to_owned();
                (Some(take_detected_band(&mut radiance)?), Some(se))
            }
            false => (None, None),
        };
        Ok(Rendered {
            radiance,
            layers,
            detected,
            detected_std_error,
            plan: self.plan,
            rows,
            image_size,
        })
    }
}

impl PreparedRender {
    /// The layers alone, all rows, without the ordinary image (their sum
    /// is that image): what `gloam sequence` needs. The job must have
    /// asked for [`RenderJob::layers`].
    pub fn render_layers(
        mut self,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Layers, RenderError> {
        let groups = self.layers.take().ok_or(LayerError::NoGroups)?;
        let rows = 0..self.image_size().1;
        self.layers_of(groups, rows, progress, stop)
    }

    /// The layers alone, all rows, sampled to a sequence's camera `goal`
    /// ([`crate::camera_goal::CameraGoal::for_sequence`]), and the pose's
    /// `camera_target` ([`crate::camera_goal::CameraGoal::report_layered`]).
    pub fn render_layers_to_goal(
        mut self,
        goal: &crate::camera_goal::CameraGoal,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<(Layers, Option<crate::camera_goal::CameraTarget>), RenderError> {
        let (map, groups) = self.layers.take().ok_or(LayerError::NoGroups)?;
        if !self.camera {
            return Err(RenderError::Trace(TraceError::BadInput(
                "--target-error camera needs a render with a camera (--sensor NAME or the scene's sensor)".into(),
            )));
        }
        let t0 = std::time::Instant::now();
        let (mut whole, outputs) = self
            .tracer
            .render_layered_to_goal(&map, goal, progress, stop)?;
        let layers = self.layers_from(groups, outputs, t0.elapsed().as_secs_f64())?;
        let last = whole.std_error.dim().0.saturating_sub(1);
        let se = whole
            .std_error
            .index_axis(ndarray::Axis(0), last)
            .to_owned();
        let detected = take_detected_band(&mut whole)?;
        let report = layers.detected.as_ref().and_then(|d| {
            goal.report_layered(
                &detected,
                &se,
                d,
                whole.error.mean_spp,
                whole.stats.trace_seconds,
            )
        });
        Ok((layers, report))
    }

    fn layers_of(
        &mut self,
        (map, groups): (LayerMap, Vec<gloam_scene::LightGroup>),
        rows: Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Layers, RenderError> {
        let t0 = std::time::Instant::now();
        let outputs = self.tracer.render_layers(&map, rows, progress, stop)?;
        self.layers_from(groups, outputs, t0.elapsed().as_secs_f64())
    }

    /// The traced layers with the camera's detected band split off each.
    fn layers_from(
        &self,
        groups: Vec<gloam_scene::LightGroup>,
        mut outputs: Vec<RenderOutput>,
        seconds: f64,
    ) -> Result<Layers, RenderError> {
        let detected = match self.camera {
            true => Some(
                outputs
                    .iter_mut()
                    .map(take_detected_band)
                    .collect::<Result<Vec<_>, _>>()?,
            ),
            false => None,
        };
        Ok(Layers {
            groups,
            outputs,
            detected,
            seconds,
        })
    }
}

/// One radiance image per light group (`--layers`), in the scene's group
/// order; they sum to [`Rendered::radiance`] (see gloam-trace `layers.rs`).
pub struct Layers {
    pub groups: Vec<gloam_scene::LightGroup>,
    pub outputs: Vec<RenderOutput>,
    /// Each layer's camera-detected radiance, e⁻ s⁻¹ m⁻² sr⁻¹ (rows ×
    /// columns), when the job had a camera: what `gloam sequence` mixes.
    pub detected: Option<Vec<Array2<f64>>>,
    /// Wall time of the one pass that traced the image and its layers
    /// (the per-group cache solves are in the preparation).
    pub seconds: f64,
}

impl Layers {
    /// `group × band × row × column` stacks of the layers' radiance and
    /// standard error.
    pub fn stacked(&self) -> (ndarray::Array4<f64>, ndarray::Array4<f64>) {
        let stack = |f: &dyn Fn(&RenderOutput) -> &ndarray::Array3<f64>| {
            let views: Vec<_> = self.outputs.iter().map(|o| f(o).view()).collect();
            ndarray::stack(ndarray::Axis(0), &views)
                .unwrap_or_else(|_| ndarray::Array4::zeros((0, 0, 0, 0)))
        };
        (stack(&|o| &o.radiance), stack(&|o| &o.std_error))
    }

    /// The `layers.json` index; the caller adds the provenance (and a
    /// sequence the pose).
    pub fn index(&self, seed: u64) -> LayersIndex {
        let groups = (self.groups.iter().zip(&self.outputs).enumerate())
            .map(|(index, (g, o))| LayerEntry {
                index,
                name: g.name.clone(),
                sources: g.sources.clone(),
                band_means_w_m2_sr: (o.band_names.iter().enumerate())
                    .map(|(b, n)| {
                        let band = o.radiance.index_axis(ndarray::Axis(0), b);
                        (n.clone(), band.mean().unwrap_or(0.0))
                    })
                    .collect(),
            })
            .collect();
        let bands = (self.outputs.first())
            .map(|o| o.band_names.clone())
            .unwrap_or_default();
        LayersIndex {
            radiance: "layers.npy",
            std_error: "layers_stderr.npy",
            shape: "group × band × row × column (index 0 is groups[0]), W m⁻² sr⁻¹ like radiance.npy",
            bands,
            groups,
            sum: "the layers sum to radiance.npy up to floating-point summation order (same seed, same samples; difference ≤ 1e-12 of the peak)",
            method: "one pass: each path traced once, as the ordinary render (same light tree, plan, samples, random numbers), each term it adds (a light sample, an emitter or the sky seen, cached interreflection) attributed to its emitter's group; a negative penumbra sum clamped on the whole with the groups scaled to follow; the interreflection cache gathered once and its bounce series solved per group with the whole scene's bounces and tail",
            seed,
            seconds: self.seconds,
            pose: None,
            provenance: None,
        }
    }
}

/// `layers.json`: what `layers.npy` and `layers_stderr.npy` hold and how
/// they were made.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LayersIndex {
    pub radiance: &'static str,
    pub std_error: &'static str,
    pub shape: &'static str,
    pub bands: Vec<String>,
    pub groups: Vec<LayerEntry>,
    pub sum: &'static str,
    pub method: &'static str,
    pub seed: u64,
    pub seconds: f64,
    /// A sequence's layers: the pose they were rendered in.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pose: Option<LayersPose>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub provenance: Option<crate::Provenance>,
}

/// One light group's layer in [`LayersIndex`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct LayerEntry {
    pub index: usize,
    pub name: String,
    pub sources: Vec<String>,
    /// Mean radiance of each band over the image, W m⁻² sr⁻¹.
    pub band_means_w_m2_sr: std::collections::BTreeMap<String, f64>,
}

/// The pose a sequence's `layers.json` describes.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LayersPose {
    /// Always 0: the layers are frame 0's.
    pub frame: u64,
    pub moves: Vec<gloam_scene::sequence::Pose>,
    pub note: &'static str,
}

/// What a render made.
pub struct Rendered {
    /// Radiance, standard error and samples of the scene's own bands.
    pub radiance: RenderOutput,
    /// With [`RenderJob::layers`].
    pub layers: Option<Layers>,
    /// The camera's detected-electron radiance, e⁻ s⁻¹ m⁻² sr⁻¹ (rows ×
    /// columns), when the job had a camera.
    pub detected: Option<Array2<f64>>,
    /// The detected band's standard error, same units and shape.
    pub detected_std_error: Option<Array2<f64>>,
    /// The effect plan the render ran.
    pub plan: EffectPlan,
    /// The rows rendered, of the whole image.
    pub rows: Range<u32>,
    /// The whole image's `(width, height)`.
    pub image_size: (u32, u32),
}

impl Rendered {
    /// Writes the radiance outputs into `dir`, each atomically:
    /// `radiance.tiff`/`.npy`, `stderr.tiff`/`.npy`, `spp.npy` and
    /// `preview.png` (see [`crate::RenderReport`]'s `outputs`).
    pub fn write_images(&self, dir: &Path) -> Result<(), crate::output::OutputError> {
        use crate::output::{write_npy, write_preview, write_tiff};
        let r = &self.radiance;
        write_tiff(&dir.join("radiance.tiff"), &r.radiance)?;
        write_npy(&dir.join("radiance.npy"), &r.radiance)?;
        write_tiff(&dir.join("stderr.tiff"), &r.std_error)?;
        write_npy(&dir.join("stderr.npy"), &r.std_error)?;
        write_npy(&dir.join("spp.npy"), &r.spp)?;
        write_preview(&dir.join("preview.png"), &r.radiance)?;
        if let Some(layers) = &self.layers {
            let (radiance, std_error) = layers.stacked();
            crate::output::write_npy(&dir.join("layers.npy"), &radiance)?;
            crate::output::write_npy(&dir.join("layers_stderr.npy"), &std_error)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_an_unnamed_whole_image_render_takes_the_default_error() {
        let args = |spp: Option<u32>, target: Option<f64>, set: &[&str]| SettingArgs {
            spp,
            target_error: target.map(crate::camera_goal::TargetError::Relative),
            set: set.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        };
        // As `gloam render` resolves them: the settings, then the default.
        let resolve = |a: SettingArgs, whole_image: bool| {
            a.with_default_error(a.settings().unwrap(), whole_image)
                .unwrap()
        };
        let (s, src) = resolve(args(None, None, &["seed=3"]), true);
        assert_eq!(s.target_error, Some(DEFAULT_TARGET_ERROR));
        assert_eq!(
            (s.spp, s.seed, src),
            (4, 3, Some(TargetErrorSource::Default))
        );
        // A tile, sweep or capture keeps the fixed default spp.
        let (s, src) = resolve(args(None, None, &[]), false);
        assert_eq!((s.target_error, s.spp, src), (None, 4, None));
        // Any named sampling is taken as given, `none` included.
        for (spp, target, set) in [
            (Some(4), None, &[][..]),
            (None, None, &["SPP = 8"][..]),
            (None, None, &["target_error=none"][..]),
        ] {
            let (s, src) = resolve(args(spp, target, set), true);
            assert_eq!((s.target_error, src), (None, None), "{spp:?} {set:?}");
        }
        let (s, src) = resolve(args(None, Some(0.05), &[]), true);
        assert_eq!(
            (s.target_error, src),
            (Some(0.05), Some(TargetErrorSource::Given))
        );
        let (s, _) = resolve(args(None, None, &["target_error=0.1"]), true);
        assert_eq!(s.target_error, Some(0.1));
    }

    #[test]
    fn max_spp_caps_the_first_round_or_is_refused() {
        let args = |spp: Option<u32>, set: &[&str]| SettingArgs {
            spp,
            set: set.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        };
        let resolve = |a: SettingArgs, whole_image: bool| {
            a.with_default_error(a.settings().unwrap(), whole_image)
        };
        // The default adaptive render's first round (4) lowered to the cap.
        // (Even: two replicates of 1 each, not of 2.)
        let (s, _) = resolve(args(None, &["max_spp=3"]), true).unwrap();
        assert_eq!(
            (s.spp, s.max_spp, s.target_error),
            (2, 3, Some(DEFAULT_TARGET_ERROR))
        );
        // An odd fixed spp takes one more in its first round.
        let e = resolve(args(Some(5), &["max_spp=5", "target_error=0.05"]), true);
        assert!(
            e.unwrap_err()
                .to_string()
                .contains("(6: two replicates of 3)")
        );
        // Above the first round: as given.
        let (s, _) = resolve(args(None, &["max_spp=64"]), true).unwrap();
        assert_eq!((s.spp, s.max_spp), (4, 64));
        let refused = |a: SettingArgs, whole: bool, says: &str| {
            let e = resolve(a, whole).unwrap_err().to_string();
            assert!(e.contains("max_spp") && e.contains(says), "{e}");
        };
        // A fixed spp above it, beside an error target.
        refused(
            args(Some(16), &["max_spp=8", "target_error=0.05"]),
            true,
            "below spp 16",
        );
        // A fixed-count render would ignore it: a named spp, a tile.
        refused(args(Some(16), &["max_spp=8"]), true, "fixed 16 per pixel");
        refused(args(None, &["max_spp=8"]), false, "fixed 4 per pixel");
        // One sample gives no second replicate.
        refused(args(None, &["max_spp=1"]), true, "at least 2");
    }

    #[test]
    fn the_plan_names_the_given_camera_and_no_other() {
        let scene_own = "sims/night/../sensors/gen2-s20-iccd.toml";
        let e = camera_effect(Some("gen3-gaas-iccd"), Some(scene_own));
        assert!(e.enabled && e.name == names::SENSOR);
        assert!(
            e.reason.starts_with("sensor 'gen3-gaas-iccd' (--sensor"),
            "{}",
            e.reason
        );
        assert!(!e.reason.contains("gen2"), "{}", e.reason);
        let off = camera_effect(None, Some(scene_own));
        assert!(
            !off.enabled && !off.reason.contains("gen2"),
            "{}",
            off.reason
        );
    }
}
