//! `gloam spectra integrate` end to end: the weighted integral of two CSV
//! spectra against its closed form.

use std::path::Path;
use std::process::{Command, Output};

fn gloam_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gloam"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run gloam")
}

fn integral_json(dir: &Path, args: &[&str]) -> f64 {
    let mut all = vec!["spectra", "integrate"];
    all.extend_from_slice(args);
    all.push("--json");
    let out = gloam_in(dir, &all);
    assert!(
        out.status.success(),
        "gloam {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    v["integral"].as_f64().expect("integral")
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn weighted_integral_of_two_ramps_matches_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    // a = λ − 400, b = 700 − λ over 400–700 nm, one linear piece each.
    std::fs::write(
        dir.path().join("a.csv"),
        "wavelength_nm,value\n400,0\n700,300\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("b.csv"),
        "wavelength_nm,value\n400,300\n700,0\n",
    )
    .unwrap();
    // ∫_400^700 (λ−400)(700−λ) dλ = 300³/6; the union-grid trapezoid said 0.
    let whole = integral_json(
        dir.path(),
        &["a.csv", "--band", "0:1000", "--weight", "b.csv"],
    );
    assert!(rel(whole, 4.5e6) < 1e-14, "{whole}");
    // Band edges inside the interval: ∫_50^250 t (300 − t) dt.
    let band =
        150.0 * (250.0f64.powi(2) - 50.0f64.powi(2)) - (250.0f64.powi(3) - 50.0f64.powi(3)) / 3.0;
    let got = integral_json(
        dir.path(),
        &["a.csv", "--band", "450:650", "--weight", "b.csv"],
    );
    assert!(rel(got, band) < 1e-14, "{got} vs {band}");
    // A ramp squared: (λ − 400)² over 400–700 nm is 300³/3 = 9e6 (was 1.35e7).
    let sq = integral_json(
        dir.path(),
        &["a.csv", "--band", "400:700", "--weight", "a.csv"],
    );
    assert!(rel(sq, 9e6) < 1e-14, "{sq}");
}
