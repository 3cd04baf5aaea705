//! A mock `FrameGrabber`: a linear camera with known gain K (DN/e⁻), offset,
//! read noise, QE, full well, Poisson shot noise from a seeded RNG, a known
//! Gaussian MTF for Sine/Edge stimuli, PRNU/DSNU, and an optional
//! first-order AGC. Every figure the calibration flows estimate is known
//! exactly here.
#![allow(dead_code, clippy::neg_cmp_op_on_partial_ord)]

use gloam_grabber::{
    DeviceControl, Frame, FrameMeta, FrameStatus, FrameStream, GrabError, Stimulus,
};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal, Poisson};
use rand_pcg::Pcg64;

#[derive(Clone, Debug)]
pub struct AgcModel {
    /// Output (DN above offset) the loop servoes to.
    pub setpoint_dn: f64,
    /// Loop gain: `log g ← log g + α log(setpoint / output)`. α = 2 is
    /// marginally stable: it oscillates forever.
    pub alpha: f64,
    pub min_gain: f64,
    pub max_gain: f64,
}

pub struct MockCamera {
    pub w: usize,
    pub h: usize,
    /// System gain at gain setting 1, DN/e⁻; K = k0 · gain.
    pub k0: f64,
    pub gain: f64,
    pub offset_dn: f64,
    pub read_noise_e: f64,
    pub qe: f64,
    pub full_well_e: f64,
    /// Photons per pixel per exposure per W m⁻² sr⁻¹ of stimulus radiance.
    pub photons_per_radiance: f64,
    pub bits: u8,
    /// Gaussian PSF σ, pixels: MTF(f) = exp(−2π²σ²f²).
    pub mtf_sigma_px: f64,
    /// Multiplies a sine stimulus's modulation (1: none) — a camera (or a
    /// light that changed between grey scale and target) that shows more
    /// contrast than the target has, which no MTF can.
    pub sine_contrast_gain: f64,
    pub prnu: Vec<f64>,
    pub dsnu: Vec<f64>,
    pub agc: Option<AgcModel>,
    pub agc_on: bool,
    /// When false, `present` returns false and the stimulus is ignored
    /// (like real hardware); the scene is then `manual_radiance`.
    pub renders: bool,
    pub manual_radiance: f64,
    stim: Stimulus,
    rng: Pcg64,
    seq: u64,
}

impl MockCamera {
    pub fn new(seed: u64) -> Self {
        let (w, h) = (64usize, 64usize);
        let mut rng = Pcg64::seed_from_u64(seed);
        let n = Normal::new(0.0, 1.0).unwrap();
        let prnu = (0..w * h)
            .map(|_| 1.0 + 0.01 * n.sample(&mut rng))
            .collect();
        let dsnu = (0..w * h).map(|_| 0.5 * n.sample(&mut rng)).collect();
        Self {
            w,
            h,
            k0: 0.25,
            gain: 1.0,
            offset_dn: 100.0,
            read_noise_e: 6.0,
            qe: 0.5,
            full_well_e: 20_000.0,
            photons_per_radiance: 600.0,
            bits: 12,
            mtf_sigma_px: 0.7,
            sine_contrast_gain: 1.0,
            prnu,
            dsnu,
            agc: None,
            agc_on: false,
            renders: true,
            manual_radiance: 0.0,
            stim: Stimulus::Dark,
            rng,
            seq: 0,
        }
    }

    pub fn k(&self) -> f64 {
        self.k0 * self.gain
    }

    pub fn mtf(&self, f: f64) -> f64 {
        (-2.0 * std::f64::consts::PI.powi(2) * self.mtf_sigma_px.powi(2) * f * f).exp()
    }

