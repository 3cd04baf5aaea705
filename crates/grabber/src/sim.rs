//! The in-process simulated grabber: the sensor chain looking at a
//! calibration rig that renders [`Stimulus`] into radiance, or at a traced
//! scene ([`SceneView`], rendered by the caller: this crate does not trace).

use ndarray::{Array2, Array3};

use gloam_sensor::{Camera, SensorConfig};
use gloam_spectra::Spectrum;

use crate::interface::{Frame, FrameGrabber, FrameMeta, FrameStatus, GrabError, Stimulus};
use crate::source::{CaptureSettings, FrameSource, Rendered, SourceInfo};

/// Default rig image size (pixels): small enough for quick serial tests
/// (153 600 bytes per 16-bit frame, 0.5 s at 3 Mbaud).
pub const DEFAULT_RIG_SIZE: (u32, u32) = (320, 240);

/// Built-in rigs: what the simulated camera looks at by default.
pub const RIGS: &[(&str, &str)] = &[
    (
        "uniform",
        "integrating-sphere port filling the view (default), CIE A, ~25 % of full scale at the reference gain",
    ),
    (
        "sine",
        "sinusoidal bar target, 0.05 cycles/pixel, modulation 0.8, tilted 5°",
    ),
    ("edge", "ISO 12233 slanted edge, 5°, 10:1 contrast"),
    ("dark", "capped lens"),
];

/// Default lamp spectrum of the rigs.
pub const DEFAULT_SPECTRUM: &str = "cie-a";

/// The stimulus of a built-in rig at mean band radiance `level`.
pub fn rig_stimulus(rig: &str, level_w_m2_sr: f64) -> Result<Stimulus, GrabError> {
    let spectrum = DEFAULT_SPECTRUM.to_string();
    Ok(match rig {
        "uniform" => Stimulus::Uniform {
            radiance_w_m2_sr: level_w_m2_sr,
            spectrum,
        },
        "sine" => Stimulus::Sine {
            mean_radiance_w_m2_sr: level_w_m2_sr,
            modulation: 0.8,
            cycles_per_pixel: 0.05,
            angle_deg: 5.0,
            spectrum,
        },
        "edge" => Stimulus::Edge {
            dark_radiance_w_m2_sr: level_w_m2_sr * 2.0 / 11.0,
            bright_radiance_w_m2_sr: level_w_m2_sr * 20.0 / 11.0,
            angle_deg: 5.0,
            spectrum,
        },
        "dark" => Stimulus::Dark,
        other => {
            return Err(GrabError::InvalidSetting(format!(
                "unknown rig '{other}' (known: {})",
                RIGS.iter().map(|r| r.0).collect::<Vec<_>>().join(", ")
            )));
        }
    })
}

