//! [`Chain`]: a validated configuration reduced to the numbers the capture
//! passes and the analytic transfer need. Gain-dependent figures take the
//! gain as an argument.

use gloam_spectra::{Spectrum, lookup, photons_per_joule};

use super::ebccd::EbParams;
use super::mcp::Mcp;
use super::mtf::MtfStage;
use super::phosphor::Screen;
use super::{ccd, coupling, optics, photocathode, video};
use crate::config::{Layout, SensorConfig, SensorKind, SpectrumRef};
use crate::error::ConfigError;

/// Resolves a spectral curve; errors name `field`.
pub fn resolve_spectrum(field: &str, r: &SpectrumRef) -> Result<Spectrum, ConfigError> {
    let err = |m: String| ConfigError::Spectrum {
        field: field.to_string(),
        message: m,
    };
    let s = match r {
        SpectrumRef::Constant(v) => {
            if !(v.is_finite() && *v >= 0.0 && *v <= 1.0) {
                return Err(err(format!("{v} is not an efficiency in 0–1")));
            }
            Spectrum::constant(200.0, 1200.0, *v).map_err(|e| err(e.to_string()))
        }
        // Unlogged: a loaded configuration's files were noted by its load
        // (`SensorConfig::load_preset_or_file`).
        SpectrumRef::Named(n) => {
            lookup(n, &gloam_io::ReadLog::off()).map_err(|e| err(e.to_string()))
        }
        SpectrumRef::Table {
            wavelength_nm,
            value,
        } => Spectrum::new(wavelength_nm.clone(), value.clone()).map_err(|e| err(e.to_string())),
    }?;
    // A quantum efficiency is a probability: above 1 is nonsense, not gain.
    if field.ends_with("qe")
        && let Some((w, v)) = s
            .wavelengths_nm()
            .iter()
            .zip(s.values())
            .find(|(_, v)| **v > 1.0)
    {
        return Err(err(format!(
            "quantum efficiency {v} at {w} nm is above 1 (a QE is a fraction of photons, 0–1)"
        )));
    }
    Ok(s)
}

/// How the camera's gain is set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GainControl {
    /// MCP: `G = G0 (V/V0)^k`.
    Mcp { g0: f64, v0: f64, k: f64 },
    /// EBCCD: `G = (V − dead)/w`.
    Ebccd { dead_ev: f64, pair_ev: f64 },
    /// Plain CCD: the digitizer's analogue gain (no voltage).
    Analog,
}

impl GainControl {
    pub fn gain_at(&self, v: f64) -> f64 {
        match *self {
            GainControl::Mcp { g0, v0, k } => g0 * (v / v0).powf(k),
            GainControl::Ebccd { dead_ev, pair_ev } => (v - dead_ev) / pair_ev,
            GainControl::Analog => v,
        }
    }
    /// The control voltage giving gain `g` (None for a plain CCD).
    pub fn voltage_for(&self, g: f64) -> Option<f64> {
        match *self {
            GainControl::Mcp { g0, v0, k } => Some(v0 * (g / g0).powf(1.0 / k)),
            GainControl::Ebccd { dead_ev, pair_ev } => Some(g * pair_ev + dead_ev),
            GainControl::Analog => None,
        }
    }
}

/// The intensifier of an ICCD, from the MCP to the CCD's electrons.
#[derive(Clone, Debug)]
pub struct Intensifier {
    pub mcp: Mcp,
    /// Photons per electron at the screen.
    pub phosphor_photons_per_e: f64,
    /// Fraction of the screen's light that reaches the CCD.
    pub coupling_fraction: f64,
    /// CCD QE at the phosphor's spectrum.
    pub ccd_qe_at_phosphor: f64,
    /// CCD electrons per MCP output electron.
    pub ccd_e_per_mcp_e: f64,
    /// Phosphor persistence: fraction of a frame's light in later frames.
    pub lag_fraction: f64,
}

/// The gain stage between the detecting surface and the CCD, one variant
/// per sensor kind.
#[derive(Clone, Debug)]
pub enum Tube {
    Iccd(Intensifier),
    Ebccd(EbParams),
    /// A plain CCD: no gain stage.
    Ccd,
}

