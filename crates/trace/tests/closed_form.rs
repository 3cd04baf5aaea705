//! Closed-form irradiance against independent answers: 2D Gauss–Legendre
//! quadrature of `∫ L cos^m θ_e cos θ_r / R² dA` over the emitter area,
//! analytic limits (edge, corner, collimated beam), and exact solid angles.
//!
//! Each comparison prints its measured error (`cargo test -- --nocapture`).

use glam::DVec3;
use gloam_trace::closed_form::{
    point_source_irradiance, polygon_irradiance_factor, polygon_solid_angle,
    rectangle_center_irradiance, shaped_polygon_irradiance_factor,
};
use std::f64::consts::PI;

// ---------------------------------------------------------------- quadrature

/// Gauss–Legendre nodes and weights on [0, 1] (Newton on P_n).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let kf = k as f64;
                let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        out.push((0.5 * (x + 1.0), 0.5 * w));
    }
    out
}

/// Composite rule on [0,1]: `panels` equal panels of `order`-point GL.
fn composite(panels: usize, order: usize) -> Vec<(f64, f64)> {
    let gl = gauss_legendre(order);
    let h = 1.0 / panels as f64;
    (0..panels)
        .flat_map(|p| gl.iter().map(move |&(x, w)| ((p as f64 + x) * h, w * h)))
        .collect()
}

/// ∫_triangle f dA by the Duffy map x = a + s(b−a) + s t (c−b), dA = s |(b−a)×(c−b)| ds dt.
fn integrate_triangle(
    a: DVec3,
    b: DVec3,
    c: DVec3,
    panels: usize,
    f: &dyn Fn(DVec3) -> f64,
) -> f64 {
    let rule = composite(panels, 10);
    let jac = (b - a).cross(c - b).length();
    let mut sum = 0.0;
    for &(s, ws) in &rule {
        for &(t, wt) in &rule {
            let x = a + (b - a) * s + (c - b) * (s * t);
            sum += ws * wt * s * f(x);
        }
    }
    sum * jac
}

/// ∫_polygon f dA over a convex polygon (fan of triangles).
fn integrate_polygon(verts: &[DVec3], panels: usize, f: &dyn Fn(DVec3) -> f64) -> f64 {
    (1..verts.len() - 1)
        .map(|i| integrate_triangle(verts[0], verts[i], verts[i + 1], panels, f))
        .sum()
}

/// Brute-force ∫ cos^m θ_e · cos θ_e max(cos θ_r, 0) / R² dA over the emitter.
fn brute_force(p: DVec3, n: DVec3, verts: &[DVec3], ne: DVec3, m: i32, panels: usize) -> f64 {
    let n = n.normalize();
    let ne = ne.normalize();
    integrate_polygon(verts, panels, &|x| {
        let d = x - p;
        let r2 = d.length_squared();
        let r = r2.sqrt();
        let cos_e = ne.dot(-d) / r;
        let cos_r = n.dot(d) / r;
        if cos_e <= 0.0 || cos_r <= 0.0 {
            return 0.0;
        }
        // dω = cos θ_e dA / R², times the shape cos^m θ_e.
        cos_e.powi(m + 1) * cos_r / r2
    })
}

