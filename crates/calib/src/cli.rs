//! The command-line arguments of `gloam calibrate …`, `capture`, `scope`
//! and `compare` (feature `cli`), and the flows they run: the front end
//! parses, opens the output set, shows progress and prints; what the
//! options mean, their defaults and checks, and the order of the steps
//! live here, beside the flows they drive.

use std::path::{Path, PathBuf};

use gloam_io::OutputSet;

use clap::{Args, Subcommand, ValueEnum};
use gloam_grabber::{Frame, FrameGrabber, GrabError, OpenOptions, Registry};
use gloam_simcam::FrameExposureExt;

use crate::CalibError;
use crate::agc::{AgcOptions, agc_linearisation};
use crate::capture::FrameLosses;
use crate::mtf_flow::{
    self, GrabberTarget, MtfRequest, VoltageRequest, measure_mtf, read_usaf_ctf, usaf_mtf,
    voltage_mtf,
};
use crate::ptc::{PtcOptions, photon_transfer};
use crate::radiance::{RadianceOptions, calibrate_radiance};
use crate::report;
use crate::rig_check::rig_mismatch;
use crate::scope_run::{ScopeOptions, sim_uri};
use crate::source::{CalibrationSource, SourceFile, open_for_grabber};

/// What a flow tells its front end while it runs.
pub enum Event<'a> {
    /// A line for the operator (stderr), printed at once.
    Note(String),
    /// Progress of a phase: its label, done and total.
    Progress(&'a str, usize, usize),
}

/// Most radiance levels a sweep takes (`--levels`).
pub const MAX_LEVELS: usize = 10_000;
/// Most frames taken at one setting (`--frames`, `--spatial-frames`).
pub const MAX_FRAMES_PER_SETTING: usize = 100_000;

/// A count flag's parser: a whole number in 1..=`max`, refused before
/// anything is sized by it.
fn count_up_to(
    max: usize,
) -> impl Fn(&str) -> Result<usize, String> + Clone + Send + Sync + 'static {
    move |s: &str| match s.trim().parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        Ok(n) => Err(format!("{n} is not in 1..={max}")),
        Err(e) => Err(format!("{e} (give a whole number in 1..={max})")),
    }
}

#[derive(Subcommand)]
pub enum CalibrateCommand {
    /// Radiance LUT across gains → OUT/lut.json, radiance.md, plots.
    Radiance(RadianceArgs),
    /// Turn a digital-count image into a radiance image (32-bit float TIFF).
    Apply(ApplyArgs),
    /// AGC staircase up and down, AGC on and overridden → OUT/agc.json.
    Agc(AgcArgs),
    /// EMVA 1288 photon transfer → OUT/ptc.json and OUT/emva1288/.
    Ptc(PtcArgs),
    /// MTF from sine targets, USAF 1951 bar contrasts or a slanted edge → OUT/mtf.json.
    Mtf(MtfArgs),
}

#[derive(Args, Clone)]
pub struct GrabberArgs {
    /// Grabber URI: sim:PRESET_OR_RIG[?rig=R&seed=S&size=WxH], serial:PATH[?baud=N], usb:VID:PID[:SERIAL], genicam:DEVICE_ID|ADDR[?trigger=auto|software|off&resend=always|never&timeout_ms=N&size=WxH] (GigE Vision / USB3 Vision through Aravis; build with --features genicam).
    #[arg(long)]
    pub grabber: String,
    /// Noise seed for sim: grabbers.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Exposure / gate time, seconds.
    #[arg(long)]
    pub exposure_s: Option<f64>,
}

#[derive(Args, Clone)]
pub struct SourceArgs {
    /// Calibration source file (TOML; docs/calibration.md).
    #[arg(long)]
    pub source: PathBuf,
    /// Number of radiance levels (generated linear in radiance when the file lists none).
    #[arg(long, value_parser = count_up_to(MAX_LEVELS))]
    pub levels: Option<usize>,
    /// Simulated cameras only: rescale a sphere source so its brightest level
    /// puts the camera at this fraction of full scale (at the highest gain).
    #[arg(long)]
    pub auto_range: Option<f64>,
}

#[derive(Args)]
pub struct RadianceArgs {
    #[command(flatten)]
    pub grabber: GrabberArgs,
    #[command(flatten)]
    pub source: SourceArgs,
    /// Gains to calibrate, comma-separated.
    #[arg(long, value_delimiter = ',', required = true)]
    pub gains: Vec<f64>,
    /// Frames per level.
    #[arg(long, default_value_t = crate::radiance::DEFAULT_FRAMES, value_parser = count_up_to(MAX_FRAMES_PER_SETTING))]
    pub frames: usize,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other files).
    #[arg(long)]
    pub force: bool,
}

#[derive(Args)]
pub struct ApplyArgs {
    /// The LUT written by `gloam calibrate radiance`.
    #[arg(long)]
    pub lut: PathBuf,
    /// Gain of the input frame (default: its line in frames.jsonl beside it).
    #[arg(long)]
    pub gain: Option<f64>,
    /// Digital-count image: a frame as gloam writes them (PNG, FITS, or a
    /// page of a TIFF stack, `--page`), or any 8/16-bit grey PNG or TIFF.
    pub input: PathBuf,
    /// The page (frame) of a multi-page TIFF INPUT, from 0 (`gloam capture
    /// --frame-format tiff`'s `frames.tiff`: its `frames.jsonl` line's
    /// `stored.page`); needed when INPUT holds more than one page.
    #[arg(long, value_parser = clap::value_parser!(u64).range(0..crate::io::MAX_TIFF_PAGES))]
    pub page: Option<u64>,
    /// Radiance image to write (32-bit float TIFF, W m⁻² sr⁻¹; saturated pixels NaN).
    pub output: PathBuf,
}

