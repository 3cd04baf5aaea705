//! The analytic transfer of a chain: mean DN, noise, saturation and MTF at a
//! gain, used by tests, `gloam sensor describe` and calibration.

use std::fmt;

use gloam_spectra::Spectrum;
use serde::Serialize;

use crate::config::SensorKind;
use crate::error::CaptureError;
use crate::kernel::Kernel;
use crate::stages::{Chain, Tube};

/// Derived figures of a camera at one gain (`gloam sensor describe`).
#[derive(Clone, Debug, Serialize)]
pub struct Description {
    pub name: String,
    pub kind: SensorKind,
    pub gain: f64,
    pub gain_min: f64,
    pub gain_max: f64,
    pub control_voltage_v: Option<f64>,
    pub dn_per_photoelectron: f64,
    pub excess_noise_factor: f64,
    pub read_noise_dn: f64,
    pub saturation_dn: f64,
    pub black_dn: f64,
    pub bit_depth: u8,
    /// Photoelectrons per pixel per frame that saturate the output.
    pub saturation_photoelectrons: f64,
    /// Dark-emission photoelectrons per pixel per frame at this gain.
    pub ebi_photoelectrons_per_pixel: f64,
    pub cathode_luminous_sensitivity_ua_lm: Option<f64>,
    pub phosphor_photons_per_electron: Option<f64>,
    pub ccd_electrons_per_photoelectron: f64,
    pub pixel_pitch_cathode_um: f64,
    pub pixel_pitch_ccd_um: f64,
    /// Combined MTF at 0.25 and 0.5 cycles/pixel.
    pub mtf_quarter_nyquist_half: [f64; 2],
    /// Per stage: (name, MTF at Nyquist).
    pub mtf_stages_at_nyquist: Vec<(String, f64)>,
}

impl Chain {
    /// Σh² of the separable post-noise blur (2-D: product of the 1-D sums),
    /// i.e. the factor by which correlated gain noise is reduced per pixel.
    pub fn post_noise_variance_factor(&self, g: f64) -> f64 {
        let stages = self.stages_at(g);
        let post: Vec<_> = stages.iter().filter(|s| s.after_noise).collect();
        match Kernel::from_mtf(|f| post.iter().map(|s| s.term.at(f)).product()) {
            Some(k) => k.sum_sq * k.sum_sq,
            None => 1.0,
        }
    }

    /// Mean CCD electrons for `pe` photoelectrons per pixel per frame (EBI
    /// and dark current added; MCP compression applied to the mean).
    pub fn expected_ccd_electrons(&self, pe: f64, g: f64) -> f64 {
        let lam = pe + self.ebi_pe(g);
        let signal = match &self.tube {
            Tube::Iccd(i) => i.ccd_e_per_mcp_e * i.mcp.compress(i.mcp.open_area * lam * g),
            _ => lam * self.ccd_e_per_pe(g),
        };
        signal + self.dark_e_per_frame
    }

    /// Expected mean DN of a uniform field giving `pe` photoelectrons per
    /// pixel per frame (before quantisation; clipped at saturation).
    pub fn expected_mean_dn_from_pe(&self, pe: f64, g: f64) -> f64 {
        let dn =
            self.black_dn(g) + self.expected_ccd_electrons(pe, g) * self.dn_per_ccd_electron(g);
        dn.clamp(0.0, self.saturation_dn(g))
    }

    /// Photoelectrons per pixel per frame on axis for uniform band radiance
    /// `radiance_w_m2_sr` of spectral shape `shape` (cos⁴θ = 1).
    pub fn photoelectrons_per_pixel(&self, radiance_w_m2_sr: f64, shape: &Spectrum) -> f64 {
        self.pe_per_radiance(shape).unwrap_or(0.0) * radiance_w_m2_sr
    }

