//! Whole output sets with provenance, and a closed stdout (issue 13):
//! a set appears at once with `manifest.json`, a used `--out` is refused
//! without `--force`, a killed run never leaves a set that mixes runs, and
//! every report names the version, commit, command and hashed inputs.

mod common;
use std::io::Read;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_gloam");

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("sims/{name}/scene.toml"))
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("running gloam")
}

fn json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// Independent SHA-256 via coreutils, when present.
fn sha256sum(path: &Path) -> Option<String> {
    let out = Command::new("sha256sum").arg(path).output().ok()?;
    Some(
        String::from_utf8_lossy(&out.stdout)
            .split_whitespace()
            .next()?
            .to_string(),
    )
}

#[test]
fn a_render_is_published_whole_with_a_manifest_and_provenance() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("panel");
    let scene = scene("panel-validation");
    let args = [
        "render",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--spp",
        "1",
    ];
    let o = run(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let m = json(&out.join("manifest.json"));
    assert_eq!(m["complete"], true);
    let files: Vec<&str> = m["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["path"].as_str().unwrap())
        .collect();
    for f in [
        "radiance.tiff",
        "radiance.npy",
        "report.json",
        "preview.png",
    ] {
        assert!(files.contains(&f), "{f} missing from {files:?}");
    }
    // The manifest's hashes are the files' (checked with coreutils).
    for f in m["files"].as_array().unwrap() {
        let p = out.join(f["path"].as_str().unwrap());
        if let Some(h) = sha256sum(&p) {
            assert_eq!(f["sha256"].as_str().unwrap(), h, "{}", p.display());
        }
        // Created with the umask's mode, not tempfile's 0600.
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_ne!(mode & 0o044, 0, "{} has mode {mode:o}", p.display());
    }
    // Provenance: version, commit, command line, the scene hashed.
    let p = &json(&out.join("report.json"))["provenance"];
    assert_eq!(p["gloam_version"], env!("CARGO_PKG_VERSION"));
    assert!(p["git_commit"].as_str().is_some_and(|c| !c.is_empty()));
    assert_eq!(p["command_line"][1], "render");
    let input = p["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|i| i["path"] == scene.to_str().unwrap())
        .expect("the scene is among the inputs");
    if let Some(h) = sha256sum(&scene) {
        assert_eq!(input["sha256"].as_str().unwrap(), h);
    }
    // No staging directory is left beside the set.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["panel".to_string()]);

    // A used --out is refused, naming --force; nothing changes.
    let before = std::fs::read(out.join("radiance.npy")).unwrap();
    let o = run(&args);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("not empty") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(std::fs::read(out.join("radiance.npy")).unwrap(), before);

    // --force replaces only a previous gloam set: a file the set did not
    // write (not in its manifest) makes it refuse, naming the file, which
    // stays as it was.
    std::fs::write(out.join("notes.txt"), b"mine").unwrap();
    let mut forced = args.to_vec();
    forced.extend(["--seed", "7", "--force"]);
    let o = run(&forced);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("notes.txt"), "{err}");
    assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"mine");
    assert_eq!(std::fs::read(out.join("radiance.npy")).unwrap(), before);
    // Without it, --force replaces the set whole: another seed, a
    // different image.
    std::fs::remove_file(out.join("notes.txt")).unwrap();
    let o = run(&forced);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_ne!(std::fs::read(out.join("radiance.npy")).unwrap(), before);
}

