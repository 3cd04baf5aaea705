//! Where an output came from: the gloam version and commit, the command
//! line, the UTC time, and every input file with its SHA-256 — those named
//! on the command line and every file the run read through `gloam_io`
//! into its [`ReadLog`] (scene, OBJ, spectra, instance CSVs, sensor
//! files, LUTs, regions, sweep files, calibration sources, tiles) —
//! recorded in every report, calibration file and manifest. The log is
//! the run's own (made by whoever starts the run, the CLI or Python), so
//! two runs in one process keep their inputs apart.

use std::path::Path;

use gloam_io::{InputFile, ReadLog, hash_file};
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
    /// The run's reads, listed by [`Provenance::add_inputs_read`].
    #[serde(skip)]
    reads: ReadLog,
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
    /// The provenance of this process's run (its command line), whose
    /// reads go to `reads`.
    pub fn of_this_run(reads: &ReadLog) -> Self {
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
        Self::of_words(lossy, candidates, reads)
    }

    /// The provenance of a run with `command_line` (its first word the
    /// program), whose reads go to `reads`.
    pub fn of_command_line(command_line: Vec<String>, reads: &ReadLog) -> Self {
        let candidates = command_line
            .iter()
            .skip(1)
            .map(|w| w.rsplit_once('=').map_or(w.as_str(), |(_, v)| v).into())
            .collect();
        Self::of_words(command_line, candidates, reads)
    }

    /// `command_line` as recorded, with each word's (after an `=`, its
    /// value's) path: those that name regular files are hashed.
    fn of_words(
        command_line: Vec<String>,
        candidates: Vec<std::path::PathBuf>,
        reads: &ReadLog,
    ) -> Self {
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
            reads: reads.clone(),
        }
    }

    /// The log this run's reads go to.
    pub fn reads(&self) -> &ReadLog {
        &self.reads
    }

    /// Adds every file read so far into the run's log that is not listed
    /// yet — the same file reached by
    /// another path counts once. A file read whole is listed with the hash
    /// of the bytes the run read; a streamed one is hashed now.
    pub fn add_inputs_read(&mut self) {
        let canon = |p: &str| std::fs::canonicalize(p).unwrap_or_else(|_| p.into());
        let mut seen: std::collections::HashSet<std::path::PathBuf> =
            self.inputs.iter().map(|i| canon(&i.path)).collect();
        for r in self.reads.reads() {
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
        self.inputs_not_listed = self.reads.not_recorded();
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
        let log = ReadLog::new();
        let p = Provenance::of_command_line(
            vec![
                "gloam".into(),
                "render".into(),
                f.display().to_string(),
                format!("--lut={}", f.display()),
                "--out".into(),
                dir.path().join("missing").display().to_string(),
            ],
            &log,
        );
        assert_eq!(p.inputs.len(), 1, "{:?}", p.inputs);
        assert_eq!(p.inputs[0].bytes, 3);
        assert_eq!(p.inputs[0].sha256, sha256_hex(b"abc"));
        // ISO-8601 with a Z.
        assert!(p.utc.ends_with('Z') && p.utc.contains('T'), "{}", p.utc);
    }

    /// The files read into the run's own log are added once each (the
    /// command line's file not again), with the hash of the bytes read;
    /// another run's log adds nothing.
    #[test]
    fn inputs_read_come_from_the_runs_own_log() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.toml"), dir.path().join("b.obj"));
        std::fs::write(&a, b"abc").unwrap();
        std::fs::write(&b, b"v 0 0 0").unwrap();
        let (log, other) = (ReadLog::new(), ReadLog::new());
        let mut p =
            Provenance::of_command_line(vec!["gloam".into(), a.display().to_string()], &log);
        for f in [&a, &b, &b] {
            gloam_io::read_bounded(f, 100, &log).unwrap();
        }
        gloam_io::read_bounded(&b, 100, &other).unwrap();
        let mut q = Provenance::of_command_line(vec!["gloam".into()], &ReadLog::new());
        p.add_inputs_read();
        q.add_inputs_read();
        let listed: Vec<(&str, &str)> = (p.inputs.iter())
            .map(|i| (i.path.as_str(), i.sha256.as_str()))
            .collect();
        let (ha, hb) = (sha256_hex(b"abc"), sha256_hex(b"v 0 0 0"));
        let (pa, pb) = (a.display().to_string(), b.display().to_string());
        assert_eq!(
            listed,
            [(pa.as_str(), ha.as_str()), (pb.as_str(), hb.as_str())]
        );
        assert!(q.inputs.is_empty(), "{:?}", q.inputs);
    }
}
