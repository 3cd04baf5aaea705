//! A night that changes, through the camera: `gloam sequence`.
//!
//! The scene is rendered once into one detected-radiance layer per light
//! group (radiance is linear in each group's emission); frame `i` is the
//! layers mixed with the sequence file's weights for its exposure window
//! ([`gloam_scene::sequence`]), captured by one camera whose AGC, lag and
//! bright-source protection run across the frames at the sequence's frame
//! rate. Mixing costs one multiply-add per pixel and group, so a sequence
//! costs the layered render plus the camera's time per frame.
//!
//! Moving bodies (`[[move]]`) break the sum: a car shadows and reflects
//! every group's light. [`capture_scene_sequence`] therefore renders every
//! group's layer once per *distinct pose* of the bodies (the poses at each
//! frame's mid-exposure), each pose exactly the still render of the scene
//! with the bodies placed there; frames that share a pose (a car parked,
//! or not yet started) share its render, which is kept from the pose's
//! first frame to its last and then dropped.

use std::path::Path;
use std::time::Instant;

use gloam_scene::sequence::Sequence;
use ndarray::Array2;

use crate::frames::{CaptureError, FrameCapture, FrameContext, FrameWriter};

/// Why a sequence was not captured.
#[derive(Debug, thiserror::Error)]
pub enum SequenceError {
    #[error(transparent)]
    Scene(#[from] gloam_scene::SceneError),
    #[error(transparent)]
    Capture(#[from] CaptureError),
    #[error(
        "{} layers for {} light groups: the layered render and the scene disagree",
        layers,
        groups
    )]
    LayerCount { layers: usize, groups: usize },
    #[error("layer {index} is {got:?}, the first layer {want:?}: layers must share one image size")]
    LayerShape {
        index: usize,
        got: (usize, usize),
        want: (usize, usize),
    },
    #[error("writing the sequence's plot")]
    Plot(#[source] gloam_calib::CalibError),
    /// An analogue camera's video standard fixes its frame rate.
    #[error(
        "{}:{line}: frame_rate_hz = {sequence_hz} Hz, but camera '{sensor}' outputs {format} video at {format_hz:.3} frames/s: give the sequence that frame rate or use a camera without a [video] stage",
        path.display()
    )]
    VideoRate {
        path: std::path::PathBuf,
        line: usize,
        sequence_hz: f64,
        sensor: String,
        format: &'static str,
        format_hz: f64,
    },
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// More distinct poses than [`MAX_POSES`] (each one is a full layered
    /// render), or more held at once than memory allows.
    #[error(
        "{}:{line}: move: the moving bodies take {poses} distinct poses over the {frames} frames (poses at mid-exposure), {held} of them needed at once ({bytes} bytes of layers); at most {max} poses and {max_bytes} bytes: each pose is a full render of every light group — use fewer frames, or hold the bodies still for part of the sequence",
        path.display()
    )]
    TooManyPoses {
        path: std::path::PathBuf,
        line: usize,
        poses: usize,
        frames: u32,
        held: usize,
        bytes: u128,
        max: usize,
        max_bytes: u128,
    },
    #[error("writing {}", path.display())]
    Preview {
        path: std::path::PathBuf,
        #[source]
        source: crate::output::OutputError,
    },
}

/// How far a sequence's frame rate may stray from an analogue camera's
/// video standard: 0.2 %, so `30` Hz names RS-170's 29.97 frames/s.
pub const VIDEO_RATE_TOLERANCE: f64 = 2e-3;

/// Refuses a frame rate the camera's video standard cannot carry (two
/// interlaced fields per frame); a camera without `[video]` takes any.
pub fn check_video_rate(
    sequence: &Sequence,
    sensor: &str,
    config: &gloam_sensor::SensorConfig,
) -> Result<(), SequenceError> {
    let Some(video) = &config.video else {
        return Ok(());
    };
    let timing = gloam_sensor::stages::video_timing::LineTiming::of(video.format);
    let format_hz = timing.field_rate_hz / 2.0;
    if (sequence.frame_rate_hz / format_hz - 1.0).abs() > VIDEO_RATE_TOLERANCE {
        return Err(SequenceError::VideoRate {
            path: sequence.path.clone(),
            line: sequence.frame_rate_line(),
            sequence_hz: sequence.frame_rate_hz,
            sensor: sensor.to_string(),
            format: video.format.label(),
            format_hz,
        });
    }
    Ok(())
}

/// `Σ_g w_g · layer_g` into `out` (resized to the layers' shape), summed in
/// group order in f64.
pub fn mix(layers: &[Array2<f64>], weights: &[f64], out: &mut Array2<f64>) {
    let Some(first) = layers.first() else {
        out.fill(0.0);
        return;
    };
    if out.dim() != first.dim() {
        *out = Array2::zeros(first.dim());
    }
    // The device's mix (`gloam device --sequence`) is the same sum.
    gloam_simcam::mix_layers(layers, weights, out);
}

pub use gloam_io::frames::{SequenceFrame, SkyAtFrame};

/// The sky at sequence time `t` s, if the sequence has a clock.
pub fn sky_at_frame(sequence: &Sequence, t: f64) -> Option<SkyAtFrame> {
    let (a, b, f) = sequence.sky_bracket(t)?;
    let clock = sequence.sky.as_ref()?;
    let sun = &clock.key_sun_deg;
    Some(SkyAtFrame {
        utc: sequence.sky_instant_at(t)?.to_iso8601(),
        sun_elevation_deg: sun[a] + (sun[b] - sun[a]) * f,
        horizontal_lux: sequence.sky_lux_at(t)?,
        renders: [a, b],
        fraction: f,
    })
}

/// What a captured sequence tells its user and records.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SequenceReport {
    pub frames: u32,
    pub frame_rate_hz: f64,
    pub groups: Vec<String>,
    /// Wall time spent mixing layers, s (all frames).
    pub mix_s: f64,
    /// Wall time in the camera model and writing frames, s (all frames).
    pub camera_s: f64,
    /// The capture's `sensor_capture` (fit, per-frame levels, saturation).
    pub sensor_capture: crate::capture::SensorCaptureReport,
    #[serde(skip)]
    pub notes: Vec<String>,
    /// (time s, gain in effect) per frame: what `gain-over-time.png` draws.
    pub gain_over_time: Vec<(f64, f64)>,
    /// With a `[sky]` clock, per frame: (time s, median count above black
    /// DN, the site's horizontal illuminance lx).
    pub medians_above_black_dn: Vec<(f64, f64, f64)>,
    /// With a scene ([`capture_scene_sequence`]): what was rendered, pose
    /// by pose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub renders: Option<PoseRenders>,
}

/// Most distinct poses a sequence may render (each a full layered render).
pub const MAX_POSES: usize = 10_000;