    fn radiance_at(&self, r: usize, c: usize) -> f64 {
        match &self.stim {
            Stimulus::Dark => 0.0,
            Stimulus::Uniform {
                radiance_w_m2_sr, ..
            } => *radiance_w_m2_sr,
            Stimulus::Sine {
                mean_radiance_w_m2_sr,
                modulation,
                cycles_per_pixel,
                angle_deg,
                ..
            } => {
                let a = angle_deg.to_radians();
                let x = c as f64 * a.cos() + r as f64 * a.sin();
                mean_radiance_w_m2_sr
                    * (1.0
                        + modulation
                            * self.sine_contrast_gain
                            * self.mtf(*cycles_per_pixel)
                            * (2.0 * std::f64::consts::PI * cycles_per_pixel * x).cos())
            }
            Stimulus::Edge {
                dark_radiance_w_m2_sr,
                bright_radiance_w_m2_sr,
                angle_deg,
                ..
            } => {
                let a = angle_deg.to_radians();
                let (cx, cy) = (self.w as f64 / 2.0, self.h as f64 / 2.0);
                let d = (c as f64 - cx) * a.cos() - (r as f64 - cy) * a.sin();
                dark_radiance_w_m2_sr
                    + (bright_radiance_w_m2_sr - dark_radiance_w_m2_sr)
                        * normal_cdf(d / self.mtf_sigma_px)
            }
        }
    }
}

/// Φ(x) via erfc (Numerical Recipes' Chebyshev erfc, |error| < 1.2e-7).
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

impl DeviceControl for MockCamera {
    fn describe(&self) -> String {
        "mock linear camera".into()
    }
    fn frame_size(&self) -> (u32, u32) {
        (self.w as u32, self.h as u32)
    }
    fn set_gain(&mut self, gain: f64) -> Result<f64, GrabError> {
        if !(gain > 0.0) {
            return Err(GrabError::InvalidSetting(format!("gain {gain}")));
        }
        self.gain = gain;
        self.agc_on = false;
        Ok(gain)
    }
    fn set_agc(&mut self, on: bool) -> Result<bool, GrabError> {
        if on && self.agc.is_none() {
            return Err(GrabError::Unsupported("no AGC".into()));
        }
        self.agc_on = on;
        Ok(on)
    }
    fn set_bits(&mut self, bits: u8) -> Result<u8, GrabError> {
        self.bits = bits;
        Ok(bits)
    }
    fn set_exposure_s(&mut self, e: f64) -> Result<f64, GrabError> {
        Ok(e)
    }
    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        if !self.renders {
            return Ok(false);
        }
        self.stim = stimulus.clone();
        Ok(true)
    }
}

impl FrameStream for MockCamera {
    fn grab(&mut self) -> Result<Frame, GrabError> {
        let n = self.w * self.h;
        let k = self.k();
        let max = ((1u32 << self.bits) - 1) as f64;
        let read = Normal::new(0.0, self.read_noise_e).unwrap();
        let mut pixels = Vec::with_capacity(n);
        let mut sum = 0.0;
        for r in 0..self.h {
            for c in 0..self.w {
                let i = r * self.w + c;
                let l = if self.renders {
                    self.radiance_at(r, c)
                } else {
                    self.manual_radiance
                };
                let mean_e = (self.qe * self.photons_per_radiance * l * self.prnu[i]).max(0.0);
                let e = if mean_e > 0.0 {
                    Poisson::new(mean_e).unwrap().sample(&mut self.rng)
                } else {
                    0.0
                };
                let e = e.min(self.full_well_e) + read.sample(&mut self.rng);
                let dn = (self.offset_dn + self.dsnu[i] + k * e)
                    .round()
                    .clamp(0.0, max);
                sum += dn;
                pixels.push(dn as u16);
            }
        }
        let meta = FrameMeta {
            seq: self.seq,
            timestamp_us: self.seq * 40_000,
            gain: self.gain,
            agc: self.agc_on,
            bits: self.bits,
            width: self.w as u32,
            height: self.h as u32,
            pixels_crc32c: 0,
            status: FrameStatus::Ok,
            levels: None,
            exposure_us: None,
            gate_duty: None,
            nd_density: None,
            sensor: None,
        };
        self.seq += 1;
        if self.agc_on
            && let Some(a) = &self.agc
        {
            let out = sum / n as f64 - self.offset_dn;
            let g = if out > 0.0 {
                (self.gain.ln() + a.alpha * (a.setpoint_dn / out).ln()).exp()
            } else {
                a.max_gain
            };
            self.gain = g.clamp(a.min_gain, a.max_gain);
        }
        Ok(Frame { meta, pixels })
    }
}
