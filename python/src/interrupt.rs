//! Ctrl-C while the GIL is released.
//!
//! Python runs its signal handlers only on the main thread, when asked. A
//! long call therefore releases the GIL and, between units of work (a
//! frame, a tile), briefly takes it back to run them
//! (`Python::check_signals`); the `KeyboardInterrupt` they raise is kept
//! here and re-raised when the call returns, and the work stops early.
//! Nothing is written to disk by these calls, so nothing is half-written.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use pyo3::prelude::*;

thread_local! {
    static PENDING: RefCell<Option<PyErr>> = const { RefCell::new(None) };
}

/// Runs Python's signal handlers; true (and the exception kept) when one
/// raised, i.e. the caller should stop.
pub fn signalled() -> bool {
    if PENDING.with(|p| p.borrow().is_some()) {
        return true;
    }
    match Python::attach(|py| py.check_signals()) {
        Ok(()) => false,
        Err(e) => {
            PENDING.with(|p| *p.borrow_mut() = Some(e));
            true
        }
    }
}

/// The exception a signal handler raised during the call, if any.
pub fn take_pending() -> Option<PyErr> {
    PENDING.with(|p| p.borrow_mut().take())
}

/// Runs `f` without the GIL on a worker thread while this thread polls
/// Python's signal handlers; `f` sees `stop` turn true after Ctrl-C and
/// should return early.
pub fn detached_with_stop<T: Send>(
    py: Python<'_>,
    f: impl FnOnce(&AtomicBool) -> anyhow::Result<T> + Send,
) -> PyResult<T> {
    let stop = AtomicBool::new(false);
    let r = py.detach(|| {
        let me = std::thread::current();
        let stop = &stop;
        std::thread::scope(|s| {
            let h = s.spawn(move || {
                let r = f(stop);
                me.unpark();
                r
            });
            while !h.is_finished() {
                std::thread::park_timeout(Duration::from_millis(50));
                if !stop.load(Ordering::Relaxed) && !h.is_finished() && signalled() {
                    stop.store(true, Ordering::Relaxed);
                }
            }
            h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))
        })
    });
    finish(r)
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
