//! The `FrameGrabber` interface and the types that cross it.

use serde::{Deserialize, Serialize};

use crate::transport::LinkError;

pub use gloam_io::frame::{DnLevels, Frame, FrameMeta, FrameStatus};

/// What a calibration source presents to the camera.
///
/// Real hardware ignores stimuli (the operator sets the lab source and says
/// so); simulated cameras and the device emulator render them. Calibration
/// flows always call [`DeviceControl::present`], so they run unchanged on both.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Stimulus {
    /// Capped lens / no light.
    Dark,
    /// A uniform field (integrating-sphere port filling the view) of band
    /// radiance `radiance_w_m2_sr` over 400–1000 nm with the relative
    /// spectrum of the built-in lamp `spectrum`.
    Uniform {
        radiance_w_m2_sr: f64,
        spectrum: String,
    },
    /// A sinusoidal bar target: radiance `mean·(1 + modulation·cos(2π f x'))`
    /// with `x'` along the direction `angle_deg` from the row axis and `f` in
    /// cycles per pixel.
    Sine {
        mean_radiance_w_m2_sr: f64,
        modulation: f64,
        cycles_per_pixel: f64,
        angle_deg: f64,
        spectrum: String,
    },
    /// A straight edge between two radiances, tilted by `angle_deg` from the
    /// column axis (ISO 12233 slanted edge, typically ~5°).
    Edge {
        dark_radiance_w_m2_sr: f64,
        bright_radiance_w_m2_sr: f64,
        angle_deg: f64,
        spectrum: String,
    },
}

/// The control side of a camera: what it is and its settings. Every
/// setter returns the value actually applied (a device may clamp or
/// round). Split from [`FrameStream`] as cameleon and Aravis split a camera's
/// control channel from its stream channel: a flow that only sets and reads
/// controls needs no frames.
pub trait DeviceControl {
    /// A one-line description (model, transport, firmware version).
    fn describe(&self) -> String;
    /// Frame size (width, height) in pixels.
    fn frame_size(&self) -> (u32, u32);
    /// Fixes a manual gain and turns AGC off (override).
    fn set_gain(&mut self, gain: f64) -> Result<f64, GrabError>;
    /// Turns AGC on (gain then servoes toward the set-point).
    fn set_agc(&mut self, on: bool) -> Result<bool, GrabError>;
    /// Digitizer depth: 8, 12 or 16 bits.
    fn set_bits(&mut self, bits: u8) -> Result<u8, GrabError>;
    /// Exposure (CCD integration or intensifier gate), seconds.
    fn set_exposure_s(&mut self, exposure_s: f64) -> Result<f64, GrabError>;
    /// Presents a stimulus. Returns false where the grabber cannot render it
    /// (real hardware: the operator sets the source).
    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError>;
}

/// The streaming side of a camera: frames as they arrive. A stream starts
/// at the first [`FrameStream::grab`] and runs until [`FrameStream::stop`] (or the
/// grabber is dropped).
pub trait FrameStream {
    /// The next whole frame. Damaged or lost frames are never returned as
    /// good: they come back as [`GrabError::FrameDamaged`] / [`GrabError::FramesLost`]
    /// and the caller may simply grab again.
    fn grab(&mut self) -> Result<Frame, GrabError>;
    /// Stops the stream, if one runs; the next [`FrameStream::grab`] starts a new
    /// one. Grabbers that render frames on demand have nothing to stop.
    fn stop(&mut self) -> Result<(), GrabError> {
        Ok(())
    }
    /// What the stream's transport did to recover lost packets so far
    /// (every acquisition of this grabber summed), for a capture's summary
    /// and report. `None`: the transport has no packet resend (in-process
    /// cameras; gloam's serial/USB protocol sends each frame once).
    fn packet_resends(&self) -> Option<PacketResends> {
        None
    }
}

