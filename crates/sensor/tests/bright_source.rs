//! The intensifier's bright-source stages in the whole chain: off (and
//! bit-identical) in a uniform field, on around a lamp, the ABC holding the
//! screen current to its limit.

mod common;

use common::{camera, clean, uniform};
use gloam_sensor::Camera;
use ndarray::Array2;

fn no_bright(mut cfg: gloam_sensor::SensorConfig) -> gloam_sensor::SensorConfig {
    cfg.bright_source.halo.enabled = false;
    cfg.bright_source.mcp_depletion.enabled = false;
    cfg.bright_source.abc.enabled = false;
    cfg
}

#[test]
fn a_uniform_field_is_bit_identical_with_the_stages_off() {
    // Noise, patterns and persistence on: the full preset.
    let cfg = gloam_sensor::SensorConfig::preset("gen3-gaas-iccd")
        .unwrap()
        .unwrap();
    let field = uniform(48, 64, 2.0);
    let mut a = Camera::new(cfg.clone()).unwrap();
    let mut b = Camera::new(no_bright(cfg)).unwrap();
    for _ in 0..3 {
        let (fa, fb) = (
            a.capture_photoelectrons(field.view()).unwrap(),
            b.capture_photoelectrons(field.view()).unwrap(),
        );
        assert_eq!(fa.pixels, fb.pixels);
        assert!(!fa.sensor().unwrap().saturation.bright_source_in_view);
        assert_eq!(fa.sensor().unwrap().saturation.halo_fraction, 0.0);
    }
}

#[test]
fn the_halo_reaches_twice_the_gap_around_a_lamp_and_no_further() {
    // Noise off: means. A 3×3 lamp at 50 pe on a 0.01 pe floor at the
    // minimum gain (the CCD clips at ~43 pe there, so the lamp clips but
    // its halo, 8 % spread over ~4 500 pixels, does not).
    let mut cfg = clean("gen3-gaas-iccd");
    cfg.noise.enabled = false;
    cfg.optics.vignetting = false;
    let gmin = Camera::new(cfg.clone()).unwrap().chain().gain_min;
    let (rows, cols) = (128, 128);
    let scene = Array2::from_shape_fn((rows, cols), |(r, c)| {
        if (63..=65).contains(&r) && (63..=65).contains(&c) {
            5000.0
        } else {
            0.01
        }
    });
    let mut on = camera(cfg.clone(), Some(gmin));
    let mut off = camera(no_bright(cfg), Some(gmin));
    let f_on = on.capture_photoelectrons(scene.view()).unwrap();
    let f_off = off.capture_photoelectrons(scene.view()).unwrap();
    assert!(f_on.sensor().unwrap().saturation.bright_source_in_view);
    let b = gloam_sensor::stages::bright::BrightStages::of(on.chain()).unwrap();
    let radius = b.halo.as_ref().unwrap().radius_px;
    // 2 × 0.2 mm over 6.45 µm / 0.611 at the cathode: 37.9 px.
    assert!((radius - 0.4 / (6.45e-3 / 0.611)).abs() < 1e-9);
    let lift =
        |c: usize| f_on.view().unwrap()[[64, c]] as f64 - f_off.view().unwrap()[[64, c]] as f64;
    // Inside the disc (beyond the blur of the lamp itself) the halo lifts
    // the floor; well outside it, nothing.
    assert!(lift(64 + 20) >= 1.0, "inside: {}", lift(84));
    assert!(lift(64 + 30) >= 1.0, "inside: {}", lift(94));
    assert!(lift(64 + 45).abs() <= 0.5, "outside: {}", lift(109));
    assert!(lift(64 - 45).abs() <= 0.5, "outside: {}", lift(19));
}

#[test]
fn the_abc_holds_the_mean_screen_current_to_its_limit() {
    // A uniform field far too bright: the tube's supply cuts the MCP gain
    // to its minimum, then gates, until the mean screen charge η G d λ is
    // its limit (closed form from the limit, the open area and the input).
    let mut cfg = clean("gen3-gaas-iccd");
    cfg.noise.enabled = false;
    let lambda = 1e5;
    let mut cam = camera(cfg, None);
    let g_set = cam.gain();
    let b = gloam_sensor::stages::bright::BrightStages::of(cam.chain()).unwrap();
    let abc = b.abc.unwrap();
    let eta = cam.config().mcp.as_ref().unwrap().open_area_fraction;
    let field = uniform(32, 32, lambda);
    let mut last = None;
    for _ in 0..150 {
        last = Some(cam.capture_photoelectrons(field.view()).unwrap());
    }
    let f = last.unwrap();
    let s = &f.sensor().unwrap().saturation;
    assert!((f.sensor().unwrap().gain_in_effect / cam.chain().gain_min - 1.0).abs() < 1e-9);
    assert!(s.abc.duty_factor < 1.0 && !s.abc_out_of_range);
    let screen = eta * f.sensor().unwrap().gain_in_effect * s.abc.duty_factor * lambda;
    assert!(
        (screen / abc.limit_e_per_pixel - 1.0).abs() < 1e-3,
        "{screen} vs {}",
        abc.limit_e_per_pixel
    );
    assert!(g_set > f.sensor().unwrap().gain_in_effect);
}

#[test]
fn pore_depletion_compresses_a_lamp_and_its_patch_recovers_with_tau() {
    // Ungated, at the maximum gain: a lamp pixel demands far more than the
    // plate's current limit; the frame after the lamp goes out still shows
    // the depleted patch dimmer than its surroundings.
    let mut cfg = clean("gen3-gaas-iccd");
    cfg.noise.enabled = false;
    cfg.bright_source.halo.enabled = false;
    cfg.bright_source.abc.enabled = false;
    let mut cam = Camera::new(cfg).unwrap();
    let gmax = cam.chain().gain_max;
    cam.set_override_gain(Some(gmax)).unwrap();
    let scene = Array2::from_shape_fn((32, 32), |(r, c)| if r < 4 && c < 4 { 1e4 } else { 0.01 });
    let f = cam.capture_photoelectrons(scene.view()).unwrap();
    // The lamp's 16 pixels and the ring the optics blur spreads it into
    // (still hundreds of pe there); not the floor.
    let c = f.sensor().unwrap().saturation.mcp_compressed_fraction;
    assert!((16.0 / 1024.0..=100.0 / 1024.0).contains(&c), "{c}");
    assert_eq!(
        f.sensor().unwrap().saturation.saturated_by,
        gloam_sensor::stages::bright::SaturatingStage::VideoClip
    );
    // The lamp goes out: a uniform floor, but the patch's reservoirs are
    // still depleted (ungated, no off-time to recover in).
    let floor = uniform(32, 32, 0.01);
    let f2 = cam.capture_photoelectrons(floor.view()).unwrap();
    assert!(!f2.sensor().unwrap().saturation.bright_source_in_view);
    let (patch, rest) = (
        f2.view().unwrap()[[1, 1]] as f64,
        f2.view().unwrap()[[20, 20]] as f64,
    );
    let black = cam.chain().black_dn(gmax);
    // Emptied reservoirs refill as 1 − e^{−t/τ} over the 40 ms frame
    // (τ = 10 ms), so the patch gives the mean of that: 1 − (1 − e^{−4})/4.
    let want = 1.0 - (1.0 - (-4.0f64).exp()) / 4.0;
    let ratio = (patch - black) / (rest - black);
    assert!(
        (ratio - want).abs() < 0.02,
        "{patch} vs {rest}: {ratio} vs {want}"
    );
}
