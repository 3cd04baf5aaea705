//! The sensor configuration: one TOML table per stage, in physical units.
//!
//! Every field carries its unit in its name. Stages that a camera does not
//! have are simply absent (an EBCCD has no `[mcp]`, `[phosphor]` or
//! `[coupling]`; a plain CCD has no `[photocathode]`). [`SensorConfig::validate`]
//! checks every number (finite, in range) and that the stages the `kind`
//! calls for are present, and names the offending field.
//!
//! Built-in presets live in `sims/sensors/*.toml` (documented there, with the
//! sources of their numbers) and are compiled in, so `gloam sensor list` works
//! anywhere.

use gloam_io::toml_place::{line_of_field, place};
use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// What kind of camera the chain models.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SensorKind {
    /// Photocathode → MCP → phosphor → coupling (fibre or relay) → CCD.
    Iccd,
    /// Photocathode → electrons accelerated into a back-thinned CCD.
    Ebccd,
    /// A plain (scientific) CCD: photons detected by the CCD itself.
    Ccd,
}

/// A spectral curve: a built-in library name or CSV path (`"qe-gen3-gaas"`),
/// an inline table, or a wavelength-independent constant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SpectrumRef {
    Constant(f64),
    Named(String),
    Table {
        wavelength_nm: Vec<f64>,
        value: Vec<f64>,
    },
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Timing {
    /// Frame rate, Hz (25 for CCIR video, 30 for RS-170).
    pub frame_rate_hz: f64,
    /// Integration time per frame, s (≤ 1 / frame rate).
    pub exposure_s: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Optics {
    /// Working f-number N of the objective.
    pub f_number: f64,
    /// Objective transmission τ (0–1).
    pub transmission: f64,
    /// Focal length, mm (sets the field angle for the cos⁴θ fall-off).
    pub focal_length_mm: f64,
    /// Apply the cos⁴θ off-axis fall-off.
    #[serde(default = "yes")]
    pub vignetting: bool,
    /// Apply the diffraction MTF of the circular pupil.
    #[serde(default = "yes")]
    pub diffraction: bool,
    /// Wavelength for the diffraction MTF, nm.
    #[serde(default = "default_diffraction_wavelength")]
    pub diffraction_wavelength_nm: f64,
    /// Focus error at the image plane, µm (0 = in focus). Blur-circle
    /// diameter `d = defocus / N`, geometric MTF `2 J1(π d ν) / (π d ν)`.
    #[serde(default)]
    pub defocus_um: f64,
    /// Neutral-density filter in front of the lens, optical density D
    /// (transmission `10^−D`, spectrally flat; 0 = no filter).
    #[serde(default)]
    pub nd_density: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Photocathode {
    /// Spectral quantum efficiency (electrons per photon).
    pub qe: SpectrumRef,
    /// Equivalent background illumination at the reference gain, lm cm⁻²
    /// (spec-sheet unit; converted with the cathode's luminous sensitivity to
    /// 2856 K light). 0 = no dark emission.
    #[serde(default)]
    pub ebi_lm_cm2: f64,
    /// EBI ∝ (gain / reference gain)^exponent: dark emission measured at the
    /// output rises with gain (field emission and ion feedback in the MCP).
    #[serde(default)]
    pub ebi_gain_exponent: f64,
    /// Cathode → next stage (MCP, or the CCD in an EBCCD) gap, mm.
    pub gap_mm: f64,
    /// Voltage across that gap, V (ICCD only; the EBCCD uses `ebccd.voltage_v`).
    #[serde(default)]
    pub gap_voltage_v: f64,
    /// Transverse emission energy of photoelectrons, eV (sets the proximity
    /// spread `σ = L √(2 ε / V)`).
    pub emission_energy_ev: f64,
    /// Gating duty cycle: the fraction of the exposure the cathode is gated
    /// on (0–1, default 1). Signal and dark emission scale with it.
    #[serde(default = "one")]
    pub gate_duty: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mcp {
    /// Gain G0 at the reference voltage V0.
    pub gain_ref: f64,
    pub voltage_ref_v: f64,
    /// Power-law exponent k in `G = G0 (V/V0)^k`.
    pub exponent: f64,
    /// Plate voltage used when AGC is off and no override is given, V.
    pub voltage_v: f64,
    pub min_voltage_v: f64,
    pub max_voltage_v: f64,
    /// Shape of the gamma distribution of single-electron gain (1 =
    /// exponential pulse-height distribution).
    pub gain_shape: f64,
    /// Fraction of photoelectrons that start a cascade (open area /
    /// first-strike efficiency).
    pub open_area_fraction: f64,
    /// Output current density where the plate saturates, A cm⁻² (soft knee).
    /// Omit for no saturation.
    #[serde(default)]
    pub output_current_limit_a_cm2: Option<f64>,
    /// Channel pitch, µm (pore-sampling MTF); 0 = off.
    #[serde(default)]
    pub pore_pitch_um: f64,
}

/// Phosphor screen types with built-in spectra and defaults.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum PhosphorType {
    P20,
    P43,
    P46,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Phosphor {
    #[serde(rename = "type")]
    pub phosphor: PhosphorType,
    /// MCP-out → screen voltage, V.
    pub screen_voltage_v: f64,
    /// Energy lost in the aluminium backing, eV (electrons below it give no
    /// light). Default per type.
    #[serde(default)]
    pub dead_voltage_v: Option<f64>,
    /// Energy conversion efficiency (light W per electron-beam W). Default per type.
    #[serde(default)]
    pub energy_efficiency: Option<f64>,
    /// MCP → screen gap, mm.
    pub gap_mm: f64,
    /// Transverse energy of electrons leaving the MCP, eV.
    pub exit_energy_ev: f64,
    /// Spread of light in the screen, µm (σ for Gaussian, decay length for exponential).
    pub spread_um: f64,
    /// `"gaussian"` or `"exponential"` (Lorentzian MTF `1/(1+(2π ν a)²)`).
    #[serde(default = "default_spread_shape")]
    pub spread_shape: SpreadShape,
    /// Fraction of a frame's light emitted in later frames (persistence),
    /// decaying geometrically. Default per type.
    #[serde(default)]
    pub lag_fraction: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpreadShape {
    Gaussian,
    Exponential,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CouplingKind {
    FibrePlate,
    FibreTaper,
    RelayLens,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Coupling {
    pub kind: CouplingKind,
    /// CCD image size / screen image size (taper: 0.5 for 2:1; plate: 1).
    pub magnification: f64,
    /// Fibre transmission for Lambertian screen light (fibre kinds).
    #[serde(default)]
    pub transmission: f64,
    /// Fibre pitch, µm (fibre MTF `2 J1(π p ν)/(π p ν)`); 0 = off.
    #[serde(default)]
    pub fibre_pitch_um: f64,
    /// Multifibre (chicken-wire) hexagon size across flats, µm, at the CCD; 0 = off.
    #[serde(default)]
    pub chicken_wire_cell_um: f64,
    /// Fractional transmission loss on a multifibre boundary.
    #[serde(default)]
    pub chicken_wire_depth: f64,
    /// Width (σ) of the boundary dip, µm.
    #[serde(default)]
    pub chicken_wire_width_um: f64,
    /// Relay lens: f-number and transmission (relay kind).
    #[serde(default)]
    pub f_number: f64,
    #[serde(default)]
    pub lens_transmission: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ebccd {
    /// Accelerating voltage used when AGC is off and no override is given, V.
    pub voltage_v: f64,
    pub min_voltage_v: f64,
    pub max_voltage_v: f64,
    /// Energy lost in the back-surface dead layer, eV.
    pub dead_layer_ev: f64,
    /// Energy per electron-hole pair in silicon, eV.
    #[serde(default = "default_pair_energy")]
    pub pair_energy_ev: f64,
    /// Fraction of electrons backscattered (deposit a uniform fraction of their energy).
    pub backscatter_fraction: f64,
    /// Fano factor of pair creation in silicon.
    #[serde(default = "default_fano")]
    pub fano: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ccd {
    /// Pixel pitch on the CCD, µm.
    pub pixel_pitch_um: f64,
    /// Spectral QE of the CCD (at the phosphor's light in an ICCD, at the
    /// scene's for a plain CCD; unused in an EBCCD).
    #[serde(default)]
    pub qe: Option<SpectrumRef>,
    pub full_well_e: f64,
    /// Spill charge above full well to column neighbours.
    #[serde(default = "yes")]
    pub blooming: bool,
    pub dark_current_e_s: f64,
    pub read_noise_e: f64,
    /// Photo-response non-uniformity, rms fraction.
    #[serde(default)]
    pub prnu: f64,
    /// Dark-signal non-uniformity (zero-mean fixed offset), rms e⁻.
    #[serde(default)]
    pub dsnu_e: f64,
    /// Charge diffusion, µm (Gaussian σ).
    #[serde(default)]
    pub diffusion_um: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Agc {
    /// Start in AGC mode (an override fixes the gain regardless).
    #[serde(default)]
    pub enabled: bool,
    /// Target mean signal above black, DN.
    pub set_point_dn: f64,
    /// Loop time constant, s.
    pub time_constant_s: f64,
    /// Gain limits of the loop (default: the hardware limits).
    #[serde(default)]
    pub min_gain: Option<f64>,
    #[serde(default)]
    pub max_gain: Option<f64>,
    /// Bright-source protection: mean signal above black, DN, beyond which
    /// gain is cut by `protect_factor` per frame.
    #[serde(default)]
    pub protect_mean_dn: Option<f64>,
    /// … or this fraction of pixels at saturation.
    #[serde(default = "default_protect_fraction")]
    pub protect_saturated_fraction: f64,
    /// Gain multiplier per frame while protecting (0–1).
    #[serde(default = "default_protect_factor")]
    pub protect_factor: f64,
    /// Autogating: below its least gain the loop shortens the
    /// photocathode's gate, down to this on-time per exposure, s (Gen III
    /// auto-gated tubes: ~100 ns), so the camera follows light from
    /// starlight to daylight. Omitted: the loop has the gain alone.
    #[serde(default)]
    pub gate_min_s: Option<f64>,
    /// What the loop servos to the set point: the frame's `mean` signal
    /// (the default) or its `median`, which a bright sky or lamp filling
    /// part of the frame does not pull down the rest of the scene.
    #[serde(default)]
    pub metering: Metering,
}

/// The shortest gate `agc.gate_min_s` may ask for, s (the fastest gated
/// image intensifiers open for ~100 ps).
pub const MIN_GATE_S: f64 = 1e-10;

/// The frame statistic an AGC servos.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Metering {
    #[default]
    Mean,
    Median,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Video {
    /// Black (blanking) level, V (sync tip at 0 V).
    pub black_level_v: f64,
    /// White level, V (1 V peak-to-peak composite).
    pub white_level_v: f64,
    /// Analogue clip, V (default: white level).
    #[serde(default)]
    pub white_clip_v: Option<f64>,
    /// CCD electrons that drive the video from black to white.
    pub full_scale_e: f64,
    /// Analogue noise, V rms.
    #[serde(default)]
    pub noise_v: f64,
    /// Line format: `"rs-170"` (525/60, 63.556 µs lines) or `"ccir"`
    /// (625/50, 64 µs; the default). See `stages/video_timing.rs`.
    #[serde(default)]
    pub format: crate::stages::video_timing::VideoFormat,
    /// Video amplifier −3 dB bandwidth, Hz (RS-170/CCIR cameras: ~4.2–5 MHz).
    /// Omitted: the amplifier is taken as flat (no horizontal video MTF).
    #[serde(default)]
    pub bandwidth_hz: Option<f64>,
    /// Shape of that low-pass: `"butterworth-2"` (default) or `"single-pole"`.
    #[serde(default)]
    pub bandwidth_filter: crate::stages::video_bandwidth::FilterKind,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Digitizer {
    /// 8 to 16.
    pub bits: u8,
    #[serde(default)]
    pub offset_dn: f64,
    /// Input range, V (with a `[video]` stage).
    #[serde(default)]
    pub input_low_v: Option<f64>,
    #[serde(default)]
    pub input_high_v: Option<f64>,
    /// Conversion gain, e⁻/DN (without a `[video]` stage).
    #[serde(default)]
    pub e_per_dn: Option<f64>,
    /// Programmable analogue gain (the camera's gain for a plain CCD).
    #[serde(default = "one")]
    pub analog_gain: f64,
    #[serde(default = "one")]
    pub min_analog_gain: f64,
    #[serde(default = "one")]
    pub max_analog_gain: f64,
    /// Video only: where in each pixel period the line-locked pixel clock
    /// samples the analogue line, 0–1 (default 0.5, mid-pixel).
    #[serde(default = "half")]
    pub sample_phase: f64,
    /// Video only: line-locked pixel-clock jitter, s rms (default 0).
    #[serde(default)]
    pub clock_jitter_s: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    /// Temporal noise (shot, gain, dark, read). Off = deterministic means.
    #[serde(default = "yes")]
    pub enabled: bool,
    pub seed: u64,
    /// Poisson draws with a mean above this use a rounded Gaussian with the
    /// same mean and variance (accuracy dial, default 12: the skewness
    /// 1/√mean ≤ 0.29 is dropped; exact inversion below).
    #[serde(default = "default_gaussian_above")]
    pub gaussian_above: f64,
}

impl Default for Noise {
    fn default() -> Self {
        Self {
            enabled: true,
            seed: 0,
            gaussian_above: default_gaussian_above(),
        }
    }
}

/// A whole camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorConfig {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Where the numbers come from.
    #[serde(default)]
    pub sources: Vec<String>,
    pub kind: SensorKind,
    pub timing: Timing,
    pub optics: Optics,
    #[serde(default)]
    pub photocathode: Option<Photocathode>,
    #[serde(default)]
    pub mcp: Option<Mcp>,
    #[serde(default)]
    pub phosphor: Option<Phosphor>,
    #[serde(default)]
    pub coupling: Option<Coupling>,
    #[serde(default)]
    pub ebccd: Option<Ebccd>,
    pub ccd: Ccd,
    #[serde(default)]
    pub agc: Option<Agc>,
    #[serde(default)]
    pub video: Option<Video>,
    pub digitizer: Digitizer,
    #[serde(default)]
    pub noise: Noise,
    /// The intensifier's bright-source stages (halo, MCP pore depletion,
    /// automatic brightness control); on by default for an ICCD.
    #[serde(default)]
    pub bright_source: BrightSource,
}

fn yes() -> bool {
    true
}
fn one() -> f64 {
    1.0
}
fn half() -> f64 {
    0.5
}
fn default_diffraction_wavelength() -> f64 {
    600.0
}
fn default_spread_shape() -> SpreadShape {
    SpreadShape::Gaussian
}
fn default_pair_energy() -> f64 {
    3.65
}
fn default_fano() -> f64 {
    0.12
}
fn default_protect_fraction() -> f64 {
    0.02
}
fn default_protect_factor() -> f64 {
    0.5
}
fn default_gaussian_above() -> f64 {
    12.0
}

/// Built-in presets: (name, TOML text).
pub const PRESETS: &[(&str, &str)] = &[
    (
        "gen2-s20-iccd",
        include_str!("../../../sims/sensors/gen2-s20-iccd.toml"),
    ),
    (
        "gen3-gaas-iccd",
        include_str!("../../../sims/sensors/gen3-gaas-iccd.toml"),
    ),
    (
        "s25-ebccd",
        include_str!("../../../sims/sensors/s25-ebccd.toml"),
    ),
    (
        "scientific-ccd",
        include_str!("../../../sims/sensors/scientific-ccd.toml"),
    ),
];

impl SensorConfig {
    /// Parses and validates TOML; `origin` names the file or preset in errors.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let cfg: SensorConfig = toml::from_str(text).map_err(|e| {
            // The field too, as semantic errors name it: `unknown variant
            // `mode`` alone did not say that it was `agc.metering`.
            let (line, message) = place(text, &e);
            ConfigError::Parse {
                origin: format!("{origin}:{line}"),
                message,
            }
        })?;
        // The stages' derived figures too (`Chain::new`): an extreme
        // finite value is named at its file and line like any other.
        let checked = cfg
            .validate()
            .and_then(|()| crate::stages::Chain::new(&cfg).map(|_| ()));
        checked.map_err(|e| match &e {
            ConfigError::Invalid { field, .. }
            | ConfigError::Missing { field, .. }
            | ConfigError::Spectrum { field, .. } => ConfigError::At {
                origin: origin.to_string(),
                line: line_of_field(text, field),
                inner: Box::new(e),
            },
            _ => e,
        })?;
        Ok(cfg)
    }

    /// A built-in preset by name.
    pub fn preset(name: &str) -> Option<Result<Self, ConfigError>> {
        PRESETS
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(n, t)| Self::from_toml_str(t, &format!("preset '{n}'")))
    }

    /// The preset `name_or_path`, or else the TOML file at that path;
    /// `reads` notes the file and the spectrum files it names.
    pub fn load_preset_or_file(
        name_or_path: &str,
        reads: &gloam_io::ReadLog,
    ) -> Result<Self, ConfigError> {
        if let Some(r) = Self::preset(name_or_path) {
            return r;
        }
        match gloam_io::read_text(
            std::path::Path::new(name_or_path),
            gloam_io::MAX_TEXT_FILE_BYTES,
            reads,
        ) {
            Ok(text) => {
                let cfg = Self::from_toml_str(&text, name_or_path)?;
                cfg.note_spectrum_files(reads);
                Ok(cfg)
            }
            Err(e) => Err(ConfigError::Unknown {
                name: name_or_path.to_string(),
                message: e.to_string(),
            }),
        }
    }

    /// Notes in `reads` the CSV files the QE curves name (validation read
    /// them without a log: it also serves presets and built configs).
    fn note_spectrum_files(&self, reads: &gloam_io::ReadLog) {
        let qe = [
            self.photocathode.as_ref().map(|p| &p.qe),
            self.ccd.qe.as_ref(),
        ];
        for r in qe.into_iter().flatten() {
            if let SpectrumRef::Named(n) = r
                && gloam_spectra::library::get(n).is_none()
            {
                let _ = gloam_spectra::lookup(n, reads);
            }
        }
    }

    /// The bright-source stages' numbers.
    fn check_bright_source(&self) -> Result<(), ConfigError> {
        let b = &self.bright_source;
        positive(
            "bright_source.on_above_max_over_mean",
            b.on_above_max_over_mean,
        )?;
        fraction(
            "bright_source.halo.backscatter_coefficient",
            b.halo.backscatter_coefficient,
        )?;
        positive(
            "bright_source.mcp_depletion.recovery_time_s",
            b.mcp_depletion.recovery_time_s,
        )?;
        positive(
            "bright_source.abc.output_luminance_limit_cd_m2",
            b.abc.output_luminance_limit_cd_m2,
        )?;
        positive("bright_source.abc.time_constant_s", b.abc.time_constant_s)?;
        positive("bright_source.abc.gate_min_s", b.abc.gate_min_s)?;
        Ok(())
    }

    /// Checks every number and that the stages `kind` needs are present.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.layout().map(|_| ())
    }

    /// Validates the configuration and returns its stages as one variant
    /// per sensor kind: the chain is built from this, so a camera whose
    /// tables do not fit its kind cannot be built (and nothing downstream
    /// has to assume an optional table is present).
    pub fn layout(&self) -> Result<Layout<'_>, ConfigError> {
        let t = &self.timing;
        positive("timing.frame_rate_hz", t.frame_rate_hz)?;
        positive("timing.exposure_s", t.exposure_s)?;
        if t.exposure_s > 1.0 / t.frame_rate_hz * (1.0 + 1e-9) {
            return Err(ConfigError::invalid(
                "timing.exposure_s",
                format!(
                    "{} s is longer than the frame period {} s",
                    t.exposure_s,
                    1.0 / t.frame_rate_hz
                ),
            ));
        }
        let o = &self.optics;
        positive("optics.f_number", o.f_number)?;
        fraction("optics.transmission", o.transmission)?;
        positive("optics.focal_length_mm", o.focal_length_mm)?;
        positive(
            "optics.diffraction_wavelength_nm",
            o.diffraction_wavelength_nm,
        )?;
        non_negative("optics.defocus_um", o.defocus_um)?;
        non_negative("optics.nd_density", o.nd_density)?;
        self.check_bright_source()?;

        let tube =
            match self.kind {
                SensorKind::Iccd => {
                    let photocathode = self.check_photocathode()?;
                    let mcp = self.check_mcp()?;
                    let phosphor = self.check_phosphor()?;
                    let coupling = self.check_coupling()?;
                    let ccd_qe =
                        self.ccd.qe.as_ref().ok_or_else(|| {
                            missing("ccd.qe", "the CCD of an ICCD sees the phosphor")
                        })?;
                    check_spectrum_ref("ccd.qe", ccd_qe)?;
                    self.forbid_ebccd()?;
                    Tube::Iccd {
                        photocathode,
                        mcp,
                        phosphor,
                        coupling,
                        ccd_qe,
                    }
                }
                SensorKind::Ebccd => {
                    let photocathode = self.check_photocathode()?;
                    self.forbid_iccd_stages()?;
                    let ebccd = self.check_ebccd()?;
                    Tube::Ebccd {
                        photocathode,
                        ebccd,
                    }
                }
                SensorKind::Ccd => {
                    if self.photocathode.is_some() {
                        return Err(ConfigError::invalid(
                            "photocathode",
                            "a plain CCD has no photocathode (remove the table or set kind)",
                        ));
                    }
                    self.forbid_iccd_stages()?;
                    self.forbid_ebccd()?;
                    positive("ccd.pixel_pitch_um", self.ccd.pixel_pitch_um)?;
                    let ccd_qe = self.ccd.qe.as_ref().ok_or_else(|| {
                        missing("ccd.qe", "a plain CCD detects the scene's photons")
                    })?;
                    check_spectrum_ref("ccd.qe", ccd_qe)?;
                    Tube::Ccd { ccd_qe }
                }
            };

        let c = &self.ccd;
        positive("ccd.pixel_pitch_um", c.pixel_pitch_um)?;
        positive("ccd.full_well_e", c.full_well_e)?;
        non_negative("ccd.dark_current_e_s", c.dark_current_e_s)?;
        non_negative("ccd.read_noise_e", c.read_noise_e)?;
        fraction("ccd.prnu", c.prnu)?;
        non_negative("ccd.dsnu_e", c.dsnu_e)?;
        non_negative("ccd.diffusion_um", c.diffusion_um)?;

        if let Some(a) = &self.agc {
            positive("agc.set_point_dn", a.set_point_dn)?;
            positive("agc.time_constant_s", a.time_constant_s)?;
            if let Some(g) = a.min_gain {
                positive("agc.min_gain", g)?;
            }
            if let Some(g) = a.max_gain {
                positive("agc.max_gain", g)?;
            }
            if let (Some(lo), Some(hi)) = (a.min_gain, a.max_gain)
                && hi < lo
            {
                return Err(ConfigError::invalid(
                    "agc.max_gain",
                    "is below agc.min_gain",
                ));
            }
            if let Some(m) = a.protect_mean_dn {
                positive("agc.protect_mean_dn", m)?;
            }
            fraction(
                "agc.protect_saturated_fraction",
                a.protect_saturated_fraction,
            )?;
            positive("agc.protect_factor", a.protect_factor)?;
            if a.protect_factor >= 1.0 {
                return Err(ConfigError::invalid("agc.protect_factor", "must be < 1"));
            }
            if let Some(g) = a.gate_min_s {
                positive("agc.gate_min_s", g)?;
                if g < MIN_GATE_S {
                    // 1e-300 s was taken: a gate no photocathode opens in.
                    return Err(ConfigError::invalid(
                        "agc.gate_min_s",
                        format!(
                            "{g:e} s is shorter than any intensifier gates ({MIN_GATE_S:e} s: the fastest gated tubes)"
                        ),
                    ));
                }
                if self.photocathode.is_none() {
                    return Err(ConfigError::invalid(
                        "agc.gate_min_s",
                        "needs a photocathode to gate (an intensified camera)",
                    ));
                }
                if g > self.timing.exposure_s {
                    return Err(ConfigError::invalid(
                        "agc.gate_min_s",
                        format!(
                            "{g:e} s is longer than the exposure, {:e} s",
                            self.timing.exposure_s
                        ),
                    ));
                }
            }
        }

        if let Some(v) = &self.video {
            non_negative("video.black_level_v", v.black_level_v)?;
            positive("video.white_level_v", v.white_level_v)?;
            if v.white_level_v <= v.black_level_v {
                return Err(ConfigError::invalid(
                    "video.white_level_v",
                    "must be above video.black_level_v",
                ));
            }
            if let Some(c) = v.white_clip_v {
                positive("video.white_clip_v", c)?;
                if c < v.black_level_v {
                    return Err(ConfigError::invalid(
                        "video.white_clip_v",
                        "is below the black level",
                    ));
                }
            }
            positive("video.full_scale_e", v.full_scale_e)?;
            // The video's full scale is a CCD signal: beyond the CCD's full
            // well it can never be reached, and every frame reads near black.
            if v.full_scale_e > c.full_well_e {
                return Err(ConfigError::invalid(
                    "video.full_scale_e",
                    format!(
                        "{:e} e is above ccd.full_well_e ({:e} e): the video's full scale could never be reached",
                        v.full_scale_e, c.full_well_e
                    ),
                ));
            }
            non_negative("video.noise_v", v.noise_v)?;
            if let Some(b) = v.bandwidth_hz {
                positive("video.bandwidth_hz", b)?;
            }
        }

        let d = &self.digitizer;
        if !(8..=16).contains(&d.bits) {
            return Err(ConfigError::invalid(
                "digitizer.bits",
                format!("{} is not a bit depth from 8 to 16", d.bits),
            ));
        }
        finite("digitizer.offset_dn", d.offset_dn)?;
        let top_dn = ((1u32 << d.bits) - 1) as f64;
        if let Some(a) = &self.agc
            && a.set_point_dn > top_dn
        {
            return Err(ConfigError::invalid(
                "agc.set_point_dn",
                format!(
                    "{:e} DN is above the {}-bit digitizer's top code {top_dn}",
                    a.set_point_dn, d.bits
                ),
            ));
        }
        let readout = match &self.video {
            Some(video) => {
                let lo = d.input_low_v.ok_or_else(|| {
                    missing("digitizer.input_low_v", "a video stage is digitised")
                })?;
                let hi = d.input_high_v.ok_or_else(|| {
                    missing("digitizer.input_high_v", "a video stage is digitised")
                })?;
                finite("digitizer.input_low_v", lo)?;
                finite("digitizer.input_high_v", hi)?;
                if hi <= lo {
                    return Err(ConfigError::invalid(
                        "digitizer.input_high_v",
                        "must be above digitizer.input_low_v",
                    ));
                }
                Readout::Video {
                    video,
                    input_low_v: lo,
                    input_high_v: hi,
                }
            }
            None => {
                let e = d.e_per_dn.ok_or_else(|| {
                    missing(
                        "digitizer.e_per_dn",
                        "without a [video] stage the digitizer converts electrons directly",
                    )
                })?;
                positive("digitizer.e_per_dn", e)?;
                Readout::Direct { e_per_dn: e }
            }
        };
        fraction("digitizer.sample_phase", d.sample_phase)?;
        non_negative("digitizer.clock_jitter_s", d.clock_jitter_s)?;
        positive("digitizer.min_analog_gain", d.min_analog_gain)?;
        positive("digitizer.max_analog_gain", d.max_analog_gain)?;
        in_range(
            "digitizer.analog_gain",
            d.analog_gain,
            d.min_analog_gain,
            d.max_analog_gain,
        )?;
        positive("noise.gaussian_above", self.noise.gaussian_above)?;
        Ok(Layout { tube, readout })
    }

    fn check_photocathode(&self) -> Result<&Photocathode, ConfigError> {
        let p = self
            .photocathode
            .as_ref()
            .ok_or_else(|| missing("photocathode", "an intensified camera needs it"))?;
        check_spectrum_ref("photocathode.qe", &p.qe)?;
        non_negative("photocathode.ebi_lm_cm2", p.ebi_lm_cm2)?;
        non_negative("photocathode.ebi_gain_exponent", p.ebi_gain_exponent)?;
        non_negative("photocathode.gap_mm", p.gap_mm)?;
        non_negative("photocathode.emission_energy_ev", p.emission_energy_ev)?;
        positive("photocathode.gate_duty", p.gate_duty)?;
        fraction("photocathode.gate_duty", p.gate_duty)?;
        if self.kind == SensorKind::Iccd {
            positive("photocathode.gap_voltage_v", p.gap_voltage_v)?;
        }
        Ok(p)
    }

    fn check_mcp(&self) -> Result<&Mcp, ConfigError> {
        let m = self
            .mcp
            .as_ref()
            .ok_or_else(|| missing("mcp", "kind = \"iccd\" needs it"))?;
        positive("mcp.gain_ref", m.gain_ref)?;
        positive("mcp.voltage_ref_v", m.voltage_ref_v)?;
        positive("mcp.exponent", m.exponent)?;
        positive("mcp.min_voltage_v", m.min_voltage_v)?;
        positive("mcp.max_voltage_v", m.max_voltage_v)?;
        if m.max_voltage_v < m.min_voltage_v {
            return Err(ConfigError::invalid(
                "mcp.max_voltage_v",
                "is below mcp.min_voltage_v",
            ));
        }
        in_range(
            "mcp.voltage_v",
            m.voltage_v,
            m.min_voltage_v,
            m.max_voltage_v,
        )?;
        positive("mcp.gain_shape", m.gain_shape)?;
        positive("mcp.open_area_fraction", m.open_area_fraction)?;
        fraction("mcp.open_area_fraction", m.open_area_fraction)?;
        if let Some(j) = m.output_current_limit_a_cm2 {
            positive("mcp.output_current_limit_a_cm2", j)?;
        }
        non_negative("mcp.pore_pitch_um", m.pore_pitch_um)?;
        Ok(m)
    }

    fn check_phosphor(&self) -> Result<&Phosphor, ConfigError> {
        let p = self
            .phosphor
            .as_ref()
            .ok_or_else(|| missing("phosphor", "kind = \"iccd\" needs it"))?;
        positive("phosphor.screen_voltage_v", p.screen_voltage_v)?;
        if let Some(d) = p.dead_voltage_v {
            non_negative("phosphor.dead_voltage_v", d)?;
        }
        let dead = crate::stages::phosphor_defaults(p.phosphor).dead_voltage_v;
        if p.screen_voltage_v <= p.dead_voltage_v.unwrap_or(dead) {
            return Err(ConfigError::invalid(
                "phosphor.screen_voltage_v",
                "must exceed the dead voltage of the aluminium layer",
            ));
        }
        if let Some(e) = p.energy_efficiency {
            positive("phosphor.energy_efficiency", e)?;
            fraction("phosphor.energy_efficiency", e)?;
        }
        non_negative("phosphor.gap_mm", p.gap_mm)?;
        non_negative("phosphor.exit_energy_ev", p.exit_energy_ev)?;
        non_negative("phosphor.spread_um", p.spread_um)?;
        if let Some(l) = p.lag_fraction {
            fraction("phosphor.lag_fraction", l)?;
            if l >= 1.0 {
                return Err(ConfigError::invalid("phosphor.lag_fraction", "must be < 1"));
            }
        }
        Ok(p)
    }

    fn check_coupling(&self) -> Result<&Coupling, ConfigError> {
        let c = self
            .coupling
            .as_ref()
            .ok_or_else(|| missing("coupling", "kind = \"iccd\" needs it"))?;
        positive("coupling.magnification", c.magnification)?;
        match c.kind {
            CouplingKind::FibrePlate | CouplingKind::FibreTaper => {
                positive("coupling.transmission", c.transmission)?;
                fraction("coupling.transmission", c.transmission)?;
            }
            CouplingKind::RelayLens => {
                positive("coupling.f_number", c.f_number)?;
                positive("coupling.lens_transmission", c.lens_transmission)?;
                fraction("coupling.lens_transmission", c.lens_transmission)?;
            }
        }
        non_negative("coupling.fibre_pitch_um", c.fibre_pitch_um)?;
        non_negative("coupling.chicken_wire_cell_um", c.chicken_wire_cell_um)?;
        fraction("coupling.chicken_wire_depth", c.chicken_wire_depth)?;
        non_negative("coupling.chicken_wire_width_um", c.chicken_wire_width_um)?;
        if c.chicken_wire_cell_um > 0.0 && c.chicken_wire_depth > 0.0 {
            positive("coupling.chicken_wire_width_um", c.chicken_wire_width_um)?;
        }
        Ok(c)
    }

    fn check_ebccd(&self) -> Result<&Ebccd, ConfigError> {
        let e = self
            .ebccd
            .as_ref()
            .ok_or_else(|| missing("ebccd", "kind = \"ebccd\" needs it"))?;
        non_negative("ebccd.dead_layer_ev", e.dead_layer_ev)?;
        positive("ebccd.pair_energy_ev", e.pair_energy_ev)?;
        positive("ebccd.min_voltage_v", e.min_voltage_v)?;
        positive("ebccd.max_voltage_v", e.max_voltage_v)?;
        if e.min_voltage_v <= e.dead_layer_ev {
            return Err(ConfigError::invalid(
                "ebccd.min_voltage_v",
                "must exceed the dead-layer loss (no gain below it)",
            ));
        }
        if e.max_voltage_v < e.min_voltage_v {
            return Err(ConfigError::invalid(
                "ebccd.max_voltage_v",
                "is below ebccd.min_voltage_v",
            ));
        }
        in_range(
            "ebccd.voltage_v",
            e.voltage_v,
            e.min_voltage_v,
            e.max_voltage_v,
        )?;
        fraction("ebccd.backscatter_fraction", e.backscatter_fraction)?;
        non_negative("ebccd.fano", e.fano)?;
        Ok(e)
    }

    fn forbid_iccd_stages(&self) -> Result<(), ConfigError> {
        for (name, present) in [
            ("mcp", self.mcp.is_some()),
            ("phosphor", self.phosphor.is_some()),
            ("coupling", self.coupling.is_some()),
        ] {
            if present {
                return Err(ConfigError::invalid(
                    name,
                    format!("only an ICCD has this stage (kind is {:?})", self.kind),
                ));
            }
        }
        Ok(())
    }

    fn forbid_ebccd(&self) -> Result<(), ConfigError> {
        if self.ebccd.is_some() {
            return Err(ConfigError::invalid(
                "ebccd",
                "only kind = \"ebccd\" has this stage",
            ));
        }
        Ok(())
    }
}

/// The stages of a validated [`SensorConfig`] ([`SensorConfig::layout`]).
#[derive(Clone, Copy, Debug)]
pub struct Layout<'a> {
    pub tube: Tube<'a>,
    pub readout: Readout<'a>,
}

/// What sits between the optics and the CCD's readout, one variant per
/// [`SensorKind`] with every table that kind needs.
#[derive(Clone, Copy, Debug)]
pub enum Tube<'a> {
    Iccd {
        photocathode: &'a Photocathode,
        mcp: &'a Mcp,
        phosphor: &'a Phosphor,
        coupling: &'a Coupling,
        /// The CCD's QE, seen at the phosphor's spectrum.
        ccd_qe: &'a SpectrumRef,
    },
    Ebccd {
        photocathode: &'a Photocathode,
        ebccd: &'a Ebccd,
    },
    Ccd {
        /// The CCD's QE, seen at the scene's spectrum.
        ccd_qe: &'a SpectrumRef,
    },
}

/// How CCD electrons become a voltage the digitizer samples.
#[derive(Clone, Copy, Debug)]
pub enum Readout<'a> {
    /// Analogue video, digitised over `input_low_v..input_high_v`.
    Video {
        video: &'a Video,
        input_low_v: f64,
        input_high_v: f64,
    },
    /// Direct digital readout at `e_per_dn`.
    Direct { e_per_dn: f64 },
}

