//! A render as a front end asks for it, written once: `gloam render` (the
//! CLI) and `gloam.render` (Python) parse their arguments into a
//! [`RenderRequest`] (plain data), [`RenderRequest::validate`] makes every
//! check either of them made, and [`ValidRender::run`] performs the recipe
//! (scene → settings → camera → prepare → render → layers → outputs →
//! `report.json`), telling the front end what happens through [`Events`].
//! The front ends only parse and present, so a bad input is refused with
//! the same message from both, and a render makes the same decisions
//! (ripgrep's `LowArgs` → `HiArgs` is the model).

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use gloam_scene::Scene;
use gloam_trace::{PrepObserver, RenderOutput, RenderSettings, TraceError};
use serde::Serialize;

use crate::camera_goal::CameraGoal;
use crate::exposure::ExposureTarget;
use crate::frames::{FrameCapture, scene_utc};
use crate::output::write_atomic;
use crate::render::{
    DEFAULT_TARGET_ERROR, RenderError, RenderJob, Rendered, SettingArgs, TargetErrorSource,
};
use crate::tile::{TileSpec, write_tile_info};
use crate::{FrameFormat, Provenance};
use gloam_io::{OutputSet, ReadLog, RunGuard};
use gloam_sensor::ResolvedSensor;

/// The scene of a request: a file to read, or one a front end holds
/// already (Python's `Scene`).
#[derive(Clone)]
pub enum SceneInput {
    /// A scene file (TOML), read by [`RenderRequest::validate`].
    File(PathBuf),
    /// A loaded scene, the file it was read from (or named after) and the
    /// seconds its load took (report.json `timings_s.load`).
    Loaded {
        scene: Arc<Scene>,
        path: PathBuf,
        load_s: f64,
    },
}

impl SceneInput {
    /// The scene file, as given.
    pub fn path(&self) -> &Path {
        match self {
            SceneInput::File(p) | SceneInput::Loaded { path: p, .. } => p,
        }
    }
}

impl std::fmt::Debug for SceneInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SceneInput::File(p) => f.debug_tuple("File").field(p).finish(),
            SceneInput::Loaded { path, .. } => f.debug_tuple("Loaded").field(path).finish(),
        }
    }
}

/// Two inputs are equal when they name the same file (and, when loaded,
/// hold the same scene).
impl PartialEq for SceneInput {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (SceneInput::File(a), SceneInput::File(b)) => a == b,
            (
                SceneInput::Loaded {
                    scene: a, path: p, ..
                },
                SceneInput::Loaded {
                    scene: b, path: q, ..
                },
            ) => Arc::ptr_eq(a, b) && p == q,
            _ => false,
        }
    }
}

/// The camera a render is for and, when it writes an output set, how its
/// frames are captured (`gloam render --sensor … --frames …`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraOptions {
    /// Preset name or sensor TOML; `None` the scene's own `sensor`, `"none"`
    /// radiance only ([`camera_of`](crate::render::camera_of)).
    pub sensor: Option<String>,
    /// `png` (default), `fits` or `tiff`.
    pub frame_format: Option<String>,
    pub frames: Option<u32>,
    pub gain: Option<f64>,
    pub agc: bool,
    pub no_noise: bool,
    /// `--exposure auto`.
    pub auto_exposure: bool,
}

/// Where a render's files go: an output set published whole at `path`.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputDir {
    pub path: PathBuf,
    /// Replace a previous gloam output set there.
    pub force: bool,
}

/// A render as asked for, before any check.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderRequest {
    pub scene: SceneInput,
    pub settings: SettingArgs,
    pub camera: CameraOptions,
    /// `K/N`: only tile K of N (radiance only, plus `tile.json`).
    pub tile: Option<String>,
    /// One radiance layer per light group.
    pub layers: bool,
    /// The output set; `None` writes nothing (the arrays and the report
    /// are returned, as Python's `render` gives them).
    pub out: Option<OutputDir>,
}

impl RenderRequest {
    /// A request for `scene` with no settings, the scene's camera and no
    /// output set.
    pub fn new(scene: SceneInput) -> Self {
        Self {
            scene,
            settings: SettingArgs::default(),
            camera: CameraOptions::default(),
            tile: None,
            layers: false,
            out: None,
        }
    }

