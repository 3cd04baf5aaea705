//! The physics of each stage, reduced to the numbers the capture loop and
//! the analytic transfer need ([`Chain`]).
//!
//! # Stage models (and where they come from)
//!
//! * **Optics** — camera equation for a distant scene:
//!   `E = π L τ cos⁴θ / (4 N²)` (the `(1+m)²` factor of the general form
//!   `π L τ / (4 N² (1+m)²)` is dropped because m ≈ 0 for distant scenes).
//!   Photoelectrons per pixel per frame `= ∫ E_λ QE(λ) λ/(hc) dλ · A_pix · t`.
//!   MTF: diffraction of a circular pupil,
//!   `M(ν) = (2/π)(acos x − x √(1−x²))`, `x = ν λ N`; optional defocus as a
//!   geometric blur circle of diameter `d = δz / N`, `M = 2 J1(π d ν)/(π d ν)`.
//! * **Photocathode** — spectral QE from the library (S-20, S-25, Gen III
//!   GaAs, GaAsP), a CSV file or an inline table; Poisson shot noise; dark
//!   emission as equivalent background illumination (EBI, lm cm⁻²)
//!   converted with the luminous sensitivity to 2856 K light
//!   `S = q ∫QE·P_A·λ/hc dλ / (683 ∫V·P_A dλ)` (A/lm), scaled by
//!   `(G/G_ref)^ebi_gain_exponent`.
//! * **Proximity focus** — an electron leaving with transverse energy ε
//!   crosses gap L at voltage V in `t = L √(2m/(eV))`; its landing spread per
//!   axis is Gaussian with `σ = L √(2ε/V)` (ε in eV, V in volts), so
//!   `M(ν) = exp(−2π²σ²ν²)` (Csorba, *Image Tubes*, 1985, ch. 4).
//! * **MCP** — `G = G0 (V/V0)^k` (Wiza, NIM 162 (1979) 587: gain is close to
//!   a power law of plate voltage over the working range). Only a fraction η
//!   (open area / first strike) of photoelectrons start a cascade. Single
//!   electron gain is gamma distributed with shape s, so the variance of the
//!   cascade is `G²/s` and the excess noise factor, referred to the
//!   photoelectrons leaving the cathode, is `F = (1 + 1/s)/η` (Eberhardt,
//!   IEEE TNS 28 (1981) 712; Frenkel et al., Appl. Opt. 36 (1997) 5288). The
//!   sum of n cascades is sampled exactly as one `Gamma(n s, G/s)` draw.
//!   Saturation: a soft knee `Q' = Q / √(1 + (Q/Q_sat)²)` with Q_sat the
//!   charge a pixel's channels deliver at the output current limit in a frame.
//!   Channel sampling MTF `2 J1(π p ν)/(π p ν)` for pore pitch p.
//! * **Phosphor** — photons per electron `η_E (V_s − V_dead) / ⟨hν⟩`;
//!   emission spectra: P20 (ZnCdS:Ag) Gaussian 560 nm, 95 nm FWHM; P43
//!   (Gd₂O₂S:Tb) as its Tb³⁺ lines 489/545/586/622 nm (0.15/0.60/0.15/0.10 of
//!   the power); P46 (YAG:Ce) Gaussian 530 nm, 110 nm FWHM (shapes after
//!   JEDEC TEP116-C). Spread: Gaussian σ or exponential (Lorentzian MTF
//!   `1/(1+(2πaν)²)`). Persistence: a fraction `p` of a frame's light comes
//!   out in later frames, decaying geometrically: `S_n = (1−p) X_n + p S_{n−1}`.
//! * **Coupling** — fibre plate / taper: transmission, fibre MTF
//!   `2 J1(π p ν)/(π p ν)`, fixed hexagonal chicken-wire pattern of multifibre
//!   boundaries; relay lens: collected fraction `τ / (4 N² (1+m)²)` of the
//!   Lambertian screen's exitance, diffraction MTF at working f-number
//!   `N (1+m)`.
//! * **EBCCD** — gain `(V − dead layer)/w`, w = 3.65 eV per pair in Si
//!   (Janesick, *Scientific CCDs*, 2001); Fano factor 0.12; a fraction b of
//!   electrons backscatter and deposit a uniform fraction of their energy, so
//!   the mean gain is `G(1 − b/2)` and `F = ((1−b)(1 + f/G) + b/3)/(1 − b/2)²`.
//! * **CCD** — QE (at the phosphor's spectrum in an ICCD, at the scene's in
//!   a plain CCD), PRNU (multiplicative) and DSNU (additive) fixed patterns,
//!   dark current (Poisson), full well with blooming along columns, read
//!   noise, charge-diffusion MTF (Gaussian σ).
//! * **Video / digitizer** — `V = V_black + e (V_white − V_black)/e_full`,
//!   clipped at the white clip; `DN = offset + g (V − V_lo)(2^b − 1)/(V_hi − V_lo)`
//!   rounded and clipped to `0..2^b − 1`. Without video: `DN = offset + g e / (e/DN)`.
//!
//! # Where MTFs act
//!
//! Blurs that move single quanta independently (optics, the cathode gap,
//! channel sampling, and for a plain CCD its charge diffusion) act on the
//! *mean* photoelectron rate before shot noise: a randomly displaced Poisson
//! process is again Poisson. Blurs of the charge cloud one photoelectron makes
//! (MCP→screen gap, phosphor, fibre, relay, the intensified CCD's diffusion)
//! act *after* the gain noise, so that noise is spatially correlated and its
//! per-pixel variance drops by `Σ h²` of the blur kernel.

