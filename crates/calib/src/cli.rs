//! The command-line arguments of `gloam calibrate …`, `capture`, `scope`
//! and `compare` (feature `cli`), and the flows they run: the front end
//! parses, opens the output set, shows progress and prints; what the
//! options mean, their defaults and checks, and the order of the steps
//! live here, beside the flows they drive.

use std::path::{Path, PathBuf};

use gloam_io::OutputSet;

use clap::{Args, Subcommand, ValueEnum};
use gloam_grabber::{FrameGrabber, GrabError, Registry};

use crate::CalibError;
use crate::mtf_flow::{self, GrabberTarget, MtfRequest, read_usaf_ctf, usaf_mtf};
use crate::radiance::{RadianceOptions, calibrate_radiance};
use crate::report;
use crate::request::{
    AgcRequest, ApplyRequest, MtfCalibration, MtfDone, PtcRequest, RadianceRequest, ScopeRequest,
    SourceRequest, VoltageOptions, open_uri, progress,
};
pub use crate::request::{CaptureTally, GrabRequest};
use crate::scope_run::ScopeOptions;

pub use crate::request::{Event, MAX_FRAMES_PER_SETTING, MAX_LEVELS};

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
    /// Sine modulation in radiance (default 0.8).
    #[arg(long)]
    pub modulation: Option<f64>,
    /// Target angle, degrees (sine: from the row axis, default 0; edge: from the column axis, default 5).
    #[arg(long)]
    pub angle_deg: Option<f64>,
    /// Sine frequencies, cycles/pixel, comma-separated (default 0.02…0.48 step 0.02).
    #[arg(long, value_delimiter = ',')]
    pub frequencies: Vec<f64>,
    /// Frames averaged per target (sine and edge; default 8).
    #[arg(long, value_parser = count_up_to(MAX_FRAMES_PER_SETTING))]
    pub frames: Option<usize>,
    /// Relative spectrum of the targets, a built-in name (sine and edge;
    /// default cie-a).
    #[arg(long)]
    pub spectrum: Option<String>,
    /// usaf: CSV of `group,element,modulation` (measured bar contrast).
    #[arg(long)]
    pub ctf: Option<PathBuf>,
    /// usaf: pixel pitch, µm.
    #[arg(long)]
    pub pixel_pitch_um: Option<f64>,
    /// usaf and sine --space voltage: optical magnification (image size /
    /// chart size; default 1).
    #[arg(long)]
    pub magnification: Option<f64>,
    /// sine: measure in digital counts (the default), or in voltage space
    /// (scope line + grey-scale curve) beside digital counts and the
    /// analytic MTF.
    #[arg(long, value_enum)]
    pub space: Option<Space>,
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

/// The flags `calibrate mtf --target sine` reads: the first
/// [`SINE_FLAGS`], and with `--space voltage` the scope's too.
const SINE_VOLTAGE_FLAGS: &[&str] = &[
    "--grabber",
    "--seed",
    "--gain",
    "--radiance",
    "--modulation",
    "--angle-deg",
    "--frequencies",
    "--frames",
    "--spectrum",
    "--space",
    "--scope-rows",
    "--magnification",
];
const SINE_FLAGS: usize = 10;

impl MtfArgs {
    fn voltage(&self) -> bool {
        self.space == Some(Space::Voltage)
    }

    fn magnification(&self) -> f64 {
        self.magnification.unwrap_or(1.0)
    }

