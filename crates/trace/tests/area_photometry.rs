//! A measured luminaire on an area emitter against the closed form: an IES
//! file of `I = I0 cos γ` on a panel of area A is, by `L = I / (A cos γ)`,
//! a Lambertian emitter of luminance `I0 / A` — rendered (floor lit by it
//! and the panel seen directly) it must match `emission = { … }` with that
//! radiance within 1e-6, and its irradiance (sampled: the closed form is
//! for `cos^m` only) must match the Lambertian closed form within noise.
//! Likewise `I0 cos^(m+1) γ` is `shape_exponent = m` (m = 2 here).

mod common;
use std::path::Path;

use glam::DVec3;
use gloam_trace::{Estimator, RenderSettings};

const I0_CD: f64 = 800.0;
/// The panel, 0.8 m × 0.5 m.
const AREA_M2: f64 = 0.4;

/// A down-facing panel 3 m over a 6 × 6 m floor, seen obliquely by a
/// camera that also sees the panel's lit face.
fn scene_text(emission: &str) -> String {
    format!(
        r#"
units = "m"
[camera]
position = [0, -4, 1]
look_at = [0, 0, 1.8]
fov_deg = 80
width = 16
height = 16
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.floor]
reflectance = 0.5
[objects.floor]
material = "floor"
quad = {{ center = [0, 0, 0], size = [6, 6], normal = [0, 0, 1] }}
[materials.panel]
emission = {{ spectrum = "cie-a", {emission} }}
[objects.panel]
material = "panel"
quad = {{ center = [0, 0, 3], size = [0.8, 0.5], normal = [0, 0, -1] }}
"#
    )
}

/// `I0 cos^power γ` on a vertical grid of `step_deg` over [0°, 90°].
fn cos_ies(step_deg: f64, power: i32) -> String {
    common::cos_power_ies(step_deg, f64::from(power), I0_CD)
}

/// The panel as `shape_exponent = m` with luminance `I0 / A` along the
/// normal, and as a file of `I0 cos^(m+1) γ`.
fn scenes(dir: &Path, m: i32) -> (gloam_scene::Scene, gloam_scene::Scene) {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("cos.ies"), cos_ies(0.02, m + 1)).unwrap();
    let a = gloam_spectra::library::get("cie-a").unwrap();
    // Luminance I0 / A from `cie-a`'s shape.
    let k = I0_CD / AREA_M2 / gloam_spectra::photopic(&a);
    let parse = |t: &str| {
        gloam_scene::parse_str(t, &dir.join("scene.toml")).unwrap_or_else(|e| panic!("{e}"))
    };
    (
        parse(&scene_text(&format!("scale = {k:e}, shape_exponent = {m}"))),
        parse(&scene_text(
            "photometry = \"cos.ies\", c0_direction = [1, 0, 0]",
        )),
    )
}

/// Same estimator (solid-angle sampling), same random numbers: the two
/// renders differ only by the table's interpolation (relative error
/// ≤ (Δγ)²/8 · |f″/f|, f″/f = p(p−1) tan²γ − p for f = cos^p γ: 1.5e-8
/// for p = 1 at Δγ = 0.02°; for p = 3 with tan²γ ≤ 4 in this view,
/// 3.2e-7) and rounding.
#[test]
fn cos_table_on_a_panel_renders_like_a_lambertian_panel() {
    for (m, tol) in [(0, 5e-8), (2, 1e-6)] {
        panel_renders_like_shape_exponent(m, tol);
    }
}

