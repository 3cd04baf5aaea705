//! The simulated grabber, and bit-identity with the emulator over a link.

mod common;

use gloam_grabber::{
    DeviceControl, FrameGrabber, FrameStream, Framing, GrabError, OpenOptions, Stimulus,
};
use gloam_simcam::{
    SceneImage, SceneView, SensorSource, SimGrabber, SimUri, open, open_sim, registry,
};

/// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78), one bit at a time.
fn crc32c_bitwise(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0x82F6_3B78
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn reference_crc32c_has_the_standard_check_value() {
    // The catalogued check value of CRC-32C over "123456789" (RFC 3720, B.4;
    // Koopman's CRC catalogue).
    assert_eq!(crc32c_bitwise(b"123456789"), 0xE306_9283);
    // And the grabber's blockwise pixel CRC agrees on a frame whose bytes
    // span several of its 4 KiB blocks.
    let pixels: Vec<u16> = (0..5000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 16) as u16)
        .collect();
    let bytes: Vec<u8> = pixels.iter().flat_map(|p| p.to_le_bytes()).collect();
    assert_eq!(
        gloam_grabber::pixels_crc32c(&pixels),
        crc32c_bitwise(&bytes)
    );
}

#[test]
fn sim_uri_opens_and_grabs() {
    let mut g = open("sim:gen2-s20-iccd?size=64x48&seed=3").unwrap();
    assert_eq!(g.frame_size(), (64, 48));
    assert_eq!(g.set_bits(12).unwrap(), 12);
    let f = g.grab().unwrap();
    assert_eq!(f.meta.seq, 0);
    assert_eq!(f.pixels.len(), 64 * 48);
    assert!(f.pixels.iter().all(|&p| p < 4096));
    assert!(
        f.pixels.iter().any(|&p| p > 0),
        "uniform rig should give signal"
    );
    // The frame's CRC against an independent bitwise CRC-32C of its
    // little-endian bytes (not the function that made it).
    let bytes: Vec<u8> = f.pixels.iter().flat_map(|p| p.to_le_bytes()).collect();
    assert_eq!(f.meta.pixels_crc32c, crc32c_bitwise(&bytes));
    assert!(g.present(&Stimulus::Dark).unwrap());
    let d = g.grab().unwrap();
    let mean = |p: &[u16]| p.iter().map(|&v| f64::from(v)).sum::<f64>() / p.len() as f64;
    assert!(mean(&d.pixels) < mean(&f.pixels));
    assert!(open("sim:no-such-preset").is_err());
}

#[test]
fn same_seed_same_frames_in_process_and_over_the_link() {
    for framing in [Framing::Cobs, Framing::UsbTransfers] {
        let mut sim = SimGrabber::from_preset(
            "gen3-gaas-iccd",
            "sine",
            11,
            (48, 32),
            &gloam_io::ReadLog::off(),
        )
        .unwrap();
        let src = SensorSource::new(
            "gen3-gaas-iccd",
            "sine",
            11,
            (48, 32),
            &gloam_io::ReadLog::off(),
        )
        .unwrap();
        let (mut wire, emu) = common::over_the_wire(src, framing);
        for g in [&mut sim as &mut dyn FrameGrabber, &mut wire] {
            g.set_bits(16).unwrap();
            g.set_gain(150.0).unwrap();
        }
        for _ in 0..4 {
            let a = sim.grab().unwrap();
            let b = wire.grab().unwrap();
            assert_eq!(a.meta.seq, b.meta.seq);
            assert_eq!(
                a.meta.pixels_crc32c, b.meta.pixels_crc32c,
                "{framing:?} seq {}",
                a.meta.seq
            );
            assert_eq!(a.pixels, b.pixels);
            assert_eq!(a.meta.gain, b.meta.gain);
            assert_eq!((a.meta.bits, a.meta.agc), (b.meta.bits, b.meta.agc));
        }
        drop(wire);
        emu.stop().unwrap();
    }
}

