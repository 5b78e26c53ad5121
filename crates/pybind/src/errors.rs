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
//! | `CoreError::SingularKkt` | `SingularKktError` (`kind`, `condition_estimate`) | of a run: the link of the first joint that moves with no inertia |
//! | `CoreError::IllPosedQuasiStatic` | `IllPosedError` | — |
//! | `RhexError::{InvalidValue, UnknownParameter, Unreadable, Unsupported, StartOverflow}`, `HybridError::InvalidOption`, `MotorError` input variants | `InvalidInputError` | the field |
//! | `HybridError::OffManifold` | `InvalidInputError` (caller's state) / `EngineError` | the field |
//! | `SimError::{InvalidValue, UnknownJoint, UnknownContact, UnknownReference, Cycle, Expression, UnknownParameter, Motor, Parse}` | `InvalidInputError` | the field, path, or what was parsed |
//! | `SimError::Io` of a file read but empty or not UTF-8 (`InvalidData`) | `InvalidInputError` | the path |
//! | `SimError::Io` otherwise | the `OSError` subclass of its kind | — |
//! | `HybridError::{TooManyContacts, ContactQp}`, `MotorError::NoConvergence`, a caught panic | `EngineError` | — |
//!
//! Variants added later fall through to `EngineError` until they are mapped here.
use motor::MotorError;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyType;
use rhex_model::RhexError;
use selfmanip_core::model::Model;
use selfmanip_core::{ContactMode, CoreError, Data, FlatGround};
use selfmanip_hybrid::HybridError;
use selfmanip_sim::SimError;

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

/// What a Rust error becomes in Python, worked out without the GIL (a sweep's worker threads
/// use the message of a failed point).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Mapped {
    pub kind: Kind,
    pub message: String,
    pub field: Option<String>,
    /// `SingularKktError`'s `kind` and `condition_estimate`.
    pub singular: Option<(String, f64)>,
}

impl Mapped {
    fn new(kind: Kind, message: impl Into<String>, field: Option<&str>) -> Self {
        Mapped {
            kind,
            message: message.into(),
            field: field.map(str::to_owned),
            singular: None,
        }
    }

    /// The Python exception.
    pub(crate) fn into_pyerr(self) -> PyErr {
        Python::attach(|py| {
            let made = self.kind.class(py).and_then(|cls| match &self.singular {
                Some((kind, cond)) => cls.call1((
                    self.message.as_str(),
                    self.field.as_deref(),
                    kind.as_str(),
                    *cond,
                )),
                None => cls.call1((self.message.as_str(), self.field.as_deref())),
            });
            match made {
                Ok(exc) => PyErr::from_value(exc),
                Err(e) => e,
            }
        })
    }
}

/// An exception of `kind` with `message`, naming `field` when there is one.
pub(crate) fn raise(kind: Kind, message: impl Into<String>, field: Option<&str>) -> PyErr {
    Mapped::new(kind, message, field).into_pyerr()
}

/// `InvalidInputError` naming `field`.
pub(crate) fn invalid(field: &str, message: impl Into<String>) -> PyErr {
    raise(Kind::InvalidInput, message, Some(field))
}

/// The value that `name` stands for among `choices` (`(name, value)` pairs), or an
/// `InvalidInputError` naming `field` that lists the names allowed:
/// ``"`field` must be "a", "b" or "c", got "x""``.
pub(crate) fn choice<T: Copy>(field: &str, name: &str, choices: &[(&str, T)]) -> PyResult<T> {
    if let Some(&(_, value)) = choices.iter().find(|(n, _)| *n == name) {
        return Ok(value);
    }
    let quoted: Vec<String> = choices.iter().map(|(n, _)| format!("{n:?}")).collect();
    let allowed = match quoted.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => quoted.concat(),
    };
    Err(invalid(
        field,
        format!("`{field}` must be {allowed}, got {name:?}"),
    ))
}

/// `InvalidTypeError` naming `field`.
pub(crate) fn invalid_type(field: &str, message: impl Into<String>) -> PyErr {
    raise(Kind::InvalidType, message, Some(field))
}

/// `EngineError`.
pub(crate) fn engine(message: impl Into<String>) -> PyErr {
    raise(Kind::Engine, message, None)
}

/// The message of a non-finite value the engine produced itself.
pub(crate) fn non_finite_state(field: &str, index: usize, value: f64) -> String {
    format!(
        "the engine produced a non-finite value ({value}) in its own state `{field}` (entry \
         {index}); the inputs were accepted, so look for extreme (finite) parameters or options"
    )
}

