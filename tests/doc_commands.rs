//! Every `sh`/`bash` command block in the README and the docs runs as
//! written, so the documentation cannot drift from the binary.
//!
//! Blocks run in document order, one `bash -euo pipefail` per block, in a
//! scratch directory that links a fixed list of the checkout's tracked
//! top-level entries (`sims/`, `docs/`, …; never a user's leftovers), with the built `gloam` first on `PATH`. A block
//! such as ```` ```csv file=my-lamp.csv ```` is written to that file first,
//! so the commands that read it run too. `cargo run --release -- ARGS` runs
//! `gloam ARGS`; the other `cargo` commands (`cargo test`, `cargo fuzz`)
//! are CI's own steps (`.ci/run`) and are echoed, not re-run. Background
//! jobs a block starts (`gloam device … &`) are stopped when it ends. When
//! `unshare -n` works (root), every block runs in a private network
//! namespace with loopback only, so nothing a block starts reaches a
//! network.

use std::path::{Path, PathBuf};
use std::process::Command;

/// One fenced block: its file, first line and text.
struct Block {
    file: PathBuf,
    line: usize,
    info: String,
    text: String,
}

fn blocks(path: &Path) -> Vec<Block> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out = Vec::new();
    let mut open: Option<(usize, String, String)> = None;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        match &mut open {
            None if t.starts_with("```") => {
                open = Some((i + 2, t[3..].trim().to_string(), String::new()));
            }
            Some(_) if t.starts_with("```") => {
                let (line, info, text) = open.take().unwrap();
                out.push(Block {
                    file: path.to_path_buf(),
                    line,
                    info,
                    text,
                });
            }
            Some((_, _, body)) => {
                body.push_str(line);
                body.push('\n');
            }
            None => {}
        }
    }
    out
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The tracked top-level entries the documented commands read (sample
/// scenes, sensors, docs, sources). A fixed list, never a listing of the
/// checkout: a user's leftovers (a `cap-pty/` from running the README's
/// tour, an `out/`) must not change what the blocks see.
const LINKED: &[&str] = &[
    "sims",
    "docs",
    "crates",
    "python",
    "tools",
    "tests",
    "fuzz",
    "firmware-protocol",
    "src",
    "README.md",
    "Cargo.toml",
    "Cargo.lock",
];

/// A scratch directory linking [`LINKED`] from the checkout.
fn scratch() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for name in LINKED {
        let p = repo().join(name);
        if p.exists() {
            std::os::unix::fs::symlink(&p, dir.path().join(name)).unwrap();
        }
    }
    dir
}

fn private_network() -> bool {
    Command::new("unshare")
        .args(["-n", "true"])
        .status()
        .is_ok_and(|s| s.success())
}

const PRELUDE: &str = r#"
cargo() {
  if [ "${1:-}" = run ] && [ "${2:-}" = --release ] && [ "${3:-}" = -- ]; then
    shift 3; gloam "$@"
  else
    echo "(doc test: \`cargo $*\` is a CI step of its own, not re-run here)"
  fi
}
trap 'kill $(jobs -p) 2>/dev/null || true' EXIT
"#;

/// Runs every block of `files` in order; panics naming the first failure.
fn run_blocks(files: &[PathBuf]) {
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_gloam"));
    let path = format!(
        "{}:{}",
        bin.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let dir = scratch();
    let netns = private_network();
    if !netns {
        eprintln!("note: `unshare -n` is not available; doc blocks run without a private network");
    }
    let mut ran = 0;
    for f in files {
        for b in blocks(f) {
            let mut words = b.info.split_whitespace();
            let lang = words.next().unwrap_or_default();
            if let Some(name) = words.find_map(|w| w.strip_prefix("file=")) {
                std::fs::write(dir.path().join(name), &b.text).unwrap();
                continue;
            }
            if lang != "sh" && lang != "bash" {
                continue;
            }
            let script = format!(
                "{PRELUDE}\nip link set lo up 2>/dev/null || true\n{}",
                b.text
            );
            let mut cmd = if netns {
                let mut c = Command::new("unshare");
                c.args(["-n", "bash", "-euo", "pipefail", "-c", &script]);
                c
            } else {
                let mut c = Command::new("bash");
                c.args(["-euo", "pipefail", "-c", &script]);
                c
            };
            let t0 = std::time::Instant::now();
            let out = cmd
                .current_dir(dir.path())
                .env("PATH", &path)
                .output()
                .unwrap();
            let rel = b
                .file
                .strip_prefix(repo())
                .unwrap_or(&b.file)
                .display()
                .to_string();
            assert!(
                out.status.success(),
                "{rel}:{}: the command block failed ({}):\n{}\n--- stdout\n{}\n--- stderr\n{}",
                b.line,
                out.status,
                b.text,
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            eprintln!("{rel}:{}: ok ({:.1} s)", b.line, t0.elapsed().as_secs_f64());
            ran += 1;
        }
    }
    assert!(ran > 0, "no command blocks found in {files:?}");
}

#[test]
fn readme_command_blocks_run() {
    run_blocks(&[repo().join("README.md")]);
}

#[test]
fn docs_command_blocks_run() {
    let mut files: Vec<PathBuf> = ["docs", "crates"]
        .iter()
        .flat_map(|d| walk(&repo().join(d)))
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    files.extend(
        ["firmware-protocol/PROTOCOL.md", "fuzz/README.md"]
            .iter()
            .map(|p| repo().join(p)),
    );
    files.sort();
    run_blocks(&files);
}

/// Every file under `dir` (no symlinks followed).
fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(rd) = std::fs::read_dir(dir) else {
        return out;
    };
    for e in rd.flatten() {
        let p = e.path();
        match e.file_type() {
            Ok(t) if t.is_dir() => out.extend(walk(&p)),
            Ok(t) if t.is_file() => out.push(p),
            _ => {}
        }
    }
    out
}