/// A two-band scene: a bright left half and a dark right half in band 0,
/// uniform in band 1.
fn two_band_scene(w: usize, h: usize) -> SceneView {
    let radiance = ndarray::Array3::from_shape_fn((2, h, w), |(b, _, c)| match b {
        0 if c < w / 2 => 2e-4,
        0 => 2e-5,
        _ => 1e-5,
    });
    let band = |lo: f64, hi: f64| gloam_spectra::Spectrum::constant(lo, hi, 1.0).unwrap();
    SceneView {
        label: "two-band test scene".into(),
        image: SceneImage::Bands {
            radiance_w_m2_sr: radiance,
            band_shapes: vec![band(450.0, 550.0), band(550.0, 650.0)],
        },
    }
}

#[test]
fn out_of_range_gains_are_refused_in_process_and_by_the_emulator() {
    // Gen III MCP: G = 1000 (V/800)^9 over 500–1000 V, so 14.552–7450.58.
    let mut sim = SimGrabber::from_preset(
        "gen3-gaas-iccd",
        "uniform",
        1,
        (8, 8),
        &gloam_io::ReadLog::off(),
    )
    .unwrap();
    let src = SensorSource::new(
        "gen3-gaas-iccd",
        "uniform",
        1,
        (8, 8),
        &gloam_io::ReadLog::off(),
    )
    .unwrap();
    let (mut wire, emu) = common::over_the_wire(src, Framing::Cobs);
    for g in [&mut sim as &mut dyn FrameGrabber, &mut wire] {
        for bad in [2.0, 14.551, 7451.0] {
            let e = g.set_gain(bad).unwrap_err();
            assert!(
                matches!(e, GrabError::InvalidSetting(_)) && e.to_string().contains("range"),
                "{bad}: {e}"
            );
        }
        assert_eq!(g.set_gain(14.552).unwrap(), 14.552);
        assert_eq!(g.set_gain(7450.58).unwrap(), 7450.58);
        // The frame runs at the gain asked for, not a clamped one.
        assert_eq!(g.grab().unwrap().meta.gain, 7450.58);
    }
    let e = sim.set_gain(2.0).unwrap_err().to_string();
    assert!(
        e.contains("'gen3-gaas-iccd'")
            && e.contains("14.552–7450.58")
            && e.contains("MCP 500–1000 V"),
        "{e}"
    );
    drop(wire);
    emu.stop().unwrap();
}

#[test]
fn scene_view_is_grabbed_at_its_size_until_a_stimulus_replaces_it() {
    let mut g = SimGrabber::from_scene(&gen2(), two_band_scene(40, 30), 5).unwrap();
    assert_eq!(g.frame_size(), (40, 30));
    g.set_gain(300.0).unwrap();
    let f = g.grab().unwrap();
    assert_eq!(f.pixels.len(), 40 * 30);
    let mean = |cols: std::ops::Range<usize>| {
        let (mut s, mut n) = (0.0, 0.0);
        for r in 0..30 {
            for c in cols.clone() {
                s += f64::from(f.pixels[r * 40 + c]);
                n += 1.0;
            }
        }
        s / n
    };
    // Away from the blurred edge, the bright half is brighter.
    let (left, right) = (mean(2..16), mean(24..38));
    assert!(left > 2.0 * right, "left {left} right {right}");

    // Same scene, same seed: the same frame (the scene is data, not a draw).
    let mut g2 = SimGrabber::from_scene(&gen2(), two_band_scene(40, 30), 5).unwrap();
    g2.set_gain(300.0).unwrap();
    assert_eq!(g2.grab().unwrap().pixels, f.pixels);

    // Presenting a stimulus (calibration) replaces the scene.
    g.present(&Stimulus::Dark).unwrap();
    let dark = g.grab().unwrap();
    let dark_mean = dark.pixels.iter().map(|&p| f64::from(p)).sum::<f64>() / 1200.0;
    assert!(dark_mean < right, "dark {dark_mean} vs scene {right}");
}

