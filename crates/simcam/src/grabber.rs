//! The in-process simulated grabber: any [`FrameSource`] behind the
//! [`FrameGrabber`](gloam_grabber::FrameGrabber) interface, quantising settings as the wire does.

use gloam_grabber::source::{CaptureSettings, FrameSource, SourceInfo};
use gloam_grabber::{
    DeviceControl, Frame, FrameMeta, FrameStatus, FrameStream, GrabError, Stimulus,
};

use crate::scene::SceneView;
use crate::source::SensorSource;

/// The refusal of a manual gain outside a source's range (`milli` is the
/// setting as it travels, thousandths), naming the range and the camera.
pub fn gain_range_error(info: &SourceInfo, gain: f64, milli: u32) -> Option<GrabError> {
    (milli < info.min_gain_milli || milli > info.max_gain_milli).then(|| {
        GrabError::InvalidSetting(format!(
            "gain {} is outside the range of '{}': {}–{} ({}); the camera is not run at a clamped gain",
            gloam_spectra::num(gain),
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
    /// A grabber over `source`; `label` goes into [`DeviceControl::describe`].
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
    /// The sensor chain of `preset` looking at `rig`, noise seed `seed`
    /// (a sensor file noted in `reads`).
    pub fn from_preset(
        preset: &str,
        rig: &str,
        seed: u64,
        size: (u32, u32),
        reads: &gloam_io::ReadLog,
    ) -> Result<Self, GrabError> {
        let src = SensorSource::new(preset, rig, seed, size, reads)?;
        Ok(Self::new(
            Box::new(src) as Box<dyn FrameSource>,
            format!(
                "simulated {preset} looking at rig '{rig}' (seed {seed}, {}×{})",
                size.0, size.1
            ),
        ))
    }

    /// The sensor chain of `sensor` (read once by the caller) looking at
    /// a rendered scene.
    pub fn from_scene(
        sensor: &gloam_sensor::ResolvedSensor,
        scene: SceneView,
        seed: u64,
    ) -> Result<Self, GrabError> {
        let (w, h) = scene.size();
        let label = format!(
            "simulated {} looking at scene '{}' (seed {seed}, {w}×{h})",
            sensor.name(),
            scene.label
        );
        let src = SensorSource::with_scene(sensor, scene, seed)?;
        Ok(Self::new(Box::new(src) as Box<dyn FrameSource>, label))
    }
}

impl<S: FrameSource> DeviceControl for SimGrabber<S> {
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
        let us = gloam_grabber::exposure_us(exposure_s)?;
        if us > self.info.max_exposure_us {
            return Err(GrabError::InvalidSetting(format!(
                "exposure {} s above the maximum {} s",
                if exposure_s.abs() >= 1e6 {
                    format!("{exposure_s:e}")
                } else {
                    exposure_s.to_string()
                },
                f64::from(self.info.max_exposure_us) / 1e6
            )));
        }
        self.settings.exposure_us = us;
        Ok(f64::from(us) / 1e6)
    }

    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        self.source.present(stimulus)
    }
}

impl<S: FrameSource> FrameStream for SimGrabber<S> {
    fn grab(&mut self) -> Result<Frame, GrabError> {
        if !self.streaming {
            self.source.restart();
            self.streaming = true;
            self.next_seq = 0;
        }
        let s = self.settings;
        self.pixels
            .resize((s.width as usize) * (s.height as usize), 0);
        let r = self.source.render(&s, &mut self.pixels)?;
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
                pixels_crc32c: (r.pixels_crc32c)
                    .unwrap_or_else(|| gloam_grabber::pixels_crc32c(&pixels)),
                status: FrameStatus::Ok,
                levels: r.levels,
                // As configured for this frame: the same values gloam's GigE
                // device sends as `ChunkExposureTime` / `ChunkGateDuty`.
                exposure_us: Some(f64::from(s.exposure_us)),
                gate_duty: r.gate_duty,
                nd_density: r.nd_density,
                sensor: r.sensor,
            },
            pixels,
        })
    }
    /// The next grab restarts the source's stream at frame 0, as the
    /// emulator does after `StopStream`.
    fn stop(&mut self) -> Result<(), GrabError> {
        self.streaming = false;
        Ok(())
    }
}
