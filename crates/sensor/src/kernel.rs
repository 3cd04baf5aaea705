//! MTF filtering as separable small-kernel convolution (no FFT).
//!
//! A stage chain's MTF `M(f)` is turned into the band-limited 1-D kernel
//! `h[n] = 2 ∫₀^½ M(f) cos(2π f n) df` (the inverse DTFT of M), truncated
//! where its tail falls below 1e-4 and renormalised to unit sum. Applied
//! along rows then columns, its response to a sine along either axis is
//! `M(f)` up to the truncation error (< 1e-3); along diagonals it is
//! `M(fx) M(fy)` — exact for Gaussian stages, an approximation for the
//! radially symmetric non-Gaussian ones (diffraction, jinc apertures). The
//! input image is taken as already pixel-integrated by the renderer, so the
//! pixel aperture is not applied again.

use rayon::prelude::*;

/// A symmetric 1-D kernel, taps `h[-R..=R]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Kernel {
    pub taps: Vec<f32>,
    pub radius: usize,
    /// Σ h² of the 1-D kernel (the 2-D separable kernel has (Σh²)²).
    pub sum_sq: f64,
}

const MAX_RADIUS: usize = 12;

impl Kernel {
    /// The kernel for `mtf` (cycles/pixel → response), or `None` when the
    /// MTF stays within 0.001 of 1 up to Nyquist (identity: skip the stage).
    ///
    /// The taps are a weighted least-squares fit of `Σ h_n cos(2π f n)` to
    /// `M(f)` (weight 1 up to 0.4 cycles/pixel, 0.05 above, DC pinned to 1),
    /// with the smallest radius whose error is below 0.003 up to 0.4 and
    /// 0.03 above (at most 12). A plainly truncated inverse DTFT would need
    /// ~25 taps when M(½) is far from 0.
    pub fn from_mtf(mtf: impl Fn(f64) -> f64) -> Option<Kernel> {
        const NQ: usize = 400;
        let fs: Vec<f64> = (0..=NQ).map(|i| 0.5 * i as f64 / NQ as f64).collect();
        let ms: Vec<f64> = fs.iter().map(|&f| mtf(f)).collect();
        let dev = ms.iter().map(|m| (1.0 - m).abs()).fold(0.0, f64::max);
        if dev < 1e-3 {
            return None;
        }
        let m0 = ms[0];
        let mut best = None;
        for radius in 1..=MAX_RADIUS {
            let n = radius + 1;
            let basis = |f: f64, j: usize| {
                if j == 0 {
                    1.0
                } else {
                    2.0 * (2.0 * std::f64::consts::PI * f * j as f64).cos()
                }
            };
            let mut a = vec![0.0; n * n];
            let mut b = vec![0.0; n];
            for (i, (&f, &m)) in fs.iter().zip(&ms).enumerate() {
                let w = if i == 0 {
                    1e4
                } else if f <= 0.4 {
                    1.0
                } else {
                    0.05
                };
                for j in 0..n {
                    let pj = basis(f, j);
                    b[j] += w * pj * m;
                    for k in 0..n {
                        a[j * n + k] += w * pj * basis(f, k);
                    }
                }
            }
            let Some(mut h) = solve(a, b, n) else { break };
            // Pin DC exactly to M(0).
            let dc = h[0] + 2.0 * h[1..].iter().sum::<f64>();
            for v in &mut h {
                *v *= m0 / dc;
            }
            let (mut e_lo, mut e_hi) = (0f64, 0f64);
            for (&f, &m) in fs.iter().zip(&ms) {
                let r: f64 = (0..n).map(|j| h[j] * basis(f, j)).sum();
                if f <= 0.4 {
                    e_lo = e_lo.max((r - m).abs());
                } else {
                    e_hi = e_hi.max((r - m).abs());
                }
            }
            best = Some((radius, h));
            if e_lo < 3e-3 && e_hi < 3e-2 {
                break;
            }
        }
        let (radius, h) = best?;
        let taps: Vec<f64> = (0..=2 * radius)
            .map(|i| h[(i as isize - radius as isize).unsigned_abs()])
            .collect();
        let sum_sq = taps.iter().map(|t| t * t).sum();
        Some(Kernel {
            taps: taps.iter().map(|&t| t as f32).collect(),
            radius,
            sum_sq,
        })
    }