/// Band radiance image (row × column, W m⁻² sr⁻¹ over 400–1000 nm) of a
/// stimulus, and its relative spectrum restricted to that band.
pub fn render_stimulus(
    stimulus: &Stimulus,
    width: u32,
    height: u32,
) -> Result<(Array2<f64>, Spectrum), GrabError> {
    let (w, h) = (width as usize, height as usize);
    let spectrum_name = match stimulus {
        Stimulus::Dark => DEFAULT_SPECTRUM,
        Stimulus::Uniform { spectrum, .. }
        | Stimulus::Sine { spectrum, .. }
        | Stimulus::Edge { spectrum, .. } => spectrum.as_str(),
    };
    let lamp = gloam_spectra::lookup(spectrum_name)
        .map_err(|e| GrabError::InvalidSetting(format!("stimulus spectrum: {e}")))?;
    let window = Spectrum::constant(400.0, 1000.0, 1.0)
        .map_err(|e| GrabError::Other(format!("band window: {e}")))?;
    let shape = lamp.product(&window);
    let bad = |what: &str, v: f64| {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(GrabError::InvalidSetting(format!(
                "{what} = {v}: must be finite and ≥ 0"
            )))
        }
    };
    let img = match stimulus {
        Stimulus::Dark => Array2::zeros((h, w)),
        Stimulus::Uniform {
            radiance_w_m2_sr, ..
        } => {
            bad("radiance_w_m2_sr", *radiance_w_m2_sr)?;
            Array2::from_elem((h, w), *radiance_w_m2_sr)
        }
        Stimulus::Sine {
            mean_radiance_w_m2_sr,
            modulation,
            cycles_per_pixel,
            angle_deg,
            ..
        } => {
            bad("mean_radiance_w_m2_sr", *mean_radiance_w_m2_sr)?;
            if !(0.0..=1.0).contains(modulation) {
                return Err(GrabError::InvalidSetting(format!(
                    "modulation {modulation} must lie in 0..=1"
                )));
            }
            bad("cycles_per_pixel", *cycles_per_pixel)?;
            let a = angle_deg.to_radians();
            let (c, s) = (a.cos(), a.sin());
            Array2::from_shape_fn((h, w), |(r, col)| {
                let xp = col as f64 * c + r as f64 * s;
                mean_radiance_w_m2_sr
                    * (1.0 + modulation * (std::f64::consts::TAU * cycles_per_pixel * xp).cos())
            })
        }
        Stimulus::Edge {
            dark_radiance_w_m2_sr,
            bright_radiance_w_m2_sr,
            angle_deg,
            ..
        } => {
            bad("dark_radiance_w_m2_sr", *dark_radiance_w_m2_sr)?;
            bad("bright_radiance_w_m2_sr", *bright_radiance_w_m2_sr)?;
            let t = angle_deg.to_radians().tan();
            let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
            // Area-weighted coverage of each pixel (4×4 supersampling) so
            // the edge profile is well defined for MTF work.
            Array2::from_shape_fn((h, w), |(r, col)| {
                let mut bright = 0u32;
                for sy in 0..4 {
                    for sx in 0..4 {
                        let y = r as f64 + (f64::from(sy) + 0.5) / 4.0;
                        let x = col as f64 + (f64::from(sx) + 0.5) / 4.0;
                        if x - cx > (y - cy) * t {
                            bright += 1;
                        }
                    }
                }
                let f = f64::from(bright) / 16.0;
                dark_radiance_w_m2_sr * (1.0 - f) + bright_radiance_w_m2_sr * f
            })
        }
    };
    Ok((img, shape))
}

/// A rendered scene as the camera sees it.
#[derive(Clone, Debug)]
pub struct SceneView {
    /// What was rendered (for descriptions), e.g. the scene path.
    pub label: String,
    pub image: SceneImage,
}

/// The radiance of a [`SceneView`].
#[derive(Clone, Debug)]
pub enum SceneImage {
    /// Per-band radiance, W m⁻² sr⁻¹, band × row × column, with each band's
    /// spectral shape (any scale): the camera integrates its QE over each
    /// shape ([`gloam_sensor::Camera::capture`]).
    Bands {
        radiance_w_m2_sr: Array3<f64>,
        band_shapes: Vec<Spectrum>,
    },
    /// Detected-electron radiance `∫ L QE λ/hc dλ` for this camera's
    /// detector, e⁻ s⁻¹ m⁻² sr⁻¹, row × column: exact for any spectrum
    /// ([`gloam_sensor::Camera::capture_detected`]).
    Detected { e_s_m2_sr: Array2<f64> },
}

impl SceneView {
    /// Checks the shapes agree and every value is finite and ≥ 0 (the first
    /// bad value is named).
    pub fn validate(&self) -> Result<(), GrabError> {
        let bad = |what: String| {
            Err(GrabError::InvalidSetting(format!(
                "scene '{}': {what}",
                self.label
            )))
        };
        let (bands, rows, cols) = match &self.image {
            SceneImage::Bands {
                radiance_w_m2_sr,
                band_shapes,
            } => {
                let (b, r, c) = radiance_w_m2_sr.dim();
                if b != band_shapes.len() {
                    return bad(format!(
                        "{b} radiance bands but {} band spectra",
                        band_shapes.len()
                    ));
                }
                (b, r, c)
            }
            SceneImage::Detected { e_s_m2_sr } => {
                let (r, c) = e_s_m2_sr.dim();
                (1, r, c)
            }
        };
        if bands == 0 || rows == 0 || cols == 0 {
            return bad(format!(
                "empty radiance image ({bands} bands, {cols}×{rows})"
            ));
        }
        if rows > 4096 || cols > 4096 {
            return bad(format!("{cols}×{rows} is larger than 4096×4096"));
        }
        let first_bad = match &self.image {
            SceneImage::Bands {
                radiance_w_m2_sr, ..
            } => radiance_w_m2_sr
                .indexed_iter()
                .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
                .map(|((b, r, c), v)| format!("radiance {v} at band {b}, row {r}, column {c}")),
            SceneImage::Detected { e_s_m2_sr } => e_s_m2_sr
                .indexed_iter()
                .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
                .map(|((r, c), v)| format!("detected radiance {v} at row {r}, column {c}")),
        };
        match first_bad {
            Some(what) => bad(format!("{what} is not finite and ≥ 0")),
            None => Ok(()),
        }
    }

