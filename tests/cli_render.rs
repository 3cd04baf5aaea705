//! End-to-end tests of `gloam render` and `gloam probe` through the binary.

mod common;
use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_gloam");

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

fn panel_scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("sims/panel-validation/scene.toml")
        .display()
        .to_string()
}

/// A small copy of the panel scene (64 × 48) so the CLI test stays quick.
fn small_scene(dir: &Path) -> String {
    let text = std::fs::read_to_string(panel_scene())
        .unwrap()
        .replace("width = 320", "width = 64")
        .replace("height = 240", "height = 48");
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

#[test]
fn render_writes_all_outputs_and_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_scene(dir.path());
    let out = dir.path().join("out");
    let out_s = out.display().to_string();
    ok(&[
        "render",
        &scene,
        "--out",
        &out_s,
        "--spp",
        "2",
        "--seed",
        "3",
        "--estimator",
        "solid-angle",
        "--set",
        "area_samples=4",
        "--set",
        "recursion=2",
        "--threads",
        "2",
    ]);
    for f in [
        "radiance.tiff",
        "radiance.npy",
        "preview.png",
        "report.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let report: Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["settings"]["spp"], 2);
    assert_eq!(report["settings"]["seed"], 3);
    assert_eq!(report["settings"]["estimator"], "solid-angle");
    assert_eq!(report["settings"]["area_samples"], 4);
    assert_eq!(report["settings"]["recursion"], 2);
    assert_eq!(report["settings"]["dirsig2001"]["MAX_SAMPLE_POINTS"], 500);
    assert!(report["rays_per_second"].as_f64().unwrap() > 0.0);
    assert!(report["rays"]["primary"].as_u64().unwrap() == 64 * 48 * 2);
    assert!(report["effect_plan"]["effects"].as_array().unwrap().len() > 3);
    assert!(report["timings_s"]["trace"].as_f64().is_some());

    // NPY: band × row × column header; TIFF: a float32 page of 64 × 48.
    let npy = std::fs::read(out.join("radiance.npy")).unwrap();
    let header = String::from_utf8_lossy(&npy[..128]);
    assert!(header.contains("(1, 48, 64)"), "{header}");
    let mut dec = tiff::decoder::Decoder::new(std::io::Cursor::new(
        std::fs::read(out.join("radiance.tiff")).unwrap(),
    ))
    .unwrap();
    assert_eq!(dec.dimensions().unwrap(), (64, 48));
    match dec.read_image().unwrap() {
        tiff::decoder::DecodingResult::F32(v) => {
            let max = v.iter().copied().fold(0.0f32, f32::max);
            assert!((max - 15.058).abs() < 1e-3, "{max}");
        }
        other => panic!("not float32: {:?}", std::mem::discriminant(&other)),
    }
    assert!(!dec.more_images());
}

#[test]
fn render_is_identical_across_thread_counts() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_scene(dir.path());
    let a = dir.path().join("a").display().to_string();
    let b = dir.path().join("b").display().to_string();
    ok(&["render", &scene, "--out", &a, "--threads", "1"]);
    ok(&["render", &scene, "--out", &b, "--threads", "2"]);
    let fa = std::fs::read(Path::new(&a).join("radiance.npy")).unwrap();
    let fb = std::fs::read(Path::new(&b).join("radiance.npy")).unwrap();
    assert_eq!(fa, fb);
}

#[test]
fn probe_point_and_pixel_print_json() {
    let scene = panel_scene();
    let out = ok(&[
        "probe", &scene, "--point", "0,0,0", "--normal", "0,0,1", "--json",
    ]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["band"], "vis");
    let e = v["irradiance_w_m2"].as_f64().unwrap();
    assert!((e - 1.428_783).abs() < 1e-5, "{e}");
    assert_eq!(v["std_error_w_m2"].as_f64().unwrap(), 0.0);
    assert!(v["radiance_w_m2_sr"].as_f64().is_some());
    // Off every surface: no radiance key.
    let out = ok(&[
        "probe", &scene, "--point", "0,0,-1", "--normal", "0,0,1", "--json",
    ]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v.get("radiance_w_m2_sr").is_none());

    let dir = tempfile::tempdir().unwrap();
    let small = small_scene(dir.path());
    let out = ok(&["probe", &small, "--pixel", "32,5", "--json"]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["radiance_w_m2_sr"].as_f64().is_some());
}

