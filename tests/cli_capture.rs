//! `gloam capture` and `gloam grabbers` from the command line.

mod common;

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_gloam");

fn gloam(args: &[&str]) -> std::process::Output {
    Command::new(BIN).args(args).output().expect("run gloam")
}

#[test]
fn capture_from_sim_writes_pngs_and_jsonl() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cap");
    let o = Command::new(BIN)
        .args([
            "capture",
            "--grabber",
            "sim:sine?size=40x30",
            "--frames",
            "4",
            "--bits",
            "12",
            "--gain",
            "800",
            "--seed",
            "3",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(out.join("frames.jsonl")).unwrap();
    let lines = common::records(&out);
    assert_eq!(lines.len(), 4);
    for (i, r) in lines.iter().enumerate() {
        for k in common::FRAME_RECORD_KEYS {
            assert!(r.get(k).is_some(), "missing {k} in {r}");
        }
        assert_eq!(r["seq"], i as u64);
        assert_eq!(r["bits"], 12);
        assert_eq!(r["agc"], false);
        assert_eq!(r["gain"], 800.0);
        assert_eq!(r["status"], "ok");
        let png = out.join(format!("frame-{i:06}.png"));
        // Read as gloam reads its frames (sBIT honoured): the exact counts.
        let (w, h, pixels) = gloam_calib::io::read_counts(&png, &gloam_io::ReadLog::off()).unwrap();
        assert_eq!((w, h), (40, 30));
        assert!(pixels.iter().all(|&p| p < 4096));
        assert_eq!(
            r["pixels_crc32c"],
            u64::from(gloam_grabber::pixels_crc32c(&pixels))
        );
    }
    // Same seed, same frames.
    let out2 = dir.path().join("cap2");
    let o = Command::new(BIN)
        .args([
            "capture",
            "--grabber",
            "sim:sine?size=40x30",
            "--frames",
            "4",
            "--bits",
            "12",
            "--gain",
            "800",
            "--seed",
            "3",
            "--out",
        ])
        .arg(&out2)
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_eq!(
        text,
        std::fs::read_to_string(out2.join("frames.jsonl")).unwrap()
    );
}

#[test]
fn capture_rejects_bad_input_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    for (args, needle) in [
        (
            vec!["capture", "--grabber", "tcp:x", "--out", out],
            "unknown scheme",
        ),
        (
            vec!["capture", "--grabber", "sim:nope-preset", "--out", out],
            "nope-preset",
        ),
        (
            vec![
                "capture",
                "--grabber",
                "serial:/dev/does-not-exist-gloam",
                "--out",
                out,
            ],
            "does-not-exist-gloam",
        ),
        (
            vec!["capture", "--grabber", "usb:1d50:6018", "--out", out],
            "usb",
        ),
        (
            vec![
                "capture",
                "--grabber",
                "sim:gen3-gaas-iccd?scene=/no/such/scene-gloam.toml",
                "--out",
                out,
            ],
            "scene-gloam.toml",
        ),
        (
            vec!["device", "--pty", "--scene", "/no/such/scene-gloam.toml"],
            "scene-gloam.toml",
        ),
        (
            vec![
                "capture",
                "--grabber",
                "sim:uniform",
                "--bits",
                "10",
                "--out",
                out,
            ],
            "10",
        ),
        (
            vec![
                "capture",
                "--grabber",
                "sim:uniform",
                "--gain",
                "2",
                "--agc",
                "--out",
                out,
            ],
            "--agc",
        ),
    ] {
        let o = gloam(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(
            err.to_lowercase().contains(&needle.to_lowercase()),
            "{args:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn grabbers_lists_serial_usb_and_sim() {
    let o = gloam(&["grabbers", "--json"]);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["serial"].is_array());
    assert!(v["usb"].is_array());
    // Either USB devices are listed or we are told plainly why not.
    if v["usb"].as_array().unwrap().is_empty() {
        if let Some(e) = v["usb_error"].as_str() {
            assert!(e.contains("no USB bus"), "{e}");
        }
    }
    let sims: Vec<&str> = v["sim"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["uri"].as_str().unwrap())
        .collect();
    for p in [
        "sim:gen2-s20-iccd",
        "sim:gen3-gaas-iccd",
        "sim:s25-ebccd",
        "sim:scientific-ccd",
        "sim:uniform",
    ] {
        assert!(sims.contains(&p), "{p} missing from {sims:?}");
    }
    let o = gloam(&["grabbers"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("USB devices:") && text.contains("serial ports:"));
}

/// Captures one frame from `uri` at `gain` into a fresh directory; returns
/// its frames.jsonl record and stderr.
fn capture_one(uri: &str, gain: &str) -> (serde_json::Value, String) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cap");
    let o = Command::new(BIN)
        .args(["capture", "--grabber", uri, "--gain", gain, "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(o.status.success(), "{stderr}");
    let text = std::fs::read_to_string(out.join("frames.jsonl")).unwrap();
    (
        serde_json::from_str(text.lines().next().unwrap()).unwrap(),
        stderr,
    )
}

#[test]
fn capture_records_the_saturated_fraction_and_warns() {
    // The scientific CCD's uniform rig: ~20 500 DN above its 500 DN black at
    // gain 1 (saturation 63 000 DN: none saturated). At gain 4 that is
    // ~82 000 DN, 40 σ past the top code 65 535 (which the 4 × 100 000 e⁻ /
    // 1.6 e⁻/DN full well cannot reach first): all 24 × 16 pixels saturated.
    let uri = "sim:scientific-ccd?size=24x16&seed=2";
    let (rec, stderr) = capture_one(uri, "1");
    assert_eq!(rec["saturated_fraction"].as_f64().unwrap(), 0.0, "{rec}");
    assert!(!stderr.contains("warning"), "{stderr}");
    let (rec, stderr) = capture_one(uri, "4");
    assert_eq!(rec["saturated_fraction"].as_f64().unwrap(), 1.0, "{rec}");
    assert!(
        stderr.contains("100.00 % of pixels saturated (warning above 1 %)")
            && stderr.contains("near full scale"),
        "{stderr}"
    );
    assert!(rec["warnings"].as_array().unwrap().len() == 2, "{rec}");
    // A capped lens: the mean sits at the black level (offset 500 DN).
    let (rec, stderr) = capture_one("sim:scientific-ccd?rig=dark&size=24x16", "1");
    assert!(
        (rec["mean_dn"].as_f64().unwrap() - 500.0).abs() < 1.0,
        "{rec}"
    );
    assert!(
        stderr.contains("within 4 DN of black (500.0 DN)"),
        "{stderr}"
    );
}

#[test]
fn capture_from_a_scene_warns_before_its_frames_when_no_gain_fits() {
    // The lamp-lit new-moon street through Gen III: the fit (from the
    // rendered scene, before any frame) says no gain fits; the frame taken
    // at the camera's least gain is the independent check.
    let gain_min = "14.5519";
    let uri = "sim:gen3-gaas-iccd?scene=sims/night-new-moon-lamps/scene.toml&size=48x36";
    let (rec, stderr) = capture_one(uri, gain_min);
    let warned = stderr
        .lines()
        .position(|l| l.contains("saturates this scene at every gain it can reach"));
    let capturing = stderr.lines().position(|l| l.starts_with("capturing from"));
    assert!(
        matches!((warned, capturing), (Some(w), Some(c)) if w < c),
        "{stderr}"
    );
    assert!(stderr.contains("an ND of density"), "{stderr}");
    // The render's own flag is not offered where there is none.
    assert!(!stderr.contains("--exposure auto"), "{stderr}");
    assert!(rec["saturated_fraction"].as_f64().unwrap() > 0.01, "{rec}");
    // A scene that fits at gain 30 (the new-moon street, no lamps) is not
    // warned about, and its frame indeed is not saturated.
    let (rec, stderr) = capture_one(
        "sim:gen3-gaas-iccd?scene=sims/night-new-moon/scene.toml&size=48x36",
        "30",
    );
    assert!(!stderr.contains("camera fit"), "{stderr}");
    assert!(rec["saturated_fraction"].as_f64().unwrap() < 0.01, "{rec}");
}

/// Seconds since the Unix epoch now.
fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64()
}

#[test]
fn capture_frame_format_fits_carries_date_instrument_and_gain_in_electrons_per_dn() {
    // The test's own date reader, checked on a known instant.
    assert_eq!(
        common::fits_date_unix_s("2025-10-22T04:00:00.040"),
        1_761_105_600.04
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cap");
    let before = unix_now();
    let o = Command::new(BIN)
        .args([
            "capture",
            "--grabber",
            "sim:scientific-ccd?size=32x24",
            "--frames",
            "3",
            "--gain",
            "2",
            "--seed",
            "4",
            "--frame-format",
            "fits",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let after = unix_now();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let recs = common::records(&out);
    assert_eq!(recs.len(), 3);
    // The preset's digitizer: 1.6 e⁻/DN at analogue gain 1
    // (sims/sensors/scientific-ccd.toml), so 0.8 e⁻/DN at gain 2.
    let toml = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("sims/sensors/scientific-ccd.toml"),
    )
    .unwrap();
    let e_per_dn: f64 = toml
        .lines()
        .find_map(|l| l.strip_prefix("e_per_dn = "))
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert_eq!(e_per_dn, 1.6);
    let want_gain = e_per_dn / 2.0;
    let mut last = f64::NEG_INFINITY;
    for (i, r) in recs.iter().enumerate() {
        let name = format!("frame-{i:06}.fits");
        assert_eq!(r["file"], name.as_str());
        assert_eq!(r["stored"]["format"], "fits");
        let bytes = std::fs::read(out.join(&name)).unwrap();
        assert_eq!(bytes.len() % 2880, 0);
        let cards = common::fits_cards(&bytes);
        let get = |k: &str| {
            let c = cards.iter().find(|c| c.0 == k);
            c.unwrap_or_else(|| panic!("no {k} in {cards:?}")).clone()
        };
        let num = |k: &str| get(k).1.parse::<f64>().unwrap();
        assert!((num("GAIN") - want_gain).abs() < 1e-12, "{}", num("GAIN"));
        assert!((r["electrons_per_dn"].as_f64().unwrap() - want_gain).abs() < 1e-12);
        assert_eq!(num("TUBEGAIN"), 2.0);
        assert_eq!(get("INSTRUME").1, "sim:scientific-ccd");
        assert_eq!(get("CAMERA").1, "sim:scientific-ccd?size=32x24");
        // The host's clock as the frame arrived: within the run, in order.
        let (_, date, why) = get("DATE-OBS");
        assert!(why.contains("host clock"), "{why}");
        let t = common::fits_date_unix_s(&date);
        assert!(t >= before - 0.002 && t <= after + 0.002, "{date}");
        assert!(t >= last);
        last = t;
        assert_eq!(num("EXPTIME"), 1.0);
        // The counts, through BZERO, are the record's.
        let end = bytes
            .chunks(80)
            .position(|c| c.starts_with(b"END "))
            .unwrap();
        let data = &bytes[(end * 80 + 80).div_ceil(2880) * 2880..][..32 * 24 * 2];
        let counts: Vec<u16> = data
            .chunks(2)
            .map(|c| (i32::from(i16::from_be_bytes([c[0], c[1]])) + 32768) as u16)
            .collect();
        assert_eq!(
            r["pixels_crc32c"],
            u64::from(gloam_grabber::pixels_crc32c(&counts))
        );
    }
    // The other formats by the same flag; a bad value names flag and value.
    let tiff = dir.path().join("tiff");
    let o = gloam(&[
        "capture",
        "--grabber",
        "sim:uniform?size=8x8",
        "--bits",
        "8",
        "--frames",
        "2",
        "--frame-format",
        "tiff",
        "--out",
        tiff.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let recs = common::records(&tiff);
    assert_eq!(recs[1]["file"], "frames.tiff");
    assert_eq!(
        recs[1]["stored"],
        serde_json::json!({"format": "tiff", "sample_shift": 8, "page": 1})
    );
    assert!(tiff.join("frames.tiff").exists() && tiff.join("frames-preview.png").exists());
    let o = gloam(&[
        "capture",
        "--grabber",
        "sim:uniform",
        "--frame-format",
        "jpeg",
        "--out",
        dir.path().join("bad").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("--frame-format") && err.contains("jpeg"),
        "{err}"
    );
    assert!(err.contains("fits") && !err.contains("panicked"), "{err}");
    assert!(!dir.path().join("bad").exists());
}

/// `gloam capture` ends with the transport's packet resends and records
/// them with the frame losses in report.json; a `sim:` camera has no
/// packets, so it says not applicable and records zeros, and its frames
/// are all there (the count frames.jsonl holds).
#[test]
fn capture_reports_losses_and_packet_resends_as_not_applicable_for_sim() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cap");
    let o = Command::new(BIN)
        .args([
            "capture",
            "--grabber",
            "sim:scientific-ccd?size=32x24",
            "--frames",
            "5",
            "--seed",
            "2",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let last = err.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("packet resends: not applicable (sim:"),
        "{err}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let kept = common::records(&out).len() as u64;
    assert_eq!(kept, 5);
    assert_eq!(r["frames"]["requested"], 5);
    assert_eq!(r["frames"]["captured"], kept);
    for k in ["damaged", "lost", "interruptions"] {
        assert_eq!(r["frames"][k], 0, "{k}: {r}");
    }
    let p = &r["packet_resends"];
    assert_eq!(p["applicable"], false, "{r}");
    for k in ["resend_requests", "packets_resent", "packets_missing"] {
        assert_eq!(p[k], 0, "{k}: {r}");
    }
    assert_eq!(r["complete"], true);
    assert_eq!(r["grabber"], "sim:scientific-ccd?size=32x24");
    // The set lists it.
    let m = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    assert!(m.contains("\"report.json\""), "{m}");
}
