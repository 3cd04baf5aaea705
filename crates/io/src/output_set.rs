//! Whole output sets, published at once.
//!
//! A command writes its files into a hidden staging directory next to
//! `--out` (`.NAME.partial-PID`); when it has finished it writes
//! `manifest.json` (every file with its size and SHA-256, and the run's
//! provenance) and renames the staging directory over `--out` in one step.
//! A run killed at any moment therefore leaves either the previous set or
//! the new one, never a mix; a killed run's partial files stay in the
//! staging directory (nothing captured is lost) and never look complete.
//! Ctrl-C removes the staging directory of a run that cannot stop cleanly
//! (a render), and lets a capture stop and publish what it captured.
//!
//! A non-empty `--out` is refused unless `--force` replaces it.
//!
//! The run's provenance (version, command line, inputs) is the caller's:
//! any [`ManifestProvenance`], completed with every input the run read
//! just before the manifest is written.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::guard::RunGuard;
use crate::hash::{InputFile, hash_file};

/// The provenance a set's `manifest.json` carries under `"provenance"`,
/// made by the crate that knows the program (its version, commit and
/// clock).
pub trait ManifestProvenance: Serialize + Clone {
    /// Adds every input the run read since the record was taken (a
    /// scene's OBJ files are read after the run's provenance was first
    /// taken).
    fn add_inputs_read(&mut self);
}

/// The manifest a published set carries.
#[derive(Serialize)]
struct Manifest<'a, P: Serialize> {
    /// False when the run stopped early (an error or Ctrl-C): the files
    /// listed are whole, but fewer than asked for.
    complete: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    stopped_because: Option<&'a str>,
    provenance: &'a P,
    files: Vec<InputFile>,
}

/// Why an output set was refused or not published, naming the path.
#[derive(Debug, thiserror::Error)]
pub enum OutputSetError {
    #[error(
        "--out {}: is a symbolic link; gloam does not replace links — name the directory itself",
        .0.display()
    )]
    Link(PathBuf),
    #[error("--out {}: exists and is not a directory", .0.display())]
    NotADirectory(PathBuf),
    #[error(
        "--out {}: the directory is not empty; give --force to replace it, or another --out",
        .0.display()
    )]
    NotEmpty(PathBuf),
    #[error(
        "--out {}: holds the input {} named on the command line; write the output elsewhere",
        target.display(),
        input.display()
    )]
    HoldsInput { target: PathBuf, input: PathBuf },
    #[error(
        "--out {}: inside the directory {} named on the command line, an input of this run; write the output outside its inputs",
        target.display(),
        input.display()
    )]
    InsideInput { target: PathBuf, input: PathBuf },
    #[error(
        "--out {}: inside {}, a published gloam output set (its manifest.json lists every file in it, and a set written inside would leave it one --force refuses to replace); write the output outside it",
        target.display(),
        set.display()
    )]
    InsideSet { target: PathBuf, set: PathBuf },
    /// `--force` on a directory that is not a previous output set.
    #[error(
        "--out {}: {why}; --force replaces only a previous gloam output set (a directory whose manifest.json lists every file in it) — choose another --out",
        target.display()
    )]
    NotOurs { target: PathBuf, why: String },
    /// A last component longer than a directory entry may be.
    #[error(
        "--out {}: its name is {bytes} bytes, longer than a file name may be ({NAME_MAX} bytes)",
        target.display()
    )]
    NameTooLong { target: PathBuf, bytes: usize },
    #[error("{}: more than {MAX_SET_ENTRIES} entries; not a gloam output set", .0.display())]
    TooManyEntries(PathBuf),
    #[error("{}: nested deeper than {MAX_SET_DEPTH} levels; not a gloam output set", .0.display())]
    TooDeep(PathBuf),
    #[error(
        "{} is not a regular file or directory (a link, device, FIFO or socket); no gloam output set holds one",
        .0.display()
    )]
    NotRegular(PathBuf),
    /// A file-system step, `doing` saying which and on what.
    #[error("{doing}")]
    Io {
        doing: String,
        #[source]
        source: std::io::Error,
    },
    #[error("writing manifest.json")]
    Manifest(#[source] serde_json::Error),
}

