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

use crate::detected::{take_detected_band, with_detected_band};
use gloam_grabber::{SceneImage, SceneRenderer, SceneView};
use gloam_trace::{RenderSettings, Tracer};

/// Renders `path` for the camera `sensor` at `size` (width, height;
/// default the scene camera's, keeping its horizontal field of view).
pub fn render_scene_view(
    path: &str,
    sensor: &str,
    size: Option<(u32, u32)>,
) -> anyhow::Result<SceneView> {
    let mut scene = gloam_scene::load(Path::new(path))?;
    if let Some((w, h)) = size {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    let traced = with_detected_band(&scene, sensor)?;
    let tracer = Tracer::new(&traced, &RenderSettings::default())?;
    let mut out = tracer.render(&|_, _| {})?;
    let detected = take_detected_band(&mut out)?;
    Ok(SceneView {
        label: path.to_string(),
        image: SceneImage::Detected {
            e_s_m2_sr: detected,
        },
    })
}

/// [`render_scene_view`] as the grabber crate's [`SceneRenderer`].
pub fn scene_renderer() -> SceneRenderer {
    Arc::new(|path, sensor, size| {
        render_scene_view(path, sensor, size).map_err(|e| format!("{e:#}"))
    })
}
