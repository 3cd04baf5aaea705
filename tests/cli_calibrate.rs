//! End-to-end tests of `gloam calibrate …` and `gloam compare` against the
//! simulated cameras.

use std::path::Path;
use std::process::Command;

use reference::preset_qe_under_cie_a;

#[path = "../crates/calib/tests/shared/reference.rs"]
mod reference;

fn gloam() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gloam"))
}

fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("run gloam");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "gloam failed: {stderr}");
    stderr
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The sphere source of the photon-transfer tests, its rig the camera `CAM`.
fn sphere() -> String {
    reference::sphere_toml("scientific-ccd")
}

const CAM: &str = "sim:scientific-ccd?size=48x48&seed=3";

/// The chain's true response, noise off: mean DN at two radiances.
fn true_line(gain: f64, l1: f64, l2: f64) -> (f64, f64) {
    let mut cam =
        gloam_sensor::Camera::from_preset_or_file("scientific-ccd", &gloam_io::ReadLog::off())
            .unwrap();
    cam.set_noise(false);
    cam.set_override_gain(Some(gain)).unwrap();
    // Stimulus radiance is band radiance over 400–1000 nm: the shape the
    // camera integrates is the lamp restricted to that band.
    let shape = gloam_spectra::library::get("cie-a")
        .unwrap()
        .product(&gloam_spectra::Spectrum::constant(400.0, 1000.0, 1.0).unwrap());
    let mut mean = |l: f64| {
        let img = ndarray::Array2::from_elem((48, 48), l);
        let f = cam.capture_mono(img.view(), &shape).unwrap();
        f.pixels.iter().map(|&p| p as f64).sum::<f64>() / f.pixels.len() as f64
    };
    let (d1, d2) = (mean(l1), mean(l2));
    let g = (l2 - l1) / (d2 - d1);
    (g, l1 - g * d1)
}

#[test]
fn radiance_lut_then_apply_recovers_radiance() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("sphere.toml");
    std::fs::write(&src, sphere()).unwrap();
    let out = dir.path().join("cal");
    run_ok(
        gloam()
            .args(["calibrate", "radiance", "--grabber", CAM, "--source"])
            .arg(&src)
            .args([
                "--gains",
                "1,2",
                "--levels",
                "8",
                "--frames",
                "4",
                "--auto-range",
                "0.8",
                "--out",
            ])
            .arg(&out),
    );
    let lut = json(&out.join("lut.json"));
    let gains = lut["gains"].as_array().unwrap();
    assert_eq!(gains.len(), 2);
    for k in [
        "gain",
        "g_w_m2_sr_per_dn",
        "b_w_m2_sr",
        "r_squared",
        "fit_range_dn",
    ] {
        assert!(gains[0].get(k).is_some(), "missing {k}");
    }
    for png in ["radiance_fit.png", "linearity_residuals.png", "radiance.md"] {
        assert!(out.join(png).exists());
    }
    // Against the chain's own noise-free response: within 0.5 %.
    for g in gains {
        let gain = g["gain"].as_f64().unwrap();
        let top = g["levels"].as_array().unwrap().last().unwrap()["band_radiance_w_m2_sr"]
            .as_f64()
            .unwrap();
        let (gt, bt) = true_line(gain, 0.2 * top, top);
        let gm = g["g_w_m2_sr_per_dn"].as_f64().unwrap();
        let bm = g["b_w_m2_sr"].as_f64().unwrap();
        eprintln!(
            "sim gain {gain}: g error {:.4} %, b error {:.4} % (of b) / {:.2e} of top radiance",
            100.0 * (gm / gt - 1.0),
            100.0 * (bm / bt - 1.0),
            (bm - bt).abs() / top
        );
        assert!((gm / gt - 1.0).abs() < 0.005);
        assert!((bm / bt - 1.0).abs() < 0.005 || (bm - bt).abs() < 1e-3 * top);
    }

    // Capture a frame and apply the LUT via frames.jsonl's gain.
    let cap = dir.path().join("cap");
    run_ok(
        gloam()
            .args([
                "capture",
                "--grabber",
                CAM,
                "--frames",
                "1",
                "--gain",
                "2",
                "--out",
            ])
            .arg(&cap),
    );
    let tif = dir.path().join("rad.tiff");
    run_ok(
        gloam()
            .args(["calibrate", "apply", "--lut"])
            .arg(out.join("lut.json"))
            .arg(cap.join("frame-000000.png"))
            .arg(&tif),
    );
    let img = gloam_calib::io::read_grey(&tif, &gloam_io::ReadLog::off()).unwrap();
    assert_eq!((img.width, img.height), (48, 48));
    assert!(img.data.iter().all(|v| v.is_finite()));
    // A --gain the frame's record contradicts is refused, naming the record.
    let o = gloam()
        .args(["calibrate", "apply", "--gain", "50", "--lut"])
        .arg(out.join("lut.json"))
        .arg(cap.join("frame-000000.png"))
        .arg(&tif)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("frames.jsonl:1 records gain 2") && err.contains("--gain 50"),
        "{err}"
    );
    // A gain outside the LUT is refused (a frame without a record: the
    // warning says what cannot be checked).
    let lone = dir.path().join("lone");
    std::fs::create_dir(&lone).unwrap();
    std::fs::copy(cap.join("frame-000000.png"), lone.join("f.png")).unwrap();
    let o = gloam()
        .args(["calibrate", "apply", "--gain", "50", "--lut"])
        .arg(out.join("lut.json"))
        .arg(lone.join("f.png"))
        .arg(&tif)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("outside the calibrated gains"), "{err}");
    assert!(
        err.contains("camera and bit depth cannot be checked"),
        "{err}"
    );
}

