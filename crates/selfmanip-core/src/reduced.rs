//! Reduced dynamics in user-chosen coordinates `y` (thesis 4.1.7, 4.1.10; eqs. 4.18–4.20,
//! 4.34–4.40).
//!
//! With `ẏ = Y q̇` (`Y`: e×q, `e = q − c`), `H = [A; Y]⁻¹ [0; I_e]` (4.20) spans the free
//! motions, `Ḣ = −[A; Y]⁻¹ [Ȧ; 0] H`, and
//! `M̃ = HᵀM̄H`, `C̃ = HᵀC̄H + HᵀM̄Ḣ`, `Ñ = HᵀN̄`, `Ỹ = HᵀΥ` (4.36–4.37),
//! `ÿ = M̃⁻¹(Ỹ − Ñ − C̃ẏ)` (4.35), `q̈ = Hÿ + Ḣẏ` (4.38),
//! `λ = A*(Υ − N̄) − A*(M̄Ḣ + C̄H)ẏ` (4.39) with `[A*; (M̄H)*] = [Aᵀ, M̄H]⁻¹` (4.40).
//! (The converted text gives `Y ∈ ℝ^{q×e}`; it must be e×q for `[A; Y]` to be square.)
#![allow(non_snake_case)]
use crate::contact::{ContactMode, Terrain};
use crate::error::{check_finite, check_vector, CoreError, Result, SingularityKind};
use crate::inertia::coriolis_matrix;
use crate::model::Model;
use crate::Data;
use nalgebra::{DMatrix, DVector};

#[derive(Debug, Clone)]
pub struct ReducedDynamics {
    pub h: DMatrix<f64>,
    pub h_dot: DMatrix<f64>,
    pub m_tilde: DMatrix<f64>,
    pub c_tilde: DMatrix<f64>,
    pub n_tilde: DVector<f64>,
    pub upsilon_tilde: DVector<f64>,
    /// The mass-weighted left inverse `A*` (c×q): `A*Aᵀ = I`, `A*M̄H = 0`.
    pub a_star: DMatrix<f64>,
    pub yd: DVector<f64>,
    pub ydd: DVector<f64>,
    pub qdd: DVector<f64>,
    pub lambda: DVector<f64>,
}

/// Evaluates the reduced dynamics for the parameterization `y_map` (= `Y`). The velocity
/// used is the constrained one, `q̇ = H Y q̇_in`.
#[allow(clippy::too_many_arguments)]
pub fn reduced_dynamics(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    y_map: &DMatrix<f64>,
) -> Result<ReducedDynamics> {
    let nq = model.nq();
    let n = model.n_joints();
    check_vector("tau", tau, n)?;
    check_vector("qd", qd, nq)?;
    check_finite("Y", y_map.as_slice())?;
    let c = mode.n_rows();
    if c > nq {
        return Err(CoreError::SingularKkt {
            kind: SingularityKind::RedundantConstraints,
            condition_estimate: f64::INFINITY,
        });
    }
    let e = nq - c;
    if y_map.shape() != (e, nq) {
        return Err(CoreError::InvalidParameterization {
            field: "Y",
            reason: format!(
                "must be {e}×{nq} (e = q − c), got {}×{}",
                y_map.nrows(),
                y_map.ncols()
            ),
        });
    }
    // Geometry and inertia at (q, q̇_in) to get H; then re-evaluate at the constrained q̇.
    // Only M̃ must be invertible (checked below), not the KKT matrix.
    let tolerate_kkt = |r: Result<()>| match r {
        Err(CoreError::SingularKkt { .. }) => Ok(()),
        other => other,
    };
    tolerate_kkt(data.prepare(model, terrain, mode, q, qd))?;
    let mut ay = DMatrix::zeros(nq, nq);
    ay.view_mut((0, 0), (c, nq)).copy_from(&data.constraints.a);
    ay.view_mut((c, 0), (e, nq)).copy_from(y_map);
    let lu = ay.clone().lu();
    if !lu.is_invertible()
        || ay.clone().svd(false, false).singular_values.min() <= 1e-12 * ay.norm()
    {
        return Err(CoreError::InvalidParameterization {
            field: "Y",
            reason: "[A; Y] is singular: y does not parameterize the free motion here".into(),
        });
    }
    let mut rhs = DMatrix::zeros(nq, e);
    rhs.view_mut((c, 0), (e, e)).fill_with_identity();
    let h = lu.solve(&rhs).expect("invertible");
    let yd = y_map * DVector::from_column_slice(qd);
    let qd_c = &h * &yd;
    tolerate_kkt(data.prepare(model, terrain, mode, q, qd_c.as_slice()))?;
    let mut adot0 = DMatrix::zeros(nq, e);
    adot0
        .view_mut((0, 0), (c, e))
        .copy_from(&(&data.constraints.a_dot * &h));
    let h_dot = -lu.solve(&adot0).expect("invertible");
    let c_bar = coriolis_matrix(model, &data.kin);
    let m_bar = &data.m_bar;
    let m_tilde = h.transpose() * m_bar * &h;
    let c_tilde = h.transpose() * &c_bar * &h + h.transpose() * m_bar * &h_dot;
    let n_tilde = h.transpose() * &data.n_bar;
    let mut upsilon = DVector::zeros(nq);
    upsilon
        .rows_mut(0, n)
        .copy_from(&DVector::from_column_slice(tau));
    let upsilon_tilde = h.transpose() * &upsilon;
    let chol = m_tilde.clone().cholesky().ok_or(CoreError::SingularKkt {
        kind: SingularityKind::UnconstrainedMasslessMotion,
        condition_estimate: f64::INFINITY,
    })?;
    let ydd = chol.solve(&(&upsilon_tilde - &n_tilde - &c_tilde * &yd));
    let qdd = &h * &ydd + &h_dot * &yd;
    // [Aᵀ, M̄H]⁻¹ : first c rows are A*
    let mut am = DMatrix::zeros(nq, nq);
    am.view_mut((0, 0), (nq, c))
        .copy_from(&data.constraints.a.transpose());
    am.view_mut((0, c), (nq, e)).copy_from(&(m_bar * &h));
    let am_inv = am.try_inverse().ok_or(CoreError::SingularKkt {
        kind: SingularityKind::UnconstrainedMasslessMotion,
        condition_estimate: f64::INFINITY,
    })?;
    let a_star = am_inv.rows(0, c).into_owned();
    let lambda =
        &a_star * (&upsilon - &data.n_bar) - &a_star * (m_bar * &h_dot + &c_bar * &h) * &yd;
    Ok(ReducedDynamics {
        h,
        h_dot,
        m_tilde,
        c_tilde,
        n_tilde,
        upsilon_tilde,
        a_star,
        yd,
        ydd,
        qdd,
        lambda,
    })
}
