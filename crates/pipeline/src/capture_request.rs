//! `gloam capture` as a request, as [`crate::request`] is `gloam render`:
//! the grab itself is gloam-calib's [`GrabRequest`] (open, settings, the
//! loop that rides out lost frames); here the frames' files (`--frame-format`,
//! `frames.jsonl`, the contact sheet), `report.json` ([`CaptureReport`]) and
//! the output set, published whole — or, when the run stops early, with
//! what was kept.

use std::path::Path;
use std::sync::Arc;

use gloam_calib::CalibError;
use gloam_calib::request::{CaptureTally, Events, GrabRequest};
use gloam_grabber::{GrabError, PacketResends};
use gloam_io::{OutputSet, RunGuard};
use serde::Serialize;

use crate::frames::{FrameContext, FrameLogError, instrument_of_grabber};
use crate::render::RenderError;
use crate::request::OutputDir;
use crate::{FrameFormat, FrameRecord, FrameWriter, Provenance};

/// The capture's report: what was asked, what came, what was lost and how
/// the transport recovered lost packets.
pub const REPORT: &str = "report.json";

/// `gloam capture` as asked for.
#[derive(Clone, Debug, PartialEq)]
pub struct CaptureRequest {
    pub grab: GrabRequest,
    /// `png` (default), `fits` or `tiff`.
    pub frame_format: Option<String>,
    pub out: OutputDir,
}

