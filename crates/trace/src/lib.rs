// The README is the crate doc; its usage sketch is not a compiled doctest.
#![cfg_attr(not(doctest), doc = include_str!("../README.md"))]

pub mod cache_check;
pub mod closed_form;
pub(crate) mod direct_view;
pub mod geometry;
pub(crate) mod guide;
pub mod indirect;
pub(crate) mod integrator;
pub mod layers;
pub(crate) mod light;
pub(crate) mod lights;
pub mod plan;
pub mod prep;
pub mod render;
pub(crate) mod sampler;
pub mod sampling;
pub mod settings;
pub mod sky_light;
pub mod spectral;
pub mod tracer;
pub(crate) mod world;

pub use glam::DVec3;
pub use layers::{LayerError, LayerMap};
pub use prep::{PrepEvent, PrepObserver, PrepStep, Preparation};
pub use render::{PixelGoal, ProbeResult, RenderOutput, RenderStats, probe_point, render};
pub use settings::{
    Dirsig2001Settings, Dropped, Estimator, Indirect, LightTreeSplit, Occlusion, RenderSettings,
    SettingsError,
};
pub use sky_light::SkySummary;
pub use tracer::{RayCounts, SkyProbeResult, TraceError, Tracer};
