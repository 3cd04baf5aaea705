//! `gloam plan` end to end: the built binary on the shipped sims (table and
//! JSON) and on a broken scene.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gloam(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gloam"))
        .args(args)
        .output()
        .expect("run gloam")
}

fn sim(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("sims")
        .join(name)
        .join("scene.toml")
}

const ALL: [&str; 14] = [
    "area-sources",
    "shaped-point-sources",
    "point-sources",
    "distant-sources",
    "transmissive-occluders",
    "specular-recursion",
    "interreflection",
    "direct-view",
    "moon",
    "night-sky",
    "sun",
    "twilight-sky",
    "atmosphere",
    "sensor",
];

fn plan_json(scene: &Path) -> Vec<(String, bool, String)> {
    let out = gloam(&["plan", scene.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    let effects = v["effects"].as_array().expect("effects array");
    effects
        .iter()
        .map(|e| {
            (
                e["name"].as_str().expect("name").to_string(),
                e["enabled"].as_bool().expect("enabled"),
                e["reason"].as_str().expect("reason").to_string(),
            )
        })
        .collect()
}

fn check_indoor_panel_plan(
    effects: &[(String, bool, String)],
    area_reason: &str,
    interreflection: bool,
) {
    let names: Vec<&str> = effects.iter().map(|e| e.0.as_str()).collect();
    assert_eq!(names, ALL);
    for (name, enabled, reason) in effects {
        assert!(!reason.is_empty(), "{name} has no reason");
        let want = matches!(name.as_str(), "area-sources" | "direct-view")
            || (name == "interreflection" && interreflection);
        assert_eq!(*enabled, want, "{name}: {reason}");
    }
    // The structural reason first, then the pilot's figures.
    assert!(
        effects[0].2.starts_with(area_reason) && effects[0].2.contains("pilot:"),
        "{}",
        effects[0].2
    );
}

#[test]
fn plan_panel_validation_json() {
    let effects = plan_json(&sim("panel-validation"));
    // One floor under one panel: nothing reflects light back onto the
    // floor, so the pilot measures a zero share and leaves it out.
    check_indoor_panel_plan(&effects, "1 emitting facet (panel); Lambertian", false);
}

#[test]
fn plan_office_room_json() {
    let effects = plan_json(&sim("office-room"));
    check_indoor_panel_plan(
        &effects,
        "2 emitting facets (panel-west, panel-east); Lambertian",
        true,
    );
    let direct_view = effects.iter().find(|e| e.0 == "direct-view").unwrap();
    assert!(direct_view.2.contains("panel-west"));
}

#[test]
fn plan_table_output() {
    for (name, area) in [
        ("panel-validation", "1 emitting facet (panel)"),
        ("office-room", "2 emitting facets (panel-west, panel-east)"),
    ] {
        let scene = sim(name);
        let out = gloam(&["plan", scene.to_str().unwrap()]);
        assert!(out.status.success());
        let text = String::from_utf8(out.stdout).unwrap();
        let row = |effect: &str| {
            text.lines()
                .find(|l| l.split_whitespace().next() == Some(effect))
                .unwrap_or_else(|| panic!("no row for {effect} in\n{text}"))
                .to_string()
        };
        let area_row = row("area-sources");
        assert!(
            area_row.contains("yes") && area_row.contains(area),
            "{area_row}"
        );
        assert!(row("moon").contains(" no "), "{text}");
        assert!(row("sensor").contains(" no "), "{text}");
        for e in ALL {
            row(e);
        }
    }
}

#[test]
fn plan_broken_scene_fails_with_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.toml");
    std::fs::write(
        &path,
        "units = \"ft\"\n\n[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [1.0, 0.0, 5.0]\nfov_deg = 60.0\nwidth = 32\nheight = 24\n\n[bands.vis]\nlo_nm = 400\nhi_nm = 700\n\n[materials.wall]\nreflectance = 1.4\n",
    )
    .unwrap();
    let out = gloam(&["plan", path.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(out.stdout.is_empty());
    let err = String::from_utf8(out.stderr).unwrap();
    let want = format!("{}:15: materials.wall.reflectance:", path.display());
    assert!(err.contains(&want), "stderr:\n{err}\nwanted {want}");
    assert!(err.contains("exceeds 1"), "{err}");

    // A file that does not exist.
    let out = gloam(&[
        "plan",
        dir.path().join("nope.toml").to_str().unwrap(),
        "--json",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.toml"));
}

/// `gloam plan --target-error camera` states before rendering what a
/// camera run costs against the 2 % default, from two trial renders at the
/// pilot's size (64 pixels wide, at most 64 spp): they are the renders
/// `gloam render` makes at that size and cap (the independent answer), through the scene's own
/// camera — the same samples per pixel, and rays scaled by the full image's
/// pixels over the trial's.
#[test]
fn plan_estimates_the_camera_target_against_the_default() {
    let scene = sim("night-new-moon");
    let s = scene.to_str().unwrap();
    let out = gloam(&["plan", s, "--json", "--target-error", "camera"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let e = &v["camera_target_estimate"];
    assert_eq!(
        (e["trial_width"].as_u64(), e["trial_height"].as_u64()),
        (Some(64), Some(48))
    );
    assert_eq!(e["full_pixels"].as_f64(), Some(768.0 * 576.0));
    let scale = format!("resolution_scale={}", 64.0 / 768.0);
    let tmp = tempfile::tempdir().unwrap();
    let render = |name: &str, target: &str| -> serde_json::Value {
        let dir = tmp.path().join(name);
        let d = dir.to_str().unwrap();
        let r = gloam(&[
            "render",
            s,
            "--out",
            d,
            "--set",
            &scale,
            "--set",
            "max_spp=64",
            "--target-error",
            target,
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
    };
    let (cam, rel) = (render("cam", "camera"), render("rel", "0.02"));
    let per = 144.0; // (768 × 576) / (64 × 48)
    assert_eq!(e["camera"]["mean_spp"], cam["camera_target"]["mean_spp"]);
    assert_eq!(e["default_2_percent"]["mean_spp"], rel["error"]["mean_spp"]);
    for (side, r) in [("camera", &cam), ("default_2_percent", &rel)] {
        let rays = r["rays_total"].as_f64().unwrap();
        assert_eq!(e[side]["rays"].as_f64().unwrap(), rays * per, "{side}");
    }
    let saving = e["rays_saving"].as_f64().unwrap();
    assert!(saving > 1.0, "{saving}");
    // The table prints the estimate on one line.
    let out = gloam(&["plan", s, "--target-error", "camera:0.5"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("--target-error camera:0.5 through") && text.contains("at the 2 % default"),
        "{text}"
    );
    // A relative error needs no estimate; a camera-only flag needs the target.
    let out = gloam(&["plan", s, "--target-error", "0.02"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("camera target only"),
        "{err}"
    );
    let out = gloam(&["plan", s, "--gain", "100"]);
    assert!(!out.status.success());
}
