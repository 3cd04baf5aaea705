//! Calibration light sources behind one interface, and the source file (TOML)
//! that describes them. The format is documented in `docs/calibration.md`.
//!
//! * [`SphereSource`]: a simulated integrating sphere. The lamp's flux `Φ(λ)`
//!   enters a sphere of inner area `A = π d²`, wall reflectance `ρ` and port
//!   fraction `f`; the exit-port radiance is `L(λ) = Φ(λ) M / (π A)` with the
//!   sphere multiplier `M = ρ / (1 − ρ(1 − f))`. It is dimmed either by
//!   neutral-density filters in front of the camera (`T = 10^−D`, or a
//!   spectral transmission curve) or by an aperture at the source, which
//!   scales the flux and leaves the spectrum unchanged.
//! * [`ManualSource`]: the lab. The operator is prompted for each level and
//!   the spectrometer's measured exit-port radiance is read from a CSV file.
//!
//! The band radiance the camera sees is
//! `L = ∫ L_src(λ) β(λ) τ_ND(λ) τ_BP(λ) dλ` over the camera band, with β the
//! camera's relative spectral response (peak 1) and τ_BP an optional bandpass.

use std::io::{BufRead, Read, Write};
use std::path::{Path, PathBuf};

use gloam_grabber::Stimulus;
use gloam_spectra::{Spectrum, photons_per_joule};
use serde::Deserialize;

use crate::error::CalibError;

/// Band over which [`Stimulus::Uniform`] radiance is defined (nm).
pub const STIMULUS_BAND_NM: (f64, f64) = (400.0, 1000.0);

/// One level of a calibration source as the camera sees it.
#[derive(Clone, Debug)]
pub struct Level {
    /// Human-readable description ("aperture 40 %", "ND 0.6").
    pub label: String,
    /// What to present to a grabber that can render stimuli.
    pub stimulus: Stimulus,
    /// Spectral radiance at the camera (after ND filters), W m⁻² sr⁻¹ nm⁻¹.
    pub spectral_radiance: Spectrum,
    /// `∫ L β τ_BP dλ` over the camera band, W m⁻² sr⁻¹: what the LUT maps to.
    pub band_radiance_w_m2_sr: f64,
}

/// A light source a calibration flow can step through.
pub trait CalibrationSource {
    /// One-line description for reports.
    fn describe(&self) -> String;
    /// Number of illuminated levels (the dark level is extra).
    fn levels(&self) -> usize;
    /// Sets level `i` (0-based, increasing radiance) and returns what the
    /// camera sees. A manual source prompts the operator here.
    fn set_level(&mut self, i: usize) -> Result<Level, CalibError>;
    /// Capped lens / lamp off.
    fn set_dark(&mut self) -> Result<Level, CalibError> {
        Ok(Level {
            label: "dark".into(),
            stimulus: Stimulus::Dark,
            spectral_radiance: Spectrum::default(),
            band_radiance_w_m2_sr: 0.0,
        })
    }
    /// The camera's spectral weighting (β, τ_BP, band).
    fn camera(&self) -> &CameraBand;
    /// Pixel and optics geometry for photon counts, if the file gave it.
    fn rig(&self) -> Option<&Rig>;
    /// Name of the lamp spectrum passed to simulated cameras.
    fn lamp_name(&self) -> &str;
}

/// The camera's spectral weighting.
#[derive(Clone, Debug)]
pub struct CameraBand {
    /// β(λ), normalised to peak 1; `None` = flat.
    pub response: Option<Spectrum>,
    /// τ_BP(λ); `None` = no filter.
    pub bandpass: Option<Spectrum>,
    /// Integration limits, nm.
    pub band_nm: (f64, f64),
}

impl Default for CameraBand {
    fn default() -> Self {
        Self {
            response: None,
            bandpass: None,
            band_nm: STIMULUS_BAND_NM,
        }
    }
}

impl CameraBand {
    /// `∫ L(λ) β(λ) τ_BP(λ) dλ` over the band (τ_ND is already in `L`).
    pub fn band_radiance(&self, radiance_at_camera: &Spectrum) -> f64 {
        let mut s = radiance_at_camera.clone();
        if let Some(b) = &self.response {
            s = s.product(b);
        }
        if let Some(t) = &self.bandpass {
            s = s.product(t);
        }
        s.integrate_band(self.band_nm.0, self.band_nm.1)
    }
}

/// Geometry that turns radiance into photons per pixel (EMVA 1288 needs the
/// photon count for quantum efficiency).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Rig {
    /// Pixel pitch at the detecting surface (square pixels), µm; pixel
    /// area = pitch². For an intensified camera, the pitch referred to the
    /// photocathode (CCD pitch / coupling magnification).
    pub pixel_pitch_um: f64,
    /// Working f-number N of the lens in front of the sensor.
    pub f_number: f64,
    /// Transmission of the optics (1 for the lensless set-up).
    pub optics_transmission: f64,
    /// Exposure (integration or gate) time, s.
    pub exposure_s: f64,
    /// The sensor preset or file the optics and pixels were taken from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera: Option<String>,
}

impl Rig {
    /// The rig of a camera: its own lens (f-number, transmission), pixel
    /// pitch at the detecting surface and exposure, so photon counts use
    /// exactly the optics the camera chain models.
    pub fn from_camera(
        config: &gloam_sensor::SensorConfig,
        label: &str,
    ) -> Result<Self, CalibError> {
        let chain = gloam_sensor::Chain::new(config)
            .map_err(|e| CalibError::Source(format!("[rig] camera '{label}': {e}")))?;
        // An ND filter in the camera file is part of its optics; a gated
        // cathode integrates only for the duty cycle.
        let duty = config.photocathode.as_ref().map_or(1.0, |p| p.gate_duty);
        Ok(Self {
            pixel_pitch_um: chain.pitch_cathode_mm * 1e3,
            f_number: config.optics.f_number,
            optics_transmission: config.optics.transmission * 10f64.powf(-config.optics.nd_density),
            exposure_s: config.timing.exposure_s * duty,
            camera: Some(label.to_string()),
        })
    }

