//! Random streams and fast samplers.
//!
//! Every (seed, frame, pass, row) gets its own PCG stream, so a frame is
//! bit-identical whatever the number of threads and whichever thread draws
//! which row.

use rand::{Rng, RngCore, SeedableRng};
use rand_distr::{Distribution, Gamma, StandardNormal};
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
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The stream for one row of one pass of one frame.
pub fn stream(seed: u64, frame: u64, pass: Pass, row: usize) -> Pcg64Mcg {
    let mut h = splitmix(seed);
    h = splitmix(h ^ frame.wrapping_mul(0xD6E8_FEB8_6659_FD93));
    h = splitmix(h ^ (pass as u64).wrapping_mul(0xA076_1D64_78BD_642F));
    h = splitmix(h ^ (row as u64));
    let lo = splitmix(h ^ 0x5555);
    Pcg64Mcg::new(((h as u128) << 64) | lo as u128 | 1)
}

/// Uniform in (0, 1).
#[inline]
pub fn uniform(rng: &mut Pcg64Mcg) -> f64 {
    ((rng.next_u64() >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
}

#[inline]
pub fn normal(rng: &mut Pcg64Mcg) -> f64 {
    rng.sample(StandardNormal)
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
    let u = uniform(rng);
    let mut p = (-lambda).exp();
    let mut cdf = p;
    let mut k = 0usize;
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

/// `x` rounded to the nearest integer, negative values to 0 (no libm call).
#[inline]
pub fn round_non_negative(x: f64) -> f64 {
    if x <= 0.0 {
        0.0
    } else {
        (x + 0.5) as i64 as f64
    }
}

/// Sum of `n` independent Gamma(shape, mean/shape) draws, i.e.
/// Gamma(n·shape, mean/shape), of mean `n·mean`.
///
/// Marsaglia & Tsang (ACM TOMS 26 (2000) 363) inline for total shape ≥ 1
/// (one normal, one uniform, one square root per draw, a logarithm only on
/// the rare squeeze failure); `rand_distr` below that.
#[inline]
pub fn gamma_sum(rng: &mut Pcg64Mcg, n: f64, shape: f64, mean: f64) -> f64 {
    if n <= 0.0 {
        return 0.0;
    }
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
    let d = a - 1.0 / 3.0;
    let c = 1.0 / (9.0 * d).sqrt();
    loop {
        let x = normal(rng);
        let v = 1.0 + c * x;
        if v <= 0.0 {
            continue;
        }
        let v = v * v * v;
        let u = uniform(rng);
        let x2 = x * x;
        if u < 1.0 - 0.0331 * x2 * x2 || u.ln() < 0.5 * x2 + d * (1.0 - v + v.ln()) {
            return d * v * scale;
        }
    }
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
    use super::*;

    #[test]
    fn poisson_moments() {
        let mut r = seeded(3);
        for lambda in [0.01, 0.7, 5.0, 29.0, 200.0] {
            let n = 200_000;
            let xs: Vec<f64> = (0..n).map(|_| poisson(&mut r, lambda, 30.0)).collect();
            let m = xs.iter().sum::<f64>() / n as f64;
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
