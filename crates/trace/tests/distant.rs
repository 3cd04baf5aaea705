//! Distant sources (`[distant_sources.NAME]`) against their closed form:
//! a surface turned by θ from the beam gets `E cos θ` and a Lambertian
//! one of reflectance ρ shows `ρ E cos θ / π`, wherever it stands, unless
//! something stands between it and the source.

use std::f64::consts::PI;
use std::path::Path;

use glam::DVec3;
use gloam_scene::Scene;
use gloam_trace::{LayerMap, RenderSettings, Tracer};

/// Irradiance normal to the beam over 400–700 nm, W m⁻².
const E_BAND: f64 = 10.0;
const RHO: f64 = 0.5;

/// A 60 × 60 m floor (ρ = 0.5) seen from 5 m above, under a distant
/// source travelling along `dir`, plus `extra` TOML.
fn floor_scene(dir: [f64; 3], extra: &str) -> Scene {
    let text = format!(
        r#"
units = "m"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 20
width = 8
height = 6
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.floor]
reflectance = {RHO}
[objects.floor]
material = "floor"
quad = {{ center = [0, 0, 0], size = [60, 60], normal = [0, 0, 1] }}
[distant_sources.sun]
direction = [{}, {}, {}]
value = 1.0
normalize = {{ lo_nm = 400, hi_nm = 700, value = {E_BAND} }}
{extra}
"#,
        dir[0], dir[1], dir[2]
    );
    gloam_scene::parse_str(&text, Path::new("test.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn settings(indirect: &str) -> RenderSettings {
    let mut s = RenderSettings::default();
    s.set("spp", "4").unwrap();
    s.set("indirect", indirect).unwrap();
    s
}

fn irradiance(sc: &Scene, p: DVec3) -> f64 {
    Tracer::new(sc, &settings("off"))
        .unwrap()
        .probe_point(p, DVec3::Z, Some("vis"), 4)
        .unwrap()
        .irradiance_w_m2
}

#[test]
fn a_floor_gets_e_cos_theta_and_shows_rho_e_cos_theta_over_pi() {
    for theta_deg in [0.0f64, 30.0, 60.0, 85.0] {
        let t = theta_deg.to_radians();
        let sc = floor_scene([t.sin(), 0.3 * t.sin(), -t.cos()], "");
        let cos = t.cos() / (1.0 + 0.09 * t.sin() * t.sin()).sqrt();
        for p in [DVec3::ZERO, DVec3::new(20.0, -7.0, 0.0)] {
            let e = irradiance(&sc, p);
            assert!(
                (e - E_BAND * cos).abs() <= 1e-9 * E_BAND,
                "θ {theta_deg}°: {e} W/m² at {p}, expected {}",
                E_BAND * cos
            );
        }
        let out = Tracer::new(&sc, &settings("cache"))
            .unwrap()
            .render(&|_, _| {})
            .unwrap();
        let want = RHO * E_BAND * cos / PI;
        for (&l, &s) in out.radiance.iter().zip(&out.std_error) {
            assert!(
                (l - want).abs() <= 1e-9 * want,
                "θ {theta_deg}°: {l} vs {want}"
            );
            assert_eq!(s, 0.0, "one deterministic shadow ray: no noise");
        }
    }
}

#[test]
fn an_occluder_casts_its_shadow_and_a_source_below_lights_nothing() {
    let block = r#"
[materials.grey]
reflectance = 0.3
[objects.block]
material = "grey"
box = { min = [-1, -1, 2], max = [1, 1, 3] }
"#;
    let sc = floor_scene([0.0, 0.0, -1.0], block);
    assert_eq!(irradiance(&sc, DVec3::ZERO), 0.0);
    let lit = irradiance(&sc, DVec3::new(5.0, 0.0, 0.0));
    assert!((lit - E_BAND).abs() <= 1e-9 * E_BAND, "{lit}");
    // Slanted 45° along +x: the shadow moves 2.5 m (the block's middle
    // height) downwind.
    let sc = floor_scene([1.0, 0.0, -1.0], block);
    assert_eq!(irradiance(&sc, DVec3::new(2.5, 0.0, 0.0)), 0.0);
    let lit = irradiance(&sc, DVec3::ZERO);
    assert!((lit - E_BAND * 0.5f64.sqrt()).abs() <= 1e-9 * E_BAND);
    // Travelling upward: the floor faces away from the source.
    let sc = floor_scene([0.0, 0.0, 1.0], "");
    assert_eq!(irradiance(&sc, DVec3::ZERO), 0.0);
}

#[test]
fn the_plan_knows_it_drop_removes_it_and_its_layer_is_its_light() {
    let lamp = r#"
[point_sources.lamp]
position = [1, 1, 3]
value = 0.05
"#;
    let sc = floor_scene([0.0, 0.6, -0.8], lamp);
    let plan = gloam_scene::plan::plan(&sc);
    let e = (plan.effects.iter())
        .find(|e| e.name == "distant-sources")
        .unwrap();
    assert!(e.enabled && e.reason.contains("sun"), "{}", e.reason);
    let names: Vec<&str> = (sc.light_groups.groups.iter())
        .map(|g| g.name.as_str())
        .collect();
    assert_eq!(names, ["lamp", "sun"]);

    let s = settings("off");
    let mut t = Tracer::new(&sc, &s).unwrap();
    let whole = t.render(&|_, _| {}).unwrap();
    let h = t.image_size().1;
    let layers = t
        .render_layers(&LayerMap::of(&sc), 0..h, &|_, _| {}, &|| false)
        .unwrap();
    let want = RHO * E_BAND * 0.8 / PI;
    for (&l, (&a, &b)) in
        (layers[1].radiance.iter()).zip(layers[0].radiance.iter().zip(&whole.radiance))
    {
        assert!((l - want).abs() <= 1e-9 * want, "sun's layer {l} vs {want}");
        assert!(
            (a + l - b).abs() <= 1e-12 * b,
            "layers {a} + {l} vs whole {b}"
        );
    }

    let mut dropped = s.clone();
    dropped.set("drop", "distant-sources").unwrap();
    let without = Tracer::new(&sc, &dropped)
        .unwrap()
        .render(&|_, _| {})
        .unwrap();
    // The lamp alone (to rounding: the layer sums per group).
    for (&a, &b) in without.radiance.iter().zip(&layers[0].radiance) {
        assert!(
            a > 0.0 && (a - b).abs() <= 1e-12 * a,
            "{a} vs the lamp's layer {b}"
        );
    }
}

#[test]
fn bad_tables_are_refused_by_name() {
    let bad = |body: &str, words: &[&str]| {
        let text = format!(
            r#"
units = "m"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
fov_deg = 20
width = 4
height = 4
[bands.vis]
lo_nm = 400
hi_nm = 700
[distant_sources.sun]
{body}
"#
        );
        let e = gloam_scene::parse_str(&text, Path::new("t.toml"))
            .unwrap_err()
            .to_string();
        for w in words {
            assert!(e.contains(w), "`{w}` not in: {e}");
        }
    };
    bad(
        "direction = [0, 0, 0]\nvalue = 1",
        &["distant_sources.sun.direction", "zero"],
    );
    bad(
        "direction = [0, 0, -1]\nvalue = -1",
        &["distant_sources.sun.value", "negative"],
    );
    bad(
        "direction = [0, 0, -1]\nvalue = 1e30",
        &["distant_sources.sun", "irradiance", "out of range"],
    );
    bad(
        "direction = [0, 0, -1]\nvalue = 1\nposition = [0, 0, 1]",
        &["position"],
    );
}