/// Everything derived from a configuration that does not change frame to
/// frame. Gain-dependent figures take the gain as an argument.
#[derive(Clone, Debug)]
pub struct Chain {
    pub config: SensorConfig,
    pub kind: SensorKind,
    pub tube: Tube,
    /// Pixel pitch referred to the photocathode (the objective's image plane), mm.
    pub pitch_cathode_mm: f64,
    /// Pixel pitch on the CCD, mm.
    pub pitch_ccd_mm: f64,
    /// `π τ 10^−D d A_pix t / (4 N²)` (ND density D, gate duty d), m² sr s:
    /// photons per pixel per frame per unit spectral photon radiance.
    pub etendue_m2_sr_s: f64,
    /// QE of the first detecting surface (photocathode, or the CCD itself).
    pub detect_qe: Spectrum,
    /// Cathode luminous sensitivity to 2856 K light, A/lm (intensified only).
    pub luminous_sensitivity_a_lm: Option<f64>,
    /// Dark-emission photoelectrons per pixel per frame at the reference gain.
    pub ebi_pe_ref: f64,
    pub ebi_exponent: f64,
    /// Gain at which EBI is specified (the configured manual gain).
    pub reference_gain: f64,
    pub gain_control: GainControl,
    /// Hardware gain limits.
    pub gain_min: f64,
    pub gain_max: f64,
    pub dark_e_per_frame: f64,
    /// DN per CCD electron at unit analogue gain.
    pub base_dn_per_e: f64,
    pub black_dn: f64,
    /// Analogue video clip, DN (f64::INFINITY without video).
    pub clip_dn_unit_gain: f64,
    pub max_code: f64,
    /// Read + video noise, e⁻ rms.
    pub read_noise_e: f64,
    pub stages: Vec<MtfStage>,
}

/// The tube's gain law, with the gains at its minimum, maximum and set
/// voltages (the digitizer's analogue gain range on a bare CCD).
fn gain_law(tube: crate::config::Tube, cfg: &SensorConfig) -> (GainControl, f64, f64, f64) {
    let law = |gc: GainControl, lo_v: f64, hi_v: f64, set_v: f64| {
        (gc, gc.gain_at(lo_v), gc.gain_at(hi_v), gc.gain_at(set_v))
    };
    match tube {
        crate::config::Tube::Iccd { mcp: m, .. } => law(
            GainControl::Mcp {
                g0: m.gain_ref,
                v0: m.voltage_ref_v,
                k: m.exponent,
            },
            m.min_voltage_v,
            m.max_voltage_v,
            m.voltage_v,
        ),
        crate::config::Tube::Ebccd { ebccd: e, .. } => law(
            GainControl::Ebccd {
                dead_ev: e.dead_layer_ev,
                pair_ev: e.pair_energy_ev,
            },
            e.min_voltage_v,
            e.max_voltage_v,
            e.voltage_v,
        ),
        crate::config::Tube::Ccd { .. } => {
            let d = &cfg.digitizer;
            (
                GainControl::Analog,
                d.min_analog_gain,
                d.max_analog_gain,
                d.analog_gain,
            )
        }
    }
}

/// The chain's tube stages from the configured tube, their MTF stages
/// appended to `stages` (after the optics') in light's order.
fn chain_tube(
    tube: crate::config::Tube,
    cfg: &SensorConfig,
    (pitch_cathode_mm, pitch_ccd_mm): (f64, f64),
    stages: &mut Vec<MtfStage>,
) -> Result<Tube, ConfigError> {
    Ok(match tube {
        crate::config::Tube::Iccd {
            photocathode: p,
            mcp: m,
            phosphor: ph,
            coupling: c,
            ccd_qe,
        } => {
            stages.extend(photocathode::proximity_gap(
                "cathode-MCP gap",
                p.gap_mm,
                p.emission_energy_ev,
                p.gap_voltage_v,
                pitch_cathode_mm,
                false,
            ));
            stages.extend(Mcp::pore_mtf(m, pitch_cathode_mm));
            let mcp = Mcp::new(m, pitch_cathode_mm, cfg.timing.exposure_s);
            stages.extend(photocathode::proximity_gap(
                "MCP-screen gap",
                ph.gap_mm,
                ph.exit_energy_ev,
                ph.screen_voltage_v,
                pitch_cathode_mm,
                true,
            ));
            stages.extend(Screen::spread_mtf(ph, pitch_cathode_mm));
            let screen = Screen::new(ph);
            let coupling_fraction = coupling::collected_fraction(c);
            stages.extend(coupling::mtf_stage(c, &screen.spectrum, pitch_ccd_mm));
            let qe = resolve_spectrum("ccd.qe", ccd_qe)?;
            let ccd_qe_at_phosphor = ccd::qe_at_spectrum(&screen.spectrum, &qe);
            stages.extend(ccd::diffusion_mtf(&cfg.ccd, pitch_ccd_mm, true));
            Tube::Iccd(Intensifier {
                mcp,
                phosphor_photons_per_e: screen.photons_per_e,
                coupling_fraction,
                ccd_qe_at_phosphor,
                ccd_e_per_mcp_e: screen.photons_per_e * coupling_fraction * ccd_qe_at_phosphor,
                lag_fraction: screen.lag_fraction,
            })
        }
        crate::config::Tube::Ebccd {
            photocathode,
            ebccd,
        } => {
            // The cathode-CCD gap term depends on the voltage; it is added
            // per gain by `stages_at`.
            stages.extend(ccd::diffusion_mtf(&cfg.ccd, pitch_ccd_mm, true));
            Tube::Ebccd(EbParams::new(photocathode, ebccd))
        }
        crate::config::Tube::Ccd { .. } => {
            stages.extend(ccd::diffusion_mtf(&cfg.ccd, pitch_ccd_mm, false));
            Tube::Ccd
        }
    })
}

