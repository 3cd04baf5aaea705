//! End-to-end tests of `gloam sequence` through the binary: a small road
//! lit by a steady overhead glow and a lamp that switches on at 1.21 s,
//! captured through the Gen III camera at its CCIR 25 frames/s.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

mod common;

const BIN: &str = env!("CARGO_BIN_EXE_gloam");

/// Two groups, `glow` and `lamp`, the same (default) spectrum over a grey
/// road: each layer's detected radiance is its visible radiance times one
/// constant, so `layers.npy` predicts the frames' detected signal.
const SCENE: &str = r#"units = "m"
[camera]
position = [-20, 0, 8]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov_deg = 60
width = 64
height = 48
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.road]
reflectance = 0.2
[objects.road]
material = "road"
quad = { center = [0, 0, 0], size = [60, 40], normal = [0, 0, 1] }
[point_sources.glow]
position = [0, 0, 200]
value = 1e-3
[point_sources.lamp]
position = [5, 5, 12]
value = 4e-6
"#;

/// 60 frames at 25 Hz; the lamp switches on 10 ms into frame 30's 40 ms
/// exposure (so that frame sees it on for 3/4 of its window).
const SEQUENCE: &str = r#"scene = "scene.toml"
frame_rate_hz = 25
frames = 60

[groups.lamp]
keys = [[0, 0], [1.21, 0], [1.21, 1]]
"#;

const SWITCH_FRAME: usize = 30;

fn gloam(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("running the gloam binary")
}

