//! The `genicam:` grabber (feature `genicam`, through Aravis) against
//! real, independent GenICam devices: Aravis's own fake camera
//! (`arv-fake-gv-camera-0.8`), and gloam's GigE Vision device checked
//! frame for frame against the in-process `sim:` grabber.
//!
//! Each run is one private network namespace with loopback alone
//! (`unshare -n`, see `aravis_netns`). Without Aravis each test prints a
//! loud notice and passes, unless `GLOAM_REQUIRE_ARAVIS=1` (CI).
#![cfg(feature = "genicam")]

use std::path::Path;

mod aravis_netns;
use aravis_netns::{BIN, aravis_ready, in_netns, in_netns_with, sim_crcs};

fn records(dir: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(dir.join("frames.jsonl"))
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .lines()
        .map(|l| serde_json::from_str(l).expect("json"))
        .collect()
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(
        &std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display())),
    )
    .expect("json")
}

/// `name = value` as `arv-tool-0.8 control` prints it.
fn feature<'a>(out: &'a str, name: &str) -> &'a str {
    out.lines()
        .filter_map(|l| l.strip_prefix(&format!("{name} = ")))
        .next_back()
        .and_then(|v| v.split_whitespace().next())
        .unwrap_or_else(|| panic!("no {name} in:\n{out}"))
}

/// `captured N frame(s) …; D damaged, L lost` from `gloam capture`.
fn losses(stderr: &str, tag: &str) -> (u64, u64, u64) {
    let line = stderr
        .lines()
        .find(|l| l.starts_with(&format!("[{tag}] captured ")))
        .unwrap_or_else(|| panic!("no [{tag}] summary in:\n{stderr}"));
    let nums: Vec<u64> = line
        .split(|c: char| !c.is_ascii_digit())
        .filter(|s| !s.is_empty())
        .filter_map(|s| s.parse().ok())
        .collect();
    let damaged = line
        .split(" damaged")
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    let lost = line
        .split(" lost")
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    (nums[0], damaged, lost)
}

/// The `n` frames captured into `dir` from Aravis's fake camera at
/// GainRaw 2 and exposure 10 ms, `size` Mono8: each is Aravis's diagonal
/// ramp ((x + y + frame id) mod 255) scaled by 1 + GainRaw + log10(exposure
/// / 10 ms) = 3, clipped at 255, pixel for pixel.
fn assert_fake_ramp(dir: &Path, n: usize, size: (u64, u64)) {
    let recs = records(dir);
    assert_eq!(recs.len(), n, "{}", dir.display());
    let mut last_seq = None;
    for r in &recs {
        assert_eq!(
            (
                r["width"].as_u64(),
                r["height"].as_u64(),
                r["bits"].as_u64()
            ),
            (Some(size.0), Some(size.1), Some(8)),
            "{r}"
        );
        assert_eq!(r["gain"].as_f64(), Some(2.0), "{r}");
        assert_eq!(r["agc"].as_bool(), Some(false), "{r}");
        let seq = r["seq"].as_u64().unwrap();
        if let Some(l) = last_seq {
            assert!(seq > l, "frame ids go forward: {l} then {seq}");
        }
        last_seq = Some(seq);
        let png = dir.join(r["file"].as_str().unwrap());
        // Read as gloam reads its frames (sBIT honoured): the exact counts.
        let (w, _, px) =
            gloam_calib::io::read_counts(&png, &gloam_io::ReadLog::off()).expect("png");
        // The camera's own 16-bit block id (seq + 1), which the ramp uses.
        let id = (seq % 65535 + 1) as u32;
        let mut wrong = 0;
        for (i, p) in px.iter().enumerate() {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let want = ((((x + y + id) % 255) as f64 * 3.0).min(255.0)) as u16;
            if *p != want {
                wrong += 1;
            }
        }
        assert_eq!(wrong, 0, "frame {seq}: {wrong} pixels off Aravis's ramp");
    }
}

/// A `gloam capture` line for a netns script, its stderr tagged.
fn capture(tag: &str, uri: &str, args: &str) -> String {
    format!(
        r#""$GLOAM" capture --grabber '{uri}' --out "$DIR/{tag}" {args} 2>&1 | sed 's/^/[{tag}] /' >&2"#
    )
}

