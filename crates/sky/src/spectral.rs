//! Spectral grid, embedded data tables and photometry.
//!
//! Spectra in this crate are plain `Vec<(wavelength_nm, value)>` sorted by
//! wavelength (the caller bridges to `gloam_spectra::Spectrum`). The default
//! grid is 300–1100 nm every 5 nm, covering S20/S25/Gen-3 GaAs photocathodes.
//!
//! Photometry: `E_v = K_m ∫ E(λ) V(λ) dλ` with `gloam-spectra`'s K_m and
//! CIE 1924 photopic V(λ), trapezoidal integration in f64.

use std::sync::OnceLock;

use crate::error::Result;

/// Maximum luminous efficacy for photopic vision, lm/W.
pub const K_M_LM_PER_W: f64 = gloam_spectra::KM_PHOTOPIC_LM_W;
/// Solar constant (total solar irradiance at 1 AU), W/m² (Kopp & Lean 2011).
pub const SOLAR_CONSTANT_W_M2: f64 = 1361.0;
/// Effective solar temperature used for the solar-spectrum approximation, K.
pub const SUN_TEMPERATURE_K: f64 = 5778.0;

/// First wavelength of the default grid, nm.
pub const GRID_START_NM: f64 = 300.0;
/// Last wavelength of the default grid, nm.
pub const GRID_END_NM: f64 = 1100.0;
/// Spacing of the default grid, nm.
pub const GRID_STEP_NM: f64 = 5.0;

/// A sampled spectrum: `(wavelength_nm, value)` pairs, ascending wavelength.
pub type Samples = Vec<(f64, f64)>;

/// The default wavelength grid: 300, 305, …, 1100 nm (161 samples).
pub fn default_grid_nm() -> Vec<f64> {
    let n = ((GRID_END_NM - GRID_START_NM) / GRID_STEP_NM).round() as usize + 1;
    (0..n)
        .map(|i| GRID_START_NM + GRID_STEP_NM * i as f64)
        .collect()
}

/// Linear interpolation in a sorted table; 0 outside its range (and for an
/// empty table or non-finite wavelength).
pub fn interpolate(table: &[(f64, f64)], wavelength_nm: f64) -> f64 {
    if table.is_empty() || !wavelength_nm.is_finite() {
        return 0.0;
    }
    let first = table[0].0;
    let last = table[table.len() - 1].0;
    if wavelength_nm < first || wavelength_nm > last {
        return 0.0;
    }
    let i = table.partition_point(|&(w, _)| w < wavelength_nm);
    if i == 0 {
        return table[0].1;
    }
    let (w0, v0) = table[i - 1];
    let (w1, v1) = table[i];
    if w1 == w0 {
        return v1;
    }
    v0 + (v1 - v0) * (wavelength_nm - w0) / (w1 - w0)
}

/// Trapezoidal integral of a sampled spectrum over wavelength (value × nm).
pub fn integrate(samples: &[(f64, f64)]) -> f64 {
    samples
        .windows(2)
        .map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0))
        .sum()
}

/// CIE 1924 photopic luminous efficiency V(λ), 360–830 nm at 1 nm, as
/// `(wavelength_nm, value)` pairs ([`gloam_spectra::library::photopic_v`]).
pub fn photopic_v() -> Result<&'static [(f64, f64)]> {
    static V: OnceLock<Samples> = OnceLock::new();
    Ok(V.get_or_init(|| {
        let v = gloam_spectra::library::photopic_v();
        v.wavelengths_nm()
            .iter()
            .copied()
            .zip(v.values().iter().copied())
            .collect()
    }))
}

/// Illuminance (lux) of a spectral irradiance in W m⁻² nm⁻¹:
/// `683 ∫ E(λ) V(λ) dλ`, evaluated on V's 1 nm grid with E interpolated
/// linearly (E = 0 outside its own range).
pub fn illuminance_lux(irradiance_w_m2_nm: &[(f64, f64)]) -> Result<f64> {
    let v = photopic_v()?;
    let weighted: Samples = v
        .iter()
        .map(|&(w, vv)| (w, vv * interpolate(irradiance_w_m2_nm, w)))
        .collect();
    Ok(K_M_LM_PER_W * integrate(&weighted))
}

/// `shape` scaled so that a photometric quantity of `per_unit` per unit
/// scale becomes `target` (all zero when the shape has no such quantity).
pub fn scaled_to(shape: Samples, target: f64, per_unit: f64) -> Samples {
    let k = if per_unit > 0.0 {
        target / per_unit
    } else {
        0.0
    };
    shape.into_iter().map(|(w, v)| (w, v * k)).collect()
}

/// Planck spectral radiance B(λ, T), W m⁻² sr⁻¹ nm⁻¹.
pub use gloam_spectra::planck_radiance_w_m2_sr_nm as planck_w_m2_sr_nm;

/// Exo-atmospheric solar spectral irradiance at 1 AU, W m⁻² nm⁻¹, at the
/// default grid.
///
/// **Approximation**: a 5778 K blackbody scaled so that its *total* (all
/// wavelengths) irradiance equals the solar constant 1361 W/m²:
/// `E(λ) = 1361 · π B(λ, 5778 K) / (σ 5778⁴)`. No measured table is
/// shipped; the blackbody lacks the Fraunhofer lines and overestimates the
/// real Sun by ≈ 10–20 % below 450 nm and is within ≈ 5 % from 500 to
/// 1100 nm (compare ASTM E-490). Lunar spectra are renormalised
/// photometrically, so this only affects the spectral *shape*.
pub fn solar_irradiance_1au_w_m2_nm(wavelength_nm: f64) -> f64 {
    const SIGMA: f64 = gloam_spectra::STEFAN_BOLTZMANN_W_M2_K4;
    if !wavelength_nm.is_finite() || wavelength_nm <= 0.0 {
        return 0.0;
    }
    let t = SUN_TEMPERATURE_K;
    SOLAR_CONSTANT_W_M2 * std::f64::consts::PI * planck_w_m2_sr_nm(wavelength_nm, t)
        / (SIGMA * t.powi(4))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn v_table_loads_and_peaks_at_555() {
        let v = photopic_v().unwrap();
        let (w, p) = v
            .iter()
            .copied()
            .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        assert!((w - 555.0).abs() <= 1.0 && (p - 1.0).abs() < 1e-3);
    }

    #[test]
    fn solar_constant_and_lux() {
        // integral over a wide range approaches the solar constant
        let wide: Samples = (100..=100_000)
            .step_by(5)
            .map(|w| (w as f64, solar_irradiance_1au_w_m2_nm(w as f64)))
            .collect();
        let total = integrate(&wide);
        assert!((total - 1361.0).abs() < 5.0, "{total}");
        // sunlight outside the atmosphere ≈ 1.3e5 lux (blackbody 5778 K)
        let lux = illuminance_lux(&wide).unwrap();
        assert!(lux > 1.2e5 && lux < 1.45e5, "{lux}");
    }

    #[test]
    fn interpolation_edges() {
        let t = vec![(400.0, 1.0), (500.0, 3.0)];
        assert_eq!(interpolate(&t, 450.0), 2.0);
        assert_eq!(interpolate(&t, 399.0), 0.0);
        assert_eq!(interpolate(&t, 500.0), 3.0);
        assert_eq!(interpolate(&t, f64::NAN), 0.0);
        assert_eq!(interpolate(&[], 450.0), 0.0);
    }
}