fn ok(args: &[&str]) -> Output {
    let out = gloam(args);
    assert!(
        out.status.success(),
        "gloam {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Writes the scene and `sequence` text into `dir`; the sequence's path.
fn files(dir: &Path, sequence: &str) -> String {
    std::fs::write(dir.join("scene.toml"), SCENE).unwrap();
    let p = dir.join("seq.toml");
    std::fs::write(&p, sequence).unwrap();
    p.display().to_string()
}

fn sequence(dir: &Path, out: &str, extra: &[&str]) -> Output {
    let seq = files(dir, SEQUENCE);
    let mut args = vec![
        "sequence",
        seq.as_str(),
        "--sensor",
        "gen3-gaas-iccd",
        "--spp",
        "2",
        "--out",
        out,
    ];
    args.extend_from_slice(extra);
    ok(&args)
}

#[test]
fn a_sequence_is_captured_with_the_file_s_weights_and_the_agc_answers_the_lamp() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = sequence(dir.path(), &out.display().to_string(), &[]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("sequence: 60 frames at 25 Hz"), "{stderr}");

    let recs = common::records(&out);
    assert_eq!(recs.len(), 60);
    for (i, r) in recs.iter().enumerate() {
        assert!(out.join(r["file"].as_str().unwrap()).is_file());
        let s = &r["sequence"];
        assert_eq!(s["time_s"].as_f64().unwrap(), i as f64 / 25.0);
        assert_eq!(s["window_s"].as_f64().unwrap(), 0.04);
        // Groups the file does not name keep 1; the lamp is off before
        // 1.21 s, on after, and on for (1.24 − 1.21)/0.04 of frame 30.
        assert_eq!(s["light_groups"]["glow"].as_f64().unwrap(), 1.0);
        let lamp = s["light_groups"]["lamp"].as_f64().unwrap();
        let want = match i {
            _ if i < SWITCH_FRAME => 0.0,
            SWITCH_FRAME => 0.75,
            _ => 1.0,
        };
        assert!((lamp - want).abs() < 1e-12, "frame {i}: lamp {lamp}");
    }
    // The preset's AGC (τ = 0.5 s) brings the gain down once the lamp
    // adds ~37 % to the signal: over the 29 frames after, by more than 10 %.
    let gain = |i: usize| recs[i]["gain"].as_f64().unwrap();
    assert!(
        gain(59) < 0.9 * gain(SWITCH_FRAME - 1),
        "{} → {}",
        gain(SWITCH_FRAME - 1),
        gain(59)
    );

    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let s = &report["sequence"];
    assert_eq!(s["frames"], 60);
    assert_eq!(s["frame_rate_hz"], 25.0);
    assert_eq!(s["groups"], serde_json::json!(["glow", "lamp"]));
    for key in ["layered_render", "mix", "camera", "mix_per_frame_ms"] {
        assert!(s["timings_s"][key].as_f64().unwrap() >= 0.0, "{key}");
    }
    // The sequence file is an input of the run, with its hash.
    let inputs = report["provenance"]["inputs"].as_array().unwrap();
    assert!(
        inputs
            .iter()
            .any(|i| i["path"].as_str().unwrap().ends_with("seq.toml")
                && i["sha256"].as_str().unwrap().len() == 64),
        "{inputs:?}"
    );
    // One layered render, every frame reusing it; no ordinary image (the
    // layers sum to it).
    assert_eq!(s["renders"]["renders"], 1);
    assert_eq!(s["renders"]["poses"][0]["frames"], 60);
    assert!(!out.join("radiance.npy").exists());
    for f in [
        "layers.npy",
        "layers.json",
        "gain-over-time.png",
        "frames-preview.png",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    // The animation: an APNG of every 2nd frame (60 → 30 ≤ 50).
    let apng = std::fs::read(out.join("frames-preview-animated.png")).unwrap();
    let at = apng.windows(4).position(|w| w == b"acTL").unwrap();
    let frames = u32::from_be_bytes(apng[at + 4..at + 8].try_into().unwrap());
    assert_eq!(frames, 30);
}

/// At a fixed gain without noise, the camera is linear: each frame's mean
/// above black is proportional to its mix of the layers. The ratio after /
/// before the switch is then (glow + lamp) / glow of the layers' means
/// (`layers.npy`, the independent answer), to within the image-plane
/// weighting (vignetting, MTF at the edges) that the plain mean ignores:
/// 1 %.
#[test]
fn at_a_fixed_gain_frames_scale_as_the_layers_mixed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    sequence(
        dir.path(),
        &out.display().to_string(),
        &["--gain", "100", "--no-noise"],
    );
    let layers: ndarray::Array4<f64> = ndarray_npy::read_npy(out.join("layers.npy")).unwrap();
    let index: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("layers.json")).unwrap()).unwrap();
    assert_eq!(index["groups"][0]["name"], "glow");
    let mean = |g: usize| layers.index_axis(ndarray::Axis(0), g).mean().unwrap();
    let want = (mean(0) + mean(1)) / mean(0);
    assert!(want > 1.2, "the lamp must matter: {want}");

    let recs = common::records(&out);
    let above = |i: usize| {
        let r = &recs[i];
        assert_eq!(r["gain"].as_f64().unwrap(), 100.0);
        assert_eq!(r["saturated_fraction"].as_f64().unwrap(), 0.0);
        r["mean_dn"].as_f64().unwrap() - r["black_dn"].as_f64().unwrap()
    };
    // Before the switch the frames are identical; after, the phosphor's
    // lag has died out by the last frame.
    assert_eq!(above(0), above(SWITCH_FRAME - 1));
    let got = above(59) / above(SWITCH_FRAME - 1);
    assert!(
        (got / want - 1.0).abs() < 0.01,
        "after/before {got}, layers {want}"
    );
}

