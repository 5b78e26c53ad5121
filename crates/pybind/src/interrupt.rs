//! Ctrl-C during long Rust work.
//!
//! Python runs its signal handlers only on the main thread and only between bytecodes, so a
//! call that sits in Rust for seconds cannot be interrupted, and the `KeyboardInterrupt`
//! surfaces later, somewhere else. [`run`] moves the work to a worker thread (the work owns
//! its inputs) and keeps the calling thread free: it waits with the GIL released, and every
//! [`POLL`] it checks Python's signals and reports progress. On an exception from a signal
//! handler (`KeyboardInterrupt`) it raises the shared cancellation flag and returns the
//! exception at once; the worker sees the flag (a sweep checks it before every point; the
//! engine's own interrupt hook, once it has one, within a leap), finishes what it cannot stop
//! and exits on its own, its result discarded.
//!
//! **Workers.** Starting a thread costs tens of microseconds on an idle machine and more than
//! a hundred under load, a sizeable part of a 0.6 ms leap; a worker therefore stays, blocked
//! on its job channel, once its job is done, and the next call reuses it. There is one per call
//! in flight (normally one in all; one more for each call abandoned to Ctrl-C while it still
//! runs). A forked child does not inherit threads, so it starts its own.
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// A job; it calls its argument once its work is done and before it delivers the result, so
/// that its worker is idle again by the time the caller can ask for the next job.
type Job = Box<dyn FnOnce(&dyn Fn()) + Send>;

/// Idle workers: the job channel of each, with the process that started it.
static IDLE: Mutex<Vec<(u32, mpsc::Sender<Job>)>> = Mutex::new(Vec::new());

fn idle() -> std::sync::MutexGuard<'static, Vec<(u32, mpsc::Sender<Job>)>> {
    IDLE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Hands `job` to an idle worker of this process, or to a new one.
fn submit(job: Job) -> PyResult<()> {
    let pid = std::process::id();
    let mut job = job;
    loop {
        let found = {
            let mut list = idle();
            list.retain(|(p, _)| *p == pid); // a forked child's inherited list names no thread
            list.pop()
        };
        let Some((_, tx)) = found else { break };
        match tx.send(job) {
            Ok(()) => return Ok(()),
            Err(mpsc::SendError(back)) => job = back, // that worker is gone: try another
        }
    }
    let (tx, rx) = mpsc::channel::<Job>();
    let me = tx.clone();
    std::thread::Builder::new()
        .name("selfmanip-work".into())
        .spawn(move || {
            for job in rx {
                job(&|| idle().push((pid, me.clone())));
            }
        })
        .map_err(|e| crate::errors::engine(format!("cannot start a worker thread: {e}")))?;
    tx.send(job)
        .map_err(|_| crate::errors::engine("the new worker thread is gone"))
}

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

/// Waits up to [`POLL`] for the worker's result with the GIL released. The receiver is
/// `Send` but not `Sync`: it travels into the GIL-free wait and back.
fn wait<R: Send>(
    py: Python<'_>,
    rx: &mut Option<mpsc::Receiver<R>>,
) -> Result<R, RecvTimeoutError> {
    let r = rx
        .take()
        .expect("the receiver is returned after every wait");
    let (back, got) = py.detach(move || {
        let got = r.recv_timeout(POLL);
        (r, got)
    });
    *rx = Some(back);
    got
}

/// Runs `work` on a worker thread with the GIL released, interruptible by Ctrl-C (see the
/// module documentation). `progress`, if given, is called with the number of units done each
/// time it changes (at most every [`POLL`]) and once at the end.
pub(crate) fn run<T: Send + 'static>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&Shared) -> T + Send + 'static,
) -> PyResult<T> {
    run_shared(py, progress, Arc::new(Shared::default()), work)
}

/// [`run`] with a [`Shared`] the caller made, so that something else it hands to the work
/// (a Python controller that failed) can raise the same cancellation flag.
pub(crate) fn run_shared<T: Send + 'static>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    shared: Arc<Shared>,
    work: impl FnOnce(&Shared) -> T + Send + 'static,
) -> PyResult<T> {
    let (tx, rx) = mpsc::sync_channel(1);
    let theirs = Arc::clone(&shared);
    submit(Box::new(move |done: &dyn Fn()| {
        let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&theirs)));
        done();
        // the receiver is gone when the call was interrupted: nothing to deliver
        let _ = tx.send(out);
    }))?;
    let mut reported = usize::MAX;
    let mut rx = Some(rx);
    loop {
        let got = wait(py, &mut rx);
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

/// Runs `work`, which borrows the caller's data, on a scoped thread with the GIL released,
/// checking Python's signals every [`POLL`]. On Ctrl-C it raises the flag `work` is given and
/// waits for `work` to return (it checks the flag often: an interrupted file write stops at
/// its next record and removes its temporary file), then raises the `KeyboardInterrupt`: the
/// call has ended, nothing of it runs on, and nothing it wrote is left half done.
pub(crate) fn run_borrowed<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&AtomicBool) -> T + Send,
) -> PyResult<T> {
    let cancel = AtomicBool::new(false);
    std::thread::scope(|scope| {
        let (tx, rx) = mpsc::sync_channel(1);
        let cancel = &cancel;
        scope.spawn(move || {
            let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(cancel)));
            let _ = tx.send(out);
        });
        let mut signal = None;
        let mut rx = Some(rx);
        loop {
            let got = wait(py, &mut rx);
            match got {
                Ok(Ok(out)) => return signal.map_or(Ok(out), Err),
                Ok(Err(p)) => {
                    return Err(signal.unwrap_or_else(|| crate::errors::panic(p.as_ref())))
                }
                Err(RecvTimeoutError::Timeout) => {
                    if signal.is_none() {
                        if let Err(e) = py.check_signals() {
                            cancel.store(true, Ordering::Relaxed);
                            signal = Some(e);
                        }
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(signal.unwrap_or_else(|| {
                        crate::errors::engine("the worker thread ended without a result")
                    }))
                }
            }
        }
    })
}
