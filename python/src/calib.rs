//! The calibration flows over an open grabber, the radiance LUT, and image
//! comparison. Each returns the dict the CLI writes as its JSON report.

use std::path::PathBuf;

use numpy::prelude::*;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;

use gloam_calib::mtf_flow::{
    DEFAULT_FRAMES, DEFAULT_MODULATION, DEFAULT_SPECTRUM, GrabberTarget, MtfRequest,
};
use gloam_calib::request::{
    AgcRequest, Event, MtfCalibration, MtfDone, PtcRequest, RadianceRequest, ScopeRequest,
    SourceRequest, VoltageOptions,
};
use gloam_calib::validate::{Region, compare_images};
use gloam_grabber::FrameGrabber;

use crate::convert::{Count, from_py, to_py_as};
use crate::errors::{GloamError, OrPy};
use crate::grabber::{Grabber, PyFrame};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Lut>()?;
    m.add_function(wrap_pyfunction!(calibrate_radiance, m)?)?;
    m.add_function(wrap_pyfunction!(photon_transfer, m)?)?;
    m.add_function(wrap_pyfunction!(mtf, m)?)?;
    m.add_function(wrap_pyfunction!(agc_linearity, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(scope, m)?)?;
    Ok(())
}

/// A flow's events, unheard: Python's calls print nothing (their
/// warnings are in the result).
fn quiet(_: Event<'_>) {}

/// Sets the exposure asked for (as `--exposure-s` does on the CLI's
/// grabber) before a flow.
fn set_exposure(g: &mut dyn FrameGrabber, exposure_s: Option<f64>) -> anyhow::Result<()> {
    if let Some(e) = exposure_s {
        g.set_exposure_s(e)?;
    }
    Ok(())
}

/// Radiance LUT across ``gains`` (``gloam calibrate radiance``): drives
/// the grabber through the source file's levels (``levels`` generated when
/// it lists none; ``auto_range`` rescales a simulated sphere to that
/// fraction of full scale at the highest gain), ``frames`` frames per
/// level, at ``exposure_s`` when given. Returns the ``lut.json`` document
/// as a ``RadianceCalibration`` (a dict with attribute access);
/// ``Lut.from_dict`` makes it appliable. Ctrl-C stops it between frames.
#[pyfunction]
#[pyo3(signature = (grabber, source, gains, frames = Count(gloam_calib::radiance::DEFAULT_FRAMES), levels = None, auto_range = None, exposure_s = None))]
#[allow(clippy::too_many_arguments)]
fn calibrate_radiance<'py>(
    py: Python<'py>,
    grabber: &Bound<'py, Grabber>,
    source: PathBuf,
    gains: Vec<f64>,
    frames: Count<usize>,
    levels: Option<Count<usize>>,
    auto_range: Option<f64>,
    exposure_s: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let (frames, levels) = (frames.0, levels.map(|l| l.0));
    // `gloam calibrate radiance`'s request: the same checks and steps.
    let req = RadianceRequest {
        source: SourceRequest {
            source,
            levels,
            auto_range,
        },
        gains,
        frames,
        exposure_s,
    };
    req.validate().or_py()?;
    let lut = grabber.borrow_mut().run(py, |g| {
        set_exposure(g, exposure_s)?;
        Ok(req.run(g, &gloam_io::ReadLog::new(), &mut quiet)?)
    })?;
    to_py_as(py, &lut, "RadianceCalibration")
}

