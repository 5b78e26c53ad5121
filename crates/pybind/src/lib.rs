//! Thin pyo3 layer: `selfmanip._native`.
//!
//! Everything here converts between Python and the Rust crates and nothing more. Inputs are
//! checked by the Rust entry points; their typed errors are mapped variant by variant to the
//! exception classes of `selfmanip.errors` ([`errors`]). Structured values cross as Python
//! objects and numpy arrays ([`convert`]), never as JSON text. Defaults are the Rust crates'
//! own. Long work runs with the GIL released and is interruptible by Ctrl-C ([`interrupt`]).
//! No call can panic across the FFI: errors are values, and every entry point is additionally
//! guarded by [`errors::guard`].

/// Adds the `#[pyfunction]`s named to the module `m`: `add_functions! { m, f, g, … }`.
macro_rules! add_functions {
    ($m:expr, $($f:ident),+ $(,)?) => {{
        $($m.add_function(pyo3::wrap_pyfunction!($f, $m)?)?;)+
    }};
}

mod analysis;
mod convert;
mod errors;
mod interrupt;
mod leap;
mod motor;
mod robot;
mod sim;
mod spatial;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    robot::register(m)?;
    motor::register(m)?;
    analysis::register(m)?;
    leap::register(m)?;
    sim::register(m)?;
    spatial::register(m)?;
    Ok(())
}
