//! The Rust error enums mapped, variant by variant, to the exception classes of
//! `selfmanip.errors` (defined in Python so that they can inherit from both
//! `SelfmanipError` and `ValueError` / `TypeError` / `RuntimeError`, and pickle by name).
//!
//! | variant | Python class | `field` |
//! |---|---|---|
//! | `CoreError::{InvalidDescription, InvalidParameterization}` | `InvalidInputError` | the field |
//! | `CoreError::Parse` | `InvalidInputError` | `description` |
//! | `CoreError::{WrongLength, NonFinite}` from the caller's own vectors | `InvalidInputError` | the field |
//! | `CoreError::{WrongLength, NonFinite}` inside a simulation | `EngineError` | — |
//! | `CoreError::{UnknownContact, InvalidMode}`, `RhexError::ModeLabel` | `InvalidInputError` | `mode` |
//! | `CoreError::SingularKkt` | `SingularKktError` (`kind`, `condition_estimate`) | — |
//! | `CoreError::IllPosedQuasiStatic` | `IllPosedError` | — |
//! | `RhexError::Params`, `HybridError::InvalidOption`, `MotorError` input variants | `InvalidInputError` | the field |
//! | `HybridError::OffManifold` | `InvalidInputError` (caller's state) / `EngineError` | the field |
//! | `HybridError::{StepTooSmall, TooManyContacts, ContactQp}`, `MotorError::NoConvergence`, a caught panic | `EngineError` | — |
//!
//! Variants added later fall through to `EngineError` until they are mapped here.
use motor::MotorError;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyType;
use rhex_model::RhexError;
use selfmanip_core::CoreError;
use selfmanip_hybrid::HybridError;

/// Where the vectors an error talks about came from: the caller (a `q` they passed names their
/// input) or the engine (a `qd` of a running simulation is the engine's own state).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Source {
    Caller,
    Engine,
}

/// The exception classes of `selfmanip.errors`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    InvalidInput,
    InvalidType,
    SingularKkt,
    IllPosed,
    Engine,
}

impl Kind {
    fn class_name(self) -> &'static str {
        match self {
            Kind::InvalidInput => "InvalidInputError",
            Kind::InvalidType => "InvalidTypeError",
            Kind::SingularKkt => "SingularKktError",
            Kind::IllPosed => "IllPosedError",
            Kind::Engine => "EngineError",
        }
    }

    fn cell(self) -> &'static PyOnceLock<Py<PyType>> {
        static CELLS: [PyOnceLock<Py<PyType>>; 5] = [
            PyOnceLock::new(),
            PyOnceLock::new(),
            PyOnceLock::new(),
            PyOnceLock::new(),
            PyOnceLock::new(),
        ];
        &CELLS[self as usize]
    }

    /// The Python class (imported once).
    pub(crate) fn class<'py>(self, py: Python<'py>) -> PyResult<&'py Bound<'py, PyType>> {
        self.cell()
            .import(py, "selfmanip.errors", self.class_name())
    }
}

/// An exception of `kind` with `message`, naming `field` when there is one.
pub(crate) fn raise(kind: Kind, message: impl Into<String>, field: Option<&str>) -> PyErr {
    let message = message.into();
    Python::attach(|py| {
        let made = kind
            .class(py)
            .and_then(|cls| cls.call1((message.as_str(), field)));
        match made {
            Ok(exc) => PyErr::from_value(exc),
            Err(e) => e,
        }
    })
}

/// `InvalidInputError` naming `field`.
pub(crate) fn invalid(field: &str, message: impl Into<String>) -> PyErr {
    raise(Kind::InvalidInput, message, Some(field))
}

/// `InvalidTypeError` naming `field`.
pub(crate) fn invalid_type(field: &str, message: impl Into<String>) -> PyErr {
    raise(Kind::InvalidType, message, Some(field))
}

/// `EngineError`.
pub(crate) fn engine(message: impl Into<String>) -> PyErr {
    raise(Kind::Engine, message, None)
}

