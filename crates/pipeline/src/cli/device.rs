//! What `gloam device` serves (`--pty` and `--gige` alike): the simulated
//! camera looking at a rig, a rendered scene (`--scene`) or a sequence's
//! light-group layers mixed per frame (`--sequence`). The arguments are
//! `gloam_simcam::cli`'s; the scene views are rendered here, where
//! rendering meets imaging.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use gloam_grabber::GrabError;
use gloam_scene::SceneError;
use gloam_scene::sequence::Sequence;
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
    (seq, scene): (Sequence, gloam_scene::Scene),
    note: &dyn Fn(&str),
) -> Result<SceneView, DeviceSourceError> {
    seq.check_static("gloam device --sequence")?;
    let scene_path = seq.scene.to_string_lossy().into_owned();
    note(&format!(
        "gloam device: rendering the light groups of {scene_path} …"
    ));
    let (groups, layers) = crate::scene_view::render_scene_layers(scene, sensor, args.size)
        .map_err(|source| DeviceSourceError::Layers {
            scene: scene_path.clone(),
            source,
        })?;
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

/// What the device looks at, each file read once.
enum Looks {
    /// `--sequence PATH`: the sequence and its scene.
    Sequence(String, Box<Sequence>, Box<gloam_scene::Scene>),
    /// `--scene PATH`.
    Scene(String, Box<gloam_scene::Scene>),
    /// A rig (`--rig`, or the default).
    Rig,
}

impl Looks {
    fn load(args: &DeviceArgs) -> Result<Self, DeviceSourceError> {
        if let Some(path) = &args.sequence {
            let seq = gloam_scene::sequence::load_sequence(Path::new(path), &unlisted()).map_err(
                |source| DeviceSourceError::Sequence {
                    path: path.into(),
                    source,
                },
            )?;
            let scene = gloam_scene::load(&seq.scene, &unlisted())?;
            return Ok(Looks::Sequence(
                path.clone(),
                Box::new(seq),
                Box::new(scene),
            ));
        }
        if let Some(path) = &args.scene {
            let scene = gloam_scene::load(Path::new(path), &unlisted())?;
            return Ok(Looks::Scene(path.clone(), Box::new(scene)));
        }
        Ok(Looks::Rig)
    }

    fn scene(&self) -> Option<&gloam_scene::Scene> {
        match self {
            Looks::Sequence(_, _, s) | Looks::Scene(_, s) => Some(s),
            Looks::Rig => None,
        }
    }
}

/// The device's camera: `--sensor`, else the `sensor` entry of the scene
/// it looks at (`--scene`, or `--sequence`'s scene), as `render` and
/// `sequence` take it, else [`DEFAULT_DEVICE_SENSOR`]. A scene naming
/// gen3-gaas-iccd was served through gen2-s20-iccd without a word.
fn camera_name(args: &DeviceArgs, scene: Option<&gloam_scene::Scene>) -> String {
    (args.sensor.clone())
        .or_else(|| scene.and_then(|s| s.sensor.clone()))
        .unwrap_or_else(|| DEFAULT_DEVICE_SENSOR.to_string())
}

/// The source from `--scene`, `--sequence` or `--rig`; `note` hears what
/// takes time and a scene the camera cannot fit at any gain.
pub fn device_source(
    args: &DeviceArgs,
    note: &dyn Fn(&str),
) -> Result<DeviceSource, DeviceSourceError> {
    let looks = Looks::load(args)?;
    let camera = camera_name(args, looks.scene());
    let sensor = |source| DeviceSourceError::Sensor {
        sensor: camera.clone(),
        source,
    };
    let (source, view) = match looks {
        Looks::Sequence(path, seq, scene) => {
            // Read once: the layers are rendered through it, the camera is it.
            let resolved = crate::resolve_sensor(&camera, &unlisted())?;
            let view = sequence_view(args, &resolved, &path, (*seq, *scene), note)?;
            let source = SensorSource::with_scene(&resolved, view, args.seed).map_err(sensor)?;
            (source, format!("sequence '{path}'"))
        }
        Looks::Scene(path, scene) => {
            note(&format!("gloam device: rendering {path} …"));
            let resolved = crate::resolve_sensor(&camera, &unlisted())?;
            let view = crate::scene_view::scene_view_of(*scene, &path, &resolved, args.size)
                .map_err(|source| DeviceSourceError::View {
                    scene: path.clone(),
                    source,
                })?;
            if let Some(fit) = crate::scene_view_fit_note(&view, &resolved) {
                note(&format!("warning: {fit}"));
            }
            let source = SensorSource::with_scene(&resolved, view, args.seed).map_err(sensor)?;
            (source, format!("scene '{path}'"))
        }
        Looks::Rig => {
            let rig = (args.rig.as_deref()).unwrap_or(gloam_simcam::DEFAULT_RIG);
            let size = args.size.unwrap_or(DEFAULT_RIG_SIZE);
            let source =
                SensorSource::new(&camera, rig, args.seed, size, &unlisted()).map_err(sensor)?;
            return Ok(DeviceSource {
                source,
                sensor: camera,
                view: format!("rig '{rig}'"),
                from_scene: false,
            });
        }
    };
    Ok(DeviceSource {
        source,
        sensor: camera,
        view,
        from_scene: true,
    })
}
