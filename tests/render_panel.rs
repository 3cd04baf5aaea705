//! Done-when test of issue 3 on `sims/panel-validation`: the panel seen
//! directly reads its band radiance within 0.1 %, and the floor directly
//! below the panel's centre reads the closed-form value within 0.5 %, both
//! in the rendered image and from the probe, with default settings.
//!
//! The truth is computed here independently of the tracer: the irradiance
//! under the centre of an x by y Lambertian panel at distance r
//! (`rectangle_center_irradiance`, checked below against a direct midpoint
//! quadrature of `E = r² ∫∫ L / (r² + x² + y²)² dx dy`), and the floor's
//! radiance `L_floor = ρ E / π`.

use std::f64::consts::PI;
use std::path::Path;

use gloam_trace::closed_form::rectangle_center_irradiance;
use gloam_trace::{DVec3, RenderSettings, Tracer};

const L_PANEL: f64 = 15.058;
const RHO_FLOOR: f64 = 0.9;

fn quadrature(l: f64, sx: f64, sy: f64, r: f64) -> f64 {
    let n = 2000;
    let (hx, hy) = (sx / n as f64, sy / n as f64);
    let mut sum = 0.0;
    for i in 0..n {
        let x = -sx / 2.0 + (i as f64 + 0.5) * hx;
        for j in 0..n {
            let y = -sy / 2.0 + (j as f64 + 0.5) * hy;
            let d = r * r + x * x + y * y;
            sum += r * r / (d * d);
        }
    }
    l * sum * hx * hy
}

#[test]
fn panel_validation_scene_matches_the_closed_form() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("sims/panel-validation/scene.toml");
    let scene = gloam_scene::load(&path, &gloam_io::ReadLog::off()).unwrap();
    let e_truth = rectangle_center_irradiance(L_PANEL, 4.0, 2.0, 9.0);
    let q = quadrature(L_PANEL, 4.0, 2.0, 9.0);
    assert!(
        (e_truth - q).abs() / q < 1e-6,
        "closed form {e_truth} vs quadrature {q}"
    );
    let floor_truth = RHO_FLOOR * e_truth / PI;

    let settings = RenderSettings::default();
    let tracer = Tracer::new(&scene, &settings).unwrap();
    let out = tracer.render(&|_, _| {}).unwrap();
    let img = out.radiance.index_axis(ndarray::Axis(0), 0);

    // Where the panel centre and the floor point land (scene camera model).
    let (pc, pr) = scene.camera.project(DVec3::new(0.0, 0.0, 9.0)).unwrap();
    let panel = img[[pr as usize, pc as usize]];
    let err_panel = (panel - L_PANEL).abs() / L_PANEL;
    assert!(err_panel < 1e-3, "panel pixel {panel} vs {L_PANEL}");

    let (fc, fr) = scene.camera.project(DVec3::ZERO).unwrap();
    let floor = img[[fr as usize, fc as usize]];
    let err_floor = (floor - floor_truth).abs() / floor_truth;
    assert!(err_floor < 5e-3, "floor pixel {floor} vs {floor_truth}");

    let probe = tracer
        .probe_point(DVec3::ZERO, DVec3::Z, Some("vis"), 16)
        .unwrap();
    let err_e = (probe.irradiance_w_m2 - e_truth).abs() / e_truth;
    assert!(
        err_e < 5e-3,
        "probe E {} vs {e_truth}",
        probe.irradiance_w_m2
    );
    let l = probe.radiance_w_m2_sr.expect("the point lies on the floor");
    assert!(
        (l - floor_truth).abs() / floor_truth < 5e-3,
        "probe L {l} vs {floor_truth}"
    );
    // The pixel probe is the rendered pixel, bit for bit.
    let px = tracer.probe_pixel(fc as u32, fr as u32).unwrap();
    assert_eq!(px[0], floor);
    eprintln!(
        "panel {panel} (err {err_panel:.2e}); floor pixel {floor} vs {floor_truth} (err {err_floor:.2e}); probe E {} (err {err_e:.2e})",
        probe.irradiance_w_m2
    );
}
