//! Scenes, the effect plan, renders and probes.

use gloam_io::ReadLog;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use numpy::prelude::*;
use numpy::{IntoPyArray, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use gloam_pipeline::camera_goal::TargetError;
use gloam_pipeline::request::CameraOptions;
use gloam_pipeline::{Events, RenderRequest, SceneInput, SettingArgs};
use gloam_trace::{DVec3, RenderSettings, Tracer};

use crate::convert::{Count, setting_pairs, to_py_as};
use crate::errors::{GloamError, OrPy};
use crate::interrupt::{ProgressSink, Reporter, detached_owned, detached_with_stop};
use crate::sensor::Sensor;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_class::<RenderResult>()?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(probe, m)?)?;
    Ok(())
}

/// A scene: TOML with inline geometry or OBJ files (docs/scene-format.md).
///
/// ``Scene.load(path)`` reads a file; ``Scene.from_toml(text)`` parses text
/// (OBJ paths relative to ``base_dir``). Errors name file, line and field.
#[pyclass(module = "gloam", frozen)]
pub struct Scene {
    /// Shared with a render's worker thread, which may outlive a call
    /// interrupted during preparation.
    pub scene: Arc<gloam_scene::Scene>,
    pub path: PathBuf,
    /// Seconds the load took (report.json `timings_s.load`).
    pub load_s: f64,
    /// What the load read (the file, its OBJ, spectra, placements): every
    /// render of the scene lists them in its provenance, as the CLI does.
    pub reads: ReadLog,
}

/// Render settings as the CLI builds them: `settings` pairs, then the flags.
fn settings(settings: Option<&Bound<'_, PyDict>>, flags: SettingArgs) -> PyResult<RenderSettings> {
    let set = setting_pairs(settings)?;
    SettingArgs { set, ..flags }.settings().or_py()
}

#[pymethods]
impl Scene {
    /// Loads a scene file (TOML); errors read ``scene.toml:15: materials.wall.reflectance: …``.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let t = Instant::now();
        let reads = ReadLog::new();
        let scene = Arc::new(gloam_scene::load(&path, &reads).or_py()?);
        let load_s = t.elapsed().as_secs_f64();
        Ok(Self {
            scene,
            path,
            load_s,
            reads,
        })
    }

    /// Parses scene TOML from a string. ``base_dir`` is where relative OBJ
    /// paths are found (default: the current directory); ``name`` is the
    /// file name errors report.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir = None, name = "scene.toml"))]
    fn from_toml(text: &str, base_dir: Option<PathBuf>, name: &str) -> PyResult<Self> {
        let path = base_dir.unwrap_or_else(|| PathBuf::from(".")).join(name);
        let t = Instant::now();
        let reads = ReadLog::new();
        let scene = Arc::new(gloam_scene::parse_str_noting(text, &path, &reads).or_py()?);
        let load_s = t.elapsed().as_secs_f64();
        Ok(Self {
            scene,
            path,
            load_s,
            reads,
        })
    }

    /// The effect plan: one ``Effect`` per effect (``name``, ``enabled``,
    /// ``reason``, ``estimated_share``; dicts with attribute access), as
    /// ``gloam plan --json`` prints its ``effects``. ``settings`` and
    /// ``tolerance`` are ``render``'s. Runs the pilot (a fraction of a
    /// second); Ctrl-C stops it.
    #[pyo3(signature = (settings = None, tolerance = None))]
    fn plan<'py>(
        &self,
        py: Python<'py>,
        settings: Option<&Bound<'py, PyDict>>,
        tolerance: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let s = self::settings(
            settings,
            SettingArgs {
                tolerance,
                ..Default::default()
            },
        )?;
        let scene = &self.scene;
        let none = ProgressSink::new(py, None, "")?;
        let plan = detached_with_stop(py, &none, |_, _| {
            Ok(gloam_trace::plan::effect_plan(scene, &s)?)
        })?;
        to_py_as(py, &plan.effects, "Effect")
    }

    /// The scene's bands: dicts with ``name``, ``lo_nm``, ``hi_nm``.
    #[getter]
    fn bands<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        band_list(py, &self.scene, &self.band_names())
    }

    /// The file the scene was read from (or named after, for ``from_toml``).
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// ``Scene('path': N facets, M point sources, bands [...])``.
    fn __repr__(&self) -> String {
        format!(
            "Scene('{}': {} facets, {} point sources, bands {:?})",
            self.path.display(),
            self.scene.facets.len(),
            self.scene.point_sources.len(),
            self.band_names()
        )
    }
}