/// Bytes free to an unprivileged writer on the filesystem holding `path`
/// (`statvfs`'s `f_bavail`), or `None` where it cannot be read.
pub fn free_disk_bytes(path: &Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes()).ok()?;
    // SAFETY: `c` is a valid NUL-terminated path; `st` is written by the
    // call and read only when it succeeds.
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    (unsafe { libc::statvfs(c.as_ptr(), &mut st) } == 0)
        .then(|| st.f_bavail.saturating_mul(st.f_frsize))
}

/// Bytes of the regular files directly in `dir` (a set being written),
/// at most [`MAX_SET_ENTRIES`] of them.
pub fn files_bytes(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .flatten()
        .take(MAX_SET_ENTRIES)
        .filter_map(|e| e.metadata().ok().filter(|m| m.is_file()).map(|m| m.len()))
        .sum()
}

/// `Result::map_err` for a file-system step: what it was doing, lazily.
fn io_err(doing: impl FnOnce() -> String) -> impl FnOnce(std::io::Error) -> OutputSetError {
    move |source| OutputSetError::Io {
        doing: doing(),
        source,
    }
}

/// An error and its sources as `error: cause: cause`, as the command line
/// prints them.
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut next = e.source();
    while let Some(c) = next {
        s.push_str(": ");
        s.push_str(&c.to_string());
        next = c.source();
    }
    s
}

/// An output set being written.
pub struct OutputSet {
    target: PathBuf,
    staging: PathBuf,
    published: bool,
    /// The run's guard, which removes the staging directory on an interrupt.
    guard: RunGuard,
}

impl OutputSet {
    /// Starts a set for `target`, guarded by the run's `guard`. Refuses a
    /// non-empty `target` unless `force`, and a `target` that holds or is
    /// inside an input named on the guard's command line.
    /// `polls_interrupt`: the caller's loop checks
    /// [`RunGuard::interrupted`] and publishes what it has, instead of
    /// Ctrl-C discarding the set.
    pub fn begin(
        target: &Path,
        force: bool,
        polls_interrupt: bool,
        guard: &RunGuard,
    ) -> Result<Self, OutputSetError> {
        refuse_target_inside_inputs(target, guard.arguments())?;
        refuse_target_inside_a_set(target)?;
        if let Ok(meta) = std::fs::symlink_metadata(target) {
            if meta.file_type().is_symlink() {
                return Err(OutputSetError::Link(target.to_path_buf()));
            }
            if !meta.is_dir() {
                return Err(OutputSetError::NotADirectory(target.to_path_buf()));
            }
            let non_empty = std::fs::read_dir(target)
                .map_err(io_err(|| format!("reading {}", target.display())))?
                .next()
                .is_some();
            if non_empty && !force {
                return Err(OutputSetError::NotEmpty(target.to_path_buf()));
            }
            if non_empty {
                refuse_inputs_inside(target, guard.arguments())?;
                refuse_unless_output_set(target)?;
            }
        }
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent).map_err(io_err(|| {
            format!("--out {}: creating {}", target.display(), parent.display())
        }))?;
        if let Some(n) = target.file_name()
            && n.len() > NAME_MAX
        {
            return Err(OutputSetError::NameTooLong {
                target: target.to_path_buf(),
                bytes: n.len(),
            });
        }
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        let staging = parent.join(staging_name(&name, std::process::id()));
        if staging.exists() {
            std::fs::remove_dir_all(&staging)
                .map_err(io_err(|| format!("removing a stale {}", staging.display())))?;
        }
        std::fs::create_dir(&staging).map_err(io_err(|| {
            format!(
                "--out {}: creating its staging directory {}",
                target.display(),
                staging.display()
            )
        }))?;
        guard.stage(staging.clone(), polls_interrupt);
        Ok(Self {
            target: target.to_path_buf(),
            staging,
            published: false,
            guard: guard.clone(),
        })
    }

    /// Where the set's files are written until it is published.
    pub fn dir(&self) -> &Path {
        &self.staging
    }

    /// The directory the set is published as.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Writes `manifest.json` and moves the set into place at once.
    /// `stopped_because`: why a run that stopped early did (the set is
    /// then published with `"complete": false`).
    pub fn publish<P: ManifestProvenance>(
        mut self,
        provenance: &P,
        stopped_because: Option<&str>,
    ) -> Result<(), OutputSetError> {
        let mut files: Vec<InputFile> = Vec::new();
        let mut names: Vec<String> = set_entries(&self.staging)?
            .into_iter()
            .filter(|(_, is_dir)| !is_dir)
            .map(|(rel, _)| rel)
            .collect();
        names.sort();
        for rel in names {
            if let Some(mut f) = hash_file(&self.staging.join(&rel)) {
                f.path = rel;
                files.push(f);
            }
        }
        // Every input the run read, however late (a scene's OBJ files are
        // read after the run's provenance was first taken).
        let mut provenance = provenance.clone();
        provenance.add_inputs_read();
        let manifest = Manifest {
            complete: stopped_because.is_none(),
            stopped_because,
            provenance: &provenance,
            files,
        };
        let text = serde_json::to_string_pretty(&manifest).map_err(OutputSetError::Manifest)?;
        std::fs::write(self.staging.join("manifest.json"), text)
            .map_err(io_err(|| "writing manifest.json".into()))?;
        // Swap: the old set aside, the new one in, the old one removed.
        let old = self.staging.with_file_name(format!(
            "{}.old",
            self.staging
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        ));
        let had_old = self.target.exists();
        if had_old {
            std::fs::rename(&self.target, &old).map_err(io_err(|| {
                format!("moving the previous {} aside", self.target.display())
            }))?;
        }
        std::fs::rename(&self.staging, &self.target)
            .map_err(io_err(|| format!("publishing {}", self.target.display())))?;
        self.published = true;
        self.guard.unstage(&self.staging);
        if had_old {
            std::fs::remove_dir_all(&old).map_err(io_err(|| {
                format!("removing the previous set {}", old.display())
            }))?;
        }
        Ok(())
    }
}

