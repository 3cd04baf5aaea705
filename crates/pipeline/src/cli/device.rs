//! What `gloam device` serves (`--pty` and `--gige` alike): the simulated
//! camera looking at a rig, a rendered scene (`--scene`) or a sequence's
//! light-group layers mixed per frame (`--sequence`). The arguments are
//! `gloam_simcam::cli`'s; the scene views are rendered here, where
//! rendering meets imaging.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use gloam_grabber::GrabError;
use gloam_scene::SceneError;
use gloam_simcam::cli::{DEFAULT_DEVICE_SENSOR, DeviceArgs};
use gloam_simcam::{DEFAULT_RIG_SIZE, LayerWeights, SceneImage, SceneView, SensorSource};

use crate::scene_view::SceneViewError;

/// Why the device's source could not be made.
#[derive(Debug, thiserror::Error)]
pub enum DeviceSourceError {
    #[error("sequence '{}'", path.display())]
    Sequence {
        path: PathBuf,
        #[source]
        source: SceneError,
    },
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("rendering the layers of scene '{scene}'")]
    Layers {
        scene: String,
        #[source]
        source: SceneViewError,
    },
    #[error("rendering scene '{scene}'")]
    View {
        scene: String,
        #[source]
        source: SceneViewError,
    },
    #[error(transparent)]
    SensorFile(#[from] crate::CaptureOptionsError),
    #[error("sensor '{sensor}'")]
    Sensor {
        sensor: String,
        #[source]
        source: GrabError,
    },
}

/// The source `--pty` and `--gige` serve: the camera, a label for
/// messages, and whether it shows a (fixed-size) rendered scene.
pub struct DeviceSource {
    pub source: SensorSource,
    /// The camera's preset or file: `--sensor`, else the scene's own.
    pub sensor: String,
    pub view: String,
    pub from_scene: bool,
}

/// `--sequence`: its scene's light-group layers, rendered once for the
/// camera, and the sequence's weights for any exposure window (looped over
/// its frames with `--loop`, else its last intensities held).
/// A device serves frames and writes no manifest: what it reads is listed
/// nowhere.
fn unlisted() -> gloam_io::ReadLog {
    gloam_io::ReadLog::off()
}

fn sequence_view(
    args: &DeviceArgs,
    sensor: &crate::ResolvedSensor,
    path: &str,
    note: &dyn Fn(&str),
) -> Result<SceneView, DeviceSourceError> {
    let seq =
        gloam_scene::sequence::load_sequence(Path::new(path), &unlisted()).map_err(|source| {
            DeviceSourceError::Sequence {
                path: path.into(),
                source,
            }
        })?;
    seq.check_static("gloam device --sequence")?;
    let scene = seq.scene.to_string_lossy().into_owned();
    note(&format!(
        "gloam device: rendering the light groups of {scene} …"
    ));
    let (groups, layers) =
        crate::scene_view::render_scene_layers(&scene, sensor, args.size, &unlisted()).map_err(
            |source| DeviceSourceError::Layers {
                scene: scene.clone(),
                source,
            },
        )?;
    seq.check_groups(groups.iter().map(String::as_str))?;
    let duration_s = f64::from(seq.frames) / seq.frame_rate_hz;
    let looped = args.loop_sequence;
    let frame_rate_hz = seq.frame_rate_hz;
    let weights = move |t0: f64, t1: f64| {
        let start = if looped {
            t0.rem_euclid(duration_s)
        } else {
            t0
        };
        seq.weights(groups.iter().map(String::as_str), start, start + (t1 - t0))
    };
    Ok(SceneView {
        label: path.to_string(),
        image: SceneImage::Layers {
            e_s_m2_sr: layers,
            frame_rate_hz,
            weights: LayerWeights(Arc::new(weights)),
        },
    })
}

/// The device's camera: `--sensor`, else the `sensor` entry of the scene
/// it looks at (`--scene`, or `--sequence`'s scene), as `render` and
/// `sequence` take it, else [`DEFAULT_DEVICE_SENSOR`]. A scene naming
/// gen3-gaas-iccd was served through gen2-s20-iccd without a word.
fn camera_name(args: &DeviceArgs) -> Result<String, DeviceSourceError> {
    if let Some(s) = &args.sensor {
        return Ok(s.clone());
    }
    let scene = match (&args.scene, &args.sequence) {
        (Some(path), _) => Some(PathBuf::from(path)),
        (None, Some(path)) => Some(
            gloam_scene::sequence::load_sequence(Path::new(path), &unlisted())
                .map_err(|source| DeviceSourceError::Sequence {
                    path: path.into(),
                    source,
                })?
                .scene,
        ),
        (None, None) => None,
    };
    let named = match scene {
        Some(p) => gloam_scene::load(&p, &unlisted())?.sensor,
        None => None,
    };
    Ok(named.unwrap_or_else(|| DEFAULT_DEVICE_SENSOR.to_string()))
}

/// The source from `--scene`, `--sequence` or `--rig`; `note` hears what
/// takes time and a scene the camera cannot fit at any gain.
pub fn device_source(
    args: &DeviceArgs,
    note: &dyn Fn(&str),
) -> Result<DeviceSource, DeviceSourceError> {
    let camera = camera_name(args)?;
    let sensor = |source| DeviceSourceError::Sensor {
        sensor: camera.clone(),
        source,
    };
    if let Some(path) = &args.sequence {
        // Read once: the layers are rendered through it, the camera is it.
        let resolved = crate::resolve_sensor(&camera, &unlisted())?;
        let view = sequence_view(args, &resolved, path, note)?;
        let source = SensorSource::with_scene(&resolved, view, args.seed).map_err(sensor)?;
        let view = format!("sequence '{path}'");
        return Ok(DeviceSource {
            source,
            sensor: camera,
            view,
            from_scene: true,
        });
    }
    if let Some(path) = &args.scene {
        note(&format!("gloam device: rendering {path} …"));
        let resolved = crate::resolve_sensor(&camera, &unlisted())?;
        let scene = crate::render_scene_view(path, &resolved, args.size, &unlisted()).map_err(
            |source| DeviceSourceError::View {
                scene: path.clone(),
                source,
            },
        )?;
        if let Some(fit) = crate::scene_view_fit_note(&scene, &resolved) {
            note(&format!("warning: {fit}"));
        }
        let source = SensorSource::with_scene(&resolved, scene, args.seed).map_err(sensor)?;
        let view = format!("scene '{path}'");
        return Ok(DeviceSource {
            source,
            sensor: camera,
            view,
            from_scene: true,
        });
    }
    let rig = (args.rig.as_deref()).unwrap_or(gloam_simcam::DEFAULT_RIG);
    let size = args.size.unwrap_or(DEFAULT_RIG_SIZE);
    let source = SensorSource::new(&camera, rig, args.seed, size, &unlisted()).map_err(sensor)?;
    Ok(DeviceSource {
        source,
        sensor: camera,
        view: format!("rig '{rig}'"),
        from_scene: false,
    })
}
