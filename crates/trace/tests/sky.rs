//! The Moon and the sky dome through the tracer, against the sky crate's
//! closed forms (`gloam_sky::SkyModel::ground_spectra`, the quantities
//! `gloam_sky::ground_illuminance` reports), band-integrated on the
//! tracer's own wavelength grid.

use std::path::Path;

use glam::DVec3;
use gloam_scene::Scene;
use gloam_sky::spectral::interpolate;
use gloam_trace::{RenderSettings, Tracer};

const FULL: &str = "2025-10-07T05:00:00Z";
const NEW: &str = "2025-10-22T04:00:00Z";

fn scene(utc: &str, units: &str, extra: &str) -> Scene {
    let text = format!(
        r#"
units = "{units}"
[camera]
position = [0, -30, 3]
look_at = [0, 0, 4]
up = [0, 0, 1]
fov_deg = 60
width = 24
height = 16
[bands.visible]
lo_nm = 400
hi_nm = 700
[sky]
utc = "{utc}"
latitude_deg = 43.0844
longitude_deg = -77.6749
height_m = 170.0
visibility_km = 23.0
[materials.ground]
reflectance = 0.3
[objects.ground]
material = "ground"
quad = {{ center = [0, 0, 0], size = [200, 200], normal = [0, 0, 1] }}
{extra}
"#
    );
    gloam_scene::parse_str(&text, Path::new("sky.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn model(utc: &str) -> gloam_sky::SkyModel {
    let site = gloam_sky::Site::new(43.0844, -77.6749, 170.0).unwrap();
    let c = gloam_sky::SkyConditions::new(23.0, gloam_sky::Cloud::Clear).unwrap();
    gloam_sky::SkyModel::new(
        gloam_sky::UtcInstant::parse_iso8601(utc).unwrap(),
        &site,
        &c,
    )
    .unwrap()
}

/// A ground spectrum band-integrated the way the tracer integrates.
fn band(t: &Tracer, table: &[(f64, f64)]) -> f64 {
    let v: Vec<f64> = t
        .wavelengths()
        .nm
        .iter()
        .enumerate()
        .map(|(i, &w)| {
            if i < t.wavelengths().n_continuum {
                interpolate(table, w)
            } else {
                0.0
            }
        })
        .collect();
    t.wavelengths().integrate(&v)[0]
}

#[test]
fn open_floor_under_the_moon_matches_the_closed_form() {
    // Feet: directional sources carry no R², so units must not matter.
    for units in ["m", "ft"] {
        let s = scene(FULL, units, "");
        let set = RenderSettings::default();
        let t = Tracer::new(&s, &set).unwrap();
        let sum = t.sky_summary().unwrap();
        assert!(sum.moon_direct && sum.moon_elevation_deg > 50.0);
        let g = model(FULL).ground_spectra();
        let direct = band(&t, &g.moon_direct_horizontal_w_m2_nm);
        let diffuse =
            band(&t, &g.moon_sky_horizontal_w_m2_nm) + band(&t, &g.night_sky_horizontal_w_m2_nm);
        let p = DVec3::new(1.0, 2.0, 0.0);
        let r = t.sky_probe(p, DVec3::Z, None, 400).unwrap().unwrap();
        // E_n cos θ_z: the tracer uses the apparent (refracted) elevation,
        // the model's horizontal term the geometric one (≈ 0.01° apart).
        let e_dir = (r.moon_direct_w_m2 / direct - 1.0).abs();
        assert!(e_dir < 2e-4, "direct {} vs {direct}", r.moon_direct_w_m2);
        // 3e-3: the model's own dome quadrature (96 × 256 nodes) differs
        // from the exact dome integral by up to 0.3 % (sky_light tests).
        let err = (r.sky_diffuse_w_m2 - diffuse).abs();
        assert!(
            err < 4.0 * r.sky_std_error_w_m2 + 3e-3 * diffuse,
            "sky {} ± {} vs {diffuse}",
            r.sky_diffuse_w_m2,
            r.sky_std_error_w_m2
        );
        assert!(r.sky_std_error_w_m2 < 0.01 * diffuse);
        eprintln!(
            "{units}: direct {:.6e} vs {direct:.6e} ({e_dir:.1e}); sky {:.6e} ± {:.1e} vs {diffuse:.6e} ({:.2e})",
            r.moon_direct_w_m2,
            r.sky_diffuse_w_m2,
            r.sky_std_error_w_m2,
            r.sky_diffuse_w_m2 / diffuse - 1.0
        );
        // The full estimate at the point: E = E_n cos θ_z + E_sky.
        let pr = t.probe_point(p, DVec3::Z, None, 400).unwrap();
        let want = direct + diffuse;
        assert!(
            (pr.irradiance_w_m2 - want).abs()
                < 4.0 * pr.std_error_w_m2 + 2e-4 * direct + 3e-3 * diffuse,
            "{} ± {} vs {want}",
            pr.irradiance_w_m2,
            pr.std_error_w_m2
        );
        let l = pr.radiance_w_m2_sr.unwrap();
        assert!((l / (pr.irradiance_w_m2 * 0.3 / std::f64::consts::PI) - 1.0).abs() < 1e-12);
    }
}

#[test]
fn floor_under_a_roof_gets_no_moon_and_an_enclosed_point_nothing() {
    let roof = "[materials.roof]\nreflectance = 0.5\n[objects.roof]\nmaterial = \"roof\"\nquad = { center = [0, 0, 3], size = [20, 20], normal = [0, 0, -1] }\n";
    let s = scene(FULL, "m", roof);
    let t = Tracer::new(&s, &RenderSettings::default()).unwrap();
    let r = t
        .sky_probe(DVec3::new(0.5, 0.5, 0.0), DVec3::Z, None, 64)
        .unwrap()
        .unwrap();
    assert_eq!(r.moon_direct_w_m2, 0.0);
    // The low sky under the roof's edge still lights it, a little.
    assert!(r.sky_diffuse_w_m2 > 0.0);
    // A closed box: exactly nothing, rendered or probed.
    let shed = "[materials.shed]\nreflectance = 0.5\n[objects.shed]\nmaterial = \"shed\"\nbox = { min = [-5, -5, -1], max = [5, 5, 3] }\n";
    let s = scene(FULL, "m", shed);
    let t = Tracer::new(&s, &RenderSettings::default()).unwrap();
    let pr = t
        .probe_point(DVec3::new(0.0, 0.0, 0.0), DVec3::Z, None, 16)
        .unwrap();
    assert_eq!(pr.irradiance_w_m2, 0.0);
}

#[test]
fn camera_sees_the_sky_and_new_moon_is_darker() {
    let s = scene(FULL, "m", "");
    let t = Tracer::new(&s, &RenderSettings::default()).unwrap();
    let full = t.render(&|_, _| {}).unwrap();
    assert!(full.stats.sky.is_some());
    assert!(full.radiance.iter().all(|v| v.is_finite() && *v >= 0.0));
    // Top row: sky. Its radiance is the dome's in that direction.
    let sky_px = full.radiance[[0, 0, 12]];
    assert!(sky_px > 0.0);
    let new = gloam_trace::render(&scene(NEW, "m", ""), &RenderSettings::default()).unwrap();
    let floor = |o: &gloam_trace::RenderOutput| o.radiance[[0, 15, 12]];
    assert!(
        floor(&full) > 20.0 * floor(&new),
        "{} vs {}",
        floor(&full),
        floor(&new)
    );
    assert!(new.radiance[[0, 0, 12]] > 0.0 && new.radiance[[0, 0, 12]] < sky_px);
    // A uniform new-moon dome: the ground reads ρ L_sky exactly.
    let l_sky = new.radiance[[0, 0, 12]];
    assert!((floor(&new) / (0.3 * l_sky) - 1.0).abs() < 1e-9);
}

#[test]
fn sky_renders_are_deterministic_across_thread_counts() {
    let s = scene(
        FULL,
        "m",
        "[materials.box]\nreflectance = 0.5\nspecular_fraction = 0.3\n[objects.box]\nmaterial = \"box\"\nbox = { min = [-3, -3, 0], max = [1, 1, 2] }\n",
    );
    let a = RenderSettings {
        threads: Some(1),
        diffuse_bounces: 1,
        ..Default::default()
    };
    let b = RenderSettings {
        threads: Some(2),
        ..a.clone()
    };
    let ra = gloam_trace::render(&s, &a).unwrap();
    let rb = gloam_trace::render(&s, &b).unwrap();
    assert_eq!(ra.radiance, rb.radiance);
    assert_eq!(ra.stats.rays, rb.stats.rays);
}

#[test]
fn no_sky_block_no_sky_rays() {
    let text = r#"
units = "m"
[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 30
width = 4
height = 4
[bands.v]
lo_nm = 400
hi_nm = 700
[materials.floor]
reflectance = 0.5
[objects.floor]
material = "floor"
quad = { center = [0, 0, 0], size = [10, 10], normal = [0, 0, 1] }
"#;
    let s = gloam_scene::parse_str(text, Path::new("indoor.toml")).unwrap();
    let out = gloam_trace::render(&s, &RenderSettings::default()).unwrap();
    assert!(out.stats.sky.is_none());
    assert_eq!(out.stats.rays.shadow, 0);
    assert!(out.radiance.iter().all(|&v| v == 0.0));
}

#[test]
fn all_effects_agrees_with_the_planned_render() {
    // Outdoor: moon, sky, a specular box; all_effects adds zero-weight
    // recursion, NEE on every hit, spectral transmission on every ray.
    let s = scene(
        FULL,
        "m",
        "[materials.box]\nreflectance = 0.5\nspecular_fraction = 0.3\n[objects.box]\nmaterial = \"box\"\nbox = { min = [-3, -3, 0], max = [1, 1, 2] }\n",
    );
    let planned = RenderSettings {
        spp: 16,
        ..Default::default()
    };
    let all = RenderSettings {
        all_effects: true,
        ..planned.clone()
    };
    let a = gloam_trace::render(&s, &planned).unwrap();
    let b = gloam_trace::render(&s, &all).unwrap();
    assert!(b.stats.rays.total() > a.stats.rays.total());
    let (ma, mb) = (a.radiance.mean().unwrap(), b.radiance.mean().unwrap());
    assert!((mb / ma - 1.0).abs() < 0.01, "{mb} vs {ma}");
    assert!(b.radiance.iter().all(|v| v.is_finite() && *v >= 0.0));

    // Indoor, no [sky]: the dark sky's paths run, and the unoccluded
    // analytic floor is unchanged (to rounding).
    let text = r#"
units = "ft"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 10
width = 8
height = 8
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.floor]
reflectance = 0.9
[materials.panel]
reflectance = 0.0
emission = { value = 1.0, normalize = { lo_nm = 400, hi_nm = 700, value = 15.058 } }
[objects.floor]
material = "floor"
quad = { center = [0, 0, 0], size = [60, 60], normal = [0, 0, 1] }
[objects.panel]
material = "panel"
quad = { center = [0, 0, 9], size = [4, 2], normal = [0, 0, -1] }
"#;
    let s = gloam_scene::parse_str(text, Path::new("panel.toml")).unwrap();
    let a = gloam_trace::render(&s, &RenderSettings::default()).unwrap();
    let b = gloam_trace::render(
        &s,
        &RenderSettings {
            all_effects: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(a.stats.sky.is_none() && b.stats.sky.is_some());
    assert!(b.stats.rays.shadow > a.stats.rays.shadow);
    for (x, y) in a.radiance.iter().zip(b.radiance.iter()) {
        assert!((x - y).abs() <= 1e-12 * x.abs(), "{x} vs {y}");
    }
}