#[test]
fn ptc_writes_emva_figures_and_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("sphere.toml");
    std::fs::write(&src, sphere()).unwrap();
    let out = dir.path().join("ptc");
    run_ok(
        gloam()
            .args([
                "calibrate",
                "ptc",
                "--grabber",
                "sim:scientific-ccd?size=96x96&seed=8",
                "--source",
            ])
            .arg(&src)
            .args([
                "--levels",
                "50",
                "--gain",
                "1",
                "--auto-range",
                "1.4",
                "--spatial-frames",
                "8",
                "--out",
            ])
            .arg(&out),
    );
    let v = json(&out.join("ptc.json"));
    for k in [
        "system_gain_dn_per_e",
        "quantum_efficiency",
        "dark_noise_e",
        "saturation_capacity_e",
        "linearity_error_percent",
        "dsnu_e",
        "prnu_percent",
    ] {
        assert!(v[k].is_number(), "missing {k}: {}", v[k]);
    }
    // Against the chain: system gain K within 2 %, temporal dark noise (read
    // noise, plus the cooled CCD's negligible dark-current shot noise) within 5 %.
    let cam =
        gloam_sensor::Camera::from_preset_or_file("scientific-ccd", &gloam_io::ReadLog::off())
            .unwrap();
    let chain = cam.chain();
    let k_true = chain.mean_dn_per_photoelectron(1.0);
    let rn_true = chain.read_noise_dn(1.0) / k_true;
    let k = v["system_gain_dn_per_e"].as_f64().unwrap();
    let rn = v["dark_noise_e"].as_f64().unwrap();
    eprintln!(
        "sim PTC: K {k:.5} vs {k_true:.5} ({:+.3} %), dark noise {rn:.3} vs {rn_true:.3} e ({:+.3} %)",
        100.0 * (k / k_true - 1.0),
        100.0 * (rn / rn_true - 1.0)
    );
    assert!((k / k_true - 1.0).abs() < 0.02);
    assert!((rn / rn_true - 1.0).abs() < 0.05);
    // QE: the rig takes the camera's own optics, so photon transfer recovers
    // the preset's QE, photon-weighted over the stimulus (CIE A, 400–1000 nm).
    let qe = v["quantum_efficiency"].as_f64().unwrap();
    let qe_true = preset_qe_under_cie_a("scientific-ccd");
    eprintln!(
        "sim PTC: QE {qe:.5} vs preset {qe_true:.5} ({:+.3} %)",
        100.0 * (qe / qe_true - 1.0)
    );
    assert!((qe / qe_true - 1.0).abs() < 0.015, "QE {qe} vs {qe_true}");
    assert_eq!(v["rig"]["camera"], "scientific-ccd");
    assert!((v["rig"]["optics_transmission"].as_f64().unwrap() - 0.9).abs() < 1e-12);
    let desc = std::fs::read_to_string(out.join("emva1288/emva1288_descriptor.txt")).unwrap();
    assert!(desc.contains("\nn 16 96 96\n"));
    assert!(out.join("photon_transfer.png").exists());
}

