//! One leg down (thesis 4.3.3, generalised to any planar robot whose contacts are listed
//! front to rear): the stance on the rear-most leg at a leg angle and pitch (body height
//! solved onto the ground), its takeoff speed ([`super::takeoff::takeoff_bound`]) and the
//! best over leg angle and gear ratio (Figs. 4.11/4.12's searches: not convex, grid then
//! golden section), and the pitch acceleration with that leg's torque (Result C.3, (4.63)).
//! RHex's instances (its rolling and stick legs, X-RHex's motor) are in `rhex-model`.
use super::maximise::grid_golden_max;
use super::takeoff::{takeoff_bound, TakeoffBound, TorqueSpeedLine};
use super::{bad, check_finite, free_motion_basis, selector_rows, solve_contact_pose};
use crate::error::SimError;
use selfmanip_core::{forward_dynamics, ContactMode, Data, FlatGround, Model};

/// The rear-most leg's joint and contact index: the last contact on a link (a model whose
/// contacts are listed front to rear, as RHex's and the description's legs are).
pub fn rear_leg(model: &Model) -> Result<(usize, usize), SimError> {
    let k = model
        .contacts
        .iter()
        .rposition(|c| c.link.is_some())
        .ok_or_else(|| bad("model", "no leg contact"))?;
    Ok((model.contacts[k].link.expect("leg"), k))
}

/// Rear-leg-only stance at `(θ₂, φ)`: body height solved so the rear leg touches (4.41)/(4.42)
/// (Newton's method from the body 0.2 m up, the other coordinates zero).
pub fn rear_stance_q(
    model: &Model,
    theta2: f64,
    phi: f64,
) -> Result<(Vec<f64>, ContactMode), SimError> {
    check_finite("theta2/phi", &[theta2, phi])?;
    let (j, k) = rear_leg(model)?;
    let mut q = vec![0.0; model.nq()];
    q[j] = theta2;
    q[model.ix_phi()] = phi;
    q[model.ix_z()] = -0.2;
    let q = solve_contact_pose(model, &FlatGround, &[k], &[model.ix_z()], &q)?;
    Ok((q, ContactMode::with_defaults(model, &[k])?))
}

/// `|ẋ|` at takeoff of the rear leg (Fig. 4.10's quantity) at `(θ₂, φ, φ̇)`.
pub fn rear_takeoff_speed(
    model: &Model,
    theta2: f64,
    phi: f64,
    phi_dot: f64,
    line: &TorqueSpeedLine,
) -> Result<Option<TakeoffBound>, SimError> {
    let (q, mode) = rear_stance_q(model, theta2, phi)?;
    let (j, _) = rear_leg(model)?;
    takeoff_bound(model, &FlatGround, mode, &q, j, phi_dot, line)
}

/// Fig. 4.11/4.12's inner problem: the best takeoff speed over the rear leg angle
/// `θ₂ ∈ theta2_range` at pitch `φ` and pitch rate `φ̇` (not convex: grid + golden section).
pub fn best_takeoff_over_theta2(
    model: &Model,
    phi: f64,
    phi_dot: f64,
    line: &TorqueSpeedLine,
    theta2_range: [f64; 2],
) -> (f64, f64) {
    let mut f = |t2: f64| {
        rear_takeoff_speed(model, t2, phi, phi_dot, line)
            .ok()
            .flatten()
            .map(|b| b.x_dot.abs())
            .unwrap_or(0.0)
    };
    grid_golden_max(theta2_range[0], theta2_range[1], 25, &mut f)
}

/// The gear ratio maximising the best takeoff speed at pitch `φ` (Fig. 4.11's optimum).
pub fn optimal_gear_ratio<E>(
    model: &Model,
    phi: f64,
    phi_dot: f64,
    theta2_range: [f64; 2],
    ratio_range: [f64; 2],
    line_of: &dyn Fn(f64) -> Result<TorqueSpeedLine, E>,
) -> Result<(f64, f64), E> {
    line_of(ratio_range[0])?;
    let mut f = |g: f64| match line_of(g) {
        Ok(line) => best_takeoff_over_theta2(model, phi, phi_dot, &line, theta2_range).1,
        Err(_) => 0.0,
    };
    Ok(grid_golden_max(ratio_range[0], ratio_range[1], 16, &mut f))
}

/// Result C.3 / (4.63): the pitch acceleration `φ̈` with only the rear leg down, from the
/// general dynamics (5.3), at `(θ₂, φ, θ̇₂, φ̇)` with rear torque `τ₂`.
pub fn single_leg_pitch_accel(
    model: &Model,
    theta2: f64,
    phi: f64,
    theta2_dot: f64,
    phi_dot: f64,
    tau2: f64,
) -> Result<f64, SimError> {
    check_finite("state", &[theta2_dot, phi_dot, tau2])?;
    let (q, mode) = rear_stance_q(model, theta2, phi)?;
    let (j, _) = rear_leg(model)?;
    let n = model.n_joints();
    let mut idx: Vec<usize> = (0..n).collect();
    idx.push(model.ix_phi());
    let h = free_motion_basis(
        model,
        &FlatGround,
        mode,
        &q,
        &selector_rows(model.nq(), &idx),
    )?;
    let mut yd = nalgebra::DVector::zeros(n + 1);
    yd[j] = theta2_dot;
    yd[n] = phi_dot;
    let qd: Vec<f64> = (&h * yd).iter().cloned().collect();
    let mut tau = vec![0.0; n];
    tau[j] = tau2;
    let mut data = Data::new(model);
    forward_dynamics(model, &mut data, &FlatGround, mode, &q, &qd, &tau, None)?;
    Ok(data.qdd[model.ix_phi()])
}