#[derive(Args)]
pub struct AgcArgs {
    #[command(flatten)]
    pub grabber: GrabberArgs,
    #[command(flatten)]
    pub source: SourceArgs,
    /// Gain for the overridden (AGC off) staircase (default: the camera's
    /// power-up gain).
    #[arg(long)]
    pub fixed_gain: Option<f64>,
    /// Frames per staircase step.
    #[arg(long, default_value_t = crate::agc::DEFAULT_FRAMES_PER_STEP, value_parser = count_up_to(MAX_FRAMES_PER_SETTING))]
    pub frames: usize,
    /// A LUT (lut.json) to linearise the AGC frames through.
    #[arg(long)]
    pub lut: Option<PathBuf>,
    /// Report instead of failing when the AGC does not settle.
    #[arg(long)]
    pub allow_unsettled: bool,
    /// A sequence file (docs/sequences.md) instead of the staircase: its
    /// scene's light-group layers are rendered once and mixed per frame
    /// through the --grabber's simulated camera with its AGC; each frame is
    /// linearised through --lut (without one, a LUT is measured first on
    /// --source over the gains the AGC visited) and compared with the true
    /// radiance → OUT/agc_sequence.json (docs/calibration.md).
    #[arg(long, conflicts_with_all = ["fixed_gain", "allow_unsettled"])]
    pub sequence: Option<PathBuf>,
    /// --sequence: a render setting, KEY=VALUE (repeatable), as `gloam
    /// render --set` (e.g. resolution_scale=0.5, spp=2, seed=3).
    #[arg(long = "set", value_name = "KEY=VALUE", requires = "sequence")]
    pub set: Vec<String>,
    /// --sequence: how the captured frames are stored, as `gloam capture`
    /// stores them: png (default), fits (one file per frame, with a
    /// header) or tiff (one multi-page frames.tiff).
    #[arg(long, value_name = "FORMAT", value_parser = crate::io::FRAME_FORMAT_NAMES, requires = "sequence")]
    pub frame_format: Option<String>,
    #[arg(long)]
    pub out: PathBuf,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other files).
    #[arg(long)]
    pub force: bool,
}

#[derive(Args)]
pub struct PtcArgs {
    #[command(flatten)]
    pub grabber: GrabberArgs,
    #[command(flatten)]
    pub source: SourceArgs,
    /// Fixed gain for the sweep.
    #[arg(long, default_value_t = crate::ptc::DEFAULT_GAIN)]
    pub gain: f64,
    /// Frames averaged for DSNU/PRNU.
    #[arg(long, default_value_t = crate::ptc::DEFAULT_SPATIAL_FRAMES, value_parser = count_up_to(MAX_FRAMES_PER_SETTING))]
    pub spatial_frames: usize,
    #[arg(long)]
    pub out: PathBuf,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other files).
    #[arg(long)]
    pub force: bool,
}

/// Where the sine flow reads modulation.
#[derive(Clone, Copy, Default, PartialEq, Eq, ValueEnum)]
pub enum Space {
    /// Digital counts after the frame grabber.
    #[default]
    Digital,
    /// The video line on an oscilloscope (§5.9.2), next to digital counts
    /// and the chain's analytic MTF (sim: grabbers only).
    Voltage,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum Target {
    Sine,
    Usaf,
    Edge,
}

#[derive(Args)]
pub struct MtfArgs {
    /// sine: sine targets (Stimulus::Sine); edge: ISO 12233 slanted edge;
    /// usaf: bar contrasts read from --ctf, converted by Coltman's series.
    #[arg(long, value_enum)]
    pub target: Target,
    /// Grabber URI (sine and edge).
    #[arg(long)]
    pub grabber: Option<String>,
    #[arg(long)]
    pub seed: Option<u64>,
    /// Fixed gain (sine and edge).
    #[arg(long)]
    pub gain: Option<f64>,
    /// Mean target radiance, W m⁻² sr⁻¹ (default: auto-ranged to 40 % of
    /// full scale on simulated cameras).
    #[arg(long)]
    pub radiance: Option<f64>,
    /// Sine modulation in radiance.
    #[arg(long, default_value_t = mtf_flow::DEFAULT_MODULATION)]
    pub modulation: f64,
    /// Target angle, degrees (sine: from the row axis, default 0; edge: from the column axis, default 5).
    #[arg(long)]
    pub angle_deg: Option<f64>,
    /// Sine frequencies, cycles/pixel, comma-separated (default 0.02…0.48 step 0.02).
    #[arg(long, value_delimiter = ',')]
    pub frequencies: Vec<f64>,
    /// Frames averaged per target.
    #[arg(long, default_value_t = mtf_flow::DEFAULT_FRAMES, value_parser = count_up_to(MAX_FRAMES_PER_SETTING))]
    pub frames: usize,
    /// Relative spectrum of the targets (built-in name).
    #[arg(long, default_value = mtf_flow::DEFAULT_SPECTRUM)]
    pub spectrum: String,
    /// usaf: CSV of `group,element,modulation` (measured bar contrast).
    #[arg(long)]
    pub ctf: Option<PathBuf>,
    /// usaf: pixel pitch, µm.
    #[arg(long)]
    pub pixel_pitch_um: Option<f64>,
    /// usaf: optical magnification (image size / chart size).
    #[arg(long, default_value_t = 1.0)]
    pub magnification: f64,
    /// sine: measure in digital counts, or in voltage space (scope line +
    /// grey-scale curve) beside digital counts and the analytic MTF.
    #[arg(long, value_enum, default_value = "digital")]
    pub space: Space,
    /// --space voltage: frame rows the scope isolates (default: 4 middle rows).
    #[arg(long, value_delimiter = ',')]
    pub scope_rows: Vec<usize>,
    #[arg(long)]
    pub out: PathBuf,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other files).
    #[arg(long)]
    pub force: bool,
}

/// What a calibration leaves its front end: the output set, written but
/// not yet published, and its main JSON (which gets the run's provenance
/// before the set is published; `None`: no set), and the lines to print
/// once it is published.
pub struct Outcome {
    pub set: Option<OutputSet>,
    pub main_json: Option<&'static str>,
    pub lines: Vec<String>,
}

