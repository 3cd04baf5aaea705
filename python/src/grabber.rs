//! Frame grabbers: the CLI's URIs (`sim:…`, `serial:…`, `usb:…`) as a
//! Python context manager.

use gloam_grabber::{DeviceControl, FrameGrabber, GrabError, OpenOptions, Stimulus};
use ndarray::Array2;
use numpy::prelude::*;
use numpy::{IntoPyArray, PyArray2};
use pyo3::prelude::*;

use crate::convert::{Count, from_py, to_py_as};
use crate::errors::GloamError;
use crate::interrupt::{SameThread, finish, signalled};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Grabber>()?;
    m.add_class::<PyFrame>()?;
    m.add_class::<FrameStream>()?;
    m.add_function(wrap_pyfunction!(open_grabber, m)?)?;
    Ok(())
}

/// An open grabber. Use it as a context manager (``with
/// gloam.open_grabber(uri) as g:``); it is bound to the thread that opened it.
#[pyclass(module = "gloam", unsendable)]
pub struct Grabber {
    inner: Option<Box<dyn FrameGrabber>>,
    uri: String,
    /// The `seed=` it was opened with (a `sim:` camera's noise seed).
    seed: Option<u64>,
}

/// A grabber that stops a calibration flow at Ctrl-C: each grab first runs
/// Python's signal handlers.
pub struct StopOnSignal<'a>(pub &'a mut dyn FrameGrabber);

impl DeviceControl for StopOnSignal<'_> {
    fn describe(&self) -> String {
        self.0.describe()
    }
    fn frame_size(&self) -> (u32, u32) {
        self.0.frame_size()
    }
    fn set_gain(&mut self, gain: f64) -> Result<f64, GrabError> {
        self.0.set_gain(gain)
    }
    fn set_agc(&mut self, on: bool) -> Result<bool, GrabError> {
        self.0.set_agc(on)
    }
    fn set_bits(&mut self, bits: u8) -> Result<u8, GrabError> {
        self.0.set_bits(bits)
    }
    fn set_exposure_s(&mut self, exposure_s: f64) -> Result<f64, GrabError> {
        self.0.set_exposure_s(exposure_s)
    }
    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        self.0.present(stimulus)
    }
}

// Named in full: `FrameStream` here is the Python frame iterator.
impl gloam_grabber::FrameStream for StopOnSignal<'_> {
    fn grab(&mut self) -> Result<gloam_grabber::Frame, GrabError> {
        if signalled() {
            return Err(GrabError::Other("interrupted".into()));
        }
        self.0.grab()
    }
    fn stop(&mut self) -> Result<(), GrabError> {
        self.0.stop()
    }
}

impl Grabber {
    /// The URI the grabber was opened with.
    pub fn uri(&self) -> &str {
        &self.uri
    }

    /// The seed it was opened with, overriding the URI's.
    pub fn seed(&self) -> Option<u64> {
        self.seed
    }

    /// The open grabber, or an error once closed.
    pub fn get(&mut self) -> PyResult<&mut Box<dyn FrameGrabber>> {
        self.inner
            .as_mut()
            .ok_or_else(|| GloamError::new_err(format!("grabber '{}' is closed", self.uri)))
    }

    /// Runs `f` on the grabber with the GIL released, Ctrl-C honoured at
    /// every grab.
    pub fn run<T>(
        &mut self,
        py: Python<'_>,
        f: impl FnOnce(&mut dyn FrameGrabber) -> anyhow::Result<T>,
    ) -> PyResult<T> {
        let g = SameThread((self.get()?, f));
        let r = py.detach(move || {
            let (g, f) = g.into_inner();
            SameThread(f(&mut StopOnSignal(g.as_mut())))
        });
        finish(r.0)
    }
}

/// Opens a grabber by URI, as ``gloam capture --grabber URI``:
/// ``sim:PRESET[?size=WxH&seed=S&scene=PATH]`` (the simulated camera),
/// ``serial:PATH[?baud=N]``, ``usb:VID:PID[:SERIAL]`` and, in a build
/// with the ``genicam`` feature, ``genicam:[DEVICE-ID]`` (a GigE Vision
/// camera through Aravis, e.g. gloam's own ``gloam device``). ``seed``
/// overrides a ``sim:`` URI's seed. Returns a ``Grabber`` (a context
/// manager); ``gloam grabbers`` lists the kinds this build has.
#[pyfunction]
#[pyo3(signature = (uri, seed = None))]
fn open_grabber(py: Python<'_>, uri: &str, seed: Option<Count<u64>>) -> PyResult<Grabber> {
    let seed = seed.map(|s| s.0);
    let opts = OpenOptions {
        seed,
        ..OpenOptions::default()
    };
    let u = uri.to_string();
    // A `sim:…?scene=` camera that cannot fit its scene at any gain says so
    // (as `gloam capture` does): a UserWarning once the grabber is open.
    let notes = std::sync::Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
    let sink = notes.clone();
    let r = py.detach(move || {
        let grabbers = gloam_pipeline::grabbers_noting(std::sync::Arc::new(move |n: &str| {
            if let Ok(mut v) = sink.lock() {
                v.push(n.to_string());
            }
        }));
        SameThread(
            grabbers
                .open(&u, &opts)
                .map_err(|e| anyhow::Error::from(e).context(format!("opening {u}"))),
        )
    });
    let notes: Vec<String> = notes.lock().map(|v| v.clone()).unwrap_or_default();
    for n in notes {
        let msg = std::ffi::CString::new(n).unwrap_or_default();
        PyErr::warn(
            py,
            &py.get_type::<pyo3::exceptions::PyUserWarning>(),
            &msg,
            1,
        )?;
    }
    Ok(Grabber {
        inner: Some(finish(r.0)?),
        uri: uri.to_string(),
        seed,
    })
}

