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
    /// The base quaternion of `q` is not of unit norm (to 1e-9).
    #[error("`{field}`: the base quaternion (entries 3..7) has norm {norm}, not 1")]
    NonUnitQuaternion { field: &'static str, norm: f64 },
    /// No frame (link or joint) of this name, given as `field` (`frame`, `contacts[…]`,
    /// `root_link`).
    #[error("`{field}`: unknown frame `{name}`")]
    UnknownFrame { field: String, name: String },
    /// An invalid argument that is not a vector (a contact normal, a reference frame name…).
    #[error("`{field}`: {reason}")]
    InvalidArgument { field: String, reason: String },
    /// A vector of the wrong length or with a non-finite entry (`CoreError::WrongLength`,
    /// `CoreError::NonFinite`, naming the field), a KKT system that cannot be solved
    /// (singular: Lemma 5.1), or a result that overflowed.
    #[error(transparent)]
    Core(#[from] CoreError),
}

pub type SpatialResult<T> = std::result::Result<T, SpatialError>;
