//! Batched executions on an explicit rayon pool.
//!
//! **Determinism.** Every point is a pure function of the base and the point: no state is
//! shared between points and results are collected in input order, so a sweep is
//! bit-identical for any thread count.
//!
//! **Failure isolation.** A point whose inputs are invalid, whose execution fails, or that
//! panics becomes a result with a failed status and the error; the other points are
//! unaffected. Only a malformed sweep (an unknown parameter name, zero threads) is an error
//! of the whole call.
//!
//! **One task per point** (`with_max_len(1)`): rayon's default splitting hands each thread
//! runs of neighbouring points, whose costs are correlated (a range of long runs), and loses
//! ~20 % to the imbalance on 2 threads.
use crate::error::SimError;
use rayon::prelude::*;

/// Runs `f` on every item on a pool of exactly `threads` threads; results in input order.
pub fn run_parallel<T: Sync, R: Send>(
    items: &[T],
    threads: usize,
    f: impl Fn(&T) -> R + Sync + Send,
) -> Result<Vec<R>, SimError> {
    if threads == 0 {
        return Err(SimError::InvalidValue {
            field: "threads".into(),
            reason: "must be at least 1".into(),
        });
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| SimError::InvalidValue {
            field: "threads".into(),
            reason: format!("cannot start a pool of {threads} threads: {e}"),
        })?;
    Ok(pool.install(|| items.par_iter().with_max_len(1).map(f).collect()))
}

/// The text of a caught panic's payload (`"unknown panic"` when it is not a string).
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "unknown panic".into())
}

/// Runs `f`, turning a panic into `Err(message)`.
pub fn catch_panic<R>(f: impl FnOnce() -> R) -> Result<R, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f))
        .map_err(|p| panic_message(p.as_ref()))
}

