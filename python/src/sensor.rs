//! Cameras: presets, their analytic description, captures of a render or
//! of an image through the modelled chain.

use ndarray::{Array2, Array3};
use numpy::prelude::*;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::IntoPyDict;

use gloam_io::frames::FrameRecord;
use gloam_sensor::{Camera, SensorConfig};
use gloam_simcam::FrameExposureExt;

use crate::convert::{Count, to_py_as};
use crate::errors::{GloamError, OrPy};
use crate::interrupt::{ProgressSink, SameThread, finish, signalled};
use crate::render::RenderResult;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Sensor>()?;
    m.add_class::<Capture>()?;
    Ok(())
}

/// A camera model: a built-in preset (``Sensor.preset("gen3-gaas-iccd")``,
/// ``Sensor.presets()``) or a sensor TOML file (``Sensor.from_toml(path)``).
#[pyclass(module = "gloam", frozen)]
pub struct Sensor {
    pub config: SensorConfig,
    /// The preset name or file path (what `gloam render --sensor` takes).
    pub source: String,
}

/// What `capture` takes.
enum Input {
    Detected(Array2<f64>),
    Photoelectrons(Array2<f64>),
}

#[pymethods]
impl Sensor {
    /// A built-in preset (see ``Sensor.presets()``).
    #[staticmethod]
    fn preset(name: &str) -> PyResult<Self> {
        match SensorConfig::preset(name) {
            Some(c) => Ok(Self {
                config: c.or_py()?,
                source: name.to_string(),
            }),
            None => Err(GloamError::new_err(format!(
                "unknown sensor preset '{name}' (presets: {})",
                gloam_sensor::PRESETS
                    .iter()
                    .map(|p| p.0)
                    .collect::<Vec<_>>()
                    .join(", ")
            ))),
        }
    }

    /// A sensor TOML file (the format of ``sims/sensors/*.toml``).
    #[staticmethod]
    fn from_toml(path: std::path::PathBuf) -> PyResult<Self> {
        let source = path.display().to_string();
        let config =
            SensorConfig::load_preset_or_file(&source, &gloam_io::ReadLog::new()).or_py()?;
        Ok(Self { config, source })
    }

