//! Instanced measured area luminaires (issue 43): an object of a
//! `photometry = "…"` material placed N times is N luminaires, each with
//! the file's flux and its C0 plane turned by its placement — exactly the
//! N quads written as separate objects, each with its C0 direction turned
//! by hand. The placed facets are copied vertex for vertex into the
//! separate objects, so both scenes hold the same facets in the same
//! order and, under one seed, `probe_point` draws the same random numbers:
//! the irradiances agree to rounding (1e-12 relative), not within noise.

use std::path::Path;

use glam::DVec3;
use gloam_trace::RenderSettings;

/// The prototype's C0 direction (in the material).
const C0: [f64; 3] = [1.0, 0.5, 0.0];

/// A C-dependent (asymmetric) table, full 0–360°:
/// `1000 cos γ (1 + 0.8 cos C + 0.3 sin C)` on 10° × 30° nodes.
fn asymmetric_ies() -> String {
    let g: Vec<f64> = (0..=9).map(|k| 10.0 * k as f64).collect();
    let c: Vec<f64> = (0..=12).map(|k| 30.0 * k as f64).collect();
    let join = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let mut cd = Vec::new();
    for ci in &c {
        let (s, co) = ci.to_radians().sin_cos();
        for gi in &g {
            cd.push(1000.0 * gi.to_radians().cos() * (1.0 + 0.8 * co + 0.3 * s));
        }
    }
    format!(
        "IESNA:LM-63-2002\n[TEST] asymmetric\nTILT=NONE\n1 -1 1 {} {} 1 1 0.5 0.25 0\n1 1 1\n{}\n{}\n{}\n",
        g.len(),
        c.len(),
        join(&g),
        join(&c),
        join(&cd)
    )
}

const HEAD: &str = r#"
units = "m"
[camera]
position = [0, -8, 1]
look_at = [0, 0, 1]
fov_deg = 60
width = 4
height = 4
[bands.vis]
lo_nm = 400
hi_nm = 700
"#;

fn material(name: &str, c0: [f64; 3]) -> String {
    format!(
        "[materials.{name}]\nemission = {{ photometry = \"lum.ies\", spectrum = \"cie-a\", c0_direction = [{}, {}, {}] }}\n",
        c0[0], c0[1], c0[2]
    )
}

fn parse(dir: &Path, text: &str) -> gloam_scene::Scene {
    gloam_scene::parse_str(text, &dir.join("scene.toml")).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// One object `lamp` of a 0.5 × 0.25 m down-facing quad 3 m up, placed at
/// `placements` (TOML inline tables).
fn instanced(dir: &Path, placements: &[String]) -> gloam_scene::Scene {
    let text = format!(
        "{HEAD}{}[objects.lamp]\nmaterial = \"lum\"\nquad = {{ center = [0, 0, 3], size = [0.5, 0.25], normal = [0, 0, -1] }}\ninstances = [{}]\n",
        material("lum", C0),
        placements.join(", ")
    );
    parse(dir, &text)
}

/// `scene`'s facets as separate objects (same vertices, same order), the
/// k-th of material `c0s[k]`'s C0 direction.
fn separate(dir: &Path, scene: &gloam_scene::Scene, c0s: &[[f64; 3]]) -> gloam_scene::Scene {
    assert_eq!(scene.facets.len(), c0s.len());
    let mut text = HEAD.to_string();
    for (k, (f, c0)) in scene.facets.iter().zip(c0s).enumerate() {
        text += &material(&format!("lum{k}"), *c0);
        let v: Vec<String> = f
            .vertices
            .iter()
            .map(|p| format!("[{}, {}, {}]", p.x, p.y, p.z))
            .collect();
        text += &format!(
            "[objects.lamp{k}]\nmaterial = \"lum{k}\"\nvertices = [{}]\nfaces = [[0, 1, 2, 3]]\n",
            v.join(", ")
        );
    }
    let s = parse(dir, &text);
    for (a, b) in s.facets.iter().zip(&scene.facets) {
        assert_eq!(a.vertices, b.vertices);
    }
    s
}

/// Irradiance (W m⁻², `vis`) on an upward normal at each point.
fn probe(scene: &gloam_scene::Scene, points: &[DVec3]) -> Vec<f64> {
    let set = RenderSettings {
        seed: 11,
        ..Default::default()
    };
    let t = gloam_trace::Tracer::new(scene, &set).unwrap();
    points
        .iter()
        .map(|&p| {
            t.probe_point(p, DVec3::Z, Some("vis"), 16)
                .unwrap()
                .irradiance_w_m2
        })
        .collect()
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            assert!(*y > 0.0, "{y}");
            (x - y).abs() / y
        })
        .fold(0.0, f64::max)
}