/// EMVA 1288 photon transfer at a fixed ``gain`` (``gloam calibrate
/// ptc``): returns the ``ptc.json`` dict (system gain K in DN/e⁻, dark
/// noise, saturation capacity, QE with a ``[rig]``, …). On an intensified
/// camera K is ``effective_system_gain_dn_per_e`` (``K_eff = g·F_pix``,
/// excess noise included); when the ``[rig]`` names the camera, the dict
/// adds its ``excess_noise_factor``, ``pixel_noise_factor``,
/// ``conversion_gain_dn_per_pe``, ``quantum_efficiency_from_conversion_gain``
/// and ``excess_noise_relation`` (the EMVA caveat). ``dataset_dir``
/// also writes the EMVA 1288 data set there. A ``[rig]`` that does not
/// describe the simulated camera (so QE would read biased) is named first
/// in ``warnings``. ``levels`` exposure levels, ``spatial_frames`` frames
/// for the spatial noise, ``auto_range`` and ``exposure_s`` as in
/// ``calibrate_radiance``. Returns a ``PhotonTransfer`` (a dict with
/// attribute access).
#[pyfunction]
#[pyo3(signature = (grabber, source, gain = gloam_calib::ptc::DEFAULT_GAIN, levels = Count(gloam_calib::ptc::DEFAULT_LEVELS), spatial_frames = Count(gloam_calib::ptc::DEFAULT_SPATIAL_FRAMES), auto_range = None, exposure_s = None, dataset_dir = None))]
#[allow(clippy::too_many_arguments)]
fn photon_transfer<'py>(
    py: Python<'py>,
    grabber: &Bound<'py, Grabber>,
    source: PathBuf,
    gain: f64,
    levels: Count<usize>,
    spatial_frames: Count<usize>,
    auto_range: Option<f64>,
    exposure_s: Option<f64>,
    dataset_dir: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let (levels, spatial_frames) = (levels.0, spatial_frames.0);
    // `gloam calibrate ptc`'s request: the same checks and steps.
    let req = PtcRequest {
        source: SourceRequest {
            source,
            levels: Some(levels),
            auto_range,
        },
        grabber: grabber.borrow().uri().to_string(),
        gain,
        spatial_frames,
        exposure_s,
        dataset_dir,
    };
    req.validate().or_py()?;
    let r = grabber.borrow_mut().run(py, |g| {
        set_exposure(g, exposure_s)?;
        let done = req.run(g, &gloam_io::ReadLog::new(), &mut quiet)?;
        let mut r = done.report;
        // The CLI prints this before the run; here it leads the warnings.
        if let Some(m) = done.rig_mismatch {
            r.warnings.insert(0, m);
        }
        Ok(r)
    })?;
    to_py_as(py, &r, "PhotonTransfer")
}

/// MTF of the camera behind the grabber (``gloam calibrate mtf``):
/// ``target="edge"`` (ISO 12233 slanted edge, ``angle_deg`` default 5) or
/// ``"sine"`` (sine targets at ``frequencies``, cycles/pixel, default
/// 0.02…0.48). ``radiance`` is the mean target radiance (default:
/// auto-ranged to 40 % of full scale), ``modulation`` the sine's,
/// ``frames`` frames averaged per target, ``spectrum`` the targets'
/// relative spectrum. Returns an ``Mtf`` (a dict with attribute access:
/// ``method``, ``frequencies_cy_per_px``, ``mtf``, ``mtf50``, ``mtf10``).
///
/// ``space="voltage"`` (sine targets on a ``sim:`` grabber, as ``gloam
/// calibrate mtf --space voltage``) measures on the camera's analogue
/// video line — the scope isolates ``scope_rows`` (default the four
/// middle rows) — beside the digital-count sine flow and the chain's
/// analytic curves: the result is ``mtf.json``'s document, the voltage
/// curve first, every curve under ``curves`` and the scope's points under
/// ``details`` (``magnification``: image size / chart size, for the
/// object-space frequencies). ``frequencies`` default 0.04…0.48 there.
#[pyfunction]
#[pyo3(signature = (grabber, target = "edge", gain = None, radiance = None, modulation = DEFAULT_MODULATION, angle_deg = None, frequencies = None, frames = Count(DEFAULT_FRAMES), spectrum = DEFAULT_SPECTRUM, space = "digital", scope_rows = None, magnification = 1.0))]
#[allow(clippy::too_many_arguments)]
fn mtf<'py>(
    py: Python<'py>,
    grabber: &Bound<'py, Grabber>,
    target: &str,
    gain: Option<f64>,
    radiance: Option<f64>,
    modulation: f64,
    angle_deg: Option<f64>,
    frequencies: Option<Vec<f64>>,
    frames: Count<usize>,
    spectrum: &str,
    space: &str,
    scope_rows: Option<Vec<Count<usize>>>,
    magnification: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let (frames, scope_rows) = (frames.0, scope_rows.map(Count::all));
    let voltage = match space {
        "digital" => None,
        "voltage" => Some(VoltageOptions {
            scope_rows: scope_rows.unwrap_or_default(),
            magnification,
        }),
        _ => {
            return Err(GloamError::new_err(format!(
                "space: '{space}' is neither 'digital' nor 'voltage'"
            )));
        }
    };
    let target = match target {
        "sine" => GrabberTarget::Sine,
        "edge" => GrabberTarget::Edge,
        _ => {
            return Err(GloamError::new_err(format!(
                "target: '{target}' is neither 'edge' nor 'sine'"
            )));
        }
    };
    // `gloam calibrate mtf`'s request: the same checks and steps.
    let req = MtfCalibration {
        mtf: MtfRequest {
            target,
            gain,
            radiance_w_m2_sr: radiance,
            modulation,
            angle_deg,
            frequencies_cy_per_px: frequencies.unwrap_or_default(),
            frames,
            spectrum: spectrum.to_string(),
        },
        voltage,
    };
    req.validate().or_py()?;
    let opened = (grabber.borrow().uri().to_string(), grabber.borrow().seed());
    let done = grabber.borrow_mut().run(py, |g: &mut dyn FrameGrabber| {
        Ok(req.run(g, (&opened.0, opened.1), &mut quiet)?)
    })?;
    match done {
        MtfDone::Digital { curve, .. } => to_py_as(py, &curve, "Mtf"),
        MtfDone::Voltage(r) => {
            // mtf.json's document, as `gloam calibrate mtf` writes it.
            let doc = gloam_calib::report::MtfDocument::new(&r.curves, &r.details).or_py()?;
            to_py_as(py, &doc, "Mtf")
        }
    }
}

