//! Every file gloam reads goes through the one bounded reader
//! (`gloam_io`: regular files only, a size limit per kind, a
//! clear error for devices, FIFOs and directories). This test enumerates
//! the readers: it scans the program's sources (tests excluded) for direct
//! `std::fs` reads and `File::open`, so a new reader cannot bypass the
//! bounds unnoticed. Reads of `/proc` (fixed-size kernel files) are
//! allowed, as is the bounded reader itself.

use std::path::{Path, PathBuf};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// Patterns that read a file without bounds.
const UNBOUNDED: [&str; 4] = [
    "fs::read_to_string(",
    "fs::read(",
    "File::open(",
    "tobj::load_obj(",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            let name = p.file_name().unwrap_or_default().to_string_lossy();
            if name != "tests" && name != "target" && name != "benches" && name != "examples" {
                rust_files(&p, out);
            }
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn every_reader_is_the_bounded_one() {
    let root = Path::new(ROOT);
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    rust_files(&root.join("python/src"), &mut files);
    for c in std::fs::read_dir(root.join("crates")).unwrap().flatten() {
        rust_files(&c.path().join("src"), &mut files);
    }
    assert!(files.len() > 50, "found only {} source files", files.len());
    let allowed = root.join("crates/io/src/input.rs");
    let mut found = Vec::new();
    for f in files.iter().filter(|f| **f != allowed) {
        let text = std::fs::read_to_string(f).unwrap();
        // Unit tests sit after `#[cfg(test)]` at the end of a module.
        let code = text.split("#[cfg(test)]").next().unwrap_or("");
        for (i, line) in code.lines().enumerate() {
            let l = line.trim_start();
            if l.starts_with("//") || line.contains("\"/proc/") {
                continue;
            }
            if UNBOUNDED.iter().any(|p| line.contains(p)) {
                found.push(format!(
                    "{}:{}: {}",
                    f.strip_prefix(root).unwrap_or(f).display(),
                    i + 1,
                    l
                ));
            }
        }
    }
    assert!(
        found.is_empty(),
        "reads that bypass gloam_io (use read_bounded/read_text/open_bounded):\n{}",
        found.join("\n")
    );
}
