#![doc = include_str!("../README.md")]
// `!(x > 0.0)` is deliberate throughout: it is true for NaN as well, so a
// non-finite input is rejected instead of slipping through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod agc;
pub mod agc_sequence;
pub mod apply;
pub mod capture;
#[cfg(feature = "cli")]
pub mod cli;
mod error;
pub mod io;
pub mod mtf;
pub mod mtf_flow;
pub mod mtf_voltage;
pub mod plot;
pub mod ptc;
pub mod radiance;
pub mod report;
pub mod request;
pub mod rig_check;
pub mod scope_plot;
pub mod scope_run;
pub mod source;
pub mod stats;
pub mod validate;

pub use error::CalibError;
