//! The calibration flows over an open grabber, the radiance LUT, and image
//! comparison. Each returns the dict the CLI writes as its JSON report.

use std::path::PathBuf;

use numpy::prelude::*;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;

use gloam_calib::agc::{AgcOptions, agc_linearisation};
use gloam_calib::mtf_flow::{
    DEFAULT_FRAMES, DEFAULT_MODULATION, DEFAULT_SPECTRUM, GrabberTarget, MtfRequest, measure_mtf,
};
use gloam_calib::ptc::{PtcOptions, photon_transfer as ptc_flow};
use gloam_calib::radiance::RadianceOptions;
use gloam_calib::rig_check::rig_mismatch;
use gloam_calib::source::open_for_grabber;
use gloam_calib::validate::{Region, compare_images};
use gloam_grabber::FrameGrabber;

use crate::convert::{from_py, to_py};
use crate::errors::{GloamError, OrPy};
use crate::grabber::{Grabber, PyFrame};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Lut>()?;
    m.add_function(wrap_pyfunction!(calibrate_radiance, m)?)?;
    m.add_function(wrap_pyfunction!(photon_transfer, m)?)?;
    m.add_function(wrap_pyfunction!(mtf, m)?)?;
    m.add_function(wrap_pyfunction!(agc_linearity, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    Ok(())
}

fn no_progress(_: usize, _: usize) {}

/// Radiance LUT across ``gains`` (``gloam calibrate radiance``): drives
/// the grabber through the source file's levels (``levels`` generated when
/// it lists none; ``auto_range`` rescales a simulated sphere to that
/// fraction of full scale at the highest gain). Returns the ``lut.json``
/// dict; ``Lut.from_dict`` makes it appliable.
#[pyfunction]
#[pyo3(signature = (grabber, source, gains, frames = gloam_calib::radiance::DEFAULT_FRAMES, levels = None, auto_range = None, exposure_s = None))]
#[allow(clippy::too_many_arguments)]
fn calibrate_radiance<'py>(
    py: Python<'py>,
    grabber: &Bound<'py, Grabber>,
    source: PathBuf,
    gains: Vec<f64>,
    frames: usize,
    levels: Option<usize>,
    auto_range: Option<f64>,
    exposure_s: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    if gains.is_empty() {
        return Err(GloamError::new_err("gains: at least one gain is needed"));
    }
    let top = gains.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let opts = RadianceOptions {
        gains,
        frames,
        exposure_s,
        ..Default::default()
    };
    let lut = grabber.borrow_mut().run(py, |g| {
        if let Some(e) = exposure_s {
            g.set_exposure_s(e)?;
        }
        let mut src = open_for_grabber(&source, levels, auto_range, g, Some(top))?.source;
        Ok(gloam_calib::radiance::calibrate_radiance(
            g,
            src.as_mut(),
            &opts,
            &mut no_progress,
        )?)
    })?;
    to_py(py, &lut)
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
/// in ``warnings``.
#[pyfunction]
#[pyo3(signature = (grabber, source, gain = gloam_calib::ptc::DEFAULT_GAIN, levels = gloam_calib::ptc::DEFAULT_LEVELS, spatial_frames = gloam_calib::ptc::DEFAULT_SPATIAL_FRAMES, auto_range = None, exposure_s = None, dataset_dir = None))]
#[allow(clippy::too_many_arguments)]
fn photon_transfer<'py>(
    py: Python<'py>,
    grabber: &Bound<'py, Grabber>,
    source: PathBuf,
    gain: f64,
    levels: usize,
    spatial_frames: usize,
    auto_range: Option<f64>,
    exposure_s: Option<f64>,
    dataset_dir: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let opts = PtcOptions {
        gain,
        exposure_s,
        spatial_frames,
        dataset_dir,
    };
    let uri = grabber.borrow().uri().to_string();
    let r = grabber.borrow_mut().run(py, |g| {
        if let Some(e) = exposure_s {
            g.set_exposure_s(e)?;
        }
        let mut src = open_for_grabber(&source, Some(levels), auto_range, g, Some(gain))?.source;
        let mismatch = rig_mismatch(&uri, src.rig(), exposure_s);
        let mut r = ptc_flow(g, src.as_mut(), &opts, &mut no_progress)?;
        // The CLI prints this before the run; here it leads the warnings.
        if let Some(m) = mismatch {
            r.warnings.insert(0, m.to_string());
        }
        Ok(r)
    })?;
    to_py(py, &r)
}