/// How a core error maps.
pub(crate) fn map_core(e: &CoreError, source: Source) -> Mapped {
    let msg = e.to_string();
    let input = |field: &str| Mapped::new(Kind::InvalidInput, msg.clone(), Some(field));
    match e {
        CoreError::InvalidDescription { field, .. } => input(field),
        CoreError::InvalidParameterization { field, .. } => input(field),
        CoreError::Parse { .. } => input("description"),
        CoreError::WrongLength { field, .. } => match source {
            Source::Caller => input(field),
            Source::Engine => Mapped::new(
                Kind::Engine,
                format!("internal error in selfmanip: {msg}"),
                None,
            ),
        },
        CoreError::NonFinite {
            field,
            index,
            value,
        } => match source {
            Source::Caller => input(field),
            // not the caller's `q`/`qd`: the engine's own state went non-finite
            Source::Engine => {
                Mapped::new(Kind::Engine, non_finite_state(field, *index, *value), None)
            }
        },
        CoreError::UnknownContact { .. } | CoreError::InvalidMode { .. } => input("mode"),
        CoreError::SingularKkt {
            kind,
            condition_estimate,
        } => Mapped {
            singular: Some((format!("{kind:?}"), *condition_estimate)),
            ..Mapped::new(Kind::SingularKkt, msg, None)
        },
        CoreError::IllPosedQuasiStatic { .. } => Mapped::new(Kind::IllPosed, msg, None),
        #[allow(unreachable_patterns)]
        _ => Mapped::new(Kind::Engine, msg, None),
    }
}

/// How a hybrid-engine error maps.
pub(crate) fn map_hybrid(e: &HybridError, source: Source) -> Mapped {
    let msg = e.to_string();
    match e {
        // whatever the caller passed in, the core was called with the engine's own state
        HybridError::Core(c) => map_core(c, Source::Engine),
        HybridError::InvalidOption { field, .. } => {
            Mapped::new(Kind::InvalidInput, msg, Some(field))
        }
        HybridError::OffManifold { field, .. } => match source {
            Source::Caller => Mapped::new(Kind::InvalidInput, msg, Some(field)),
            Source::Engine => Mapped::new(Kind::Engine, msg, None),
        },
        #[allow(unreachable_patterns)]
        _ => Mapped::new(Kind::Engine, msg, None),
    }
}

/// How an RHex-model error maps; `source` says whose vectors a core error talks about.
pub(crate) fn map_rhex(e: &RhexError, source: Source) -> Mapped {
    match e {
        RhexError::InvalidValue { .. }
        | RhexError::UnknownParameter { .. }
        | RhexError::Unreadable { .. }
        | RhexError::Unsupported { .. }
        | RhexError::StartOverflow { .. }
        | RhexError::ModeLabel { .. } => Mapped::new(Kind::InvalidInput, e.to_string(), e.field()),
        RhexError::Core(c) => map_core(c, source),
        RhexError::Hybrid(h) => map_hybrid(h, source),
        RhexError::Sim(s) => map_sim(s, source),
        #[allow(unreachable_patterns)]
        _ => Mapped::new(Kind::Engine, e.to_string(), None),
    }
}

/// How an error of the generic simulation crate maps: a value, name, reference, cycle,
/// expression, parameter or file of the caller's is invalid input naming its field.
pub(crate) fn map_sim(e: &SimError, source: Source) -> Mapped {
    let msg = e.to_string();
    match e {
        SimError::Core(c) => map_core(c, source),
        SimError::Hybrid(h) => map_hybrid(h, source),
        SimError::InvalidValue { field, .. }
        | SimError::UnknownJoint { field, .. }
        | SimError::UnknownContact { field, .. }
        | SimError::UnknownReference { field, .. }
        | SimError::Cycle { field, .. }
        | SimError::Expression { field, .. } => Mapped::new(Kind::InvalidInput, msg, Some(field)),
        SimError::UnknownParameter { path, .. } => Mapped::new(Kind::InvalidInput, msg, Some(path)),
        SimError::Motor { field, .. } => Mapped::new(Kind::InvalidInput, msg, Some(field)),
        // a data file or a value of the wrong shape: `what` is `behaviour`, `scenario`, …
        SimError::Parse { what, .. } => Mapped::new(Kind::InvalidInput, msg, Some(what)),
        #[allow(unreachable_patterns)]
        _ => Mapped::new(Kind::Engine, msg, None),
    }
}

