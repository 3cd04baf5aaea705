//! A render a caller stops (`Tracer::render_rows_until`, used by the
//! Python package for Ctrl-C): it ends early with `TraceError::Interrupted`,
//! and an unstopped one is bit-identical to `render_rows`.

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use gloam_trace::{RenderSettings, TraceError, Tracer};

const SCENE: &str = r#"
units = "m"
[camera]
position = [0, -3, 2]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov_deg = 60
width = 64
height = 48
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.floor]
reflectance = 0.5
[materials.lamp]
reflectance = 0.0
emission = { value = 1.0 }
[objects.floor]
material = "floor"
quad = { center = [0, 0, 0], size = [4, 4], normal = [0, 0, 1] }
[objects.lamp]
material = "lamp"
quad = { center = [0, 0, 2], size = [1, 1], normal = [0, 0, -1] }
"#;

fn tracer(spp: u32) -> Tracer {
    let scene = gloam_scene::parse_str(SCENE, Path::new("test.toml")).unwrap();
    let mut s = RenderSettings::default();
    s.set("spp", &spp.to_string()).unwrap();
    s.threads = Some(1);
    Tracer::new(&scene, &s).unwrap()
}

#[test]
fn a_stopped_render_ends_early_with_interrupted() {
    let t = tracer(4);
    let rows = 0..t.image_size().1;
    let polls = AtomicU64::new(0);
    // Stop after the third poll: the remaining tiles are skipped.
    let r = t.render_rows_until(rows.clone(), &|_, _| {}, &|| {
        polls.fetch_add(1, Ordering::Relaxed) >= 3
    });
    assert!(matches!(r, Err(TraceError::Interrupted)), "{r:?}");
    // Polled before each tile and each later row of it (16 rows of 16 ×
    // 16 tiles): the third poll's tile stops at its second row; after that
    // the flag is remembered and `stop` is not asked again.
    assert_eq!(polls.load(Ordering::Relaxed), 4);
}

#[test]
fn an_unstopped_render_is_bit_identical() {
    let t = tracer(2);
    let rows = 0..t.image_size().1;
    let a = t.render_rows(rows.clone(), &|_, _| {}).unwrap();
    let b = t.render_rows_until(rows, &|_, _| {}, &|| false).unwrap();
    assert_eq!(a.radiance, b.radiance);
    assert_eq!(a.std_error, b.std_error);
    assert!(a.radiance.iter().any(|&v| v > 0.0));
}