#[test]
fn bad_sequences_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out").display().to_string();
    let fails = |sequence: &str, extra: &[&str]| {
        let seq = files(dir.path(), sequence);
        let mut args = vec!["sequence", seq.as_str(), "--out", out.as_str()];
        args.extend_from_slice(extra);
        let run = gloam(&args);
        assert!(!run.status.success(), "{sequence}");
        String::from_utf8_lossy(&run.stderr).into_owned()
    };
    let camera = ["--sensor", "gen3-gaas-iccd"];
    // A group the scene does not have: named with its line.
    let e = fails(&SEQUENCE.replace("groups.lamp", "groups.lamps"), &camera);
    assert!(e.contains("seq.toml:5") && e.contains("lamps"), "{e}");
    // A bad field: file, line and field.
    let e = fails(&SEQUENCE.replace("frames = 60", "frames = 0"), &camera);
    assert!(e.contains("seq.toml:3") && e.contains("frames"), "{e}");
    // The Gen III camera's CCIR video runs at 25 frames/s, not 30.
    let e = fails(
        &SEQUENCE.replace("frame_rate_hz = 25", "frame_rate_hz = 30"),
        &camera,
    );
    assert!(
        e.contains("frame_rate_hz = 30") && e.contains("CCIR") && e.contains("25.000"),
        "{e}"
    );
    // The file sets the number of frames.
    let e = fails(SEQUENCE, &["--sensor", "gen3-gaas-iccd", "--frames", "5"]);
    assert!(e.contains("--frames") && e.contains("(60)"), "{e}");
    // No camera: neither --sensor nor a `sensor` entry.
    let e = fails(SEQUENCE, &[]);
    assert!(e.contains("give --sensor"), "{e}");
    // A moving body the scene does not have: the file's line and key.
    let moving = format!(
        "{SEQUENCE}\n[[move]]\nobjects = [\"truck\"]\nkeys = [[1, 0, 0, 0], [2, 5, 0, 0]]\n"
    );
    let e = fails(&moving, &camera);
    assert!(
        e.contains("seq.toml:9")
            && e.contains("move[0].objects[0]")
            && e.contains("[objects.truck]"),
        "{e}"
    );
    // Pose keys that go back in time.
    let e = fails(
        &moving
            .replace("[\"truck\"]", "[\"road\"]")
            .replace("[2, 5, 0, 0]", "[0.5, 5, 0, 0]"),
        &camera,
    );
    assert!(
        e.contains("seq.toml:10") && e.contains("move[0].keys[1]") && e.contains("forward in time"),
        "{e}"
    );
    // A key that carries the body past the scene's coordinate limit
    // (1e12 scene units), as a placement there would be refused.
    let e = fails(
        &moving
            .replace("[\"truck\"]", "[\"road\"]")
            .replace("[2, 5, 0, 0]", "[2, 1e12, 0, 0]"),
        &camera,
    );
    assert!(
        e.contains("seq.toml:8") && e.contains("move[0].keys[1]") && e.contains("limit"),
        "{e}"
    );
    // A scene that is not there.
    let e = fails(&SEQUENCE.replace("scene.toml", "nowhere.toml"), &camera);
    assert!(e.contains("nowhere.toml"), "{e}");
}

/// `--frame-format fits` on a scene with a time: each frame's `DATE-OBS`
/// is the scene's `[sky] utc` plus its exposure start in the sequence
/// (frame i at i / 25 s), `GAIN` e⁻/DN and the tube gain in `TUBEGAIN`.
#[test]
fn sequence_fits_frames_are_dated_by_the_scene_time() {
    let dir = tempfile::tempdir().unwrap();
    let scene = format!(
        "{SCENE}[sky]\nutc = \"2025-10-22T04:00:00Z\"\nlatitude_deg = 32.2\nlongitude_deg = -110.9\nmoon = false\nnight_sky = false\n"
    );
    std::fs::write(dir.path().join("scene.toml"), scene).unwrap();
    let seq = dir.path().join("seq.toml");
    std::fs::write(
        &seq,
        "scene = \"scene.toml\"\nframe_rate_hz = 25\nframes = 3\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    ok(&[
        "sequence",
        seq.to_str().unwrap(),
        "--sensor",
        "gen3-gaas-iccd",
        "--spp",
        "1",
        "--gain",
        "100",
        "--frame-format",
        "fits",
        "--out",
        out.to_str().unwrap(),
    ]);
    let recs = common::records(&out);
    assert_eq!(recs.len(), 3);
    for (i, r) in recs.iter().enumerate() {
        assert_eq!(r["file"], format!("frame-{i:06}.fits"));
        let bytes = std::fs::read(out.join(format!("frame-{i:06}.fits"))).unwrap();
        let cards = common::fits_cards(&bytes);
        let get = |k: &str| cards.iter().find(|c| c.0 == k).unwrap().clone();
        let (_, date, why) = get("DATE-OBS");
        assert_eq!(
            date,
            [
                "2025-10-22T04:00:00.000",
                "2025-10-22T04:00:00.040",
                "2025-10-22T04:00:00.080"
            ][i]
        );
        assert_eq!(why, "UTC, scene [sky] utc + frame start");
        let t = r["sequence"]["time_s"].as_f64().unwrap();
        assert!((common::fits_date_unix_s(&date) - (1_761_105_600.0 + t)).abs() < 1e-6);
        assert_eq!(get("TUBEGAIN").1.parse::<f64>().unwrap(), 100.0);
        let gain: f64 = get("GAIN").1.parse().unwrap();
        assert_eq!(gain, r["electrons_per_dn"].as_f64().unwrap());
        assert_eq!(get("INSTRUME").1, "gen3-gaas-iccd");
    }
}