/// A core error.
pub(crate) fn core(e: CoreError, source: Source) -> PyErr {
    let msg = e.to_string();
    match e {
        CoreError::InvalidDescription { field, .. } => invalid(&field, msg),
        CoreError::InvalidParameterization { field, .. } => invalid(field, msg),
        CoreError::Parse { .. } => invalid("description", msg),
        CoreError::WrongLength { field, .. } => match source {
            Source::Caller => invalid(field, msg),
            Source::Engine => engine(format!("internal error in selfmanip: {msg}")),
        },
        CoreError::NonFinite {
            field,
            index,
            value,
        } => match source {
            Source::Caller => invalid(field, msg),
            // not the caller's `q`/`qd`: the engine's own state went non-finite
            Source::Engine => engine(non_finite_state(field, index, value)),
        },
        CoreError::UnknownContact { .. } | CoreError::InvalidMode { .. } => invalid("mode", msg),
        CoreError::SingularKkt {
            kind,
            condition_estimate,
        } => Python::attach(|py| {
            let made = Kind::SingularKkt.class(py).and_then(|cls| {
                cls.call1((
                    msg.as_str(),
                    py.None(),
                    format!("{kind:?}"),
                    condition_estimate,
                ))
            });
            match made {
                Ok(exc) => PyErr::from_value(exc),
                Err(e) => e,
            }
        }),
        CoreError::IllPosedQuasiStatic { .. } => raise(Kind::IllPosed, msg, None),
        #[allow(unreachable_patterns)]
        _ => engine(msg),
    }
}

/// The message of a non-finite value the engine produced itself.
pub(crate) fn non_finite_state(field: &str, index: usize, value: f64) -> String {
    format!(
        "the engine produced a non-finite value ({value}) in its own state `{field}` (entry \
         {index}); the inputs were accepted, so look for extreme (finite) parameters or options"
    )
}

/// A hybrid-engine error.
pub(crate) fn hybrid(e: HybridError, source: Source) -> PyErr {
    let msg = e.to_string();
    match e {
        // whatever the caller passed in, the core was called with the engine's own state
        HybridError::Core(c) => core(c, Source::Engine),
        HybridError::InvalidOption { field, .. } => invalid(field, msg),
        HybridError::OffManifold { field, .. } => match source {
            Source::Caller => invalid(field, msg),
            Source::Engine => engine(msg),
        },
        #[allow(unreachable_patterns)]
        _ => engine(msg),
    }
}

/// An RHex-model error; `source` says whose vectors a core error talks about.
pub(crate) fn rhex(e: RhexError, source: Source) -> PyErr {
    match e {
        RhexError::Params { ref field, .. } => invalid(field, e.to_string()),
        RhexError::ModeLabel { .. } => invalid("mode", e.to_string()),
        RhexError::Core(c) => core(c, source),
        RhexError::Hybrid(h) => hybrid(h, source),
        #[allow(unreachable_patterns)]
        _ => engine(e.to_string()),
    }
}

/// A motor-crate error.
pub(crate) fn motor(e: MotorError) -> PyErr {
    let msg = e.to_string();
    match e {
        MotorError::InvalidParameter { field, .. }
        | MotorError::NonFiniteSample { field, .. }
        | MotorError::LengthMismatch { field, .. }
        | MotorError::TooFewSamples { field, .. }
        | MotorError::EmptyCatalog { field } => invalid(field, msg),
        MotorError::UnknownEntry { kind, .. } => invalid(kind, msg),
        MotorError::Parse { .. } => invalid("catalog_toml", msg),
        MotorError::NoConvergence { .. } => engine(msg),
        #[allow(unreachable_patterns)]
        _ => engine(msg),
    }
}

/// Runs `f`, turning an unexpected Rust panic into an `EngineError` instead of aborting the
/// interpreter (belt and braces: the engine returns errors, not panics).
pub(crate) fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => Err(panic(p.as_ref())),
    }
}

/// The `EngineError` of a caught panic.
pub(crate) fn panic(payload: &(dyn std::any::Any + Send)) -> PyErr {
    engine(format!(
        "internal error in selfmanip (a bug, please report it): {}",
        rhex_model::sweep::panic_message(payload)
    ))
}