fn missing(field: &str, why: &str) -> ConfigError {
    ConfigError::Missing {
        field: field.to_string(),
        why: why.to_string(),
    }
}

fn finite(field: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(ConfigError::invalid(
            field,
            format!("{v} is not a finite number"),
        ))
    }
}

fn non_negative(field: &str, v: f64) -> Result<(), ConfigError> {
    finite(field, v)?;
    if v < 0.0 {
        return Err(ConfigError::invalid(
            field,
            format!("{} is negative", gloam_spectra::num(v)),
        ));
    }
    Ok(())
}

fn positive(field: &str, v: f64) -> Result<(), ConfigError> {
    finite(field, v)?;
    if v <= 0.0 {
        return Err(ConfigError::invalid(
            field,
            format!("{} must be > 0", gloam_spectra::num(v)),
        ));
    }
    Ok(())
}

fn fraction(field: &str, v: f64) -> Result<(), ConfigError> {
    non_negative(field, v)?;
    if v > 1.0 {
        return Err(ConfigError::invalid(
            field,
            format!("{} is above 1", gloam_spectra::num(v)),
        ));
    }
    Ok(())
}

fn in_range(field: &str, v: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
    finite(field, v)?;
    if v < lo || v > hi {
        return Err(ConfigError::invalid(
            field,
            format!("{} is outside its limits {lo}–{hi}", gloam_spectra::num(v)),
        ));
    }
    Ok(())
}

