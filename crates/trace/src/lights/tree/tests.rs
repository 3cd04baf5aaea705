//! The light tree's tests: cone bounds, pick frequencies against the pmf,
//! and lamp grids against summing every emitter.

use super::*;
use rand::SeedableRng;

fn point(i: u32, pos: DVec3, phi: f64, cone: Cone) -> LightInfo {
    LightInfo {
        light: LightRef::Point(i),
        lo: pos,
        hi: pos,
        phi,
        cone,
    }
}

#[test]
fn cone_union_holds_both() {
    let down = Cone {
        axis: DVec3::NEG_Z,
        theta_o: 0.0,
        theta_e: FRAC_PI_2,
        exponent: 1.0,
    };
    let side = Cone {
        axis: DVec3::X,
        theta_o: 0.1,
        theta_e: FRAC_PI_2,
        exponent: 2.0,
    };
    let u = Cone::union(down, side);
    for c in [down, side] {
        let d = u.axis.dot(c.axis).clamp(-1.0, 1.0).acos();
        assert!(d + c.theta_o <= u.theta_o + 1e-12, "{u:?} {c:?}");
    }
    let up = Cone {
        axis: DVec3::Z,
        ..down
    };
    assert_eq!(Cone::union(down, up).theta_o, PI);
}

/// Over all draws, each light's selection probability sums with the
/// others to the number of branches, and its 1/pmf matches how often
/// it is drawn.
#[test]
fn pmf_matches_frequency() {
    let infos: Vec<LightInfo> = (0..40)
        .map(|i| {
            let pos = DVec3::new((i % 8) as f64, (i / 8) as f64, 3.0);
            point(i, pos, 1.0 + (i % 3) as f64, Cone::ALL)
        })
        .collect();
    let t = LightTree::build(infos, 10.0, Split::Fixed { branches: 2 }).unwrap();
    let p = DVec3::new(2.0, 1.0, 0.0);
    let mut rng = Pcg64Mcg::seed_from_u64(1);
    let mut out = Vec::new();
    let mut count = [0u32; 40];
    let mut inv = [0.0; 40];
    let draws = 200_000;
    for _ in 0..draws {
        t.select_in(p, DVec3::Z, usize::MAX, &mut rng, &mut out);
        assert!(out.len() <= 2);
        for &(l, w) in &out {
            let LightRef::Point(i) = l else { panic!() };
            count[i as usize] += 1;
            inv[i as usize] = w;
        }
    }
    for i in 0..40 {
        let f = count[i] as f64 / draws as f64;
        let expect = 1.0 / inv[i];
        let se = (expect / draws as f64).sqrt();
        assert!(
            (f - expect).abs() < 5.0 * se + 1e-9,
            "light {i}: {f} vs {expect}"
        );
    }
}

/// A `side × side` grid of isotropic point lamps, 1 m apart, `height`
/// up, intensities 1, 2, 3 in turn.
fn lamp_grid(side: u32, height: f64) -> Vec<LightInfo> {
    (0..side * side)
        .map(|i| {
            let h = 0.5 * (side - 1) as f64;
            let pos = DVec3::new((i % side) as f64 - h, (i / side) as f64 - h, height);
            point(i, pos, 1.0 + (i % 3) as f64, Cone::ALL)
        })
        .collect()
}

/// Irradiance at `p` on an upward plane from isotropic lamp `i`:
/// `I cos θ / d²`, the closed form.
fn lamp_e(infos: &[LightInfo], l: LightRef, p: DVec3) -> f64 {
    let LightRef::Point(i) = l else { panic!() };
    let li = &infos[i as usize];
    let d = li.lo - p;
    li.phi * (d.z / d.length()).max(0.0) / d.length_squared()
}

/// The defaults (`light_split_threshold`, `light_tree_max_picks`).
const ADAPTIVE: Split = Split::Adaptive {
    threshold: 0.2,
    max_picks: 64,
};