impl Chain {
    pub fn new(config: &SensorConfig) -> Result<Self, ConfigError> {
        let layout = config.layout()?;
        let cfg = config;
        let kind = cfg.kind;
        let Layout { tube, readout } = layout;
        let pitch_ccd_mm = cfg.ccd.pixel_pitch_um * 1e-3;
        let (pitch_cathode_mm, cathode) = match tube {
            crate::config::Tube::Iccd {
                photocathode,
                coupling,
                ..
            } => (pitch_ccd_mm / coupling.magnification, Some(photocathode)),
            crate::config::Tube::Ebccd { photocathode, .. } => (pitch_ccd_mm, Some(photocathode)),
            crate::config::Tube::Ccd { .. } => (pitch_ccd_mm, None),
        };
        let o = &cfg.optics;
        let a_pix_m2 = (pitch_cathode_mm * 1e-3).powi(2);
        // Light reaching the detector per frame: the camera equation, the
        // ND filter 10^−D and, for a gated cathode, the duty cycle.
        let duty = cathode.map_or(1.0, |p| p.gate_duty);
        let etendue = optics::image_irradiance_per_radiance(o.f_number, o.transmission)
            * 10f64.powf(-o.nd_density)
            * duty
            * a_pix_m2
            * cfg.timing.exposure_s;

        let detect_qe = match tube {
            crate::config::Tube::Iccd { photocathode, .. }
            | crate::config::Tube::Ebccd { photocathode, .. } => {
                resolve_spectrum("photocathode.qe", &photocathode.qe)?
            }
            crate::config::Tube::Ccd { ccd_qe } => resolve_spectrum("ccd.qe", ccd_qe)?,
        };

        let (gain_control, gain_min, gain_max, reference_gain) = gain_law(tube, cfg);

        let mut luminous_sensitivity_a_lm = None;
        let mut ebi_pe_ref = 0.0;
        let mut ebi_exponent = 0.0;
        if let Some(p) = cathode {
            let s = photocathode::luminous_sensitivity_a_lm(&detect_qe);
            luminous_sensitivity_a_lm = Some(s);
            ebi_pe_ref =
                photocathode::ebi_pe_per_frame(p, s, pitch_cathode_mm, cfg.timing.exposure_s);
            ebi_exponent = p.ebi_gain_exponent;
        }

        // Optics, at the cathode plane.
        let mut stages = optics::mtf_stages(o, pitch_cathode_mm);
        let tube = chain_tube(tube, cfg, (pitch_cathode_mm, pitch_ccd_mm), &mut stages)?;

        let d = &cfg.digitizer;
        let max_code = ((1u32 << d.bits) - 1) as f64;
        let transfer = video::Transfer::new(&readout, d, max_code);
        let read_noise_e = (cfg.ccd.read_noise_e.powi(2) + transfer.noise_e.powi(2)).sqrt();
        let dark_e_per_frame = cfg.ccd.dark_current_e_s * cfg.timing.exposure_s;

        let chain = Self {
            kind,
            tube,
            pitch_cathode_mm,
            pitch_ccd_mm,
            etendue_m2_sr_s: etendue,
            detect_qe,
            luminous_sensitivity_a_lm,
            ebi_pe_ref,
            ebi_exponent,
            reference_gain,
            gain_control,
            gain_min,
            gain_max,
            dark_e_per_frame,
            base_dn_per_e: transfer.base_dn_per_e,
            black_dn: transfer.black_dn,
            clip_dn_unit_gain: transfer.clip_dn,
            max_code,
            read_noise_e,
            stages,
            config: cfg.clone(),
        };
        chain.check_figures()?;
        Ok(chain)
    }