#[test]
fn ptc_warns_when_the_rig_is_not_the_simulated_camera() {
    // f/2 without τ (so τ = 1) in front of the scientific CCD, whose lens has
    // τ = 0.9: the rig counts 1/0.9 − 1 = 11.1 % more photons.
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("sphere.toml");
    std::fs::write(
        &src,
        sphere().replace(
            "camera = \"scientific-ccd\"",
            "pixel_pitch_um = 13.5\nf_number = 2.0\nexposure_s = 1.0",
        ),
    )
    .unwrap();
    let out = gloam()
        .args([
            "calibrate",
            "ptc",
            "--grabber",
            "sim:scientific-ccd?size=32x32&seed=8",
            "--source",
        ])
        .arg(&src)
        .args(["--levels", "20", "--gain", "1", "--auto-range", "1.4"])
        .args(["--spatial-frames", "2", "--out"])
        .arg(dir.path().join("ptc"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("11.11 % more photons") && stderr.contains("camera = \"scientific-ccd\""),
        "{stderr}"
    );
}

#[test]
fn mtf_sine_edge_and_usaf() {
    let dir = tempfile::tempdir().unwrap();
    for target in ["sine", "edge"] {
        let out = dir.path().join(target);
        run_ok(
            gloam()
                .args([
                    "calibrate",
                    "mtf",
                    "--target",
                    target,
                    "--grabber",
                    "sim:gen2-s20-iccd?size=96x96&seed=8",
                    "--frames",
                    "4",
                    "--out",
                ])
                .arg(&out),
        );
        let v = json(&out.join("mtf.json"));
        assert!(v["frequencies_cy_per_px"].is_array() && v["mtf"].is_array());
        assert!(v.get("mtf50").is_some() && v.get("mtf10").is_some());
        assert!(out.join("mtf.png").exists());
    }
    let ctf = dir.path().join("ctf.csv");
    std::fs::write(
        &ctf,
        "group,element,modulation\n0,1,0.95\n1,1,0.85\n2,1,0.6\n3,1,0.3\n4,1,0.05\n",
    )
    .unwrap();
    let out = dir.path().join("usaf");
    run_ok(
        gloam()
            .args([
                "calibrate",
                "mtf",
                "--target",
                "usaf",
                "--pixel-pitch-um",
                "10",
                "--ctf",
            ])
            .arg(&ctf)
            .arg("--out")
            .arg(&out),
    );
    let v = json(&out.join("mtf.json"));
    // 16 lp/mm at 10 µm pixels = 0.16 cy/px.
    assert!((v["frequencies_cy_per_px"][4].as_f64().unwrap() - 0.16).abs() < 1e-12);
    assert!(v["mtf"][0].as_f64().unwrap() < 0.95 + 1e-9);
}

#[test]
fn compare_reports_spearman_with_ties_and_rms() {
    let dir = tempfile::tempdir().unwrap();
    // Two 5×1 16-bit images: scipy's tied example [1..5] vs [5,6,7,8,7].
    let write = |name: &str, v: &[u16]| {
        let img =
            image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(5, 1, v.to_vec()).unwrap();
        let p = dir.path().join(name);
        img.save(&p).unwrap();
        p
    };
    let t = write("t.png", &[1, 2, 3, 4, 5]);
    let s = write("s.png", &[5, 6, 7, 8, 7]);
    let regions = dir.path().join("r.json");
    let r: Vec<serde_json::Value> = (0..5).map(|x| serde_json::json!({"name": format!("p{x}"), "x": x, "y": 0, "width": 1, "height": 1})).collect();
    std::fs::write(&regions, serde_json::to_string(&r).unwrap()).unwrap();
    let out = gloam()
        .arg("compare")
        .arg(&t)
        .arg(&s)
        .arg("--regions")
        .arg(&regions)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!((v["spearman_rho"].as_f64().unwrap() - 0.820_782_681_668_123_3).abs() < 1e-12);
    assert!((v["rms"].as_f64().unwrap() - (68.0f64 / 5.0).sqrt()).abs() < 1e-12);
}

/// MTF through the CLI against the simulated chain's analytic MTF
/// (`Chain::mtf`), below Nyquist. The simulated Sine stimulus is point
/// sampled, so the sine-target MTF is the chain's; the simulated Edge is
/// rendered with 4×4 pixel-area coverage, which adds the pixel aperture
/// `sinc(f)` — the slanted edge is compared with `Chain::mtf · sinc`.
#[test]
fn mtf_matches_the_simulated_chain() {
    let dir = tempfile::tempdir().unwrap();
    for preset in ["scientific-ccd", "gen2-s20-iccd", "gen3-gaas-iccd"] {
        let cam =
            gloam_sensor::Camera::from_preset_or_file(preset, &gloam_io::ReadLog::off()).unwrap();
        let chain = cam.chain();
        // At its reference gain one Gen III photoelectron fills ~70 % of the
        // digitizer, so single events clip and the frames stop being linear
        // in the stimulus, which a modulation measurement needs. Measure it
        // where events are small, as a lab would (a tenth of the gain).
        let g = if preset == "gen3-gaas-iccd" {
            chain.reference_gain / 10.0
        } else {
            chain.reference_gain
        };
        for target in ["sine", "edge"] {
            let out = dir.path().join(format!("{preset}-{target}"));
            run_ok(
                gloam()
                    .args(["calibrate", "mtf", "--target", target, "--grabber"])
                    .arg(format!("sim:{preset}?size=128x128&seed=2"))
                    .args([
                        "--frames",
                        if target == "edge" { "48" } else { "16" },
                        "--gain",
                        &g.to_string(),
                        "--out",
                    ])
                    .arg(&out),
            );
            let v = json(&out.join("mtf.json"));
            let f = v["frequencies_cy_per_px"].as_array().unwrap();
            let m = v["mtf"].as_array().unwrap();
            let mut worst: f64 = 0.0;
            for (fi, mi) in f.iter().zip(m) {
                let (fi, mi) = (fi.as_f64().unwrap(), mi.as_f64().unwrap());
                if fi >= 0.5 {
                    continue;
                }
                let x = std::f64::consts::PI * fi;
                let aperture = if target == "edge" && fi > 0.0 {
                    x.sin() / x
                } else {
                    1.0
                };
                worst = worst.max((mi - chain.mtf(fi, g) * aperture).abs());
            }
            eprintln!("sim {preset} {target}: max |MTF error| below Nyquist {worst:.4}");
            let tol = 0.03;
            assert!(worst < tol, "{preset} {target}: {worst}");
        }
    }
}

/// The same radiance flow through the device emulator over a PTY gives the
/// same LUT as in-process (within 0.5 %; the noise streams differ in phase).
#[cfg(unix)]
#[test]
fn radiance_lut_through_the_emulator_matches_in_process() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("sphere.toml");
    std::fs::write(&src, sphere()).unwrap();
    let mut dev = gloam()
        .args([
            "device",
            "--pty",
            "--sensor",
            "scientific-ccd",
            "--size",
            "48x48",
            "--seed",
            "3",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start the emulator");
    let mut first = String::new();
    std::io::BufReader::new(dev.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let pty = first.trim().to_string();
    let lut_of = |uri: &str, out: &Path| {
        let o = gloam()
            .args(["calibrate", "radiance", "--grabber", uri, "--source"])
            .arg(&src)
            .args([
                "--gains",
                "1,2",
                "--levels",
                "6",
                "--frames",
                "3",
                "--auto-range",
                "0.8",
                "--out",
            ])
            .arg(out)
            .output()
            .unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };
    let (ok, err) = lut_of(&format!("serial:{pty}"), &dir.path().join("pty"));
    let _ = dev.kill();
    let _ = dev.wait();
    assert!(ok, "through the emulator: {err}");
    let (ok, err) = lut_of(
        "sim:scientific-ccd?size=48x48&seed=3",
        &dir.path().join("sim"),
    );
    assert!(ok, "in process: {err}");
    let a = json(&dir.path().join("pty/lut.json"));
    let b = json(&dir.path().join("sim/lut.json"));
    for (x, y) in a["gains"]
        .as_array()
        .unwrap()
        .iter()
        .zip(b["gains"].as_array().unwrap())
    {
        for k in ["g_w_m2_sr_per_dn", "b_w_m2_sr"] {
            let r = x[k].as_f64().unwrap() / y[k].as_f64().unwrap() - 1.0;
            eprintln!(
                "emulator vs in-process, gain {}: {k} differs by {:.2e}",
                x["gain"], r
            );
            assert!(r.abs() < 0.005);
        }
    }
}