/// A simulated camera's analogue video on the oscilloscope, as ``gloam
/// scope``: the camera (``sensor``, a preset or sensor TOML, or the
/// ``sim:`` URI ``grabber``, whose rig, seed and size it takes) looks at
/// ``rig`` (``uniform``, ``sine``, ``edge``, ``dark``; default sine at
/// ``frequency`` cycles/pixel) at ``level`` (mean signal, fraction of the
/// range above black), ``frames`` frames at ``gain`` (AGC off); frame
/// ``rows`` (default the middle row) are scoped. ``format``
/// (``"rs-170"``/``"ccir"``) and ``bandwidth_hz`` override the sensor
/// file's video stage; ``size`` is ``(width, height)``. Returns a
/// ``Scope`` (a dict with attribute access): ``sensor``, ``format``,
/// ``pixel_clock_hz``, ``readouts`` (``[row, {sync_tip_v, blanking_v,
/// active_min_v, active_max_v, sync_width_s, line_period_s}]``, what the
/// cursors read) and ``lines`` (per row: ``row``, ``field``, ``line``,
/// ``time_s`` and ``volts`` as float64 arrays).
#[pyfunction]
#[pyo3(signature = (sensor = None, grabber = None, rig = None, frequency = 0.05, level = 0.4, rows = None, size = None, seed = None, gain = None, format = None, bandwidth_hz = None, frames = Count(1)))]
#[allow(clippy::too_many_arguments)]
fn scope<'py>(
    py: Python<'py>,
    sensor: Option<String>,
    grabber: Option<&str>,
    rig: Option<String>,
    frequency: f64,
    level: f64,
    rows: Option<Vec<Count<usize>>>,
    size: Option<(Count<u32>, Count<u32>)>,
    seed: Option<Count<u64>>,
    gain: Option<f64>,
    format: Option<&str>,
    bandwidth_hz: Option<f64>,
    frames: Count<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    let (rows, size) = (rows.map(Count::all), size.map(|(w, h)| (w.0, h.0)));
    let (seed, frames) = (seed.map(|s| s.0), frames.0);
    use gloam_sensor::stages::video_timing::VideoFormat;
    let format = match format {
        None => None,
        Some("rs-170" | "rs170") => Some(VideoFormat::Rs170),
        Some("ccir") => Some(VideoFormat::Ccir),
        Some(f) => {
            return Err(GloamError::new_err(format!(
                "format: '{f}' is neither 'rs-170' nor 'ccir'"
            )));
        }
    };
    // `gloam scope`'s request: the sensor (rig sine, seed 0) or the sim: URI.
    let o = ScopeRequest {
        sensor,
        grabber: grabber.map(str::to_string),
        rig,
        frequency_cy_per_px: frequency,
        level_fraction: level,
        rows: rows.unwrap_or_default(),
        size,
        seed,
        gain,
        format,
        bandwidth_hz,
        frames,
    }
    .validate()
    .or_py()?;
    let r = py
        .detach(|| gloam_calib::scope_run::run_scope(&o, &gloam_io::ReadLog::new()))
        .or_py()?;
    let out = to_py_as(py, &r, "Scope")?;
    let lines = pyo3::types::PyList::empty(py);
    for l in &r.lines {
        let d = pyo3::types::PyDict::new(py);
        d.set_item("row", l.row)?;
        d.set_item("field", l.field)?;
        d.set_item("line", l.line)?;
        d.set_item("time_s", l.time_s.clone().into_pyarray(py))?;
        d.set_item("volts", l.volts.clone().into_pyarray(py))?;
        lines.append(
            py.import("gloam._results")?
                .getattr("Result")?
                .call1((d,))?,
        )?;
    }
    out.set_item("lines", lines)?;
    Ok(out)
}

