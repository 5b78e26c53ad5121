//! Several guards at once: the one-sided derivatives of an event at which the guards of
//! several contacts fired at the same instant (two feet landing together, or lifting off
//! together), one per order in which a perturbation may make them fire.
//!
//! Near such a state the flow is piecewise smooth ("event-selected C^r", Burden, Revzen,
//! Sastry, *Model reduction near periodic orbits of hybrid dynamical systems*, IEEE TAC 2015;
//! Hiskens, Pai, *Trajectory sensitivity analysis of hybrid systems*, IEEE TCAS-I 2000): a
//! perturbation `δ` makes the guards fire in the order of their times `t_i + Dt_i δ`, and the
//! run goes through that sequence of single-guard events with modes held for `O(|δ|)` time
//! between them. Its Bouligand derivative is piecewise linear, one piece per order `σ`,
//! `Ξ_σ = Ξ_{σ_k} ⋯ Ξ_{σ_1}`, each factor the single guard's saltation with the flow of the
//! mode the earlier guards left. Where the flow is continuous across the switch (plastic
//! impacts are nested projections, `P_{AB} P_A = P_{AB}`; a liftoff where `λ_n = 0` changes
//! no velocity) the pieces agree on the perturbations that keep the guards simultaneous —
//! in a mirror-symmetric gait, the symmetric ones — and where they agree everywhere the
//! event is differentiable.
use super::evaluator::{torque_time_derivative, Evaluator, FlowPoint};
use super::force_events::{drift_reset, force_guard_gradient};
use super::reset_jacobian::{EventAt, GuardReset, NotDifferentiated};
use super::saltation::saltation_with_rate;
use super::types::{OneSidedSaltation, SensitivityError};
use crate::contact_set::rows_of;
use crate::controller::Controller;
use crate::event::{max_diff, Event, EventKind};
use crate::execution::Segment;
use nalgebra::{DMatrix, DVector, RowDVector};
use selfmanip_core::contact::{contact_geometry, RowDirection};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::tangent::{height_gradient, plastic_impact_jacobian};
use selfmanip_core::{ContactMode, Data};

/// The most guards of one event whose orders are formed (`k!` orders).
pub const MAX_SIMULTANEOUS_GUARDS: usize = 4;

/// Relative difference (max norm, to `max(1, |Ξ|)`) up to which the orders' derivatives count
/// as one: the event is then differentiable.
pub const ORDER_AGREEMENT_TOL: f64 = 1e-8;

/// A contact the reset of a liftoff released at once counts as a guard of the event when
/// its own guard `−λ_n` would have reached zero within this time of the event (s): `|λ_n| ≤
/// SIMULTANEOUS_GUARD_S |λ̇_n|`. Far below any time scale of the flow, far above the events'
/// location (1e-10 s by default, [`crate::HybridOptions::event_tol_s`]) and round-off: on a
/// symmetric orbit, the twin foot whose force vanishes with the triggering one's.
pub const SIMULTANEOUS_GUARD_S: f64 = 1e-8;

/// The contacts whose guards fired at `event` (state `y = [q; q̇⁻]` before it, flow of
/// `before`): those that triggered it and, at a liftoff, those its reset released at once
/// whose own force vanished with them ([`SIMULTANEOUS_GUARD_S`]). A contact released with
/// a force still pushing is no guard: complementarity let it go, the same on either side.
pub(super) fn guards_at_once(
    ev: &mut Evaluator,
    before: &Segment,
    event: &Event,
    y: &[f64],
) -> Result<Vec<usize>, SensitivityError> {
    let mut guards = event.triggered.clone();
    if event.kind == EventKind::Jam {
        // a jam names the contact whose slide was inconsistent with the contacts that
        // touched down: only the touchdowns are guards that fired
        guards.retain(|&c| !before.mode.contains(c));
        return Ok(guards);
    }
    if event.kind != EventKind::Liftoff {
        return Ok(guards);
    }
    let released: Vec<usize> = before
        .mode
        .active()
        .filter(|&c| !event.mode_after.contains(c) && !guards.contains(&c))
        .collect();
    if released.is_empty() {
        return Ok(guards);
    }
    let fj = ev.eval(FlowPoint::on(before, event.t, y))?;
    for c in released {
        let Some(rn) = rows_of(before.mode, c).1 else {
            continue;
        };
        let rate = (fj.dlambda.row(rn) * &fj.f)[0];
        if fj.lambda[rn].abs() <= SIMULTANEOUS_GUARD_S * rate.abs() {
            guards.push(c);
        }
    }
    Ok(guards)
}

