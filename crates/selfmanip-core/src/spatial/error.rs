//! The error type of the spatial module: every bad input names its field.
use crate::error::CoreError;
use thiserror::Error;

#[derive(Debug, Clone, Error, PartialEq)]
pub enum SpatialError {
    /// The URDF text could not be read or parsed (`urdf-rs`'s message; an unknown joint type
    /// string ends here, since the parser rejects it).
    #[error("could not read URDF: {message}")]
    UrdfParse { message: String },
    /// A field of the URDF is invalid: `field` names it as `link[NAME].inertial.mass`,
    /// `joint[NAME].parent`, ….
    #[error("URDF field `{field}`: {reason}")]
    InvalidUrdf { field: String, reason: String },
    /// A state or input vector has the wrong length.
    #[error("`{field}` has length {actual}, expected {expected}")]
    WrongLength {
        field: &'static str,
        expected: usize,
        actual: usize,
    },
    /// A state or input vector has a NaN or infinite entry.
    #[error("`{field}` has a non-finite entry at index {index} ({value})")]
    NonFinite {
        field: &'static str,
        index: usize,
        value: f64,
    },
    /// The base quaternion of `q` is not of unit norm (to 1e-9).
    #[error("`{field}`: the base quaternion (entries 3..7) has norm {norm}, not 1")]
    NonUnitQuaternion { field: &'static str, norm: f64 },
    /// No frame (link or joint) of this name.
    #[error("unknown frame `{name}`")]
    UnknownFrame { name: String },
    /// An invalid argument that is not a vector (a contact normal, a reference frame name…).
    #[error("`{field}`: {reason}")]
    InvalidArgument { field: String, reason: String },
    /// The KKT system could not be solved (singular: Lemma 5.1), or a result overflowed.
    #[error(transparent)]
    Core(#[from] CoreError),
}

pub type SpatialResult<T> = std::result::Result<T, SpatialError>;

/// Checks the length and finiteness of a vector argument.
pub(crate) fn check_vector(field: &'static str, v: &[f64], expected: usize) -> SpatialResult<()> {
    if v.len() != expected {
        return Err(SpatialError::WrongLength {
            field,
            expected,
            actual: v.len(),
        });
    }
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(SpatialError::NonFinite {
            field,
            index,
            value: v[index],
        }),
        None => Ok(()),
    }
}
