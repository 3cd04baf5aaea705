//! `gloam sequence` with a `[sky]` clock: the sky rendered at its
//! instants, frames geometrically between them, a lamp switched by its
//! photocell where `gloam sky`'s illuminance crosses its threshold.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_gloam");

/// A grey road under the sky at Rochester NY, 2025-10-21 at 22:30 UTC
/// (the Sun at −2.6°), a lamp on a pole, the camera seeing road and sky.
const SCENE: &str = r#"units = "m"
[camera]
position = [-20, 0, 3]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov_deg = 60
width = 16
height = 12
[bands.vis]
lo_nm = 400
hi_nm = 700
[sky]
utc = "2025-10-21T22:30:00Z"
latitude_deg = 43.0844
longitude_deg = -77.6749
height_m = 170.0
visibility_km = 23.0
moon = false
night_sky = true
overcast = false
[materials.road]
reflectance = 0.2
[objects.road]
material = "road"
quad = { center = [0, 0, 0], size = [60, 40], normal = [0, 0, 1] }
[point_sources.lamp]
position = [5, 5, 8]
value = 1e-4
"#;

/// 10 frames at 25 Hz with the sky at 3000× (0.4 s of sequence: 20 min
/// of evening, the Sun from −2.6° to about −6°), rendered 3 times; the
/// lamp's photocell switches it on below 16 lx, at once.
const SEQUENCE: &str = r#"scene = "scene.toml"
frame_rate_hz = 25
frames = 10

[sky]
time_scale = 3000.0
renders = 3

[groups.lamp]
photocell = { on_lux = 16.0 }
"#;

fn ok(args: &[&str]) -> Output {
    let out = Command::new(BIN)
        .args(args)
        .output()
        .expect("running gloam");
    assert!(
        out.status.success(),
        "gloam {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn lines(path: &Path) -> Vec<Value> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// `gloam sky`'s horizontal illuminance at `utc` (Sun and night sky; no
/// Moon in this scene), lux.
fn sky_lux(utc: &str) -> f64 {
    let out = ok(&[
        "sky",
        "--utc",
        utc,
        "--lat",
        "43.0844",
        "--lon",
        "-77.6749",
        "--height-m",
        "170",
        "--json",
    ]);
    let r: Value = serde_json::from_slice(&out.stdout).unwrap();
    let t = &r["twilight_lux"];
    t["sun_direct"].as_f64().unwrap()
        + t["sun_sky"].as_f64().unwrap()
        + r["illuminance_lux"]["night_sky"].as_f64().unwrap()
}

/// ISO 8601 of `unix_s` seconds after the Unix epoch, on 2025-10-21
/// after 22:00 UTC (1761084000 s).
fn iso(unix_s: f64) -> String {
    let s = unix_s - 1_761_084_000.0;
    let (h, m) = ((s / 3600.0).floor(), ((s % 3600.0) / 60.0).floor());
    format!("2025-10-21T{:02}:{m:02}:{:06.3}Z", 22.0 + h, s % 60.0)
}

#[test]
fn a_sky_clock_renders_its_instants_and_switches_the_photocell_where_the_sky_says() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), SCENE).unwrap();
    let seq = dir.path().join("seq.toml");
    std::fs::write(&seq, SEQUENCE).unwrap();
    let out = dir.path().join("out");
    let (seq, out_s) = (seq.display().to_string(), out.display().to_string());
    ok(&[
        "sequence",
        &seq,
        "--sensor",
        "gen3-gaas-iccd",
        "--spp",
        "2",
        "--gain",
        "100",
        "--out",
        &out_s,
    ]);
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let sky = &report["sequence"]["sky"];
    let renders = sky["renders"].as_array().unwrap();
    assert_eq!(renders.len(), 3);
    // The renders' instants: the scene's utc + k × 0.2 s × 3000.
    let want = [
        "2025-10-21T22:30:00.000Z",
        "2025-10-21T22:40:00.000Z",
        "2025-10-21T22:50:00.000Z",
    ];
    for (r, w) in renders.iter().zip(want) {
        assert_eq!(r["utc"], w);
    }
    // Three renders over 3.4° of Sun: nothing to warn of.
    assert_eq!(sky["warnings"], serde_json::json!([]), "{sky}");
    // Each render's illuminance is gloam sky's at that instant.
    for r in renders {
        let (got, want) = (
            r["horizontal_lux"].as_f64().unwrap(),
            sky_lux(r["utc"].as_str().unwrap()),
        );
        assert!((got / want - 1.0).abs() < 1e-9, "{got} vs {want}");
    }
    // The Sun and twilight groups are in the layers (the clock keeps the
    // Sun's sky lit throughout, its beam below the horizon).
    let groups: Vec<&str> = (report["sequence"]["groups"].as_array().unwrap().iter())
        .map(|g| g.as_str().unwrap())
        .collect();
    assert!(
        groups.contains(&"twilight") && groups.contains(&"lamp"),
        "{groups:?}"
    );

    // Frames: the sky at mid-exposure, between the right renders.
    let frames = lines(&out.join("frames.jsonl"));
    assert_eq!(frames.len(), 10);
    let mut last_lux = f64::INFINITY;
    for (i, f) in frames.iter().enumerate() {
        let s = &f["sequence"]["sky"];
        let mid = i as f64 * 0.04 + 0.5 * f["sequence"]["window_s"].as_f64().unwrap();
        let [a, b] = [0, 1].map(|k| s["renders"][k].as_u64().unwrap() as f64);
        let frac = s["fraction"].as_f64().unwrap();
        assert!(
            ((a + (b - a) * frac) * 0.2 - mid).abs() < 1e-9,
            "frame {i}: {s}"
        );
        let lux = s["horizontal_lux"].as_f64().unwrap();
        assert!(lux < last_lux, "the evening darkens: frame {i} {lux}");
        last_lux = lux;
    }

    // The photocell's switch: where gloam sky's illuminance crosses 16 lx,
    // to a hundredth of a frame (0.4 ms of sequence, 1.2 s of sky).
    let keys = sky["photocells"]["lamp"]["keys"].as_array().unwrap();
    assert_eq!(keys.len(), 3, "{keys:?}");
    let t_on = keys[1][0].as_f64().unwrap();
    assert!(t_on > 0.0 && t_on < 0.4, "{t_on}");
    let start = 1_761_085_800.0;
    let before = sky_lux(&iso(start + (t_on - 0.0005) * 3000.0));
    let after = sky_lux(&iso(start + (t_on + 0.0005) * 3000.0));
    assert!(before > 16.0 && after < 16.0, "{before} {after} at {t_on}");
    // Frames before the switch see the lamp off, after it on.
    for f in &frames {
        let (t0, w) = (
            f["sequence"]["time_s"].as_f64().unwrap(),
            f["sequence"]["window_s"].as_f64().unwrap(),
        );
        let lamp = f["sequence"]["light_groups"]["lamp"].as_f64().unwrap();
        let want = ((t0 + w - t_on) / w).clamp(0.0, 1.0);
        assert!((lamp - want).abs() < 1e-9, "{lamp} {want}");
    }

    // Frame 0's layers are the still render of the scene at the clock's
    // start (the scene's own utc here): the clock's instant is the one
    // rendered.
    let still = dir.path().join("still");
    let still_s = still.display().to_string();
    let scene = dir.path().join("scene.toml").display().to_string();
    ok(&[
        "render",
        &scene,
        "--sensor",
        "gen3-gaas-iccd",
        "--spp",
        "2",
        "--layers",
        "--out",
        &still_s,
    ]);
    let a = std::fs::read(out.join("layers.npy")).unwrap();
    let b = std::fs::read(still.join("layers.npy")).unwrap();
    assert!(a == b, "frame 0's layers differ from the still's");
}

