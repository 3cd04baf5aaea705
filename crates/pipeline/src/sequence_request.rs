//! `gloam sequence` as a request, as [`crate::request`] is `gloam render`:
//! the front end parses its flags into a [`SequenceRequest`],
//! [`SequenceRequest::validate`] reads the sequence and its scene and makes
//! every check before an output opens, and [`ValidSequence::run`] renders
//! the layers, captures the frames ([`capture_scene_sequence`]), writes
//! frame 0's layers and `report.json` ([`SequenceRunReport`]) and publishes
//! the output set, telling the front end its progress through [`Events`].

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use gloam_io::{OutputSet, RunGuard};
use gloam_scene::sequence::Sequence;
use gloam_scene::{Scene, SceneError};
use gloam_trace::RenderSettings;
use serde::Serialize;

use crate::output::{write_atomic, write_npy};
use crate::render::{RenderError, SettingArgs};
use crate::request::{CameraOptions, Capture, Events, OutputDir};
use crate::sequence::{
    AGC_SET_RANGE_FACTOR, ANIMATION_MAX_FRAMES, ANIMATION_MAX_WIDTH_PX, AgcOverSky, PoseRenders,
    SceneCaptured, SceneSequence, SequenceError, agc_over_sky, capture_scene_sequence,
};
use crate::{FrameContext, Provenance};

/// `gloam sequence` as asked for, before any check.
#[derive(Clone, Debug, PartialEq)]
pub struct SequenceRequest {
    /// The sequence file (TOML).
    pub sequence: PathBuf,
    pub settings: SettingArgs,
    /// The camera; its frame count is the sequence file's.
    pub camera: CameraOptions,
    pub out: OutputDir,
}

/// Why a sequence was refused or failed.
#[derive(Debug, thiserror::Error)]
pub enum SequenceRequestError {
    #[error(
        "gloam sequence captures frames through a camera: give --sensor or a `sensor` entry in {}",
        scene.display()
    )]
    NoCamera { scene: PathBuf },
    #[error("--frames: the sequence file {} sets the number of frames ({frames})", path.display())]
    Frames { path: PathBuf, frames: u32 },
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Sequence(Box<SequenceError>),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    OutputSet(#[from] gloam_io::OutputSetError),
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("encoding the sequence's JSON")]
    Encode(#[from] serde_json::Error),
}

impl From<SequenceError> for SequenceRequestError {
    fn from(e: SequenceError) -> Self {
        Self::Sequence(Box::new(e))
    }
}

/// A checked sequence request: the sequence and its scene read and bound,
/// the camera and its capture known, ready to [`run`](ValidSequence::run).
pub struct ValidSequence {
    file: PathBuf,
    sequence: Sequence,
    scene: Scene,
    settings: RenderSettings,
    /// `K` of `--target-error camera[:K]`.
    camera_k: Option<f64>,
    camera: crate::ResolvedSensor,
    capture: Capture,
    load_s: f64,
    out: OutputDir,
    /// The run's log of what it read (its provenance's inputs).
    reads: gloam_io::ReadLog,
}

