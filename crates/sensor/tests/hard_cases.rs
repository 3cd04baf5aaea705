//! Hard cases: no light, single photoelectrons, a lamp beside starlight,
//! coarse quantisation, saturated frames, and bad configurations.

mod common;

use common::*;
use gloam_sensor::{CaptureError, ConfigError, SensorConfig};
use ndarray::Array2;

#[test]
fn zero_photons_give_black_plus_dark() {
    for (name, _) in gloam_sensor::PRESETS {
        let mut cam = camera(clean(name), None);
        let g = cam.gain();
        let f = cam
            .capture_photoelectrons(uniform(96, 96, 0.0).view())
            .unwrap();
        let ch = cam.chain();
        let m = mean(&interior(&f, 0));
        let expected = ch.expected_mean_dn_from_pe(0.0, g);
        println!("{name}: dark frame {m:.2} DN, analytic {expected:.2} DN");
        assert!(m.is_finite());
        assert!(f.sensor().unwrap().saturated_fraction < 0.05, "{name}");
        if ch.ebi_pe(g) * ch.mean_dn_per_photoelectron(g) < 1.0 {
            assert!((m - expected).abs() < 1.0, "{name}: {m} vs {expected}");
        }
    }
}

#[test]
fn one_photoelectron_per_frame_is_counted() {
    // 64×64 pixels sharing one photoelectron per frame on average.
    let mut cfg = clean("gen3-gaas-iccd");
    cfg.photocathode.as_mut().unwrap().ebi_lm_cm2 = 0.0;
    let mut cam = camera(cfg, None);
    let g = cam.gain();
    let n_pix = 64.0 * 64.0;
    let field = uniform(64, 64, 1.0 / n_pix);
    let ch = cam.chain().clone();
    let zero = ch.expected_mean_dn_from_pe(0.0, g);
    let per_pe = ch.mean_dn_per_photoelectron(g);
    let frames = 300;
    let mut counts = Vec::new();
    for _ in 0..frames {
        let f = cam.capture_photoelectrons(field.view()).unwrap();
        let total: f64 = f.pixels.iter().map(|&p| p as f64 - zero).sum();
        counts.push(total / per_pe);
    }
    let m = mean(&counts);
    let v = variance(&counts);
    // Poisson(1) compounded with the gain noise: mean 1, variance F.
    let f_excess = ch.excess_noise_factor(g);
    let se = (f_excess / frames as f64).sqrt();
    println!("one pe/frame: mean {m:.3} (±{se:.3}), variance {v:.2} (F = {f_excess:.2})");
    assert!((m - 1.0).abs() < 4.0 * se);
    assert!((v / f_excess - 1.0).abs() < 0.35);
    let empty = counts.iter().filter(|c| c.abs() < 0.3).count() as f64 / frames as f64;
    // P(no detected electron) = exp(−η) for η = open-area fraction.
    let p0 = (-ch.intensifier().unwrap().mcp.open_area).exp();
    assert!((empty - p0).abs() < 0.1, "empty fraction {empty} vs {p0}");
}