/// Independent Sutherland–Hodgman clip of a polygon to `n·(x − p) ≥ 0`
/// (so quadrature does not integrate across the receiver-horizon kink).
fn clip(verts: &[DVec3], p: DVec3, n: DVec3) -> Vec<DVec3> {
    let mut out = Vec::new();
    for i in 0..verts.len() {
        let (a, b) = (verts[i], verts[(i + 1) % verts.len()]);
        let (da, db) = (n.dot(a - p), n.dot(b - p));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

fn rel_err(got: f64, want: f64) -> f64 {
    (got - want).abs() / want.abs()
}

fn square(cx: f64, cy: f64, half: f64) -> Vec<DVec3> {
    vec![
        DVec3::new(cx - half, cy - half, 0.0),
        DVec3::new(cx + half, cy - half, 0.0),
        DVec3::new(cx + half, cy + half, 0.0),
        DVec3::new(cx - half, cy + half, 0.0),
    ]
}

/// Factor for a point at height c above the corner of an a×b rectangle,
/// receiver parallel (Howell C-11 corner form: F·π).
fn corner_factor(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    0.5 * (x / sx * (y / sx).atan() + y / sy * (x / sy).atan())
}

// ------------------------------------------------------------------ panels

#[test]
fn rectangle_closed_form_matches_quadrature() {
    for &(x, y, r) in &[
        (1.0, 1.0, 1.0),
        (2.0, 0.5, 0.3),
        (10.0, 3.0, 0.2),
        (0.01, 0.02, 5.0),
        (1e3, 1e3, 1.0),
    ] {
        let closed = rectangle_center_irradiance(1.0, x, y, r);
        // r² ∫∫ 1/(r²+x²+y²)² over the quarter, ×4, with panels graded
        // geometrically towards the centre where the integrand peaks.
        let edges = |len: f64| {
            let mut e = vec![0.0];
            let mut h = (r * 0.05).min(len / 8.0);
            while *e.last().unwrap() < len {
                let next = (e.last().unwrap() + h).min(len);
                e.push(next);
                h *= 1.3;
            }
            e
        };
        let gl = gauss_legendre(12);
        let rule = |len: f64| {
            let e = edges(len);
            e.windows(2)
                .flat_map(|w| {
                    let (lo, hi) = (w[0], w[1]);
                    gl.iter()
                        .map(move |&(t, wt)| (lo + (hi - lo) * t, wt * (hi - lo)))
                })
                .collect::<Vec<_>>()
        };
        let (rx, ry) = (rule(x / 2.0), rule(y / 2.0));
        let mut q = 0.0;
        for &(u, wu) in &rx {
            for &(v, wv) in &ry {
                let s = r * r + u * u + v * v;
                q += wu * wv / (s * s);
            }
        }
        q *= 4.0 * r * r;
        let e = rel_err(closed, q);
        println!(
            "rectangle centre x={x} y={y} r={r}: closed {closed:.15} quad {q:.15} rel {e:.1e}"
        );
        assert!(e < 1e-11, "rel err {e}");
    }
    // Infinite plane limit: πL.
    assert!(rel_err(rectangle_center_irradiance(2.0, 1e12, 1e12, 1.0), 2.0 * PI) < 1e-10);
    assert_eq!(rectangle_center_irradiance(1.0, 0.0, 1.0, 1.0), 0.0);
    assert!(rel_err(rectangle_center_irradiance(1.0, 1.0, 1.0, 0.0), PI) < 1e-15);
}

#[test]
fn lambert_polygon_matches_rectangle_closed_form() {
    for &(x, y, r) in &[
        (1.0, 1.0, 1.0),
        (2.0, 0.5, 0.3),
        (10.0, 3.0, 0.2),
        (0.01, 0.02, 5.0),
    ] {
        let verts = [
            DVec3::new(-x / 2.0, -y / 2.0, 0.0),
            DVec3::new(x / 2.0, -y / 2.0, 0.0),
            DVec3::new(x / 2.0, y / 2.0, 0.0),
            DVec3::new(-x / 2.0, y / 2.0, 0.0),
        ];
        let p = DVec3::new(0.0, 0.0, r);
        let f = polygon_irradiance_factor(p, -DVec3::Z, &verts, DVec3::Z);
        let want = rectangle_center_irradiance(1.0, x, y, r);
        let e = rel_err(f, want);
        println!("Lambert vs panel closed form {x}x{y} at {r}: rel {e:.1e}");
        assert!(e < 1e-13);
        // Either winding, shaped m = 0 identical.
        let rev: Vec<DVec3> = verts.iter().rev().copied().collect();
        assert!(
            rel_err(
                polygon_irradiance_factor(p, -DVec3::Z, &rev, DVec3::Z),
                want
            ) < 1e-13
        );
        assert_eq!(
            shaped_polygon_irradiance_factor(p, -DVec3::Z, &verts, DVec3::Z, 0),
            f
        );
    }
}

// ------------------------------------------------- tilted / off-axis / shaped

struct Case {
    name: &'static str,
    p: DVec3,
    n: DVec3,
    verts: Vec<DVec3>,
    ne: DVec3,
}

fn cases() -> Vec<Case> {
    // A tilted quad in a general plane, and triangles.
    let quad_c = DVec3::new(0.2, -0.1, 0.3);
    let u = DVec3::new(1.0, 0.2, 0.1).normalize();
    let ne_q = u.cross(DVec3::new(0.1, 1.0, -0.3)).normalize();
    let v = ne_q.cross(u);
    let quad = vec![
        quad_c - u * 0.6 - v * 0.4,
        quad_c + u * 0.6 - v * 0.4,
        quad_c + u * 0.6 + v * 0.4,
        quad_c - u * 0.6 + v * 0.4,
    ];
    let tri = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.5, 0.2, 0.0),
        DVec3::new(0.3, 1.1, 0.0),
    ];
    vec![
        Case {
            name: "square, tilted receiver above",
            p: DVec3::new(0.1, 0.2, 1.2),
            n: DVec3::new(0.3, -0.2, -1.0),
            verts: square(0.0, 0.0, 0.5),
            ne: DVec3::Z,
        },
        Case {
            name: "square, point off to the side",
            p: DVec3::new(2.0, 0.7, 0.8),
            n: DVec3::new(-1.0, -0.3, -0.4),
            verts: square(0.0, 0.0, 0.5),
            ne: DVec3::Z,
        },
        Case {
            name: "triangle, off to the side, tilted",
            p: DVec3::new(-0.8, 1.5, 0.6),
            n: DVec3::new(0.7, -0.6, -0.5),
            verts: tri.clone(),
            ne: DVec3::Z,
        },
        Case {
            name: "triangle, reversed winding, above",
            p: DVec3::new(0.5, 0.4, 0.7),
            n: DVec3::new(0.0, 0.2, -1.0),
            verts: tri.iter().rev().copied().collect(),
            ne: DVec3::Z,
        },
        Case {
            name: "tilted quad in a general plane",
            p: quad_c + ne_q * 0.9 + u * 0.5 + v * 0.2,
            n: -ne_q + u * 0.4,
            verts: quad,
            ne: ne_q,
        },
    ]
}

