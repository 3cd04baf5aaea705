//! Where a frame sits in its range, by the sensor's exposure rules
//! ([`gloam_sensor::levels`]). Here because this crate is where the sensor
//! model and the grabbed frame meet; the frame itself stays model-free.

use gloam_grabber::Frame;
use gloam_sensor::levels::{self, WarningKind};

/// A frame's mean, saturated fraction and exposure warnings.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FrameExposure {
    pub mean_dn: f64,
    /// Fraction of pixels at or above the saturated level (the camera's,
    /// else the top code `2^bits − 1`).
    pub saturated_fraction: f64,
    /// Exposure warnings (empty when well exposed) and their kinds.
    pub warnings: Vec<String>,
    pub warning_kinds: Vec<WarningKind>,
}

/// [`FrameExposureExt::exposure`] on a [`Frame`], grabbed or made in
/// process.
pub trait FrameExposureExt {
    /// The frame's mean, saturated fraction and exposure warnings.
    fn exposure(&self) -> FrameExposure;
}

impl FrameExposureExt for Frame {
    fn exposure(&self) -> FrameExposure {
        let top = f64::from((1u32 << self.meta.bits.min(16)) - 1);
        let (black, sat, at) = match self.meta.levels {
            Some(l) => (Some(l.black_dn), l.saturation_dn, l.saturated_at_dn),
            None => (None, top, top),
        };
        // The sensor model's own figures when it made the frame (as its
        // record takes them), else the counts'.
        let (mean_dn, saturated_fraction) = match &self.meta.sensor {
            Some(s) => (s.mean_dn, s.saturated_fraction),
            None => (
                levels::mean_dn(&self.pixels),
                levels::saturated_fraction(&self.pixels, at),
            ),
        };
        FrameExposure {
            mean_dn,
            saturated_fraction,
            warnings: levels::exposure_warnings(mean_dn, saturated_fraction, black, sat),
            warning_kinds: levels::warning_kinds(mean_dn, saturated_fraction, black, sat),
        }
    }
}