/// Runs one `gloam calibrate` flow with grabbers from `registry`. The
/// output set opens after the inputs are checked and before the grabber
/// opens; the front end publishes it ([`Outcome::set`]). Progress stays silent for manual sources (the operator
/// is prompted on the terminal).
pub fn run_calibrate<E: From<CalibError> + From<GrabError>>(
    cmd: &CalibrateCommand,
    registry: &Registry,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    // An --out set holding one of the run's inputs would replace it
    // (apply writes one file, checked against its inputs in apply.rs).
    let out_and_inputs: Option<(&Path, Vec<(&'static str, &Path)>)> = match cmd {
        CalibrateCommand::Radiance(a) => Some((&a.out, vec![("--source", &a.source.source)])),
        CalibrateCommand::Agc(a) => Some((&a.out, agc_inputs(a))),
        CalibrateCommand::Ptc(a) => Some((&a.out, vec![("--source", &a.source.source)])),
        CalibrateCommand::Mtf(a) => Some((
            &a.out,
            a.ctf.iter().map(|c| ("--ctf", c.as_path())).collect(),
        )),
        CalibrateCommand::Apply(_) => None,
    };
    if let Some((out, inputs)) = out_and_inputs {
        report::refuse_out_dir_holding_inputs(out, &inputs)?;
    }
    match cmd {
        CalibrateCommand::Radiance(a) => radiance(a, registry, ev),
        CalibrateCommand::Apply(a) => {
            let r = crate::apply::apply_lut_to_frame(
                &a.lut,
                &a.input,
                a.page,
                &a.output,
                a.gain,
                &mut |w| ev(Event::Note(format!("warning: {w}"))),
            )?;
            let saturated = if r.saturated_pixels > 0 {
                format!(", {} saturated pixel(s) set to NaN", r.saturated_pixels)
            } else {
                String::new()
            };
            let line = format!(
                "wrote {} ({}×{}, gain {}{saturated})",
                a.output.display(),
                r.width,
                r.height,
                r.gain
            );
            Ok(Outcome {
                set: None,
                main_json: None,
                lines: vec![line],
            })
        }
        CalibrateCommand::Agc(a) if a.sequence.is_some() => Err(CalibError::Usage(
            "--sequence renders a scene: run it from the gloam command line".into(),
        )
        .into()),
        CalibrateCommand::Agc(a) => agc(a, registry, ev),
        CalibrateCommand::Ptc(a) => ptc(a, registry, ev),
        CalibrateCommand::Mtf(a) => mtf(a, registry, ev),
    }
}

/// The files `calibrate agc` reads (`--source`, `--lut`, `--sequence`).
fn agc_inputs(a: &AgcArgs) -> Vec<(&'static str, &Path)> {
    let mut v = vec![("--source", a.source.source.as_path())];
    v.extend(a.lut.iter().map(|l| ("--lut", l.as_path())));
    v.extend(a.sequence.iter().map(|l| ("--sequence", l.as_path())));
    v
}

/// Opens grabber `uri` (noise seed `seed` for `sim:`), naming the URI if
/// it will not open.
fn open_uri(
    registry: &Registry,
    uri: &str,
    seed: Option<u64>,
) -> Result<Box<dyn FrameGrabber>, CalibError> {
    let opts = OpenOptions {
        seed,
        ..OpenOptions::default()
    };
    registry
        .open(uri, &opts)
        .map_err(|source| CalibError::Open {
            uri: uri.to_string(),
            source: Box::new(source),
        })
}

impl GrabberArgs {
    /// Opens the grabber and sets the exposure asked for.
    pub fn open<E: From<CalibError> + From<GrabError>>(
        &self,
        registry: &Registry,
        ev: &mut dyn FnMut(Event<'_>),
    ) -> Result<Box<dyn FrameGrabber>, E> {
        let mut g = open_uri(registry, &self.grabber, self.seed)?;
        if let Some(e) = self.exposure_s {
            g.set_exposure_s(e)?;
        }
        ev(Event::Note(format!("grabber: {}", g.describe())));
        Ok(g)
    }
}

impl SourceArgs {
    /// Opens the source; auto-ranges a sphere at `gain` (`None`: the
    /// camera's current gain) when asked ([`open_for_grabber`]).
    fn open(
        &self,
        g: &mut dyn FrameGrabber,
        gain: Option<f64>,
        ev: &mut dyn FnMut(Event<'_>),
    ) -> Result<Box<dyn CalibrationSource>, CalibError> {
        let opened = open_for_grabber(&self.source, self.levels, self.auto_range, g, gain)?;
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
    fn is_manual(&self) -> bool {
        SourceFile::load(&self.source).is_ok_and(|f| f.is_manual())
    }
}

/// `ev`'s progress under `label`, or nothing when `silent`.
fn progress<'a>(
    ev: &'a mut dyn FnMut(Event<'_>),
    label: &'a str,
    silent: bool,
) -> impl FnMut(usize, usize) + 'a {
    move |done, total| {
        if !silent {
            ev(Event::Progress(label, done, total))
        }
    }
}

/// A flow's outcome: its summary `lines`, then where `main_json` went.
fn written(set: OutputSet, main_json: &'static str, mut lines: Vec<String>) -> Outcome {
    lines.push(format!("wrote {}", set.target().join(main_json).display()));
    Outcome {
        set: Some(set),
        main_json: Some(main_json),
        lines,
    }
}

/// What the grabber-and-source flows (radiance, AGC, photon transfer)
/// start from, opened in the one order they share: the output set first
/// (so a refused `--out` touches no camera), then the grabber, then the
/// source against it.
struct Bench {
    set: OutputSet,
    g: Box<dyn FrameGrabber>,
    src: Box<dyn CalibrationSource>,
    /// A manual source prompts on the terminal: no progress bar then.
    silent: bool,
}

impl Bench {
    /// Opens the output set (`out`, `force`), the grabber and `source`,
    /// auto-ranged at `gain` (`None`: the camera's current gain).
    fn open<E: From<CalibError> + From<GrabError>>(
        (out, force): (&Path, bool),
        grabber: &GrabberArgs,
        source: &SourceArgs,
        gain: Option<f64>,
        registry: &Registry,
        ev: &mut dyn FnMut(Event<'_>),
    ) -> Result<Self, E> {
        let set = OutputSet::begin(out, force, false).map_err(CalibError::from)?;
        let mut g = grabber.open::<E>(registry, ev)?;
        let src = source.open(g.as_mut(), gain, ev)?;
        Ok(Self {
            set,
            g,
            src,
            silent: source.is_manual(),
        })
    }
}

fn radiance<E: From<CalibError> + From<GrabError>>(
    a: &RadianceArgs,
    registry: &Registry,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    if a.gains.is_empty() {
        return Err(CalibError::Usage("--gains needs at least one gain".into()).into());
    }
    if let Some(g) = a.gains.iter().find(|g| !(g.is_finite() && **g > 0.0)) {
        let m = format!("--gains: {g} is not a gain (each must be a finite number > 0)");
        return Err(CalibError::Usage(m).into());
    }
    let top = a.gains.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let out = (a.out.as_path(), a.force);
    let mut b = Bench::open::<E>(out, &a.grabber, &a.source, Some(top), registry, ev)?;
    let opts = RadianceOptions {
        gains: a.gains.clone(),
        frames: a.frames,
        exposure_s: a.grabber.exposure_s,
        ..Default::default()
    };
    let lut = calibrate_radiance(
        b.g.as_mut(),
        b.src.as_mut(),
        &opts,
        &mut progress(ev, "levels", b.silent),
    )?;
    report::write_radiance_report(b.set.dir(), &lut)?;
    let mut lines = Vec::new();
    for c in &lut.gains {
        lines.push(format!(
            "gain {}: L = {:.6e}·DC + {:.6e} W m⁻² sr⁻¹ (R² {:.6}, {} points, DC {:.1}–{:.1})",
            c.gain,
            c.g_w_m2_sr_per_dn,
            c.b_w_m2_sr,
            c.r_squared,
            c.n_fit_points,
            c.fit_range_dn[0],
            c.fit_range_dn[1]
        ));
        lines.extend(
            c.warnings
                .iter()
                .map(|w| format!("warning: gain {}: {w}", c.gain)),
        );
    }
    Ok(written(b.set, "lut.json", lines))
}

fn agc<E: From<CalibError> + From<GrabError>>(
    a: &AgcArgs,
    registry: &Registry,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    let lut = a.lut.as_deref().map(crate::apply::load_lut).transpose()?;
    let out = (a.out.as_path(), a.force);
    let mut b = Bench::open::<E>(out, &a.grabber, &a.source, a.fixed_gain, registry, ev)?;
    let opts = AgcOptions {
        fixed_gain: a.fixed_gain,
        frames_per_step: a.frames,
        allow_unsettled: a.allow_unsettled,
        ..Default::default()
    };
    let r = agc_linearisation(
        b.g.as_mut(),
        b.src.as_mut(),
        &opts,
        lut.as_ref(),
        &mut progress(ev, "steps", b.silent),
    )
    .map_err(|e| match (e, &a.lut) {
        // Name the file the user passed.
        (e @ CalibError::LutNotForCamera { .. }, Some(path)) => CalibError::file(path, e),
        (e, _) => e,
    })?;
    report::write_agc_report(b.set.dir(), &r)?;
    let summary = format!(
        "AGC: settled {}, max settling {} µs, overshoot {} %, hysteresis {:.3} %, linearity error {:.3} %",
        r.all_settled,
        r.max_settling_time_us
            .map_or("—".into(), |v| format!("{v:.0}")),
        r.max_overshoot_percent
            .map_or("—".into(), |v| format!("{v:.2}")),
        r.hysteresis_gain_percent,
        r.linearity_error_percent
    );
    let mut lines = vec![summary];
    lines.extend(linearised_line(&r));
    Ok(written(b.set, "agc.json", lines))
}

/// What the front end's renderer returns for `calibrate agc --sequence`:
/// the sequence captured into the output directory (frames,
/// `frames.jsonl`) and the layers it was mixed from.
pub struct CapturedSequence {
    /// The scene's light groups, in the layers' order.
    pub groups: Vec<String>,
    /// Each group's detected radiance, e⁻ s⁻¹ m⁻² sr⁻¹ (rows × columns).
    pub layers: Vec<ndarray::Array2<f64>>,
    /// The camera's exposure window per frame, s.
    pub exposure_s: f64,
    /// With a `[sky]` clock: each sky render's layers, by render index
    /// (each frame's truth lies between two of them; `layers` is frame
    /// 0's).
    pub sky_layers: Vec<Vec<ndarray::Array2<f64>>>,
}

/// Gains a LUT measured for a sequence steps by at most (its responsivity
/// is interpolated linearly in gain between them).
pub const SEQUENCE_LUT_GAIN_RATIO: f64 = 1.25;
/// Levels and auto-range of a LUT measured for a sequence when
/// `--levels` / `--auto-range` are not given.
pub const SEQUENCE_LUT_LEVELS: usize = 10;
pub const SEQUENCE_LUT_AUTO_RANGE: f64 = 0.8;

/// `gloam calibrate agc --sequence`, checked and with its output set open.
/// The front end renders the sequence's layers and captures it through
/// the camera [`sensor`](Self::sensor) with its AGC and noise seed
/// [`seed`](Self::seed) into [`dir`](Self::dir) (its renderer is
/// `gloam_pipeline::sequence`, which calib sits below), then
/// [`finish`](Self::finish) does the rest.
pub struct SequenceRun<'a> {
    a: &'a AgcArgs,
    set: OutputSet,
    preset: String,
    seed: u64,
    config: gloam_sensor::SensorConfig,
    lut: Option<crate::radiance::Lut>,
    opts: crate::agc_sequence::AgcSequenceOptions,
}

/// `gloam calibrate agc --sequence`: checks the camera (a `sim:` grabber)
/// and the LUT and opens the output set, before anything is rendered
/// ([`SequenceRun`]).
pub fn agc_sequence(a: &AgcArgs) -> Result<SequenceRun<'_>, CalibError> {
    use crate::agc_sequence::AgcSequenceOptions;
    report::refuse_out_dir_holding_inputs(&a.out, &agc_inputs(a))?;
    let (preset, _, uri_seed, _) = crate::scope_run::sim_uri(&a.grabber.grabber).map_err(|_| {
        CalibError::Usage(format!(
            "--sequence: --grabber '{}' is not a simulated camera; a sequence is rendered, so it needs a sim:PRESET grabber",
            a.grabber.grabber
        ))
    })?;
    if a.grabber.exposure_s.is_some() {
        return Err(CalibError::Usage(
            "--sequence sets the exposure (the camera's, within the sequence's frame period); drop --exposure-s".into(),
        ));
    }
    let config = gloam_sensor::load_preset_or_file(&preset)?;
    let camera = format!("simulated {preset}");
    let lut = match &a.lut {
        Some(path) => {
            let lut = crate::apply::load_lut(path)?;
            crate::apply::check_lut_fits_camera(&lut, &camera, config.digitizer.bits)
                .map_err(|e| CalibError::file(path, e))?;
            Some(lut)
        }
        None => None,
    };
    let opts = AgcSequenceOptions::for_sensor(&config)?.ok_or_else(|| {
        CalibError::Usage(format!(
            "--sequence: camera '{preset}' has no AGC ([agc] in its sensor file)"
        ))
    })?;
    let set = OutputSet::begin(&a.out, a.force, false)?;
    let seed = a.grabber.seed.unwrap_or(uri_seed);
    Ok(SequenceRun {
        a,
        set,
        preset,
        seed,
        config,
        lut,
        opts,
    })
}