    /// (width, height) in pixels.
    pub fn size(&self) -> (u32, u32) {
        let (rows, cols) = match &self.image {
            SceneImage::Bands {
                radiance_w_m2_sr, ..
            } => {
                let (_, r, c) = radiance_w_m2_sr.dim();
                (r, c)
            }
            SceneImage::Detected { e_s_m2_sr } => e_s_m2_sr.dim(),
        };
        (cols as u32, rows as u32)
    }
}

/// What the simulated camera looks at.
enum View {
    /// A rig or a presented stimulus, rendered at the frame size on demand.
    Stimulus {
        stimulus: Stimulus,
        radiance: Option<(u32, u32, Array2<f64>, Spectrum)>,
    },
    /// A traced scene, fixed at its rendered size.
    Scene(SceneView),
}

/// The sensor chain as a [`FrameSource`]: a preset (or sensor TOML file)
/// looking at a rig or a scene.
pub struct SensorSource {
    name: String,
    base: SensorConfig,
    camera: Camera,
    /// Settings the camera was built for (bits, exposure, AGC set-point, MCP).
    built: CaptureSettings,
    /// Mode applied to the camera: (agc, manual gain milli).
    mode: Option<(bool, u32)>,
    view: View,
    info: SourceInfo,
}

fn cfg_err(e: impl std::fmt::Display) -> GrabError {
    GrabError::InvalidSetting(e.to_string())
}

impl SensorSource {
    /// `preset`: a built-in sensor preset or a sensor TOML path; `rig`: a
    /// built-in rig name; `seed`: the noise seed; `size`: the image size.
    pub fn new(preset: &str, rig: &str, seed: u64, size: (u32, u32)) -> Result<Self, GrabError> {
        let mut base = SensorConfig::load_preset_or_file(preset).map_err(cfg_err)?;
        base.noise.seed = seed;
        let camera = Camera::new(base.clone()).map_err(cfg_err)?;
        let chain = camera.chain();
        let full = f64::from((1u32 << base.digitizer.bits.min(16)) - 1);
        let lamp = gloam_spectra::lookup(DEFAULT_SPECTRUM).map_err(cfg_err)?;
        // Mean radiance that puts the image at ~25 % of full scale at the
        // reference gain (black level aside).
        let per_radiance = chain.pe_per_radiance(&lamp).unwrap_or(1.0)
            * chain.mean_dn_per_photoelectron(chain.reference_gain);
        let level = if per_radiance > 0.0 && per_radiance.is_finite() {
            0.25 * full / per_radiance
        } else {
            1e-6
        };
        let stimulus = rig_stimulus(rig, level)?;
        let gain_max_milli = (chain.gain_max * 1000.0).min(f64::from(u32::MAX)).floor() as u32;
        // The lowest setting in thousandths at or above the hardware minimum.
        let gain_min_milli = ((chain.gain_min * 1000.0 - 1e-6).ceil().max(1.0))
            .min(f64::from(gain_max_milli.max(1))) as u32;
        let gain_control = match (&base.mcp, &base.ebccd) {
            (Some(m), _) => format!("MCP {}–{} V", m.min_voltage_v, m.max_voltage_v),
            (_, Some(e)) => format!(
                "EB accelerating voltage {}–{} V",
                e.min_voltage_v, e.max_voltage_v
            ),
            _ => "digitizer analogue gain".to_string(),
        };
        let defaults = CaptureSettings {
            gain_milli: ((chain.reference_gain * 1000.0).round() as u32)
                .clamp(gain_min_milli, gain_max_milli.max(1)),
            agc: base.agc.as_ref().is_some_and(|a| a.enabled),
            agc_setpoint_ppm: base.agc.as_ref().map_or(500_000, |a| {
                ((a.set_point_dn / full) * 1e6).round().clamp(0.0, 1e6) as u32
            }),
            exposure_us: (base.timing.exposure_s * 1e6).round().max(1.0) as u32,
            gate_ns: (base.timing.exposure_s * 1e9)
                .round()
                .min(f64::from(u32::MAX)) as u32,
            mcp_voltage_mv: base
                .mcp
                .as_ref()
                .map_or(0, |m| (m.voltage_v * 1000.0).round() as u32),
            bits: base.digitizer.bits,
            width: size.0,
            height: size.1,
        };
        let info = SourceInfo {
            name: base.name.clone(),
            max_width: size.0,
            max_height: size.1,
            min_gain_milli: gain_min_milli,
            max_gain_milli: gain_max_milli.max(1),
            gain_control,
            max_exposure_us: ((1.0 / base.timing.frame_rate_hz) * 1e6).round().max(1.0) as u32
                * 100,
            has_agc: base.agc.is_some(),
            has_mcp: base.mcp.is_some(),
            has_gate: base.photocathode.is_some(),
            defaults,
        };
        Ok(Self {
            name: preset.to_string(),
            built: defaults,
            base,
            camera,
            mode: None,
            view: View::Stimulus {
                stimulus,
                radiance: None,
            },
            info,
        })
    }