fn check_spectrum_ref(field: &str, r: &SpectrumRef) -> Result<(), ConfigError> {
    crate::stages::resolve_spectrum(field, r).map(|_| ())
}

/// The intensifier's bright-source stages (`[bright_source]` and its
/// sub-tables). They switch on per frame only when a bright source is in
/// view: the frame's brightest input pixel exceeds `on_above_max_over_mean`
/// times its mean (a uniform calibration field, a ramp or an edge target
/// stays below, so those frames are unchanged).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BrightSource {
    #[serde(default = "default_bright_ratio")]
    pub on_above_max_over_mean: f64,
    #[serde(default)]
    pub halo: HaloConfig,
    #[serde(default)]
    pub mcp_depletion: McpDepletionConfig,
    #[serde(default)]
    pub abc: AbcConfig,
}

impl Default for BrightSource {
    fn default() -> Self {
        Self {
            on_above_max_over_mean: default_bright_ratio(),
            halo: HaloConfig::default(),
            mcp_depletion: McpDepletionConfig::default(),
            abc: AbcConfig::default(),
        }
    }
}

fn default_bright_ratio() -> f64 {
    10.0
}

/// The halo of photoelectrons backscattered from the MCP input
/// (`stages/halo.rs`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HaloConfig {
    #[serde(default = "yes")]
    pub enabled: bool,
    /// Fraction of the photoelectrons striking the MCP's closed area that
    /// bounce back (elastic + inelastic backscatter of the input face).
    #[serde(default = "default_backscatter")]
    pub backscatter_coefficient: f64,
}

