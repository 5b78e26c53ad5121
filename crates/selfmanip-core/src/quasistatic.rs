//! Quasi-static contact forces and torques (thesis 4.1.8, eqs. 4.21–4.23).
//!
//! At rest (`q̇ = q̈ = 0`) the body rows of (4.32) read `G_s f_c = −F_g` (4.21) with
//! `F_g = −R_wpᵀ N̄_body` the gravity wrench in body coordinates (4.91) and `f_c = −λ` the
//! force the robot exerts on the ground. Internal forces span `ker G_s` (4.22). A particular
//! solution is fixed by torque constraints `tᵀ τ = 0` (4.23), `τ = N̄_θ + J_hᵀ f_c`.
//! Results are returned in both conventions: `f_c` (thesis chapter 4) and `λ = −f_c`.
#![allow(non_snake_case)]
use crate::contact::{ConstraintRow, ContactMode, Terrain};
use crate::error::{check_finite, check_result, check_vector, CoreError, Result};
use crate::frames::rot3;
use crate::grasp::grasp_maps;
use crate::kinematics::Kinematics;
use crate::model::Model;
use crate::Data;
use nalgebra::{DMatrix, DVector, SymmetricEigen, Vector3};

/// Relative tolerance for the null space of `G_s`.
pub const NULL_SPACE_TOLERANCE: f64 = 1e-10;

#[derive(Debug, Clone)]
pub struct QuasiStatic {
    pub rows: Vec<ConstraintRow>,
    pub g_s: DMatrix<f64>,
    pub j_h: DMatrix<f64>,
    /// Gravity wrench on the body in body coordinates `F_g` (4.91).
    pub gravity_wrench: Vector3<f64>,
    /// Internal force basis `f_N` (c×a), columns orthonormal, in the `f_c` convention.
    pub internal_basis: DMatrix<f64>,
    /// Joint torques of each internal force `J_hᵀ f_N` (n×a).
    pub internal_torques: DMatrix<f64>,
    /// The particular solution `f_p` of (4.23) in the `f_c` convention.
    pub f_particular: DVector<f64>,
    /// The same forces as Lagrange multipliers `λ_p = −f_p`.
    pub lambda_particular: DVector<f64>,
    /// Joint torques that hold the particular solution, `τ_p = N̄_θ + J_hᵀ f_p`.
    pub tau_particular: DVector<f64>,
}

