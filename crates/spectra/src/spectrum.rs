//! The spectrum type: a sampled continuum plus discrete emission lines.
//!
//! Lamps such as mercury and low-pressure sodium put most of their power into
//! lines far narrower than any practical wavelength grid. Sampling them onto a
//! grid smears or loses them depending on where the grid nodes fall, so gloam
//! keeps lines apart from the continuum and integrates them exactly (a line
//! is a Dirac delta with an integrated value).

use serde::{Deserialize, Serialize};

use crate::error::SpectrumError;

/// Most emission lines one spectrum may carry: a metal-halide or sodium
/// lamp has tens to a few hundred; each line is placed on every source's
/// wavelength grid and checked against the others, and 100 000 of them
/// took 18 s of preparation and 4 GB before the pilot aborted (issue 46).
pub const MAX_LINES: usize = 10_000;

/// One discrete emission line: all of its power sits at `wavelength_nm`.
///
/// `value` is the line's integrated value, in the spectrum's units × nm
/// (a continuum in W m⁻² sr⁻¹ nm⁻¹ has lines in W m⁻² sr⁻¹).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EmissionLine {
    pub wavelength_nm: f64,
    pub value: f64,
}

/// A spectral quantity: a piecewise-linear continuum on a strictly increasing
/// wavelength grid (zero outside the grid) plus emission lines.
///
/// All values are f64 and must be finite and non-negative: every spectrum in
/// gloam is a physical radiance, intensity, reflectance, transmission or
/// efficiency.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Spectrum {
    wavelength_nm: Vec<f64>,
    value: Vec<f64>,
    lines: Vec<EmissionLine>,
}

impl Spectrum {
    /// A continuum sampled at `wavelength_nm` (strictly increasing, finite)
    /// with `value` (finite, non-negative) at each node.
    pub fn new(wavelength_nm: Vec<f64>, value: Vec<f64>) -> Result<Self, SpectrumError> {
        if wavelength_nm.len() != value.len() {
            return Err(SpectrumError::LengthMismatch {
                wavelengths: wavelength_nm.len(),
                values: value.len(),
            });
        }
        for (i, (&w, &v)) in wavelength_nm.iter().zip(&value).enumerate() {
            check_wavelength(w, i)?;
            check_value(v, i)?;
            if i > 0 {
                let prev = wavelength_nm[i - 1];
                if w == prev {
                    return Err(SpectrumError::DuplicateWavelength {
                        index: i,
                        wavelength_nm: w,
                    });
                }
                if w < prev {
                    return Err(SpectrumError::NotIncreasing {
                        index: i,
                        previous_nm: prev,
                        wavelength_nm: w,
                    });
                }
            }
        }
        Ok(Self {
            wavelength_nm,
            value,
            lines: Vec::new(),
        })
    }

    /// A spectrum made only of emission lines (no continuum).
    pub fn from_lines(lines: Vec<EmissionLine>) -> Result<Self, SpectrumError> {
        Self::default().with_lines(lines)
    }

    /// A flat continuum `value` between `lo_nm` and `hi_nm`.
    pub fn constant(lo_nm: f64, hi_nm: f64, value: f64) -> Result<Self, SpectrumError> {
        Self::new(vec![lo_nm, hi_nm], vec![value, value])
    }

    /// Adds emission lines (each with finite wavelength > 0 and value ≥ 0).
    ///
    /// A wavelength may carry one line only: a line at the wavelength of an
    /// existing line or of an earlier one in `lines` is an error
    /// ([`SpectrumError::DuplicateLine`]), since two entries for one line are
    /// far more often a slip than a deliberate split of its value.
    pub fn with_lines(mut self, lines: Vec<EmissionLine>) -> Result<Self, SpectrumError> {
        let count = self.lines.len() + lines.len();
        if count > MAX_LINES {
            return Err(SpectrumError::TooManyLines {
                count,
                limit: MAX_LINES,
            });
        }
        for (i, l) in lines.iter().enumerate() {
            check_wavelength(l.wavelength_nm, i)?;
            check_value(l.value, i)?;
            let mut earlier = self.lines.iter().chain(&lines[..i]);
            if earlier.any(|e| e.wavelength_nm == l.wavelength_nm) {
                return Err(SpectrumError::DuplicateLine {
                    index: i,
                    wavelength_nm: l.wavelength_nm,
                });
            }
        }
        self.lines.extend(lines);
        self.lines
            .sort_by(|a, b| a.wavelength_nm.total_cmp(&b.wavelength_nm));
        Ok(self)
    }