    /// Names of the built-in presets (what ``Sensor.preset`` takes).
    #[staticmethod]
    fn presets() -> Vec<&'static str> {
        gloam_sensor::PRESETS.iter().map(|p| p.0).collect()
    }

    /// The preset's or file's camera name.
    #[getter]
    fn name(&self) -> String {
        self.config.name.clone()
    }

    /// Derived figures at ``gain`` (default: the configured gain), as
    /// ``gloam sensor describe --json``: a ``SensorDescription`` (a dict
    /// with attribute access) with DN per photoelectron, excess noise
    /// factor, read noise, black and saturation levels, bit depth, MTF.
    #[pyo3(signature = (gain = None))]
    fn describe<'py>(&self, py: Python<'py>, gain: Option<f64>) -> PyResult<Bound<'py, PyAny>> {
        let camera = Camera::new(self.config.clone()).or_py()?;
        to_py_as(
            py,
            &camera.chain().describe_checked(gain).or_py()?,
            "SensorDescription",
        )
    }

    /// Captures ``frames`` frames through the camera; returns a
    /// ``Capture`` with ``frames`` (uint16, frames × row × column) and
    /// ``meta`` (one dict per frame: the ``frames.jsonl`` record —
    /// gain, AGC state, saturation, CRC-32C).
    ///
    /// ``image`` is a ``RenderResult`` rendered with ``sensor=`` (its
    /// detected band), or a 2-D array of any float (or integer) dtype and
    /// any layout (float32, Fortran order, strided views: converted to
    /// float64, exactly): detected-electron radiance (e⁻ s⁻¹ m⁻² sr⁻¹)
    /// with ``input="detected"`` (default), or mean photoelectrons per
    /// pixel per frame with ``input="photoelectrons"``. ``gain`` fixes the
    /// tube gain (override); ``agc=True`` lets the AGC servo it; ``noise``
    /// False gives the mean response; ``seed`` gives the same frames as
    /// ``gloam render --sensor … --seed``. ``progress`` (``True`` for a
    /// tqdm bar, or a callable ``progress(done, total, "frames")``) is
    /// told after each frame; an exception it raises stops the capture.
    /// The GIL is released; Ctrl-C stops between frames.
    #[pyo3(signature = (image, frames = Count(1), gain = None, agc = false, seed = Count(0), noise = true, input = "detected", progress = None))]
    #[allow(clippy::too_many_arguments)]
    fn capture(
        &self,
        py: Python<'_>,
        image: &Bound<'_, PyAny>,
        frames: Count<u32>,
        gain: Option<f64>,
        agc: bool,
        seed: Count<u64>,
        noise: bool,
        input: &str,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Capture> {
        let (frames, seed) = (frames.0, seed.0);
        if frames == 0 {
            return Err(GloamError::new_err("frames must be at least 1"));
        }
        if frames > MAX_CAPTURE_FRAMES {
            return Err(GloamError::new_err(format!(
                "frames = {frames}: at most {MAX_CAPTURE_FRAMES} frames per capture"
            )));
        }
        if gain.is_some() && agc {
            return Err(GloamError::new_err("give gain= or agc=True, not both"));
        }
        let input = if let Ok(r) = image.cast::<RenderResult>() {
            let d = r.get().detected_view(py).ok_or_else(|| {
                GloamError::new_err(
                    "this render has no detected band: render it with sensor=… to capture it",
                )
            })?;
            Input::Detected(d.readonly().as_array().to_owned())
        } else {
            let a = float64_image(py, image, frames)?;
            let a = a.as_array().to_owned();
            match input {
                "detected" => Input::Detected(a),
                "photoelectrons" => Input::Photoelectrons(a),
                other => {
                    return Err(GloamError::new_err(format!(
                        "input: '{other}' is neither 'detected' nor 'photoelectrons'"
                    )));
                }
            }
        };
        let mut config = self.config.clone();
        config.noise.seed = seed;
        let source = self.source.clone();
        let sink = ProgressSink::new(py, progress, "capture")?;
        let sink_ref = SameThread(&sink);
        let r = py.detach(move || -> anyhow::Result<_> {
            let sink = sink_ref.into_inner();
            let mut camera = Camera::new(config)?;
            camera.set_noise(noise);
            if let Some(g) = gain {
                camera.set_override_gain(Some(g))?;
            }
            if agc {
                camera.set_agc(true);
            }
            let mut stack: Option<Array3<u16>> = None;
            let mut records = Vec::new();
            for i in 0..frames {
                if signalled() {
                    anyhow::bail!("interrupted");
                }
                let frame = match &input {
                    Input::Detected(d) => camera.capture_detected(d.view()),
                    Input::Photoelectrons(p) => camera.capture_photoelectrons(p.view()),
                }
                .map_err(|e| anyhow::anyhow!("capturing frame {i}: {e}"))?;
                let view = frame.view()?;
                let st = stack.get_or_insert_with(|| {
                    Array3::zeros((frames as usize, view.nrows(), view.ncols()))
                });
                st.index_axis_mut(ndarray::Axis(0), i as usize)
                    .assign(&view);
                let warnings = frame.exposure().warnings;
                let file = format!("frame-{i:06}.png");
                records.push(FrameRecord::of_frame(u64::from(i), file, &frame, warnings));
                if !sink.tell(u64::from(i) + 1, u64::from(frames), "frames") {
                    anyhow::bail!("stopped by the progress callback");
                }
            }
            Ok(SameThread((stack, records)))
        });
        sink.close(py);
        let SameThread((stack, records)) = finish(r)?;
        let stack = stack.ok_or_else(|| GloamError::new_err("no frame was captured"))?;
        Ok(Capture {
            frames: stack.into_pyarray(py).unbind(),
            meta: to_py_as(py, &records, "FrameRecord")?.unbind(),
            sensor: source,
        })
    }

    /// ``Sensor('preset-or-path')``.
    fn __repr__(&self) -> String {
        format!("Sensor('{}')", self.source)
    }
}

