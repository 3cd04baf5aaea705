//! The executor that runs a sweep's tasks over gloam's render and camera
//! code ([`Pipeline`]): a chunk renders once (radiance, or the camera's
//! detected band), and each task writes its images or captures its frames.
//!
//! Frames are written as every other command writes them: 16-bit PNGs
//! (counts scaled to 16 bits, `sBIT` declared) and `frames-preview.png`
//! through the one atomic writer and one [`FrameRecord`] per line of
//! `frames.jsonl`, so a sweep task's frames read like `gloam capture`'s.

use std::ops::Range;
use std::path::{Path, PathBuf};

use gloam_grabber::GrabError;
use gloam_pipeline::frames::FrameWriter;
use gloam_pipeline::output::{write_npy, write_preview, write_tiff};
use gloam_pipeline::{FrameCapture, FrameRecord, ResolvedSensor};
use gloam_simcam::FrameExposureExt;
use gloam_trace::RenderOutput;
use ndarray::Array2;

use crate::run::{Executor, Figures, TaskError};
use crate::spec::{Flow, Sweep, Task};

/// Why a task could not open or drive its camera (the render and file
/// errors a task meets are their crates' own).
#[derive(Debug, thiserror::Error)]
pub enum ExecError {
    #[error("the {0} flow needs a sensor")]
    NoSensor(&'static str),
    #[error("opening {uri}")]
    Open {
        uri: String,
        #[source]
        source: GrabError,
    },
    #[error("gain")]
    Gain(#[source] GrabError),
    #[error("grabbing frame {frame}")]
    Grab {
        frame: u32,
        #[source]
        source: GrabError,
    },
}

/// Runs tasks over the render and camera code.
pub struct Pipeline;

/// A chunk's shared work.
pub enum Shared {
    /// Capture tasks share nothing.
    Nothing,
    Render(Box<Rendered>),
}

/// One render of a chunk.
pub struct Rendered {
    out: RenderOutput,
    /// The camera's detected-electron radiance (with a sensor).
    detected: Option<Array2<f64>>,
    /// The whole image's width and height, and the rows rendered.
    full: (u32, u32),
    rows: Range<u32>,
    scene: PathBuf,
    /// With `target_error = "camera[:K]"`: report.json's `camera_target`.
    camera_target: Option<gloam_pipeline::camera_goal::CameraTarget>,
    /// The task's camera, read once for the render and its capture.
    sensor: Option<ResolvedSensor>,
}

/// Renders `task`'s scene (its tile's rows, and the camera's detected band
/// when it has a sensor) through the pipeline's one render entry point.
fn render_point(
    sweep: &Sweep,
    task: &Task,
    reads: &gloam_io::ReadLog,
) -> Result<Rendered, TaskError> {
    let scene = sweep.load_scene(task, reads)?;
    let settings = task.render_settings()?;
    let sensor = (sweep.sensor(task).as_deref())
        .map(|name| gloam_pipeline::resolve_sensor(name, reads))
        .transpose()?;
    // The gain is checked per task (it differs within a chunk).
    if let Some(s) = &sensor {
        gloam_pipeline::check_options(s, None, task.frames())?;
    }
    let job = gloam_pipeline::RenderJob {
        camera: sensor.as_ref(),
        ..gloam_pipeline::RenderJob::new(&scene, &settings)
    };
    let prepared = job.prepare()?;
    let full = prepared.image_size();
    let rows = task.tile().map(|t| t.rows(full.1)).transpose()?;
    // `target_error = "camera[:K]"`: the whole image sampled to the noise
    // of the task's camera at its gain (as `gloam render --target-error
    // camera`; the file's checks refused it without a sensor or a tile).
    let (r, camera_target) = match (task.camera_target(), &sensor) {
        (Some(k), Some(s)) => {
            let goal =
                gloam_pipeline::camera_goal::CameraGoal::new(&prepared, k, &capture_of(s, task));
            let r = prepared.render_to_goal(&goal, &|_, _| {}, &|| false)?;
            let target = goal.report(&r);
            (r, target)
        }
        _ => (prepared.render(rows, &|_, _| {}, &|| false)?, None),
    };
    let (out, detected, rows) = (r.radiance, r.detected, r.rows);
    Ok(Rendered {
        out,
        detected,
        full,
        rows,
        scene: sweep.resolve(&task.text("scene").unwrap_or_default()),
        camera_target,
        sensor,
    })
}

/// A camera-target task's render (`radiance.npy`, `spp.npy`, as `gloam
/// render` writes them) and its `camera_target.json` (report.json's
/// `camera_target` without the tracing time: a task's files are
/// deterministic).
fn write_camera_target(
    r: &Rendered,
    target: &gloam_pipeline::camera_goal::CameraTarget,
    out: &Path,
) -> Result<(), TaskError> {
    write_npy(&out.join("radiance.npy"), &r.out.radiance)?;
    write_npy(&out.join("spp.npy"), &r.out.spp)?;
    let mut t = target.clone();
    t.trace_seconds = None;
    gloam_pipeline::output::write_atomic(
        &out.join("camera_target.json"),
        serde_json::to_string_pretty(&t)?.as_bytes(),
    )?;
    Ok(())
}

/// The capture of `task`'s frames through `sensor`.
fn capture_of<'a>(sensor: &'a ResolvedSensor, task: &Task) -> FrameCapture<'a> {
    FrameCapture {
        sensor,
        frames: task.frames(),
        gain: task.gain(),
        agc: task.agc(),
        noise: task.noise(),
        seed: task.seed,
        auto_exposure: None,
        frame_format: Default::default(),
    }
}

