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

const ALL: [&str; 11] = [
    "area-sources",
    "shaped-point-sources",
    "point-sources",
    "transmissive-occluders",
    "specular-recursion",
    "interreflection",
    "direct-view",
    "moon",
    "night-sky",
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
    assert!(effects[6].2.contains("panel-west"));
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
