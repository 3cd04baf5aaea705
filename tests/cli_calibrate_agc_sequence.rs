//! End-to-end tests of `gloam calibrate agc --sequence` through the binary:
//! the street-switch-on road (a lamp 205 m away switching on at 2 s)
//! through a noise-free Gen III camera whose AGC runs across the frames,
//! linearised through a LUT measured on the integrating sphere.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_gloam");

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn gloam(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("running the gloam binary")
}

/// The Gen III preset with its noise off (a deterministic chain: the
/// frames are the camera's means), as a sensor file in `dir`.
fn quiet_gen3(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo("sims/sensors/gen3-gaas-iccd.toml")).unwrap();
    let quiet = text.replace("[noise]\nenabled = true", "[noise]\nenabled = false");
    assert_ne!(quiet, text, "the preset's [noise] table moved");
    let path = dir.join("gen3-quiet.toml");
    std::fs::write(&path, quiet).unwrap();
    path
}

/// 100 frames at 25 Hz of the street-switch-on scene, the light group
/// `group` off until 2 s.
fn sequence(dir: &Path, group: &str) -> PathBuf {
    let scene = repo("sims/street-switch-on/scene.toml");
    let text = format!(
        "scene = {:?}\nframe_rate_hz = 25\nframes = 100\n[groups.{group}]\nkeys = [[0, 0], [2, 0], [2, 1]]\n",
        scene.display().to_string()
    );
    let path = dir.join("seq.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn run(dir: &Path, seq: &Path, sensor: &Path, out: &str, extra: &[&str]) -> Output {
    let grabber = format!("sim:{}?size=64x64", sensor.display());
    let out = dir.join(out);
    let mut args = vec![
        "calibrate",
        "agc",
        "--sequence",
        seq.to_str().unwrap(),
        "--grabber",
        &grabber,
        "--source",
        repo("sims/calibration/sphere.toml").to_str().unwrap(),
        "--set",
        "resolution_scale=0.5",
        "--out",
        out.to_str().unwrap(),
    ]
    .into_iter()
    .map(String::from)
    .collect::<Vec<_>>();
    args.extend(extra.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    gloam(&args)
}

/// With the gain in effect applied per frame, a noise-free camera's
/// linearised radiance is as right mid-transient as settled: its AGC
/// changes the gain between frames, never within one. The residual left
/// (about −1.5 %) is spatial — the intensifier's halo and blur carry light
/// out of the compared pixels — and the same in every frame after the
/// switch. A LUT applied at the settled gain instead (ignoring the AGC's
/// time series) is wrong by the gain's own ratio, G_i / G_settled: the
/// MCP's gain scales the counts, the independent answer checked frame by
/// frame.
#[test]
fn a_lamp_switching_on_is_linearised_at_the_gain_in_effect() {
    let dir = tempfile::tempdir().unwrap();
    let sensor = quiet_gen3(dir.path());
    let seq = sequence(dir.path(), "road_lamp");
    let o = run(dir.path(), &seq, &sensor, "out", &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("LUT measured on"), "{err}");
    let out = dir.path().join("out");
    for f in [
        "lut.json",
        "frames.jsonl",
        "agc_sequence.png",
        "agc_sequence_residual.png",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let r: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("agc_sequence.json")).unwrap())
            .unwrap();
    assert_eq!(r["switches_s"], serde_json::json!([2.0]));
    let settled = r["settled_gain"].as_f64().unwrap();
    let frames = r["frames"].as_array().unwrap();
    let after: Vec<&Value> = frames
        .iter()
        .filter(|f| f["time_s"].as_f64().unwrap() >= 2.0 && !f["residual_percent"].is_null())
        .collect();
    assert!(after.len() >= 45, "{}", after.len());
    let res = |f: &Value| f["residual_percent"].as_f64().unwrap();
    let steady_after: Vec<f64> = (after.iter())
        .filter(|f| f["phase"] == "steady")
        .map(|f| res(f))
        .collect();
    assert!(!steady_after.is_empty());
    let bias = steady_after.iter().sum::<f64>() / steady_after.len() as f64;
    eprintln!(
        "noise-free: residual after the switch {bias:.3} % (steady), transient {:?}",
        (after.iter())
            .filter(|f| f["phase"] == "transient")
            .map(|f| (res(f) * 1000.0).round() / 1000.0)
            .collect::<Vec<_>>()
    );
    assert!(bias.abs() < 2.0, "spatial residual {bias} %");
    let mut worst_settled = 0.0f64;
    for f in &after {
        let (r_now, r_settled) = (
            res(f),
            f["residual_at_settled_gain_percent"].as_f64().unwrap(),
        );
        // Mid-transient as good as settled, to 0.3 %.
        assert!((r_now - bias).abs() < 0.3, "{f}");
        // Ignoring time: wrong by G_i / G_settled (the dark level, the same
        // at every gain to 2 DN in ~800, leaves ≤ 0.5 %).
        let g = f["gain"].as_f64().unwrap();
        let predicted = g / settled;
        let got = (1.0 + r_settled / 100.0) / (1.0 + r_now / 100.0);
        assert!(
            (got / predicted - 1.0).abs() < 5e-3,
            "{got} vs {predicted}: {f}"
        );
        worst_settled = worst_settled.max(r_settled.abs());
    }
    // The AGC's first frames after the switch are at a gain 30 % above
    // the settled one: a time-blind LUT misses by as much.
    assert!(worst_settled > 20.0, "{worst_settled}");
    let t = &r["transient"];
    let s = &r["steady"];
    assert!(
        t["rms_residual_at_settled_gain_percent"].as_f64().unwrap()
            > 5.0 * t["rms_residual_percent"].as_f64().unwrap(),
        "{t}"
    );
    assert!(s["frames"].as_u64().unwrap() > 0, "{s}");
    // The measured LUT given back with --lut: the same camera, seed and
    // frames give the same figures.
    let lut = out.join("lut.json");
    let o = run(
        dir.path(),
        &seq,
        &sensor,
        "again",
        &["--lut", lut.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let again: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("again/agc_sequence.json")).unwrap(),
    )
    .unwrap();
    for phase in ["transient", "steady"] {
        for k in [
            "rms_residual_percent",
            "rms_residual_at_settled_gain_percent",
        ] {
            let (a, b) = (
                again[phase][k].as_f64().unwrap(),
                r[phase][k].as_f64().unwrap(),
            );
            // The same to rounding (the source is scaled differently).
            assert!((a - b).abs() < 1e-9 * b.abs(), "{phase}.{k}: {a} vs {b}");
        }
    }
}

#[test]
fn a_sequence_naming_a_group_the_scene_lacks_is_refused_before_the_render() {
    let dir = tempfile::tempdir().unwrap();
    let sensor = quiet_gen3(dir.path());
    let seq = sequence(dir.path(), "headlights");
    let o = run(dir.path(), &seq, &sensor, "out", &[]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("seq.toml:4: groups.headlights")
            && err.contains("has no light group 'headlights'")
            && err.contains("road_lamp"),
        "{err}"
    );
    assert!(!dir.path().join("out").exists());
}

#[test]
fn a_lut_of_another_camera_is_refused_before_the_render() {
    let dir = tempfile::tempdir().unwrap();
    let sensor = quiet_gen3(dir.path());
    let seq = sequence(dir.path(), "road_lamp");
    // A LUT made on the scientific CCD.
    let lut = dir.path().join("ccd");
    let o = gloam(&[
        "calibrate",
        "radiance",
        "--grabber",
        "sim:scientific-ccd?size=32x32",
        "--source",
        repo("sims/calibration/sphere.toml").to_str().unwrap(),
        "--gains",
        "1",
        "--levels",
        "4",
        "--auto-range",
        "0.8",
        "--out",
        lut.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lut = lut.join("lut.json");
    let o = run(
        dir.path(),
        &seq,
        &sensor,
        "out",
        &["--lut", lut.to_str().unwrap()],
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("lut.json")
            && err.contains("'simulated scientific-ccd'")
            && err.contains("gen3-quiet.toml'")
            && err.contains("made on another camera"),
        "{err}"
    );
    assert!(!dir.path().join("out").exists());
    // A real camera cannot view a rendered sequence.
    let o = gloam(&[
        "calibrate",
        "agc",
        "--sequence",
        seq.to_str().unwrap(),
        "--grabber",
        "serial:/dev/null",
        "--source",
        repo("sims/calibration/sphere.toml").to_str().unwrap(),
        "--out",
        dir.path().join("out2").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("needs a sim:PRESET grabber"), "{err}");
}

mod common;

/// A FITS frame's counts read from its bytes here (BITPIX 16, big-endian,
/// + BZERO), independently of gloam's reader.
fn fits_counts(bytes: &[u8], cards: &[(String, String, String)]) -> Vec<u16> {
    let get = |k: &str| cards.iter().find(|c| c.0 == k).unwrap().1.clone();
    assert_eq!(get("BITPIX"), "16");
    let (w, h): (usize, usize) = (
        get("NAXIS1").parse().unwrap(),
        get("NAXIS2").parse().unwrap(),
    );
    let zero: i32 = get("BZERO").parse().unwrap();
    let end = bytes
        .chunks(80)
        .position(|c| c.starts_with(b"END "))
        .unwrap();
    let data = &bytes[(end * 80 + 80).div_ceil(2880) * 2880..];
    (data.chunks(2).take(w * h))
        .map(|c| u16::try_from(i32::from(i16::from_be_bytes([c[0], c[1]])) + zero).unwrap())
        .collect()
}

/// `calibrate agc --sequence --frame-format fits|tiff` stores the frames
/// it captures as `gloam capture` does, and reads them back: the same
/// counts (each frame's CRC-32C), the same linearised figures as the PNG
/// run to the last digit, FITS headers holding the record's values, and
/// `calibrate apply` on a FITS frame or a page of the TIFF stack giving
/// the PNG frame's radiance.
#[test]
fn sequence_frames_as_fits_or_tiff_are_read_back_to_the_same_figures() {
    let dir = tempfile::tempdir().unwrap();
    let sensor = quiet_gen3(dir.path());
    // The lamp switching on at 2 s, 100 frames.
    let seq = sequence(dir.path(), "road_lamp");
    let o = run(dir.path(), &seq, &sensor, "png", &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lut = dir.path().join("png/lut.json");
    let lut_arg = lut.to_str().unwrap();
    let o = run(dir.path(), &seq, &sensor, "png-lut", &["--lut", lut_arg]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for format in ["fits", "tiff"] {
        let o = run(
            dir.path(),
            &seq,
            &sensor,
            format,
            &["--lut", lut_arg, "--frame-format", format],
        );
        assert!(
            o.status.success(),
            "{format}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let report = |d: &str| -> Value {
        serde_json::from_str(
            &std::fs::read_to_string(dir.path().join(d).join("agc_sequence.json")).unwrap(),
        )
        .unwrap()
    };
    let png_report = report("png-lut");
    let png_frames = png_report["frames"].as_array().unwrap();
    assert_eq!(png_frames.len(), 100);
    let png = common::records(&dir.path().join("png-lut"));
    for format in ["fits", "tiff"] {
        let out = dir.path().join(format);
        let recs = common::records(&out);
        assert_eq!(recs.len(), 100, "{format}");
        let r = report(format);
        for (i, (a, b)) in (r["frames"].as_array().unwrap().iter())
            .zip(png_frames)
            .enumerate()
        {
            assert_eq!(recs[i]["stored"]["format"], format);
            assert_eq!(
                recs[i]["pixels_crc32c"], png[i]["pixels_crc32c"],
                "{format} {i}"
            );
            for k in [
                "gain",
                "residual_percent",
                "residual_at_settled_gain_percent",
            ] {
                assert_eq!(a[k], b[k], "{format}: frame {i}'s {k}");
            }
        }
        assert!(
            png_frames.iter().any(|f| f["residual_percent"].is_number()),
            "no frame compared"
        );
    }
    assert_eq!(
        recs_files(&dir.path().join("tiff")),
        vec!["frames.tiff".to_string(); 100]
    );

    // The FITS frames, read here: counts and header against the record.
    let fits_dir = dir.path().join("fits");
    let scene_t0 = common::fits_date_unix_s("2025-10-22T04:00:00");
    for r in &common::records(&fits_dir) {
        let bytes = std::fs::read(fits_dir.join(r["file"].as_str().unwrap())).unwrap();
        let cards = common::fits_cards(&bytes);
        let get = |k: &str| {
            let c = cards.iter().find(|c| c.0 == k);
            c.unwrap_or_else(|| panic!("no {k} in {cards:?}")).1.clone()
        };
        let num = |k: &str| get(k).parse::<f64>().unwrap();
        let counts = fits_counts(&bytes, &cards);
        let n = r["width"].as_u64().unwrap() * r["height"].as_u64().unwrap();
        assert_eq!(counts.len() as u64, n);
        assert!(n >= 16 * 16, "{n} pixels");
        assert_eq!(
            u64::from(gloam_grabber::pixels_crc32c(&counts)),
            r["pixels_crc32c"].as_u64().unwrap()
        );
        // serde_json's float parsing may be off in the last digit (the
        // header holds Rust's exact shortest digits).
        let close = |k: &str, want: f64| {
            let got = num(k);
            assert!(
                (got - want).abs() <= 1e-14 * want.abs(),
                "{k} {got} vs {want}"
            );
        };
        close("TUBEGAIN", r["gain"].as_f64().unwrap());
        assert_eq!(get("AGC"), "T");
        assert_eq!(num("BITS"), r["bits"].as_f64().unwrap());
        assert_eq!(get("INSTRUME"), "gen3-quiet.toml");
        close("EXPTIME", r["sensor"]["exposure_s"].as_f64().unwrap());
        // GAIN is e⁻/DN (ccdproc's), the record's electrons_per_dn.
        close("GAIN", r["electrons_per_dn"].as_f64().unwrap());
        // The scene's [sky] utc plus the frame's start in the sequence.
        let t = common::fits_date_unix_s(&get("DATE-OBS"));
        let want = scene_t0 + r["sequence"]["time_s"].as_f64().unwrap();
        assert!((t - want).abs() < 1.5e-3, "DATE-OBS {t} vs {want}");
        assert_eq!(get("CAMERA"), sensor.display().to_string());
        get("SEED").parse::<u64>().unwrap();
        // The run's start, before this frame's file.
        let run_start = common::fits_date_unix_s(&get("DATE"));
        let written = std::fs::metadata(fits_dir.join(r["file"].as_str().unwrap()))
            .unwrap()
            .modified()
            .unwrap()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_secs_f64();
        assert!(
            run_start <= written + 1.0,
            "DATE {run_start} after {written}"
        );
    }

    // calibrate apply: a FITS frame and a page of the TIFF stack give the
    // PNG frame's radiance, pixel for pixel.
    let apply = |input: &Path, page: Option<&str>, output: &Path| {
        let mut args = vec!["calibrate", "apply", "--lut", lut_arg];
        args.extend(page.map(|p| ["--page", p]).iter().flatten());
        args.extend([input.to_str().unwrap(), output.to_str().unwrap()]);
        gloam(&args)
    };
    let radiance = |p: &Path| {
        gloam_calib::io::read_grey(p, &gloam_io::ReadLog::off())
            .unwrap()
            .data
    };
    // Two frames the LUT covers (linearised in the report): the first
    // and the last.
    let covered: Vec<usize> = (png_frames.iter().enumerate())
        .filter(|(_, f)| f["residual_percent"].is_number())
        .map(|(i, _)| i)
        .collect();
    assert!(covered.len() >= 2, "{covered:?}");
    for i in [covered[0], covered[covered.len() - 1]] {
        let name = format!("frame-{i:06}");
        let want = dir.path().join(format!("png-{i}.tiff"));
        let o = apply(&dir.path().join(format!("png-lut/{name}.png")), None, &want);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let from_fits = dir.path().join(format!("fits-{i}.tiff"));
        let o = apply(&fits_dir.join(format!("{name}.fits")), None, &from_fits);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let from_tiff = dir.path().join(format!("tiff-{i}.tiff"));
        let page = i.to_string();
        let o = apply(
            &dir.path().join("tiff/frames.tiff"),
            Some(&page),
            &from_tiff,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (w, f, t) = (radiance(&want), radiance(&from_fits), radiance(&from_tiff));
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
        };
        assert!(same(&w, &f) && same(&w, &t), "frame {i}");
        assert!(w.iter().any(|v| *v > 0.0));
    }
    // The stack without a page is refused, naming its pages.
    let o = apply(
        &dir.path().join("tiff/frames.tiff"),
        None,
        &dir.path().join("x.tiff"),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("holds 100 pages"),
        "{err}"
    );
    assert!(!dir.path().join("x.tiff").exists());
}

fn recs_files(dir: &Path) -> Vec<String> {
    common::records(dir)
        .iter()
        .map(|r| r["file"].as_str().unwrap().to_string())
        .collect()
}
