#![doc = include_str!("../README.md")]

pub mod bench;
pub mod detected;
pub mod exposure;
pub mod frames;
pub mod output;
pub mod output_set;
pub mod provenance;
pub mod render;
pub mod scene_view;

pub use detected::{DETECTED_BAND, take_detected_band, with_detected_band};
pub use frames::{FrameCapture, FrameLog, FrameRecord, check_options};
pub use output_set::OutputSet;
pub use provenance::Provenance;
pub use scene_view::{grabbers, render_scene_view};
