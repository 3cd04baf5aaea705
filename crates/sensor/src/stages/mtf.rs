//! Analytic MTF terms shared by the stages (pupil diffraction, blur circles
//! and apertures, Gaussian and exponential spreads), in pixel units.

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

/// A named stage MTF and whether it acts after the gain noise.
#[derive(Clone, Debug, PartialEq)]
pub struct MtfStage {
    pub name: &'static str,
    pub term: MtfTerm,
    pub after_noise: bool,
}

/// `2 J1(z)/z`, 1 at z = 0.
pub fn jinc(z: f64) -> f64 {
    if z.abs() < 1e-8 {
        1.0
    } else {
        2.0 * bessel_j1(z) / z
    }
}

/// Bessel J1 by the rational (|x| < 8) and asymptotic (|x| ≥ 8) fits of
/// Hart et al., *Computer Approximations* (1968), as tabulated in Numerical
/// Recipes: |error| < 1e-7, far below what an MTF needs. Kept (rather than
/// `libm::j1`) because the blur kernels, hence every frame, are computed
/// from it; the test below holds it to `libm::j1`.
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bessel_j1_matches_libm_everywhere_it_is_used() {
        // Reference implementation: libm's j1 (a port of FreeBSD msun).
        let mut worst = 0f64;
        for i in -4000..=4000 {
            let x = i as f64 * 0.01;
            worst = worst.max((bessel_j1(x) - libm::j1(x)).abs());
        }
        assert!(worst < 2e-7, "worst |J1 − libm::j1| = {worst:e}");
    }

    #[test]
    fn jinc_first_zero_is_the_airy_radius() {
        // J1's first zero, 3.831 705 97 (Abramowitz & Stegun table 9.5).
        assert!(jinc(3.831_705_97).abs() < 1e-7);
        assert_eq!(jinc(0.0), 1.0);
    }

    #[test]
    fn diffraction_mtf_at_half_cutoff() {
        // (2/π)(acos ½ − ½ √¾) = 0.391 002 (Goodman, Fourier Optics, eq. 6-32).
        let m = MtfTerm::Diffraction { cutoff_cy_px: 1.0 }.at(0.5);
        assert!((m - 0.391_002_4).abs() < 1e-6, "{m}");
        assert_eq!(MtfTerm::Diffraction { cutoff_cy_px: 1.0 }.at(1.0), 0.0);
    }

    #[test]
    fn gaussian_and_lorentzian_halve_where_closed_forms_say() {
        // exp(−2π²σ²f²) = ½ at f = √(ln 2 / 2) / (π σ).
        let s = 1.7;
        let f = (std::f64::consts::LN_2 / 2.0).sqrt() / (std::f64::consts::PI * s);
        assert!((MtfTerm::Gaussian { sigma_px: s }.at(f) - 0.5).abs() < 1e-12);
        // 1/(1+(2πaf)²) = ½ at f = 1/(2πa).
        let a = 0.8;
        let f = 1.0 / (2.0 * std::f64::consts::PI * a);
        assert!((MtfTerm::Lorentzian { length_px: a }.at(f) - 0.5).abs() < 1e-12);
    }
}
