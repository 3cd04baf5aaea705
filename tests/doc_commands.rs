//! Every `sh`/`bash` command block in the README and the docs (`docs/`,
//! `crates/*/README.md`, `sims/**/README.md`, …) runs as written, so the
//! documentation cannot drift from the binary; a ```` ```console run ````
//! block's `$ ` commands run too and must print what the block shows
//! under them. Every other block that shows a command is listed in
//! [`NOT_RUN`] with the reason, and every command that writes writes
//! under `out/` and can be run again ([`every_shown_command_runs_or_says_why_not`]).
//!
//! Blocks run in document order (a block repeated word for word runs
//! once), one `bash -euo pipefail` per block, in a
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
    let mut seen: std::collections::HashMap<String, (String, usize)> = Default::default();
    // What the scratch directory may hold besides the links: `out/` and
    // the files `file=` blocks write.
    let mut allowed: Vec<String> = LINKED.iter().map(|s| s.to_string()).collect();
    allowed.push("out".into());
    for f in files {
        for b in blocks(f) {
            let mut words = b.info.split_whitespace();
            let lang = words.next().unwrap_or_default();
            let rest: Vec<&str> = words.collect();
            if let Some(name) = rest.iter().find_map(|w| w.strip_prefix("file=")) {
                std::fs::write(dir.path().join(name), &b.text).unwrap();
                allowed.push(name.to_string());
                continue;
            }
            let rel = b
                .file
                .strip_prefix(repo())
                .unwrap_or(&b.file)
                .display()
                .to_string();
            if lang == "console" && rest.contains(&"run") {
                run_console(&b, &rel, dir.path(), &path);
                check_writes_under_out(dir.path(), &allowed, &rel, b.line);
                ran += 1;
                continue;
            }
            if lang != "sh" && lang != "bash" {
                continue;
            }
            // A block shown again word for word (a sample's README and the
            // guide that walks through it) has run in this directory: its
            // outputs are there, as the reader's would be.
            if let Some((first, at)) = seen.get(&b.text) {
                eprintln!(
                    "{rel}:{}: ok (the block of {first}:{at}, already run)",
                    b.line
                );
                ran += 1;
                continue;
            }
            seen.insert(b.text.clone(), (rel.clone(), b.line));
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
            check_writes_under_out(dir.path(), &allowed, &rel, b.line);
            ran += 1;
        }
    }
    assert!(ran > 0, "no command blocks found in {files:?}");
}

/// A block may leave files only under `out/` (ignored by git): anything
/// else in the scratch directory is a command a user would run that
/// litters the checkout.
fn check_writes_under_out(dir: &Path, allowed: &[String], rel: &str, line: usize) {
    let stray: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !allowed.contains(n))
        .collect();
    assert!(
        stray.is_empty(),
        "{rel}:{line}: the block wrote {stray:?} outside out/ (doc commands write under out/, which git ignores)"
    );
}

/// A ```` ```console run ```` block: each `$ COMMAND` line runs (as the
/// `sh` blocks do) and its stdout must be the lines below it, up to the
/// next `$ ` line (trailing spaces and blank lines aside).
fn run_console(b: &Block, rel: &str, dir: &Path, path: &str) {
    let mut steps: Vec<(String, Vec<String>)> = Vec::new();
    for line in b.text.lines() {
        match line.strip_prefix("$ ") {
            Some(cmd) => steps.push((cmd.to_string(), Vec::new())),
            None => match steps.last_mut() {
                Some((_, want)) => want.push(line.trim_end().to_string()),
                None => panic!(
                    "{rel}:{}: console text before its first `$ ` command",
                    b.line
                ),
            },
        }
    }
    assert!(
        !steps.is_empty(),
        "{rel}:{}: a console block without a `$ ` command",
        b.line
    );
    for (cmd, want) in steps {
        let script = format!("{PRELUDE}\n{cmd}");
        let out = Command::new("bash")
            .args(["-euo", "pipefail", "-c", &script])
            .current_dir(dir)
            .env("PATH", path)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{rel}:{}: `{cmd}` failed ({}):\n{}",
            b.line,
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        let trim = |v: Vec<String>| {
            let mut v = v;
            while v.last().is_some_and(|l| l.is_empty()) {
                v.pop();
            }
            v
        };
        let got = trim(
            String::from_utf8_lossy(&out.stdout)
                .lines()
                .map(|l| l.trim_end().to_string())
                .collect(),
        );
        let want = trim(want);
        assert!(
            got == want,
            "{rel}:{}: `{cmd}` prints\n{}\nbut the block shows\n{}",
            b.line,
            got.join("\n"),
            want.join("\n")
        );
    }
    eprintln!("{rel}:{}: ok (console)", b.line);
}

