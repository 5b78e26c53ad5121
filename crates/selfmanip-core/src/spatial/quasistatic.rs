//! Quasi-static contact forces of a spatial robot (thesis §4.1.8, (4.21)–(4.22), `d = 3`):
//! at rest (`q̇ = q̈ = 0`) the floating base's `b` rows of `M q̈ + h = τ + Aᵀλ` read
//! `G λ = g_b`, with `G = A_bᵀ` the grasp map (the contact rows' base columns transposed: the
//! wrench on the base, in base coordinates, of the contact forces) and `g_b` the base rows of
//! the gravity forces `h(q, 0)`. The forces split into an external part, the minimum-norm
//! solution `λ_e = G⁺ g_b` (for a plate on point feet, the forces of equally stiff legs:
//! affine in the feet's positions), and internal forces `ker G` (4.22), which move no part of
//! the base; the joints hold `λ` with `τ = h_j − A_jᵀ λ` (the joint rows). The planar core's
//! [`balance_contact_forces`] solves both dimensions (`b = 6` base equations for a free
//! flyer, 3 for a planar base and in the planar core). The rows are the base's rates: a free
//! flyer's wrench in its own frame, a planar base's `(f_x, f_z)` along the world's axes and
//! the moment about `y` at its origin.
#![allow(non_snake_case)]
use super::contact::{contact_rows, PointContact};
use super::error::{SpatialError, SpatialResult};
use super::kinematics::{forward_kinematics_velocity, SpatialData};
use super::model::SpatialModel;
use super::rigid_body::bias_forces_from_kinematics;
use crate::error::CoreError;
use crate::quasistatic::{balance_contact_forces, ParticularForces};
use nalgebra::{DMatrix, DVector};

/// The quasi-static forces of a contact set at a configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialQuasiStatic {
    /// The grasp map `G = A_bᵀ` (b × c; `b` = 6 for a free flyer, 3 for a planar base).
    pub grasp: DMatrix<f64>,
    /// The base rows of the gravity forces, `g_b = G λ` (b).
    pub gravity_wrench: DVector<f64>,
    /// `λ_e = G⁺ g_b` (c), the ground's forces on the robot along the rows (as `λ`).
    pub lambda_external: DVector<f64>,
    /// An orthonormal basis of `ker G` (c × k), the internal forces.
    pub internal_basis: DMatrix<f64>,
    /// The joint torques that hold `λ_e` at rest, `h_j − A_jᵀ λ_e` (nv − b; the base's rates
    /// carry none).
    pub tau_external: DVector<f64>,
    /// The joint torques of each internal force, `−A_jᵀ N` ((nv − b) × k).
    pub internal_torques: DMatrix<f64>,
}

/// The quasi-static forces of `contacts` at `q` (see the module's doc). The robot must have a
/// free-flying or planar base; contacts that cannot hold the base at rest (`g_b` outside
/// `G`'s range, to 1e-9 relative) are an error naming `contacts`.
pub fn quasi_static(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
) -> SpatialResult<SpatialQuasiStatic> {
    let Some(base) = model.floating_base() else {
        return Err(SpatialError::InvalidArgument {
            field: "base".into(),
            reason: "quasi-static forces need a free-flying or planar base".into(),
        });
    };
    let zero = vec![0.0; model.nv];
    forward_kinematics_velocity(model, data, q, &zero)?;
    bias_forces_from_kinematics(model, data);
    contact_rows(model, data, contacts);
    let nb = base.nv();
    let nj = model.nv - nb;
    let grasp = data.A.columns(0, nb).transpose();
    let gravity_wrench = data.h.rows(0, nb).into_owned();
    // τ = h_j − A_jᵀ λ: the planar core's `J_h` is −A_j here
    let minus_A_j = -data.A.columns(nb, nj);
    let balance = balance_contact_forces(
        &grasp,
        &gravity_wrench,
        &minus_A_j,
        &data.h.rows(nb, nj).into_owned(),
        ParticularForces::MinimumNorm,
    )
    .map_err(|e| match e {
        CoreError::IllPosedQuasiStatic { reason } => SpatialError::InvalidArgument {
            field: "contacts".into(),
            reason,
        },
        other => other.into(),
    })?;
    Ok(SpatialQuasiStatic {
        grasp,
        gravity_wrench,
        lambda_external: balance.f_particular,
        internal_basis: balance.internal_basis,
        tau_external: balance.tau_particular,
        internal_torques: balance.internal_torques,
    })
}
