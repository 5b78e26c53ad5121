//! RHex's design-insight analyses of thesis section 4.3, built on the generic analyses of
//! `selfmanip-sim` ([`selfmanip_sim::analysis`]: free motions, contact poses, standing,
//! legs as tails), which run for any planar robot:
//!
//! - [`standing`]: reactive standing (4.3.1) on RHex's random rough-terrain stances
//!   (Results A.1–A.3);
//! - [`sensor_sweep`]: the pitching sensor sweep (4.3.2): pitch range over every quasi-static
//!   mode (Result B.1), holding torque by leg shape (B.2), the exact pitch-rate controller
//!   (4.59, B.3) and the largest leg speed before a contact lifts (Fig. 4.8);
//! - [`pitch_control`]: pitch control in leaping (4.3.3): the splay derivative (4.61, C.2),
//!   single-leg pitch dynamics (4.63, C.3), the takeoff-speed bound with a torque–speed motor
//!   (4.64)–(4.66), Result C.4 and Figs. 4.10–4.12;
//! - [`leg_tail`]: RHex's legs as inertial tails in flight (4.67)–(4.68), Result C.5.
//!
//! Which problems are convex: the liftoff speed of Fig. 4.8 is a linear program in `s = ẏ²`
//! (λ is exactly quadratic in the velocity at fixed torque) and is solved with Clarabel; the
//! takeoff bound at one state is the root of a scalar quadratic (closed form); the
//! maximisation over leg angle and gear ratio (Figs. 4.11/4.12) is not convex and is done by
//! a grid followed by golden-section refinement.
#![allow(non_snake_case)]
pub mod leg_tail;
pub mod pitch_control;
pub mod sensor_sweep;
pub mod standing;

use crate::RhexError;
pub(crate) use selfmanip_sim::analysis::{check_finite, solve_contact_pose};

pub(crate) fn bad(field: &str, reason: impl Into<String>) -> RhexError {
    RhexError::invalid(field, reason)
}

pub(crate) use selfmanip_sim::analysis::takeoff_maps::grid_points;
pub use selfmanip_sim::analysis::takeoff_maps::MAX_FIGURE_GRID;
