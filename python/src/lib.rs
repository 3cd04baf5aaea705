//! `import gloam`: the library crates as a Python extension module.
//!
//! Every call goes straight to the Rust crates (no subprocess). Long calls
//! (renders, captures, calibrations) release the GIL and poll Python's
//! signal handlers, so Ctrl-C raises `KeyboardInterrupt` within a tile or a
//! frame (and pass progress to a `progress=` callback); results are
//! `gloam.Result` dicts with attribute access; every other error is a `gloam.GloamError` carrying the CLI's
//! message (`file:line: field: …` for scene files).

use pyo3::prelude::*;

mod calib;
mod convert;
mod errors;
mod grabber;
mod interrupt;
mod render;
mod sensor;
mod sky;
mod sweep;

#[pymodule]
fn _gloam(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("GloamError", m.py().get_type::<errors::GloamError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    render::register(m)?;
    sensor::register(m)?;
    grabber::register(m)?;
    calib::register(m)?;
    sky::register(m)?;
    sweep::register(m)?;
    Ok(())
}