/// The renders a sequence from a scene made: one layered render per
/// distinct pose of its moving bodies (one in all without `[[move]]`).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PoseRenders {
    /// Layered renders made (= distinct poses).
    pub renders: usize,
    /// Frames in all; `frames − renders` frames reused a render.
    pub frames: u32,
    /// Light groups rendered per pose (every group: a moving body changes
    /// every group's light).
    pub groups_per_render: usize,
    /// Wall time of all renders (preparation — BVH, pilot, cache — and
    /// layers), s.
    pub seconds: f64,
    /// Each render: its pose per move, its frames and its time.
    pub poses: Vec<PoseRender>,
}

/// One layered render of a sequence.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PoseRender {
    /// One pose per `[[move]]`, in file order.
    pub poses: Vec<gloam_scene::sequence::Pose>,
    /// With a `[sky]` clock: the sky's instant of this render (frames
    /// between two renders take their pixels geometrically between).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky_utc: Option<String>,
    /// Its index among the sky's renders.
    #[serde(skip)]
    pub sky_key: Option<usize>,
    /// First and last frame seeing it (every frame between with the same
    /// pose counted in `frames`).
    pub first_frame: u32,
    pub last_frame: u32,
    pub frames: u32,
    pub seconds: f64,
    /// With `--target-error camera`: the pose's `camera_target`
    /// ([`crate::camera_goal::CameraGoal::report_layered`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_target: Option<crate::camera_goal::CameraTarget>,
}

/// Captures `sequence` from the layers (`groups[i]`'s detected radiance,
/// e⁻ s⁻¹ m⁻² sr⁻¹, is `layers[i]`) through `capture`'s camera into `out`:
/// the frames, `frames.jsonl` (each line with its `sequence` place),
/// `frames-preview.png`, the animated [`ANIMATION`] and `gain-over-time.png`.
/// The layers are the whole sequence's: a sequence with `[[move]]` needs
/// [`capture_scene_sequence`].
pub fn capture_sequence(
    sequence: &Sequence,
    groups: &[String],
    layers: &[Array2<f64>],
    capture: &FrameCapture<'_>,
    out: &Path,
    context: FrameContext,
) -> Result<SequenceReport, SequenceError> {
    sequence.check_groups(groups.iter().map(String::as_str))?;
    sequence.check_static("a sequence captured from layers given")?;
    check_layers(layers, groups.len())?;
    let want = layers.first().map_or((0, 0), Array2::dim);
    let mut feed = |_: &SequenceStep, weights: &[f64], img: &mut Array2<f64>| {
        mix(layers, weights, img);
        Ok(())
    };
    capture_with(sequence, groups, want, &mut feed, capture, out, context)
}

/// Refuses layers that are not one per group and of one size.
fn check_layers(layers: &[Array2<f64>], groups: usize) -> Result<(), SequenceError> {
    if layers.len() != groups {
        return Err(SequenceError::LayerCount {
            layers: layers.len(),
            groups,
        });
    }
    let want = layers.first().map_or((0, 0), Array2::dim);
    for (index, l) in layers.iter().enumerate() {
        if l.dim() != want {
            return Err(SequenceError::LayerShape {
                index,
                got: l.dim(),
                want,
            });
        }
    }
    Ok(())
}

/// A sequence to render from its scene: [`capture_scene_sequence`]'s job.
pub struct SceneSequence<'a> {
    pub sequence: &'a Sequence,
    /// The sequence's scene as loaded (its bodies at the identity pose).
    pub scene: &'a gloam_scene::Scene,
    pub settings: &'a gloam_trace::RenderSettings,
    /// Told of each render's preparation steps.
    pub observer: Option<gloam_trace::PrepObserver>,
    /// Told of each render's tiles, `(done, total)`.
    pub progress: &'a (dyn Fn(u64, u64) + Sync),
    /// `K` of `--target-error camera[:K]`: each pose's layers sampled to
    /// the camera's noise at the brightest frame each pixel sees
    /// ([`crate::camera_goal`]).
    pub camera_k: Option<f64>,
    /// With a `[sky]` clock, keep every sky render's detected layers (for
    /// a calibration that needs each frame's true radiance afterwards).
    pub keep_sky_renders: bool,
}

/// What [`capture_scene_sequence`] made besides the frames.
pub struct SceneCaptured {
    pub report: SequenceReport,
    /// The layers of frame 0's pose (for `layers.npy`; with no `[[move]]`,
    /// the layers of every frame).
    pub first: crate::render::Layers,
    /// Frame 0's bodies' poses, one per move.
    pub first_poses: Vec<gloam_scene::sequence::Pose>,
    /// The effect plan frame 0's render ran (each pose's render plans
    /// itself, as a still of that pose would).
    pub plan: gloam_scene::plan::EffectPlan,
    /// With `keep_sky_renders`: each sky render's detected layers, by its
    /// index among the clock's renders (empty where none was made).
    pub sky_renders: Vec<Vec<Array2<f64>>>,
}

/// Renders `job`'s scene into layers once per distinct pose of its moving
/// bodies (see the module docs) and captures the sequence through
/// `capture`'s camera into `out`, as [`capture_sequence`] does.
pub fn capture_scene_sequence(
    job: &SceneSequence<'_>,
    capture: &FrameCapture<'_>,
    out: &Path,
    context: FrameContext,
) -> Result<SceneCaptured, SequenceError> {
    let sequence = job.sequence;
    let groups: Vec<String> = (job.scene.light_groups.groups.iter())
        .map(|g| g.name.clone())
        .collect();
    sequence.check_groups(groups.iter().map(String::as_str))?;
    sequence.check_moves(job.scene)?;
    if let Some(c) = &sequence.sky
        && c.key_times_s.is_empty()
    {
        return Err(SequenceError::Scene(gloam_scene::SceneError::Invalid {
            path: sequence.path.clone(),
            line: 1,
            column: 1,
            field: "sky".into(),
            message: "the [sky] clock was not tied to the scene (Sequence::bind_sky)".into(),
        }));
    }
    // The tracer's image size: the camera's times `resolution_scale`
    // (rounded, ≥ 1), as `gloam_trace` sizes it; the layers are checked
    // against it.
    let cam = &job.scene.camera;
    let scaled = |n: u32| ((f64::from(n) * job.settings.resolution_scale).round() as usize).max(1);
    let want = (scaled(cam.height), scaled(cam.width));
    let mut cache = PoseCache::new(job, capture, groups.len(), want);
    let mut feed = |f: &SequenceStep, weights: &[f64], img: &mut Array2<f64>| {
        let layers = cache.layers(f)?;
        check_layers(layers, weights.len())?;
        if let Some(l) = layers.first().filter(|l| l.dim() != want) {
            return Err(SequenceError::LayerShape {
                index: 0,
                got: l.dim(),
                want,
            });
        }
        mix(layers, weights, img);
        cache.done(f);
        Ok(())
    };
    let mut report = capture_with(sequence, &groups, want, &mut feed, capture, out, context)?;
    let renders = cache.summary(sequence.frames);
    // The renders after frame 0's look ran inside the frames' mixing:
    // their time is theirs.
    report.mix_s = (report.mix_s - (renders.seconds - cache.seconds_before)).max(0.0);
    report.renders = Some(renders);
    let (first, first_poses, plan) = cache.first.take().ok_or(SequenceError::LayerCount {
        layers: 0,
        groups: groups.len(),
    })?;
    let mut sky_renders = vec![Vec::new(); sequence.sky_key_times_s().len()];
    for (k, layers) in std::mem::take(&mut cache.kept) {
        if let Some(slot) = sky_renders.get_mut(k) {
            *slot = layers;
        }
    }
    Ok(SceneCaptured {
        report,
        first,
        first_poses,
        plan,
        sky_renders,
    })
}