#[test]
fn lambert_and_shaped_match_brute_force_quadrature() {
    for c in cases() {
        for &m in &[0u32, 1, 2, 5, 20] {
            let got = shaped_polygon_irradiance_factor(c.p, c.n, &c.verts, c.ne, m);
            let want = brute_force(c.p, c.n, &c.verts, c.ne, m as i32, 24);
            let e = rel_err(got, want);
            println!(
                "{} m={m}: closed {got:.12e} quad {want:.12e} rel {e:.1e}",
                c.name
            );
            assert!(want > 0.0);
            // 1e-10 relative, except where the axis is far outside the polygon
            // and the recurrence cancels: there the absolute error stays below
            // 1e-14 of the unshaped (m = 0) factor.
            let f0 = polygon_irradiance_factor(c.p, c.n, &c.verts, c.ne);
            assert!(
                (got - want).abs() < 1e-10 * want + 1e-14 * f0,
                "{} m={m}: rel err {e}",
                c.name
            );
            if m == 0 {
                assert_eq!(got, polygon_irradiance_factor(c.p, c.n, &c.verts, c.ne));
            }
        }
    }
}

#[test]
fn receiver_horizon_clips_the_emitter() {
    // Grazing receivers whose tangent plane slices through the emitter.
    let verts = square(0.0, 0.0, 1.0);
    for &(n, m) in &[
        (DVec3::new(1.0, 0.0, -0.05), 0u32),
        (DVec3::new(1.0, 0.3, -0.2), 3),
        (DVec3::new(0.0, -1.0, 1e-3), 1),
        (DVec3::new(1.0, 1.0, 0.0), 10),
    ] {
        let p = DVec3::new(0.1, -0.2, 0.5);
        let got = shaped_polygon_irradiance_factor(p, n, &verts, DVec3::Z, m);
        let clipped = clip(&verts, p, n.normalize());
        let want = brute_force(p, n, &clipped, DVec3::Z, m as i32, 48);
        let e = rel_err(got, want);
        println!("horizon clip n={n} m={m}: closed {got:.12e} quad {want:.12e} rel {e:.1e}");
        assert!(e < 1e-9);
    }
    // Emitter entirely below the horizon: 0.
    let p = DVec3::new(0.0, 0.0, 1.0);
    assert_eq!(
        polygon_irradiance_factor(p, DVec3::Z, &verts, DVec3::Z),
        0.0
    );
}

#[test]
fn grazing_emission_point_just_above_emitter_plane() {
    // Point 1e-3 above the emitter's plane, beside it: almost edge-on.
    let verts = square(0.0, 0.0, 1.0);
    for &(h, m) in &[(1e-3, 0u32), (1e-3, 2), (1e-2, 5)] {
        let p = DVec3::new(3.0, 0.4, h);
        let n = DVec3::new(-1.0, 0.0, -0.1);
        let got = shaped_polygon_irradiance_factor(p, n, &verts, DVec3::Z, m);
        let want = brute_force(p, n, &verts, DVec3::Z, m as i32, 24);
        let e = rel_err(got, want);
        println!("grazing emission h={h} m={m}: closed {got:.12e} quad {want:.12e} rel {e:.1e}");
        // Cancellation regime (axis far outside): bounded absolute error.
        let f0 = polygon_irradiance_factor(p, n, &verts, DVec3::Z);
        assert!(got.is_finite() && (got - want).abs() < 1e-9 * want + 1e-14 * f0);
    }
}

// ------------------------------------------------------------- hard cases

#[test]
fn receiver_in_or_behind_the_emitter_plane_gets_nothing() {
    let verts = square(0.0, 0.0, 1.0);
    for &p in &[
        DVec3::new(3.0, 0.0, 0.0),  // in the plane, beside
        DVec3::new(0.2, 0.1, 0.0),  // on the emitter
        DVec3::new(1.0, 0.0, 0.0),  // on an edge
        DVec3::new(1.0, 1.0, 0.0),  // on a corner
        DVec3::new(0.0, 0.0, -1.0), // behind
    ] {
        for &n in &[-DVec3::Z, DVec3::Z, DVec3::X, -DVec3::X] {
            for &m in &[0u32, 1, 7, 10_000] {
                let f = shaped_polygon_irradiance_factor(p, n, &verts, DVec3::Z, m);
                assert_eq!(f, 0.0, "p={p} n={n} m={m}");
            }
        }
    }
    // Degenerate input: no panic, zero.
    assert_eq!(
        polygon_irradiance_factor(DVec3::Z, -DVec3::Z, &verts[..2], DVec3::Z),
        0.0
    );
    assert_eq!(
        polygon_irradiance_factor(DVec3::Z, DVec3::ZERO, &verts, DVec3::Z),
        0.0
    );
    let collinear = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
    assert_eq!(
        polygon_irradiance_factor(DVec3::Z, -DVec3::Z, &collinear, DVec3::Z),
        0.0
    );
}