/// Every rule, whatever its budget: each lamp's weight, averaged over
/// draws (0 when not reached), is 1 — the estimate of any sum over the
/// lamps is unbiased — at points under the grid, at its corner, and
/// right under a lamp. Splitting decisions that depend on earlier
/// random choices (the budget) must not change that.
#[test]
fn every_lamps_expected_weight_is_one() {
    let infos = lamp_grid(7, 3.0);
    for rule in [
        Split::Fixed { branches: 3 },
        ADAPTIVE,
        Split::Adaptive {
            threshold: 0.0,
            max_picks: 5,
        },
        Split::Adaptive {
            threshold: 0.9,
            max_picks: 3,
        },
    ] {
        let t = LightTree::build(infos.clone(), 10.0, rule).unwrap();
        for p in [
            DVec3::new(0.3, 0.2, 0.0),
            DVec3::new(4.0, -5.0, 0.0),
            DVec3::new(1.0, 1.0, 2.9),
        ] {
            let mut rng = Pcg64Mcg::seed_from_u64(7);
            let mut out = Vec::new();
            let draws = 100_000;
            let mut sum = vec![0.0; infos.len()];
            let mut sum2 = vec![0.0; infos.len()];
            for _ in 0..draws {
                t.select_in(p, DVec3::Z, usize::MAX, &mut rng, &mut out);
                for &(l, w) in &out {
                    let LightRef::Point(i) = l else { panic!() };
                    sum[i as usize] += w;
                    sum2[i as usize] += w * w;
                }
            }
            for i in 0..infos.len() {
                let m = sum[i] / draws as f64;
                let var = (sum2[i] / draws as f64 - m * m).max(0.0);
                let se = (var / draws as f64).sqrt();
                assert!(
                    (m - 1.0).abs() < 5.0 * se + 1e-9,
                    "{rule:?} at {p}: lamp {i} mean weight {m} ± {se}"
                );
            }
        }
    }
}

/// The tree's estimate of the closed form `E = Σ I cos θ / d²` over a
/// 30 × 30 grid of isotropic lamps (1 m apart, 0.6 m up: the pitch to
/// height of `gloam bench scale`'s lamp grid): unbiased under both
/// rules, and at
/// the same cap on emitters per vertex (64) adaptive splitting has a
/// far smaller variance times cost (emitters reached) than the fixed
/// picks — near a lamp it splits down to the lamp itself, far away it
/// samples one from a cluster.
#[test]
fn splitting_lowers_the_variance_at_a_fixed_cost() {
    let infos = lamp_grid(30, 0.6);
    let fixed = LightTree::build(infos.clone(), 30.0, Split::Fixed { branches: 64 }).unwrap();
    let adaptive = LightTree::build(infos.clone(), 30.0, ADAPTIVE).unwrap();
    let draws = 20_000;
    let mut worse = Vec::new();
    for p in [
        DVec3::new(0.3, 0.2, 0.0),
        DVec3::new(-7.2, 11.6, 0.0),
        DVec3::new(14.0, 14.0, 0.0),
        DVec3::new(2.5, -3.5, 0.0),
    ] {
        let exact: f64 = (0..infos.len() as u32)
            .map(|i| lamp_e(&infos, LightRef::Point(i), p))
            .sum();
        let mut stats = Vec::new();
        for t in [&fixed, &adaptive] {
            let mut rng = Pcg64Mcg::seed_from_u64(3);
            let mut out = Vec::new();
            let (mut s, mut s2, mut picks) = (0.0, 0.0, 0usize);
            for _ in 0..draws {
                t.select_in(p, DVec3::Z, usize::MAX, &mut rng, &mut out);
                assert!(out.len() <= 64);
                picks += out.len();
                let e: f64 = out.iter().map(|&(l, w)| w * lamp_e(&infos, l, p)).sum();
                s += e;
                s2 += e * e;
            }
            let m = s / draws as f64;
            let var = (s2 / draws as f64 - m * m).max(0.0);
            let se = (var / draws as f64).sqrt();
            assert!(
                (m - exact).abs() < 5.0 * se + 1e-12 * exact,
                "{p}: {m} ± {se} vs exact {exact}"
            );
            stats.push((var.sqrt() / exact, picks as f64 / draws as f64));
        }
        eprintln!(
            "{p}: (relative sd, picks) fixed {:?}, adaptive {:?}",
            stats[0], stats[1]
        );
        let ((sd_f, n_f), (sd_a, n_a)) = (stats[0], stats[1]);
        // Variance × cost: at least 4× better.
        if sd_a * sd_a * n_a > 0.25 * sd_f * sd_f * n_f {
            worse.push((p, stats));
        }
    }
    assert!(worse.is_empty(), "{worse:?}");
}