    /// `preset` looking at a rendered scene: frames have the scene's size.
    /// A stimulus presented later (calibration) replaces the scene.
    pub fn with_scene(preset: &str, scene: SceneView, seed: u64) -> Result<Self, GrabError> {
        scene.validate()?;
        let size = scene.size();
        let mut src = Self::new(preset, crate::uri::DEFAULT_RIG, seed, size)?;
        src.view = View::Scene(scene);
        Ok(src)
    }

    /// The preset or file this source was built from.
    pub fn preset(&self) -> &str {
        &self.name
    }

    /// Rebuild the camera when a setting baked into its configuration changed.
    fn configure(&mut self, s: &CaptureSettings) -> Result<(), String> {
        let b = &self.built;
        if (b.bits, b.exposure_us, b.agc_setpoint_ppm, b.mcp_voltage_mv)
            == (s.bits, s.exposure_us, s.agc_setpoint_ppm, s.mcp_voltage_mv)
        {
            return Ok(());
        }
        let mut cfg = self.base.clone();
        cfg.digitizer.bits = s.bits;
        cfg.timing.exposure_s = f64::from(s.exposure_us) / 1e6;
        if cfg.timing.exposure_s > 1.0 / cfg.timing.frame_rate_hz {
            cfg.timing.frame_rate_hz = 1.0 / cfg.timing.exposure_s;
        }
        let full = f64::from((1u32 << s.bits.min(16)) - 1);
        if let Some(a) = cfg.agc.as_mut() {
            a.set_point_dn = f64::from(s.agc_setpoint_ppm) / 1e6 * full;
        }
        if let Some(m) = cfg.mcp.as_mut()
            && s.mcp_voltage_mv > 0
        {
            m.voltage_v =
                (f64::from(s.mcp_voltage_mv) / 1000.0).clamp(m.min_voltage_v, m.max_voltage_v);
        }
        self.camera = Camera::new(cfg).map_err(|e| e.to_string())?;
        self.built = *s;
        self.mode = None;
        Ok(())
    }
}

impl FrameSource for SensorSource {
    fn info(&self) -> SourceInfo {
        self.info.clone()
    }

    fn restart(&mut self) {
        self.camera.reset();
        self.mode = None;
    }

    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, String> {
        // Validate now so a bad stimulus fails at `present`, not at `grab`.
        render_stimulus(stimulus, 2, 2).map_err(|e| e.to_string())?;
        self.view = View::Stimulus {
            stimulus: stimulus.clone(),
            radiance: None,
        };
        Ok(true)
    }

