//! Shared by the Aravis tests: is Aravis there (or must it be), and a
//! private network namespace with loopback alone for each device + client
//! run, so GigE Vision discovery broadcasts never leave the test.
#![allow(dead_code)]

use std::path::Path;
use std::process::Command;

pub const BIN: &str = env!("CARGO_BIN_EXE_gloam");

/// True when everything needed is there; otherwise a loud notice, and a
/// failure if Aravis is required.
pub fn aravis_ready(test: &str, tools: &[&str]) -> bool {
    let mut missing: Vec<String> = tools
        .iter()
        .filter(|t| {
            !Command::new("sh")
                .args(["-c", &format!("command -v {t}")])
                .output()
                .is_ok_and(|o| o.status.success())
        })
        .map(|t| t.to_string())
        .collect();
    let netns = Command::new("unshare")
        .args(["-n", "true"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !netns {
        missing.push("a private network namespace (unshare -n: needs root)".into());
    }
    if missing.is_empty() {
        return true;
    }
    let msg = format!(
        "\n!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!\n\
         !!! {test}: NOT RUN — missing {}\n\
         !!! install: apt-get install aravis-tools aravis-tools-cli libaravis-dev libusb-1.0-0-dev\n\
         !!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!\n",
        missing.join(", ")
    );
    eprintln!("{msg}");
    assert!(
        std::env::var("GLOAM_REQUIRE_ARAVIS").as_deref() != Ok("1"),
        "GLOAM_REQUIRE_ARAVIS=1 but {test} cannot run: {msg}"
    );
    false
}

pub struct NetnsRun {
    pub stdout: String,
    pub stderr: String,
    pub device_stderr: String,
    pub ok: bool,
}

/// Runs `client` (a shell command) next to `gloam device --gige 127.0.0.1
/// DEVICE_ARGS` inside a fresh network namespace with loopback only.
pub fn in_netns(dir: &Path, device_args: &str, client: &str, timeout_s: u32) -> NetnsRun {
    in_netns_with(
        dir,
        &format!(r#""$GLOAM" device --gige 127.0.0.1 {device_args}"#),
        r#"[ -s "$DIR/dev.out" ]"#,
        client,
        timeout_s,
    )
}

/// Runs `client` next to the device started by the shell command `device`
/// (its stdout and stderr go to `$DIR/dev.out`, `$DIR/dev.err`) once
/// `ready` (a shell test) holds, inside a fresh network namespace with
/// loopback only; `$GLOAM` is the gloam binary, `$DIR` the scratch dir.
pub fn in_netns_with(
    dir: &Path,
    device: &str,
    ready: &str,
    client: &str,
    timeout_s: u32,
) -> NetnsRun {
    let script = format!(
        r#"set -u
ip link set lo up || exit 90
{device} >"$DIR/dev.out" 2>"$DIR/dev.err" &
DEV=$!
i=0
while ! {ready} && [ $i -lt 300 ]; do sleep 0.1; i=$((i+1)); done
{client}
RC=$?
kill $DEV 2>/dev/null
wait $DEV 2>/dev/null
exit $RC
"#
    );
    std::fs::write(dir.join("run.sh"), script).expect("write script");
    let out = Command::new("timeout")
        .arg(timeout_s.to_string())
        .args(["unshare", "-n", "sh"])
        .arg(dir.join("run.sh"))
        .env("GLOAM", BIN)
        .env("DIR", dir)
        .output()
        .expect("run unshare");
    NetnsRun {
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        device_stderr: std::fs::read_to_string(dir.join("dev.err")).unwrap_or_default(),
        ok: out.status.success(),
    }
}

/// CRCs of frames 0.. from `gloam capture --grabber sim:…`.
pub fn sim_crcs(dir: &Path, uri: &str, frames: u32, extra: &[&str]) -> Vec<u32> {
    let out_dir = dir.join("sim");
    let out = Command::new(BIN)
        .args([
            "capture",
            "--grabber",
            uri,
            "--frames",
            &frames.to_string(),
            "--out",
        ])
        .arg(&out_dir)
        .args(extra)
        .output()
        .expect("gloam capture");
    assert!(
        out.status.success(),
        "gloam capture: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::read_to_string(out_dir.join("frames.jsonl"))
        .expect("frames.jsonl")
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).expect("json");
            v["pixels_crc32c"].as_u64().expect("crc") as u32
        })
        .collect()
}
