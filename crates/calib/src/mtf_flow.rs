//! The MTF measurements as `gloam calibrate mtf` and Python's `gloam.mtf`
//! run them, with their defaults in one place so the two front ends cannot
//! drift: sine targets and the slanted edge through any grabber, USAF 1951
//! bar contrasts read from a CTF file, and the voltage-space flow on a
//! simulated camera's video line.

use std::path::{Path, PathBuf};

use gloam_grabber::FrameGrabber;
use serde::Serialize;

use crate::capture::{agc_off, auto_range};
use crate::error::CalibError;
use crate::mtf::{
    EdgeOptions, MtfCurve, SineOptions, coltman_sine_from_square_samples, edge_mtf, sine_mtf,
    usaf_lp_per_mm,
};
use crate::mtf_voltage::{VoltageMtf, VoltageOptions, analytic_curves, voltage_sine_mtf};

/// Auto-ranged mean target radiance, as a fraction of full scale above
/// dark: mid-scale leaves room for the bright half of a sine or edge.
pub const AUTO_RANGE_FRACTION: f64 = 0.4;
/// Sine modulation in radiance.
pub const DEFAULT_MODULATION: f64 = 0.8;
/// Frames averaged per target.
pub const DEFAULT_FRAMES: usize = 8;
/// Relative spectrum of the targets (a built-in name).
pub const DEFAULT_SPECTRUM: &str = "cie-a";
/// Sine targets are at 0° to the row axis unless asked otherwise.
pub const DEFAULT_SINE_ANGLE_DEG: f64 = 0.0;
/// The slanted edge's angle from the column axis (ISO 12233 asks for a few
/// degrees so the edge samples every sub-pixel phase).
pub const DEFAULT_EDGE_ANGLE_DEG: f64 = 5.0;
/// Edge dark and bright sides, as multiples of the mean radiance.
pub const EDGE_DARK_FACTOR: f64 = 0.2;
pub const EDGE_BRIGHT_FACTOR: f64 = 1.8;

/// Which pattern the grabber is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GrabberTarget {
    /// Sine targets (`Stimulus::Sine`), read in digital counts.
    Sine,
    /// ISO 12233 slanted edge.
    Edge,
}

/// An MTF measurement through a grabber. `None` and empty fields take the
/// defaults above; [`Default`] is what both front ends start from.
#[derive(Clone, Debug)]
pub struct MtfRequest {
    pub target: GrabberTarget,
    /// Fixed gain (AGC off either way); `None` leaves the camera's gain.
    pub gain: Option<f64>,
    /// Mean target radiance, W m⁻² sr⁻¹; `None`: auto-ranged to
    /// [`AUTO_RANGE_FRACTION`] of full scale (simulated cameras only).
    pub radiance_w_m2_sr: Option<f64>,
    pub modulation: f64,
    /// `None`: [`DEFAULT_SINE_ANGLE_DEG`] or [`DEFAULT_EDGE_ANGLE_DEG`].
    pub angle_deg: Option<f64>,
    /// Empty: [`default_sine_frequencies`] (or, in voltage space,
    /// [`default_voltage_frequencies`]).
    pub frequencies_cy_per_px: Vec<f64>,
    pub frames: usize,
    pub spectrum: String,
}

impl Default for MtfRequest {
    fn default() -> Self {
        Self {
            target: GrabberTarget::Edge,
            gain: None,
            radiance_w_m2_sr: None,
            modulation: DEFAULT_MODULATION,
            angle_deg: None,
            frequencies_cy_per_px: Vec::new(),
            frames: DEFAULT_FRAMES,
            spectrum: DEFAULT_SPECTRUM.to_string(),
        }
    }
}

/// Sine frequencies in digital counts: 0.02 … 0.48 cy/px in steps of 0.02.
pub fn default_sine_frequencies() -> Vec<f64> {
    (1..=24).map(|i| 0.02 * i as f64).collect()
}

/// Sine frequencies in voltage space: 0.04 … 0.48 cy/px in steps of 0.04
/// (each point scopes every row, so half as many).
pub fn default_voltage_frequencies() -> Vec<f64> {
    (1..=12).map(|i| 0.04 * i as f64).collect()
}