#[test]
fn saturated_lamp_beside_starlit_field() {
    for name in ["gen3-gaas-iccd", "gen2-s20-iccd", "scientific-ccd"] {
        let mut cfg = clean(name);
        cfg.optics.vignetting = false;
        // The CCD's spatial isolation only: the tube's ABC, which a lamp
        // this bright trips (cutting the whole frame's gain from the next
        // frame on), and its halo, which at 10⁷× the field saturates a
        // disc of 2 × the cathode–MCP gap around it, are off; both are
        // tested in tests/bright_source.rs.
        cfg.bright_source.abc.enabled = false;
        cfg.bright_source.halo.enabled = false;
        let mut cam = camera(cfg, None);
        let g = cam.gain();
        let ch = cam.chain().clone();
        let star = 0.05 * (ch.saturation_dn(g) - ch.black_dn(g)) / ch.mean_dn_per_photoelectron(g);
        let (rows, cols) = (128, 128);
        let scene = Array2::from_shape_fn((rows, cols), |(r, c)| {
            if (60..66).contains(&r) && (30..36).contains(&c) {
                1e7 * star.max(1.0)
            } else {
                star
            }
        });
        let frames: Vec<_> = (0..6)
            .map(|_| cam.capture_photoelectrons(scene.view()).unwrap())
            .collect();
        let f = &frames[0];
        let sat = ch.saturation_dn(g) as u16;
        let tol = (6.0 * ch.read_noise_dn(g)).ceil() as u16 + 1;
        assert!(
            f.view().unwrap()[[62, 32]] + tol >= sat,
            "{name}: lamp saturates"
        );
        // Far from the lamp the starlit field is undisturbed: its mean is
        // within 4 standard errors of the analytic one (the noise is
        // correlated over ~1/S² pixels by the post-gain blur).
        let mut far = Vec::new();
        for f in &frames {
            for r in 8..120 {
                for c in 80..120 {
                    far.push(f.view().unwrap()[[r, c]] as f64);
                }
            }
        }
        let expected = ch.expected_mean_dn_from_pe(star, g);
        let m = mean(&far);
        let n_eff = far.len() as f64 * ch.post_noise_variance_factor(g);
        let se = (ch.temporal_variance_dn2_from_pe(star, g) / n_eff).sqrt();
        println!(
            "{name}: starlit field {m:.2} DN (analytic {expected:.2} ± {se:.2}), lamp {}",
            f.view().unwrap()[[62, 32]]
        );
        assert!((m - expected).abs() < 4.0 * se + 1.0);
        // Blooming runs along the lamp's columns, not across rows.
        let bloom_up = f.view().unwrap()[[50, 32]] as f64;
        let side = f.view().unwrap()[[62, 70]] as f64;
        if cam.config().ccd.blooming {
            assert!(
                bloom_up + tol as f64 >= sat as f64,
                "{name}: charge spills along the column"
            );
        }
        assert!(
            side + (tol as f64) < sat as f64,
            "{name}: no spill across the row"
        );
    }
}

#[test]
fn eight_bit_quantisation_of_a_sixteen_bit_scene() {
    let mut cfg = clean("gen2-s20-iccd");
    cfg.noise.enabled = false;
    cfg.optics.vignetting = false;
    let mut cam = camera(cfg, Some(100.0));
    let g = 100.0;
    let ch = cam.chain().clone();
    let full = (ch.saturation_dn(g) - ch.black_dn(g)) / ch.mean_dn_per_photoelectron(g);
    // 65536 input levels from 0 to 2× full scale along a ramp.
    let scene = Array2::from_shape_fn((4, 65536 / 4), |(r, c)| {
        ((r * 16384 + c) as f64 / 65535.0) * 2.0 * full
    });
    // Each row is its own ramp segment; MTF smooths only across neighbours.
    let f = cam.capture_photoelectrons(scene.view()).unwrap();
    assert_eq!(f.meta.bits, 8);
    let max = *f.pixels.iter().max().unwrap();
    assert!(max as f64 <= ch.saturation_dn(g) && max <= 255);
    let mut levels: Vec<u16> = f.pixels.to_vec();
    levels.sort_unstable();
    levels.dedup();
    assert!(levels.len() <= 256);
    assert!(levels.len() > 200, "uses most codes: {}", levels.len());
    // Monotonic along the middle row (away from the row ends).
    let view = f.view().unwrap();
    let row = view.row(1);
    for w in row.as_slice().unwrap()[20..16000].windows(2) {
        assert!(w[1] >= w[0]);
    }
}