    /// Reads the scene (if a file) and checks everything that can be
    /// checked before the render: the tile, the settings, the camera (its
    /// sensor loads, its gain is in range), flags that need a camera or
    /// exclude each other, and `--target-error camera`'s conditions.
    /// `reads` is the run's log: the scene, the files it names and the
    /// sensor file are noted there, and the run's provenance lists them.
    pub fn validate(&self, reads: &ReadLog) -> Result<ValidRender, RenderError> {
        let c = &self.camera;
        // Pairs that exclude each other (clap refuses them on the command
        // line first; a request from elsewhere is checked here).
        let conflicts = [
            (
                "--tile",
                self.tile.is_some(),
                "--sensor",
                c.sensor.is_some(),
            ),
            ("--tile", self.tile.is_some(), "--layers", self.layers),
            ("--gain", c.gain.is_some(), "--agc", c.agc),
            ("--exposure", c.auto_exposure, "--gain", c.gain.is_some()),
            ("--exposure", c.auto_exposure, "--agc", c.agc),
        ];
        if let Some((a, _, b, _)) = conflicts.into_iter().find(|(_, x, _, y)| *x && *y) {
            return Err(RenderError::Conflict { a, b });
        }
        let (scene, scene_path, load_s) = match &self.scene {
            SceneInput::File(path) => {
                let t = Instant::now();
                let scene = Arc::new(gloam_scene::load(path, reads)?);
                (scene, path.clone(), t.elapsed().as_secs_f64())
            }
            SceneInput::Loaded {
                scene,
                path,
                load_s,
            } => (Arc::clone(scene), path.clone(), *load_s),
        };
        let tile = self.tile.as_deref().map(TileSpec::parse).transpose()?;
        let settings = self.settings.settings()?;
        let frame_format = c.frame_format()?;
        // Read once: the detected band, the camera goal and the capture
        // share it.
        let camera = crate::resolve_scene_sensor(c.sensor.as_deref(), &scene, &scene_path, reads)?;
        // A tile is traced with the camera's band all the same (the effect
        // plan weighs every band, so a tile makes the whole render's
        // decisions) but captures nothing.
        let capture = (camera.as_ref().filter(|_| tile.is_none())).map(|_| c.capture(frame_format));
        let valid = ValidRender {
            scene,
            scene_path,
            load_s,
            target_error_source: None,
            camera,
            capture,
            camera_k: self.settings.camera_target(),
            tile,
            layers: self.layers,
            out: self.out.clone(),
            settings,
            reads: reads.clone(),
        };
        match valid.frame_capture() {
            Some(fc) => fc.check()?,
            None => c.refuse_flags_without_camera(valid.tile.is_some())?,
        }
        // `--target-error camera[:K]`: each pixel to the camera's own noise.
        if valid.camera_k.is_some() && (valid.capture.is_none() || valid.layers) {
            return Err(RenderError::CameraTarget(
                "--target-error camera needs a camera (--sensor NAME, or the scene's sensor), the whole image (no --tile) and no --layers",
            ));
        }
        // Frames without temporal noise hide no render error: the bound would
        // be the noisy camera's, so the render's noise would show (it was
        // accepted and reported as within the camera's).
        if valid.camera_k.is_some() && valid.capture.as_ref().is_some_and(|c| !c.noise) {
            return Err(RenderError::CameraTarget(
                "--target-error camera with --no-noise: frames without temporal noise hide no render error; give --target-error E (a relative error) or --spp N",
            ));
        }
        // A tile or a capture keeps the fixed default spp (see with_default_error).
        let whole_image = valid.tile.is_none() && valid.capture.is_none();
        let (settings, source) = (self.settings).with_default_error(valid.settings, whole_image)?;
        Ok(ValidRender {
            settings,
            target_error_source: source,
            ..valid
        })
    }
}

/// How a render with a camera captures its frames.
#[derive(Clone, Debug)]
pub(crate) struct Capture {
    pub(crate) frames: u32,
    pub(crate) gain: Option<f64>,
    pub(crate) agc: bool,
    pub(crate) noise: bool,
    pub(crate) auto_exposure: Option<ExposureTarget>,
    pub(crate) frame_format: FrameFormat,
}