/// AGC staircase up and down, AGC on and overridden at ``fixed_gain``
/// (``gloam calibrate agc``): settling time, overshoot, hysteresis and
/// linearity (through ``lut``, a ``Lut``, when given). ``frames`` frames
/// per step, ``levels`` and ``auto_range`` as in ``calibrate_radiance``;
/// ``allow_unsettled`` reports a servo that never settled instead of
/// failing. Returns the ``agc.json`` document as an ``AgcLinearity`` (a
/// dict with attribute access).
#[pyfunction]
#[pyo3(signature = (grabber, source, fixed_gain = None, frames = Count(gloam_calib::agc::DEFAULT_FRAMES_PER_STEP), levels = None, auto_range = None, lut = None, allow_unsettled = false))]
#[allow(clippy::too_many_arguments)]
fn agc_linearity<'py>(
    py: Python<'py>,
    grabber: &Bound<'py, Grabber>,
    source: PathBuf,
    fixed_gain: Option<f64>,
    frames: Count<usize>,
    levels: Option<Count<usize>>,
    auto_range: Option<f64>,
    lut: Option<&Bound<'py, Lut>>,
    allow_unsettled: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let (frames, levels) = (frames.0, levels.map(|l| l.0));
    // `gloam calibrate agc`'s request: the same checks and steps.
    let req = AgcRequest {
        source: SourceRequest {
            source,
            levels,
            auto_range,
        },
        fixed_gain,
        frames,
        lut: lut.map(|l| (l.get().lut.clone(), None)),
        allow_unsettled,
    };
    req.validate().or_py()?;
    let r = grabber.borrow_mut().run(py, |g| {
        Ok(req.run(g, &gloam_io::ReadLog::new(), &mut quiet)?)
    })?;
    to_py_as(py, &r, "AgcLinearity")
}

