//! The calibration flows as a front end asks for them, written once:
//! `gloam calibrate …` and `gloam scope` (feature `cli`, [`crate::cli`])
//! and Python's `calibrate_radiance`, `photon_transfer`, `agc_linearity`,
//! `mtf` and `scope` build the same request (plain data), its `validate`
//! makes every check either of them made, and its `run` drives the flow
//! over a grabber the front end opened, telling it what happens through
//! [`Event`]s. So a bad input is refused with one message from both
//! (ripgrep's `LowArgs` → `HiArgs` is the model). The front ends keep what
//! is theirs: the CLI opens the grabber from its URI and the output set and
//! writes the reports; Python passes its open `Grabber` and returns dicts.

use std::path::PathBuf;

use std::path::Path;

use gloam_grabber::{Frame, FrameGrabber, GrabError, OpenOptions, Registry};
use gloam_simcam::FrameExposureExt;

use crate::CalibError;
use crate::agc::{AgcOptions, AgcReport, agc_linearisation};
use crate::capture::FrameLosses;
use crate::mtf_flow::{
    GrabberTarget, MtfRequest, VoltageReport, VoltageRequest, check_sine_frequencies,
    check_target_settings, measure_mtf, voltage_mtf,
};
use crate::ptc::{PtcOptions, PtcResult, photon_transfer};
use crate::radiance::{Lut, RadianceOptions, calibrate_radiance};
use crate::report;
use crate::rig_check::rig_mismatch;
use crate::scope_run::{ScopeOptions, SizeFrom, sim_uri};
use crate::source::{CalibrationSource, SourceFile, open_for_grabber};

/// Why a capture stopped at a signal (Ctrl-C, SIGTERM or SIGHUP): its
/// error and its manifest's `stopped_because`.
pub const INTERRUPTED: &str = "interrupted (Ctrl-C, SIGTERM or SIGHUP)";

/// What a flow tells its front end while it runs.
pub enum Event<'a> {
    /// A line for the operator (stderr), printed at once.
    Note(String),
    /// Progress of a phase: its label, done and total.
    Progress(&'a str, usize, usize),
}

/// The front end's listener: a progress bar and stderr (CLI), nothing or
/// a callback (Python).
pub type Events<'e> = dyn FnMut(Event<'_>) + 'e;

/// Most radiance levels a sweep takes (`--levels`).
pub const MAX_LEVELS: usize = 10_000;
/// Most frames taken at one setting (`--frames`, `--spatial-frames`).
pub const MAX_FRAMES_PER_SETTING: usize = 100_000;
/// Most gains one LUT calibrates (a camera's gain control has at most a
/// few hundred useful settings; each gain is a whole staircase).
pub const MAX_LUT_GAINS: usize = 1_000;

fn usage(m: impl Into<String>) -> CalibError {
    CalibError::Usage(m.into())
}

/// A count in 1..=`max`, refused naming its flag before anything is sized
/// by it (the CLI's parser refuses it first with the same bounds).
fn check_count(flag: &str, n: usize, max: usize) -> Result<(), CalibError> {
    match (1..=max).contains(&n) {
        true => Ok(()),
        false => Err(usage(format!("{flag}: {n} is not in 1..={max}"))),
    }
}

/// A gain: a finite number > 0.
fn check_gain(flag: &str, g: f64) -> Result<(), CalibError> {
    match g.is_finite() && g > 0.0 {
        true => Ok(()),
        false => Err(usage(format!(
            "{flag}: {g} is not a gain (each must be a finite number > 0)"
        ))),
    }
}

/// The calibration source of a flow: its file and how its levels are made.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceRequest {
    /// The source file (TOML; docs/calibration.md).
    pub source: PathBuf,
    /// Radiance levels (generated linear in radiance when the file lists none).
    pub levels: Option<usize>,
    /// Simulated cameras only: the brightest level at this fraction of full scale.
    pub auto_range: Option<f64>,
}

impl SourceRequest {
    fn validate(&self) -> Result<(), CalibError> {
        if let Some(n) = self.levels {
            check_count("--levels", n, MAX_LEVELS)?;
        }
        Ok(())
    }