/// Most entries an output set may hold (files and subdirectories, all
/// levels): the walk that recognises one is bounded.
pub const MAX_SET_ENTRIES: usize = 1_000_000;
/// Deepest subdirectory level an output set has (`images/` of an EMVA
/// dataset is level 1).
const MAX_SET_DEPTH: usize = 8;

/// Every entry under `dir`, as `(path relative to dir with '/', is a
/// directory)`; symbolic links and other non-regular entries are errors (no
/// gloam set holds them).
fn set_entries(dir: &Path) -> Result<Vec<(String, bool)>, OutputSetError> {
    let mut out = Vec::new();
    let mut stack = vec![(dir.to_path_buf(), String::new(), 0usize)];
    while let Some((d, prefix, depth)) = stack.pop() {
        for e in std::fs::read_dir(&d).map_err(io_err(|| format!("reading {}", d.display())))? {
            let e = e.map_err(io_err(|| format!("reading {}", d.display())))?;
            let name = e.file_name().to_string_lossy().into_owned();
            let rel = if prefix.is_empty() {
                name
            } else {
                format!("{prefix}/{name}")
            };
            let ft = e
                .file_type()
                .map_err(io_err(|| format!("reading {}", e.path().display())))?;
            if out.len() >= MAX_SET_ENTRIES {
                return Err(OutputSetError::TooManyEntries(dir.to_path_buf()));
            }
            if ft.is_dir() {
                if depth + 1 > MAX_SET_DEPTH {
                    return Err(OutputSetError::TooDeep(e.path()));
                }
                out.push((rel.clone(), true));
                stack.push((e.path(), rel, depth + 1));
            } else if ft.is_file() {
                out.push((rel, false));
            } else {
                return Err(OutputSetError::NotRegular(e.path()));
            }
        }
    }
    Ok(out)
}

