//! `gloam capture`'s arguments: gloam-calib's grab flags and how the
//! frames are stored; [`CaptureArgs::request`] makes the
//! [`CaptureRequest`].

use clap::Args;

use crate::FrameFormat;
use crate::capture_request::CaptureRequest;
use crate::request::OutputDir;

/// `gloam capture`: the grabber and grab settings, and how the frames are
/// stored.
#[derive(Args)]
// Its own group id: the flattened grab arguments' group is `CaptureArgs`.
#[group(id = "capture-command")]
pub struct CaptureArgs {
    #[command(flatten)]
    pub grab: gloam_calib::cli::CaptureArgs,
    /// How frames are stored: png (16-bit, counts scaled to 16 bits with
    /// sBIT; default), fits (one file per frame, with a header) or tiff
    /// (one multi-page frames.tiff), as `render` and `sequence` store them.
    #[arg(long, value_name = "FORMAT", value_parser = FrameFormat::NAMES)]
    pub frame_format: Option<String>,
}

impl CaptureArgs {
    /// The capture these flags ask for.
    pub fn request(&self) -> CaptureRequest {
        CaptureRequest {
            grab: self.grab.request(),
            frame_format: self.frame_format.clone(),
            out: OutputDir {
                path: self.grab.out.clone(),
                force: self.grab.force,
            },
        }
    }
}

/// `gloam capture`'s command with `--out`'s help naming what it holds
/// now that the frames need not be PNGs (the flag is `gloam_calib`'s).
pub fn with_out_help(cmd: clap::Command) -> clap::Command {
    cmd.mut_subcommand("capture", |c| {
        c.mut_arg("out", |a| {
            a.help("Output directory: the frames (--frame-format), frames.jsonl, frames-preview.png, camera.json, report.json")
        })
    })
}