#[test]
fn point_on_or_next_to_an_edge_gives_the_correct_limit() {
    // 2×2 square, receiver facing it, point at height ε above an edge midpoint
    // (exact: two 1×2 corner rectangles), above a corner (one 2×2 corner), and
    // above the interior. As ε → 0 these tend to π/2, π/4 and π.
    let verts = square(0.0, 0.0, 1.0);
    for &eps in &[1e-6, 1e-9, 1e-12] {
        let edge =
            polygon_irradiance_factor(DVec3::new(1.0, 0.0, eps), -DVec3::Z, &verts, DVec3::Z);
        let want_edge = 2.0 * corner_factor(1.0, 2.0, eps);
        let corner =
            polygon_irradiance_factor(DVec3::new(1.0, 1.0, eps), -DVec3::Z, &verts, DVec3::Z);
        let want_corner = corner_factor(2.0, 2.0, eps);
        let inside =
            polygon_irradiance_factor(DVec3::new(0.3, 0.2, eps), -DVec3::Z, &verts, DVec3::Z);
        let want_inside = corner_factor(1.3, 1.2, eps)
            + corner_factor(0.7, 1.2, eps)
            + corner_factor(1.3, 0.8, eps)
            + corner_factor(0.7, 0.8, eps);
        let (e1, e2, e3) = (
            rel_err(edge, want_edge),
            rel_err(corner, want_corner),
            rel_err(inside, want_inside),
        );
        println!(
            "ε={eps:e}: edge {edge:.15} (rel {e1:.1e}), corner {corner:.15} (rel {e2:.1e}), inside {inside:.15} (rel {e3:.1e})"
        );
        assert!(e1 < 1e-9 && e2 < 1e-9 && e3 < 1e-12);
        assert!((edge - PI / 2.0).abs() < 10.0 * eps + 1e-12);
        assert!((corner - PI / 4.0).abs() < 10.0 * eps + 1e-12);
        // Shaped emitter: receiver normal along the axis, so the limit is
        // ∫_{half/quarter hemisphere} cos^{m+1} = π/(m+2), π/(2(m+2)).
        for &m in &[1u32, 3, 50] {
            let mf = m as f64;
            let e = shaped_polygon_irradiance_factor(
                DVec3::new(1.0, 0.0, eps),
                -DVec3::Z,
                &verts,
                DVec3::Z,
                m,
            );
            let c = shaped_polygon_irradiance_factor(
                DVec3::new(-1.0, 1.0, eps),
                -DVec3::Z,
                &verts,
                DVec3::Z,
                m,
            );
            println!(
                "  m={m}: edge rel {:.1e}, corner rel {:.1e}",
                rel_err(e, PI / (mf + 2.0)),
                rel_err(c, PI / (2.0 * (mf + 2.0)))
            );
            assert!(rel_err(e, PI / (mf + 2.0)) < 1e-5);
            assert!(rel_err(c, PI / (2.0 * (mf + 2.0))) < 1e-5);
        }
    }
}

#[test]
fn point_just_outside_an_edge() {
    // Point δ beyond the edge x = 1 of the 2×2 square, at height h, facing
    // down: the panel is [−1, 1+δ] minus [1, 1+δ] seen from the corner line.
    let verts = square(0.0, 0.0, 1.0);
    for &(d, h) in &[(1e-6, 1e-6), (1e-6, 1e-3), (1e-3, 1e-6), (1e-9, 1e-9)] {
        let p = DVec3::new(1.0 + d, 0.0, h);
        let got = polygon_irradiance_factor(p, -DVec3::Z, &verts, DVec3::Z);
        let d = p.x - 1.0; // the offset actually represented (exact subtraction)
        let want = 2.0 * (corner_factor(2.0 + d, 1.0, h) - corner_factor(d, 1.0, h));
        let e = rel_err(got, want);
        println!("δ={d:e} outside the edge, h={h:e}: {got:.12e} vs {want:.12e} rel {e:.1e}");
        assert!(got.is_finite() && e < 1e-8, "{e}");
        // In the plane just beside the edge: edge-on, nothing.
        let q = DVec3::new(1.0 + d, 0.0, 0.0);
        assert_eq!(
            polygon_irradiance_factor(q, -DVec3::Z, &verts, DVec3::Z),
            0.0
        );
    }
}

