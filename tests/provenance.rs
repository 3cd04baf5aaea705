//! Provenance that covers every input (issue 28): the manifest hashes every
//! file a run read, merge refuses tiles whose files or render differ,
//! sweep resume reruns a task whose inputs changed, and `calibrate apply`
//! refuses a LUT of another camera or bit depth. Hashes are checked
//! against coreutils' `sha256sum`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_gloam");

fn gloam(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let mut c = Command::new(BIN);
    for a in args {
        c.arg(a);
    }
    c.output().expect("running gloam")
}

fn ok(o: Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    err
}

fn refused(o: Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

fn json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// Independent SHA-256 via coreutils.
fn sha256sum(path: &Path) -> String {
    let out = Command::new("sha256sum").arg(path).output().unwrap();
    String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .next()
        .unwrap()
        .to_string()
}

const SCENE: &str = r#"units = "m"

[camera]
position = [0.0, -5.0, 1.5]
look_at = [0.0, 0.0, 1.0]
fov_deg = 60.0
width = 16
height = 12

[bands.vis]
lo_nm = 400
hi_nm = 700

[materials.grey]
reflectance = "paint.csv"

[objects.floor]
material = "grey"
quad = { center = [0.0, 0.0, 0.0], size = [10.0, 10.0], normal = [0.0, 0.0, 1.0] }

[objects.m]
material = "grey"
obj = "tri.obj"
instances_csv = "place.csv"
"#;

/// A scene that reads a spectrum CSV, an OBJ and a placements CSV.
fn scene_dir(dir: &Path) -> PathBuf {
    std::fs::write(
        dir.join("paint.csv"),
        "wavelength_nm,value\n400,0.2\n700,0.4\n",
    )
    .unwrap();
    std::fs::write(dir.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(
        dir.join("place.csv"),
        "x,y,z,rotate_z_deg,scale\n0,0,0.5,0,1\n1,0,0.5,0,1\n",
    )
    .unwrap();
    let s = dir.join("s.toml");
    std::fs::write(&s, SCENE).unwrap();
    s
}

/// `inputs` of a provenance block as (canonical path → sha256).
fn inputs(p: &Value) -> Vec<(PathBuf, String)> {
    p["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| {
            (
                std::fs::canonicalize(i["path"].as_str().unwrap()).unwrap(),
                i["sha256"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

#[test]
fn the_manifest_and_report_hash_every_file_the_render_read() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_dir(dir.path());
    let out = dir.path().join("out");
    // A sensor file (read, never written).
    let sensor = Path::new(env!("CARGO_MANIFEST_DIR")).join("sims/sensors/scientific-ccd.toml");
    ok(gloam(&[
        &"render",
        &scene,
        &"--sensor",
        &sensor,
        &"--out",
        &out,
        &"--spp",
        &"1",
    ]));
    let m = json(&out.join("manifest.json"));
    let r = json(&out.join("report.json"));
    for listed in [inputs(&m["provenance"]), inputs(&r["provenance"])] {
        let read = ["s.toml", "paint.csv", "tri.obj", "place.csv"]
            .map(|n| dir.path().join(n))
            .into_iter()
            .chain([sensor.clone()]);
        for path in read {
            let name = path.display().to_string();
            let f = std::fs::canonicalize(&path).unwrap();
            let hits: Vec<&(PathBuf, String)> = listed.iter().filter(|(p, _)| *p == f).collect();
            assert_eq!(hits.len(), 1, "{name} once in {listed:?}");
            assert_eq!(hits[0].1, sha256sum(&f), "{name}");
        }
        // Nothing the run wrote is listed as an input.
        assert!(
            listed.iter().all(|(p, _)| !p.starts_with(&out)),
            "{listed:?}"
        );
    }
    // `--version` names the commit the manifest records.
    let v = ok_stdout(gloam(&[&"--version"]));
    let commit = m["provenance"]["git_commit"].as_str().unwrap();
    assert!(v.contains(commit), "{v} vs {commit}");
}

fn ok_stdout(o: Output) -> String {
    assert!(o.status.success());
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn tile(scene: &Path, k: &str, out: &Path, spp: &str) {
    ok(gloam(&[
        &"render", &scene, &"--tile", &k, &"--out", &out, &"--spp", &spp,
    ]));
}

#[test]
fn merge_refuses_a_tampered_tile_naming_the_file_and_a_foreign_tile_naming_what_differs() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_dir(dir.path());
    let (t1, t2) = (dir.path().join("t1"), dir.path().join("t2"));
    tile(&scene, "1/2", &t1, "1");
    tile(&scene, "2/2", &t2, "1");
    ok(gloam(&[
        &"merge",
        &t1,
        &t2,
        &"--out",
        &dir.path().join("m"),
    ]));

    // One byte of a tile's radiance changed: refused, naming the file.
    let npy = t2.join("radiance.npy");
    let mut bytes = std::fs::read(&npy).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&npy, &bytes).unwrap();
    let err = refused(gloam(&[
        &"merge",
        &t1,
        &t2,
        &"--out",
        &dir.path().join("m2"),
    ]));
    assert!(
        err.contains(&npy.display().to_string()) && err.contains("changed since the render"),
        "{err}"
    );
    assert!(!dir.path().join("m2").exists());

    // A deleted manifest: the tile cannot be checked, so it is refused.
    let t2m = dir.path().join("t2m");
    tile(&scene, "2/2", &t2m, "1");
    std::fs::remove_file(t2m.join("manifest.json")).unwrap();
    let err = refused(gloam(&[
        &"merge",
        &t1,
        &t2m,
        &"--out",
        &dir.path().join("m2"),
    ]));
    assert!(err.contains("manifest.json"), "{err}");

    // Other settings: the differing setting is named.
    let t2s = dir.path().join("t2s");
    tile(&scene, "2/2", &t2s, "2");
    let err = refused(gloam(&[
        &"merge",
        &t1,
        &t2s,
        &"--out",
        &dir.path().join("m2"),
    ]));
    assert!(err.contains("settings (spp 2 vs 1)"), "{err}");
    assert!(
        !err.contains("image size") && !err.contains("tile count"),
        "{err}"
    );

    // The same scene path, edited between the tiles: the scene is named.
    let mut text = std::fs::read_to_string(&scene).unwrap();
    text.push_str("\n# edited\n");
    std::fs::write(&scene, text).unwrap();
    let t2e = dir.path().join("t2e");
    tile(&scene, "2/2", &t2e, "1");
    let err = refused(gloam(&[
        &"merge",
        &t1,
        &t2e,
        &"--out",
        &dir.path().join("m2"),
    ]));
    assert!(err.contains("scene (") && err.contains("SHA-256"), "{err}");

    // The scene unchanged but an OBJ it reads edited: the OBJ is named.
    let t1b = dir.path().join("t1b");
    tile(&scene, "1/2", &t1b, "1");
    std::fs::write(
        dir.path().join("tri.obj"),
        "v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n",
    )
    .unwrap();
    let t2o = dir.path().join("t2o");
    tile(&scene, "2/2", &t2o, "1");
    let err = refused(gloam(&[
        &"merge",
        &t1b,
        &t2o,
        &"--out",
        &dir.path().join("m2"),
    ]));
    assert!(err.contains("tri.obj"), "{err}");
}

#[test]
fn sweep_resume_reruns_a_task_whose_inputs_changed() {
    let dir = tempfile::tempdir().unwrap();
    scene_dir(dir.path());
    let sweep = dir.path().join("sw.toml");
    std::fs::write(
        &sweep,
        "[base]\nspp = 1\nframes = 1\nscene = \"s.toml\"\n[axes]\ngain = [20, 100]\nsensor = [\"gen2-s20-iccd\"]\n",
    )
    .unwrap();
    let out = dir.path().join("swo");
    ok(gloam(&[&"sweep", &sweep, &"--out", &out]));
    let rec = json(&out.join("tasks/00000/task.json"));
    let place = std::fs::canonicalize(dir.path().join("place.csv")).unwrap();
    assert_eq!(
        rec["inputs"][place.display().to_string()].as_str(),
        Some(sha256sum(&place).as_str()),
        "{rec}"
    );
    let err = ok(gloam(&[&"sweep", &sweep, &"--out", &out]));
    assert!(err.contains("0 ran, 2 already done"), "{err}");
    // An instance CSV the scene reads is edited: both records are stale.
    std::fs::write(&place, "x,y,z,rotate_z_deg,scale\n0,0,0.7,0,1\n").unwrap();
    let err = ok(gloam(&[&"sweep", &sweep, &"--out", &out]));
    assert!(err.contains("2 ran, 0 already done"), "{err}");
    assert!(
        err.contains("record is stale") && err.contains("place.csv changed"),
        "{err}"
    );
}

/// The shipped sphere source (the calibration rig of the tour).
const SPHERE: &str = include_str!("../sims/calibration/sphere.toml");

#[test]
fn apply_refuses_a_lut_of_another_camera_or_bit_depth() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("sphere.toml"), SPHERE).unwrap();
    let cam = "sim:scientific-ccd?size=48x48&seed=3";
    let cal = d.join("cal");
    ok(gloam(&[
        &"calibrate",
        &"radiance",
        &"--grabber",
        &cam,
        &"--source",
        &d.join("sphere.toml"),
        &"--gains",
        &"1,2",
        &"--levels",
        &"8",
        &"--frames",
        &"4",
        &"--auto-range",
        &"0.8",
        &"--out",
        &cal,
    ]));
    let lut = cal.join("lut.json");
    // The LUT's manifest hashes the calibration source it read.
    let listed = inputs(&json(&cal.join("manifest.json"))["provenance"]);
    let src = std::fs::canonicalize(d.join("sphere.toml")).unwrap();
    assert!(
        listed.contains(&(src.clone(), sha256sum(&src))),
        "{listed:?}"
    );
    let tif = d.join("r.tiff");
    let capture = |grabber: &str, extra: &[&str], out: &Path| {
        let mut c = Command::new(BIN);
        c.args(["capture", "--grabber", grabber, "--frames", "1"])
            .args(extra)
            .arg("--out")
            .arg(out);
        ok(c.output().unwrap());
    };
    // Its own camera: applied.
    let same = d.join("same");
    capture(cam, &["--gain", "2"], &same);
    ok(gloam(&[
        &"calibrate",
        &"apply",
        &"--lut",
        &lut,
        &same.join("frame-000000.png"),
        &tif,
    ]));
    // Another camera: refused, naming both.
    let other = d.join("other");
    capture(
        "sim:gen3-gaas-iccd?size=48x48&seed=3",
        &["--gain", "20"],
        &other,
    );
    let err = refused(gloam(&[
        &"calibrate",
        &"apply",
        &"--lut",
        &lut,
        &other.join("frame-000000.png"),
        &tif,
    ]));
    assert!(
        err.contains("camera 'simulated scientific-ccd'")
            && err.contains("'simulated gen3-gaas-iccd'"),
        "{err}"
    );
    // Another bit depth (an 8-bit capture through a 16-bit LUT): refused.
    let eight = d.join("eight");
    capture(cam, &["--gain", "2", "--bits", "8"], &eight);
    let err = refused(gloam(&[
        &"calibrate",
        &"apply",
        &"--lut",
        &lut,
        &eight.join("frame-000000.png"),
        &tif,
    ]));
    assert!(err.contains("8-bit") && err.contains("65535"), "{err}");
    // A gain the frame's record contradicts: refused, naming the record.
    let err = refused(gloam(&[
        &"calibrate",
        &"apply",
        &"--gain",
        &"1",
        &"--lut",
        &lut,
        &same.join("frame-000000.png"),
        &tif,
    ]));
    assert!(err.contains("frames.jsonl:1 records gain 2"), "{err}");
}
