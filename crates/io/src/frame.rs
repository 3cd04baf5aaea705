//! A frame and what is known of it, on the lowest floor so every crate
//! that makes, carries or records frames shares them: the digitised
//! frame a grabber hands out ([`Frame`], with the [`FrameMeta`] every
//! camera reports) and the simulated camera's own figures of a frame
//! ([`SensorMeta`], with its AGC state and saturation account), which
//! `frames.jsonl` records ([`crate::frames::FrameRecord`]). Plain data:
//! the sensor model that fills them in is `gloam_sensor`'s.

use serde::{Deserialize, Serialize};

/// Whether a frame arrived whole. Only `Ok` frames are ever returned as good
/// by a grabber's `grab`; damaged frames are reported as errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrameStatus {
    Ok,
    /// The device flagged the frame (e.g. sensor overrun) but its bytes are whole.
    DeviceWarning,
}

/// Metadata that travels with every frame: the settings actually in effect
/// when it was captured (not the ones last requested).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameMeta {
    /// Sequence number assigned by the camera (gaps mean lost frames).
    pub seq: u64,
    /// Capture time, microseconds since the stream started.
    pub timestamp_us: u64,
    /// Tube (or system) gain in effect, as the camera reports it.
    pub gain: f64,
    /// True when AGC was servoing the gain for this frame.
    pub agc: bool,
    /// Digitizer bit depth (8, 12 or 16); pixel values lie in `0..2^bits`.
    pub bits: u8,
    pub width: u32,
    pub height: u32,
    /// CRC-32C (Castagnoli) of the pixels as little-endian u16 bytes.
    pub pixels_crc32c: u32,
    pub status: FrameStatus,
    /// The camera's black and saturation levels for this frame, when it
    /// knows them (simulated cameras); `None` over the wire.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub levels: Option<DnLevels>,
    /// Exposure this frame was taken with, µs, when the camera says
    /// (simulated cameras; GenICam cameras with `ChunkExposureTime`). Left
    /// out when `None`, so records of cameras that do not know it are as
    /// before; the serial protocol does not carry it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_us: Option<f64>,
    /// Fraction of the exposure the photocathode was gated on for this
    /// frame (configured duty × the tube's autogating), when the camera
    /// has a gated photocathode and says (simulated cameras; gloam's GigE
    /// device's `ChunkGateDuty`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gate_duty: Option<f64>,
    /// Optical density of the ND filter in front of the camera, when the
    /// camera says (simulated cameras).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nd_density: Option<f64>,
    /// The simulated camera's own figures of this frame, when it came from
    /// one in process (the sensor model makes them; the simulated grabber
    /// passes them on unchanged). `None` for frames over a wire.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor: Option<SensorMeta>,
}

/// A camera's output levels at the settings of one frame, DN.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DnLevels {
    /// Output with no light.
    pub black_dn: f64,
    /// Where the output saturates (full well, video clip or top code).
    pub saturation_dn: f64,
    /// Pixels at or above this count as saturated.
    pub saturated_at_dn: f64,
    /// The camera's mean conversion at this frame's gain, photoelectrons
    /// per DN (1/K of photon transfer; FITS `GAIN` as astropy and ccdproc
    /// read it), when it knows it (simulated cameras). Left out when
    /// `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub electrons_per_dn: Option<f64>,
}

/// One digitised frame: row-major `height × width` digital counts with
/// the settings in effect. The one frame type in gloam, whether the
/// sensor model made it in process or a grabber received it over a link.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub meta: FrameMeta,
    pub pixels: Vec<u16>,
}

/// A frame whose counts do not fill its `width × height`.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("frame of {width}×{height} carries {pixels} counts")]
pub struct FrameShapeError {
    pub width: u32,
    pub height: u32,
    pub pixels: usize,
}

impl Frame {
    /// The counts as a `height × width` array (rows first), without a
    /// copy: for code that indexes pixels by row and column.
    pub fn view(&self) -> Result<ndarray::ArrayView2<'_, u16>, FrameShapeError> {
        let (w, h) = (self.meta.width as usize, self.meta.height as usize);
        ndarray::ArrayView2::from_shape((h, w), &self.pixels).map_err(|_| FrameShapeError {
            width: self.meta.width,
            height: self.meta.height,
            pixels: self.pixels.len(),
        })
    }
}

/// CRC-32C of pixels as little-endian `u16` bytes:
/// [`FrameMeta::pixels_crc32c`]. The protocol's own engine, so the host,
/// the device and the sensor model checksum frames with one
/// implementation.
pub fn pixels_crc32c(pixels: &[u16]) -> u32 {
    let mut d = firmware_protocol::Crc32c::new();
    let mut buf = [0u8; 4096];
    for block in pixels.chunks(buf.len() / 2) {
        for (o, p) in buf.chunks_exact_mut(2).zip(block) {
            o.copy_from_slice(&p.to_le_bytes());
        }
        d.update(&buf[..block.len() * 2]);
    }
    d.value()
}

