//! Thin pyo3 layer: `selfmanip._native`.
//!
//! Everything here converts between Python and the Rust crates and nothing more: inputs
//! are checked by the Rust entry points (typed errors become [`SelfmanipError`], a
//! `ValueError` subclass whose message names the offending field), outputs are numpy
//! arrays inside plain dicts that the Python package (`python/selfmanip`) wraps in
//! documented dataclasses. No call can panic across the FFI: errors are values, and
//! every entry point is additionally guarded by `guard`.
mod analysis;
mod leap;
mod motor;
mod robot;

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

create_exception!(
    selfmanip,
    SelfmanipError,
    PyValueError,
    "Invalid input or an ill-posed problem reported by the selfmanip engine."
);
create_exception!(
    selfmanip,
    SingularKktError,
    SelfmanipError,
    "The KKT matrix of (5.2) is singular (Lemma 5.1); the message carries the condition estimate."
);

/// Maps a Rust error to the Python exception hierarchy.
pub(crate) fn to_py_err(e: impl std::fmt::Display + 'static) -> PyErr {
    let msg = e.to_string();
    if msg.starts_with("KKT matrix is singular") {
        SingularKktError::new_err(msg)
    } else {
        SelfmanipError::new_err(msg)
    }
}

/// Runs `f`, turning an unexpected Rust panic into a Python `RuntimeError` instead of
/// aborting the interpreter (belt and braces: the engine returns errors, not panics).
pub(crate) fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => Err(pyo3::exceptions::PyRuntimeError::new_err(format!(
            "internal error in selfmanip: {}",
            selfmanip_sim::sweep::panic_message(p.as_ref())
        ))),
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SelfmanipError", m.py().get_type::<SelfmanipError>())?;
    m.add("SingularKktError", m.py().get_type::<SingularKktError>())?;
    robot::register(m)?;
    motor::register(m)?;
    analysis::register(m)?;
    leap::register(m)?;
    Ok(())
}
