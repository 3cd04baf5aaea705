//! gloam-calib: calibration flows over any [`gloam_grabber::FrameGrabber`] —
//! radiance look-up tables, AGC linearisation, EMVA 1288 photon transfer,
//! MTF (sine, USAF 1951 with Coltman's conversion, ISO 12233 slanted edge),
//! validation metrics, and JSON/Markdown/PNG reports.
//!
//! Nothing here knows which grabber it talks to: every flow calls
//! `grabber.present(&stimulus)` (simulated cameras render it; real hardware
//! returns false and the operator sets the source) and then grabs.

pub mod agc;
pub mod capture;
mod error;
pub mod mtf;
pub mod plot;
pub mod ptc;
pub mod radiance;
pub mod report;
pub mod source;
pub mod stats;
pub mod validate;

pub use error::CalibError;