/// `image` as a 2-D float64 array: any real dtype and layout, converted
/// exactly (NumPy's `astype`), its size checked before anything is
/// copied: a broadcast view costs nothing to pass in and everything to copy.
fn float64_image<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    frames: u32,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let refuse = |what: String| {
        GloamError::new_err(format!(
            "image: expected a RenderResult or a 2-D float array (row × column), got {what}"
        ))
    };
    let np = py.import("numpy")?;
    let a = np
        .call_method1("asarray", (image,))
        .map_err(|e| refuse(e.to_string()))?;
    let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    if !matches!(kind.as_str(), "f" | "i" | "u") {
        let dtype = a.getattr("dtype")?.str()?.to_string();
        return Err(refuse(format!("dtype {dtype}")));
    }
    let [h, w] = shape[..] else {
        return Err(refuse(format!("{} dimensions", shape.len())));
    };
    check_capture_size(h, w, frames)?;
    let f64_type = np.getattr("float64")?;
    let a = a.call_method(
        "astype",
        (f64_type,),
        Some(&[("copy", false)].into_py_dict(py)?),
    )?;
    a.extract::<PyReadonlyArray2<'py, f64>>()
        .map_err(|e: PyErr| refuse(e.to_string()))
}

/// Frames from ``Sensor.capture``: ``frames`` (uint16, frames × row ×
/// column) and ``meta`` (a list of per-frame dicts, the ``frames.jsonl``
/// records: ``gain``, ``agc``, ``sensor.agc_state``, ``mean_dn``,
/// ``saturated_fraction``, ``pixels_crc32c``, …).
#[pyclass(module = "gloam", frozen)]
pub struct Capture {
    /// The frames: uint16, frames × row × column, digital counts.
    #[pyo3(get)]
    frames: Py<PyArray3<u16>>,
    /// One ``FrameRecord`` per frame (the ``frames.jsonl`` record, a dict
    /// with attribute access).
    #[pyo3(get)]
    meta: Py<PyAny>,
    /// The preset name or sensor file the frames were captured with.
    #[pyo3(get)]
    sensor: String,
}

#[pymethods]
impl Capture {
    /// The number of frames.
    fn __len__(&self, py: Python<'_>) -> usize {
        self.frames.bind(py).shape()[0]
    }

    /// ``frames``, ``meta`` and ``sensor`` as a plain dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let d = pyo3::types::PyDict::new(py);
        d.set_item("frames", &self.frames)?;
        d.set_item("meta", &self.meta)?;
        d.set_item("sensor", &self.sensor)?;
        Ok(d)
    }

    /// ``capture["frames"]`` as ``capture.frames``.
    fn __getitem__<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        crate::convert::dict_item(self.to_dict(py)?, key)
    }

    /// ``Capture('sensor', frames (n, rows, columns))``.
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Capture('{}', frames {:?})",
            self.sensor,
            self.frames.bind(py).shape()
        )
    }
}

/// Most frames one `Sensor.capture` takes (as `gloam capture --frames`).
const MAX_CAPTURE_FRAMES: u32 = 1_000_000;
/// Most pixels a captured image has (as a render: 8192 × 8192).
const MAX_CAPTURE_PIXELS: u64 = 1 << 26;

/// Refuses an image or a frame stack too large to hold (the input copy,
/// 8 bytes a pixel, and the stack, 2 bytes a pixel a frame), against the
/// pixel limit and 80 % of the memory available, before anything is
/// allocated: a `GloamError`, never an abort.
fn check_capture_size(h: usize, w: usize, frames: u32) -> PyResult<()> {
    let pixels = (h as u64).saturating_mul(w as u64);
    if pixels == 0 || pixels > MAX_CAPTURE_PIXELS {
        return Err(GloamError::new_err(format!(
            "image: {h}×{w} pixels; a capture takes 1 to {MAX_CAPTURE_PIXELS} pixels (8192×8192)"
        )));
    }
    let bytes = pixels.saturating_mul(8 + 2 * frames as u64);
    let available = gloam_scene::available_memory_bytes();
    if let Some(avail) = available.filter(|&a| bytes > a / 10 * 8) {
        return Err(GloamError::new_err(format!(
            "a {h}×{w} capture of {frames} frame(s) needs about {:.1} GiB, more than 80 % of the {:.1} GiB available",
            bytes as f64 / (1u64 << 30) as f64,
            avail as f64 / (1u64 << 30) as f64
        )));
    }
    Ok(())
}