/// `--target-error camera` on a sequence bounds each pixel by the camera's
/// noise at the brightest frame it sees. Here that frame is every frame
/// after the switch (glow and lamp both at 1), whose image is the still
/// render's: so the sequence's layers are sampled exactly as `gloam render
/// --target-error camera` samples the still at the same gain (the
/// independent answer) — the same samples per pixel, and layers that sum
/// to the still's radiance. With the lamp at twice its intensity in the
/// brightest frames the bound is tighter and more samples are taken.
#[test]
fn a_sequence_renders_to_the_camera_s_noise_at_each_pixel_s_brightest_frame() {
    let dir = tempfile::tempdir().unwrap();
    let seq = files(dir.path(), SEQUENCE);
    let out = dir.path().join("seq-out");
    let run = ok(&[
        "sequence",
        &seq,
        "--sensor",
        "gen3-gaas-iccd",
        "--gain",
        "100",
        "--target-error",
        "camera",
        "--out",
        &out.display().to_string(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("brightest frame"), "{stderr}");
    let read = |p: &Path| -> Value {
        serde_json::from_str(&std::fs::read_to_string(p.join("report.json")).unwrap()).unwrap()
    };
    let report = read(&out);
    let t = &report["camera_target"];
    assert_eq!(t["k"], 0.3);
    assert_eq!(t["gain"], 100.0);
    assert_eq!(t["frames"], 60);
    assert_eq!(
        report["sequence"]["renders"]["poses"][0]["camera_target"],
        *t
    );
    // Every pixel within its bound (none capped on this small scene).
    let p99 = t["added_variance_fraction_p99"].as_f64().unwrap();
    assert!(p99 <= 0.09 * (1.0 + 1e-9) && p99 > 0.0, "{p99}");

    let still = dir.path().join("still");
    ok(&[
        "render",
        &dir.path().join("scene.toml").display().to_string(),
        "--sensor",
        "gen3-gaas-iccd",
        "--gain",
        "100",
        "--target-error",
        "camera",
        "--out",
        &still.display().to_string(),
    ]);
    let s = read(&still);
    let spp = t["mean_spp"].as_f64().unwrap();
    assert_eq!(spp, s["camera_target"]["mean_spp"].as_f64().unwrap());
    assert!(
        spp > 2.0,
        "the bound must ask for more than the first round: {spp}"
    );
    let layers: ndarray::Array4<f64> = ndarray_npy::read_npy(out.join("layers.npy")).unwrap();
    let radiance: ndarray::Array3<f64> = ndarray_npy::read_npy(still.join("radiance.npy")).unwrap();
    let sum = layers.sum_axis(ndarray::Axis(0));
    let peak = radiance.iter().copied().fold(0.0, f64::max);
    let worst = (&sum - &radiance)
        .iter()
        .map(|d| d.abs())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-12 * peak, "{worst} of {peak}");

    // The lamp at twice its intensity after the switch: a brighter frame,
    // a tighter bound where the lamp lights the road.
    let brighter = SEQUENCE.replace("[1.21, 1]]", "[1.21, 2]]");
    let seq2 = dir.path().join("seq2.toml");
    std::fs::write(&seq2, brighter).unwrap();
    let out2 = dir.path().join("seq2-out");
    ok(&[
        "sequence",
        &seq2.display().to_string(),
        "--sensor",
        "gen3-gaas-iccd",
        "--gain",
        "100",
        "--target-error",
        "camera",
        "--out",
        &out2.display().to_string(),
    ]);
    let spp2 = read(&out2)["camera_target"]["mean_spp"].as_f64().unwrap();
    assert!(spp2 > spp, "{spp2} vs {spp}");
}
