//! # rhex-model
//!
//! The RHex robot of thesis section 4.2 as an instance of the generic self-manipulation
//! core: Table 4.2 parameters ([`params`]), contact-mode labels in the thesis's
//! `FB FL RB RL` bit order ([`modes`]), the quasi-static contact-mode map and pitch of
//! Figs. 4.3/4.6 ([`quasistatic_map`]), and the ground reaction complex of chapter 3
//! ([`grc`]), the leap strategies ([`leap`]) with their sweeps ([`sweep`]) and logs
//! ([`mcap_log`]), and RHex's analyses of section 4.3 ([`analysis`]). What works for any
//! robot — terrains, prescribed motions, trajectories, sweeps, MCAP logs, the analyses that
//! take any model — is `selfmanip-sim`'s.
//!
//! Coordinates are the thesis's `q = [θ₁, θ₂, x, z, φ]` (joints front to rear, then the body;
//! z down, φ nose-up, θ clockwise from the body's `+z`).
pub mod analysis;
pub mod figures;
pub mod grc;
pub mod leap;
pub mod leap_sensitivity;
pub mod mcap_log;
pub mod modes;
pub mod params;
pub mod quasistatic_map;
pub mod sweep;

pub use modes::Rhex;
pub use params::{LegPair, LegShape, RhexParams};

use thiserror::Error;

/// What went wrong. Every error of the caller's input names its field ([`RhexError::field`]).
#[derive(Debug, Clone, Error, PartialEq)]
pub enum RhexError {
    /// A value outside its domain (the reason says which: finite, positive, a range, …).
    #[error("RHex parameter `{field}`: {reason}")]
    InvalidValue { field: String, reason: String },
    /// A name that names no parameter (`known`: the names that do, comma-separated).
    #[error("RHex parameter `{field}`: unknown parameter (known: {known})")]
    UnknownParameter { field: String, known: String },
    /// A value that does not read as its field's type or grammar (a strategy, a TOML file,
    /// a sweep's override).
    #[error("RHex parameter `{field}`: {reason}")]
    Unreadable { field: String, reason: String },
    /// Something asked of a leap that it does not have (a derivative its model cannot give,
    /// a timing a scenario cannot take).
    #[error("RHex parameter `{field}`: {reason}")]
    Unsupported { field: String, reason: String },
    /// The leap's start state, built from the parameters, overflows: `field` is the parameter
    /// (`m_b`, `I_b`, `m_l`, `I_l`) whose size makes it so.
    #[error("RHex parameter `{field}`: the leap's start state overflows with it: {reason}")]
    StartOverflow { field: String, reason: String },
    #[error("bad contact-mode label `{label}`: {reason}")]
    ModeLabel { label: String, reason: String },
    #[error(transparent)]
    Core(#[from] selfmanip_core::CoreError),
    #[error(transparent)]
    Hybrid(#[from] selfmanip_hybrid::HybridError),
    #[error(transparent)]
    Sim(selfmanip_sim::SimError),
}

impl RhexError {
    /// The value of `field` is outside its domain: `reason`.
    pub fn invalid(field: &str, reason: impl Into<String>) -> Self {
        RhexError::InvalidValue {
            field: field.into(),
            reason: reason.into(),
        }
    }

    /// The input at fault, for an error of the caller's input: a parameter or setting by
    /// name, `mode` for a bad mode label; `None` for a failure of the engine.
    pub fn field(&self) -> Option<&str> {
        match self {
            RhexError::InvalidValue { field, .. }
            | RhexError::UnknownParameter { field, .. }
            | RhexError::Unreadable { field, .. }
            | RhexError::Unsupported { field, .. }
            | RhexError::StartOverflow { field, .. } => Some(field),
            RhexError::ModeLabel { .. } => Some("mode"),
            _ => None,
        }
    }
}

/// A value out of its domain stays a parameter error naming its field (a leap's terrain,
/// an analysis's input); every other error of the simulation crate is carried as it is.
impl From<selfmanip_sim::SimError> for RhexError {
    fn from(e: selfmanip_sim::SimError) -> Self {
        match e {
            selfmanip_sim::SimError::InvalidValue { field, reason } => {
                RhexError::InvalidValue { field, reason }
            }
            selfmanip_sim::SimError::Core(c) => RhexError::Core(c),
            selfmanip_sim::SimError::Hybrid(h) => RhexError::Hybrid(h),
            other => RhexError::Sim(other),
        }
    }
}