impl SequenceRequest {
    /// Reads the sequence and its scene and checks, before any render or
    /// output: the groups and moving bodies the sequence names, the
    /// settings, the camera (the flags' or the scene's) and its options,
    /// and `--target-error camera`'s conditions. The sky clock's warnings
    /// are told to `events` as soon as it is bound (a refused run still
    /// shows them). `reads` is the run's log: the files read are noted
    /// there, and the run's provenance lists them.
    pub fn validate(
        &self,
        reads: &gloam_io::ReadLog,
        events: &dyn Events,
    ) -> Result<ValidSequence, SequenceRequestError> {
        let t_load = Instant::now();
        let mut sequence = gloam_scene::sequence::load_sequence(&self.sequence, reads)?;
        let mut scene = gloam_scene::load(&sequence.scene, reads)?;
        sequence.bind_sky(&mut scene)?;
        for w in sequence.sky.iter().flat_map(|c| &c.warnings) {
            events.note(w);
        }
        let load_s = t_load.elapsed().as_secs_f64();
        // Refused before any render: a group or moving table the scene lacks
        // (the camera's video rate is checked before the first render too).
        let groups = scene.light_groups.groups.iter().map(|g| g.name.as_str());
        sequence.check_groups(groups)?;
        sequence.check_moves(&scene)?;
        // `--target-error camera[:K]`: each pose's layers sampled until the
        // render's error is under K of the camera's noise at the brightest
        // frame each pixel sees (camera_goal.rs); its first round 2 spp.
        let camera_k = self.settings.camera_target();
        let settings = self.settings.settings()?;
        let (settings, _) = self.settings.with_default_error(settings, false)?;
        let c = &self.camera;
        if c.frames.is_some() {
            let (path, frames) = (sequence.path.clone(), sequence.frames);
            return Err(SequenceRequestError::Frames { path, frames });
        }
        let frame_format = c.frame_format()?;
        // Read once: the frames, the goal and the AGC summary share it.
        let camera =
            crate::resolve_scene_sensor(c.sensor.as_deref(), &scene, &sequence.scene, reads)
                .map_err(RenderError::from)?;
        let Some(camera) = camera else {
            c.refuse_flags_without_camera(false)?;
            let scene = sequence.scene.clone();
            return Err(SequenceRequestError::NoCamera { scene });
        };
        let capture = Capture {
            frames: sequence.frames,
            ..c.capture(frame_format)
        };
        (capture.through(&camera, settings.seed).check()).map_err(RenderError::from)?;
        if camera_k.is_some() && !capture.noise {
            return Err(RenderError::CameraTarget(
                "--target-error camera with --no-noise: frames without temporal noise hide no render error; give --target-error E (a relative error) or --spp N",
            )
            .into());
        }
        Ok(ValidSequence {
            file: self.sequence.clone(),
            sequence,
            scene,
            settings,
            camera_k,
            camera,
            capture,
            load_s,
            out: self.out.clone(),
            reads: reads.clone(),
        })
    }
}

/// What a sequence run made: the lines its front end prints.
pub struct SequenceDone {
    pub lines: Vec<String>,
}

impl ValidSequence {
    /// Opens the output set, renders the layers and captures the frames
    /// through the camera, writes frame 0's layers and `report.json`, and
    /// publishes the set, which `guard` removes if the run is interrupted.
    pub fn run(
        self,
        events: &dyn Events,
        guard: &RunGuard,
    ) -> Result<SequenceDone, SequenceRequestError> {
        let t_start = Instant::now();
        let mut provenance = Provenance::of_this_run(&self.reads);
        let set = OutputSet::begin(&self.out.path, self.out.force, false, guard)?;
        let dir = set.dir().to_path_buf();
        let progress = |d, t| events.tiles(d, t);
        let job = SceneSequence {
            sequence: &self.sequence,
            scene: &self.scene,
            settings: &self.settings,
            observer: events.preparation(),
            progress: &progress,
            camera_k: self.camera_k,
            keep_sky_renders: false,
        };
        let context = FrameContext {
            camera: Some(self.camera.name().to_string()),
            seed: Some(self.settings.seed),
            provenance: Some(provenance.clone()),
            scene_utc: crate::frames::scene_utc(&self.scene),
            ..FrameContext::default()
        };
        let capture = self.capture.through(&self.camera, self.settings.seed);
        let captured = capture_scene_sequence(&job, &capture, &dir, context);
        events.traced();
        let captured = captured?;
        for line in &captured.report.notes {
            events.note(line);
        }

        let t_write = Instant::now();
        let layers = &captured.first;
        let (radiance, std_error) = layers.stacked();
        write_npy(&dir.join("layers.npy"), &radiance)?;
        write_npy(&dir.join("layers_stderr.npy"), &std_error)?;
        provenance.add_inputs_read();
        let mut index = layers.index(self.settings.seed);
        index.pose = Some(crate::render::LayersPose {
            frame: 0,
            moves: captured.first_poses.clone(),
            note: "the layers of frame 0's pose; with [[move]] each distinct pose was rendered so (report.json sequence.renders)",
        });
        index.provenance = Some(provenance.clone());
        let index = serde_json::to_string_pretty(&index)?;
        write_atomic(&dir.join("layers.json"), index.as_bytes())?;
        let write_s = t_write.elapsed().as_secs_f64();

        let r = &captured.report;
        // With a sky clock: how the AGC held the median over the sky's light.
        let agc_over_sky = match self.sequence.sky.is_some() && !r.medians_above_black_dn.is_empty()
        {
            true => (self.camera.config().agc.clone()).and_then(|agc| agc_over_sky(r, &agc)),
            false => None,
        };
        let renders = r.renders.clone().unwrap_or_default();
        let timings = (self.load_s, write_s);
        let report = self.report(
            &captured,
            &renders,
            agc_over_sky.as_ref(),
            timings,
            &provenance,
        );
        // Every object's keys in order, as report.json has always had them.
        let text = serde_json::to_string_pretty(&serde_json::to_value(&report)?)?;
        write_atomic(&dir.join("report.json"), text.as_bytes())?;
        set.publish(&provenance, None)?;

        let mut lines = Vec::new();
        if let (Some(k), Some(t)) = (self.camera_k, &report.camera_target) {
            lines.push(camera_target_line(k, t));
        }
        lines.extend(self.sky_line());
        lines.extend(agc_over_sky.as_ref().map(|a| agc_line(a, r.frames)));
        let total_s = self.load_s + t_start.elapsed().as_secs_f64();
        lines.push(self.summary_line(&captured, &renders, total_s));
        Ok(SequenceDone { lines })
    }

