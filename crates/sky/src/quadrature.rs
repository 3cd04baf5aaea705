//! Gauss–Legendre quadrature, the one rule both the sky's dome integrals
//! and the tracer's tail quadrature use (the tracer depends on this crate,
//! so the rule lives here, the lower floor).

/// The `n` roots `z` of the Legendre polynomial P_n on [-1, 1], descending,
/// each with its Gauss weight for [0, 1] (half the [-1, 1] weight), found by
/// Newton's method from Tricomi's first guess; a root's iteration stops when
/// its step falls below `newton_step_tol` (or after 100 steps).
///
/// Map a root to [0, 1] as `0.5 * (1.0 - z)` (ascending nodes) or
/// `0.5 * (z + 1.0)` (descending). The stopping step is the caller's so
/// that each caller keeps the nodes it has always had, to the bit: the sky
/// uses 1e-15, the tracer 1e-16, and the two differ in the last place for
/// a few roots.
pub fn legendre_roots_01_weights(n: usize, newton_step_tol: f64) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, z);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
                let dz = p1 / dp;
                z -= dz;
                if dz.abs() < newton_step_tol {
                    break;
                }
            }
            // Half of the [-1, 1] weight 2 / ((1 − z²) P_n'(z)²); exactly
            // (bit for bit) 0.5 · 2/q, since scaling by 2 commutes with rounding.
            (z, 1.0 / ((1.0 - z * z) * dp * dp))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The n-point rule integrates polynomials up to degree 2n − 1 exactly:
    /// ∫₀¹ x^k dx = 1/(k + 1).
    #[test]
    fn integrates_polynomials_to_degree_2n_minus_1() {
        for n in [1, 2, 5, 16, 96] {
            let rule = legendre_roots_01_weights(n, 1e-15);
            for k in 0..2 * n {
                let sum: f64 = rule
                    .iter()
                    .map(|&(z, w)| w * (0.5 * (1.0 - z)).powi(k as i32))
                    .sum();
                let exact = 1.0 / (k as f64 + 1.0);
                assert!(
                    (sum - exact).abs() <= 1e-13 * exact.max(1e-3),
                    "n {n}, x^{k}: {sum} vs {exact}"
                );
            }
        }
    }

    /// Known 2-point rule: nodes (1 ∓ 1/√3)/2, weights ½.
    #[test]
    fn two_point_rule() {
        let rule = legendre_roots_01_weights(2, 1e-16);
        assert!((rule[0].0 - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert!((rule[1].0 + 1.0 / 3f64.sqrt()).abs() < 1e-15);
        for &(_, w) in &rule {
            assert!((w - 0.5).abs() < 1e-15);
        }
    }
}