impl Executor for Pipeline {
    type Shared = Shared;

    fn prepare(
        &self,
        sweep: &Sweep,
        task: &Task,
        reads: &gloam_io::ReadLog,
    ) -> Result<Shared, TaskError> {
        if task.flow() == Flow::Capture {
            return Ok(Shared::Nothing);
        }
        Ok(Shared::Render(Box::new(render_point(sweep, task, reads)?)))
    }

    fn run(
        &self,
        sweep: &Sweep,
        task: &Task,
        shared: &Shared,
        out: &Path,
        reads: &gloam_io::ReadLog,
    ) -> Result<Figures, TaskError> {
        match shared {
            Shared::Nothing => capture_stimulus(sweep, task, out, reads),
            Shared::Render(r) => match &r.detected {
                Some(d) => {
                    let sensor = r.sensor.as_ref().ok_or(ExecError::NoSensor("render"))?;
                    let mut f = capture_detected(sensor, task, d, out)?;
                    // The camera target's figures (results.csv columns),
                    // and the render it chose, as `gloam render` writes it.
                    if let Some(t) = &r.camera_target {
                        write_camera_target(r, t, out)?;
                        for (key, v) in [
                            (
                                "added_variance_fraction_median",
                                Some(t.added_variance_fraction_median),
                            ),
                            (
                                "added_variance_fraction_p99",
                                Some(t.added_variance_fraction_p99),
                            ),
                            ("mean_spp", t.mean_spp),
                        ] {
                            // JSON has no NaN: a non-finite figure was never a column.
                            if let Some(v) = v.filter(|v| v.is_finite()) {
                                f.insert(format!("camera_target_{key}"), v);
                            }
                        }
                    }
                    Ok(f)
                }
                None => write_radiance(task, r, out),
            },
        }
    }
}

/// A render task's images (and `tile.json` for a tile); its figures are
/// each band's mean radiance.
fn write_radiance(task: &Task, r: &Rendered, out: &Path) -> Result<Figures, TaskError> {
    let o = &r.out;
    // Deterministic outputs only (no timings): their hashes are the task's.
    write_npy(&out.join("radiance.npy"), &o.radiance)?;
    write_tiff(&out.join("radiance.tiff"), &o.radiance)?;
    write_npy(&out.join("stderr.npy"), &o.std_error)?;
    write_npy(&out.join("spp.npy"), &o.spp)?;
    write_preview(&out.join("preview.png"), &o.radiance)?;
    if let Some(t) = task.tile() {
        let label = task
            .text("scene")
            .map(PathBuf::from)
            .unwrap_or(r.scene.clone());
        crate::tile::write_tile_info(out, t, r.rows.clone(), r.full, &label, o)?;
    }
    let mut f = Figures::new();
    for (b, name) in o.band_names.iter().enumerate() {
        let img = o.radiance.index_axis(ndarray::Axis(0), b);
        f.insert(
            format!("mean_radiance_{name}"),
            img.mean().unwrap_or(f64::NAN),
        );
    }
    Ok(f)
}