/// The event's derivative for every order of its `guards` (their contacts), the first in
/// the order they are listed; or why they are not formed.
pub(super) fn one_sided_saltations(
    ev: &mut Evaluator,
    (before, after): (&Segment, &Segment),
    event: &Event,
    guards: &[usize],
    y: &[f64],
) -> Result<Result<Vec<OneSidedSaltation>, NotDifferentiated>, SensitivityError> {
    let n = guards.len();
    let not = |r: String| Ok(Err(NotDifferentiated(r)));
    if !matches!(event.kind, EventKind::Touchdown | EventKind::Liftoff) {
        return not(format!("several guards of a {} at once", event.kind.name()));
    }
    if n > MAX_SIMULTANEOUS_GUARDS {
        return not(format!(
            "{n} guards at once (the orders are formed for at most {MAX_SIMULTANEOUS_GUARDS})"
        ));
    }
    if before.controller.has_event_memory() || after.controller.has_event_memory() {
        return not("several guards at once under a controller with event memory".into());
    }
    let mut out = Vec::new();
    for order in permutations(guards) {
        match fire_in_order(ev, (before, after), event, y, &order)? {
            Ok(p) => out.push(p),
            Err(e) => return Ok(Err(e)),
        }
    }
    Ok(Ok(out))
}

/// Whether every order's derivative is the first's (to [`ORDER_AGREEMENT_TOL`]).
pub(super) fn orders_agree(pieces: &[OneSidedSaltation]) -> bool {
    let first = &pieces[0].saltation;
    let scale = first.amax().max(1.0);
    pieces[1..]
        .iter()
        .all(|p| (&p.saltation - first).amax() <= ORDER_AGREEMENT_TOL * scale)
}

/// Every order of `items`, the given one first.
fn permutations(items: &[usize]) -> Vec<Vec<usize>> {
    if items.len() <= 1 {
        return vec![items.to_vec()];
    }
    let mut out = Vec::new();
    for (i, &first) in items.iter().enumerate() {
        let rest: Vec<usize> = items
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, &c)| c)
            .collect();
        for mut tail in permutations(&rest) {
            tail.insert(0, first);
            out.push(tail);
        }
    }
    out
}

/// One guard's part of the composition: its gradient and rate's time part, the reset's
/// Jacobian, the mode and state after it, the impulse into that mode.
struct GuardStep {
    dg: RowDVector<f64>,
    dg_dt: f64,
    dr: DMatrix<f64>,
    mode_after: ContactMode,
    y_plus: Vec<f64>,
    impulse: Vec<f64>,
}