use gloam_spectra::{EmissionLine, KM_PHOTOPIC_LM_W, Spectrum, library, lookup, photons_per_joule};

use crate::config::{
    CouplingKind, PhosphorType, SensorConfig, SensorKind, SpectrumRef, SpreadShape,
};
use crate::error::ConfigError;

/// Elementary charge, C.
pub const ELEMENTARY_CHARGE_C: f64 = 1.602_176_634e-19;
/// hc in eV nm.
const HC_EV_NM: f64 = 1_239.841_984;

/// Image-plane irradiance per unit scene radiance on axis, sr: the camera
/// equation `E / L = π τ / (4 N²)` for a distant scene (working f-number N,
/// optics transmission τ). The one place this factor is computed: the camera
/// chain's étendue and the calibration rig's photon count both use it.
pub fn image_irradiance_per_radiance(f_number: f64, transmission: f64) -> f64 {
    std::f64::consts::PI * transmission / (4.0 * f_number * f_number)
}

/// Defaults of a phosphor type.
#[derive(Clone, Copy, Debug)]
pub struct PhosphorDefaults {
    pub energy_efficiency: f64,
    pub dead_voltage_v: f64,
    pub lag_fraction: f64,
}

/// Energy efficiencies are typical forward-emission values for aluminised
/// screens in image tubes (P20 ≈ 0.10, P43 ≈ 0.08, P46 ≈ 0.03; ZnS-type
/// phosphors are the most efficient, YAG:Ce trades efficiency for speed).
/// Dead voltage 2 kV is typical for the aluminium film. Lag fractions are
/// *assumed* afterglow carried into the next 40 ms frame: P20's hyperbolic
/// tail ≈ 1 %, P43 ≈ 0.2 % (1 ms to 10 %), P46 (≈ 0.3 µs) none.
pub fn phosphor_defaults(p: PhosphorType) -> PhosphorDefaults {
    match p {
        PhosphorType::P20 => PhosphorDefaults {
            energy_efficiency: 0.10,
            dead_voltage_v: 2000.0,
            lag_fraction: 0.01,
        },
        PhosphorType::P43 => PhosphorDefaults {
            energy_efficiency: 0.08,
            dead_voltage_v: 2000.0,
            lag_fraction: 0.002,
        },
        PhosphorType::P46 => PhosphorDefaults {
            energy_efficiency: 0.03,
            dead_voltage_v: 2000.0,
            lag_fraction: 0.0,
        },
    }
}

