//! The one error type of the simulation crate: every variant carries the field or path it
//! is about, so that a binding can map variants to exception classes and a user can find
//! the line of a data file at fault.
use selfmanip_core::CoreError;
use selfmanip_hybrid::HybridError;
use thiserror::Error;

#[derive(Debug, Clone, Error, PartialEq)]
pub enum SimError {
    /// A value out of its domain (a negative gain, NaN, an empty list, …).
    #[error("`{field}`: {reason}")]
    InvalidValue { field: String, reason: String },
    /// A behaviour names a joint the robot does not have.
    #[error("`{field}`: no joint named `{name}` (joints: {known})")]
    UnknownJoint {
        field: String,
        name: String,
        known: String,
    },
    /// A behaviour or an initial state names a contact the robot does not have.
    #[error("`{field}`: no contact named `{name}` (contacts: {known})")]
    UnknownContact {
        field: String,
        name: String,
        known: String,
    },
    /// A behaviour refers to an event, phase, actuator or parameter it does not define.
    #[error("`{field}`: no {kind} named `{name}` (known: {known})")]
    UnknownReference {
        field: String,
        kind: &'static str,
        name: String,
        known: String,
    },
    /// Parameters, named events or phases that refer to each other in a cycle.
    #[error("`{field}`: cyclic references: {}", cycle.join(" -> "))]
    Cycle { field: String, cycle: Vec<String> },
    /// An expression that does not parse.
    #[error("`{field}`: expression `{expr}`: {reason}")]
    Expression {
        field: String,
        expr: String,
        reason: String,
    },
    /// A parameter path that names nothing settable.
    #[error("unknown parameter `{path}`: {reason}")]
    UnknownParameter { path: String, reason: String },
    /// A file that does not parse (TOML or JSON), or a value of the wrong type.
    #[error("could not parse {what} ({format}): {message}")]
    Parse {
        what: String,
        format: &'static str,
        message: String,
    },
    /// A file that cannot be read or written (`kind`: the operating system's reason, so a
    /// binding can raise its own error for it — not found, permission denied, …).
    #[error("{path}: {message}")]
    Io {
        path: String,
        message: String,
        kind: std::io::ErrorKind,
    },
    /// The MCAP writer failed.
    #[error("MCAP log: {message}")]
    Mcap { message: String },
    /// A motor or gearbox that the catalog does not have, or a bad motor parameter.
    #[error("`{field}`: {source}")]
    Motor {
        field: String,
        #[source]
        source: motor::MotorError,
    },
    #[error(transparent)]
    Core(#[from] CoreError),
    #[error(transparent)]
    Hybrid(#[from] HybridError),
}

impl SimError {
    /// A stable, short name of the variant (for sweep tables and error mapping).
    pub fn kind(&self) -> &'static str {
        use selfmanip_core::CoreError as C;
        match self {
            SimError::InvalidValue { .. } => "invalid_value",
            SimError::UnknownJoint { .. } => "unknown_joint",
            SimError::UnknownContact { .. } => "unknown_contact",
            SimError::UnknownReference { .. } => "unknown_reference",
            SimError::Cycle { .. } => "cycle",
            SimError::Expression { .. } => "expression",
            SimError::UnknownParameter { .. } => "unknown_parameter",
            SimError::Parse { .. } => "parse",
            SimError::Io { .. } => "io",
            SimError::Mcap { .. } => "mcap",
            SimError::Motor { .. } => "invalid_value",
            SimError::Core(c) | SimError::Hybrid(HybridError::Core(c)) => match c {
                C::SingularKkt { .. } => "singular_kkt",
                C::NonFinite { .. } => "non_finite",
                C::IllPosedQuasiStatic { .. } => "ill_posed",
                C::InvalidDescription { .. } | C::InvalidParameterization { .. } => "invalid_value",
                C::Parse { .. } => "parse",
                C::UnknownContact { .. } => "unknown_contact",
                _ => "engine_error",
            },
            SimError::Hybrid(h) => match h {
                HybridError::OffManifold { .. } => "off_manifold",
                HybridError::InvalidOption { .. } => "invalid_value",
                HybridError::TooManyContacts { .. } => "too_many_contacts",
                HybridError::ContactQp(_) => "contact_qp",
                _ => "engine_error",
            },
        }
    }

    /// Whether the error is about the inputs (as opposed to the engine failing on them).
    pub fn is_input_error(&self) -> bool {
        matches!(
            self.kind(),
            "invalid_value"
                | "unknown_joint"
                | "unknown_contact"
                | "unknown_reference"
                | "cycle"
                | "expression"
                | "unknown_parameter"
                | "parse"
                | "off_manifold"
        )
    }
}

pub(crate) fn invalid(field: impl Into<String>, reason: impl Into<String>) -> SimError {
    SimError::InvalidValue {
        field: field.into(),
        reason: reason.into(),
    }
}

/// `v` finite, else an error naming `field`.
pub(crate) fn finite(field: &str, v: f64) -> Result<f64, SimError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(invalid(field, format!("must be finite, got {v}")))
    }
}

/// `v` finite and `≥ 0`, else an error naming `field`.
pub(crate) fn non_negative(field: &str, v: f64) -> Result<f64, SimError> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(invalid(
            field,
            format!("must be finite and non-negative, got {v}"),
        ))
    }
}

/// `v` finite and `> 0`, else an error naming `field`.
pub(crate) fn positive(field: &str, v: f64) -> Result<f64, SimError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(invalid(
            field,
            format!("must be finite and positive, got {v}"),
        ))
    }
}