impl Scene {
    fn band_names(&self) -> Vec<String> {
        self.scene.bands.iter().map(|b| b.name.clone()).collect()
    }
}

/// Bands as dicts (name, edges, units of the radiance array).
fn band_list<'py>(
    py: Python<'py>,
    scene: &gloam_scene::Scene,
    names: &[String],
) -> PyResult<Bound<'py, PyAny>> {
    let list = PyList::empty(py);
    for n in names {
        let d = PyDict::new(py);
        d.set_item("name", n)?;
        if let Some(b) = scene.band(n) {
            d.set_item("lo_nm", b.lo_nm)?;
            d.set_item("hi_nm", b.hi_nm)?;
        }
        d.set_item("units", "W m^-2 sr^-1")?;
        list.append(d)?;
    }
    Ok(list.into_any())
}

/// A render: ``radiance`` (float64, band × row × column, W m⁻² sr⁻¹),
/// ``std_error`` (same shape), ``spp`` (uint32, row × column), ``bands``,
/// ``report`` (the dict ``report.json`` holds) and, when rendered with a
/// ``sensor``, ``detected`` (float64 row × column, detected-electron
/// radiance e⁻ s⁻¹ m⁻² sr⁻¹, what ``Sensor.capture`` takes).
#[pyclass(module = "gloam", frozen)]
pub struct RenderResult {
    /// Radiance of the scene's bands: float64, band × row × column, W m⁻² sr⁻¹.
    #[pyo3(get)]
    radiance: Py<PyArray3<f64>>,
    /// Estimated standard error of each pixel (same shape and units).
    #[pyo3(get)]
    std_error: Py<PyArray3<f64>>,
    /// Camera samples per pixel: uint32, row × column.
    #[pyo3(get)]
    spp: Py<PyArray2<u32>>,
    /// Detected-electron radiance, e⁻ s⁻¹ m⁻² sr⁻¹ (float64, row ×
    /// column), when rendered with ``sensor=``; else None.
    #[pyo3(get)]
    detected: Option<Py<PyArray2<f64>>>,
    /// The bands: dicts with ``name``, ``lo_nm``, ``hi_nm``, ``units``.
    #[pyo3(get)]
    bands: Py<PyAny>,
    /// The ``report.json`` document (a dict with attribute access).
    #[pyo3(get)]
    report: Py<PyAny>,
}

impl RenderResult {
    /// The detected band, for a capture.
    pub fn detected_view<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.detected.as_ref().map(|d| d.bind(py).clone())
    }
}

#[pymethods]
impl RenderResult {
    /// The arrays and the report as a plain dict (``radiance``,
    /// ``std_error``, ``spp``, ``detected``, ``bands``, ``report``).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("radiance", &self.radiance)?;
        d.set_item("std_error", &self.std_error)?;
        d.set_item("spp", &self.spp)?;
        d.set_item("detected", &self.detected)?;
        d.set_item("bands", &self.bands)?;
        d.set_item("report", &self.report)?;
        Ok(d)
    }

    /// ``result["radiance"]`` as ``result.radiance`` (dict-style code keeps working).
    fn __getitem__<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        crate::convert::dict_item(self.to_dict(py)?, key)
    }

    /// ``RenderResult(radiance (bands, rows, columns), …)``.
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "RenderResult(radiance {:?}{})",
            self.radiance.bind(py).shape(),
            if self.detected.is_some() {
                ", with the sensor's detected band"
            } else {
                ""
            }
        )
    }
}