#[test]
fn genicam_grabber_streams_from_the_aravis_fake_camera_and_its_controls_read_back() {
    if !aravis_ready(
        "genicam: vs arv-fake-gv-camera",
        &["arv-fake-gv-camera-0.8", "arv-tool-0.8", "ip"],
    ) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let client = [
        r#""$GLOAM" grabbers"#.to_string(),
        // By address: 64×48 Mono8, GainRaw 2, exposure 10 ms.
        capture(
            "mono8",
            "genicam:127.0.0.1?size=64x48",
            "--frames 4 --bits 8 --gain 2 --exposure-s 0.01",
        ),
        "arv-tool-0.8 -a 127.0.0.1 control GainRaw GainAuto PixelFormat ExposureTimeAbs Width Height".into(),
        // By the device id Aravis lists, free-running, AGC on, Mono16.
        capture(
            "mono16",
            "genicam:Aravis-Fake-GV01?trigger=off",
            "--frames 3 --bits 16 --agc",
        ),
        "arv-tool-0.8 -a 127.0.0.1 control GainAuto PixelFormat".into(),
        // Refused, not clamped: GainRaw runs 0…10; Mono12 is not offered.
        capture("badgain", "genicam:127.0.0.1", "--gain 50"),
        capture("badbits", "genicam:127.0.0.1", "--bits 12"),
        capture("nocam", "genicam:No-Such-Camera", ""),
    ]
    .join("\n");
    let run = in_netns_with(
        dir.path(),
        "arv-fake-gv-camera-0.8 -i 127.0.0.1",
        "arv-tool-0.8 -a 127.0.0.1 control Width >/dev/null 2>&1",
        &client,
        120,
    );
    let (out, err) = (&run.stdout, &run.stderr);
    assert!(run.ok, "{out}\n{err}\n{}", run.device_stderr);
    assert!(
        out.contains("genicam:Aravis-Fake-GV01") && out.contains("GigEVision"),
        "gloam grabbers:\n{out}"
    );
    // Controls set through the grabber, read back by Aravis's own tool.
    assert_eq!(feature(out, "GainRaw"), "2", "{out}");
    assert_eq!(feature(out, "ExposureTimeAbs"), "10000", "{out}");
    assert_eq!(feature(out, "Width"), "64", "{out}");
    assert_eq!(feature(out, "Height"), "48", "{out}");
    assert!(out.contains("PixelFormat = Mono8"), "{out}");
    assert_eq!(feature(out, "PixelFormat"), "Mono16", "{out}");
    assert_eq!(feature(out, "GainAuto"), "Continuous", "{out}");

    assert_fake_ramp(&dir.path().join("mono8"), 4, (64, 48));
    let recs = records(&dir.path().join("mono16"));
    assert_eq!(recs.len(), 3, "{err}");
    for r in &recs {
        assert_eq!(r["bits"].as_u64(), Some(16), "{r}");
        assert_eq!(r["agc"].as_bool(), Some(true), "{r}");
    }
    for (tag, why) in [
        ("badgain", "outside the camera's range 0–10"),
        ("badbits", "has no PixelFormat Mono12"),
        ("nocam", "no GenICam camera 'No-Such-Camera'"),
    ] {
        assert!(
            err.lines()
                .any(|l| l.starts_with(&format!("[{tag}] error:")) && l.contains(why)),
            "{tag}: want '{why}' in:\n{err}"
        );
    }
}

