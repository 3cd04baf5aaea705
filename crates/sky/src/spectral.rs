//! Spectral grid, embedded data tables and photometry.
//!
//! Spectra in this crate are plain `Vec<(wavelength_nm, value)>` sorted by
//! wavelength (the caller bridges to `gloam_spectra::Spectrum`). The default
//! grid is 300–1100 nm every 5 nm, covering S20/S25/Gen-3 GaAs photocathodes.
//!
//! Photometry: `E_v = K_m ∫ E(λ) V(λ) dλ` with K_m = 683 lm/W and the CIE
//! 1924 photopic V(λ), read from `crates/spectra/data/cie_1924_photopic_v.csv`
//! (embedded at compile time), trapezoidal integration in f64.

use std::sync::OnceLock;

use crate::error::{Result, SkyError};

/// Maximum luminous efficacy for photopic vision, lm/W.
pub const K_M_LM_PER_W: f64 = 683.0;
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

fn parse_csv(table: &'static str, text: &str) -> Result<Samples> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with("wavelength") {
            continue;
        }
        let mut it = line.split(',');
        let parse = |s: Option<&str>| -> Result<f64> {
            s.map(str::trim)
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| SkyError::BadTable {
                    table,
                    line: i + 1,
                    reason: format!("expected two numbers, got {line:?}"),
                })
        };
        let w = parse(it.next())?;
        let v = parse(it.next())?;
        if let Some(&(prev, _)) = out.last()
            && w <= prev
        {
            return Err(SkyError::BadTable {
                table,
                line: i + 1,
                reason: "wavelengths must increase".to_string(),
            });
        }
        out.push((w, v));
    }
    if out.len() < 2 {
        return Err(SkyError::BadTable {
            table,
            line: 0,
            reason: "fewer than two samples".to_string(),
        });
    }
    Ok(out)
}

/// CIE 1924 photopic luminous efficiency V(λ), 360–830 nm at 1 nm.
pub fn photopic_v() -> Result<&'static [(f64, f64)]> {
    static V: OnceLock<Result<Samples>> = OnceLock::new();
    V.get_or_init(|| {
        parse_csv(
            "cie_1924_photopic_v.csv",
            include_str!("../../spectra/data/cie_1924_photopic_v.csv"),
        )
    })
    .as_ref()
    .map(|v| v.as_slice())
    .map_err(Clone::clone)
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

/// Planck spectral radiance B(λ, T), W m⁻² sr⁻¹ nm⁻¹.
pub fn planck_w_m2_sr_nm(wavelength_nm: f64, temperature_k: f64) -> f64 {
    const H: f64 = 6.626_070_15e-34;
    const C: f64 = 299_792_458.0;
    const KB: f64 = 1.380_649e-23;
    let l = wavelength_nm * 1e-9;
    let x = H * C / (l * KB * temperature_k);
    // per metre → per nanometre
    2.0 * H * C * C / l.powi(5) / x.exp_m1() * 1e-9
}

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
    const SIGMA: f64 = 5.670_374_419e-8;
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
        assert!(parse_csv("t", "1,2\n1,3\n").is_err());
        assert!(parse_csv("t", "1,x\n2,3\n").is_err());
    }
}