#[test]
fn huge_exponent_is_finite_and_collimated() {
    let m = 10_000u32;
    let mf = m as f64;
    let verts = square(0.0, 0.0, 2.0);
    // Axis through the point hits the panel well inside: 2π (n·w)/(m+2).
    let n = DVec3::new(0.3, 0.1, -1.0).normalize();
    let p = DVec3::new(0.3, -0.2, 1.0);
    let got = shaped_polygon_irradiance_factor(p, n, &verts, DVec3::Z, m);
    let want = 2.0 * PI * n.dot(-DVec3::Z) / (mf + 2.0);
    let e = rel_err(got, want);
    println!("m=1e4 interior: {got:.15e} collimated {want:.15e} rel {e:.1e}");
    assert!(e < 1e-10);
    // Quadrature over a window around the beam (integrand < e^-100 outside).
    let window = |cx: f64, cy: f64| {
        let w = square(cx, cy, 0.15);
        // intersect with the panel [-2,2]² (clip four times)
        let mut poly = w;
        for (pp, nn) in [
            (DVec3::new(-2.0, 0.0, 0.0), DVec3::X),
            (DVec3::new(2.0, 0.0, 0.0), -DVec3::X),
            (DVec3::new(0.0, -2.0, 0.0), DVec3::Y),
            (DVec3::new(0.0, 2.0, 0.0), -DVec3::Y),
        ] {
            poly = clip(&poly, pp, nn);
        }
        poly
    };
    for &(p, label) in &[
        (DVec3::new(0.3, -0.2, 1.0), "interior"),
        (DVec3::new(0.5, -2.0, 1.0), "over an edge"),
        (DVec3::new(2.0, 2.0, 1.0), "over a corner"),
        (DVec3::new(0.5, -2.003, 1.0), "beam misses by 3 mrad"),
        (DVec3::new(0.5, -1.99, 1.0), "beam 10 mrad inside an edge"),
    ] {
        let got = shaped_polygon_irradiance_factor(p, n, &verts, DVec3::Z, m);
        let want = brute_force(p, n, &window(p.x, p.y), DVec3::Z, m as i32, 60);
        let e = rel_err(got, want);
        println!("m=1e4 {label}: closed {got:.12e} quad {want:.12e} rel {e:.1e}");
        assert!(got.is_finite() && e < 1e-8, "{label}: {e}");
    }
    // Over an edge with the receiver along the axis: exactly half the beam.
    let got = shaped_polygon_irradiance_factor(
        DVec3::new(0.5, -2.0, 1.0),
        -DVec3::Z,
        &verts,
        DVec3::Z,
        m,
    );
    assert!(rel_err(got, PI / (mf + 2.0)) < 1e-10);
    // Beam misses by a wide margin: essentially nothing, and finite.
    let off =
        shaped_polygon_irradiance_factor(DVec3::new(5.0, 0.0, 1.0), -DVec3::X, &verts, DVec3::Z, m);
    println!("m=1e4 far miss: {off:e}");
    assert!(off.is_finite() && (0.0..1e-300).contains(&off));
    // m up to 10 000 everywhere finite and monotone non-increasing in m above the interior.
    let mut prev = f64::INFINITY;
    for m in [0u32, 1, 10, 100, 1000, 10_000] {
        let f = shaped_polygon_irradiance_factor(
            DVec3::new(0.1, 0.0, 1.0),
            -DVec3::Z,
            &verts,
            DVec3::Z,
            m,
        );
        assert!(f.is_finite() && f > 0.0 && f <= prev);
        prev = f;
    }
}

#[test]
fn missed_beams_stay_within_rigorous_bounds() {
    // Beam axis missing the 4×4 panel by `miss` at unit height: the result
    // must lie in [0, cos^m(atan miss) · D_0].
    let verts = square(0.0, 0.0, 2.0);
    let n = DVec3::new(0.3, 0.1, -1.0);
    for m in [20u32, 100, 1000, 10_000] {
        let mut prev = f64::INFINITY;
        for miss in [0.003, 0.01, 0.03, 0.1, 0.3, 1.0] {
            let p = DVec3::new(0.5, -2.0 - miss, 1.0);
            let f = shaped_polygon_irradiance_factor(p, n, &verts, DVec3::Z, m);
            let d0 = polygon_irradiance_factor(p, n, &verts, DVec3::Z);
            let bound = (1.0 / (1.0 + miss * miss)).sqrt().powi(m as i32) * d0;
            assert!(
                f.is_finite() && f >= 0.0 && f <= bound,
                "m={m} miss={miss}: {f} vs {bound}"
            );
            // Away from the rounding floor (~1e-17 D_0) it falls with the miss.
            if f > 1e-15 * d0 {
                assert!(f < prev, "m={m} miss={miss}");
            }
            prev = f;
        }
    }
}

#[test]
fn far_from_origin_with_small_panels() {
    let off = DVec3::new(1e5, -1e5, 1e5);
    let (sx, sy, r) = (0.01, 0.02, 0.05);
    let local = [
        DVec3::new(-sx / 2.0, -sy / 2.0, 0.0),
        DVec3::new(sx / 2.0, -sy / 2.0, 0.0),
        DVec3::new(sx / 2.0, sy / 2.0, 0.0),
        DVec3::new(-sx / 2.0, sy / 2.0, 0.0),
    ];
    let far: Vec<DVec3> = local.iter().map(|&v| v + off).collect();
    let p = DVec3::new(0.0, 0.0, r);
    let near_f = polygon_irradiance_factor(p, -DVec3::Z, &local, DVec3::Z);
    let far_f = polygon_irradiance_factor(p + off, -DVec3::Z, &far, DVec3::Z);
    let want = rectangle_center_irradiance(1.0, sx, sy, r);
    let e = rel_err(far_f, want);
    println!(
        "far from origin: rel {e:.1e} (at origin {:.1e})",
        rel_err(near_f, want)
    );
    assert!(e < 1e-8);
    // Shaped, tilted, off-axis: far copy vs brute force at the origin.
    let q = DVec3::new(0.03, -0.01, 0.04);
    let n = DVec3::new(-0.5, 0.2, -1.0);
    for m in [0u32, 5] {
        let got = shaped_polygon_irradiance_factor(q + off, n, &far, DVec3::Z, m);
        let want = brute_force(q, n, &local, DVec3::Z, m as i32, 16);
        let e = rel_err(got, want);
        println!("far from origin, off-axis m={m}: rel {e:.1e}");
        assert!(e < 1e-7);
    }
    let om = polygon_solid_angle(p + off, &far);
    let want_om = 4.0 * (sx * sy / 4.0 / (r * (r * r + (sx * sx + sy * sy) / 4.0).sqrt())).atan();
    assert!(rel_err(om, want_om) < 1e-8);
}