/// `--force` replaces only a previous gloam output set: a directory whose
/// `manifest.json` lists every file in it. Anything else there (the scene
/// the run reads, a `notes.txt`, a link) means the directory is not ours to
/// delete.
fn refuse_unless_output_set(target: &Path) -> Result<(), OutputSetError> {
    let not_ours = |why: String| OutputSetError::NotOurs {
        target: target.to_path_buf(),
        why,
    };
    let entries = set_entries(target).map_err(|e| not_ours(chain(&e)))?;
    let manifest = target.join("manifest.json");
    let text = crate::read_text(
        &manifest,
        crate::MAX_TEXT_FILE_BYTES,
        &crate::ReadLog::off(),
    )
    .map_err(|_| not_ours("it holds no readable manifest.json".into()))?;
    let listed: std::collections::HashSet<String> = crate::json::parse_value(&text)
        .ok()
        .and_then(|v| {
            v.get("files")?.as_array().map(|files| {
                files
                    .iter()
                    .filter_map(|f| f.get("path")?.as_str().map(String::from))
                    .collect()
            })
        })
        .ok_or_else(|| not_ours("its manifest.json is not a gloam manifest".into()))?;
    let strays: Vec<&str> = entries
        .iter()
        .filter(|(rel, is_dir)| !is_dir && rel != "manifest.json" && !listed.contains(rel))
        .map(|(rel, _)| rel.as_str())
        .collect();
    if let Some(first) = strays.first() {
        return Err(not_ours(format!(
            "it holds {first}{}, which no gloam output set there wrote",
            if strays.len() > 1 {
                format!(" and {} more file(s)", strays.len() - 1)
            } else {
                String::new()
            }
        )));
    }
    Ok(())
}

/// The existing paths named on the command line, as given and resolved
/// (links and `..` gone): every argument (the command's own words are not
/// among them, [`RunGuard::for_command_line`]) but the `--out` value,
/// which names the target, not an input.
fn named_paths(args: &[std::ffi::OsString]) -> Vec<(PathBuf, PathBuf)> {
    let mut after_out = false;
    let mut out = Vec::new();
    for a in args {
        let is_out_value = std::mem::replace(&mut after_out, a == "--out");
        if is_out_value || a.to_string_lossy().starts_with("--out=") || a.is_empty() {
            continue;
        }
        let p = PathBuf::from(a);
        if let Ok(c) = p.canonicalize() {
            out.push((p, c));
        }
    }
    out
}

/// Refuses a `target` that holds (or is) any existing path named on the
/// command line — an input the run reads (`gloam merge t1 t2 --out t1`,
/// `gloam render sd/s.toml --out sd`).
fn refuse_inputs_inside(target: &Path, args: &[std::ffi::OsString]) -> Result<(), OutputSetError> {
    let Ok(t) = target.canonicalize() else {
        return Ok(());
    };
    match named_paths(args)
        .into_iter()
        .find(|(_, c)| c.starts_with(&t))
    {
        Some((input, _)) => Err(OutputSetError::HoldsInput {
            target: target.to_path_buf(),
            input,
        }),
        None => Ok(()),
    }
}

/// `path` resolved as far as it exists: the canonical path of its nearest
/// existing ancestor joined with the rest as given (`None` when not even
/// the working directory resolves). Bounded by the path's components.
pub fn resolved_as_far_as_it_exists(path: &Path) -> Option<PathBuf> {
    let mut probe = path.to_path_buf();
    let mut rest = Vec::new();
    for _ in 0..=path.components().count() {
        if let Ok(c) = std::fs::canonicalize(&probe) {
            return Some(rest.iter().rev().fold(c, |p: PathBuf, part| p.join(part)));
        }
        match (probe.file_name().map(|n| n.to_os_string()), probe.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name);
                probe = if parent.as_os_str().is_empty() {
                    PathBuf::from(".")
                } else {
                    parent.to_path_buf()
                };
            }
            _ => break,
        }
    }
    Some(std::env::current_dir().ok()?.join(path))
}

/// Refuses a `target` strictly inside an existing directory named on the
/// command line — an input the run reads (`gloam merge t1 t2 --out
/// t1/merged`): the set would be added to its own input, and the next run
/// over the same inputs would meet it there. The twin of
/// [`refuse_inputs_inside`] (a target that holds an input); both compare
/// resolved paths (links and `..` gone).
fn refuse_target_inside_inputs(
    target: &Path,
    args: &[std::ffi::OsString],
) -> Result<(), OutputSetError> {
    let Some(t) = resolved_as_far_as_it_exists(target) else {
        return Ok(());
    };
    let inside = |c: &PathBuf| c.is_dir() && t != *c && t.starts_with(c);
    match named_paths(args).into_iter().find(|(_, c)| inside(c)) {
        Some((input, _)) => Err(OutputSetError::InsideInput {
            target: target.to_path_buf(),
            input,
        }),
        None => Ok(()),
    }
}