/// `Ξ_σ` of the guards in `order`, starting from the state `y = [q; q̇⁻]` before the event
/// in the mode and with the controller of `before`, ending in the recorded mode and flow of
/// `after`.
fn fire_in_order(
    ev: &mut Evaluator,
    (before, after): (&Segment, &Segment),
    event: &Event,
    y: &[f64],
    order: &[usize],
) -> Result<Result<OneSidedSaltation, NotDifferentiated>, SensitivityError> {
    let (model, t) = (ev.model, event.t);
    let n2 = 2 * model.nq();
    let mut ctrl: Box<dyn Controller> = before.controller.clone_box();
    let mut mode = before.mode;
    let mut cur = y.to_vec();
    let mut xi = DMatrix::identity(n2, n2);
    let mut time_row = None;
    let said = |k: usize, r: String| {
        Ok(Err(NotDifferentiated(format!(
            "in the order {order:?}, contact {k}: {r}"
        ))))
    };
    for (i, &k) in order.iter().enumerate() {
        let last = i + 1 == order.len();
        let here = FlowPoint {
            ctrl: &*ctrl,
            locked: &before.locked,
            dirs: &before.slide_directions,
            t,
            mode,
            y: &cur,
        };
        let (f_minus, step) = match event.kind {
            EventKind::Touchdown => {
                let f = ev.flow(here)?;
                (f, touch(ev, event, mode, &cur, k, last))
            }
            _ => {
                let fj = ev.eval(here)?;
                let step = release(ev, (before, &*ctrl), event, (mode, &fj), &cur, k, last);
                (fj.f, step)
            }
        };
        let step = match step {
            Ok(s) => s,
            Err(NotDifferentiated(r)) => return said(k, r),
        };
        let f_plus = if last {
            ev.flow(FlowPoint {
                mode: event.mode_after,
                ..FlowPoint::on(after, t, &step.y_plus)
            })?
        } else {
            ctrl.on_event(&Event {
                t,
                kind: event.kind,
                mode_before: mode,
                mode_after: step.mode_after,
                triggered: vec![k],
                impulse: step.impulse.clone(),
                // a touchdown's impact goes into its own mode; a release has no impact
                impulse_mode: if step.impulse.is_empty() {
                    ContactMode::FLIGHT
                } else {
                    step.mode_after
                },
                pseudo_impulse: vec![],
                // the controller's event is the guard's alone: no forces are solved for it
                force: vec![],
                kinetic_before: f64::NAN,
                kinetic_after: f64::NAN,
                q: step.y_plus[..model.nq()].to_vec(),
                qd_after: step.y_plus[model.nq()..].to_vec(),
            });
            ev.flow(FlowPoint {
                ctrl: &*ctrl,
                locked: &before.locked,
                dirs: &before.slide_directions,
                t,
                mode: step.mode_after,
                y: &step.y_plus,
            })?
        };
        let s = match saltation_with_rate(&step.dr, &f_minus, &f_plus, &step.dg, step.dg_dt) {
            Ok(s) => s,
            Err(status) => return said(k, status.reason().unwrap_or_default()),
        };
        if i == 0 {
            let rate = (&step.dg * &f_minus)[0] + step.dg_dt;
            time_row = Some(-&step.dg / rate);
        }
        xi = s * xi;
        mode = step.mode_after;
        cur = step.y_plus;
    }
    let scale = 1.0 + event.qd_after.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mismatch = max_diff(&cur[model.nq()..], &event.qd_after);
    if mode != event.mode_after || mismatch > 1e-9 * scale {
        return Ok(Err(NotDifferentiated(format!(
            "the guards fired one by one in the order {order:?} do not reproduce the event's \
             reset (mode {} against {}, q̇⁺ off by {mismatch:.2e})",
            mode.normal_bits(),
            event.mode_after.normal_bits()
        ))));
    }
    Ok(Ok(OneSidedSaltation {
        order: order.to_vec(),
        saltation: xi,
        time_row: time_row.expect("at least one guard"),
    }))
}

/// Contact `k`'s touchdown alone at `y` in `mode`: `g` its height (5.49), `R` the plastic
/// impact (5.10)/(5.52) into `mode` with `k` added as the event's mode after has it (the
/// last guard: into the event's mode after). An intermediate impact must push at every
/// contact (else that order leads to another mode, which this does not follow).
fn touch(
    ev: &mut Evaluator,
    event: &Event,
    mode: ContactMode,
    y: &[f64],
    k: usize,
    last: bool,
) -> Result<GuardStep, NotDifferentiated> {
    let (model, terrain) = (ev.model, ev.terrain);
    let nq = model.nq();
    let (q, qd) = y.split_at(nq);
    let mut kin = Kinematics::default();
    kin.compute(model, q, qd);
    let geo = contact_geometry(model, &kin, terrain, k);
    let mut dg = RowDVector::zeros(2 * nq);
    dg.columns_mut(0, nq)
        .copy_from(&height_gradient(model, &kin, &geo).transpose());
    let mode_after = if last {
        event.mode_after
    } else {
        let Some(kind) = event.mode_after.kind(k) else {
            return Err(NotDifferentiated(
                "released by the event's impact: its single impact is not followed".into(),
            ));
        };
        mode.with(k, kind)
    };
    let mut data = Data::new(model);
    let ij = plastic_impact_jacobian(model, &mut data, terrain, mode_after, q, qd)
        .map_err(|e| NotDifferentiated(format!("its impact: {e}")))?;
    if !last {
        // (a pushing normal impulse is negative, as a pushing λ_n: crate::guard)
        let tol = 1e-12 * (1.0 + ij.impact.impulse.amax());
        let pulls = mode_after
            .rows()
            .zip(ij.impact.impulse.iter())
            .any(|(r, &p)| r.direction == RowDirection::Normal && p > tol);
        if pulls {
            return Err(NotDifferentiated(
                "its impact alone pulls at a contact: that order leads to another mode".into(),
            ));
        }
    }
    let mut dr = DMatrix::identity(2 * nq, 2 * nq);
    dr.view_mut((nq, 0), (nq, nq)).copy_from(&ij.dqd_plus.dq);
    dr.view_mut((nq, nq), (nq, nq)).copy_from(&ij.dqd_plus.dqd);
    let mut y_plus = y.to_vec();
    y_plus[nq..].copy_from_slice(ij.impact.qd_plus.as_slice());
    Ok(GuardStep {
        dg,
        dg_dt: 0.0,
        dr,
        mode_after,
        y_plus,
        impulse: ij.impact.impulse.iter().copied().collect(),
    })
}

