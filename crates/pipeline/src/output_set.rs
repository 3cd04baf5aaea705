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

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, bail};
use serde::Serialize;

use crate::provenance::{InputFile, Provenance, hash_file};

/// Staging directories of this process, removed on Ctrl-C.
static STAGING: Mutex<Vec<(PathBuf, bool)>> = Mutex::new(Vec::new());
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
static HANDLER: std::sync::Once = std::sync::Once::new();

/// True once Ctrl-C was pressed during a run whose loop polls for it.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

fn install_handler() {
    HANDLER.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            let staging = STAGING.lock().map(|s| s.clone()).unwrap_or_default();
            if staging.iter().any(|(_, polls)| *polls) && !interrupted() {
                // A loop will stop and publish what it has.
                INTERRUPTED.store(true, Ordering::SeqCst);
                return;
            }
            for (dir, _) in staging {
                let _ = std::fs::remove_dir_all(dir);
            }
            eprintln!("interrupted: nothing was published");
            std::process::exit(130);
        });
    });
}

/// The manifest a published set carries.
#[derive(Serialize)]
struct Manifest<'a> {
    /// False when the run stopped early (an error or Ctrl-C): the files
    /// listed are whole, but fewer than asked for.
    complete: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    stopped_because: Option<&'a str>,
    provenance: &'a Provenance,
    files: Vec<InputFile>,
}

/// An output set being written.
pub struct OutputSet {
    target: PathBuf,
    staging: PathBuf,
    published: bool,
}

impl OutputSet {
    /// Starts a set for `target`. Refuses a non-empty `target` unless
    /// `force`. `polls_interrupt`: the caller's loop checks
    /// [`interrupted`] and publishes what it has, instead of Ctrl-C
    /// discarding the set.
    pub fn begin(target: &Path, force: bool, polls_interrupt: bool) -> anyhow::Result<Self> {
        if target.exists() {
            if !target.is_dir() {
                bail!("--out {}: exists and is not a directory", target.display());
            }
            let non_empty = std::fs::read_dir(target)
                .with_context(|| format!("reading {}", target.display()))?
                .next()
                .is_some();
            if non_empty && !force {
                bail!(
                    "--out {}: the directory is not empty; give --force to replace it, or another --out",
                    target.display()
                );
            }
        }
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent)
            .with_context(|| format!("creating {}", parent.display()))?;
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
        if staging.exists() {
            std::fs::remove_dir_all(&staging)
                .with_context(|| format!("removing a stale {}", staging.display()))?;
        }
        std::fs::create_dir(&staging).with_context(|| format!("creating {}", staging.display()))?;
        install_handler();
        if let Ok(mut s) = STAGING.lock() {
            s.push((staging.clone(), polls_interrupt));
        }
        Ok(Self {
            target: target.to_path_buf(),
            staging,
            published: false,
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
    pub fn publish(
        mut self,
        provenance: &Provenance,
        stopped_because: Option<&str>,
    ) -> anyhow::Result<()> {
        let mut files: Vec<InputFile> = Vec::new();
        let mut names: Vec<PathBuf> = std::fs::read_dir(&self.staging)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file())
            .collect();
        names.sort();
        for p in names {
            if let Some(mut f) = hash_file(&p) {
                f.path = p
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                files.push(f);
            }
        }
        let manifest = Manifest {
            complete: stopped_because.is_none(),
            stopped_because,
            provenance,
            files,
        };
        std::fs::write(
            self.staging.join("manifest.json"),
            serde_json::to_string_pretty(&manifest)?,
        )
        .context("writing manifest.json")?;
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
            std::fs::rename(&self.target, &old)
                .with_context(|| format!("moving the previous {} aside", self.target.display()))?;
        }
        std::fs::rename(&self.staging, &self.target)
            .with_context(|| format!("publishing {}", self.target.display()))?;
        self.published = true;
        if let Ok(mut s) = STAGING.lock() {
            s.retain(|(d, _)| d != &self.staging);
        }
        if had_old {
            std::fs::remove_dir_all(&old)
                .with_context(|| format!("removing the previous set {}", old.display()))?;
        }
        Ok(())
    }
}

impl Drop for OutputSet {
    /// A set dropped unpublished (an error before anything worth keeping)
    /// leaves nothing behind.
    fn drop(&mut self) {
        if !self.published {
            let _ = std::fs::remove_dir_all(&self.staging);
            if let Ok(mut s) = STAGING.lock() {
                s.retain(|(d, _)| d != &self.staging);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prov() -> Provenance {
        Provenance::of_command_line(vec!["gloam".into()])
    }

    #[test]
    fn a_set_appears_whole_and_replaces_the_old_one_only_with_force() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let set = OutputSet::begin(&out, false, false).unwrap();
        std::fs::write(set.dir().join("a.txt"), b"first").unwrap();
        assert!(!out.exists(), "nothing is visible before publishing");
        set.publish(&prov(), None).unwrap();
        assert_eq!(std::fs::read(out.join("a.txt")).unwrap(), b"first");
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
        assert_eq!(m["complete"], true);
        assert_eq!(m["files"][0]["path"], "a.txt");
        assert_eq!(
            m["files"][0]["sha256"],
            crate::provenance::sha256_hex(b"first")
        );

        // A non-empty --out is refused without --force.
        let err = OutputSet::begin(&out, false, false).err().unwrap();
        assert!(format!("{err}").contains("--force"), "{err}");
        // With --force, a smaller set leaves no stale file of the old one.
        let set = OutputSet::begin(&out, true, false).unwrap();
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
    fn a_set_dropped_unpublished_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        {
            let set = OutputSet::begin(&out, false, false).unwrap();
            std::fs::write(set.dir().join("a.txt"), b"x").unwrap();
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