impl SequenceRun<'_> {
    /// Where the sequence's frames and `frames.jsonl` go.
    pub fn dir(&self) -> &Path {
        self.set.dir()
    }

    /// The camera (preset or sensor file) the sequence is captured through.
    pub fn sensor(&self) -> &str {
        &self.preset
    }

    /// The camera's noise seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// With the sequence `captured` into [`dir`](Self::dir): measures a
    /// LUT over the gains the AGC settled through if none was given, and
    /// compares each frame linearised through the LUT with the true
    /// radiance.
    pub fn finish<E: From<CalibError> + From<GrabError>>(
        self,
        captured: CapturedSequence,
        registry: &Registry,
        ev: &mut dyn FnMut(Event<'_>),
    ) -> Result<Outcome, E> {
        use crate::agc_sequence::{
            SequenceLayers, detected_per_band_radiance, linearise_sequence, lut_gains_spanning,
            write_agc_sequence_report,
        };
        let SequenceRun {
            a,
            set,
            config,
            lut,
            opts,
            ..
        } = self;
        let tau_s = opts.agc_time_constant_s;
        let dir = set.dir();
        let mut g = a.grabber.open::<E>(registry, ev)?;
        g.set_exposure_s(captured.exposure_s)?;
        let mut lines = Vec::new();
        // The source gives the LUT's units (its lamp's spectrum) even when the
        // LUT is given, and measures the LUT when it is not.
        let source = SourceArgs {
            levels: a.source.levels.or(Some(SEQUENCE_LUT_LEVELS)),
            auto_range: a.source.auto_range.or(Some(SEQUENCE_LUT_AUTO_RANGE)),
            ..a.source.clone()
        };
        let (lut, mut src) = match lut {
            Some(lut) => (lut, source.open(g.as_mut(), None, ev)?),
            None => {
                // The gains the loop went through once it left its power-up
                // gain (the acquisition window is not judged).
                let from_s = opts.transient_time_constants * tau_s;
                // Named by the sequence file, not the staging directory the
                // frames are in (it is removed when the run fails).
                let gains = crate::agc_sequence::gains_in_effect(dir, from_s).map_err(|e| match e {
                CalibError::InsufficientData(_) => CalibError::InsufficientData(format!(
                    "--sequence {}: no frame starts {from_s} s or more after the first ({} AGC time constants of {tau_s} s: the loop's acquisition, not judged), so no gain to measure a LUT at; lengthen the sequence or give --lut",
                    a.sequence.as_deref().unwrap_or(Path::new("?")).display(),
                    opts.transient_time_constants
                )),
                other => other,
            })?;
                let (lo, hi) = gains
                    .iter()
                    .fold((f64::INFINITY, 0.0f64), |(l, h), &g| (l.min(g), h.max(g)));
                let gains = lut_gains_spanning(lo, hi, SEQUENCE_LUT_GAIN_RATIO);
                let top = gains.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                let mut src = source.open(g.as_mut(), Some(top), ev)?;
                let ropts = RadianceOptions {
                    gains: gains.clone(),
                    exposure_s: Some(captured.exposure_s),
                    ..Default::default()
                };
                let silent = source.is_manual();
                let lut = calibrate_radiance(
                    g.as_mut(),
                    src.as_mut(),
                    &ropts,
                    &mut progress(ev, "LUT levels", silent),
                )?;
                report::write_radiance_report(dir, &lut)?;
                lines.push(format!(
                "LUT measured on {} at {} gains {}–{} (the gains the AGC visited from {from_s} s on) → lut.json",
                a.source.source.display(),
                lut.gains.len(),
                gains[0],
                gains[gains.len() - 1]
            ));
                (lut, src)
            }
        };
        let k = detected_per_band_radiance(src.as_mut(), &config)?;
        let truth = SequenceLayers {
            groups: &captured.groups,
            layers: &captured.layers,
            sky: &captured.sky_layers,
        };
        let r = linearise_sequence(
            dir,
            &lut,
            &g.describe(),
            &truth,
            k,
            &opts,
            &mut progress(ev, "frames", false),
        )
        .map_err(|e| match (e, &a.lut) {
            (e @ CalibError::LutNotForCamera { .. }, Some(path)) => CalibError::file(path, e),
            (e, _) => e,
        })?;
        write_agc_sequence_report(dir, &r)?;
        let fmt = |s: &crate::agc_sequence::PhaseSummary| match (
            s.rms_residual_percent,
            s.max_abs_residual_percent,
        ) {
            (Some(rms), Some(max)) => {
                format!("RMS {rms:.2} %, max {max:.2} % over {} frames", s.frames)
            }
            _ => "no frames".into(),
        };
        lines.push(format!(
        "linearised vs true radiance, residual per frame: steady {}; transient ({:.2} s after {} switch(es)) {}; acquiring {}{}",
        fmt(&r.steady),
        r.transient_window_s,
        r.switches_s.len(),
        fmt(&r.transient),
        fmt(&r.acquiring),
        match r.frames_outside_lut {
            0 => String::new(),
            n => format!("; {n} frames outside the LUT's gains not linearised"),
        }
    ));
        Ok(written(set, "agc_sequence.json", lines))
    }
}