fn frame_of(py: Python<'_>, f: gloam_grabber::Frame) -> PyResult<PyFrame> {
    let (w, h) = (f.meta.width as usize, f.meta.height as usize);
    let pixels = Array2::from_shape_vec((h, w), f.pixels).map_err(|e| {
        GloamError::new_err(format!(
            "frame {}: pixels do not fill {w}×{h}: {e}",
            f.meta.seq
        ))
    })?;
    Ok(PyFrame {
        gain: f.meta.gain,
        meta: to_py_as(py, &f.meta, "FrameMeta")?.unbind(),
        pixels: pixels.into_pyarray(py).unbind(),
    })
}

#[pymethods]
impl Grabber {
    /// The grabber itself (``with gloam.open_grabber(uri) as g:``).
    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Closes the grabber at the end of the ``with`` block.
    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, _args: &Bound<'_, pyo3::types::PyTuple>) -> bool {
        self.inner = None;
        false
    }

    /// Closes the grabber (also done by leaving the ``with`` block).
    fn close(&mut self) {
        self.inner = None;
    }

    /// What the grabber is (device, camera, link).
    fn describe(&mut self) -> PyResult<String> {
        Ok(self.get()?.describe())
    }

    /// ``(width, height)`` of its frames.
    #[getter]
    fn frame_size(&mut self) -> PyResult<(u32, u32)> {
        Ok(self.get()?.frame_size())
    }

    /// Fixes the gain (AGC off); returns the gain the device took.
    fn set_gain(&mut self, py: Python<'_>, gain: f64) -> PyResult<f64> {
        self.run(py, |g| Ok(g.set_gain(gain)?))
    }

    /// AGC on or off; returns the state the device took.
    fn set_agc(&mut self, py: Python<'_>, on: bool) -> PyResult<bool> {
        self.run(py, |g| Ok(g.set_agc(on)?))
    }

    /// Exposure or gate time, seconds; returns what the device took.
    fn set_exposure(&mut self, py: Python<'_>, exposure_s: f64) -> PyResult<f64> {
        self.run(py, |g| Ok(g.set_exposure_s(exposure_s)?))
    }

    /// Digitizer bits; returns what the device took.
    fn set_bits(&mut self, py: Python<'_>, bits: Count<u8>) -> PyResult<u8> {
        let bits = bits.0;
        self.run(py, |g| Ok(g.set_bits(bits)?))
    }

    /// Shows a stimulus to a simulated camera, e.g. ``{"kind": "uniform",
    /// "radiance_w_m2_sr": 1e-6, "spectrum": "cie-a"}`` or ``{"kind":
    /// "dark"}``; returns whether the grabber can.
    fn present(&mut self, py: Python<'_>, stimulus: &Bound<'_, PyAny>) -> PyResult<bool> {
        let s: Stimulus = from_py(stimulus, "stimulus")?;
        self.run(py, |g| Ok(g.present(&s)?))
    }

    /// One frame (GIL released while it waits).
    fn grab(&mut self, py: Python<'_>) -> PyResult<PyFrame> {
        let f = self.run(py, |g| Ok(g.grab()?))?;
        frame_of(py, f)
    }

    /// An iterator over the next ``n`` frames (a ``FrameStream`` of ``Frame``).
    fn stream(slf: Py<Self>, n: u64) -> FrameStream {
        FrameStream {
            grabber: slf,
            left: n,
        }
    }

    /// ``Grabber('uri')`` (``, closed`` once closed).
    fn __repr__(&self) -> String {
        format!(
            "Grabber('{}'{})",
            self.uri,
            if self.inner.is_none() { ", closed" } else { "" }
        )
    }
}

/// One grabbed frame: ``pixels`` (uint16, row × column), ``gain`` and
/// ``meta`` (seq, timestamp_us, gain, agc, bits, width, height,
/// pixels_crc32c, status, levels).
///
/// Python's view of [`gloam_grabber::Frame`] (the one grabbed-frame type),
/// its pixels as a NumPy array; `Frame` to Python.
#[pyclass(name = "Frame", module = "gloam", frozen)]
pub struct PyFrame {
    /// The frame's counts: uint16, row × column.
    #[pyo3(get)]
    pub pixels: Py<PyArray2<u16>>,
    /// The gain in effect for the frame (linear factor).
    #[pyo3(get)]
    pub gain: f64,
    /// The frame's record: a ``FrameMeta`` (a dict with attribute access).
    #[pyo3(get)]
    pub meta: Py<PyAny>,
}

#[pymethods]
impl PyFrame {
    /// ``Frame((rows, columns), gain g)``.
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Frame({:?}, gain {})",
            self.pixels.bind(py).shape(),
            self.gain
        )
    }
}

/// The iterator ``Grabber.stream(n)`` returns.
#[pyclass(module = "gloam", unsendable)]
pub struct FrameStream {
    grabber: Py<Grabber>,
    left: u64,
}

#[pymethods]
impl FrameStream {
    /// The stream itself.
    fn __iter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// The next frame (GIL released while it waits); StopIteration after ``n``.
    fn __next__(&mut self, py: Python<'_>) -> PyResult<Option<PyFrame>> {
        if self.left == 0 {
            return Ok(None);
        }
        self.left -= 1;
        let mut g = self.grabber.bind(py).try_borrow_mut()?;
        let f = g.run(py, |g| Ok(g.grab()?))?;
        frame_of(py, f).map(Some)
    }
}