impl Capture {
    /// The capture through `sensor` with noise seed `seed`.
    pub(crate) fn through<'a>(&self, sensor: &'a ResolvedSensor, seed: u64) -> FrameCapture<'a> {
        FrameCapture {
            sensor,
            frames: self.frames,
            gain: self.gain,
            agc: self.agc,
            noise: self.noise,
            seed,
            auto_exposure: self.auto_exposure,
            frame_format: self.frame_format,
        }
    }
}

impl CameraOptions {
    /// The `--frame-format` asked for (PNG when not given).
    pub(crate) fn frame_format(&self) -> Result<FrameFormat, RenderError> {
        match self.frame_format.as_deref() {
            None => Ok(FrameFormat::default()),
            Some(v) => v.parse().map_err(|source| RenderError::FrameFormat {
                value: v.to_string(),
                source,
            }),
        }
    }

    /// How the frames are captured (the camera aside).
    pub(crate) fn capture(&self, frame_format: FrameFormat) -> Capture {
        Capture {
            frames: self.frames.unwrap_or(1),
            gain: self.gain,
            agc: self.agc,
            noise: !self.no_noise,
            auto_exposure: self.auto_exposure.then(ExposureTarget::default),
            frame_format,
        }
    }

    /// Refuses a camera flag given where there is no camera (`tile`: a
    /// `--tile` render, which captures nothing).
    pub(crate) fn refuse_flags_without_camera(&self, tile: bool) -> Result<(), RenderError> {
        let given = [
            ("--frames", self.frames.is_some()),
            ("--gain", self.gain.is_some()),
            ("--agc", self.agc),
            ("--no-noise", self.no_noise),
            ("--exposure", self.auto_exposure),
            ("--frame-format", self.frame_format.is_some()),
        ];
        match given.into_iter().find(|(_, g)| *g) {
            Some((flag, _)) => Err(RenderError::NeedsCamera { flag, tile }),
            None => Ok(()),
        }
    }
}

/// A checked request: the scene loaded, the settings resolved, ready to
/// [`run`](ValidRender::run).
pub struct ValidRender {
    pub scene: Arc<Scene>,
    /// The scene file as given (report.json `scene`).
    pub scene_path: PathBuf,
    pub load_s: f64,
    /// The settings, the default error target applied.
    pub settings: RenderSettings,
    pub target_error_source: Option<TargetErrorSource>,
    /// The camera the render is for ([`camera_of`](crate::render::camera_of)), read once.
    pub camera: Option<ResolvedSensor>,
    capture: Option<Capture>,
    /// `K` of `--target-error camera[:K]`.
    pub camera_k: Option<f64>,
    pub tile: Option<TileSpec>,
    pub layers: bool,
    pub out: Option<OutputDir>,
    /// The run's log of what it read (its provenance's inputs).
    reads: ReadLog,
}

/// What a render tells its front end as it runs. Every method has a
/// default that does nothing: a quiet front end implements none.
pub trait Events: Sync {
    /// The observer of the preparation's steps (BVH, sources, pilot,
    /// cache), for a spinner or a progress callback.
    fn preparation(&self) -> Option<PrepObserver> {
        None
    }
    /// `done` of `total` tiles traced.
    fn tiles(&self, _done: u64, _total: u64) {}
    /// The tracing ended (done, stopped or failed).
    fn traced(&self) {}
    /// True once the render should stop (Ctrl-C): it ends with
    /// [`TraceError::Interrupted`].
    fn stop(&self) -> bool {
        false
    }
    /// A line for the user (the capture's notes).
    fn note(&self, _line: &str) {}
}

/// Events that tell nobody.
pub struct Quiet;

impl Events for Quiet {}

/// What a render made and reported.
pub struct RenderDone {
    pub rendered: Rendered,
    /// The `report.json` document (also written to the output set, if any).
    pub report: RenderReport,
    /// Seconds from the scene's load to the prepared render.
    pub prepare_s: f64,
}