    /// The sequence's `report.json`.
    fn report<'a>(
        &'a self,
        captured: &'a SceneCaptured,
        renders: &'a PoseRenders,
        agc: Option<&'a AgcOverSky>,
        (load_s, write_s): (f64, f64),
        provenance: &'a Provenance,
    ) -> SequenceRunReport<'a> {
        let (seq, r) = (&self.sequence, &captured.report);
        let first_out = captured.first.outputs.first();
        let frames = f64::from(r.frames.max(1));
        SequenceRunReport {
            scene: seq.scene.display().to_string(),
            units: self.scene.units.as_str(),
            image: SequenceImage {
                width: self.scene.camera.width,
                height: self.scene.camera.height,
                bands: first_out.map(|o| &o.band_names),
            },
            settings: first_out.map(|o| &o.settings),
            effect_plan: &captured.plan,
            sequence: SequenceSection {
                file: self.file.display().to_string(),
                frames: r.frames,
                frame_rate_hz: r.frame_rate_hz,
                groups: &r.groups,
                camera: self.camera.name(),
                moves: (seq.moves.iter())
                    .map(|m| MoveSummary {
                        objects: &m.objects,
                        point_sources: &m.point_sources,
                        keys: m.keys.len(),
                    })
                    .collect(),
                renders,
                sky: seq.sky.as_ref().map(|c| SkySection::of(seq, c, agc)),
                outputs: sequence_outputs(),
                timings_s: SequenceTimings {
                    load: load_s,
                    layered_render: renders.seconds,
                    layered_render_per_pose: renders.seconds / (renders.renders.max(1) as f64),
                    mix: r.mix_s,
                    camera: r.camera_s,
                    write_layers: write_s,
                    mix_per_frame_ms: 1e3 * r.mix_s / frames,
                    camera_per_frame_ms: 1e3 * r.camera_s / frames,
                },
                method: SEQUENCE_METHOD,
            },
            sensor_capture: &r.sensor_capture,
            provenance,
            // Frame 0's pose's (each pose's own is under sequence.renders.poses).
            camera_target: renders.poses.first().and_then(|p| p.camera_target.as_ref()),
        }
    }

    /// `sky: N renders from … to …`, with a sky clock.
    fn sky_line(&self) -> Option<String> {
        let (seq, c) = (&self.sequence, self.sequence.sky.as_ref()?);
        let (n, lux, sun) = (c.key_lux.len(), &c.key_lux, &c.key_sun_deg);
        let iso = |t: f64| {
            seq.sky_instant_at(t)
                .map_or_else(String::new, |t| t.to_iso8601())
        };
        (n > 0).then(|| {
            format!(
                "sky: {} renders from {} ({:.2}°, {:.3e} lx) to {} ({:.2}°, {:.3e} lx), {}× time",
                n,
                iso(0.0),
                sun[0],
                lux[0],
                iso(seq.duration_s()),
                sun[n - 1],
                lux[n - 1],
                c.time_scale
            )
        })
    }

    /// The run in one line: frames, renders, times, gains, where.
    fn summary_line(
        &self,
        captured: &SceneCaptured,
        renders: &PoseRenders,
        total_s: f64,
    ) -> String {
        let (r, moves) = (&captured.report, self.sequence.moves.len());
        let frames = f64::from(r.frames.max(1));
        let gains = r.gain_over_time.iter().map(|g| g.1);
        let (lo, hi) = gains.fold((f64::INFINITY, 0.0f64), |(l, h), g| (l.min(g), h.max(g)));
        let plural =
            |n: usize, one: &'static str, many: &'static str| if n == 1 { one } else { many };
        format!(
            "sequence: {} frames at {} Hz through '{}', {} light groups; {} layered render{} ({} pose{} of {} moving bod{}, {} frames reused a render) {:.2} s, {:.2} s a render; mixing {:.2} ms/frame, camera {:.1} ms/frame; gain in effect {:.4}–{:.4}; {:.2} s in all → {}",
            r.frames,
            r.frame_rate_hz,
            self.camera.name(),
            r.groups.len(),
            renders.renders,
            plural(renders.renders, "", "s"),
            renders.poses.len(),
            plural(renders.poses.len(), "", "s"),
            moves,
            plural(moves, "y", "ies"),
            renders.frames.saturating_sub(renders.renders as u32),
            renders.seconds,
            renders.seconds / (renders.renders.max(1) as f64),
            1e3 * r.mix_s / frames,
            1e3 * r.camera_s / frames,
            lo,
            hi,
            total_s,
            self.out.path.display()
        )
    }
}