/// Packet resends of a stream that asks for lost packets again (GigE
/// Vision's PACKETRESEND, as Aravis counts them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct PacketResends {
    /// Whether the grabber asked for lost packets again (`resend=always`
    /// and a camera that offers PACKETRESEND).
    pub resend: bool,
    /// Whether the camera offers PACKETRESEND (its GVCP capability
    /// register); `None` when it does not say.
    pub camera_offers_resend: Option<bool>,
    /// Resend requests the host sent.
    pub resend_requests: u64,
    /// Packets that arrived after being asked for again.
    pub packets_resent: u64,
    /// Packets never received (their frames were reported damaged).
    pub packets_missing: u64,
}

impl PacketResends {
    /// The sum of two acquisitions' counts (the settings of `later`).
    pub fn plus(self, later: PacketResends) -> PacketResends {
        PacketResends {
            resend: later.resend,
            camera_offers_resend: later.camera_offers_resend.or(self.camera_offers_resend),
            resend_requests: self.resend_requests.saturating_add(later.resend_requests),
            packets_resent: self.packets_resent.saturating_add(later.packets_resent),
            packets_missing: self.packets_missing.saturating_add(later.packets_missing),
        }
    }
}

/// A camera with both sides: what calibration flows, captures and the
/// front ends take (as `dyn FrameGrabber`). Implemented for every type that
/// is [`DeviceControl`] and [`FrameStream`].
pub trait FrameGrabber: DeviceControl + FrameStream {}

impl<G: DeviceControl + FrameStream + ?Sized> FrameGrabber for G {}

impl<G: DeviceControl + ?Sized> DeviceControl for Box<G> {
    fn describe(&self) -> String {
        (**self).describe()
    }
    fn frame_size(&self) -> (u32, u32) {
        (**self).frame_size()
    }
    fn set_gain(&mut self, gain: f64) -> Result<f64, GrabError> {
        (**self).set_gain(gain)
    }
    fn set_agc(&mut self, on: bool) -> Result<bool, GrabError> {
        (**self).set_agc(on)
    }
    fn set_bits(&mut self, bits: u8) -> Result<u8, GrabError> {
        (**self).set_bits(bits)
    }
    fn set_exposure_s(&mut self, exposure_s: f64) -> Result<f64, GrabError> {
        (**self).set_exposure_s(exposure_s)
    }
    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        (**self).present(stimulus)
    }
}

impl<G: FrameStream + ?Sized> FrameStream for Box<G> {
    fn grab(&mut self) -> Result<Frame, GrabError> {
        (**self).grab()
    }
    fn stop(&mut self) -> Result<(), GrabError> {
        (**self).stop()
    }
    fn packet_resends(&self) -> Option<PacketResends> {
        (**self).packet_resends()
    }
}