    /// Opens the source; auto-ranges a sphere at `gain` (`None`: the
    /// camera's current gain) when asked ([`open_for_grabber`]). `reads`
    /// notes the source file and the files it names.
    pub fn open(
        &self,
        g: &mut dyn FrameGrabber,
        gain: Option<f64>,
        reads: &gloam_io::ReadLog,
        ev: &mut Events<'_>,
    ) -> Result<Box<dyn CalibrationSource>, CalibError> {
        let opened = open_for_grabber(&self.source, self.levels, self.auto_range, g, gain, reads)?;
        if let (Some(top), Some(frac)) = (opened.auto_ranged_max_w_m2_sr, self.auto_range) {
            ev(Event::Note(format!(
                "auto-range: brightest level set to {:.4e} W m⁻² sr⁻¹ ({:.0} % of full scale at {})",
                top,
                100.0 * frac,
                gain.map_or("the camera's power-up gain".into(), |g| format!("gain {g}"))
            )));
        }
        Ok(opened.source)
    }

    /// A manual source prompts on the terminal, where a bar would garble it.
    pub fn is_manual(&self) -> bool {
        SourceFile::load(&self.source, &gloam_io::ReadLog::off()).is_ok_and(|f| f.is_manual())
    }
}

/// `ev`'s progress under `label`, or nothing when `silent`.
pub fn progress<'a>(
    ev: &'a mut Events<'_>,
    label: &'a str,
    silent: bool,
) -> impl FnMut(usize, usize) + 'a {
    move |done, total| {
        if !silent {
            ev(Event::Progress(label, done, total))
        }
    }
}

/// `gloam calibrate radiance` / `calibrate_radiance`: a LUT across gains.
#[derive(Clone, Debug, PartialEq)]
pub struct RadianceRequest {
    pub source: SourceRequest,
    pub gains: Vec<f64>,
    /// Frames per level.
    pub frames: usize,
    pub exposure_s: Option<f64>,
}

impl RadianceRequest {
    /// Checks the gains, the frame count and the levels.
    pub fn validate(&self) -> Result<(), CalibError> {
        if self.gains.is_empty() {
            return Err(usage("--gains needs at least one gain"));
        }
        check_count(
            "--gains: the number of gains",
            self.gains.len(),
            MAX_LUT_GAINS,
        )?;
        for (i, &g) in self.gains.iter().enumerate() {
            check_gain("--gains", g)?;
            // The LUT would hold the gain twice, which `calibrate apply`
            // refuses: the run's captures at it were spent for nothing.
            if let Some(j) = self.gains[..i].iter().position(|&e| e == g) {
                return Err(usage(format!(
                    "--gains: {g} is given twice (gains {} and {}); a LUT holds one line per gain",
                    j + 1,
                    i + 1
                )));
            }
        }
        check_count("--frames", self.frames, MAX_FRAMES_PER_SETTING)?;
        self.source.validate()
    }

    /// The highest gain: the source is auto-ranged there.
    pub fn top_gain(&self) -> f64 {
        self.gains.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }

    /// Opens the source on `g` and measures the LUT; `reads` notes the
    /// files the source reads.
    pub fn run(
        &self,
        g: &mut dyn FrameGrabber,
        reads: &gloam_io::ReadLog,
        ev: &mut Events<'_>,
    ) -> Result<Lut, CalibError> {
        let mut src = self.source.open(g, Some(self.top_gain()), reads, ev)?;
        let opts = RadianceOptions {
            gains: self.gains.clone(),
            frames: self.frames,
            exposure_s: self.exposure_s,
            ..Default::default()
        };
        let silent = self.source.is_manual();
        calibrate_radiance(g, src.as_mut(), &opts, &mut progress(ev, "levels", silent))
    }
}

/// `gloam calibrate ptc` / `photon_transfer`: EMVA 1288 at a fixed gain.
#[derive(Clone, Debug, PartialEq)]
pub struct PtcRequest {
    /// Its levels default to [`crate::ptc::DEFAULT_LEVELS`].
    pub source: SourceRequest,
    /// The grabber's URI: the rig check compares the source's `[rig]` with it.
    pub grabber: String,
    pub gain: f64,
    pub spatial_frames: usize,
    pub exposure_s: Option<f64>,
    /// Where the EMVA 1288 data set is written, if anywhere.
    pub dataset_dir: Option<PathBuf>,
}

/// A photon transfer and the rig mismatch found before it (told as a
/// warning note too).
pub struct PtcDone {
    pub report: PtcResult,
    pub rig_mismatch: Option<String>,
}

impl PtcRequest {
    /// Checks the gain, the frame count and the levels.
    pub fn validate(&self) -> Result<(), CalibError> {
        check_gain("--gain", self.gain)?;
        check_count(
            "--spatial-frames",
            self.spatial_frames,
            MAX_FRAMES_PER_SETTING,
        )?;
        self.source.validate()
    }

