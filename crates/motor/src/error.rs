//! The one error type of the motor crate.
use thiserror::Error;

/// `x` as a message shows it: in exponent form when plain digits would run long (1e308 is
/// 309 digits, 1e-300 three hundred zeros), as written otherwise.
fn shown(x: f64) -> String {
    if x != 0.0 && !(1e-6..1e16).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// Errors of the actuator models. Every public constructor and analysis checks its inputs
/// and returns one of these instead of panicking or producing NaN.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum MotorError {
    /// A physical parameter is out of its domain (negative resistance, zero gear ratio, …).
    #[error("`{field}` = {}: {reason}", shown(*value))]
    InvalidParameter {
        field: &'static str,
        value: f64,
        reason: &'static str,
    },
    /// A logged or profiled sample is NaN or infinite.
    #[error("`{field}` has a non-finite sample at index {index} ({value})")]
    NonFiniteSample {
        field: &'static str,
        index: usize,
        value: f64,
    },
    /// Two logged signals that must pair up sample by sample have different lengths.
    #[error("`{field}` has {actual} samples, expected {expected}")]
    LengthMismatch {
        field: &'static str,
        expected: usize,
        actual: usize,
    },
    /// Too few samples for the requested fit or simulation.
    #[error("`{field}` needs at least {required} samples, got {actual}")]
    TooFewSamples {
        field: &'static str,
        required: usize,
        actual: usize,
    },
    /// A sample count asked for is beyond what the routine allocates (bounded cost).
    #[error("`{field}` asks for {actual} samples, more than the {limit} allowed")]
    TooManySamples {
        field: &'static str,
        limit: usize,
        actual: usize,
    },
    /// Inputs each inside its domain whose result overflows double precision (a heat input
    /// so large that the winding's temperature is infinite): `field` names the inputs.
    #[error("`{field}`: {quantity} overflows double precision")]
    Overflow {
        field: &'static str,
        quantity: &'static str,
    },
    /// A catalog or candidate list is empty.
    #[error("`{field}` is empty")]
    EmptyCatalog { field: &'static str },
    /// A catalog entry refers to a motor or gearbox that the catalog does not contain.
    #[error("no {kind} named `{name}` in the catalog")]
    UnknownEntry { kind: &'static str, name: String },
    /// The catalog file does not parse.
    #[error("could not parse the catalog: {message}")]
    Parse { message: String },
    /// A root finder or optimizer failed to converge (reported, never guessed).
    #[error("{what} did not converge: {reason}")]
    NoConvergence { what: &'static str, reason: String },
}

pub type Result<T> = std::result::Result<T, MotorError>;

/// Checks that `value` is finite and strictly positive.
pub(crate) fn positive(field: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(MotorError::InvalidParameter {
            field,
            value,
            reason: "must be finite and > 0",
        })
    }
}

/// Checks that `value` is finite and non-negative.
pub(crate) fn non_negative(field: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(MotorError::InvalidParameter {
            field,
            value,
            reason: "must be finite and >= 0",
        })
    }
}

/// Checks that `value` is finite.
pub(crate) fn finite(field: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(MotorError::InvalidParameter {
            field,
            value,
            reason: "must be finite",
        })
    }
}

/// Checks that a sample count is at most `limit`.
pub(crate) fn at_most(field: &'static str, actual: usize, limit: usize) -> Result<usize> {
    if actual <= limit {
        Ok(actual)
    } else {
        Err(MotorError::TooManySamples {
            field,
            limit,
            actual,
        })
    }
}

/// Checks that a computed `value` is finite, else [`MotorError::Overflow`] naming the inputs.
pub(crate) fn no_overflow(field: &'static str, quantity: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(MotorError::Overflow { field, quantity })
    }
}

/// Checks every sample of a logged signal.
pub(crate) fn finite_samples(field: &'static str, samples: &[f64]) -> Result<()> {
    match samples.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(MotorError::NonFiniteSample {
            field,
            index,
            value: samples[index],
        }),
        None => Ok(()),
    }
}
