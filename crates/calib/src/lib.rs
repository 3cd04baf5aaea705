//! gloam-calib: calibration flows over any [`gloam_grabber::FrameGrabber`] —
//! radiance look-up tables, AGC linearisation, EMVA 1288 photon transfer,
//! MTF (sine, USAF 1951 with Coltman's conversion, ISO 12233 slanted edge),
//! validation metrics, and JSON/Markdown/PNG reports.
//!
//! Nothing here knows which grabber it talks to: every flow calls
//! `grabber.present(&stimulus)` (simulated cameras render it; real hardware
//! returns false and the operator sets the source) and then grabs.

// `!(x > 0.0)` is deliberate throughout: it is true for NaN as well, so a
// non-finite input is rejected instead of slipping through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod agc;
pub mod capture;
mod error;
pub mod io;
pub mod mtf;
pub mod plot;
pub mod ptc;
pub mod radiance;
pub mod report;
pub mod source;
pub mod stats;
pub mod validate;

pub use error::CalibError;
