//! `gloam render --sensor`: a render captured through a simulated camera
//! writes 16-bit PNG frames and frames.jsonl whose gain, bits and CRC match
//! the pixels, and the frames are exactly what the sensor library makes of
//! the rendered radiance (the camera's physics is tested in `gloam-sensor`).

mod common;

use std::path::Path;
use std::process::{Command, Output};

use common::records;

const SCENE: &str = "sims/panel-validation/scene.toml";

/// Renders the panel scene at 1 spp through `sensor` into `out`.
fn render_with_sensor(out: &Path, sensor: &str, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gloam"))
        .args(["render", SCENE, "--out"])
        .arg(out)
        .args(["--spp", "1", "--sensor", sensor])
        .args(extra)
        .output()
        .expect("run gloam")
}

/// Independent bitwise CRC-32C (Castagnoli, reflected 0x82F63B78) of the
/// pixels as little-endian u16.
fn crc32c(pixels: &[u16]) -> u32 {
    let mut crc = !0u32;
    for b in pixels.iter().flat_map(|p| p.to_le_bytes()) {
        crc ^= b as u32;
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

fn crcs(recs: &[serde_json::Value]) -> Vec<u64> {
    recs.iter()
        .map(|r| r["pixels_crc32c"].as_u64().unwrap())
        .collect()
}

#[test]
fn render_with_sensor_writes_frames_and_metadata() {
    let args = ["--frames", "2", "--gain", "1", "--seed", "7"];
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let o = render_with_sensor(out, "scientific-ccd", &args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let recs = records(out);
    assert_eq!(recs.len(), 2);
    for (i, rec) in recs.iter().enumerate() {
        for key in common::FRAME_RECORD_KEYS {
            assert!(rec.get(key).is_some(), "missing {key} in {rec}");
        }
        assert_eq!(rec["agc"], false);
        // Read as gloam reads its frames (sBIT honoured): the exact counts.
        let (w, _, px) = gloam_calib::io::read_counts(
            &out.join(format!("frame-{i:06}.png")),
            &gloam_io::ReadLog::off(),
        )
        .unwrap();
        let bits = rec["bits"].as_u64().unwrap();
        assert!(px.iter().all(|&p| u64::from(p) < (1u64 << bits)));
        assert_eq!(
            rec["pixels_crc32c"].as_u64().unwrap(),
            u64::from(crc32c(&px))
        );
        assert_eq!(rec["width"].as_u64().unwrap(), w as u64);
    }

    // The seed is explicit: a rerun is identical, while temporal noise
    // differs from frame to frame.
    let dir2 = tempfile::tempdir().unwrap();
    assert!(
        render_with_sensor(dir2.path(), "scientific-ccd", &args)
            .status
            .success()
    );
    let first = crcs(&recs);
    assert_eq!(first, crcs(&records(dir2.path())));
    assert_ne!(
        first[0], first[1],
        "temporal noise should differ between frames"
    );

    // The same radiance through the library camera gives the same frames.
    let radiance: ndarray::Array3<f64> = ndarray_npy::read_npy(out.join("radiance.npy")).unwrap();
    let scene = gloam_scene::load(Path::new(SCENE), &gloam_io::ReadLog::off()).unwrap();
    let shapes: Vec<_> = scene.bands.iter().map(|b| b.response.clone()).collect();
    let mut config =
        gloam_sensor::load_preset_or_file("scientific-ccd", &gloam_io::ReadLog::off()).unwrap();
    config.noise.seed = 7;
    let mut cam = gloam_sensor::Camera::new(config).unwrap();
    cam.set_override_gain(Some(1.0)).unwrap();
    for want in first {
        let f = cam.capture(radiance.view(), &shapes).unwrap();
        assert_eq!(u64::from(crc32c(&f.pixels)), want);
    }
}

#[test]
fn unknown_sensor_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = render_with_sensor(dir.path(), "no-such-camera", &[]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no-such-camera"), "{err}");
}

#[test]
fn render_with_sensor_records_the_saturated_fraction_and_warns() {
    // The directly viewed 15 W m⁻² sr⁻¹ panel through a Gen III tube at its
    // power-up gain: a frame with clipped pixels.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let o = render_with_sensor(out, "gen3-gaas-iccd", &["--frames", "2", "--seed", "3"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let recs = records(out);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let summary = &report["sensor_capture"]["frames"];
    assert_eq!(summary.as_array().unwrap().len(), 2);
    for (i, rec) in recs.iter().enumerate() {
        // Counted again here from the PNG, at the level the record names.
        let (_, _, px) = gloam_calib::io::read_counts(
            &out.join(format!("frame-{i:06}.png")),
            &gloam_io::ReadLog::off(),
        )
        .unwrap();
        let at = rec["saturated_at_dn"].as_f64().unwrap();
        let n = px.iter().filter(|&&p| f64::from(p) >= at).count();
        let frac = n as f64 / px.len() as f64;
        assert_eq!(rec["saturated_fraction"].as_f64().unwrap(), frac);
        assert_eq!(summary[i]["saturated_fraction"].as_f64().unwrap(), frac);
        let mean = px.iter().map(|&p| f64::from(p)).sum::<f64>() / px.len() as f64;
        assert!((rec["mean_dn"].as_f64().unwrap() - mean).abs() < 1e-9);
        if i == 0 {
            assert!(frac > 0.01, "the panel should clip: {frac}");
            assert!(
                stderr.contains("% of pixels saturated (warning above 1 %)"),
                "{stderr}"
            );
            assert!(
                summary[0]["warnings"]
                    .as_array()
                    .unwrap()
                    .contains(&serde_json::json!("saturated"))
            );
        }
    }
}