    /// Expected mean DN on axis for a uniform radiance.
    pub fn expected_mean_dn(&self, radiance_w_m2_sr: f64, shape: &Spectrum, g: f64) -> f64 {
        self.expected_mean_dn_from_pe(self.photoelectrons_per_pixel(radiance_w_m2_sr, shape), g)
    }

    /// Temporal variance per pixel, DN², of a uniform field of `pe`
    /// photoelectrons per pixel per frame in the linear range, in steady
    /// state: shot × excess noise (reduced by the post-noise blur and the
    /// phosphor persistence), the CCD's shot and dark noise, read noise and
    /// quantisation (1/12 DN²).
    pub fn temporal_variance_dn2_from_pe(&self, pe: f64, g: f64) -> f64 {
        let lam = pe + self.ebi_pe(g);
        let s2 = self.post_noise_variance_factor(g);
        let dark = self.dark_e_per_frame;
        let var_e = match &self.tube {
            Tube::Iccd(i) => {
                let p = i.lag_fraction;
                let lag = (1.0 - p) / (1.0 + p);
                let eta = i.mcp.open_area;
                let q = eta * lam * g;
                let var_q = eta * lam * g * g * (1.0 + 1.0 / i.mcp.gain_shape);
                i.ccd_e_per_mcp_e.powi(2) * var_q * s2 * lag + i.ccd_e_per_mcp_e * q + dark
            }
            Tube::Ebccd(e) => {
                let b = e.backscatter;
                let m2 = g * g * ((1.0 - b) * (1.0 + e.fano / g) + b / 3.0);
                lam * m2 * s2 + dark
            }
            Tube::Ccd => lam + dark,
        };
        let k = self.dn_per_ccd_electron(g);
        k * k * (var_e + self.read_noise_e.powi(2)) + 1.0 / 12.0
    }

    /// Noise factor seen per pixel: the variance/mean slope of the output
    /// (EMVA 1288's "K") over the DN per photoelectron `g`, so that
    /// `K_eff = g · F_pix`. From [`Chain::temporal_variance_dn2_from_pe`]
    /// per photoelectron over `g²`: ICCD `(F − F_ccd)·Σh²·(1−p)/(1+p) +
    /// F_ccd` with `F` [`Chain::excess_noise_factor`], `F_ccd = 1/(η G
    /// g_ccd)` the CCD's shot noise on the screen light, `Σh²` the post-noise
    /// blur and `p` the phosphor persistence; EBCCD `F·Σh²`; a plain CCD 1.
    /// Why not `F` alone: the blur after the gain process averages the
    /// excess noise over neighbouring pixels, so a pixel sees less of it.
    pub fn pixel_noise_factor(&self, g: f64) -> f64 {
        let s2 = self.post_noise_variance_factor(g);
        match &self.tube {
            Tube::Iccd(i) => {
                let p = i.lag_fraction;
                let lag = (1.0 - p) / (1.0 + p);
                let eta = i.mcp.open_area;
                let f_ccd = 1.0 / (eta * g * i.ccd_e_per_mcp_e).max(1e-300);
                (self.excess_noise_factor(g) - f_ccd) * s2 * lag + f_ccd
            }
            Tube::Ebccd(_) => self.excess_noise_factor(g) * s2,
            Tube::Ccd => 1.0,
        }
    }

    /// Spatial variance from the fixed patterns (PRNU, DSNU), DN², for the same field.
    pub fn fixed_pattern_variance_dn2_from_pe(&self, pe: f64, g: f64) -> f64 {
        let k = self.dn_per_ccd_electron(g);
        let signal = self.expected_ccd_electrons(pe, g) - self.dark_e_per_frame;
        let prnu = self.config.ccd.prnu * signal;
        k * k * (prnu * prnu + self.config.ccd.dsnu_e.powi(2))
    }