/// Solves (4.21)–(4.23) in `mode` at `q` with torque constraints `t` (n×a_t, the rows of
/// `tᵀ τ = 0`; pass an n×0 matrix when the contact forces are already determined).
pub fn quasi_static(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    t: &DMatrix<f64>,
) -> Result<QuasiStatic> {
    let nq = model.nq();
    let n = model.n_joints();
    check_vector("q", q, nq)?;
    mode.validate(model)?;
    if t.nrows() != n {
        return Err(CoreError::WrongLength {
            field: "torque_constraints rows",
            expected: n,
            actual: t.nrows(),
        });
    }
    check_finite("torque_constraints", t.as_slice())?;
    if mode.is_flight() {
        return Err(CoreError::IllPosedQuasiStatic {
            reason: if model.n_contacts() == 0 {
                "the robot has no contact sites: nothing can hold it at rest".into()
            } else {
                "the mode has no active contact (flight): nothing holds the robot at rest".into()
            },
        });
    }
    let zero = vec![0.0; nq];
    let mut kin = Kinematics::default();
    kin.compute(model, q, &zero);
    let maps = grasp_maps(model, &kin, terrain, mode);
    // N̄ at rest (C̄q̇ = 0)
    let mut scratch = Default::default();
    crate::inertia::mass_coriolis_gravity(
        model,
        &kin,
        &zero,
        &mut scratch,
        &mut data.m_bar,
        &mut data.c_qd,
        &mut data.n_bar,
    );
    let nb = Vector3::new(data.n_bar[n], data.n_bar[n + 1], data.n_bar[n + 2]);
    let f_g = -(rot3(q[n + 2]).transpose() * nb);
    let c = maps.rows.len();
    // (4.21) has three equations: with fewer contact rows (flight, a single sliding contact)
    // gravity cannot be balanced, and `ker G_s` of an empty `G_s` is not defined
    if c < 3 {
        return Err(CoreError::IllPosedQuasiStatic {
            reason: format!(
                "the mode has {c} contact row(s); balancing the body's three equations (4.21) \
                 needs at least 3"
            ),
        });
    }

    // ker G_s from the eigenvectors of G_sᵀ G_s with (relatively) zero eigenvalue
    let gtg = maps.g_s.transpose() * &maps.g_s;
    let eig = SymmetricEigen::new(gtg);
    let scale = eig
        .eigenvalues
        .iter()
        .cloned()
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let null: Vec<usize> = (0..c)
        .filter(|&i| eig.eigenvalues[i] <= NULL_SPACE_TOLERANCE * scale)
        .collect();
    let mut internal_basis = DMatrix::zeros(c, null.len());
    for (col, &i) in null.iter().enumerate() {
        internal_basis.set_column(col, &eig.eigenvectors.column(i));
    }
    let internal_torques = maps.j_h.transpose() * &internal_basis;

    // [G_s; tᵀ J_hᵀ] f = [−F_g; −tᵀ N̄_θ]
    let at = t.ncols();
    if 3 + at != c {
        return Err(CoreError::IllPosedQuasiStatic {
            reason: format!(
                "{c} contact rows need {} torque constraints, got {at}",
                c as i64 - 3
            ),
        });
    }
    let mut lhs = DMatrix::zeros(c, c);
    lhs.view_mut((0, 0), (3, c)).copy_from(&maps.g_s);
    let tj = t.transpose() * maps.j_h.transpose();
    lhs.view_mut((3, 0), (at, c)).copy_from(&tj);
    let n_theta = data.n_bar.rows(0, n).into_owned();
    let mut rhs = DVector::zeros(c);
    rhs.rows_mut(0, 3).copy_from(&(-f_g));
    rhs.rows_mut(3, at)
        .copy_from(&(-(t.transpose() * &n_theta)));
    let svd = lhs.clone().svd(false, false);
    let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
    if !(smin > 1e-12 * smax) {
        return Err(CoreError::IllPosedQuasiStatic {
            reason: format!(
                "the augmented grasp map is singular (condition {:.3e})",
                smax / smin
            ),
        });
    }
    let f_p = lhs
        .lu()
        .solve(&rhs)
        .ok_or_else(|| CoreError::IllPosedQuasiStatic {
            reason: "the augmented grasp map is singular".into(),
        })?;
    let tau_p = &n_theta + maps.j_h.transpose() * &f_p;
    check_result("f_p", f_p.as_slice())?;
    check_result("τ_p", tau_p.as_slice())?;
    Ok(QuasiStatic {
        rows: maps.rows,
        g_s: maps.g_s,
        j_h: maps.j_h,
        gravity_wrench: f_g,
        internal_basis,
        internal_torques,
        lambda_particular: -&f_p,
        f_particular: f_p,
        tau_particular: tau_p,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::FlatGround;
    use crate::RobotDescription;

    /// `tests/data/robots/massless_leg_toe.toml`, with its toe or (`toe = false`) without
    /// any contact.
    fn model(toe: bool) -> Model {
        let text = include_str!("../../../tests/data/robots/massless_leg_toe.toml");
        let mut description = RobotDescription::from_toml_str(text).expect("valid description");
        if !toe {
            description.contacts.clear();
        }
        description.build().expect("valid description")
    }

    /// Fewer than three contact rows cannot balance the body's three equations (4.21): a
    /// typed error, not a panic in the eigen-solver of an empty `G_sᵀ G_s` (flight, or a robot
    /// with no contacts at all) nor a request for a negative number of torque constraints.
    #[test]
    fn fewer_than_three_contact_rows_are_ill_posed() {
        let q = [0.0, 0.0, -0.2, 0.0];
        let none = DMatrix::zeros(1, 0);
        for (m, spec) in [(model(false), ""), (model(true), ""), (model(true), "toe")] {
            let mode = ContactMode::parse_names(&m, spec).unwrap();
            let mut data = Data::new(&m);
            let e = quasi_static(&m, &mut data, &FlatGround, mode, &q, &none).unwrap_err();
            assert!(
                matches!(e, CoreError::IllPosedQuasiStatic { .. }),
                "{spec:?}: {e}"
            );
        }
    }
}
