//! Readout to the digitizer's input: analogue video
//! `V = V_black + e (V_white − V_black)/e_full`, clipped at the white clip,
//! sampled over the digitizer's input range — or a direct digital readout
//! at a fixed e⁻/DN.

use crate::config::{Digitizer, Readout};

/// The readout's transfer at the configured analogue gain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transfer {
    /// DN per CCD electron at unit analogue gain.
    pub base_dn_per_e: f64,
    /// Black level, DN.
    pub black_dn: f64,
    /// Analogue video clip, DN (infinite without video).
    pub clip_dn: f64,
    /// The video's own noise referred to CCD electrons, e⁻ rms.
    pub noise_e: f64,
}

impl Transfer {
    /// `DN = offset + g (V − V_lo)(2^b − 1)/(V_hi − V_lo)` for video, or
    /// `DN = offset + g e / (e/DN)` without.
    pub fn new(readout: &Readout<'_>, d: &Digitizer, max_code: f64) -> Self {
        match *readout {
            Readout::Video {
                video: v,
                input_low_v: lo,
                input_high_v: hi,
            } => {
                let dn_per_v = max_code / (hi - lo);
                let v_per_e = (v.white_level_v - v.black_level_v) / v.full_scale_e;
                let clip = v.white_clip_v.unwrap_or(v.white_level_v);
                Self {
                    base_dn_per_e: v_per_e * dn_per_v,
                    black_dn: d.offset_dn + d.analog_gain * (v.black_level_v - lo) * dn_per_v,
                    clip_dn: d.offset_dn + d.analog_gain * (clip - lo) * dn_per_v,
                    noise_e: v.noise_v / v_per_e,
                }
            }
            Readout::Direct { e_per_dn } => Self {
                base_dn_per_e: 1.0 / e_per_dn,
                black_dn: d.offset_dn,
                clip_dn: f64::INFINITY,
                noise_e: 0.0,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Video;

    fn digitizer(bits: u8) -> Digitizer {
        Digitizer {
            bits,
            offset_dn: 0.0,
            input_low_v: Some(0.0),
            input_high_v: Some(1.0),
            e_per_dn: None,
            analog_gain: 1.0,
            min_analog_gain: 1.0,
            max_analog_gain: 1.0,
            sample_phase: 0.5,
            clock_jitter_s: 0.0,
        }
    }

    #[test]
    fn ccir_video_into_an_8_bit_grabber() {
        // 0.3 V black, 1.0 V white (ITU-R BT.470 composite), 0–1 V input at
        // 8 bits: black at 0.3 × 255 = 76.5 DN, white at 255 DN, and
        // 10 000 e⁻ full scale gives 0.7 × 255 / 10 000 DN per electron.
        let v = Video {
            black_level_v: 0.3,
            white_level_v: 1.0,
            white_clip_v: None,
            full_scale_e: 10_000.0,
            noise_v: 0.0007,
            format: Default::default(),
            bandwidth_hz: None,
            bandwidth_filter: Default::default(),
        };
        let r = Readout::Video {
            video: &v,
            input_low_v: 0.0,
            input_high_v: 1.0,
        };
        let t = Transfer::new(&r, &digitizer(8), 255.0);
        assert!((t.black_dn - 76.5).abs() < 1e-12);
        assert!((t.clip_dn - 255.0).abs() < 1e-12);
        assert!((t.base_dn_per_e - 0.7 * 255.0 / 1e4).abs() < 1e-15);
        // 0.7 mV of video noise is 10 e⁻ at 70 µV per electron.
        assert!((t.noise_e - 10.0).abs() < 1e-9);
    }

    #[test]
    fn direct_readout_is_one_over_e_per_dn() {
        let t = Transfer::new(&Readout::Direct { e_per_dn: 4.0 }, &digitizer(16), 65535.0);
        assert_eq!(t.base_dn_per_e, 0.25);
        assert_eq!(t.clip_dn, f64::INFINITY);
    }
}