#[test]
fn bad_scenes_are_clear_errors() {
    fn radiance(v: &mut SceneView) -> &mut ndarray::Array3<f64> {
        match &mut v.image {
            SceneImage::Bands {
                radiance_w_m2_sr, ..
            } => radiance_w_m2_sr,
            SceneImage::Detected { .. } | SceneImage::Layers { .. } => unreachable!(),
        }
    }
    let mut nan = two_band_scene(8, 6);
    radiance(&mut nan)[[1, 4, 3]] = f64::NAN;
    let e = SimGrabber::from_scene(&gen2(), nan, 0)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("band 1, row 4, column 3"), "{e}");

    let mut neg = two_band_scene(8, 6);
    radiance(&mut neg)[[0, 0, 0]] = -1.0;
    let e = SimGrabber::from_scene(&gen2(), neg, 0)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("row 0, column 0"), "{e}");

    let mut shapes = two_band_scene(8, 6);
    if let SceneImage::Bands { band_shapes, .. } = &mut shapes.image {
        band_shapes.pop();
    }
    let e = SimGrabber::from_scene(&gen2(), shapes, 0)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("2 radiance bands but 1 band spectra"), "{e}");
    let mut detected = ndarray::Array2::from_elem((6, 8), 1e12);
    detected[[5, 7]] = f64::INFINITY;
    let e = SimGrabber::from_scene(
        &gen2(),
        SceneView {
            label: "d".into(),
            image: SceneImage::Detected {
                e_s_m2_sr: detected,
            },
        },
        0,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("row 5, column 7"), "{e}");

    // A scene URI without a renderer says what is missing.
    let e = open("sim:gen2-s20-iccd?scene=x.toml").err().unwrap();
    assert!(matches!(e, GrabError::Unsupported(_)), "{e}");
    // The layer that renders scenes registers its own `sim:` constructor;
    // a renderer's failure names the scene.
    let mut failing = registry();
    failing.register(
        "sim",
        std::sync::Arc::new(|uri, opts| {
            let SimUri {
                scene: Some(path), ..
            } = SimUri::parse(uri)?
            else {
                return open_sim(uri, opts, None);
            };
            Err(GrabError::Scene {
                path,
                source: "no such file".into(),
            })
        }),
    );
    let e = failing
        .open("sim:gen2-s20-iccd?scene=x.toml", &OpenOptions::default())
        .err()
        .unwrap();
    let chain = format!("{e}: {}", std::error::Error::source(&e).unwrap());
    assert!(
        chain.contains("x.toml") && chain.contains("no such file"),
        "{chain}"
    );
    // The renderer renders at the URI's size.
    let mut rendering = registry();
    rendering.register(
        "sim",
        std::sync::Arc::new(|uri, opts| {
            let SimUri { size, .. } = SimUri::parse(uri)?;
            let (w, h) = size.unwrap_or((4, 4));
            let sensor = gen2();
            open_sim(
                uri,
                opts,
                Some((two_band_scene(w as usize, h as usize), &sensor)),
            )
        }),
    );
    let g = rendering
        .open(
            "sim:gen2-s20-iccd?scene=x.toml&size=24x10",
            &OpenOptions::default(),
        )
        .unwrap();
    assert_eq!(g.frame_size(), (24, 10));
    // The transports alone refuse sim: and say where it lives.
    let e = gloam_grabber::open("sim:gen2-s20-iccd").err().unwrap();
    assert!(
        matches!(e, GrabError::Unsupported(_)) && e.to_string().contains("gloam-simcam"),
        "{e}"
    );
}

/// The Gen II camera, read once as a front end reads it.
fn gen2() -> gloam_sensor::ResolvedSensor {
    gloam_sensor::ResolvedSensor::load("gen2-s20-iccd", &gloam_io::ReadLog::off()).unwrap()
}

/// Another bit depth keeps the top bits: an 8-bit frame's mean is the
/// 16-bit one's over 256 (its 500 DN black once put every 8-bit pixel at
/// the top code).
#[test]
fn an_8_bit_frame_is_the_top_bits_of_the_16_bit_one() {
    let mean = |bits: u8| {
        let mut g = open("sim:scientific-ccd?size=48x48&seed=3").unwrap();
        g.set_bits(bits).unwrap();
        g.set_gain(2.0).unwrap();
        let f = g.grab().unwrap();
        f.pixels.iter().map(|&p| f64::from(p)).sum::<f64>() / f.pixels.len() as f64
    };
    let (m16, m8) = (mean(16), mean(8));
    assert!((m8 * 256.0 / m16 - 1.0).abs() < 0.01, "{m8} × 256 vs {m16}");
    assert!(m8 < 250.0, "{m8}");
}