/// Compares two equally sized images over ``regions`` (dicts with
/// ``name``, ``x``, ``y``, ``width``, ``height``), as ``gloam compare
/// --json``: a ``Comparison`` (a dict with attribute access) with the
/// Spearman ρ of the region means, the RMS of their differences, and each
/// region's two means. The images are 2-D arrays of any float dtype and
/// layout.
#[pyfunction]
fn compare<'py>(
    py: Python<'py>,
    truth: &Bound<'py, PyAny>,
    synthetic: &Bound<'py, PyAny>,
    regions: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let (truth, synthetic) = (
        as_f64_2d(py, truth, "truth")?,
        as_f64_2d(py, synthetic, "synthetic")?,
    );
    let (t, s) = (truth.as_array(), synthetic.as_array());
    if t.dim() != s.dim() {
        return Err(GloamError::new_err(format!(
            "the images differ in size: {}×{} vs {}×{}",
            t.dim().1,
            t.dim().0,
            s.dim().1,
            s.dim().0
        )));
    }
    let regions: Vec<Region> = from_py(regions, "regions")?;
    let (h, w) = t.dim();
    let tv: Vec<f64> = t.iter().copied().collect();
    let sv: Vec<f64> = s.iter().copied().collect();
    let c = py
        .detach(|| compare_images(&tv, &sv, w, h, &regions))
        .or_py()?;
    to_py_as(py, &c, "Comparison")
}

/// A 2-D array of any real dtype and layout as float64 (exact).
fn as_f64_2d<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    what: &str,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let np = py.import("numpy")?;
    np.call_method1("asarray", (a, np.getattr("float64")?))?
        .extract()
        .map_err(|_| GloamError::new_err(format!("{what}: expected a 2-D real array")))
}

/// A radiance look-up table (``lut.json``): ``Lut.load(path)`` or
/// ``Lut.from_dict(calibrate_radiance(…))``; ``apply(frame, gain)`` turns
/// digital counts into radiance (float32, W m⁻² sr⁻¹; saturated pixels NaN).
#[pyclass(module = "gloam", frozen)]
pub struct Lut {
    lut: gloam_calib::radiance::Lut,
}

#[pymethods]
impl Lut {
    /// Reads a ``lut.json`` written by ``gloam calibrate radiance``.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let lut = gloam_calib::apply::load_lut(&path, &gloam_io::ReadLog::new()).or_py()?;
        Ok(Self { lut })
    }

    /// A LUT from the dict ``calibrate_radiance`` returns, checked as
    /// ``Lut.load`` and ``gloam calibrate apply --lut`` check a file (a
    /// slope that is not positive, a reversed or repeated gain, a top code
    /// that is not a 16-bit count… raise ``GloamError`` naming the key).
    #[staticmethod]
    fn from_dict(d: &Bound<'_, PyAny>) -> PyResult<Self> {
        let lut: gloam_calib::radiance::Lut = from_py(d, "not a gloam LUT")?;
        lut.check()
            .map_err(|p| GloamError::new_err(format!("Lut.from_dict: {p}")))?;
        Ok(Self { lut })
    }

    /// The LUT as the ``lut.json`` dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py_as(py, &self.lut, "RadianceCalibration")
    }

    /// Calibrated gains.
    #[getter]
    fn gains(&self) -> Vec<f64> {
        self.lut.gains.iter().map(|c| c.gain).collect()
    }

    /// Radiance of a frame (a ``Frame`` from ``grab()``, whose gain is
    /// used, or a 2-D uint16 array with ``gain``): float32, row × column.
    #[pyo3(signature = (frame, gain = None))]
    fn apply<'py>(
        &self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
        gain: Option<f64>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (px, gain) = if let Ok(f) = frame.cast::<PyFrame>() {
            let f = f.get();
            let a = f.pixels.bind(py).readonly().as_array().to_owned();
            (a, gain.unwrap_or(f.gain))
        } else {
            let a: PyReadonlyArray2<u16> = frame.extract().map_err(|_| {
                GloamError::new_err("frame: expected a Frame or a 2-D uint16 array")
            })?;
            let g = gain.ok_or_else(|| {
                GloamError::new_err("gain: needed for an array (a Frame carries its own)")
            })?;
            (a.as_array().to_owned(), g)
        };
        let (h, w) = px.dim();
        let flat: Vec<u16> = px.iter().copied().collect();
        let out = self.lut.apply(gain, &flat).or_py()?;
        let arr = ndarray::Array2::from_shape_vec((h, w), out)
            .map_err(|e| GloamError::new_err(e.to_string()))?;
        Ok(arr.into_pyarray(py))
    }

    /// ``Lut(gains [...])``.
    fn __repr__(&self) -> String {
        format!("Lut(gains {:?})", self.gains())
    }
}