    fn render(&mut self, s: &CaptureSettings, out: &mut [u16]) -> Result<Rendered, String> {
        self.configure(s)?;
        let mode = (s.agc && self.info.has_agc, s.gain_milli);
        if self.mode != Some(mode) {
            if mode.0 {
                self.camera.set_agc(true);
            } else {
                let c = self.camera.chain();
                let g = (f64::from(s.gain_milli) / 1000.0).clamp(c.gain_min, c.gain_max);
                self.camera
                    .set_override_gain(Some(g))
                    .map_err(|e| e.to_string())?;
            }
            self.mode = Some(mode);
        }
        let frame = match &mut self.view {
            View::Stimulus { stimulus, radiance } => {
                if !matches!(radiance, Some((w, h, ..)) if (*w, *h) == (s.width, s.height)) {
                    let (img, shape) =
                        render_stimulus(stimulus, s.width, s.height).map_err(|e| e.to_string())?;
                    *radiance = Some((s.width, s.height, img, shape));
                }
                let Some((_, _, img, shape)) = radiance else {
                    return Err("no radiance image".into());
                };
                self.camera.capture_mono(img.view(), shape)
            }
            View::Scene(scene) => {
                if scene.size() != (s.width, s.height) {
                    return Err(format!(
                        "scene '{}' was rendered at {}×{}, frames of {}×{} asked for",
                        scene.label,
                        scene.size().0,
                        scene.size().1,
                        s.width,
                        s.height
                    ));
                }
                match &scene.image {
                    SceneImage::Bands {
                        radiance_w_m2_sr,
                        band_shapes,
                    } => self.camera.capture(radiance_w_m2_sr.view(), band_shapes),
                    SceneImage::Detected { e_s_m2_sr } => {
                        self.camera.capture_detected(e_s_m2_sr.view())
                    }
                }
            }
        }
        .map_err(|e| e.to_string())?;
        if out.len() != frame.pixels.len() {
            return Err(format!(
                "frame of {} pixels, buffer of {}",
                frame.pixels.len(),
                out.len()
            ));
        }
        for (o, p) in out.iter_mut().zip(frame.pixels.iter()) {
            *o = *p;
        }
        let g = frame.meta.gain_in_effect;
        let gain_milli = (g * 1000.0).round().clamp(0.0, f64::from(u32::MAX)) as u32;
        let chain = self.camera.chain();
        Ok(Rendered {
            gain_milli,
            levels: Some(crate::interface::DnLevels {
                black_dn: chain.black_dn(g),
                saturation_dn: chain.saturation_dn(g),
                saturated_at_dn: chain.saturated_threshold_dn(g),
            }),
            bright_source_protection: frame.meta.agc_state == gloam_sensor::AgcState::Protecting,
        })
    }
}

/// The refusal of a manual gain outside a source's range (`milli` is the
/// setting as it travels, thousandths), naming the range and the camera.
pub fn gain_range_error(info: &SourceInfo, gain: f64, milli: u32) -> Option<GrabError> {
    (milli < info.min_gain_milli || milli > info.max_gain_milli).then(|| {
        GrabError::InvalidSetting(format!(
            "gain {gain} is outside the range of '{}': {}–{} ({}); the camera is not run at a clamped gain",
            info.name,
            f64::from(info.min_gain_milli) / 1000.0,
            f64::from(info.max_gain_milli) / 1000.0,
            info.gain_control
        ))
    })
}

/// The in-process simulated grabber over any [`FrameSource`].
///
/// Semantics match the protocol client against the emulator: a stream
/// starts at the first `grab` (and again after `set_bits`), settings travel
/// quantised exactly as on the wire (gain in thousandths, exposure in µs),
/// so frame `k` of a stream is bit-identical to the emulator's frame `k`.
pub struct SimGrabber<S: FrameSource = Box<dyn FrameSource>> {
    source: S,
    info: SourceInfo,
    settings: CaptureSettings,
    streaming: bool,
    next_seq: u64,
    pixels: Vec<u16>,
    label: String,
}

impl<S: FrameSource> SimGrabber<S> {
    /// A grabber over `source`; `label` goes into [`FrameGrabber::describe`].
    pub fn new(source: S, label: impl Into<String>) -> Self {
        let info = source.info();
        Self {
            settings: info.defaults,
            info,
            source,
            streaming: false,
            next_seq: 0,
            pixels: Vec::new(),
            label: label.into(),
        }
    }

    /// Current settings.
    pub fn settings(&self) -> &CaptureSettings {
        &self.settings
    }
}