// ------------------------------------------------------------ solid angles

#[test]
fn solid_angle_of_square_tiny_and_near_two_pi() {
    let s = 1.0;
    // Brief's closed form Ω = 4 asin(s²/(s²+4d²)); the equivalent corner
    // form 4 atan(s²/(4 d √(d²+s²/2))) is used where asin is ill-conditioned.
    let asin_form = |d: f64| 4.0 * (s * s / (s * s + 4.0 * d * d)).asin();
    let atan_form = |d: f64| 4.0 * (s * s / (4.0 * d * (d * d + s * s / 2.0).sqrt())).atan();
    for &d in &[0.1, 1.0, 10.0] {
        assert!(rel_err(asin_form(d), atan_form(d)) < 1e-14);
        let om = polygon_solid_angle(DVec3::new(0.0, 0.0, d), &square(0.0, 0.0, s / 2.0));
        assert!(rel_err(om, asin_form(d)) < 1e-14, "d={d}");
    }
    // Tiny: Ω ≈ 1e-9 sr.
    let d = (s * s / (4.0 * 2.5e-10)).sqrt();
    let om = polygon_solid_angle(DVec3::new(0.0, 0.0, d), &square(0.0, 0.0, s / 2.0));
    let want = asin_form(d);
    println!(
        "tiny solid angle {om:e} vs {want:e}: rel {:.1e}",
        rel_err(om, want)
    );
    assert!((want - 1e-9).abs() < 1e-11);
    assert!(rel_err(om, want) < 1e-12);
    // Tiny and off-axis (the foot of the perpendicular outside the polygon):
    // rectangle [X, X+s]×[X, X+s] at height D via corner inclusion–exclusion.
    let corner = |x: f64, y: f64, h: f64| (x * y / (h * (h * h + x * x + y * y).sqrt())).atan();
    let (xx, ss, dd) = (3.0, 1e-4, 2.0);
    let want = corner(xx + ss, xx + ss, dd) - 2.0 * corner(xx, xx + ss, dd) + corner(xx, xx, dd);
    let verts = [
        DVec3::new(xx, xx, 0.0),
        DVec3::new(xx + ss, xx, 0.0),
        DVec3::new(xx + ss, xx + ss, 0.0),
        DVec3::new(xx, xx + ss, 0.0),
    ];
    let om = polygon_solid_angle(DVec3::new(0.0, 0.0, dd), &verts);
    println!(
        "tiny off-axis solid angle {om:e}: rel {:.1e}",
        rel_err(om, want)
    );
    // (the reference itself cancels to ~1e-16/Ω ≈ 5e-7 relative)
    assert!(om < 1e-8 && rel_err(om, want) < 3e-6);
    // Near 2π: the deficit 2π − Ω = 4 atan(4 d √(d²+s²/2)/s²) is resolved.
    for &d in &[1e-3, 1e-6, 1e-9] {
        let p = DVec3::new(0.0, 0.0, d);
        let om = polygon_solid_angle(p, &square(0.0, 0.0, s / 2.0));
        let deficit = 4.0 * (4.0 * d * (d * d + s * s / 2.0).sqrt() / (s * s)).atan();
        let err = ((2.0 * PI - om) - deficit).abs();
        println!(
            "near 2π, d={d:e}: deficit {:.6e} vs {deficit:.6e} (abs err {err:.1e})",
            2.0 * PI - om
        );
        assert!(err < 1e-14);
        // Off-centre and triangle split: still exact (sum of 4 corner rectangles).
        let q = DVec3::new(0.2, -0.1, d);
        let want =
            corner(0.3, 0.4, d) + corner(0.7, 0.4, d) + corner(0.3, 0.6, d) + corner(0.7, 0.6, d);
        let om = polygon_solid_angle(q, &square(0.0, 0.0, 0.5));
        assert!((om - want).abs() < 1e-13, "{om} {want}");
        // As two triangles the sum is the same.
        let sq = square(0.0, 0.0, 0.5);
        let t = polygon_solid_angle(q, &[sq[0], sq[1], sq[2]])
            + polygon_solid_angle(q, &[sq[0], sq[2], sq[3]]);
        assert!((t - want).abs() < 1e-6, "{t} {want}");
    }
    // Either winding, and in-plane → 0.
    let sq = square(0.0, 0.0, 0.5);
    let rev: Vec<DVec3> = sq.iter().rev().copied().collect();
    let p = DVec3::new(0.1, 0.2, 0.3);
    assert_eq!(polygon_solid_angle(p, &sq), polygon_solid_angle(p, &rev));
    assert_eq!(polygon_solid_angle(DVec3::new(3.0, 0.0, 0.0), &sq), 0.0);
}

