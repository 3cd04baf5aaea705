//! Where a frame sits in the digitizer's range: the saturated-pixel fraction
//! and the warnings a lab would want before trusting a frame (clipped
//! highlights, a mean near full scale, a mean in the bottom few DN).
//!
//! One definition for every capture path: the camera's [`crate::SensorMeta`],
//! `gloam capture` over any grabber and `gloam render --sensor`.

/// Warn when more than this fraction of a frame's pixels are saturated (1 %).
pub const SATURATED_WARN_FRACTION: f64 = 0.01;
/// Warn when the mean signal above black reaches this fraction of the
/// range from black to saturation (95 %).
pub const NEAR_FULL_SCALE_FRACTION: f64 = 0.95;
/// Warn when the mean is within this many DN of black (or of code 0 when
/// the black level is unknown): the signal is then buried in the bottom
/// codes, quantisation and the clip at 0 dominate (4 DN).
pub const NEAR_BLACK_DN: f64 = 4.0;

/// The DN at and above which a pixel counts as saturated: within 3 σ of
/// the read noise (at least 1 DN) of the saturation level, since full-well
/// clipping happens before the read noise is added.
pub fn saturated_threshold_dn(saturation_dn: f64, read_noise_dn: f64) -> f64 {
    saturation_dn - (3.0 * read_noise_dn).max(1.0)
}

pub use gloam_io::frame::{mean_dn, saturated_fraction};

/// What an exposure warning is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum WarningKind {
    /// More than [`SATURATED_WARN_FRACTION`] of pixels saturated.
    Saturated,
    /// Mean at or above [`NEAR_FULL_SCALE_FRACTION`] of the range.
    NearFullScale,
    /// Mean within [`NEAR_BLACK_DN`] of black.
    NearBlack,
}

/// The kind of each of [`exposure_warnings`]' messages, in the same order.
pub fn warning_kinds(
    mean_dn: f64,
    saturated_fraction: f64,
    black_dn: Option<f64>,
    saturation_dn: f64,
) -> Vec<WarningKind> {
    let black = black_dn.unwrap_or(0.0);
    let span = saturation_dn - black;
    let mut k = Vec::new();
    if saturated_fraction > SATURATED_WARN_FRACTION {
        k.push(WarningKind::Saturated);
    }
    if span > 0.0 && mean_dn - black >= NEAR_FULL_SCALE_FRACTION * span {
        k.push(WarningKind::NearFullScale);
    }
    if mean_dn - black < NEAR_BLACK_DN {
        k.push(WarningKind::NearBlack);
    }
    k
}

/// The exposure warnings for a frame with mean `mean_dn` and saturated
/// fraction `saturated_fraction`, given its black level (`None`: 0) and
/// saturation level in DN. Empty when the frame is well exposed.
pub fn exposure_warnings(
    mean_dn: f64,
    saturated_fraction: f64,
    black_dn: Option<f64>,
    saturation_dn: f64,
) -> Vec<String> {
    let black = black_dn.unwrap_or(0.0);
    let span = saturation_dn - black;
    warning_kinds(mean_dn, saturated_fraction, black_dn, saturation_dn)
        .into_iter()
        .map(|k| match k {
            WarningKind::Saturated => format!(
                "{:.2} % of pixels saturated (warning above {} %)",
                100.0 * saturated_fraction,
                100.0 * SATURATED_WARN_FRACTION
            ),
            WarningKind::NearFullScale => format!(
                "mean {mean_dn:.1} DN is {:.1} % of the way from black ({black:.1}) to saturation ({saturation_dn:.1}): near full scale (warning at {} %)",
                100.0 * (mean_dn - black) / span,
                100.0 * NEAR_FULL_SCALE_FRACTION
            ),
            WarningKind::NearBlack => format!(
                "mean {mean_dn:.2} DN is within {NEAR_BLACK_DN} DN of {}: the signal is in the bottom codes",
                match black_dn {
                    Some(b) => format!("black ({b:.1} DN)"),
                    None => "code 0".to_string(),
                }
            ),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fraction_counts_the_pixels_at_or_above_the_threshold() {
        // 1000 pixels: 37 clipped at 4095, 5 just at the threshold, the rest mid-scale.
        let mut px = vec![2000u16; 1000];
        px[..37].fill(4095);
        px[500..505].fill(4090);
        px[600] = 4089;
        assert_eq!(saturated_fraction(&px, 4090.0), 42.0 / 1000.0);
        assert_eq!(saturated_fraction(&px, 4095.0), 37.0 / 1000.0);
        assert_eq!(saturated_fraction(&[], 1.0), 0.0);
        let want_mean = (37.0 * 4095.0 + 5.0 * 4090.0 + 4089.0 + 957.0 * 2000.0) / 1000.0;
        assert!((mean_dn(&px) - want_mean).abs() < 1e-9);
        assert_eq!(saturated_threshold_dn(4095.0, 0.1), 4094.0);
        assert_eq!(saturated_threshold_dn(4095.0, 2.0), 4089.0);
    }

    #[test]
    fn warnings_name_saturation_full_scale_and_bottom_codes() {
        assert!(exposure_warnings(2000.0, 0.0, Some(240.0), 3854.0).is_empty());
        // Exactly 1 % is not above the threshold; 1.1 % is.
        assert!(exposure_warnings(2000.0, 0.01, Some(240.0), 3854.0).is_empty());
        let w = exposure_warnings(2000.0, 0.011, Some(240.0), 3854.0);
        assert!(
            w.len() == 1 && w[0].contains("1.10 % of pixels saturated"),
            "{w:?}"
        );
        // 95 % of the way from black to saturation.
        let top = 240.0 + 0.95 * (3854.0 - 240.0);
        assert!(exposure_warnings(top - 0.1, 0.0, Some(240.0), 3854.0).is_empty());
        let w = exposure_warnings(top, 0.0, Some(240.0), 3854.0);
        assert!(w.len() == 1 && w[0].contains("near full scale"), "{w:?}");
        let w = exposure_warnings(243.9, 0.0, Some(240.0), 3854.0);
        assert!(w.len() == 1 && w[0].contains("black (240.0 DN)"), "{w:?}");
        assert!(exposure_warnings(244.0, 0.0, Some(240.0), 3854.0).is_empty());
        let w = exposure_warnings(1.0, 0.0, None, 4095.0);
        assert!(w.len() == 1 && w[0].contains("code 0"), "{w:?}");
    }
}