#[test]
fn readme_command_blocks_run() {
    run_blocks(&[repo().join("README.md")]);
}

/// The documentation besides the README: `docs/`, every crate's
/// Markdown, the sample scenes' READMEs, the protocol and fuzzing notes.
fn doc_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = ["docs", "crates", "sims"]
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
    files
}

#[test]
fn docs_command_blocks_run() {
    run_blocks(&doc_files());
}

/// Blocks that show commands and are not run here, each with why: the
/// block's file and the start of its first command line. A block that
/// shows a command and is neither run nor listed fails
/// [`every_shown_command_runs_or_says_why_not`], as does an entry that no
/// longer matches a block.
const NOT_RUN: &[(&str, &str, &str)] = &[
    (
        "docs/bench.md",
        "gloam bench accuracy sims/office-room",
        "20 minutes of rendering; the same flags run on the panel in the sh block above it",
    ),
    (
        "docs/gige.md",
        "gloam device --gige 192.168.1.10",
        "serves on a real network interface; tests run GigE only on loopback in a private namespace",
    ),
    (
        "docs/gige.md",
        "arv-camera-test-0.8 --chunks",
        "needs a GigE device serving; tests/genicam_aravis.rs runs it against gloam's device",
    ),
    (
        "docs/gige.md",
        "cargo build --release --features genicam",
        "needs the genicam build (libaravis); tests/genicam_aravis.rs runs the same capture and calibration",
    ),
    ("docs/hardware.md", "gloam device --pty [", "a synopsis"),
    (
        "docs/hardware.md",
        "gloam capture --grabber URI",
        "a synopsis",
    ),
    ("docs/night-sky.md", "gloam ephem --lat DEG", "a synopsis"),
    ("docs/night-sky.md", "gloam sky --lat DEG", "a synopsis"),
    (
        "docs/python.md",
        "pip install ./python",
        "builds and installs the wheel from PyPI packages; CI runs it as bash python/test.sh",
    ),
    (
        "docs/sweep.md",
        "gloam sweep sims/sweeps/validation.toml",
        "timings of a long sweep on two machines, as measured",
    ),
    (
        "docs/sweep.md",
        "export RAYON_NUM_THREADS=8",
        "a line of a Slurm batch script",
    ),
    (
        "python/README.md",
        "pip install ./python",
        "builds and installs the wheel from PyPI packages; CI runs it as bash python/test.sh",
    ),
    (
        "sims/night-town/README.md",
        "python3 sims/night-town/generate.py  ",
        "rewrites the committed scene in the checkout (byte-identical); the variants run in the sh block below it",
    ),
];

/// The commands `--force` lets re-run over their previous `--out` set
/// (`gloam sweep` resumes into its directory instead).
const FORCE_COMMANDS: &[&str] = &[
    "gloam render ",
    "gloam sequence ",
    "gloam capture ",
    "gloam calibrate ",
    "gloam scope ",
    "gloam merge ",
    "gloam bench accuracy ",
];