    /// Opens the source on `g` (auto-ranged at the gain), checks its rig
    /// against the camera and measures; `reads` notes the files the source
    /// reads.
    pub fn run(
        &self,
        g: &mut dyn FrameGrabber,
        reads: &gloam_io::ReadLog,
        ev: &mut Events<'_>,
    ) -> Result<PtcDone, CalibError> {
        let source = SourceRequest {
            levels: self.source.levels.or(Some(crate::ptc::DEFAULT_LEVELS)),
            ..self.source.clone()
        };
        let mut src = source.open(g, Some(self.gain), reads, ev)?;
        // Only photon transfer reports in photons (QE), so only it checks
        // that the source's rig is the camera's.
        let mismatch =
            rig_mismatch(&self.grabber, src.rig(), self.exposure_s).map(|w| w.to_string());
        if let Some(w) = &mismatch {
            ev(Event::Note(format!("warning: {w}")));
        }
        let opts = PtcOptions {
            gain: self.gain,
            exposure_s: self.exposure_s,
            spatial_frames: self.spatial_frames,
            dataset_dir: self.dataset_dir.clone(),
        };
        let silent = source.is_manual();
        let report = photon_transfer(g, src.as_mut(), &opts, &mut progress(ev, "levels", silent))?;
        Ok(PtcDone {
            report,
            rig_mismatch: mismatch,
        })
    }
}

/// `gloam calibrate agc` / `agc_linearity`: the AGC staircase.
#[derive(Clone, Debug)]
pub struct AgcRequest {
    pub source: SourceRequest,
    /// Gain of the overridden staircase (`None`: the power-up gain).
    pub fixed_gain: Option<f64>,
    /// Frames per step.
    pub frames: usize,
    /// A LUT to linearise through, and the file it was read from (named
    /// when it does not fit the camera).
    pub lut: Option<(Lut, Option<PathBuf>)>,
    pub allow_unsettled: bool,
}

impl AgcRequest {
    /// Checks the fixed gain, the frame count and the levels.
    pub fn validate(&self) -> Result<(), CalibError> {
        if let Some(g) = self.fixed_gain {
            check_gain("--fixed-gain", g)?;
        }
        check_count("--frames", self.frames, MAX_FRAMES_PER_SETTING)?;
        self.source.validate()
    }

    /// Opens the source on `g` (auto-ranged at the fixed gain) and runs
    /// the staircase; `reads` notes the files the source reads.
    pub fn run(
        &self,
        g: &mut dyn FrameGrabber,
        reads: &gloam_io::ReadLog,
        ev: &mut Events<'_>,
    ) -> Result<AgcReport, CalibError> {
        let mut src = self.source.open(g, self.fixed_gain, reads, ev)?;
        let opts = AgcOptions {
            fixed_gain: self.fixed_gain,
            frames_per_step: self.frames,
            allow_unsettled: self.allow_unsettled,
            ..Default::default()
        };
        let silent = self.source.is_manual();
        let lut = self.lut.as_ref().map(|(l, _)| l);
        let mut p = progress(ev, "steps", silent);
        agc_linearisation(g, src.as_mut(), &opts, lut, &mut p).map_err(|e| {
            match (e, self.lut.as_ref().and_then(|(_, p)| p.as_ref())) {
                // Name the file the user passed.
                (e @ CalibError::LutNotForCamera { .. }, Some(path)) => CalibError::file(path, e),
                (e, _) => e,
            }
        })
    }
}

/// `gloam calibrate mtf --target sine|edge` / `mtf`: over a grabber, in
/// digital counts or (sine, `sim:`) in voltage space.
#[derive(Clone, Debug)]
pub struct MtfCalibration {
    pub mtf: MtfRequest,
    /// `--space voltage`: the scope's rows and the magnification.
    pub voltage: Option<VoltageOptions>,
}

#[derive(Clone, Debug, Default)]
pub struct VoltageOptions {
    pub scope_rows: Vec<usize>,
    pub magnification: f64,
}

/// What an MTF over a grabber measured.
pub enum MtfDone {
    /// One curve, with the mean radiance it was measured at.
    Digital {
        curve: crate::mtf::MtfCurve,
        mean_radiance_w_m2_sr: f64,
    },
    /// The voltage-space flow's curves, scope points and details.
    Voltage(VoltageReport),
}