/// One step of a sequence: which frame, its exposure start and window, s
/// (not a frame: the frames are the camera's).
pub struct SequenceStep {
    pub index: u32,
    pub start_s: f64,
    pub window_s: f64,
    /// False for the look at frame 0 the fit takes before the capture.
    count: bool,
}

impl SequenceStep {
    /// Mid-exposure: the instant a frame's moving bodies are drawn at.
    pub fn mid_s(&self) -> f64 {
        self.start_s + 0.5 * self.window_s
    }
}

/// A render's key: its bodies' poses (to the bit) and its sky render.
type StateKeys = std::collections::HashMap<(Vec<[u64; 4]>, Option<usize>), usize>;

/// The layered renders of each distinct pose (and sky instant), each kept
/// from its first frame to its last.
struct PoseCache<'a> {
    job: &'a SceneSequence<'a>,
    capture: &'a FrameCapture<'a>,
    camera: &'a crate::ResolvedSensor,
    /// With `--target-error camera`: per pose, its frames' weightings.
    mixes: Vec<crate::camera_goal::Mixes>,
    /// The camera's level as frame 0's pose's goal decided it.
    settled: Option<crate::camera_goal::Settled>,
    groups: usize,
    size: (usize, usize),
    /// Per frame, its render's id (its poses and, with a `[sky]` clock,
    /// the sky render before it) and the sky render after it with how far
    /// towards it the frame lies; per id, its poses, sky and frames.
    ids: Vec<(usize, Option<(usize, f64)>)>,
    planned: Vec<PoseRender>,
    /// A frame's layers between two sky renders.
    between: Vec<Array2<f64>>,
    /// With `keep_sky_renders`: (sky render, its detected layers).
    kept: Vec<(usize, Vec<Array2<f64>>)>,
    window_s: Option<f64>,
    live: std::collections::HashMap<usize, Vec<Array2<f64>>>,
    rendered: Vec<bool>,
    /// Layered renders made (a pose dropped and needed again would count
    /// twice; the plan keeps each pose until its last frame, so none is).
    calls: usize,
    seconds: f64,
    /// Of `seconds`, the renders for frame 0's look before the capture.
    seconds_before: f64,
    first: Option<(
        crate::render::Layers,
        Vec<gloam_scene::sequence::Pose>,
        gloam_scene::plan::EffectPlan,
    )>,
}

impl<'a> PoseCache<'a> {
    fn new(
        job: &'a SceneSequence<'a>,
        capture: &'a FrameCapture<'a>,
        groups: usize,
        size: (usize, usize),
    ) -> Self {
        Self {
            job,
            capture,
            camera: capture.sensor,
            mixes: Vec::new(),
            settled: None,
            groups,
            size,
            ids: Vec::new(),
            planned: Vec::new(),
            between: Vec::new(),
            kept: Vec::new(),
            window_s: None,
            live: std::collections::HashMap::new(),
            rendered: Vec::new(),
            calls: 0,
            seconds: 0.0,
            seconds_before: 0.0,
            first: None,
        }
    }

    /// Plans every frame's pose for exposure window `window_s` (known once
    /// the camera is configured), refusing more than [`MAX_POSES`] or more
    /// layers held at once than half the memory available.
    fn plan(&mut self, window_s: f64) -> Result<(), SequenceError> {
        let seq = self.job.sequence;
        let mut by_key = StateKeys::new();
        self.ids = Vec::with_capacity(seq.frames as usize);
        self.planned.clear();
        self.mixes.clear();
        let names: Vec<&str> = (self.job.scene.light_groups.groups.iter())
            .map(|g| g.name.as_str())
            .collect();
        for i in 0..seq.frames {
            let f = SequenceStep {
                index: i,
                start_s: seq.frame_start_s(i),
                window_s,
                count: true,
            };
            let poses = seq.poses_at(f.mid_s());
            let t0 = f.start_s;
            let weights = seq.weights(names.iter().copied(), t0, t0 + window_s);
            let ids = match seq.sky_bracket(f.mid_s()) {
                None => (self.state(&mut by_key, &poses, None, i, &weights), None),
                Some((a, b, fraction)) => {
                    let first = self.state(&mut by_key, &poses, Some(a), i, &weights);
                    let second = (b != a && fraction > 0.0).then(|| {
                        let id = self.state(&mut by_key, &poses, Some(b), i, &weights);
                        (id, fraction)
                    });
                    (first, second)
                }
            };
            self.ids.push(ids);
        }
        // Poses held at once: each from its first frame to its last.
        let mut delta = vec![0i64; seq.frames as usize + 1];
        for p in &self.planned {
            delta[p.first_frame as usize] += 1;
            delta[p.last_frame as usize + 1] -= 1;
        }
        let (mut held, mut now) = (0i64, 0i64);
        for d in &delta {
            now += d;
            held = held.max(now);
        }
        let held = held.max(1) as usize;
        let bytes = (held as u128)
            * (self.groups.max(1) as u128)
            * (self.size.0 as u128)
            * (self.size.1 as u128)
            * 8;
        let max_bytes =
            gloam_scene::available_memory_bytes().map_or(u128::MAX, |b| u128::from(b) / 2);
        if self.planned.len() > MAX_POSES || bytes > max_bytes {
            return Err(SequenceError::TooManyPoses {
                path: seq.path.clone(),
                line: seq.move_line(0),
                poses: self.planned.len(),
                frames: seq.frames,
                held,
                bytes,
                max: MAX_POSES,
                max_bytes,
            });
        }
        self.rendered = vec![false; self.planned.len()];
        self.window_s = Some(window_s);
        Ok(())
    }

