//! The quasi-static pose on level ground as a map over two joints, for any planar robot
//! whose contacts split into a front and a rear side (thesis section 4.2.2, (4.44), Figs.
//! 4.3/4.6): the pitch at which the two sides' lowest contacts are equally deep
//! ([`super::balance_pitch`]), how each side is supported, and the map of it over the joint
//! torus; on that map, the pitch's range (Result B.1) and the lead joint's liftoff speed
//! (Fig. 4.8). RHex's sides and labels are in `rhex-model`.
use super::maximise::pattern_search_max;
use super::pose_rates::lead_liftoff_speed;
use super::takeoff_maps::{grid_points, linspace};
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

/// The extremes of the balanced pitch over the joint torus ([`pitch_range`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PitchRange {
    /// Largest pitch (rad) and the joint angles `(θ₁, θ₂)` where it is reached.
    pub max_phi: f64,
    pub argmax: [f64; 2],
    /// Smallest (most nose-down) pitch (rad) and where.
    pub min_phi: f64,
    pub argmin: [f64; 2],
    /// Largest pitch over the grid points where both sides roll (`R–R` of Fig. 4.3).
    pub rolling_max_phi: f64,
}

/// Result B.1 for any robot: the extremes of the pitch of the balanced poses `pose(θ₁, θ₂)`
/// over the whole joint torus (every quasi-static contact mode), searched on a `grid × grid`
/// [`torus_map`] and refined by [`pattern_search_max`] from the highest and lowest points;
/// an error naming `grid` below 8 points, or `model` where no pose balances.
pub fn pitch_range(
    grid: usize,
    pose: impl Fn(f64, f64) -> Option<BalancedPose>,
) -> Result<PitchRange, SimError> {
    if grid < 8 {
        return Err(bad("grid", "at least 8 points per joint"));
    }
    let map = torus_map(grid, |t1, t2| pose(t1, t2).map(|p| ([t1, t2], p)))?;
    let by_phi =
        |a: &&([f64; 2], BalancedPose), b: &&([f64; 2], BalancedPose)| a.1.phi.total_cmp(&b.1.phi);
    let (Some(hi), Some(lo)) = (map.iter().max_by(by_phi), map.iter().min_by(by_phi)) else {
        return Err(bad("model", "no quasi-static pose exists"));
    };
    let rolling_max_phi = map
        .iter()
        .filter(|(_, p)| p.front == Support::Rolling && p.rear == Support::Rolling)
        .map(|(_, p)| p.phi)
        .fold(f64::NAN, f64::max);
    // the angles near `start` where `sign·φ` is largest, and `φ` there
    let refine = |start: [f64; 2], sign: f64| {
        let (best, val) =
            pattern_search_max(start, &mut |t| pose(t[0], t[1]).map(|p| sign * p.phi));
        (best, sign * val)
    };
    let (argmax, max_phi) = refine(hi.0, 1.0);
    let (argmin, min_phi) = refine(lo.0, -1.0);
    Ok(PitchRange {
        max_phi,
        argmax,
        min_phi,
        argmin,
        rolling_max_phi,
    })
}

/// One point of [`liftoff_speed_map`]: the joint angles, the balanced pose there and the
/// largest rate of the lead joint before a contact lifts (`None` if none lifts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiftoffSample {
    pub theta: [f64; 2],
    pub pose: BalancedPose,
    pub speed: Option<f64>,
}

/// Fig. 4.8 for any robot: over an `n × n` grid of the first two joints' angles
/// (`ranges`, the first slowest), each balanced pose `pose(θ₁, θ₂)` in which a contact of
/// joint `lead`'s leg carries the robot, with [`lead_liftoff_speed`] there (zero torque,
/// along the free motion led by `lead`); poses where that motion is undefined are left out.
/// An error naming `n` outside 2 to [`super::takeoff_maps::MAX_FIGURE_GRID`], or `lead`
/// where the model has no such joint.
pub fn liftoff_speed_map(
    model: &Model,
    ranges: [[f64; 2]; 2],
    n: usize,
    lead: usize,
    pose: impl Fn(f64, f64) -> Option<BalancedPose>,
) -> Result<Vec<LiftoffSample>, SimError> {
    let n = grid_points(n)?;
    let Some(leg) = model.joints.get(lead).map(|j| j.leg) else {
        return Err(bad("lead", format!("the model has no joint {lead}")));
    };
    let mut out = Vec::new();
    for &t1 in &linspace(ranges[0], n) {
        for &t2 in &linspace(ranges[1], n) {
            let Some(p) = pose(t1, t2) else {
                continue;
            };
            if !p.mode.active().any(|k| model.contact_leg(k) == Some(leg)) {
                continue; // the lead leg must carry the sweep
            }
            let mut q = vec![0.0; model.nq()];
            q[..2].copy_from_slice(&[t1, t2]);
            (q[model.ix_z()], q[model.ix_phi()]) = (-p.height_m, p.phi);
            let Ok(speed) = lead_liftoff_speed(model, p.mode, &q, lead) else {
                continue;
            };
            out.push(LiftoffSample {
                theta: [t1, t2],
                pose: p,
                speed,
            });
        }
    }
    Ok(out)
}