    /// On-axis image irradiance per unit radiance, sr: the camera equation
    /// `E / L = π τ / (4 N²)` of the sensor chain
    /// ([`gloam_sensor::image_irradiance_per_radiance`]), so a rig that
    /// describes a simulated camera counts the photons that camera receives.
    /// (A lensless EMVA set-up with a disk port of diameter D at distance d
    /// has `π / (1 + 4 (d/D)²)`: give `f_number = sqrt((d/D)² + 1/4)`.)
    pub fn irradiance_factor(&self) -> f64 {
        gloam_sensor::image_irradiance_per_radiance(self.f_number, self.optics_transmission)
    }

    /// Mean photons per pixel per exposure over `band_nm`:
    /// `μ_p = A t ∫ E(λ) λ/(hc) dλ`.
    pub fn photons_per_pixel(&self, radiance_at_camera: &Spectrum, band_nm: (f64, f64)) -> f64 {
        let area_m2 = (self.pixel_pitch_um * 1e-6).powi(2);
        let photon_radiance = radiance_at_camera.map_all(|w, v| v * photons_per_joule(w));
        area_m2
            * self.exposure_s
            * self.irradiance_factor()
            * photon_radiance.integrate_band(band_nm.0, band_nm.1)
    }

    fn validate(&self) -> Result<(), CalibError> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if !(ok(self.pixel_pitch_um)
            && ok(self.f_number)
            && ok(self.optics_transmission)
            && self.optics_transmission <= 1.0
            && ok(self.exposure_s))
        {
            return Err(CalibError::Source(format!(
                "[rig] needs pixel_pitch_um > 0, f_number > 0, 0 < optics_transmission ≤ 1 and exposure_s > 0 (got {self:?})"
            )));
        }
        Ok(())
    }
}

/// The `[rig]` table: either every number, or `camera = "PRESET_OR_FILE"`
/// (the numbers come from that sensor; any number given overrides it).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
struct RigToml {
    #[serde(default)]
    camera: Option<String>,
    #[serde(default)]
    pixel_pitch_um: Option<f64>,
    #[serde(default)]
    f_number: Option<f64>,
    #[serde(default)]
    optics_transmission: Option<f64>,
    #[serde(default)]
    exposure_s: Option<f64>,
}

/// A simulated integrating sphere.
#[derive(Clone, Debug)]
pub struct IntegratingSphere {
    pub lamp_name: String,
    /// Lamp flux spectrum into the sphere, W nm⁻¹ (already scaled to the flux).
    pub lamp_flux: Spectrum,
    pub reflectance: f64,
    pub port_fraction: f64,
    pub diameter_m: f64,
}

impl IntegratingSphere {
    /// Sphere multiplier `M = ρ / (1 − ρ(1 − f))`.
    pub fn multiplier(&self) -> f64 {
        sphere_multiplier(self.reflectance, self.port_fraction)
    }

    /// Inner surface area `π d²`, m².
    pub fn area_m2(&self) -> f64 {
        std::f64::consts::PI * self.diameter_m * self.diameter_m
    }

    /// Exit-port spectral radiance with the flux scaled by `flux_fraction`
    /// (an aperture at the source): `L(λ) = Φ(λ) M / (π A)`.
    pub fn exit_radiance(&self, flux_fraction: f64) -> Spectrum {
        let k = flux_fraction * self.multiplier() / (std::f64::consts::PI * self.area_m2());
        self.lamp_flux.map_all(|_, v| v * k)
    }
}

impl SphereSource {
    /// Rescales the lamp flux so that the brightest level's stimulus
    /// radiance (400–1000 nm, at the camera) equals `radiance_w_m2_sr`.
    /// Used to fit a rehearsal to a camera's range (see `auto_range`).
    pub fn scale_max_radiance(&mut self, radiance_w_m2_sr: f64) -> Result<(), CalibError> {
        let n = self.levels();
        let mut top = 0.0f64;
        for i in 0..n {
            if let Stimulus::Uniform {
                radiance_w_m2_sr: l,
                ..
            } = self.set_level(i)?.stimulus
            {
                top = top.max(l);
            }
        }
        if !(top > 0.0 && radiance_w_m2_sr > 0.0 && radiance_w_m2_sr.is_finite()) {
            return Err(CalibError::Source(format!(
                "cannot scale a source whose brightest level is {top} W m⁻² sr⁻¹ to {radiance_w_m2_sr}"
            )));
        }
        let k = radiance_w_m2_sr / top;
        self.sphere.lamp_flux = self.sphere.lamp_flux.map_all(|_, v| v * k);
        Ok(())
    }
}

/// `M = ρ / (1 − ρ(1 − f))`.
pub fn sphere_multiplier(reflectance: f64, port_fraction: f64) -> f64 {
    reflectance / (1.0 - reflectance * (1.0 - port_fraction))
}

/// One neutral-density filter.
#[derive(Clone, Debug)]
pub enum NdFilter {
    /// Spectrally flat, `T = 10^−D`.
    Density(f64),
    /// A measured transmission curve.
    Curve {
        name: String,
        transmission: Spectrum,
    },
}

