//! Frame sources: what a simulated camera (in-process or behind the device
//! emulator) renders. The sensor-chain source is `gloam-simcam`'s; this
//! crate has the interface and a cheap synthetic source for link tests. The simulated grabber and the emulator's HAL drive the
//! *same* source type with the same settings, so their frames are
//! bit-identical for the same seed.
//!
//! Determinism contract: a source is a pure function of (configuration,
//! seed, stimulus, the settings of each frame, frame index since the last
//! [`FrameSource::restart`]). A stream starts with `restart`.

use crate::faults::SplitMix;
use crate::interface::{GrabError, Stimulus};

/// Capture settings as they travel on the wire (integers, so the simulated
/// grabber quantises exactly like the device does).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CaptureSettings {
    /// Manual gain, thousandths (used when AGC is off; AGC starts from it).
    pub gain_milli: u32,
    pub agc: bool,
    /// AGC target mean, ppm of full scale.
    pub agc_setpoint_ppm: u32,
    pub exposure_us: u32,
    pub gate_ns: u32,
    pub mcp_voltage_mv: u32,
    pub bits: u8,
    pub width: u32,
    pub height: u32,
}

impl Default for CaptureSettings {
    fn default() -> Self {
        Self {
            gain_milli: 1000,
            agc: false,
            agc_setpoint_ppm: 500_000,
            exposure_us: 20_000,
            gate_ns: 20_000_000,
            mcp_voltage_mv: 0,
            bits: 16,
            width: 640,
            height: 480,
        }
    }
}

/// What a source reports with a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Rendered {
    /// Gain actually in effect, thousandths (differs from the manual gain under AGC).
    pub gain_milli: u32,
    /// Black and saturation levels at this frame's settings, if known.
    pub levels: Option<crate::interface::DnLevels>,
    /// The AGC's bright-source protection was cutting the gain at this frame.
    pub bright_source_protection: bool,
    /// Fraction of the exposure the photocathode was gated on for this
    /// frame (configured duty × the tube's autogating), if it has one.
    pub gate_duty: Option<f64>,
    /// Optical density of the camera's ND filter, if it has one.
    pub nd_density: Option<f64>,
    /// The sensor model's own figures of the frame, for a simulated
    /// camera (its grabber passes them on; a wire does not carry them).
    pub sensor: Option<gloam_io::frame::SensorMeta>,
    /// The pixels' CRC-32C when the source already computed it (a
    /// simulated camera's frame carries one): a grabber passing the same
    /// pixels on reuses it rather than hashing the frame again.
    pub pixels_crc32c: Option<u32>,
}

/// Fixed facts about a source.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceInfo {
    /// Preset / model name.
    pub name: String,
    pub max_width: u32,
    pub max_height: u32,
    /// Lowest manual gain, thousandths (a setting below it is refused).
    pub min_gain_milli: u32,
    pub max_gain_milli: u32,
    /// What sets the gain and over what range, for error messages
    /// ("MCP 500–1000 V").
    pub gain_control: String,
    pub max_exposure_us: u32,
    pub has_agc: bool,
    pub has_mcp: bool,
    pub has_gate: bool,
    /// Power-up settings.
    pub defaults: CaptureSettings,
}

/// A simulated camera.
pub trait FrameSource: Send {
    fn info(&self) -> SourceInfo;
    /// Begin a new stream: frame index 0, fresh noise and AGC state.
    fn restart(&mut self);
    /// Set what the camera looks at. Returns false if it cannot render it;
    /// a stimulus it cannot accept is [`GrabError::InvalidSetting`].
    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError>;
    /// Render the next frame of the stream into `out` (`width × height`
    /// values below `2^bits`). A failure here is the camera's, so grabbers
    /// report it as it comes (the emulator as a hardware fault).
    fn render(
        &mut self,
        settings: &CaptureSettings,
        out: &mut [u16],
    ) -> Result<Rendered, GrabError>;
}

impl<S: FrameSource + ?Sized> FrameSource for Box<S> {
    fn info(&self) -> SourceInfo {
        (**self).info()
    }
    fn restart(&mut self) {
        (**self).restart()
    }
    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        (**self).present(stimulus)
    }
    fn render(
        &mut self,
        settings: &CaptureSettings,
        out: &mut [u16],
    ) -> Result<Rendered, GrabError> {
        (**self).render(settings, out)
    }
}

