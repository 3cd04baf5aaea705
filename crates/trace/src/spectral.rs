//! The wavelengths a render carries, and integration into the scene's bands.
//!
//! A spectral value is a `Vec<f64>` with one slot per carried wavelength:
//! first the continuum grid (a density, per nm), then one slot per distinct
//! emission-line wavelength of any source (an integrated value: the line's
//! power). Reflectances and transmissions are evaluated at every slot, so
//! products slot by slot carry both the continuum and the lines exactly.
//!
//! The continuum grid spans the union of the bands' `[lo_nm, hi_nm]` with
//! step `spectral_step_nm`, plus every band edge. A band value is
//! `∫_lo^hi R(λ) L(λ) dλ` by the trapezoid rule on that grid plus
//! `Σ R(λ_l) L_l` over lines with `lo ≤ λ_l < hi` (exact).
//!
//! Emitted continua are not point-sampled at the nodes but averaged over
//! each node's hat function (the trapezoid rule's basis), so the
//! trapezoid sum of a flat band reproduces `∫ L dλ` exactly on any grid,
//! however spiky `L` is between nodes (a triphosphor continuum on a 20 nm
//! grid). A band edge inside the grid carries two slots at the same
//! wavelength (the left and the right half of its hat), so each band is
//! exact on its own. Reflectances and responses, which are smooth, are
//! sampled.

use gloam_scene::Scene;
use gloam_spectra::Spectrum;

/// Finest wavelength step, nm.
pub const MIN_STEP_NM: f64 = 1e-3;
/// Most wavelength samples a render takes (the span over the step).
pub const MAX_WAVELENGTHS: f64 = 1e6;

/// The lowest and highest band edge of the scene, nm (∞, −∞ without bands).
fn band_span_nm(scene: &Scene) -> (f64, f64) {
    let lo = scene
        .bands
        .iter()
        .map(|b| b.lo_nm)
        .fold(f64::INFINITY, f64::min);
    let hi = scene
        .bands
        .iter()
        .map(|b| b.hi_nm)
        .fold(f64::NEG_INFINITY, f64::max);
    (lo, hi)
}

/// Samples of the scene's spectral span at `step_nm` (before the band
/// edges are added), as a float so an absurd span cannot overflow.
pub fn wavelength_count(scene: &Scene, step_nm: f64) -> f64 {
    let (lo, hi) = band_span_nm(scene);
    if lo < hi {
        ((hi - lo) / step_nm.max(MIN_STEP_NM)).ceil() + 1.0
    } else {
        0.0
    }
}

/// The wavelength slots of a render and the band integration weights.
#[derive(Clone, Debug)]
pub struct Wavelengths {
    /// Every slot's wavelength: the continuum nodes, then line wavelengths.
    pub nm: Vec<f64>,
    /// How many leading slots are continuum nodes.
    pub n_continuum: usize,
    /// Band names, in scene order.
    pub band_names: Vec<String>,
    /// `weights[b][k]`: band `b` value = `Σ_k weights[b][k] · value[k]`.
    pub weights: Vec<Vec<f64>>,
}

