//! Random streams and fast samplers.
//!
//! Every (seed, frame, pass, row) gets its own PCG stream, so a frame is
//! bit-identical whatever the number of threads and whichever thread draws
//! which row.

use rand::{RngCore, SeedableRng};
use rand_distr::{Distribution, Gamma};
use rand_pcg::Pcg64Mcg;

/// Passes of the capture loop that draw random numbers.
#[derive(Clone, Copy, Debug)]
#[repr(u64)]
pub enum Pass {
    Photoelectrons = 1,
    Ccd = 2,
    Read = 3,
    Prnu = 10,
    Dsnu = 11,
    /// Line-locked pixel-clock jitter of the digitizer.
    ClockJitter = 20,
}

/// SplitMix64 (Steele, Lea & Flood, OOPSLA 2014; Vigna's `splitmix64.c`):
/// the output for generator state `z` before its increment — a strong
/// 64-bit mixer used to derive stream seeds from (seed, frame, pass, row)
/// and, stepped by the golden-ratio increment, a small generator.
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The stream for one row of one pass of one frame.
pub fn stream(seed: u64, frame: u64, pass: Pass, row: usize) -> Pcg64Mcg {
    let mut h = splitmix64(seed);
    h = splitmix64(h ^ frame.wrapping_mul(0xD6E8_FEB8_6659_FD93));
    h = splitmix64(h ^ (pass as u64).wrapping_mul(0xA076_1D64_78BD_642F));
    h = splitmix64(h ^ (row as u64));
    let lo = splitmix64(h ^ 0x5555);
    Pcg64Mcg::new(((h as u128) << 64) | lo as u128 | 1)
}

