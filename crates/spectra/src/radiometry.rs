//! Physical constants, Planck's law, photometric and photon-count conversion.

use crate::spectrum::Spectrum;

/// Planck constant, J s (exact, SI 2019).
pub const PLANCK_J_S: f64 = 6.626_070_15e-34;
/// Speed of light in vacuum, m/s (exact).
pub const SPEED_OF_LIGHT_M_S: f64 = 299_792_458.0;
/// Boltzmann constant, J/K (exact, SI 2019).
pub const BOLTZMANN_J_K: f64 = 1.380_649e-23;
/// Stefan–Boltzmann constant, W m⁻² K⁻⁴ (derived from the exact constants).
pub const STEFAN_BOLTZMANN_W_M2_K4: f64 = 5.670_374_419e-8;
/// Maximum photopic luminous efficacy, lm/W (CIE).
pub const KM_PHOTOPIC_LM_W: f64 = 683.0;
/// Maximum scotopic luminous efficacy, lm/W (CIE 1951).
pub const KM_SCOTOPIC_LM_W: f64 = 1700.0;

/// Blackbody spectral radiance at `wavelength_nm` and `temperature_k`,
/// in W m⁻² sr⁻¹ nm⁻¹.
///
/// `B = 2hc²/λ⁵ / (exp(hc/λkT) − 1)`, evaluated with `exp_m1` so the
/// long-wavelength tail keeps full precision.
pub fn planck_radiance_w_m2_sr_nm(wavelength_nm: f64, temperature_k: f64) -> f64 {
    if !(wavelength_nm > 0.0 && temperature_k > 0.0) {
        return 0.0;
    }
    let lambda_m = wavelength_nm * 1e-9;
    let x = PLANCK_J_S * SPEED_OF_LIGHT_M_S / (lambda_m * BOLTZMANN_J_K * temperature_k);
    let per_m =
        2.0 * PLANCK_J_S * SPEED_OF_LIGHT_M_S * SPEED_OF_LIGHT_M_S / lambda_m.powi(5) / x.exp_m1();
    per_m * 1e-9
}

/// A Planckian continuum in W m⁻² sr⁻¹ nm⁻¹ sampled every `step_nm` from
/// `lo_nm` to `hi_nm` (inclusive of both ends).
pub fn planck_spectrum(temperature_k: f64, lo_nm: f64, hi_nm: f64, step_nm: f64) -> Spectrum {
    let grid = uniform_grid(lo_nm, hi_nm, step_nm);
    let values = grid
        .iter()
        .map(|&w| planck_radiance_w_m2_sr_nm(w, temperature_k))
        .collect();
    Spectrum::new(grid, values).unwrap_or_default()
}

/// `lo, lo+step, …` up to and including `hi` (the last node is `hi` itself,
/// even where `step` does not divide the range).
pub fn uniform_grid(lo_nm: f64, hi_nm: f64, step_nm: f64) -> Vec<f64> {
    if !(step_nm > 0.0 && hi_nm > lo_nm) {
        return vec![lo_nm];
    }
    let n = ((hi_nm - lo_nm) / step_nm).floor() as usize;
    let mut grid: Vec<f64> = (0..=n).map(|i| lo_nm + step_nm * i as f64).collect();
    if hi_nm - grid[n] > 1e-9 * step_nm {
        grid.push(hi_nm);
    }
    grid
}

/// Photopic luminous quantity: `683 ∫ S(λ) V(λ) dλ` (W → lm; W m⁻² → lux;
/// W m⁻² sr⁻¹ → cd m⁻²) with the CIE 1924 V(λ).
pub fn photopic(spectrum_per_nm: &Spectrum) -> f64 {
    KM_PHOTOPIC_LM_W * spectrum_per_nm.integrate_weighted(crate::library::photopic_v())
}

/// Scotopic luminous quantity: `1700 ∫ S(λ) V'(λ) dλ` with the CIE 1951 V'(λ).
pub fn scotopic(spectrum_per_nm: &Spectrum) -> f64 {
    KM_SCOTOPIC_LM_W * spectrum_per_nm.integrate_weighted(crate::library::scotopic_v())
}

/// Photons per joule at `wavelength_nm`: `λ / (h c)`.
pub fn photons_per_joule(wavelength_nm: f64) -> f64 {
    wavelength_nm * 1e-9 / (PLANCK_J_S * SPEED_OF_LIGHT_M_S)
}

