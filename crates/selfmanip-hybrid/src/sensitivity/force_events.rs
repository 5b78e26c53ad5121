//! The force events' guards and resets: liftoff `g = −λ_n` (5.50) and slip
//! `g = μ(−λ_n) − |λ_t|` with the guard's explicit time dependence through the torques, and
//! the reset of a force event, the identity — or, where the reset projected the integrator's
//! drift away (`crate::reset`), that plastic impact into the mode before ([`DRIFT_JUMP_TOL`]).
use super::evaluator::{torque_time_derivative, FlowJacobian};
use super::reset_jacobian::{EventAt, GuardReset, NotDifferentiated};
use crate::contact_set::rows_of;
use crate::event::{max_diff, EventKind};
use nalgebra::{DMatrix, DVector, RowDVector};
use selfmanip_core::model::Friction;
use selfmanip_core::tangent::{plastic_impact_jacobian, ImpactJacobian};
use selfmanip_core::{Data, Model};

/// A liftoff's or a slip's guard gradient `D_xg` at the flow `fm` before it; its `∂g/∂t`
/// goes into `dg_dt`.
pub(super) fn force_guard(
    at: &EventAt,
    fm: &FlowJacobian,
    dg_dt: &mut f64,
) -> Result<RowDVector<f64>, NotDifferentiated> {
    let (model, event, before) = (at.model, at.event, at.before);
    let k = event.triggered[0];
    let (rt, rn) = rows_of(before.mode, k);
    let Some(rn) = rn else {
        return Err(NotDifferentiated("no normal row".into()));
    };
    match force_guard_gradient(model, event.kind, k, (rt, rn), &fm.lambda, &fm.dlambda) {
        Some(dg) => {
            // the guard's explicit time dependence through the torques
            let dtau_dt = torque_time_derivative(
                &*before.controller,
                model.n_joints(),
                event.t,
                (at.q(), at.qd_minus()),
                before.mode,
            );
            let dt = &fm.dlambda_dtau
                * DMatrix::from_column_slice(model.n_joints(), 1, dtau_dt.as_slice());
            if let Some(r) = force_guard_gradient(model, event.kind, k, (rt, rn), &fm.lambda, &dt) {
                *dg_dt = r[0];
            }
            Ok(dg)
        }
        None => Err(NotDifferentiated(
            "slip of a contact without a tangential row".into(),
        )),
    }
}

/// The reset of an event other than a touchdown: no velocity jump but the drift's, the
/// identity in state, or (at a slip, `crate::reset`) the projection of the integrator's
/// drift `A q̇ ≠ 0` away, a plastic impact into the mode before (5.52), whose Jacobians and
/// state after go into `gr`.
pub(super) fn drift_reset(at: &EventAt, gr: &mut GuardReset) -> Result<(), NotDifferentiated> {
    let model = at.model;
    let qd_minus = at.qd_minus();
    let jump = max_diff(qd_minus, &at.event.qd_after);
    if jump > 0.0 {
        let mut data = Data::new(model);
        match drift_projection(at, &mut data) {
            Some(ij) => {
                // its body parameters' `D_pR` are of the order of the drift
                gr.plastic_impact(at, &mut data, &ij, &at.event.qd_after);
            }
            None => {
                return Err(NotDifferentiated(format!(
                    "velocity jump {jump:.2e} at a non-impact event"
                )))
            }
        }
    }
    Ok(())
}

/// Relative size `|q̇⁺ − q̇⁻| / (1 + |q̇⁻|)` (max norms) up to which a velocity jump at a
/// force event is the projection of the integrator's drift (the constraint velocity `A q̇`
/// of a located event is of the order of the tolerances; a sliding speed this small counts
/// as rest, `selfmanip_core::friction::SLIDING_SPEED_EPS_M_S`).
pub const DRIFT_JUMP_TOL: f64 = 1e-6;

/// The drift projection a force event's reset applied (`crate::reset`): the plastic impact
/// (5.52) into the mode before from `q̇⁻`, with its Jacobian, if it reproduces the
/// recorded `q̇⁺` and the jump is within [`DRIFT_JUMP_TOL`]; `None` for any other jump. `data`
/// is left with the impact's factorization (for [`plastic_impact_body_derivatives`]).
///
/// Its Jacobian is the reset's `D_xR` exactly. On a tangent that satisfies the linearized
/// constraints of the mode, `D_qA[δq] q̇ + A δq̇ = 0`, it is the identity up to the drift:
/// `q̇⁺ = q̇ − M̄⁻¹Aᵀ(AM̄⁻¹Aᵀ)⁻¹A q̇` gives
/// `δq̇⁺ = δq̇ − M̄⁻¹Aᵀ(AM̄⁻¹Aᵀ)⁻¹(A δq̇ + D_qA[δq] q̇) + O(|A q̇|)`; on one that drifted off
/// them it projects that drift away too, as the reset does to the state.
fn drift_projection(at: &EventAt, data: &mut Data) -> Option<ImpactJacobian> {
    let (model, terrain, mode) = (at.model, at.terrain, at.before.mode);
    let (q, qd_minus, qd_after) = (at.q(), at.qd_minus(), &at.event.qd_after[..]);
    let scale = 1.0 + qd_minus.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if max_diff(qd_minus, qd_after) > DRIFT_JUMP_TOL * scale {
        return None;
    }
    let ij = plastic_impact_jacobian(model, data, terrain, mode, q, qd_minus).ok()?;
    (max_diff(ij.impact.qd_plus.as_slice(), qd_after) <= 1e-12 * scale).then_some(ij)
}

/// The gradient of a force guard (liftoff `g = −λ_n` (5.50), slip `g = μ(−λ_n) − |λ_t|`) of
/// contact `k` with rows `(tangential, normal)` from `∂λ` along any columns; `None` for a
/// slip without a tangential row or friction coefficient.
pub(super) fn force_guard_gradient(
    model: &Model,
    kind: EventKind,
    k: usize,
    (rt, rn): (Option<usize>, usize),
    lambda: &DVector<f64>,
    dlambda: &DMatrix<f64>,
) -> Option<RowDVector<f64>> {
    if kind == EventKind::Liftoff {
        return Some(-dlambda.row(rn));
    }
    let (Some(rt), Friction::Sticking { mu }) = (rt, model.contacts[k].friction) else {
        return None;
    };
    Some(-mu * dlambda.row(rn) - lambda[rt].signum() * dlambda.row(rt))
}
