//! What a run must undo or stop when it is interrupted, owned by its
//! front end.
//!
//! The command line makes one [`RunGuard`] per process, gives it to its
//! signal handler (`gloam_pipeline::cli::process::install_interrupt_handler`)
//! and to every output set and child process the command starts. A library
//! keeps no process-wide list: two guards (two tests in one process, a
//! Python session beside a CLI) never see each other's sets. Python writes
//! no output sets and starts no children; it passes [`RunGuard::detached`].
//!
//! The guard also holds the command line's arguments: an output set must
//! not replace, or be written inside, an input named there.

use std::ffi::OsString;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// A run's staging directories, child process groups and interrupt flag.
/// Cheap to clone: clones share one state.
#[derive(Clone, Default)]
pub struct RunGuard(Arc<State>);

#[derive(Default)]
struct State {
    /// Staging directories of unpublished sets, and whether the run's
    /// loop polls [`RunGuard::interrupted`] (then it publishes what it has).
    staging: Mutex<Vec<(PathBuf, bool)>>,
    /// Process groups of running children (`gloam_bench::child::Reaper`).
    child_groups: Mutex<Vec<u32>>,
    interrupted: AtomicBool,
    /// The command line's arguments that may name inputs: everything after
    /// the program name but the command's own words (`calibrate`, `agc`).
    arguments: Vec<OsString>,
}

/// What the front end's signal handler does after [`RunGuard::on_interrupt`].
#[derive(Debug, PartialEq, Eq)]
pub enum AfterInterrupt {
    /// A loop will stop at its next poll and publish what it has: keep
    /// running.
    Continue,
    /// The staging directories are removed and the children killed: end
    /// the process now. `had_sets`: an output set was being written (the
    /// user is told nothing was published).
    Exit { had_sets: bool },
}

/// Most command-line arguments looked at for inputs.
const MAX_ARGUMENTS: usize = 10_000;
/// Most subcommand words (`calibrate agc`) a command line has: the
/// binary's walk of its parsed subcommands stops there too.
pub const MAX_COMMAND_WORDS: usize = 8;

impl RunGuard {
    /// A guard for a command line: `args` after the program name, and the
    /// subcommand path its parser found. The command's own words are
    /// dropped from the arguments in order (the first `agc` after
    /// `calibrate` is the command; a later `--out agc` names a directory).
    pub fn for_command_line(
        args: impl IntoIterator<Item = OsString>,
        command_words: &[OsString],
    ) -> Self {
        let mut words = command_words.iter().take(MAX_COMMAND_WORDS).peekable();
        let arguments = args
            .into_iter()
            .take(MAX_ARGUMENTS)
            .filter(|a| match words.peek() {
                Some(w) if *w == a => {
                    words.next();
                    false
                }
                _ => true,
            })
            .collect();
        Self(Arc::new(State {
            arguments,
            ..State::default()
        }))
    }

    /// A guard with no command line and no signal handler (Python, tests):
    /// sets it guards are still removed when dropped unpublished.
    pub fn detached() -> Self {
        Self::default()
    }

    /// True once an interrupt reached a run whose loop polls for it.
    pub fn interrupted(&self) -> bool {
        self.0.interrupted.load(Ordering::SeqCst)
    }

    /// What an interrupt (Ctrl-C, SIGTERM, SIGHUP) does, for the front
    /// end's handler to call: kills every child group; lets a polling loop
    /// stop and publish (the first interrupt only); else removes every
    /// staging directory.
    pub fn on_interrupt(&self) -> AfterInterrupt {
        let groups = lock(&self.0.child_groups).clone();
        groups.into_iter().for_each(kill_group);
        let staging = lock(&self.0.staging).clone();
        if staging.iter().any(|(_, polls)| *polls) && !self.interrupted() {
            self.0.interrupted.store(true, Ordering::SeqCst);
            return AfterInterrupt::Continue;
        }
        for (dir, _) in &staging {
            let _ = std::fs::remove_dir_all(dir);
        }
        AfterInterrupt::Exit {
            had_sets: !staging.is_empty(),
        }
    }

    /// Kills child process group `pgid` on an interrupt, until
    /// [`Self::forget_child_group`].
    pub fn watch_child_group(&self, pgid: u32) {
        lock(&self.0.child_groups).push(pgid);
    }

    /// Stops tracking `pgid` (the child was reaped).
    pub fn forget_child_group(&self, pgid: u32) {
        lock(&self.0.child_groups).retain(|&p| p != pgid);
    }

    /// Removes `dir` on an interrupt (unless `polls` and a loop publishes).
    pub(crate) fn stage(&self, dir: PathBuf, polls: bool) {
        lock(&self.0.staging).push((dir, polls));
    }

    /// `dir` was published or removed.
    pub(crate) fn unstage(&self, dir: &std::path::Path) {
        lock(&self.0.staging).retain(|(d, _)| d != dir);
    }

    /// The command line's arguments that may name inputs.
    pub(crate) fn arguments(&self) -> &[OsString] {
        &self.0.arguments
    }
}

/// The list behind `m`, even if a thread panicked holding it (the lists
/// stay valid: every change is one push or retain).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// SIGKILL to every process of group `pgid`.
pub fn kill_group(pgid: u32) {
    #[cfg(unix)]
    if let Ok(pid) = i32::try_from(pgid)
        && pid > 0
    {
        // SAFETY: kill(2) with a negative pid signals that process group;
        // no memory is shared with the callee.
        unsafe {
            libc::kill(-pid, libc::SIGKILL);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn os(v: &[&str]) -> Vec<OsString> {
        v.iter().map(OsString::from).collect()
    }

    /// The command's words go once each, in order: `--out agc` after
    /// `calibrate agc` still names a directory.
    #[test]
    fn command_words_are_dropped_once_in_order() {
        let g = RunGuard::for_command_line(
            os(&["calibrate", "agc", "--out", "agc", "calibrate"]),
            &os(&["calibrate", "agc"]),
        );
        assert_eq!(g.arguments(), os(&["--out", "agc", "calibrate"]));
    }

    /// A polling loop gets the first interrupt; the second removes the
    /// staging directories and ends the run. Two guards share nothing.
    #[test]
    fn the_first_interrupt_stops_a_polling_loop_the_second_removes_the_set() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        std::fs::create_dir(&a).unwrap();
        std::fs::create_dir(&b).unwrap();
        let g = RunGuard::detached();
        let other = RunGuard::detached();
        g.stage(a.clone(), true);
        other.stage(b.clone(), false);
        assert_eq!(g.on_interrupt(), AfterInterrupt::Continue);
        assert!(g.interrupted() && !other.interrupted() && a.is_dir());
        assert_eq!(g.on_interrupt(), AfterInterrupt::Exit { had_sets: true });
        assert!(!a.exists() && b.is_dir(), "only this guard's set goes");
        g.unstage(&a);
        assert_eq!(g.on_interrupt(), AfterInterrupt::Exit { had_sets: false });
    }
}
