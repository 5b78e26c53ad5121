//! Coulomb sliding of spatial contacts (`d = 3`; the planar core's general sliding site,
//! [`crate::friction`]): a sliding contact keeps its normal row in `A`, and the ground's
//! tangential force on it lies on the edge of the **circular** friction cone, opposite the
//! contact point's sliding velocity: `F_t = −μ λ_n ŝ`, `ŝ = v_t/|v_t|`, `v_t` the tangential
//! part of the material point's velocity. As a generalized force it is linear in `λ_n`,
//! `J_pᵀ F_t = Bᵀλ` with `B`'s row of that contact `−μ ŝᵀ J_p` (zero in every other row), so
//! the KKT system (5.2) becomes the square nonsymmetric
//!
//! ```text
//! [M  −(A + B)ᵀ] [q̈]   [τ − h ]
//! [A      0    ] [λ ] = [−Ȧq̇ ]
//! ```
//!
//! solved here by a dense LU: exact for a singular `M` (massless limbs) wherever the system
//! is regular. Sign convention as [`super::contact`]: `λ_n > 0` pushes; a sliding contact whose
//! `λ_n` comes out negative is leaving the ground (the caller's event, not an error here).
//! [`super::contact::friction_rows`] writes `B`.
#![allow(non_snake_case)]
use super::error::SpatialResult;
use super::kinematics::SpatialData;
use nalgebra::{DMatrix, DVector};
use std::cmp::Ordering;

/// A sliding velocity `|v_t|` at most this (m/s) has no direction: the contact is sticking or
/// starting to slide, and needs its tangent rows.
pub const MIN_SLIDING_SPEED: f64 = 1e-9;
/// `min |U_ii| / max |U_ii|` of the LU factor below which the sliding KKT system is singular.
pub const SINGULAR_PIVOT_RATIO: f64 = 1e-13;

/// Solves the nonsymmetric system of the module's doc into `data.qdd` and `data.lam` (`M`,
/// `h`, `A`, `Ȧq̇` already in `data`).
pub fn solve_sliding(data: &mut SpatialData, B: &DMatrix<f64>, tau: &[f64]) -> SpatialResult<()> {
    let (nv, c) = (data.M.nrows(), data.A.nrows());
    let mut K = DMatrix::zeros(nv + c, nv + c);
    K.view_mut((0, 0), (nv, nv)).copy_from(&data.M);
    K.view_mut((0, nv), (nv, c))
        .copy_from(&(-(&data.A + B).transpose()));
    K.view_mut((nv, 0), (c, nv)).copy_from(&data.A);
    let mut rhs = DVector::zeros(nv + c);
    for i in 0..nv {
        rhs[i] = tau[i] - data.h[i];
    }
    for r in 0..c {
        rhs[nv + r] = -data.A_drift[r];
    }
    let lu = K.lu();
    let diag = lu.u().diagonal().map(f64::abs);
    let ratio = diag.min() / diag.max().max(f64::MIN_POSITIVE);
    if ratio.partial_cmp(&SINGULAR_PIVOT_RATIO) != Some(Ordering::Greater) {
        return Err(crate::CoreError::SingularKkt {
            kind: crate::SingularityKind::UnconstrainedMasslessMotion,
            condition_estimate: 1.0 / ratio,
        }
        .into());
    }
    let x = lu.solve(&rhs).ok_or(crate::CoreError::SingularKkt {
        kind: crate::SingularityKind::UnconstrainedMasslessMotion,
        condition_estimate: f64::INFINITY,
    })?;
    data.qdd.copy_from(&x.rows(0, nv));
    data.lam.copy_from(&x.rows(nv, c));
    Ok(())
}
