//! The catalogue of bad inputs (issue 13): each case runs the release
//! binary's code path through the built `gloam` and must end with a clear
//! error — exit status 1, `error:` on stderr naming what and where (the
//! expected words), never a panic, a hang or a success.
//!
//! A case is a command line plus files written into a scratch directory
//! first; `{base}` in a file is the small valid scene of
//! `tests/bad_inputs/base.toml`, so each scene case states only what it
//! breaks. Add a case for every bad input found: the mechanism, not the
//! instance, is what the fix must hold.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_gloam");
const BASE: &str = include_str!("bad_inputs/base.toml");
/// A case that has not ended by then has hung.
const TIMEOUT: Duration = Duration::from_secs(60);

struct Case {
    name: &'static str,
    files: &'static [(&'static str, &'static str)],
    args: &'static [&'static str],
    /// Every one of these must appear in stderr (case-insensitive).
    expect: &'static [&'static str],
}

macro_rules! case {
    ($name:expr, [$($f:expr => $c:expr),* $(,)?], [$($a:expr),* $(,)?], [$($e:expr),* $(,)?]) => {
        Case { name: $name, files: &[$(($f, $c)),*], args: &[$($a),*], expect: &[$($e),*] }
    };
}

/// A scene with one line of the base replaced (`from` → `to`).
fn patched(from: &str, to: &str) -> String {
    assert!(BASE.contains(from), "the base scene has no `{from}`");
    BASE.replacen(from, to, 1)
}

fn run(case: &Case, dir: &Path) -> (Option<i32>, String) {
    for (name, content) in case.files {
        let text = content.replace("{base}", BASE);
        let text = scene_patch(&text);
        let p = dir.join(name);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).unwrap();
        }
        std::fs::write(&p, text).unwrap();
    }
    let mut child = Command::new(BIN)
        .args(case.args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
            return (status.code(), err);
        }
        if t0.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return (None, format!("HUNG: no end after {TIMEOUT:?}"));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// `{patch:FROM=>TO}` on the first line of a file: the base scene with one
/// substring replaced.
fn scene_patch(text: &str) -> String {
    match text.strip_prefix("{patch:") {
        Some(rest) => {
            let (spec, tail) = rest
                .split_once("}\n")
                .unwrap_or((rest.trim_end_matches('}'), ""));
            let (from, to) = spec.split_once("=>").expect("{patch:FROM=>TO}");
            format!("{}{tail}", patched(from, to))
        }
        None => text.to_string(),
    }
}