impl MtfCalibration {
    /// Checks what needs no camera: voltage space reads sine patterns, and
    /// no sine is above Nyquist.
    pub fn validate(&self) -> Result<(), CalibError> {
        let sine = self.mtf.target == GrabberTarget::Sine;
        if self.voltage.is_some() && !sine {
            return Err(usage(
                "--space voltage reads sine patterns: use --target sine",
            ));
        }
        if sine {
            check_sine_frequencies(&self.mtf.frequencies_cy_per_px)?;
        }
        check_target_settings(&self.mtf)?;
        if let Some(g) = self.mtf.gain {
            check_gain("--gain", g)?;
        }
        check_count("--frames", self.mtf.frames, MAX_FRAMES_PER_SETTING)
    }

    /// Measures over `g`, opened from `uri` with noise seed `seed` (the
    /// voltage flow models the camera from them).
    pub fn run(
        &self,
        g: &mut dyn FrameGrabber,
        (uri, seed): (&str, Option<u64>),
        ev: &mut Events<'_>,
    ) -> Result<MtfDone, CalibError> {
        if let Some(v) = &self.voltage {
            let v = VoltageRequest {
                uri: uri.to_string(),
                seed,
                scope_rows: v.scope_rows.clone(),
                magnification: v.magnification,
            };
            let r = voltage_mtf(g, &self.mtf, &v, &mut |phase, done, total| {
                ev(Event::Progress(phase, done, total))
            })?;
            return Ok(MtfDone::Voltage(r));
        }
        let label = match self.mtf.target {
            GrabberTarget::Sine => "targets",
            GrabberTarget::Edge => "edge",
        };
        let m = measure_mtf(g, &self.mtf, &mut progress(ev, label, false))?;
        Ok(MtfDone::Digital {
            curve: m.curve,
            mean_radiance_w_m2_sr: m.mean_radiance_w_m2_sr,
        })
    }
}

/// `gloam calibrate apply`: a LUT applied to one frame file, written as a
/// radiance TIFF beside (never into) an output set.
#[derive(Clone, Debug, PartialEq)]
pub struct ApplyRequest {
    /// The LUT (`lut.json`).
    pub lut: PathBuf,
    /// A frame as gloam writes them, or any 8/16-bit grey PNG or TIFF.
    pub input: PathBuf,
    /// The page of a multi-page TIFF input.
    pub page: Option<u64>,
    /// The radiance image to write (32-bit float TIFF).
    pub output: PathBuf,
    /// The frame's gain (default: its line in `frames.jsonl` beside it).
    pub gain: Option<f64>,
}

impl ApplyRequest {
    /// Applies the LUT (its checks against the frame's camera and gain
    /// are [`crate::apply`]'s) and says what was written.
    pub fn run(&self, ev: &mut Events<'_>) -> Result<String, CalibError> {
        let r = crate::apply::apply_lut_to_frame(
            &self.lut,
            &self.input,
            self.page,
            &self.output,
            self.gain,
            &mut |w| ev(Event::Note(format!("warning: {w}"))),
        )?;
        let saturated = match r.saturated_pixels {
            0 => String::new(),
            n => format!(", {n} saturated pixel(s) set to NaN"),
        };
        Ok(format!(
            "wrote {} ({}×{}, gain {}{saturated})",
            self.output.display(),
            r.width,
            r.height,
            r.gain
        ))
    }
}

/// `gloam scope` / `scope`: a simulated camera's video on the scope.
#[derive(Clone, Debug, Default)]
pub struct ScopeRequest {
    /// A sensor preset or TOML file, or …
    pub sensor: Option<String>,
    /// … a `sim:` URI (sensor, rig, seed and size from it).
    pub grabber: Option<String>,
    pub rig: Option<String>,
    pub frequency_cy_per_px: f64,
    pub level_fraction: f64,
    pub rows: Vec<usize>,
    pub size: Option<(u32, u32)>,
    pub seed: Option<u64>,
    pub gain: Option<f64>,
    pub format: Option<gloam_sensor::stages::video_timing::VideoFormat>,
    pub bandwidth_hz: Option<f64>,
    pub frames: usize,
}

/// The most frames `scope` captures before the one it shows (the AGC and
/// phosphor lag settle within a few hundred).
pub const MAX_SCOPE_FRAMES: usize = 10_000;

