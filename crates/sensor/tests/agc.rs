//! The AGC loop and other memory of the chain: step response, limits,
//! bright-source protection, override, phosphor persistence, determinism.

mod common;

use common::*;
use gloam_sensor::{AgcState, Camera};

fn agc_camera() -> Camera {
    let mut cfg = clean("gen3-gaas-iccd");
    cfg.agc.as_mut().unwrap().enabled = true;
    Camera::new(cfg).unwrap()
}

#[test]
fn agc_step_response_has_the_configured_time_constant() {
    let mut cam = agc_camera();
    let tau = cam.config().agc.as_ref().unwrap().time_constant_s;
    let dt = 1.0 / cam.config().timing.frame_rate_hz;
    let (l1, l2) = (4.0, 8.0);
    let lo = uniform(128, 128, l1);
    let hi = uniform(128, 128, l2);
    for _ in 0..150 {
        cam.capture_photoelectrons(lo.view()).unwrap();
    }
    let g1 = cam.gain();
    let mut log_g = Vec::new();
    for _ in 0..200 {
        let f = cam.capture_photoelectrons(hi.view()).unwrap();
        assert!(f.sensor().unwrap().agc_enabled);
        assert_eq!(f.sensor().unwrap().agc_state, AgcState::Tracking);
        log_g.push(f.sensor().unwrap().gain_in_effect.ln());
    }
    let g_inf = log_g.last().unwrap();
    // Settles to half the gain for twice the light.
    assert!(((g_inf - g1.ln()) - 0.5f64.ln()).abs() < 0.01);
    // ln|error| against time over the decay from 100 % to 3 %.
    let err0 = log_g[0] - g_inf;
    let pts: Vec<(f64, f64)> = log_g
        .iter()
        .enumerate()
        .map(|(n, lg)| (n as f64 * dt, (lg - g_inf) / err0))
        .take_while(|(_, e)| *e > 0.03)
        .map(|(t, e)| (t, e.ln()))
        .collect();
    let n = pts.len() as f64;
    let mt = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let me = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let slope = pts.iter().map(|p| (p.0 - mt) * (p.1 - me)).sum::<f64>()
        / pts.iter().map(|p| (p.0 - mt).powi(2)).sum::<f64>();
    let measured = -1.0 / slope;
    println!(
        "AGC τ measured {measured:.4} s vs configured {tau} s over {} frames",
        pts.len()
    );
    assert!((measured / tau - 1.0).abs() < 0.05);
}

#[test]
fn agc_in_darkness_rises_to_its_limit() {
    // With dark emission (EBI) the loop settles where the EBI itself fills
    // the set-point, below the limit (real tubes do this too).
    let mut cam = agc_camera();
    let dark = uniform(64, 64, 0.0);
    let mut f = None;
    for _ in 0..400 {
        f = Some(cam.capture_photoelectrons(dark.view()).unwrap());
    }
    let f = f.unwrap();
    let set = cam.config().agc.as_ref().unwrap().set_point_dn;
    let signal =
        f.sensor().unwrap().mean_dn - cam.chain().black_dn(f.sensor().unwrap().gain_in_effect);
    println!(
        "EBI-limited AGC: gain {:.0}, signal {signal:.0} DN (set-point {set}), {:?}",
        f.sensor().unwrap().gain_in_effect,
        f.sensor().unwrap().agc_state
    );
    // Sparse, bright EBI events: the loop hunts between tracking and
    // protection below the limit instead of running away.
    assert!(f.sensor().unwrap().gain_in_effect < cam.chain().gain_max);
    assert!(signal > 0.0 && signal < 2.0 * set);

    // Without EBI nothing is left to servo on: the gain goes to its limit.
    let mut cfg = clean("gen3-gaas-iccd");
    cfg.agc.as_mut().unwrap().enabled = true;
    cfg.photocathode.as_mut().unwrap().ebi_lm_cm2 = 0.0;
    let mut cam = Camera::new(cfg).unwrap();
    let mut last = None;
    for _ in 0..400 {
        last = Some(cam.capture_photoelectrons(dark.view()).unwrap());
    }
    let f = last.unwrap();
    let ch = cam.chain();
    assert!((f.sensor().unwrap().gain_in_effect / ch.gain_max - 1.0).abs() < 1e-9);
    assert_eq!(f.sensor().unwrap().agc_state, AgcState::AtMaxGain);
    let v = f.sensor().unwrap().mcp_voltage_v.unwrap();
    assert!((v - cam.config().mcp.as_ref().unwrap().max_voltage_v).abs() < 1e-6);
    assert!(
        f.pixels
            .iter()
            .all(|&p| (p as f64) < ch.saturation_dn(ch.gain_max))
    );
}

