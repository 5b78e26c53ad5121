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

#[derive(Debug, Clone, Error, PartialEq)]
pub enum RhexError {
    #[error("RHex parameter `{field}`: {reason}")]
    Params { field: String, reason: String },
    #[error("bad contact-mode label `{label}`: {reason}")]
    ModeLabel { label: String, reason: String },
    #[error(transparent)]
    Core(#[from] selfmanip_core::CoreError),
    #[error(transparent)]
    Hybrid(#[from] selfmanip_hybrid::HybridError),
    #[error(transparent)]
    Sim(selfmanip_sim::SimError),
}

/// A value out of its domain stays a parameter error naming its field (a leap's terrain,
/// an analysis's input); every other error of the simulation crate is carried as it is.
impl From<selfmanip_sim::SimError> for RhexError {
    fn from(e: selfmanip_sim::SimError) -> Self {
        match e {
            selfmanip_sim::SimError::InvalidValue { field, reason } => {
                RhexError::Params { field, reason }
            }
            selfmanip_sim::SimError::Core(c) => RhexError::Core(c),
            selfmanip_sim::SimError::Hybrid(h) => RhexError::Hybrid(h),
            other => RhexError::Sim(other),
        }
    }
}