/// Contact `k`'s liftoff alone at `y` in `mode` (flow and `∂λ/∂x` in `fj`): `g = −λ_n`
/// (5.50) with its time dependence through the torques, `R = I` — or, where the event's
/// reset projected the integrator's drift away (at the first guard: the state is still the
/// one before the event), that plastic impact into the mode before ([`drift_reset`]).
fn release(
    ev: &mut Evaluator,
    (before, ctrl): (&Segment, &dyn Controller),
    event: &Event,
    (mode, fj): (ContactMode, &super::evaluator::FlowJacobian),
    y: &[f64],
    k: usize,
    last: bool,
) -> Result<GuardStep, NotDifferentiated> {
    let model = ev.model;
    let nq = model.nq();
    let mut gr = GuardReset {
        dg: RowDVector::zeros(0),
        dg_dt: 0.0,
        dr: DMatrix::identity(2 * nq, 2 * nq),
        dr_p: DMatrix::zeros(2 * nq, 0),
        y_plus: y.to_vec(),
        impact_mode: None,
        dr_mu: Vec::new(),
    };
    if y[nq..] != event.qd_after[..] {
        // the reset projected the integrator's drift away first (in the mode before the
        // event: the first guard's state), as a single liftoff's does
        let at = EventAt::new((model, ev.terrain), before, event, &[], y);
        drift_reset(&at, &mut gr)?;
    }
    let (rt, rn) = rows_of(mode, k);
    let Some(rn) = rn else {
        return Err(NotDifferentiated("not in contact".into()));
    };
    let lift = |dl: &DMatrix<f64>| {
        force_guard_gradient(model, EventKind::Liftoff, k, (rt, rn), &fj.lambda, dl)
            .expect("a liftoff's guard needs only the normal row")
    };
    let dg = lift(&fj.dlambda);
    let dtau_dt =
        torque_time_derivative(ctrl, model.n_joints(), event.t, (&y[..nq], &y[nq..]), mode);
    let dt = &fj.dlambda_dtau * DVector::from_column_slice(dtau_dt.as_slice());
    let dg_dt = lift(&DMatrix::from_column_slice(dt.len(), 1, dt.as_slice()))[0];
    let mode_after = if last {
        event.mode_after
    } else {
        mode.without(k)
    };
    Ok(GuardStep {
        dg,
        dg_dt,
        dr: gr.dr,
        mode_after,
        y_plus: gr.y_plus,
        impulse: vec![],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every order once, the given one first: 1, 2, 6 and 24 of them.
    #[test]
    fn permutations_are_every_order_once() {
        for n in 1..=4usize {
            let items: Vec<usize> = (0..n).map(|i| 3 * i + 1).collect();
            let p = permutations(&items);
            let fact: usize = (1..=n).product();
            assert_eq!(p.len(), fact);
            assert_eq!(p[0], items);
            let mut sorted = p.clone();
            sorted.sort();
            sorted.dedup();
            assert_eq!(sorted.len(), fact);
            assert!(p.iter().all(|o| {
                let mut s = o.clone();
                s.sort();
                s == items
            }));
        }
    }
}
