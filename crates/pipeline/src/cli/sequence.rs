//! `gloam sequence`: the arguments of a night that changes, captured
//! through a camera (see [`crate::sequence_request`]).

use std::path::PathBuf;

use clap::Args;

use super::CameraArgs;
use crate::render::SettingArgs;
use crate::request::OutputDir;
use crate::sequence_request::SequenceRequest;

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

impl SequenceArgs {
    /// The sequence these flags ask for; [`SequenceRequest::validate`]
    /// checks it.
    pub fn request(&self) -> SequenceRequest {
        SequenceRequest {
            sequence: self.sequence.clone(),
            settings: self.settings.clone(),
            camera: self.camera.options(),
            out: OutputDir {
                path: self.out.clone(),
                force: self.force,
            },
        }
    }
}
