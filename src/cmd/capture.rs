//! `gloam capture`: grab frames from any grabber into frame files (PNG,
//! FITS or a multi-page TIFF, `--frame-format`) + frames.jsonl. The grab
//! arguments and loop are `gloam_calib::cli`'s; here `--frame-format`,
//! the output set, the frame writer, the progress bar and printing.

use std::io::IsTerminal;

use clap::Args;
use gloam_calib::cli::Event;
use gloam_io::OutputSet;
use gloam_pipeline::frames::{FrameContext, instrument_of_grabber};
use gloam_pipeline::{FrameFormat, FrameRecord, FrameWriter, Provenance};

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

/// `gloam capture`'s command with `--out`'s help naming what it holds
/// now that the frames need not be PNGs (the flag is `gloam_calib`'s).
pub fn with_out_help(cmd: clap::Command) -> clap::Command {
    cmd.mut_subcommand("capture", |c| {
        c.mut_arg("out", |a| {
            a.help("Output directory: the frames (--frame-format), frames.jsonl, frames-preview.png, camera.json, report.json")
        })
    })
}

pub fn run(args: CaptureArgs) -> anyhow::Result<()> {
    let format = gloam_pipeline::cli::frame_format(args.frame_format.as_deref())?;
    let args = args.grab;
    args.check()?;
    let provenance = Provenance::of_this_run();
    // The frames appear at once with manifest.json; Ctrl-C stops the loop
    // and publishes what was captured.
    let set = OutputSet::begin(&args.out, args.force, true)?;
    let dir = set.dir().to_path_buf();
    let bar = progress_bar(args.frames);
    let mut ev = |e: Event<'_>| match e {
        Event::Note(line) => bar.suspend(|| eprintln!("{line}")),
        Event::Progress(status, done, _) => {
            bar.set_message(status.to_string());
            bar.set_position(done as u64);
        }
    };
    // A `sim:…?scene=` camera that cannot fit its scene at any gain says so
    // before its first frame, as `render --sensor` does.
    let fit_bar = bar.clone();
    let grabbers = gloam_pipeline::grabbers_noting(std::sync::Arc::new(move |note: &str| {
        fit_bar.suspend(|| eprintln!("warning: {note}"))
    }));
    let mut g = args.open::<anyhow::Error>(&grabbers, &dir, &mut ev)?;
    // FITS headers name the camera, its URI, the seed and this run.
    let context = FrameContext {
        camera: Some(args.grabber.clone()),
        instrument: Some(instrument_of_grabber(&args.grabber, &g.describe())),
        seed: args.seed,
        provenance: Some(provenance.clone()),
        scene_utc: None,
    };
    // Appended as frames are written: an interrupted capture lists every
    // frame it kept.
    let mut writer = FrameWriter::with_format(&dir, format, context)?;
    let (tally, result) = args.grab::<anyhow::Error, _>(
        g.as_mut(),
        &gloam_io::output_set::interrupted,
        |index, f: &gloam_grabber::Frame, warnings| {
            let rec = FrameRecord::of_grab(index, format.file_name(index), f, warnings);
            Ok(writer.write(&rec, &f.pixels)?)
        },
        &mut ev,
    );
    bar.finish_and_clear();
    // Read before the grabber closes: a stream's counts end with it.
    let resends = Resends::of(&args.grabber, g.packet_resends());
    drop(g);
    // Nothing captured is lost: a run that stopped early publishes its
    // whole frames, marked incomplete in manifest.json.
    if tally.kept > 0 || result.is_ok() {
        let why = result.as_ref().err().map(|e| format!("{e:#}"));
        // The contact sheet of what was kept (frames-preview.png).
        writer.finish()?;
        let report = report_json(&args, &tally, &resends, why.as_deref(), &provenance);
        gloam_pipeline::output::write_atomic(
            &dir.join(REPORT),
            &serde_json::to_vec_pretty(&report)?,
        )?;
        set.publish(&provenance, why.as_deref())?;
    }
    let (kept, warned) = (tally.kept as usize, tally.frames_warned);
    eprintln!("{}", tally.losses.summary(kept, &args.out, warned));
    eprintln!("{}", resends.line());
    result
}

/// The capture's report: what was asked, what came, what was lost and how
/// the transport recovered lost packets.
pub const REPORT: &str = "report.json";

/// The packet resends of a capture, or why there are none to count.
enum Resends {
    Counted(gloam_grabber::PacketResends),
    NotApplicable(&'static str),
}

impl Resends {
    fn of(uri: &str, counted: Option<gloam_grabber::PacketResends>) -> Self {
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

    fn json(&self) -> serde_json::Value {
        match self {
            Self::Counted(c) => serde_json::json!({
                "applicable": true,
                "resend": c.resend,
                "camera_offers_resend": c.camera_offers_resend,
                "resend_requests": c.resend_requests,
                "packets_resent": c.packets_resent,
                "packets_missing": c.packets_missing,
            }),
            Self::NotApplicable(why) => serde_json::json!({
                "applicable": false,
                "why": why,
                "resend_requests": 0,
                "packets_resent": 0,
                "packets_missing": 0,
            }),
        }
    }
}

fn report_json(
    args: &gloam_calib::cli::CaptureArgs,
    tally: &gloam_calib::cli::CaptureTally,
    resends: &Resends,
    stopped: Option<&str>,
    provenance: &Provenance,
) -> serde_json::Value {
    let l = &tally.losses;
    serde_json::json!({
        "command": "capture",
        "grabber": args.grabber,
        "frames": {
            "requested": args.frames,
            "captured": tally.kept,
            "damaged": l.damaged,
            "lost": l.lost,
            "interruptions": l.interruptions,
            "interruptions_with_unknown_loss": l.unknown,
            "with_exposure_warnings": tally.frames_warned,
        },
        "packet_resends": resends.json(),
        "complete": stopped.is_none(),
        "stopped_by": stopped,
        "provenance": provenance,
    })
}

fn progress_bar(frames: u64) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(frames);
    b.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} frames {per_sec} eta {eta} {msg}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}
