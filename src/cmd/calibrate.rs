//! `gloam calibrate …`: radiance LUTs, applying them, AGC linearisation,
//! EMVA 1288 photon transfer and MTF — thin wrappers over `gloam-calib`
//! (argument parsing, progress bars, output files). See docs/calibration.md.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, Subcommand, ValueEnum};

use gloam_calib::CalibError;
use gloam_calib::agc::{AgcOptions, agc_linearisation};
use gloam_calib::capture::auto_range;
use gloam_calib::mtf::{
    EdgeOptions, MtfCurve, SineOptions, coltman_sine_from_square_samples, edge_mtf, sine_mtf,
    usaf_lp_per_mm,
};
use gloam_calib::ptc::{PtcOptions, photon_transfer};
use gloam_calib::radiance::{Lut, RadianceOptions, calibrate_radiance};
use gloam_calib::report;
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
    #[arg(long, default_value_t = 8)]
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
    #[arg(long, default_value_t = 60)]
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
    #[arg(long, default_value_t = 1.0)]
    pub gain: f64,
    /// Frames averaged for DSNU/PRNU.
    #[arg(long, default_value_t = 16)]
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
    #[arg(long, default_value_t = 0.8)]
    pub modulation: f64,
    /// Target angle, degrees (sine: from the row axis, default 0; edge: from the column axis, default 5).
    #[arg(long)]
    pub angle_deg: Option<f64>,
    /// Sine frequencies, cycles/pixel, comma-separated (default 0.02…0.48 step 0.02).
    #[arg(long, value_delimiter = ',')]
    pub frequencies: Vec<f64>,
    /// Frames averaged per target.
    #[arg(long, default_value_t = 8)]
    pub frames: usize,
    /// Relative spectrum of the targets (built-in name).
    #[arg(long, default_value = "cie-a")]
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
    set.publish(&provenance, None)
}

fn load_lut(path: &Path) -> anyhow::Result<Lut> {
    let text = gloam_spectra::input::read_text(path, gloam_spectra::input::MAX_TEXT_FILE_BYTES)
        .with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a gloam LUT", path.display()))
}

fn apply(a: ApplyArgs) -> anyhow::Result<()> {
    let lut = load_lut(&a.lut)?;
    let record = gloam_calib::io::frame_record(&a.input)?;
    let jl = a
        .input
        .parent()
        .unwrap_or(Path::new("."))
        .join("frames.jsonl");
    let recorded_gain = record
        .as_ref()
        .and_then(|(line, v)| Some((*line, v.get("gain")?.as_f64()?)));
    let gain = match (a.gain, recorded_gain) {
        (Some(g), Some((line, r))) if (g - r).abs() > 1e-6 * r.abs().max(1e-12) => bail!(
            "--gain {g}: {}:{line} records gain {r} for {}; the frame was not taken at gain {g} (omit --gain to use the recorded gain)",
            jl.display(),
            a.input.display()
        ),
        (Some(g), _) => g,
        (None, Some((_, r))) => r,
        (None, None) => gloam_calib::io::gain_from_frames_jsonl(&a.input)?,
    };
    let (w, h, px) = gloam_calib::io::read_counts(&a.input)?;
    check_lut_fits_frame(&lut, &a.lut, &a.input, record.as_ref(), &px)?;
    let out = lut.apply(gain, &px)?;
    gloam_calib::io::write_tiff_f32(&a.output, w, h, &out)?;
    let nan = out.iter().filter(|v| v.is_nan()).count();
    eprintln!(
        "wrote {} ({w}×{h}, gain {gain}{})",
        a.output.display(),
        if nan > 0 {
            format!(", {nan} saturated pixel(s) set to NaN")
        } else {
            String::new()
        }
    );
    Ok(())
}

/// The camera in a grabber's description, without the scene, rig, seed or
/// firmware details: `simulated gen3 looking at rig …` → `simulated gen3`.
fn camera_identity(described: &str) -> &str {
    let cut = [" looking at ", " ("]
        .iter()
        .filter_map(|m| described.find(m))
        .min()
        .unwrap_or(described.len());
    described[..cut].trim()
}

