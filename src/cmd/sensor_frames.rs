//! Capturing a render through a simulated camera (`gloam render --sensor`,
//! and the scenes of `gloam device --scene` / `sim:PRESET?scene=PATH`).
//!
//! A band value `∫ L R_b dλ` loses the spectrum inside the band, and the
//! detector's QE varies across it (an S-20 cathode sees tungsten or HPS
//! light ~27 % less efficiently than a flat spectrum of the same band
//! power). So the render carries one extra band whose response is the
//! camera's detector response QE(λ)·λ/hc over the scene's spectral range:
//! its value is the detected-electron radiance `∫ L QE λ/hc dλ`, exact for
//! any spectrum (lines included), which the camera captures directly. The
//! extra band is not written to the radiance outputs.

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use gloam_scene::{Band, Scene};
use gloam_sensor::Camera;
use gloam_spectra::Spectrum;
use gloam_trace::RenderOutput;
use ndarray::{Array2, Axis, s};
use serde::Serialize;

/// Name of the band the sensor capture adds to a render.
pub const DETECTED_BAND: &str = "sensor-detected";

/// `scene` with one more band, [`DETECTED_BAND`], whose response is
/// `sensor`'s detector response (QE·λ/hc, e⁻ J⁻¹) over the span of the
/// scene's bands.
pub fn with_detected_band(scene: &Scene, sensor: &str) -> anyhow::Result<Scene> {
    anyhow::ensure!(
        scene.band(DETECTED_BAND).is_none(),
        "the scene already has a band named '{DETECTED_BAND}', which the sensor capture needs"
    );
    let camera = Camera::from_preset_or_file(sensor)
        .with_context(|| format!("loading sensor '{sensor}'"))?;
    let lo_nm = scene
        .bands
        .iter()
        .map(|b| b.lo_nm)
        .fold(f64::INFINITY, f64::min);
    let hi_nm = scene
        .bands
        .iter()
        .map(|b| b.hi_nm)
        .fold(f64::NEG_INFINITY, f64::max);
    anyhow::ensure!(lo_nm < hi_nm, "the scene has no spectral band to capture");
    let window = Spectrum::constant(lo_nm, hi_nm, 1.0)?;
    let mut with = scene.clone();
    with.bands.push(Band {
        name: DETECTED_BAND.into(),
        response: camera.chain().detected_response_e_per_j().product(&window),
        lo_nm,
        hi_nm,
    });
    Ok(with)
}

/// Splits the [`DETECTED_BAND`] (the last band) off a render of a scene
/// from [`with_detected_band`]: the render keeps the scene's own bands.
pub fn take_detected_band(render: &mut RenderOutput) -> anyhow::Result<Array2<f64>> {
    anyhow::ensure!(
        render.band_names.last().map(String::as_str) == Some(DETECTED_BAND),
        "the render has no '{DETECTED_BAND}' band"
    );
    let last = render.band_names.len() - 1;
    let detected = render.radiance.index_axis(Axis(0), last).to_owned();
    render.radiance = render.radiance.slice(s![..last, .., ..]).to_owned();
    // The standard error too, so stderr.npy has the radiance's bands.
    render.std_error = render.std_error.slice(s![..last, .., ..]).to_owned();
    render.band_names.pop();
    render.stats.bands = last;
    Ok(detected)
}

use super::output::{png16_bytes, write_atomic};

/// Checks the sensor options of a capture (the sensor loads, `--gain` is
/// in its range, at least one frame) before anything expensive runs.
pub fn check_options(sensor: &str, gain: Option<f64>, frames: u32) -> anyhow::Result<()> {
    anyhow::ensure!(frames >= 1, "--frames must be at least 1");
    let mut camera = Camera::from_preset_or_file(sensor)
        .with_context(|| format!("loading sensor '{sensor}'"))?;
    if let Some(g) = gain {
        camera.set_override_gain(Some(g)).context("--gain")?;
    }
    Ok(())
}

/// Adds `sensor_capture` (per-frame mean, saturated fraction, warnings) to
/// the render's `report.json` in `out`, when there is one.
fn record_in_report(out: &Path, capture: serde_json::Value) -> anyhow::Result<()> {
    let path = out.join("report.json");
    let Ok(text) = std::fs::read_to_string(&path) else {
        return Ok(());
    };
    let mut report: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("reading {}", path.display()))?;
    if let Some(obj) = report.as_object_mut() {
        obj.insert("sensor_capture".into(), capture);
        write_atomic(&path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    Ok(())
}

/// What to capture and how.
pub struct FrameCapture<'a> {
    pub sensor: &'a str,
    pub frames: u32,
    pub gain: Option<f64>,
    pub agc: bool,
    pub noise: bool,
    pub seed: u64,
}