#[test]
fn force_never_deletes_the_inputs_or_what_gloam_did_not_write() {
    // The scene's own folder as --out (`gloam render sd/s.toml --out sd
    // --force`), and merge's input tile as its --out: refused, untouched.
    let dir = tempfile::tempdir().unwrap();
    let sd = dir.path().join("sd");
    std::fs::create_dir(&sd).unwrap();
    let s = sd.join("s.toml");
    std::fs::copy(scene("panel-validation"), &s).unwrap();
    let before = std::fs::read(&s).unwrap();
    let o = run(&[
        "render",
        s.to_str().unwrap(),
        "--out",
        sd.to_str().unwrap(),
        "--force",
        "--spp",
        "1",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("input") || err.contains("s.toml"), "{err}");
    assert_eq!(std::fs::read(&s).unwrap(), before);

    let t1 = dir.path().join("t1");
    let o = run(&[
        "render",
        s.to_str().unwrap(),
        "--out",
        t1.to_str().unwrap(),
        "--spp",
        "1",
        "--tile",
        "1/2",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let tile = std::fs::read(t1.join("radiance.npy")).unwrap();
    let t2 = dir.path().join("t2");
    let o = run(&[
        "render",
        s.to_str().unwrap(),
        "--out",
        t2.to_str().unwrap(),
        "--spp",
        "1",
        "--tile",
        "2/2",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(&[
        "merge",
        t1.to_str().unwrap(),
        t2.to_str().unwrap(),
        "--out",
        t1.to_str().unwrap(),
        "--force",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("holds the input"), "{err}");
    assert_eq!(std::fs::read(t1.join("radiance.npy")).unwrap(), tile);

    // A symbolic link as --out: refused with --force too; the link stays.
    let link = dir.path().join("link");
    std::os::unix::fs::symlink(&t1, &link).unwrap();
    let o = run(&[
        "render",
        s.to_str().unwrap(),
        "--out",
        link.to_str().unwrap(),
        "--force",
        "--spp",
        "1",
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("symbolic link"));
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
}

#[test]
fn a_killed_render_leaves_the_previous_set_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("office");
    // The previous set: a quick render published there.
    let panel = scene("panel-validation");
    let o = run(&[
        "render",
        panel.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--spp",
        "1",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let previous = std::fs::read(out.join("radiance.npy")).unwrap();
    let mut previous_names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    previous_names.sort();
    let scene = scene("office-room");
    let mut child = Command::new(BIN)
        .args([
            "render",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--force",
            "--spp",
            "64",
        ])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait until it is staging, then kill it hard.
    let t0 = Instant::now();
    let staging = loop {
        let s = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok())
            .find(|e| e.file_name().to_string_lossy().contains(".partial-"));
        if let Some(s) = s {
            break s.path();
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "no staging directory appeared"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    std::thread::sleep(Duration::from_millis(300));
    child.kill().unwrap();
    child.wait().unwrap();
    // The old set is whole and alone; the partial one is hidden and has no
    // manifest, so nothing takes it for a finished set.
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, previous_names);
    assert_eq!(std::fs::read(out.join("radiance.npy")).unwrap(), previous);
    assert!(!staging.join("manifest.json").exists());
}

#[test]
fn a_closed_stdout_ends_a_command_quietly() {
    let scene = scene("office-room");
    for args in [
        vec!["plan", scene.to_str().unwrap()],
        vec!["sensor", "list"],
        vec!["spectra", "list"],
    ] {
        let mut child = Command::new(BIN)
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Close the read end at once, as `| true` does.
        drop(child.stdout.take());
        let status = child.wait().unwrap();
        let mut err = String::new();
        child
            .stderr
            .take()
            .unwrap()
            .read_to_string(&mut err)
            .unwrap();
        assert!(status.success(), "gloam {args:?}: {status}, stderr: {err}");
        assert!(!err.contains("panicked"), "gloam {args:?}: {err}");
    }
}

/// The command's own words are not inputs: `gloam render … --out render
/// --force` run where a previous set `render/` exists (relative paths, as
/// a user in the tour types `gloam calibrate agc … --out agc`) replaces
/// it, while a positional input of the same name still protects it.
#[test]
fn a_subcommand_word_is_not_an_input_even_where_its_directory_exists() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene("panel-validation");
    let render = |extra: &[&str]| {
        Command::new(BIN)
            .current_dir(dir.path())
            .args([
                "render",
                s.to_str().unwrap(),
                "--out",
                "render",
                "--spp",
                "1",
            ])
            .args(extra)
            .output()
            .expect("running gloam")
    };
    let o = render(&[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = render(&["--force"]);
    assert!(
        o.status.success(),
        "the word `render` was taken for an input: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    // `gloam render render --out render --force`, where `render` is a
    // directory holding the scene: the positional `render`… is an input
    // path here (the second word), so the set is refused and untouched.
    let before = std::fs::read(dir.path().join("render/radiance.npy")).unwrap();
    std::fs::copy(&s, dir.path().join("render/s.toml")).unwrap();
    let o = Command::new(BIN)
        .current_dir(dir.path())
        .args(["render", "render/s.toml", "--out", "render", "--force"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("input"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let after = std::fs::read(dir.path().join("render/radiance.npy")).unwrap();
    assert_eq!(before, after);
}

/// A capture stopped by SIGTERM publishes its frames with the reason, and
/// the reason does not say "Ctrl-C" alone: one handler takes SIGINT,
/// SIGTERM and SIGHUP without knowing which came (round 9).
#[test]
fn a_terminated_capture_says_it_was_a_signal_not_only_ctrl_c() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cap");
    let mut child = Command::new(BIN)
        .args([
            "capture",
            "--grabber",
            "sim:gen3-gaas-iccd?size=64x64",
            "--frames",
            "1000000",
            "--out",
            out.to_str().unwrap(),
        ])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait until frames are being written, then send SIGTERM.
    let t0 = Instant::now();
    loop {
        let writing = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".partial-"))
            .any(|e| e.path().join("frame-000001.png").exists());
        if writing {
            break;
        }
        assert!(t0.elapsed() < Duration::from_secs(60), "no frames appeared");
        std::thread::sleep(Duration::from_millis(20));
    }
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    child.wait().unwrap();
    let m = json(&out.join("manifest.json"));
    assert_eq!(m["complete"], Value::Bool(false), "{m}");
    let why = m["stopped_because"].as_str().unwrap_or_default();
    assert!(why.contains("SIGTERM"), "stopped_because: {why}");
}

/// Issue 46, round 12: under `ulimit -f` a write past the limit raised
/// SIGXFSZ, which ended the run without a word (exit 153) and left its
/// staging directory. Now the write fails (`EFBIG`): an error naming the
/// file, and nothing left behind.
#[test]
fn a_file_size_limit_is_an_error_that_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let mut cmd = Command::new(BIN);
    cmd.args(["render", "--spp", "1", "--out"])
        .arg(&out)
        .arg(scene("office-room"))
        .args(["--set", "resolution_scale=0.25"]);
    common::limited(&mut cmd, libc::RLIMIT_FSIZE, 4096);
    let o = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("error:") && err.contains("File too large"),
        "{err}"
    );
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}
