//! `gloam calibrate …` and `gloam scope` past their arguments: the flows
//! are gloam-calib's ([`run_calibrate`], over its request types); here
//! what calib sits below — `calibrate agc --sequence`'s render and
//! capture ([`crate::sequence`]) — and the run's provenance added to the
//! set's main JSON before the set is published.

use std::path::Path;

use gloam_calib::CalibError;
use gloam_calib::cli::{
    CalibrateCommand, CapturedSequence, Event, Outcome, SequenceRun, agc_sequence, run_calibrate,
};
use gloam_grabber::GrabError;
use gloam_io::OutputSet;
use gloam_scene::SceneError;
use gloam_scene::sequence::Sequence;
use gloam_trace::RenderSettings;

use crate::render::RenderError;
use crate::request::Events;
use crate::sequence::{SceneSequence, SequenceError, capture_scene_sequence};
use crate::{FrameCapture, FrameContext, FrameFormat, Provenance, SettingArgs};
use gloam_io::{ReadLog, RunGuard};

/// Why a calibration was refused or failed.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    #[error(transparent)]
    Calib(#[from] CalibError),
    #[error(transparent)]
    Grab(#[from] GrabError),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Render(#[from] Box<RenderError>),
    #[error(transparent)]
    Sequence(#[from] Box<SequenceError>),
    #[error(transparent)]
    Arg(#[from] super::ArgError),
    #[error(transparent)]
    OutputSet(#[from] gloam_io::OutputSetError),
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("the layered render carried no detected band")]
    NoDetectedBand,
}

impl From<RenderError> for CalibrateError {
    fn from(e: RenderError) -> Self {
        Self::Render(Box::new(e))
    }
}

impl From<SequenceError> for CalibrateError {
    fn from(e: SequenceError) -> Self {
        Self::Sequence(Box::new(e))
    }
}

/// A sequence and its scene, read and checked before any output opens.
struct LoadedSequence {
    sequence: Sequence,
    scene: gloam_scene::Scene,
    groups: Vec<String>,
    settings: RenderSettings,
}

fn load_sequence(
    path: &Path,
    set: &[String],
    reads: &ReadLog,
    events: &dyn Events,
) -> Result<LoadedSequence, CalibrateError> {
    let mut sequence = gloam_scene::sequence::load_sequence(path, reads)?;
    let mut scene = gloam_scene::load(&sequence.scene, reads)?;
    sequence.bind_sky(&mut scene)?;
    for w in sequence.sky.iter().flat_map(|c| &c.warnings) {
        events.note(w);
    }
    let groups: Vec<String> = (scene.light_groups.groups.iter())
        .map(|g| g.name.clone())
        .collect();
    sequence.check_groups(groups.iter().map(String::as_str))?;
    // The true radiance is layers mixed (between two sky renders with a
    // `[sky]` clock): refused here, before any render or output, when
    // bodies move.
    sequence.check_still_bodies("gloam calibrate agc --sequence")?;
    let settings = SettingArgs {
        set: set.to_vec(),
        ..SettingArgs::default()
    }
    .settings()?;
    Ok(LoadedSequence {
        sequence,
        scene,
        groups,
        settings,
    })
}

/// Renders the sequence's layers once and captures its frames through
/// the run's camera with its AGC into the run's directory (the frames and
/// `frames.jsonl`), as `gloam sequence` does.
fn capture(
    l: &LoadedSequence,
    run: &SequenceRun<'_>,
    frame_format: FrameFormat,
    reads: &ReadLog,
    events: &dyn Events,
) -> Result<CapturedSequence, CalibrateError> {
    // The camera as the run resolved it once (not re-read by name).
    let (sensor, seed) = (run.sensor(), run.seed());
    let config = sensor.config();
    let capture = FrameCapture {
        sensor,
        frames: l.sequence.frames,
        gain: None,
        agc: true,
        // The sensor's own setting: a noise-free camera file stays so.
        noise: config.noise.enabled,
        seed,
        auto_exposure: None,
        frame_format,
    };
    // FITS headers name the camera, the seed and this run, as `gloam
    // sequence`'s do.
    let context = FrameContext {
        camera: Some(sensor.name().to_string()),
        seed: Some(seed),
        provenance: Some(Provenance::of_this_run(reads)),
        scene_utc: crate::frames::scene_utc(&l.scene),
        ..FrameContext::default()
    };
    // The one sequence path: the layers rendered once (a static
    // sequence), the video rate checked, the frames through the AGC.
    let progress = |d, t| events.tiles(d, t);
    let job = SceneSequence {
        sequence: &l.sequence,
        scene: &l.scene,
        settings: &l.settings,
        observer: events.preparation(),
        progress: &progress,
        camera_k: None,
        keep_sky_renders: true,
    };
    let captured = capture_scene_sequence(&job, &capture, run.dir(), context);
    events.traced();
    let captured = captured?;
    for line in &captured.report.notes {
        events.note(line);
    }
    let detected = (captured.first.detected).ok_or(CalibrateError::NoDetectedBand)?;
    Ok(CapturedSequence {
        groups: l.groups.clone(),
        layers: detected,
        // The window the sequence capture gives the camera.
        exposure_s: config.timing.exposure_s.min(l.sequence.frame_period_s()),
        sky_layers: captured.sky_renders,
    })
}

/// Runs one `gloam calibrate` flow (`calibrate agc --sequence` with its
/// render), publishes its output set with the run's provenance and
/// returns the lines to print. `ev` hears the flow (notes, progress);
/// `events` the sequence's render; `guard` removes the set if the run
/// is interrupted.
pub fn run_calibrate_command(
    cmd: &CalibrateCommand,
    ev: &mut dyn FnMut(Event<'_>),
    events: &dyn Events,
    guard: &RunGuard,
) -> Result<Vec<String>, CalibrateError> {
    let registry = crate::grabbers();
    // This run's reads, for its manifest.
    let reads = ReadLog::new();
    let outcome = match cmd {
        CalibrateCommand::Agc(a) if a.sequence.is_some() => {
            let path = a.sequence.as_deref().unwrap_or(Path::new(""));
            let loaded = load_sequence(path, &a.set, &reads, events)?;
            let frame_format = super::frame_format(a.frame_format.as_deref())?;
            let run = agc_sequence(a, &reads, guard)?;
            let captured = capture(&loaded, &run, frame_format, &reads, events)?;
            run.finish::<CalibrateError>(captured, &registry, &reads, ev)?
        }
        _ => run_calibrate::<CalibrateError>(cmd, &registry, &reads, guard, ev)?,
    };
    let Outcome {
        set,
        main_json,
        lines,
    } = outcome;
    if let (Some(set), Some(main_json)) = (set, main_json) {
        publish(set, main_json, &reads)?;
    }
    Ok(lines)
}

/// Adds the run's provenance (its reads from `reads`) to the set's main
/// JSON and publishes the set.
pub fn publish(set: OutputSet, main_json: &str, reads: &ReadLog) -> Result<(), CalibrateError> {
    let provenance = Provenance::of_this_run(reads);
    crate::output::add_provenance(&set.dir().join(main_json), &provenance)?;
    Ok(set.publish(&provenance, None)?)
}

/// `gloam scope`: the scope's options checked, its output set, the run,
/// `scope.csv`/`.png`/`.json` published; the readout lines (stdout) and
/// where the plot went (stderr) to print.
pub fn run_scope_command(
    a: &gloam_calib::cli::ScopeArgs,
    guard: &RunGuard,
) -> Result<(Vec<String>, String), CalibrateError> {
    use gloam_calib::scope_run::{run_scope, write_scope};
    let opts = a.options()?;
    let set = OutputSet::begin(&a.out, a.force, false, guard)?;
    let reads = gloam_io::ReadLog::new();
    let r = run_scope(&opts, &reads)?;
    write_scope(set.dir(), &r)?;
    publish(set, "scope.json", &reads)?;
    // A row the cursors cannot read (a line smeared by a narrow video
    // bandwidth: `--bandwidth-hz 3e4`) printed nothing, exit 0.
    let unread = r
        .lines
        .iter()
        .map(|l| l.row)
        .filter(|row| r.readouts.iter().all(|(r, _)| r != row));
    let unread = unread.map(|row| {
        format!(
            "row {row}: no sync pulse or blanking level could be read off the line{} (its trace is in scope.csv)",
            r.bandwidth_hz.map_or(String::new(), |b| format!(" at a video bandwidth of {} Hz", gloam_spectra::num(b)))
        )
    });
    let readouts = (r.readouts.iter()).map(|(row, l)| {
        format!(
            "row {row}: sync {:.3} V, blanking {:.3} V, active {:.3}–{:.3} V, sync {:.3} µs, line {:.3} µs",
            l.sync_tip_v,
            l.blanking_v,
            l.active_min_v,
            l.active_max_v,
            l.sync_width_s * 1e6,
            l.line_period_s * 1e6
        )
    });
    let wrote = format!(
        "{} ({}, {:.2} MHz pixel clock): wrote {}",
        r.sensor,
        r.format,
        r.pixel_clock_hz / 1e6,
        a.out.join("scope.png").display()
    );
    Ok((readouts.chain(unread).collect(), wrote))
}
