//! `gloam calibrate …`: radiance LUTs, applying them, AGC linearisation,
//! EMVA 1288 photon transfer and MTF — thin wrappers over `gloam-calib`
//! (argument parsing, progress bars, output files). See docs/calibration.md.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::{Args, Subcommand, ValueEnum};

use gloam_calib::CalibError;
use gloam_calib::agc::{AgcOptions, agc_linearisation};
use gloam_calib::mtf_flow::{
    self, GrabberTarget, MtfRequest, VoltageRequest, measure_mtf, read_usaf_ctf, usaf_mtf,
    voltage_mtf,
};
use gloam_calib::ptc::{PtcOptions, photon_transfer};
use gloam_calib::radiance::{RadianceOptions, calibrate_radiance};
use gloam_calib::report;
use gloam_calib::rig_check::rig_mismatch;
use gloam_calib::source::{CalibrationSource, SourceFile, open_for_grabber};
use gloam_grabber::{FrameGrabber, OpenOptions};
use gloam_pipeline::{OutputSet, Provenance};

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
    /// Grabber URI: sim:PRESET_OR_RIG[?rig=R&seed=S&size=WxH], serial:PATH[?baud=N], usb:VID:PID[:SERIAL].
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
    #[arg(long)]
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
    #[arg(long, default_value_t = gloam_calib::radiance::DEFAULT_FRAMES)]
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
    /// Digital-count image (PNG or TIFF, 8/16-bit grey).
    pub input: PathBuf,
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
    #[arg(long, default_value_t = gloam_calib::agc::DEFAULT_FRAMES_PER_STEP)]
    pub frames: usize,
    /// A LUT (lut.json) to linearise the AGC frames through.
    #[arg(long)]
    pub lut: Option<PathBuf>,
    /// Report instead of failing when the AGC does not settle.
    #[arg(long)]
    pub allow_unsettled: bool,
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
    #[arg(long, default_value_t = gloam_calib::ptc::DEFAULT_GAIN)]
    pub gain: f64,
    /// Frames averaged for DSNU/PRNU.
    #[arg(long, default_value_t = gloam_calib::ptc::DEFAULT_SPATIAL_FRAMES)]
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
    #[arg(long, default_value_t = mtf_flow::DEFAULT_FRAMES)]
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

pub fn run(cmd: CalibrateCommand) -> anyhow::Result<()> {
    match cmd {
        CalibrateCommand::Radiance(a) => radiance(a),
        CalibrateCommand::Apply(a) => apply(a),
        CalibrateCommand::Agc(a) => agc(a),
        CalibrateCommand::Ptc(a) => ptc(a),
        CalibrateCommand::Mtf(a) => mtf(a),
    }
}

fn open_grabber(a: &GrabberArgs) -> anyhow::Result<Box<dyn FrameGrabber>> {
    let opts = OpenOptions {
        seed: a.seed,
        ..OpenOptions::default()
    };
    let mut g = gloam_pipeline::grabbers()
        .open(&a.grabber, &opts)
        .with_context(|| format!("opening {}", a.grabber))?;
    if let Some(e) = a.exposure_s {
        g.set_exposure_s(e)?;
    }
    eprintln!("grabber: {}", g.describe());
    Ok(g)
}

/// Opens the source; auto-ranges a sphere at `gain` (`None`: the camera's
/// current gain) when asked (`gloam_calib::source::open_for_grabber`).
fn open_source(
    a: &SourceArgs,
    g: &mut dyn FrameGrabber,
    gain: Option<f64>,
) -> anyhow::Result<Box<dyn CalibrationSource>> {
    let opened = open_for_grabber(&a.source, a.levels, a.auto_range, g, gain)?;
    if let (Some(top), Some(frac)) = (opened.auto_ranged_max_w_m2_sr, a.auto_range) {
        eprintln!(
            "auto-range: brightest level set to {:.4e} W m⁻² sr⁻¹ ({:.0} % of full scale at {})",
            top,
            100.0 * frac,
            gain.map_or("the camera's power-up gain".into(), |g| format!("gain {g}"))
        );
    }
    Ok(opened.source)
}

fn progress_bar(hidden: bool) -> indicatif::ProgressBar {
    if hidden || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(1);
    b.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} {msg} eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}

fn with_bar<T>(
    hidden: bool,
    msg: &str,
    f: impl FnOnce(&mut dyn FnMut(usize, usize)) -> Result<T, CalibError>,
) -> anyhow::Result<T> {
    let bar = progress_bar(hidden);
    bar.set_message(msg.to_string());
    let r = f(&mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    });
    bar.finish_and_clear();
    Ok(r?)
}

