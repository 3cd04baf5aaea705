//! `gloam sweep` run locally (the 12-task sweep, resuming after a kill,
//! errors) and `gloam render --tile` + `gloam merge` bit-identity.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn gloam() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gloam"))
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("run gloam");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "gloam failed: {err}");
    err
}

fn run_err(cmd: &mut Command) -> String {
    let out = cmd.output().expect("run gloam");
    assert!(!out.status.success(), "gloam should have failed");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn done_records(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir.join("tasks")) {
        for e in rd.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') {
                continue;
            }
            if let Ok(b) = std::fs::read(e.path().join("task.json")) {
                v.push((name, b));
            }
        }
    }
    v.sort();
    v
}

/// "N task(s): R ran, S already done, F failed" from a run's stderr.
fn counts(stderr: &str) -> (usize, usize, usize) {
    let line = stderr
        .lines()
        .find(|l| l.contains(" ran, "))
        .unwrap_or_else(|| panic!("no summary in: {stderr}"));
    let num = |after: &str| -> usize {
        line.split(after)
            .next()
            .unwrap()
            .split_whitespace()
            .last()
            .unwrap()
            .parse()
            .unwrap()
    };
    (num(" ran"), num(" already done"), num(" failed"))
}

#[test]
fn twelve_task_sweep_runs_locally_and_a_killed_run_finishes_only_the_missing_tasks() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = root().join("tests/sweep/twelve.toml");
    let full = tmp.path().join("full");
    let err = run_ok(gloam().arg("sweep").arg(&sweep).arg("--out").arg(&full));
    assert_eq!(counts(&err), (12, 0, 0), "{err}");

    // The task list is the product of the axes (2 scenes × 2 cameras × 3
    // gains), with distinct ids and one render per scene × camera.
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(full.join("plan.json")).unwrap()).unwrap();
    assert_eq!(plan["task_count"], 2 * 2 * 3);
    assert_eq!(plan["chunk_count"], 2 * 2);
    let ids: std::collections::BTreeSet<&str> = plan["tasks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids.len(), 12);
    let csv = std::fs::read_to_string(full.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 13, "{csv}");
    assert!(csv.lines().skip(1).all(|l| l.contains(",done,")), "{csv}");
    let header = csv.lines().next().unwrap();
    // One name per column (a `seed` axis and the noise seed were both `seed`).
    let names: Vec<&str> = header.split(',').collect();
    let unique: std::collections::BTreeSet<&str> = names.iter().copied().collect();
    assert_eq!(unique.len(), names.len(), "{header}");
    for col in [
        "scene",
        "sensor",
        "gain",
        "mean_dn",
        "snr",
        "noise_seed",
        "outputs_sha256",
    ] {
        assert!(
            header.split(',').any(|c| c == col),
            "{col} missing: {header}"
        );
    }
    assert!(full.join("figures").read_dir().unwrap().count() >= 2);

    // Tasks sharing a render differ only by their camera settings: the
    // mean DN rises with gain for each scene and camera.
    let rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(full.join("results.json")).unwrap()).unwrap();
    let rows = rows["rows"].as_array().unwrap();
    for g in rows.chunks(3) {
        let dn: Vec<f64> = g.iter().map(|r| r["mean_dn"].as_f64().unwrap()).collect();
        assert!(dn[0] <= dn[1] && dn[1] <= dn[2], "{dn:?}");
    }

    // Kill a sequential run as soon as a task is recorded, then rerun.
    let part = tmp.path().join("part");
    let mut child = gloam()
        .arg("sweep")
        .arg(&sweep)
        .arg("--out")
        .arg(&part)
        .args(["--jobs", "1"])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while done_records(&part).is_empty() {
        assert!(t0.elapsed() < Duration::from_secs(120), "no task finished");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it was killed"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let before = done_records(&part);
    let k = before.len();
    assert!(
        (1..12).contains(&k),
        "{k} tasks were recorded when the run was killed"
    );
    let err = run_ok(gloam().arg("sweep").arg(&sweep).arg("--out").arg(&part));
    assert_eq!(counts(&err), (12 - k, k, 0), "{err}");
    // The records from before the kill were kept, untouched.
    let after = done_records(&part);
    for r in &before {
        assert!(after.contains(r), "record {} changed", r.0);
    }
    assert_eq!(
        std::fs::read_to_string(part.join("results.csv")).unwrap(),
        csv,
        "the resumed sweep's results differ from the uninterrupted run's"
    );

    // A changed output is noticed and its task rerun.
    let victim = part.join("tasks/00004/frame-000000.png");
    std::fs::write(&victim, b"not a frame").unwrap();
    let err = run_ok(gloam().arg("sweep").arg(&sweep).arg("--out").arg(&part));
    assert_eq!(counts(&err), (1, 11, 0), "{err}");
    assert_eq!(
        std::fs::read_to_string(part.join("results.csv")).unwrap(),
        csv
    );
}

