//! Small statistics used by every flow: weighted straight-line fits with
//! residuals and R², rank correlation with ties, RMS differences.

use serde::Serialize;

use crate::error::CalibError;

/// A straight line `y = slope·x + intercept` fitted by weighted least squares.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LinearFit {
    pub slope: f64,
    pub intercept: f64,
    /// Coefficient of determination of the (unweighted) residuals.
    pub r_squared: f64,
    /// `y_i − (slope·x_i + intercept)` for each input point.
    pub residuals: Vec<f64>,
    pub n_points: usize,
}

/// The inputs of a weighted fit: equal lengths, finite, weights ≥ 0.
fn check_fit_input(x: &[f64], y: &[f64], w: &[f64]) -> Result<(), CalibError> {
    if x.len() != y.len() || x.len() != w.len() {
        return Err(CalibError::Invalid(format!(
            "fit input lengths differ: {} x, {} y, {} weights",
            x.len(),
            y.len(),
            w.len()
        )));
    }
    if x.iter().chain(y).chain(w).any(|v| !v.is_finite()) || w.iter().any(|&v| v < 0.0) {
        return Err(CalibError::Invalid(
            "fit input holds a non-finite value or a negative weight".into(),
        ));
    }
    Ok(())
}

/// Weighted least-squares line through `(x_i, y_i)` with weights `w_i ≥ 0`
/// (use 1/σ² of each `y_i`, or all ones).
///
/// Errors (never NaN): fewer than two points with positive weight, all `x`
/// equal (the slope is undetermined), or non-finite input.
pub fn weighted_linear_fit(x: &[f64], y: &[f64], w: &[f64]) -> Result<LinearFit, CalibError> {
    check_fit_input(x, y, w)?;
    let used = w.iter().filter(|&&v| v > 0.0).count();
    if used < 2 {
        return Err(CalibError::SingularFit(format!(
            "{used} point(s) with positive weight; a line needs at least 2"
        )));
    }
    let sw: f64 = w.iter().sum();
    let mx = x.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / sw;
    let my = y.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / sw;
    let mut sxx = 0.0;
    let mut sxy = 0.0;
    for i in 0..x.len() {
        sxx += w[i] * (x[i] - mx) * (x[i] - mx);
        sxy += w[i] * (x[i] - mx) * (y[i] - my);
    }
    let scale = x.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-300);
    if !(sxx > 1e-24 * scale * scale * sw) {
        return Err(CalibError::SingularFit(
            "all points share the same x, so the slope is undetermined".into(),
        ));
    }
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let residuals: Vec<f64> = x
        .iter()
        .zip(y)
        .map(|(a, b)| b - (slope * a + intercept))
        .collect();
    let ybar = y.iter().sum::<f64>() / y.len() as f64;
    let ss_tot: f64 = y.iter().map(|v| (v - ybar) * (v - ybar)).sum();
    let ss_res: f64 = residuals.iter().map(|r| r * r).sum();
    let r_squared = if ss_tot > 0.0 {
        1.0 - ss_res / ss_tot
    } else {
        1.0
    };
    Ok(LinearFit {
        slope,
        intercept,
        r_squared,
        residuals,
        n_points: used,
    })
}

/// Weighted least-squares slope of a line through the origin, `y = slope·x`
/// (`Σwxy / Σwx²`), for quantities that are zero by definition at `x = 0`
/// (dark-subtracted signal and variance). Errors like
/// [`weighted_linear_fit`]: mismatched lengths, non-finite input, negative
/// weights, or no point with positive weight and `x ≠ 0`.
pub fn weighted_slope_through_origin(x: &[f64], y: &[f64], w: &[f64]) -> Result<f64, CalibError> {
    check_fit_input(x, y, w)?;
    let sxx: f64 = x.iter().zip(w).map(|(a, b)| b * a * a).sum();
    let sxy: f64 = x.iter().zip(y).zip(w).map(|((a, c), b)| b * a * c).sum();
    if !(sxx > 0.0) {
        return Err(CalibError::SingularFit(
            "no point with positive weight away from x = 0: the slope is undetermined".into(),
        ));
    }
    Ok(sxy / sxx)
}

/// Ranks 1..=n with ties given the average of the ranks they span.
pub fn average_ranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut ranks = vec![0.0; v.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
            j += 1;
        }
        // Positions i..=j (0-based) hold ranks i+1..=j+1; their mean:
        let r = (i + j) as f64 / 2.0 + 1.0;
        for &k in &idx[i..=j] {
            ranks[k] = r;
        }
        i = j + 1;
    }
    ranks
}

