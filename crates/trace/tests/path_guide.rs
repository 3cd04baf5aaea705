//! Path tracing's bounce guide (`path_guide`, `guide.rs`) moves noise, not
//! the answer: a lamp a few centimetres under its own open-bottomed head
//! lights the head's inside hundreds of times more brightly than the
//! ground, the case the guide is for. Rendered by plain cosine-sampled path
//! tracing (the guide off: the independent reference) and guided, the
//! image means agree within their noise, and the guided one is less noisy.

use std::path::Path;

use gloam_trace::{RenderSettings, Tracer};

const SCENE: &str = r#"
units = "m"
[camera]
position = [0, -4, 1]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov_deg = 50
width = 24
height = 18
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.ground]
reflectance = 0.3
[materials.steel]
reflectance = 0.6
[objects.ground]
material = "ground"
quad = { center = [0, 0, 0], size = [12, 12], normal = [0, 0, 1] }
[objects.head]
material = "steel"
box = { min = [-0.2, -0.15, 3.0], max = [0.2, 0.15, 3.15], omit = ["bottom"] }
[point_sources.lamp]
position = [0.12, 0, 2.99]
value = 0.05
"#;

/// Mean image radiance and its standard error.
fn render(guide: bool, spp: u32, seed: u64) -> (f64, f64, Option<usize>) {
    let scene =
        gloam_scene::parse_str(SCENE, Path::new("guide.toml")).unwrap_or_else(|e| panic!("{e}"));
    let mut set = RenderSettings::default();
    for kv in [
        "indirect=path".to_string(),
        "diffuse_bounces=16".to_string(),
        format!("spp={spp}"),
        format!("seed={seed}"),
        format!("path_guide={guide}"),
    ] {
        set.set_pair(&kv).unwrap();
    }
    let t = Tracer::new(&scene, &set).unwrap();
    let guided = t.interreflection().guided_facets;
    let out = t.render(&|_, _| {}).unwrap();
    let n = out.radiance.len() as f64;
    let mean = out.radiance.sum() / n;
    let se = out.std_error.iter().map(|s| s * s).sum::<f64>().sqrt() / n;
    (mean, se, guided)
}

#[test]
fn guided_bounces_agree_with_plain_path_tracing_and_are_less_noisy() {
    let (plain, plain_se, none) = render(false, 128, 1);
    let (guided, guided_se, hot) = render(true, 128, 2);
    assert_eq!(none, None, "the guide is off");
    assert!(
        hot.is_some_and(|n| n >= 1),
        "the head's inside is found hot: {hot:?}"
    );
    let z = (guided - plain) / (plain_se.hypot(guided_se));
    assert!(
        z.abs() < 4.0,
        "guided {guided:.6e} ± {guided_se:.1e} vs plain {plain:.6e} ± {plain_se:.1e} (z = {z:.2})"
    );
    assert!(
        guided_se < 0.5 * plain_se,
        "guided ± {guided_se:.2e} vs plain ± {plain_se:.2e}, both at 128 spp"
    );
}
