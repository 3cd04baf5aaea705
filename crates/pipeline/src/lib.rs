#![doc = include_str!("../README.md")]

pub mod camera_goal;
pub mod capture;
pub mod capture_request;
#[cfg(feature = "cli")]
pub mod cli;
pub mod detected;
pub mod exposure;
pub mod fit;
pub mod frame_files;
pub mod frames;
pub mod output;
pub mod provenance;
pub mod render;
pub mod request;
pub mod scene_view;
pub mod sequence;
pub mod sequence_request;
pub mod tile;

pub use detected::{DETECTED_BAND, DetectedError, take_detected_band, with_detected_band};
pub use frame_files::FrameFormat;
pub use frames::{
    CaptureError, CaptureOptionsError, Captured, Capturing, FrameCapture, FrameContext,
    FrameRecord, FrameWriter, check_options, resolve_scene_sensor, resolve_sensor,
};
/// Most independent estimates a probe averages (each is a full estimate
/// at the point): `gloam probe --samples` and Python's `probe(samples=)`
/// alike (Python took 10⁹ and ran for hours).
pub const MAX_PROBE_SAMPLES: u32 = 1_000_000;
pub use gloam_sensor::ResolvedSensor;
pub use provenance::Provenance;
pub use render::{
    DEFAULT_TARGET_ERROR, Layers, PreparedRender, RenderError, RenderJob, Rendered, SettingArgs,
    TargetErrorSource,
};
pub use request::{Events, RenderDone, RenderReport, RenderRequest, SceneInput, ValidRender};
pub use scene_view::{
    SceneViewError, grabbers, grabbers_noting, render_scene_view, scene_view_fit_note,
};
pub use sequence_request::{SequenceRequest, ValidSequence};