impl ScopeRequest {
    /// The scope's options: the sensor, rig, seed and size from `sensor`
    /// (rig sine, seed 0) or the `grabber` URI, each overridable.
    pub fn validate(&self) -> Result<ScopeOptions, CalibError> {
        let (sensor, rig, seed, size) = match (&self.sensor, &self.grabber) {
            (Some(_), Some(_)) => return Err(usage("give --sensor or --grabber, not both")),
            (Some(s), None) => (s.clone(), "sine".to_string(), 0, None),
            (None, Some(u)) => sim_uri(u)?,
            (None, None) => return Err(usage("give --sensor PRESET_OR_FILE or --grabber sim:…")),
        };
        // A row given twice was scoped (and written) twice.
        if let Some((i, r)) =
            (self.rows.iter().enumerate()).find(|(i, r)| self.rows[..*i].contains(r))
        {
            return Err(usage(format!(
                "--rows: row {r} is given twice (items {} and {})",
                self.rows.iter().position(|x| x == r).unwrap_or(0) + 1,
                i + 1
            )));
        }
        // Each frame before the shown one is a whole capture: 10⁹ ran for
        // hours, and 0 was taken as 1.
        if !(1..=MAX_SCOPE_FRAMES).contains(&self.frames) {
            return Err(usage(format!(
                "--frames: {} is not in 1..={MAX_SCOPE_FRAMES} (frames captured before the one shown)",
                self.frames
            )));
        }
        let size_from = match (self.size, size, &self.grabber) {
            (Some(_), _, _) => SizeFrom::Flag,
            (None, Some(_), Some(uri)) => SizeFrom::Uri(uri.clone()),
            _ => SizeFrom::Default,
        };
        Ok(ScopeOptions {
            sensor,
            seed: self.seed.unwrap_or(seed),
            size: self.size.or(size),
            size_from,
            rows: self.rows.clone(),
            rig: self.rig.clone().unwrap_or(rig),
            level_fraction: self.level_fraction,
            frequency_cy_per_px: self.frequency_cy_per_px,
            gain: self.gain,
            format: self.format,
            bandwidth_hz: self.bandwidth_hz,
            frames: self.frames,
        })
    }
}

/// Opens grabber `uri` (noise seed `seed` for `sim:`; a file it reads noted
/// in `reads`), naming the URI if
/// it will not open.
pub fn open_uri(
    registry: &Registry,
    uri: &str,
    seed: Option<u64>,
    reads: &gloam_io::ReadLog,
) -> Result<Box<dyn FrameGrabber>, CalibError> {
    let opts = OpenOptions {
        seed,
        reads: reads.clone(),
        ..OpenOptions::default()
    };
    registry
        .open(uri, &opts)
        .map_err(|source| CalibError::Open {
            uri: uri.to_string(),
            source: Box::new(source),
        })
}

/// Most frames one capture takes: nine hours at 30 frames/s (split
/// longer runs).
pub const MAX_CAPTURE_FRAMES: u64 = 1_000_000;

/// `gloam capture`: frames from any grabber (the frames' files are
/// `gloam_pipeline::capture_request`'s).
#[derive(Clone, Debug, PartialEq)]
pub struct GrabRequest {
    /// The grabber's URI.
    pub grabber: String,
    /// Good frames to capture.
    pub frames: u64,
    /// Fixed gain (AGC off).
    pub gain: Option<f64>,
    pub agc: bool,
    /// Digitizer bits: 8, 12 or 16.
    pub bits: Option<u8>,
    pub exposure_s: Option<f64>,
    /// Noise seed for `sim:` grabbers.
    pub seed: Option<u64>,
    /// Give up after this many lost or damaged frames in a row.
    pub max_consecutive_failures: u64,
}

/// How a capture went: frames kept, frames with exposure warnings, losses.
#[derive(Default)]
pub struct CaptureTally {
    pub kept: u64,
    pub frames_warned: u64,
    pub losses: FrameLosses,
}

impl GrabRequest {
    /// Checks the options that clap cannot.
    pub fn check(&self) -> Result<(), CalibError> {
        if self.frames == 0 {
            return Err(CalibError::Usage("--frames must be at least 1".into()));
        }
        if self.frames > MAX_CAPTURE_FRAMES {
            let (n, max) = (self.frames, MAX_CAPTURE_FRAMES);
            return Err(usage(format!("--frames: {n} is not in 1..={max}")));
        }
        if let Some(b) = self.bits.filter(|b| ![8, 12, 16].contains(b)) {
            return Err(usage(format!("--bits: {b} is not 8, 12 or 16")));
        }
        Ok(())
    }

