#![doc = include_str!("../README.md")]

#[cfg(feature = "cli")]
pub mod cli;
mod exposure;
mod grabber;
mod scene;
mod source;
mod stimulus;
pub mod uri;

use std::sync::Arc;

use gloam_grabber::{FrameGrabber, GrabError, GrabberList, OpenOptions, Registry, SimInfo};

pub use exposure::{FrameExposure, FrameExposureExt};
pub use grabber::{SimGrabber, gain_range_error};
pub use scene::{LayerWeights, SceneImage, SceneView, layers_between, mix_layers};
pub use source::SensorSource;
pub use stimulus::{DEFAULT_RIG_SIZE, DEFAULT_SPECTRUM, render_stimulus, rig_stimulus};
pub use uri::{DEFAULT_RIG, DEFAULT_SIM_PRESET, RIGS, SimUri};

/// Opens a `sim:` URI: the rig it names, or `scene` when the caller
/// rendered the URI's scene through the sensor it resolved from the URI
/// (the camera then uses that configuration, not a second read of the
/// preset; a scene URI without one is refused, naming who renders
/// scenes). `opts.seed` (`--seed`) stands in for a URI without `seed=`
/// and must agree with one that has it.
pub fn open_sim(
    uri: &str,
    opts: &OpenOptions,
    scene: Option<(SceneView, &gloam_sensor::ResolvedSensor)>,
) -> Result<Box<dyn FrameGrabber>, GrabError> {
    let SimUri {
        preset,
        rig,
        seed,
        size,
        scene: scene_path,
    } = SimUri::parse(uri)?;
    let seed = uri::agreed_seed(uri, seed, opts.seed)?;
    match (scene_path, scene) {
        (Some(_), Some((view, sensor))) => {
            Ok(Box::new(SimGrabber::from_scene(sensor, view, seed)?))
        }
        (Some(_), None) => Err(GrabError::Unsupported(format!(
            "'{uri}': scenes need a renderer (the gloam CLI provides one)"
        ))),
        (None, _) => Ok(Box::new(SimGrabber::from_preset(
            &preset,
            &rig,
            seed,
            size.unwrap_or(DEFAULT_RIG_SIZE),
            &opts.reads,
        )?)),
    }
}

/// The transports plus `sim:` rigs. Scenes are `gloam-pipeline`'s to
/// register: it renders them before the camera looks.
pub fn registry() -> Registry {
    let mut r = Registry::transports();
    r.register("sim", Arc::new(|uri, opts| open_sim(uri, opts, None)));
    r
}

/// Opens a grabber by URI through [`registry`] with default options.
pub fn open(uri: &str) -> Result<Box<dyn FrameGrabber>, GrabError> {
    registry().open(uri, &OpenOptions::default())
}

/// [`gloam_grabber::list_grabbers`] plus every sensor preset and rig.
pub fn list_grabbers() -> GrabberList {
    let mut list = gloam_grabber::list_grabbers();
    list.sim = gloam_sensor::presets()
        .into_iter()
        .map(|(name, description)| SimInfo {
            uri: format!("sim:{name}"),
            description,
        })
        .collect();
    list.sim.extend(RIGS.iter().map(|(name, d)| SimInfo {
        uri: format!("sim:{name}"),
        description: format!("rig: {d} (sensor {DEFAULT_SIM_PRESET})"),
    }));
    list
}