impl ValidRender {
    /// The capture of a render with a camera (not a tile).
    pub fn frame_capture(&self) -> Option<FrameCapture<'_>> {
        let (sensor, c) = (self.camera.as_ref()?, self.capture.as_ref()?);
        Some(c.through(sensor, self.settings.seed))
    }

    /// Renders, and with an output set writes the images, `tile.json`,
    /// `report.json`, `layers.json` and the camera's frames, then
    /// publishes the set, which `guard` removes if the run is interrupted.
    pub fn run(self, events: &dyn Events, guard: &RunGuard) -> Result<RenderDone, RenderError> {
        let t_start = Instant::now();
        let mut provenance = Provenance::of_this_run(&self.reads);
        // Refused up front when the directory is in use; the files appear
        // at once when the set is published.
        let set = (self.out.as_ref())
            .map(|o| OutputSet::begin(&o.path, o.force, false, guard))
            .transpose()?;
        let job = RenderJob {
            camera: self.camera.as_ref(),
            observer: events.preparation(),
            layers: self.layers,
            ..RenderJob::new(&self.scene, &self.settings)
        };
        let prepared = job.prepare()?;
        if events.stop() {
            return Err(TraceError::Interrupted.into());
        }
        let prepare_s = self.load_s + t_start.elapsed().as_secs_f64();
        let full = prepared.image_size();
        let rows: Option<Range<u32>> = self.tile.map(|t| t.rows(full.1)).transpose()?;
        let capture = self.frame_capture();
        let goal = match (self.camera_k, &capture) {
            (Some(k), Some(c)) => Some(CameraGoal::new(&prepared, k, c)),
            _ => None,
        };
        let progress = |done, total| events.tiles(done, total);
        let stop = || events.stop();
        let rendered = match &goal {
            Some(g) => prepared.render_to_goal(g, &progress, &stop),
            None => prepared.render(rows, &progress, &stop),
        };
        events.traced();
        let rendered = rendered?;

        let t_write = Instant::now();
        if let Some(set) = &set {
            rendered.write_images(set.dir())?;
            if let Some(t) = self.tile {
                let (rows, out) = (rendered.rows.clone(), &rendered.radiance);
                write_tile_info(set.dir(), t, rows, full, &self.scene_path, out)?;
            }
        }
        let write_s = match set {
            Some(_) => t_write.elapsed().as_secs_f64(),
            None => 0.0,
        };
        // The scene's OBJ, spectrum and instance files were read after the
        // provenance was first taken.
        provenance.add_inputs_read();
        let mut report = RenderReport {
            target_error_source: self.target_error_source,
            camera_target: goal.as_ref().and_then(|g| g.report(&rendered)),
            ..RenderReport::of(
                &self.scene_path,
                &self.scene,
                &rendered,
                self.load_s,
                write_s,
                provenance.clone(),
            )
        };
        if let Some(set) = set {
            let dir = set.dir();
            if let Some(layers) = &rendered.layers {
                let mut index = layers.index(self.settings.seed);
                index.provenance = Some(provenance.clone());
                let index = serde_json::to_string_pretty(&index).map_err(RenderError::Encode)?;
                write_atomic(&dir.join("layers.json"), index.as_bytes())?;
            }
            if let (Some(capture), Some(detected)) = (&capture, &rendered.detected) {
                let utc = scene_utc(&self.scene);
                let captured = capture.run(detected, dir, Some(&provenance), utc)?;
                for line in &captured.notes {
                    events.note(line);
                }
                report.sensor_capture = Some(captured.report);
                // No path: `dir` is the hidden staging directory until the
                // set is published.
                let (n, sensor) = (capture.frames, capture.sensor.name());
                events.note(&format!("captured {n} frame(s) through '{sensor}'"));
            }
            write_atomic(&dir.join("report.json"), report.to_pretty()?.as_bytes())?;
            set.publish(&provenance, None)?;
        }
        Ok(RenderDone {
            rendered,
            report,
            prepare_s,
        })
    }
}