#[test]
fn sweep_files_with_mistakes_get_located_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let p = tmp.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let scene = root().join("sims/panel-validation/scene.toml");
    let cases = [
        (
            format!("[base]\nscene = {scene:?}\n\n[axes]\nspp = [1, 0]\n"),
            ":5: axes.spp[1]:",
        ),
        (
            format!("[base]\nscene = {scene:?}\nwarp_speed = 9\n"),
            ":3: base.warp_speed:",
        ),
        (
            format!(
                "[base]\nscene = {scene:?}\nsensor = \"gen3-gaas-iccd\"\n[axes]\ngain = \"high\"\n"
            ),
            ":5: axes.gain:",
        ),
        (
            format!(
                "[base]\nscene = {scene:?}\n[axes]\nseed = {{ from = 0, count = 400 }}\nspp = {{ from = 1, count = 400 }}\n"
            ),
            "exceeds 100000 tasks",
        ),
        (
            format!("[base]\nscene = {scene:?}\n[axes]\ntile = [\"1/4\", \"5/4\"]\n"),
            ":4: axes.tile[1]:",
        ),
        (
            "[bsae]\nscene = \"x\"\n".to_string(),
            ":1: bsae: unknown field `bsae`",
        ),
    ];
    for (i, (text, want)) in cases.iter().enumerate() {
        let p = write(&format!("s{i}.toml"), text);
        let err = run_err(
            gloam()
                .arg("sweep")
                .arg(&p)
                .arg("--out")
                .arg(tmp.path().join(format!("o{i}"))),
        );
        assert!(err.contains(want), "case {i}: wanted '{want}' in: {err}");
        assert!(
            err.contains(&format!("s{i}.toml")),
            "case {i}: no file in: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    // Another sweep into a planned directory is refused, not mixed in.
    let a = write(
        "a.toml",
        &format!(
            "[base]\nscene = {scene:?}\n\"camera.width\" = 8\n\"camera.height\" = 6\n[axes]\nspp = [1, 2]\n"
        ),
    );
    let b = write(
        "b.toml",
        &format!(
            "[base]\nscene = {scene:?}\n\"camera.width\" = 8\n\"camera.height\" = 6\n[axes]\nspp = [1, 3]\n"
        ),
    );
    let out = tmp.path().join("ab");
    run_ok(gloam().arg("sweep").arg(&a).arg("--out").arg(&out));
    let err = run_err(gloam().arg("sweep").arg(&b).arg("--out").arg(&out));
    assert!(err.contains("holds another sweep"), "{err}");
}

const OUTPUTS: [&str; 5] = [
    "radiance.npy",
    "stderr.npy",
    "spp.npy",
    "radiance.tiff",
    "preview.png",
];

#[test]
fn merged_tiles_are_bit_identical_to_the_untiled_render() {
    let tmp = tempfile::tempdir().unwrap();
    // Point lamps seen directly, the sky and interreflection: every kind of
    // per-pixel stream and deposit the tracer has.
    let scene = root().join("sims/night-new-moon-lamps/scene.toml");
    let common = [
        "--set",
        "resolution_scale=0.07",
        "--spp",
        "2",
        "--seed",
        "3",
    ];
    let whole = tmp.path().join("whole");
    run_ok(
        gloam()
            .arg("render")
            .arg(&scene)
            .arg("--out")
            .arg(&whole)
            .args(common),
    );
    for n in [1u32, 3, 4] {
        let mut dirs = Vec::new();
        for k in 1..=n {
            let d = tmp.path().join(format!("t{n}-{k}"));
            run_ok(
                gloam()
                    .arg("render")
                    .arg(&scene)
                    .arg("--out")
                    .arg(&d)
                    .args(common)
                    .arg("--tile")
                    .arg(format!("{k}/{n}")),
            );
            dirs.push(d);
        }
        // Any order.
        dirs.reverse();
        let merged = tmp.path().join(format!("merged{n}"));
        run_ok(gloam().arg("merge").args(&dirs).arg("--out").arg(&merged));
        for f in OUTPUTS {
            let a = std::fs::read(whole.join(f)).unwrap();
            let b = std::fs::read(merged.join(f)).unwrap();
            assert!(a == b, "N = {n}: {f} differs from the untiled render");
        }
        if n == 4 {
            // --out inside one of the tiles (also through `..`) is refused
            // before anything is written.
            for out in [dirs[1].join("merged"), dirs[2].join("x/../y")] {
                let err = run_err(gloam().arg("merge").args(&dirs).arg("--out").arg(&out));
                assert!(err.contains("inside the directory"), "{err}");
                assert!(err.contains("an input of this run"), "{err}");
                assert!(!out.exists());
            }
            // A tile short, a tile twice, and tiles of another render are refused.
            let err = run_err(
                gloam()
                    .arg("merge")
                    .args(&dirs[..3])
                    .arg("--out")
                    .arg(tmp.path().join("x")),
            );
            assert!(err.contains("missing tiles: 1/4"), "{err}");
            let mut twice = dirs.clone();
            twice[0] = dirs[1].clone();
            let err = run_err(
                gloam()
                    .arg("merge")
                    .args(&twice)
                    .arg("--out")
                    .arg(tmp.path().join("y")),
            );
            assert!(err.contains("given twice"), "{err}");
            let mut other = dirs[..3].to_vec();
            other.push(tmp.path().join("t3-1"));
            let err = run_err(
                gloam()
                    .arg("merge")
                    .args(&other)
                    .arg("--out")
                    .arg(tmp.path().join("z")),
            );
            assert!(err.contains("another render"), "{err}");
        }
    }
    let err = run_err(
        gloam()
            .arg("render")
            .arg(&scene)
            .arg("--out")
            .arg(tmp.path().join("bad"))
            .args(common)
            .args(["--tile", "5/4"]),
    );
    assert!(err.contains("not a tile K/N"), "{err}");
}

#[test]
fn a_tile_axis_sweep_merges_into_the_untiled_render() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("tiles");
    let err = run_ok(
        gloam()
            .arg("sweep")
            .arg(root().join("tests/sweep/tiles4.toml"))
            .arg("--out")
            .arg(&out),
    );
    assert_eq!(counts(&err), (4, 0, 0), "{err}");
    let dirs: Vec<PathBuf> = (0..4).map(|i| out.join(format!("tasks/{i:05}"))).collect();
    let merged = tmp.path().join("merged");
    run_ok(gloam().arg("merge").args(&dirs).arg("--out").arg(&merged));
    // The same render untiled: the sweep's base as a one-task sweep.
    let one = tmp.path().join("one.toml");
    let text = std::fs::read_to_string(root().join("tests/sweep/tiles4.toml"))
        .unwrap()
        .replace("../../sims", &root().join("sims").display().to_string())
        .replace("tile = [\"1/4\", \"2/4\", \"3/4\", \"4/4\"]", "seed = [0]");
    std::fs::write(&one, text).unwrap();
    let whole = tmp.path().join("whole");
    run_ok(gloam().arg("sweep").arg(&one).arg("--out").arg(&whole));
    for f in OUTPUTS {
        let a = std::fs::read(whole.join("tasks/00000").join(f)).unwrap();
        let b = std::fs::read(merged.join(f)).unwrap();
        assert!(a == b, "{f} differs from the untiled render");
    }
}