/// Converts a power spectrum (W …) into a photon-rate spectrum (photons/s …)
/// node by node and line by line.
pub fn to_photon_rate(spectrum_w: &Spectrum) -> Spectrum {
    spectrum_w.map_all(|w, v| v * photons_per_joule(w))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use std::f64::consts::PI;

    #[test]
    fn planck_total_matches_stefan_boltzmann() {
        // ∫ B dλ = σT⁴/π. A fine grid over 50 nm – 200 µm captures all but
        // ~1e-6 of the total at 3200 K.
        let t = 3200.0;
        let s = planck_spectrum(t, 50.0, 200_000.0, 0.5);
        let exact = STEFAN_BOLTZMANN_W_M2_K4 * t.powi(4) / PI;
        assert_relative_eq!(s.integral(), exact, max_relative = 1e-5);
    }

    #[test]
    fn planck_peak_obeys_wien() {
        // Wien's displacement: λ_max T = 2.897771955e-3 m K.
        let t = 2800.0;
        let peak_nm = 2.897_771_955e6 / t;
        let b = |w| planck_radiance_w_m2_sr_nm(w, t);
        assert!(b(peak_nm) > b(peak_nm * 0.999));
        assert!(b(peak_nm) > b(peak_nm * 1.001));
    }

    #[test]
    fn monochromatic_555nm_watt_is_683_lumens() {
        // V(555) = 1.0 in the CIE 1924 table, so 1 W at 555 nm is 683 lm.
        let s = Spectrum::from_lines(vec![crate::EmissionLine {
            wavelength_nm: 555.0,
            value: 1.0,
        }])
        .unwrap();
        assert_relative_eq!(photopic(&s), 683.0, max_relative = 1e-9);
        // V'(507) = 0.982 in the CIE 1951 table (peak 1.0 at 507 nm is
        // listed as 0.982 on the 1 nm table ⇒ check against the table value).
        let sc = Spectrum::from_lines(vec![crate::EmissionLine {
            wavelength_nm: 507.0,
            value: 1.0,
        }])
        .unwrap();
        let v507 = crate::library::scotopic_v().eval(507.0);
        assert!(v507 > 0.95);
        assert_relative_eq!(scotopic(&sc), 1700.0 * v507, max_relative = 1e-12);
    }

    #[test]
    fn illuminant_a_scotopic_photopic_ratio_is_published_1_41() {
        // The S/P ratio of CIE illuminant A (2856 K) is 1.41 (Berman et al.,
        // widely tabulated for incandescent lamps).
        let a = crate::library::get("cie-a").unwrap();
        let sp = scotopic(&a) / photopic(&a);
        assert!((sp - 1.41).abs() < 0.01, "S/P = {sp}");
    }

    #[test]
    fn photon_rate_of_one_watt_at_500nm() {
        // 1 W at 500 nm = λ/(hc) = λ/(hc) with hc = 1.98644586e-25 J m (CODATA).
        assert_relative_eq!(
            photons_per_joule(500.0),
            500e-9 / 1.986_445_86e-25,
            max_relative = 1e-7
        );
    }

    #[test]
    fn grid_includes_both_ends() {
        assert_eq!(
            uniform_grid(400.0, 700.0, 100.0),
            vec![400.0, 500.0, 600.0, 700.0]
        );
        assert_eq!(
            uniform_grid(400.0, 650.0, 100.0),
            vec![400.0, 500.0, 600.0, 650.0]
        );
    }
}

/// Light between two instants `f` (0…1) of the way from `a` to `b`:
/// `a^{1−f} b^f` where both are positive (exact for light that falls
/// exponentially, as twilight does: ×2.5 per degree of Sun), linearly
/// where either is zero.
pub fn geometric_between(a: f64, b: f64, f: f64) -> f64 {
    if f <= 0.0 {
        a
    } else if f >= 1.0 {
        b
    } else if a > 0.0 && b > 0.0 {
        (a.ln() * (1.0 - f) + b.ln() * f).exp()
    } else {
        a + (b - a) * f
    }
}

#[cfg(test)]
mod between_tests {
    use super::geometric_between;

    #[test]
    fn geometric_is_exact_for_an_exponential_and_linear_through_zero() {
        // Light falling ×2.5 per step: halfway is 1/√2.5 of the first.
        let (a, b) = (1.0, 1.0 / 2.5);
        let half = geometric_between(a, b, 0.5);
        assert!((half - (1.0 / 2.5f64).sqrt()).abs() < 1e-15);
        assert_eq!(geometric_between(0.0, 4.0, 0.25), 1.0);
        assert_eq!(geometric_between(3.0, 5.0, 0.0), 3.0);
        assert_eq!(geometric_between(3.0, 5.0, 1.0), 5.0);
    }
}