/// The four middle rows of a frame `height` rows tall (fewer when it is
/// smaller): what the scope isolates unless told otherwise.
pub fn default_scope_rows(height: u32) -> Vec<usize> {
    let m = height as usize / 2;
    (m.saturating_sub(2)..(m + 2).min(height as usize)).collect()
}

/// A measured curve and the mean radiance it was measured at.
#[derive(Clone, Debug)]
pub struct MtfMeasurement {
    pub curve: MtfCurve,
    pub mean_radiance_w_m2_sr: f64,
}

/// Turns AGC off, applies the fixed gain and finds the mean radiance
/// (given, or auto-ranged).
fn prepare(g: &mut dyn FrameGrabber, req: &MtfRequest) -> Result<(), CalibError> {
    agc_off(g)?;
    if let Some(gain) = req.gain {
        g.set_gain(gain)?;
    }
    Ok(())
}

fn mean_radiance(g: &mut dyn FrameGrabber, req: &MtfRequest) -> Result<f64, CalibError> {
    match req.radiance_w_m2_sr {
        Some(l) => Ok(l),
        None => auto_range(g, &req.spectrum, AUTO_RANGE_FRACTION),
    }
}

/// Sine-target or slanted-edge MTF through `g` with `req`'s settings and
/// the defaults for what it leaves open.
pub fn measure_mtf(
    g: &mut dyn FrameGrabber,
    req: &MtfRequest,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<MtfMeasurement, CalibError> {
    if req.target == GrabberTarget::Sine {
        check_sine_frequencies(&req.frequencies_cy_per_px)?;
    }
    check_target_settings(req)?;
    prepare(g, req)?;
    let level = mean_radiance(g, req)?;
    let curve = match req.target {
        GrabberTarget::Sine => {
            let o = SineOptions {
                frequencies_cy_per_px: if req.frequencies_cy_per_px.is_empty() {
                    default_sine_frequencies()
                } else {
                    req.frequencies_cy_per_px.clone()
                },
                mean_radiance_w_m2_sr: level,
                modulation: req.modulation,
                angle_deg: req.angle_deg.unwrap_or(DEFAULT_SINE_ANGLE_DEG),
                spectrum: req.spectrum.clone(),
                frames: req.frames,
            };
            sine_mtf(g, &o, progress)?
        }
        GrabberTarget::Edge => {
            let o = EdgeOptions {
                dark_radiance_w_m2_sr: level * EDGE_DARK_FACTOR,
                bright_radiance_w_m2_sr: level * EDGE_BRIGHT_FACTOR,
                angle_deg: req.angle_deg.unwrap_or(DEFAULT_EDGE_ANGLE_DEG),
                spectrum: req.spectrum.clone(),
                frames: req.frames,
            };
            edge_mtf(g, &o, progress)?
        }
    };
    Ok(MtfMeasurement {
        curve,
        mean_radiance_w_m2_sr: level,
    })
}

/// The voltage-space settings beyond [`MtfRequest`].
#[derive(Clone, Debug)]
pub struct VoltageRequest {
    /// The `sim:` grabber URI the camera is modelled from.
    pub uri: String,
    /// Noise seed; `None`: the URI's.
    pub seed: Option<u64>,
    /// Frame rows the scope isolates; empty: [`default_scope_rows`].
    pub scope_rows: Vec<usize>,
    /// Optical magnification, image size / chart size.
    pub magnification: f64,
}

/// The voltage-space report: curves (voltage, digital counts, then the
/// chain's analytic line and digitised MTF), the scope's points and the
/// `details` block of `mtf.json`.
#[derive(Clone, Debug)]
pub struct VoltageReport {
    pub curves: Vec<MtfCurve>,
    pub voltage: VoltageMtf,
    pub frequencies_cy_per_px: Vec<f64>,
    pub details: MtfDetails,
}

/// The `details` block of `mtf.json`: how the flow that made the curves
/// measured (one shape per flow, told apart by their keys).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum MtfDetails {
    /// `--space voltage`: the scope's measurement beside the digital flow.
    Voltage(Box<VoltageDetails>),
    /// `--target usaf`: each bar's chart and image frequency.
    Usaf { usaf: Vec<UsafRow> },
    /// `--target sine/edge` in digital counts.
    Digital {
        mean_radiance_w_m2_sr: f64,
        grabber: String,
    },
}