    /// The figures the stages derive, finite (and the light and gain
    /// positive): each field is checked alone, but an extreme finite one —
    /// `f_number = 1e-300`, an MCP `exponent = 1e300`, a `1e-300` µm pixel
    /// — overflowed or vanished in a product, and the camera gave black or
    /// saturated frames (`sensor describe`: gain range 0 – inf, EBI NaN)
    /// with exit 0. Each is named by the first field it comes from.
    fn check_figures(&self) -> Result<(), ConfigError> {
        let lit = self.config.optics.transmission > 0.0;
        let gain = match self.kind {
            SensorKind::Iccd => "mcp",
            SensorKind::Ebccd => "ebccd",
            SensorKind::Ccd => "digitizer",
        };
        let checks = [
            (
                "optics.f_number",
                "the light on a pixel per radiance (from optics.f_number, optics.transmission and the pixel pitch)",
                self.etendue_m2_sr_s,
                lit,
            ),
            (
                "ccd.pixel_pitch_um",
                "the pixel pitch on the cathode",
                self.pitch_cathode_mm,
                true,
            ),
            (gain, "the least gain", self.gain_min, true),
            (gain, "the greatest gain", self.gain_max, true),
            (gain, "the reference gain", self.reference_gain, true),
            (
                "photocathode.ebi_lm_cm2",
                "the EBI per pixel",
                self.ebi_pe_ref,
                false,
            ),
            (
                "ccd.dark_current_e_s",
                "the dark electrons per frame",
                self.dark_e_per_frame,
                false,
            ),
            (
                "ccd.read_noise_e",
                "the read noise (the CCD's and the video line's)",
                self.read_noise_e,
                false,
            ),
            (
                "digitizer",
                "the counts per electron",
                self.base_dn_per_e,
                true,
            ),
            ("digitizer", "the black level", self.black_dn, false),
        ];
        // At the least gain a photoelectron must stay below full scale: a
        // screen voltage of 1e300 made it 7e296 DN, and the frames black.
        let g = self.gain_min;
        let dn_pe = self.mean_dn_per_photoelectron(g);
        let full_pe = (self.saturation_dn(g) - self.black_dn(g)) / dn_pe;
        let checks = checks.into_iter().chain([(
            gain,
            "the photoelectrons that fill the range at the least gain (the tube's gain, screen and coupling against the digitizer)",
            if full_pe >= 1.0 { full_pe } else { 0.0 },
            true,
        )]);
        for (field, what, v, positive) in checks {
            if !v.is_finite() || (positive && v <= 0.0) {
                return Err(ConfigError::invalid(
                    field,
                    format!(
                        "{what} comes to {} with these values: a number this extreme leaves the model (check the table's values for ones far from any camera's)",
                        gloam_spectra::num(v)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The intensifier, for an ICCD.
    pub fn intensifier(&self) -> Option<&Intensifier> {
        match &self.tube {
            Tube::Iccd(i) => Some(i),
            _ => None,
        }
    }

    /// Phosphor persistence (0 without a phosphor).
    pub fn lag_fraction(&self) -> f64 {
        self.intensifier().map_or(0.0, |i| i.lag_fraction)
    }

    /// Analogue gain of the digitizer at camera gain `g`.
    fn analog_gain(&self, g: f64) -> f64 {
        match self.tube {
            Tube::Ccd => g,
            _ => self.config.digitizer.analog_gain,
        }
    }

    /// DN per CCD electron at gain `g`.
    pub fn dn_per_ccd_electron(&self, g: f64) -> f64 {
        self.base_dn_per_e * self.analog_gain(g)
    }

    /// Analogue video clip in DN at gain `g` (infinite without video).
    pub fn clip_dn(&self, g: f64) -> f64 {
        if self.config.video.is_none() {
            return f64::INFINITY;
        }
        let ag = self.analog_gain(g);
        let base = self.config.digitizer.analog_gain;
        // offset + ag·(clip − lo)·dn/V, rescaled from the configured gain.
        let off = self.config.digitizer.offset_dn;
        off + (self.clip_dn_unit_gain - off) * ag / base
    }

    /// Black level in DN at gain `g`.
    pub fn black_dn(&self, g: f64) -> f64 {
        let off = self.config.digitizer.offset_dn;
        off + (self.black_dn - off) * self.analog_gain(g) / self.config.digitizer.analog_gain
    }

    /// Mean CCD electrons per photoelectron leaving the detecting surface.
    pub fn ccd_e_per_pe(&self, g: f64) -> f64 {
        match &self.tube {
            Tube::Iccd(i) => i.mcp.open_area * g * i.ccd_e_per_mcp_e,
            Tube::Ebccd(e) => e.mean_gain(g),
            Tube::Ccd => 1.0,
        }
    }

    /// Mean DN per photoelectron at gain `g` (in the linear range).
    pub fn mean_dn_per_photoelectron(&self, g: f64) -> f64 {
        self.ccd_e_per_pe(g) * self.dn_per_ccd_electron(g)
    }

    /// Excess noise factor of the gain process referred to photoelectrons
    /// (1 for a plain CCD): ICCD `(1 + 1/s)/η + 1/(η G g_ccd)` (the last term
    /// is the CCD's own shot noise on the screen light); EBCCD from Fano and
    /// backscatter.
    pub fn excess_noise_factor(&self, g: f64) -> f64 {
        match &self.tube {
            Tube::Iccd(i) => {
                let eta = i.mcp.open_area;
                (1.0 + 1.0 / i.mcp.gain_shape) / eta
                    + 1.0 / (eta * g * i.ccd_e_per_mcp_e).max(1e-300)
            }
            Tube::Ebccd(e) => e.excess_noise_factor(g),
            Tube::Ccd => 1.0,
        }
    }

    /// Read (and video) noise in DN rms at gain `g`.
    pub fn read_noise_dn(&self, g: f64) -> f64 {
        self.read_noise_e * self.dn_per_ccd_electron(g)
    }

    /// The DN at which the output saturates (full well, video clip or the
    /// top code), as the digitizer rounds it. At full well, read noise still
    /// spreads the output by ± [`Chain::read_noise_dn`].
    pub fn saturation_dn(&self, g: f64) -> f64 {
        let fw = self.black_dn(g) + self.config.ccd.full_well_e * self.dn_per_ccd_electron(g);
        (fw.min(self.clip_dn(g)).min(self.max_code) + 0.5).floor()
    }

    /// The DN at and above which a pixel counts as saturated at gain `g`
    /// ([`crate::levels::saturated_threshold_dn`]).
    pub fn saturated_threshold_dn(&self, g: f64) -> f64 {
        crate::levels::saturated_threshold_dn(self.saturation_dn(g), self.read_noise_dn(g))
    }

    /// Dark-emission photoelectrons per pixel per frame at gain `g`.
    pub fn ebi_pe(&self, g: f64) -> f64 {
        if self.ebi_pe_ref == 0.0 {
            return 0.0;
        }
        self.ebi_pe_ref * (g / self.reference_gain).powf(self.ebi_exponent)
    }

    /// The MTF stages in effect at gain `g` (the EBCCD's gap depends on its voltage).
    pub fn stages_at(&self, g: f64) -> Vec<MtfStage> {
        let mut s = self.stages.clone();
        if let Tube::Ebccd(e) = &self.tube {
            s.extend(photocathode::proximity_gap(
                "cathode-CCD gap",
                e.gap_mm,
                e.emission_ev,
                e.voltage_for(g),
                self.pitch_cathode_mm,
                false,
            ));
        }
        s
    }

    /// Product of all stage MTFs at `f` cycles/pixel along a row or column.
    pub fn mtf(&self, f_cy_px: f64, g: f64) -> f64 {
        self.stages_at(g)
            .iter()
            .map(|s| s.term.at(f_cy_px))
            .product()
    }

    /// Photoelectrons per pixel per frame at a spectral shape `shape` (any
    /// scale; normalised here) per unit band radiance (W m⁻² sr⁻¹), on axis.
    pub fn pe_per_radiance(&self, shape: &Spectrum) -> Option<f64> {
        let total = shape.integral();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let e_per_j = shape
            .map_all(|w, x| x * photons_per_joule(w))
            .integrate_weighted(&self.detect_qe)
            / total;
        Some(self.etendue_m2_sr_s * e_per_j)
    }

    /// The detecting surface's response to radiance, electrons per joule:
    /// QE(λ) · λ/(hc) (photocathode, or the CCD of a plain CCD). A band with
    /// this response turns spectral radiance into the detected-electron
    /// radiance `∫ L QE λ/hc dλ` (e⁻ s⁻¹ m⁻² sr⁻¹) that
    /// [`crate::Camera::capture_detected`] takes, exact for any spectrum.
    pub fn detected_response_e_per_j(&self) -> Spectrum {
        self.detect_qe.map_all(|w, q| q * photons_per_joule(w))
    }
}