/// Relative spectral power of a phosphor's emission (integral 1).
pub fn phosphor_spectrum(p: PhosphorType) -> Spectrum {
    let gaussian = |peak: f64, fwhm: f64| {
        let sigma = fwhm / 2.354_820_045;
        let grid: Vec<f64> = (0..=120).map(|i| 350.0 + 4.0 * i as f64).collect();
        let v = grid
            .iter()
            .map(|&w| (-0.5 * ((w - peak) / sigma).powi(2)).exp())
            .collect();
        Spectrum::new(grid, v).expect("static grid")
    };
    let s = match p {
        PhosphorType::P20 => gaussian(560.0, 95.0),
        PhosphorType::P46 => gaussian(530.0, 110.0),
        PhosphorType::P43 => Spectrum::from_lines(
            [(489.0, 0.15), (545.0, 0.60), (586.0, 0.15), (622.0, 0.10)]
                .iter()
                .map(|&(w, v)| EmissionLine {
                    wavelength_nm: w,
                    value: v,
                })
                .collect(),
        )
        .expect("static lines"),
    };
    let total = s.integral();
    s.scaled(1.0 / total).expect("positive")
}

/// Resolves a spectral curve; errors name `field`.
pub fn resolve_spectrum(field: &str, r: &SpectrumRef) -> Result<Spectrum, ConfigError> {
    let err = |m: String| ConfigError::Spectrum {
        field: field.to_string(),
        message: m,
    };
    match r {
        SpectrumRef::Constant(v) => {
            if !(v.is_finite() && *v >= 0.0 && *v <= 1.0) {
                return Err(err(format!("{v} is not an efficiency in 0–1")));
            }
            Spectrum::constant(200.0, 1200.0, *v).map_err(|e| err(e.to_string()))
        }
        SpectrumRef::Named(n) => lookup(n).map_err(|e| err(e.to_string())),
        SpectrumRef::Table {
            wavelength_nm,
            value,
        } => Spectrum::new(wavelength_nm.clone(), value.clone()).map_err(|e| err(e.to_string())),
    }
}

/// One analytic MTF term, in pixel units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MtfTerm {
    /// Circular-pupil diffraction with cutoff `1/(λN)` in cycles/pixel.
    Diffraction { cutoff_cy_px: f64 },
    /// `2 J1(π d f)/(π d f)`, d in pixels (blur circle, pore or fibre aperture).
    Jinc { diameter_px: f64 },
    /// `exp(−2π² σ² f²)`.
    Gaussian { sigma_px: f64 },
    /// `1 / (1 + (2π a f)²)` (exponential line spread).
    Lorentzian { length_px: f64 },
}

impl MtfTerm {
    /// The MTF at `f` cycles/pixel.
    pub fn at(&self, f: f64) -> f64 {
        let f = f.abs();
        match *self {
            MtfTerm::Diffraction { cutoff_cy_px } => {
                let x = f / cutoff_cy_px;
                if x >= 1.0 {
                    0.0
                } else {
                    (2.0 / std::f64::consts::PI) * (x.acos() - x * (1.0 - x * x).sqrt())
                }
            }
            MtfTerm::Jinc { diameter_px } => jinc(std::f64::consts::PI * diameter_px * f),
            MtfTerm::Gaussian { sigma_px } => {
                (-2.0 * std::f64::consts::PI.powi(2) * sigma_px * sigma_px * f * f).exp()
            }
            MtfTerm::Lorentzian { length_px } => {
                1.0 / (1.0 + (2.0 * std::f64::consts::PI * length_px * f).powi(2))
            }
        }
    }
}

/// `2 J1(z)/z`, 1 at z = 0.
pub fn jinc(z: f64) -> f64 {
    if z.abs() < 1e-8 {
        1.0
    } else {
        2.0 * bessel_j1(z) / z
    }
}

