use super::*;
use rand::{Rng, SeedableRng};

/// `m` jittered (stratified) samples of f(u) = u into replicate `r`.
fn stratified(e: &mut PixelEstimate, m: usize, r: usize, rng: &mut rand_pcg::Pcg64Mcg) {
    for k in 0..m {
        let u = (k as f64 + rng.random::<f64>()) / m as f64;
        e.add(&[u], &[u], Some(r));
    }
}

/// Stratified samples of f(u) = u: each of two replicates of `m`
/// jittered samples has var(mean) = 1/(12 m³), so the pixel's mean (n =
/// 2m) has v = 1/(24 m³), while the per-sample estimate expects
/// s²/n with E[s²] = n/(n−1) · (1/12 − v) for these samples. The
/// replicates must measure the ratio sqrt(v / (E[s²]/n)) (≈ 1/m).
#[test]
fn replicates_measure_the_stratification_gain() {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
    for m in [4usize, 8, 16] {
        let ests: Vec<PixelEstimate> = (0..4096)
            .map(|_| {
                let mut e = PixelEstimate::new(1, 1, 0);
                stratified(&mut e, m, 0, &mut rng);
                stratified(&mut e, m, 1, &mut rng);
                e
            })
            .collect();
        let (factor, global) = stratification(&ests, &[0.0]);
        let (n, v) = (2.0 * m as f64, 1.0 / (24.0 * (m as f64).powi(3)));
        let want = (v / (n / (n - 1.0) * (1.0 / 12.0 - v) / n)).sqrt();
        assert!(
            (global / want - 1.0).abs() < 0.06,
            "m {m}: {global} vs {want}"
        );
        assert!(factor.iter().all(|f| (f / want - 1.0).abs() < 0.2));
    }
}

/// Pixels grown to many samples get the ratio measured on pixels of
/// their own sample count, not the ratio of the many pixels with few
/// (4 096 pixels of 2 × 4 jittered samples of f(u) = u beside 64 of
/// 2 × 64: the closed form of the test above gives ratios ≈ 1/4 and
/// ≈ 1/64; pooled together the 64-sample pixels stated ~10× their
/// error).
#[test]
fn pixels_of_many_samples_get_their_own_ratio() {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
    let want = |m: usize| {
        let (n, v) = (2.0 * m as f64, 1.0 / (24.0 * (m as f64).powi(3)));
        (v / (n / (n - 1.0) * (1.0 / 12.0 - v) / n)).sqrt()
    };
    let ests: Vec<PixelEstimate> = (0..4096 + 64)
        .map(|i| {
            let m = if i < 4096 { 4 } else { 64 };
            let mut e = PixelEstimate::new(1, 1, 0);
            stratified(&mut e, m, 0, &mut rng);
            stratified(&mut e, m, 1, &mut rng);
            e
        })
        .collect();
    let (factor, _) = stratification(&ests, &[0.0]);
    for (i, f) in factor.iter().enumerate() {
        let w = want(if i < 4096 { 4 } else { 64 });
        assert!((f / w - 1.0).abs() < 0.35, "pixel {i}: {f} vs {w}");
    }
}

/// A pixel whose samples were all zero states the error one sample of
/// its brightest neighbour's size would make (mean / n), not zero; one
/// with no lit neighbour within the window states zero.
#[test]
fn all_zero_pixels_state_an_upper_bound() {
    let w = 8;
    let mut ests: Vec<PixelEstimate> = (0..w * w).map(|_| PixelEstimate::new(1, 1, 0)).collect();
    for e in ests.iter_mut() {
        for _ in 0..16 {
            e.add(&[0.0], &[0.0], None);
        }
    }
    // Pixel (row 0, col 0) is lit: mean 2.0 (half its samples 4.0).
    let mut lit = PixelEstimate::new(1, 1, 0);
    for k in 0..16 {
        let v = if k % 2 == 0 { 4.0 } else { 0.0 };
        lit.add(&[v], &[v], None);
    }
    ests[0] = lit;
    let se = stated_std_errors(&ests, w, &vec![1.0; w * w], &[0.0], true);
    // Within DARK_NEIGHBOURHOOD (2) of (0, 0): 2.0 / 16.
    assert_eq!(se[2 * w + 2], 2.0 / 16.0);
    assert_eq!(se[1], 2.0 / 16.0);
    // Outside it: provably nothing to scale by.
    assert_eq!(se[3 * w + 3], 0.0);
    assert_eq!(se[7], 0.0);
    // The lit pixel keeps its per-sample standard error: sd 2·sqrt(16/15), /4.
    assert!((se[0] - 2.0 * (16.0f64 / 15.0).sqrt() / 4.0).abs() < 1e-12);
}