/// `--target-error camera:K`: what frame 0's pose was rendered to.
fn camera_target_line(k: f64, t: &crate::camera_goal::CameraTarget) -> String {
    format!(
        "--target-error camera:{k}: frame 0's pose rendered until, at each pixel's brightest frame, its variance is under {:.0} % of the camera's frame variance at gain {:.4}: added {:.1} % (median), {:.1} % (99th percentile); mean {:.1} spp",
        100.0 * k * k,
        t.gain,
        100.0 * t.added_variance_fraction_median,
        100.0 * t.added_variance_fraction_p99,
        t.mean_spp.unwrap_or(f64::NAN),
    )
}

/// How the AGC held the median over the sky's light. A loop that never
/// reached its set range has no frame "from" which it held, nor a range of
/// medians or light: said so, not `frame -1 (NaN s)`, `inf–-inf` and `NaN
/// decades`.
fn agc_line(a: &AgcOverSky, frames: u32) -> String {
    let head = format!(
        "AGC ({:?} metering, set point {} DN): the median",
        a.metering, a.set_point_dn
    );
    let range = AGC_SET_RANGE_FACTOR;
    match (a.held_from_frame, a.held_from_s) {
        (Some(frame), Some(s)) => format!(
            "{head} within ×/÷{range} of it in {} of {} frames from frame {frame} ({s:.2} s) on, {:.3}–{:.3} of the set point, over {:.3e} → {:.3e} lx ({:.2} decades)",
            a.frames_in_range,
            a.frames_after,
            a.median_over_set_point[0],
            a.median_over_set_point[1],
            a.lux_range[0],
            a.lux_range[1],
            a.decades
        ),
        _ => format!("{head} never came within ×/÷{range} of it in {frames} frames"),
    }
}

const SEQUENCE_METHOD: &str = "each distinct pose of the moving bodies (at each frame's mid-exposure; one pose without [[move]]) rendered once, in one pass that attributes each path's light to its emitter's light group (one layer per group, the still render's samples and random numbers), the whole scene moved, so each pose's layers sum to the still render of that pose; frame i mixes its pose's layers' detected radiance with the groups' mean intensities over its exposure window and runs it through one camera, whose AGC, lag and bright-source protection carry over between frames";

const SKY_METHOD: &str = "the scene rendered at each instant of `renders` (the sky's clock: utc_at_start + time_scale × t), each frame's layers taken pixel by pixel geometrically between the two renders around its mid-exposure (a^(1-f) b^f; linearly where either is 0); photocells switch on the sky model's horizontal illuminance at the site";

/// What each of the sequence's own output files holds.
fn sequence_outputs() -> BTreeMap<&'static str, String> {
    BTreeMap::from([
        ("frames.jsonl", "one line per frame; its `sequence` gives time_s, window_s and each light group's mean intensity over the exposure".to_string()),
        ("gain-over-time.png", "the gain in effect per frame".to_string()),
        ("frames-preview-animated.png", format!(
            "APNG: the frames (at most {ANIMATION_MAX_FRAMES}, at most {ANIMATION_MAX_WIDTH_PX} px wide), each black level to clip"
        )),
        ("layers.npy", "frame 0's pose: group × band × row × column, W m⁻² sr⁻¹ (their sum is the still render of that pose)".to_string()),
    ])
}