/// Uniform in (0, 1).
#[inline]
pub fn uniform(rng: &mut Pcg64Mcg) -> f64 {
    ((rng.next_u64() >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
}

/// A standard normal draw: the Marsaglia–Tsang ziggurat (J. Stat. Softw.
/// 5(8), 2000) with 128 layers, taking the layer index and the 32-bit
/// abscissa from separate bits of one 64-bit draw (Leong et al., J. Stat.
/// Softw. 12(7), 2005, on correlated bits). ~98.8 % of draws cost one
/// integer compare and one multiply.
#[inline]
pub fn normal(rng: &mut Pcg64Mcg) -> f64 {
    let z = zig();
    let u = rng.next_u64();
    let hz = (u >> 32) as u32 as i32;
    let iz = (u & 127) as usize;
    if hz.unsigned_abs() < z.kn[iz] {
        return hz as f64 * z.wn[iz];
    }
    normal_slow(rng, hz, iz)
}

/// A standard normal and an independent uniform in (0, 1) of 25-bit
/// resolution from the same 64-bit draw: the ziggurat uses bits 0–6 and
/// 32–63, the uniform takes bits 7–31. Saves a generator call where a
/// coarse uniform suffices (a rejection test).
#[inline]
pub fn normal_and_uniform(rng: &mut Pcg64Mcg) -> (f64, f64) {
    let z = zig();
    let u = rng.next_u64();
    let spare = (((u >> 7) & 0x1FF_FFFF) as f64 + 0.5) * (1.0 / (1u64 << 25) as f64);
    let hz = (u >> 32) as u32 as i32;
    let iz = (u & 127) as usize;
    if hz.unsigned_abs() < z.kn[iz] {
        return (hz as f64 * z.wn[iz], spare);
    }
    (normal_slow(rng, hz, iz), spare)
}

#[cold]
fn normal_slow(rng: &mut Pcg64Mcg, mut hz: i32, mut iz: usize) -> f64 {
    const R: f64 = 3.442_619_855_899;
    let z = zig();
    loop {
        let x = hz as f64 * z.wn[iz];
        if iz == 0 {
            // Tail beyond R (Marsaglia 1964).
            loop {
                let x = -uniform(rng).ln() / R;
                let y = -uniform(rng).ln();
                if y + y >= x * x {
                    return if hz > 0 { R + x } else { -R - x };
                }
            }
        }
        if z.fn_[iz] + uniform(rng) * (z.fn_[iz - 1] - z.fn_[iz]) < (-0.5 * x * x).exp() {
            return x;
        }
        let u = rng.next_u64();
        hz = (u >> 32) as u32 as i32;
        iz = (u & 127) as usize;
        if hz.unsigned_abs() < z.kn[iz] {
            return hz as f64 * z.wn[iz];
        }
    }
}

struct Ziggurat {
    kn: [u32; 128],
    wn: [f64; 128],
    fn_: [f64; 128],
}

fn zig() -> &'static Ziggurat {
    static Z: std::sync::OnceLock<Ziggurat> = std::sync::OnceLock::new();
    Z.get_or_init(|| {
        let m1 = 2_147_483_648.0f64;
        let mut dn = 3.442_619_855_899f64;
        let mut tn = dn;
        let vn = 9.912_563_035_262_17e-3f64;
        let mut z = Ziggurat {
            kn: [0; 128],
            wn: [0.0; 128],
            fn_: [0.0; 128],
        };
        let q = vn / (-0.5 * dn * dn).exp();
        z.kn[0] = ((dn / q) * m1) as u32;
        z.kn[1] = 0;
        z.wn[0] = q / m1;
        z.wn[127] = dn / m1;
        z.fn_[0] = 1.0;
        z.fn_[127] = (-0.5 * dn * dn).exp();
        for i in (1..=126).rev() {
            dn = (-2.0 * (vn / dn + (-0.5 * dn * dn).exp()).ln()).sqrt();
            z.kn[i + 1] = ((dn / tn) * m1) as u32;
            tn = dn;
            z.fn_[i] = (-0.5 * dn * dn).exp();
            z.wn[i] = dn / m1;
        }
        z
    })
}

/// Poisson counts for the pixels of a row, drawn as one unit-rate Poisson
/// process over the row's cumulative mean: a pixel with mean λ owns the next
/// λ of "time", and its count is the number of arrivals (exponential gaps)
/// falling there. Counts are exactly Poisson and independent between pixels;
/// the cost is one exponential variate (a ziggurat draw, no logarithm) per
/// *event* instead of an `e^{-λ}` per pixel, which suits photon-starved
/// pixels. Busier pixels (mean above [`PoissonRow::PROCESS_BELOW`]) are
/// drawn by inversion (or the Gaussian, as [`poisson`]) without advancing
/// the process (it is memoryless).
pub struct PoissonRow {
    acc: f64,
    next: f64,
    gaussian_above: f64,
}

impl PoissonRow {
    /// Means up to this walk the process; above it, per-pixel inversion.
    pub const PROCESS_BELOW: f64 = 0.5;

    pub fn new(rng: &mut Pcg64Mcg, gaussian_above: f64) -> Self {
        Self {
            acc: 0.0,
            next: rand_distr::Exp1.sample(rng),
            gaussian_above,
        }
    }

    #[inline]
    pub fn draw(&mut self, rng: &mut Pcg64Mcg, lambda: f64) -> f64 {
        if lambda > Self::PROCESS_BELOW && lambda <= self.gaussian_above {
            return poisson_inversion(rng, lambda, (-lambda).exp());
        }
        self.draw_given(rng, lambda, 0.0)
    }

    /// Counts for a whole row of means `lambdas` into `counts`: the same
    /// draws as [`PoissonRow::draw`] pixel by pixel, with every `e^{-λ}`
    /// the inversion needs computed first in one vectorised pass
    /// ([`exp_neg_into`]). `scratch` is reused between rows.
    pub fn draw_row(
        &mut self,
        rng: &mut Pcg64Mcg,
        lambdas: &[f64],
        counts: &mut Vec<f64>,
        scratch: &mut Vec<f64>,
    ) {
        scratch.resize(lambdas.len(), 0.0);
        // Starlit rows walk the process only: skip the exponentials.
        if lambdas.iter().any(|&l| l > Self::PROCESS_BELOW) {
            exp_neg_into(lambdas, scratch);
        }
        counts.clear();
        counts.extend(
            lambdas
                .iter()
                .zip(scratch.iter())
                .map(|(&l, &p0)| self.draw_given(rng, l, p0)),
        );
    }

    /// [`PoissonRow::draw`] with `p0 = e^{-λ}` supplied (used only where
    /// inversion is the method).
    #[inline]
    fn draw_given(&mut self, rng: &mut Pcg64Mcg, lambda: f64, p0: f64) -> f64 {
        if lambda <= 0.0 {
            return 0.0;
        }
        if lambda > Self::PROCESS_BELOW {
            // Busy pixels: inversion (or the Gaussian) is cheaper than
            // walking many arrivals; the process just skips this pixel.
            if lambda > self.gaussian_above {
                return round_non_negative(lambda + lambda.sqrt() * normal(rng));
            }
            return poisson_inversion(rng, lambda, p0);
        }
        self.acc += lambda;
        let mut n = 0.0;
        while self.next <= self.acc {
            n += 1.0;
            // Exponential gaps from rand_distr's ziggurat: no logarithm.
            let gap: f64 = rand_distr::Exp1.sample(rng);
            self.next += gap;
        }
        n
    }
}

/// 1/k for the inversion loop (a multiply instead of a divide per step).
static RECIP: [f64; 64] = {
    let mut t = [0.0; 64];
    let mut k = 1;
    while k < 64 {
        t[k] = 1.0 / k as f64;
        k += 1;
    }
    t
};

/// A Poisson draw with mean `lambda` ≥ 0: exact sequential-search inversion
/// below `gaussian_above`, else a rounded Gaussian with the same mean and
/// variance (clamped at 0).
#[inline]
pub fn poisson(rng: &mut Pcg64Mcg, lambda: f64, gaussian_above: f64) -> f64 {
    if lambda <= 0.0 {
        return 0.0;
    }
    if lambda > gaussian_above {
        return round_non_negative(lambda + lambda.sqrt() * normal(rng));
    }
    poisson_inversion(rng, lambda, (-lambda).exp())
}

/// Sequential-search inversion for a Poisson mean `lambda > 0` given
/// `p0 = e^{-λ}`.
#[inline]
fn poisson_inversion(rng: &mut Pcg64Mcg, lambda: f64, p0: f64) -> f64 {
    let u = uniform(rng);
    // The first four steps of the inversion without branches (most draws
    // at photon-starved levels end here), then the sequential search.
    let p1 = p0 * lambda;
    let p2 = p1 * lambda * 0.5;
    let p3 = p2 * lambda * (1.0 / 3.0);
    let c0 = p0;
    let c1 = c0 + p1;
    let c2 = c1 + p2;
    let c3 = c2 + p3;
    if u <= c3 {
        return ((u > c0) as u32 + (u > c1) as u32 + (u > c2) as u32) as f64;
    }
    let mut p = p3;
    let mut cdf = c3;
    let mut k = 3usize;
    while u > cdf && k < 1000 {
        k += 1;
        p *= lambda
            * if k < RECIP.len() {
                RECIP[k]
            } else {
                1.0 / k as f64
            };
        cdf += p;
        if p == 0.0 {
            break;
        }
    }
    k as f64
}

/// `out[i] = e^{-xs[i]}` for `xs[i] ≥ 0` (NaN and above 700 give
/// `e^{-700}`, callers only use values ≤ the Gaussian threshold), to within
/// 2 ulp.
///
/// Why not libm: a call per pixel cost a quarter of the MCP pass, and libm
/// does not vectorise. Cody–Waite reduction `x = k ln 2 + r`, `|r| ≤ ln 2 / 2`,
/// then the Taylor series of `e^r` to degree 12 (truncation < 2e-16
/// relative), scaled by `2^k` built in the exponent bits. Branch-free, so it
/// runs four lanes wide with AVX2 (picked at run time; no fused
/// multiply-adds, so every machine gives the same bits).
#[multiversion::multiversion(targets("x86_64+avx2"))]
pub fn exp_neg_into(xs: &[f64], out: &mut [f64]) {
    // 1.5·2^52: adding it rounds to an integer held in the low mantissa bits.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    // ln 2 split as in fdlibm: the high part has 32 trailing zero bits, so
    // k · LN2_HI is exact for |k| < 2^20.
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    const INV_FACT: [f64; 13] = {
        let mut t = [1.0; 13];
        let mut k = 1;
        while k < 13 {
            t[k] = t[k - 1] / k as f64;
            k += 1;
        }
        t
    };
    for (o, &x) in out.iter_mut().zip(xs) {
        let y = -(x.clamp(0.0, 700.0));
        let t = y * std::f64::consts::LOG2_E + ROUND;
        let k = t - ROUND;
        let r = (y - k * LN2_HI) - k * LN2_LO;
        let mut p = INV_FACT[12];
        for c in INV_FACT[..12].iter().rev() {
            p = p * r + c;
        }
        let kb = t.to_bits().wrapping_sub(ROUND.to_bits());
        *o = p * f64::from_bits(kb.wrapping_add(1023) << 52);
    }
}

/// `x` rounded to the nearest integer, negative values to 0 (no libm call).
#[inline]
pub fn round_non_negative(x: f64) -> f64 {
    if x <= 0.0 {
        0.0
    } else {
        (x + 0.5) as i64 as f64
    }
}

/// Sums of `n` independent Gamma(shape, mean/shape) draws, i.e.
/// Gamma(n·shape, mean/shape), of mean `n·mean`.
///
/// Marsaglia & Tsang (ACM TOMS 26 (2000) 363) inline for total shape ≥ 1
/// (one normal and one uniform per draw, a logarithm only on the rare
/// squeeze failure), with its constants tabulated for small n;
/// `rand_distr` for total shape below 1.
pub struct GammaSums {
    shape: f64,
    /// (d, c) for n = 0..TABLE.
    table: Vec<(f64, f64)>,
}

impl GammaSums {
    const TABLE: usize = 64;

    pub fn new(shape: f64) -> Self {
        let table = (0..Self::TABLE)
            .map(|n| {
                let a = n as f64 * shape;
                let d = a - 1.0 / 3.0;
                (d, if d > 0.0 { 1.0 / (9.0 * d).sqrt() } else { 0.0 })
            })
            .collect();
        Self { shape, table }
    }

    #[inline]
    pub fn sample(&self, rng: &mut Pcg64Mcg, n: f64, mean: f64) -> f64 {
        if n <= 0.0 {
            return 0.0;
        }
        let shape = self.shape;
        if !shape.is_finite() {
            return n * mean;
        }
        let a = n * shape;
        let scale = mean / shape;
        if a < 1.0 {
            return match Gamma::new(a, scale) {
                Ok(g) => g.sample(rng),
                Err(_) => n * mean,
            };
        }
        let i = n as usize;
        let (d, c) = if i < self.table.len() && i as f64 == n {
            self.table[i]
        } else {
            let d = a - 1.0 / 3.0;
            (d, 1.0 / (9.0 * d).sqrt())
        };
        loop {
            // The acceptance test needs only a coarse uniform (its 25-bit
            // resolution moves acceptance probabilities by < 3e-8).
            let (x, u) = normal_and_uniform(rng);
            let v = 1.0 + c * x;
            if v <= 0.0 {
                continue;
            }
            let v = v * v * v;
            let x2 = x * x;
            if u < 1.0 - 0.0331 * x2 * x2 || u.ln() < 0.5 * x2 + d * (1.0 - v + v.ln()) {
                return d * v * scale;
            }
        }
    }
}

/// One Gamma(n·shape, mean/shape) draw (see [`GammaSums`]).
pub fn gamma_sum(rng: &mut Pcg64Mcg, n: f64, shape: f64, mean: f64) -> f64 {
    GammaSums {
        shape,
        table: Vec::new(),
    }
    .sample(rng, n, mean)
}

/// Charge collected from `n` electrons bombarding silicon: each either
/// deposits the full gain `g` with Fano-limited variance `f·g`, or (with
/// probability `b`) backscatters and deposits a uniform fraction of it.
pub fn eb_charge(rng: &mut Pcg64Mcg, n: f64, g: f64, b: f64, fano: f64) -> f64 {
    if n <= 0.0 {
        return 0.0;
    }
    let (n_back, back_charge) = if n <= 32.0 {
        let mut nb = 0.0;
        let mut q = 0.0;
        for _ in 0..n as u32 {
            if uniform(rng) < b {
                nb += 1.0;
                q += g * uniform(rng);
            }
        }
        (nb, q)
    } else {
        let nb = (n * b + (n * b * (1.0 - b)).sqrt() * normal(rng))
            .round()
            .clamp(0.0, n);
        (
            nb,
            g * (0.5 * nb + (nb / 12.0).sqrt() * normal(rng)).max(0.0),
        )
    };
    let full = (n - n_back) * g;
    (full + (fano * full).sqrt() * normal(rng)).max(0.0) + back_charge
}

/// A deterministic RNG for fixed patterns.
pub fn pattern_rng(seed: u64, pass: Pass, row: usize) -> Pcg64Mcg {
    stream(seed, u64::MAX, pass, row)
}

#[allow(dead_code)]
pub fn seeded(seed: u64) -> Pcg64Mcg {
    Pcg64Mcg::seed_from_u64(seed)
}

#[cfg(test)]
mod tests {
    #[test]
    fn splitmix64_matches_the_reference_sequence() {
        // splitmix64.c seeded with x = 0: the first three outputs.
        let mut x = 0u64;
        let mut next = || {
            let out = super::splitmix64(x);
            x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
            out
        };
        assert_eq!(next(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(next(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(next(), 0x06C4_5D18_8009_454F);
    }
    use super::*;

    #[test]
    fn normal_moments_and_tails() {
        let mut r = seeded(11);
        let n = 2_000_000;
        let (mut s1, mut s2, mut s4, mut tail) = (0.0, 0.0, 0.0, 0usize);
        for _ in 0..n {
            let x = normal(&mut r);
            s1 += x;
            s2 += x * x;
            s4 += x * x * x * x;
            tail += (x.abs() > 3.0) as usize;
        }
        let n = n as f64;
        assert!((s1 / n).abs() < 5.0 / n.sqrt());
        assert!((s2 / n - 1.0).abs() < 5.0 * (2.0 / n).sqrt());
        assert!((s4 / n - 3.0).abs() < 5.0 * (96.0 / n).sqrt());
        // P(|x| > 3) = 0.0026998.
        let p = tail as f64 / n;
        assert!((p - 0.0026998).abs() < 5.0 * (0.0027 / n).sqrt(), "{p}");
    }

    #[test]
    fn poisson_row_counts_are_poisson() {
        let mut r = seeded(5);
        // Pixel by pixel, and a whole row at once (vectorised e^{-λ}).
        for (lambda, whole_row) in [
            (0.05, false),
            (0.7, false),
            (2.0, false),
            (9.0, false),
            (0.05, true),
            (0.7, true),
            (2.0, true),
            (9.0, true),
        ] {
            let n = 200_000;
            let mut row = PoissonRow::new(&mut r, 30.0);
            let xs: Vec<f64> = if whole_row {
                let (mut xs, mut scratch) = (Vec::new(), Vec::new());
                row.draw_row(&mut r, &vec![lambda; n], &mut xs, &mut scratch);
                xs
            } else {
                (0..n).map(|_| row.draw(&mut r, lambda)).collect()
            };
            let m = xs.iter().sum::<f64>() / n as f64;
            let v = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64;
            assert!(
                (m - lambda).abs() < 5.0 * (lambda / n as f64).sqrt(),
                "λ={lambda} mean {m}"
            );
            let tol = 5.0 * ((1.0 + 2.0 * lambda) / (lambda * n as f64)).sqrt();
            assert!((v / lambda - 1.0).abs() < tol, "λ={lambda} var {v}");
            for k in 0..5 {
                let pk = xs.iter().filter(|&&x| x == k as f64).count() as f64 / n as f64;
                let exact = (-lambda).exp() * lambda.powi(k) / (1..=k).product::<i32>() as f64;
                assert!(
                    (pk - exact).abs() < 5.0 * (exact / n as f64).sqrt() + 1e-6,
                    "λ={lambda} P({k})"
                );
            }
            // Neighbouring counts are uncorrelated.
            let c = xs.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / (n - 1) as f64;
            assert!(
                c.abs() / v < 5.0 / (n as f64).sqrt(),
                "λ={lambda} lag-1 corr {}",
                c / v
            );
        }
    }

    #[test]
    fn exp_neg_matches_libm() {
        let mut r = seeded(9);
        let mut xs: Vec<f64> = (0..100_000).map(|_| 40.0 * uniform(&mut r)).collect();
        xs.extend((0..100_000).map(|_| 700.0 * uniform(&mut r)));
        // Reduction boundaries and the ends of the range.
        for k in 0..=1000 {
            let b = k as f64 * std::f64::consts::LN_2 * 0.5;
            xs.extend([b, b.next_up(), b.next_down().max(0.0)]);
        }
        xs.extend([0.0, 1e-300, 700.0]);
        let mut out = vec![0.0; xs.len()];
        exp_neg_into(&xs, &mut out);
        for (&x, &e) in xs.iter().zip(&out) {
            let want = (-x).exp();
            assert!(
                (e - want).abs() <= 4.0 * f64::EPSILON * want,
                "x={x}: {e} vs {want}"
            );
        }
        // Out-of-domain input saturates instead of producing garbage.
        exp_neg_into(&[-3.0, f64::INFINITY], &mut out[..2]);
        assert_eq!(out[0], 1.0);
        assert_eq!(out[1], (-700f64).exp());
    }

    #[test]
    fn poisson_moments() {
        let mut r = seeded(3);
        for lambda in [0.01, 0.7, 2.0, 3.5, 5.0, 29.0, 200.0] {
            let n = 200_000;
            let xs: Vec<f64> = (0..n).map(|_| poisson(&mut r, lambda, 30.0)).collect();
            let m = xs.iter().sum::<f64>() / n as f64;
            for k in 0..6 {
                let pk = xs.iter().filter(|&&x| x == k as f64).count() as f64 / n as f64;
                let exact = (-lambda).exp() * lambda.powi(k) / (1..=k).product::<i32>() as f64;
                if lambda < 30.0 {
                    assert!(
                        (pk - exact).abs() < 5.0 * (exact / n as f64).sqrt() + 1e-6,
                        "λ={lambda} P({k})"
                    );
                }
            }
            let v = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64;
            let se = (lambda / n as f64).sqrt();
            assert!((m - lambda).abs() < 5.0 * se, "λ={lambda} mean {m}");
            // Relative standard error of a Poisson sample variance ≈ √((1 + 2λ)/(λ n)).
            let tol = (5.0 * ((1.0 + 2.0 * lambda) / (lambda * n as f64)).sqrt()).max(0.02);
            assert!(
                (v / lambda - 1.0).abs() < tol,
                "λ={lambda} var {v} (rounding adds 1/12 above the Gaussian threshold)"
            );
        }
    }
}
