//! Property tests of the solid-angle samplers: samples land on the emitter,
//! Monte Carlo with uniform solid-angle samples reproduces the closed-form
//! irradiance (within 5 standard errors), and the samplers' solid angles
//! equal `polygon_solid_angle`.

use glam::DVec3;
use gloam_trace::closed_form::{
    polygon_irradiance_factor, polygon_solid_angle, shaped_polygon_irradiance_factor,
};
use gloam_trace::sampling::{
    SphericalRectangle, SphericalTriangle, sample_parallelogram_area, sample_triangle_area,
};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

const SAMPLES: usize = 3000;

fn vec3(range: f64) -> impl Strategy<Value = DVec3> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn unit() -> impl Strategy<Value = DVec3> {
    vec3(1.0)
        .prop_filter("non-zero", |v| v.length() > 0.1)
        .prop_map(|v| v.normalize())
}

/// Barycentric coordinates of `q` in triangle (a, b, c).
fn barycentric(q: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let n = (b - a).cross(c - a);
    let nn = n.length_squared();
    let l1 = (c - b).cross(q - b).dot(n) / nn;
    let l2 = (a - c).cross(q - c).dot(n) / nn;
    [l1, l2, 1.0 - l1 - l2]
}

/// Ray from `p` along unit `d` against the plane of (a, b, c).
fn hit_plane(p: DVec3, d: DVec3, a: DVec3, b: DVec3, c: DVec3) -> Option<DVec3> {
    let n = (b - a).cross(c - a);
    let denom = n.dot(d);
    if denom == 0.0 {
        return None;
    }
    let t = n.dot(a - p) / denom;
    (t > 0.0).then(|| p + d * t)
}

/// Front normal of the emitter facing the point.
fn facing_normal(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let n = (b - a).cross(c - a).normalize();
    if n.dot(p - a) >= 0.0 { n } else { -n }
}

/// Mean and standard error of Ω·f over `SAMPLES` directions, and how many
/// samples were non-zero.
fn mc(omega: f64, mut draw: impl FnMut() -> f64) -> (f64, f64, usize) {
    let (mut s, mut s2, mut hits) = (0.0, 0.0, 0);
    for _ in 0..SAMPLES {
        let x = omega * draw();
        s += x;
        s2 += x * x;
        hits += usize::from(x != 0.0);
    }
    let n = SAMPLES as f64;
    let mean = s / n;
    let var = (s2 / n - mean * mean).max(0.0) * n / (n - 1.0);
    (mean, (var / n).sqrt(), hits)
}

/// Within 5 standard errors, plus a floor of 1e-5·Ω. The normal
/// approximation needs enough non-zero samples: when fewer than 30 samples
/// hit the part of the emitter above the receiver's horizon (a thin sliver),
/// the sample s.e. is meaningless and only the sign/finiteness is checked.
fn within_5se(est: (f64, f64, usize), exact: f64, omega: f64) -> bool {
    if est.2 < 30 {
        return est.0.is_finite() && est.0 >= 0.0 && exact >= 0.0;
    }
    (est.0 - exact).abs() <= 5.0 * est.1 + 1e-5 * omega
}

