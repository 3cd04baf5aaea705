//! `gloam calibrate …`: radiance LUTs, applying them, AGC linearisation
//! (on a rig's staircase, or on a sequence), EMVA 1288 photon transfer and
//! MTF. The arguments and flows are `gloam_calib::cli`'s (they open the
//! output set); here its provenance and publishing, the progress bar and
//! printing, and for `calibrate agc --sequence` the sequence's render and
//! capture (`gloam_pipeline::sequence`, which calib sits below). See
//! docs/calibration.md.

use std::io::IsTerminal;
use std::path::Path;

pub use gloam_calib::cli::CalibrateCommand;
use gloam_calib::cli::{CapturedSequence, Event, agc_sequence, run_calibrate};
use gloam_io::OutputSet;
use gloam_pipeline::sequence::{SceneSequence, capture_scene_sequence};
use gloam_pipeline::{FrameCapture, FrameContext, FrameFormat, Provenance, SettingArgs};
use gloam_scene::sequence::Sequence;
use gloam_trace::RenderSettings;

/// A sequence and its scene, read and checked before any output opens.
struct LoadedSequence {
    sequence: Sequence,
    scene: gloam_scene::Scene,
    groups: Vec<String>,
    settings: RenderSettings,
}

fn load_sequence(path: &Path, set: &[String]) -> anyhow::Result<LoadedSequence> {
    let mut sequence = gloam_scene::sequence::load_sequence(path)?;
    let mut scene = gloam_scene::load(&sequence.scene)?;
    sequence.bind_sky(&mut scene)?;
    for w in sequence.sky.iter().flat_map(|c| &c.warnings) {
        eprintln!("{w}");
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
/// `sensor` with its AGC into `dir` (the frames and `frames.jsonl`), as
/// `gloam sequence` does.
fn capture(
    l: &LoadedSequence,
    dir: &Path,
    sensor: &str,
    seed: u64,
    frame_format: FrameFormat,
) -> anyhow::Result<CapturedSequence> {
    let config = gloam_sensor::load_preset_or_file(sensor)
        .map_err(|e| anyhow::anyhow!(e).context(format!("camera '{sensor}'")))?;
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
        camera: Some(sensor.to_string()),
        seed: Some(seed),
        provenance: Some(Provenance::of_this_run()),
        scene_utc: gloam_pipeline::frames::scene_utc(&l.scene),
        ..FrameContext::default()
    };
    // The one sequence path: the layers rendered once (a static
    // sequence), the video rate checked, the frames through the AGC.
    let bar = super::progress::TileBar::new();
    let job = SceneSequence {
        sequence: &l.sequence,
        scene: &l.scene,
        settings: &l.settings,
        observer: super::progress::prep_spinner(),
        progress: &|d, t| bar.progress(d, t),
        camera_k: None,
        keep_sky_renders: true,
    };
    let captured = capture_scene_sequence(&job, &capture, dir, context)?;
    bar.finish();
    for line in &captured.report.notes {
        eprintln!("{line}");
    }
    let detected = (captured.first.detected)
        .ok_or_else(|| anyhow::anyhow!("the layered render carried no detected band"))?;
    Ok(CapturedSequence {
        groups: l.groups.clone(),
        layers: detected,
        // The window the sequence capture gives the camera.
        exposure_s: config.timing.exposure_s.min(l.sequence.frame_period_s()),
        sky_layers: captured.sky_renders,
    })
}

pub fn run(cmd: CalibrateCommand) -> anyhow::Result<()> {
    let loaded = match &cmd {
        CalibrateCommand::Agc(a) => (a.sequence.as_deref())
            .map(|p| load_sequence(p, &a.set))
            .transpose()?,
        _ => None,
    };
    let frame_format = match &cmd {
        CalibrateCommand::Agc(a) => gloam_pipeline::cli::frame_format(a.frame_format.as_deref())?,
        _ => FrameFormat::Png,
    };
    let mut bar: Option<indicatif::ProgressBar> = None;
    let registry = gloam_pipeline::grabbers();
    let mut ev = |e: Event<'_>| match e {
        Event::Note(line) => match &bar {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        },
        Event::Progress(phase, done, total) => {
            let b = bar.get_or_insert_with(progress_bar);
            b.set_message(phase.to_string());
            b.set_length(total as u64);
            b.set_position(done as u64);
        }
    };
    let r = match (&cmd, &loaded) {
        (CalibrateCommand::Agc(a), Some(l)) => (|| {
            let run = agc_sequence(a)?;
            let captured = capture(l, run.dir(), run.sensor(), run.seed(), frame_format)?;
            run.finish::<anyhow::Error>(captured, &registry, &mut ev)
        })(),
        _ => run_calibrate::<anyhow::Error>(&cmd, &registry, &mut ev),
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let outcome = r?;
    if let (Some(set), Some(main_json)) = (outcome.set, outcome.main_json) {
        publish(set, main_json)?;
    }
    for line in &outcome.lines {
        eprintln!("{line}");
    }
    Ok(())
}

fn progress_bar() -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(1);
    b.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} {msg} eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}

/// Adds the run's provenance to the set's main JSON and publishes the set.
pub fn publish(set: OutputSet, main_json: &str) -> anyhow::Result<()> {
    let provenance = Provenance::of_this_run();
    gloam_pipeline::output::add_provenance(&set.dir().join(main_json), &provenance)?;
    Ok(set.publish(&provenance, None)?)
}