// ------------------------------------------------------------ point sources

#[test]
fn shaped_point_source_values() {
    let src = DVec3::new(0.0, 0.0, 3.0);
    // Isotropic, straight below: I/R².
    let e = point_source_irradiance(DVec3::ZERO, DVec3::Z, src, -DVec3::Z, 10.0, 0.0);
    assert!(rel_err(e, 10.0 / 9.0) < 1e-15);
    // 3-4-5 geometry: cos α = cos θ = 3/5, R = 5.
    let p = DVec3::new(4.0, 0.0, 0.0);
    for &m in &[0.0, 1.0, 2.0, 1.5, 40.0] {
        let e = point_source_irradiance(p, DVec3::Z, src, -DVec3::Z, 7.0, m);
        let want = 7.0 * 0.6f64.powf(m) * 0.6 / 25.0;
        assert!(rel_err(e, want) < 1e-14, "m={m}");
    }
    // Receiver facing away → 0; behind the source → 0 for m > 0, not for m = 0.
    assert_eq!(
        point_source_irradiance(p, -DVec3::Z, src, -DVec3::Z, 7.0, 2.0),
        0.0
    );
    let above = DVec3::new(1.0, 0.0, 5.0);
    assert_eq!(
        point_source_irradiance(above, -DVec3::Z, src, -DVec3::Z, 7.0, 1.0),
        0.0
    );
    let iso = point_source_irradiance(above, -DVec3::Z, src, -DVec3::Z, 7.0, 0.0);
    assert!(rel_err(iso, 7.0 * (2.0 / 5f64.sqrt()) / 5.0) < 1e-14);
    // Grazing (cos θ → 0⁺) is finite and tiny; source at the point → 0.
    let g = point_source_irradiance(
        DVec3::new(4.0, 0.0, 3.0 - 1e-9),
        DVec3::Z,
        src,
        DVec3::X,
        1.0,
        3.0,
    );
    assert!(g.is_finite() && g > 0.0 && g < 1e-10);
    assert_eq!(
        point_source_irradiance(src, DVec3::Z, src, -DVec3::Z, 1.0, 1.0),
        0.0
    );
}

#[test]
fn tiny_shaped_panel_is_a_shaped_point_source() {
    // A small panel of area A, radiance L cos^m: intensity L A cos^{m+1}(α).
    let half = 5e-4;
    let verts = square(0.0, 0.0, half);
    let area = (2.0 * half) * (2.0 * half);
    for &m in &[0u32, 3, 20] {
        for &p in &[DVec3::new(0.3, 0.4, 1.0), DVec3::new(-1.0, 0.2, 0.5)] {
            let n = DVec3::new(0.1, 0.2, -1.0);
            let panel = shaped_polygon_irradiance_factor(p, n, &verts, DVec3::Z, m);
            let point = point_source_irradiance(p, n, DVec3::ZERO, DVec3::Z, area, m as f64 + 1.0);
            let e = rel_err(panel, point);
            // Finite-size correction ~ (m+2)² (size/R)².
            let bound = ((m + 2) as f64).powi(2) * (2.0 * half / p.length()).powi(2);
            println!("tiny panel m={m} p={p}: rel {e:.1e} (bound {bound:.1e})");
            assert!(e < bound);
        }
    }
}

#[test]
fn deep_tail_of_a_cos100_emitter_keeps_its_digits() {
    // Receiver far off the beam of a cos^100 panel: E/E_peak ~ 1e-18, where
    // the moment recurrence alone kept no digit (+358 %). The closed form
    // falls back to quadrature there; check against brute force.
    let verts = square(0.0, 0.0, 1.0);
    let m = 100;
    for p in [
        DVec3::new(1.9, 0.0, 1.0),
        DVec3::new(2.3, 0.4, 1.2),
        DVec3::new(4.0, 0.0, 1.0),
        DVec3::new(3.0, 2.5, 0.8),
        DVec3::new(6.0, -1.0, 2.0),
    ] {
        let n = (DVec3::new(0.0, 0.0, 0.0) - p).normalize();
        let got = shaped_polygon_irradiance_factor(p, n, &verts, DVec3::Z, m);
        let want = brute_force(p, n, &verts, DVec3::Z, m as i32, 80);
        let peak = shaped_polygon_irradiance_factor(
            DVec3::new(0.0, 0.0, 1.0),
            -DVec3::Z,
            &verts,
            DVec3::Z,
            m,
        );
        let e = rel_err(got, want);
        println!(
            "tail at {p}: {got:.6e} vs {want:.6e} (E/E_peak {:.1e}) rel {e:.1e}",
            want / peak
        );
        assert!(want / peak < 1e-8, "not a tail case");
        assert!(e < 1e-6, "{p}: {got} vs {want}");
    }
}

// ------------------------------------------------- grazing, far out (#43)