fn is_manual(a: &SourceArgs) -> bool {
    SourceFile::load(&a.source).is_ok_and(|f| f.is_manual())
}

fn radiance(a: RadianceArgs) -> anyhow::Result<()> {
    if a.gains.is_empty() {
        bail!("--gains needs at least one gain");
    }
    if let Some(g) = a.gains.iter().find(|g| !(g.is_finite() && **g > 0.0)) {
        bail!("--gains: {g} is not a gain (each must be a finite number > 0)");
    }
    let set = OutputSet::begin(&a.out, a.force, false)?;
    let mut g = open_grabber(&a.grabber)?;
    let top = a.gains.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let mut src = open_source(&a.source, g.as_mut(), Some(top))?;
    let opts = RadianceOptions {
        gains: a.gains.clone(),
        frames: a.frames,
        exposure_s: a.grabber.exposure_s,
        ..Default::default()
    };
    let lut = with_bar(is_manual(&a.source), "levels", |p| {
        calibrate_radiance(g.as_mut(), src.as_mut(), &opts, p)
    })?;
    report::write_radiance_report(set.dir(), &lut)?;
    publish(set, "lut.json")?;
    for c in &lut.gains {
        eprintln!(
            "gain {}: L = {:.6e}·DC + {:.6e} W m⁻² sr⁻¹ (R² {:.6}, {} points, DC {:.1}–{:.1})",
            c.gain,
            c.g_w_m2_sr_per_dn,
            c.b_w_m2_sr,
            c.r_squared,
            c.n_fit_points,
            c.fit_range_dn[0],
            c.fit_range_dn[1]
        );
        for w in &c.warnings {
            eprintln!("warning: gain {}: {w}", c.gain);
        }
    }
    eprintln!("wrote {}", a.out.join("lut.json").display());
    Ok(())
}

/// Adds the run's provenance to the set's main JSON and publishes the set.
fn publish(set: OutputSet, main_json: &str) -> anyhow::Result<()> {
    let provenance = Provenance::of_this_run();
    gloam_pipeline::output::add_provenance(&set.dir().join(main_json), &provenance)?;
    Ok(set.publish(&provenance, None)?)
}

fn apply(a: ApplyArgs) -> anyhow::Result<()> {
    let r = gloam_calib::apply::apply_lut_file(&a.lut, &a.input, &a.output, a.gain, &mut |w| {
        eprintln!("warning: {w}")
    })?;
    eprintln!(
        "wrote {} ({}×{}, gain {}{})",
        a.output.display(),
        r.width,
        r.height,
        r.gain,
        if r.saturated_pixels > 0 {
            format!(", {} saturated pixel(s) set to NaN", r.saturated_pixels)
        } else {
            String::new()
        }
    );
    Ok(())
}

fn agc(a: AgcArgs) -> anyhow::Result<()> {
    let lut = a
        .lut
        .as_deref()
        .map(gloam_calib::apply::load_lut)
        .transpose()?;
    let set = OutputSet::begin(&a.out, a.force, false)?;
    let mut g = open_grabber(&a.grabber)?;
    let mut src = open_source(&a.source, g.as_mut(), a.fixed_gain)?;
    let opts = AgcOptions {
        fixed_gain: a.fixed_gain,
        frames_per_step: a.frames,
        allow_unsettled: a.allow_unsettled,
        ..Default::default()
    };
    let r = with_bar(is_manual(&a.source), "steps", |p| {
        agc_linearisation(g.as_mut(), src.as_mut(), &opts, lut.as_ref(), p)
    })?;
    report::write_agc_report(set.dir(), &r)?;
    publish(set, "agc.json")?;
    eprintln!(
        "AGC: settled {}, max settling {} µs, overshoot {} %, hysteresis {:.3} %, linearity error {:.3} %",
        r.all_settled,
        r.max_settling_time_us
            .map_or("—".into(), |v| format!("{v:.0}")),
        r.max_overshoot_percent
            .map_or("—".into(), |v| format!("{v:.2}")),
        r.hysteresis_gain_percent,
        r.linearity_error_percent
    );
    eprintln!("wrote {}", a.out.join("agc.json").display());
    Ok(())
}