/// The voltage-space flow's `details`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VoltageDetails {
    /// Always `"voltage"`.
    pub space: &'static str,
    pub mean_radiance_w_m2_sr: f64,
    pub gain: f64,
    pub grabber: String,
    pub pixel_clock_hz: f64,
    /// The video amplifier's bandwidth; None for a chain without one.
    pub video_bandwidth_hz: Option<f64>,
    /// Image size / chart size.
    pub magnification: f64,
    /// (reflectance, volts) of the grey scale the scope read.
    pub grey_scale_reflectance_volts: Vec<(f64, f64)>,
    pub voltage_points: Vec<crate::mtf_voltage::VoltagePoint>,
}

/// One USAF bar in `details.usaf`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct UsafRow {
    pub group: i32,
    pub element: i32,
    pub lp_per_mm: f64,
    pub cycles_per_pixel: f64,
    pub square_wave_modulation: f64,
}

/// Sine MTF in voltage space (the scope on a simulated camera modelled
/// from `v.uri`) beside the digital-count sine flow through `g` on the same
/// camera and the chain's analytic MTF. `progress` gets the phase
/// (`"scope"`, then `"targets"`), done and total.
pub fn voltage_mtf(
    g: &mut dyn FrameGrabber,
    req: &MtfRequest,
    v: &VoltageRequest,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<VoltageReport, CalibError> {
    check_sine_frequencies(&req.frequencies_cy_per_px)?;
    prepare(g, req)?;
    let (preset, _, seed, size) = crate::scope_run::sim_uri(&v.uri)?;
    let size = size.unwrap_or(gloam_simcam::DEFAULT_RIG_SIZE);
    // The grabber's open noted a sensor file; this is the same one again.
    let mut cfg =
        gloam_sensor::SensorConfig::load_preset_or_file(&preset, &gloam_io::ReadLog::off())?;
    cfg.noise.seed = v.seed.unwrap_or(seed);
    let mut cam = gloam_sensor::Camera::new(cfg)?;
    // Before the grabber captures anything: the scope's frame must fit the
    // format's picture lines (`size=768x576` was refused after the
    // mean radiance's frames, with no word of the URI).
    if let Some(t) = cam.chain().line_timing() {
        let from = crate::scope_run::SizeFrom::Uri(v.uri.clone());
        crate::scope_run::check_frame_fits(t.format, size, &from)?;
    }
    let gain = req.gain.unwrap_or(cam.chain().reference_gain);
    cam.set_override_gain(Some(gain))?;
    g.set_gain(gain)?;
    let level = mean_radiance(g, req)?;
    let freqs = if req.frequencies_cy_per_px.is_empty() {
        default_voltage_frequencies()
    } else {
        req.frequencies_cy_per_px.clone()
    };
    let rows = if v.scope_rows.is_empty() {
        default_scope_rows(size.1)
    } else {
        v.scope_rows.clone()
    };
    let vo = VoltageOptions {
        frequencies_cy_per_px: freqs.clone(),
        mean_radiance_w_m2_sr: level,
        modulation: req.modulation,
        spectrum: req.spectrum.clone(),
        frames: req.frames,
        rows,
        magnification: v.magnification,
        size,
    };
    let voltage = voltage_sine_mtf(&mut cam, &vo, &mut |d, t| progress("scope", d, t))?;
    let so = SineOptions {
        frequencies_cy_per_px: freqs.clone(),
        mean_radiance_w_m2_sr: level,
        modulation: req.modulation,
        angle_deg: DEFAULT_SINE_ANGLE_DEG,
        spectrum: req.spectrum.clone(),
        frames: req.frames,
    };
    let mut digital = sine_mtf(g, &so, &mut |d, t| progress("targets", d, t))?;
    digital.method = "digital count (sine)".into();
    let mut curves = vec![voltage.curve.clone(), digital];
    curves.extend(analytic_curves(&cam, &freqs, gain, size.0 as usize));
    let details = MtfDetails::Voltage(Box::new(VoltageDetails {
        space: "voltage",
        mean_radiance_w_m2_sr: level,
        gain,
        grabber: g.describe(),
        pixel_clock_hz: voltage.pixel_clock_hz,
        video_bandwidth_hz: cam.chain().amplifier().map(|x| x.bandwidth_hz),
        magnification: v.magnification,
        grey_scale_reflectance_volts: voltage.grey_scale.clone(),
        voltage_points: voltage.points.clone(),
    }));
    Ok(VoltageReport {
        curves,
        voltage,
        frequencies_cy_per_px: freqs,
        details,
    })
}

/// One measured USAF 1951 bar contrast.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct UsafBar {
    pub group: i32,
    /// 1 … 6.
    pub element: i32,
    /// Measured square-wave (bar) modulation.
    pub modulation: f64,
    /// Its 1-based line in the CTF file (0: not from a file).
    #[serde(skip)]
    pub line: usize,
}

