//! Ctrl-C during long Rust work.
//!
//! Python runs its signal handlers only on the main thread and only between bytecodes, so a
//! call that sits in Rust for seconds cannot be interrupted, and the `KeyboardInterrupt`
//! surfaces later, somewhere else. [`run`] moves the work to a worker thread (which owns its
//! inputs) and keeps the calling thread free: it waits with the GIL released, and every
//! [`POLL`] it checks Python's signals and reports progress. On an exception from a signal
//! handler (`KeyboardInterrupt`) it raises the shared cancellation flag and returns the
//! exception at once; the worker sees the flag (a sweep checks it before every point; the
//! engine's own interrupt hook, once it has one, within a leap), finishes what it cannot stop
//! and exits on its own, its result discarded.
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Arc;
use std::time::Duration;

/// How often the waiting thread checks for signals and reports progress.
pub(crate) const POLL: Duration = Duration::from_millis(25);

/// What the worker shares with the waiting thread.
#[derive(Default)]
pub(crate) struct Shared {
    /// Set by the waiting thread on Ctrl-C; the work polls it.
    pub cancel: AtomicBool,
    /// Units of work done so far (points of a sweep), for a progress callback.
    pub done: AtomicUsize,
}

impl Shared {
    pub(crate) fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
    pub(crate) fn tick(&self) {
        self.done.fetch_add(1, Ordering::Relaxed);
    }
}

/// Runs `work` on a worker thread with the GIL released, interruptible by Ctrl-C (see the
/// module documentation). `progress`, if given, is called with the number of units done each
/// time it changes (at most every [`POLL`]) and once at the end.
pub(crate) fn run<T: Send + 'static>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&Shared) -> T + Send + 'static,
) -> PyResult<T> {
    let shared = Arc::new(Shared::default());
    let (tx, rx) = mpsc::sync_channel(1);
    let theirs = Arc::clone(&shared);
    std::thread::Builder::new()
        .name("selfmanip-work".into())
        .spawn(move || {
            let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&theirs)));
            // the receiver is gone when the call was interrupted: nothing to deliver
            let _ = tx.send(out);
        })
        .map_err(|e| crate::errors::engine(format!("cannot start a worker thread: {e}")))?;
    let mut reported = usize::MAX;
    let mut rx = Some(rx);
    loop {
        // the receiver is `Send` but not `Sync`: it travels into the GIL-free wait and back
        let (back, got) = py.detach(move || {
            let r = rx
                .take()
                .expect("the receiver is returned after every wait");
            let got = r.recv_timeout(POLL);
            (r, got)
        });
        rx = Some(back);
        if let Some(cb) = progress {
            let done = shared.done.load(Ordering::Relaxed);
            if done != reported {
                reported = done;
                if let Err(e) = cb.call1((done,)) {
                    shared.cancel.store(true, Ordering::Relaxed);
                    return Err(e);
                }
            }
        }
        match got {
            Ok(Ok(out)) => return Ok(out),
            Ok(Err(p)) => return Err(crate::errors::panic(p.as_ref())),
            Err(RecvTimeoutError::Timeout) => {
                if let Err(e) = py.check_signals() {
                    shared.cancel.store(true, Ordering::Relaxed);
                    return Err(e);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(crate::errors::engine(
                    "the worker thread ended without a result",
                ))
            }
        }
    }
}
