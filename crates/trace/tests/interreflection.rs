//! Interreflection against closed forms: the furnace (any closed enclosure
//! whose walls all emit `Le` and reflect `ρ` has `L = Le/(1−ρ)` everywhere)
//! and an integrating sphere with a port. Default settings unless stated: the
//! effect plan has to turn interreflection on by itself.

use std::fmt::Write;
use std::path::Path;

use gloam_scene::Scene;
use gloam_trace::{RenderSettings, Tracer};

const LE: f64 = 1.0;

fn scene(text: &str) -> Scene {
    gloam_scene::parse_str(text, Path::new("test.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn header(rho: f64, camera: &str) -> String {
    format!(
        r#"
units = "m"
[camera]
{camera}
up = [0, 0, 1]
fov_deg = 60
width = 16
height = 12
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.wall]
reflectance = {rho}
emission = {{ value = 1.0, normalize = {{ lo_nm = 400, hi_nm = 700, value = {LE} }} }}
"#
    )
}

/// A closed box, walls emitting and reflecting.
fn furnace_box(rho: f64, max: [f64; 3]) -> Scene {
    let mut t = header(
        rho,
        &format!(
            "position = [{}, {}, {}]\nlook_at = [{}, {}, {}]",
            0.3 * max[0],
            0.4 * max[1],
            0.5 * max[2],
            max[0],
            max[1],
            0.3 * max[2]
        ),
    );
    let _ = write!(
        t,
        "[objects.box]\nmaterial = \"wall\"\nbox = {{ min = [0, 0, 0], max = [{}, {}, {}], inward = true }}\n",
        max[0], max[1], max[2]
    );
    scene(&t)
}

/// A closed tetrahedron (four triangles facing inward).
fn furnace_tetra(rho: f64) -> Scene {
    let mut t = header(
        rho,
        "position = [0.9, 0.6, 0.35]\nlook_at = [0.2, 0.3, 0.1]",
    );
    // Vertices of a tetrahedron; faces wound to face the inside.
    t.push_str(
        "[objects.tetra]\nmaterial = \"wall\"\nvertices = [[0, 0, 0], [2, 0, 0], [1, 1.8, 0], [1, 0.6, 1.6]]\nfaces = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]]\n",
    );
    scene(&t)
}

/// Band-mean of the image (W m⁻² sr⁻¹ in `vis`; `LE` per 300 nm band).
fn mean(s: &Scene, set: &RenderSettings) -> (f64, Tracer) {
    let t = Tracer::new(s, set).unwrap();
    let out = t.render(&|_, _| {}).unwrap();
    let img = out.radiance.index_axis(ndarray::Axis(0), 0);
    (img.mean().unwrap(), t)
}

#[test]
fn furnace_box_default_render_is_within_half_a_percent_at_rho_half_and_two_at_point_nine() {
    for (rho, tol) in [(0.5, 0.005), (0.9, 0.02)] {
        let s = furnace_box(rho, [2.0, 1.5, 1.0]);
        let (m, t) = mean(&s, &RenderSettings::default());
        let want = LE / (1.0 - rho);
        assert_eq!(
            t.interreflection().method,
            "cache",
            "{:?}",
            t.interreflection()
        );
        assert!(
            ((m - want) / want).abs() < tol,
            "ρ = {rho}: mean {m}, want {want} (Le/(1−ρ)), decision {:?}",
            t.interreflection()
        );
        // The plan's estimate: every pixel sees an emitter, so the share is
        // over all pixels: indirect / total = ρ (Le/(1−ρ) − Le … − ρLe)/…
        // i.e. (L − Le − ρ Le)/L = ρ².
        let share = t.interreflection().estimated_share.unwrap();
        assert!(
            (share - rho * rho).abs() < 0.02,
            "ρ = {rho}: share {share}, want ρ² = {}",
            rho * rho
        );
    }
}

#[test]
fn furnace_holds_for_other_shapes_and_rho_up_to_0_99() {
    for (name, s, rho, tol) in [
        ("long box", furnace_box(0.7, [4.0, 1.0, 0.5]), 0.7, 0.005),
        ("tetrahedron", furnace_tetra(0.8), 0.8, 0.01),
        (
            "cube ρ = 0.99",
            furnace_box(0.99, [1.0, 1.0, 1.0]),
            0.99,
            0.02,
        ),
    ] {
        let (m, t) = mean(&s, &RenderSettings::default());
        let want = LE / (1.0 - rho);
        assert!(
            ((m - want) / want).abs() < tol,
            "{name}: mean {m}, want {want}, {:?}",
            t.interreflection()
        );
    }
}

#[test]
fn brute_force_path_tracing_agrees_with_the_furnace() {
    // The reference method, bounces chosen by the plan (share · q^k < tol).
    let s = furnace_box(0.5, [2.0, 1.5, 1.0]);
    let mut set = RenderSettings::default();
    set.set("indirect", "path").unwrap();
    set.spp = 64;
    let (m, t) = mean(&s, &set);
    assert!(
        t.interreflection().diffuse_bounces >= 5,
        "{:?}",
        t.interreflection()
    );
    let want = LE / (1.0 - 0.5);
    assert!(
        ((m - want) / want).abs() < 0.01,
        "path: mean {m}, want {want}"
    );
}

#[test]
fn direct_only_is_what_the_first_wave_computed() {
    // indirect = off leaves exactly Le + ρ·Le (emission + one reflection of
    // the walls' direct light): the truncation the plan now avoids.
    let rho = 0.5;
    let s = furnace_box(rho, [2.0, 1.5, 1.0]);
    let mut set = RenderSettings::default();
    set.set("indirect", "off").unwrap();
    let (m, _) = mean(&s, &set);
    assert!((m - LE * (1.0 + rho)).abs() < 1e-9, "direct only: {m}");
}

/// A UV sphere of radius 1 (flat facets, vertices on the sphere, facing
/// inward) with the polar cap above `port_lat` left open as the port.
fn sphere(rho: f64, n_lat: usize, n_lon: usize, port_rows: usize) -> (Scene, f64) {
    let mut t = header(rho, "position = [0, 0, -0.3]\nlook_at = [0.3, 0.2, -1]");
    let mut verts = Vec::new();
    let lat =
        |i: usize| -std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * i as f64 / n_lat as f64;
    let lon = |j: usize| 2.0 * std::f64::consts::PI * j as f64 / n_lon as f64;
    for i in 0..=n_lat {
        for j in 0..n_lon {
            let (a, b) = (lat(i), lon(j));
            verts.push([a.cos() * b.cos(), a.cos() * b.sin(), a.sin()]);
        }
    }
    let id = |i: usize, j: usize| i * n_lon + (j % n_lon);
    let mut faces: Vec<Vec<usize>> = Vec::new();
    let mut wall_area = 0.0;
    let mut port_area = 0.0;
    let area = |f: &[usize]| {
        let p: Vec<glam::DVec3> = f
            .iter()
            .map(|&k| glam::DVec3::from_array(verts[k]))
            .collect();
        let mut a = glam::DVec3::ZERO;
        for k in 1..p.len() - 1 {
            a += (p[k] - p[0]).cross(p[k + 1] - p[0]);
        }
        0.5 * a.length()
    };
    for i in 0..n_lat {
        for j in 0..n_lon {
            // Inward: clockwise seen from outside.
            let f: Vec<usize> = if i == 0 {
                vec![id(0, j), id(1, j), id(1, j + 1)]
            } else if i == n_lat - 1 {
                vec![id(i, j), id(i + 1, j), id(i, j + 1)]
            } else {
                vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]
            };
            if i >= n_lat - port_rows {
                port_area += area(&f);
            } else {
                wall_area += area(&f);
                faces.push(f);
            }
        }
    }
    // Degenerate pole vertices are fine: triangles use one of them each.
    let v: Vec<String> = verts
        .iter()
        .map(|p| format!("[{:.15}, {:.15}, {:.15}]", p[0], p[1], p[2]))
        .collect();
    let f: Vec<String> = faces
        .iter()
        .map(|f| {
            format!(
                "[{}]",
                f.iter()
                    .map(|k| k.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
        .collect();
    let _ = write!(
        t,
        "[objects.sphere]\nmaterial = \"wall\"\nvertices = [{}]\nfaces = [{}]\n",
        v.join(", "),
        f.join(", ")
    );
    (scene(&t), port_area / (port_area + wall_area))
}

#[test]
fn integrating_sphere_with_a_port() {
    // Every wall point sees the same fraction (1 − f) of the sphere's wall,
    // so the radiance is uniform: B = Le + ρ(1 − f)B → B = Le/(1 − ρ(1 − f));
    // the reflected part is Le·ρ(1 − f)/(1 − ρ(1 − f)) — the rig's
    // multiplier ρ/(1 − ρ(1 − f)) times (1 − f)Le.
    let rho = 0.9;
    let (s, f) = sphere(rho, 24, 32, 2);
    assert!(f > 0.005 && f < 0.05, "port fraction {f}");
    let (m, t) = mean(&s, &RenderSettings::default());
    let want = LE / (1.0 - rho * (1.0 - f));
    // Flat facets are chords of the sphere: the uniform-view-factor
    // property holds to the facets' angular size squared (~1 %).
    assert!(
        ((m - want) / want).abs() < 0.02,
        "sphere: mean {m}, want {want} (f = {f:.4}), {:?}",
        t.interreflection()
    );
}

#[test]
fn probe_answers_with_the_whole_light_of_a_render() {
    // In the furnace every surface point receives E = π L = π Le/(1−ρ):
    // π Le directly from the other walls, the rest interreflected. The
    // probe must answer with both (the plan's decision), by cache and by
    // path tracing, and say so.
    let rho = 0.5;
    let s = furnace_box(rho, [2.0, 1.5, 1.0]);
    let want = std::f64::consts::PI * LE / (1.0 - rho);
    let direct = std::f64::consts::PI * LE;
    for method in ["auto", "path"] {
        let mut set = RenderSettings::default();
        set.set("indirect", method).unwrap();
        let t = Tracer::new(&s, &set).unwrap();
        let p = gloam_trace::DVec3::new(1.0, 0.75, 0.0);
        let r = t.probe_point(p, gloam_trace::DVec3::Z, None, 32).unwrap();
        let e_ind = r
            .indirect_irradiance_w_m2
            .expect("interreflection included");
        assert!(
            ((r.direct_irradiance_w_m2 - direct) / direct).abs() < 1e-6,
            "{method}: direct {} vs π Le {direct}",
            r.direct_irradiance_w_m2
        );
        let tol = 0.01 * want + 4.0 * r.std_error_w_m2;
        assert!(
            (r.irradiance_w_m2 - want).abs() < tol,
            "{method}: E {} ± {} (direct {} + indirect {e_ind}) vs π Le/(1−ρ) = {want}",
            r.irradiance_w_m2,
            r.std_error_w_m2,
            r.direct_irradiance_w_m2
        );
        assert!(r.terms.contains("interreflection"), "{}", r.terms);
    }
    // Interreflection off: direct light only, and the probe says so.
    let mut set = RenderSettings::default();
    set.set("indirect", "off").unwrap();
    let r = Tracer::new(&s, &set)
        .unwrap()
        .probe_point(
            gloam_trace::DVec3::new(1.0, 0.75, 0.0),
            gloam_trace::DVec3::Z,
            None,
            4,
        )
        .unwrap();
    assert!(r.indirect_irradiance_w_m2.is_none());
    assert!((r.irradiance_w_m2 - direct).abs() < 1e-6 * direct);
    assert!(r.terms.contains("direct light only"), "{}", r.terms);
}

/// An isotropic lamp 0.1 m in front of a 1 m × 1 m grey panel (ρ = 0.5)
/// above a black floor, cache texels 20 m or more (`extra` adds objects).
/// Returns the floor's interreflected irradiance at X = (2, 0, 0) in units
/// of the lamp's direct irradiance straight below it at 2 m (I/4), its
/// standard error, and the panel integral it must equal,
///   E_ind(X) = ∫ (ρ/π) E_lamp(y) cos θ_X cos θ_y / r² dA,
/// by a 1 mm midpoint quadrature. The panel's direct irradiance falls 50×
/// from its centre to its corners: its centre stands for ≈ 19× its mean.
fn lamp_beside_a_panel(extra: &str, samples: u32) -> (f64, f64, f64, Tracer) {
    let rho = 0.5;
    let s = scene(&format!(
        r#"
units = "m"
[camera]
position = [4, 0, 1]
look_at = [0, 0, 1]
up = [0, 0, 1]
fov_deg = 60
width = 8
height = 6
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.grey]
reflectance = {rho}
[materials.black]
reflectance = 0.0
[objects.floor]
material = "black"
quad = {{ center = [0, 0, 0], size = [20, 20], normal = [0, 0, 1] }}
[objects.panel]
material = "grey"
quad = {{ center = [0, 0, 2], size = [1, 1], normal = [1, 0, 0] }}
[point_sources.lamp]
position = [0.1, 0, 2]
value = 1.0
{extra}
"#
    ));
    let x = gloam_trace::DVec3::new(2.0, 0.0, 0.0);
    let n = 1000;
    let h = 1.0 / n as f64;
    let mut integral = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (y, z) = (-0.5 + (i as f64 + 0.5) * h, 1.5 + (j as f64 + 0.5) * h);
            let rl2 = 0.01 + y * y + (z - 2.0).powi(2);
            let e_lamp = 0.1 / (rl2 * rl2.sqrt()); // I cos/r², I = 1
            let r2 = (x.x * x.x) + y * y + z * z;
            let (cos_x, cos_y) = (z / r2.sqrt(), x.x / r2.sqrt());
            integral += rho / std::f64::consts::PI * e_lamp * cos_x * cos_y / r2 * h * h;
        }
    }
    let mut set = RenderSettings::default();
    set.set("indirect", "cache").unwrap();
    set.set("cache_texels", "2").unwrap();
    let t = Tracer::new(&s, &set).unwrap();
    let below = gloam_trace::DVec3::new(0.1, 0.0, 0.0);
    let unit = t
        .probe_point(below, gloam_trace::DVec3::Z, None, 1)
        .unwrap();
    let unit = unit.direct_irradiance_w_m2;
    let r = t
        .probe_point(x, gloam_trace::DVec3::Z, None, samples)
        .unwrap();
    let got = r.indirect_irradiance_w_m2.expect("interreflection") / unit;
    (got, r.std_error_w_m2 / unit, integral / 0.25, t)
}

#[test]
fn a_lamp_beside_a_coarse_texel_is_recomputed_where_gather_rays_land() {
    // One texel a side: a gather ray that lands on the panel must
    // recompute the lamp's light there (the centre's: 18× too much).
    let (got, se, want, t) = lamp_beside_a_panel("", 4000);
    assert_eq!(
        t.interreflection().cache.as_ref().map(|c| c.guided_texels),
        Some(0)
    );
    assert!(
        (got - want).abs() < 0.03 * want + 4.0 * se,
        "E_ind at X: {got} ± {se} (in I/4) vs the panel integral {want}"
    );
}

#[test]
fn gather_rays_aimed_at_a_bright_texel_keep_the_integral_and_cut_its_noise() {
    // A grey sheet under the black floor (unlit, unseen) makes the panel
    // far brighter than the texels' mean: final gathers also aim at it,
    // weighted by the balance heuristic. Same integral; at equal samples
    // the cosine-weighted rays alone left ~3 % noise.
    let under = "[objects.under]\nmaterial = \"grey\"\nquad = { center = [0, 0, -5], size = [20, 20], normal = [0, 0, -1] }\n";
    let (got, se, want, t) = lamp_beside_a_panel(under, 4000);
    assert_eq!(
        t.interreflection().cache.as_ref().map(|c| c.guided_texels),
        Some(1)
    );
    assert!(
        (got - want).abs() < 0.01 * want + 4.0 * se,
        "E_ind at X: {got} ± {se} (in I/4) vs the panel integral {want}"
    );
    assert!(se < 0.01 * want, "standard error {se} of {want}");
}