#[test]
fn bright_source_protection_cuts_gain_fast() {
    // The camera's AGC alone: the tube's own ABC (which would also act on
    // this lamp, tests/bright_source.rs) is switched off.
    let mut cfg = clean("gen3-gaas-iccd");
    cfg.agc.as_mut().unwrap().enabled = true;
    cfg.bright_source.abc.enabled = false;
    let mut cam = Camera::new(cfg).unwrap();
    // A lamp filling 20 % of the view at a flux that saturates any gain.
    let scene = ndarray::Array2::from_shape_fn((64, 64), |(r, _)| if r < 13 { 1e6 } else { 0.1 });
    let f0 = cam.capture_photoelectrons(scene.view()).unwrap();
    assert!(f0.sensor().unwrap().saturated_fraction > 0.05);
    let g0 = f0.sensor().unwrap().gain_in_effect;
    let f1 = cam.capture_photoelectrons(scene.view()).unwrap();
    assert_eq!(f1.sensor().unwrap().agc_state, AgcState::Protecting);
    assert!((f1.sensor().unwrap().gain_in_effect / g0 - 0.5).abs() < 1e-9);
    let mut g = f1.sensor().unwrap().gain_in_effect;
    for _ in 0..40 {
        let f = cam.capture_photoelectrons(scene.view()).unwrap();
        assert!(f.sensor().unwrap().gain_in_effect <= g * (1.0 + 1e-12));
        g = f.sensor().unwrap().gain_in_effect;
    }
    assert!(
        (g / cam.chain().gain_min - 1.0).abs() < 1e-9,
        "clamped at the lower limit"
    );
}

#[test]
fn override_fixes_gain_and_returns_to_agc() {
    let mut cam = agc_camera();
    cam.set_override_gain(Some(100.0)).unwrap();
    for l in [0.1, 10.0, 0.0] {
        let f = cam
            .capture_photoelectrons(uniform(32, 32, l).view())
            .unwrap();
        assert_eq!(f.sensor().unwrap().gain_in_effect, 100.0);
        assert_eq!(f.sensor().unwrap().agc_state, AgcState::Override);
        assert!(!f.sensor().unwrap().agc_enabled);
    }
    cam.set_override_gain(None).unwrap();
    let f = cam
        .capture_photoelectrons(uniform(32, 32, 10.0).view())
        .unwrap();
    assert!(f.sensor().unwrap().agc_enabled);
    let f2 = cam
        .capture_photoelectrons(uniform(32, 32, 10.0).view())
        .unwrap();
    assert!(f2.sensor().unwrap().gain_in_effect < f.sensor().unwrap().gain_in_effect);
    // Limits.
    let ch = cam.chain().clone();
    assert!(cam.set_override_gain(Some(ch.gain_min)).is_ok());
    assert!(cam.set_override_gain(Some(ch.gain_max)).is_ok());
    assert!(cam.set_override_gain(Some(ch.gain_max * 1.01)).is_err());
    assert!(cam.set_override_gain(Some(ch.gain_min * 0.99)).is_err());
    assert!(cam.set_override_gain(Some(f64::NAN)).is_err());
}

#[test]
fn phosphor_persistence_decays_geometrically() {
    let mut cfg = clean("gen3-gaas-iccd");
    cfg.phosphor.as_mut().unwrap().lag_fraction = Some(0.1);
    cfg.noise.enabled = false;
    cfg.ccd.dark_current_e_s = 0.0;
    cfg.photocathode.as_mut().unwrap().ebi_lm_cm2 = 0.0;
    let mut cam = camera(cfg, Some(30.0));
    let black = cam.chain().black_dn(30.0);
    let bright = uniform(32, 32, 10.0);
    let dark = uniform(32, 32, 0.0);
    let s0 = mean(&interior(
        &cam.capture_photoelectrons(bright.view()).unwrap(),
        4,
    )) - black;
    let s1 = mean(&interior(
        &cam.capture_photoelectrons(dark.view()).unwrap(),
        4,
    )) - black;
    let s2 = mean(&interior(
        &cam.capture_photoelectrons(dark.view()).unwrap(),
        4,
    )) - black;
    println!("persistence: {s0:.1} → {s1:.2} → {s2:.3} DN");
    assert!((s1 / s0 - 0.1).abs() < 0.002);
    assert!((s2 / s0 - 0.01).abs() < 0.002);
}

#[test]
fn frames_are_bit_identical_across_thread_counts_and_seeded() {
    let scene = gloam_sensor::bench::test_scene(160, 120, 1.0);
    let run = |threads: usize, seed: u64| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut cfg = gloam_sensor::SensorConfig::preset("gen3-gaas-iccd")
                .unwrap()
                .unwrap();
            cfg.noise.seed = seed;
            let mut cam = Camera::new(cfg).unwrap();
            (0..3)
                .map(|_| cam.capture_photoelectrons(scene.view()).unwrap())
                .collect::<Vec<_>>()
        })
    };
    let a = run(1, 7);
    let b = run(2, 7);
    let c = run(3, 7);
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert_ne!(a[1].pixels, a[2].pixels, "frames differ in time");
    let d = run(2, 8);
    assert_ne!(a[0].pixels, d[0].pixels, "seed matters");
}