fn temp_dir(tag: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("gloam-inst-lum-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("lum.ies"), asymmetric_ies()).unwrap();
    dir
}

/// Under, beside and between the lamps (they stand 2 m apart along x).
fn points() -> Vec<DVec3> {
    [
        [0.0, 0.0, 0.0],
        [0.7, -1.1, 0.0],
        [2.0, 0.3, 0.5],
        [5.0, 1.5, 0.0],
        [8.0, -0.4, 1.0],
        [-1.5, 2.0, 0.0],
    ]
    .map(|[x, y, z]| DVec3::new(x, y, z))
    .to_vec()
}

/// 1, 2 and 5 placements carry the flux of as many separate objects (the
/// luminous area is each placement's, not the sum over placements); the
/// irradiance under the first lamp is the same whatever N (the others are
/// 2 m or more away and add a little).
#[test]
fn n_placements_emit_like_n_separate_luminaires() {
    let dir = temp_dir("n");
    let pts = points();
    let mut under_first = Vec::new();
    for n in [1usize, 2, 5] {
        let pl: Vec<String> = (0..n)
            .map(|k| format!("{{ translate = [{}, 0, 0] }}", 2 * k))
            .collect();
        let a = instanced(&dir, &pl);
        let b = separate(&dir, &a, &vec![C0; n]);
        let (ea, eb) = (probe(&a, &pts), probe(&b, &pts));
        let rel = max_rel(&ea, &eb);
        eprintln!(
            "{n} placements: E under the first {:.6e} W/m² instanced, {:.6e} separate; max relative difference {rel:e}",
            ea[0], eb[0]
        );
        assert!(rel < 1e-12, "{n} placements: {ea:?} vs {eb:?}");
        under_first.push(ea[0]);
    }
    // One lamp's own contribution does not shrink as lamps are added.
    assert!(under_first[1] >= under_first[0] && under_first[2] >= under_first[1]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A placement's `rotate_z_deg = 90` turns its C0 plane with its quad:
/// it lights like a separate object whose quad is turned and whose
/// `c0_direction` is turned by hand, (1, 0.5, 0) → (−0.5, 1, 0); with the
/// unturned direction the table (asymmetric in C) lights it otherwise.
#[test]
fn a_placements_rotation_turns_its_c0_plane() {
    let dir = temp_dir("rot");
    let pts = points();
    let a = instanced(
        &dir,
        &[
            "{ translate = [-1, 0, 0] }".to_string(),
            "{ rotate_z_deg = 90, translate = [2, 0.5, 0] }".to_string(),
        ],
    );
    // The turned quad by hand: 0.25 m along x, 0.5 m along y, about (2, 0.5).
    let mut v = a.facets[1].vertices.clone();
    v.sort_by(|p, q| p.x.total_cmp(&q.x).then(p.y.total_cmp(&q.y)));
    let want = [[1.875, 0.25], [1.875, 0.75], [2.125, 0.25], [2.125, 0.75]];
    for (p, w) in v.iter().zip(want) {
        assert_eq!(*p, DVec3::new(w[0], w[1], 3.0));
    }
    let turned = [-0.5, 1.0, 0.0];
    let b = separate(&dir, &a, &[C0, turned]);
    let (ea, eb) = (probe(&a, &pts), probe(&b, &pts));
    let rel = max_rel(&ea, &eb);
    eprintln!("rotate_z_deg = 90: max relative difference {rel:e} against C0 turned by hand");
    assert!(rel < 1e-12, "{ea:?} vs {eb:?}");
    // Orientation matters here: the unturned C0 differs.
    let c = separate(&dir, &a, &[C0, C0]);
    let ec = probe(&c, &pts);
    let off = max_rel(&ec, &eb);
    eprintln!("… and {off:e} against the unturned C0");
    assert!(off > 0.05, "{ec:?} vs {eb:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