    /// A flag the chosen target does not read, refused: it was ignored,
    /// and the report looked as if it had been applied.
    fn refuse_unused(&self) -> Result<(), CalibError> {
        let given = [
            ("--grabber", self.grabber.is_some()),
            ("--seed", self.seed.is_some()),
            ("--gain", self.gain.is_some()),
            ("--radiance", self.radiance.is_some()),
            ("--modulation", self.modulation.is_some()),
            ("--angle-deg", self.angle_deg.is_some()),
            ("--frequencies", !self.frequencies.is_empty()),
            ("--frames", self.frames.is_some()),
            ("--spectrum", self.spectrum.is_some()),
            ("--ctf", self.ctf.is_some()),
            ("--pixel-pitch-um", self.pixel_pitch_um.is_some()),
            ("--magnification", self.magnification.is_some()),
            ("--space", self.space.is_some()),
            ("--scope-rows", !self.scope_rows.is_empty()),
        ];
        let (name, reads): (&str, &[&str]) = match self.target {
            Target::Usaf => ("usaf", &["--ctf", "--pixel-pitch-um", "--magnification"]),
            // `--space voltage` on an edge has its own refusal (validate).
            Target::Edge => (
                "edge",
                &[
                    "--grabber",
                    "--seed",
                    "--gain",
                    "--radiance",
                    "--angle-deg",
                    "--frames",
                    "--spectrum",
                    "--space",
                ],
            ),
            Target::Sine if self.voltage() => ("sine --space voltage", SINE_VOLTAGE_FLAGS),
            Target::Sine => ("sine", &SINE_VOLTAGE_FLAGS[..SINE_FLAGS]),
        };
        let unused: Vec<&str> = given
            .iter()
            .filter(|(flag, g)| *g && !reads.contains(flag))
            .map(|(flag, _)| *flag)
            .collect();
        if unused.is_empty() {
            return Ok(());
        }
        Err(CalibError::Usage(format!(
            "--target {name} does not use {}: drop {} (it reads {})",
            unused.join(", "),
            if unused.len() == 1 { "it" } else { "them" },
            reads.join(", ")
        )))
    }
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
    reads: &gloam_io::ReadLog,
    guard: &gloam_io::RunGuard,
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
        CalibrateCommand::Radiance(a) => radiance(a, registry, reads, guard, ev),
        CalibrateCommand::Apply(a) => {
            let req = ApplyRequest {
                lut: a.lut.clone(),
                input: a.input.clone(),
                page: a.page,
                output: a.output.clone(),
                gain: a.gain,
            };
            let line = req.run(ev)?;
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
        CalibrateCommand::Agc(a) => agc(a, registry, reads, guard, ev),
        CalibrateCommand::Ptc(a) => ptc(a, registry, reads, guard, ev),
        CalibrateCommand::Mtf(a) => mtf(a, registry, reads, guard, ev),
    }
}

/// The files `calibrate agc` reads (`--source`, `--lut`, `--sequence`).
fn agc_inputs(a: &AgcArgs) -> Vec<(&'static str, &Path)> {
    let mut v = vec![("--source", a.source.source.as_path())];
    v.extend(a.lut.iter().map(|l| ("--lut", l.as_path())));
    v.extend(a.sequence.iter().map(|l| ("--sequence", l.as_path())));
    v
}

