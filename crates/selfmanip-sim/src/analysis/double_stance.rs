//! Two contacts down (thesis 4.3.3, for any planar robot): the stance with two contacts on
//! level ground, its body coordinates solved from the base constraints (4.41), moving along
//! its free motion (4.46); and the difference of the two contacts' normal forces under given
//! torques ((4.60)) and its derivative in the splay of two joints at `θ_m ± θ_d` (Result C.2,
//! [`splay_derivative`]). RHex's instance (its two leg pairs, its sitting height) is in
//! `rhex-model`.
use super::{free_motion_basis, normal_rows, solve_contact_pose};
use crate::error::SimError;
use nalgebra::DMatrix;
use selfmanip_core::{forward_dynamics, ContactMode, Data, FlatGround, Model};

/// The stance of `mode` (two contacts) from `q` with the body height and pitch solved onto
/// level ground, and its velocity along the free motion whose coordinate is `y·q` (one row
/// of `nq` entries) at rate `y_dot`: `(q, q̇)`.
pub fn double_stance(
    model: &Model,
    mode: ContactMode,
    q: &[f64],
    y: &[f64],
    y_dot: f64,
) -> Result<(Vec<f64>, Vec<f64>), SimError> {
    let contacts: Vec<usize> = mode.active().collect();
    let free = [model.ix_z(), model.ix_phi()];
    let q = solve_contact_pose(model, &FlatGround, &contacts, &free, q)?;
    let y_map = DMatrix::from_row_slice(1, model.nq(), y);
    let h = free_motion_basis(model, &FlatGround, mode, &q, &y_map)?;
    let qd = h.column(0).iter().map(|v| v * y_dot).collect();
    Ok((q, qd))
}

/// `λ_n,1 − λ_n,2`: the first normal row's force less the second's (in row order) at
/// `(q, q̇)` in `mode` with joint torques `tau`, on level ground.
pub fn normal_force_difference(
    model: &Model,
    mode: ContactMode,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Result<f64, SimError> {
    let mut data = Data::new(model);
    forward_dynamics(model, &mut data, &FlatGround, mode, q, qd, tau, None)?;
    let rows = normal_rows(&data);
    Ok(-data.lambda[rows[1]] + data.lambda[rows[0]])
}

/// The two-joint stance of `mode` with the joints at `θ_m ± θ_d` (`theta = [θ_m, θ_d]`), the
/// body's height and pitch solved from `z_guess` and level, moving along the free motion of
/// the mean angle `y = (θ₁ + θ₂)/2` at rate `theta_m_dot` ([`double_stance`]): `(q, q̇)`.
pub fn splay_stance(
    model: &Model,
    mode: ContactMode,
    theta: [f64; 2],
    theta_m_dot: f64,
    z_guess: f64,
) -> Result<(Vec<f64>, Vec<f64>), SimError> {
    let (mut q, mut y) = (vec![0.0; model.nq()], vec![0.0; model.nq()]);
    q[..2].copy_from_slice(&[theta[0] + theta[1], theta[0] - theta[1]]);
    q[model.ix_z()] = z_guess;
    y[..2].copy_from_slice(&[0.5, 0.5]);
    double_stance(model, mode, &q, &y, theta_m_dot)
}

/// Result C.2 / (4.61) for any two-joint robot: `∂(λ_n,1 − λ_n,2)/∂θ_d` at `θ_d = 0` with
/// equal torques `τ` on both joints ([`normal_force_difference`] at [`splay_stance`]), by
/// central differences (step 10⁻⁵) of the general dynamics.
pub fn splay_derivative(
    model: &Model,
    mode: ContactMode,
    theta_m: f64,
    theta_m_dot: f64,
    tau: f64,
    z_guess: f64,
) -> Result<f64, SimError> {
    let h = 1e-5;
    let imbalance = |theta_d: f64| {
        let (q, qd) = splay_stance(model, mode, [theta_m, theta_d], theta_m_dot, z_guess)?;
        normal_force_difference(model, mode, &q, &qd, &[tau, tau])
    };
    Ok((imbalance(h)? - imbalance(-h)?) / (2.0 * h))
}