/// Frames of a render through the task's camera (noise seeded by the
/// task): the one capture loop, [`FrameCapture::start`]'s, keeping the
/// pixels for the task's noise figures.
fn capture_detected(
    sensor: &ResolvedSensor,
    task: &Task,
    detected: &Array2<f64>,
    out: &Path,
) -> Result<Figures, TaskError> {
    let capture = capture_of(sensor, task);
    let mut writer = FrameWriter::create(out)?;
    let mut frames: Vec<Vec<u16>> = Vec::new();
    let (mut black, mut gain, mut sat) = (f64::NAN, f64::NAN, 0.0);
    let mut capturing = capture.start(detected)?;
    // Bounded: the task's frames.
    while let Some((f, rec)) = capturing.next_frame(None)? {
        writer.write(&rec, &f.pixels)?;
        (black, gain) = (rec.black_dn.unwrap_or(f64::NAN), rec.gain);
        sat += rec.saturated_fraction;
        frames.push(f.pixels);
    }
    let captured = capturing.finish();
    writer.finish()?;
    let refs: Vec<&[u16]> = frames.iter().map(Vec::as_slice).collect();
    let mut f = crate::figures::frame_figures(&refs, Some(black));
    f.insert("gain_in_effect".into(), gain);
    f.insert("saturated_fraction".into(), sat / task.frames() as f64);
    // The camera fit predicted before the first frame: how much of the
    // frame saturates at this gain and at the least sensitive one, and
    // the ND that would fit (absent: none within reach, or not needed).
    let fit = &captured.report.fit;
    for (key, value) in [
        (
            "fit_saturated_fraction",
            Some(fit.at_gain.saturated_fraction),
        ),
        (
            "fit_saturated_fraction_at_gain_min",
            Some(fit.at_gain_min.saturated_fraction),
        ),
        (
            "fit_median_above_black_of_full_scale",
            Some(fit.at_gain.median_above_black_of_full_scale),
        ),
        ("fit_nd_density", fit.nd_density_to_fit),
    ] {
        // A figure that is not a number was never recorded (JSON has none).
        if let Some(v) = value.filter(|v| v.is_finite()) {
            f.insert(key.into(), v);
        }
    }
    // What the frames gave, to set beside it: the median above black over
    // full scale, averaged over the frames.
    {
        let m: Vec<f64> = (captured.report.frames.iter())
            .map(|fr| fr.median_above_black_of_full_scale)
            .filter(|v| v.is_finite())
            .collect();
        if !m.is_empty() {
            f.insert(
                "median_above_black_of_full_scale".into(),
                m.iter().sum::<f64>() / m.len() as f64,
            );
        }
    }
    for note in captured.notes.iter().filter(|n| n.contains("camera fit:")) {
        eprintln!("task {}: {note}", task.id);
    }
    Ok(f)
}

/// Frames of the sensor's default uniform stimulus (`sim:PRESET`).
fn capture_stimulus(
    sweep: &Sweep,
    task: &Task,
    out: &Path,
    reads: &gloam_io::ReadLog,
) -> Result<Figures, TaskError> {
    let sensor = sweep.sensor(task).ok_or(ExecError::NoSensor("capture"))?;
    let uri = match task.size() {
        Some((w, h)) => format!("sim:{sensor}?size={w}x{h}"),
        None => format!("sim:{sensor}"),
    };
    let opts = gloam_grabber::OpenOptions {
        seed: Some(task.seed),
        reads: reads.clone(),
        ..Default::default()
    };
    let mut g = gloam_simcam::registry()
        .open(&uri, &opts)
        .map_err(|source| ExecError::Open {
            uri: uri.clone(),
            source,
        })?;
    if let Some(gain) = task.gain() {
        g.set_gain(gain).map_err(ExecError::Gain)?;
    }
    if task.agc() {
        g.set_agc(true)?;
    }
    let mut writer = FrameWriter::create(out)?;
    let mut frames = Vec::new();
    let mut black = None;
    let mut gain = f64::NAN;
    for i in 0..task.frames() {
        let f = g
            .grab()
            .map_err(|source| ExecError::Grab { frame: i, source })?;
        let file = format!("frame-{i:06}.png");
        let rec = FrameRecord::of_frame(u64::from(i), file, &f, f.exposure().warnings);
        writer.write(&rec, &f.pixels)?;
        black = f.meta.levels.map(|l| l.black_dn);
        gain = f.meta.gain;
        frames.push(f.pixels);
    }
    writer.finish()?;
    let refs: Vec<&[u16]> = frames.iter().map(Vec::as_slice).collect();
    let mut f = crate::figures::frame_figures(&refs, black);
    f.insert("gain_in_effect".into(), gain);
    Ok(f)
}