impl Wavelengths {
    /// Slots for `scene` with continuum step `step_nm`.
    pub fn for_scene(scene: &Scene, step_nm: f64) -> Self {
        // (Settings refuse steps below MIN_STEP_NM; the clamp is for
        // settings built in code.)
        let (lo, hi) = band_span_nm(scene);
        let mut grid = Vec::new();
        if lo < hi {
            let step = step_nm.max(MIN_STEP_NM);
            let n = ((hi - lo) / step).ceil() as usize;
            for i in 0..=n {
                grid.push((lo + step * i as f64).min(hi));
            }
            for b in &scene.bands {
                grid.push(b.lo_nm);
                grid.push(b.hi_nm);
            }
        }
        grid.sort_by(f64::total_cmp);
        grid.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        // A band edge inside the grid gets two slots at its wavelength: the
        // band below integrates the emission averaged over the left half of
        // the hat there, the band above over the right half.
        if let (Some(&g_lo), Some(&g_hi)) = (grid.first(), grid.last()) {
            let inner_edge = |x: f64| {
                x > g_lo + 1e-9
                    && x < g_hi - 1e-9
                    && scene
                        .bands
                        .iter()
                        .any(|b| (b.lo_nm - x).abs() < 1e-9 || (b.hi_nm - x).abs() < 1e-9)
            };
            grid = grid
                .iter()
                .flat_map(|&x| std::iter::repeat_n(x, if inner_edge(x) { 2 } else { 1 }))
                .collect();
        }

        let mut lines: Vec<f64> = Vec::new();
        let mut add_lines = |s: &Spectrum| {
            for l in s.lines() {
                if l.wavelength_nm >= lo && l.wavelength_nm < hi {
                    lines.push(l.wavelength_nm);
                }
            }
        };
        for m in &scene.materials {
            if let Some(e) = &m.emission {
                add_lines(&e.radiance_w_m2_sr_nm);
            }
        }
        for p in &scene.point_sources {
            add_lines(&p.intensity_w_sr_nm);
        }
        lines.sort_by(f64::total_cmp);
        lines.dedup();

        let n_continuum = grid.len();
        let mut weights = Vec::with_capacity(scene.bands.len());
        for b in &scene.bands {
            let mut w = vec![0.0; n_continuum + lines.len()];
            for j in 1..n_continuum {
                let (x0, x1) = (grid[j - 1], grid[j]);
                if x0 >= b.lo_nm - 1e-9 && x1 <= b.hi_nm + 1e-9 {
                    let h = 0.5 * (x1 - x0);
                    w[j - 1] += h * b.response.eval(x0);
                    w[j] += h * b.response.eval(x1);
                }
            }
            for (i, &l) in lines.iter().enumerate() {
                if l >= b.lo_nm && l < b.hi_nm {
                    w[n_continuum + i] = b.response.eval(l);
                }
            }
            weights.push(w);
        }
        let mut nm = grid;
        nm.extend(lines);
        Self {
            nm,
            n_continuum,
            band_names: scene.bands.iter().map(|b| b.name.clone()).collect(),
            weights,
        }
    }

    /// Number of slots.
    pub fn len(&self) -> usize {
        self.nm.len()
    }

    /// True when no wavelength is carried.
    pub fn is_empty(&self) -> bool {
        self.nm.is_empty()
    }

    /// An emitted quantity: at each continuum node the density averaged
    /// over the node's hat function, and in each line slot the summed power
    /// of the spectrum's lines there.
    pub fn emission(&self, s: &Spectrum) -> Vec<f64> {
        let grid = &self.nm[..self.n_continuum];
        let mut v: Vec<f64> = (0..grid.len())
            .map(|j| {
                let c = grid[j];
                let a = if j > 0 { grid[j - 1] } else { c };
                let b = grid.get(j + 1).copied().unwrap_or(c);
                hat_average(s, a, c, b)
            })
            .collect();
        v.extend(self.nm[self.n_continuum..].iter().map(|&w| {
            s.lines()
                .iter()
                .filter(|l| l.wavelength_nm == w)
                .map(|l| l.value)
                .sum::<f64>()
        }));
        v
    }

    /// A dimensionless factor (reflectance, transmission) at every slot.
    pub fn factor(&self, s: &Spectrum) -> Vec<f64> {
        self.nm.iter().map(|&w| s.eval(w)).collect()
    }

    /// The band values of a spectral value.
    pub fn integrate(&self, v: &[f64]) -> Vec<f64> {
        self.weights
            .iter()
            .map(|w| w.iter().zip(v).map(|(a, b)| a * b).sum())
            .collect()
    }

    /// Sum over every band of the band value (a scalar size for choosing).
    pub fn total(&self, v: &[f64]) -> f64 {
        self.integrate(v).iter().sum()
    }
}