/// Refuses a `target` inside a published gloam output set (a directory
/// above it whose `manifest.json` is a gloam manifest): `render --out
/// real/inner` left `real` holding files its manifest does not list, and
/// `--force` on `real` was then refused. Bounded by the path's components.
fn refuse_target_inside_a_set(target: &Path) -> Result<(), OutputSetError> {
    let Some(t) = resolved_as_far_as_it_exists(target) else {
        return Ok(());
    };
    let is_set = |dir: &Path| {
        let manifest = dir.join("manifest.json");
        manifest.is_file()
            && crate::read_text(
                &manifest,
                crate::MAX_TEXT_FILE_BYTES,
                &crate::ReadLog::off(),
            )
            .ok()
            .and_then(|text| crate::json::parse_value(&text).ok())
            .is_some_and(|v| {
                v.get("complete").is_some_and(|c| c.is_boolean())
                    && v.get("files").is_some_and(|f| f.is_array())
            })
    };
    match t.ancestors().skip(1).find(|dir| is_set(dir)) {
        Some(set) => Err(OutputSetError::InsideSet {
            target: target.to_path_buf(),
            set: set.to_path_buf(),
        }),
        None => Ok(()),
    }
}

impl Drop for OutputSet {
    /// A set dropped unpublished (an error before anything worth keeping)
    /// leaves nothing behind.
    fn drop(&mut self) {
        if !self.published {
            let _ = std::fs::remove_dir_all(&self.staging);
            self.guard.unstage(&self.staging);
        }
    }
}

/// Longest file name (one path component), bytes: Linux's `NAME_MAX`.
pub const NAME_MAX: usize = 255;

