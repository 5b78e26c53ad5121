//! Quasi-static contact forces and torques (thesis 4.1.8, eqs. 4.21–4.23).
//!
//! At rest (`q̇ = q̈ = 0`) the body rows of (4.32) read `G_s f_c = −F_g` (4.21) with
//! `F_g = −R_wpᵀ N̄_body` the gravity wrench in body coordinates (4.91) and `f_c = −λ` the
//! force the robot exerts on the ground. Internal forces span `ker G_s` (4.22). A particular
//! solution is fixed by torque constraints `tᵀ τ = 0` (4.23), `τ = N̄_θ + J_hᵀ f_c`.
//! Results are returned in both conventions: `f_c` (thesis chapter 4) and `λ = −f_c`.
#![allow(non_snake_case)]
use crate::contact::{ContactMode, Terrain};
use crate::error::{check_finite, check_result, check_vector, CoreError, Result};
use crate::frames::rot3;
use crate::grasp::{grasp_maps, GraspMaps};
use crate::kinematics::Kinematics;
use crate::model::Model;
use crate::Data;
use nalgebra::{DMatrix, DVector, SymmetricEigen, Vector3};

/// Relative tolerance for the null space of `G_s`.
pub const NULL_SPACE_TOLERANCE: f64 = 1e-10;

#[derive(Debug, Clone)]
pub struct QuasiStatic {
    /// `G_s`, `J_h` and the row layout of the mode.
    pub maps: GraspMaps,
    /// Gravity wrench on the body in body coordinates `F_g` (4.91).
    pub gravity_wrench: Vector3<f64>,
    /// The forces that balance it, in the `f_c` convention: the internal force basis `f_N`
    /// (c×a, columns orthonormal) with its joint torques `J_hᵀ f_N`, the particular
    /// solution `f_p` of (4.23) and the joint torques that hold it, `τ_p = N̄_θ + J_hᵀ f_p`.
    pub balance: ContactForceBalance,
}

impl QuasiStatic {
    /// The particular forces as Lagrange multipliers, `λ_p = −f_p`.
    pub fn lambda_particular(&self) -> DVector<f64> {
        -&self.balance.f_particular
    }
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

    let n_theta = data.n_bar.rows(0, n).into_owned();
    let balance = balance_contact_forces(
        &maps.g_s,
        &DVector::from_column_slice((-f_g).as_slice()),
        &maps.j_h,
        &n_theta,
        ParticularForces::TorqueConstraints(t),
    )?;
    Ok(QuasiStatic {
        maps,
        gravity_wrench: f_g,
        balance,
    })
}

/// How the particular forces are chosen among the solutions `f_p + ker G` of `G f = w`.
#[derive(Debug, Clone, Copy)]
pub enum ParticularForces<'a> {
    /// Torque constraints `tᵀ τ = 0` (4.23): `t` is n×a_t with `b + a_t = c` (the base's `b`
    /// equations and the `c` contact rows), so `[G; tᵀ J_hᵀ] f = [w; −tᵀ τ₀]` is square.
    TorqueConstraints(&'a DMatrix<f64>),
    /// The minimum-norm forces `G⁺ w`, orthogonal to `ker G` (for a plate on point feet, the
    /// forces of equally stiff legs); `w` outside `G`'s range (to 1e-9 relative) is an error.
    MinimumNorm,
}

/// The contact forces that hold a robot's base at rest, for `d = 2` (`b = 3` base equations)
/// and `d = 3` (`b = 6`).
#[derive(Debug, Clone, PartialEq)]
pub struct ContactForceBalance {
    /// An orthonormal basis of the internal forces `ker G` (4.22), c×k.
    pub internal_basis: DMatrix<f64>,
    /// The joint torques of each internal force, `J_hᵀ N` (n×k).
    pub internal_torques: DMatrix<f64>,
    /// The particular forces `f_p` (c), `G f_p = w`.
    pub f_particular: DVector<f64>,
    /// The joint torques that hold them, `τ₀ + J_hᵀ f_p` (n).
    pub tau_particular: DVector<f64>,
}

