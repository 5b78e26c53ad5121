//! # rhex-model
//!
//! The RHex robot of thesis section 4.2 as an instance of the generic self-manipulation
//! core: Table 4.2 parameters ([`params`]), contact-mode labels in the thesis's
//! `FB FL RB RL` bit order ([`modes`]), the quasi-static contact-mode map and pitch of
//! Figs. 4.3/4.6 ([`quasistatic_map`]), and the ground reaction complex of chapter 3
//! ([`grc`]).
//!
//! Coordinates are the thesis's `q = [θ₁, θ₂, x, z, φ]` (joints front to rear, then the body;
//! z down, φ nose-up, θ clockwise from the body's `+z`).
pub mod analysis;
pub mod figures;
pub mod grc;
pub mod leap;
pub mod leg_motion;
pub mod mcap_log;
pub mod modes;
pub mod params;
pub mod quasistatic_map;
pub mod sweep;
pub mod terrain;

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
}