#[test]
fn all_black_and_all_white_frames() {
    for (name, _) in gloam_sensor::PRESETS {
        // Capped lens, and no dark emission (a single EBI event at full
        // gain can itself saturate a pixel).
        let mut cfg = clean(name);
        if let Some(p) = &mut cfg.photocathode {
            p.ebi_lm_cm2 = 0.0;
        }
        let mut cam = camera(cfg, None);
        let g = cam.gain();
        let ch = cam.chain().clone();
        let white = cam
            .capture_photoelectrons(uniform(48, 64, 1e9).view())
            .unwrap();
        let sat = ch.saturation_dn(g) as u16;
        let tol = (6.0 * ch.read_noise_dn(g)).ceil() as u16;
        assert!(
            white.pixels.iter().all(|&p| p.abs_diff(sat) <= tol),
            "{name}: all white"
        );
        assert!(white.sensor().unwrap().saturated_fraction > 0.99);
        let black = cam
            .capture_photoelectrons(uniform(48, 64, 0.0).view())
            .unwrap();
        assert!(black.pixels.iter().all(|&p| p + tol < sat), "{name}");
        assert!(black.sensor().unwrap().mean_dn.is_finite());
    }
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let mut cam = camera(clean("gen3-gaas-iccd"), None);
    let mut img = uniform(8, 8, 1.0);
    img[[3, 4]] = f64::NAN;
    match cam.capture_photoelectrons(img.view()) {
        Err(CaptureError::BadRadiance { row: 3, col: 4, .. }) => {}
        other => panic!("{other:?}"),
    }
    img[[3, 4]] = -1.0;
    assert!(cam.capture_photoelectrons(img.view()).is_err());
    let empty = Array2::<f64>::zeros((0, 5));
    assert!(cam.capture_photoelectrons(empty.view()).is_err());
    let shape = gloam_spectra::library::get("cie-a").unwrap();
    let bands = ndarray::Array3::<f64>::zeros((2, 4, 4));
    assert!(matches!(
        cam.capture(bands.view(), std::slice::from_ref(&shape)),
        Err(CaptureError::BandMismatch { .. })
    ));
    let dark_shape = gloam_spectra::Spectrum::constant(2000.0, 3000.0, 0.0).unwrap();
    assert!(matches!(
        cam.capture_mono(uniform(4, 4, 1.0).view(), &dark_shape),
        Err(CaptureError::EmptyBand { band: 0 })
    ));
}

fn preset_text(name: &str) -> String {
    gloam_sensor::PRESETS
        .iter()
        .find(|p| p.0 == name)
        .unwrap()
        .1
        .to_string()
}

fn err_of(text: &str) -> String {
    SensorConfig::from_toml_str(text, "test.toml")
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_configs_name_the_field() {
    let base = preset_text("gen3-gaas-iccd");
    let cases = [
        ("f_number = 1.4", "f_number = nan", "optics.f_number"),
        (
            "read_noise_e = 8.0",
            "read_noise_e = -8.0",
            "ccd.read_noise_e",
        ),
        ("gain_shape = 1.5", "gain_shape = inf", "mcp.gain_shape"),
        ("voltage_v = 750.0", "voltage_v = 1500.0", "mcp.voltage_v"),
        ("bits = 12", "bits = 20", "digitizer.bits"),
        ("exposure_s = 0.04", "exposure_s = 0.5", "timing.exposure_s"),
        (
            "qe = \"qe-gen3-gaas\"",
            "qe = \"no-such-cathode\"",
            "photocathode.qe",
        ),
        ("f_number = 1.4\n", "", "f_number"),
        (
            "time_constant_s = 0.5",
            "time_constant_s = 0.0",
            "agc.time_constant_s",
        ),
    ];
    for (from, to, field) in cases {
        assert!(base.contains(from), "{from}");
        let e = err_of(&base.replacen(from, to, 1));
        println!("{field}: {e}");
        assert!(e.contains(field), "{field} not named in: {e}");
    }
    // A whole stage missing.
    let no_mcp = base.replace("[mcp]", "[unused]");
    let e = err_of(&no_mcp);
    assert!(e.contains("unused") || e.contains("mcp"), "{e}");
    let start = base.find("[mcp]").unwrap();
    let end = base.find("[phosphor]").unwrap();
    let e = err_of(&format!("{}{}", &base[..start], &base[end..]));
    println!("{e}");
    assert!(e.contains("`mcp`"), "{e}");
    // Stages that do not belong.
    let sci = preset_text("scientific-ccd");
    let e = err_of(&format!(
        "{sci}\n[ebccd]\nvoltage_v = 8000.0\nmin_voltage_v = 3000.0\nmax_voltage_v = 10000.0\ndead_layer_ev = 1500.0\nbackscatter_fraction = 0.1\n"
    ));
    assert!(e.contains("ebccd"), "{e}");
    // Unknown preset or file.
    let e =
        SensorConfig::load_preset_or_file("no-such-sensor", &gloam_io::ReadLog::off()).unwrap_err();
    assert!(matches!(e, ConfigError::Unknown { .. }));
    assert!(e.to_string().contains("no-such-sensor"));
}