/// Refuses a LUT made for another camera or bit depth than the frame's
/// (from `camera.json` and `frames.jsonl` beside the frame), or a frame
/// holding counts above the LUT's digitizer maximum. A frame with no
/// record beside it can be checked only by its counts: a warning says so.
fn check_lut_fits_frame(
    lut: &Lut,
    lut_path: &Path,
    frame: &Path,
    record: Option<&(usize, serde_json::Value)>,
    px: &[u16],
) -> anyhow::Result<()> {
    let dir = frame.parent().unwrap_or(Path::new("."));
    let jl = dir.join("frames.jsonl");
    let cam_file = dir.join(super::capture::CAMERA_FILE);
    let lut_camera = camera_identity(&lut.grabber);
    let mut unchecked = Vec::new();
    if cam_file.is_file() {
        let text =
            gloam_spectra::input::read_text(&cam_file, gloam_spectra::input::MAX_TEXT_FILE_BYTES)
                .with_context(|| format!("reading {}", cam_file.display()))?;
        let v: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a gloam camera record", cam_file.display()))?;
        let camera = v
            .get("camera")
            .and_then(|c| c.as_str())
            .with_context(|| format!("{}: no \"camera\"", cam_file.display()))?;
        if camera_identity(camera) != lut_camera {
            bail!(
                "{}: made with camera '{lut_camera}', but {} was captured with '{}' ({}); calibrate that camera, or apply its own LUT",
                lut_path.display(),
                frame.display(),
                camera_identity(camera),
                cam_file.display()
            );
        }
    } else {
        unchecked.push("camera");
    }
    let lut_max = lut.digitizer_max_dn;
    match record.and_then(|(line, v)| Some((*line, v.get("bits")?.as_u64()?))) {
        Some((line, bits)) if lut_max > 0.0 => {
            let frame_max = 2f64.powi(bits.min(32) as i32) - 1.0;
            if frame_max != lut_max {
                bail!(
                    "{}: made for a digitizer whose top code is {lut_max} DN, but {}:{line} records {} as {bits}-bit (top code {frame_max} DN); apply a LUT of this bit depth",
                    lut_path.display(),
                    jl.display(),
                    frame.display()
                );
            }
        }
        _ => unchecked.push("bit depth"),
    }
    if lut_max > 0.0
        && let Some(&top) = px.iter().max()
        && f64::from(top) > lut_max
    {
        bail!(
            "{}: holds {top} DN, above the top code {lut_max} DN of the camera {} was made for; the frame is from another camera or bit depth",
            frame.display(),
            lut_path.display()
        );
    }
    if !unchecked.is_empty() {
        eprintln!(
            "warning: {}: no {} beside it, so its {} cannot be checked against {}",
            frame.display(),
            if record.is_none() {
                "frames.jsonl line or camera.json"
            } else {
                "camera.json"
            },
            unchecked.join(" and "),
            lut_path.display()
        );
    }
    Ok(())
}