#[test]
fn genicam_capture_from_gloams_gige_device_is_bit_identical_to_sim() {
    if !aravis_ready("genicam: vs gloam device --gige", &["ip", "arv-tool-0.8"]) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    // Registers persist across control sessions (SFNC) until DeviceReset
    // loads the default user set: a client leaves the gain manual at
    // 40 dB, the frame rate at 5 Hz and 8-bit pixels, the next reads them
    // back and resets the device, and the AGC run starts from the preset.
    let client = [
        capture(
            "fixed",
            "genicam:127.0.0.1",
            "--frames 30 --bits 12 --exposure-s 0.002 --gain 50",
        ),
        "timeout 20 arv-tool-0.8 control GainAuto=Off Gain=40 AcquisitionFrameRate=5 PixelFormat=Mono8 >&2".to_string(),
        "timeout 20 arv-tool-0.8 control GainAuto Gain AcquisitionFrameRate PixelFormat DeviceReset".to_string(),
        capture("agc", "genicam:127.0.0.1", "--frames 30 --bits 16 --agc"),
    ]
    .join("\n");
    let run = in_netns(dir.path(), "--size 160x120 --seed 7", &client, 120);
    assert!(run.ok, "{}\n{}", run.stderr, run.device_stderr);
    let out = &run.stdout;
    assert_eq!(feature(out, "GainAuto"), "Off", "{out}");
    assert_eq!(feature(out, "Gain"), "40", "{out}");
    assert_eq!(feature(out, "AcquisitionFrameRate"), "5", "{out}");
    assert_eq!(feature(out, "PixelFormat"), "Mono8", "{out}");
    assert!(out.contains("DeviceReset executed"), "{out}");
    for (tag, extra) in [
        (
            "fixed",
            &["--bits", "12", "--exposure-s", "0.002", "--gain", "50"][..],
        ),
        ("agc", &["--bits", "16", "--agc"][..]),
    ] {
        let got = records(&dir.path().join(tag));
        let sim_dir = dir.path().join(format!("sim-{tag}"));
        std::fs::create_dir_all(&sim_dir).unwrap();
        let sim = sim_crcs(
            &sim_dir,
            "sim:gen2-s20-iccd?rig=uniform&seed=7&size=160x120",
            30,
            extra,
        );
        let sim_recs = records(&sim_dir.join("sim"));
        assert_eq!(got.len(), 30, "{}", run.stderr);
        for (k, r) in got.iter().enumerate() {
            // Frame k of the acquisition is seq k, as with sim:.
            assert_eq!(r["seq"].as_u64(), Some(k as u64), "{r}");
            assert_eq!(
                r["pixels_crc32c"].as_u64(),
                Some(u64::from(sim[k])),
                "{tag} frame {k}: CRC differs from sim:"
            );
            let (g, s) = (
                r["gain"].as_f64().unwrap(),
                sim_recs[k]["gain"].as_f64().unwrap(),
            );
            // The gain in effect crosses the wire in double precision, in
            // the frame's own ChunkGainLinear.
            assert_eq!(g, s, "{tag} frame {k}: gain {g} vs sim {s}");
            assert_eq!(r["agc"], sim_recs[k]["agc"], "{tag} frame {k}");
            // Exposure and gate duty come in the frame's own
            // ChunkExposureTime / ChunkGateDuty, as sim: records them.
            for key in ["exposure_us", "gate_duty"] {
                assert!(r[key].is_f64(), "{tag} frame {k}: no {key}: {r}");
                assert_eq!(r[key], sim_recs[k][key], "{tag} frame {k}: {key}");
            }
            if tag == "fixed" {
                assert_eq!(r["exposure_us"].as_f64(), Some(2000.0), "{r}");
            }
        }
    }
}