    /// The id of the render of `poses` under sky render `sky`, planned
    /// now if new, with frame `frame` (of `weights`) counted in it.
    fn state(
        &mut self,
        by_key: &mut StateKeys,
        poses: &[gloam_scene::sequence::Pose],
        sky: Option<usize>,
        frame: u32,
        weights: &[f64],
    ) -> usize {
        let seq = self.job.sequence;
        let key = (poses.iter().map(|p| p.bits()).collect(), sky);
        let next = self.planned.len();
        let id = *by_key.entry(key).or_insert(next);
        if id == next {
            let sky_utc = sky
                .and_then(|k| seq.sky_key_times_s().get(k).copied())
                .and_then(|t| seq.sky_instant_at(t))
                .map(|t| t.to_iso8601());
            self.planned.push(PoseRender {
                poses: poses.to_vec(),
                sky_utc,
                sky_key: sky,
                first_frame: frame,
                last_frame: frame,
                frames: 0,
                seconds: 0.0,
                camera_target: None,
            });
            if self.job.camera_k.is_some() {
                self.mixes.push(crate::camera_goal::Mixes::default());
            }
        }
        if let Some(m) = self.mixes.get_mut(id) {
            m.add(weights);
        }
        let p = &mut self.planned[id];
        p.last_frame = frame;
        p.frames += 1;
        id
    }

    /// Frame `f`'s layers: its render's, rendered now if not yet; between
    /// two sky renders, each pixel geometrically between theirs.
    fn layers(&mut self, f: &SequenceStep) -> Result<&[Array2<f64>], SequenceError> {
        if self.window_s != Some(f.window_s) {
            self.plan(f.window_s)?;
        }
        let (id, second) = self.ids[f.index as usize];
        self.ensure(id, f)?;
        let Some((other, fraction)) = second else {
            return Ok(self.live.get(&id).map_or(&[][..], Vec::as_slice));
        };
        self.ensure(other, f)?;
        let (Some(a), Some(b)) = (self.live.get(&id), self.live.get(&other)) else {
            return Ok(&[]);
        };
        gloam_simcam::layers_between(a, b, fraction, &mut self.between);
        Ok(&self.between)
    }

    /// Renders state `id` if it is not live yet (for frame `f`).
    fn ensure(&mut self, id: usize, f: &SequenceStep) -> Result<(), SequenceError> {
        if !self.live.contains_key(&id) {
            let poses = self.planned[id].poses.clone();
            let t0 = Instant::now();
            let (layers, plan, target) = self.render(id, &poses)?;
            self.planned[id].camera_target = target;
            let s = t0.elapsed().as_secs_f64();
            self.planned[id].seconds += s;
            self.seconds += s;
            if !f.count {
                self.seconds_before += s;
            }
            self.rendered[id] = true;
            self.calls += 1;
            let detected = layers.detected.clone().unwrap_or_default();
            if f.index == 0 && self.first.is_none() {
                self.first = Some((layers, poses, plan));
            }
            if let (true, Some(k)) = (self.job.keep_sky_renders, self.planned[id].sky_key) {
                self.kept.push((k, detected.clone()));
            }
            self.live.insert(id, detected);
        }
        Ok(())
    }

    /// Drops frame `f`'s renders after their last frame.
    fn done(&mut self, f: &SequenceStep) {
        let (id, second) = self.ids[f.index as usize];
        for id in std::iter::once(id).chain(second.map(|s| s.0)) {
            if f.count && self.planned[id].last_frame == f.index {
                self.live.remove(&id);
            }
        }
    }

    /// The scene with its bodies at `poses` (pose `id`), rendered into
    /// layers, and with `--target-error camera` its `camera_target`.
    #[allow(clippy::type_complexity)]
    fn render(
        &mut self,
        id: usize,
        poses: &[gloam_scene::sequence::Pose],
    ) -> Result<
        (
            crate::render::Layers,
            gloam_scene::plan::EffectPlan,
            Option<crate::camera_goal::CameraTarget>,
        ),
        SequenceError,
    > {
        let (moved, skied);
        let scene = match self.job.sequence.moves.is_empty() {
            true => self.job.scene,
            false => {
                moved = self.job.sequence.scene_at_checked(self.job.scene, poses)?;
                &moved
            }
        };
        let scene = match self.planned[id].sky_key {
            None => scene,
            Some(k) => {
                skied = self.job.sequence.scene_at_sky(scene, k);
                &skied
            }
        };
        let job = crate::render::RenderJob {
            camera: Some(self.camera),
            observer: self.job.observer.clone(),
            layers: true,
            ..crate::render::RenderJob::new(scene, self.job.settings)
        };
        let prepared = job.prepare()?;
        let plan = prepared.plan().clone();
        let Some(k) = self.job.camera_k else {
            let layers = prepared.render_layers(self.job.progress, &|| false)?;
            return Ok((layers, plan, None));
        };
        let config = sequence_config(self.job.sequence, self.capture)?;
        let mixes = self.mixes.get(id).cloned().unwrap_or_default();
        let goal = crate::camera_goal::CameraGoal::for_sequence(
            &prepared,
            k,
            self.capture,
            config,
            mixes,
            self.settled.clone(),
        );
        let (layers, target) =
            prepared.render_layers_to_goal(&goal, self.job.progress, &|| false)?;
        if self.settled.is_none() {
            self.settled = goal.settled().cloned();
        }
        Ok((layers, plan, target))
    }

    fn summary(&self, frames: u32) -> PoseRenders {
        PoseRenders {
            renders: self.calls,
            frames,
            groups_per_render: self.groups,
            seconds: self.seconds,
            poses: self.planned.clone(),
        }
    }
}

/// The sensor as a sequence runs it: at the sequence's frame rate, its
/// exposure time each frame's window (clamped to the frame period), which
/// frame 0's look needs before the capture; a frame rate the camera's
/// video standard cannot carry is refused.
fn sequence_config(
    sequence: &Sequence,
    capture: &FrameCapture<'_>,
) -> Result<gloam_sensor::SensorConfig, SequenceError> {
    let mut config = capture.sensor.config().clone();
    check_video_rate(sequence, capture.sensor.name(), &config)?;
    config.timing.frame_rate_hz = sequence.frame_rate_hz;
    config.timing.exposure_s = config.timing.exposure_s.min(sequence.frame_period_s());
    Ok(config)
}

/// Writes frame `f`'s image for its weights into the array given.
type Feed<'a> =
    dyn FnMut(&SequenceStep, &[f64], &mut Array2<f64>) -> Result<(), SequenceError> + 'a;