/// The groups of a real USAF 1951 chart: −2 (0.25 lp/mm) on the large
/// targets to 11 (≈ 3650 lp/mm, element 6) on the finest high-resolution
/// glass targets. A group outside is a typo, not a chart (group 100 would
/// be 10³⁰ lp/mm).
pub const USAF_GROUPS: std::ops::RangeInclusive<i32> = -2..=11;
/// Nyquist frequency, cycles per pixel: a target above it aliases onto a
/// lower frequency, and its modulation is not the MTF there.
pub const NYQUIST_CY_PER_PX: f64 = 0.5;
/// Most an MTF value is taken to be: 1 plus measurement noise. A Coltman
/// result above it (or below 0) means bar contrasts no imaging system gives.
pub const MAX_MTF: f64 = 1.05;

/// Refuses sine frequencies outside (0, Nyquist]: above 0.5 cycles/pixel
/// a target aliases and its modulation is not the MTF at its frequency.
/// 0.5 itself is accepted (at 0° its sine's phase cannot be measured and
/// the fit says so; tilt it with `--angle-deg`).
pub fn check_sine_frequencies(f: &[f64]) -> Result<(), CalibError> {
    if f.len() > MAX_SINE_FREQUENCIES {
        return Err(CalibError::Usage(format!(
            "--frequencies: {} frequencies, at most {MAX_SINE_FREQUENCIES} (each is a target shown and captured)",
            f.len()
        )));
    }
    for (i, &x) in f.iter().enumerate() {
        if !(x > 0.0 && x <= NYQUIST_CY_PER_PX) {
            return Err(CalibError::Usage(format!(
                "--frequencies {x}: a sine target's frequency must lie in (0, {NYQUIST_CY_PER_PX}] cycles/pixel; above Nyquist it aliases onto a lower frequency, so its modulation is not MTF"
            )));
        }
        // A curve with two points at one frequency has no slope there.
        if f[..i].contains(&x) {
            return Err(CalibError::Usage(format!(
                "--frequencies {x}: given twice; an MTF curve has one point per frequency"
            )));
        }
    }
    Ok(())
}

/// Most sine targets one measurement shows (`--frequencies`).
pub const MAX_SINE_FREQUENCIES: usize = 256;

/// The steepest slanted edge the analysis reads, degrees from the column
/// axis.
pub const MAX_EDGE_ANGLE_DEG: f64 = 30.0;

/// The settings that need no camera: an angle the target can be drawn at
/// (a slanted edge within [`MAX_EDGE_ANGLE_DEG`]) and a mean radiance a
/// target can have.
pub fn check_target_settings(req: &MtfRequest) -> Result<(), CalibError> {
    if let Some(a) = req.angle_deg
        && !(a.is_finite() && a.abs() <= 90.0)
    {
        return Err(CalibError::Usage(format!(
            "--angle-deg {a}: the target's tilt must be a finite angle within ±90°"
        )));
    }
    // The edge analysis projects along a near-vertical edge: at 60° it
    // gave MTF50 0.04 cy/px (5°: 0.47), at 45° 0.36, each exit 0.
    if let (GrabberTarget::Edge, Some(a)) = (req.target, req.angle_deg)
        && a.abs() > MAX_EDGE_ANGLE_DEG
    {
        return Err(CalibError::Usage(format!(
            "--angle-deg {a}: a slanted edge must lie within {MAX_EDGE_ANGLE_DEG}° of the column axis (either way; ISO 12233 uses about 5°)"
        )));
    }
    if let Some(l) = req.radiance_w_m2_sr
        && !(l.is_finite() && l > 0.0 && l <= crate::radiance::MAX_LUT_RADIANCE_W_M2_SR)
    {
        return Err(CalibError::Usage(format!(
            "--radiance {l}: the mean target radiance must be a finite number in (0, 1e20] W m⁻² sr⁻¹"
        )));
    }
    Ok(())
}

