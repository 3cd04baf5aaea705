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

use crate::fit::FitVerdict;
use crate::render::{RenderError, RenderJob};
use gloam_grabber::{GrabError, Registry};
use gloam_simcam::{SceneImage, SceneView};
use gloam_trace::RenderSettings;
use ndarray::Array2;

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
/// default the scene camera's, keeping its horizontal field of view);
/// `reads` notes the scene and its files.
pub fn render_scene_view(
    path: &str,
    sensor: &crate::ResolvedSensor,
    size: Option<(u32, u32)>,
    reads: &gloam_io::ReadLog,
) -> Result<SceneView, SceneViewError> {
    let scene = gloam_scene::load(Path::new(path), reads)?;
    scene_view_of(scene, path, sensor, size)
}

/// [`render_scene_view`] of a scene already loaded (from `path`, which
/// labels the view): a caller that read the scene for its `sensor` entry
/// does not read it twice.
pub fn scene_view_of(
    mut scene: gloam_scene::Scene,
    path: &str,
    sensor: &crate::ResolvedSensor,
    size: Option<(u32, u32)>,
) -> Result<SceneView, SceneViewError> {
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

/// Renders a loaded scene as [`scene_view_of`] does, but one detected-radiance
/// layer per light group (e⁻ s⁻¹ m⁻² sr⁻¹, row × column) instead of their
/// sum: the group names in the scene's order and their layers, which any
/// weighting of the groups mixes into a frame (`gloam device --sequence`).
/// Only the layers are traced (not the ordinary image they sum to).
pub fn render_scene_layers(
    mut scene: gloam_scene::Scene,
    sensor: &crate::ResolvedSensor,
    size: Option<(u32, u32)>,
) -> Result<(Vec<String>, Vec<Array2<f64>>), SceneViewError> {
    if let Some((w, h)) = size {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    let settings = RenderSettings::default();
    // Only the layers (a device never shows their sum): the tracer is
    // prepared for them — its cache solved per group once — and each
    // layer's detected band taken off directly.
    let banded = crate::with_detected_band(&scene, sensor).map_err(RenderError::from)?;
    let map = gloam_trace::layers::LayerMap::of(&scene);
    let mut tracer = gloam_trace::Tracer::prepare_layered(&banded, &settings, None, &map)
        .map_err(RenderError::from)?;
    let height = tracer.image_size().1;
    let outputs = tracer
        .render_layers(&map, 0..height, &|_, _| {}, &|| false)
        .map_err(RenderError::from)?;
    let layers = outputs
        .into_iter()
        .map(|mut o| crate::take_detected_band(&mut o).map_err(RenderError::from))
        .collect::<Result<Vec<_>, _>>()?;
    let groups = scene
        .light_groups
        .groups
        .iter()
        .map(|g| g.name.clone())
        .collect();
    Ok((groups, layers))
}

/// Whether the camera `sensor` can see `view` at any gain it reaches: the
/// fit's note (the same words `render --sensor` prints) when it saturates
/// or sits in the noise at every gain, `None` when some gain fits. A
/// capture's gain is set later, so only the gain-independent verdicts speak.
pub fn scene_view_fit_note(view: &SceneView, sensor: &crate::ResolvedSensor) -> Option<String> {
    let SceneImage::Detected { e_s_m2_sr } = &view.image else {
        return None;
    };
    let fit = crate::fit::predict(sensor.config(), e_s_m2_sr, None).ok()?;
    matches!(
        fit.verdict,
        FitVerdict::SaturatesAtEveryGain | FitVerdict::InTheNoiseAtEveryGain
    )
    .then(|| {
        let n = &fit.note;
        n.strip_suffix(crate::fit::EXPOSURE_AUTO_HINT)
            .unwrap_or(n)
            .to_string()
    })
}

/// Every grabber the CLI and Python open: the transports and `sim:` rigs
/// ([`gloam_simcam::registry`]), with `sim:` here also taking
/// `?scene=PATH`, rendered by [`render_scene_view`] before the camera
/// looks — this crate owns scenes, so the camera never calls back up.
pub fn grabbers() -> Registry {
    grabbers_noting(Arc::new(|_| {}))
}

/// [`grabbers`], with `note` told (before the first frame) when a
/// `sim:…?scene=` camera cannot fit its scene at any gain
/// ([`scene_view_fit_note`]).
pub fn grabbers_noting(note: Arc<dyn Fn(&str) + Send + Sync>) -> Registry {
    let mut r = gloam_simcam::registry();
    r.register(
        "sim",
        Arc::new(move |uri, opts| {
            let view = match gloam_simcam::SimUri::parse(uri)? {
                gloam_simcam::SimUri {
                    preset,
                    size,
                    scene: Some(path),
                    ..
                } => {
                    let view = crate::resolve_sensor(&preset, &opts.reads)
                        .map_err(|e| SceneViewError::from(RenderError::from(e)))
                        .and_then(|sensor| {
                            let view = render_scene_view(&path, &sensor, size, &opts.reads)?;
                            Ok((scene_view_fit_note(&view, &sensor), view, sensor))
                        });
                    let (fit, view, sensor) = view.map_err(|e| GrabError::Scene {
                        path,
                        source: e.into(),
                    })?;
                    if let Some(n) = fit {
                        note(&n);
                    }
                    Some((view, sensor))
                }
                _ => None,
            };
            // The camera is the sensor the scene was rendered through.
            match view {
                Some((view, sensor)) => gloam_simcam::open_sim(uri, opts, Some((view, &sensor))),
                None => gloam_simcam::open_sim(uri, opts, None),
            }
        }),
    );
    r
}