/// The one capture loop of a sequence: frame `i`'s image is `feed`'s mix
/// for its place and weights.
fn capture_with(
    sequence: &Sequence,
    groups: &[String],
    want: (usize, usize),
    feed: &mut Feed<'_>,
    capture: &FrameCapture<'_>,
    out: &Path,
    context: FrameContext,
) -> Result<SequenceReport, SequenceError> {
    let names = || groups.iter().map(String::as_str);
    let config = sequence_config(sequence, capture)?;
    let window_s = config.timing.exposure_s;
    let frame = |i: u32, count: bool| SequenceStep {
        index: i,
        start_s: sequence.frame_start_s(i),
        window_s,
        count,
    };
    // Frame 0's image for the fit and any automatic exposure.
    let mut first = Array2::zeros(want);
    {
        let f = frame(0, false);
        let weights = sequence.weights(names(), f.start_s, f.start_s + f.window_s);
        feed(&f, &weights, &mut first)?;
    }
    let mut places: Vec<SequenceFrame> = Vec::new();
    let mut mix_s = 0.0f64;
    let mut writer = None;
    let mut animation = Animation::new(sequence.frames, sequence.frame_rate_hz);
    let mut gain_over_time = Vec::new();
    let (mut medians, mut throughput_over_time) = (Vec::new(), Vec::new());
    let t_capture = Instant::now();
    let mut capturing = capture.start_configured(config, &first)?;
    // Bounded: the capture's frames, one image each.
    while capturing.next_index() < capture.frames {
        let t = Instant::now();
        let f = frame(capturing.next_index(), true);
        let weights = sequence.weights(names(), f.start_s, f.start_s + f.window_s);
        let mut img = Array2::zeros(want);
        feed(&f, &weights, &mut img)?;
        places.push(SequenceFrame {
            time_s: f.start_s,
            window_s: f.window_s,
            light_groups: groups.iter().cloned().zip(weights).collect(),
            sky: sky_at_frame(sequence, f.mid_s()),
            median_above_black_dn: None,
        });
        mix_s += t.elapsed().as_secs_f64();
        let Some((f, mut rec)) = capturing.next_frame(Some(&img))? else {
            break;
        };
        let i = rec.index as usize;
        if let Some(p) = places.get(i) {
            gain_over_time.push((p.time_s, rec.gain));
            let mut p = p.clone();
            if let Some(sky) = &p.sky {
                // The camera's own median when its AGC metered one.
                let median = (rec.sensor.as_ref())
                    .and_then(|m| m.median_dn)
                    .unwrap_or_else(|| gloam_sensor::median_dn(&f.pixels))
                    - rec.black_dn.unwrap_or(0.0);
                p.median_above_black_dn = Some(median);
                medians.push((p.time_s, median, sky.horizontal_lux));
            }
            if let Some(d) = rec.gate_duty {
                throughput_over_time.push((p.time_s, rec.gain * d));
            }
            rec.sequence = Some(p);
        }
        let r = &rec;
        let black = r.black_dn.unwrap_or(0.0);
        animation.add(
            r.index,
            r.width,
            r.height,
            &f.pixels,
            black,
            r.saturated_at_dn,
        );
        let w = match &mut writer {
            Some(w) => w,
            None => writer.insert(
                FrameWriter::with_format(out, capture.frame_format, context.clone())
                    .map_err(CaptureError::from)?,
            ),
        };
        w.write(&rec, &f.pixels).map_err(CaptureError::from)?;
    }
    let captured = capturing.finish();
    if let Some(w) = writer {
        w.finish().map_err(CaptureError::from)?;
    }
    let path = out.join(ANIMATION);
    if let Some(bytes) = animation.apng().map_err(|source| SequenceError::Preview {
        path: path.clone(),
        source,
    })? {
        crate::output::write_atomic(&path, &bytes)
            .map_err(|source| SequenceError::Preview { path, source })?;
    }
    let camera_s = t_capture.elapsed().as_secs_f64() - mix_s;
    gloam_calib::plot::xy_plot_scaled(
        &out.join("gain-over-time.png"),
        &format!(
            "gain in effect, {} frames at {} Hz ({})",
            sequence.frames,
            sequence.frame_rate_hz,
            // A sensor file's name, not its path: the title stays short.
            Path::new(capture.sensor.name())
                .file_stem()
                .map_or(capture.sensor.name().into(), |s| s.to_string_lossy())
        ),
        ("time, s", gloam_calib::plot::Scale::Linear),
        ("gain in effect", gloam_calib::plot::Scale::Log10),
        &gain_series(&gain_over_time, throughput_over_time),
    )
    .map_err(SequenceError::Plot)?;
    plot_sky(sequence, &places, out)?;
    Ok(SequenceReport {
        frames: sequence.frames,
        frame_rate_hz: sequence.frame_rate_hz,
        groups: groups.to_vec(),
        mix_s,
        camera_s,
        sensor_capture: captured.report,
        notes: captured.notes,
        gain_over_time,
        medians_above_black_dn: medians,
        renders: None,
    })
}

/// The AGC's set range: its set point within a factor of this (±1 stop).
pub const AGC_SET_RANGE_FACTOR: f64 = 2.0;

/// How the AGC held a frame statistic over a sky clock's light.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AgcOverSky {
    pub set_point_dn: f64,
    /// What the loop servos: `mean` or `median`.
    pub metering: gloam_sensor::config::Metering,
    /// The set range, DN above black: set point ÷ and × [`AGC_SET_RANGE_FACTOR`].
    pub set_range_dn: [f64; 2],
    /// The first frame whose median is in the set range (the loop's
    /// acquisition from its power-up gain ends there), and its time.
    pub held_from_frame: Option<usize>,
    pub held_from_s: Option<f64>,
    /// Frames from then on, and how many of them have their median in
    /// the set range.
    pub frames_after: usize,
    pub frames_in_range: usize,
    /// Lowest and highest median over the set point from then on.
    pub median_over_set_point: [f64; 2],
    /// The site's horizontal illuminance from then on: brightest and
    /// darkest, lux, and the decades between.
    pub lux_range: [f64; 2],
    pub decades: f64,
}

/// [`AgcOverSky`] from a captured sequence's medians (a `[sky]` clock's
/// frames) and the camera's AGC.
pub fn agc_over_sky(
    report: &SequenceReport,
    agc: &gloam_sensor::config::Agc,
) -> Option<AgcOverSky> {
    let m = &report.medians_above_black_dn;
    let sp = agc.set_point_dn;
    let range = [sp / AGC_SET_RANGE_FACTOR, sp * AGC_SET_RANGE_FACTOR];
    let inside = |v: f64| (range[0]..=range[1]).contains(&v);
    let from = m.iter().position(|x| inside(x.1));
    let after = from.map_or(&[][..], |i| &m[i..]);
    let fold = |f: &dyn Fn(&(f64, f64, f64)) -> f64| {
        after
            .iter()
            .map(f)
            .fold([f64::INFINITY, f64::NEG_INFINITY], |a, v| {
                [a[0].min(v), a[1].max(v)]
            })
    };
    let ratio = fold(&|x| x.1 / sp);
    let lux = fold(&|x| x.2);
    (!m.is_empty()).then(|| AgcOverSky {
        set_point_dn: sp,
        metering: agc.metering,
        set_range_dn: range,
        held_from_frame: from,
        held_from_s: from.map(|i| m[i].0),
        frames_after: after.len(),
        frames_in_range: after.iter().filter(|x| inside(x.1)).count(),
        median_over_set_point: ratio,
        lux_range: [lux[1], lux[0]],
        decades: if lux[0] > 0.0 {
            (lux[1] / lux[0]).log10()
        } else {
            f64::NAN
        },
    })
}