fn ptc(a: PtcArgs) -> anyhow::Result<()> {
    let set = OutputSet::begin(&a.out, a.force, false)?;
    let mut g = open_grabber(&a.grabber)?;
    let mut sa = a.source.clone();
    if sa.levels.is_none() {
        sa.levels = Some(gloam_calib::ptc::DEFAULT_LEVELS);
    }
    let mut src = open_source(&sa, g.as_mut(), Some(a.gain))?;
    if let Some(w) = rig_mismatch(&a.grabber.grabber, src.rig(), a.grabber.exposure_s) {
        eprintln!("warning: {w}");
    }
    let opts = PtcOptions {
        gain: a.gain,
        exposure_s: a.grabber.exposure_s,
        spatial_frames: a.spatial_frames,
        dataset_dir: Some(set.dir().join("emva1288")),
    };
    let r = with_bar(is_manual(&a.source), "levels", |p| {
        photon_transfer(g.as_mut(), src.as_mut(), &opts, p)
    })?;
    report::write_ptc_report(set.dir(), &r)?;
    publish(set, "ptc.json")?;
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "K = {:.5} DN/e⁻, dark noise {:.3} e⁻, saturation {:.0} e⁻, QE {}",
        r.system_gain_dn_per_e,
        r.dark_noise_e,
        r.saturation_capacity_e,
        r.quantum_efficiency
            .map_or("— (no [rig])".into(), |q| format!("{q:.4}"))
    );
    eprintln!("wrote {}", a.out.join("ptc.json").display());
    Ok(())
}

/// `--space voltage`: the scope flow on the sim: camera, the digital-count
/// sine flow through the grabber, and the analytic curves, in one report.
fn mtf_voltage(
    a: &MtfArgs,
    set: OutputSet,
    g: &mut dyn FrameGrabber,
    req: &MtfRequest,
    v: &VoltageRequest,
) -> anyhow::Result<()> {
    let bar = progress_bar(false);
    let r = voltage_mtf(g, req, v, &mut |phase, done, total| {
        bar.set_message(phase.to_string());
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    });
    bar.finish_and_clear();
    let r = r?;
    report::write_mtf_report(set.dir(), &r.curves, r.details)?;
    publish(set, "mtf.json")?;
    let (c, p) = (&r.curves, &r.voltage.points);
    for (i, f) in r.frequencies_cy_per_px.iter().enumerate() {
        eprintln!(
            "{f:.3} cy/px ({:.2} MHz, {:.2} lp/mm object): voltage {:.3}, digital {:.3}, analytic line {:.3}, digitised {:.3}",
            p[i].line_frequency_mhz,
            p[i].object_lp_per_mm,
            c[0].mtf[i],
            c[1].mtf[i],
            c[2].mtf[i],
            c[3].mtf[i]
        );
    }
    eprintln!("wrote {}", a.out.join("mtf.json").display());
    Ok(())
}

fn mtf(a: MtfArgs) -> anyhow::Result<()> {
    let set = OutputSet::begin(&a.out, a.force, false)?;
    let (curves, details) = match a.target {
        Target::Usaf => {
            let ctf_path = a.ctf.as_ref().context("--target usaf needs --ctf FILE")?;
            let pitch = a
                .pixel_pitch_um
                .context("--target usaf needs --pixel-pitch-um")?;
            usaf_mtf(read_usaf_ctf(ctf_path)?, pitch, a.magnification)?
        }
        Target::Sine | Target::Edge => {
            let uri = a
                .grabber
                .clone()
                .context("--target sine/edge needs --grabber")?;
            let ga = GrabberArgs {
                grabber: uri.clone(),
                seed: a.seed,
                exposure_s: None,
            };
            let mut g = open_grabber(&ga)?;
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
                anyhow::ensure!(
                    req.target == GrabberTarget::Sine,
                    "--space voltage reads sine patterns: use --target sine"
                );
                let v = VoltageRequest {
                    uri,
                    seed: a.seed,
                    scope_rows: a.scope_rows.clone(),
                    magnification: a.magnification,
                };
                return mtf_voltage(&a, set, g.as_mut(), &req, &v);
            }
            let msg = match req.target {
                GrabberTarget::Sine => "targets",
                GrabberTarget::Edge => "edge",
            };
            let m = with_bar(false, msg, |p| measure_mtf(g.as_mut(), &req, p))?;
            let details = serde_json::json!({
                "mean_radiance_w_m2_sr": m.mean_radiance_w_m2_sr,
                "grabber": g.describe(),
            });
            (vec![m.curve], details)
        }
    };
    report::write_mtf_report(set.dir(), &curves, details)?;
    publish(set, "mtf.json")?;
    let c = &curves[0];
    eprintln!(
        "{}: MTF50 {} cy/px, MTF10 {} cy/px",
        c.method,
        c.mtf50.map_or("—".into(), |v| format!("{v:.4}")),
        c.mtf10.map_or("—".into(), |v| format!("{v:.4}"))
    );
    eprintln!("wrote {}", a.out.join("mtf.json").display());
    Ok(())
}