/// What the camera's gain loop (`gloam_sensor::stages::agc`) is doing
/// for a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AgcState {
    /// No AGC: the configured fixed gain.
    Off,
    /// A manual override fixes the gain.
    Override,
    /// Servoing toward the set-point.
    Tracking,
    /// Wants more gain than its upper limit allows.
    AtMaxGain,
    /// Wants less gain than its lower limit allows.
    AtMinGain,
    /// Bright-source protection is cutting the gain.
    Protecting,
}

/// The stage whose limit sets a frame's saturation level.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SaturatingStage {
    CcdFullWell,
    VideoClip,
    DigitizerRail,
}

/// Where a frame saturated and how the tube's bright-source stages acted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SaturationAccount {
    /// Fraction of pixels saturated (information lost).
    pub saturated_fraction: f64,
    /// The stage that clipped them.
    pub saturated_by: SaturatingStage,
    /// A bright source was in view (the halo and pore depletion ran).
    pub bright_source_in_view: bool,
    /// Input max over mean (photoelectrons after the optics).
    pub input_max_over_mean: f64,
    /// Fraction of pixels the MCP's pore depletion compressed by > 10 %.
    pub mcp_compressed_fraction: f64,
    /// Share of the output the halo moved (0 when it did not run).
    pub halo_fraction: f64,
    /// The ABC's cut in effect for this frame.
    pub abc: AbcSetting,
    /// The ABC wanted more cut than the MCP and the gate allow: the
    /// cathode-current limit is reached and the frame is brighter than the
    /// tube can regulate.
    pub abc_out_of_range: bool,
}

impl Default for SaturationAccount {
    fn default() -> Self {
        Self {
            saturated_fraction: 0.0,
            saturated_by: SaturatingStage::DigitizerRail,
            bright_source_in_view: false,
            input_max_over_mean: 0.0,
            mcp_compressed_fraction: 0.0,
            halo_fraction: 0.0,
            abc: AbcSetting::OPEN,
            abc_out_of_range: false,
        }
    }
}

/// What the tube's brightness control (`gloam_sensor::stages::abc`)
/// sets for a frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AbcSetting {
    /// Multiplier on the MCP gain (lower plate voltage), ≤ 1.
    pub gain_factor: f64,
    /// Multiplier on the photocathode's duty cycle (autogating), ≤ 1.
    pub duty_factor: f64,
}

impl AbcSetting {
    pub const OPEN: Self = Self {
        gain_factor: 1.0,
        duty_factor: 1.0,
    };
}

/// The simulated camera's own figures of one frame (`gloam_sensor`'s
/// `Camera` makes them): the settings actually in effect when it was
/// taken, its levels and its saturation account. `frames.jsonl` records
/// them under `sensor`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorMeta {
    /// Frame number since the camera was created or reset.
    pub seq: u64,
    /// Start of the frame, s since the stream started (seq / frame rate).
    pub time_s: f64,
    pub exposure_s: f64,
    /// Tube gain (MCP gain, EB gain or analogue gain) for this frame.
    pub gain_in_effect: f64,
    /// MCP plate voltage for this frame (ICCD).
    pub mcp_voltage_v: Option<f64>,
    /// Control voltage (MCP or EBCCD accelerating voltage).
    pub control_voltage_v: Option<f64>,
    /// True when AGC (not a fixed or override gain) set this frame's gain.
    pub agc_enabled: bool,
    pub agc_state: AgcState,
    pub bits: u8,
    pub width: usize,
    pub height: usize,
    /// Mean DN of the frame.
    pub mean_dn: f64,
    /// Fraction of pixels at saturation (within 3 σ of read noise, at least
    /// 1 DN, of the chain's saturation level).
    pub saturated_fraction: f64,
    /// Temporal noise on.
    pub noise: bool,
    /// Which stage saturated, MCP compression and the tube's brightness
    /// control (`gloam_sensor::stages::bright`).
    #[serde(default)]
    pub saturation: SaturationAccount,
    /// The frame's median DN, when a median-metering AGC measured it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub median_dn: Option<f64>,
}

/// Fraction of `pixels` at or above `threshold_dn` (0 for no pixels).
pub fn saturated_fraction(pixels: &[u16], threshold_dn: f64) -> f64 {
    if pixels.is_empty() {
        return 0.0;
    }
    let n = pixels
        .iter()
        .filter(|&&p| f64::from(p) >= threshold_dn)
        .count();
    n as f64 / pixels.len() as f64
}

/// Mean DN of `pixels` (0 for no pixels).
pub fn mean_dn(pixels: &[u16]) -> f64 {
    if pixels.is_empty() {
        return 0.0;
    }
    pixels.iter().map(|&p| f64::from(p)).sum::<f64>() / pixels.len() as f64
}