/// `∫ s φ dλ / ∫ φ dλ` for the hat `φ` rising from `a` to 1 at `c` and
/// falling to `b` (a half hat when `a = c` or `c = b`); `s(c)` when the hat
/// has no width. Exact for the piecewise-linear continuum: the interval is
/// split at every node of `s` and the product, quadratic on each piece, is
/// integrated by Simpson's rule; pieces outside `s`'s support add nothing.
fn hat_average(s: &Spectrum, a: f64, c: f64, b: f64) -> f64 {
    if b <= a {
        return s.eval(c);
    }
    let nodes = s.wavelengths_nm();
    if nodes.len() < 2 {
        // No extent: zero density almost everywhere, as `eval` has it.
        return s.eval(c);
    }
    let (first, last) = (nodes[0], nodes[nodes.len() - 1]);
    let mut cuts: Vec<f64> = vec![a, c, b];
    cuts.extend(nodes.iter().copied().filter(|&x| x > a && x < b));
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let hat = |x: f64| {
        if x <= c {
            if c > a { (x - a) / (c - a) } else { 1.0 }
        } else if b > c {
            (b - x) / (b - c)
        } else {
            1.0
        }
    };
    let mut sum = 0.0;
    for w in cuts.windows(2) {
        let (x0, x1) = (w[0], w[1]);
        let xm = 0.5 * (x0 + x1);
        if !(xm > first && xm < last) {
            continue;
        }
        // Inside the support: s is linear on [x0, x1] (its nodes are cuts).
        let f = |x: f64| s.eval(x.clamp(first, last)) * hat(x);
        sum += (x1 - x0) / 6.0 * (f(x0) + 4.0 * f(xm) + f(x1));
    }
    sum / (0.5 * (b - a))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_weights_are_exact_for_flat_and_line_spectra() {
        let text = r#"
units = "m"
camera = { position = [0, 0, 1], look_at = [0, 0, 0], up = [0, 1, 0], fov_deg = 10, width = 2, height = 2 }
[bands.a]
lo_nm = 400
hi_nm = 553
[bands.b]
lo_nm = 553
hi_nm = 700
[materials.lamp]
reflectance = 0.0
emission = { spectrum = "lps", scale = 1.0 }
[objects.lamp]
material = "lamp"
quad = { center = [0, 0, 0], size = [1, 1], normal = [0, 0, 1] }
"#;
        let scene = gloam_scene::parse_str(text, std::path::Path::new("t.toml")).unwrap();
        let wl = Wavelengths::for_scene(&scene, 7.0);
        // Band edges are nodes; grid within [400, 700].
        assert!(wl.nm[..wl.n_continuum].contains(&553.0));
        assert_eq!(wl.nm[0], 400.0);
        assert_eq!(wl.nm[wl.n_continuum - 1], 700.0);
        // A flat continuum of 2 per nm integrates to 2 × width exactly.
        let flat = Spectrum::constant(300.0, 800.0, 2.0).unwrap();
        let v = wl.integrate(&wl.emission(&flat));
        assert!(
            (v[0] - 306.0).abs() < 1e-9 && (v[1] - 294.0).abs() < 1e-9,
            "{v:?}"
        );
        // The sodium D lines land in band b, exactly.
        let lps = &scene.materials[0]
            .emission
            .as_ref()
            .unwrap()
            .radiance_w_m2_sr_nm;
        let v = wl.integrate(&wl.emission(lps));
        assert!((v[1] - lps.integrate_band(553.0, 700.0)).abs() < 1e-12 * v[1]);
        assert!((v[0] - lps.integrate_band(400.0, 553.0)).abs() < 1e-12 * v[1].max(1.0));

        // Continua that point-sampling on a 7 nm grid gets wrong: a 1 nm
        // spike between nodes over a floor, a spike straddling the shared
        // 553 nm edge, and a box whose ends fall inside cells.
        let spiky = Spectrum::new(
            vec![300.0, 500.0, 500.3, 500.8, 552.6, 553.0, 553.5, 800.0],
            vec![0.1, 0.1, 100.0, 0.1, 0.1, 40.0, 0.1, 0.1],
        )
        .unwrap();
        let boxed = Spectrum::new(vec![503.2, 620.7], vec![1.0, 1.0]).unwrap();
        for s in [&spiky, &boxed] {
            let v = wl.integrate(&wl.emission(s));
            for (b, (lo, hi)) in [(0, (400.0, 553.0)), (1, (553.0, 700.0))] {
                let exact = s.integrate_band(lo, hi);
                assert!(
                    (v[b] - exact).abs() < 1e-12 * exact.max(1.0),
                    "band {b}: {} vs {exact}",
                    v[b]
                );
            }
        }
        // The spike (a 0.8 nm triangle 100 high) holds ~40 of band a's ~55:
        // sampling at the nodes (every 7 nm from 400) would miss all of it.
        assert!(spiky.integrate_band(400.0, 553.0) > 54.0);
        // A single-node continuum has no extent: zero, as before.
        let dot = Spectrum::new(vec![500.0], vec![3.0]).unwrap();
        assert_eq!(wl.integrate(&wl.emission(&dot)), vec![0.0, 0.0]);
    }
}