// ---- The tree inside the tracer (scenes built in code) ----

use crate::settings::{Indirect, RenderSettings};
use crate::tracer::{RayCounts, Tracer};

/// A ground plane (ρ 0.5, z = 0) under `quads` small emitting quads
/// facing down on a ceiling grid (z = 4; m = 0, 1 and, every seventh,
/// the non-integer 1.5) and `lamps` shaped point lamps (z = 3; cos²,
/// cos⁴ tilted, every fifth isotropic), spacing 1 m, with opaque
/// blockers at z = 1 casting shadows.
pub(crate) fn many_lights_scene(quads: usize, lamps: usize) -> String {
    use std::fmt::Write;
    let side = |k: usize| (k as f64).sqrt().ceil().max(1.0) as usize;
    let span = side(quads.max(lamps)) as f64;
    let mut t = format!(
        r#"units = "m"
[camera]
position = [0, {cy}, 30]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 60
width = 16
height = 12
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.ground]
reflectance = 0.5
[materials.block]
reflectance = 0.2
[materials.e0]
reflectance = 0.0
emission = {{ value = 1.0, shape_exponent = 0 }}
[materials.e1]
reflectance = 0.0
emission = {{ value = 2.0, shape_exponent = 1 }}
[materials.e2]
reflectance = 0.0
emission = {{ value = 0.5, shape_exponent = 1.5 }}
[objects.ground]
material = "ground"
quad = {{ center = [0, 0, 0], size = [{g}, {g}], normal = [0, 0, 1] }}
"#,
        cy = -0.5 * span,
        g = 2.0 * span + 10.0,
    );
    let at = |i: usize, k: usize| {
        let n = side(k);
        let (x, y) = ((i % n) as f64, (i / n) as f64);
        (x - 0.5 * (n as f64 - 1.0), y - 0.5 * (n as f64 - 1.0))
    };
    for i in 0..quads {
        let (x, y) = at(i, quads);
        let m = if i % 7 == 6 { 2 } else { i % 2 };
        writeln!(
            t,
            "[objects.q{i}]\nmaterial = \"e{m}\"\nquad = {{ center = [{x}, {y}, 4], size = [0.3, 0.2], normal = [0, 0, -1], width_axis = [1, 0, 0] }}"
        )
        .unwrap();
    }
    for i in 0..lamps {
        let (x, y) = at(i, lamps);
        let (dx, m) = match i % 5 {
            4 => (0.0, 0.0),
            k if k % 2 == 0 => (0.0, 2.0),
            _ => (0.5, 4.0),
        };
        let v = 0.01 * (1 + i % 3) as f64;
        writeln!(
            t,
            "[point_sources.l{i}]\nposition = [{x}, {y}, 3]\ndirection = [{dx}, 0, -1]\nshape_exponent = {m}\nvalue = {v}"
        )
        .unwrap();
    }
    for i in 0..(quads.max(lamps) / 50).clamp(1, 40) {
        let (x, y) = at(i * 37 % quads.max(lamps).max(1), quads.max(lamps));
        writeln!(
            t,
            "[objects.b{i}]\nmaterial = \"block\"\nbox = {{ min = [{}, {}, 1], max = [{}, {}, 1.2] }}",
            x - 0.6,
            y - 0.6,
            x + 0.4,
            y + 0.3
        )
        .unwrap();
    }
    t
}