/// What the LUT made of the AGC frames, against the source's true band
/// radiance; `None` without a LUT.
fn linearised_line(r: &crate::agc::AgcReport) -> Option<String> {
    let [lo, hi] = r.agc_gain_range;
    let lut = r.lut_gain_range?;
    let outside = match r.frames_outside_lut {
        0 => String::new(),
        n => format!("; {n} frames outside the LUT's gains not linearised"),
    };
    Some(
        match (
            r.linearised_rms_error_percent,
            r.linearised_max_error_percent,
        ) {
            (Some(rms), Some(max)) => format!(
                "linearised radiance vs true: residual RMS {rms:.2} %, max {max:.2} % over {} settled AGC frames at gains {lo}–{hi} (LUT gains {}–{}){outside}",
                r.frames_linearised, lut[0], lut[1]
            ),
            _ => format!("linearised radiance vs true: no settled AGC frame to linearise{outside}"),
        },
    )
}

fn ptc<E: From<CalibError> + From<GrabError>>(
    a: &PtcArgs,
    registry: &Registry,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    let mut sa = a.source.clone();
    sa.levels = sa.levels.or(Some(crate::ptc::DEFAULT_LEVELS));
    let out = (a.out.as_path(), a.force);
    let mut b = Bench::open::<E>(out, &a.grabber, &sa, Some(a.gain), registry, ev)?;
    // Only photon transfer reports in photons (QE), so only it checks that
    // the source's rig is the camera's.
    if let Some(w) = rig_mismatch(&a.grabber.grabber, b.src.rig(), a.grabber.exposure_s) {
        ev(Event::Note(format!("warning: {w}")));
    }
    let opts = PtcOptions {
        gain: a.gain,
        exposure_s: a.grabber.exposure_s,
        spatial_frames: a.spatial_frames,
        dataset_dir: Some(b.set.dir().join("emva1288")),
    };
    let r = photon_transfer(
        b.g.as_mut(),
        b.src.as_mut(),
        &opts,
        &mut progress(ev, "levels", b.silent),
    )?;
    report::write_ptc_report(b.set.dir(), &r)?;
    let mut lines: Vec<String> = r.warnings.iter().map(|w| format!("warning: {w}")).collect();
    lines.push(format!(
        "K = {:.5} DN/e⁻, dark noise {:.3} e⁻, saturation {:.0} e⁻, QE {}",
        r.system_gain_dn_per_e,
        r.dark_noise_e,
        r.saturation_capacity_e,
        r.quantum_efficiency
            .map_or("— (no [rig])".into(), |q| format!("{q:.4}"))
    ));
    // An intensified camera's K folds in the gain process's excess noise:
    // say so beside it, with the conversion gain it implies.
    if let (Some(g), Some(f_pix)) = (r.conversion_gain_dn_per_pe, r.pixel_noise_factor)
        && (f_pix - 1.0).abs() > 1e-9
    {
        lines.push(format!(
            "K_eff = g·F_pix: conversion gain g = {g:.4} DN/photoelectron, F_pix = {f_pix:.4}{}",
            r.quantum_efficiency_from_conversion_gain
                .map_or(String::new(), |q| format!(", QE = R/g = {q:.4}"))
        ));
    }
    Ok(written(b.set, "ptc.json", lines))
}