#[test]
fn a_capture_sweep_scales_with_gain_and_a_dry_run_writes_the_array_job() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = tmp.path().join("cap.toml");
    std::fs::write(
        &sweep,
        "[base]\nsensor = \"scientific-ccd\"\nsize = \"16x12\"\nframes = 3\n[axes]\ngain = [1, 2]\n",
    )
    .unwrap();
    let out = tmp.path().join("cap");
    let err = run_ok(gloam().arg("sweep").arg(&sweep).arg("--out").arg(&out));
    assert_eq!(counts(&err), (2, 0, 0), "{err}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let rows = v["rows"].as_array().unwrap();
    let s: Vec<f64> = rows
        .iter()
        .map(|r| r["signal_dn"].as_f64().unwrap())
        .collect();
    // A CCD's signal above black is linear in its gain (shot noise on
    // ~20 000 DN over 192 pixels × 3 frames is far below 1 %).
    assert!((s[1] / s[0] - 2.0).abs() < 0.01, "signal {s:?}");
    assert!(
        rows.iter().all(|r| r["snr"].as_f64().unwrap() > 10.0),
        "{v:#}"
    );

    let dry = tmp.path().join("dry");
    run_ok(
        gloam()
            .arg("sweep")
            .arg(&sweep)
            .arg("--out")
            .arg(&dry)
            .args(["--slurm", "--dry-run", "--max-parallel", "2", "--time", "5"]),
    );
    let script = std::fs::read_to_string(dry.join("sweep.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --array=0-1%2\n"), "{script}");
    assert!(script.contains("#SBATCH --time=5\n"), "{script}");
    assert!(script.contains("sweep run") && script.contains("--chunk \"$SLURM_ARRAY_TASK_ID\""));
    assert!(
        !dry.join("slurm.json").exists(),
        "a dry run submitted nothing"
    );
    assert!(!dry.join("tasks/00000").exists());
}

