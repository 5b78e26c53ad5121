//! Errors that prevent an execution from starting or continuing (a run that ends for a
//! physical reason ends with a [`crate::Termination`] instead).
use crate::impact_qp::ContactQpError;
use crate::limits::ENUMERATION_LIMIT;
use selfmanip_core::CoreError;
use thiserror::Error;

#[derive(Debug, Clone, Error, PartialEq)]
pub enum HybridError {
    #[error(transparent)]
    Core(#[from] CoreError),
    #[error("initial state is off the constraint manifold of its mode: `{field}` residual {residual:.3e}")]
    OffManifold { field: &'static str, residual: f64 },
    #[error("invalid option `{field}`: {reason}")]
    InvalidOption { field: &'static str, reason: String },
    /// More candidates than [`ENUMERATION_LIMIT`], not all frictionless: the convex QP that
    /// takes over beyond the limit covers frictionless contacts only.
    #[error("{n} candidate contacts are too many for exact enumeration (at most {ENUMERATION_LIMIT}) and contact {sticking} can stick: the QP path is frictionless only")]
    TooManyContacts { n: usize, sticking: usize },
    #[error(transparent)]
    ContactQp(#[from] ContactQpError),
}
