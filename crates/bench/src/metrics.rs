//! Error metrics of a render against a truth, and the accuracy/time
//! summaries built on them (time to an error, the Pareto front).

use ndarray::{Array3, Axis};

use super::truth::Truth;

/// `sqrt(Σ(a − b)² / Σ b²)` over every pixel and band.
pub fn rel_rms_diff(a: &Array3<f64>, b: &Array3<f64>) -> f64 {
    let (mut se, mut st) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b.iter()) {
        se += (x - y) * (x - y);
        st += y * y;
    }
    if st > 0.0 {
        (se / st).sqrt()
    } else {
        se.sqrt()
    }
}

/// Errors of a render against the truth, over the counted pixels, with the
/// reference's own noise subtracted (per pixel and band).
#[derive(Clone, Copy, Debug, Default)]
pub struct Errors {
    /// Energy-weighted: `sqrt(Σ(x−t)²/Σt²)` (bright pixels dominate).
    pub energy: f64,
    /// Per pixel: `sqrt(mean(((x−t)/t)²))` (penumbrae and dark walls count
    /// as much as bright ones).
    pub pixel: f64,
    /// Per pixel as `--target-error` defines it: `(x−t)/max(t, floor)`
    /// with the render's dark floor (`DARK_FLOOR` × the image's band
    /// mean), so a near-black pixel counts by its error against that
    /// floor, as the target does — what "achieved vs asked" compares.
    pub pixel_as_targeted: f64,
    /// `max |x−t|/t` over pixels above 1 % of the band mean.
    pub max_rel: f64,
}

pub fn errors(img: &Array3<f64>, truth: &Truth) -> Errors {
    let mut se = 0.0;
    let mut st = 0.0;
    let mut sv = 0.0;
    let mut rel2 = 0.0;
    let mut n = 0usize;
    let mut nrel = 0usize;
    let mut max_rel: f64 = 0.0;
    let mut rel2_floor = 0.0;
    for (b, (pi, pt)) in img
        .axis_iter(Axis(0))
        .zip(truth.image.axis_iter(Axis(0)))
        .enumerate()
    {
        let (mut sum_t, mut cnt) = (0.0, 0usize);
        for ((r, c), &m) in truth.mask.indexed_iter() {
            if m {
                sum_t += pt[[r, c]];
                cnt += 1;
            }
        }
        let floor = 0.01 * sum_t / cnt.max(1) as f64;
        let target_floor =
            gloam_trace::render::DARK_FLOOR * pi.iter().sum::<f64>() / pi.len().max(1) as f64;
        for ((r, c), &m) in truth.mask.indexed_iter() {
            if !m {
                continue;
            }
            let (x, t) = (pi[[r, c]], pt[[r, c]]);
            let var = truth.noise_var.as_ref().map_or(0.0, |v| v[[b, r, c]]);
            se += (x - t).powi(2);
            st += t * t;
            sv += var;
            n += 1;
            if t > 0.0 {
                rel2 += ((x - t).powi(2) - var) / (t * t);
                rel2_floor += ((x - t).powi(2) - var) / t.max(target_floor).powi(2);
                nrel += 1;
            }
            if t > floor && t > 0.0 {
                max_rel = max_rel.max((x - t).abs() / t);
            }
        }
    }
    if n == 0 || st <= 0.0 {
        return Errors {
            energy: f64::NAN,
            pixel: f64::NAN,
            pixel_as_targeted: f64::NAN,
            max_rel: f64::NAN,
        };
    }
    Errors {
        energy: ((se - sv).max(0.0) / st).sqrt(),
        pixel: (rel2 / nrel.max(1) as f64).max(0.0).sqrt(),
        pixel_as_targeted: (rel2_floor / nrel.max(1) as f64).max(0.0).sqrt(),
        max_rel,
    }
}

/// For a target-error render: the fraction of counted pixels (first band)
/// whose actual error `|x−t|` is within 2× the target (relative to
/// `max(t, dark floor)`) and within 2× the render's own standard-error
/// estimate (combined with the reference's noise).
pub fn error_coverage(
    img: &Array3<f64>,
    se: &Array3<f64>,
    truth: &Truth,
    target: f64,
) -> (f64, f64) {
    let (pi, ps, pt) = (
        img.index_axis(Axis(0), 0),
        se.index_axis(Axis(0), 0),
        truth.image.index_axis(Axis(0), 0),
    );
    let mean_t = {
        let v: Vec<f64> = pi.iter().copied().collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let floor = gloam_trace::render::DARK_FLOOR * mean_t;
    let (mut n, mut a, mut b) = (0usize, 0usize, 0usize);
    for ((r, c), &m) in truth.mask.indexed_iter() {
        if !m {
            continue;
        }
        let (x, t, s) = (pi[[r, c]], pt[[r, c]], ps[[r, c]]);
        let var_ref = truth.noise_var.as_ref().map_or(0.0, |v| v[[0, r, c]]);
        let err = (x - t).abs();
        n += 1;
        if err <= 2.0 * (target * t.max(floor)).hypot(var_ref.sqrt()) {
            a += 1;
        }
        if err <= 2.0 * (s * s + var_ref).sqrt() {
            b += 1;
        }
    }
    let n = n.max(1) as f64;
    (a as f64 / n, b as f64 / n)
}
