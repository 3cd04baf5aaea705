//! Ctrl-C and progress while the GIL is released.
//!
//! Python runs its signal handlers only on the main thread, when asked. A
//! long call therefore releases the GIL and, between units of work (a
//! frame, a tile), briefly takes it back to run them
//! (`Python::check_signals`); the `KeyboardInterrupt` they raise is kept
//! here and re-raised when the call returns, and the work stops early.
//! The same poll passes the work's progress to the caller's `progress`
//! callable, on the calling thread (so a callback needs no locking); an
//! exception it raises stops the work as Ctrl-C does.
//! Nothing is written to disk by these calls (a sweep writes each task
//! atomically), so nothing is half-written.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use pyo3::prelude::*;

thread_local! {
    static PENDING: RefCell<Option<PyErr>> = const { RefCell::new(None) };
}

/// How often the calling thread polls for signals and progress.
const POLL: Duration = Duration::from_millis(50);

/// Runs Python's signal handlers; true (and the exception kept) when one
/// raised, i.e. the caller should stop.
pub fn signalled() -> bool {
    if PENDING.with(|p| p.borrow().is_some()) {
        return true;
    }
    match Python::attach(|py| py.check_signals()) {
        Ok(()) => false,
        Err(e) => {
            keep(e);
            true
        }
    }
}

fn keep(e: PyErr) {
    PENDING.with(|p| *p.borrow_mut() = Some(e));
}

/// The exception a signal handler (or a progress callback) raised during
/// the call, if any.
pub fn take_pending() -> Option<PyErr> {
    PENDING.with(|p| p.borrow_mut().take())
}

/// The caller's `progress=` argument made callable: `None`/`False`
/// nothing, `True` a tqdm bar (a plain line on stderr without tqdm), a
/// callable `progress(done, total, what)` itself (`gloam/_progress.py`).
pub struct ProgressSink(Option<Py<PyAny>>);

impl ProgressSink {
    pub fn new(py: Python<'_>, progress: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Self> {
        let Some(p) = progress else {
            return Ok(Self(None));
        };
        let cb = py
            .import("gloam._progress")?
            .call_method1("resolve", (p, what))?;
        Ok(Self((!cb.is_none()).then(|| cb.unbind())))
    }

    /// Tells the callback (the GIL taken); false, with the exception kept,
    /// when it raised: the work should stop.
    pub fn tell(&self, done: u64, total: u64, what: &str) -> bool {
        let Some(cb) = &self.0 else { return true };
        match Python::attach(|py| cb.call1(py, (done, total, what)).map(|_| ())) {
            Ok(()) => true,
            Err(e) => {
                keep(e);
                false
            }
        }
    }

    /// Closes a bar `resolve` made (the GIL held).
    pub fn close(&self, py: Python<'_>) {
        if let Some(cb) = &self.0 {
            if let Ok(m) = py.import("gloam._progress") {
                let _ = m.call_method1("finish", (cb,));
            }
        }
    }
}

/// Progress a worker thread reports, for the polling thread to pass on.
#[derive(Default)]
pub struct Reporter {
    state: Mutex<(u64, u64, String)>,
    changes: AtomicU64,
}

impl Reporter {
    /// `done` of `total` units of `what` (`tiles`, `tasks`, `prepare: bvh`).
    pub fn set(&self, what: &str, done: u64, total: u64) {
        if let Ok(mut s) = self.state.lock() {
            *s = (done, total, what.to_string());
        }
        self.changes.fetch_add(1, Ordering::Relaxed);
    }

    fn latest(&self) -> Option<(u64, u64, String)> {
        self.state.lock().ok().map(|s| s.clone())
    }
}

/// What the polling thread does each turn: signals, then progress. True:
/// stop the work (the exception kept).
fn poll_turn(sink: &ProgressSink, rep: &Reporter, seen: &mut u64) -> bool {
    if signalled() {
        return true;
    }
    let n = rep.changes.load(Ordering::Relaxed);
    if n != *seen {
        *seen = n;
        if let Some((d, t, w)) = rep.latest() {
            return !sink.tell(d, t, &w);
        }
    }
    false
}