impl GrabberArgs {
    /// Opens the grabber and sets the exposure asked for.
    pub fn open<E: From<CalibError> + From<GrabError>>(
        &self,
        registry: &Registry,
        reads: &gloam_io::ReadLog,
        ev: &mut dyn FnMut(Event<'_>),
    ) -> Result<Box<dyn FrameGrabber>, E> {
        let mut g = open_uri(registry, &self.grabber, self.seed, reads)?;
        if let Some(e) = self.exposure_s {
            g.set_exposure_s(e)?;
        }
        ev(Event::Note(format!("grabber: {}", g.describe())));
        Ok(g)
    }
}

impl SourceArgs {
    /// The flags as a flow's source.
    pub fn request(&self) -> SourceRequest {
        SourceRequest {
            source: self.source.clone(),
            levels: self.levels,
            auto_range: self.auto_range,
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

fn radiance<E: From<CalibError> + From<GrabError>>(
    a: &RadianceArgs,
    registry: &Registry,
    reads: &gloam_io::ReadLog,
    guard: &gloam_io::RunGuard,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    let req = RadianceRequest {
        source: a.source.request(),
        gains: a.gains.clone(),
        frames: a.frames,
        exposure_s: a.grabber.exposure_s,
    };
    req.validate()?;
    // The output set first (a refused `--out` touches no camera), then
    // the grabber, then the source against it.
    let set = OutputSet::begin(&a.out, a.force, false, guard).map_err(CalibError::from)?;
    let mut g = a.grabber.open::<E>(registry, reads, ev)?;
    let lut = req.run(g.as_mut(), reads, ev)?;
    report::write_radiance_report(set.dir(), &lut)?;
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
    Ok(written(set, "lut.json", lines))
}

fn agc<E: From<CalibError> + From<GrabError>>(
    a: &AgcArgs,
    registry: &Registry,
    reads: &gloam_io::ReadLog,
    guard: &gloam_io::RunGuard,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    let lut = (a.lut.as_deref())
        .map(|p| crate::apply::load_lut(p, reads))
        .transpose()?;
    let req = AgcRequest {
        source: a.source.request(),
        fixed_gain: a.fixed_gain,
        frames: a.frames,
        lut: lut.map(|l| (l, a.lut.clone())),
        allow_unsettled: a.allow_unsettled,
    };
    req.validate()?;
    let set = OutputSet::begin(&a.out, a.force, false, guard).map_err(CalibError::from)?;
    let mut g = a.grabber.open::<E>(registry, reads, ev)?;
    let r = req.run(g.as_mut(), reads, ev)?;
    report::write_agc_report(set.dir(), &r)?;
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
    Ok(written(set, "agc.json", lines))
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
    seed: u64,
    /// The `sim:` grabber's preset, read once for the checks and the
    /// capture.
    sensor: gloam_sensor::ResolvedSensor,
    lut: Option<crate::radiance::Lut>,
    opts: crate::agc_sequence::AgcSequenceOptions,
}

/// `gloam calibrate agc --sequence`: checks the camera (a `sim:` grabber)
/// and the LUT and opens the output set, before anything is rendered
/// ([`SequenceRun`]).
pub fn agc_sequence<'a>(
    a: &'a AgcArgs,
    reads: &gloam_io::ReadLog,
    guard: &gloam_io::RunGuard,
) -> Result<SequenceRun<'a>, CalibError> {
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
    let sensor = gloam_sensor::ResolvedSensor::load(&preset, reads)?;
    let config = sensor.config();
    let camera = format!("simulated {preset}");
    let lut = match &a.lut {
        Some(path) => {
            let lut = crate::apply::load_lut(path, reads)?;
            crate::apply::check_lut_fits_camera(&lut, &camera, config.digitizer.bits)
                .map_err(|e| CalibError::file(path, e))?;
            Some(lut)
        }
        None => None,
    };
    let opts = AgcSequenceOptions::for_sensor(config)?.ok_or_else(|| {
        CalibError::Usage(format!(
            "--sequence: camera '{preset}' has no AGC ([agc] in its sensor file)"
        ))
    })?;
    let set = OutputSet::begin(&a.out, a.force, false, guard)?;
    let seed = a.grabber.seed.unwrap_or(uri_seed);
    Ok(SequenceRun {
        a,
        set,
        seed,
        sensor,
        lut,
        opts,
    })
}

impl SequenceRun<'_> {
    /// Where the sequence's frames and `frames.jsonl` go.
    pub fn dir(&self) -> &Path {
        self.set.dir()
    }

