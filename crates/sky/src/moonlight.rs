//! Exo-atmospheric lunar irradiance.
//!
//! Model: Krisciunas & Schaefer (1991), PASP 103, 1033, eqs. 8 and 20:
//! the Moon's integrated V magnitude at mean distance,
//! `m_V(α) = −12.73 + 0.026|α| + 4×10⁻⁹ α⁴` (α phase angle in degrees, from
//! Allen 1973), i.e. an illuminance outside the atmosphere
//! `I*(α) = 10^{−0.4(3.84 + 0.026|α| + 4×10⁻⁹ α⁴)}` foot-candles
//! (1 fc = 10.7639 lux), scaled by `(384 400 km / d)²`, and — as in K&S —
//! brightened by the opposition surge for |α| < 7°: a factor
//! `1.35 − 0.05|α|` (35 % at α = 0, falling linearly to none at 7°).
//! Switch the surge off with [`MoonlightOptions::opposition_surge`].
//!
//! Spectral shape (not ROLO): the solar spectrum (see
//! [`crate::spectral::solar_irradiance_1au_w_m2_nm`]) times a lunar
//! disk-reflectance colour ("the Moon is red"), tabulated in
//! [`LUNAR_RELATIVE_REFLECTANCE`]; the product is renormalised so its
//! photopic illuminance equals K&S's. The colour is taken as independent of
//! phase angle (real phase reddening is a few % per 10°).
//!
//! Figures at mean distance (384 400 km): α = 0 → 0.423 lux with the surge
//! (0.313 without); α = 3° → 0.352 lux; α = 7° → 0.299 lux; α = 90° → 0.0285
//! lux (0.091 of the full-moon value without surge).

use crate::error::{Result, check_range};
use crate::spectral::{self, Samples};

/// Mean Earth–Moon distance used by Krisciunas & Schaefer, km.
pub const MEAN_MOON_DISTANCE_KM: f64 = 384_400.0;
/// Lux per foot-candle.
pub const LUX_PER_FOOTCANDLE: f64 = 10.763_910_4;

/// Relative lunar disk reflectance (normalised to 1 at 550 nm), λ in nm.
/// Approximate values read from the ROLO disk-equivalent reflectance at
/// small phase angles (Kieffer & Stone 2005, AJ 129, 2887) and Lane &
/// Irvine (1973); ±10 %. Interpolated linearly, held constant beyond the ends.
pub const LUNAR_RELATIVE_REFLECTANCE: [(f64, f64); 17] = [
    (300.0, 0.45),
    (350.0, 0.56),
    (400.0, 0.70),
    (450.0, 0.81),
    (500.0, 0.90),
    (550.0, 1.00),
    (600.0, 1.08),
    (650.0, 1.16),
    (700.0, 1.24),
    (750.0, 1.31),
    (800.0, 1.38),
    (850.0, 1.45),
    (900.0, 1.52),
    (950.0, 1.59),
    (1000.0, 1.66),
    (1050.0, 1.73),
    (1100.0, 1.80),
];

/// Options of the lunar model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoonlightOptions {
    /// Apply K&S's opposition surge (default true).
    pub opposition_surge: bool,
}

impl Default for MoonlightOptions {
    fn default() -> Self {
        Self {
            opposition_surge: true,
        }
    }
}

/// Integrated V magnitude of the Moon at mean distance (K&S 1991 eq. 20),
/// without the opposition surge. `phase_angle_deg` in [0, 180].
pub fn lunar_v_magnitude(phase_angle_deg: f64) -> f64 {
    let a = phase_angle_deg.abs();
    -12.73 + 0.026 * a + 4e-9 * a.powi(4)
}

/// K&S opposition-surge factor: `1.35 − 0.05|α|` for |α| < 7°, else 1.
pub fn opposition_surge_factor(phase_angle_deg: f64) -> f64 {
    let a = phase_angle_deg.abs();
    if a < 7.0 { 1.35 - 0.05 * a } else { 1.0 }
}

/// Illuminance from the Moon on a surface normal to its rays, outside the
/// atmosphere, lux. `phase_angle_deg` in [0, 180], `distance_km` in
/// [300 000, 450 000] (geocentric or topocentric).
pub fn lunar_illuminance_exo_lux(
    phase_angle_deg: f64,
    distance_km: f64,
    options: MoonlightOptions,
) -> Result<f64> {
    check_range("phase_angle_deg", phase_angle_deg, 0.0, 180.0)?;
    check_range("distance_km", distance_km, 300_000.0, 450_000.0)?;
    let a = phase_angle_deg;
    let fc = 10f64.powf(-0.4 * (3.84 + 0.026 * a + 4e-9 * a.powi(4)));
    let surge = if options.opposition_surge {
        opposition_surge_factor(a)
    } else {
        1.0
    };
    let d = MEAN_MOON_DISTANCE_KM / distance_km;
    Ok(fc * LUX_PER_FOOTCANDLE * surge * d * d)
}