/// Runs `f` without the GIL on a worker thread while this thread polls
/// Python's signal handlers and passes `f`'s progress on; `f` sees `stop`
/// turn true after Ctrl-C and should return early.
pub fn detached_with_stop<T: Send>(
    py: Python<'_>,
    sink: &ProgressSink,
    f: impl FnOnce(&AtomicBool, &Reporter) -> anyhow::Result<T> + Send,
) -> PyResult<T> {
    let stop = AtomicBool::new(false);
    let rep = Reporter::default();
    let sink_ref = SameThread(sink);
    let r = py.detach(|| {
        let sink = sink_ref.into_inner();
        let me = std::thread::current();
        let (stop, rep) = (&stop, &rep);
        let mut seen = 0;
        std::thread::scope(|s| {
            let h = s.spawn(move || {
                let r = f(stop, rep);
                me.unpark();
                r
            });
            while !h.is_finished() {
                std::thread::park_timeout(POLL);
                if !stop.load(Ordering::Relaxed)
                    && !h.is_finished()
                    && poll_turn(sink, rep, &mut seen)
                {
                    stop.store(true, Ordering::Relaxed);
                }
            }
            // The last state (e.g. every task done) reaches the callback.
            if !stop.load(Ordering::Relaxed) {
                poll_turn(sink, rep, &mut seen);
            }
            h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))
        })
    });
    sink.close(py);
    finish(r)
}

/// As [`detached_with_stop`] for work that owns everything it uses: at
/// Ctrl-C (or a raising callback) the call returns at once, even from a
/// step that cannot stop midway (a render's preparation), and the worker
/// is told to stop and drops its result whenever it ends.
pub fn detached_owned<T: Send + 'static>(
    py: Python<'_>,
    sink: &ProgressSink,
    f: impl FnOnce(&AtomicBool, Arc<Reporter>) -> anyhow::Result<T> + Send + 'static,
) -> PyResult<T> {
    let stop = Arc::new(AtomicBool::new(false));
    let rep = Arc::new(Reporter::default());
    let (tx, rx) = std::sync::mpsc::channel();
    let (s2, r2) = (stop.clone(), rep.clone());
    std::thread::Builder::new()
        .name("gloam-render".into())
        .spawn(move || {
            let _ = tx.send(f(&s2, r2));
        })
        .map_err(|e| crate::errors::GloamError::new_err(format!("starting a worker: {e}")))?;
    let sink_ref = SameThread(sink);
    let stop_poll = Arc::clone(&stop);
    let r = py.detach(move || {
        let (sink, stop, rep) = (sink_ref.into_inner(), stop_poll, rep);
        let mut seen = 0;
        loop {
            match rx.recv_timeout(POLL) {
                Ok(r) => {
                    poll_turn(sink, &rep, &mut seen);
                    return Some(r);
                }
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    return Some(Err(anyhow::anyhow!(
                        "the worker thread ended without a result"
                    )));
                }
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                    if poll_turn(sink, &rep, &mut seen) {
                        stop.store(true, Ordering::Relaxed);
                        return None;
                    }
                }
            }
        }
    });
    sink.close(py);
    match r {
        Some(r) => finish(r),
        None => Err(take_pending()
            .unwrap_or_else(|| pyo3::exceptions::PyKeyboardInterrupt::new_err("interrupted"))),
    }
}

/// The result of a detached call: the pending `KeyboardInterrupt` first.
pub fn finish<T>(r: anyhow::Result<T>) -> PyResult<T> {
    if let Some(e) = take_pending() {
        return Err(e);
    }
    r.map_err(crate::errors::to_py)
}

/// A value used only on the thread that made it, moved into a
/// `Python::detach` closure. `detach` runs its closure synchronously on
/// the calling thread (it only releases the GIL), so the value never
/// changes thread; the grabbers behind `Box<dyn FrameGrabber>` are not
/// declared `Send`, hence this wrapper.
pub struct SameThread<T>(pub T);

impl<T> SameThread<T> {
    /// The value (a method, so a closure captures the whole wrapper).
    pub fn into_inner(self) -> T {
        self.0
    }
}

// SAFETY: see the type's doc: only used with `Python::detach`, whose
// closure runs on the same thread; the wrapped value never crosses threads.
unsafe impl<T> Send for SameThread<T> {}