/// One line of `frames.jsonl` (the same keys as `gloam capture` writes,
/// plus the sensor's own figures).
#[derive(Serialize)]
struct FrameRecord<'a> {
    index: u32,
    file: String,
    seq: u64,
    /// µs since the stream started.
    timestamp: u64,
    gain: f64,
    agc: bool,
    bits: u8,
    width: usize,
    height: usize,
    pixels_crc32c: u32,
    status: &'static str,
    mean_dn: f64,
    /// Fraction of pixels at or above `saturated_at_dn`.
    saturated_fraction: f64,
    saturated_at_dn: f64,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    warnings: Vec<String>,
    sensor: &'a gloam_sensor::FrameMeta,
}

impl FrameCapture<'_> {
    /// Captures `frames` frames of the detected-electron radiance
    /// `detected` (e⁻ s⁻¹ m⁻² sr⁻¹, from [`take_detected_band`]) into `out`.
    pub fn run(&self, detected: &Array2<f64>, out: &Path) -> anyhow::Result<()> {
        anyhow::ensure!(self.frames >= 1, "--frames must be at least 1");
        let mut config = gloam_sensor::load_preset_or_file(self.sensor)
            .with_context(|| format!("loading sensor '{}'", self.sensor))?;
        config.noise.seed = self.seed;
        let mut camera = Camera::new(config)?;
        camera.set_noise(self.noise);
        if let Some(g) = self.gain {
            camera.set_override_gain(Some(g))?;
        }
        if self.agc {
            camera.set_agc(true);
        }
        let mut jsonl = Vec::new();
        let mut warned = std::collections::BTreeSet::new();
        let mut per_frame = Vec::new();
        for i in 0..self.frames {
            let frame = camera
                .capture_detected(detected.view())
                .with_context(|| format!("capturing frame {i}"))?;
            let (h, w) = frame.pixels.dim();
            let pixels: Vec<u16> = frame.pixels.iter().copied().collect();
            let file = format!("frame-{i:06}.png");
            write_atomic(&out.join(&file), &png16_bytes(w as u32, h as u32, &pixels)?)?;
            let m = &frame.meta;
            let g = m.gain_in_effect;
            let chain = camera.chain();
            let (black, sat) = (chain.black_dn(g), chain.saturation_dn(g));
            let args = (m.mean_dn, m.saturated_fraction, Some(black), sat);
            let warnings = gloam_sensor::levels::exposure_warnings(args.0, args.1, args.2, args.3);
            let kinds = gloam_sensor::levels::warning_kinds(args.0, args.1, args.2, args.3);
            for (w, k) in warnings.iter().zip(&kinds) {
                if warned.insert(*k) {
                    eprintln!("warning: frame {i}: {w}");
                }
            }
            per_frame.push(serde_json::json!({
                "file": format!("frame-{i:06}.png"),
                "gain": g,
                "mean_dn": m.mean_dn,
                "saturated_fraction": m.saturated_fraction,
                "warnings": kinds,
            }));
            let rec = FrameRecord {
                index: i,
                file,
                seq: m.seq,
                timestamp: (m.time_s * 1e6).round() as u64,
                gain: m.gain_in_effect,
                agc: m.agc_enabled,
                bits: m.bits,
                width: w,
                height: h,
                pixels_crc32c: gloam_grabber::pixels_crc32c(&pixels),
                status: "ok",
                mean_dn: m.mean_dn,
                saturated_fraction: m.saturated_fraction,
                saturated_at_dn: chain.saturated_threshold_dn(g),
                warnings,
                sensor: m,
            };
            serde_json::to_writer(&mut jsonl, &rec)?;
            jsonl.write_all(b"\n")?;
            // Rewritten after every frame so an interrupted run keeps what it captured.
            write_atomic(&out.join("frames.jsonl"), &jsonl)?;
        }
        record_in_report(
            out,
            serde_json::json!({
                "sensor": self.sensor,
                "frames": per_frame,
                "thresholds": {
                    "saturated_fraction_warning": gloam_sensor::levels::SATURATED_WARN_FRACTION,
                    "near_full_scale_fraction": gloam_sensor::levels::NEAR_FULL_SCALE_FRACTION,
                    "near_black_dn": gloam_sensor::levels::NEAR_BLACK_DN,
                },
            }),
        )?;
        eprintln!(
            "captured {} frame(s) through '{}' → {}",
            self.frames,
            self.sensor,
            out.display()
        );
        Ok(())
    }
}
