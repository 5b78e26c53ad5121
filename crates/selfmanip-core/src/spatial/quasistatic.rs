//! Quasi-static contact forces of a spatial robot (thesis §4.1.8, (4.21)–(4.22), `d = 3`):
//! at rest (`q̇ = q̈ = 0`) the free-flying base's six rows of `M q̈ + h = τ + Aᵀλ` read
//! `G λ = g_b`, with `G = A_bᵀ` the grasp map (the contact rows' base columns transposed: the
//! wrench on the base, in base coordinates, of the contact forces) and `g_b` the base rows of
//! the gravity forces `h(q, 0)`. The forces split into an external part, the minimum-norm
//! solution `λ_e = G⁺ g_b` (for a plate on point feet, the forces of equally stiff legs:
//! affine in the feet's positions), and internal forces `ker G` (4.22), which move no part of
//! the base; the joints hold `λ` with `τ = h_j − A_jᵀ λ` (the joint rows).
#![allow(non_snake_case)]
use super::contact::{contact_rows, PointContact};
use super::error::{SpatialError, SpatialResult};
use super::kinematics::{forward_kinematics_velocity, SpatialData};
use super::model::{JointKind, SpatialModel};
use super::rigid_body::bias_forces_from_kinematics;
use nalgebra::{DMatrix, DVector};

/// Relative size (to the largest) below which a singular value of `G` spans internal forces.
pub const INTERNAL_FORCE_TOLERANCE: f64 = 1e-10;

/// The quasi-static forces of a contact set at a configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialQuasiStatic {
    /// The grasp map `G = A_bᵀ` (6 × c).
    pub grasp: DMatrix<f64>,
    /// The base rows of the gravity forces, `g_b = G λ` (6).
    pub gravity_wrench: DVector<f64>,
    /// `λ_e = G⁺ g_b` (c), the ground's forces on the robot along the rows (as `λ`).
    pub lambda_external: DVector<f64>,
    /// An orthonormal basis of `ker G` (c × k), the internal forces.
    pub internal_basis: DMatrix<f64>,
    /// The joint torques that hold `λ_e` at rest, `h_j − A_jᵀ λ_e` (nv − 6; the base's six
    /// rates carry none).
    pub tau_external: DVector<f64>,
    /// The joint torques of each internal force, `−A_jᵀ N` ((nv − 6) × k).
    pub internal_torques: DMatrix<f64>,
}

/// The quasi-static forces of `contacts` at `q` (see the module's doc). The robot must have a
/// free-flying base; contacts that cannot hold the base at rest (`g_b` outside `G`'s range,
/// to 1e-9 relative) are an error naming `contacts`.
pub fn quasi_static(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
) -> SpatialResult<SpatialQuasiStatic> {
    if model.joints.first().map(|j| j.kind) != Some(JointKind::FreeFlyer) {
        return Err(SpatialError::InvalidArgument {
            field: "base".into(),
            reason: "quasi-static forces need a free-flying base".into(),
        });
    }
    let zero = vec![0.0; model.nv];
    forward_kinematics_velocity(model, data, q, &zero)?;
    bias_forces_from_kinematics(model, data);
    contact_rows(model, data, contacts);
    let (c, nj) = (data.A.nrows(), model.nv - 6);
    let grasp = data.A.columns(0, 6).transpose();
    let gravity_wrench = data.h.rows(0, 6).into_owned();
    let svd = data.A.columns(0, 6).into_owned().svd(true, true);
    let (u, vt) = (svd.u.expect("asked for"), svd.v_t.expect("asked for"));
    // A_b = U Σ Vᵀ, so G = V Σ Uᵀ: G⁺ = U Σ⁺ Vᵀ, ker G = the columns of U with σ = 0 and
    // the complement of U's columns in ℝᶜ
    let top = svd.singular_values.max();
    let mut lambda_external = DVector::zeros(c);
    let mut range = Vec::new();
    for (k, &s) in svd.singular_values.iter().enumerate() {
        if s > INTERNAL_FORCE_TOLERANCE * top {
            lambda_external += u.column(k) * (vt.row(k).transpose().dot(&gravity_wrench) / s);
            range.push(u.column(k).into_owned());
        }
    }
    let residual = (&grasp * &lambda_external - &gravity_wrench).amax();
    if residual > 1e-9 * gravity_wrench.amax().max(1.0) {
        return Err(SpatialError::InvalidArgument {
            field: "contacts".into(),
            reason: format!("cannot hold the base at rest (wrench residual {residual:.3e})"),
        });
    }
    let internal_basis = orthogonal_complement(c, &range);
    let A_j = data.A.columns(6, nj);
    let tau_external = data.h.rows(6, nj) - A_j.transpose() * &lambda_external;
    let internal_torques = -(A_j.transpose() * &internal_basis);
    Ok(SpatialQuasiStatic {
        grasp,
        gravity_wrench,
        lambda_external,
        internal_basis,
        tau_external,
        internal_torques,
    })
}

/// An orthonormal basis of the complement in `ℝⁿ` of the orthonormal vectors `basis`
/// (Gram–Schmidt, twice, on the unit vectors).
fn orthogonal_complement(n: usize, basis: &[DVector<f64>]) -> DMatrix<f64> {
    let mut kept: Vec<DVector<f64>> = basis.to_vec();
    let mut out = Vec::new();
    for i in 0..n {
        let mut e = DVector::zeros(n);
        e[i] = 1.0;
        for _ in 0..2 {
            for b in &kept {
                let d = b.dot(&e);
                e -= b * d;
            }
        }
        let norm = e.norm();
        if norm > 1e-8 {
            e /= norm;
            kept.push(e.clone());
            out.push(e);
        }
        if kept.len() == n {
            break;
        }
    }
    if out.is_empty() {
        return DMatrix::zeros(n, 0);
    }
    DMatrix::from_columns(&out)
}