/// The gain in effect and, when a gate cut the light (autogating, the
/// tube's ABC), the gain times the gate's duty: the camera's throughput.
fn gain_series(gain: &[(f64, f64)], throughput: Vec<(f64, f64)>) -> Vec<gloam_calib::plot::Series> {
    let mut out = vec![gloam_calib::plot::Series::new(
        "gain",
        gain.to_vec(),
        gloam_calib::plot::Mark::Line,
    )];
    if throughput.iter().zip(gain).any(|(t, g)| t.1 < g.1) {
        out.push(gloam_calib::plot::Series::new(
            "gain x gate duty",
            throughput,
            gloam_calib::plot::Mark::Line,
        ));
    }
    out
}

/// With a `[sky]` clock, `sky-over-time.png`: the site's horizontal
/// illuminance per frame (what the photocells see), on a log scale.
fn plot_sky(
    sequence: &Sequence,
    places: &[SequenceFrame],
    out: &Path,
) -> Result<(), SequenceError> {
    let lux: Vec<(f64, f64)> = (places.iter())
        .filter_map(|p| p.sky.as_ref().map(|s| (p.time_s, s.horizontal_lux)))
        .filter(|p| p.1 > 0.0)
        .collect();
    if lux.is_empty() {
        return Ok(());
    }
    let scale = sequence.sky.as_ref().map_or(1.0, |c| c.time_scale);
    gloam_calib::plot::xy_plot_scaled(
        &out.join(SKY_PLOT),
        &format!("horizontal illuminance at the site (the sky's clock at {scale}x)"),
        ("time, s", gloam_calib::plot::Scale::Linear),
        ("illuminance, lx", gloam_calib::plot::Scale::Log10),
        &[gloam_calib::plot::Series::new(
            "sky",
            lux,
            gloam_calib::plot::Mark::Line,
        )],
    )
    .map_err(SequenceError::Plot)
}

/// The sky's plot, with a `[sky]` clock.
pub const SKY_PLOT: &str = "sky-over-time.png";

/// The animated preview's file: an APNG (a PNG whose first frame is what
/// viewers without animation show), every browser plays it.
pub const ANIMATION: &str = "frames-preview-animated.png";
/// Most frames in the animation (the sequence is subsampled evenly).
pub const ANIMATION_MAX_FRAMES: u32 = 50;
/// Widest animation frame, pixels (frames box-averaged down by a whole
/// factor).
pub const ANIMATION_MAX_WIDTH_PX: u32 = 240;

/// The frames of a sequence as an 8-bit grey animation, each scaled from
/// its black level (0) to its clip (255) as the contact sheet is, shown at
/// the sequence's pace (each kept frame lasts `stride` frame periods).
struct Animation {
    stride: u64,
    delay_ms: u16,
    size: Option<(u32, u32)>,
    frames: Vec<Vec<u8>>,
}

impl Animation {
    fn new(frames: u32, frame_rate_hz: f64) -> Self {
        let stride = u64::from(frames.div_ceil(ANIMATION_MAX_FRAMES).max(1));
        let delay_ms = (1000.0 * stride as f64 / frame_rate_hz).round();
        Self {
            stride,
            delay_ms: delay_ms.clamp(10.0, 10_000.0) as u16,
            size: None,
            frames: Vec::new(),
        }
    }

    fn add(
        &mut self,
        index: u64,
        width: u32,
        height: u32,
        pixels: &[u16],
        black_dn: f64,
        clip_dn: f64,
    ) {
        let n = width as usize * height as usize;
        if index % self.stride != 0 || pixels.len() != n || n == 0 {
            return;
        }
        if self.frames.len() >= ANIMATION_MAX_FRAMES as usize {
            return;
        }
        let f = width.div_ceil(ANIMATION_MAX_WIDTH_PX).max(1);
        let (w, h) = (width.div_ceil(f), height.div_ceil(f));
        if *self.size.get_or_insert((w, h)) != (w, h) {
            return;
        }
        let (_, _, grey) =
            crate::frame_files::scaled_grey(width, height, pixels, black_dn, clip_dn, f);
        self.frames.push(grey);
    }