impl NdFilter {
    fn apply(&self, l: &Spectrum) -> Spectrum {
        match self {
            NdFilter::Density(d) => {
                let t = 10f64.powf(-d);
                l.map_all(|_, v| v * t)
            }
            NdFilter::Curve { transmission, .. } => l.product(transmission),
        }
    }
    fn label(&self) -> String {
        match self {
            NdFilter::Density(d) => format!("ND {d:.3}"),
            NdFilter::Curve { name, .. } => format!("ND curve {name}"),
        }
    }
}

/// How a sphere is dimmed from level to level.
#[derive(Clone, Debug)]
pub enum Dimming {
    /// ND filters in front of the camera, one per level.
    Nd(Vec<NdFilter>),
    /// An aperture at the source: the flux fraction per level.
    Aperture(Vec<f64>),
}

/// An integrating sphere stepped through ND filters or aperture settings.
pub struct SphereSource {
    pub sphere: IntegratingSphere,
    pub dimming: Dimming,
    pub camera: CameraBand,
    pub rig: Option<Rig>,
}

impl CalibrationSource for SphereSource {
    fn describe(&self) -> String {
        let how = match &self.dimming {
            Dimming::Nd(f) => format!("{} ND filters", f.len()),
            Dimming::Aperture(a) => format!("{} aperture settings", a.len()),
        };
        format!(
            "simulated integrating sphere ({}, ρ = {}, f = {}, M = {:.3}), {how}",
            self.sphere.lamp_name,
            self.sphere.reflectance,
            self.sphere.port_fraction,
            self.sphere.multiplier()
        )
    }
    fn levels(&self) -> usize {
        match &self.dimming {
            Dimming::Nd(f) => f.len(),
            Dimming::Aperture(a) => a.len(),
        }
    }
    fn set_level(&mut self, i: usize) -> Result<Level, CalibError> {
        let n = self.levels();
        if i >= n {
            return Err(CalibError::Invalid(format!(
                "level {i} out of range (source has {n})"
            )));
        }
        let (l, label) = match &self.dimming {
            Dimming::Nd(f) => (f[i].apply(&self.sphere.exit_radiance(1.0)), f[i].label()),
            Dimming::Aperture(a) => (
                self.sphere.exit_radiance(a[i]),
                format!("aperture {:.2} %", 100.0 * a[i]),
            ),
        };
        Ok(make_level(label, l, &self.camera, &self.sphere.lamp_name))
    }
    fn camera(&self) -> &CameraBand {
        &self.camera
    }
    fn rig(&self) -> Option<&Rig> {
        self.rig.as_ref()
    }
    fn lamp_name(&self) -> &str {
        &self.sphere.lamp_name
    }
}

fn make_level(label: String, l: Spectrum, camera: &CameraBand, lamp: &str) -> Level {
    let stim = l.integrate_band(STIMULUS_BAND_NM.0, STIMULUS_BAND_NM.1);
    Level {
        label,
        stimulus: Stimulus::Uniform {
            radiance_w_m2_sr: stim,
            spectrum: lamp.to_string(),
        },
        band_radiance_w_m2_sr: camera.band_radiance(&l),
        spectral_radiance: l,
    }
}

/// One level of a manual source.
#[derive(Clone, Debug)]
pub struct ManualLevel {
    pub label: String,
    /// The spectrometer's CSV for this level; `None` = ask the operator.
    pub spectrum_csv: Option<PathBuf>,
}

/// The lab source: the operator sets each level, the spectrometer measures
/// the exit port, and its CSV (W m⁻² sr⁻¹ nm⁻¹) gives the radiance.
pub struct ManualSource {
    pub levels: Vec<ManualLevel>,
    pub lamp_name: String,
    pub camera: CameraBand,
    pub rig: Option<Rig>,
    /// Directory relative paths are resolved against.
    pub base_dir: PathBuf,
    input: Box<dyn BufRead>,
    output: Box<dyn Write>,
    /// Where the spectrometer files the operator names are noted.
    reads: gloam_io::ReadLog,
}

impl ManualSource {
    /// A manual source talking to the operator through `input`/`output`
    /// (stdin/stderr in the CLI; buffers in tests).
    pub fn new(
        levels: Vec<ManualLevel>,
        lamp_name: String,
        camera: CameraBand,
        rig: Option<Rig>,
        base_dir: PathBuf,
        input: Box<dyn BufRead>,
        output: Box<dyn Write>,
    ) -> Self {
        Self {
            levels,
            lamp_name,
            camera,
            rig,
            base_dir,
            input,
            output,
            reads: gloam_io::ReadLog::off(),
        }
    }

    /// Notes the spectrometer files read in `reads`.
    pub fn noting_reads(self, reads: &gloam_io::ReadLog) -> Self {
        Self {
            reads: reads.clone(),
            ..self
        }
    }

    /// One answer typed at `prompt`, at most [`MAX_ANSWER_BYTES`] long: a
    /// stream without newlines (the wrong program piped in, a device) grew
    /// one line until the process aborted.
    fn ask(&mut self, prompt: &str) -> Result<String, CalibError> {
        write!(self.output, "{prompt}").map_err(|e| CalibError::Io(e.to_string()))?;
        self.output
            .flush()
            .map_err(|e| CalibError::Io(e.to_string()))?;
        let prompt = prompt.trim();
        let mut line = Vec::new();
        let n = (&mut self.input)
            .take(MAX_ANSWER_BYTES + 1)
            .read_until(b'\n', &mut line)
            .map_err(|e| CalibError::Io(format!("reading the answer to '{prompt}': {e}")))?;
        if n == 0 {
            return Err(CalibError::EndOfInput(format!("'{prompt}'")));
        }
        if line.last() == Some(&b'\n') {
            line.pop();
        }
        if line.len() as u64 > MAX_ANSWER_BYTES {
            return Err(CalibError::Invalid(format!(
                "the answer to '{prompt}' is longer than {MAX_ANSWER_BYTES} bytes without a newline; \
                 type Enter, a path or q (is standard input the terminal?)"
            )));
        }
        let Ok(text) = String::from_utf8(line) else {
            return Err(CalibError::Invalid(format!(
                "the answer to '{prompt}' is not UTF-8 text; type Enter, a path or q"
            )));
        };
        let t = text.trim().to_string();
        if t.eq_ignore_ascii_case("q") || t.eq_ignore_ascii_case("quit") {
            return Err(CalibError::Aborted(format!("'{prompt}'")));
        }
        Ok(t)
    }
}