/// A sequence's `report.json`. Its keys are a user contract: add, never
/// rename.
#[derive(Serialize)]
pub struct SequenceRunReport<'a> {
    /// The scene file, as the sequence names it.
    pub scene: String,
    pub units: &'a str,
    pub image: SequenceImage<'a>,
    pub settings: Option<&'a RenderSettings>,
    pub effect_plan: &'a gloam_scene::plan::EffectPlan,
    pub sequence: SequenceSection<'a>,
    pub sensor_capture: &'a crate::capture::SensorCaptureReport,
    pub provenance: &'a Provenance,
    /// `--target-error camera[:K]`: frame 0's pose's camera target.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_target: Option<&'a crate::camera_goal::CameraTarget>,
}

#[derive(Serialize)]
pub struct SequenceImage<'a> {
    pub width: u32,
    pub height: u32,
    pub bands: Option<&'a Vec<String>>,
}

/// `report.json`'s `sequence`: the file, its frames, groups and bodies,
/// what was rendered, the sky clock, the outputs and the timings.
#[derive(Serialize)]
pub struct SequenceSection<'a> {
    pub file: String,
    pub frames: u32,
    pub frame_rate_hz: f64,
    pub groups: &'a [String],
    pub camera: &'a str,
    pub moves: Vec<MoveSummary<'a>>,
    pub renders: &'a PoseRenders,
    pub sky: Option<SkySection<'a>>,
    pub outputs: BTreeMap<&'static str, String>,
    pub timings_s: SequenceTimings,
    pub method: &'static str,
}

#[derive(Serialize)]
pub struct MoveSummary<'a> {
    pub objects: &'a [String],
    pub point_sources: &'a [String],
    /// How many keys the body's track has.
    pub keys: usize,
}

#[derive(Serialize)]
pub struct SequenceTimings {
    pub load: f64,
    pub layered_render: f64,
    pub layered_render_per_pose: f64,
    pub mix: f64,
    pub camera: f64,
    pub write_layers: f64,
    pub mix_per_frame_ms: f64,
    pub camera_per_frame_ms: f64,
}

/// `sequence.sky`: the sky clock, its renders, the photocells and the AGC
/// over the sky's light.
#[derive(Serialize)]
pub struct SkySection<'a> {
    pub utc_at_start: Option<String>,
    pub time_scale: f64,
    pub renders: Vec<SkyRender>,
    pub photocells: BTreeMap<&'a str, PhotocellReport<'a>>,
    pub agc: Option<&'a AgcOverSky>,
    pub warnings: &'a [String],
    pub method: &'static str,
}

#[derive(Serialize)]
pub struct SkyRender {
    pub time_s: f64,
    pub utc: Option<String>,
    pub sun_elevation_deg: f64,
    pub horizontal_lux: f64,
}

#[derive(Serialize)]
pub struct PhotocellReport<'a> {
    pub on_lux: f64,
    pub run_up_s: f64,
    pub keys: &'a [(f64, f64)],
}

impl<'a> SkySection<'a> {
    fn of(
        seq: &'a Sequence,
        c: &'a gloam_scene::sequence::SkyClock,
        agc: Option<&'a AgcOverSky>,
    ) -> Self {
        let renders = (c.key_times_s.iter().zip(&c.key_sun_deg).zip(&c.key_lux))
            .map(|((&t, &sun), &lux)| SkyRender {
                time_s: t,
                utc: seq.sky_instant_at(t).map(|u| u.to_iso8601()),
                sun_elevation_deg: sun,
                horizontal_lux: lux,
            })
            .collect();
        let photocells = (seq.groups.iter())
            .filter_map(|(g, t)| t.photocell.map(|p| (g, p, t)))
            .map(|(g, p, t)| {
                let cell = PhotocellReport {
                    on_lux: p.on_lux,
                    run_up_s: p.run_up_s,
                    keys: &t.keys,
                };
                (g.as_str(), cell)
            })
            .collect();
        Self {
            utc_at_start: c.start.as_ref().map(|t| t.to_iso8601()),
            time_scale: c.time_scale,
            renders,
            photocells,
            agc,
            warnings: &c.warnings,
            method: SKY_METHOD,
        }
    }
}