impl SimGrabber<Box<dyn FrameSource>> {
    /// The sensor chain of `preset` looking at `rig`, noise seed `seed`.
    pub fn from_preset(
        preset: &str,
        rig: &str,
        seed: u64,
        size: (u32, u32),
    ) -> Result<Self, GrabError> {
        let src = SensorSource::new(preset, rig, seed, size)?;
        Ok(Self::new(
            Box::new(src) as Box<dyn FrameSource>,
            format!(
                "simulated {preset} looking at rig '{rig}' (seed {seed}, {}×{})",
                size.0, size.1
            ),
        ))
    }

    /// The sensor chain of `preset` looking at a rendered scene.
    pub fn from_scene(preset: &str, scene: SceneView, seed: u64) -> Result<Self, GrabError> {
        let (w, h) = scene.size();
        let label = format!(
            "simulated {preset} looking at scene '{}' (seed {seed}, {w}×{h})",
            scene.label
        );
        let src = SensorSource::with_scene(preset, scene, seed)?;
        Ok(Self::new(Box::new(src) as Box<dyn FrameSource>, label))
    }
}

impl<S: FrameSource> FrameGrabber for SimGrabber<S> {
    fn describe(&self) -> String {
        self.label.clone()
    }

    fn frame_size(&self) -> (u32, u32) {
        (self.settings.width, self.settings.height)
    }

    fn set_gain(&mut self, gain: f64) -> Result<f64, GrabError> {
        if !gain.is_finite() || gain <= 0.0 {
            return Err(GrabError::InvalidSetting(format!(
                "gain {gain} must be positive"
            )));
        }
        let milli = (gain * 1000.0).round().clamp(1.0, f64::from(u32::MAX)) as u32;
        if let Some(e) = gain_range_error(&self.info, gain, milli) {
            return Err(e);
        }
        self.settings.gain_milli = milli;
        self.settings.agc = false;
        Ok(f64::from(milli) / 1000.0)
    }

    fn set_agc(&mut self, on: bool) -> Result<bool, GrabError> {
        if on && !self.info.has_agc {
            return Err(GrabError::Unsupported("this camera has no AGC".into()));
        }
        self.settings.agc = on;
        Ok(on)
    }

    fn set_bits(&mut self, bits: u8) -> Result<u8, GrabError> {
        if !matches!(bits, 8 | 12 | 16) {
            return Err(GrabError::InvalidSetting(format!(
                "bit depth {bits}: use 8, 12 or 16"
            )));
        }
        // Like the device: not changeable mid-stream, so the stream restarts.
        self.streaming = false;
        self.settings.bits = bits;
        Ok(bits)
    }

    fn set_exposure_s(&mut self, exposure_s: f64) -> Result<f64, GrabError> {
        let us = crate::interface::exposure_us(exposure_s)?;
        if us > self.info.max_exposure_us {
            return Err(GrabError::InvalidSetting(format!(
                "exposure {exposure_s} s above the maximum {} s",
                f64::from(self.info.max_exposure_us) / 1e6
            )));
        }
        self.settings.exposure_us = us;
        Ok(f64::from(us) / 1e6)
    }

    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        self.source
            .present(stimulus)
            .map_err(GrabError::InvalidSetting)
    }

    fn grab(&mut self) -> Result<Frame, GrabError> {
        if !self.streaming {
            self.source.restart();
            self.streaming = true;
            self.next_seq = 0;
        }
        let s = self.settings;
        self.pixels
            .resize((s.width as usize) * (s.height as usize), 0);
        let r = self
            .source
            .render(&s, &mut self.pixels)
            .map_err(GrabError::Device)?;
        let seq = self.next_seq;
        self.next_seq += 1;
        let frame_period_us = u64::from(s.exposure_us.max(1));
        let pixels = self.pixels.clone();
        Ok(Frame {
            meta: FrameMeta {
                seq,
                timestamp_us: seq * frame_period_us,
                gain: f64::from(r.gain_milli) / 1000.0,
                agc: s.agc,
                bits: s.bits,
                width: s.width,
                height: s.height,
                pixels_crc32c: crate::pixels_crc32c(&pixels),
                status: FrameStatus::Ok,
                levels: r.levels,
            },
            pixels,
        })
    }
}