    /// The figures `gloam sensor describe` prints.
    pub fn describe(&self, g: f64) -> Description {
        let dn_pe = self.mean_dn_per_photoelectron(g);
        let sat = self.saturation_dn(g);
        let black = self.black_dn(g);
        let stages = self.stages_at(g);
        Description {
            name: self.config.name.clone(),
            kind: self.kind,
            gain: g,
            gain_min: self.gain_min,
            gain_max: self.gain_max,
            control_voltage_v: self.gain_control.voltage_for(g),
            dn_per_photoelectron: dn_pe,
            excess_noise_factor: self.excess_noise_factor(g),
            read_noise_dn: self.read_noise_dn(g),
            saturation_dn: sat,
            black_dn: black,
            bit_depth: self.config.digitizer.bits,
            saturation_photoelectrons: ((sat - black) / dn_pe).max(0.0),
            ebi_photoelectrons_per_pixel: self.ebi_pe(g),
            cathode_luminous_sensitivity_ua_lm: self.luminous_sensitivity_a_lm.map(|s| s * 1e6),
            phosphor_photons_per_electron: self.intensifier().map(|i| i.phosphor_photons_per_e),
            ccd_electrons_per_photoelectron: self.ccd_e_per_pe(g),
            pixel_pitch_cathode_um: self.pitch_cathode_mm * 1e3,
            pixel_pitch_ccd_um: self.pitch_ccd_mm * 1e3,
            mtf_quarter_nyquist_half: [self.mtf(0.25, g), self.mtf(0.5, g)],
            mtf_stages_at_nyquist: stages
                .iter()
                .map(|s| (s.name.to_string(), s.term.at(0.5)))
                .collect(),
        }
    }
}

impl Chain {
    /// The figures at `gain` (default: the configured gain), refusing a gain
    /// outside the chain's range as [`crate::Camera::set_override_gain`]
    /// does, so `gloam sensor describe` and Python's `Sensor.describe` agree.
    pub fn describe_checked(&self, gain: Option<f64>) -> Result<Description, CaptureError> {
        let g = gain.unwrap_or(self.reference_gain);
        if !(g.is_finite()
            && g >= self.gain_min * (1.0 - 1e-9)
            && g <= self.gain_max * (1.0 + 1e-9))
        {
            return Err(CaptureError::GainOutOfRange {
                gain: g,
                min: self.gain_min,
                max: self.gain_max,
                camera: self.config.name.clone(),
            });
        }
        Ok(self.describe(g))
    }
}

/// The text `gloam sensor describe` prints, one figure a line.
impl fmt::Display for Description {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} ({:?}) at gain {:.4}",
            self.name, self.kind, self.gain
        )?;
        if let Some(v) = self.control_voltage_v {
            writeln!(f, "  control voltage        {v:.1} V")?;
        }
        let (lo, hi) = (self.gain_min, self.gain_max);
        writeln!(f, "  gain range             {lo:.4} – {hi:.4}")?;
        writeln!(
            f,
            "  DN per photoelectron   {:.6}",
            self.dn_per_photoelectron
        )?;
        writeln!(
            f,
            "  excess noise factor    {:.4}",
            self.excess_noise_factor
        )?;
        writeln!(f, "  read noise             {:.3} DN", self.read_noise_dn)?;
        writeln!(f, "  black level            {:.2} DN", self.black_dn)?;
        writeln!(
            f,
            "  saturation             {:.0} DN ({:.4} photoelectrons)",
            self.saturation_dn, self.saturation_photoelectrons
        )?;
        writeln!(f, "  bit depth              {}", self.bit_depth)?;
        writeln!(
            f,
            "  EBI                    {:.3e} photoelectrons/pixel/frame",
            self.ebi_photoelectrons_per_pixel
        )?;
        if let Some(s) = self.cathode_luminous_sensitivity_ua_lm {
            writeln!(f, "  cathode sensitivity    {s:.0} µA/lm (2856 K)")?;
        }
        let [q, h] = self.mtf_quarter_nyquist_half;
        write!(f, "  MTF at 0.25 / 0.5 cy/px {q:.3} / {h:.3}")
    }
}
