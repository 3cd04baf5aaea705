//! `gloam sequence`: the arguments of a night that changes, captured
//! through a camera (see [`crate::sequence`]).

use std::path::PathBuf;

use clap::Args;

use super::{ArgError, CameraArgs};
use crate::render::SettingArgs;

/// `gloam sequence`.
#[derive(Args)]
pub struct SequenceArgs {
    /// The sequence file (TOML): the scene, frame rate, frames and each
    /// light group's intensity over time. See docs/sequences.md.
    pub sequence: PathBuf,
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
}

/// A sequence needs a camera; its frames come from the sequence file.
#[derive(Debug, thiserror::Error)]
pub enum SequenceArgError {
    #[error(
        "gloam sequence captures frames through a camera: give --sensor or a `sensor` entry in {}",
        scene.display()
    )]
    NoCamera { scene: PathBuf },
    #[error("--frames: the sequence file {} sets the number of frames ({frames})", path.display())]
    Frames { path: PathBuf, frames: u32 },
    #[error(transparent)]
    Arg(#[from] ArgError),
}

impl SequenceArgs {
    /// The capture of `sequence` (its frame count) through the camera the
    /// flags or the scene name, checked before any render.
    pub fn capture<'a>(
        &'a self,
        sequence: &gloam_scene::sequence::Sequence,
        scene: &'a gloam_scene::Scene,
        seed: u64,
    ) -> Result<(&'a str, crate::FrameCapture<'a>), SequenceArgError> {
        if self.camera.frames.is_some() {
            return Err(SequenceArgError::Frames {
                path: sequence.path.clone(),
                frames: sequence.frames,
            });
        }
        let (camera, capture) = self.camera.capture(scene, seed, false)?;
        match (camera, capture) {
            (Some(c), Some(capture)) => Ok((
                c,
                crate::FrameCapture {
                    frames: sequence.frames,
                    ..capture
                },
            )),
            _ => Err(SequenceArgError::NoCamera {
                scene: sequence.scene.clone(),
            }),
        }
    }
}