    /// The camera (preset or sensor file) the sequence is captured
    /// through, read once when the run was checked.
    pub fn sensor(&self) -> &gloam_sensor::ResolvedSensor {
        &self.sensor
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
        reads: &gloam_io::ReadLog,
        ev: &mut dyn FnMut(Event<'_>),
    ) -> Result<Outcome, E> {
        use crate::agc_sequence::{
            SequenceLayers, detected_per_band_radiance, linearise_sequence,
            write_agc_sequence_report,
        };
        let SequenceRun {
            a,
            set,
            sensor,
            lut,
            opts,
            ..
        } = self;
        let dir = set.dir();
        let mut g = a.grabber.open::<E>(registry, reads, ev)?;
        g.set_exposure_s(captured.exposure_s)?;
        let mut lines = Vec::new();
        // The source gives the LUT's units (its lamp's spectrum) even when the
        // LUT is given, and measures the LUT when it is not.
        let source = SourceRequest {
            levels: a.source.levels.or(Some(SEQUENCE_LUT_LEVELS)),
            auto_range: a.source.auto_range.or(Some(SEQUENCE_LUT_AUTO_RANGE)),
            ..a.source.request()
        };
        let (lut, mut src) = match lut {
            Some(lut) => (lut, source.open(g.as_mut(), None, reads, ev)?),
            None => {
                let exposure_s = captured.exposure_s;
                let (lut, src, line) = measure_sequence_lut(
                    a,
                    &opts,
                    dir,
                    exposure_s,
                    g.as_mut(),
                    (&source, reads),
                    ev,
                )?;
                lines.push(line);
                (lut, src)
            }
        };
        let k = detected_per_band_radiance(src.as_mut(), sensor.config())?;
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
        lines.push(sequence_line(&r));
        Ok(written(set, "agc_sequence.json", lines))
    }
}

/// With no `--lut`: measures one on `source` over the gains the AGC went
/// through once it left its power-up gain (the acquisition window is not
/// judged), into `dir`'s `lut.json`; with the line that says so.
fn measure_sequence_lut(
    a: &AgcArgs,
    opts: &crate::agc_sequence::AgcSequenceOptions,
    dir: &Path,
    exposure_s: f64,
    g: &mut dyn FrameGrabber,
    (source, reads): (&SourceRequest, &gloam_io::ReadLog),
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<
    (
        crate::radiance::Lut,
        Box<dyn crate::source::CalibrationSource>,
        String,
    ),
    CalibError,
> {
    use crate::agc_sequence::lut_gains_spanning;
    let tau_s = opts.agc_time_constant_s;
    let from_s = opts.transient_time_constants * tau_s;
    // Named by the sequence file, not the staging directory the frames are
    // in (it is removed when the run fails).
    let gains = crate::agc_sequence::gains_in_effect(dir, from_s).map_err(|e| match e {
        CalibError::InsufficientData(_) => CalibError::InsufficientData(format!(
            "--sequence {}: no frame starts {from_s} s or more after the first ({} AGC time constants of {tau_s} s: the loop's acquisition, not judged), so no gain to measure a LUT at; lengthen the sequence or give --lut",
            a.sequence.as_deref().unwrap_or(Path::new("?")).display(),
            opts.transient_time_constants
        )),
        other => other,
    })?;
    let (lo, hi) = (gains.iter()).fold((f64::INFINITY, 0.0f64), |(l, h), &g| (l.min(g), h.max(g)));
    let gains = lut_gains_spanning(lo, hi, SEQUENCE_LUT_GAIN_RATIO);
    let top = gains.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut src = source.open(g, Some(top), reads, ev)?;
    let ropts = RadianceOptions {
        gains: gains.clone(),
        exposure_s: Some(exposure_s),
        ..Default::default()
    };
    let silent = source.is_manual();
    let mut p = progress(ev, "LUT levels", silent);
    let lut = calibrate_radiance(g, src.as_mut(), &ropts, &mut p)?;
    report::write_radiance_report(dir, &lut)?;
    let line = format!(
        "LUT measured on {} at {} gains {}–{} (the gains the AGC visited from {from_s} s on) → lut.json",
        a.source.source.display(),
        lut.gains.len(),
        gains[0],
        gains[gains.len() - 1]
    );
    Ok((lut, src, line))
}

/// The sequence's residuals in one line: steady, transient, acquiring.
fn sequence_line(r: &crate::agc_sequence::AgcSequenceReport) -> String {
    let fmt = |s: &crate::agc_sequence::PhaseSummary| match (
        s.rms_residual_percent,
        s.max_abs_residual_percent,
    ) {
        (Some(rms), Some(max)) => {
            format!("RMS {rms:.2} %, max {max:.2} % over {} frames", s.frames)
        }
        _ => "no frames".into(),
    };
    format!(
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
    )
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
            // The frames linearised lie within both the AGC's range and the
            // LUT's: the AGC's whole range (575.67 beside a LUT to 300)
            // read as if those frames had been measured too.
            (Some(rms), Some(max)) => format!(
                "linearised radiance vs true: residual RMS {rms:.2} %, max {max:.2} % over {} {} AGC frames at gains within {}–{} (the AGC visited {}–{}; LUT gains {}–{}){outside}",
                r.frames_linearised,
                if r.all_settled {
                    "settled"
                } else {
                    "unsettled"
                },
                crate::error::gain_text(lo.max(lut[0])),
                crate::error::gain_text(hi.min(lut[1])),
                crate::error::gain_text(lo),
                crate::error::gain_text(hi),
                crate::error::gain_text(lut[0]),
                crate::error::gain_text(lut[1])
            ),
            _ => format!("linearised radiance vs true: no settled AGC frame to linearise{outside}"),
        },
    )
}

fn ptc<E: From<CalibError> + From<GrabError>>(
    a: &PtcArgs,
    registry: &Registry,
    reads: &gloam_io::ReadLog,
    guard: &gloam_io::RunGuard,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    let mut req = PtcRequest {
        source: a.source.request(),
        grabber: a.grabber.grabber.clone(),
        gain: a.gain,
        spatial_frames: a.spatial_frames,
        exposure_s: a.grabber.exposure_s,
        dataset_dir: None,
    };
    req.validate()?;
    let set = OutputSet::begin(&a.out, a.force, false, guard).map_err(CalibError::from)?;
    let mut g = a.grabber.open::<E>(registry, reads, ev)?;
    req.dataset_dir = Some(set.dir().join("emva1288"));
    let r = req.run(g.as_mut(), reads, ev)?.report;
    report::write_ptc_report(set.dir(), &r)?;
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
    Ok(written(set, "ptc.json", lines))
}

fn mtf<E: From<CalibError> + From<GrabError>>(
    a: &MtfArgs,
    registry: &Registry,
    reads: &gloam_io::ReadLog,
    guard: &gloam_io::RunGuard,
    ev: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, E> {
    let usage = |m: &str| CalibError::Usage(m.into());
    a.refuse_unused()?;
    let target = match a.target {
        Target::Usaf => None,
        Target::Sine => Some(GrabberTarget::Sine),
        Target::Edge => Some(GrabberTarget::Edge),
    };
    let req = target.map(|target| MtfCalibration {
        mtf: MtfRequest {
            target,
            gain: a.gain,
            radiance_w_m2_sr: a.radiance,
            modulation: a.modulation.unwrap_or(mtf_flow::DEFAULT_MODULATION),
            angle_deg: a.angle_deg,
            frequencies_cy_per_px: a.frequencies.clone(),
            frames: a.frames.unwrap_or(mtf_flow::DEFAULT_FRAMES),
            spectrum: (a.spectrum.as_deref())
                .unwrap_or(mtf_flow::DEFAULT_SPECTRUM)
                .to_string(),
        },
        voltage: a.voltage().then(|| VoltageOptions {
            scope_rows: a.scope_rows.clone(),
            magnification: a.magnification(),
        }),
    });
    // Before the output set opens: nothing is measured above Nyquist.
    if let Some(r) = &req {
        r.validate()?;
    }
    let set = OutputSet::begin(&a.out, a.force, false, guard).map_err(CalibError::from)?;
    let dir = set.dir();
    let Some(req) = req else {
        let ctf_path = a
            .ctf
            .as_ref()
            .ok_or_else(|| usage("--target usaf needs --ctf FILE"))?;
        let pitch = a
            .pixel_pitch_um
            .ok_or_else(|| usage("--target usaf needs --pixel-pitch-um"))?;
        let (curves, details) = usaf_mtf(
            read_usaf_ctf(ctf_path, reads)?,
            pitch,
            a.magnification(),
            ctf_path,
        )?;
        report::write_mtf_report(dir, &curves, &details)?;
        return Ok(written(set, "mtf.json", vec![mtf_line(&curves[0])]));
    };
    let uri = (a.grabber.clone()).ok_or_else(|| usage("--target sine/edge needs --grabber"))?;
    let ga = GrabberArgs {
        grabber: uri.clone(),
        seed: a.seed,
        exposure_s: None,
    };
    let mut g = ga.open::<E>(registry, reads, ev)?;
    match req.run(g.as_mut(), (&uri, a.seed), ev)? {
        MtfDone::Voltage(r) => mtf_voltage(set, r),
        MtfDone::Digital {
            curve,
            mean_radiance_w_m2_sr,
        } => {
            let details = crate::mtf_flow::MtfDetails::Digital {
                mean_radiance_w_m2_sr,
                grabber: g.describe(),
            };
            let line = mtf_line(&curve);
            report::write_mtf_report(dir, &[curve], &details)?;
            Ok(written(set, "mtf.json", vec![line]))
        }
    }
}

/// `METHOD: MTF50 … cy/px, MTF10 … cy/px`.
fn mtf_line(c: &crate::mtf::MtfCurve) -> String {
    format!(
        "{}: MTF50 {} cy/px, MTF10 {} cy/px",
        c.method,
        c.mtf50.map_or("—".into(), |v| format!("{v:.4}")),
        c.mtf10.map_or("—".into(), |v| format!("{v:.4}"))
    )
}

/// `--space voltage`: the scope flow on the sim: camera, the digital-count
/// sine flow through the grabber, and the analytic curves, in one report.
fn mtf_voltage<E: From<CalibError>>(
    set: OutputSet,
    r: crate::mtf_flow::VoltageReport,
) -> Result<Outcome, E> {
    report::write_mtf_report(set.dir(), &r.curves, &r.details)?;
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
    #[arg(value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
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

impl CaptureArgs {
    /// The grab these flags ask for.
    pub fn request(&self) -> GrabRequest {
        GrabRequest {
            grabber: self.grabber.clone(),
            frames: self.frames,
            gain: self.gain,
            agc: self.agc,
            bits: self
                .bits
                .as_deref()
                .map(|b| b.parse().expect("clap checked 8, 12 or 16")),
            exposure_s: self.exposure_s,
            seed: self.seed,
            max_consecutive_failures: self.max_consecutive_failures,
        }
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
    #[arg(long, conflicts_with = "grabber", value_parser = gloam_sensor::cli::preset_or_file())]
    pub sensor: Option<String>,
    /// A sim: grabber URI (sensor, rig, seed, size from it).
    #[arg(long)]
    pub grabber: Option<String>,
    /// Rig the camera looks at: uniform, sine, edge, dark (default sine).
    #[arg(long)]
    pub rig: Option<String>,
    /// Sine bars across the line, cycles/pixel (rig sine; default 0.05).
    #[arg(long)]
    pub frequency: Option<f64>,
    /// Mean signal, fraction of the range above black (every rig but dark;
    /// default 0.4).
    #[arg(long)]
    pub level: Option<f64>,
    /// Frame rows to show, comma-separated (default: the middle row).
    #[arg(long, value_delimiter = ',')]
    pub rows: Vec<usize>,
    /// Frame size WxH (default: 640x480 RS-170, 768x574 CCIR, whose 575
    /// picture lines hold at most 575 rows).
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
        let size =
            match &self.size {
                Some(s) => Some(gloam_grabber::uri::parse_size(s).ok_or_else(|| {
                    CalibError::Usage(format!("--size '{s}' is not WxH (1..4096)"))
                })?),
                None => None,
            };
        let o = ScopeRequest {
            sensor: self.sensor.clone(),
            grabber: self.grabber.clone(),
            rig: self.rig.clone(),
            frequency_cy_per_px: self.frequency.unwrap_or(0.05),
            level_fraction: self.level.unwrap_or(0.4),
            rows: self.rows.clone(),
            size,
            seed: self.seed,
            gain: self.gain,
            format: self.format.map(|f| match f {
                Format::Rs170 => VideoFormat::Rs170,
                Format::Ccir => VideoFormat::Ccir,
            }),
            bandwidth_hz: self.bandwidth_hz,
            frames: self.frames,
        }
        .validate()?;
        // A flag the rig does not read was ignored, and the trace looked
        // as if it had been applied.
        let unused = match o.rig.as_str() {
            "sine" => None,
            "dark" if self.level.is_some() => Some("--level"),
            _ if self.frequency.is_some() => Some("--frequency"),
            _ => None,
        };
        if let Some(flag) = unused {
            return Err(CalibError::Usage(format!(
                "{flag} is not used by rig '{}'{}: drop it",
                o.rig,
                if flag == "--level" {
                    " (it shows the dark signal)"
                } else {
                    " (only the sine rig has a frequency)"
                }
            )));
        }
        Ok(o)
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
    use crate::capture::FrameLosses;

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
            &gloam_io::ReadLog::off(),
            &gloam_io::RunGuard::detached(),
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
        let mut g = gloam_simcam::SimGrabber::from_preset(
            "scientific-ccd",
            "uniform",
            0,
            (16, 8),
            &gloam_io::ReadLog::off(),
        )
        .unwrap();
        let mut kept = Vec::new();
        let request = capture(3).request();
        let mut grabbing = request.grabbing();
        let guard = gloam_io::RunGuard::detached();
        while let Some((i, f, _)) = grabbing.next_frame(&mut g, &guard, &mut |_| {}).unwrap() {
            kept.push((i, f.pixels.len()));
        }
        assert_eq!(kept, [(0, 128), (1, 128), (2, 128)]);
        let t = grabbing.tally();
        assert_eq!((t.kept, t.losses), (3, FrameLosses::default()));
        // An interrupt the guard heard (a capture's set polls for it).
        let dir = tempfile::tempdir().unwrap();
        let staging = dir.path().join("s");
        let set = gloam_io::OutputSet::begin(&staging, false, true, &guard).unwrap();
        assert_eq!(
            guard.on_interrupt(),
            gloam_io::guard::AfterInterrupt::Continue
        );
        let mut grabbing = request.grabbing();
        let r = grabbing.next_frame(&mut g, &guard, &mut |_| {});
        assert_eq!(
            r.unwrap_err().to_string(),
            "interrupted (Ctrl-C, SIGTERM or SIGHUP)"
        );
        assert_eq!(grabbing.tally().kept, 0);
        drop(set);
        assert!(capture(0).request().check().is_err());
    }
}