/// Fixed seed (reproducible CI); `GLOAM_PROPTEST_SEED` / `GLOAM_PROPTEST_CASES`
/// explore further.
fn config() -> ProptestConfig {
    let env = |k: &str| std::env::var(k).ok().and_then(|s| s.parse::<u64>().ok());
    ProptestConfig {
        cases: env("GLOAM_PROPTEST_CASES").unwrap_or(128) as u32,
        rng_seed: RngSeed::Fixed(env("GLOAM_PROPTEST_SEED").unwrap_or(0x676c_6f61_6d00)),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn triangle_samples_are_uniform_inside_and_unbiased(
        a in vec3(1.0), b in vec3(1.0), c in vec3(1.0),
        p in vec3(2.0), n in unit(), seed in any::<u64>(),
    ) {
        let tri = SphericalTriangle::new(p, a, b, c);
        prop_assume!(tri.is_some());
        let tri = tri.unwrap();
        let omega = tri.solid_angle();
        // (3) solid angle equals the closed form.
        let exact_omega = polygon_solid_angle(p, &[a, b, c]);
        prop_assert!((omega - exact_omega).abs() <= 1e-12 * exact_omega);
        let ne = facing_normal(p, a, b, c);
        let mut rng = Pcg64::seed_from_u64(seed);
        let draw = |rng: &mut Pcg64| {
            let u = [rng.random::<f64>(), rng.random::<f64>()];
            tri.sample(u)
        };
        // (1) every sample is a unit direction hitting the triangle.
        let corners = [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0], [0.5, 0.5]];
        for i in 0..200 {
            let d = if i < corners.len() { tri.sample(corners[i]) } else { draw(&mut rng) };
            prop_assert!((d.length() - 1.0).abs() < 1e-12);
            let q = hit_plane(p, d, a, b, c);
            prop_assert!(q.is_some(), "direction {d} misses the plane");
            let l = barycentric(q.unwrap(), a, b, c);
            // Placement is good to ~1e-8 rad (the inverse-cosine steps), i.e. to
            // ~1e-6 of the triangle's size at the 1e-6 sr threshold.
            prop_assert!(l.iter().all(|&x| x > -1e-5), "barycentrics {l:?}, Ω = {omega}");
        }
        // (2) Ω·mean(cos θ_r) reproduces Lambert's formula, and Ω·mean(cos θ_e^3 cos θ_r)
        // the m = 3 double-axis moment.
        let lambert = polygon_irradiance_factor(p, n, &[a, b, c], ne);
        let est = mc(omega, || n.dot(draw(&mut rng)).max(0.0));
        prop_assert!(within_5se(est, lambert, omega), "MC {est:?} vs closed {lambert}, Ω = {omega}");
        let shaped = shaped_polygon_irradiance_factor(p, n, &[a, b, c], ne, 3);
        let est = mc(omega, || {
            let d = draw(&mut rng);
            (-ne.dot(d)).max(0.0).powi(3) * n.dot(d).max(0.0)
        });
        prop_assert!(within_5se(est, shaped, omega), "MC {est:?} vs closed m=3 {shaped}");
    }

    #[test]
    fn rectangle_samples_are_uniform_inside_and_unbiased(
        corner in vec3(1.0), ex in vec3(1.0), dir in vec3(1.0), ey_len in 0.05..1.5f64,
        p in vec3(2.0), n in unit(), seed in any::<u64>(),
    ) {
        prop_assume!(ex.length() > 0.05);
        let ey = ex.cross(dir).try_normalize();
        prop_assume!(ey.is_some());
        let ey = ey.unwrap() * ey_len;
        let rect = SphericalRectangle::new(p, corner, ex, ey);
        prop_assume!(rect.is_some());
        let rect = rect.unwrap();
        let verts = [corner, corner + ex, corner + ex + ey, corner + ey];
        let omega = rect.solid_angle();
        let exact_omega = polygon_solid_angle(p, &verts);
        prop_assert!((omega - exact_omega).abs() <= 1e-12 * exact_omega);
        let ne = facing_normal(p, verts[0], verts[1], verts[2]);
        let mut rng = Pcg64::seed_from_u64(seed);
        let size = ex.length().max(ey_len);
        // (1) samples lie on the rectangle.
        for i in 0..200 {
            let u = if i < 4 {
                [(i & 1) as f64, (i >> 1) as f64]
            } else {
                [rng.random::<f64>(), rng.random::<f64>()]
            };
            let q = rect.sample(u);
            let r = q - corner;
            let off_plane = r.dot(ne).abs();
            let s = r.dot(ex) / ex.length_squared();
            let t = r.dot(ey) / ey.length_squared();
            prop_assert!(off_plane < 1e-9 * size, "off plane by {off_plane}");
            prop_assert!((-1e-5..=1.0 + 1e-5).contains(&s) && (-1e-5..=1.0 + 1e-5).contains(&t),
                "local coords ({s}, {t}), Ω = {omega}");
        }
        // (2) unbiased irradiance estimates.
        let dir_of = |q: DVec3| (q - p).normalize();
        let lambert = polygon_irradiance_factor(p, n, &verts, ne);
        let est = mc(omega, || {
            let u = [rng.random::<f64>(), rng.random::<f64>()];
            n.dot(dir_of(rect.sample(u))).max(0.0)
        });
        prop_assert!(within_5se(est, lambert, omega), "MC {est:?} vs closed {lambert}, Ω = {omega}");
        let shaped = shaped_polygon_irradiance_factor(p, n, &verts, ne, 3);
        let est = mc(omega, || {
            let d = dir_of(rect.sample([rng.random::<f64>(), rng.random::<f64>()]));
            (-ne.dot(d)).max(0.0).powi(3) * n.dot(d).max(0.0)
        });
        prop_assert!(within_5se(est, shaped, omega), "MC {est:?} vs closed m=3 {shaped}");
    }

    #[test]
    fn area_samplers_stay_inside_and_average_to_the_centroid(
        a in vec3(1.0), b in vec3(1.0), c in vec3(1.0), seed in any::<u64>(),
    ) {
        prop_assume!((b - a).cross(c - a).length() > 1e-3);
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut sum = DVec3::ZERO;
        let n = 2000;
        for _ in 0..n {
            let q = sample_triangle_area(a, b, c, [rng.random(), rng.random()]);
            let l = barycentric(q, a, b, c);
            prop_assert!(l.iter().all(|&x| x > -1e-9));
            sum += q;
        }
        let mean = sum / n as f64;
        let centroid = (a + b + c) / 3.0;
        // Each coordinate's s.d. is below the triangle's extent / √12·…; use a loose 5σ bound.
        let extent = (a - b).length().max((b - c).length()).max((c - a).length());
        prop_assert!((mean - centroid).length() < 5.0 * extent / (n as f64).sqrt());
        let q = sample_parallelogram_area(a, b - a, c - a, [0.25, 0.5]);
        prop_assert!((q - (a + (b - a) * 0.25 + (c - a) * 0.5)).length() < 1e-12);
    }
}

