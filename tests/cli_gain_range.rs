//! Out-of-range gains are refused with the allowed range and the camera
//! named, never clamped: `capture`, `calibrate` and `render --sensor`
//! (before the trace).

use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_gloam");

fn gloam(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().expect("run gloam")
}

/// The Gen III preset's MCP range, from `G = G0 (V/V0)^k` with its numbers
/// (G0 = 1000 at 800 V, k = 9, 500–1000 V), written out here.
fn gen3_range() -> (f64, f64) {
    let g = |v: f64| 1000.0 * (v / 800.0f64).powi(9);
    (g(500.0), g(1000.0))
}

fn refused(o: &Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!o.status.success(), "{what}: accepted\n{stderr}");
    assert!(!stderr.contains("panicked"), "{what}: {stderr}");
    assert!(stderr.contains("gen3-gaas-iccd"), "{what}: {stderr}");
    stderr
}

#[test]
fn capture_refuses_a_gain_below_the_preset_range() {
    let (lo, hi) = gen3_range();
    assert!((lo - 14.5519).abs() < 1e-4 && (hi - 7450.58).abs() < 1e-2);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cap");
    for gain in ["2", "14.55", "8000"] {
        let o = gloam(&[
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd?size=16x16",
            "--gain",
            gain,
            "--out",
            out.to_str().unwrap(),
        ]);
        let e = refused(&o, &format!("capture --gain {gain}"));
        assert!(
            e.contains(&format!("gain {gain} is outside")) && e.contains("14.552–7450.58"),
            "{e}"
        );
        assert!(e.contains("MCP 500–1000 V"), "{e}");
        assert!(!out.join("frame-000000.png").exists());
    }
    // The bottom of the range itself is accepted (and applied, not clamped).
    let o = gloam(&[
        "capture",
        "--grabber",
        "sim:gen3-gaas-iccd?size=16x16",
        "--gain",
        "14.552",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rec: serde_json::Value = serde_json::from_str(
        std::fs::read_to_string(out.join("frames.jsonl"))
            .unwrap()
            .lines()
            .next()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(rec["gain"].as_f64().unwrap(), 14.552);
}

#[test]
fn calibrate_refuses_out_of_range_gains() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("sphere.toml");
    std::fs::write(
        &src,
        "[source]\nkind = \"sphere\"\nlamp = \"cie-a\"\nlamp_flux_w = 1.0\nsphere_diameter_m = 0.5\nreflectance = 0.98\nport_fraction = 0.02\n[dimming]\nmethod = \"aperture\"\n",
    )
    .unwrap();
    let src = src.to_str().unwrap();
    let out = dir.path().join("cal");
    let out = out.to_str().unwrap();
    let cam = "sim:gen3-gaas-iccd?size=16x16";
    let runs: [&[&str]; 3] = [
        &[
            "calibrate",
            "radiance",
            "--grabber",
            cam,
            "--source",
            src,
            "--gains",
            "2,100",
            "--levels",
            "3",
            "--frames",
            "2",
            "--out",
            out,
        ],
        &[
            "calibrate",
            "ptc",
            "--grabber",
            cam,
            "--source",
            src,
            "--gain",
            "2",
            "--levels",
            "3",
            "--out",
            out,
        ],
        &[
            "calibrate",
            "agc",
            "--grabber",
            cam,
            "--source",
            src,
            "--fixed-gain",
            "2",
            "--levels",
            "2",
            "--frames",
            "4",
            "--out",
            out,
        ],
    ];
    for args in runs {
        let e = refused(&gloam(args), &args[..2].join(" "));
        assert!(
            e.contains("gain 2 is outside") && e.contains("14.552–7450.58"),
            "{e}"
        );
    }
}

#[test]
fn render_refuses_an_out_of_range_gain_before_tracing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o = gloam(&[
        "render",
        "sims/panel-validation/scene.toml",
        "--out",
        out.to_str().unwrap(),
        "--spp",
        "1",
        "--sensor",
        "gen3-gaas-iccd",
        "--gain",
        "2",
    ]);
    let e = refused(&o, "render --gain 2");
    assert!(e.contains("--gain") && e.contains("14.552–7450.581"), "{e}");
    // Nothing was traced: no radiance written, no "rendered" line.
    assert!(!out.join("radiance.tiff").exists());
    assert!(!e.contains("rendered"), "{e}");
}