/// Parses a CTF file's text: rows of `group,element,modulation` (commas,
/// semicolons, tabs or spaces), `#` comments and blank lines skipped, and
/// one header line (no field a number) before the first row. Every other
/// line must be a row: one that does not parse is an error naming its
/// line, never skipped. A group outside the chart's [`USAF_GROUPS`], an
/// element outside 1–6 or a bar modulation outside [0, 1] (a contrast
/// (max − min)/(max + min)) is refused at its line. `path` names the file
/// in errors.
pub fn parse_usaf_ctf(text: &str, path: &Path) -> Result<Vec<UsafBar>, CalibError> {
    let mut out = Vec::new();
    let mut content_lines = 0;
    for (i, line) in text.lines().enumerate() {
        let l = line.trim().trim_start_matches('\u{feff}');
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        content_lines += 1;
        let f: Vec<&str> = l
            .split([',', ';', '\t', ' '])
            .filter(|s| !s.is_empty())
            .collect();
        let at = |message: String| CalibError::Line {
            path: path.to_path_buf(),
            line: i + 1,
            message,
        };
        let header = content_lines == 1 && f.iter().all(|x| x.parse::<f64>().is_err());
        if header {
            continue;
        }
        let parsed = (|| -> Option<(i32, i32, f64)> {
            if f.len() != 3 {
                return None;
            }
            Some((f[0].parse().ok()?, f[1].parse().ok()?, f[2].parse().ok()?))
        })();
        let Some((group, element, modulation)) = parsed else {
            return Err(at(format!(
                "'{l}' is not a 'group,element,modulation' row (whole group and element, numeric modulation)"
            )));
        };
        if !USAF_GROUPS.contains(&group) {
            return Err(at(format!(
                "group {group} is not on a USAF 1951 chart (groups {}…{})",
                USAF_GROUPS.start(),
                USAF_GROUPS.end()
            )));
        }
        if !(1..=6).contains(&element) {
            return Err(at(format!("element {element} is not 1–6")));
        }
        if !(0.0..=1.0).contains(&modulation) {
            return Err(at(format!(
                "modulation {modulation} is outside [0, 1], where a bar contrast (max − min)/(max + min) lies"
            )));
        }
        out.push(UsafBar {
            group,
            element,
            modulation,
            line: i + 1,
        });
    }
    if out.is_empty() {
        return Err(CalibError::file(path, "no 'group,element,modulation' rows"));
    }
    Ok(out)
}

/// Reads and parses a CTF file (see [`parse_usaf_ctf`]), noting it in
/// `reads`.
pub fn read_usaf_ctf(path: &Path, reads: &gloam_io::ReadLog) -> Result<Vec<UsafBar>, CalibError> {
    let text =
        gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(|source| {
            CalibError::Read {
                path: PathBuf::from(path),
                source,
            }
        })?;
    parse_usaf_ctf(&text, path)
}

/// `--magnification` accepted: a chart imaged from 1e4× smaller to 1e4×
/// larger (outside it no USAF bar lands between a pixel's worth of cycles
/// and Nyquist at any real pitch).
pub const MIN_MAGNIFICATION: f64 = 1e-4;
pub const MAX_MAGNIFICATION: f64 = 1e4;
/// `--pixel-pitch-um` accepted, µm.
pub const MIN_PIXEL_PITCH_UM: f64 = 0.1;
pub const MAX_PIXEL_PITCH_UM: f64 = 1000.0;