/// The staging directory's name for a set named `name`: `.NAME.partial-PID`,
/// the name cut (at a character) and marked with a hash of the whole when
/// that would be longer than a file name may be — a valid `--out` of 245
/// bytes was refused with "File name too long", naming the staging
/// directory.
fn staging_name(name: &str, pid: u32) -> String {
    let full = format!(".{name}.partial-{pid}");
    if full.len() <= NAME_MAX {
        return full;
    }
    // FNV-1a over the whole name: two long names sharing a prefix differ.
    let hash = name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    let tail = format!("~{hash:016x}.partial-{pid}");
    let mut cut = NAME_MAX - 1 - tail.len();
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    format!(".{}{tail}", &name[..cut])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A valid `--out` of 250 bytes publishes (its staging name was 265
    /// bytes: "File name too long"); two long names sharing a prefix get
    /// two staging directories.
    #[test]
    fn a_long_out_name_stages_within_a_file_name() {
        let dir = tempfile::tempdir().unwrap();
        let a = "é".repeat(125);
        let b = format!("{}x", "é".repeat(124));
        let (sa, sb) = (staging_name(&a, 4_194_304), staging_name(&b, 4_194_304));
        assert!(sa.len() <= NAME_MAX && sb.len() <= NAME_MAX && sa != sb);
        assert_eq!(staging_name("o", 7), ".o.partial-7");
        let out = dir.path().join(&a);
        let set = OutputSet::begin(&out, false, false, &RunGuard::detached()).unwrap();
        std::fs::write(set.dir().join("x.txt"), b"x").unwrap();
        set.publish(&prov(), None).unwrap();
        assert!(out.join("x.txt").is_file());
    }

    /// A run's provenance as the manifest states it.
    #[derive(Clone, Serialize)]
    struct Prov {
        command_line: Vec<String>,
    }

    impl ManifestProvenance for Prov {
        fn add_inputs_read(&mut self) {}
    }

    fn prov() -> Prov {
        Prov {
            command_line: vec!["gloam".into()],
        }
    }

    #[test]
    fn a_set_appears_whole_and_replaces_the_old_one_only_with_force() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let set = OutputSet::begin(&out, false, false, &RunGuard::detached()).unwrap();
        std::fs::write(set.dir().join("a.txt"), b"first").unwrap();
        assert!(!out.exists(), "nothing is visible before publishing");
        set.publish(&prov(), None).unwrap();
        assert_eq!(std::fs::read(out.join("a.txt")).unwrap(), b"first");
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
        assert_eq!(m["complete"], true);
        assert_eq!(m["files"][0]["path"], "a.txt");
        assert_eq!(m["files"][0]["sha256"], crate::sha256_hex(b"first"));

        // A non-empty --out is refused without --force.
        let err = OutputSet::begin(&out, false, false, &RunGuard::detached())
            .err()
            .unwrap();
        assert!(format!("{err}").contains("--force"), "{err}");
        // With --force, a smaller set leaves no stale file of the old one.
        let set = OutputSet::begin(&out, true, false, &RunGuard::detached()).unwrap();
        std::fs::write(set.dir().join("b.txt"), b"second").unwrap();
        set.publish(&prov(), Some("interrupted")).unwrap();
        assert!(!out.join("a.txt").exists());
        assert_eq!(std::fs::read(out.join("b.txt")).unwrap(), b"second");
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
        assert_eq!(m["complete"], false);
        // No staging directory is left behind.
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, vec![std::ffi::OsString::from("out")]);
    }

    #[test]
    fn force_replaces_only_a_previous_gloam_set() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        // A set with a subdirectory (an EMVA dataset's images/) is ours.
        let set = OutputSet::begin(&out, false, false, &RunGuard::detached()).unwrap();
        std::fs::create_dir(set.dir().join("images")).unwrap();
        std::fs::write(set.dir().join("images/a.tif"), b"x").unwrap();
        std::fs::write(set.dir().join("r.json"), b"{}").unwrap();
        set.publish(&prov(), None).unwrap();
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
        let paths: Vec<&str> = m["files"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f["path"].as_str().unwrap())
            .collect();
        assert_eq!(paths, ["images/a.tif", "r.json"]);
        OutputSet::begin(&out, true, false, &RunGuard::detached())
            .unwrap()
            .publish(&prov(), None)
            .unwrap();
        assert!(
            !out.join("images/a.tif").exists(),
            "the old set was replaced"
        );

        // A file the set did not write: refused, named, and left alone.
        std::fs::write(out.join("notes.txt"), b"mine").unwrap();
        let err = format!(
            "{:#}",
            OutputSet::begin(&out, true, false, &RunGuard::detached())
                .err()
                .unwrap()
        );
        assert!(
            err.contains("notes.txt") && err.contains("--force"),
            "{err}"
        );
        assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"mine");

        // A directory without a manifest (a scene's own folder).
        let scene_dir = dir.path().join("sd");
        std::fs::create_dir(&scene_dir).unwrap();
        std::fs::write(scene_dir.join("s.toml"), b"units = 'm'").unwrap();
        let err = format!(
            "{:#}",
            OutputSet::begin(&scene_dir, true, false, &RunGuard::detached())
                .err()
                .unwrap()
        );
        assert!(err.contains("manifest.json"), "{err}");
        assert!(scene_dir.join("s.toml").exists());
    }

    /// Issue 46, round 12: `render --out real/inner` wrote a set inside a
    /// published one, which `--force` then refused to replace.
    #[test]
    fn a_target_inside_a_published_set_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real");
        let set = OutputSet::begin(&real, false, false, &RunGuard::detached()).unwrap();
        std::fs::write(set.dir().join("a.txt"), "a").unwrap();
        set.publish(&prov(), None).unwrap();
        for inner in [real.join("inner"), real.join("x/y/inner")] {
            let err = OutputSet::begin(&inner, false, false, &RunGuard::detached())
                .err()
                .unwrap()
                .to_string();
            assert!(err.contains("a published gloam output set"), "{err}");
            assert!(err.contains(&real.display().to_string()), "{err}");
        }
        // Beside it, and over it with --force: allowed.
        OutputSet::begin(
            &dir.path().join("beside"),
            false,
            false,
            &RunGuard::detached(),
        )
        .unwrap();
        OutputSet::begin(&real, true, false, &RunGuard::detached()).unwrap();
        // A manifest.json that is not a gloam manifest is not a set.
        let other = dir.path().join("other");
        std::fs::create_dir(&other).unwrap();
        std::fs::write(other.join("manifest.json"), r#"{"name":"npm"}"#).unwrap();
        OutputSet::begin(&other.join("inner"), false, false, &RunGuard::detached()).unwrap();
    }

    /// The twin of `holds the input`: a target inside a directory named on
    /// the command line, however spelled (`..`, a link to it, not yet
    /// existing below it), is refused; beside it, or the directory itself
    /// (the other check's case), is not this check's to refuse.
    #[cfg(unix)]
    #[test]
    fn a_target_inside_an_input_directory_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let t1 = dir.path().join("t1");
        std::fs::create_dir_all(t1.join("sub")).unwrap();
        std::os::unix::fs::symlink(&t1, dir.path().join("via")).unwrap();
        let args = |out: &Path| -> Vec<std::ffi::OsString> {
            vec![
                "merge".into(),
                t1.clone().into_os_string(),
                "--out".into(),
                out.as_os_str().to_owned(),
            ]
        };
        for inside in [
            t1.join("merged"),
            t1.join("sub/x/../deeper/still"),
            dir.path().join("via/merged"),
            dir.path().join("t1/sub"),
        ] {
            let err = refuse_target_inside_inputs(&inside, &args(&inside))
                .unwrap_err()
                .to_string();
            assert!(
                err.contains("inside the directory"),
                "{}: {err}",
                inside.display()
            );
            assert!(err.contains(&*t1.to_string_lossy()), "{err}");
        }
        for outside in [
            dir.path().join("merged"),
            t1.clone(),
            dir.path().join("t10"),
        ] {
            refuse_target_inside_inputs(&outside, &args(&outside))
                .unwrap_or_else(|e| panic!("{}: {e}", outside.display()));
        }
        // A file argument is not a directory the set could sit inside.
        std::fs::write(dir.path().join("s.toml"), "").unwrap();
        let out = dir.path().join("s.toml/o");
        let a = vec!["render".into(), dir.path().join("s.toml").into_os_string()];
        refuse_target_inside_inputs(&out, &a).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn links_are_never_replaced_and_inputs_never_overwritten() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real");
        std::fs::create_dir(&real).unwrap();
        std::fs::write(real.join("keep.txt"), b"k").unwrap();
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        for force in [false, true] {
            let err = format!(
                "{:#}",
                OutputSet::begin(&link, force, false, &RunGuard::detached())
                    .err()
                    .unwrap()
            );
            assert!(err.contains("symbolic link"), "{err}");
        }
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert!(real.join("keep.txt").exists());

        // `gloam merge t1 t2 --out t1 --force`: t1 is an input.
        let t1 = dir.path().join("t1");
        OutputSet::begin(&t1, false, false, &RunGuard::detached())
            .unwrap()
            .publish(&prov(), None)
            .unwrap();
        let args = ["merge", "t1", "t2", "--out", "t1", "--force"];
        let cwd_args: Vec<std::ffi::OsString> = args
            .iter()
            .map(|a| {
                if a.starts_with('t') {
                    dir.path().join(a).into_os_string()
                } else {
                    a.into()
                }
            })
            .collect();
        let err = format!("{:#}", refuse_inputs_inside(&t1, &cwd_args).unwrap_err());
        assert!(err.contains("holds the input"), "{err}");
        // The value of --out alone is not an input.
        assert!(refuse_inputs_inside(&t1, &cwd_args[3..]).is_ok());
        // A file inside the target named as an input, too.
        let inner = t1.join("manifest.json").into_os_string();
        assert!(refuse_inputs_inside(&t1, &[inner]).is_err());
        // Paths elsewhere are fine.
        let other = dir.path().join("real").into_os_string();
        assert!(refuse_inputs_inside(&t1, &[other]).is_ok());
    }

    #[test]
    fn a_set_dropped_unpublished_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        {
            let set = OutputSet::begin(&out, false, false, &RunGuard::detached()).unwrap();
            std::fs::write(set.dir().join("a.txt"), b"x").unwrap();
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
