//! The sensor chain as a [`FrameSource`]: what the in-process grabber, the
//! device emulator and the GigE Vision device all render, so their frames
//! are bit-identical for one seed.

use ndarray::Array2;

use gloam_grabber::source::{CaptureSettings, FrameSource, Rendered, SourceInfo};
use gloam_grabber::{GrabError, Stimulus};
use gloam_sensor::{Camera, SensorConfig};
use gloam_spectra::Spectrum;

use crate::scene::{SceneImage, SceneView};
use crate::stimulus::{DEFAULT_SPECTRUM, render_stimulus, rig_stimulus};

/// What the simulated camera looks at.
enum View {
    /// A rig or a presented stimulus, rendered at the frame size on demand.
    Stimulus {
        stimulus: Stimulus,
        radiance: Option<(u32, u32, Array2<f64>, Spectrum)>,
    },
    /// A traced scene, fixed at its rendered size; for a layered scene
    /// the mix of the current frame and the frames since the acquisition
    /// started (its clock).
    Scene {
        view: SceneView,
        mixed: Array2<f64>,
        frame: u64,
    },
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

/// The sensor model refused a configuration: its error is the source.
fn cfg_err(e: impl std::error::Error + Send + Sync + 'static) -> GrabError {
    GrabError::CameraModel(Box::new(e))
}

/// The sensor model failed on a frame: its error is the source.
fn fault(e: impl std::error::Error + Send + Sync + 'static) -> GrabError {
    GrabError::CameraFault(Box::new(e))
}

impl SensorSource {
    /// `preset`: a built-in sensor preset or a sensor TOML path; `rig`: a
    /// built-in rig name; `seed`: the noise seed; `size`: the image size;
    /// `reads` notes a sensor file.
    pub fn new(
        preset: &str,
        rig: &str,
        seed: u64,
        size: (u32, u32),
        reads: &gloam_io::ReadLog,
    ) -> Result<Self, GrabError> {
        let base = SensorConfig::load_preset_or_file(preset, reads).map_err(cfg_err)?;
        Self::from_config(preset, base, rig, seed, size)
    }

    /// [`SensorSource::new`] from a loaded configuration.
    fn from_config(
        preset: &str,
        mut base: SensorConfig,
        rig: &str,
        seed: u64,
        size: (u32, u32),
    ) -> Result<Self, GrabError> {
        base.noise.seed = seed;
        let camera = Camera::new(base.clone()).map_err(cfg_err)?;
        let chain = camera.chain();
        let full = f64::from((1u32 << base.digitizer.bits.min(16)) - 1);
        let lamp =
            gloam_spectra::lookup(DEFAULT_SPECTRUM, &gloam_io::ReadLog::off()).map_err(cfg_err)?;
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

    /// `sensor` (read once by the caller, who rendered the scene through
    /// it) looking at a rendered scene: frames have the scene's size.
    /// A stimulus presented later (calibration) replaces the scene. A
    /// layered scene sets the camera's frame rate to its own (the exposure
    /// held within one period), so its clock runs in real time at the
    /// camera's default rate and the AGC's time constants count in it.
    pub fn with_scene(
        sensor: &gloam_sensor::ResolvedSensor,
        scene: SceneView,
        seed: u64,
    ) -> Result<Self, GrabError> {
        scene.validate()?;
        let size = scene.size();
        let mut base = sensor.config().clone();
        if let SceneImage::Layers { frame_rate_hz, .. } = &scene.image {
            base.timing.frame_rate_hz = *frame_rate_hz;
            base.timing.exposure_s = base.timing.exposure_s.min(1.0 / frame_rate_hz);
        }
        let mut src = Self::from_config(sensor.name(), base, crate::uri::DEFAULT_RIG, seed, size)?;
        let (w, h) = size;
        src.view = View::Scene {
            view: scene,
            mixed: Array2::zeros((h as usize, w as usize)),
            frame: 0,
        };
        Ok(src)
    }

    /// The camera's configuration as built (a layered scene's frame rate
    /// and exposure applied).
    pub fn config(&self) -> &SensorConfig {
        &self.base
    }

    /// The camera's frame rate as built, Hz (a layered scene's own rate).
    pub fn frame_rate_hz(&self) -> f64 {
        self.base.timing.frame_rate_hz
    }

    /// The preset or file this source was built from.
    pub fn preset(&self) -> &str {
        &self.name
    }

    /// Rebuild the camera when a setting baked into its configuration changed.
    fn configure(&mut self, s: &CaptureSettings) -> Result<(), GrabError> {
        let b = &self.built;
        if (b.bits, b.exposure_us, b.agc_setpoint_ppm, b.mcp_voltage_mv)
            == (s.bits, s.exposure_us, s.agc_setpoint_ppm, s.mcp_voltage_mv)
        {
            return Ok(());
        }
        let mut cfg = self.base.clone();
        // Another bit depth keeps the top bits, as a camera's Mono8 does:
        // the offset and the conversion gain scale with the code range. Kept
        // in DN of the configured depth, a 500 DN black put every pixel of
        // an 8-bit frame at its top code.
        let k = 2f64.powi(i32::from(s.bits) - i32::from(cfg.digitizer.bits));
        cfg.digitizer.offset_dn *= k;
        if let Some(e) = cfg.digitizer.e_per_dn.as_mut() {
            *e /= k;
        }
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
        self.camera = Camera::new(cfg).map_err(fault)?;
        self.built = *s;
        self.mode = None;
        Ok(())
    }
}

impl SensorSource {
    /// The stimulus the camera looks at (a rig's, or the last presented),
    /// `None` for a scene: what a device reports it shows.
    pub fn stimulus(&self) -> Option<&Stimulus> {
        match &self.view {
            View::Stimulus { stimulus, .. } => Some(stimulus),
            View::Scene { .. } => None,
        }
    }
}

impl FrameSource for SensorSource {
    fn info(&self) -> SourceInfo {
        self.info.clone()
    }

