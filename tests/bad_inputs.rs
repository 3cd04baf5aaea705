//! The catalogue of bad inputs (issue 13): each case runs the release
//! binary's code path through the built `gloam` and must end with a clear
//! error — exit status 1, `error:` on stderr naming what and where (the
//! expected words), never a panic, a hang or a success.
//!
//! A case is a command line plus files written into a scratch directory
//! first; `{base}` in a file is the small valid scene of
//! `tests/bad_inputs/base.toml`, so each scene case states only what it
//! breaks; a file whose content is `{fifo}` is made a FIFO nobody writes.
//! Add a case for every bad input found: the mechanism, not the instance,
//! is what the fix must hold.

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
        if text == "{fifo}" {
            // A FIFO nobody writes: a reader that opens it blocks forever.
            let ok = Command::new("mkfifo").arg(&p).status().unwrap();
            assert!(ok.success(), "mkfifo {}", p.display());
            continue;
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
    // --- more cases (scene fields, settings, tiles, sweeps, grabbers)
    case!("scene: empty file", ["s.toml" => ""], ["plan", "s.toml"], ["s.toml"]),
    case!("scene: duplicate key", ["s.toml" => "{patch:fov_deg = 76.0=>fov_deg = 76.0\nfov_deg = 60.0}\n"], ["plan", "s.toml"], ["s.toml", ":8", "duplicate key"]),
    case!("scene: fov negative", ["s.toml" => "{patch:fov_deg = 76.0=>fov_deg = -10.0}\n"], ["plan", "s.toml"], ["s.toml", "fov_deg"]),
    case!("scene: fov NaN", ["s.toml" => "{patch:fov_deg = 76.0=>fov_deg = nan}\n"], ["plan", "s.toml"], ["s.toml", "fov_deg"]),
    case!("scene: fov a string", ["s.toml" => "{patch:fov_deg = 76.0=>fov_deg = \"wide\"}\n"], ["plan", "s.toml"], ["s.toml", "fov_deg"]),
    case!("scene: height 0", ["s.toml" => "{patch:height = 24=>height = 0}\n"], ["plan", "s.toml"], ["s.toml", "height"]),
    case!("scene: position with a string", ["s.toml" => "{patch:position = [0.0, -10.0, 6.0]=>position = [0.0, \"x\", 6.0]}\n"], ["plan", "s.toml"], ["s.toml", "camera.position"]),
    case!("scene: position infinite", ["s.toml" => "{patch:position = [0.0, -10.0, 6.0]=>position = [0.0, inf, 6.0]}\n"], ["plan", "s.toml"], ["s.toml", "camera.position"]),
    case!("scene: missing camera", ["s.toml" => "{patch:[camera]=>[camera_]}\n"], ["plan", "s.toml"], ["s.toml"]),
    case!("scene: band hi equals lo", ["s.toml" => "{patch:hi_nm = 700=>hi_nm = 400}\n"], ["plan", "s.toml"], ["s.toml", "bands.vis"]),
    case!("scene: band NaN", ["s.toml" => "{patch:hi_nm = 700=>hi_nm = nan}\n"], ["plan", "s.toml"], ["s.toml", "bands.vis"]),
    case!("scene: reflectance NaN", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = nan}\n"], ["plan", "s.toml"], ["s.toml", "materials.floor.reflectance"]),
    case!("scene: specular fraction 1.5", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = 0.9\nspecular_fraction = 1.5}\n"], ["plan", "s.toml"], ["s.toml", "specular_fraction"]),
    case!("scene: specular fraction negative", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = 0.9\nspecular_fraction = -0.1}\n"], ["plan", "s.toml"], ["s.toml", "specular_fraction"]),
    case!("scene: reflectance plus transmission above 1", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = 0.9\ntransmission = 0.5}\n"], ["plan", "s.toml"], ["s.toml", "materials.floor"]),
    case!("scene: transmission negative", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = 0.1\ntransmission = -0.5}\n"], ["plan", "s.toml"], ["s.toml", "transmission"]),
    case!("scene: unknown material key", ["s.toml" => "{patch:reflectance = 0.9=>reflectance = 0.9\ncolour = 1}\n"], ["plan", "s.toml"], ["s.toml", "colour"]),
    case!("scene: shape exponent negative", ["s.toml" => "{patch:shape_exponent = 0=>shape_exponent = -2}\n"], ["plan", "s.toml"], ["s.toml", "shape_exponent"]),
    case!("scene: shape exponent NaN", ["s.toml" => "{patch:shape_exponent = 0=>shape_exponent = nan}\n"], ["plan", "s.toml"], ["s.toml", "shape_exponent"]),
    case!("scene: emission line at a negative wavelength", ["s.toml" => "{patch:value = 1.0, shape=>value = 1.0, lines = [[-546.0, 0.1]], shape}\n"], ["plan", "s.toml"], ["s.toml", "emission"]),
    case!("scene: emission line with a negative value", ["s.toml" => "{patch:value = 1.0, shape=>value = 1.0, lines = [[546.0, -0.1]], shape}\n"], ["plan", "s.toml"], ["s.toml", "emission"]),
    case!("scene: emission line with one number", ["s.toml" => "{patch:value = 1.0, shape=>value = 1.0, lines = [[546.0]], shape}\n"], ["plan", "s.toml"], ["s.toml", "emission"]),
    case!("scene: emission normalize band reversed", ["s.toml" => "{patch:value = 1.0, shape=>value = 1.0, normalize = { lo_nm = 700, hi_nm = 400, value = 1.0 }, shape}\n"], ["plan", "s.toml"], ["s.toml", "normalize"]),
    case!("scene: quad size negative", ["s.toml" => "{patch:size = [40.0, 40.0]=>size = [40.0, -40.0]}\n"], ["plan", "s.toml"], ["s.toml", "size"]),
    case!("scene: quad size with one number", ["s.toml" => "{patch:size = [40.0, 40.0]=>size = [40.0]}\n"], ["plan", "s.toml"], ["s.toml", "size"]),
    case!("scene: width axis along the normal", ["s.toml" => "{patch:width_axis = [1.0, 0.0, 0.0]=>width_axis = [0.0, 0.0, 1.0]}\n"], ["plan", "s.toml"], ["s.toml", "width_axis"]),
    case!("scene: object with two shapes", ["s.toml" => "{base}\n[objects.two]\nmaterial = \"floor\"\nbox = { min = [0, 0, 0], max = [1, 1, 1] }\nquad = { center = [0.0, 0.0, 1.0], size = [1.0, 1.0], normal = [0.0, 0.0, 1.0] }\n"], ["plan", "s.toml"], ["s.toml", "objects.two"]),
    case!("scene: object with no shape", ["s.toml" => "{base}\n[objects.ghost]\nmaterial = \"floor\"\n"], ["plan", "s.toml"], ["s.toml", "objects.ghost"]),
    case!("scene: object without material", ["s.toml" => "{base}\n[objects.ghost]\nquad = { center = [0.0, 0.0, 1.0], size = [1.0, 1.0], normal = [0.0, 0.0, 1.0] }\n"], ["plan", "s.toml"], ["s.toml", "objects.ghost"]),
    case!("scene: box min above max", ["s.toml" => "{base}\n[objects.b]\nmaterial = \"floor\"\nbox = { min = [1, 1, 1], max = [0, 0, 0] }\n"], ["plan", "s.toml"], ["s.toml", "objects.b"]),
    case!("scene: box of zero thickness", ["s.toml" => "{base}\n[objects.b]\nmaterial = \"floor\"\nbox = { min = [0, 0, 1], max = [1, 1, 1] }\n"], ["plan", "s.toml"], ["s.toml", "objects.b"]),
    case!("scene: inline face index out of range", ["s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nvertices = [[0, 0, 1], [1, 0, 1], [1, 1, 1]]\nfaces = [[0, 1, 7]]\n"], ["plan", "s.toml"], ["s.toml", "objects.m"]),
    case!("scene: inline face of two vertices", ["s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nvertices = [[0, 0, 1], [1, 0, 1], [1, 1, 1]]\nfaces = [[0, 1]]\n"], ["plan", "s.toml"], ["s.toml", "objects.m"]),
    case!("scene: inline face index negative", ["s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nvertices = [[0, 0, 1], [1, 0, 1], [1, 1, 1]]\nfaces = [[0, 1, -1]]\n"], ["plan", "s.toml"], ["s.toml", "objects.m"]),
    case!("scene: inline collinear face", ["s.toml" => "{base}\n[objects.m]\nmaterial = \"floor\"\nvertices = [[0, 0, 1], [1, 0, 1], [2, 0, 1]]\nfaces = [[0, 1, 2]]\n"], ["plan", "s.toml"], ["s.toml", "objects.m"]),
    case!("scene: point source at NaN", ["s.toml" => "{base}\n[point_sources.l]\nposition = [0.0, nan, 3.0]\nvalue = 1.0\n"], ["plan", "s.toml"], ["s.toml", "point_sources.l"]),
    case!("scene: point source direction zero", ["s.toml" => "{base}\n[point_sources.l]\nposition = [0.0, 0.0, 3.0]\ndirection = [0.0, 0.0, 0.0]\nshape_exponent = 2\nvalue = 1.0\n"], ["plan", "s.toml"], ["s.toml", "point_sources.l"]),
    case!("scene: point source negative value", ["s.toml" => "{base}\n[point_sources.l]\nposition = [0.0, 0.0, 3.0]\nvalue = -1.0\n"], ["plan", "s.toml"], ["s.toml", "point_sources.l"]),
    case!("scene: point source unknown spectrum", ["s.toml" => "{base}\n[point_sources.l]\nposition = [0.0, 0.0, 3.0]\nspectrum = \"nosuch-lamp\"\n"], ["plan", "s.toml"], ["s.toml", "nosuch-lamp"]),
    case!("scene: sky latitude 95", ["s.toml" => "{base}\n[sky]\nutc = \"2025-10-07T05:00:00Z\"\nlatitude_deg = 95.0\nlongitude_deg = 0.0\n"], ["plan", "s.toml"], ["s.toml", "latitude"]),
    case!("scene: sky time not a date", ["s.toml" => "{base}\n[sky]\nutc = \"tonight\"\nlatitude_deg = 43.0\nlongitude_deg = 0.0\n"], ["plan", "s.toml"], ["s.toml", "utc"]),
    case!("scene: sky on February 30th", ["s.toml" => "{base}\n[sky]\nutc = \"2025-02-30T05:00:00Z\"\nlatitude_deg = 43.0\nlongitude_deg = 0.0\n"], ["plan", "s.toml"], ["s.toml", "utc"]),
    case!("scene: sky visibility 0", ["s.toml" => "{base}\n[sky]\nutc = \"2025-10-07T05:00:00Z\"\nlatitude_deg = 43.0\nlongitude_deg = 0.0\nvisibility_km = 0.0\n"], ["plan", "s.toml"], ["s.toml", "visibility"]),
    case!("scene: sky unknown key", ["s.toml" => "{base}\n[sky]\nutc = \"2025-10-07T05:00:00Z\"\nlatitude_deg = 43.0\nlongitude_deg = 0.0\nsun = true\n"], ["plan", "s.toml"], ["s.toml", "sun"]),
    case!("render: scene names an unknown sensor", ["s.toml" => "{patch:units = \"ft\"=>units = \"ft\"\nsensor = \"gen9\"}\n"], ["render", "s.toml", "--out", "o"], ["gen9"]),
    case!("scene: CSV line row without a value", ["l.csv" => "400,0.5\n700,0.5\nline,546.07\n", "s.toml" => "{patch:value = 1.0, shape=>spectrum = \"l.csv\", shape}\n"], ["plan", "s.toml"], ["l.csv", ":3"]),
    case!("scene: CSV duplicate wavelength", ["d.csv" => "400,0.5\n400,0.6\n700,0.5\n", "s.toml" => "{patch:reflectance = 0.9=>reflectance = \"d.csv\"}\n"], ["plan", "s.toml"], ["d.csv", ":2"]),
    case!("scene: CSV negative wavelength", ["d.csv" => "-400,0.5\n700,0.5\n", "s.toml" => "{patch:reflectance = 0.9=>reflectance = \"d.csv\"}\n"], ["plan", "s.toml"], ["d.csv", ":1"]),
    case!("scene: CSV three columns", ["d.csv" => "400,0.5,1\n700,0.5,1\n", "s.toml" => "{patch:reflectance = 0.9=>reflectance = \"d.csv\"}\n"], ["plan", "s.toml"], ["d.csv", ":1"]),
    case!("render: --set recursion=0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "recursion=0"], ["recursion"]),
    case!("render: --set area_samples=0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "area_samples=0"], ["area_samples"]),
    case!("render: --set sky_samples=0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "sky_samples=0"], ["sky_samples"]),
    case!("render: --set tolerance=1", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "tolerance=1"], ["tolerance"]),
    case!("render: --set tolerance=-0.1", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "tolerance=-0.1"], ["tolerance"]),
    case!("render: --set cache_texels=0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "cache_texels=0"], ["cache_texels"]),
    case!("render: --set max_spp=0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "max_spp=0"], ["max_spp"]),
    case!("render: --set drop=sun", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "drop=sun"], ["drop"]),
    case!("render: --set all_effects=maybe", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "all_effects=maybe"], ["all_effects"]),
    case!("render: --set occlusion=xyz", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "occlusion=xyz"], ["occlusion"]),
    case!("render: --set indirect=photon-map", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "indirect=photon-map"], ["indirect"]),
    case!("render: --set seed=-1", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "seed=-1"], ["seed"]),
    case!("render: --set resolution_scale=0", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "resolution_scale=0"], ["resolution_scale"]),
    case!("render: --set resolution_scale=nan", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "resolution_scale=nan"], ["resolution_scale"]),
    case!("render: --set gather_rays=1000000000", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "gather_rays=1000000000"], ["gather_rays"]),
    case!("render: --set cache_tolerance=1", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--set", "cache_tolerance=1"], ["cache_tolerance"]),
    case!("render: tile 0 of 2", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--tile", "0/2"], ["tile"]),
    case!("render: tile 3 of 2", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--tile", "3/2"], ["tile"]),
    case!("render: tile not a fraction", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--tile", "a/b"], ["tile"]),
    case!("render: more tiles than rows", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--tile", "1/100000"], ["tile"]),
    case!("render: exposure mode unknown", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--sensor", "gen3-gaas-iccd", "--exposure", "manual"], ["exposure"]),
    case!("render: exposure auto with a gain", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--sensor", "gen3-gaas-iccd", "--exposure", "auto", "--gain", "20"], ["gain"]),
    case!("render: tolerance 2", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--tolerance", "2"], ["tolerance"]),
    case!("plan: tolerance negative", ["s.toml" => "{base}"], ["plan", "s.toml", "--tolerance", "-1"], ["tolerance"]),
    case!("probe: unknown band", ["s.toml" => "{base}"], ["probe", "s.toml", "--point", "0,0,0", "--normal", "0,0,1", "--band", "nir"], ["nir"]),
    case!("probe: pixel outside the image", ["s.toml" => "{base}"], ["probe", "s.toml", "--pixel", "500,500"], ["pixel"]),
    case!("probe: samples 0", ["s.toml" => "{base}"], ["probe", "s.toml", "--point", "0,0,0", "--normal", "0,0,1", "--samples", "0"], ["samples"]),
    case!("probe: point NaN", ["s.toml" => "{base}"], ["probe", "s.toml", "--point", "0,nan,0", "--normal", "0,0,1"], ["point"]),
    case!(
        "spectra: unknown weight",
        [],
        [
            "spectra",
            "integrate",
            "cie-a",
            "--band",
            "400:700",
            "--weight",
            "nosuch"
        ],
        ["nosuch"]
    ),
    case!(
        "spectra: band with one number",
        [],
        ["spectra", "integrate", "cie-a", "--band", "400"],
        ["band"]
    ),
    case!(
        "spectra: band NaN",
        [],
        ["spectra", "integrate", "cie-a", "--band", "nan:700"],
        ["band"]
    ),
    case!(
        "ephem: longitude 400",
        [],
        [
            "ephem",
            "--lat",
            "43",
            "--lon",
            "400",
            "--utc",
            "2025-10-07T05:00:00Z"
        ],
        ["lon"]
    ),
    case!(
        "ephem: window reversed",
        [],
        [
            "ephem",
            "--lat",
            "43",
            "--lon",
            "0",
            "--from",
            "2025-11-01",
            "--to",
            "2025-10-01",
            "--find",
            "full"
        ],
        ["from"]
    ),
    case!(
        "ephem: min hours negative",
        [],
        [
            "ephem",
            "--lat",
            "43",
            "--lon",
            "0",
            "--from",
            "2025-10-01",
            "--to",
            "2025-11-01",
            "--find",
            "full",
            "--min-hours",
            "-1"
        ],
        ["hours"]
    ),
    case!(
        "sky: visibility 0",
        [],
        [
            "sky",
            "--lat",
            "43",
            "--lon",
            "0",
            "--utc",
            "2025-10-07T05:00:00Z",
            "--visibility-km",
            "0"
        ],
        ["visibility"]
    ),
    // --- every reader refuses devices and FIFOs (one bounded reader)
    case!(
        "sensor file: a device",
        [],
        ["sensor", "describe", "/dev/zero"],
        ["/dev/zero", "not a regular file"]
    ),
    case!("sensor file: a FIFO", ["p.toml" => "{fifo}"], ["sensor", "describe", "p.toml"], ["p.toml", "not a regular file"]),
    case!("render --sensor: a device", ["s.toml" => "{base}"], ["render", "s.toml", "--out", "o", "--sensor", "/dev/zero"], ["/dev/zero", "not a regular file"]),
    case!("capture sim: sensor a FIFO", ["p.toml" => "{fifo}"], ["capture", "--grabber", "sim:p.toml", "--frames", "1", "--out", "o"], ["p.toml", "not a regular file"]),
    case!(
        "sweep file: a device",
        [],
        ["sweep", "/dev/zero", "--out", "o"],
        ["/dev/zero", "not a regular file"]
    ),
    case!("sweep file: a FIFO", ["w.toml" => "{fifo}"], ["sweep", "w.toml", "--out", "o"], ["w.toml", "not a regular file"]),
    case!("calibrate apply: LUT a device", ["f.png" => ""], ["calibrate", "apply", "--lut", "/dev/zero", "f.png", "o.tiff"], ["/dev/zero", "not a regular file"]),
    case!("calibrate apply: LUT a FIFO", ["l.json" => "{fifo}", "f.png" => ""], ["calibrate", "apply", "--lut", "l.json", "f.png", "o.tiff"], ["l.json", "not a regular file"]),
    case!(
        "calibrate radiance: source a device",
        [],
        [
            "calibrate",
            "radiance",
            "--grabber",
            "sim:gen3-gaas-iccd",
            "--source",
            "/dev/zero",
            "--gains",
            "20",
            "--out",
            "o"
        ],
        ["/dev/zero", "not a regular file"]
    ),
    case!("calibrate radiance: source a FIFO", ["src.toml" => "{fifo}"], ["calibrate", "radiance", "--grabber", "sim:gen3-gaas-iccd", "--source", "src.toml", "--gains", "20", "--out", "o"], ["src.toml", "not a regular file"]),
    case!(
        "calibrate mtf: CTF file a device",
        [],
        [
            "calibrate",
            "mtf",
            "--target",
            "usaf",
            "--ctf",
            "/dev/zero",
            "--pixel-pitch-um",
            "10",
            "--out",
            "o"
        ],
        ["/dev/zero", "not a regular file"]
    ),
    case!("calibrate mtf: CTF file a FIFO", ["c.csv" => "{fifo}"], ["calibrate", "mtf", "--target", "usaf", "--ctf", "c.csv", "--pixel-pitch-um", "10", "--out", "o"], ["c.csv", "not a regular file"]),
    case!("sky --spectra-out: a directory", ["d/x" => ""], ["sky", "--lat", "43", "--lon", "-77", "--utc", "2025-10-07T05:00:00Z", "--spectra-out", "d"], ["d", "directory"]),
    case!("sky --spectra-out: a FIFO is never replaced", ["p.csv" => "{fifo}"], ["sky", "--lat", "43", "--lon", "-77", "--utc", "2025-10-07T05:00:00Z", "--spectra-out", "p.csv"], ["p.csv", "not a regular file"]),
    case!("render --out: holds the scene, with --force", ["sd/s.toml" => "{base}"], ["render", "sd/s.toml", "--out", "sd", "--force"], ["sd", "input"]),
    case!("render --out: a stray file, with --force", ["s.toml" => "{base}", "o/notes.txt" => "mine"], ["render", "s.toml", "--out", "o", "--force"], ["manifest.json", "--force"]),
    case!(
        "sweep: missing file",
        [],
        ["sweep", "none.toml", "--out", "o"],
        ["none.toml"]
    ),
    case!("sweep: unknown axis", ["w.toml" => "[base]\nsensor = \"gen3-gaas-iccd\"\n[axes]\ncolour = [1, 2]\n"], ["sweep", "w.toml", "--out", "o"], ["w.toml", "colour"]),
    case!("sweep: empty axis", ["w.toml" => "[base]\nsensor = \"gen3-gaas-iccd\"\n[axes]\ngain = []\n"], ["sweep", "w.toml", "--out", "o"], ["w.toml", "gain"]),
    case!("sweep: seed count 0", ["w.toml" => "[base]\nsensor = \"gen3-gaas-iccd\"\n[axes]\nseed = { from = 0, count = 0 }\n"], ["sweep", "w.toml", "--out", "o"], ["w.toml", "seed"]),
    case!("sweep: unknown flow", ["w.toml" => "[base]\nsensor = \"gen3-gaas-iccd\"\nflow = \"dance\"\n[axes]\ngain = [20]\n"], ["sweep", "w.toml", "--out", "o"], ["w.toml", "dance"]),
    case!("sweep: TOML syntax", ["w.toml" => "[base\n"], ["sweep", "w.toml", "--out", "o"], ["w.toml"]),
    case!(
        "merge: missing tile directory",
        [],
        ["merge", "--out", "o", "t1", "t2"],
        ["t1"]
    ),
    case!(
        "sweep status: not a sweep directory",
        [],
        ["sweep", "status", "nodir"],
        ["nodir"]
    ),
    case!(
        "capture: unknown sim preset",
        [],
        ["capture", "--grabber", "sim:gen9", "--out", "o"],
        ["gen9"]
    ),
    case!(
        "capture: sim size not numbers",
        [],
        [
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd?size=axb",
            "--out",
            "o"
        ],
        ["size"]
    ),
    case!(
        "capture: sim unknown option",
        [],
        [
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd?colour=red",
            "--out",
            "o"
        ],
        ["colour"]
    ),
    case!(
        "capture: gain NaN",
        [],
        [
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd",
            "--gain",
            "nan",
            "--out",
            "o"
        ],
        ["gain"]
    ),
    case!(
        "sensor: gain NaN",
        [],
        ["sensor", "describe", "gen3-gaas-iccd", "--gain", "nan"],
        ["gain"]
    ),
    case!("sensor: unknown key", ["c.toml" => "kind = \"ccd\"\ncolour = 1\n"], ["sensor", "describe", "c.toml"], ["c.toml"]),
    case!(
        "calibrate mtf: unknown target",
        [],
        [
            "calibrate",
            "mtf",
            "--grabber",
            "sim:scientific-ccd?size=64x64",
            "--target",
            "zebra",
            "--out",
            "o"
        ],
        ["zebra"]
    ),
    case!(
        "calibrate ptc: one level",
        [],
        [
            "calibrate",
            "ptc",
            "--grabber",
            "sim:scientific-ccd?size=16x16",
            "--levels",
            "1",
            "--out",
            "o"
        ],
        ["levels"]
    ),
    case!(
        "calibrate agc: unknown grabber",
        [],
        [
            "calibrate",
            "agc",
            "--grabber",
            "ftp:x",
            "--source",
            "x.toml",
            "--out",
            "o"
        ],
        ["ftp"]
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
