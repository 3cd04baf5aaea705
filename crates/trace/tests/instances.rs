//! Shared instances (a two-level BVH) against the same placements copied
//! into facets: the same scene, traced both ways, must give the same
//! image — the expanded scene is the independent answer.

use std::path::Path;

use gloam_scene::Scene;
use gloam_trace::{Indirect, RenderSettings, render};

/// A lamp over a floor, and a small object (a roof-like pair of quads and
/// a triangle) placed 12 times with turns, uniform and per-axis scales,
/// `instancing = "{how}"`; `indirect` for the tracer.
fn scene(how: &str) -> Scene {
    scene_with(how, "")
}

/// [`scene`] with `grey` given `more` (e.g. a transmission).
fn scene_with(how: &str, more: &str) -> Scene {
    let mut placements = String::new();
    for k in 0..12 {
        let (x, y) = ((k % 4) as f64 * 2.5 - 3.75, (k / 4) as f64 * 2.5 - 2.5);
        let scale = match k % 3 {
            0 => "1.0".to_string(),
            1 => "0.7".to_string(),
            _ => "[1.3, 0.6, 1.8]".to_string(),
        };
        placements.push_str(&format!(
            "  {{ translate = [{x}, {y}, 0.0], rotate_z_deg = {}, scale = {scale} }},\n",
            17.0 * k as f64
        ));
    }
    let text = format!(
        r#"
units = "m"
[camera]
position = [0.5, -9, 7]
look_at = [0, 0, 0]
fov_deg = 60
width = 48
height = 36
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.floor]
reflectance = 0.5
[materials.grey]
reflectance = 0.7
{more}
[objects.floor]
material = "floor"
quad = {{ center = [0, 0, 0], size = [20, 20], normal = [0, 0, 1] }}
[objects.hut]
material = "grey"
vertices = [[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.0, 1.0], [-0.5, 0.0, 1.0], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.0], [0.0, 0.0, 1.6]]
faces = [[0, 1, 2, 3], [3, 2, 4, 5], [2, 6, 3]]
translate = [0.1, 0.0, 0.0]
instancing = "{how}"
instances = [
{placements}]
[point_sources.lamp]
position = [1, -1, 6]
direction = [0, 0, -1]
value = 500
"#
    );
    gloam_scene::parse_str(&text, Path::new("instances.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn settings(indirect: Indirect) -> RenderSettings {
    RenderSettings {
        spp: 4,
        seed: 7,
        indirect,
        threads: Some(1),
        ..Default::default()
    }
}

#[test]
fn shared_placements_are_kept_once_and_counted() {
    let shared = scene("shared");
    let copies = scene("expand");
    assert_eq!(shared.shared.len(), 1);
    assert_eq!(shared.shared[0].placements.len(), 12);
    assert_eq!(shared.shared[0].prototype.len(), 3);
    assert!(copies.shared.is_empty());
    assert_eq!(shared.facets.len(), 1);
    assert_eq!(copies.facets.len(), 1 + 12 * 3);
    assert_eq!(shared.counts().shared_facets, 36);
    assert!(shared.objects[1].shared && shared.objects[1].facets().is_empty());
}

/// Direct light only: both scenes draw the same random numbers wherever
/// the same facets are hit, so the images agree to rounding except at the
/// rare sample that grazes an edge.
#[test]
fn shared_and_expanded_direct_light_agree() {
    let a = render(&scene("shared"), &settings(Indirect::Off)).unwrap();
    let b = render(&scene("expand"), &settings(Indirect::Off)).unwrap();
    let (ra, rb) = (&a.radiance, &b.radiance);
    assert_eq!(ra.shape(), rb.shape());
    let n = ra.len();
    let same = ra
        .iter()
        .zip(rb.iter())
        .filter(|(x, y)| (*x - *y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1e-30))
        .count();
    assert!(same * 1000 >= n * 995, "{same} of {n} pixels agree");
    let (sa, sb): (f64, f64) = (ra.sum(), rb.sum());
    assert!((sa - sb).abs() <= 1e-3 * sb, "{sa} vs {sb}");
    // The objects are in view and lit: they change the image.
    let floor_only = {
        let s = scene("shared");
        let mut t = s.clone();
        t.shared.clear();
        render(&t, &settings(Indirect::Off)).unwrap()
    };
    assert!((floor_only.radiance.sum() - sa).abs() > 0.01 * sa);
}

/// Shadow rays and camera rays pass through transmissive shared facets as
/// through their copies.
#[test]
fn transmissive_shared_instances_attenuate_as_their_copies() {
    let more = "transmission = 0.25";
    let a = render(&scene_with("shared", more), &settings(Indirect::Off)).unwrap();
    let b = render(&scene_with("expand", more), &settings(Indirect::Off)).unwrap();
    let opaque = render(&scene("shared"), &settings(Indirect::Off)).unwrap();
    let (sa, sb, so): (f64, f64, f64) = (a.radiance.sum(), b.radiance.sum(), opaque.radiance.sum());
    assert!((sa - sb).abs() <= 1e-3 * sb, "{sa} vs {sb}");
    assert!(sa > so * 1.01, "light passes through: {sa} vs opaque {so}");
}

/// Path-traced interreflection, chosen by default for shared instances
/// (the cache has no texels on them), matches the expanded scene's path
/// tracing within the two renders' stated noise.
#[test]
fn shared_instances_interreflect_by_path_tracing() {
    let mut set = settings(Indirect::Auto);
    set.spp = 64;
    let a = render(&scene("shared"), &set).unwrap();
    let reason = &a.stats.interreflection.reason;
    assert_eq!(a.stats.interreflection.method, "path", "{reason}");
    assert!(reason.contains("shared instances"), "{reason}");
    set.indirect = Indirect::Path;
    set.diffuse_bounces = a.stats.interreflection.diffuse_bounces;
    set.seed = 11;
    let b = render(&scene("expand"), &set).unwrap();
    let (sa, sb): (f64, f64) = (a.radiance.sum(), b.radiance.sum());
    let var = |o: &gloam_trace::RenderOutput| o.std_error.iter().map(|e| e * e).sum::<f64>();
    let sigma = (var(&a) + var(&b)).sqrt();
    assert!((sa - sb).abs() < 4.0 * sigma, "{sa} vs {sb} (σ {sigma})");
}

/// 2 000 unit boxes in a row 2 m apart, shared and expanded: equal boxes
/// evenly spaced made the BVH builder merge one pair per pass (quadratic:
/// 10⁵ on a line took 151 s, issue 46). Both ways build, and under a
/// distant source 20° from the zenith the top of box 1 234 gets `E cos θ`,
/// the ground in the gap after it too (the box's shadow falls short), and
/// the ground just beside it, in its shadow, nothing.
#[test]
fn boxes_in_a_row_build_and_cast_their_shadows() {
    use glam::DVec3;
    let csv = std::env::temp_dir().join(format!("gloam-row-{}.csv", std::process::id()));
    let rows: String = (0..2_000).map(|i| format!("{},0,0,0,1\n", 2 * i)).collect();
    std::fs::write(&csv, rows).unwrap();
    let t = 20f64.to_radians();
    for how in ["shared", "expand"] {
        let text = format!(
            r#"
units = "m"
[camera]
position = [2468, -10, 5]
look_at = [2468, 0, 0]
fov_deg = 40
width = 4
height = 4
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.grey]
reflectance = 0.5
[objects.ground]
material = "grey"
quad = {{ center = [2000, 0, -0.001], size = [5000, 100], normal = [0, 0, 1] }}
[objects.row]
material = "grey"
box = {{ min = [-0.5, -0.5, 0.0], max = [0.5, 0.5, 1.0] }}
instancing = "{how}"
instances_csv = "{}"
[distant_sources.sun]
direction = [{}, 0, {}]
value = 1.0
normalize = {{ lo_nm = 400, hi_nm = 700, value = 10.0 }}
"#,
            csv.display(),
            t.sin(),
            -t.cos()
        );
        let sc = gloam_scene::parse_str(&text, Path::new("row.toml")).unwrap();
        let mut s = RenderSettings::default();
        s.set("indirect", "off").unwrap();
        let tracer = gloam_trace::Tracer::new(&sc, &s).unwrap();
        let e = |x: f64, z: f64| {
            let p = DVec3::new(x, 0.0, z);
            tracer
                .probe_point(p, DVec3::Z, Some("vis"), 1)
                .unwrap()
                .irradiance_w_m2
        };
        let lit = 10.0 * t.cos();
        // The box's shadow reaches tan 20° = 0.36 m past its far side.
        for (x, z, want) in [
            (2468.0, 1.0, lit),
            (2469.3, -0.001, lit),
            (2468.6, -0.001, 0.0),
        ] {
            let got = e(x, z);
            assert!(
                (got - want).abs() <= 1e-9 * lit,
                "{how}: E({x}, {z}) = {got}, expected {want}"
            );
        }
    }
    let _ = std::fs::remove_file(&csv);
}
