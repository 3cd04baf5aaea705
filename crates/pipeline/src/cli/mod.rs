//! The command line's arguments for the pipeline's requests (feature
//! `cli`): clap derives on the request types, so the flags, their help and
//! the checks that turn them into a request are written next to the code
//! they drive, and the binary only dispatches and prints.

use std::path::PathBuf;

use clap::Args;
use gloam_scene::Scene;
use gloam_trace::DVec3;

use crate::exposure::ExposureTarget;
use crate::render::{SettingArgs, camera_of};
use crate::request::{CameraOptions, OutputDir, RenderRequest, SceneInput};
use crate::{CaptureOptionsError, FrameCapture};

pub mod calibrate;
pub mod capture;
pub mod device;
pub mod print;
pub mod process;
pub mod sequence;

pub use sequence::SequenceArgs;

/// An argument that does not say what its flag asks for.
#[derive(Debug, thiserror::Error)]
pub enum ArgError {
    #[error("--{flag} `{value}`: expected {expected}")]
    Malformed {
        flag: &'static str,
        value: String,
        expected: &'static str,
        /// The number that did not parse, if one did not.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// A camera flag given to a render without a camera would be ignored.
    #[error("{flag} needs a camera: give --sensor or a `sensor` entry in the scene{}",
        if *.tile { " (a --tile render captures no frames)" } else { "" })]
    NeedsCamera { flag: &'static str, tile: bool },
    #[error(transparent)]
    Capture(#[from] CaptureOptionsError),
    /// A setting that shapes only pixels, given to a point's estimate.
    #[error(
        "--set {key} cannot be used with --point: it shapes pixels only (a point's estimate takes no camera samples; it averages --samples estimates); use it with --pixel"
    )]
    PixelOnly { key: String },
}

/// The render settings a point's estimate does not use: it traces no
/// camera ray. `--set spp=5` with `--point` was accepted and ignored, as
/// `--spp` was before round 9.
const PIXEL_ONLY_SETTINGS: [&str; 5] = [
    "spp",
    "max_spp",
    "target_error",
    "pixel_strata",
    "resolution_scale",
];

/// `gloam render`.
#[derive(Args)]
pub struct RenderArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub settings: SettingArgs,
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other files).
    #[arg(long)]
    pub force: bool,
    /// Render only tile K of N: rows ⌊(K−1)H/N⌋ to ⌊KH/N⌋ (horizontal
    /// bands), radiance only, plus `tile.json`; `gloam merge` reassembles
    /// the tiles bit-identically. See docs/sweep.md.
    #[arg(long, value_name = "K/N", conflicts_with = "sensor")]
    pub tile: Option<String>,
    /// Also write one radiance layer per light group (`layers.npy`,
    /// group × band × row × column; `layers_stderr.npy`; `layers.json`
    /// naming each group and its sources). The layers sum to radiance.npy.
    /// See docs/scene-format.md (light groups).
    #[arg(long, conflicts_with = "tile")]
    pub layers: bool,
}

impl RenderArgs {
    /// The render these flags ask for; [`RenderRequest::validate`] checks
    /// it (the checks are the Python `render`'s too).
    pub fn request(&self) -> RenderRequest {
        RenderRequest {
            scene: SceneInput::File(self.scene.clone()),
            settings: self.settings.clone(),
            camera: self.camera.options(),
            tile: self.tile.clone(),
            layers: self.layers,
            out: Some(OutputDir {
                path: self.out.clone(),
                force: self.force,
            }),
        }
    }
}

/// The camera a render is captured through, and how.
#[derive(Args)]
pub struct CameraArgs {
    /// Also capture the render through this camera (preset name, see
    /// `gloam sensor list`, or a sensor TOML file). Defaults to the scene's
    /// `sensor` entry, if any; `none` renders radiance only. Writes the
    /// frames, `frames.jsonl` and `frames-preview.png`.
    #[arg(long, value_name = "PRESET_OR_FILE", value_parser = gloam_sensor::cli::preset_or_file())]
    pub sensor: Option<String>,
    /// How frames are stored: png (16-bit, counts scaled to 16 bits with
    /// sBIT; default), fits (one file per frame, with a header) or tiff
    /// (one multi-page frames.tiff). Needs a camera.
    #[arg(long, value_name = "FORMAT", value_parser = crate::FrameFormat::NAMES)]
    pub frame_format: Option<String>,
    /// Number of frames to capture (AGC and phosphor lag evolve over them;
    /// default 1, at most 100 000). Needs a camera.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    pub frames: Option<u32>,
    /// Manual (override) tube gain: output linear in input flux.
    #[arg(long, conflicts_with = "agc")]
    pub gain: Option<f64>,
    /// Let the camera's AGC servo the gain.
    #[arg(long)]
    pub agc: bool,
    /// Turn the camera's temporal noise off (deterministic mean response).
    #[arg(long)]
    pub no_noise: bool,
    /// `auto`: choose the gain, gate (or exposure time) and ND filter that
    /// put the frame's 99th percentile at 80 % of the camera's range, and
    /// record the choice (report.json `sensor_capture.exposure`).
    #[arg(long, value_name = "auto", value_parser = ["auto"], conflicts_with_all = ["gain", "agc"])]
    pub exposure: Option<String>,
}