/// Bessel J1 (Numerical Recipes rational/asymptotic approximations, |err| < 1e-7).
pub fn bessel_j1(x: f64) -> f64 {
    let ax = x.abs();
    if ax < 8.0 {
        let y = x * x;
        let a1 = x
            * (72362614232.0
                + y * (-7895059235.0
                    + y * (242396853.1
                        + y * (-2972611.439 + y * (15704.48260 + y * (-30.16036606))))));
        let a2 = 144725228442.0
            + y * (2300535178.0
                + y * (18583304.74 + y * (99447.43394 + y * (376.9991397 + y * 1.0))));
        a1 / a2
    } else {
        let z = 8.0 / ax;
        let y = z * z;
        let xx = ax - 3.0 * std::f64::consts::FRAC_PI_4;
        let a1 = 1.0
            + y * (0.183105e-2
                + y * (-0.3516396496e-4 + y * (0.2457520174e-5 + y * (-0.240337019e-6))));
        let a2 = 0.04687499995
            + y * (-0.2002690873e-3
                + y * (0.8449199096e-5 + y * (-0.88228987e-6 + y * 0.105787412e-6)));
        let ans = (std::f64::consts::FRAC_2_PI / ax).sqrt() * (xx.cos() * a1 - z * xx.sin() * a2);
        if x < 0.0 { -ans } else { ans }
    }
}

/// A named stage MTF and whether it acts after the gain noise.
#[derive(Clone, Debug, PartialEq)]
pub struct MtfStage {
    pub name: &'static str,
    pub term: MtfTerm,
    pub after_noise: bool,
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

/// The EBCCD's electron-bombarded gain process.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EbParams {
    pub backscatter: f64,
    pub fano: f64,
    pub gap_mm: f64,
    pub emission_ev: f64,
}

