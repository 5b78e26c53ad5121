//! The pitching sensor sweep (thesis 4.3.2): pitch range over all quasi-static contact modes
//! (Result B.1, eqs. 4.55–4.56), holding torque by leg shape (B.2, eqs. 4.57–4.58), the exact
//! pitch-rate controller from the free-motion Jacobian `H` (B.3, eq. 4.59), and the largest
//! leg speed before a contact lifts (Fig. 4.8).
use super::{bad, check_finite, grid_points, linspace};
use crate::quasistatic_map::{quasi_static_pose, QuasiStaticPose, Support};
use crate::{Rhex, RhexError};
pub use selfmanip_sim::analysis::liftoff::{
    free_leg_parameterization, liftoff_speed, LiftoffSpeed,
};
use selfmanip_sim::analysis::maximise::pattern_search_max;
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

fn pose(rhex: &Rhex, t: [f64; 2]) -> Option<QuasiStaticPose> {
    quasi_static_pose(rhex, t[0], t[1])
}

/// The leg angles near `start` where `sign·φ` is largest ([`pattern_search_max`]), and `φ`
/// there.
fn refine(rhex: &Rhex, start: [f64; 2], sign: f64) -> ([f64; 2], f64) {
    let (best, val) = pattern_search_max(start, &mut |t| pose(rhex, t).map(|p| sign * p.phi));
    (best, sign * val)
}

/// Result B.1: the maximal sensor pitch, found by searching the whole joint torus — every
/// quasi-static contact mode of Fig. 4.3 — on an `grid × grid` grid and refining the best
/// points by pattern search. Needs a two-pair model.
pub fn max_sensor_pitch(rhex: &Rhex, grid: usize) -> Result<SensorPitchRange, RhexError> {
    if rhex.params.pairs.len() != 2 {
        return Err(bad("pairs", "the pitch map needs exactly two leg pairs"));
    }
    if grid < 8 {
        return Err(bad("grid", "at least 8 points per joint"));
    }
    let map = crate::quasistatic_map::contact_mode_map(rhex, grid)?;
    if map.is_empty() {
        return Err(bad("model", "no quasi-static pose exists"));
    }
    let hi = map
        .iter()
        .max_by(|a, b| a.phi.total_cmp(&b.phi))
        .expect("non-empty");
    let lo = map
        .iter()
        .min_by(|a, b| a.phi.total_cmp(&b.phi))
        .expect("non-empty");
    let rolling_max_phi = map
        .iter()
        .filter(|p| p.front == Support::Rolling && p.rear == Support::Rolling)
        .map(|p| p.phi)
        .fold(f64::NAN, f64::max);
    let (argmax, max_phi) = refine(rhex, [hi.theta1, hi.theta2], 1.0);
    let (argmin, min_phi) = refine(rhex, [lo.theta1, lo.theta2], -1.0);
    let argmax_label = pose(rhex, argmax).map(|p| p.label).unwrap_or_default();
    Ok(SensorPitchRange {
        max_phi,
        argmax,
        argmax_label,
        min_phi,
        argmin,
        rolling_max_phi,
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
/// `y = θ₁` (other free joints at rest).
pub fn fig_4_8(
    rhex: &Rhex,
    theta1_range: [f64; 2],
    theta2_range: [f64; 2],
    n: usize,
) -> Result<Vec<Fig48Point>, RhexError> {
    let n = grid_points(n)?;
    let model = &rhex.model;
    let mut out = Vec::new();
    for &t1 in &linspace(theta1_range, n) {
        for &t2 in &linspace(theta2_range, n) {
            let Some(p) = quasi_static_pose(rhex, t1, t2) else {
                continue;
            };
            if !p
                .mode
                .active()
                .any(|k| super::contact_leg(model, k) == Some(0))
            {
                continue; // the front leg must carry the sweep
            }
            let q = [t1, t2, 0.0, -p.height_m, p.phi];
            let Ok(speed) = pose_rates::lead_liftoff_speed(model, p.mode, &q, 0) else {
                continue;
            };
            out.push(Fig48Point {
                theta1: t1,
                theta2: t2,
                phi: p.phi,
                label: p.label,
                max_leg_speed: speed,
            });
        }
    }
    Ok(out)
}

/// Default window of Fig. 4.8 (rad): `θ₁ ∈ [−90°, 0°]`, `θ₂ ∈ [−180°, 0°]`.
pub const FIG_4_8_WINDOW: ([f64; 2], [f64; 2]) = ([-PI / 2.0, 0.0], [-PI, 0.0]);