fn mtf<E: From<CalibError> + From<GrabError>>(
    a: &MtfArgs,
    registry: &Registry,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    let usage = |m: &str| CalibError::Usage(m.into());
    if matches!(a.target, Target::Sine) {
        // Before the output set opens: nothing is measured above Nyquist.
        mtf_flow::check_sine_frequencies(&a.frequencies)?;
    }
    let set = OutputSet::begin(&a.out, a.force, false).map_err(CalibError::from)?;
    let dir = set.dir();
    let (curves, details) = match a.target {
        Target::Usaf => {
            let ctf_path = a
                .ctf
                .as_ref()
                .ok_or_else(|| usage("--target usaf needs --ctf FILE"))?;
            let pitch = a
                .pixel_pitch_um
                .ok_or_else(|| usage("--target usaf needs --pixel-pitch-um"))?;
            usaf_mtf(read_usaf_ctf(ctf_path)?, pitch, a.magnification, ctf_path)?
        }
        Target::Sine | Target::Edge => {
            let uri =
                (a.grabber.clone()).ok_or_else(|| usage("--target sine/edge needs --grabber"))?;
            let ga = GrabberArgs {
                grabber: uri.clone(),
                seed: a.seed,
                exposure_s: None,
            };
            let mut g = ga.open::<E>(registry, ev)?;
            let req = MtfRequest {
                target: match a.target {
                    Target::Sine => GrabberTarget::Sine,
                    _ => GrabberTarget::Edge,
                },
                gain: a.gain,
                radiance_w_m2_sr: a.radiance,
                modulation: a.modulation,
                angle_deg: a.angle_deg,
                frequencies_cy_per_px: a.frequencies.clone(),
                frames: a.frames,
                spectrum: a.spectrum.clone(),
            };
            if a.space == Space::Voltage {
                if req.target != GrabberTarget::Sine {
                    let m = "--space voltage reads sine patterns: use --target sine";
                    return Err(usage(m).into());
                }
                let v = VoltageRequest {
                    uri,
                    seed: a.seed,
                    scope_rows: a.scope_rows.clone(),
                    magnification: a.magnification,
                };
                return mtf_voltage(set, g.as_mut(), &req, &v, ev);
            }
            let label = match req.target {
                GrabberTarget::Sine => "targets",
                GrabberTarget::Edge => "edge",
            };
            let m = measure_mtf(g.as_mut(), &req, &mut progress(ev, label, false))?;
            let details = serde_json::json!({
                "mean_radiance_w_m2_sr": m.mean_radiance_w_m2_sr,
                "grabber": g.describe(),
            });
            (vec![m.curve], details)
        }
    };
    report::write_mtf_report(dir, &curves, details)?;
    let c = &curves[0];
    let line = format!(
        "{}: MTF50 {} cy/px, MTF10 {} cy/px",
        c.method,
        c.mtf50.map_or("—".into(), |v| format!("{v:.4}")),
        c.mtf10.map_or("—".into(), |v| format!("{v:.4}"))
    );
    Ok(written(set, "mtf.json", vec![line]))
}

/// `--space voltage`: the scope flow on the sim: camera, the digital-count
/// sine flow through the grabber, and the analytic curves, in one report.
fn mtf_voltage<E: From<CalibError>>(
    set: OutputSet,
    g: &mut dyn FrameGrabber,
    req: &MtfRequest,
    v: &VoltageRequest,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    let r = voltage_mtf(g, req, v, &mut |phase, done, total| {
        ev(Event::Progress(phase, done, total))
    })?;
    report::write_mtf_report(set.dir(), &r.curves, r.details)?;
    let (c, p) = (&r.curves, &r.voltage.points);
    let mut lines = Vec::new();
    for (i, f) in r.frequencies_cy_per_px.iter().enumerate() {
        lines.push(format!(
            "{f:.3} cy/px ({:.2} MHz, {:.2} lp/mm object): voltage {:.3}, digital {:.3}, analytic line {:.3}, digitised {:.3}",
            p[i].line_frequency_mhz,
            p[i].object_lp_per_mm,
            c[0].mtf[i],
            c[1].mtf[i],
            c[2].mtf[i],
            c[3].mtf[i]
        ));
    }
    Ok(written(set, "mtf.json", lines))
}