    /// Wavelengths of the continuum's nodes, nm.
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelength_nm
    }

    /// Continuum values at the nodes.
    pub fn values(&self) -> &[f64] {
        &self.value
    }

    /// The emission lines, sorted by wavelength.
    pub fn lines(&self) -> &[EmissionLine] {
        &self.lines
    }

    /// True when there is neither a continuum nor a line.
    pub fn is_empty(&self) -> bool {
        self.wavelength_nm.is_empty() && self.lines.is_empty()
    }

    /// Smallest and largest wavelength where the spectrum can be non-zero
    /// (continuum grid or a line), or `None` for an empty spectrum.
    pub fn support_nm(&self) -> Option<(f64, f64)> {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        if let (Some(&a), Some(&b)) = (self.wavelength_nm.first(), self.wavelength_nm.last()) {
            lo = lo.min(a);
            hi = hi.max(b);
        }
        for l in &self.lines {
            lo = lo.min(l.wavelength_nm);
            hi = hi.max(l.wavelength_nm);
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// The continuum at `wavelength_nm` by linear interpolation; zero outside
    /// the grid. Lines are not included (they have no finite density).
    pub fn eval(&self, wavelength_nm: f64) -> f64 {
        let w = &self.wavelength_nm;
        let n = w.len();
        if n == 0 || !(wavelength_nm >= w[0] && wavelength_nm <= w[n - 1]) {
            return 0.0;
        }
        if n == 1 {
            return self.value[0];
        }
        // First node strictly greater than the query, clamped to the last segment.
        let j = w.partition_point(|&x| x <= wavelength_nm).clamp(1, n - 1);
        let (x0, x1) = (w[j - 1], w[j]);
        let (y0, y1) = (self.value[j - 1], self.value[j]);
        let t = (wavelength_nm - x0) / (x1 - x0);
        y0 + t * (y1 - y0)
    }

    /// This spectrum multiplied by a constant `factor` (finite, ≥ 0).
    pub fn scaled(&self, factor: f64) -> Result<Self, SpectrumError> {
        check_value(factor, 0)?;
        Ok(self.map_all(|_, v| v * factor))
    }

    /// Applies `f(wavelength_nm, value)` to every continuum node and line
    /// value. `f` must keep values finite and non-negative (it is used for
    /// per-wavelength conversions such as W → photons/s).
    pub fn map_all(&self, f: impl Fn(f64, f64) -> f64) -> Self {
        Self {
            wavelength_nm: self.wavelength_nm.clone(),
            value: self
                .wavelength_nm
                .iter()
                .zip(&self.value)
                .map(|(&w, &v)| f(w, v))
                .collect(),
            lines: self
                .lines
                .iter()
                .map(|l| EmissionLine {
                    wavelength_nm: l.wavelength_nm,
                    value: f(l.wavelength_nm, l.value),
                })
                .collect(),
        }
    }

    /// The product of two spectra, e.g. a lamp times a filter.
    ///
    /// The continuum is sampled on the union of both grids over their overlap
    /// (zero elsewhere) and is linear between those nodes, which the true
    /// product (a quadratic on each interval) is not: to integrate a product,
    /// use [`Spectrum::integrate_weighted_band`], which is exact. A line in
    /// either factor is weighted by the other factor's continuum at the
    /// line's wavelength. Line × line products are
    /// dropped: a product of two Dirac deltas has no physical meaning here.
    pub fn product(&self, other: &Spectrum) -> Spectrum {
        let mut grid = Vec::new();
        if let (Some(&a0), Some(&a1), Some(&b0), Some(&b1)) = (
            self.wavelength_nm.first(),
            self.wavelength_nm.last(),
            other.wavelength_nm.first(),
            other.wavelength_nm.last(),
        ) {
            let lo = a0.max(b0);
            let hi = a1.min(b1);
            if lo <= hi {
                grid = merge_grids(&self.wavelength_nm, &other.wavelength_nm, lo, hi);
            }
        }
        let value = grid.iter().map(|&w| self.eval(w) * other.eval(w)).collect();
        let mut lines: Vec<EmissionLine> = self
            .lines
            .iter()
            .map(|l| EmissionLine {
                wavelength_nm: l.wavelength_nm,
                value: l.value * other.eval(l.wavelength_nm),
            })
            .chain(other.lines.iter().map(|l| EmissionLine {
                wavelength_nm: l.wavelength_nm,
                value: l.value * self.eval(l.wavelength_nm),
            }))
            .filter(|l| l.value > 0.0)
            .collect();
        lines.sort_by(|a, b| a.wavelength_nm.total_cmp(&b.wavelength_nm));
        Spectrum {
            wavelength_nm: grid,
            value,
            lines,
        }
    }

    /// The continuum resampled onto `grid_nm` (strictly increasing); lines are
    /// kept as they are, so resampling never loses line power.
    pub fn resampled(&self, grid_nm: &[f64]) -> Result<Self, SpectrumError> {
        let value = grid_nm.iter().map(|&w| self.eval(w)).collect();
        let mut s = Spectrum::new(grid_nm.to_vec(), value)?;
        s.lines = self.lines.clone();
        Ok(s)
    }

    /// ∫ over the whole spectrum: the continuum by the trapezoid rule (exact
    /// for the piecewise-linear continuum) plus every line.
    pub fn integral(&self) -> f64 {
        self.integrate_band(f64::NEG_INFINITY, f64::INFINITY)
    }

    /// ∫ from `lo_nm` to `hi_nm`: the piecewise-linear continuum integrated
    /// exactly over the clipped interval, plus every line with
    /// `lo_nm <= λ < hi_nm` (half-open, so adjacent bands split a line on
    /// their shared edge exactly once).
    pub fn integrate_band(&self, lo_nm: f64, hi_nm: f64) -> f64 {
        if lo_nm.is_nan() || hi_nm.is_nan() || hi_nm <= lo_nm {
            return 0.0;
        }
        let mut sum = 0.0f64;
        let w = &self.wavelength_nm;
        for j in 1..w.len() {
            let (x0, x1) = (w[j - 1], w[j]);
            let a = x0.max(lo_nm);
            let b = x1.min(hi_nm);
            if b > a {
                sum += 0.5 * (b - a) * (self.eval_segment(j, a) + self.eval_segment(j, b));
            }
        }
        for l in &self.lines {
            if l.wavelength_nm >= lo_nm && l.wavelength_nm < hi_nm {
                sum += l.value;
            }
        }
        sum
    }

    /// ∫ S(λ) W(λ) dλ against a response or weighting curve `weight`, over
    /// all wavelengths; see [`Spectrum::integrate_weighted_band`].
    pub fn integrate_weighted(&self, weight: &Spectrum) -> f64 {
        self.integrate_weighted_band(weight, f64::NEG_INFINITY, f64::INFINITY)
    }

    /// ∫ S(λ) W(λ) dλ from `lo_nm` to `hi_nm`, exactly.
    ///
    /// Both continua are piecewise linear, so their product is a quadratic
    /// on each interval of the union of the two grids (clipped to the band
    /// and to the overlap of the grids): each interval `[x0, x1]` contributes
    /// `(x1 − x0)/6 · (2 s0 w0 + s0 w1 + s1 w0 + 2 s1 w1)`, the exact integral
    /// of that quadratic. Sampling the product at the union nodes and
    /// integrating it as piecewise linear instead overstates it wherever
    /// both factors slope the same way (and understates it where they slope
    /// against each other), by up to the whole integral on a coarse grid.
    ///
    /// A line of either factor with `lo_nm <= λ < hi_nm` (half-open, as in
    /// [`Spectrum::integrate_band`]) adds its value times the other factor's
    /// continuum at λ; line × line products are dropped, as in
    /// [`Spectrum::product`]. Sums are accumulated in f64.
    pub fn integrate_weighted_band(&self, weight: &Spectrum, lo_nm: f64, hi_nm: f64) -> f64 {
        if lo_nm.is_nan() || hi_nm.is_nan() || hi_nm <= lo_nm {
            return 0.0;
        }
        let mut sum = continuum_product_integral(self, weight, lo_nm, hi_nm);
        let in_band = |w: f64| w >= lo_nm && w < hi_nm;
        for l in self.lines.iter().filter(|l| in_band(l.wavelength_nm)) {
            sum += l.value * weight.eval(l.wavelength_nm);
        }
        for l in weight.lines.iter().filter(|l| in_band(l.wavelength_nm)) {
            sum += l.value * self.eval(l.wavelength_nm);
        }
        sum
    }

    /// This spectrum scaled so that its integral over `[lo_nm, hi_nm)` equals
    /// `target` (e.g. 15.058 W m⁻² sr⁻¹ over 400–700 nm).
    pub fn normalized_to_band(
        &self,
        lo_nm: f64,
        hi_nm: f64,
        target: f64,
    ) -> Result<Self, SpectrumError> {
        let current = self.integrate_band(lo_nm, hi_nm);
        if !(current > 0.0 && current.is_finite()) {
            return Err(SpectrumError::ZeroInBand { lo_nm, hi_nm });
        }
        self.scaled(target / current)
    }

    /// Linear interpolation within segment `j` (nodes `j-1`, `j`).
    fn eval_segment(&self, j: usize, x: f64) -> f64 {
        let (x0, x1) = (self.wavelength_nm[j - 1], self.wavelength_nm[j]);
        let (y0, y1) = (self.value[j - 1], self.value[j]);
        y0 + (x - x0) / (x1 - x0) * (y1 - y0)
    }
}

/// ∫ a(λ) b(λ) dλ of two piecewise-linear continua over `[lo, hi]`, exact:
/// the product is quadratic between consecutive nodes of the union grid.
fn continuum_product_integral(a: &Spectrum, b: &Spectrum, lo: f64, hi: f64) -> f64 {
    let (wa, wb) = (&a.wavelength_nm, &b.wavelength_nm);
    if wa.len() < 2 || wb.len() < 2 {
        // A single node has zero width: its continuum integrates to zero.
        return 0.0;
    }
    let start = wa[0].max(wb[0]).max(lo);
    let end = wa[wa.len() - 1].min(wb[wb.len() - 1]).min(hi);
    if end <= start {
        return 0.0;
    }
    let mut grid = merge_grids(wa, wb, start, end);
    // The band edges split the intervals they fall in.
    grid.push(start);
    grid.push(end);
    grid.sort_by(f64::total_cmp);
    grid.dedup();
    let mut sum = 0.0f64;
    let (mut x0, mut a0, mut b0) = (grid[0], a.eval(grid[0]), b.eval(grid[0]));
    for &x1 in &grid[1..] {
        let (a1, b1) = (a.eval(x1), b.eval(x1));
        sum += (x1 - x0) / 6.0 * (2.0 * a0 * b0 + a0 * b1 + a1 * b0 + 2.0 * a1 * b1);
        (x0, a0, b0) = (x1, a1, b1);
    }
    sum
}

/// Sorted union of two grids restricted to `[lo, hi]`, duplicates removed.
fn merge_grids(a: &[f64], b: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    let mut out: Vec<f64> = a
        .iter()
        .chain(b)
        .copied()
        .filter(|&w| w >= lo && w <= hi)
        .collect();
    out.sort_by(f64::total_cmp);
    out.dedup();
    out
}

fn check_wavelength(w: f64, index: usize) -> Result<(), SpectrumError> {
    if !w.is_finite() || w <= 0.0 {
        return Err(SpectrumError::BadWavelength {
            index,
            wavelength_nm: w,
        });
    }
    Ok(())
}

fn check_value(v: f64, index: usize) -> Result<(), SpectrumError> {
    if v.is_nan() || v.is_infinite() {
        return Err(SpectrumError::NonFiniteValue { index, value: v });
    }
    if v < 0.0 {
        return Err(SpectrumError::NegativeValue { index, value: v });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn line(w: f64, v: f64) -> EmissionLine {
        EmissionLine {
            wavelength_nm: w,
            value: v,
        }
    }

    #[test]
    fn eval_interpolates_and_is_zero_outside() {
        let s = Spectrum::new(vec![400.0, 500.0, 600.0], vec![1.0, 3.0, 2.0]).unwrap();
        assert_eq!(s.eval(450.0), 2.0);
        assert_eq!(s.eval(500.0), 3.0);
        assert_eq!(s.eval(600.0), 2.0);
        assert_eq!(s.eval(399.999), 0.0);
        assert_eq!(s.eval(600.001), 0.0);
        assert_eq!(s.eval(f64::NAN), 0.0);
    }

    #[test]
    fn band_integral_of_linear_continuum_is_exact() {
        // y = λ on [400, 700]: ∫_450^650 λ dλ = (650² − 450²)/2 = 110 000.
        let s = Spectrum::new(vec![400.0, 700.0], vec![400.0, 700.0]).unwrap();
        assert_relative_eq!(
            s.integrate_band(450.0, 650.0),
            110_000.0,
            max_relative = 1e-14
        );
        // Clipped at the grid: ∫_400^700 = (700² − 400²)/2.
        assert_relative_eq!(s.integrate_band(0.0, 1e4), 165_000.0, max_relative = 1e-14);
    }

    #[test]
    fn line_on_band_edge_counts_once_across_adjacent_bands() {
        let s = Spectrum::from_lines(vec![line(500.0, 2.5)]).unwrap();
        let lower = s.integrate_band(400.0, 500.0);
        let upper = s.integrate_band(500.0, 600.0);
        assert_eq!(lower, 0.0);
        assert_eq!(upper, 2.5);
        assert_eq!(lower + upper, s.integral());
    }

    #[test]
    fn coarse_and_fine_grids_agree_on_line_spectrum() {
        // Mercury green line against a smooth weighting curve: resampling the
        // weight's continuum coarsely moves the continuum integral but must
        // never move the line's contribution, which is evaluated at 546.07 nm.
        let lamp = Spectrum::from_lines(vec![line(546.07, 1.0), line(435.83, 0.5)]).unwrap();
        let weight = Spectrum::new(vec![400.0, 700.0], vec![0.2, 0.8]).unwrap();
        let exact = 1.0 * weight.eval(546.07) + 0.5 * weight.eval(435.83);
        for step in [1.0, 5.0, 20.0, 50.0] {
            let grid: Vec<f64> = (0..)
                .map(|i| 400.0 + step * i as f64)
                .take_while(|&w| w <= 700.0)
                .collect();
            let coarse = weight.resampled(&grid).unwrap();
            assert_relative_eq!(
                lamp.integrate_weighted(&coarse),
                exact,
                max_relative = 1e-12
            );
        }
    }

    #[test]
    fn product_weights_lines_by_other_continuum() {
        let lamp = Spectrum::constant(400.0, 700.0, 2.0)
            .unwrap()
            .with_lines(vec![line(550.0, 10.0)])
            .unwrap();
        let filter = Spectrum::new(vec![500.0, 600.0], vec![0.5, 0.5]).unwrap();
        let p = lamp.product(&filter);
        // continuum 2 × 0.5 over 100 nm = 100; line 10 × 0.5 = 5.
        assert_relative_eq!(p.integral(), 105.0, max_relative = 1e-14);
    }

    /// The old rule: sample the product at the union nodes, integrate it as
    /// piecewise linear.
    fn union_grid_trapezoid(a: &Spectrum, b: &Spectrum) -> f64 {
        a.product(b).integral()
    }

    /// ∫ a b dλ by the trapezoid rule on `n` uniform steps over `[lo, hi]`,
    /// from point values only (an answer independent of the union grid).
    fn fine_trapezoid(a: &Spectrum, b: &Spectrum, lo: f64, hi: f64, n: usize) -> f64 {
        let h = (hi - lo) / n as f64;
        let f = |i: usize| {
            let x = if i == n { hi } else { lo + h * i as f64 };
            a.eval(x) * b.eval(x)
        };
        let inner: f64 = (1..n).map(f).sum();
        h * (inner + 0.5 * (f(0) + f(n)))
    }

    #[test]
    fn product_of_two_ramps_integrates_to_the_closed_form() {
        // a = λ − 400 and b = 700 − λ on 400–700 nm, each one linear piece:
        // ∫ (λ−400)(700−λ) dλ = ∫_0^300 t (300 − t) dt = 300³/6 = 4.5e6.
        let a = Spectrum::new(vec![400.0, 700.0], vec![0.0, 300.0]).unwrap();
        let b = Spectrum::new(vec![400.0, 700.0], vec![300.0, 0.0]).unwrap();
        assert_relative_eq!(a.integrate_weighted(&b), 4.5e6, max_relative = 1e-14);
        // The product sampled at the two nodes is 0 at both: all of it lost.
        assert_eq!(union_grid_trapezoid(&a, &b), 0.0);
        // Band 450–650 nm: ∫_50^250 t (300 − t) dt = 150 (250² − 50²) − (250³ − 50³)/3.
        let band = 150.0 * (250.0f64.powi(2) - 50.0f64.powi(2))
            - (250.0f64.powi(3) - 50.0f64.powi(3)) / 3.0;
        assert_relative_eq!(
            a.integrate_weighted_band(&b, 450.0, 650.0),
            band,
            max_relative = 1e-14
        );
        // Same-signed slopes: a² = (λ − 400)² over 400–700 nm is 300³/3 = 9e6,
        // where the two-node trapezoid says 300 · 300²/2 = 1.35e7 (+50 %).
        assert_relative_eq!(a.integrate_weighted(&a), 9e6, max_relative = 1e-14);
        assert_relative_eq!(union_grid_trapezoid(&a, &a), 1.35e7, max_relative = 1e-14);
        // Grids that only partly overlap: the product is zero outside 500–700.
        let c = Spectrum::new(vec![500.0, 900.0], vec![1.0, 1.0]).unwrap();
        // ∫_100^300 t dt = (300² − 100²)/2 = 40 000.
        assert_relative_eq!(a.integrate_weighted(&c), 40_000.0, max_relative = 1e-14);
    }

    #[test]
    fn coarse_irregular_pair_matches_a_fine_trapezoid() {
        // A lamp and a response on unrelated, irregular, coarse grids.
        let lamp = Spectrum::new(
            vec![380.0, 410.0, 455.0, 530.0, 600.0, 690.0, 780.0],
            vec![0.2, 1.4, 0.6, 2.5, 0.9, 3.0, 0.1],
        )
        .unwrap();
        let qe = Spectrum::new(
            vec![400.0, 430.0, 500.0, 515.0, 640.0, 720.0, 900.0],
            vec![0.05, 0.30, 0.10, 0.45, 0.20, 0.35, 0.0],
        )
        .unwrap();
        // 10⁵ steps of 3.8e-3 nm: the trapezoid's error on this product is
        // O(h²) ≈ 1e-10 relative, far below the difference being tested.
        let fine = fine_trapezoid(&lamp, &qe, 400.0, 780.0, 100_000);
        let exact = lamp.integrate_weighted(&qe);
        assert_relative_eq!(exact, fine, max_relative = 1e-8);
        // Symmetric in its factors.
        assert_relative_eq!(qe.integrate_weighted(&lamp), exact, max_relative = 1e-14);
        // The old union-grid trapezoid is off by far more than that.
        let old = union_grid_trapezoid(&lamp, &qe);
        assert!((old / fine - 1.0).abs() > 1e-3, "old {old} fine {fine}");
        // A band whose edges fall inside intervals of both grids.
        let fine_band = fine_trapezoid(&lamp, &qe, 442.5, 611.25, 100_000);
        assert_relative_eq!(
            lamp.integrate_weighted_band(&qe, 442.5, 611.25),
            fine_band,
            max_relative = 1e-8
        );
    }

    #[test]
    fn weighted_band_is_half_open_for_lines_and_additive() {
        let lamp = Spectrum::new(vec![400.0, 700.0], vec![1.0, 2.0])
            .unwrap()
            .with_lines(vec![line(500.0, 3.0), line(600.0, 5.0)])
            .unwrap();
        let weight = Spectrum::new(vec![450.0, 650.0], vec![0.5, 1.5])
            .unwrap()
            .with_lines(vec![line(550.0, 2.0)])
            .unwrap();
        // A line on the upper edge is out; one on the lower edge is in.
        let lower = lamp.integrate_weighted_band(&weight, 450.0, 500.0);
        let upper = lamp.integrate_weighted_band(&weight, 500.0, 650.0);
        let whole = lamp.integrate_weighted(&weight);
        assert_relative_eq!(lower + upper, whole, max_relative = 1e-14);
        let w500 = weight.eval(500.0);
        let no_lines = Spectrum::new(vec![400.0, 700.0], vec![1.0, 2.0]).unwrap();
        let plain_weight = Spectrum::new(vec![450.0, 650.0], vec![0.5, 1.5]).unwrap();
        assert_relative_eq!(
            upper - no_lines.integrate_weighted_band(&plain_weight, 500.0, 650.0),
            3.0 * w500 + 5.0 * weight.eval(600.0) + 2.0 * lamp.eval(550.0),
            max_relative = 1e-12
        );
        assert_relative_eq!(
            lower,
            no_lines.integrate_weighted_band(&plain_weight, 450.0, 500.0),
            max_relative = 1e-14
        );
        // Empty or reversed bands integrate to zero.
        assert_eq!(lamp.integrate_weighted_band(&weight, 600.0, 600.0), 0.0);
        assert_eq!(lamp.integrate_weighted_band(&weight, 700.0, 400.0), 0.0);
        assert_eq!(lamp.integrate_weighted_band(&weight, f64::NAN, 700.0), 0.0);
    }

    #[test]
    fn normalisation_hits_target() {
        let s = Spectrum::constant(380.0, 780.0, 1.0).unwrap();
        let n = s.normalized_to_band(400.0, 700.0, 15.058).unwrap();
        assert_relative_eq!(n.integrate_band(400.0, 700.0), 15.058, max_relative = 1e-14);
        assert_relative_eq!(n.eval(500.0), 15.058 / 300.0, max_relative = 1e-14);
        let empty = Spectrum::constant(800.0, 900.0, 1.0).unwrap();
        assert!(matches!(
            empty.normalized_to_band(400.0, 700.0, 1.0),
            Err(SpectrumError::ZeroInBand { .. })
        ));
    }

    #[test]
    fn construction_errors_name_the_index() {
        assert!(matches!(
            Spectrum::new(vec![400.0, 400.0], vec![1.0, 1.0]),
            Err(SpectrumError::DuplicateWavelength { index: 1, .. })
        ));
        assert!(matches!(
            Spectrum::new(vec![500.0, 400.0], vec![1.0, 1.0]),
            Err(SpectrumError::NotIncreasing { index: 1, .. })
        ));
        assert!(matches!(
            Spectrum::new(vec![400.0, 500.0], vec![1.0, f64::NAN]),
            Err(SpectrumError::NonFiniteValue { index: 1, .. })
        ));
        assert!(matches!(
            Spectrum::new(vec![400.0, 500.0], vec![-1.0, 1.0]),
            Err(SpectrumError::NegativeValue { index: 0, .. })
        ));
        assert!(matches!(
            Spectrum::new(vec![400.0], vec![1.0, 2.0]),
            Err(SpectrumError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn a_wavelength_carries_one_line() {
        let s = Spectrum::from_lines(vec![line(546.07, 1.0)]).unwrap();
        assert_eq!(
            s.clone()
                .with_lines(vec![line(435.83, 1.0), line(546.07, 2.0)]),
            Err(SpectrumError::DuplicateLine {
                index: 1,
                wavelength_nm: 546.07
            })
        );
        assert!(matches!(
            Spectrum::from_lines(vec![line(500.0, 1.0), line(600.0, 1.0), line(500.0, 1.0)]),
            Err(SpectrumError::DuplicateLine { index: 2, .. })
        ));
        assert!(matches!(
            s.with_lines(vec![line(f64::NAN, 1.0)]),
            Err(SpectrumError::BadWavelength { index: 0, .. })
        ));
    }
}