/// The sensor argument of `render`: a `Sensor` or a preset name / file.
fn sensor_source(sensor: Option<&Bound<'_, PyAny>>) -> PyResult<Option<String>> {
    let Some(s) = sensor else { return Ok(None) };
    if let Ok(s) = s.cast::<Sensor>() {
        return Ok(Some(s.get().source.clone()));
    }
    Ok(Some(s.extract::<String>()?))
}

/// `target_error`: a number (relative error per pixel) or "camera" / "camera:K".
fn target_error(t: Option<&Bound<'_, PyAny>>) -> PyResult<Option<TargetError>> {
    let Some(t) = t else { return Ok(None) };
    if let Ok(e) = t.extract::<f64>() {
        return Ok(Some(TargetError::Relative(e)));
    }
    let text = t.extract::<String>().map_err(|_| {
        GloamError::new_err("target_error: a number (e.g. 0.02) or \"camera\" / \"camera:K\"")
    })?;
    text.parse().map(Some).or_py()
}

/// A render's progress for the polling thread (``progress=``), and Ctrl-C.
struct Polled<'a> {
    stop: &'a AtomicBool,
    rep: Arc<Reporter>,
}

impl Events for Polled<'_> {
    fn preparation(&self) -> Option<gloam_trace::PrepObserver> {
        let rep = Arc::clone(&self.rep);
        let observer: gloam_trace::PrepObserver = Arc::new(move |ev| {
            if let gloam_trace::PrepEvent::Begin(step) = ev {
                rep.set(&format!("prepare: {step}"), 0, 0);
            }
        });
        Some(observer)
    }
    fn tiles(&self, done: u64, total: u64) {
        self.rep.set("tiles", done, total);
    }
    fn stop(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

/// Renders ``scene``: the same computation, with the same seed, as
/// ``gloam render`` (``radiance`` is bit-identical to its radiance.npy).
///
/// ``spp``, ``seed``, ``estimator`` (analytic, solid-angle, dirsig2001),
/// ``threads`` and ``target_error``/``tolerance`` are the CLI's flags
/// (``target_error="camera"`` or ``"camera:K"`` with a camera: each pixel
/// to the camera's own noise at its preset gain, ``report["camera_target"]``);
/// ``settings`` is any ``--set KEY=VALUE`` as a dict. With neither
/// ``spp`` nor ``target_error`` (nor either in ``settings``) and no
/// camera, it samples to ``target_error = 0.02`` as the CLI does
/// (``report["target_error_source"] == "default"``). ``sensor`` (a
/// ``Sensor``, preset name or sensor TOML path; default the scene's own
/// ``sensor`` entry, as the CLI) adds the camera's detected band as
/// ``result.detected``. ``progress`` is ``True`` (a tqdm bar when tqdm is
/// installed, else a line on stderr) or a callable ``progress(done,
/// total, what)``, told each preparation step (``what`` ``"prepare:
/// bvh"`` …, ``done = total = 0``) and each finished tile (``"tiles"``);
/// an exception it raises stops the render. The GIL is released while it
/// renders; Ctrl-C raises KeyboardInterrupt within a tile, and during the
/// scene's preparation at once (the abandoned preparation finishes its
/// step in the background and is dropped). The arguments make a
/// ``gloam render`` request (gloam-pipeline's ``RenderRequest``): the same
/// checks, the same messages.
#[pyfunction]
#[pyo3(signature = (scene, spp = None, seed = None, estimator = None, settings = None, threads = None, target_error = None, tolerance = None, sensor = None, progress = None))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    scene: &Bound<'py, Scene>,
    spp: Option<Count<u32>>,
    seed: Option<Count<u64>>,
    estimator: Option<&str>,
    settings: Option<&Bound<'py, PyDict>>,
    threads: Option<Count<usize>>,
    target_error: Option<&Bound<'py, PyAny>>,
    tolerance: Option<f64>,
    sensor: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<RenderResult> {
    let sc = scene.get();
    let request = RenderRequest {
        settings: SettingArgs {
            spp: spp.map(|c| c.0),
            seed: seed.map(|c| c.0),
            estimator: estimator.map(str::to_string),
            set: setting_pairs(settings)?,
            threads: threads.map(|c| c.0),
            target_error: self::target_error(target_error)?,
            tolerance,
        },
        camera: CameraOptions {
            sensor: sensor_source(sensor)?,
            ..Default::default()
        },
        ..RenderRequest::new(SceneInput::Loaded {
            scene: Arc::clone(&sc.scene),
            path: sc.path.clone(),
            load_s: sc.load_s,
        })
    };
    // This render's own log, starting with what loading its scene read.
    let reads = ReadLog::new();
    reads.extend(&sc.reads.reads());
    let valid = request.validate(&reads).or_py()?;
    let sink = ProgressSink::new(py, progress, "render")?;
    let done = detached_owned(py, &sink, move |stop, rep| {
        // No output set, no children: nothing for a guard to undo.
        Ok(valid.run(&Polled { stop, rep }, &gloam_io::RunGuard::detached())?)
    })?;
    let report = done.report.to_value().or_py()?;
    let (mut out, detected) = (done.rendered.radiance, done.rendered.detected);
    let bands = band_list(py, &sc.scene, &out.band_names)?.unbind();
    let radiance = std::mem::take(&mut out.radiance).into_pyarray(py).unbind();
    let std_error = std::mem::take(&mut out.std_error).into_pyarray(py).unbind();
    let spp = std::mem::take(&mut out.spp).into_pyarray(py).unbind();
    Ok(RenderResult {
        radiance,
        std_error,
        spp,
        detected: detected.map(|d| d.into_pyarray(py).unbind()),
        bands,
        report: to_py_as(py, &report, "RenderReport")?.unbind(),
    })
}

fn vec3(what: &str, v: Vec<f64>) -> PyResult<DVec3> {
    match v.as_slice() {
        [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(crate::errors::GloamError::new_err(format!(
            "{what}: expected 3 numbers (x, y, z in scene units), got {}",
            v.len()
        ))),
    }
}

/// Irradiance at a world-space ``point`` (scene units) on a receiver with
/// ``normal``, in ``band`` (default: the first), from ``samples`` samples
/// per source: a ``Probe`` (a dict with attribute access) with
/// ``irradiance_w_m2``, ``std_error_w_m2`` and, on a facet, the reflected
/// ``radiance_w_m2_sr`` — what ``gloam probe --point … --json`` prints.
/// ``seed``, ``estimator`` and ``settings`` are ``render``'s.
#[pyfunction]
#[pyo3(signature = (scene, point, normal, band = None, samples = Count(16), seed = None, estimator = None, settings = None))]
#[allow(clippy::too_many_arguments)]
fn probe<'py>(
    py: Python<'py>,
    scene: &Bound<'py, Scene>,
    point: Vec<f64>,
    normal: Vec<f64>,
    band: Option<&str>,
    samples: Count<u32>,
    seed: Option<Count<u64>>,
    estimator: Option<&str>,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let samples = samples.0;
    let flags = SettingArgs {
        seed: seed.map(|c| c.0),
        estimator: estimator.map(str::to_string),
        ..Default::default()
    };
    if !(1..=gloam_pipeline::MAX_PROBE_SAMPLES).contains(&samples) {
        return Err(crate::errors::GloamError::new_err(format!(
            "samples = {samples}: from 1 to {} independent estimates (each a full estimate at the point)",
            gloam_pipeline::MAX_PROBE_SAMPLES
        )));
    }
    let s = self::settings(settings, flags)?;
    let (p, n) = (vec3("point", point)?, vec3("normal", normal)?);
    let sc = &scene.get().scene;
    let none = ProgressSink::new(py, None, "")?;
    let r = detached_with_stop(py, &none, |_, _| {
        Ok(Tracer::new(sc, &s)?.probe_point(p, n, band, samples)?)
    })?;
    to_py_as(py, &r, "Probe")
}
