//! The quasi-static contact-mode map over the joint torus (Fig. 4.3) and the pitch as an
//! implicit function of the legs (eq. 4.44, Fig. 4.6), for two-pair models.
//!
//! Quasi-statically on level ground the robot rests on its lowest front support and its
//! lowest rear support (section 4.2.2): with the body at `x = z = 0`, the pitch `φ(θ₁, θ₂)`
//! is the root of `depth_front(φ) = depth_rear(φ)` where each depth is the largest world
//! `z` (z down) of that side's contact sites (body end, leg on its round or on its toe): the
//! generic [`selfmanip_sim::analysis::balance_pitch`] on RHex's two sides.
use crate::modes::Rhex;
use crate::RhexError;
use selfmanip_core::contact::TouchKind;
use selfmanip_core::ContactMode;
use selfmanip_sim::analysis::{balance_pitch, SideSupport};
use serde::Serialize;

/// How one side of the robot is supported (the letters of Fig. 4.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Support {
    /// `B`: the rounded body end.
    Body,
    /// `R`: the leg's round side (rolling).
    Rolling,
    /// `T`: the leg's toe.
    Toe,
}

impl Support {
    pub fn letter(self) -> char {
        match self {
            Support::Body => 'B',
            Support::Rolling => 'R',
            Support::Toe => 'T',
        }
    }
}

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

/// Pitch and supports for legs `(θ₁, θ₂)` ([`balance_pitch`]); `None` for a model without
/// exactly two pairs or where no pitch in (−π/2, π/2) balances the two sides.
pub fn quasi_static_pose(rhex: &Rhex, theta1: f64, theta2: f64) -> Option<QuasiStaticPose> {
    let [front, rear] = sides(rhex)?;
    let q = [theta1, theta2, 0.0, 0.0, 0.0];
    let (phi, f, r) = balance_pitch(&rhex.model, &q, &front, &rear)?;
    let support = |s: SideSupport| {
        if rhex.model.contacts[s.contact].link.is_none() {
            Support::Body
        } else if s.touch == TouchKind::Rolling {
            Support::Rolling
        } else {
            Support::Toe
        }
    };
    let mode = ContactMode::with_defaults(&rhex.model, &[f.contact, r.contact]).ok()?;
    Some(QuasiStaticPose {
        theta1,
        theta2,
        phi,
        front: support(f),
        rear: support(r),
        height_m: f.depth_m,
        label: rhex.label(mode),
        mode,
    })
}

/// The most grid points per joint of [`contact_mode_map`]: 1024² poses (a figure needs
/// 64–144 a side); the bound keeps a map's time and memory bounded (a few seconds, and about
/// a gigabyte once every pose is a Python object).
pub const MAX_MAP_N: usize = 1024;

/// Fig. 4.3 / 4.6 as data: the pose on an `n × n` grid over `θ₁, θ₂ ∈ [−π, π)`.
pub fn contact_mode_map(rhex: &Rhex, n: usize) -> Result<Vec<QuasiStaticPose>, RhexError> {
    if !(1..=MAX_MAP_N).contains(&n) {
        return Err(RhexError::InvalidValue {
            field: "n".into(),
            reason: format!("the grid has 1 to {MAX_MAP_N} points per joint, got {n}"),
        });
    }
    let step = std::f64::consts::TAU / n as f64;
    let mut out = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let t1 = -std::f64::consts::PI + i as f64 * step;
            let t2 = -std::f64::consts::PI + j as f64 * step;
            if let Some(p) = quasi_static_pose(rhex, t1, t2) {
                out.push(p);
            }
        }
    }
    Ok(out)
}
