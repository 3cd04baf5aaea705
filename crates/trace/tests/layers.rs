//! Light layers (`render_layers`, one pass): the layers sum to the
//! ordinary render, which the pass reproduces bit for bit, adaptive
//! sampling included; and a lamp's layer is what a separate render of the
//! scene with only that lamp shows.

use std::path::Path;

use gloam_scene::Scene;
use gloam_trace::{LayerMap, RenderOutput, RenderSettings, Tracer};

fn scene(text: &str) -> Scene {
    gloam_scene::parse_str(text, Path::new("test.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// A small room under a moonlit sky: an open-topped box (grey walls, a
/// half-specular floor), an emissive ceiling panel, a table of two street
/// lamps, one more lamp merged with the panel by `group`, plus `extra`.
fn room(lamps: &str, extra: &str) -> String {
    format!(
        r#"
units = "m"
[camera]
position = [1, 1, 2.5]
look_at = [5, 4, 0.5]
up = [0, 0, 1]
fov_deg = 70
width = 24
height = 18
[bands.vis]
lo_nm = 400
hi_nm = 700
[bands.nir]
lo_nm = 700
hi_nm = 900
[sky]
utc = "2025-10-07T05:00:00Z"
latitude_deg = 43.0844
longitude_deg = -77.6749
[materials.wall]
reflectance = 0.6
[materials.floor]
reflectance = 0.5
specular_fraction = 0.3
[materials.glow]
reflectance = 0.0
emission = {{ value = 1.0, normalize = {{ lo_nm = 400, hi_nm = 700, value = 2.0 }} }}
[objects.room]
material = "wall"
box = {{ min = [0, 0, 0], max = [8, 6, 3], inward = true, omit = ["top", "bottom"] }}
[objects.floor]
material = "floor"
quad = {{ center = [4, 3, 0], size = [8, 6], normal = [0, 0, 1] }}
[objects.panel]
material = "glow"
quad = {{ center = [6, 4, 2.5], size = [1, 0.5], normal = [0, 0, -1] }}
{lamps}
{extra}
"#
    )
}

const LAMP_A: &str = r#"
[point_sources.a]
position = [2, 4, 2.8]
value = 0.02
instances = [{ translate = [0, 0, 0] }, { translate = [3, -2, 0] }]
"#;

const LAMP_B: &str = r#"
[point_sources.b]
position = [6, 1.5, 2.0]
direction = [0, 0, -1]
shape_exponent = 3
value = 0.05
group = "panel"
"#;

fn settings(spp: u32, indirect: &str) -> RenderSettings {
    let mut s = RenderSettings::default();
    s.set("spp", &spp.to_string()).unwrap();
    s.set("indirect", indirect).unwrap();
    s
}

fn layers(sc: &Scene, s: &RenderSettings) -> (RenderOutput, Vec<RenderOutput>) {
    let mut t = Tracer::new(sc, s).unwrap();
    let whole = t.render(&|_, _| {}).unwrap();
    let h = t.image_size().1;
    let map = LayerMap::of(sc);
    let layers = t.render_layers(&map, 0..h, &|_, _| {}, &|| false).unwrap();
    // The tracer is left as it was: a render after the layers is the same.
    let again = t.render(&|_, _| {}).unwrap();
    assert_eq!(again.radiance, whole.radiance);
    (whole, layers)
}

#[test]
fn layers_sum_to_the_ordinary_render() {
    let sc = scene(&room(&format!("{LAMP_A}{LAMP_B}"), ""));
    let names: Vec<&str> = (sc.light_groups.groups.iter())
        .map(|g| g.name.as_str())
        .collect();
    assert_eq!(names, ["panel", "a", "moon", "sky"]);
    assert_eq!(
        sc.light_groups.groups[0].sources,
        ["objects.panel", "point_sources.b"]
    );
    for indirect in ["off", "cache"] {
        let (whole, layers) = layers(&sc, &settings(4, indirect));
        assert_eq!(layers.len(), 4);
        // The lamps' layers carry light of their own (the moon's and the
        // sky's may be left out by the effect plan next to the lamps).
        for l in &layers[..2] {
            assert!(
                l.radiance.iter().any(|&x| x > 0.0),
                "{indirect}: an empty layer"
            );
        }
        assert_sums_to(&layers, &whole, indirect);
    }
}

/// The layers sum to `whole` within 1e-12 of its peak (floating-point
/// summation order: the clamp of negative penumbra sums is the whole's)
/// and none is negative.
fn assert_sums_to(layers: &[RenderOutput], whole: &RenderOutput, what: &str) {
    let mut sum = whole.radiance.clone();
    sum.fill(0.0);
    for l in layers {
        sum += &l.radiance;
        assert!(l.radiance.iter().all(|&x| x >= 0.0), "{what}: negative");
        assert_eq!(l.spp, whole.spp, "{what}: the whole's samples");
    }
    let peak = whole.radiance.iter().copied().fold(0.0, f64::max);
    assert!(peak > 0.0);
    let worst = (sum.iter().zip(&whole.radiance))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= 1e-12 * peak,
        "{what}: layers' sum off by {worst:e} (peak {peak:e})"
    );
}

/// The image mean of band `b` and its standard error (pixels independent).
fn mean_and_error(o: &RenderOutput, b: usize) -> (f64, f64) {
    let r = o.radiance.index_axis(ndarray::Axis(0), b);
    let e = o.std_error.index_axis(ndarray::Axis(0), b);
    let n = r.len() as f64;
    (r.sum() / n, e.iter().map(|x| x * x).sum::<f64>().sqrt() / n)
}

#[test]
fn a_lamps_layer_is_the_scene_with_only_that_lamp() {
    // No sky here: the lamp alone, against an independent render of the
    // scene with the panel's group (panel and lamp b) removed.
    let strip = |t: String| {
        t.replace(
            t.get(t.find("[sky]").unwrap()..t.find("[materials.wall]").unwrap())
                .unwrap(),
            "",
        )
    };
    let both = scene(&strip(room(&format!("{LAMP_A}{LAMP_B}"), "")));
    let only_a = room(LAMP_A, "").replace(
        "[objects.panel]\nmaterial = \"glow\"",
        "[objects.panel]\nmaterial = \"wall\"",
    );
    let only_a = scene(&strip(only_a));
    let s = settings(16, "cache");
    let (_, layers) = layers(&both, &s);
    let a = both
        .light_groups
        .groups
        .iter()
        .position(|g| g.name == "a")
        .unwrap();
    let alone = Tracer::new(&only_a, &s)
        .unwrap()
        .render(&|_, _| {})
        .unwrap();
    for b in 0..2 {
        let (m1, e1) = mean_and_error(&layers[a], b);
        let (m2, e2) = mean_and_error(&alone, b);
        assert!(m1 > 0.0);
        let tol = 5.0 * (e1 * e1 + e2 * e2).sqrt() + 0.02 * m2;
        assert!(
            (m1 - m2).abs() <= tol,
            "band {b}: layer {m1:e} vs alone {m2:e} (±{tol:e})"
        );
    }
}

/// Adaptive sampling: the pass's whole is the adaptive render bit for
/// bit (its sample counts follow the whole's errors), and every layer has
/// those samples and sums to it.
#[test]
fn adaptive_layers_take_the_wholes_samples() {
    let sc = scene(&room(&format!("{LAMP_A}{LAMP_B}"), ""));
    let mut s = settings(4, "cache");
    s.set("target_error", "0.05").unwrap();
    s.set("max_spp", "64").unwrap();
    let map = LayerMap::of(&sc);
    let mut t = Tracer::prepare_layered(&sc, &s, None, &map).unwrap();
    let h = t.image_size().1;
    let (whole, layers) = t.render_layered(&map, 0..h, &|_, _| {}, &|| false).unwrap();
    let plain = Tracer::new(&sc, &s).unwrap().render(&|_, _| {}).unwrap();
    assert_eq!(whole.radiance, plain.radiance);
    assert_eq!(whole.spp, plain.spp);
    assert!(whole.spp.iter().any(|&n| n > 4), "nothing adaptive");
    assert_sums_to(&layers, &whole, "adaptive");
}

/// More light groups than a layered render takes: a clear error.
#[test]
fn too_many_groups_are_refused() {
    let lamps: String = (0..=gloam_trace::layers::MAX_LAYER_GROUPS)
        .map(|i| {
            format!(
                "[point_sources.l{i}]\nposition = [{}, 3, 2.8]\nvalue = 0.001\n",
                1.0 + 0.05 * i as f64
            )
        })
        .collect();
    let sc = scene(&room(&lamps, ""));
    let mut t = Tracer::new(&sc, &settings(1, "off")).unwrap();
    let err = t.render_layers(&LayerMap::of(&sc), 0..1, &|_, _| {}, &|| false);
    assert!(
        matches!(err, Err(gloam_trace::LayerError::TooManyGroups(n)) if n > gloam_trace::layers::MAX_LAYER_GROUPS),
        "{err:?}"
    );
}

/// Each lamp's layer against its closed form: a Lambertian floor (ρ = 0.5)
/// under two isotropic lamps of their own groups, seen straight down by a
/// one-pixel camera (0.35 m of floor), direct light only:
/// `L = ρ/π · I cos θ / R²` per lamp, with `I` = 0.02 and 0.01 W sr⁻¹ nm⁻¹
/// over the 300 nm band, R = 5 m, cos θ = 0.8 and 0.6.
#[test]
fn each_lamps_layer_is_its_closed_form() {
    let sc = scene(
        r#"
units = "m"
camera = { position = [0, 0, 10], look_at = [0, 0, 0], up = [0, 1, 0], fov_deg = 2, width = 1, height = 1 }
bands.vis = { lo_nm = 400, hi_nm = 700 }
materials.floor = { reflectance = 0.5 }
objects.floor = { material = "floor", quad = { center = [0, 0, 0], size = [20, 20], normal = [0, 0, 1] } }
point_sources.a = { position = [3, 0, 4], value = 0.02 }
point_sources.b = { position = [0, -4, 3], value = 0.01 }
"#,
    );
    let (whole, layers) = layers(&sc, &settings(16, "off"));
    let closed = |i: f64, cos: f64| 0.5 / std::f64::consts::PI * i * 300.0 * cos / 25.0;
    for (l, want) in layers.iter().zip([closed(0.02, 0.8), closed(0.01, 0.6)]) {
        let got = l.radiance[[0, 0, 0]];
        // The pixel averages E over its 0.35 m footprint: < 0.2 % off the
        // centre's value.
        assert!(((got - want) / want).abs() < 2e-3, "{got} vs {want}");
    }
    assert_sums_to(&layers, &whole, "two lamps");
}