#[test]
fn with_injected_gvsp_loss_no_damaged_frame_is_accepted_and_every_loss_is_reported() {
    if !aravis_ready("genicam: lossy", &["ip", "arv-tool-0.8"]) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let sent = "arv-tool-0.8 -a 127.0.0.1 control GloamFramesSent GloamPacketsDroppedByFaultInjector GloamPacketsResent";
    let client = [
        sent.to_string(),
        // PACKETRESEND on (Aravis's default): the losses are repaired.
        capture(
            "resend",
            "genicam:127.0.0.1",
            "--frames 100 --bits 12 --exposure-s 0.002",
        ),
        sent.to_string(),
        // Resends off: the damaged frames must be reported, not returned.
        capture(
            "raw",
            "genicam:127.0.0.1?resend=never",
            "--frames 60 --bits 12 --exposure-s 0.002",
        ),
        sent.to_string(),
        // Free-running at 20 Hz (the rate persists into the grabber's
        // session), resends on: frames the capture loop cannot take in
        // time may be lost, but at least 99 % must come through.
        "timeout 20 arv-tool-0.8 -a 127.0.0.1 control AcquisitionFrameRate=20 >&2".to_string(),
        capture(
            "free",
            "genicam:127.0.0.1?trigger=off",
            "--frames 100 --bits 12 --exposure-s 0.002",
        ),
        sent.to_string(),
    ]
    .join("\n");
    let run = in_netns(
        dir.path(),
        "--size 160x120 --seed 11 --gvsp-loss 0.01 --fault-seed 3",
        &client,
        240,
    );
    let (out, err) = (&run.stdout, &run.stderr);
    assert!(run.ok, "{out}\n{err}\n{}", run.device_stderr);
    let counts: Vec<(u64, u64, u64)> = out
        .lines()
        .filter_map(|l| l.strip_prefix("GloamFramesSent = "))
        .zip(
            out.lines()
                .filter_map(|l| l.strip_prefix("GloamPacketsDroppedByFaultInjector = ")),
        )
        .zip(
            out.lines()
                .filter_map(|l| l.strip_prefix("GloamPacketsResent = ")),
        )
        .map(|((f, d), r)| {
            let n = |s: &str| s.split_whitespace().next().unwrap().parse::<u64>().unwrap();
            (n(f), n(d), n(r))
        })
        .collect();
    assert_eq!(counts.len(), 4, "{out}");
    let sim = sim_crcs(
        dir.path(),
        "sim:gen2-s20-iccd?rig=uniform&seed=11&size=160x120",
        400,
        &["--bits", "12", "--exposure-s", "0.002"],
    );
    for (k, tag) in ["resend", "raw", "free"].into_iter().enumerate() {
        let (good, damaged, lost) = losses(err, tag);
        let frames_sent = counts[k + 1].0 - counts[k].0;
        let dropped = counts[k + 1].1 - counts[k].1;
        let resent = counts[k + 1].2 - counts[k].2;
        let recs = records(&dir.path().join(tag));
        assert_eq!(recs.len() as u64, good);
        // Every accepted frame is the sim: grabber's frame with its id.
        for r in &recs {
            let seq = r["seq"].as_u64().unwrap() as usize;
            assert_eq!(
                r["pixels_crc32c"].as_u64(),
                Some(u64::from(sim[seq])),
                "{tag}: frame {seq} accepted with wrong pixels"
            );
        }
        // Every frame the device sent is either captured or reported
        // (free-running, frames still in flight when the capture stops
        // are neither).
        let seen = good + damaged + lost;
        if tag == "free" {
            assert!(
                seen <= frames_sent && frames_sent <= seen + 10,
                "{tag}: {good} good + {damaged} damaged + {lost} lost vs {frames_sent} sent"
            );
        } else {
            assert_eq!(
                seen, frames_sent,
                "{tag}: {good} good + {damaged} damaged + {lost} lost ≠ {frames_sent} sent"
            );
        }
        assert!(dropped > 0, "{tag}: the injector dropped nothing");
        eprintln!(
            "{tag}: {frames_sent} frames sent, {dropped} packets dropped, {resent} resent; {good} good, {damaged} damaged, {lost} lost"
        );
        // The capture's report.json and closing line: the summary's frame
        // losses, and the stream's packet resends as Aravis counted them
        // (never more resent packets received than the device resent).
        let report = json(&dir.path().join(tag).join("report.json"));
        let (f, p) = (&report["frames"], &report["packet_resends"]);
        assert_eq!(
            (
                f["captured"].as_u64(),
                f["damaged"].as_u64(),
                f["lost"].as_u64()
            ),
            (Some(good), Some(damaged), Some(lost)),
            "{tag}: {report}"
        );
        assert_eq!(p["applicable"], true, "{tag}: {report}");
        assert_eq!(p["resend"], tag != "raw", "{tag}: {report}");
        assert_eq!(p["camera_offers_resend"], true, "{tag}: {report}");
        let n = |k: &str| p[k].as_u64().unwrap_or_else(|| panic!("{k}: {report}"));
        assert!(
            n("packets_resent") <= resent,
            "{tag}: {report} vs {resent} resent"
        );
        let line = format!(
            "[{tag}] packet resends: {} packet(s) resent, {} missing, {} resend request(s)",
            n("packets_resent"),
            n("packets_missing"),
            n("resend_requests")
        );
        assert!(err.contains(&line), "{tag}: no `{line}` in:\n{err}");
        if tag == "raw" {
            assert_eq!(
                (n("resend_requests"), n("packets_resent")),
                (0, 0),
                "{report}"
            );
            // Aravis counts the packets a damaged frame lacked.
            assert_eq!(n("packets_missing") > 0, damaged > 0, "{report}");
        } else {
            assert!(
                n("packets_resent") > 0 && n("resend_requests") > 0,
                "{tag}: {report}"
            );
        }
        if tag == "resend" {
            assert_eq!(
                n("packets_missing"),
                0,
                "nothing damaged, nothing missing: {report}"
            );
        }
        match tag {
            "resend" => {
                assert!(resent > 0, "{out}");
                assert_eq!((damaged, lost), (0, 0), "1 % loss is repaired by resends");
            }
            "free" => {
                assert!(resent > 0, "{out}");
                assert!(
                    good as f64 >= 0.99 * seen as f64,
                    "{tag}: {good} of {seen} frames recovered (< 99 %)"
                );
            }
            _ => assert!(damaged + lost > 0, "no loss reported with resends off"),
        }
    }
}