/// MTF of the camera behind the grabber (``gloam calibrate mtf``):
/// ``target="edge"`` (ISO 12233 slanted edge, ``angle_deg`` default 5) or
/// ``"sine"`` (sine targets at ``frequencies``, cycles/pixel, default
/// 0.02…0.48). ``radiance`` is the mean target radiance (default:
/// auto-ranged to 40 % of full scale). Returns the curve as a dict
/// (``frequencies_cy_per_px``, ``mtf``, ``mtf50``, ``mtf10``, …).
#[pyfunction]
#[pyo3(signature = (grabber, target = "edge", gain = None, radiance = None, modulation = DEFAULT_MODULATION, angle_deg = None, frequencies = None, frames = DEFAULT_FRAMES, spectrum = DEFAULT_SPECTRUM))]
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
    frames: usize,
    spectrum: &str,
) -> PyResult<Bound<'py, PyAny>> {
    if target != "edge" && target != "sine" {
        return Err(GloamError::new_err(format!(
            "target: '{target}' is neither 'edge' nor 'sine'"
        )));
    }
    let req = MtfRequest {
        target: if target == "sine" {
            GrabberTarget::Sine
        } else {
            GrabberTarget::Edge
        },
        gain,
        radiance_w_m2_sr: radiance,
        modulation,
        angle_deg,
        frequencies_cy_per_px: frequencies.unwrap_or_default(),
        frames,
        spectrum: spectrum.to_string(),
    };
    let curve = grabber.borrow_mut().run(py, |g: &mut dyn FrameGrabber| {
        Ok(measure_mtf(g, &req, &mut no_progress)?.curve)
    })?;
    to_py(py, &curve)
}

/// AGC staircase up and down, AGC on and overridden at ``fixed_gain``
/// (``gloam calibrate agc``): settling time, overshoot, hysteresis and
/// linearity (through ``lut``, a ``Lut``, when given). Returns the
/// ``agc.json`` dict.
#[pyfunction]
#[pyo3(signature = (grabber, source, fixed_gain = None, frames = gloam_calib::agc::DEFAULT_FRAMES_PER_STEP, levels = None, auto_range = None, lut = None, allow_unsettled = false))]
#[allow(clippy::too_many_arguments)]
fn agc_linearity<'py>(
    py: Python<'py>,
    grabber: &Bound<'py, Grabber>,
    source: PathBuf,
    fixed_gain: Option<f64>,
    frames: usize,
    levels: Option<usize>,
    auto_range: Option<f64>,
    lut: Option<&Bound<'py, Lut>>,
    allow_unsettled: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let opts = AgcOptions {
        fixed_gain,
        frames_per_step: frames,
        allow_unsettled,
        ..Default::default()
    };
    let lut = lut.map(|l| l.get().lut.clone());
    let r = grabber.borrow_mut().run(py, |g| {
        let mut src = open_for_grabber(&source, levels, auto_range, g, fixed_gain)?.source;
        Ok(agc_linearisation(
            g,
            src.as_mut(),
            &opts,
            lut.as_ref(),
            &mut no_progress,
        )?)
    })?;
    to_py(py, &r)
}

/// Compares two equally sized images over ``regions`` (dicts with
/// ``name``, ``x``, ``y``, ``width``, ``height``), as ``gloam compare
/// --json``: Spearman ρ of the region means and the RMS of their
/// differences, and each region's two means.
#[pyfunction]
fn compare<'py>(
    py: Python<'py>,
    truth: PyReadonlyArray2<'py, f64>,
    synthetic: PyReadonlyArray2<'py, f64>,
    regions: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
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
    to_py(py, &c)
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
        let lut = gloam_calib::apply::load_lut(&path).or_py()?;
        Ok(Self { lut })
    }

    /// A LUT from the dict ``calibrate_radiance`` returns.
    #[staticmethod]
    fn from_dict(d: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(Self {
            lut: from_py(d, "not a gloam LUT")?,
        })
    }

    /// The LUT as the ``lut.json`` dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.lut)
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

    fn __repr__(&self) -> String {
        format!("Lut(gains {:?})", self.gains())
    }
}