/// Pearson correlation coefficient. Errors when either input is constant
/// (the coefficient is undefined) or the lengths differ.
pub fn pearson(x: &[f64], y: &[f64]) -> Result<f64, CalibError> {
    if x.len() != y.len() || x.len() < 2 {
        return Err(CalibError::InsufficientData(format!(
            "correlation needs two equally long series of at least 2 values (got {} and {})",
            x.len(),
            y.len()
        )));
    }
    if x.iter().chain(y).any(|v| !v.is_finite()) {
        return Err(CalibError::Invalid(
            "correlation input is not finite".into(),
        ));
    }
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return Err(CalibError::InsufficientData(
            "one series is constant, so the correlation is undefined".into(),
        ));
    }
    Ok((sxy / (sxx * syy).sqrt()).clamp(-1.0, 1.0))
}

/// Spearman's rank-order correlation: Pearson's coefficient of the average
/// ranks, which is correct with ties (the `1 − 6Σd²/(n(n²−1))` shortcut is
/// not).
pub fn spearman_rho(x: &[f64], y: &[f64]) -> Result<f64, CalibError> {
    pearson(&average_ranks(x), &average_ranks(y))
}

/// Root-mean-square of `a_i − b_i`.
pub fn rms_difference(a: &[f64], b: &[f64]) -> Result<f64, CalibError> {
    if a.len() != b.len() || a.is_empty() {
        return Err(CalibError::InsufficientData(format!(
            "RMS difference needs two equally long, non-empty series (got {} and {})",
            a.len(),
            b.len()
        )));
    }
    let s: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    Ok((s / a.len() as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranks_average_ties() {
        assert_eq!(
            average_ranks(&[10.0, 20.0, 20.0, 5.0]),
            vec![2.0, 3.5, 3.5, 1.0]
        );
    }

    #[test]
    fn spearman_with_ties_matches_scipy_doc_example() {
        // scipy.stats.spearmanr([1,2,3,4,5], [5,6,7,8,7]) = 0.8207826816681233
        let r = spearman_rho(&[1.0, 2.0, 3.0, 4.0, 5.0], &[5.0, 6.0, 7.0, 8.0, 7.0]).unwrap();
        assert!((r - 0.820_782_681_668_123_3).abs() < 1e-12, "{r}");
        // By hand: ranks y = [1, 2, 3.5, 5, 3.5] (the two 7s share 3.5);
        // deviations from 3: x [−2 −1 0 1 2], y [−2 −1 .5 2 .5]; Σxy = 8,
        // Σx² = 10, Σy² = 9.5 → ρ = 8/√95. (The no-ties shortcut
        // 1 − 6Σd²/(n(n²−1)) would give 0.825 instead.)
        assert!((r - 8.0 / 95f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn constant_series_is_an_error_not_nan() {
        assert!(spearman_rho(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0]).is_err());
    }

    #[test]
    fn singular_fit_is_an_error() {
        let e = weighted_linear_fit(&[2.0, 2.0, 2.0], &[1.0, 2.0, 3.0], &[1.0; 3]);
        assert!(matches!(e, Err(CalibError::SingularFit(_))));
        let e = weighted_linear_fit(&[2.0], &[1.0], &[1.0]);
        assert!(matches!(e, Err(CalibError::SingularFit(_))));
    }

    #[test]
    fn slope_through_origin_matches_hand_sums() {
        // Σwxy = 1·1·2.2 + 4·2·3.9 = 33.4; Σwx² = 1 + 16 = 17.
        let k = weighted_slope_through_origin(&[1.0, 2.0], &[2.2, 3.9], &[1.0, 4.0]).unwrap();
        assert!((k - 33.4 / 17.0).abs() < 1e-12, "{k}");
        assert!(weighted_slope_through_origin(&[0.0], &[1.0], &[1.0]).is_err());
    }

    #[test]
    fn exact_line() {
        let f = weighted_linear_fit(&[0.0, 1.0, 2.0], &[1.0, 3.0, 5.0], &[1.0, 2.0, 1.0]).unwrap();
        assert!((f.slope - 2.0).abs() < 1e-12 && (f.intercept - 1.0).abs() < 1e-12);
        assert!((f.r_squared - 1.0).abs() < 1e-12);
    }
}