#[derive(Args)]
pub struct CaptureArgs {
    /// Grabber URI: sim:PRESET_OR_RIG[?rig=R&seed=S&size=WxH],
    /// serial:PATH[?baud=N], usb:VID:PID[:SERIAL],
    /// genicam:DEVICE_ID|ADDR[?trigger=auto|software|off&resend=always|never&timeout_ms=N&size=WxH]
    /// (GigE Vision / USB3 Vision cameras through Aravis, gloam's own
    /// `gloam device --gige` included; build with --features genicam).
    #[arg(long)]
    pub grabber: String,
    /// Good frames to capture.
    #[arg(long, default_value_t = 1)]
    /// At most 1 000 000 (nine hours at 30 frames/s; split longer runs).
    #[arg(value_parser = clap::value_parser!(u64).range(0..=1_000_000))]
    pub frames: u64,
    /// Output directory (frame-NNNNNN.png + frames.jsonl).
    #[arg(long)]
    pub out: PathBuf,
    /// Fixed gain (turns AGC off).
    #[arg(long, conflicts_with = "agc")]
    pub gain: Option<f64>,
    /// Turn AGC on.
    #[arg(long)]
    pub agc: bool,
    /// Digitizer bit depth.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["8", "12", "16"]))]
    pub bits: Option<String>,
    /// Exposure / gate time, seconds.
    #[arg(long)]
    pub exposure_s: Option<f64>,
    /// Noise seed for sim: grabbers (the emulator takes its own --seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Give up after this many lost/damaged frames in a row.
    #[arg(long, default_value_t = 1000)]
    pub max_consecutive_failures: u64,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other files).
    #[arg(long)]
    pub force: bool,
}

/// How a capture went: frames kept, frames with exposure warnings, losses.
#[derive(Default)]
pub struct CaptureTally {
    pub kept: u64,
    pub frames_warned: u64,
    pub losses: FrameLosses,
}