/// Everything derived from a configuration that does not change frame to
/// frame. Gain-dependent figures take the gain as an argument.
#[derive(Clone, Debug)]
pub struct Chain {
    pub config: SensorConfig,
    pub kind: SensorKind,
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
    /// MCP open-area fraction η and gamma shape s (ICCD).
    pub open_area: f64,
    pub gain_shape: f64,
    /// MCP saturation charge per pixel per frame, e⁻ (None = no saturation).
    pub mcp_saturation_e: Option<f64>,
    mcp_saturation_inv: f64,
    pub phosphor_photons_per_e: f64,
    pub coupling_fraction: f64,
    pub ccd_qe_at_phosphor: f64,
    /// CCD electrons per MCP output electron (ICCD).
    pub ccd_e_per_mcp_e: f64,
    pub lag_fraction: f64,
    pub eb: Option<EbParams>,
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

impl Chain {
    pub fn new(config: &SensorConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let cfg = config.clone();
        let kind = cfg.kind;
        let pitch_ccd_mm = cfg.ccd.pixel_pitch_um * 1e-3;
        let pitch_cathode_mm = match (&cfg.coupling, kind) {
            (Some(c), SensorKind::Iccd) => pitch_ccd_mm / c.magnification,
            _ => pitch_ccd_mm,
        };
        let o = &cfg.optics;
        let a_pix_m2 = (pitch_cathode_mm * 1e-3).powi(2);
        // Light reaching the detector per frame: the camera equation, the
        // ND filter 10^−D and, for a gated cathode, the duty cycle.
        let duty = cfg.photocathode.as_ref().map_or(1.0, |p| p.gate_duty);
        let etendue = image_irradiance_per_radiance(o.f_number, o.transmission)
            * 10f64.powf(-o.nd_density)
            * duty
            * a_pix_m2
            * cfg.timing.exposure_s;

        let detect_qe = match (&cfg.photocathode, kind) {
            (Some(p), _) => resolve_spectrum("photocathode.qe", &p.qe)?,
            (None, _) => resolve_spectrum("ccd.qe", cfg.ccd.qe.as_ref().expect("validated"))?,
        };

        let (gain_control, gain_min, gain_max, reference_gain) = match kind {
            SensorKind::Iccd => {
                let m = cfg.mcp.as_ref().expect("validated");
                let gc = GainControl::Mcp {
                    g0: m.gain_ref,
                    v0: m.voltage_ref_v,
                    k: m.exponent,
                };
                (
                    gc,
                    gc.gain_at(m.min_voltage_v),
                    gc.gain_at(m.max_voltage_v),
                    gc.gain_at(m.voltage_v),
                )
            }
            SensorKind::Ebccd => {
                let e = cfg.ebccd.as_ref().expect("validated");
                let gc = GainControl::Ebccd {
                    dead_ev: e.dead_layer_ev,
                    pair_ev: e.pair_energy_ev,
                };
                (
                    gc,
                    gc.gain_at(e.min_voltage_v),
                    gc.gain_at(e.max_voltage_v),
                    gc.gain_at(e.voltage_v),
                )
            }
            SensorKind::Ccd => {
                let d = &cfg.digitizer;
                (
                    GainControl::Analog,
                    d.min_analog_gain,
                    d.max_analog_gain,
                    d.analog_gain,
                )
            }
        };

        let mut luminous_sensitivity_a_lm = None;
        let mut ebi_pe_ref = 0.0;
        let mut ebi_exponent = 0.0;
        if let Some(p) = &cfg.photocathode {
            let a = library::get("cie-a").expect("built-in");
            let v = library::photopic_v();
            let electrons_per_w = a
                .map_all(|w, x| x * photons_per_joule(w))
                .integrate_weighted(&detect_qe);
            let lumens = KM_PHOTOPIC_LM_W * a.integrate_weighted(v);
            let s = ELEMENTARY_CHARGE_C * electrons_per_w / lumens;
            luminous_sensitivity_a_lm = Some(s);
            let a_pix_cm2 = (pitch_cathode_mm * 0.1).powi(2);
            ebi_pe_ref = p.ebi_lm_cm2 * s / ELEMENTARY_CHARGE_C
                * a_pix_cm2
                * cfg.timing.exposure_s
                * p.gate_duty;
            ebi_exponent = p.ebi_gain_exponent;
        }

        let mut open_area = 1.0;
        let mut gain_shape = f64::INFINITY;
        let mut mcp_saturation_e = None;
        let mut phosphor_photons_per_e = 0.0;
        let mut coupling_fraction = 0.0;
        let mut ccd_qe_at_phosphor = 0.0;
        let mut lag_fraction = 0.0;
        let mut stages = Vec::new();

        // Optics, at the cathode plane.
        if o.diffraction {
            let cutoff_cy_mm = 1.0 / (o.diffraction_wavelength_nm * 1e-6 * o.f_number);
            stages.push(MtfStage {
                name: "optics diffraction",
                term: MtfTerm::Diffraction {
                    cutoff_cy_px: cutoff_cy_mm * pitch_cathode_mm,
                },
                after_noise: false,
            });
        }
        if o.defocus_um > 0.0 {
            stages.push(MtfStage {
                name: "optics defocus",
                term: MtfTerm::Jinc {
                    diameter_px: o.defocus_um * 1e-3 / o.f_number / pitch_cathode_mm,
                },
                after_noise: false,
            });
        }

        let mut eb = None;
        match kind {
            SensorKind::Iccd => {
                let p = cfg.photocathode.as_ref().expect("validated");
                let m = cfg.mcp.as_ref().expect("validated");
                let ph = cfg.phosphor.as_ref().expect("validated");
                let c = cfg.coupling.as_ref().expect("validated");
                push_gap(
                    &mut stages,
                    "cathode-MCP gap",
                    p.gap_mm,
                    p.emission_energy_ev,
                    p.gap_voltage_v,
                    pitch_cathode_mm,
                    false,
                );
                if m.pore_pitch_um > 0.0 {
                    stages.push(MtfStage {
                        name: "MCP channels",
                        term: MtfTerm::Jinc {
                            diameter_px: m.pore_pitch_um * 1e-3 / pitch_cathode_mm,
                        },
                        after_noise: false,
                    });
                }
                open_area = m.open_area_fraction;
                gain_shape = m.gain_shape;
                mcp_saturation_e = m.output_current_limit_a_cm2.map(|j| {
                    j * (pitch_cathode_mm * 0.1).powi(2) * cfg.timing.exposure_s
                        / ELEMENTARY_CHARGE_C
                });
                push_gap(
                    &mut stages,
                    "MCP-screen gap",
                    ph.gap_mm,
                    ph.exit_energy_ev,
                    ph.screen_voltage_v,
                    pitch_cathode_mm,
                    true,
                );
                if ph.spread_um > 0.0 {
                    let a_px = ph.spread_um * 1e-3 / pitch_cathode_mm;
                    stages.push(MtfStage {
                        name: "phosphor spread",
                        term: match ph.spread_shape {
                            SpreadShape::Gaussian => MtfTerm::Gaussian { sigma_px: a_px },
                            SpreadShape::Exponential => MtfTerm::Lorentzian { length_px: a_px },
                        },
                        after_noise: true,
                    });
                }
                let d = phosphor_defaults(ph.phosphor);
                let spec = phosphor_spectrum(ph.phosphor);
                // Mean photon energy of the emission, eV: power / photon count.
                let photons_per_w = spec.map_all(|w, x| x * w / HC_EV_NM).integral();
                let mean_photon_ev = 1.0 / photons_per_w;
                let eff = ph.energy_efficiency.unwrap_or(d.energy_efficiency);
                let dead = ph.dead_voltage_v.unwrap_or(d.dead_voltage_v);
                phosphor_photons_per_e = eff * (ph.screen_voltage_v - dead) / mean_photon_ev;
                lag_fraction = ph.lag_fraction.unwrap_or(d.lag_fraction);
                coupling_fraction = match c.kind {
                    CouplingKind::FibrePlate | CouplingKind::FibreTaper => c.transmission,
                    CouplingKind::RelayLens => {
                        c.lens_transmission
                            / (4.0 * c.f_number * c.f_number * (1.0 + c.magnification).powi(2))
                    }
                };
                if c.fibre_pitch_um > 0.0 && c.kind != CouplingKind::RelayLens {
                    stages.push(MtfStage {
                        name: "fibre optic",
                        term: MtfTerm::Jinc {
                            diameter_px: c.fibre_pitch_um * 1e-3 / pitch_ccd_mm,
                        },
                        after_noise: true,
                    });
                }
                if c.kind == CouplingKind::RelayLens {
                    // Photon-weighted mean wavelength of the screen light.
                    let photons = spec.map_all(|w, x| x * w);
                    let lam = photons.map_all(|w, x| x * w).integral() / photons.integral();
                    let n_w = c.f_number * (1.0 + c.magnification);
                    stages.push(MtfStage {
                        name: "relay lens diffraction",
                        term: MtfTerm::Diffraction {
                            cutoff_cy_px: pitch_ccd_mm / (lam * 1e-6 * n_w),
                        },
                        after_noise: true,
                    });
                }
                let qe = resolve_spectrum("ccd.qe", cfg.ccd.qe.as_ref().expect("validated"))?;
                let photons = spec.map_all(|w, x| x * w);
                ccd_qe_at_phosphor = photons.integrate_weighted(&qe) / photons.integral();
                if cfg.ccd.diffusion_um > 0.0 {
                    stages.push(MtfStage {
                        name: "CCD diffusion",
                        term: MtfTerm::Gaussian {
                            sigma_px: cfg.ccd.diffusion_um * 1e-3 / pitch_ccd_mm,
                        },
                        after_noise: true,
                    });
                }
            }
            SensorKind::Ebccd => {
                let p = cfg.photocathode.as_ref().expect("validated");
                let e = cfg.ebccd.as_ref().expect("validated");
                eb = Some(EbParams {
                    backscatter: e.backscatter_fraction,
                    fano: e.fano,
                    gap_mm: p.gap_mm,
                    emission_ev: p.emission_energy_ev,
                });
                // The cathode-CCD gap term depends on the voltage; it is added
                // per gain by `stages_at`.
                if cfg.ccd.diffusion_um > 0.0 {
                    stages.push(MtfStage {
                        name: "CCD diffusion",
                        term: MtfTerm::Gaussian {
                            sigma_px: cfg.ccd.diffusion_um * 1e-3 / pitch_ccd_mm,
                        },
                        after_noise: true,
                    });
                }
            }
            SensorKind::Ccd => {
                if cfg.ccd.diffusion_um > 0.0 {
                    stages.push(MtfStage {
                        name: "CCD diffusion",
                        term: MtfTerm::Gaussian {
                            sigma_px: cfg.ccd.diffusion_um * 1e-3 / pitch_ccd_mm,
                        },
                        after_noise: false,
                    });
                }
            }
        }
        let ccd_e_per_mcp_e = phosphor_photons_per_e * coupling_fraction * ccd_qe_at_phosphor;

        let d = &cfg.digitizer;
        let max_code = ((1u32 << d.bits) - 1) as f64;
        let (base_dn_per_e, black_dn, clip_dn_unit_gain, video_noise_e) = match &cfg.video {
            Some(v) => {
                let lo = d.input_low_v.expect("validated");
                let hi = d.input_high_v.expect("validated");
                let dn_per_v = max_code / (hi - lo);
                let v_per_e = (v.white_level_v - v.black_level_v) / v.full_scale_e;
                let clip = v.white_clip_v.unwrap_or(v.white_level_v);
                (
                    v_per_e * dn_per_v,
                    d.offset_dn + d.analog_gain * (v.black_level_v - lo) * dn_per_v,
                    d.offset_dn + d.analog_gain * (clip - lo) * dn_per_v,
                    v.noise_v / v_per_e,
                )
            }
            None => (
                1.0 / d.e_per_dn.expect("validated"),
                d.offset_dn,
                f64::INFINITY,
                0.0,
            ),
        };
        let read_noise_e = (cfg.ccd.read_noise_e.powi(2) + video_noise_e.powi(2)).sqrt();
        let dark_e_per_frame = cfg.ccd.dark_current_e_s * cfg.timing.exposure_s;

        Ok(Self {
            kind,
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
            open_area,
            gain_shape,
            mcp_saturation_e,
            mcp_saturation_inv: mcp_saturation_e.map_or(0.0, |s| 1.0 / s),
            phosphor_photons_per_e,
            coupling_fraction,
            ccd_qe_at_phosphor,
            ccd_e_per_mcp_e,
            lag_fraction,
            eb,
            dark_e_per_frame,
            base_dn_per_e,
            black_dn,
            clip_dn_unit_gain,
            max_code,
            read_noise_e,
            stages,
            config: cfg,
        })
    }