/// At 1 % GVSP loss Aravis's fake camera (`-r 10`, per thousand) loses
/// frames that no client can repair: its GVCP capability register says it
/// has no PACKETRESEND (0x0934 reads 0), so Aravis never asks (its own
/// `arv-camera-test-0.8` makes 0 resend requests and fails most frames),
/// and its GVCP handler has no PACKETRESEND command anyway. The `genicam:`
/// grabber says so, reports every damaged frame, and returns only whole
/// ones: each exactly Aravis's ramp.
#[test]
fn the_fake_camera_offers_no_packetresend_and_its_damaged_frames_are_reported() {
    if !aravis_ready(
        "genicam: vs arv-fake-gv-camera at 1 % loss",
        &[
            "arv-fake-gv-camera-0.8",
            "arv-tool-0.8",
            "arv-camera-test-0.8",
            "ip",
        ],
    ) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let client = [
        "echo '== capability'".to_string(),
        "timeout 10 arv-tool-0.8 -a 127.0.0.1 control 'R[0x934]'".to_string(),
        "echo '== arv-camera-test'".to_string(),
        "timeout 30 arv-camera-test-0.8 --duration 3".to_string(),
        "echo '== capture'".to_string(),
        // 512×512 Mono8: 190 packets a frame, ~15 % of frames whole.
        capture(
            "fake",
            "genicam:127.0.0.1",
            "--frames 8 --bits 8 --gain 2 --exposure-s 0.01",
        ),
    ]
    .join("\n");
    let run = in_netns_with(
        dir.path(),
        "arv-fake-gv-camera-0.8 -i 127.0.0.1 -r 10",
        "arv-tool-0.8 -a 127.0.0.1 control Width >/dev/null 2>&1",
        &client,
        150,
    );
    let (out, err) = (&run.stdout, &run.stderr);
    assert!(run.ok, "{out}\n{err}\n{}", run.device_stderr);
    assert!(out.contains("R[0x00000934] = 0x00000000"), "{out}");
    let stat = |name: &str| -> u64 {
        out.lines()
            .find_map(|l| {
                l.strip_prefix(name)?
                    .trim()
                    .strip_prefix('=')?
                    .trim()
                    .parse()
                    .ok()
            })
            .unwrap_or_else(|| panic!("no {name} in:\n{out}"))
    };
    assert_eq!(stat("n_resend_requests"), 0, "{out}");
    assert!(stat("n_missing_packets") > 0, "{out}");
    assert!(stat("n_failures") > stat("n_completed_buffers"), "{out}");
    eprintln!(
        "arv-camera-test vs fake camera at 1 % loss: {} completed, {} failed, {} resend requests",
        stat("n_completed_buffers"),
        stat("n_failures"),
        stat("n_resend_requests")
    );
    assert!(
        err.contains("does not offer PACKETRESEND"),
        "the grabber should say resends cannot help:\n{err}"
    );
    let (good, damaged, lost) = losses(err, "fake");
    assert_eq!(good, 8, "{err}");
    assert!(damaged > 0, "1 % loss and nothing damaged:\n{err}");
    // As arv-camera-test: no resend asked for (the grabber asks only a
    // camera that offers it), packets missing; said in the closing line
    // and report.json.
    let report = json(&dir.path().join("fake/report.json"));
    let p = &report["packet_resends"];
    assert_eq!(
        (
            &p["camera_offers_resend"],
            &p["resend_requests"],
            &p["packets_resent"]
        ),
        (
            &serde_json::json!(false),
            &serde_json::json!(0),
            &serde_json::json!(0)
        ),
        "{report}"
    );
    assert!(p["packets_missing"].as_u64().unwrap() > 0, "{report}");
    assert_eq!(p["resend"], false, "{report}");
    assert!(
        err.contains("0 resend request(s) (none asked: the camera does not offer PACKETRESEND)"),
        "no packet-resend line:\n{err}"
    );
    eprintln!("genicam: vs fake camera at 1 % loss: {good} good, {damaged} damaged, {lost} lost");
    assert_fake_ramp(&dir.path().join("fake"), 8, (512, 512));
}

