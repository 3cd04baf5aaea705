//! The render's own measurement of the radiosity cache's bias (issue 43):
//! made deliberately biased (a coarse cache read by interpolation, no
//! final gather), the office's bias over the pixels that see no emitter is
//! measured here against a 64-bounce path-traced render, and the bias the
//! render states in `error.bias` must agree with it within their noise.

use std::path::Path;

use gloam_trace::{Indirect, RenderSettings};

#[test]
fn the_stated_cache_bias_is_the_bias_against_path_tracing() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sims/office-room/scene.toml");
    let scene = gloam_scene::load(&path, &gloam_io::ReadLog::off()).unwrap();
    let base = RenderSettings {
        resolution_scale: 0.1,
        ..RenderSettings::default()
    };
    let biased = RenderSettings {
        indirect: Indirect::Cache,
        cache_texels: 64,
        gather_rays: 0,
        spp: 16,
        ..base.clone()
    };
    let reference = RenderSettings {
        indirect: Indirect::Path,
        diffuse_bounces: 64,
        spp: 256,
        ..base
    };
    let a = gloam_trace::render(&scene, &biased).unwrap();
    let b = gloam_trace::render(&scene, &reference).unwrap();
    let stated = a
        .error
        .bias
        .as_ref()
        .expect("a cache render states its bias");
    assert!(b.error.bias.is_none(), "path tracing has no cache bias");
    // Pixels that see no emitter: the direct-view term is the same in
    // both (computed apart, same seed), so leave out every pixel whose
    // value the troffers' faces dominate in either.
    let (ra, rb) = (
        a.radiance.index_axis(ndarray::Axis(0), 0),
        b.radiance.index_axis(ndarray::Axis(0), 0),
    );
    let (sa, sb) = (
        a.std_error.index_axis(ndarray::Axis(0), 0),
        b.std_error.index_axis(ndarray::Axis(0), 0),
    );
    let peak = rb.iter().copied().fold(0.0, f64::max);
    let (mut sum_a, mut sum_b, mut var_a, mut var_b, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (((x, y), ex), ey) in ra.iter().zip(rb.iter()).zip(sa.iter()).zip(sb.iter()) {
        if *y > 0.0 && *y < 0.02 * peak {
            sum_a += x;
            sum_b += y;
            var_a += ex * ex;
            var_b += ey * ey;
            n += 1.0;
        }
    }
    assert!(n > 400.0, "{n} pixels");
    let actual = sum_a / sum_b - 1.0;
    let actual_se = (var_a / (sum_a * sum_a) + var_b / (sum_b * sum_b)).sqrt();
    let band = &stated.bands[0];
    let tol = 3.0 * band.relative_bias_std_error.hypot(actual_se);
    eprintln!(
        "actual {actual:+.4} ± {actual_se:.4}; stated {:+.4} ± {:.4}",
        band.relative_bias, band.relative_bias_std_error
    );
    // The deliberate bias must be large enough to tell from noise ...
    assert!(
        actual.abs() > 2.0 * tol,
        "actual bias {actual} vs tolerance {tol}"
    );
    // ... and the render must state it.
    assert!(
        (band.relative_bias - actual).abs() < tol,
        "stated {} vs actual {actual} (tolerance {tol})",
        band.relative_bias
    );
    assert!(stated.relative_bias_bound >= band.relative_bias.abs());
}