/// A simulation-crate error as a Python exception; a file that cannot be read or written
/// (`SimError::Io`) is the `OSError` subclass of its kind (`FileNotFoundError`, …).
pub(crate) fn sim(e: SimError, source: Source) -> PyErr {
    match e {
        // read, but not what it should hold (empty, not UTF-8): the caller's input, named by
        // its path
        SimError::Io {
            path,
            message,
            kind: std::io::ErrorKind::InvalidData,
        } => invalid(&path, format!("{path}: {message}")),
        SimError::Io {
            path,
            message,
            kind,
        } => PyErr::from(std::io::Error::new(kind, format!("{path}: {message}"))),
        e => map_sim(&e, source).into_pyerr(),
    }
}

/// A core error as a Python exception.
pub(crate) fn core(e: CoreError, source: Source) -> PyErr {
    map_core(&e, source).into_pyerr()
}

/// An RHex-model error as a Python exception.
pub(crate) fn rhex(e: RhexError, source: Source) -> PyErr {
    map_rhex(&e, source).into_pyerr()
}

/// A motor-crate error.
pub(crate) fn motor(e: MotorError) -> PyErr {
    let msg = e.to_string();
    match e {
        MotorError::InvalidParameter { field, .. }
        | MotorError::NonFiniteSample { field, .. }
        | MotorError::LengthMismatch { field, .. }
        | MotorError::TooFewSamples { field, .. }
        | MotorError::TooManySamples { field, .. }
        | MotorError::Overflow { field, .. }
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
        selfmanip_sim::sweep::panic_message(payload)
    ))
}

/// The joints whose motion has no inertia at `q`: the directions of the mass matrix `M̄(q)`
/// (4.24) with a vanishing eigenvalue, the motion Lemma 5.1 calls unconstrained and massless
/// when no contact pins it. A joint is named when it carries a tenth of such a direction.
pub(crate) fn inertia_free_joints(model: &Model, q: &[f64]) -> Vec<usize> {
    let nq = model.nq();
    if q.len() != nq || q.iter().any(|x| !x.is_finite()) {
        return Vec::new();
    }
    let mut data = Data::new(model);
    // flight: M̄ only (a singular KKT matrix in flight is the very thing being explained)
    match data.prepare(model, &FlatGround, ContactMode::FLIGHT, q, &vec![0.0; nq]) {
        Ok(()) | Err(CoreError::SingularKkt { .. }) => {}
        Err(_) => return Vec::new(),
    }
    let eig = nalgebra::SymmetricEigen::new(data.m_bar.clone());
    let scale = eig.eigenvalues.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let mut joints = Vec::new();
    for (i, &lambda) in eig.eigenvalues.iter().enumerate() {
        if lambda.is_nan() || lambda.abs() > 1e-12 * scale {
            continue;
        }
        let v = eig.eigenvectors.column(i);
        let vmax = v.amax();
        for j in 0..model.n_joints() {
            if v[j].abs() >= 0.1 * vmax && !joints.contains(&j) {
                joints.push(j);
            }
        }
    }
    joints.sort_unstable();
    joints
}

impl Mapped {
    /// A `SingularKktError` of unconstrained massless motion names the joints that move with
    /// no inertia at `q` ([`inertia_free_joints`]) and the description field of the first
    /// one's link; other errors pass unchanged.
    pub(crate) fn naming_massless_joints(mut self, model: &Model, q: &[f64]) -> Self {
        let massless = matches!(&self.singular, Some((k, _)) if k == "UnconstrainedMasslessMotion");
        if !massless {
            return self;
        }
        let joints = inertia_free_joints(model, q);
        let Some(&first) = joints.first() else {
            return self;
        };
        let names: Vec<String> = joints
            .iter()
            .map(|&j| format!("`{}`", selfmanip_sim::labels::joint_name(model, j)))
            .collect();
        let joint = &model.joints[first];
        self.message = format!(
            "{}: joint(s) {} move with no inertia (their links and those beyond carry no mass \
             off the joint axis, no rotational inertia and no armature) and no contact pins them",
            self.message,
            names.join(", ")
        );
        self.field = Some(format!("legs[{}].links[{}]", joint.leg, joint.index_in_leg));
        self
    }
}