/// Why a capture was refused, failed or stopped.
#[derive(Debug, thiserror::Error)]
pub enum CaptureRequestError {
    #[error(transparent)]
    Calib(#[from] CalibError),
    #[error(transparent)]
    Grab(#[from] GrabError),
    #[error(transparent)]
    Render(#[from] Box<RenderError>),
    #[error(transparent)]
    OutputSet(#[from] gloam_io::OutputSetError),
    #[error(transparent)]
    Frames(#[from] FrameLogError),
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("encoding report.json")]
    Encode(#[from] serde_json::Error),
    /// The frames would not fit the disk: stopped after the first, whose
    /// size gave the estimate, instead of when the disk filled.
    #[error(
        "the {frames} frames need about {} ({} each, as the first took) and {} is free on the filesystem of {}: capture fewer frames (--frames), or to a disk with room",
        bytes_text(*need_bytes),
        bytes_text(*per_frame_bytes),
        bytes_text(*free_bytes),
        out.display()
    )]
    NoRoom {
        frames: u64,
        need_bytes: u64,
        per_frame_bytes: u64,
        free_bytes: u64,
        out: std::path::PathBuf,
    },
}

/// Bytes as the disk message prints them (`1.23 GB`, `456 kB`).
fn bytes_text(bytes: u64) -> String {
    let b = bytes as f64;
    match b {
        b if b >= 1e9 => format!("{:.2} GB", b / 1e9),
        b if b >= 1e6 => format!("{:.1} MB", b / 1e6),
        b => format!("{:.0} kB", (b / 1e3).ceil()),
    }
}

/// After the first frame is stored: whether the other `frames − 1` fit the
/// free space of `dir`'s filesystem at the first one's size (the files in
/// `dir` so far: the frame, its `frames.jsonl` line). An hour-long capture
/// that cannot fit stops now, not when the disk is full.
fn check_room(dir: &Path, frames: u64, out: &Path) -> Result<(), CaptureRequestError> {
    let per_frame_bytes = gloam_io::output_set::files_bytes(dir);
    let Some(free_bytes) = gloam_io::output_set::free_disk_bytes(dir) else {
        return Ok(());
    };
    let rest = per_frame_bytes.saturating_mul(frames.saturating_sub(1));
    if rest <= free_bytes {
        return Ok(());
    }
    Err(CaptureRequestError::NoRoom {
        frames,
        need_bytes: per_frame_bytes.saturating_mul(frames),
        per_frame_bytes,
        free_bytes,
        out: out.to_path_buf(),
    })
}

/// A checked capture request.
pub struct ValidCapture {
    grab: GrabRequest,
    format: FrameFormat,
    out: OutputDir,
    /// The run's log of what it read (its provenance's inputs).
    reads: gloam_io::ReadLog,
}

impl CaptureRequest {
    /// Checks the grab's options and the frame format; the run notes what
    /// it reads (a `sim:` camera's sensor file) in `reads`.
    pub fn validate(&self, reads: &gloam_io::ReadLog) -> Result<ValidCapture, CaptureRequestError> {
        let format = crate::request::CameraOptions {
            frame_format: self.frame_format.clone(),
            ..Default::default()
        }
        .frame_format()
        .map_err(Box::new)?;
        self.grab.check()?;
        Ok(ValidCapture {
            grab: self.grab.clone(),
            format,
            out: self.out.clone(),
            reads: reads.clone(),
        })
    }
}

/// What a capture did: the lines its front end prints, and the error that
/// stopped it early, if one did (what was kept is published all the same).
pub struct CaptureDone {
    pub lines: Vec<String>,
    pub stopped: Option<CaptureRequestError>,
}

impl ValidCapture {
    /// Opens the output set and the grabber, grabs the frames into their
    /// files and `frames.jsonl`, writes `report.json` and publishes the
    /// set. `fit_note` hears a `sim:…?scene=` camera that cannot fit its
    /// scene at any gain, before its first frame. The grab stops at an
    /// interrupt `guard` reports, and the set keeps what was captured.
    pub fn run(
        self,
        ev: &mut Events<'_>,
        fit_note: Arc<dyn Fn(&str) + Send + Sync>,
        guard: &RunGuard,
    ) -> Result<CaptureDone, CaptureRequestError> {
        let (grab, format) = (&self.grab, self.format);
        let provenance = Provenance::of_this_run(&self.reads);
        // The frames appear at once with manifest.json; Ctrl-C stops the
        // loop and publishes what was captured.
        let set = OutputSet::begin(&self.out.path, self.out.force, true, guard)?;
        let dir = set.dir().to_path_buf();
        let grabbers = crate::grabbers_noting(fit_note);
        let mut g = grab.open::<CaptureRequestError>(&grabbers, &dir, &self.reads, ev)?;
        // FITS headers name the camera, its URI, the seed and this run.
        let context = FrameContext {
            camera: Some(grab.grabber.clone()),
            instrument: Some(instrument_of_grabber(&grab.grabber, &g.describe())),
            seed: grab.seed,
            provenance: Some(provenance.clone()),
            scene_utc: None,
        };
        // Appended as frames are written: an interrupted capture lists
        // every frame it kept.
        let mut writer = FrameWriter::with_format(&dir, format, context)?;
        let mut grabbing = grab.grabbing();
        // Frames whose file and frames.jsonl line were written: a frame
        // grabbed but not stored (a full disk) is not reported captured.
        let mut stored = 0u64;
        let result = (|| -> Result<(), CaptureRequestError> {
            // Bounded: each step keeps a frame or ends the loop, at most
            // --frames of them.
            while let Some((index, f, warnings)) = grabbing.next_frame(g.as_mut(), guard, ev)? {
                let rec = FrameRecord::of_frame(index, format.file_name(index), &f, warnings);
                writer.write(&rec, &f.pixels)?;
                stored += 1;
                if stored == 1 {
                    check_room(&dir, grab.frames, &self.out.path)?;
                }
            }
            Ok(())
        })();
        let grabbed = grabbing.tally();
        let tally = &CaptureTally {
            kept: stored.min(grabbed.kept),
            frames_warned: grabbed.frames_warned,
            losses: grabbed.losses,
        };
        // Read before the grabber closes: a stream's counts end with it.
        let resends = Resends::of(&grab.grabber, g.packet_resends());
        drop(g);
        // Nothing captured is lost: a run that stopped early publishes its
        // whole frames, marked incomplete in manifest.json.
        if tally.kept > 0 || result.is_ok() {
            let why = result.as_ref().err().map(chain);
            // The contact sheet of what was kept (frames-preview.png).
            writer.finish()?;
            let report = CaptureReport::of(grab, tally, &resends, why.as_deref(), &provenance);
            // Every object's keys in order, as report.json has always had them.
            let value = serde_json::to_value(&report)?;
            crate::output::write_atomic(&dir.join(REPORT), &serde_json::to_vec_pretty(&value)?)?;
            set.publish(&provenance, why.as_deref())?;
        }
        let (kept, warned) = (tally.kept as usize, tally.frames_warned);
        let lines = vec![
            (tally.losses).summary(kept, &self.out.path, warned),
            resends.line(),
        ];
        Ok(CaptureDone {
            lines,
            stopped: result.err(),
        })
    }
}

/// An error and its causes, `outer: cause: cause` (as the CLI prints it).
fn chain(e: &CaptureRequestError) -> String {
    let mut s = e.to_string();
    let mut cause = std::error::Error::source(e);
    // Bounded: a chain of causes is short; stop at 32 all the same.
    for _ in 0..32 {
        let Some(c) = cause else { break };
        s.push_str(&format!(": {c}"));
        cause = c.source();
    }
    s
}

/// The packet resends of a capture, or why there are none to count.
enum Resends {
    Counted(PacketResends),
    NotApplicable(&'static str),
}

impl Resends {
    fn of(uri: &str, counted: Option<PacketResends>) -> Self {
        if let Some(c) = counted {
            return Self::Counted(c);
        }
        let scheme = uri.split_once(':').map_or(uri, |(s, _)| s);
        Self::NotApplicable(match scheme {
            "sim" => "sim: frames are made in process, no packets travel",
            "serial" | "usb" => {
                "the gloam protocol sends each frame once and has no packet resend (a frame that arrives damaged is counted as damaged)"
            }
            "genicam" => "not a GigE Vision stream: Aravis counts no packet resends for it",
            _ => "this grabber's transport has no packet resend",
        })
    }

    /// The line `gloam capture` ends with.
    fn line(&self) -> String {
        match self {
            Self::Counted(c) => format!(
                "packet resends: {} packet(s) resent, {} missing, {} resend request(s) ({})",
                c.packets_resent,
                c.packets_missing,
                c.resend_requests,
                match (c.camera_offers_resend, c.resend) {
                    (Some(false), _) => "none asked: the camera does not offer PACKETRESEND",
                    (_, true) => "resend=always",
                    (_, false) => "resend=never",
                }
            ),
            Self::NotApplicable(why) => format!("packet resends: not applicable ({why})"),
        }
    }

    fn report(&self) -> ResendsReport {
        match self {
            Self::Counted(c) => ResendsReport {
                applicable: true,
                resend: Some(c.resend),
                camera_offers_resend: Some(c.camera_offers_resend),
                why: None,
                resend_requests: c.resend_requests,
                packets_resent: c.packets_resent,
                packets_missing: c.packets_missing,
            },
            Self::NotApplicable(why) => ResendsReport {
                applicable: false,
                resend: None,
                camera_offers_resend: None,
                why: Some(why),
                resend_requests: 0,
                packets_resent: 0,
                packets_missing: 0,
            },
        }
    }
}

/// A capture's `report.json`. Its keys are a user contract: add, never
/// rename.
#[derive(Serialize)]
pub struct CaptureReport<'a> {
    /// `"capture"`.
    pub command: &'static str,
    pub grabber: &'a str,
    pub frames: FramesReport,
    pub packet_resends: ResendsReport,
    pub complete: bool,
    /// The error that stopped the run early, if one did.
    pub stopped_by: Option<&'a str>,
    pub provenance: &'a Provenance,
}

/// What was asked, kept and lost.
#[derive(Serialize)]
pub struct FramesReport {
    pub requested: u64,
    pub captured: u64,
    pub damaged: u64,
    pub lost: u64,
    pub interruptions: u64,
    pub interruptions_with_unknown_loss: u64,
    pub with_exposure_warnings: u64,
}

/// How the transport recovered lost packets; `why` not, when it has no
/// resend (`resend` and `camera_offers_resend` then absent).
#[derive(Serialize)]
pub struct ResendsReport {
    pub applicable: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resend: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_offers_resend: Option<Option<bool>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub why: Option<&'static str>,
    pub resend_requests: u64,
    pub packets_resent: u64,
    pub packets_missing: u64,
}

impl<'a> CaptureReport<'a> {
    fn of(
        grab: &'a GrabRequest,
        tally: &CaptureTally,
        resends: &Resends,
        stopped: Option<&'a str>,
        provenance: &'a Provenance,
    ) -> Self {
        let l = &tally.losses;
        Self {
            command: "capture",
            grabber: &grab.grabber,
            frames: FramesReport {
                requested: grab.frames,
                captured: tally.kept,
                damaged: l.damaged,
                lost: l.lost,
                interruptions: l.interruptions,
                interruptions_with_unknown_loss: l.unknown,
                with_exposure_warnings: tally.frames_warned,
            },
            packet_resends: resends.report(),
            complete: stopped.is_none(),
            stopped_by: stopped,
            provenance,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first frame's bytes times the frames asked, against the free
    /// space `statvfs` reports for the directory (no disk has 10¹⁸ bytes
    /// free; every disk a test runs on has 10 kB).
    #[test]
    fn a_capture_that_cannot_fit_stops_after_its_first_frame() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("frame-000000.png"), vec![0u8; 4000]).unwrap();
        std::fs::write(dir.path().join("frames.jsonl"), vec![b'x'; 1000]).unwrap();
        let free = gloam_io::output_set::free_disk_bytes(dir.path()).unwrap();
        assert!(free > 10_000, "{free}");
        check_room(dir.path(), 2, Path::new("o")).unwrap();
        let frames = free / 5000 + 2;
        let e = check_room(dir.path(), frames, Path::new("o")).unwrap_err();
        match &e {
            CaptureRequestError::NoRoom {
                per_frame_bytes,
                need_bytes,
                ..
            } => assert_eq!((*per_frame_bytes, *need_bytes), (5000, 5000 * frames)),
            other => panic!("{other}"),
        }
        let text = e.to_string();
        assert!(
            text.contains("5 kB each") && text.contains("--frames"),
            "{text}"
        );
    }
}
