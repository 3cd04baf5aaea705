//! A traced scene for a simulated camera to look at: `gloam device --scene`
//! and `sim:PRESET?scene=PATH` grabbers (in `capture` and `calibrate`).
//!
//! The scene is rendered once, with default render settings (seed 0), so the
//! emulator and the in-process grabber see bit-identical radiance. As in
//! `render --sensor`, each band's response curve stands in for the spectrum
//! inside the band.

use std::path::Path;
use std::sync::Arc;

use anyhow::Context;
use gloam_grabber::{SceneRenderer, SceneView};
use gloam_trace::{RenderSettings, Tracer};

/// Renders `path` at `size` (width, height; default the scene camera's,
/// keeping its horizontal field of view).
pub fn render_scene_view(path: &str, size: Option<(u32, u32)>) -> anyhow::Result<SceneView> {
    let mut scene = gloam_scene::load(Path::new(path))?;
    if let Some((w, h)) = size {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    let tracer = Tracer::new(&scene, &RenderSettings::default())?;
    let out = tracer.render(&|_, _| {})?;
    let band_shapes = out
        .band_names
        .iter()
        .map(|name| {
            scene
                .band(name)
                .map(|b| b.response.clone())
                .with_context(|| format!("band '{name}' missing from the scene"))
        })
        .collect::<anyhow::Result<_>>()?;
    Ok(SceneView {
        label: path.to_string(),
        radiance_w_m2_sr: out.radiance,
        band_shapes,
    })
}

/// [`render_scene_view`] as the grabber crate's [`SceneRenderer`].
pub fn scene_renderer() -> SceneRenderer {
    Arc::new(|path, size| render_scene_view(path, size).map_err(|e| format!("{e:#}")))
}