    /// The APNG, looping; None before any frame.
    fn apng(&self) -> Result<Option<Vec<u8>>, crate::output::OutputError> {
        let Some((w, h)) = self.size else {
            return Ok(None);
        };
        let enc_err = |e: png::EncodingError| crate::output::OutputError::Encode {
            path: ANIMATION.into(),
            source: e.into(),
        };
        let mut bytes = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut bytes, w, h);
            enc.set_color(png::ColorType::Grayscale);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_animated(self.frames.len() as u32, 0)
                .map_err(enc_err)?;
            enc.set_frame_delay(self.delay_ms, 1000).map_err(enc_err)?;
            let mut writer = enc.write_header().map_err(enc_err)?;
            for f in &self.frames {
                writer.write_image_data(f).map_err(enc_err)?;
            }
            writer.finish().map_err(enc_err)?;
        }
        Ok(Some(bytes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Gen III preset, read once for the tests' captures and renders.
    fn gen3() -> &'static gloam_sensor::ResolvedSensor {
        static G: std::sync::OnceLock<gloam_sensor::ResolvedSensor> = std::sync::OnceLock::new();
        G.get_or_init(|| {
            gloam_sensor::ResolvedSensor::load("gen3-gaas-iccd", &gloam_io::ReadLog::off()).unwrap()
        })
    }

    #[test]
    fn mixing_is_the_weighted_sum_in_f64() {
        let a = Array2::from_shape_fn((3, 4), |(r, c)| (r * 4 + c) as f64);
        let b = Array2::from_elem((3, 4), 0.5);
        let mut out = Array2::zeros((1, 1));
        mix(&[a.clone(), b.clone()], &[2.0, 4.0], &mut out);
        assert_eq!(out, &a * 2.0 + 2.0);
        mix(&[a.clone(), b], &[1.0, 0.0], &mut out);
        assert_eq!(out, a);
    }

    /// A street lamp switching on at 2 s over a moonlit ground: the Gen III
    /// camera's AGC (`time_constant_s = 0.5` in the preset) brings the gain
    /// down with the loop's first-order decay. The decay constant fitted
    /// to the gains in effect is the independent check (within 5 %).
    #[test]
    fn the_agc_answers_a_lamp_switching_on_with_its_time_constant() {
        let dir = tempfile::tempdir().unwrap();
        let seq = gloam_scene::sequence::parse_sequence(
            "scene = \"street.toml\"\nframe_rate_hz = 25\nframes = 125\n[groups.lamp]\nkeys = [[0, 0], [2, 0], [2, 1]]\n",
            &dir.path().join("seq.toml"),
        )
        .unwrap();
        let groups = vec!["moon".to_string(), "lamp".to_string()];
        let layers = vec![
            Array2::from_elem((36, 48), 1e12),
            Array2::from_elem((36, 48), 2e12),
        ];
        let capture = FrameCapture {
            sensor: gen3(),
            frames: seq.frames,
            gain: None,
            agc: true,
            noise: false,
            seed: 1,
            auto_exposure: None,
            frame_format: crate::FrameFormat::Png,
        };
        let r = capture_sequence(
            &seq,
            &groups,
            &layers,
            &capture,
            dir.path(),
            FrameContext {
                camera: None,
                seed: None,
                provenance: None,
                ..FrameContext::default()
            },
        )
        .unwrap();
        let g = &r.gain_over_time;
        assert_eq!(g.len(), 125);
        let on = g.iter().position(|&(t, _)| t >= 2.0).unwrap();
        let g_end = g.last().unwrap().1;
        // Before the lamp the loop had settled on the moonlit ground; after,
        // a third of that gain (the signal tripled).
        let before = g[on].1;
        assert!((before / g_end - 3.0).abs() < 0.15, "{before} → {g_end}");
        // ln g − ln g_∞ decays as e^{−t/τ}: fit τ over the decay's first
        // 95 % (the frames whose error is still > 5 % of its start).
        let y0 = (g[on + 1].1 / g_end).ln();
        let pts: Vec<(f64, f64)> = g[on + 1..]
            .iter()
            .map(|&(t, gain)| (t, (gain / g_end).ln()))
            .take_while(|&(_, y)| y > 0.05 * y0)
            .map(|(t, y)| (t, y.ln()))
            .collect();
        assert!(pts.len() >= 10, "{pts:?}");
        let n = pts.len() as f64;
        let (mx, my) = (
            pts.iter().map(|p| p.0).sum::<f64>() / n,
            pts.iter().map(|p| p.1).sum::<f64>() / n,
        );
        let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
            / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
        let tau = -1.0 / slope;
        eprintln!(
            "AGC after a lamp switched on: fitted τ = {tau:.4} s over {} frames (preset 0.5 s)",
            pts.len()
        );
        assert!((tau / 0.5 - 1.0).abs() < 0.05, "fitted τ = {tau} s");
        // Every frame's line says where it sits in the sequence.
        let text = std::fs::read_to_string(dir.path().join("frames.jsonl")).unwrap();
        let line: serde_json::Value = serde_json::from_str(text.lines().nth(on).unwrap()).unwrap();
        assert_eq!(line["sequence"]["light_groups"]["lamp"], 1.0);
        assert_eq!(line["sequence"]["light_groups"]["moon"], 1.0);
        assert!(dir.path().join("gain-over-time.png").is_file());
        // The animation: 125 frames → every 3rd (≤ 50), 48 px wide (≤ 240).
        let apng = std::fs::read(dir.path().join(ANIMATION)).unwrap();
        let at = apng.windows(4).position(|w| w == b"acTL").unwrap();
        let n = u32::from_be_bytes(apng[at + 4..at + 8].try_into().unwrap());
        assert_eq!(n, 125u32.div_ceil(3));
        let at = apng.windows(4).position(|w| w == b"IHDR").unwrap();
        assert_eq!(
            u32::from_be_bytes(apng[at + 4..at + 8].try_into().unwrap()),
            48
        );
    }

    /// A small road, a static lamp and a car (a box body and a headlamp);
    /// `car` and `heads` are extra lines of their tables.
    fn car_scene(car: &str, heads: &str) -> String {
        format!(
            r#"units = "m"
[camera]
position = [-12, -1, 2]
look_at = [5, 0, 0]
up = [0, 0, 1]
fov_deg = 60
width = 32
height = 24
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.road]
reflectance = 0.2
[materials.paint]
reflectance = 0.5
specular_fraction = 0.3
[objects.road]
material = "road"
quad = {{ center = [0, 0, 0], size = [60, 20], normal = [0, 0, 1] }}
[objects.car]
material = "paint"
box = {{ min = [-2, -0.9, 0.3], max = [2, 0.9, 1.4], omit = ["bottom"] }}
{car}
[point_sources.lamp]
position = [6, -4, 8]
value = 1e-4
[point_sources.heads]
position = [-2.1, 0.6, 0.6]
direction = [-1, 0.1, -0.05]
shape_exponent = 6
value = 1e-4
{heads}
"#
        )
    }

    fn scene_and_sequence(dir: &Path, seq: &str) -> (gloam_scene::Scene, Sequence) {
        let scene_path = dir.join("scene.toml");
        std::fs::write(&scene_path, car_scene("", "")).unwrap();
        let sequence = gloam_scene::sequence::parse_sequence(seq, &dir.join("seq.toml")).unwrap();
        (
            gloam_scene::load(&scene_path, &gloam_io::ReadLog::off()).unwrap(),
            sequence,
        )
    }

    fn quiet_capture(frames: u32) -> FrameCapture<'static> {
        FrameCapture {
            sensor: gen3(),
            frames,
            gain: Some(100.0),
            agc: false,
            noise: false,
            seed: 1,
            auto_exposure: None,
            frame_format: crate::FrameFormat::Png,
        }
    }

    fn no_context() -> FrameContext {
        FrameContext {
            camera: None,
            seed: None,
            provenance: None,
            ..FrameContext::default()
        }
    }

    /// The sequence captured with the tests' settings, no progress and a
    /// noise-free camera.
    fn capture_quietly(
        scene: &gloam_scene::Scene,
        seq: &Sequence,
        frames: u32,
        dir: &Path,
    ) -> Result<SceneCaptured, SequenceError> {
        let settings = settings();
        let job = SceneSequence {
            sequence: seq,
            scene,
            settings: &settings,
            observer: None,
            progress: &|_, _| {},
            camera_k: None,
            keep_sky_renders: false,
        };
        capture_scene_sequence(&job, &quiet_capture(frames), dir, no_context())
    }

    fn settings() -> gloam_trace::RenderSettings {
        let mut s = gloam_trace::RenderSettings::default();
        s.set("spp", "2").unwrap();
        s
    }

    /// The moved scene's layers are the layers of a still render of a
    /// scene *file* that writes the car at that pose (the body's own
    /// `rotate_z_deg`/`translate`, the headlamp as a placement): same
    /// seed, same spp, bit-identical; and their sum is that still's
    /// ordinary image to floating-point summation order (≤ 1e-9).
    #[test]
    fn a_moved_body_renders_as_the_still_of_that_pose() {
        let dir = tempfile::tempdir().unwrap();
        let (scene, seq) = scene_and_sequence(
            dir.path(),
            "scene = \"scene.toml\"\nframe_rate_hz = 25\nframes = 2\n[[move]]\nobjects = [\"car\"]\npoint_sources = [\"heads\"]\nkeys = [[0, 3.5, 1.75, 0, 30]]\n",
        );
        let got = capture_quietly(&scene, &seq, 2, dir.path()).unwrap();
        assert_eq!(got.report.renders.as_ref().unwrap().renders, 1);
        let placed = gloam_scene::parse_str(
            &car_scene(
                "rotate_z_deg = 30\ntranslate = [3.5, 1.75, 0]",
                "instances = [{ translate = [3.5, 1.75, 0], rotate_z_deg = 30 }]",
            ),
            &dir.path().join("placed.toml"),
        )
        .unwrap();
        let still = crate::render::RenderJob {
            camera: Some(gen3()),
            layers: true,
            ..crate::render::RenderJob::new(&placed, &settings())
        }
        .run(&|_, _| {}, &|| false)
        .unwrap();
        let still_layers = still.layers.unwrap().detected.unwrap();
        assert_eq!(still_layers.len(), 2);
        assert_eq!(got.first.detected.as_ref().unwrap(), &still_layers);
        let sum = still_layers
            .iter()
            .fold(Array2::<f64>::zeros(still_layers[0].dim()), |a, l| a + l);
        let whole = still.detected.unwrap();
        let rel = (&sum - &whole)
            .iter()
            .map(|d: &f64| d.abs())
            .fold(0.0, f64::max)
            / whole.iter().copied().fold(0.0, f64::max);
        assert!(rel < 1e-9, "{rel}");
        // And the car is in the picture: the scene as written differs.
        let written = crate::render::RenderJob {
            camera: Some(gen3()),
            ..crate::render::RenderJob::new(&scene, &settings())
        }
        .run(&|_, _| {}, &|| false)
        .unwrap();
        assert_ne!(written.detected.unwrap(), whole);
    }

    /// Frames whose mid-exposure pose is the same share one render: the
    /// car parked until 0.15 s, driving until 0.29 s, parked after. At
    /// 25 Hz with a 40 ms window the mid-exposures are 0.02, 0.06, …:
    /// four frames before the first key, three between, three after.
    #[test]
    fn frames_without_motion_reuse_their_pose_s_render() {
        let dir = tempfile::tempdir().unwrap();
        let (scene, seq) = scene_and_sequence(
            dir.path(),
            "scene = \"scene.toml\"\nframe_rate_hz = 25\nframes = 10\n[[move]]\nobjects = [\"car\"]\npoint_sources = [\"heads\"]\nkeys = [[0.15, 0, 0, 0], [0.29, 5, 0, 0]]\n",
        );
        let got = capture_quietly(&scene, &seq, 10, dir.path()).unwrap();
        let r = got.report.renders.unwrap();
        let frames: Vec<(u32, u32, u32)> = (r.poses.iter())
            .map(|p| (p.first_frame, p.last_frame, p.frames))
            .collect();
        assert_eq!(
            frames,
            [(0, 3, 4), (4, 4, 1), (5, 5, 1), (6, 6, 1), (7, 9, 3)]
        );
        assert_eq!(r.renders, 5);
        // Frame 4's pose is the path's at its mid-exposure, 0.18 s.
        let x = r.poses[1].poses[0].translate[0];
        assert!((x - 5.0 * (0.18 - 0.15) / 0.14).abs() < 1e-12, "{x}");
        // The frames between differ (the car moved), those within a pose
        // do not (no noise, fixed gain; the phosphor's lag has settled).
        let recs: Vec<serde_json::Value> =
            (std::fs::read_to_string(dir.path().join("frames.jsonl"))
                .unwrap()
                .lines())
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(recs[0]["sequence"]["window_s"], 0.04);
        let mean = |i: usize| recs[i]["mean_dn"].as_f64().unwrap();
        assert_ne!(mean(5), mean(6));
    }

    /// A path with more distinct poses than [`MAX_POSES`] is refused
    /// before any render, naming the file and the move's line.
    #[test]
    fn too_many_poses_are_refused_before_rendering() {
        let dir = tempfile::tempdir().unwrap();
        let frames = MAX_POSES as u32 + 1;
        let (scene, seq) = scene_and_sequence(
            dir.path(),
            &format!(
                "scene = \"scene.toml\"\nframe_rate_hz = 25\nframes = {frames}\n\n[[move]]\nobjects = [\"car\"]\nkeys = [[0, 0, 0, 0], [1000, 100, 0, 0]]\n"
            ),
        );
        let t = Instant::now();
        let e = capture_quietly(&scene, &seq, frames, dir.path())
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("seq.toml:5: move:") && e.contains("10001 distinct poses"),
            "{e}"
        );
        assert!(t.elapsed().as_secs_f64() < 5.0);
    }

    #[test]
    fn a_camera_s_video_standard_fixes_the_frame_rate() {
        let seq = |hz: f64| {
            gloam_scene::sequence::parse_sequence(
                &format!("scene = \"s.toml\"\nframe_rate_hz = {hz}\nframes = 1\n"),
                Path::new("seq.toml"),
            )
            .unwrap()
        };
        let gen3 =
            gloam_sensor::load_preset_or_file("gen3-gaas-iccd", &gloam_io::ReadLog::off()).unwrap();
        check_video_rate(&seq(25.0), "gen3", &gen3).unwrap();
        let e = check_video_rate(&seq(30.0), "gen3", &gen3).unwrap_err();
        assert!(
            e.to_string().contains("CCIR (625/50) video at 25.000"),
            "{e}"
        );
        // RS-170's 30000/1001 frames/s answers to `30`.
        let mut rs170 = gen3.clone();
        rs170.video.as_mut().unwrap().format =
            gloam_sensor::stages::video_timing::VideoFormat::Rs170;
        check_video_rate(&seq(30.0), "rs170", &rs170).unwrap();
        check_video_rate(&seq(25.0), "rs170", &rs170).unwrap_err();
        // A camera without analogue video takes any rate.
        let mut ccd =
            gloam_sensor::load_preset_or_file("scientific-ccd", &gloam_io::ReadLog::off()).unwrap();
        ccd.video = None;
        check_video_rate(&seq(30.0), "ccd", &ccd).unwrap();
    }
}
