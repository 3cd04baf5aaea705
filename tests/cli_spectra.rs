//! `gloam spectra integrate` end to end: the weighted integral of two CSV
//! spectra against its closed form, lines in user CSV files, errors, and the
//! command blocks of `crates/spectra/README.md` (run here, so the documented
//! figures cannot drift from the binary).

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

#[test]
fn csv_lines_count_once_in_half_open_bands_weighted_or_not() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("lamp.csv"),
        "400,1\n700,1\nline,500,2\nline,600,3\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("half.csv"), "400,0.5\n700,0.5\n").unwrap();
    // Unweighted: 100 nm of continuum plus the 500 nm line; 600 nm is the
    // open upper edge.
    let plain = integral_json(dir.path(), &["lamp.csv", "--band", "500:600"]);
    assert!(rel(plain, 102.0) < 1e-14, "{plain}");
    // Weighted by 0.5: the same band, halved — the same half-open rule.
    let weighted = integral_json(
        dir.path(),
        &["lamp.csv", "--band", "500:600", "--weight", "half.csv"],
    );
    assert!(rel(weighted, 51.0) < 1e-14, "{weighted}");
}

#[test]
fn bad_csv_lines_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.csv"), "400,1\n700,1\nline,546.07,-1\n").unwrap();
    let out = gloam_in(
        dir.path(),
        &["spectra", "integrate", "bad.csv", "--band", "400:700"],
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.csv:3: emission line value -1 at 546.07 nm is negative"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// The fenced blocks of `lang` in `doc`, in order.
/// The bodies of the fenced blocks whose info string starts with `lang`
/// (`csv file=my-lamp.csv` counts as `csv`).
fn blocks<'a>(doc: &'a str, lang: &str) -> Vec<&'a str> {
    let fence = format!("```{lang}");
    let mut out = Vec::new();
    let mut rest = doc;
    while let Some(i) = rest.find(&fence) {
        let after = &rest[i + fence.len()..];
        let Some(eol) = after.find('\n') else { break };
        let info = &after[..eol];
        if !(info.is_empty() || info.starts_with(' ')) {
            rest = after;
            continue;
        }
        let body = &after[eol + 1..];
        let Some(end) = body.find("```") else { break };
        out.push(&body[..end]);
        rest = &body[end + 3..];
    }
    out
}

/// Runs the README's `sh` block in a directory holding its CSV example and
/// checks each printed line against the `text` block: the number to the
/// digits the README prints, the rest exactly.
#[test]
fn spectra_readme_commands_print_the_documented_figures() {
    let doc = include_str!("../crates/spectra/README.md");
    let dir = tempfile::tempdir().unwrap();
    let csv = blocks(doc, "csv");
    assert_eq!(csv.len(), 1, "one CSV example");
    // Its first comment names the file: `# my-lamp.csv: …`.
    let name = csv[0]
        .lines()
        .next()
        .and_then(|l| l.strip_prefix("# "))
        .and_then(|l| l.split(':').next())
        .expect("the CSV example names its file");
    std::fs::write(dir.path().join(name), csv[0]).unwrap();
    let commands: Vec<&str> = blocks(doc, "sh")
        .into_iter()
        .flat_map(str::lines)
        .filter(|l| !l.trim().is_empty())
        .collect();
    let expected: Vec<&str> = blocks(doc, "text")
        .into_iter()
        .flat_map(str::lines)
        .collect();
    assert_eq!(
        commands.len(),
        expected.len(),
        "one output line per command"
    );
    for (cmd, want) in commands.iter().zip(&expected) {
        let args: Vec<&str> = cmd.split_whitespace().collect();
        assert_eq!(args[0], "gloam", "{cmd}");
        let out = gloam_in(dir.path(), &args[1..]);
        assert!(
            out.status.success(),
            "{cmd}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let got = String::from_utf8(out.stdout).unwrap();
        let got = got.trim_end();
        let (got_num, got_rest) = got.split_once(' ').unwrap();
        let (want_num, want_rest) = want.split_once(' ').unwrap();
        assert_eq!(got_rest, want_rest, "{cmd}");
        // The README rounds: the printed figure must round to its digits.
        let (g, w): (f64, f64) = (got_num.parse().unwrap(), want_num.parse().unwrap());
        let decimals = want_num.split_once('.').map_or(0, |(_, d)| d.len());
        let half_ulp = 0.5 * 10f64.powi(-(decimals as i32));
        assert!(
            (g - w).abs() <= half_ulp * (1.0 + 1e-9),
            "{cmd}: printed {g}, README says {w}"
        );
    }
}

/// The README's two example errors are what the binary reports for the
/// edits it describes.
#[test]
fn spectra_readme_errors_are_the_real_messages() {
    let doc = include_str!("../crates/spectra/README.md");
    let csv = blocks(doc, "csv")[0];
    let quoted: Vec<&str> = doc
        .split('`')
        .filter(|q| q.starts_with("my-lamp.csv:"))
        .collect();
    assert_eq!(quoted.len(), 2, "{quoted:?}");
    let edits = [
        format!("{csv}line,546.07,0.1\n"),
        csv.replace("line,546.07,0.12", "line,546.07,-0.12"),
    ];
    for (text, want) in edits.iter().zip(quoted) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("my-lamp.csv"), text).unwrap();
        let out = gloam_in(
            dir.path(),
            &["spectra", "integrate", "my-lamp.csv", "--band", "400:700"],
        );
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(want), "stderr {err}\nREADME {want}");
    }
}