#[test]
fn bad_input_is_a_clear_error() {
    let scene = panel_scene();
    for args in [
        vec!["probe", &scene, "--point", "0,0", "--normal", "0,0,1"],
        vec!["probe", &scene, "--point", "0,0,0", "--normal", "0,0,0"],
        vec![
            "probe", &scene, "--point", "0,0,0", "--normal", "0,0,1", "--band", "nir",
        ],
        vec!["probe", &scene, "--pixel", "9999,0"],
        vec!["render", &scene, "--out", "/tmp/x", "--set", "nope=1"],
        vec!["render", &scene, "--out", "/tmp/x", "--estimator", "magic"],
    ] {
        let out = gloam(&args);
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("error"), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// With no sampling flag a whole-image render samples to the default error
/// and says so; its achieved per-pixel error against the closed form is
/// within that target. `--spp 4` keeps the fixed count (this floor is
/// easy: 4 stratified samples already give ~1 %).
#[test]
fn render_without_sampling_flags_samples_to_the_default_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_scene(dir.path());
    let (d, f) = (dir.path().join("d"), dir.path().join("f"));
    // solid-angle with one shadow ray per hit: noisy enough that 4 spp
    // misses 2 % and the sampling shows.
    let common = ["--estimator", "solid-angle", "--set", "area_samples=1"];
    let d_s = d.display().to_string();
    let f_s = f.display().to_string();
    let out = ok(&[&["render", &scene, "--out", &d_s][..], &common].concat());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("default per-pixel error 2 %"), "{stderr}");
    ok(&[
        &["render", &scene, "--out", &f_s, "--spp", "4"][..],
        &common,
    ]
    .concat());
    let report = |dir: &Path| -> Value {
        serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap()
    };
    let (rd, rf) = (report(&d), report(&f));
    assert_eq!(rd["target_error_source"], "default");
    assert_eq!(rd["settings"]["target_error"], 0.02);
    assert_eq!(rd["error"]["target"], 0.02);
    assert_eq!(rf["target_error_source"], Value::Null);
    assert_eq!(rf["error"]["target"], Value::Null);
    assert_eq!(rf["rays"]["primary"], 64 * 48 * 4);
    let spp_f: ndarray::Array2<u32> = ndarray_npy::read_npy(f.join("spp.npy")).unwrap();
    assert!(spp_f.iter().all(|&n| n == 4));

    // The closed form per pixel (Lambert/Arvo, 8 × 8 sub-pixel hits,
    // independent of the tracer's estimators) over the pixels that see
    // one receiving facet.
    let loaded = gloam_scene::load(Path::new(&scene), &gloam_io::ReadLog::off()).unwrap();
    let tracer = gloam_trace::Tracer::new(&loaded, &Default::default()).unwrap();
    let truth = gloam_bench::truth::closed_form_truth(&loaded, &tracer);
    let n = truth.mask.iter().filter(|&&m| m).count();
    assert!(n > 1000, "{n} floor pixels");
    let rms = |dir: &Path| {
        let img: ndarray::Array3<f64> = ndarray_npy::read_npy(dir.join("radiance.npy")).unwrap();
        gloam_bench::metrics::errors(&img, &truth).pixel
    };
    let (e_default, e_fixed) = (rms(&d), rms(&f));
    eprintln!("per-pixel RMS vs closed form: default {e_default:.4}, --spp 4 {e_fixed:.4}");
    // The achieved error is within the target (the estimate errs high,
    // issue 30) but not far below it: the render stopped at the target,
    // not at a large fixed count.
    assert!(
        (0.4 * 0.02..=1.2 * 0.02).contains(&e_default),
        "default render's per-pixel error {e_default} for a 2 % target"
    );
    let spp_d: ndarray::Array2<u32> = ndarray_npy::read_npy(d.join("spp.npy")).unwrap();
    let mean_spp = spp_d.iter().map(|&n| n as f64).sum::<f64>() / spp_d.len() as f64;
    assert!(
        spp_d.iter().all(|&n| n >= 4) && mean_spp > 5.0,
        "{mean_spp}"
    );
    assert!(e_fixed < 0.05, "--spp 4: {e_fixed}");
}

/// A 64 KiB main-thread stack (`ulimit -s 64`) aborted every command, even
/// `--help`: the command now runs on a thread with its own stack. The
/// render must equal the one under the default stack bit for bit.
#[cfg(unix)]
#[test]
fn a_small_main_stack_still_renders() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = panel_scene();
    let (small, normal) = (tmp.path().join("small"), tmp.path().join("normal"));
    let args = |out: &Path| {
        vec![
            "render".to_string(),
            scene.clone(),
            "--out".into(),
            out.display().to_string(),
            "--spp".into(),
            "2".into(),
        ]
    };
    let out = Command::new("sh")
        .arg("-c")
        .arg("ulimit -s 64 && exec \"$0\" \"$@\"")
        .arg(BIN)
        .args(args(&small))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "under a 64 KiB stack: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let a: Vec<String> = args(&normal);
    ok(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let read = |d: &Path| std::fs::read(d.join("radiance.npy")).unwrap();
    assert!(read(&small) == read(&normal), "the images differ");
}

/// Round 12 of issue 46: `--threads 1024` whose pool could not start (a
/// 2 GB address space holds no 1 024 stacks) rendered on the default pool
/// and reported `threads: 1024`; now it is refused, naming the flag's
/// setting and the limit.
#[cfg(unix)]
#[test]
fn a_thread_pool_that_cannot_start_is_an_error_not_another_pool() {
    let dir = tempfile::tempdir().unwrap();
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_inputs/base.toml");
    let mut cmd = Command::new(BIN);
    cmd.arg("render")
        .arg(&base)
        .args(["--spp", "1", "--threads", "1024", "--out"])
        .arg(dir.path().join("o"))
        .env("RAYON_NUM_THREADS", "2");
    common::limited(&mut cmd, libc::RLIMIT_AS, 2_000_000_000);
    let o = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("threads = 1024") && err.contains("could not start"),
        "{err}"
    );
    assert!(!dir.path().join("o").exists());
}