/// `n` samples alternating between `lo` and `hi` (mean (lo+hi)/2,
/// per-sample sd |hi−lo|/2·√(n/(n−1))).
fn two_level(n: u32, lo: f64, hi: f64) -> PixelEstimate {
    let mut e = PixelEstimate::new(1, 1, 0);
    for k in 0..n {
        let v = if k % 2 == 0 { hi } else { lo };
        e.add(&[v], &[v], None);
    }
    e
}

/// The Lagrange multiplier comes from the lit pixels that see no
/// emitter: with them at the target, an all-zero pixel whose bound is
/// far above it grows on its own (4×) and nothing else gets samples;
/// an emitter pixel never does. The lit pixels' counts follow
/// n_i = s_i Σs_j / (N E²) when they are above it.
#[test]
fn allocation_leaves_dark_and_emitter_pixels_out_of_the_multiplier() {
    // Lit pixels: 16 samples of 0.9/1.1, relative error 0.1/√15·√… —
    // use their stated rel directly.
    let mut ests: Vec<PixelEstimate> = (0..8).map(|_| two_level(16, 0.9, 1.1)).collect();
    ests.push(two_level(16, 0.0, 0.0)); // all zero
    let mut em = two_level(4, 0.0, 1000.0);
    em.sees_emitter = true;
    ests.push(em);
    let rel_lit = ests[0].std_error(0) / ests[0].mean(0);
    // The dark pixel's bound: 5× the target; the emitter pixel's: huge.
    let target = rel_lit;
    let mut rel = vec![rel_lit; 8];
    rel.push(5.0 * target);
    rel.push(10.0);
    let work = allocate(&ests, &rel, target, 1024, 1.0);
    assert_eq!(work, vec![(8, 48)]); // 16 → 64 = DARK_MAX_SPP
    // Lit pixels at twice the target: each wants λ s_i with
    // λ = Σ s / (N E²), i.e. 4× its samples (capped at 4× per round).
    let rel2: Vec<f64> = rel
        .iter()
        .take(8)
        .map(|r| 2.0 * r)
        .chain([0.0, 10.0])
        .collect();
    let work = allocate(&ests, &rel2, target, 1024, 1.0);
    let want = (4.0f64 * 16.0 * 1.05).ceil().min(64.0) as u32 - 16;
    assert_eq!(work.len(), 8);
    assert!(
        work.iter().all(|&(i, add)| i < 8 && add == want),
        "{work:?}"
    );
}

/// A pixel with fewer than TRUSTED_SPP samples that all agree (a
/// penumbra pixel whose few shadow rays fell on one side) states the
/// RMS per-sample deviation of its 3 × 3 neighbourhood, not ~0; with
/// TRUSTED_SPP samples it states its own.
#[test]
fn few_agreeing_samples_borrow_the_neighbourhoods_deviation() {
    let w = 3;
    let mut ests: Vec<PixelEstimate> = (0..9).map(|_| two_level(4, 0.0, 2.0)).collect();
    ests[4] = two_level(4, 1.0, 1.0);
    let se = stated_std_errors(&ests, w, &[1.0; 9], &[0.0], true);
    // Neighbours: mean 1, per-sample sd √(4/3); RMS over the 9 pixels
    // (the centre's own is 0) = √(8/9 · 4/3); stated = that / √4.
    let want = (8.0 / 9.0 * 4.0 / 3.0f64).sqrt() / 2.0;
    assert!((se[4] - want).abs() < 1e-12, "{} vs {want}", se[4]);
    ests[4] = two_level(TRUSTED_SPP, 1.0, 1.0);
    let se = stated_std_errors(&ests, w, &[1.0; 9], &[0.0], true);
    assert_eq!(se[4], 0.0);
}
