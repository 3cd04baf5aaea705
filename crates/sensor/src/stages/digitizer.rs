//! Digitizer: electrons (with the DSNU offsets added) to rounded, clipped
//! codes `0..2^b − 1`, with the frame's DN sum and saturated count —
//! directly, or by sampling the analogue line
//! ([`super::video_bandwidth::LineSampler`]) when the video stage has a
//! bandwidth.

use super::video_bandwidth::LineSampler;

/// The digitizer's transfer at one frame's gain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Digitizer {
    /// Black level, DN.
    pub black_dn: f64,
    /// DN per CCD electron.
    pub dn_per_e: f64,
    /// Analogue clip, DN (infinite without video).
    pub clip_dn: f64,
    /// Top code `2^b − 1`.
    pub max_code: f64,
    /// Codes at or above this count as saturated.
    pub saturated_dn: f64,
}

impl Digitizer {
    /// Row of electrons `v` to codes `out`: `round(clamp(min(black + e·k,
    /// clip), 0, max))`. Returns the row's DN sum and saturated count.
    #[inline]
    pub fn row(&self, v: &[f64], out: &mut [u16]) -> (f64, usize) {
        let mut sum = 0f64;
        let mut nsat = 0usize;
        for (o, &x) in out.iter_mut().zip(v.iter()) {
            let dn = (self.black_dn + x * self.dn_per_e)
                .min(self.clip_dn)
                .clamp(0.0, self.max_code);
            let dn = (dn + 0.5) as i32 as f64;
            *o = dn as u16;
            sum += dn;
            nsat += (dn >= self.saturated_dn) as usize;
        }
        (sum, nsat)
    }

    /// [`Digitizer::row`] through the analogue line: each pixel's level
    /// `min(black + e·k, clip)` is held for a pixel period, run through
    /// the video amplifier and sampled at the line sampler's phase (from
    /// rest at the blanking level), then rounded and clipped. `jitter`
    /// draws one standard normal per sample (clock jitter on).
    pub fn row_sampled(
        &self,
        v: &mut [f64],
        out: &mut [u16],
        line: &LineSampler,
        jitter: impl FnMut() -> f64,
    ) -> (f64, usize) {
        for x in v.iter_mut() {
            *x = (self.black_dn + *x * self.dn_per_e).min(self.clip_dn);
        }
        line.sample_row(self.black_dn, v, jitter);
        let mut sum = 0f64;
        let mut nsat = 0usize;
        for (o, &x) in out.iter_mut().zip(v.iter()) {
            let dn = (x.clamp(0.0, self.max_code) + 0.5) as i32 as f64;
            *o = dn as u16;
            sum += dn;
            nsat += (dn >= self.saturated_dn) as usize;
        }
        (sum, nsat)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounds_to_nearest_and_clips_at_both_ends() {
        let d = Digitizer {
            black_dn: 10.0,
            dn_per_e: 0.5,
            clip_dn: 200.0,
            max_code: 255.0,
            saturated_dn: 199.0,
        };
        let mut out = [0u16; 5];
        let (sum, nsat) = d.row(&[-100.0, 0.0, 3.0, 1000.0, 377.0], &mut out);
        // −100 e⁻ → 10 − 50 < 0 → 0; 0 → 10; 3 → 11.5 → 12; 1000 → 510 →
        // clip 200; 377 → 198.5 → 199.
        assert_eq!(out, [0, 10, 12, 200, 199]);
        assert_eq!(sum, 421.0);
        assert_eq!(nsat, 2);
    }
}