#[test]
fn near_two_pi_and_degenerate_samplers() {
    // Point 1e-6 in front of a big triangle's interior: Ω close to 2π, samples fine.
    let (a, b, c) = (
        DVec3::new(-10.0, -10.0, 0.0),
        DVec3::new(10.0, -10.0, 0.0),
        DVec3::new(0.0, 10.0, 0.0),
    );
    let p = DVec3::new(0.0, 0.0, 1e-6);
    let tri = SphericalTriangle::new(p, a, b, c).expect("near-2π triangle");
    assert!((tri.solid_angle() - 2.0 * std::f64::consts::PI).abs() < 1e-5);
    let rect = SphericalRectangle::new(
        p,
        DVec3::new(-10.0, -10.0, 0.0),
        DVec3::X * 20.0,
        DVec3::Y * 20.0,
    )
    .expect("near-2π rectangle");
    let mut rng = Pcg64::seed_from_u64(7);
    let n = -DVec3::Z;
    let (mut st, mut sr) = (0.0, 0.0);
    let k = 20_000;
    for _ in 0..k {
        let d = tri.sample([rng.random(), rng.random()]);
        assert!(d.z < 0.0 && d.is_finite());
        st += n.dot(d);
        let q = rect.sample([rng.random(), rng.random()]);
        assert!(
            q.is_finite()
                && q.z.abs() < 1e-9
                && q.x.abs() <= 10.0 + 1e-9
                && q.y.abs() <= 10.0 + 1e-9
        );
        sr += n.dot((q - p).normalize());
    }
    let est_t = tri.solid_angle() * st / k as f64;
    let est_r = rect.solid_angle() * sr / k as f64;
    let exact_t = polygon_irradiance_factor(p, n, &[a, b, c], DVec3::Z);
    let exact_r = polygon_irradiance_factor(
        p,
        n,
        &[
            DVec3::new(-10.0, -10.0, 0.0),
            DVec3::new(10.0, -10.0, 0.0),
            DVec3::new(10.0, 10.0, 0.0),
            DVec3::new(-10.0, 10.0, 0.0),
        ],
        DVec3::Z,
    );
    // cos θ_r has s.d. ≈ 0.24 over a hemisphere: 5 s.e. ≈ 2π·0.24·5/√k.
    let tol = 2.0 * std::f64::consts::PI * 0.24 * 5.0 / (k as f64).sqrt();
    assert!((est_t - exact_t).abs() < tol, "{est_t} {exact_t}");
    assert!((est_r - exact_r).abs() < tol, "{est_r} {exact_r}");
    // Degenerate geometry: None, so the caller falls back to area sampling.
    assert!(SphericalTriangle::new(DVec3::new(0.0, 0.0, 0.0), a, b, c).is_none()); // in plane
    assert!(SphericalTriangle::new(a, a, b, c).is_none()); // on a vertex
    assert!(SphericalTriangle::new(p, a, a, c).is_none()); // collapsed edge
    assert!(SphericalTriangle::new(DVec3::new(0.0, 0.0, 1e6), a, b, c).is_none()); // Ω ≈ 3e-10
    assert!(SphericalRectangle::new(p, a, DVec3::X, DVec3::new(1.0, 1.0, 0.0)).is_none()); // not ⟂
    assert!(SphericalRectangle::new(p, a, DVec3::ZERO, DVec3::Y).is_none());
    assert!(SphericalRectangle::new(DVec3::new(1e6, 0.0, 1.0), a, DVec3::X, DVec3::Y).is_none());
}