fn tracer(text: &str, min_lights: u32) -> Tracer {
    tracer_split(text, min_lights, "adaptive")
}

/// [`tracer`] with `light_tree_split` set.
fn tracer_split(text: &str, min_lights: u32, split: &str) -> Tracer {
    let scene = gloam_scene::parse_str(text, std::path::Path::new("many.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    let mut s = RenderSettings {
        indirect: Indirect::Off,
        tolerance: 0.0,
        light_tree_min_lights: min_lights,
        ..Default::default()
    };
    s.set("light_tree_split", split).unwrap();
    Tracer::new(&scene, &s).unwrap()
}

/// The tree's estimate, averaged over many draws, matches the
/// exhaustive sum (the path below the threshold) within a few standard
/// errors, at points in the open, near the edge and in a blocker's
/// penumbra; and its noise is small enough for that to mean something.
#[test]
fn tree_is_unbiased() {
    let text = many_lights_scene(500, 500);
    let tree = tracer(&text, 64);
    let full = tracer(&text, u32::MAX);
    assert!(tree.light_tree.is_some() && full.light_tree.is_none());
    for p in [
        DVec3::new(0.3, 0.2, 0.0),
        DVec3::new(-10.5, 9.0, 0.0),
        DVec3::new(3.7, -6.1, 0.0),
        DVec3::new(-1.4, -11.3, 0.0),
    ] {
        let a = tree.probe_point(p, DVec3::Z, None, 6000).unwrap();
        let b = full.probe_point(p, DVec3::Z, None, 300).unwrap();
        let se = (a.std_error_w_m2.powi(2) + b.std_error_w_m2.powi(2)).sqrt();
        let d = a.irradiance_w_m2 - b.irradiance_w_m2;
        eprintln!(
            "{p}: tree {:.6e} ± {:.1e}, exhaustive {:.6e} ± {:.1e}",
            a.irradiance_w_m2, a.std_error_w_m2, b.irradiance_w_m2, b.std_error_w_m2
        );
        assert!(
            d.abs() < 4.0 * se,
            "{p}: tree {} ± {}, exhaustive {} ± {}",
            a.irradiance_w_m2,
            a.std_error_w_m2,
            b.irradiance_w_m2,
            b.std_error_w_m2
        );
        assert!(a.std_error_w_m2 < 0.01 * b.irradiance_w_m2, "{p}: {a:?}");
    }
}

/// With the `solid-angle` estimator the area sources keep their loop
/// and the tree holds the point sources only; a dropped term is left
/// out of the tree's sum. Both still agree with the exhaustive path.
#[test]
fn other_estimators_and_drop_with_the_tree() {
    let text = many_lights_scene(150, 150);
    let scene = gloam_scene::parse_str(&text, std::path::Path::new("many.toml")).unwrap();
    let p = DVec3::new(0.3, 0.2, 0.0);
    let run = |min: u32, est: &str, drop: &str| {
        let mut s = RenderSettings {
            indirect: Indirect::Off,
            tolerance: 0.0,
            light_tree_min_lights: min,
            ..Default::default()
        };
        s.set("estimator", est).unwrap();
        s.set("drop", drop).unwrap();
        let t = Tracer::new(&scene, &s).unwrap();
        let has_area = t.light_tree.as_ref().map(|t| t.has_area);
        (has_area, t.probe_point(p, DVec3::Z, None, 3000).unwrap())
    };
    let (h, a) = run(64, "solid-angle", "none");
    assert_eq!(h, Some(false));
    let (_, b) = run(u32::MAX, "solid-angle", "none");
    let se = (a.std_error_w_m2.powi(2) + b.std_error_w_m2.powi(2)).sqrt();
    assert!(
        (a.irradiance_w_m2 - b.irradiance_w_m2).abs() < 4.0 * se,
        "{a:?} {b:?}"
    );
    // Dropping the shaped lamps: what is left matches the exhaustive
    // path's same drop.
    let drop = "shaped-point-sources";
    let (h, a) = run(64, "analytic", drop);
    assert_eq!(h, Some(true));
    let (_, b) = run(u32::MAX, "analytic", drop);
    let (_, all) = run(u32::MAX, "analytic", "none");
    let se = (a.std_error_w_m2.powi(2) + b.std_error_w_m2.powi(2)).sqrt();
    assert!(
        (a.irradiance_w_m2 - b.irradiance_w_m2).abs() < 4.0 * se,
        "{a:?} {b:?}"
    );
    assert!(
        b.irradiance_w_m2 < 0.95 * all.irradiance_w_m2,
        "{b:?} {all:?}"
    );
}

/// Shadow rays per vertex for 10 … 10 000 lights: under the fixed rule
/// they grow no faster than c·log N (the exhaustive path: linearly)
/// and stay within `light_tree_branches × area_samples`; under
/// adaptive splitting they stay within `light_tree_max_picks ×
/// area_samples` and stop growing once that cap binds.
#[test]
fn cost_per_vertex_is_bounded() {
    for split in ["fixed", "adaptive"] {
        for (quads, lamps) in [(true, false), (false, true)] {
            let mut per_vertex = Vec::new();
            for n in [10usize, 100, 1000, 10_000] {
                let text = many_lights_scene(if quads { n } else { 0 }, if lamps { n } else { 0 });
                let t = tracer_split(&text, 0, split);
                assert!(t.light_tree.is_some());
                let mut c = RayCounts::default();
                let mut e = crate::light::Light::dark(t.wl.len(), 0);
                let mut rng = crate::tracer::stream(0, 27, n as u64);
                let k = 400;
                let half = 0.5 * (n as f64).sqrt();
                for i in 0..k {
                    let u = (i as f64 + 0.5) / k as f64;
                    let p = DVec3::new(half * (2.0 * u - 1.0), half * (1.0 - 2.0 * u * u), 0.0)
                        - t.geom.origin;
                    let f = t.facet_at(p).unwrap_or(u32::MAX);
                    t.irradiance(p, DVec3::Z, f, &mut rng, &mut c, &mut e);
                }
                per_vertex.push((n, c.shadow as f64 / k as f64));
            }
            eprintln!("{split}: shadow rays per vertex (quads {quads}): {per_vertex:?}");
            assert!(per_vertex.iter().all(|&(_, r)| r > 0.0), "{per_vertex:?}");
            let d = RenderSettings::default();
            let picks = if split == "fixed" {
                let c10 = per_vertex[0].1 / (10f64).ln();
                for &(n, r) in &per_vertex {
                    assert!(r <= c10 * (n as f64).ln() + 1e-9, "{per_vertex:?}");
                }
                d.light_tree_branches
            } else {
                let (r3, r4) = (per_vertex[2].1, per_vertex[3].1);
                assert!(r4 <= 1.25 * r3, "{per_vertex:?}");
                d.light_tree_max_picks
            };
            let budget = (picks * d.area_samples) as f64;
            assert!(
                per_vertex.iter().all(|&(_, r)| r <= budget),
                "{per_vertex:?}"
            );
        }
    }
}

/// At or below `light_tree_min_lights` emitters there is no tree and
/// the render is bit-identical to the exhaustive path; above it the
/// tree is in use.
#[test]
fn below_threshold_is_the_exhaustive_path() {
    let render = |text: &str, min: u32| {
        let t = tracer(text, min);
        (
            t.light_tree.is_some(),
            t.render(&|_, _| {}).unwrap().radiance,
        )
    };
    let text = many_lights_scene(32, 32);
    let (tree, a) = render(&text, 64);
    let (_, b) = render(&text, u32::MAX);
    assert!(!tree);
    assert_eq!(
        a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    );
    let (tree, _) = render(&text, 63);
    assert!(tree);
}