/// Longest answer a manual prompt takes, bytes: a path or `q` is far
/// shorter.
pub const MAX_ANSWER_BYTES: u64 = 64 * 1024;

impl CalibrationSource for ManualSource {
    fn describe(&self) -> String {
        format!(
            "manual lab source ({} levels, spectrometer-measured)",
            self.levels.len()
        )
    }
    fn levels(&self) -> usize {
        self.levels.len()
    }
    fn set_level(&mut self, i: usize) -> Result<Level, CalibError> {
        let lv = self
            .levels
            .get(i)
            .cloned()
            .ok_or_else(|| CalibError::Invalid(format!("level {i} out of range")))?;
        let n = self.levels.len();
        let path = match lv.spectrum_csv {
            Some(p) => {
                self.ask(&format!(
                    "Level {}/{n} ({}): set the source, then press Enter (q to abort): ",
                    i + 1,
                    lv.label
                ))?;
                p
            }
            None => {
                let typed = self.ask(&format!(
                    "Level {}/{n} ({}): set the source, measure the exit port, and type the spectrometer CSV path (q to abort): ",
                    i + 1,
                    lv.label
                ))?;
                // An empty line read as the path "" and failed as ": : cannot read".
                if typed.is_empty() {
                    return Err(CalibError::Source(format!(
                        "level {}/{n} ({}): no spectrometer CSV path typed (an empty line); \
                         type the path of the level's measured spectrum, or q to abort",
                        i + 1,
                        lv.label
                    )));
                }
                PathBuf::from(typed)
            }
        };
        let path = if path.is_absolute() {
            path
        } else {
            self.base_dir.join(path)
        };
        // The CSV error names the file; the level says which prompt it was.
        let l = gloam_spectra::read_csv(&path, &self.reads)
            .map_err(|e| CalibError::Source(format!("level {}/{n} ({}): {e}", i + 1, lv.label)))?;
        Ok(make_level(lv.label, l, &self.camera, &self.lamp_name))
    }
    fn set_dark(&mut self) -> Result<Level, CalibError> {
        self.ask("Dark: cap the lens or switch the source off, then press Enter (q to abort): ")?;
        Ok(Level {
            label: "dark".into(),
            stimulus: Stimulus::Dark,
            spectral_radiance: Spectrum::default(),
            band_radiance_w_m2_sr: 0.0,
        })
    }
    fn camera(&self) -> &CameraBand {
        &self.camera
    }
    fn rig(&self) -> Option<&Rig> {
        self.rig.as_ref()
    }
    fn lamp_name(&self) -> &str {
        &self.lamp_name
    }
}

/// Largest ND density a [dimming] list takes (1e300 was accepted: a
/// second dark level labelled in 300 digits).
pub const MAX_ND_DENSITY: f64 = 10.0;
/// A sphere's lamp flux, W, and diameter, m: from a micro-lamp to a
/// stadium floodlight, from a 1 mm sphere to a 100 m room.
pub const SPHERE_FLUX_W: (f64, f64) = (1e-9, 1e6);
pub const SPHERE_DIAMETER_M: (f64, f64) = (1e-3, 100.0);

