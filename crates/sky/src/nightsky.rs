//! Moonless night-sky background: integrated starlight, zodiacal light and
//! airglow as a uniform spectral radiance of the sky dome.
//!
//! The default curve ([`NIGHT_SKY_RELATIVE_RADIANCE`]) is a *documented
//! approximation*, not a measurement: a smooth continuum rising steeply into
//! the near infrared (OH Meinel bands dominate beyond 700 nm), after the
//! shapes in Vatsia (1972, "Atmospheric optical environment", ECOM-7023) and
//! Leinert et al. (1998, A&AS 127, 1), plus the three strongest visible
//! airglow lines (O I 557.7 nm, Na D 589.3 nm, O I 630.0 nm) added as
//! single 5-nm bins. It is scaled photometrically so that a clear moonless
//! sky gives [`CLEAR_MOONLESS_LUX`] = 1e-3 lux on the ground, using
//! `E = π L` for a uniform dome. An overcast sky multiplies it by
//! [`OVERCAST_FACTOR`] = 0.1 (≈ 1e-4 lux; no light pollution modelled).

use crate::error::{Result, check_range};
use crate::spectral::{self, Samples};

/// Horizontal illuminance of the clear moonless night sky, lux.
pub const CLEAR_MOONLESS_LUX: f64 = 1e-3;
/// Overcast / clear ratio of the night-sky background.
pub const OVERCAST_FACTOR: f64 = 0.1;

/// Relative spectral radiance (energy units, per nm, arbitrary scale) of
/// the continuum, 50-nm nodes; linear interpolation in between.
pub const NIGHT_SKY_RELATIVE_RADIANCE: [(f64, f64); 17] = [
    (300.0, 0.05),
    (350.0, 0.15),
    (400.0, 0.35),
    (450.0, 0.55),
    (500.0, 0.70),
    (550.0, 1.00),
    (600.0, 1.10),
    (650.0, 1.50),
    (700.0, 2.00),
    (750.0, 3.00),
    (800.0, 4.00),
    (850.0, 5.50),
    (900.0, 6.00),
    (950.0, 6.50),
    (1000.0, 7.00),
    (1050.0, 8.00),
    (1100.0, 9.00),
];

/// Airglow lines: (centre nm, integrated strength in relative-radiance × nm).
pub const AIRGLOW_LINES: [(f64, f64); 3] = [(557.7, 3.0), (589.3, 1.0), (630.0, 1.5)];

/// Sky-dome spectral radiance of the night-sky background on the default
/// grid, W m⁻² sr⁻¹ nm⁻¹, scaled so that `π L` gives `horizontal_lux`.
/// `horizontal_lux` must be in [0, 1].
pub fn night_sky_radiance_w_m2_sr_nm(horizontal_lux: f64) -> Result<Samples> {
    check_range("night_sky_horizontal_lux", horizontal_lux, 0.0, 1.0)?;
    let grid = spectral::default_grid_nm();
    let step = spectral::GRID_STEP_NM;
    let shape: Samples = grid
        .iter()
        .map(|&w| {
            let mut v = spectral::interpolate(&NIGHT_SKY_RELATIVE_RADIANCE, w);
            for &(c, s) in AIRGLOW_LINES.iter() {
                if (w - c).abs() < 0.5 * step {
                    v += s / step;
                }
            }
            (w, v)
        })
        .collect();
    let lux_per_unit = std::f64::consts::PI * spectral::illuminance_lux(&shape)?;
    Ok(spectral::scaled_to(shape, horizontal_lux, lux_per_unit))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clear_and_overcast_levels() {
        let l = night_sky_radiance_w_m2_sr_nm(CLEAR_MOONLESS_LUX).unwrap();
        let e: Samples = l
            .iter()
            .map(|&(w, v)| (w, v * std::f64::consts::PI))
            .collect();
        let lux = spectral::illuminance_lux(&e).unwrap();
        assert!((lux - 1e-3).abs() < 1e-9, "{lux}");
        let o = night_sky_radiance_w_m2_sr_nm(CLEAR_MOONLESS_LUX * OVERCAST_FACTOR).unwrap();
        let e: Samples = o
            .iter()
            .map(|&(w, v)| (w, v * std::f64::consts::PI))
            .collect();
        assert!((spectral::illuminance_lux(&e).unwrap() - 1e-4).abs() < 1e-10);
        // NIR-rich: more radiance at 900 nm than at 500 nm
        assert!(spectral::interpolate(&l, 900.0) > 4.0 * spectral::interpolate(&l, 500.0));
        assert!(night_sky_radiance_w_m2_sr_nm(-1.0).is_err());
    }
}
