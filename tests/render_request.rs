//! `gloam render` and Python's `gloam.render` make one `RenderRequest`
//! (gloam-pipeline's `request.rs`) and refuse a bad one with one message:
//! the CLI's flags parse into the request the Python keywords build, and
//! each bad input below gives the CLI's `error: …` line word for word from
//! the request as Python builds it. (python/tests/test_api.py checks the
//! same through the Python package itself.)

use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use clap::Parser;
use gloam_pipeline::cli::RenderArgs;
use gloam_pipeline::request::{CameraOptions, OutputDir};
use gloam_pipeline::{RenderRequest, SceneInput, SettingArgs};

const SCENE: &str = "sims/panel-validation/scene.toml";

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    render: RenderArgs,
}

/// The request `gloam render SCENE --out OUT ARGS…` parses into.
fn cli_request(out: &Path, args: &[&str]) -> RenderRequest {
    let argv = ["gloam", SCENE, "--out", out.to_str().unwrap()];
    let cli = Cli::try_parse_from(argv.iter().chain(args)).expect("flags parse");
    cli.render.request()
}

/// The request `gloam.render(Scene.load(SCENE), …)` builds
/// (python/src/render.rs): the scene loaded, no output set.
fn python_request(settings: SettingArgs, sensor: Option<&str>) -> RenderRequest {
    let scene = Arc::new(
        gloam_scene::load(Path::new(SCENE), &gloam_io::ReadLog::off()).expect("scene loads"),
    );
    RenderRequest {
        settings,
        camera: CameraOptions {
            sensor: sensor.map(String::from),
            ..Default::default()
        },
        ..RenderRequest::new(SceneInput::Loaded {
            scene,
            path: SCENE.into(),
            load_s: 0.0,
        })
    }
}

/// The CLI's stderr for `args`.
fn cli_stderr(out: &Path, args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_gloam"))
        .args(["render", SCENE, "--out"])
        .arg(out)
        .args(args)
        .output()
        .expect("run gloam");
    assert!(!o.status.success(), "{args:?} was accepted");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_bad_input_is_refused_with_the_same_message_from_both_front_ends() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let set = |pairs: &[&str]| pairs.iter().map(|s| s.to_string()).collect();
    let cases: [(&[&str], SettingArgs, Option<&str>, &str); 4] = [
        (
            &["--sensor", "no-such-sensor"],
            SettingArgs::default(),
            Some("no-such-sensor"),
            "no-such-sensor",
        ),
        (
            &["--set", "spp=many"],
            SettingArgs {
                set: set(&["spp=many"]),
                ..Default::default()
            },
            None,
            "spp",
        ),
        (
            &["--set", "spp=2", "--spp", "3"],
            SettingArgs {
                spp: Some(3),
                set: set(&["spp=2"]),
                ..Default::default()
            },
            None,
            "both set spp",
        ),
        (
            &["--target-error", "camera", "--sensor", "none"],
            SettingArgs {
                target_error: Some(gloam_pipeline::camera_goal::TargetError::Camera { k: 0.3 }),
                ..Default::default()
            },
            Some("none"),
            "needs a camera",
        ),
    ];
    for (flags, settings, sensor, names) in cases {
        let py = python_request(settings, sensor);
        // The same request but for where the scene comes from and where
        // the files go.
        let cli = cli_request(&out, flags);
        assert_eq!(cli.scene.path(), py.scene.path());
        assert_eq!(
            cli.out,
            Some(OutputDir {
                path: out.clone(),
                force: false
            })
        );
        let same = RenderRequest {
            scene: py.scene.clone(),
            out: None,
            ..cli
        };
        assert_eq!(same, py, "{flags:?}");
        let Err(e) = py.validate(&gloam_io::ReadLog::new()) else {
            panic!("{flags:?} was accepted")
        };
        // As both front ends print it: anyhow's `{:#}` (the CLI's
        // `error: …`, Python's GloamError).
        let message = format!("{:#}", anyhow::Error::from(e));
        assert!(message.contains(names), "{flags:?}: {message}");
        let stderr = cli_stderr(&out, flags);
        assert!(
            stderr.contains(&format!("error: {message}\n")),
            "{flags:?}: the CLI said\n{stderr}\nPython says\n{message}"
        );
    }
    assert!(!out.exists(), "a refused render wrote {}", out.display());
}