// ---------------------------------------------------------------- file format

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileToml {
    source: SourceToml,
    #[serde(default)]
    dimming: Option<DimmingToml>,
    #[serde(default)]
    camera: Option<CameraToml>,
    #[serde(default)]
    rig: Option<RigToml>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SourceToml {
    kind: String,
    #[serde(default = "default_lamp")]
    lamp: String,
    lamp_flux_w: Option<f64>,
    flux_band_nm: Option<[f64; 2]>,
    sphere_diameter_m: Option<f64>,
    reflectance: Option<f64>,
    port_fraction: Option<f64>,
    #[serde(default)]
    levels: Vec<ManualLevelToml>,
}

fn default_lamp() -> String {
    "tungsten-halogen-3200k".into()
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ManualLevelToml {
    #[serde(default)]
    label: Option<String>,
    #[serde(default)]
    spectrum_csv: Option<PathBuf>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DimmingToml {
    method: String,
    #[serde(default)]
    densities: Option<Vec<f64>>,
    #[serde(default)]
    transmission_csv: Option<Vec<PathBuf>>,
    #[serde(default)]
    fractions: Option<Vec<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraToml {
    #[serde(default)]
    response: Option<String>,
    #[serde(default)]
    bandpass: Option<String>,
    #[serde(default)]
    band_nm: Option<[f64; 2]>,
}

/// A parsed source file, ready to be opened as a [`CalibrationSource`].
pub struct SourceFile {
    parsed: FileToml,
    base_dir: PathBuf,
    label: String,
    /// Where the files it names (spectra, sensor files) are noted.
    reads: gloam_io::ReadLog,
}

impl SourceFile {
    /// Reads and checks a source file; `reads` notes it and the files it
    /// names as they are read.
    pub fn load(path: &Path, reads: &gloam_io::ReadLog) -> Result<Self, CalibError> {
        let text = gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, reads)
            .map_err(|e| CalibError::file(path, e))?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let file = Self::parse(&text, &base, &path.display().to_string())?;
        Ok(Self {
            reads: reads.clone(),
            ..file
        })
    }

    /// Parses source-file text; relative paths resolve against `base_dir`
    /// (the files it names are read unnoted).
    pub fn parse(text: &str, base_dir: &Path, label: &str) -> Result<Self, CalibError> {
        // One line with the file's line and field, not the parser's quoted
        // line under a caret.
        let parsed: FileToml =
            toml::from_str(text).map_err(|e| CalibError::toml(label, text, &e))?;
        Ok(Self {
            parsed,
            base_dir: base_dir.to_path_buf(),
            label: label.to_string(),
            reads: gloam_io::ReadLog::off(),
        })
    }

    /// True for `kind = "manual"`.
    pub fn is_manual(&self) -> bool {
        self.parsed.source.kind == "manual"
    }

    fn err(&self, m: impl std::fmt::Display) -> CalibError {
        CalibError::file(&self.label, m)
    }

    fn spectrum(&self, name: &str) -> Result<Spectrum, CalibError> {
        let p = self.base_dir.join(name);
        let key = if !Path::new(name).is_absolute() && p.exists() {
            p.display().to_string()
        } else {
            name.to_string()
        };
        gloam_spectra::lookup(&key, &self.reads).map_err(|e| self.err(e))
    }

    fn camera(&self) -> Result<CameraBand, CalibError> {
        let Some(c) = &self.parsed.camera else {
            return Ok(CameraBand::default());
        };
        let response = match &c.response {
            Some(n) => {
                let s = self.spectrum(n)?;
                let peak = s
                    .values()
                    .iter()
                    .chain(s.lines().iter().map(|l| &l.value))
                    .fold(0.0f64, |a, &b| a.max(b));
                if peak <= 0.0 {
                    return Err(self.err(format!("camera response '{n}' is zero everywhere")));
                }
                Some(s.scaled(1.0 / peak).map_err(|e| self.err(e))?)
            }
            None => None,
        };
        let bandpass = match &c.bandpass {
            Some(n) => Some(self.spectrum(n)?),
            None => None,
        };
        let band_nm = match c.band_nm {
            Some([a, b]) if a.is_finite() && b.is_finite() && a > 0.0 && b > a => (a, b),
            Some(b) => {
                return Err(self.err(format!("camera.band_nm {b:?} is not an increasing pair")));
            }
            None => STIMULUS_BAND_NM,
        };
        Ok(CameraBand {
            response,
            bandpass,
            band_nm,
        })
    }

    fn rig(&self) -> Result<Option<Rig>, CalibError> {
        let Some(r) = &self.parsed.rig else {
            return Ok(None);
        };
        let mut rig = match &r.camera {
            Some(name) => {
                // A relative sensor file resolves against the source file.
                let p = self.base_dir.join(name);
                let key = if gloam_sensor::SensorConfig::preset(name).is_none() && p.exists() {
                    p.display().to_string()
                } else {
                    name.clone()
                };
                let cfg = gloam_sensor::load_preset_or_file(&key, &self.reads)
                    .map_err(|e| self.err(format!("[rig] camera: {e}")))?;
                Rig::from_camera(&cfg, name).map_err(|e| self.err(e))?
            }
            None => {
                let need = |v: Option<f64>, name: &str| {
                    v.ok_or_else(|| {
                        self.err(format!(
                            "[rig] needs {name} (or camera = \"PRESET_OR_FILE\" to take the camera's own optics)"
                        ))
                    })
                };
                Rig {
                    pixel_pitch_um: need(r.pixel_pitch_um, "pixel_pitch_um")?,
                    f_number: need(r.f_number, "f_number")?,
                    optics_transmission: r.optics_transmission.unwrap_or(1.0),
                    exposure_s: need(r.exposure_s, "exposure_s")?,
                    camera: None,
                }
            }
        };
        if let Some(v) = r.pixel_pitch_um {
            rig.pixel_pitch_um = v;
        }
        if let Some(v) = r.f_number {
            rig.f_number = v;
        }
        if let Some(v) = r.optics_transmission {
            rig.optics_transmission = v;
        }
        if let Some(v) = r.exposure_s {
            rig.exposure_s = v;
        }
        rig.validate().map_err(|e| self.err(e))?;
        Ok(Some(rig))
    }

    /// Opens a sphere source. `levels`: when the file lists no explicit
    /// densities/fractions, generate this many levels linear in radiance
    /// (`i/N`, i = 1..N: aperture fraction i/N or ND density −log10(i/N));
    /// when it does, `levels` must match the list (or be `None`).
    pub fn open_sphere(&self, levels: Option<usize>) -> Result<SphereSource, CalibError> {
        let s = &self.parsed.source;
        if s.kind != "sphere" {
            return Err(self.err(format!(
                "source.kind is '{}'; expected \"sphere\" (or open it as a manual source)",
                s.kind
            )));
        }
        let need = |v: Option<f64>, name: &str| {
            v.filter(|x| x.is_finite())
                .ok_or_else(|| self.err(format!("source.{name} is missing or not a number")))
        };
        let flux = need(s.lamp_flux_w, "lamp_flux_w")?;
        let rho = need(s.reflectance, "reflectance")?;
        let f = need(s.port_fraction, "port_fraction")?;
        let d = need(s.sphere_diameter_m, "sphere_diameter_m")?;
        if !(flux > 0.0 && rho > 0.0 && rho < 1.0 && f > 0.0 && f < 1.0 && d > 0.0) {
            return Err(self.err(
                "need lamp_flux_w > 0, 0 < reflectance < 1, 0 < port_fraction < 1, sphere_diameter_m > 0",
            ));
        }
        // Physical ranges: a 1e-200 m sphere reached the grabber as a NaN
        // radiance, and a 1e-300 W lamp was reported as "saturated".
        let num = gloam_spectra::num;
        for (name, v, (lo, hi), unit) in [
            ("lamp_flux_w", flux, SPHERE_FLUX_W, "W"),
            ("sphere_diameter_m", d, SPHERE_DIAMETER_M, "m"),
        ] {
            if !(lo..=hi).contains(&v) {
                return Err(self.err(format!(
                    "source.{name} = {}: must be from {} to {} {unit}",
                    num(v),
                    num(lo),
                    num(hi)
                )));
            }
        }
        let band = s
            .flux_band_nm
            .unwrap_or([STIMULUS_BAND_NM.0, STIMULUS_BAND_NM.1]);
        let lamp = self.spectrum(&s.lamp)?;
        let lamp_flux = lamp
            .normalized_to_band(band[0], band[1], flux)
            .map_err(|e| self.err(format!("lamp '{}': {e}", s.lamp)))?;
        let sphere = IntegratingSphere {
            lamp_name: s.lamp.clone(),
            lamp_flux,
            reflectance: rho,
            port_fraction: f,
            diameter_m: d,
        };
        let dimming = self.sphere_dimming(levels)?;
        Ok(SphereSource {
            sphere,
            dimming,
            camera: self.camera()?,
            rig: self.rig()?,
        })
    }

    /// The sphere's [dimming] table: aperture fractions or ND filters
    /// (densities and measured curves), as listed or, with none listed,
    /// `levels` evenly spaced steps; a listed count must match `levels`.
    fn sphere_dimming(&self, levels: Option<usize>) -> Result<Dimming, CalibError> {
        let dim = self
            .parsed
            .dimming
            .as_ref()
            .ok_or_else(|| self.err("a sphere source needs a [dimming] table"))?;
        let check_n = |len: usize| match levels {
            Some(n) if n != len => Err(self.err(format!(
                "--levels {n} but the file lists {len} dimming steps"
            ))),
            _ => Ok(()),
        };
        let generated = |n: Option<usize>| -> Result<Vec<f64>, CalibError> {
            let n = n.ok_or_else(|| {
                self.err("[dimming] lists no steps and no level count was given (--levels)")
            })?;
            if n == 0 {
                return Err(self.err("zero levels requested"));
            }
            Ok((1..=n).map(|i| i as f64 / n as f64).collect())
        };
        // The other method's list was silently ignored.
        let unused = match dim.method.as_str() {
            "aperture" if dim.densities.is_some() => Some("densities"),
            "aperture" if dim.transmission_csv.is_some() => Some("transmission_csv"),
            "nd" if dim.fractions.is_some() => Some("fractions"),
            _ => None,
        };
        if let Some(key) = unused {
            return Err(self.err(format!(
                "dimming.{key} is not read with method = \"{}\"; remove it or change the method",
                dim.method
            )));
        }
        // A step listed twice was measured twice and weighed double in the fit.
        let repeated = |what: &str, v: &[f64]| -> Result<(), CalibError> {
            for (i, x) in v.iter().enumerate() {
                if let Some(j) = v[..i].iter().position(|y| y == x) {
                    return Err(self.err(format!(
                        "dimming.{what}[{i}] = {} repeats dimming.{what}[{j}]; list each step once",
                        gloam_spectra::num(*x)
                    )));
                }
            }
            Ok(())
        };
        Ok(match dim.method.as_str() {
            "aperture" => {
                let fr = match &dim.fractions {
                    Some(v) => {
                        check_n(v.len())?;
                        v.clone()
                    }
                    None => generated(levels)?,
                };
                if fr.iter().any(|&x| !(x > 0.0 && x <= 1.0)) {
                    return Err(self.err("aperture fractions must lie in (0, 1]"));
                }
                repeated("fractions", &fr)?;
                Dimming::Aperture(fr)
            }
            "nd" => {
                let mut filters = Vec::new();
                if let Some(ds) = &dim.densities {
                    for &d in ds {
                        if !(d.is_finite() && (0.0..=MAX_ND_DENSITY).contains(&d)) {
                            return Err(self.err(format!(
                                "ND density {} must be from 0 to {MAX_ND_DENSITY} (a transmission down to 1e-{MAX_ND_DENSITY})",
                                gloam_spectra::num(d)
                            )));
                        }
                        filters.push(NdFilter::Density(d));
                    }
                    repeated("densities", ds)?;
                }
                if let Some(cs) = &dim.transmission_csv {
                    for c in cs {
                        let p = self.base_dir.join(c);
                        let t =
                            gloam_spectra::read_csv(&p, &self.reads).map_err(|e| self.err(e))?;
                        filters.push(NdFilter::Curve {
                            name: c.display().to_string(),
                            transmission: t,
                        });
                    }
                }
                if filters.is_empty() {
                    filters = generated(levels)?
                        .into_iter()
                        .map(|t| NdFilter::Density(-t.log10()))
                        .collect();
                } else {
                    check_n(filters.len())?;
                }
                Dimming::Nd(filters)
            }
            m => {
                return Err(self.err(format!(
                    "dimming.method '{m}' is not \"nd\" or \"aperture\""
                )));
            }
        })
    }

    /// Opens a manual source prompting through `input`/`output`.
    pub fn open_manual(
        &self,
        levels: Option<usize>,
        input: Box<dyn BufRead>,
        output: Box<dyn Write>,
    ) -> Result<ManualSource, CalibError> {
        let s = &self.parsed.source;
        if s.kind != "manual" {
            return Err(self.err(format!("source.kind is '{}', not \"manual\"", s.kind)));
        }
        let mut lv: Vec<ManualLevel> = s
            .levels
            .iter()
            .enumerate()
            .map(|(i, l)| ManualLevel {
                label: l
                    .label
                    .clone()
                    .unwrap_or_else(|| format!("level {}", i + 1)),
                spectrum_csv: l.spectrum_csv.clone(),
            })
            .collect();
        match (levels, lv.len()) {
            (Some(n), 0) => {
                lv = (0..n)
                    .map(|i| ManualLevel {
                        label: format!("level {}", i + 1),
                        spectrum_csv: None,
                    })
                    .collect()
            }
            (Some(n), m) if n != m => {
                return Err(self.err(format!("--levels {n} but the file lists {m} levels")));
            }
            (None, 0) => {
                return Err(self.err("a manual source needs [[source.levels]] or --levels"));
            }
            _ => {}
        }
        Ok(ManualSource::new(
            lv,
            s.lamp.clone(),
            self.camera()?,
            self.rig()?,
            self.base_dir.clone(),
            input,
            output,
        )
        .noting_reads(&self.reads))
    }

    /// Opens whichever kind the file describes; a manual source prompts on
    /// stdin/stderr.
    pub fn open(&self, levels: Option<usize>) -> Result<Box<dyn CalibrationSource>, CalibError> {
        if self.is_manual() {
            Ok(Box::new(self.open_manual(
                levels,
                Box::new(std::io::BufReader::new(std::io::stdin())),
                Box::new(std::io::stderr()),
            )?))
        } else {
            Ok(Box::new(self.open_sphere(levels)?))
        }
    }
}

/// A source opened for a grabber, and the brightest radiance auto-ranging
/// chose (W m⁻² sr⁻¹), if it ran.
pub struct OpenedSource {
    pub source: Box<dyn CalibrationSource>,
    pub auto_ranged_max_w_m2_sr: Option<f64>,
}

/// The most `--auto-range` asks: ten times full scale (a photon-transfer
/// sweep past saturation asks about 1.4).
pub const MAX_AUTO_RANGE: f64 = 10.0;

/// Opens the source file at `path` for `grabber`. With `auto_range =
/// Some(f)` (simulated spheres only) the sphere is rescaled so its
/// brightest level puts the camera at fraction `f` of full scale, measured
/// with AGC off at `gain` (`None`: the camera's current gain). Shared by
/// the CLI's `gloam calibrate` and the Python package.
pub fn open_for_grabber(
    path: &Path,
    levels: Option<usize>,
    auto_range: Option<f64>,
    grabber: &mut dyn gloam_grabber::FrameGrabber,
    gain: Option<f64>,
    reads: &gloam_io::ReadLog,
) -> Result<OpenedSource, CalibError> {
    let file = SourceFile::load(path, reads)?;
    let Some(frac) = auto_range else {
        return Ok(OpenedSource {
            source: file.open(levels)?,
            auto_ranged_max_w_m2_sr: None,
        });
    };
    if file.is_manual() {
        return Err(CalibError::Invalid(
            "--auto-range only applies to a simulated sphere source".into(),
        ));
    }
    // 1e300 set a sphere of 1.6e297 W m⁻² sr⁻¹ and printed it as 1e302 %
    // in 303 digits; past-saturation sweeps (PTC) ask 1.4 or so.
    if !(frac > 0.0 && frac <= MAX_AUTO_RANGE) {
        return Err(CalibError::Invalid(format!(
            "--auto-range {}: must be a positive fraction of full scale, at most {MAX_AUTO_RANGE}",
            gloam_spectra::num(frac)
        )));
    }
    let mut s = file.open_sphere(levels)?;
    crate::capture::agc_off(grabber)?;
    if let Some(gain) = gain {
        grabber.set_gain(gain)?;
    }
    // Aim at half scale (always reachable), then scale to the request.
    let l50 = crate::capture::auto_range(grabber, s.lamp_name(), 0.5)?;
    let top = l50 * frac / 0.5;
    s.scale_max_radiance(top)?;
    Ok(OpenedSource {
        source: Box::new(s),
        auto_ranged_max_w_m2_sr: Some(top),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_multiplier_and_radiance() {
        // ρ = 0.98, f = 0.02: M = 0.98 / (1 − 0.98·0.98) = 24.75.
        let m = sphere_multiplier(0.98, 0.02);
        assert!((m - 0.98 / (1.0 - 0.9604)).abs() < 1e-12);
        let sph = IntegratingSphere {
            lamp_name: "flat".into(),
            lamp_flux: Spectrum::constant(400.0, 1000.0, 10.0 / 600.0).unwrap(),
            reflectance: 0.98,
            port_fraction: 0.02,
            diameter_m: 0.5,
        };
        // L = Φ M / (π · π d²)
        let l = sph.exit_radiance(1.0).integrate_band(400.0, 1000.0);
        let want = 10.0 * m / (std::f64::consts::PI * std::f64::consts::PI * 0.25);
        assert!((l / want - 1.0).abs() < 1e-12);
        let half = sph.exit_radiance(0.5).integrate_band(400.0, 1000.0);
        assert!((half / want - 0.5).abs() < 1e-12);
    }

    #[test]
    fn nd_density_and_band_weighting() {
        let text = r#"
[source]
kind = "sphere"
lamp = "tungsten-halogen-3200k"
lamp_flux_w = 1.0
sphere_diameter_m = 0.3
reflectance = 0.95
port_fraction = 0.05
[dimming]
method = "nd"
densities = [0.0, 1.0]
"#;
        let f = SourceFile::parse(text, Path::new("."), "t.toml").unwrap();
        let mut s = f.open_sphere(None).unwrap();
        let a = s.set_level(0).unwrap();
        let b = s.set_level(1).unwrap();
        assert!((b.band_radiance_w_m2_sr / a.band_radiance_w_m2_sr - 0.1).abs() < 1e-12);
        assert!(f.open_sphere(Some(3)).is_err());
    }

    #[test]
    fn rig_from_camera_counts_the_photons_the_chain_receives() {
        let text = |rig: &str| {
            format!(
                "[source]\nkind = \"sphere\"\nlamp_flux_w = 1.0\nsphere_diameter_m = 0.5\nreflectance = 0.98\nport_fraction = 0.02\n[dimming]\nmethod = \"aperture\"\n[rig]\n{rig}\n"
            )
        };
        for preset in ["scientific-ccd", "gen3-gaas-iccd"] {
            let f = SourceFile::parse(
                &text(&format!("camera = \"{preset}\"")),
                Path::new("."),
                "t.toml",
            )
            .unwrap();
            let rig = f.rig().unwrap().unwrap();
            let cfg = gloam_sensor::load_preset_or_file(preset, &gloam_io::ReadLog::off()).unwrap();
            let chain = gloam_sensor::Chain::new(&cfg).unwrap();
            // Étendue × exposure of the chain: π τ A t / (4 N²), written out.
            let (n, tau) = (cfg.optics.f_number, cfg.optics.transmission);
            let a = (chain.pitch_cathode_mm * 1e-3).powi(2);
            let want = std::f64::consts::PI * tau * a * cfg.timing.exposure_s / (4.0 * n * n);
            let got =
                (rig.pixel_pitch_um * 1e-6).powi(2) * rig.exposure_s * rig.irradiance_factor();
            assert!(
                (got / want - 1.0).abs() < 1e-12,
                "{preset}: {got} vs {want}"
            );
            assert!((chain.etendue_m2_sr_s / want - 1.0).abs() < 1e-12);
        }
        // A number given next to `camera` overrides the camera's.
        let f = SourceFile::parse(
            &text("camera = \"scientific-ccd\"\nexposure_s = 0.5"),
            Path::new("."),
            "t.toml",
        )
        .unwrap();
        let rig = f.rig().unwrap().unwrap();
        assert_eq!((rig.exposure_s, rig.optics_transmission), (0.5, 0.9));
        // Missing numbers without a camera, and an unknown camera: errors.
        let f = SourceFile::parse(&text("f_number = 2.0"), Path::new("."), "t.toml").unwrap();
        assert!(f.rig().unwrap_err().to_string().contains("pixel_pitch_um"));
        let f = SourceFile::parse(&text("camera = \"nope\""), Path::new("."), "t.toml").unwrap();
        assert!(f.rig().is_err());
    }

    #[test]
    fn manual_source_prompts_and_reads_csv() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("l1.csv"),
            "wavelength_nm,radiance\n400,0.001\n1000,0.001\n",
        )
        .unwrap();
        let text = r#"
[source]
kind = "manual"
[[source.levels]]
label = "lamp 1"
spectrum_csv = "l1.csv"
[[source.levels]]
label = "lamp 2"
"#;
        let f = SourceFile::parse(text, dir.path(), "m.toml").unwrap();
        let input = format!("\n{}\n", dir.path().join("l1.csv").display());
        let mut s = f
            .open_manual(
                None,
                Box::new(std::io::Cursor::new(input)),
                Box::new(Vec::new()),
            )
            .unwrap();
        let a = s.set_level(0).unwrap();
        assert!((a.band_radiance_w_m2_sr - 0.6).abs() < 1e-12);
        let b = s.set_level(1).unwrap();
        assert!((b.band_radiance_w_m2_sr - 0.6).abs() < 1e-12);
        // End of input: said as such, not a hang, a panic or an operator's abort.
        assert!(matches!(s.set_level(0), Err(CalibError::EndOfInput(_))));
    }
    /// A stream without newlines is refused at the bound, naming the
    /// prompt, instead of growing one line until the allocation fails; an
    /// empty path names its level instead of failing as ": : cannot read".
    #[test]
    fn manual_answers_are_bounded_and_named() {
        let dir = tempfile::tempdir().unwrap();
        let text = "[source]\nkind = \"manual\"\n[[source.levels]]\nlabel = \"b\"\n";
        let f = SourceFile::parse(text, dir.path(), "m.toml").unwrap();
        let long = vec![0u8; MAX_ANSWER_BYTES as usize + 10];
        let mut s = f
            .open_manual(
                None,
                Box::new(std::io::Cursor::new(long)),
                Box::new(Vec::new()),
            )
            .unwrap();
        let e = s.set_dark().unwrap_err().to_string();
        assert!(
            e.contains("Dark:") && e.contains("longer than 65536 bytes"),
            "{e}"
        );
        let mut s = f
            .open_manual(
                None,
                Box::new(std::io::Cursor::new("\n\n")),
                Box::new(Vec::new()),
            )
            .unwrap();
        s.set_dark().unwrap();
        let e = s.set_level(0).unwrap_err().to_string();
        assert!(
            e.contains("level 1/1 (b): no spectrometer CSV path typed"),
            "{e}"
        );
        let e = s.set_level(0).unwrap_err().to_string();
        assert!(e.starts_with("end of input at 'Level 1/1 (b)"), "{e}");
    }
}