/// Every command the documentation shows runs in a test or is listed in
/// [`NOT_RUN`] with why; each one run writes under `out/` and carries
/// `--force` where its command refuses an existing `--out` without it, so
/// a user can run the docs again.
#[test]
fn every_shown_command_runs_or_says_why_not() {
    let mut files = doc_files();
    files.push(repo().join("README.md"));
    files.push(repo().join("python/README.md"));
    let command = |l: &str| {
        let l = l.trim_start().trim_start_matches("$ ");
        [
            "gloam ", "cargo ", "python3 ", "pip ", "bash ", "arv-", "export ",
        ]
        .iter()
        .any(|p| l.starts_with(p))
    };
    let mut matched = vec![false; NOT_RUN.len()];
    let mut problems = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(repo()).unwrap().display().to_string();
        for b in blocks(f) {
            let mut words = b.info.split_whitespace();
            let lang = words.next().unwrap_or_default();
            let rest: Vec<&str> = words.collect();
            if rest.iter().any(|w| w.starts_with("file=")) {
                continue;
            }
            let runs =
                lang == "sh" || lang == "bash" || (lang == "console" && rest.contains(&"run"));
            if !runs {
                let Some(first) = b.text.lines().find(|l| command(l)) else {
                    continue;
                };
                let first = first.trim_start().trim_start_matches("$ ");
                match NOT_RUN
                    .iter()
                    .position(|(file, start, _)| *file == rel && first.starts_with(start))
                {
                    Some(i) => matched[i] = true,
                    None => problems.push(format!(
                        "{rel}:{}: shows `{first}` in a block that is not run: make it ```sh (or ```console run), or list it in NOT_RUN with why",
                        b.line
                    )),
                }
                continue;
            }
            // Logical lines (continuations joined), comments dropped.
            let joined = b.text.replace("\\\n", " ");
            for line in joined.lines() {
                let code = line.trim_start().trim_start_matches("$ ");
                let code = code.split(" #").next().unwrap_or("");
                for part in code.split("&&") {
                    let part = part.trim();
                    let words: Vec<&str> = part.split_whitespace().collect();
                    if let Some(i) = words.iter().position(|w| *w == "--out") {
                        let target = words.get(i + 1).copied().unwrap_or("");
                        if !target.trim_matches('"').starts_with("out/") {
                            problems.push(format!(
                                "{rel}:{}: `{part}` writes --out {target}, not under out/",
                                b.line
                            ));
                        }
                        if FORCE_COMMANDS.iter().any(|c| part.starts_with(c))
                            && !words.contains(&"--force")
                        {
                            problems.push(format!(
                                "{rel}:{}: `{part}` cannot run again without --force",
                                b.line
                            ));
                        }
                    }
                    // `calibrate apply`'s OUTPUT is its last word: in out/
                    // itself, never inside a set another command published
                    // (a file its manifest does not list makes the set not
                    // gloam's, and --force then refuses to replace it).
                    if part.starts_with("gloam calibrate apply ")
                        && !words.last().is_some_and(|w| {
                            w.strip_prefix("out/").is_some_and(|n| !n.contains('/'))
                        })
                    {
                        problems.push(format!(
                            "{rel}:{}: `{part}` writes its OUTPUT elsewhere than directly in out/",
                            b.line
                        ));
                    }
                }
            }
        }
    }
    for (i, m) in matched.iter().enumerate() {
        if !m {
            problems.push(format!(
                "NOT_RUN entry {:?} matches no block: remove it",
                NOT_RUN[i]
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
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

/// The README's set-up names the same Debian packages `.ci/run` installs.
#[test]
fn readme_set_up_lists_the_packages_ci_installs() {
    let packages = |text: &str, after: &str| -> Vec<String> {
        let start = text.find(after).unwrap_or_else(|| panic!("no `{after}`")) + after.len();
        let mut out: Vec<String> = text[start..]
            .replace("\\\n", " ")
            .lines()
            .next()
            .unwrap_or_default()
            .split_whitespace()
            .take_while(|w| !w.starts_with('>'))
            .filter(|w| !w.starts_with('-'))
            .map(str::to_string)
            .collect();
        out.sort();
        out
    };
    let ci = std::fs::read_to_string(repo().join(".ci/run")).unwrap();
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    let want = packages(&ci, "apt-get install -y -qq");
    assert!(want.len() >= 10, "{want:?}");
    assert_eq!(packages(&readme, "\napt-get install"), want);
}
