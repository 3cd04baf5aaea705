//! Ephemeris and night-sky illuminance (`gloam ephem`, `gloam sky`).

use pyo3::prelude::*;

use gloam_sky::report::{InputNames, QueryError, checked_site, parse_instant};
use gloam_sky::{Cloud, Refraction, Site, UtcInstant, ephemeris, ground_illuminance};

use crate::convert::to_py_as;
use crate::errors::OrPy;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(ephem, m)?)?;
    m.add_function(wrap_pyfunction!(sky, m)?)?;
    Ok(())
}

/// The site and instant, checked by the same functions as `gloam ephem`
/// and `gloam sky`, with errors naming the keyword.
fn site_and_time(
    lat: f64,
    lon: f64,
    height_m: f64,
    utc: &str,
) -> Result<(Site, UtcInstant), QueryError> {
    let names = InputNames::PYTHON;
    let site = checked_site(lat, lon, height_m, &names)?;
    Ok((site, parse_instant(names.utc, utc)?))
}

/// Moon and Sun positions and the lunar phase at ``utc`` (ISO 8601) for a
/// site (degrees north, degrees east, metres): Meeus with parallax and
/// standard refraction. An ``Ephemeris`` (a dict with attribute access):
/// ``moon``, ``sun`` (elevation_deg, azimuth_deg, …),
/// ``illuminated_fraction``, ``phase_angle_deg``, …
#[pyfunction]
#[pyo3(signature = (lat, lon, utc, height_m = 0.0))]
fn ephem<'py>(
    py: Python<'py>,
    lat: f64,
    lon: f64,
    utc: &str,
    height_m: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let (site, t) = site_and_time(lat, lon, height_m, utc).or_py()?;
    to_py_as(py, &ephemeris(t, &site, Refraction::STANDARD), "Ephemeris")
}

/// Illuminance on the ground from the Moon (direct and sky-scattered) and
/// the night sky, as ``gloam sky``, at a site (degrees north, degrees
/// east, metres) and ``utc`` (ISO 8601) under a clear sky of
/// ``visibility_km`` or ``overcast``: a ``SkyIlluminance`` (a dict with
/// attribute access) with ``illuminance_lux`` (moon_direct, moon_sky,
/// night_sky, total), the ephemeris, and with ``spectra=True`` the
/// spectral irradiance tables (W m⁻² nm⁻¹).
#[pyfunction]
#[pyo3(signature = (lat, lon, utc, height_m = 0.0, visibility_km = 23.0, overcast = false, spectra = false))]
#[allow(clippy::too_many_arguments)]
fn sky<'py>(
    py: Python<'py>,
    lat: f64,
    lon: f64,
    utc: &str,
    height_m: f64,
    visibility_km: f64,
    overcast: bool,
    spectra: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let (site, t) = site_and_time(lat, lon, height_m, utc).or_py()?;
    let cloud = if overcast {
        Cloud::Overcast
    } else {
        Cloud::Clear
    };
    let g = py
        .detach(|| ground_illuminance(t, &site, visibility_km, cloud, spectra))
        .or_py()?;
    to_py_as(py, &g, "SkyIlluminance")
}