impl Default for HaloConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            backscatter_coefficient: default_backscatter(),
        }
    }
}

fn default_backscatter() -> f64 {
    0.25
}

/// Local MCP saturation by pore charge depletion (`stages/mcp_depletion.rs`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct McpDepletionConfig {
    #[serde(default = "yes")]
    pub enabled: bool,
    /// Channel wall recharge time constant R·C, s.
    #[serde(default = "default_recovery_time")]
    pub recovery_time_s: f64,
}

impl Default for McpDepletionConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            recovery_time_s: default_recovery_time(),
        }
    }
}

fn default_recovery_time() -> f64 {
    0.01
}

/// Automatic brightness control and bright-source protection of the tube's
/// power supply (`stages/abc.rs`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AbcConfig {
    #[serde(default = "yes")]
    pub enabled: bool,
    /// Screen luminance the supply holds the tube to, cd m⁻².
    #[serde(default = "default_abc_luminance")]
    pub output_luminance_limit_cd_m2: f64,
    /// Time constant of the regulation, s.
    #[serde(default = "default_abc_tau")]
    pub time_constant_s: f64,
    /// Shortest photocathode gate of the autogating supply, s.
    #[serde(default = "default_abc_gate_min")]
    pub gate_min_s: f64,
}

impl Default for AbcConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            output_luminance_limit_cd_m2: default_abc_luminance(),
            time_constant_s: default_abc_tau(),
            gate_min_s: default_abc_gate_min(),
        }
    }
}

fn default_abc_luminance() -> f64 {
    10.0
}
fn default_abc_tau() -> f64 {
    0.1
}
fn default_abc_gate_min() -> f64 {
    100e-9
}
