//! `gloam bench accuracy` and `gloam bench throughput` end to end: the
//! output files, the CSV header and the JSON keys.

use std::path::Path;
use std::process::Command;

fn gloam() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_gloam"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn run_json(c: &mut Command) -> serde_json::Value {
    let out = c.output().expect("runs gloam");
    assert!(
        out.status.success(),
        "gloam failed: {}\n{}",
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not JSON ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

#[test]
fn accuracy_on_the_panel_writes_csv_png_summary_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let v = run_json(gloam().args([
        "bench",
        "accuracy",
        "sims/panel-validation/scene.toml",
        "--out",
        dir.path().to_str().unwrap(),
        "--budget-s",
        "20",
        "--json",
    ]));
    let csv = std::fs::read_to_string(dir.path().join("accuracy.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some(
            "estimator,setting,value,spp,time_s,rel_rms_error,max_rel_error,pixel_rms_error,prepare_s"
        )
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(!rows.is_empty(), "no runs in the CSV");
    for r in &rows {
        assert_eq!(r.len(), 9, "{r:?}");
        for x in &r[3..] {
            assert!(x.parse::<f64>().is_ok(), "{r:?}");
        }
    }
    // Every estimator's spp ladder starts.
    for est in ["analytic", "solid-angle", "dirsig2001"] {
        assert!(
            rows.iter().any(|r| r[0] == est && r[1] == "spp"),
            "{est} missing"
        );
    }
    let png = dir.path().join("accuracy.png");
    let bytes = std::fs::read(&png).unwrap();
    assert!(bytes.starts_with(b"\x89PNG"), "accuracy.png is not a PNG");
    assert!(Path::new(&dir.path().join("summary.md")).exists());
    for key in ["time_to_1pct_s", "time_to_0_1pct_s"] {
        let m = v[key]
            .as_object()
            .unwrap_or_else(|| panic!("{key} missing: {v}"));
        for est in ["analytic", "solid-angle", "dirsig2001"] {
            let x = m.get(est).unwrap_or_else(|| panic!("{key}.{est} missing"));
            assert!(x.is_null() || x.as_f64().is_some_and(|t| t > 0.0), "{x}");
        }
    }
    // The default estimator is exact on the unoccluded floor: it reaches 1 %.
    assert!(v["time_to_1pct_s"]["analytic"].as_f64().is_some(), "{v}");
}

#[test]
fn throughput_json_has_every_figure() {
    let v = run_json(gloam().args(["bench", "throughput", "--quick", "--json"]));
    for (section, keys) in [
        (
            "render",
            &["primary_rays_per_s", "shadow_rays_per_s", "rays_per_s"][..],
        ),
        ("sensor", &["frames_per_s", "width", "height"][..]),
        ("codec", &["encode_gb_per_s", "decode_gb_per_s"][..]),
    ] {
        for k in keys {
            let x = &v[section][k];
            assert!(
                x.as_f64().is_some_and(|x| x > 0.0),
                "{section}.{k} = {x} in {v}"
            );
        }
    }
    assert_eq!(v["sensor"]["width"], 1024);
    assert_eq!(v["sensor"]["height"], 768);
}

#[test]
fn plan_saving_on_the_panel_agrees_within_noise() {
    let v = run_json(gloam().args([
        "bench",
        "plan",
        "sims/panel-validation/scene.toml",
        "--json",
    ]));
    let s = &v["scenes"][0];
    for k in ["plan_s", "all_effects_s"] {
        assert!(s[k].as_f64().is_some_and(|t| t > 0.0), "{k} in {v}");
    }
    assert_eq!(s["agree_within_noise"], true, "{v}");
    assert!(v["total"]["saved_s"].as_f64().is_some(), "{v}");
}
