//! The detected band: what a simulated camera sees of a render.
//!
//! A band value `∫ L R_b dλ` loses the spectrum inside the band, and the
//! detector's QE varies across it (an S-20 cathode sees tungsten or HPS
//! light ~27 % less efficiently than a flat spectrum of the same band
//! power). So the render carries one extra band whose response is the
//! camera's detector response QE(λ)·λ/hc over the scene's spectral range:
//! its value is the detected-electron radiance `∫ L QE λ/hc dλ`, exact for
//! any spectrum (lines included), which the camera captures directly. The
//! extra band is not written to the radiance outputs.

use gloam_scene::{Band, Scene};
use gloam_sensor::Camera;
use gloam_spectra::Spectrum;
use gloam_trace::RenderOutput;
use ndarray::{Array2, Axis, s};

use gloam_sensor::ResolvedSensor;

/// Name of the band the sensor capture adds to a render.
pub const DETECTED_BAND: &str = "sensor-detected";

/// Why a render cannot carry (or give up) the detected band.
#[derive(Debug, thiserror::Error)]
pub enum DetectedError {
    #[error("the scene already has a band named '{DETECTED_BAND}', which the sensor capture needs")]
    BandTaken,
    #[error("loading sensor '{sensor}'")]
    Sensor {
        sensor: String,
        #[source]
        source: gloam_sensor::ConfigError,
    },
    #[error("the scene has no spectral band to capture")]
    NoBand,
    #[error(transparent)]
    Window(#[from] gloam_spectra::SpectrumError),
    #[error("the render has no '{DETECTED_BAND}' band")]
    NotRendered,
}

/// `scene` with one more band, [`DETECTED_BAND`], whose response is
/// `sensor`'s detector response (QE·λ/hc, e⁻ J⁻¹) over the span of the
/// scene's bands.
pub fn with_detected_band(scene: &Scene, sensor: &ResolvedSensor) -> Result<Scene, DetectedError> {
    if scene.band(DETECTED_BAND).is_some() {
        return Err(DetectedError::BandTaken);
    }
    let camera = Camera::new(sensor.config().clone()).map_err(|source| DetectedError::Sensor {
        sensor: sensor.name().to_string(),
        source,
    })?;
    let lo_nm = scene
        .bands
        .iter()
        .map(|b| b.lo_nm)
        .fold(f64::INFINITY, f64::min);
    let hi_nm = scene
        .bands
        .iter()
        .map(|b| b.hi_nm)
        .fold(f64::NEG_INFINITY, f64::max);
    if lo_nm.partial_cmp(&hi_nm) != Some(std::cmp::Ordering::Less) {
        return Err(DetectedError::NoBand);
    }
    let window = Spectrum::constant(lo_nm, hi_nm, 1.0)?;
    let mut with = scene.clone();
    with.bands.push(Band {
        name: DETECTED_BAND.into(),
        response: camera.chain().detected_response_e_per_j().product(&window),
        lo_nm,
        hi_nm,
    });
    Ok(with)
}

/// Splits the [`DETECTED_BAND`] (the last band) off a render of a scene
/// from [`with_detected_band`]: the render keeps the scene's own bands.
pub fn take_detected_band(render: &mut RenderOutput) -> Result<Array2<f64>, DetectedError> {
    if render.band_names.last().map(String::as_str) != Some(DETECTED_BAND) {
        return Err(DetectedError::NotRendered);
    }
    let last = render.band_names.len() - 1;
    let detected = render.radiance.index_axis(Axis(0), last).to_owned();
    render.radiance = render.radiance.slice(s![..last, .., ..]).to_owned();
    // The standard error too, so stderr.npy has the radiance's bands.
    render.std_error = render.std_error.slice(s![..last, .., ..]).to_owned();
    render.band_names.pop();
    render.stats.bands = last;
    Ok(detected)
}
