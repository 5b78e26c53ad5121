//! The pitching sensor sweep (thesis 4.3.2): pitch range over all quasi-static contact modes
//! (Result B.1, eqs. 4.55–4.56), holding torque by leg shape (B.2, eqs. 4.57–4.58), the exact
//! pitch-rate controller from the free-motion Jacobian `H` (B.3, eq. 4.59), and the largest
//! leg speed before a contact lifts (Fig. 4.8).
use super::{bad, check_finite};
use crate::quasistatic_map::{balanced, quasi_static_pose, QuasiStaticPose};
use crate::{Rhex, RhexError};
use selfmanip_sim::analysis::balance_map::{liftoff_speed_map, pitch_range};
pub use selfmanip_sim::analysis::liftoff::{
    free_leg_parameterization, liftoff_speed, LiftoffSpeed,
};
use selfmanip_sim::analysis::pose_rates;
use serde::Serialize;
use std::f64::consts::PI;

/// Extremes of the quasi-static pitch over the joint torus.
#[derive(Debug, Clone, Serialize)]
pub struct SensorPitchRange {
    /// Largest pitch (rad) over every quasi-static mode.
    pub max_phi: f64,
    /// `(θ₁, θ₂)` where it is reached and the contact label there.
    pub argmax: [f64; 2],
    pub argmax_label: String,
    /// Smallest (most nose-down) pitch (rad).
    pub min_phi: f64,
    pub argmin: [f64; 2],
    /// Largest pitch over the grid points where both legs roll (`R–R` of Fig. 4.3).
    pub rolling_max_phi: f64,
    /// Grid size used for the search before refinement.
    pub grid: usize,
}

/// Result B.1: the maximal sensor pitch, found by searching the whole joint torus — every
/// quasi-static contact mode of Fig. 4.3 — on an `grid × grid` grid and refining the best
/// points by pattern search ([`pitch_range`]). Needs a two-pair model.
pub fn max_sensor_pitch(rhex: &Rhex, grid: usize) -> Result<SensorPitchRange, RhexError> {
    if rhex.params.pairs.len() != 2 {
        return Err(bad("pairs", "the pitch map needs exactly two leg pairs"));
    }
    let r = pitch_range(grid, |t1, t2| balanced(rhex, t1, t2))?;
    let argmax_label =
        balanced(rhex, r.argmax[0], r.argmax[1]).map_or_else(String::new, |p| rhex.label(p.mode));
    Ok(SensorPitchRange {
        max_phi: r.max_phi,
        argmax: r.argmax,
        argmax_label,
        min_phi: r.min_phi,
        argmin: r.argmin,
        rolling_max_phi: r.rolling_max_phi,
        grid,
    })
}

/// Holding torque at a quasi-static pose (thesis (4.21)–(4.23) with (4.16)): the joint
/// torques that balance gravity in the pose's own contact mode. With two toes down the
/// internal force is fixed by `t_dᵀτ = 0` (the difference condition of 4.3.1).
#[derive(Debug, Clone, Serialize)]
pub struct HoldingTorque {
    pub theta1: f64,
    pub theta2: f64,
    pub phi: f64,
    pub label: String,
    /// Joint torques (N m), front to rear.
    pub tau: Vec<f64>,
}

pub fn holding_torque(rhex: &Rhex, theta1: f64, theta2: f64) -> Result<HoldingTorque, RhexError> {
    check_finite("theta", &[theta1, theta2])?;
    let (p, q) = pose_q(rhex, theta1, theta2)?;
    Ok(HoldingTorque {
        theta1,
        theta2,
        phi: p.phi,
        tau: pose_rates::holding_torque(&rhex.model, p.mode, &q)?,
        label: p.label,
    })
}

/// The quasi-static pose at `(θ₁, θ₂)` and its configuration (an error naming `theta` where
/// there is none).
fn pose_q(rhex: &Rhex, theta1: f64, theta2: f64) -> Result<(QuasiStaticPose, [f64; 5]), RhexError> {
    let p = quasi_static_pose(rhex, theta1, theta2)
        .ok_or_else(|| bad("theta", "no quasi-static pose at these leg angles"))?;
    let q = [theta1, theta2, 0.0, -p.height_m, p.phi];
    Ok((p, q))
}

/// Result B.3 / eq. (4.59): the leg rate per unit pitch rate, `θ̇₁/φ̇ = 1/H_φ`, with
/// `H_φ = π_φ H` from the free-motion basis (4.20) at the quasi-static pose, `y = θ₁`
/// ([`pose_rates::pitch_rate_gain`]). Setting `θ̇₁ = φ̇_d / H_φ` tracks a desired pitch rate
/// exactly.
pub fn pitch_rate_gain(rhex: &Rhex, theta1: f64, theta2: f64) -> Result<f64, RhexError> {
    let (p, q) = pose_q(rhex, theta1, theta2)?;
    Ok(pose_rates::pitch_rate_gain(&rhex.model, p.mode, &q, 0)?)
}

/// One point of Fig. 4.8.
#[derive(Debug, Clone, Serialize)]
pub struct Fig48Point {
    pub theta1: f64,
    pub theta2: f64,
    pub phi: f64,
    pub label: String,
    /// Largest `|θ̇₁|` (rad/s) before a contact lifts, zero torque; `None` if none lifts.
    pub max_leg_speed: Option<f64>,
}

/// Fig. 4.8: the leg speed `ẏ = θ̇₁` at takeoff (no torque) over a grid of the quasi-static
/// configuration space, each point in its own quasi-static mode, along the free motion with
/// `y = θ₁` (other free joints at rest): [`liftoff_speed_map`] on RHex's sides.
pub fn fig_4_8(
    rhex: &Rhex,
    theta1_range: [f64; 2],
    theta2_range: [f64; 2],
    n: usize,
) -> Result<Vec<Fig48Point>, RhexError> {
    let ranges = [theta1_range, theta2_range];
    let map = liftoff_speed_map(&rhex.model, ranges, n, 0, |t1, t2| balanced(rhex, t1, t2))?;
    Ok(map
        .into_iter()
        .map(|s| Fig48Point {
            theta1: s.theta[0],
            theta2: s.theta[1],
            phi: s.pose.phi,
            label: rhex.label(s.pose.mode),
            max_leg_speed: s.speed,
        })
        .collect())
}

/// Default window of Fig. 4.8 (rad): `θ₁ ∈ [−90°, 0°]`, `θ₂ ∈ [−180°, 0°]`.
pub const FIG_4_8_WINDOW: ([f64; 2], [f64; 2]) = ([-PI / 2.0, 0.0], [-PI, 0.0]);