    /// Convolves `img` (rows × cols, row-major) in place along rows then
    /// columns, with edge samples replicated. `tmp` is scratch of the same size.
    pub fn apply(&self, img: &mut [f32], tmp: &mut Vec<f32>, rows: usize, cols: usize) {
        let r = self.radius;
        tmp.resize(rows * cols, 0.0);
        tmp.par_chunks_mut(cols)
            .zip(img.par_chunks(cols))
            .for_each_init(Vec::new, |pad: &mut Vec<f32>, (out, row)| {
                pad.clear();
                pad.extend(std::iter::repeat_n(row[0], r));
                pad.extend_from_slice(row);
                pad.extend(std::iter::repeat_n(row[cols - 1], r));
                convolve_row(&self.taps, pad, out);
            });
        let src: &[f32] = tmp;
        img.par_chunks_mut(cols).enumerate().for_each(|(y, out)| {
            convolve_column(&self.taps, src, rows, cols, y, out);
        });
    }
}

// The two inner loops are compiled for AVX2 as well as the baseline and
// picked at run time: twice the lanes. Rust never fuses the multiply-adds,
// so both versions give bit-identical results.
//
// Both work on blocks of `BLOCK` outputs held in registers over all the
// taps (the block is written once, not loaded and stored per tap); each
// output is still `((0 + h₀p₀) + h₁p₁) + …` in tap order, as plain axpy
// passes over the row give it.

/// Outputs per register block: 4 AVX2 vectors.
const BLOCK: usize = 32;

/// `out[i] = Σ_k taps[k] · rows[k][i]` for a block, in tap order.
#[inline(always)]
fn block_sum(taps: &[f32], row_at: impl Fn(usize) -> [f32; BLOCK]) -> [f32; BLOCK] {
    let mut acc = [0f32; BLOCK];
    for (k, &h) in taps.iter().enumerate() {
        let p = row_at(k);
        for (a, &p) in acc.iter_mut().zip(&p) {
            *a += h * p;
        }
    }
    acc
}

/// Row pass: `out[x] = Σ_k h[k] pad[x + k]`.
#[multiversion::multiversion(targets("x86_64+avx2"))]
fn convolve_row(taps: &[f32], pad: &[f32], out: &mut [f32]) {
    let cols = out.len();
    let whole = cols / BLOCK * BLOCK;
    for (b, o) in out[..whole].chunks_exact_mut(BLOCK).enumerate() {
        let x0 = b * BLOCK;
        o.copy_from_slice(&block_sum(taps, |k| {
            pad[x0 + k..x0 + k + BLOCK]
                .try_into()
                .unwrap_or_else(|_| unreachable!("a block of BLOCK"))
        }));
    }
    let rest = &mut out[whole..];
    rest.fill(0.0);
    for (k, &h) in taps.iter().enumerate() {
        for (o, &p) in rest.iter_mut().zip(&pad[whole + k..]) {
            *o += h * p;
        }
    }
}

/// Column pass for output row `y`: `Σ_k h[k] · row(clamp(y + k − R))` of `src`.
#[multiversion::multiversion(targets("x86_64+avx2"))]
fn convolve_column(taps: &[f32], src: &[f32], rows: usize, cols: usize, y: usize, out: &mut [f32]) {
    let r = taps.len() / 2;
    let row_start = |k: usize| {
        (y as isize + k as isize - r as isize).clamp(0, rows as isize - 1) as usize * cols
    };
    let whole = cols / BLOCK * BLOCK;
    for (b, o) in out[..whole].chunks_exact_mut(BLOCK).enumerate() {
        let x0 = b * BLOCK;
        o.copy_from_slice(&block_sum(taps, |k| {
            let s = row_start(k) + x0;
            src[s..s + BLOCK]
                .try_into()
                .unwrap_or_else(|_| unreachable!("a block of BLOCK"))
        }));
    }
    let rest = &mut out[whole..];
    rest.fill(0.0);
    for (k, &h) in taps.iter().enumerate() {
        let s = row_start(k) + whole;
        for (o, &p) in rest.iter_mut().zip(&src[s..s + (cols - whole)]) {
            *o += h * p;
        }
    }
}

