//! The Sun in a scene's `[sky]`: at dusk the twilight sky lights an open
//! floor with the diffuse irradiance the sky crate integrates over its own
//! dome (an independent quadrature of the same model), and while the Sun
//! is up its beam adds the model's direct horizontal irradiance; the plan
//! and the light groups know both terms.

use std::path::Path;

use glam::DVec3;
use gloam_scene::Scene;
use gloam_sky::{Site, TwilightOptions, TwilightSky, UtcInstant};
use gloam_trace::{RenderSettings, Tracer};

const LAT: f64 = 43.0844;
const LON: f64 = -77.6749;

/// The minute of 2025-10-07 (UTC, 20:00–23:59) when the Sun is nearest
/// `target_deg` at the site.
fn utc_at_sun(target_deg: f64) -> String {
    let site = Site::new(LAT, LON, 0.0).unwrap();
    let mut best = (f64::INFINITY, String::new());
    for m in 20 * 60..24 * 60 {
        let utc = format!("2025-10-07T{:02}:{:02}:00Z", m / 60, m % 60);
        let t = UtcInstant::parse_iso8601(&utc).unwrap();
        let e = gloam_sky::ephemeris(t, &site, gloam_sky::Refraction::None);
        let d = (e.sun.elevation_geometric_deg - target_deg).abs();
        if d < best.0 {
            best = (d, utc);
        }
    }
    assert!(best.0 < 0.2, "no minute near {target_deg}°");
    best.1
}

fn open_floor(utc: &str) -> Scene {
    floor_seen_from(
        utc,
        "position = [0, -20, 5]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nfov_deg = 40\nwidth = 8\nheight = 6",
    )
}

/// The open floor under the sky at `utc`, seen by the `[camera]` lines
/// given.
fn floor_seen_from(utc: &str, camera: &str) -> Scene {
    let text = format!(
        r#"
units = "m"
[camera]
{camera}
[bands.vis]
lo_nm = 400
hi_nm = 700
[sky]
utc = "{utc}"
latitude_deg = {LAT}
longitude_deg = {LON}
moon = false
night_sky = false
[materials.ground]
reflectance = 0.2
[objects.ground]
material = "ground"
quad = {{ center = [0, 0, 0], size = [400, 400], normal = [0, 0, 1] }}
"#
    );
    gloam_scene::parse_str(&text, Path::new("t.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// ∫ over 400–700 nm of a model spectrum (trapezoid on its 5 nm grid).
fn band(s: &[(f64, f64)]) -> f64 {
    s.windows(2)
        .filter(|w| w[0].0 >= 400.0 && w[1].0 <= 700.0)
        .map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0))
        .sum()
}

fn model(utc: &str) -> TwilightSky {
    let t = UtcInstant::parse_iso8601(utc).unwrap();
    let site = Site::new(LAT, LON, 0.0).unwrap();
    TwilightSky::at(t, &site, 23.0, TwilightOptions::default()).unwrap()
}

fn probe(sc: &Scene, drop: &str, k: u32) -> (f64, f64) {
    let mut s = RenderSettings::default();
    s.set("drop", drop).unwrap();
    let r = Tracer::new(sc, &s)
        .unwrap()
        .probe_point(DVec3::new(3.0, 2.0, 0.0), DVec3::Z, Some("vis"), k)
        .unwrap();
    (r.irradiance_w_m2, r.std_error_w_m2)
}

#[test]
fn at_civil_dusk_the_floor_gets_the_models_diffuse_sky() {
    let utc = utc_at_sun(-6.0);
    let sc = open_floor(&utc);
    let plan = gloam_scene::plan::plan(&sc);
    assert!(plan.is_enabled("twilight-sky"));
    assert!(!plan.is_enabled("sun"), "the Sun is down");
    let names: Vec<&str> = (sc.light_groups.groups.iter())
        .map(|g| g.name.as_str())
        .collect();
    assert_eq!(names, ["moon", "sky", "twilight"]);
    let want = band(&model(&utc).diffuse_horizontal_w_m2_nm());
    let (e, se) = probe(&sc, "none", 64);
    // The tracer's 1.5° × 2.5° table and render grid against the model's
    // own dome quadrature on its 5 nm grid: 2 %, plus the sampling noise.
    let tol = 4.0 * se + 0.02 * want;
    assert!(
        want > 0.0 && (e - want).abs() <= tol,
        "{e} ± {se} vs {want} W/m²"
    );
    // Dropped, it is gone.
    let (dark, _) = probe(&sc, "twilight-sky", 4);
    assert_eq!(dark, 0.0);
}

#[test]
fn with_the_sun_up_its_beam_adds_the_models_direct_light() {
    let utc = utc_at_sun(5.0);
    let sc = open_floor(&utc);
    let plan = gloam_scene::plan::plan(&sc);
    assert!(plan.is_enabled("sun") && plan.is_enabled("twilight-sky"));
    let m = model(&utc);
    let direct = band(&m.direct_horizontal_w_m2_nm());
    let (beam, se) = probe(&sc, "twilight-sky", 4);
    assert_eq!(se, 0.0, "one deterministic shadow ray");
    assert!(
        direct > 0.0 && (beam - direct).abs() <= 0.01 * direct,
        "{beam} vs {direct} W/m²"
    );
    let (both, se) = probe(&sc, "none", 64);
    let want = direct + band(&m.diffuse_horizontal_w_m2_nm());
    assert!(
        (both - want).abs() <= 4.0 * se + 0.02 * want,
        "{both} ± {se} vs {want} W/m²"
    );
}

#[test]
fn after_dark_nothing_changes() {
    let utc = "2025-10-07T05:00:00Z";
    let sc = open_floor(utc);
    let plan = gloam_scene::plan::plan(&sc);
    assert!(!plan.is_enabled("sun") && !plan.is_enabled("twilight-sky"));
    assert!(sc.light_groups.sun.is_none() && sc.light_groups.twilight.is_none());
}

#[test]
fn a_camera_looking_up_at_dusk_sees_the_models_sky() {
    // A camera at the floor looking at the zenith through a narrow field:
    // every pixel is the twilight model's zenith radiance (the tracer's
    // table at its 1.5° × 2.5° cells and render grid against the model's
    // own spectrum on its 5 nm grid: 2 %).
    let utc = utc_at_sun(-6.0);
    let camera = "position = [0, 0, 1]\nlook_at = [0, 0, 100]\nup = [0, 1, 0]\nfov_deg = 2\nwidth = 3\nheight = 3";
    let sc = floor_seen_from(&utc, camera);
    let out = Tracer::new(&sc, &RenderSettings::default())
        .unwrap()
        .render(&|_, _| {})
        .unwrap();
    let want = band(&model(&utc).radiance_w_m2_sr_nm([0.0, 0.0, 1.0]));
    for &l in out.radiance.iter() {
        assert!(
            want > 0.0 && (l - want).abs() <= 0.02 * want,
            "{l} vs {want} W m⁻² sr⁻¹"
        );
    }
}