/// A cheap analytic camera for link tests and benchmarks: the stimulus as a
/// normalised pattern times gain, plus hash-based noise keyed by (seed,
/// frame index, pixel); a first-order AGC. Not physics — see the sensor-chain
/// source for that.
#[derive(Clone, Debug)]
pub struct SyntheticSource {
    seed: u64,
    index: u64,
    stimulus: Stimulus,
    agc_gain_milli: Option<u32>,
    info: SourceInfo,
}

impl SyntheticSource {
    /// A synthetic camera of the given frame size.
    pub fn new(width: u32, height: u32, seed: u64) -> Self {
        let defaults = CaptureSettings {
            width,
            height,
            ..CaptureSettings::default()
        };
        Self {
            seed,
            index: 0,
            stimulus: Stimulus::Uniform {
                radiance_w_m2_sr: 1e-6,
                spectrum: "illuminant-a".into(),
            },
            agc_gain_milli: None,
            info: SourceInfo {
                name: "synthetic".into(),
                max_width: width,
                max_height: height,
                min_gain_milli: 1,
                max_gain_milli: 100_000,
                gain_control: "synthetic gain".into(),
                max_exposure_us: 10_000_000,
                has_agc: true,
                has_mcp: false,
                has_gate: false,
                defaults,
            },
        }
    }

    /// Relative level (0..1) of the stimulus at a pixel.
    fn level(&self, x: u32, y: u32) -> f64 {
        match &self.stimulus {
            Stimulus::Dark => 0.0,
            Stimulus::Uniform { .. } => 0.25,
            Stimulus::Sine {
                modulation,
                cycles_per_pixel,
                angle_deg,
                ..
            } => {
                let a = angle_deg.to_radians();
                let xp = f64::from(x) * a.cos() + f64::from(y) * a.sin();
                0.25 * (1.0 + modulation * (std::f64::consts::TAU * cycles_per_pixel * xp).cos())
            }
            Stimulus::Edge { angle_deg, .. } => {
                let w = f64::from(self.info.max_width);
                let edge_x = w / 2.0 + (f64::from(y) - w / 2.0) * angle_deg.to_radians().tan();
                if f64::from(x) < edge_x { 0.05 } else { 0.4 }
            }
        }
    }
}

impl FrameSource for SyntheticSource {
    fn info(&self) -> SourceInfo {
        self.info.clone()
    }

    fn restart(&mut self) {
        self.index = 0;
        self.agc_gain_milli = None;
    }

    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        self.stimulus = stimulus.clone();
        Ok(true)
    }

    fn render(&mut self, s: &CaptureSettings, out: &mut [u16]) -> Result<Rendered, GrabError> {
        let (w, h) = (s.width, s.height);
        if out.len() != (w as usize) * (h as usize) {
            return Err(GrabError::Device(format!(
                "frame buffer holds {} pixels, {w}×{h} needed",
                out.len()
            )));
        }
        let full = ((1u32 << s.bits) - 1) as f64;
        let gain_milli = if s.agc {
            *self.agc_gain_milli.get_or_insert(s.gain_milli)
        } else {
            s.gain_milli
        };
        let gain = f64::from(gain_milli) / 1000.0;
        let exposure = f64::from(s.exposure_us) / 20_000.0;
        let mut rng = SplitMix::new(self.seed ^ self.index.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let mut sum = 0.0;
        for y in 0..h {
            for x in 0..w {
                let signal = self.level(x, y) * gain * exposure * full;
                let noise = (rng.unit() - 0.5) * 0.02 * full;
                let v = (signal + noise).round().clamp(0.0, full);
                sum += v;
                out[(y * w + x) as usize] = v as u16;
            }
        }
        if s.agc {
            // First-order servo of the mean toward the set-point.
            let mean = sum / (f64::from(w) * f64::from(h)).max(1.0) / full;
            let target = f64::from(s.agc_setpoint_ppm) / 1e6;
            let ratio = if mean > 1e-6 {
                (target / mean).clamp(0.5, 2.0)
            } else {
                2.0
            };
            let next = (f64::from(gain_milli) * ratio.sqrt()).round();
            self.agc_gain_milli = Some(next.clamp(1.0, f64::from(self.info.max_gain_milli)) as u32);
        }
        self.index += 1;
        Ok(Rendered {
            gain_milli,
            levels: None,
            bright_source_protection: false,
            gate_duty: None,
            nd_density: None,
            sensor: None,
            pixels_crc32c: None,
        })
    }
}