/// Solves the symmetric positive-definite system `a x = b` (Gauss with
/// partial pivoting); `None` if singular.
fn solve(mut a: Vec<f64>, mut b: Vec<f64>, n: usize) -> Option<Vec<f64>> {
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        if a[piv * n + col].abs() < 1e-300 {
            return None;
        }
        if piv != col {
            for k in 0..n {
                a.swap(col * n + k, piv * n + k);
            }
            b.swap(col, piv);
        }
        for i in col + 1..n {
            let f = a[i * n + col] / a[col * n + col];
            for k in col..n {
                a[i * n + k] -= f * a[col * n + k];
            }
            b[i] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|k| a[i * n + k] * x[k]).sum();
        x[i] = (b[i] - s) / a[i * n + i];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_reproduces_gaussian_mtf() {
        let sigma = 0.6;
        let m = |f: f64| (-2.0 * std::f64::consts::PI.powi(2) * sigma * sigma * f * f).exp();
        let k = Kernel::from_mtf(m).unwrap();
        for f in [0.05, 0.1, 0.2, 0.3, 0.4] {
            let resp: f64 = k
                .taps
                .iter()
                .enumerate()
                .map(|(i, &h)| {
                    h as f64 * (2.0 * std::f64::consts::PI * f * (i as f64 - k.radius as f64)).cos()
                })
                .sum();
            assert!((resp - m(f)).abs() < 4e-3, "f={f}: {resp} vs {}", m(f));
        }
    }

    /// The blocked passes against the convolution written per pixel
    /// (edges replicated, taps summed in order from 0), to the bit, on
    /// sizes with whole blocks and remainders.
    #[test]
    fn apply_is_the_per_pixel_convolution() {
        let k = Kernel::from_mtf(|f: f64| (-2.0 * (std::f64::consts::PI * 0.9 * f).powi(2)).exp())
            .unwrap();
        let r = k.radius as isize;
        for (rows, cols) in [(37, 71), (5, 64), (40, 3)] {
            let img: Vec<f32> = (0..rows * cols)
                .map(|i| ((i * 7919) % 1013) as f32 * 0.37 + 1.0)
                .collect();
            let at = |v: &[f32], y: isize, x: isize| {
                let (y, x) = (y.clamp(0, rows as isize - 1), x.clamp(0, cols as isize - 1));
                v[y as usize * cols + x as usize]
            };
            let mut horiz = vec![0f32; rows * cols];
            let mut want = vec![0f32; rows * cols];
            for y in 0..rows as isize {
                for x in 0..cols as isize {
                    let mut s = 0f32;
                    for (j, &h) in k.taps.iter().enumerate() {
                        s += h * at(&img, y, x + j as isize - r);
                    }
                    horiz[y as usize * cols + x as usize] = s;
                }
            }
            for y in 0..rows as isize {
                for x in 0..cols as isize {
                    let mut s = 0f32;
                    for (j, &h) in k.taps.iter().enumerate() {
                        s += h * at(&horiz, y + j as isize - r, x);
                    }
                    want[y as usize * cols + x as usize] = s;
                }
            }
            let (mut got, mut tmp) = (img.clone(), Vec::new());
            k.apply(&mut got, &mut tmp, rows, cols);
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert_eq!(
                    g.to_bits(),
                    w.to_bits(),
                    "{rows}x{cols} pixel {i}: {g} vs {w}"
                );
            }
        }
    }

    #[test]
    fn identity_is_skipped() {
        assert!(Kernel::from_mtf(|_| 1.0).is_none());
    }
}