    fn restart(&mut self) {
        self.camera.reset();
        self.mode = None;
        if let View::Scene { frame, .. } = &mut self.view {
            *frame = 0;
        }
    }

    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        // Validate now so a bad stimulus fails at `present`, not at `grab`.
        render_stimulus(stimulus, 2, 2)?;
        self.view = View::Stimulus {
            stimulus: stimulus.clone(),
            radiance: None,
        };
        Ok(true)
    }

    fn render(&mut self, s: &CaptureSettings, out: &mut [u16]) -> Result<Rendered, GrabError> {
        self.configure(s)?;
        let mode = (s.agc && self.info.has_agc, s.gain_milli);
        if self.mode != Some(mode) {
            if mode.0 {
                self.camera.set_agc(true);
            } else {
                let c = self.camera.chain();
                let g = (f64::from(s.gain_milli) / 1000.0).clamp(c.gain_min, c.gain_max);
                self.camera.set_override_gain(Some(g)).map_err(fault)?;
            }
            self.mode = Some(mode);
        }
        let frame = match &mut self.view {
            View::Stimulus { stimulus, radiance } => {
                if !matches!(radiance, Some((w, h, ..)) if (*w, *h) == (s.width, s.height)) {
                    let (img, shape) = render_stimulus(stimulus, s.width, s.height)?;
                    *radiance = Some((s.width, s.height, img, shape));
                }
                let Some((_, _, img, shape)) = radiance else {
                    return Err(GrabError::Device("no radiance image".into()));
                };
                self.camera.capture_mono(img.view(), shape)
            }
            View::Scene {
                view: scene,
                mixed,
                frame,
            } => {
                if scene.size() != (s.width, s.height) {
                    return Err(GrabError::Device(format!(
                        "scene '{}' was rendered at {}×{}, frames of {}×{} asked for",
                        scene.label,
                        scene.size().0,
                        scene.size().1,
                        s.width,
                        s.height
                    )));
                }
                match &scene.image {
                    SceneImage::Bands {
                        radiance_w_m2_sr,
                        band_shapes,
                    } => self.camera.capture(radiance_w_m2_sr.view(), band_shapes),
                    SceneImage::Detected { e_s_m2_sr } => {
                        self.camera.capture_detected(e_s_m2_sr.view())
                    }
                    SceneImage::Layers {
                        e_s_m2_sr,
                        frame_rate_hz,
                        weights,
                    } => {
                        let t0 = *frame as f64 / frame_rate_hz;
                        let window_s = self
                            .camera
                            .config()
                            .timing
                            .exposure_s
                            .min(1.0 / frame_rate_hz);
                        let w = (weights.0)(t0, t0 + window_s);
                        if w.len() != e_s_m2_sr.len()
                            || w.iter().any(|v| !(v.is_finite() && *v >= 0.0))
                        {
                            return Err(GrabError::Device(format!(
                                "scene '{}': {} weights for {} layers at {t0} s ({w:?})",
                                scene.label,
                                w.len(),
                                e_s_m2_sr.len()
                            )));
                        }
                        crate::scene::mix_layers(e_s_m2_sr, &w, mixed);
                        *frame += 1;
                        self.camera.capture_detected(mixed.view())
                    }
                }
            }
        }
        .map_err(fault)?;
        if out.len() != frame.pixels.len() {
            return Err(GrabError::Device(format!(
                "frame of {} pixels, buffer of {}",
                frame.pixels.len(),
                out.len()
            )));
        }
        out.copy_from_slice(&frame.pixels);
        let m = frame.meta;
        let gain_milli = (m.gain * 1000.0).round().clamp(0.0, f64::from(u32::MAX)) as u32;
        let protecting = m.sensor.as_ref().map(|s| s.agc_state);
        Ok(Rendered {
            gain_milli,
            levels: m.levels,
            bright_source_protection: protecting == Some(gloam_sensor::AgcState::Protecting),
            gate_duty: m.gate_duty,
            nd_density: m.nd_density,
            sensor: m.sensor,
            // `out` holds the camera's pixels unchanged.
            pixels_crc32c: Some(m.pixels_crc32c),
        })
    }
}