/// Thesis (4.21)–(4.23) for `SE(d)`: the forces `f` (c) on the contact rows with `G f = w`
/// (`G` b×c, the grasp map; `w` the wrench the contacts balance, b), split into a particular
/// solution chosen by `choice` and the internal forces `ker G`, with the joint torques
/// `τ = τ₀ + J_hᵀ f` (`J_h` c×n) that hold them. `ker G` comes from the eigenvectors of `GᵀG`
/// whose eigenvalue is at most [`NULL_SPACE_TOLERANCE`] of the largest.
pub fn balance_contact_forces(
    G: &DMatrix<f64>,
    w: &DVector<f64>,
    J_h: &DMatrix<f64>,
    tau_0: &DVector<f64>,
    choice: ParticularForces,
) -> Result<ContactForceBalance> {
    let (b, c) = (G.nrows(), G.ncols());
    if c == 0 {
        return Err(CoreError::IllPosedQuasiStatic {
            reason: "no contact rows: nothing holds the robot at rest".into(),
        });
    }
    // ker G from the eigenvectors of GᵀG with (relatively) zero eigenvalue
    let eig = SymmetricEigen::new(G.transpose() * G);
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
    let internal_torques = J_h.transpose() * &internal_basis;
    let f_p = match choice {
        ParticularForces::TorqueConstraints(t) => torque_constrained(G, w, J_h, tau_0, t)?,
        ParticularForces::MinimumNorm => {
            // G⁺ w = Σ over GᵀG's range of v_k (v_kᵀ Gᵀ w) / μ_k
            let gtw = G.transpose() * w;
            let mut f = DVector::zeros(c);
            for k in (0..c).filter(|k| !null.contains(k)) {
                let v_k = eig.eigenvectors.column(k);
                f += v_k * (v_k.dot(&gtw) / eig.eigenvalues[k]);
            }
            let residual = (G * &f - w).amax();
            if residual > 1e-9 * w.amax().max(1.0) {
                return Err(CoreError::IllPosedQuasiStatic {
                    reason: format!(
                        "the contacts cannot hold the base at rest (wrench residual \
                         {residual:.3e} of {b} base equations)"
                    ),
                });
            }
            f
        }
    };
    let tau_p = tau_0 + J_h.transpose() * &f_p;
    check_result("f_p", f_p.as_slice())?;
    check_result("τ_p", tau_p.as_slice())?;
    Ok(ContactForceBalance {
        internal_basis,
        internal_torques,
        f_particular: f_p,
        tau_particular: tau_p,
    })
}

/// The particular solution of (4.23): `[G; tᵀ J_hᵀ] f = [w; −tᵀ τ₀]`.
fn torque_constrained(
    G: &DMatrix<f64>,
    w: &DVector<f64>,
    J_h: &DMatrix<f64>,
    tau_0: &DVector<f64>,
    t: &DMatrix<f64>,
) -> Result<DVector<f64>> {
    let (b, c) = (G.nrows(), G.ncols());
    let at = t.ncols();
    if b + at != c {
        return Err(CoreError::IllPosedQuasiStatic {
            reason: format!(
                "{c} contact rows need {} torque constraints, got {at}",
                c as i64 - b as i64
            ),
        });
    }
    let mut lhs = DMatrix::zeros(c, c);
    lhs.view_mut((0, 0), (b, c)).copy_from(G);
    let tj = t.transpose() * J_h.transpose();
    lhs.view_mut((b, 0), (at, c)).copy_from(&tj);
    let mut rhs = DVector::zeros(c);
    rhs.rows_mut(0, b).copy_from(w);
    rhs.rows_mut(b, at).copy_from(&(-(t.transpose() * tau_0)));
    let svd = lhs.clone().svd(false, false);
    let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
    if smin.is_nan() || smax.is_nan() || smin <= 1e-12 * smax {
        return Err(CoreError::IllPosedQuasiStatic {
            reason: format!(
                "the augmented grasp map is singular (condition {:.3e})",
                smax / smin
            ),
        });
    }
    lhs.lu()
        .solve(&rhs)
        .ok_or_else(|| CoreError::IllPosedQuasiStatic {
            reason: "the augmented grasp map is singular".into(),
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