const CASES: &[Case] = &[
    // --- scene files
    case!(
        "scene: missing file",
        [],
        ["plan", "nope.toml"],
        ["nope.toml"]
    ),
    case!("scene: a directory", ["d/x" => ""], ["plan", "d"], ["directory"]),
    case!(
        "scene: a device",
        [],
        ["plan", "/dev/zero"],
        ["not a regular file"]
    ),
    case!("scene: not UTF-8 on the last line", ["s.toml" => "units = \"ft\"\n# caf\u{e9}\n"], ["plan", "s.toml"], ["s.toml"]),
    case!("scene: TOML syntax", ["s.toml" => "units = \n"], ["plan", "s.toml"], ["s.toml", ":1"]),
    case!("scene: unknown top-level key", ["s.toml" => "{patch:units = \"ft\"=>units = \"ft\"\nbogus = 1}\n"], ["plan", "s.toml"], ["s.toml", "bogus"]),
    case!("scene: unknown unit", ["s.toml" => "{patch:units = \"ft\"=>units = \"furlong\"}\n"], ["plan", "s.toml"], ["s.toml", "units"]),
    case!("scene: camera at 1e300", ["s.toml" => "{patch:position = [0.0, -10.0, 6.0]=>position = [0.0, -1e300, 6.0]}\n"], ["plan", "s.toml"], ["s.toml", "camera.position"]),
    case!("scene: camera position NaN", ["s.toml" => "{patch:position = [0.0, -10.0, 6.0]=>position = [0.0, nan, 6.0]}\n"], ["plan", "s.toml"], ["s.toml", "camera.position"]),
    case!("scene: camera looks at itself", ["s.toml" => "{patch:look_at = [0.0, 0.0, 4.8]=>look_at = [0.0, -10.0, 6.0]}\n"], ["plan", "s.toml"], ["s.toml", "camera"]),
    case!("scene: up parallel to view", ["s.toml" => "{patch:up = [0.0, 0.0, 1.0]=>up = [0.0, 1.0, -0.12]}\n"], ["plan", "s.toml"], ["s.toml", "camera.up"]),
    case!("scene: up is zero", ["s.toml" => "{patch:up = [0.0, 0.0, 1.0]=>up = [0.0, 0.0, 0.0]}\n"], ["plan", "s.toml"], ["s.toml", "camera.up"]),
    case!("scene: position has 2 elements", ["s.toml" => "{patch:position = [0.0, -10.0, 6.0]=>position = [0.0, -10.0]}\n"], ["plan", "s.toml"], ["s.toml", "camera.position"]),
    case!("scene: position has 4 elements", ["s.toml" => "{patch:position = [0.0, -10.0, 6.0]=>position = [0.0, -10.0, 6.0, 1.0]}\n"], ["plan", "s.toml"], ["s.toml", "camera.position"]),
    case!("scene: fov 0", ["s.toml" => "{patch:fov_deg = 76.0=>fov_deg = 0.0}\n"], ["plan", "s.toml"], ["s.toml", "fov_deg"]),
    case!("scene: fov 180", ["s.toml" => "{patch:fov_deg = 76.0=>fov_deg = 180.0}\n"], ["plan", "s.toml"], ["s.toml", "fov_deg"]),
    case!("scene: width 0", ["s.toml" => "{patch:width = 32=>width = 0}\n"], ["plan", "s.toml"], ["s.toml", "width"]),
    case!("scene: width negative", ["s.toml" => "{patch:width = 32=>width = -32}\n"], ["plan", "s.toml"], ["s.toml", "width"]),
    case!("scene: width as a float", ["s.toml" => "{patch:width = 32=>width = 32.5}\n"], ["plan", "s.toml"], ["s.toml", "width"]),
    case!("render: a 4294967295² camera", ["s.toml" => "{patch:width = 32\nheight = 24=>width = 4294967295\nheight = 4294967295}\n"], ["render", "s.toml", "--out", "o"], ["pixel"]),
    case!("render: a 100000² camera", ["s.toml" => "{patch:width = 32\nheight = 24=>width = 100000\nheight = 100000}\n"], ["render", "s.toml", "--out", "o"], ["pixel"]),
    case!("render: resolution_scale 1e6", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "resolution_scale=1e6"], ["resolution_scale"]),
    case!("render: a band to 1e12 nm", ["s.toml" => "{patch:hi_nm = 700=>hi_nm = 1e12}\n"], ["render", "s.toml", "--out", "o"], ["wavelength"]),
    case!("scene: band lo above hi", ["s.toml" => "{patch:lo_nm = 400=>lo_nm = 800}\n"], ["plan", "s.toml"], ["s.toml", "bands.vis"]),
    case!("scene: band negative", ["s.toml" => "{patch:lo_nm = 400=>lo_nm = -400}\n"], ["plan", "s.toml"], ["s.toml", "bands.vis.lo_nm"]),
    case!("scene: no bands", ["s.toml" => "{patch:[bands.vis]\nlo_nm = 400\nhi_nm = 700\n=>}\n"], ["render", "s.toml", "--out", "o"], ["band"]),
    case!("scene: reflectance above 1", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = 1.5}\n"], ["plan", "s.toml"], ["s.toml", "materials.floor.reflectance"]),
    case!("scene: reflectance negative", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = -0.1}\n"], ["plan", "s.toml"], ["s.toml", "materials.floor.reflectance"]),
    case!("scene: emission overflows", ["s.toml" => "{patch:value = 1.0, shape=>value = 1e308, shape}\n"], ["render", "s.toml", "--out", "o"], ["s.toml", "emission"]),
    case!("scene: emission negative", ["s.toml" => "{patch:value = 1.0, shape=>value = -1.0, shape}\n"], ["plan", "s.toml"], ["s.toml", "emission"]),
    case!("scene: unknown material", ["s.toml" => "{patch:material = \"floor\"=>material = \"flor\"}\n"], ["plan", "s.toml"], ["s.toml", "flor"]),
    case!("scene: quad of zero size", ["s.toml" => "{patch:size = [40.0, 40.0]=>size = [40.0, 0.0]}\n"], ["plan", "s.toml"], ["s.toml", "size"]),
    case!("scene: quad normal zero", ["s.toml" => "{patch:normal = [0.0, 0.0, 1.0]=>normal = [0.0, 0.0, 0.0]}\n"], ["plan", "s.toml"], ["s.toml", "normal"]),
    case!("scene: unknown spectrum name", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = \"unobtainium\"}\n"], ["plan", "s.toml"], ["s.toml", "unobtainium"]),
    case!("scene: CSV spectrum missing", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = \"missing.csv\"}\n"], ["plan", "s.toml"], ["missing.csv"]),
    case!("scene: CSV spectrum is /dev/zero", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = \"/dev/zero\"}\n"], ["plan", "s.toml"], ["not a regular file"]),
    case!("scene: CSV with one row", ["one.csv" => "500,0.5\n", "s.toml" => "{patch:reflectance = 0.9=>reflectance = \"one.csv\"}\n"], ["plan", "s.toml"], ["one.csv"]),
    case!("scene: CSV wavelengths not increasing", ["bad.csv" => "500,0.5\n400,0.5\n", "s.toml" => "{patch:reflectance = 0.9=>reflectance = \"bad.csv\"}\n"], ["plan", "s.toml"], ["bad.csv", ":2"]),
    case!("scene: CSV with text in a value", ["bad.csv" => "400,0.5\n500,abc\n", "s.toml" => "{patch:reflectance = 0.9=>reflectance = \"bad.csv\"}\n"], ["plan", "s.toml"], ["bad.csv", ":2"]),
    case!("scene: CSV with NaN", ["bad.csv" => "400,0.5\n500,nan\n", "s.toml" => "{patch:reflectance = 0.9=>reflectance = \"bad.csv\"}\n"], ["plan", "s.toml"], ["bad.csv", ":2"]),
    case!("scene: CSV empty", ["bad.csv" => "", "s.toml" => "{patch:reflectance = 0.9=>reflectance = \"bad.csv\"}\n"], ["plan", "s.toml"], ["bad.csv"]),
    // --- OBJ files
    case!("OBJ: missing", ["s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"none.obj\"\n"], ["plan", "s.toml"], ["s.toml", "objects.m.obj", "none.obj"]),
    case!("OBJ: a directory", ["d.obj/x" => "", "s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"d.obj\"\n"], ["plan", "s.toml"], ["objects.m.obj", "directory"]),
    case!("OBJ: /dev/zero", ["s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"/dev/zero\"\n"], ["plan", "s.toml"], ["objects.m.obj", "not a regular file"]),
    case!("OBJ: a line element", ["l.obj" => "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nl 1 2\n", "s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"l.obj\"\n"], ["plan", "s.toml"], ["objects.m.obj", "line element"]),
    case!("OBJ: a face of 2 vertices", ["l.obj" => "v 0 0 0\nv 1 0 0\nf 1 2\n", "s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"l.obj\"\n"], ["plan", "s.toml"], ["objects.m.obj"]),
    case!("OBJ: index out of range", ["l.obj" => "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 9\n", "s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"l.obj\"\n"], ["plan", "s.toml"], ["objects.m.obj"]),
    case!("OBJ: collinear face", ["l.obj" => "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"l.obj\"\n"], ["plan", "s.toml"], ["objects.m.obj", "collinear"]),
    case!("OBJ: coincident vertices", ["l.obj" => "v 0 0 0\nv 0 0 0\nv 1 1 0\nf 1 2 3\n", "s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"l.obj\"\n"], ["plan", "s.toml"], ["objects.m.obj"]),
    case!("OBJ: bow-tie quad", ["l.obj" => "v 0 0 0\nv 1 1 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 4\n", "s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"l.obj\"\n"], ["plan", "s.toml"], ["objects.m.obj"]),
    case!("OBJ: no faces", ["l.obj" => "v 0 0 0\n", "s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"l.obj\"\n"], ["plan", "s.toml"], ["objects.m.obj", "no faces"]),
    case!("OBJ: garbage", ["l.obj" => "v a b c\nf 1 2 3\n", "s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nobj = \"l.obj\"\n"], ["plan", "s.toml"], ["objects.m.obj"]),
    // --- settings and flags
    case!("render: unknown setting", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "bogus=1"], ["bogus"]),
    case!("render: setting without =", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "spp"], ["spp"]),
    case!("render: spp 0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--spp", "0"], ["spp"]),
    case!("render: spp negative", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--spp", "-5"], ["spp"]),
    case!("render: threads 0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--threads", "0"], ["threads"]),
    case!("render: threads 1e9", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--threads", "1000000000"], ["threads"]),
    case!("render: spectral step 1e-9", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "spectral_step_nm=1e-9"], ["spectral_step_nm"]),
    case!("render: target error 0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--target-error", "0"], ["target_error"]),
    case!("render: target error NaN", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--target-error", "NaN"], ["target_error"]),
    case!("render: unknown estimator", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--estimator", "magic"], ["magic"]),
    case!("render: unknown sensor", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--sensor", "nosuch"], ["nosuch"]),
    case!("render: gain below the range", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--sensor", "gen3-gaas-iccd", "--gain", "2"], ["gain", "range"]),
    case!("render: frames 0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--sensor", "gen3-gaas-iccd", "--frames", "0"], ["frames"]),
    case!("render: --out is a file", ["s.toml" => "{base}", "o" => "x"], ["render", "s.toml", "--out", "o"], ["not a directory"]),
    case!("render: --out in use", ["s.toml" => "{base}", "o/radiance.npy" => "x"], ["render", "s.toml", "--out", "o"], ["not empty", "--force"]),
    case!("probe: normal zero", ["s.toml" => "{base}"], ["probe", "s.toml", "--point", "0,0,0", "--normal", "0,0,0"], ["normal"]),
    case!("probe: point with 2 numbers", ["s.toml" => "{base}"], ["probe", "s.toml", "--point", "0,0", "--normal", "0,0,1"], ["point"]),
    // --- sensor files
    case!(
        "sensor: missing file",
        [],
        ["sensor", "describe", "nosuch.toml"],
        ["nosuch.toml"]
    ),
    case!(
        "sensor: unknown preset",
        [],
        ["sensor", "describe", "gen9"],
        ["gen9"]
    ),
    case!("sensor: TOML syntax", ["c.toml" => "kind = \n"], ["sensor", "describe", "c.toml"], ["c.toml"]),
    case!(
        "sensor: gain out of range",
        [],
        ["sensor", "describe", "gen3-gaas-iccd", "--gain", "1e9"],
        ["gain"]
    ),
    // --- capture and grabbers
    case!(
        "capture: unknown grabber scheme",
        [],
        ["capture", "--grabber", "ftp:x", "--out", "o"],
        ["ftp"]
    ),
    case!(
        "capture: missing serial port",
        [],
        [
            "capture",
            "--grabber",
            "serial:/dev/nonexistent-gloam",
            "--out",
            "o"
        ],
        ["/dev/nonexistent-gloam"]
    ),
    case!(
        "capture: sim size 0x0",
        [],
        [
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd?size=0x0",
            "--out",
            "o"
        ],
        ["size"]
    ),
    case!(
        "capture: sim size huge",
        [],
        [
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd?size=100000x100000",
            "--out",
            "o"
        ],
        ["size"]
    ),
    case!(
        "capture: frames 0",
        [],
        [
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd",
            "--frames",
            "0",
            "--out",
            "o"
        ],
        ["frames"]
    ),
    case!(
        "capture: gain outside the range",
        [],
        [
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd",
            "--gain",
            "2",
            "--out",
            "o"
        ],
        ["gain"]
    ),
    case!(
        "capture: exposure negative",
        [],
        [
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd",
            "--exposure-s",
            "-1",
            "--out",
            "o"
        ],
        ["exposure"]
    ),
    // --- calibration inputs
    case!("calibrate apply: LUT missing", ["f.png" => ""], ["calibrate", "apply", "--lut", "none.json", "f.png", "o.tiff"], ["none.json"]),
    case!("calibrate apply: LUT not JSON", ["lut.json" => "{", "f.png" => ""], ["calibrate", "apply", "--lut", "lut.json", "f.png", "o.tiff"], ["lut.json"]),
    case!("calibrate apply: frame not an image", ["lut.json" => "{}", "f.png" => "not a png"], ["calibrate", "apply", "--lut", "lut.json", "f.png", "o.tiff"], ["lut.json"]),
    case!(
        "calibrate radiance: source missing",
        [],
        [
            "calibrate",
            "radiance",
            "--grabber",
            "sim:scientific-ccd?size=16x16",
            "--source",
            "none.toml",
            "--gains",
            "1",
            "--out",
            "o"
        ],
        ["none.toml"]
    ),
    case!("calibrate radiance: source syntax", ["s.toml" => "kind = \n"], ["calibrate", "radiance", "--grabber", "sim:scientific-ccd?size=16x16", "--source", "s.toml", "--gains", "1", "--out", "o"], ["s.toml"]),
    case!(
        "calibrate radiance: empty gains",
        [],
        [
            "calibrate",
            "radiance",
            "--grabber",
            "sim:scientific-ccd?size=16x16",
            "--source",
            "s.toml",
            "--gains",
            "",
            "--out",
            "o"
        ],
        ["gains"]
    ),
    // --- compare
    case!("compare: regions missing", ["a.tiff" => "", "b.tiff" => ""], ["compare", "a.tiff", "b.tiff", "--regions", "r.json"], ["a.tiff"]),
    // --- ephem and sky
    case!(
        "ephem: latitude 91",
        [],
        [
            "ephem",
            "--lat",
            "91",
            "--lon",
            "0",
            "--utc",
            "2025-10-07T05:00:00Z"
        ],
        ["lat"]
    ),
    case!(
        "ephem: February 30th",
        [],
        [
            "ephem",
            "--lat",
            "43",
            "--lon",
            "0",
            "--utc",
            "2025-02-30T05:00:00Z"
        ],
        ["2025-02-30"]
    ),
    case!(
        "ephem: not a time",
        [],
        ["ephem", "--lat", "43", "--lon", "0", "--utc", "yesterday"],
        ["yesterday"]
    ),
    case!(
        "sky: height negative huge",
        [],
        [
            "sky",
            "--lat",
            "43",
            "--lon",
            "0",
            "--height-m",
            "-1e9",
            "--utc",
            "2025-10-07T05:00:00Z"
        ],
        ["height"]
    ),
    // --- spectra
    case!(
        "spectra: unknown spectrum",
        [],
        ["spectra", "integrate", "nosuch", "--band", "400:700"],
        ["nosuch"]
    ),
    case!(
        "spectra: band reversed",
        [],
        ["spectra", "integrate", "cie-a", "--band", "700:400"],
        ["band"]
    ),
    case!(
        "spectra: band not numbers",
        [],
        ["spectra", "integrate", "cie-a", "--band", "a:b"],
        ["band"]
    ),
];

#[test]
fn every_bad_input_gets_a_clear_error() {
    let mut failures = Vec::new();
    for case in CASES {
        let dir = tempfile::tempdir().unwrap();
        let (code, err) = run(case, dir.path());
        let lower = err.to_lowercase();
        let problem = if code.is_none() {
            Some(format!(
                "no exit status (hung or killed by a signal): {err}"
            ))
        } else if err.contains("panicked") || code == Some(101) {
            Some(format!("panicked: {err}"))
        } else if code == Some(0) {
            Some("succeeded".to_string())
        } else if !lower.contains("error") {
            Some(format!("no `error` on stderr: {err}"))
        } else {
            case.expect
                .iter()
                .find(|w| !lower.contains(&w.to_lowercase()))
                .map(|w| format!("does not mention `{w}`: {err}"))
        };
        if let Some(p) = problem {
            failures.push(format!("{}: {p}", case.name));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} bad inputs were not handled:\n{}",
        failures.len(),
        CASES.len(),
        failures.join("\n")
    );
    eprintln!("{} bad inputs, each a clear error", CASES.len());
}