impl CaptureArgs {
    /// Checks the options that clap cannot.
    pub fn check(&self) -> Result<(), CalibError> {
        if self.frames == 0 {
            return Err(CalibError::Usage("--frames must be at least 1".into()));
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
        ev: &mut dyn FnMut(Event<'_>),
    ) -> Result<Box<dyn FrameGrabber>, E> {
        let mut g = open_uri(registry, &self.grabber, self.seed)?;
        ev(Event::Note(format!("capturing from {}", g.describe())));
        let camera = serde_json::json!({ "camera": g.describe(), "grabber": self.grabber });
        report::write_json(&dir.join(crate::apply::CAMERA_FILE), &camera)?;
        if let Some(b) = &self.bits {
            g.set_bits(b.parse().expect("clap checked 8, 12 or 16"))?;
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

    /// Grabs `--frames` good frames, handing each to `keep` with its index
    /// and exposure warnings; rides out up to `--max-consecutive-failures`
    /// lost or damaged frames in a row, and stops when `interrupted()`.
    /// Each kind of exposure warning is noted once (every frame keeps its
    /// own through `keep`). The tally is returned even when the run failed.
    pub fn grab<E: From<CalibError>, K: FnMut(u64, &Frame, Vec<String>) -> Result<(), E>>(
        &self,
        g: &mut dyn FrameGrabber,
        interrupted: &dyn Fn() -> bool,
        mut keep: K,
        ev: &mut dyn FnMut(Event<'_>),
    ) -> (CaptureTally, Result<(), E>) {
        let mut t = CaptureTally::default();
        let mut consecutive = 0u64;
        let mut warned = std::collections::BTreeSet::new();
        let mut status = String::new();
        let result = (|| {
            while t.kept < self.frames {
                if interrupted() {
                    return Err(CalibError::Usage("interrupted (Ctrl-C)".into()).into());
                }
                match g.grab() {
                    Ok(f) => {
                        consecutive = 0;
                        let exposure = f.exposure();
                        for (w, k) in exposure.warnings.iter().zip(&exposure.warning_kinds) {
                            if warned.insert(*k) {
                                ev(Event::Note(format!("warning: frame {}: {w}", t.kept)));
                            }
                        }
                        t.frames_warned += u64::from(!exposure.warnings.is_empty());
                        keep(t.kept, &f, exposure.warnings)?;
                        t.kept += 1;
                    }
                    Err(e) if t.losses.count(&e) => {
                        consecutive += 1;
                        ev(Event::Note(format!("warning: {e}")));
                        let l = &t.losses;
                        status = format!("{} damaged, {} lost", l.damaged, l.lost);
                        if consecutive >= self.max_consecutive_failures {
                            let m =
                                format!("{consecutive} lost or damaged frames in a row; giving up");
                            return Err(CalibError::Usage(m).into());
                        }
                    }
                    Err(e) => return Err(CalibError::Grabbing(Box::new(e)).into()),
                }
                ev(Event::Progress(
                    &status,
                    t.kept as usize,
                    self.frames as usize,
                ));
            }
            Ok(())
        })();
        (t, result)
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum Format {
    #[value(name = "rs-170")]
    Rs170,
    Ccir,
}

#[derive(Args)]
pub struct ScopeArgs {
    /// Sensor preset or TOML file (or give --grabber sim:…).
    #[arg(long, conflicts_with = "grabber")]
    pub sensor: Option<String>,
    /// A sim: grabber URI (sensor, rig, seed, size from it).
    #[arg(long)]
    pub grabber: Option<String>,
    /// Rig the camera looks at: uniform, sine, edge, dark (default sine).
    #[arg(long)]
    pub rig: Option<String>,
    /// Sine bars across the line, cycles/pixel.
    #[arg(long, default_value_t = 0.05)]
    pub frequency: f64,
    /// Mean signal, fraction of the range above black.
    #[arg(long, default_value_t = 0.4)]
    pub level: f64,
    /// Frame rows to show, comma-separated (default: the middle row).
    #[arg(long, value_delimiter = ',')]
    pub rows: Vec<usize>,
    /// Frame size WxH (default: 640x480 RS-170, 768x576 CCIR).
    #[arg(long)]
    pub size: Option<String>,
    #[arg(long)]
    pub seed: Option<u64>,
    /// Fixed gain (AGC off).
    #[arg(long)]
    pub gain: Option<f64>,
    /// Override the sensor file's line format.
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// Override the video amplifier's −3 dB bandwidth, Hz.
    #[arg(long)]
    pub bandwidth_hz: Option<f64>,
    /// Frames captured before the one shown.
    #[arg(long, default_value_t = 1)]
    pub frames: usize,
    /// Output directory: scope.csv, scope.png, scope.json.
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long)]
    pub force: bool,
}

impl ScopeArgs {
    /// The scope's options: the sensor, rig, seed and size from `--sensor`
    /// (rig sine, seed 0) or the `--grabber` URI, each overridable.
    pub fn options(&self) -> Result<ScopeOptions, CalibError> {
        use gloam_sensor::stages::video_timing::VideoFormat;
        let (sensor, rig, seed, size) = match (&self.sensor, &self.grabber) {
            (Some(s), _) => (s.clone(), "sine".to_string(), 0, None),
            (None, Some(u)) => sim_uri(u)?,
            (None, None) => {
                let m = "give --sensor PRESET_OR_FILE or --grabber sim:…";
                return Err(CalibError::Usage(m.into()));
            }
        };
        let size =
            match &self.size {
                Some(s) => Some(gloam_grabber::uri::parse_size(s).ok_or_else(|| {
                    CalibError::Usage(format!("--size '{s}' is not WxH (1..4096)"))
                })?),
                None => size,
            };
        Ok(ScopeOptions {
            sensor,
            seed: self.seed.unwrap_or(seed),
            size,
            rows: self.rows.clone(),
            rig: self.rig.clone().unwrap_or(rig),
            level_fraction: self.level,
            frequency_cy_per_px: self.frequency,
            gain: self.gain,
            format: self.format.map(|f| match f {
                Format::Rs170 => VideoFormat::Rs170,
                Format::Ccir => VideoFormat::Ccir,
            }),
            bandwidth_hz: self.bandwidth_hz,
            frames: self.frames,
        })
    }
}

#[derive(Args)]
pub struct CompareArgs {
    /// Reference image (e.g. a calibrated radiance TIFF).
    pub truth: PathBuf,
    /// Image to validate (e.g. a gloam render), same size.
    pub synthetic: PathBuf,
    /// Ground-control regions: JSON array of {name,x,y,width,height} or TOML [[region]].
    #[arg(long)]
    pub regions: PathBuf,
    /// Print the figures as JSON ({"spearman_rho", "rms", "regions"}).
    #[arg(long)]
    pub json: bool,
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Parser)]
    struct Scope {
        #[command(flatten)]
        a: ScopeArgs,
    }

    #[test]
    fn scope_takes_the_uri_and_lets_flags_override_it() {
        let o = Scope::parse_from([
            "scope",
            "--grabber",
            "sim:gen2-s20-iccd?rig=edge&seed=5&size=64x48",
            "--out",
            "o",
        ])
        .a
        .options()
        .unwrap();
        assert_eq!(
            (o.sensor.as_str(), o.rig.as_str(), o.seed, o.size),
            ("gen2-s20-iccd", "edge", 5, Some((64, 48)))
        );
        let o = Scope::parse_from(["scope", "--sensor", "s", "--seed", "9", "--out", "o"])
            .a
            .options()
            .unwrap();
        assert_eq!((o.rig.as_str(), o.seed, o.size), ("sine", 9, None));
        let e = Scope::parse_from(["scope", "--out", "o"]).a.options();
        assert_eq!(
            e.unwrap_err().to_string(),
            "give --sensor PRESET_OR_FILE or --grabber sim:…"
        );
    }

    #[test]
    fn radiance_refuses_a_bad_gain_before_opening_anything() {
        let dir = tempfile::tempdir().unwrap();
        let a = RadianceArgs {
            grabber: GrabberArgs {
                grabber: "sim:scientific-ccd".into(),
                seed: None,
                exposure_s: None,
            },
            source: SourceArgs {
                source: "missing.toml".into(),
                levels: None,
                auto_range: None,
            },
            gains: vec![1.0, -2.0],
            frames: 1,
            out: dir.path().join("o"),
            force: false,
        };
        let r = run_calibrate::<CalibError>(
            &CalibrateCommand::Radiance(a),
            &gloam_simcam::registry(),
            &mut |_| {},
        );
        let e = r.err().expect("a negative gain is refused");
        assert_eq!(
            e.to_string(),
            "--gains: -2 is not a gain (each must be a finite number > 0)"
        );
        // No output set was begun: no staging directory, no --out.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    fn capture(frames: u64) -> CaptureArgs {
        CaptureArgs {
            grabber: "sim:scientific-ccd".into(),
            frames,
            out: "o".into(),
            gain: None,
            agc: false,
            bits: None,
            exposure_s: None,
            seed: None,
            max_consecutive_failures: 3,
            force: false,
        }
    }

    #[test]
    fn capture_keeps_each_frame_once_in_order_and_stops_when_interrupted() {
        let mut g =
            gloam_simcam::SimGrabber::from_preset("scientific-ccd", "uniform", 0, (16, 8)).unwrap();
        let mut kept = Vec::new();
        let (t, r) = capture(3).grab::<CalibError, _>(
            &mut g,
            &|| false,
            |i, f: &Frame, _| {
                kept.push((i, f.pixels.len()));
                Ok(())
            },
            &mut |_| {},
        );
        r.unwrap();
        assert_eq!(kept, [(0, 128), (1, 128), (2, 128)]);
        assert_eq!((t.kept, t.losses), (3, FrameLosses::default()));
        let (t, r) = capture(3).grab::<CalibError, _>(
            &mut g,
            &|| true,
            |_, _: &Frame, _| Ok(()),
            &mut |_| {},
        );
        assert_eq!(r.unwrap_err().to_string(), "interrupted (Ctrl-C)");
        assert_eq!(t.kept, 0);
        assert!(capture(0).check().is_err());
    }
}