    /// Opens the grabber, records which camera it is in `dir`'s
    /// `camera.json` (`calibrate apply` checks a LUT against it) and
    /// applies the settings asked for.
    pub fn open<E: From<CalibError> + From<GrabError>>(
        &self,
        registry: &Registry,
        dir: &Path,
        reads: &gloam_io::ReadLog,
        ev: &mut dyn FnMut(Event<'_>),
    ) -> Result<Box<dyn FrameGrabber>, E> {
        let mut g = open_uri(registry, &self.grabber, self.seed, reads)?;
        ev(Event::Note(format!("capturing from {}", g.describe())));
        let camera = crate::apply::CameraRecord {
            camera: g.describe(),
            grabber: self.grabber.clone(),
        };
        report::write_json(&dir.join(crate::apply::CAMERA_FILE), &camera)?;
        if let Some(b) = self.bits {
            g.set_bits(b)?;
        }
        if let Some(e) = self.exposure_s {
            g.set_exposure_s(e)?;
        }
        if let Some(gain) = self.gain {
            let applied = g.set_gain(gain)?;
            if (applied - gain).abs() > 1e-9 * gain.abs().max(1.0) {
                ev(Event::Note(format!(
                    "note: gain {gain} applied as {applied}"
                )));
            }
        }
        if self.agc {
            g.set_agc(true)?;
        }
        Ok(g)
    }

    /// The grab loop, driven by its caller ([`Grabbing::next_frame`]):
    /// the caller stores each frame where it belongs (a capture's files),
    /// so nothing of the caller's is passed down here.
    pub fn grabbing(&self) -> Grabbing<'_> {
        Grabbing {
            request: self,
            tally: CaptureTally::default(),
            consecutive: 0,
            warned: std::collections::BTreeSet::new(),
            status: String::new(),
        }
    }
}

/// A capture under way: `--frames` good frames, riding out up to
/// `--max-consecutive-failures` lost or damaged frames in a row, stopping
/// when the run's guard reports an interrupt. Each kind of exposure
/// warning is noted once (every frame keeps its own).
pub struct Grabbing<'r> {
    request: &'r GrabRequest,
    tally: CaptureTally,
    consecutive: u64,
    warned: std::collections::BTreeSet<gloam_sensor::levels::WarningKind>,
    status: String,
}

impl Grabbing<'_> {
    /// The next good frame, its index and its exposure warnings; `None`
    /// once every frame asked for was kept. Counts the frame kept.
    /// Bounded: each call returns after a good frame or at most
    /// `--max-consecutive-failures` bad ones.
    pub fn next_frame(
        &mut self,
        g: &mut dyn FrameGrabber,
        guard: &gloam_io::RunGuard,
        ev: &mut dyn FnMut(Event<'_>),
    ) -> Result<Option<(u64, Frame, Vec<String>)>, CalibError> {
        let t = &mut self.tally;
        if t.kept >= self.request.frames {
            return Ok(None);
        }
        loop {
            if guard.interrupted() {
                // One handler takes all three (the `ctrlc` crate does not say which):
                // a SIGTERM was recorded as "Ctrl-C".
                return Err(CalibError::Usage(INTERRUPTED.into()));
            }
            match g.grab() {
                Ok(f) => {
                    self.consecutive = 0;
                    let exposure = f.exposure();
                    for (w, k) in exposure.warnings.iter().zip(&exposure.warning_kinds) {
                        if self.warned.insert(*k) {
                            ev(Event::Note(format!("warning: frame {}: {w}", t.kept)));
                        }
                    }
                    t.frames_warned += u64::from(!exposure.warnings.is_empty());
                    let index = t.kept;
                    t.kept += 1;
                    ev(Event::Progress(
                        &self.status,
                        t.kept as usize,
                        self.request.frames as usize,
                    ));
                    return Ok(Some((index, f, exposure.warnings)));
                }
                Err(e) if t.losses.count(&e) => {
                    self.consecutive += 1;
                    ev(Event::Note(format!("warning: {e}")));
                    let l = &t.losses;
                    self.status = format!("{} damaged, {} lost", l.damaged, l.lost);
                    let n = self.consecutive;
                    if n >= self.request.max_consecutive_failures {
                        let m = format!("{n} lost or damaged frames in a row; giving up");
                        return Err(CalibError::Usage(m));
                    }
                    ev(Event::Progress(
                        &self.status,
                        t.kept as usize,
                        self.request.frames as usize,
                    ));
                }
                Err(e) => return Err(CalibError::Grabbing(Box::new(e))),
            }
        }
    }

    /// How the capture went so far.
    pub fn tally(&self) -> &CaptureTally {
        &self.tally
    }
}