impl CameraArgs {
    /// The flags as a request's camera options.
    pub fn options(&self) -> CameraOptions {
        CameraOptions {
            sensor: self.sensor.clone(),
            frame_format: self.frame_format.clone(),
            frames: self.frames,
            gain: self.gain,
            agc: self.agc,
            no_noise: self.no_noise,
            auto_exposure: self.exposure.is_some(),
        }
    }
}

/// `--frame-format` (`render`, `sequence`, `capture`): PNG when not
/// given; a value that is none of [`crate::FrameFormat::NAMES`] is
/// refused naming the flag (clap's value parser refuses it first).
pub fn frame_format(value: Option<&str>) -> Result<crate::FrameFormat, ArgError> {
    match value {
        None => Ok(crate::FrameFormat::default()),
        Some(v) => {
            v.parse().map_err(
                |e: crate::frame_files::UnknownFrameFormat| ArgError::Malformed {
                    flag: "frame-format",
                    value: v.to_string(),
                    expected: "png, fits or tiff",
                    source: Some(Box::new(e)),
                },
            )
        }
    }
}

/// `gloam plan`.
#[derive(Args)]
pub struct PlanArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Print `{"effects":[{"name","enabled","reason"}]}`.
    #[arg(long)]
    pub json: bool,
    /// The plan's tolerance: effects whose estimated share of the band
    /// signal at the camera is below it are not simulated (default 0.005).
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Render settings the plan is made for, KEY=VALUE (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// With `camera[:K]` and a camera (`--sensor` or the scene's): also
    /// estimate, from two trial renders at the pilot's size, the samples,
    /// rays and tracing time of `gloam render --target-error camera[:K]`
    /// against the 2 % default (report: `camera_target_estimate`).
    #[arg(long, value_name = "camera[:K]")]
    pub target_error: Option<crate::camera_goal::TargetError>,
    /// The camera of the estimate (preset or sensor TOML; default the
    /// scene's `sensor`).
    #[arg(long, value_name = "PRESET_OR_FILE", requires = "target_error",
          value_parser = gloam_sensor::cli::preset_or_file())]
    pub sensor: Option<String>,
    /// The estimate's fixed tube gain (as `gloam render --gain`).
    #[arg(long, conflicts_with_all = ["agc", "exposure"], requires = "target_error")]
    pub gain: Option<f64>,
    /// The estimate with the camera's AGC (as `gloam render --agc`).
    #[arg(long, requires = "target_error")]
    pub agc: bool,
    /// `auto`: the estimate with automatic exposure (as `gloam render
    /// --exposure auto`).
    #[arg(long, value_name = "auto", value_parser = ["auto"], conflicts_with = "agc", requires = "target_error")]
    pub exposure: Option<String>,
}

/// Why `gloam plan`'s estimate cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum PlanArgError {
    #[error(
        "gloam plan --target-error {0}: the plan estimates the camera target only (`camera` or `camera:K`); a relative error needs no estimate"
    )]
    NotCamera(f64),
    #[error(
        "gloam plan --target-error camera needs a camera: --sensor NAME or a `sensor` entry in {}",
        scene.display()
    )]
    NoCamera { scene: PathBuf },
    #[error(transparent)]
    Capture(#[from] crate::frames::CaptureOptionsError),
}

impl PlanArgs {
    pub fn settings(&self) -> SettingArgs {
        SettingArgs {
            set: self.set.clone(),
            tolerance: self.tolerance,
            ..Default::default()
        }
    }

    /// `K` and the camera (read once, its capture checked) for
    /// `--target-error camera[:K]`, if asked; refused with a relative error or without a camera.
    /// `reads` notes a sensor file.
    pub fn camera_target(
        &self,
        scene: &Scene,
        reads: &gloam_io::ReadLog,
    ) -> Result<Option<(f64, crate::ResolvedSensor)>, PlanArgError> {
        let k = match self.target_error {
            None => return Ok(None),
            Some(crate::camera_goal::TargetError::Relative(e)) => {
                return Err(PlanArgError::NotCamera(e));
            }
            Some(crate::camera_goal::TargetError::Camera { k }) => k,
        };
        let sensor = camera_of(self.sensor.as_deref(), scene).ok_or(PlanArgError::NoCamera {
            scene: self.scene.clone(),
        })?;
        let sensor = crate::resolve_sensor(sensor, reads)?;
        self.capture(&sensor).check()?;
        Ok(Some((k, sensor)))
    }