/// Relative lunar reflectance at a wavelength (see
/// [`LUNAR_RELATIVE_REFLECTANCE`]).
pub fn lunar_relative_reflectance(wavelength_nm: f64) -> f64 {
    let t = &LUNAR_RELATIVE_REFLECTANCE;
    let w = wavelength_nm.clamp(t[0].0, t[t.len() - 1].0);
    spectral::interpolate(t, w)
}

/// Exo-atmospheric lunar spectral irradiance on a surface normal to the
/// rays, W m⁻² nm⁻¹, on the default grid (300–1100 nm, 5 nm), photometrically
/// normalised to [`lunar_illuminance_exo_lux`].
pub fn lunar_spectral_irradiance_exo(
    phase_angle_deg: f64,
    distance_km: f64,
    options: MoonlightOptions,
) -> Result<Samples> {
    let lux = lunar_illuminance_exo_lux(phase_angle_deg, distance_km, options)?;
    let shape: Samples = spectral::default_grid_nm()
        .into_iter()
        .map(|w| {
            (
                w,
                spectral::solar_irradiance_1au_w_m2_nm(w) * lunar_relative_reflectance(w),
            )
        })
        .collect();
    let shape_lux = spectral::illuminance_lux(&shape)?;
    Ok(spectral::scaled_to(shape, lux, shape_lux))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_moon_anchor() {
        let o = MoonlightOptions::default();
        let full0 = lunar_illuminance_exo_lux(0.0, MEAN_MOON_DISTANCE_KM, o).unwrap();
        let full3 = lunar_illuminance_exo_lux(3.0, MEAN_MOON_DISTANCE_KM, o).unwrap();
        let nosurge = lunar_illuminance_exo_lux(
            0.0,
            MEAN_MOON_DISTANCE_KM,
            MoonlightOptions {
                opposition_surge: false,
            },
        )
        .unwrap();
        println!("full moon exo lux: α=0 {full0:.3} (no surge {nosurge:.3}), α=3° {full3:.3}");
        // ≈ 0.3 lux (accept 0.2–0.4) for a real full moon (α ≈ 1.5–7°, no eclipse)
        for a in [1.5, 3.0, 5.0, 7.0] {
            let e = lunar_illuminance_exo_lux(a, MEAN_MOON_DISTANCE_KM, o).unwrap();
            assert!((0.2..=0.4).contains(&e), "α={a}: {e}");
        }
        assert!((nosurge - 0.313).abs() < 0.002);
        assert!((full0 - 0.423).abs() < 0.002);
    }

    #[test]
    fn quarter_is_a_tenth_of_full() {
        let o = MoonlightOptions {
            opposition_surge: false,
        };
        let full = lunar_illuminance_exo_lux(0.0, MEAN_MOON_DISTANCE_KM, o).unwrap();
        let q = lunar_illuminance_exo_lux(90.0, MEAN_MOON_DISTANCE_KM, o).unwrap();
        let ratio = q / full;
        println!("quarter/full = {ratio:.4} (quarter {q:.4} lux)");
        assert!((0.06..=0.14).contains(&ratio), "{ratio}");
        // also against the surge-brightened full moon at α = 3°
        let full3 =
            lunar_illuminance_exo_lux(3.0, MEAN_MOON_DISTANCE_KM, MoonlightOptions::default())
                .unwrap();
        assert!((0.06..=0.14).contains(&(q / full3)));
    }

    #[test]
    fn spectrum_is_photometrically_consistent() {
        let o = MoonlightOptions::default();
        let s = lunar_spectral_irradiance_exo(5.0, 370_000.0, o).unwrap();
        let lux = spectral::illuminance_lux(&s).unwrap();
        let want = lunar_illuminance_exo_lux(5.0, 370_000.0, o).unwrap();
        assert!((lux / want - 1.0).abs() < 1e-9);
        // red Moon: more power per nm at 800 than at 450
        assert!(spectral::interpolate(&s, 800.0) > spectral::interpolate(&s, 450.0));
        assert!(s.iter().all(|&(_, v)| v.is_finite() && v >= 0.0));
    }

    #[test]
    fn distance_and_bad_input() {
        let o = MoonlightOptions::default();
        let near = lunar_illuminance_exo_lux(10.0, 356_500.0, o).unwrap();
        let far = lunar_illuminance_exo_lux(10.0, 406_700.0, o).unwrap();
        assert!((near / far - (406_700.0f64 / 356_500.0).powi(2)).abs() < 1e-12);
        assert!(lunar_illuminance_exo_lux(f64::NAN, 384_400.0, o).is_err());
        assert!(lunar_illuminance_exo_lux(10.0, 0.0, o).is_err());
        assert!(lunar_illuminance_exo_lux(181.0, 384_400.0, o).is_err());
    }
}