impl RenderDone {
    /// What the front end prints when the render is done: the default
    /// error target, the camera target, the cache's bias (each when it
    /// applies), then the figures, `total_s` the wall time the user waited
    /// and `out` where the files went.
    pub fn lines(&self, out: &Path, total_s: f64) -> Vec<String> {
        let (rendered, report) = (&self.rendered, &self.report);
        let e = &rendered.radiance.error;
        let mut lines = Vec::new();
        if report.target_error_source == Some(TargetErrorSource::Default) {
            lines.push(format!(
                "no --spp or --target-error: sampled to the default per-pixel error {:.0} % (--target-error {DEFAULT_TARGET_ERROR}): estimated RMS {:.2} %, mean {:.1} spp; --spp N renders a fixed count",
                100.0 * DEFAULT_TARGET_ERROR,
                100.0 * e.rel_std_error_rms_target_pixels.unwrap_or(e.rel_std_error_rms),
                e.mean_spp,
            ));
        }
        if let Some(t) = &report.camera_target {
            lines.push(format!(
                "--target-error camera:{}: each pixel rendered until its variance is under {:.0} % of the camera's frame variance at gain {:.4}: added {:.1} % (median), {:.1} % (99th percentile); mean {:.1} spp",
                t.k,
                100.0 * t.asked_added_variance_fraction,
                t.gain,
                100.0 * t.added_variance_fraction_median,
                100.0 * t.added_variance_fraction_p99,
                t.mean_spp.unwrap_or(f64::NAN),
            ));
        }
        if let Some(b) = &e.bias
            && let Some(band) = b.bands.first()
        {
            lines.push(format!(
                "radiosity cache bias ({}): {:+.2} % ± {:.2} % of the signal, measured against path tracing at {} pixels (report.json: error.bias); the per-pixel errors above and in stderr.npy are noise only",
                band.band,
                100.0 * band.relative_bias,
                100.0 * band.relative_bias_std_error,
                b.pixels
            ));
        }
        let s = &rendered.radiance.stats;
        let prep_s = self.prepare_s;
        lines.push(format!(
            "rendered {}×{}×{} bands in {:.2} s ({} rays, {:.3e} rays/s); {:.2} s in all, {:.2} s ({:.0} %) of it preparation (scene, BVH, pilot, cache) → {}",
            s.width,
            s.height,
            s.bands,
            s.trace_seconds,
            s.rays.total(),
            s.rays_per_second,
            total_s,
            prep_s,
            100.0 * prep_s / total_s.max(1e-9),
            out.display()
        ));
        lines
    }
}

fn to_value(v: &impl Serialize) -> Result<serde_json::Value, RenderError> {
    serde_json::to_value(v).map_err(RenderError::Encode)
}

/// A render's `report.json`: settings, effect plan, timings, rays,
/// per-band means, where the error target came from and the provenance.
/// Its keys are a user contract (scripts read them): add, never rename.
#[derive(Clone, Debug, Serialize)]
pub struct RenderReport {
    /// The scene file, as given.
    pub scene: String,
    pub units: String,
    pub meters_per_unit: f64,
    pub image: ImageReport,
    pub outputs: OutputsReport,
    pub error: gloam_trace::render::ErrorSummary,
    pub settings: RenderSettings,
    pub effect_plan: gloam_scene::plan::EffectPlan,
    pub timings_s: Timings,
    pub rays: gloam_trace::RayCounts,
    pub rays_total: u64,
    pub rays_per_second: f64,
    pub threads: usize,
    pub wavelengths: usize,
    pub emission_lines: usize,
    pub triangles: usize,
    pub area_sources: usize,
    pub point_sources: usize,
    pub sky: Option<gloam_trace::SkySummary>,
    pub interreflection: gloam_trace::plan::InterreflectionDecision,
    pub preparation: gloam_trace::Preparation,
    /// Mean and peak radiance of each band, by name.
    pub bands: BTreeMap<String, BandReport>,
    /// `"default"` when no sampling was named and the render sampled to
    /// [`crate::DEFAULT_TARGET_ERROR`], `"given"`, or null for a fixed spp.
    pub target_error_source: Option<TargetErrorSource>,
    /// `--target-error camera[:K]`: what the camera's noise allowed and
    /// what the render added ([`CameraGoal::report`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_target: Option<crate::camera_goal::CameraTarget>,
    /// With a camera: what it made of the scene ([`FrameCapture::run`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_capture: Option<crate::capture::SensorCaptureReport>,
    pub provenance: Provenance,
}