/// Sine MTF from USAF bar contrasts: each bar's chart frequency (lp/mm)
/// goes to the image through `magnification` (image size / chart size) and
/// to cycles per pixel at `pixel_pitch_um`, then Coltman's series turns the
/// square-wave response into the sine MTF. Returns the Coltman curve, the
/// measured square-wave curve (both sorted by frequency) and the `details`
/// block of `mtf.json`. Refused, naming the row's line in `ctf` (the
/// `--ctf` file): a bar above Nyquist (0.5 cycles/pixel; exactly 0.5 is
/// kept), two rows of one bar, or a Coltman MTF outside [0, [`MAX_MTF`]]
/// (contrasts no imaging system gives).
pub fn usaf_mtf(
    mut bars: Vec<UsafBar>,
    pixel_pitch_um: f64,
    magnification: f64,
    ctf: &Path,
) -> Result<(Vec<MtfCurve>, MtfDetails), CalibError> {
    // Ranges, not just signs: --magnification 1e300 put the bars at
    // 1e-302 cycles/pixel and was accepted as a measurement.
    let num = gloam_spectra::num;
    if !(MIN_PIXEL_PITCH_UM..=MAX_PIXEL_PITCH_UM).contains(&pixel_pitch_um) {
        return Err(CalibError::Usage(format!(
            "--pixel-pitch-um {}: must be a pitch from {} to {} µm",
            num(pixel_pitch_um),
            num(MIN_PIXEL_PITCH_UM),
            num(MAX_PIXEL_PITCH_UM)
        )));
    }
    if !(MIN_MAGNIFICATION..=MAX_MAGNIFICATION).contains(&magnification) {
        return Err(CalibError::Usage(format!(
            "--magnification {}: must be from {} to {} (image size / chart size)",
            num(magnification),
            num(MIN_MAGNIFICATION),
            num(MAX_MAGNIFICATION)
        )));
    }
    let lp = |b: &UsafBar| usaf_lp_per_mm(b.group, b.element);
    bars.sort_by(|x, y| lp(x).total_cmp(&lp(y)));
    let at = |b: &UsafBar, message: String| CalibError::Line {
        path: ctf.to_path_buf(),
        line: b.line,
        message,
    };
    // Chart lp/mm → image cycles per pixel.
    let f: Vec<f64> = bars
        .iter()
        .map(|b| lp(b) / magnification * pixel_pitch_um * 1e-3)
        .collect();
    for (b, &fp) in bars.iter().zip(&f) {
        if fp > NYQUIST_CY_PER_PX {
            return Err(at(
                b,
                format!(
                    "group {} element {} ({} lp/mm) is {} cycles/pixel at --pixel-pitch-um {} and --magnification {}, above Nyquist ({NYQUIST_CY_PER_PX}): its bars alias, so their contrast is not MTF; leave the row out",
                    b.group,
                    b.element,
                    num(lp(b)),
                    num(fp),
                    num(pixel_pitch_um),
                    num(magnification)
                ),
            ));
        }
    }
    for w in bars.windows(2) {
        if (w[0].group, w[0].element) == (w[1].group, w[1].element) {
            let (first, again) = if w[0].line < w[1].line {
                (&w[0], &w[1])
            } else {
                (&w[1], &w[0])
            };
            return Err(at(
                again,
                format!(
                    "group {} element {} again (first at line {})",
                    again.group, again.element, first.line
                ),
            ));
        }
    }
    let c: Vec<f64> = bars.iter().map(|b| b.modulation).collect();
    let m = coltman_sine_from_square_samples(&f, &c)?;
    for (b, &v) in bars.iter().zip(&m) {
        if !(0.0..=MAX_MTF).contains(&v) {
            return Err(at(
                b,
                format!(
                    "Coltman's series gives MTF {v:.4} at group {} element {} from these bar contrasts, outside [0, {MAX_MTF}]: no imaging system gives them (its square-wave response falls with frequency and is at least its sine MTF); check the modulations",
                    b.group, b.element
                ),
            ));
        }
    }
    let usaf = (bars.iter().zip(&f))
        .map(|(b, &cycles_per_pixel)| UsafRow {
            group: b.group,
            element: b.element,
            lp_per_mm: lp(b),
            cycles_per_pixel,
            square_wave_modulation: b.modulation,
        })
        .collect();
    Ok((
        vec![
            MtfCurve::new("usaf-coltman", f.clone(), m),
            MtfCurve::new("usaf-square-wave", f, c),
        ],
        MtfDetails::Usaf { usaf },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ctf_rows_skip_header_and_comments_and_name_bad_lines() {
        let p = Path::new("c.csv");
        let bars =
            parse_usaf_ctf("group,element,modulation\n# x\n\n0,1,0.9\n1;2;0.5\n", p).unwrap();
        assert_eq!(
            bars,
            vec![
                UsafBar {
                    group: 0,
                    element: 1,
                    modulation: 0.9,
                    line: 4,
                },
                UsafBar {
                    group: 1,
                    element: 2,
                    modulation: 0.5,
                    line: 5,
                }
            ]
        );
        let e = parse_usaf_ctf("0,1,0.9\n0,7,0.5\n", p).unwrap_err();
        assert_eq!(e.to_string(), "c.csv:2: element 7 is not 1–6");
        let e = parse_usaf_ctf("0,1,0.9\nx\n", p).unwrap_err();
        assert_eq!(
            e.to_string(),
            "c.csv:2: 'x' is not a 'group,element,modulation' row (whole group and element, numeric modulation)"
        );
        let e = parse_usaf_ctf("# only\n", p).unwrap_err();
        assert_eq!(e.to_string(), "c.csv: no 'group,element,modulation' rows");
    }

    #[test]
    fn usaf_frequencies_go_from_chart_to_image_pixels() {
        // Group 0 element 1 is 1 lp/mm; at magnification 0.5 it is 2 lp/mm
        // on the sensor, and with 10 µm pixels 0.02 cycles per pixel.
        // Group 2 element 1 (4 lp/mm) lands at 0.08.
        let bars = vec![
            UsafBar {
                group: 2,
                element: 1,
                modulation: 0.5,
                line: 1,
            },
            UsafBar {
                group: 0,
                element: 1,
                modulation: 0.9,
                line: 2,
            },
        ];
        let (curves, details) = usaf_mtf(bars, 10.0, 0.5, Path::new("c.csv")).unwrap();
        let f = &curves[1].frequencies_cy_per_px;
        assert!(
            (f[0] - 0.02).abs() < 1e-15 && (f[1] - 0.08).abs() < 1e-15,
            "{f:?}"
        );
        assert_eq!(curves[1].mtf, vec![0.9, 0.5]);
        let details = serde_json::to_value(&details).unwrap();
        assert_eq!(details["usaf"][1]["lp_per_mm"], 4.0);
    }

    #[test]
    fn ctf_rows_out_of_physics_are_refused_at_their_line() {
        let p = Path::new("c.csv");
        let err = |t: &str| parse_usaf_ctf(t, p).unwrap_err().to_string();
        // A first row that fails to parse is not a header: never dropped.
        assert_eq!(
            err("0,1,0.9x\n1,1,0.5\n"),
            "c.csv:1: '0,1,0.9x' is not a 'group,element,modulation' row (whole group and element, numeric modulation)"
        );
        assert_eq!(
            err("group,element,modulation\nGroup,Element,Modulation\n0,1,0.5\n"),
            "c.csv:2: 'Group,Element,Modulation' is not a 'group,element,modulation' row (whole group and element, numeric modulation)"
        );
        assert_eq!(
            err("0,1,0.9\n100,1,0.5\n"),
            "c.csv:2: group 100 is not on a USAF 1951 chart (groups -2…11)"
        );
        assert!(err("-3,1,0.5\n").starts_with("c.csv:1: group -3 is not"));
        for bad in ["1.18", "-0.39", "1.0000001", "nan", "inf"] {
            let e = err(&format!("# c\n0,1,{bad}\n"));
            assert!(e.starts_with("c.csv:2: modulation "), "{bad}: {e}");
            assert!(e.contains("outside [0, 1]"), "{bad}: {e}");
        }
        // The chart's ends and the modulation's bounds are accepted.
        let ok = parse_usaf_ctf("-2,1,1\n11,6,0\n", p).unwrap();
        assert_eq!(ok.len(), 2);
    }

    fn bar(group: i32, element: i32, modulation: f64, line: usize) -> UsafBar {
        UsafBar {
            group,
            element,
            modulation,
            line,
        }
    }

    #[test]
    fn usaf_bars_above_nyquist_repeated_or_unphysical_are_refused() {
        let p = Path::new("c.csv");
        // Group 0 element 1 is 1 lp/mm: with 500 µm pixels exactly 0.5
        // cycles/pixel, Nyquist itself, which is kept.
        let (c, _) = usaf_mtf(vec![bar(0, 1, 0.6, 3)], 500.0, 1.0, p).unwrap();
        assert_eq!(c[0].frequencies_cy_per_px, vec![0.5]);
        // Element 2 is above it.
        let e = usaf_mtf(vec![bar(0, 1, 0.6, 3), bar(0, 2, 0.5, 4)], 500.0, 1.0, p)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("c.csv:4: group 0 element 2"), "{e}");
        assert!(e.contains("--pixel-pitch-um 500"), "{e}");
        assert!(e.contains("above Nyquist (0.5)"), "{e}");
        let e = usaf_mtf(vec![bar(0, 1, 0.6, 3), bar(0, 1, 0.5, 7)], 10.0, 1.0, p)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "c.csv:7: group 0 element 1 again (first at line 3)");
        // A perfect bar contrast at 1 lp/mm: π/4 at f, kept.
        let ok = usaf_mtf(vec![bar(0, 1, 1.0, 1), bar(1, 4, 0.7, 2)], 10.0, 1.0, p);
        let (c, _) = ok.unwrap();
        assert!(
            c[0].mtf.iter().all(|m| (0.0..=MAX_MTF).contains(m)),
            "{c:?}"
        );
        // A contrast that rises again at 3f, 7f and 11f: Coltman's series
        // passes 1.05.
        let f = |k: f64| (k.log2() * 6.0).round() as i32;
        let rows: Vec<UsafBar> = [1.0, 3.0, 5.0, 7.0, 11.0]
            .iter()
            .enumerate()
            .map(|(i, &k)| {
                let s = f(k);
                bar(
                    s.div_euclid(6),
                    s.rem_euclid(6) + 1,
                    if k == 5.0 { 0.0 } else { 1.0 },
                    i + 1,
                )
            })
            .collect();
        let e = usaf_mtf(rows, 1.0, 1.0, p).unwrap_err().to_string();
        assert!(
            e.starts_with("c.csv:1: Coltman's series gives MTF 1."),
            "{e}"
        );
        assert!(e.contains("outside [0, 1.05]"), "{e}");
        // Pitch and magnification are flags, named as such.
        let e = usaf_mtf(vec![bar(0, 1, 0.5, 1)], 0.0, 1.0, p).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--pixel-pitch-um 0: must be a pitch from 0.1 to 1000 µm"
        );
        // A magnification of 1e300 put the bars at 1e-302 cycles/pixel.
        let e = usaf_mtf(vec![bar(0, 1, 0.5, 1)], 10.0, 1e300, p).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--magnification 1e300: must be from 0.0001 to 10000 (image size / chart size)"
        );
    }

    #[test]
    fn sine_frequencies_stop_at_nyquist() {
        assert!(check_sine_frequencies(&[0.02, 0.25, 0.5]).is_ok());
        for bad in [0.5000001, 0.6, 2.0, 0.0, -0.1, f64::NAN] {
            let e = check_sine_frequencies(&[0.1, bad]).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--frequencies {bad}:")), "{e}");
            assert!(e.contains("(0, 0.5]"), "{e}");
        }
    }

    #[test]
    fn defaults_are_the_documented_grids() {
        let s = default_sine_frequencies();
        assert_eq!(s.len(), 24);
        assert!((s[0] - 0.02).abs() < 1e-15 && (s[23] - 0.48).abs() < 1e-15);
        let v = default_voltage_frequencies();
        assert_eq!(v.len(), 12);
        assert!((v[11] - 0.48).abs() < 1e-15);
        assert_eq!(default_scope_rows(240), vec![118, 119, 120, 121]);
        assert_eq!(default_scope_rows(1), vec![0]);
        let r = MtfRequest::default();
        assert_eq!(
            (r.modulation, r.frames, r.spectrum.as_str()),
            (0.8, 8, "cie-a")
        );
    }
}