#[test]
fn sky_clocks_and_photocells_refuse_what_they_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), SCENE).unwrap();
    let cases = [
        ("[sky]\ntime_scale = 0.0\n", "sky.time_scale"),
        ("[sky]\ntime_scale = 10.0\nrenders = 1\n", "sky.renders"),
        (
            "[sky]\ntime_scale = 10.0\nutc_at_start = \"yesterday\"\n",
            "sky.utc_at_start",
        ),
        (
            "[groups.lamp]\nphotocell = { on_lux = 16.0 }\n",
            "needs the sequence's [sky] clock",
        ),
        (
            "[sky]\ntime_scale = 10.0\n[groups.lamp]\nkeys = [[0, 1]]\nphotocell = { on_lux = 16.0 }\n",
            "not both",
        ),
        (
            "[sky]\ntime_scale = 10.0\n[groups.lamp]\nphotocell = { on_lux = -1.0 }\n",
            "on_lux",
        ),
        (
            "[sky]\ntime_scale = 10.0\n[groups.lamp]\nphotocell = { on_lux = 1.0, run_up_s = 1e9 }\n",
            "run_up_s",
        ),
    ];
    let cases = cases.into_iter().chain([(
        "[sky]\ntime_scale = 10.0\n[groups.twilight]\nphotocell = { on_lux = 16.0 }\n",
        "a photocell switches a lamp's group",
    )]);
    for (extra, want) in cases {
        let err = refused(dir.path(), extra);
        assert!(err.contains(want), "{extra}: {err}");
        assert!(
            err.contains("seq.toml:"),
            "{extra}: names the file and line: {err}"
        );
    }
    // A clock over a scene without a sky.
    std::fs::write(
        dir.path().join("scene.toml"),
        SCENE.split("[sky]").next().unwrap().to_string()
            + "[materials.road]\nreflectance = 0.2\n[objects.road]\nmaterial = \"road\"\nquad = { center = [0, 0, 0], size = [60, 40], normal = [0, 0, 1] }\n",
    )
    .unwrap();
    let err = refused(dir.path(), "[sky]\ntime_scale = 10.0\n");
    assert!(err.contains("has no [sky]"), "{err}");
}

