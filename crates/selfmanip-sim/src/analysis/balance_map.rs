//! The quasi-static pose on level ground as a map over two joints, for any planar robot
//! whose contacts split into a front and a rear side (thesis section 4.2.2, (4.44), Figs.
//! 4.3/4.6): the pitch at which the two sides' lowest contacts are equally deep
//! ([`super::balance_pitch`]), how each side is supported, and the map of it over the joint
//! torus. RHex's sides and labels are in `rhex-model`.
use super::{bad, balance_pitch, SideSupport};
use crate::error::SimError;
use selfmanip_core::contact::TouchKind;
use selfmanip_core::{ContactMode, Model};
use serde::Serialize;

/// How one side of the robot is supported (the letters of Fig. 4.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Support {
    /// `B`: a body contact.
    Body,
    /// `R`: a leg rolling on its round side.
    Rolling,
    /// `T`: a leg on its toe.
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

    /// How the side's lowest contact `s` supports it.
    pub fn of(model: &Model, s: SideSupport) -> Self {
        if model.contacts[s.contact].link.is_none() {
            Support::Body
        } else if s.touch == TouchKind::Rolling {
            Support::Rolling
        } else {
            Support::Toe
        }
    }
}

/// The quasi-static pose of a configuration: pitch, each side's support, body height and
/// the contact mode of the two supporting contacts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BalancedPose {
    /// Pitch `φ` (rad) from (4.44).
    pub phi: f64,
    pub front: Support,
    pub rear: Support,
    /// Body height above the ground (m, positive up).
    pub height_m: f64,
    pub mode: ContactMode,
}

/// The pose at the joint angles of `q` (body coordinates ignored) resting on the lowest of
/// the `front` contacts and the lowest of the `rear` ones ([`balance_pitch`]); `None` where
/// no pitch in (−π/2, π/2) balances the two sides.
pub fn balanced_pose(
    model: &Model,
    q: &[f64],
    front: &[usize],
    rear: &[usize],
) -> Option<BalancedPose> {
    let (phi, f, r) = balance_pitch(model, q, front, rear)?;
    Some(BalancedPose {
        phi,
        front: Support::of(model, f),
        rear: Support::of(model, r),
        height_m: f.depth_m,
        mode: ContactMode::with_defaults(model, &[f.contact, r.contact]).ok()?,
    })
}

/// The most grid points per joint of [`torus_map`]: 1024² poses (a figure needs 64–144 a
/// side); the bound keeps a map's time and memory bounded (a few seconds, and about a
/// gigabyte once every pose is a Python object).
pub const MAX_MAP_N: usize = 1024;

/// `f(θ₁, θ₂)` on an `n × n` grid over `θ₁, θ₂ ∈ [−π, π)` (`θ₁` slowest), where it is
/// `Some`; `n` from 1 to [`MAX_MAP_N`] (else an error naming `n`).
pub fn torus_map<T>(
    n: usize,
    mut f: impl FnMut(f64, f64) -> Option<T>,
) -> Result<Vec<T>, SimError> {
    if !(1..=MAX_MAP_N).contains(&n) {
        let reason = format!("the grid has 1 to {MAX_MAP_N} points per joint, got {n}");
        return Err(bad("n", reason));
    }
    let step = std::f64::consts::TAU / n as f64;
    let mut out = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let t1 = -std::f64::consts::PI + i as f64 * step;
            let t2 = -std::f64::consts::PI + j as f64 * step;
            out.extend(f(t1, t2));
        }
    }
    Ok(out)
}
