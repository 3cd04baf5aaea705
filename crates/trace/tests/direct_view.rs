//! Emitters seen directly (issue 43): a pixel that a lamp's face covers in
//! part holds the face's radiance times the covered fraction of the pixel.
//! The render computes that share over the face's footprint in the pixel,
//! apart from its camera samples; here the fraction is found independently
//! by a dense grid of camera rays against the rectangle, in the test's own
//! arithmetic. At one camera sample per pixel the samples alone would give
//! each edge pixel 0 or the whole radiance.

use std::path::Path;

use glam::DVec3;
use gloam_trace::RenderSettings;

const SCENE: &str = r#"
units = "m"

[camera]
position = [0.0, 0.0, 0.0]
look_at = [0.0, 10.0, 0.0]
up = [0.0, 0.0, 1.0]
fov_deg = 40.0
width = 24
height = 16

[bands.vis]
lo_nm = 400
hi_nm = 700

[materials.panel]
reflectance = 0.0
emission = { value = 1.0, shape_exponent = 0 }

[objects.panel]
material = "panel"
quad = { center = [0.3, 10.0, -0.2], size = [3.1, 1.7], normal = [0.2, -1.0, 0.1], width_axis = [0.95, 0.2, 0.3] }
"#;

/// The panel's corners as the test reads its TOML: centre ± half the size
/// along the width axis (made perpendicular to the normal) and along
/// normal × width axis.
fn panel() -> (DVec3, DVec3, DVec3, DVec3) {
    let c = DVec3::new(0.3, 10.0, -0.2);
    let n = DVec3::new(0.2, -1.0, 0.1).normalize();
    let wa = DVec3::new(0.95, 0.2, 0.3);
    let a = (wa - n * wa.dot(n)).normalize();
    let b = n.cross(a);
    (c, n, a * 1.55, b * 0.85)
}

/// The fraction of pixel `(col, row)` whose camera rays meet the panel,
/// on a `k × k` grid of ray centres.
fn coverage(cam: &gloam_scene::Camera, col: u32, row: u32, k: u32) -> f64 {
    let (c, n, ha, hb) = panel();
    let mut hits = 0u32;
    for i in 0..k {
        for j in 0..k {
            let px = col as f64 + (i as f64 + 0.5) / k as f64;
            let py = row as f64 + (j as f64 + 0.5) / k as f64;
            let d = cam.pixel_direction(px, py);
            let t = (c - cam.position).dot(n) / d.dot(n);
            let p = cam.position + d * t - c;
            let (s, u) = (
                p.dot(ha) / ha.length_squared(),
                p.dot(hb) / hb.length_squared(),
            );
            if t > 0.0 && s.abs() <= 1.0 && u.abs() <= 1.0 {
                hits += 1;
            }
        }
    }
    hits as f64 / (k * k) as f64
}

#[test]
fn a_partly_covered_pixel_holds_the_covered_fraction_of_the_face() {
    let scene = gloam_scene::parse_str(SCENE, Path::new("direct_view.toml")).unwrap();
    for (spp, target) in [(1, None), (4, Some(0.02))] {
        let settings = RenderSettings {
            spp,
            target_error: target,
            ..RenderSettings::default()
        };
        let out = gloam_trace::render(&scene, &settings).unwrap();
        let img = out.radiance.index_axis(ndarray::Axis(0), 0);
        // A pixel the face covers wholly gives the face's band radiance.
        let l = img[[8, 12]];
        assert!(l > 0.0);
        let (mut edge, mut worst) = (0, 0.0f64);
        for row in 0..16u32 {
            for col in 0..24u32 {
                let f = coverage(&scene.camera, col, row, 400);
                let got = img[[row as usize, col as usize]] / l;
                if f > 0.0 && f < 1.0 {
                    edge += 1;
                }
                // The grid's own error is about one edge cell's share,
                // 400 cells along an edge of 160 000: ≲ 1.5e-3.
                worst = worst.max((got - f).abs());
                assert!(
                    (got - f).abs() < 3e-3,
                    "spp {spp}: pixel ({col}, {row}) covered {f:.4}, rendered {got:.4}"
                );
            }
        }
        assert!(edge > 20, "the panel's edges cross {edge} pixels");
        eprintln!("spp {spp}: {edge} edge pixels, worst |rendered − covered| {worst:.2e}");
    }
}