/// A `2 half`-wide square lamp facing down, `height` up, seen from ground
/// points (normal up) at the given horizontal distances along `dir`.
fn grazing_errors(half: f64, height: f64, m: u32, dir: DVec3, dists: &[f64]) -> Vec<f64> {
    let verts: Vec<DVec3> = square(0.0, 0.0, half)
        .into_iter()
        .map(|v| v + DVec3::new(0.0, 0.0, height))
        .collect();
    dists
        .iter()
        .map(|&d| {
            let p = dir * d;
            let got = shaped_polygon_irradiance_factor(p, DVec3::Z, &verts, -DVec3::Z, m);
            let want = brute_force(p, DVec3::Z, &verts, -DVec3::Z, m as i32, 8);
            let coarse = brute_force(p, DVec3::Z, &verts, -DVec3::Z, m as i32, 4);
            assert!(
                rel_err(coarse, want) < 1e-13,
                "reference not converged at {d}"
            );
            let e = (got - want) / want;
            println!("half {half} m={m} dir {dir} d={d:e}: {got:.9e} vs {want:.9e} rel {e:+.1e}");
            e
        })
        .collect()
}

#[test]
fn small_lamp_at_grazing_far_out_keeps_its_digits() {
    // Issue 43: a 1 cm lamp 5 m up, ground points 10 km and 100 km out: the
    // edge sums cancel by 16 orders (before: −2.9e-4 at 10 km, +5.9 % at
    // 100 km, m = 0; −3.5e-3 at 1 km, m = 2). Far-field quadrature now.
    let dists = [1.0, 10.0, 100.0, 1e3, 1e4, 1e5];
    for m in [0, 2] {
        for dir in [DVec3::X, DVec3::new(0.6, 0.8, 0.0)] {
            for (d, e) in dists.iter().zip(grazing_errors(0.005, 5.0, m, dir, &dists)) {
                assert!(e.abs() < 1e-12, "m={m} {dir} at {d}: rel {e:e}");
            }
        }
    }
}

#[test]
fn large_panel_near_and_far_at_grazing() {
    // A 1 m panel 5 m up (before: 2.9e-3 at 100 km, m = 0; 2.3e-5 at 1 km,
    // m = 2), plus points under and beside it.
    let dists = [0.0, 0.3, 0.5, 1.0, 3.0, 10.0, 100.0, 1e3, 1e4, 1e5];
    for m in [0, 2] {
        for dir in [DVec3::X, DVec3::new(0.6, 0.8, 0.0)] {
            for (d, e) in dists.iter().zip(grazing_errors(0.5, 5.0, m, dir, &dists)) {
                assert!(e.abs() < 1e-12, "m={m} {dir} at {d}: rel {e:e}");
            }
        }
    }
}

#[test]
fn far_field_switch_is_seamless_across_distances_and_exponents() {
    // Points all round a 1 m square, some at grazing emission (just below its
    // plane) and with grazing or tilted receivers, at (m + 3) R / d either
    // side of every quadrature-order bound and of the switch to the closed
    // form (0.1). Near-field shaped grazing points used to lose up to 1e-4
    // in the moment recurrence; they now fall back to quadrature too.
    let verts = square(0.0, 0.0, 0.5);
    let r = 2f64.sqrt();
    let mut worst: f64 = 0.0;
    for m in [0u32, 1, 2, 5, 20, 100, 1000] {
        for ratio in [
            0.99e-4, 1.1e-4, 0.99e-3, 1.1e-3, 0.99e-2, 1.1e-2, 0.029, 0.031, 0.099, 0.11, 0.3, 0.6,
        ] {
            for k in 0..24 {
                let kf = k as f64;
                let d = (m as f64 + 3.0) * r / ratio;
                let th = 0.05 + 1.5 * (kf * 0.37).sin().abs();
                let ph = kf * 1.3;
                let mut p = DVec3::new(
                    d * th.sin() * ph.cos() - 0.5,
                    d * th.sin() * ph.sin() - 0.5,
                    -d * th.cos(),
                );
                if k % 3 == 0 {
                    p.z = -1e-3 * (kf + 1.0) * d;
                }
                if p.length() < 1.5 {
                    continue; // too close to the panel for the reference rule
                }
                let n = match k % 4 {
                    0 => DVec3::Z,
                    1 => -p.normalize(),
                    2 => DVec3::new(0.3, -0.2, 1.0),
                    _ => DVec3::new(kf.cos(), kf.sin(), 0.01),
                };
                let got = shaped_polygon_irradiance_factor(p, n, &verts, -DVec3::Z, m);
                let want = brute_force(p, n, &verts, -DVec3::Z, m as i32, 8);
                if want < 1e-250 {
                    // Underflowing (m = 1 000 at grazing): no relative digits.
                    assert!(
                        got < 1e-240,
                        "m={m} ratio {ratio} p={p}: {got:e} vs {want:e}"
                    );
                    continue;
                }
                let e = rel_err(got, want);
                worst = worst.max(e);
                assert!(e < 1e-7, "m={m} ratio {ratio} p={p} n={n}: rel {e:e}");
            }
        }
    }
    println!("far-field switch: worst rel {worst:.1e}");
}
