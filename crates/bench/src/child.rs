//! Child processes of the benches — each `bench scale` case in its own
//! `gloam`, Mitsuba 3's side in `python3` — run with a timeout, their
//! output in files, a failure reported by the last lines of its stderr.

use std::ffi::OsStr;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use gloam_io::RunGuard;

use super::BenchError;

/// While alive, a child started in its own process group is killed with
/// its group if the run's guard hears Ctrl-C or SIGTERM; dropped (the child
/// reaped or given up), its group is killed too — a case never outlives the
/// bench that started it.
pub struct Reaper {
    pgid: u32,
    guard: RunGuard,
}

impl Reaper {
    pub fn new(child: &std::process::Child, guard: &RunGuard) -> Self {
        let pgid = child.id();
        guard.watch_child_group(pgid);
        Self {
            pgid,
            guard: guard.clone(),
        }
    }
}

impl Drop for Reaper {
    fn drop(&mut self) {
        self.guard.forget_child_group(self.pgid);
        gloam_io::guard::kill_group(self.pgid);
    }
}

/// Has the kernel kill the child `cmd` will start when the thread that
/// starts it ends (Linux's parent-death signal), and the child end at
/// once if that happened before it could ask. [`Reaper`] kills a case's
/// group only once it knows it: a SIGTERM between the fork and
/// `Reaper::new` — before the bench's handler was even installed — ended
/// the bench and left the case running (caught on a loaded machine, the
/// forked child still showing the bench's command line). Call from the
/// thread that lives as long as the child should.
pub fn die_with_parent(cmd: &mut Command) {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        let parent = std::process::id();
        // SAFETY: the closure runs in the forked child before exec and
        // calls only prctl, getppid and _exit, which are async-signal-safe.
        unsafe {
            cmd.pre_exec(move || {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                if u32::try_from(libc::getppid()).ok() != Some(parent) {
                    libc::_exit(1);
                }
                Ok(())
            });
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = cmd;
}

/// Waits for `child` until `timeout` after `t0`; past it, kills it and
/// returns `None` (what it started goes with its group: [`Reaper`]).
pub fn wait_with_timeout(
    child: &mut std::process::Child,
    t0: Instant,
    timeout: Duration,
) -> Result<Option<std::process::ExitStatus>, BenchError> {
    loop {
        if let Some(st) = child.try_wait().map_err(BenchError::io(
            "waiting for a child process of",
            &std::env::temp_dir(),
        ))? {
            return Ok(Some(st));
        }
        if t0.elapsed() >= timeout {
            let _ = child.kill();
            let _ = child.wait();
            return Ok(None);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The last `lines` lines of the text file at `path`, joined by " / "
/// (empty when it cannot be read): what a failed child said last.
pub fn stderr_tail(path: &Path, lines: usize) -> String {
    let text = gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, &crate::unlisted())
        .unwrap_or_default();
    let tail: Vec<&str> = text.lines().rev().take(lines).collect();
    tail.into_iter().rev().collect::<Vec<_>>().join(" / ")
}

/// True when `python3 -c 'import mitsuba'` works.
pub fn mitsuba_importable() -> bool {
    Command::new("python3")
        .args(["-c", "import mitsuba"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Runs Mitsuba 3's side of a bench, `python3 SCRIPT ARGS…`, its stdout
/// and stderr into those files, within `timeout`: killed or failed, a
/// [`BenchError::Child`] naming Mitsuba 3 with its stderr's last 3 lines.
pub fn run_mitsuba_script(
    script: &Path,
    args: &[&OsStr],
    stdout: &Path,
    stderr: &Path,
    timeout: Duration,
    guard: &RunGuard,
) -> Result<(), BenchError> {
    let t0 = Instant::now();
    let mut cmd = Command::new("python3");
    cmd.arg(script)
        .args(args)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(stdout).map_err(BenchError::io("creating", stdout))?)
        .stderr(std::fs::File::create(stderr).map_err(BenchError::io("creating", stderr))?);
    // As a scale case: its own group, killed with the bench on a signal
    // or a timeout, and with its parent between the fork and the reaper.
    #[cfg(unix)]
    std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
    die_with_parent(&mut cmd);
    let mut child = cmd
        .spawn()
        .map_err(BenchError::io("starting python3 for", script))?;
    let _reaper = Reaper::new(&child, guard);
    let failed = |why: String| BenchError::Child {
        what: "Mitsuba 3".into(),
        why,
    };
    match wait_with_timeout(&mut child, t0, timeout)? {
        None => Err(failed(format!(
            "killed after {:.0} s",
            timeout.as_secs_f64()
        ))),
        Some(st) if !st.success() => Err(failed(format!("{st}: {}", stderr_tail(stderr, 3)))),
        Some(_) => Ok(()),
    }
}