#[test]
fn far_from_origin_small_emitters_sample_inside() {
    // 1e5 units from the origin, 1 cm emitters at 20 cm: samples stay on them.
    let off = DVec3::new(1e5, -1e5, 1e5);
    let p = off + DVec3::new(0.01, 0.02, 0.2);
    let (a, b, c) = (
        off,
        off + DVec3::new(0.01, 0.0, 0.0),
        off + DVec3::new(0.0, 0.01, 0.0),
    );
    let tri = SphericalTriangle::new(p, a, b, c).expect("small but above threshold");
    let rect = SphericalRectangle::new(p, a, DVec3::X * 0.01, DVec3::Y * 0.01).expect("rect");
    let mut rng = Pcg64::seed_from_u64(11);
    for _ in 0..2000 {
        let d = tri.sample([rng.random(), rng.random()]);
        let q = hit_plane(p, d, a, b, c).unwrap();
        let l = barycentric(q, a, b, c);
        assert!(l.iter().all(|&x| x > -1e-6), "{l:?}");
        let q = rect.sample([rng.random(), rng.random()]);
        let r = q - a;
        assert!(
            r.z.abs() < 1e-9
                && (-1e-9..=0.01 + 1e-9).contains(&r.x)
                && (-1e-9..=0.01 + 1e-9).contains(&r.y)
        );
    }
}

#[test]
fn points_next_to_an_edge_are_sampled_without_bias() {
    // Hit points 1e-4 … 1e-9 from an emitter edge (above it, just outside,
    // above the interior): the vertex directions are antipodal to rounding.
    let (a, b, c) = (
        DVec3::new(-1.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 1.5, 0.0),
    );
    let rect = [
        a,
        a + DVec3::X * 2.0,
        a + DVec3::X * 2.0 + DVec3::Y * 1.5,
        a + DVec3::Y * 1.5,
    ];
    let n = -DVec3::Z;
    let mut rng = Pcg64::seed_from_u64(5);
    let k = 40_000;
    for &h in &[1e-4, 1e-6, 1e-9] {
        for &p in &[
            DVec3::new(0.1, 0.0, h),
            DVec3::new(0.0, -h, h),
            DVec3::new(-0.3, -1e-6, h),
            DVec3::new(0.5, 0.7499, h),
        ] {
            let tri = SphericalTriangle::new(p, a, b, c).expect("triangle sampler");
            let (mut s, mut s2) = (0.0, 0.0);
            for _ in 0..k {
                let f = n.dot(tri.sample([rng.random(), rng.random()])).max(0.0);
                s += f;
                s2 += f * f;
            }
            let (mean, var) = (s / k as f64, s2 / k as f64 - (s / k as f64).powi(2));
            let se = tri.solid_angle() * (var.max(0.0) / k as f64).sqrt();
            let exact = polygon_irradiance_factor(p, n, &[a, b, c], DVec3::Z);
            let dev = (tri.solid_angle() * mean - exact) / se;
            assert!(dev.abs() < 5.0, "triangle h={h} p={p}: {dev} s.e.");
            let r = SphericalRectangle::new(p, a, DVec3::X * 2.0, DVec3::Y * 1.5).expect("rect");
            let (mut s, mut s2) = (0.0, 0.0);
            for _ in 0..k {
                let q = r.sample([rng.random(), rng.random()]);
                let f = n.dot((q - p).normalize()).max(0.0);
                s += f;
                s2 += f * f;
            }
            let (mean, var) = (s / k as f64, s2 / k as f64 - (s / k as f64).powi(2));
            let se = r.solid_angle() * (var.max(0.0) / k as f64).sqrt();
            let exact = polygon_irradiance_factor(p, n, &rect, DVec3::Z);
            let dev = (r.solid_angle() * mean - exact) / se;
            assert!(dev.abs() < 5.0, "rectangle h={h} p={p}: {dev} s.e.");
        }
    }
    // 1e-12 from the plane: below MIN_RELATIVE_HEIGHT, the caller area-samples.
    let p = DVec3::new(0.1, 0.2, 1e-12);
    assert!(SphericalTriangle::new(p, a, b, c).is_none());
    assert!(SphericalRectangle::new(p, a, DVec3::X * 2.0, DVec3::Y * 1.5).is_none());
}