fn agc(a: AgcArgs) -> anyhow::Result<()> {
    let lut = a.lut.as_deref().map(load_lut).transpose()?;
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
        sa.levels = Some(50);
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

/// For a simulated camera: how far the source's `[rig]` photon count is
/// from what that camera receives (its own lens, pixel and exposure), as a
/// warning naming the QE bias; `None` when they agree within 0.1 % or the
/// grabber is not simulated.
fn rig_mismatch(
    uri: &str,
    rig: Option<&gloam_calib::source::Rig>,
    exposure_s: Option<f64>,
) -> Option<String> {
    let rig = rig?;
    let gloam_grabber::GrabberUri::Sim { preset, .. } =
        gloam_grabber::GrabberUri::parse(uri).ok()?
    else {
        return None;
    };
    let mut cfg = gloam_sensor::load_preset_or_file(&preset).ok()?;
    if let Some(e) = exposure_s {
        cfg.timing.exposure_s = e;
    }
    let cam = gloam_calib::source::Rig::from_camera(&cfg, &preset).ok()?;
    let photons = |r: &gloam_calib::source::Rig| {
        (r.pixel_pitch_um * 1e-6).powi(2) * r.exposure_s * r.irradiance_factor()
    };
    let ratio = photons(rig) / photons(&cam);
    ((ratio - 1.0).abs() > 1e-3).then(|| {
        format!(
            "the source's [rig] (pitch {} µm, f/{}, τ {}, {} s) counts {:.2} % {} photons than the simulated '{preset}' receives (pitch {:.4} µm, f/{}, τ {}, {} s): its QE will read {:.2} % {}; use camera = \"{preset}\" in [rig]",
            rig.pixel_pitch_um,
            rig.f_number,
            rig.optics_transmission,
            rig.exposure_s,
            100.0 * (ratio - 1.0).abs(),
            if ratio > 1.0 { "more" } else { "fewer" },
            cam.pixel_pitch_um,
            cam.f_number,
            cam.optics_transmission,
            cam.exposure_s,
            100.0 * (1.0 / ratio - 1.0).abs(),
            if ratio > 1.0 { "low" } else { "high" },
        )
    })
}

fn read_usaf_ctf(path: &Path) -> anyhow::Result<Vec<(i32, i32, f64)>> {
    let text = gloam_spectra::input::read_text(path, gloam_spectra::input::MAX_TEXT_FILE_BYTES)
        .with_context(|| format!("reading {}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l
            .split([',', ';', '\t', ' '])
            .filter(|s| !s.is_empty())
            .collect();
        let parsed = (|| -> Option<(i32, i32, f64)> {
            if f.len() != 3 {
                return None;
            }
            Some((f[0].parse().ok()?, f[1].parse().ok()?, f[2].parse().ok()?))
        })();
        match parsed {
            Some((g, e, m)) if (1..=6).contains(&e) && m.is_finite() => out.push((g, e, m)),
            Some(_) => bail!(
                "{}:{}: element must be 1–6 and the modulation finite",
                path.display(),
                i + 1
            ),
            None if out.is_empty() => continue, // header
            None => bail!(
                "{}:{}: expected 'group,element,modulation'",
                path.display(),
                i + 1
            ),
        }
    }
    if out.is_empty() {
        bail!("{}: no 'group,element,modulation' rows", path.display());
    }
    Ok(out)
}

/// `--space voltage`: the scope flow on the sim: camera, the digital-count
/// sine flow through the grabber, and the analytic curves, in one report.
fn mtf_voltage(a: &MtfArgs, set: OutputSet, g: &mut dyn FrameGrabber) -> anyhow::Result<()> {
    use gloam_calib::mtf_voltage::{VoltageOptions, analytic_curves, voltage_sine_mtf};
    let uri = a.grabber.as_deref().unwrap_or_default();
    let (preset, _, seed, size) = gloam_calib::scope_run::sim_uri(uri)?;
    let size = size.unwrap_or(gloam_simcam::DEFAULT_RIG_SIZE);
    let mut cfg = gloam_sensor::SensorConfig::load_preset_or_file(&preset)?;
    cfg.noise.seed = a.seed.unwrap_or(seed);
    let mut cam = gloam_sensor::Camera::new(cfg)?;
    let gain = a.gain.unwrap_or(cam.chain().reference_gain);
    cam.set_override_gain(Some(gain))?;
    g.set_gain(gain)?;
    let level = match a.radiance {
        Some(l) => l,
        None => auto_range(g, &a.spectrum, 0.4)?,
    };
    let freqs = if a.frequencies.is_empty() {
        (1..=12).map(|i| 0.04 * i as f64).collect()
    } else {
        a.frequencies.clone()
    };
    let rows = if a.scope_rows.is_empty() {
        let m = size.1 as usize / 2;
        (m.saturating_sub(2)..(m + 2).min(size.1 as usize)).collect()
    } else {
        a.scope_rows.clone()
    };
    let vo = VoltageOptions {
        frequencies_cy_per_px: freqs.clone(),
        mean_radiance_w_m2_sr: level,
        modulation: a.modulation,
        spectrum: a.spectrum.clone(),
        frames: a.frames,
        rows,
        magnification: a.magnification,
        size,
    };
    let v = with_bar(false, "scope", |p| voltage_sine_mtf(&mut cam, &vo, p))?;
    let so = SineOptions {
        frequencies_cy_per_px: freqs.clone(),
        mean_radiance_w_m2_sr: level,
        modulation: a.modulation,
        angle_deg: 0.0,
        spectrum: a.spectrum.clone(),
        frames: a.frames,
    };
    let mut digital = with_bar(false, "targets", |p| sine_mtf(g, &so, p))?;
    digital.method = "digital count (sine)".into();
    let mut curves = vec![v.curve.clone(), digital];
    curves.extend(analytic_curves(&cam, &freqs, gain, size.0 as usize));
    let details = serde_json::json!({
        "space": "voltage",
        "mean_radiance_w_m2_sr": level,
        "gain": gain,
        "grabber": g.describe(),
        "pixel_clock_hz": v.pixel_clock_hz,
        "video_bandwidth_hz": cam.chain().amplifier().map(|x| x.bandwidth_hz),
        "magnification": a.magnification,
        "grey_scale_reflectance_volts": v.grey_scale,
        "voltage_points": v.points,
    });
    report::write_mtf_report(set.dir(), &curves, details)?;
    publish(set, "mtf.json")?;
    for (i, f) in freqs.iter().enumerate() {
        eprintln!(
            "{f:.3} cy/px ({:.2} MHz, {:.2} lp/mm object): voltage {:.3}, digital {:.3}, analytic line {:.3}, digitised {:.3}",
            v.points[i].line_frequency_mhz,
            v.points[i].object_lp_per_mm,
            curves[0].mtf[i],
            curves[1].mtf[i],
            curves[2].mtf[i],
            curves[3].mtf[i]
        );
    }
    eprintln!("wrote {}", a.out.join("mtf.json").display());
    Ok(())
}

fn mtf(a: MtfArgs) -> anyhow::Result<()> {
    let set = OutputSet::begin(&a.out, a.force, false)?;
    let hidden = false;
    let (curves, details) = match a.target {
        Target::Usaf => {
            let ctf_path = a.ctf.as_ref().context("--target usaf needs --ctf FILE")?;
            let pitch = a
                .pixel_pitch_um
                .context("--target usaf needs --pixel-pitch-um")?;
            let mut rows = read_usaf_ctf(ctf_path)?;
            rows.sort_by(|x, y| usaf_lp_per_mm(x.0, x.1).total_cmp(&usaf_lp_per_mm(y.0, y.1)));
            // Chart lp/mm → image cycles per pixel.
            let f: Vec<f64> = rows
                .iter()
                .map(|r| usaf_lp_per_mm(r.0, r.1) / a.magnification * pitch * 1e-3)
                .collect();
            let c: Vec<f64> = rows.iter().map(|r| r.2).collect();
            let m = coltman_sine_from_square_samples(&f, &c)?;
            let details = serde_json::json!({
                "usaf": rows.iter().zip(&f).map(|(r, fp)| serde_json::json!({
                    "group": r.0, "element": r.1, "lp_per_mm": usaf_lp_per_mm(r.0, r.1),
                    "cycles_per_pixel": fp, "square_wave_modulation": r.2,
                })).collect::<Vec<_>>(),
            });
            (
                vec![
                    MtfCurve::new("usaf-coltman", f.clone(), m),
                    MtfCurve::new("usaf-square-wave", f, c),
                ],
                details,
            )
        }
        Target::Sine | Target::Edge => {
            let uri = a
                .grabber
                .clone()
                .context("--target sine/edge needs --grabber")?;
            let ga = GrabberArgs {
                grabber: uri,
                seed: a.seed,
                exposure_s: None,
            };
            let mut g = open_grabber(&ga)?;
            gloam_calib::capture::agc_off(g.as_mut())?;
            if let Some(gain) = a.gain {
                g.set_gain(gain)?;
            }
            if a.space == Space::Voltage {
                anyhow::ensure!(
                    matches!(a.target, Target::Sine),
                    "--space voltage reads sine patterns: use --target sine"
                );
                return mtf_voltage(&a, set, g.as_mut());
            }
            let level = match a.radiance {
                Some(l) => l,
                None => auto_range(g.as_mut(), &a.spectrum, 0.4)?,
            };
            let curve = if matches!(a.target, Target::Sine) {
                let freqs = if a.frequencies.is_empty() {
                    (1..=24).map(|i| 0.02 * i as f64).collect()
                } else {
                    a.frequencies.clone()
                };
                let o = SineOptions {
                    frequencies_cy_per_px: freqs,
                    mean_radiance_w_m2_sr: level,
                    modulation: a.modulation,
                    angle_deg: a.angle_deg.unwrap_or(0.0),
                    spectrum: a.spectrum.clone(),
                    frames: a.frames,
                };
                with_bar(hidden, "targets", |p| sine_mtf(g.as_mut(), &o, p))?
            } else {
                let o = EdgeOptions {
                    dark_radiance_w_m2_sr: level * 0.2,
                    bright_radiance_w_m2_sr: level * 1.8,
                    angle_deg: a.angle_deg.unwrap_or(5.0),
                    spectrum: a.spectrum.clone(),
                    frames: a.frames,
                };
                with_bar(hidden, "edge", |p| edge_mtf(g.as_mut(), &o, p))?
            };
            (
                vec![curve],
                serde_json::json!({ "mean_radiance_w_m2_sr": level, "grabber": g.describe() }),
            )
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