/// Renders far apart in the Sun's travel are rendered as asked, with a
/// warning that says how many the default would use (issue 46: 2 renders
/// over 10° of Sun were taken silently).
#[test]
fn sky_renders_far_apart_in_the_suns_travel_are_warned_of() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), SCENE).unwrap();
    // Two frames at 1e5×: 8000 s of sky, the Sun from −2.6° to about −19°.
    // The scene has no camera, so the run stops after binding the clock;
    // the warning is printed before that.
    let err = refused(dir.path(), "[sky]\ntime_scale = 1e5\nrenders = 2\n");
    assert!(
        err.contains("warning: ")
            && err.contains("seq.toml:4: sky: `renders = 2`; the default would use 3, as many as 2 frames allow (one per 1° of Sun would be ")
            && err.contains("between renders")
            && err.contains("may be off"),
        "{err}"
    );
    // The same clock at the default renders: as many as the frames allow,
    // still said.
    let err = refused(dir.path(), "[sky]\ntime_scale = 1e5\n");
    assert!(
        err.contains("3 renders, the default: 3, as many as 2 frames allow"),
        "{err}"
    );
    // Renders a degree apart: no warning.
    let err = refused(dir.path(), "[sky]\ntime_scale = 100\n");
    assert!(!err.contains("warning: "), "{err}");
}

/// Runs `gloam sequence` on a two-frame sequence of `dir`'s scene with
/// `extra` tables; it must fail: its stderr.
fn refused(dir: &Path, extra: &str) -> String {
    let seq = dir.join("seq.toml");
    let text = format!("scene = \"scene.toml\"\nframe_rate_hz = 25\nframes = 2\n{extra}");
    std::fs::write(&seq, text).unwrap();
    let (seq, out) = (
        seq.display().to_string(),
        dir.join("o").display().to_string(),
    );
    let run = Command::new(BIN)
        .args(["sequence", &seq, "--out", &out])
        .output()
        .unwrap();
    assert!(!run.status.success(), "{extra}: accepted");
    String::from_utf8_lossy(&run.stderr).into_owned()
}

/// A grey field seen from above under a falling twilight sky, through the
/// auto-gated Gen III camera of sims/dusk-street: every steady frame is
/// gated, and `calibrate agc --sequence` must divide each by its duty.
#[test]
fn calibrate_agc_over_a_moving_sky_linearises_gated_frames() {
    let root = env!("CARGO_MANIFEST_DIR");
    let dir = tempfile::tempdir().unwrap();
    let scene = SCENE
        .replace("position = [-20, 0, 3]", "position = [0, 0, 10]")
        .replace("look_at = [0, 0, 0]", "look_at = [0, 0.5, 0]")
        .replace("up = [0, 0, 1]", "up = [0, 1, 0]")
        .replace(
            "utc = \"2025-10-21T22:30:00Z\"",
            "utc = \"2025-10-21T22:20:00Z\"",
        )
        .replace("width = 16\nheight = 12", "width = 48\nheight = 36");
    // Lamp off: the sky alone, falling ~2.5× per degree.
    let scene = scene.replace("value = 1e-4", "value = 0.0");
    std::fs::write(dir.path().join("scene.toml"), scene).unwrap();
    let seq = dir.path().join("seq.toml");
    std::fs::write(
        &seq,
        "scene = \"scene.toml\"\nframe_rate_hz = 25\nframes = 100\n[sky]\ntime_scale = 300.0\nrenders = 4\n",
    )
    .unwrap();
    let out = dir.path().join("agc");
    let grabber = format!("sim:{root}/sims/dusk-street/gen3-autogated.toml?size=48x36");
    let source = format!("{root}/sims/calibration/sphere.toml");
    ok(&[
        "calibrate",
        "agc",
        "--sequence",
        &seq.display().to_string(),
        "--grabber",
        &grabber,
        "--source",
        &source,
        "--out",
        &out.display().to_string(),
    ]);
    let r: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("agc_sequence.json")).unwrap())
            .unwrap();
    let steady = &r["steady"];
    let frames = lines(&out.join("frames.jsonl"));
    // Every frame after the acquisition is gated, by a factor that changes
    // with the sky (the gate follows the light down).
    let duties: Vec<f64> = frames[40..]
        .iter()
        .map(|f| f["gate_duty"].as_f64().unwrap())
        .collect();
    assert!(duties.iter().all(|&d| d < 0.1), "{duties:?}");
    assert!(duties[duties.len() - 1] > 2.0 * duties[0], "{duties:?}");
    // Linearised through the LUT at each frame's gain and duty, the
    // frames match the truth between the sky renders: the residual is the
    // frame means' noise, a few per cent; ignoring the gate (the settled
    // frame's gain and duty for all) is off by far more.
    let rms = steady["rms_residual_percent"].as_f64().unwrap();
    let blind = steady["rms_residual_at_settled_gain_percent"]
        .as_f64()
        .unwrap();
    assert!(steady["frames"].as_u64().unwrap() >= 50, "{steady}");
    assert!(rms < 5.0, "{steady}");
    assert!(blind > 20.0, "{steady}");
}