/// Everything that can go wrong talking to a grabber.
#[derive(Debug, thiserror::Error)]
pub enum GrabError {
    #[error("{0}")]
    Unsupported(String),
    #[error("invalid setting: {0}")]
    InvalidSetting(String),
    #[error("timed out after {after_ms} ms waiting for {what}")]
    Timeout { what: String, after_ms: u64 },
    #[error("frame {seq} damaged: {reason}")]
    FrameDamaged { seq: u64, reason: String },
    #[error("{count} frame(s) lost before frame {next_seq}")]
    FramesLost { count: u64, next_seq: u64 },
    #[error("device disconnected: {0}")]
    Disconnected(String),
    /// The stream was interrupted (link lost, port closed, device reset) and
    /// has been restarted. `frames_lost` is the number of frames the device
    /// produced that never arrived, when the device could tell (`None`: it
    /// was reset, so the count is unknown). The caller may simply grab again.
    #[error("stream interrupted ({reason}); {} lost, stream restarted", match frames_lost { Some(n) => format!("{n} frame(s)"), None => "an unknown number of frames".to_string() })]
    Interrupted {
        reason: String,
        frames_lost: Option<u64>,
    },
    /// The link to the device failed: the error says whether the device
    /// went away, what was being done, and the OS's or USB stack's error.
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The device went away and did not come back within the reconnect
    /// timeout; the last attempt's error is the source.
    #[error("device disconnected: {reason}; still away after {after_s:.1} s")]
    StillAway {
        reason: String,
        after_s: f64,
        #[source]
        source: LinkError,
    },
    /// No camera answers to `what` (the discovery layer's error is the source).
    #[error("device disconnected: {what}")]
    NotFound {
        what: String,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error("device error: {0}")]
    Device(String),
    /// The device answered a request with a protocol error code.
    #[error("device error: {what}: {code}")]
    Nak {
        what: String,
        code: firmware_protocol::ErrorCode,
    },
    /// A call into the device failed: what was asked, and the device
    /// library's error (e.g. Aravis's) as the source.
    #[error("device error: {what}")]
    DeviceCall {
        what: String,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The device refused a setting; its library's error is the source.
    #[error("invalid setting: {what}")]
    SettingRefused {
        what: String,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A simulated camera's model refused a setting: the model's own error
    /// (e.g. the sensor chain's configuration error) is the source.
    #[error("invalid setting")]
    CameraModel(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// A simulated camera's model failed to render a frame (its own error
    /// is the source), as hardware would report a device fault.
    #[error("device error")]
    CameraFault(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// The scene a simulated camera was to look at could not be rendered
    /// (the renderer's error is the source).
    #[error("invalid setting: scene '{path}'")]
    Scene {
        path: String,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A stimulus could not be written as the emulator's JSON request.
    #[error("invalid setting")]
    StimulusJson(#[source] serde_json::Error),
    /// A request did not fit the wire encoding.
    #[error("encoding request")]
    Encode(#[source] firmware_protocol::EncodeError),
    #[error("{0}")]
    Other(String),
}

impl GrabError {
    /// Why the device is gone, for errors after which the protocol client
    /// reconnects and retries (the text goes into the interruption report).
    pub(crate) fn disconnect_reason(&self) -> Option<String> {
        match self {
            GrabError::Disconnected(m) => Some(m.clone()),
            GrabError::Link(e) if e.is_disconnect() => Some(e.reason()),
            GrabError::StillAway {
                reason,
                after_s,
                source,
            } => Some(format!(
                "{reason}; still away after {after_s:.1} s ({})",
                source.full_text()
            )),
            _ => None,
        }
    }

    /// True for errors that only report lost or damaged frames: the grabber
    /// is still usable and the caller may grab again.
    pub fn is_frame_loss(&self) -> bool {
        matches!(
            self,
            GrabError::FrameDamaged { .. }
                | GrabError::FramesLost { .. }
                | GrabError::Interrupted { .. }
        )
    }
}

/// An exposure in seconds as the whole microseconds the wire and the device
/// use (at least 1 µs), or why it cannot be one.
pub fn exposure_us(exposure_s: f64) -> Result<u32, GrabError> {
    if !exposure_s.is_finite() || exposure_s <= 0.0 {
        return Err(GrabError::InvalidSetting(format!(
            "exposure {exposure_s} s must be positive"
        )));
    }
    let us = (exposure_s * 1e6).round();
    // Rounded up to 1 µs, `--exposure-s 1e-7` (or 1e-320) was run and
    // recorded at 10× (10³¹⁴×) what was asked, silently.
    if us < 1.0 {
        return Err(GrabError::InvalidSetting(format!(
            "exposure {exposure_s:e} s is below the 1 µs the device takes (whole microseconds)"
        )));
    }
    // Past 32 bits of microseconds the value was clamped without a word.
    if us > f64::from(u32::MAX) {
        return Err(GrabError::InvalidSetting(format!(
            "exposure {exposure_s:e} s is above the {} s the device takes (whole microseconds in 32 bits)",
            f64::from(u32::MAX) / 1e6
        )));
    }
    Ok(us as u32)
}