#[derive(Clone, Debug, Serialize)]
pub struct ImageReport {
    pub width: u32,
    pub height: u32,
    pub bands: Vec<String>,
}

/// What each output file holds.
#[derive(Clone, Debug, Serialize)]
pub struct OutputsReport {
    #[serde(rename = "radiance.tiff")]
    pub radiance_tiff: &'static str,
    #[serde(rename = "radiance.npy")]
    pub radiance_npy: &'static str,
    #[serde(rename = "preview.png")]
    pub preview_png: &'static str,
    #[serde(rename = "stderr.npy")]
    pub stderr_npy: &'static str,
    #[serde(rename = "stderr.tiff")]
    pub stderr_tiff: &'static str,
    #[serde(rename = "spp.npy")]
    pub spp_npy: &'static str,
}

impl Default for OutputsReport {
    fn default() -> Self {
        Self {
            radiance_tiff: "float32, one page per band, W m^-2 sr^-1",
            radiance_npy: "float64, band x row x column, W m^-2 sr^-1",
            preview_png: "first band, scaled to its 99.5th percentile, gamma 2.2",
            stderr_npy: "float64, band x row x column, W m^-2 sr^-1: estimated standard error of each pixel",
            stderr_tiff: "float32, one page per band: the same standard error",
            spp_npy: "uint32, row x column: camera samples per pixel",
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct Timings {
    pub load: f64,
    pub prepare: f64,
    pub trace: f64,
    pub write: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct BandReport {
    pub mean_radiance_w_m2_sr: f64,
    pub max_radiance_w_m2_sr: f64,
}

impl RenderReport {
    /// The report of `rendered` (a render of `scene`, read from
    /// `scene_path` in `load_s` seconds, written in `write_s`), with no
    /// error-target source or camera target yet.
    pub fn of(
        scene_path: &Path,
        scene: &Scene,
        rendered: &Rendered,
        load_s: f64,
        write_s: f64,
        provenance: Provenance,
    ) -> Self {
        let out: &RenderOutput = &rendered.radiance;
        let bands = (out.band_names.iter().enumerate())
            .map(|(b, name)| {
                let img = out.radiance.index_axis(ndarray::Axis(0), b);
                let band = BandReport {
                    mean_radiance_w_m2_sr: img.mean().unwrap_or(0.0),
                    max_radiance_w_m2_sr: img.iter().copied().fold(0.0, f64::max),
                };
                (name.clone(), band)
            })
            .collect();
        let s = &out.stats;
        Self {
            scene: scene_path.display().to_string(),
            units: scene.units.as_str().to_string(),
            meters_per_unit: scene.meters_per_unit,
            image: ImageReport {
                width: s.width,
                height: s.height,
                bands: out.band_names.clone(),
            },
            outputs: OutputsReport::default(),
            error: out.error.clone(),
            settings: out.settings.clone(),
            effect_plan: rendered.plan.clone(),
            timings_s: Timings {
                load: load_s,
                prepare: s.prepare_seconds,
                trace: s.trace_seconds,
                write: write_s,
            },
            rays: s.rays,
            rays_total: s.rays.total(),
            rays_per_second: s.rays_per_second,
            threads: s.threads,
            wavelengths: s.wavelengths,
            emission_lines: s.emission_lines,
            triangles: s.triangles,
            area_sources: s.area_sources,
            point_sources: s.point_sources,
            sky: s.sky.clone(),
            interreflection: s.interreflection.clone(),
            preparation: s.preparation.clone(),
            bands,
            target_error_source: None,
            camera_target: None,
            sensor_capture: None,
            provenance,
        }
    }

    /// The report as a JSON value: every object's keys in order, as
    /// report.json has always had them.
    pub fn to_value(&self) -> Result<serde_json::Value, RenderError> {
        to_value(self)
    }

    /// `report.json`'s text.
    pub fn to_pretty(&self) -> Result<String, RenderError> {
        serde_json::to_string_pretty(&self.to_value()?).map_err(RenderError::Encode)
    }
}