/// `ChunkNAME = value` lines as `arv-camera-test-0.8 --chunks` prints
/// them, one map per frame (a frame starts at its ChunkFrameID line).
fn chunk_lines(out: &str) -> Vec<std::collections::BTreeMap<String, f64>> {
    let mut frames: Vec<std::collections::BTreeMap<String, f64>> = Vec::new();
    for l in out.lines() {
        let Some((k, v)) = l.split_once(" = ") else {
            continue;
        };
        let (Some(k), Ok(v)) = (k.strip_prefix("Chunk"), v.trim().parse::<f64>()) else {
            continue;
        };
        if k == "FrameID" {
            frames.push(Default::default());
        }
        if let Some(f) = frames.last_mut() {
            f.insert(k.to_string(), v);
        }
    }
    frames
}

#[test]
fn arv_test_passes_without_a_config_and_chunks_carry_each_frames_gain_and_exposure() {
    if !aravis_ready(
        "arv-test / arv-camera-test --chunks vs gloam device --gige",
        &["arv-test-0.8", "arv-camera-test-0.8", "ip"],
    ) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    // No configuration file: arv-test's defaults, chunk test included
    // (ChunkList "OffsetX OffsetY"). arv-test leaves its settings (5 Hz,
    // registers persist across sessions): DeviceReset loads the default
    // set. Then a client streaming 2 s with the chunks on, at the AGC's
    // default settings, Mono16.
    let client = [
        r#"cd "$DIR" && arv-test-0.8; echo "arv-test rc=$?""#,
        "timeout 20 arv-tool-0.8 control DeviceReset >&2",
        "timeout 30 arv-camera-test-0.8 --chunks FrameID,Gain,GainLinear,ExposureTime,AgcActive,GateDuty --features PixelFormat=Mono16 --duration 2",
    ]
    .join("\n");
    let run = in_netns(dir.path(), "--size 160x120 --seed 7", &client, 120);
    let out = &run.stdout;
    assert!(run.ok, "{out}\n{}\n{}", run.stderr, run.device_stderr);
    let results: Vec<&str> = out
        .lines()
        .filter(|l| l.contains("SUCCESS") || l.contains("FAILURE"))
        .collect();
    assert!(results.len() >= 15, "arv-test ran:\n{out}");
    assert!(
        results.iter().all(|l| !l.contains("FAILURE")),
        "arv-test without a config:\n{out}"
    );
    assert!(
        out.lines()
            .any(|l| l.starts_with("Chunks:BufferCheck") && l.contains("SUCCESS")),
        "{out}"
    );
    // The same frames in process: frame k of the acquisition is the sim:
    // grabber's frame k, whose frames.jsonl holds the gain it was taken at.
    let frames = chunk_lines(out);
    assert!(
        frames.len() >= 10,
        "chunk values of {} frames:\n{out}",
        frames.len()
    );
    let n = frames.iter().map(|f| f["FrameID"] as u32).max().unwrap();
    let sim_dir = dir.path().join("sim-chunks");
    std::fs::create_dir_all(&sim_dir).unwrap();
    sim_crcs(
        &sim_dir,
        "sim:gen2-s20-iccd?rig=uniform&seed=7&size=160x120",
        n,
        &["--bits", "16", "--agc"],
    );
    let sim = records(&sim_dir.join("sim"));
    // The exposure the device reported before streaming (ExposureTime).
    let exposure_us: f64 = out
        .lines()
        .find_map(|l| l.strip_prefix("exposure "))
        .and_then(|r| r.split('=').nth(1))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no exposure line in:\n{out}"));
    let mut gains_seen = std::collections::BTreeSet::new();
    for f in &frames {
        let k = f["FrameID"] as usize - 1;
        let s = &sim[k];
        let g = s["gain"].as_f64().unwrap();
        // arv-camera-test prints with %g: 6 significant digits.
        let close = |a: f64, b: f64| (a - b).abs() <= 5e-6 * b.abs();
        assert!(
            close(f["GainLinear"], g),
            "frame {k}: {f:?} vs sim gain {g}"
        );
        assert!(
            close(f["Gain"], 20.0 * g.log10()),
            "frame {k}: {f:?} vs sim gain {g}"
        );
        assert_eq!(f["AgcActive"], 1.0, "frame {k}");
        assert_eq!(s["agc"].as_bool(), Some(true));
        assert_eq!(f["ExposureTime"], exposure_us, "frame {k}");
        assert!(f["GateDuty"] > 0.0 && f["GateDuty"] <= 1.0, "{f:?}");
        gains_seen.insert(g.to_bits());
    }
    // The AGC moved the gain: per-frame values, not one setting repeated.
    assert!(gains_seen.len() > 3, "{frames:?}");
    eprintln!(
        "arv-camera-test --chunks: {} frames, gain {:.3}…{:.3} dB, each equal to sim:'s frames.jsonl",
        frames.len(),
        frames.iter().map(|f| f["Gain"]).fold(f64::MAX, f64::min),
        frames.iter().map(|f| f["Gain"]).fold(f64::MIN, f64::max)
    );
}