/// `target_error = "camera"` in a sweep renders as `gloam render
/// --target-error camera` does at the same gain and seed: the same
/// radiance and samples per pixel, bit for bit, and the same
/// `camera_target` figures; two gains are two renders (the bound depends
/// on the gain: their samples differ).
#[test]
fn a_camera_target_sweep_renders_as_the_cli_does() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = root().join("sims/night-new-moon-lamps/scene.toml");
    let sweep = tmp.path().join("cam.toml");
    std::fs::write(
        &sweep,
        format!(
            "[base]\nscene = {:?}\nsensor = \"gen3-gaas-iccd\"\nresolution_scale = 0.07\nseed = 3\nframes = 1\ntarget_error = \"camera\"\n[axes]\ngain = [100, 1000]\n",
            scene.display().to_string()
        ),
    )
    .unwrap();
    let out = tmp.path().join("out");
    run_ok(gloam().arg("sweep").arg(&sweep).arg("--out").arg(&out));
    let mut spp = Vec::new();
    for (i, gain) in ["100", "1000"].iter().enumerate() {
        let task = out.join(format!("tasks/{i:05}"));
        let cli = tmp.path().join(format!("cli-{gain}"));
        run_ok(
            gloam()
                .arg("render")
                .arg(&scene)
                .arg("--out")
                .arg(&cli)
                .args(["--set", "resolution_scale=0.07", "--seed", "3"])
                .args(["--sensor", "gen3-gaas-iccd", "--gain", gain])
                .args(["--target-error", "camera"]),
        );
        for f in ["radiance.npy", "spp.npy"] {
            let a = std::fs::read(cli.join(f)).unwrap();
            let b = std::fs::read(task.join(f)).unwrap();
            assert!(a == b, "gain {gain}: {f} differs from gloam render's");
        }
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(cli.join("report.json")).unwrap())
                .unwrap();
        let t: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(task.join("camera_target.json")).unwrap(),
        )
        .unwrap();
        let want = &report["camera_target"];
        for key in [
            "k",
            "gain",
            "mean_spp",
            "added_variance_fraction_median",
            "added_variance_fraction_p99",
        ] {
            assert_eq!(t[key], want[key], "gain {gain}: {key}");
        }
        spp.push(t["mean_spp"].as_f64().unwrap());
    }
    // The task list names the gains in order; the results carry the figures.
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert!(csv.contains("camera_target_mean_spp"), "{csv}");
    assert_ne!(spp[0], spp[1], "the gain changes the bound: {spp:?}");
}