    /// The capture the camera target's estimate runs through `sensor`.
    pub fn capture<'a>(&self, sensor: &'a crate::ResolvedSensor) -> FrameCapture<'a> {
        FrameCapture {
            sensor,
            frames: 1,
            gain: self.gain,
            agc: self.agc,
            noise: true,
            seed: 0,
            auto_exposure: self.exposure.as_ref().map(|_| ExposureTarget::default()),
            frame_format: crate::FrameFormat::default(),
        }
    }
}

/// `gloam probe`.
#[derive(Args)]
pub struct ProbeArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// The point, scene units: X,Y,Z.
    #[arg(long, allow_hyphen_values = true, required_unless_present = "pixel")]
    pub point: Option<String>,
    /// The receiver's normal: X,Y,Z (need not be unit length).
    #[arg(long, allow_hyphen_values = true, required_unless_present = "pixel")]
    pub normal: Option<String>,
    /// Instead of a point: the radiance of pixel COL,ROW (as rendered).
    #[arg(long, conflicts_with_all = ["point", "normal"], allow_hyphen_values = true)]
    pub pixel: Option<String>,
    /// Band name (default: the scene's first band).
    #[arg(long)]
    pub band: Option<String>,
    /// Area-source estimator: analytic (default), solid-angle or dirsig2001.
    #[arg(long)]
    pub estimator: Option<String>,
    /// Independent estimates averaged at the point (the standard error
    /// comes from their spread).
    // A pixel's radiance takes --spp camera samples: `--samples` there
    // was accepted and ignored.
    #[arg(long, default_value_t = 16, conflicts_with = "pixel")]
    /// At most 1 000 000 (each is a full estimate at the point).
    #[arg(value_parser = clap::value_parser!(u32).range(1..=i64::from(crate::MAX_PROBE_SAMPLES)))]
    pub samples: u32,
    /// Camera samples per pixel for --pixel (default 4, as a fixed-count
    /// `render --spp`).
    // A point's estimate takes no camera samples: `--spp` there was
    // accepted and ignored.
    #[arg(long, conflicts_with_all = ["point", "normal"])]
    pub spp: Option<u32>,
    /// Seed (default 0).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Any render setting, KEY=VALUE (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

impl ProbeArgs {
    pub fn settings(&self) -> SettingArgs {
        SettingArgs {
            set: self.set.clone(),
            spp: self.spp,
            seed: self.seed,
            estimator: self.estimator.clone(),
            ..Default::default()
        }
    }

    /// `--pixel COL,ROW`, if given.
    pub fn pixel(&self) -> Result<Option<(u32, u32)>, ArgError> {
        let Some(px) = &self.pixel else {
            return Ok(None);
        };
        match numbers::<u32>(px).map_err(|e| malformed("pixel", px, "COL,ROW", Some(e)))?[..] {
            [c, r] => Ok(Some((c, r))),
            _ => Err(malformed("pixel", px, "COL,ROW", None)),
        }
    }

    /// `--point` and `--normal` (clap requires both without `--pixel`);
    /// a `--set` of a setting that shapes pixels only is refused.
    pub fn point_normal(&self) -> Result<(DVec3, DVec3), ArgError> {
        let keys = self.set.iter().filter_map(|kv| kv.split_once('='));
        if let Some((k, _)) = keys
            .into_iter()
            .find(|(k, _)| PIXEL_ONLY_SETTINGS.contains(&k.trim().to_ascii_lowercase().as_str()))
        {
            return Err(ArgError::PixelOnly {
                key: k.trim().to_string(),
            });
        }
        let triple = |flag, s: &Option<String>| {
            let s = s.as_deref().unwrap_or_default();
            let v = numbers::<f64>(s)
                .map_err(|e| malformed(flag, s, "three numbers X,Y,Z", Some(e)))?;
            match v[..] {
                [x, y, z] if [x, y, z].iter().all(|v| v.is_finite()) => Ok(DVec3::new(x, y, z)),
                _ => Err(malformed(flag, s, "three finite numbers X,Y,Z", None)),
            }
        };
        Ok((
            triple("point", &self.point)?,
            triple("normal", &self.normal)?,
        ))
    }
}

/// Comma-separated numbers, or the first that does not parse.
fn numbers<T>(s: &str) -> Result<Vec<T>, Box<dyn std::error::Error + Send + Sync>>
where
    T: std::str::FromStr,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    Ok(s.split(',')
        .map(|x| x.trim().parse())
        .collect::<Result<_, T::Err>>()?)
}

fn malformed(
    flag: &'static str,
    value: &str,
    expected: &'static str,
    source: Option<Box<dyn std::error::Error + Send + Sync>>,
) -> ArgError {
    let value = value.to_string();
    ArgError::Malformed {
        flag,
        value,
        expected,
        source,
    }
}