fn panel_renders_like_shape_exponent(m: i32, tol: f64) {
    let dir = std::env::temp_dir().join(format!("gloam-area-phot-{m}-{}", std::process::id()));
    let (lambert, table) = scenes(&dir, m);
    let set = RenderSettings {
        spp: 4,
        seed: 5,
        estimator: Estimator::SolidAngle,
        ..Default::default()
    };
    let a = gloam_trace::render(&lambert, &set).unwrap().radiance;
    let b = gloam_trace::render(&table, &set).unwrap().radiance;
    assert_eq!(a.shape(), b.shape());
    let (mut rel, mut lit) = (0.0f64, 0);
    for (x, y) in b.iter().zip(a.iter()) {
        if *y == 0.0 {
            assert_eq!(*x, 0.0);
            continue;
        }
        lit += 1;
        rel = rel.max((x - y).abs() / y);
    }
    // The panel in view: its pixels are far brighter than the floor's.
    let peak = a.iter().copied().fold(0.0, f64::max);
    let floor = a[[0, 15, 8]];
    assert!(peak > 10.0 * floor && floor > 0.0, "{peak} vs {floor}");
    assert!(lit > 60, "{lit} lit values");
    assert!(rel < tol, "m = {m}: max relative difference {rel:e}");
    eprintln!(
        "cos^{} table on a panel vs shape_exponent = {m}: max relative difference {rel:e} over {lit} values",
        m + 1
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Through the default (analytic) estimator the table is sampled while the
/// Lambertian panel takes its closed form: irradiance under the panel's
/// corner and beside it agrees within 4 standard errors (and 1 %).
#[test]
fn cos_table_irradiance_matches_the_closed_form() {
    let dir = std::env::temp_dir().join(format!("gloam-area-phot-e-{}", std::process::id()));
    let (lambert, table) = scenes(&dir, 0);
    let set = RenderSettings::default();
    let tl = gloam_trace::Tracer::new(&lambert, &set).unwrap();
    let tt = gloam_trace::Tracer::new(&table, &set).unwrap();
    for p in [[0.0, 0.0], [0.4, 0.25], [2.0, -1.0]] {
        let p = DVec3::new(p[0], p[1], 0.0);
        let e = tl.probe_point(p, DVec3::Z, Some("vis"), 4).unwrap();
        let s = tt.probe_point(p, DVec3::Z, Some("vis"), 400).unwrap();
        let d = (s.irradiance_w_m2 - e.irradiance_w_m2).abs();
        assert!(
            d <= 4.0 * s.std_error_w_m2 + 1e-12 && d < 0.01 * e.irradiance_w_m2,
            "at {p}: sampled {} ± {} vs closed form {}",
            s.irradiance_w_m2,
            s.std_error_w_m2,
            e.irradiance_w_m2
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Through the light tree: three tabulated panels, the tree split into as
/// many branches as lights (every pick has pmf 1), agree with the
/// exhaustive sum within noise — the tree's bound for a table (I_max, no
/// falloff) never drops a panel that lights the point.
#[test]
fn tabulated_panels_through_the_light_tree() {
    let dir = std::env::temp_dir().join(format!("gloam-area-phot-tree-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("cos.ies"), cos_ies(1.0, 2)).unwrap();
    let mut text = scene_text("photometry = \"cos.ies\"");
    for (name, x, y) in [("b", 2.5, 0.0), ("c", -2.0, 1.0)] {
        text += &format!(
            "[objects.{name}]\nmaterial = \"panel\"\nquad = {{ center = [{x}, {y}, 2], size = [0.8, 0.5], normal = [0, 0, -1] }}\n"
        );
    }
    let s =
        gloam_scene::parse_str(&text, &dir.join("scene.toml")).unwrap_or_else(|e| panic!("{e}"));
    let probe = |min_lights: u32| {
        let set = RenderSettings {
            light_tree_min_lights: min_lights,
            light_tree_branches: 8,
            ..Default::default()
        };
        let t = gloam_trace::Tracer::new(&s, &set).unwrap();
        [[0.3, 0.2], [2.9, -0.4], [-2.5, 1.5]].map(|[x, y]| {
            t.probe_point(DVec3::new(x, y, 0.0), DVec3::Z, Some("vis"), 200)
                .unwrap()
        })
    };
    let (all, tree) = (probe(u32::MAX), probe(0));
    for (a, b) in all.iter().zip(&tree) {
        let se = a.std_error_w_m2.hypot(b.std_error_w_m2);
        let d = (a.irradiance_w_m2 - b.irradiance_w_m2).abs();
        assert!(
            a.irradiance_w_m2 > 0.0 && d <= 4.0 * se && d < 0.02 * a.irradiance_w_m2,
            "{} ± {} vs {} ± {}",
            a.irradiance_w_m2,
            a.std_error_w_m2,
            b.irradiance_w_m2,
            b.std_error_w_m2
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
