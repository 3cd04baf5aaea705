//! gloam's spectral ray tracer.
//!
//! `closed_form` and `sampling` hold the exact irradiance formulas and the
//! solid-angle samplers the area-source estimators are built on.

pub mod closed_form;
pub mod sampling;
