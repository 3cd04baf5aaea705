//! A traced scene for a simulated camera to look at: `gloam device --scene`
//! and `sim:PRESET?scene=PATH` grabbers (in `capture` and `calibrate`).
//!
//! The scene is rendered once, with default render settings (seed 0), so the
//! emulator and the in-process grabber see bit-identical radiance. As in
//! `render --sensor`, the render carries a band weighted by the camera's
//! detector response, so the camera sees the detected-electron radiance,
//! exact for any spectrum.

use std::path::Path;
use std::sync::Arc;

use crate::render::{RenderError, RenderJob};
use gloam_grabber::{GrabError, GrabberUri, Registry};
use gloam_simcam::{SceneImage, SceneView};
use gloam_trace::RenderSettings;

/// Why a scene view was not rendered.
#[derive(Debug, thiserror::Error)]
pub enum SceneViewError {
    #[error(transparent)]
    Scene(#[from] gloam_scene::SceneError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error("{0}: the render carried no detected band")]
    NoDetectedBand(String),
}

/// Renders `path` for the camera `sensor` at `size` (width, height;
/// default the scene camera's, keeping its horizontal field of view).
pub fn render_scene_view(
    path: &str,
    sensor: &str,
    size: Option<(u32, u32)>,
) -> Result<SceneView, SceneViewError> {
    let mut scene = gloam_scene::load(Path::new(path))?;
    if let Some((w, h)) = size {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    let settings = RenderSettings::default();
    let job = RenderJob {
        camera: Some(sensor),
        ..RenderJob::new(&scene, &settings)
    };
    let detected = job
        .run(&|_, _| {}, &|| false)?
        .detected
        .ok_or_else(|| SceneViewError::NoDetectedBand(path.to_string()))?;
    Ok(SceneView {
        label: path.to_string(),
        image: SceneImage::Detected {
            e_s_m2_sr: detected,
        },
    })
}

/// Every grabber the CLI and Python open: the transports and `sim:` rigs
/// ([`gloam_simcam::registry`]), with `sim:` here also taking
/// `?scene=PATH`, rendered by [`render_scene_view`] before the camera
/// looks — this crate owns scenes, so the camera never calls back up.
pub fn grabbers() -> Registry {
    let mut r = gloam_simcam::registry();
    r.register(
        "sim",
        Arc::new(|uri, opts| {
            let view =
                match GrabberUri::parse(uri)? {
                    GrabberUri::Sim {
                        preset,
                        size,
                        scene: Some(path),
                        ..
                    } => Some(render_scene_view(&path, &preset, size).map_err(|e| {
                        GrabError::Scene {
                            path,
                            source: e.into(),
                        }
                    })?),
                    _ => None,
                };
            gloam_simcam::open_sim(uri, opts, view)
        }),
    );
    r
}
