//! Where an output came from: the gloam version and commit, the command
//! line, the UTC time, and every input file with its SHA-256 — those named
//! on the command line and every file the run read through
//! `gloam_io` (scene, OBJ, spectra, instance CSVs, sensor
//! files, LUTs, regions, sweep files, calibration sources, tiles) —
//! recorded in every report, calibration file and manifest.

use std::path::Path;

use gloam_io::{InputFile, hash_file};
use serde::Serialize;

/// The provenance block of an output.
#[derive(Clone, Debug, Serialize)]
pub struct Provenance {
    pub gloam_version: &'static str,
    /// `git rev-parse HEAD` at build time (`unknown` outside a checkout).
    pub git_commit: &'static str,
    /// The full command line, as given.
    pub command_line: Vec<String>,
    /// When the run started, ISO-8601 UTC.
    pub utc: String,
    /// Every existing regular file named by a command-line word (or the
    /// value of a `--flag=VALUE` or `KEY=VALUE` word), then every other
    /// file the run read (see [`Provenance::add_inputs_read`]), hashed.
    pub inputs: Vec<InputFile>,
    /// Files read past `gloam_io::MAX_RECORDED_READS`, not
    /// listed.
    #[serde(skip_serializing_if = "is_zero")]
    pub inputs_not_listed: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// `gloam --version`: the version and the commit it was built from.
pub const VERSION_WITH_COMMIT: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("GLOAM_GIT_COMMIT"),
    ")"
);

impl Provenance {
    /// The provenance of this process's run.
    pub fn of_this_run() -> Self {
        // As the OS gave them: a path need not be UTF-8 (the command line
        // is recorded lossily, the files are found by their own bytes).
        use std::os::unix::ffi::OsStrExt;
        let words: Vec<std::ffi::OsString> = std::env::args_os().collect();
        let candidates = words
            .iter()
            .skip(1)
            .map(|w| {
                let b = w.as_bytes();
                let v = b.rsplit(|&c| c == b'=').next().unwrap_or(b);
                std::path::PathBuf::from(std::ffi::OsStr::from_bytes(v))
            })
            .collect();
        let lossy = words
            .iter()
            .map(|w| w.to_string_lossy().into_owned())
            .collect();
        Self::of_words(lossy, candidates)
    }

    /// The provenance of a run with `command_line` (its first word the
    /// program).
    pub fn of_command_line(command_line: Vec<String>) -> Self {
        let candidates = command_line
            .iter()
            .skip(1)
            .map(|w| w.rsplit_once('=').map_or(w.as_str(), |(_, v)| v).into())
            .collect();
        Self::of_words(command_line, candidates)
    }

    /// `command_line` as recorded, with each word's (after an `=`, its
    /// value's) path: those that name regular files are hashed.
    fn of_words(command_line: Vec<String>, candidates: Vec<std::path::PathBuf>) -> Self {
        let mut inputs: Vec<InputFile> = Vec::new();
        let mut seen: Vec<&Path> = Vec::new();
        for path in &candidates {
            if !path.is_file() || seen.contains(&path.as_path()) {
                continue;
            }
            seen.push(path);
            if let Some(f) = hash_file(path) {
                inputs.push(f);
            }
        }
        Self {
            gloam_version: env!("CARGO_PKG_VERSION"),
            git_commit: env!("GLOAM_GIT_COMMIT"),
            command_line,
            utc: utc_now(),
            inputs,
            inputs_not_listed: 0,
        }
    }

    /// Adds every file read so far through `gloam_io` (since
    /// `record_reads`) that is not listed yet — the same file reached by
    /// another path counts once. A file read whole is listed with the hash
    /// of the bytes the run read; a streamed one is hashed now.
    pub fn add_inputs_read(&mut self) {
        let canon = |p: &str| std::fs::canonicalize(p).unwrap_or_else(|_| p.into());
        let mut seen: std::collections::HashSet<std::path::PathBuf> =
            self.inputs.iter().map(|i| canon(&i.path)).collect();
        for r in gloam_io::reads() {
            let c = std::fs::canonicalize(&r.path).unwrap_or_else(|_| r.path.clone());
            if !seen.insert(c) {
                continue;
            }
            let f = match r.sha256 {
                Some(sha256) => Some(InputFile {
                    path: r.path.display().to_string(),
                    bytes: r.bytes,
                    sha256,
                }),
                None => hash_file(&r.path),
            };
            self.inputs.extend(f);
        }
        self.inputs_not_listed = gloam_io::reads_not_recorded();
    }
}

impl gloam_io::ManifestProvenance for Provenance {
    fn add_inputs_read(&mut self) {
        Provenance::add_inputs_read(self);
    }
}

/// SHA-256 of bytes, hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    gloam_io::sha256_hex(bytes)
}

/// The current time, ISO-8601 UTC to the millisecond.
pub fn utc_now() -> String {
    let unix_s = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64());
    // JD 2440587.5 is the Unix epoch.
    gloam_sky::time::UtcInstant::from_julian_date(unix_s / 86_400.0 + 2_440_587.5)
        .map(|t| t.to_iso8601())
        .unwrap_or_else(|_| format!("unix {unix_s:.3} s"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_abc_is_the_fips_180_2_example() {
        // FIPS 180-2, appendix B.1.
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn inputs_are_the_existing_files_named_on_the_command_line() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("scene.toml");
        std::fs::write(&f, b"abc").unwrap();
        let p = Provenance::of_command_line(vec![
            "gloam".into(),
            "render".into(),
            f.display().to_string(),
            format!("--lut={}", f.display()),
            "--out".into(),
            dir.path().join("missing").display().to_string(),
        ]);
        assert_eq!(p.inputs.len(), 1, "{:?}", p.inputs);
        assert_eq!(p.inputs[0].bytes, 3);
        assert_eq!(p.inputs[0].sha256, sha256_hex(b"abc"));
        // ISO-8601 with a Z.
        assert!(p.utc.ends_with('Z') && p.utc.contains('T'), "{}", p.utc);
    }
}
