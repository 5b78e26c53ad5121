//! The quasi-static contact-mode map over the joint torus (Fig. 4.3) and the pitch as an
//! implicit function of the legs (eq. 4.44, Fig. 4.6), for two-pair models.
//!
//! Quasi-statically on level ground the robot rests on its lowest front support and its
//! lowest rear support (section 4.2.2): with the body at `x = z = 0`, the pitch `φ(θ₁, θ₂)`
//! is the root of `depth_front(φ) = depth_rear(φ)` where each depth is the largest world
//! `z` (z down) of that side's contact sites (body end, leg on its round or on its toe): the
//! generic [`selfmanip_sim::analysis::balance_map`] on RHex's two sides.
use crate::modes::Rhex;
use crate::RhexError;
use selfmanip_core::ContactMode;
use selfmanip_sim::analysis::balance_map::{balanced_pose, torus_map, BalancedPose};
pub use selfmanip_sim::analysis::balance_map::{Support, MAX_MAP_N};
use serde::Serialize;

/// The quasi-static pose at one leg configuration.
#[derive(Debug, Clone, Serialize)]
pub struct QuasiStaticPose {
    pub theta1: f64,
    pub theta2: f64,
    /// Pitch `φ` (rad) from (4.44).
    pub phi: f64,
    pub front: Support,
    pub rear: Support,
    /// Body height above the ground (m, positive up).
    pub height_m: f64,
    /// Chapter-3 label of the active contacts (`FB FL RB RL`).
    pub label: String,
    #[serde(skip)]
    pub mode: ContactMode,
}

/// The contact sites of the front and rear sides, `[leg, body]` each.
fn sides(rhex: &Rhex) -> Option<[[usize; 2]; 2]> {
    let m = &rhex.model;
    let pairs = rhex.params.ordered_pairs();
    if pairs.len() != 2 {
        return None;
    }
    let leg = |i: usize| m.contact_index(&format!("{}_leg", pairs[i].name())).ok();
    Some([
        [leg(0)?, m.contact_index("front_body").ok()?],
        [leg(1)?, m.contact_index("rear_body").ok()?],
    ])
}

/// The generic pose for legs `(θ₁, θ₂)` on RHex's two sides ([`balanced_pose`]); `None` for
/// a model without exactly two pairs or where no pitch in (−π/2, π/2) balances the sides.
pub fn balanced(rhex: &Rhex, theta1: f64, theta2: f64) -> Option<BalancedPose> {
    let [front, rear] = sides(rhex)?;
    balanced_pose(&rhex.model, &[theta1, theta2, 0.0, 0.0, 0.0], &front, &rear)
}

/// Pitch, supports and label for legs `(θ₁, θ₂)` ([`balanced`]).
pub fn quasi_static_pose(rhex: &Rhex, theta1: f64, theta2: f64) -> Option<QuasiStaticPose> {
    let p = balanced(rhex, theta1, theta2)?;
    Some(QuasiStaticPose {
        theta1,
        theta2,
        phi: p.phi,
        front: p.front,
        rear: p.rear,
        height_m: p.height_m,
        label: rhex.label(p.mode),
        mode: p.mode,
    })
}

/// Fig. 4.3 / 4.6 as data: the pose on an `n × n` grid over `θ₁, θ₂ ∈ [−π, π)`
/// ([`torus_map`], `n` at most [`MAX_MAP_N`]).
pub fn contact_mode_map(rhex: &Rhex, n: usize) -> Result<Vec<QuasiStaticPose>, RhexError> {
    Ok(torus_map(n, |t1, t2| quasi_static_pose(rhex, t1, t2))?)
}