    /// Analogue gain of the digitizer at camera gain `g`.
    fn analog_gain(&self, g: f64) -> f64 {
        match self.kind {
            SensorKind::Ccd => g,
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
        match self.kind {
            SensorKind::Iccd => self.open_area * g * self.ccd_e_per_mcp_e,
            SensorKind::Ebccd => g * (1.0 - 0.5 * self.eb.expect("ebccd").backscatter),
            SensorKind::Ccd => 1.0,
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
        match self.kind {
            SensorKind::Iccd => {
                (1.0 + 1.0 / self.gain_shape) / self.open_area
                    + 1.0 / (self.open_area * g * self.ccd_e_per_mcp_e).max(1e-300)
            }
            SensorKind::Ebccd => {
                let e = self.eb.expect("ebccd");
                let b = e.backscatter;
                ((1.0 - b) * (1.0 + e.fano / g) + b / 3.0) / (1.0 - 0.5 * b).powi(2)
            }
            SensorKind::Ccd => 1.0,
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
        if let (Some(e), SensorKind::Ebccd) = (self.eb, self.kind) {
            let v = self.gain_control.voltage_for(g).expect("ebccd voltage");
            let mut tmp = Vec::new();
            push_gap(
                &mut tmp,
                "cathode-CCD gap",
                e.gap_mm,
                e.emission_ev,
                v,
                self.pitch_cathode_mm,
                false,
            );
            s.extend(tmp);
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

    /// MCP soft saturation of a charge `q` (e⁻).
    pub fn mcp_compress(&self, q: f64) -> f64 {
        match self.mcp_saturation_e {
            Some(_) => {
                let x = q * self.mcp_saturation_inv;
                let x2 = x * x;
                if x2 < 1e-3 {
                    // Series of 1/√(1+x²); error < 4e-7 relative.
                    q * (1.0 - 0.5 * x2)
                } else {
                    q / (1.0 + x2).sqrt()
                }
            }
            None => q,
        }
    }
}

fn push_gap(
    stages: &mut Vec<MtfStage>,
    name: &'static str,
    gap_mm: f64,
    energy_ev: f64,
    voltage_v: f64,
    pitch_mm: f64,
    after_noise: bool,
) {
    if gap_mm > 0.0 && energy_ev > 0.0 && voltage_v > 0.0 {
        let sigma_mm = gap_mm * (2.0 * energy_ev / voltage_v).sqrt();
        stages.push(MtfStage {
            name,
            term: MtfTerm::Gaussian {
                sigma_px: sigma_mm / pitch_mm,
            },
            after_noise,
        });
    }
}
