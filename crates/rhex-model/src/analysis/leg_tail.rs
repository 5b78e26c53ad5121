//! RHex's legs as inertial tails in flight (thesis 4.3.3, "Inertial Leg Effects", eqs.
//! 4.67–4.68, Result C.5), on the generic momentum and flight-dynamics routes of
//! [`selfmanip_sim::analysis::leg_tail`].
use super::bad;
use crate::params::{LegPair, RhexParams};
use crate::{Rhex, RhexError};
use selfmanip_sim::analysis::leg_tail::revolution_rotation_momentum;

/// RHex for the tail analysis: Table 4.2 with the leg mass and inertia doubled for the
/// contralateral pair (0.126 kg, 0.00092 kg m²) and `pairs` planar legs (1: middle;
/// 2: front and rear; 3: front, middle, rear at `+ℓ, 0, −ℓ`).
pub fn tail_rhex(base: Option<RhexParams>, pairs: usize) -> Result<Rhex, RhexError> {
    let mut p = base.unwrap_or_else(|| RhexParams::default().with_table_4_2_legs());
    p.pairs = match pairs {
        1 => vec![LegPair::Middle],
        2 => vec![LegPair::Front, LegPair::Rear],
        3 => vec![LegPair::Front, LegPair::Middle, LegPair::Rear],
        _ => return Err(bad("pairs", "must be 1, 2 or 3")),
    };
    if p.m_l.is_nan() || p.m_l <= 0.0 {
        return Err(bad("m_l", "legs must have mass for the tail effect"));
    }
    Rhex::new(p)
}

/// Result C.5: body rotation per full in-phase revolution of every leg in flight, divided by
/// `2π` (magnitude; the body turns against the legs), from the momentum route.
pub fn leg_effectiveness(rhex: &Rhex) -> Result<f64, RhexError> {
    let model = &rhex.model;
    let joints: Vec<usize> = (0..model.n_joints()).collect();
    let q0 = vec![0.0; model.nq()];
    Ok(revolution_rotation_momentum(model, &q0, &joints, 64)?.abs() / std::f64::consts::TAU)
}