// The photon-transfer tests' sphere source (its rig the scientific CCD).
#[allow(dead_code)] // Only the source is used here, not the QE reference.
#[path = "../crates/calib/tests/shared/reference.rs"]
mod reference;

#[test]
fn calibration_rehearsal_through_genicam_matches_in_process() {
    if !aravis_ready("genicam: calibration rehearsal", &["ip"]) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let src = dir.path().join("sphere.toml");
    std::fs::write(&src, reference::sphere_toml("scientific-ccd")).unwrap();
    let radiance = "--gains 1,2 --levels 6 --frames 3 --auto-range 0.8";
    let ptc = "--levels 12 --gain 1 --auto-range 1.4 --spatial-frames 2";
    let calib = |kind: &str, uri: &str, out: &str, args: &str| {
        format!(
            r#""$GLOAM" calibrate {kind} --grabber '{uri}' --source "$DIR/sphere.toml" {args} --out "$DIR/{out}" || echo "{out} failed""#
        )
    };
    let client = [
        calib("radiance", "genicam:127.0.0.1", "gc-lut", radiance),
        calib("ptc", "genicam:127.0.0.1", "gc-ptc", ptc),
    ]
    .join("\n");
    let run = in_netns(
        dir.path(),
        "--sensor scientific-ccd --size 48x48 --seed 3",
        &client,
        240,
    );
    assert!(
        run.ok && !run.stdout.contains("failed"),
        "{}\n{}\n{}",
        run.stdout,
        run.stderr,
        run.device_stderr
    );
    let sim = "sim:scientific-ccd?size=48x48&seed=3";
    for (kind, out, args) in [("radiance", "sim-lut", radiance), ("ptc", "sim-ptc", ptc)] {
        let o = std::process::Command::new(BIN)
            .args(["calibrate", kind, "--grabber", sim, "--source"])
            .arg(&src)
            .args(args.split_whitespace())
            .arg("--out")
            .arg(dir.path().join(out))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let rel = |a: f64, b: f64| (a / b - 1.0).abs();
    let a = json(&dir.path().join("gc-lut/lut.json"));
    let b = json(&dir.path().join("sim-lut/lut.json"));
    let (ga, gb) = (
        a["gains"].as_array().unwrap(),
        b["gains"].as_array().unwrap(),
    );
    assert_eq!(ga.len(), 2);
    assert_eq!(ga.len(), gb.len());
    for (x, y) in ga.iter().zip(gb) {
        for k in ["g_w_m2_sr_per_dn", "b_w_m2_sr"] {
            let r = rel(x[k].as_f64().unwrap(), y[k].as_f64().unwrap());
            eprintln!(
                "radiance LUT, gain {}: {k} genicam vs in-process {r:.1e}",
                x["gain"]
            );
            assert!(r < 1e-4, "gain {}: {k} differs by {r:e}", x["gain"]);
        }
    }
    let a = json(&dir.path().join("gc-ptc/ptc.json"));
    let b = json(&dir.path().join("sim-ptc/ptc.json"));
    for k in [
        "system_gain_dn_per_e",
        "quantum_efficiency",
        "dark_noise_e",
        "saturation_capacity_e",
    ] {
        let r = rel(a[k].as_f64().unwrap(), b[k].as_f64().unwrap());
        eprintln!("PTC {k}: genicam vs in-process {r:.1e}");
        assert!(r < 1e-4, "{k} differs by {r:e}");
    }
}
