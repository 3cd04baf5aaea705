//! A measured luminaire (IES file) against the same distribution given
//! analytically: a `cos^m` lamp written as an IES table renders the same
//! image as `shape_exponent = m`, to the interpolation error the grid
//! allows.

mod common;
use std::path::Path;

use gloam_trace::RenderSettings;

const M: f64 = 3.0;
const I0_CD: f64 = 1000.0;

/// One lamp 3 m over a 6 × 6 m floor, seen from 2 m up by a camera under
/// it (so the lamp itself is out of view): a single source, so light
/// selection is deterministic and the two renders share every random
/// number.
fn scene_text(lamp: &str) -> String {
    format!(
        r#"
units = "m"
[camera]
position = [0, 0, 2]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 90
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
[point_sources.lamp]
position = [0, 0, 3]
direction = [0, 0, -1]
spectrum = "cie-a"
{lamp}
"#
    )
}

/// `I0 cos^m γ` on a vertical grid of `step_deg`, rotationally symmetric.
fn cos_m_ies(step_deg: f64) -> String {
    common::cos_power_ies(step_deg, M, I0_CD)
}

fn render(text: &str, dir: &Path) -> ndarray::Array3<f64> {
    let s = gloam_scene::parse_str(text, &dir.join("scene.toml")).unwrap_or_else(|e| panic!("{e}"));
    let set = RenderSettings {
        spp: 4,
        seed: 11,
        ..Default::default()
    };
    gloam_trace::render(&s, &set).unwrap().radiance
}

fn max_rel(a: &ndarray::Array3<f64>, b: &ndarray::Array3<f64>) -> f64 {
    assert_eq!(a.shape(), b.shape());
    a.iter()
        .zip(b.iter())
        .map(|(x, y)| {
            assert!(*y > 0.0, "every pixel sees the lit floor");
            (x - y).abs() / y
        })
        .fold(0.0, f64::max)
}

/// Grid for 1e-6: linear interpolation of f errs by at most
/// (Δγ)²/8 · |f''|/f, and for f = cos^m γ, f''/f = m(m−1) tan²γ − m. The
/// camera sees the floor out to 2 m from the lamp's foot (tan²γ ≤ 8/9),
/// so |f''/f| ≤ 6 · 8/9 + 3 = 8.4 and Δγ = 0.02° (3.5e-4 rad) bounds the
/// error by 1.3e-7. A 5° grid (bound 8e-3) must visibly differ.
#[test]
fn cos_m_as_an_ies_file_renders_like_shape_exponent() {
    let dir = std::env::temp_dir().join(format!("gloam-photometry-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The same luminous intensity on axis: I0 cd from `cie-a`'s shape.
    let a = gloam_spectra::library::get("cie-a").unwrap();
    let k = I0_CD / gloam_spectra::photopic(&a);
    let analytic = render(
        &scene_text(&format!("shape_exponent = {M}\nscale = {k:e}")),
        &dir,
    );
    std::fs::write(dir.join("fine.ies"), cos_m_ies(0.02)).unwrap();
    let fine = render(&scene_text("photometry = \"fine.ies\""), &dir);
    let rel = max_rel(&fine, &analytic);
    assert!(rel < 1e-6, "fine grid: {rel:e}");
    std::fs::write(dir.join("coarse.ies"), cos_m_ies(5.0)).unwrap();
    let coarse = render(&scene_text("photometry = \"coarse.ies\""), &dir);
    let rel_coarse = max_rel(&coarse, &analytic);
    assert!(
        rel_coarse > 1e-4 && rel_coarse < 8e-3,
        "coarse grid: {rel_coarse:e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!(
        "cos^{M} as IES: max relative difference {rel:e} (0.02° grid), {rel_coarse:e} (5° grid)"
    );
}

/// Through the light tree: three placements of a tabulated lamp, the tree
/// split into as many branches as lamps (every pick has pmf 1), give the
/// exhaustive sum — the tree's cone for a tabulated lamp never drops one
/// that lights the point.
#[test]
fn tabulated_lamps_through_the_light_tree() {
    let dir = std::env::temp_dir().join(format!("gloam-photometry-tree-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("lamp.ies"), cos_m_ies(1.0)).unwrap();
    let text = scene_text(
        "photometry = \"lamp.ies\"\nc0_direction = [1, 0, 0]\ninstances = [{ translate = [0, 0, 0] }, { translate = [2.5, 0, -1] }, { translate = [-2, 1, 0] }]",
    );
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
            t.probe_point(glam::DVec3::new(x, y, 0.0), glam::DVec3::Z, Some("vis"), 1)
                .unwrap()
                .irradiance_w_m2
        })
    };
    let (all, tree) = (probe(u32::MAX), probe(0));
    for (a, b) in all.iter().zip(&tree) {
        assert!(*a > 0.0 && (a - b).abs() <= 1e-12 * a, "{a} vs {b}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
