//! The saltation of each event of an execution: the guard's gradient and the reset's
//! Jacobian by its kind — touchdown ([`super::touchdown`]), liftoff and slip
//! ([`super::force_events`]), stick, apex — the flows before and after it, and what the
//! parameter columns need of it ([`EventParts`]).
use super::evaluator::{Evaluator, FlowJacobian, FlowPoint};
use super::force_events::{drift_reset, force_guard};
use super::reset_jacobian::{EventAt, GuardReset, KindOutcome, NotDifferentiated};
use super::saltation::saltation_with_rate;
use super::simultaneous::{guards_at_once, one_sided_saltations, orders_agree};
use super::touchdown::{jam, touchdown};
use super::truncation::{compose, FirstReset};
use super::types::{EventSensitivity, SaltationStatus, SensitivityError};
use crate::event::{Event, EventKind};
use crate::execution::{Execution, Segment};
use nalgebra::{DMatrix, DVector, RowDVector};
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::tangent::{sliding_velocity_gradient, BodyParameter};

/// What the parameter columns need of an event whose saltation is defined.
pub(super) struct EventParts {
    pub(super) f_minus: DVector<f64>,
    pub(super) f_plus: DVector<f64>,
    /// `D_xR` and `D_pR` (body parameters' columns) of the reset.
    pub(super) dr: DMatrix<f64>,
    pub(super) dr_p: DMatrix<f64>,
    /// `∂R/∂μ` of static friction coefficients (a Coulomb impact's, [`GuardReset::dr_mu`]).
    pub(super) dr_mu: Vec<(usize, DVector<f64>)>,
    /// `D_xg f⁻`.
    pub(super) den: f64,
    pub(super) y_minus: Vec<f64>,
    /// The reset of the event alone where a Zeno truncation followed it at once (the two
    /// differentiated as one, [`super::truncation`]): its memory's derivative needs it.
    pub(super) first: Option<FirstReset>,
}

/// [`event_sensitivity`] of the event that ended segment `si` (with the Zeno truncation
/// `trunc` taken at once after it, if any: one event, [`super::truncation`]), flagged
/// simultaneous (without parts) when a neighbouring mode lasted zero time.
pub(super) fn segment_event(
    ev: &mut Evaluator,
    exec: &Execution,
    si: usize,
    (event, trunc): (&Event, Option<&Event>),
    body: &[BodyParameter],
) -> Result<(EventSensitivity, Option<EventParts>), SensitivityError> {
    // a jam hold (crate::jam_hold) is entered by force and ended by its own guard, neither
    // differentiated: the events from its entry on are refused by name
    let hold = exec
        .events
        .iter()
        .take_while(|e| e.t <= event.t)
        .find_map(|e| crate::jam_hold::entered(ev.model, e));
    if let Some(k) = hold {
        let reason = format!(
            "after a jam hold of contact {k} (a massless shin held sticking by consistency): \
             its entry and its end are not differentiated"
        );
        return Ok((unsupported(event, reason), None));
    }
    let seg = &exec.segments[si];
    let after = exec.segments.get(si + 1);
    let zero_time = seg.t1 == seg.t0 || after.is_some_and(|a| a.t1 == a.t0);
    // a damped slide (selfmanip_core::damped_slide) before or after the event: the
    // derivatives of its flow and of its resets are not formed
    let damped = crate::damped_slide::damped_contacts(ev.model);
    let slides = |m| crate::damped_slide::sliding_damped(damped, m);
    let held = trunc.map_or(0, |z| slides(z.mode_after));
    if damped != 0 && (slides(event.mode_before) | slides(event.mode_after) | held) != 0 {
        let reason = "a massless chain's damped slide before or after it: not differentiated";
        return Ok((unsupported(event, reason), None));
    }
    let (mut es, parts) = event_sensitivity(ev, (seg, after), (event, trunc), body)?;
    // an event at a time event of the controller that ran up to it was fired by the flow's
    // jump there (a torque switched on pushes a force to its cone at once), not by a
    // crossing: its instant follows the time event's, which the state event's
    // `−D_xg X / D_xg f⁻` does not give (the controller after it may start motions at the
    // event itself: those follow the event, they do not fire it)
    let at_time_event = seg
        .controller
        .time_events(&[])
        .iter()
        .any(|te| (te.t - event.t).abs() <= 1e-12 * (1.0 + event.t.abs()));
    if es.status == SaltationStatus::Defined && event.kind != EventKind::Apex && at_time_event {
        return Ok((
            unsupported(
                event,
                "fired at a controller's time event (the flow's jump there), not by a \
                 crossing: not differentiated",
            ),
            None,
        ));
    }
    if zero_time && es.status == SaltationStatus::Defined {
        es.status = SaltationStatus::Simultaneous;
        es.saltation = None;
        return Ok((es, None));
    }
    Ok((es, parts))
}

fn unsupported(event: &Event, reason: impl Into<String>) -> EventSensitivity {
    EventSensitivity {
        t: event.t,
        kind: event.kind,
        status: SaltationStatus::Unsupported {
            reason: reason.into(),
        },
        saltation: None,
        guard_gradient: None,
        time_gradient: None,
        impact_mode: None,
        one_sided: Vec::new(),
    }
}

/// An event at which several guards fired at once, with a flow after it: its derivative for
/// each order of the guards ([`super::simultaneous`]); `Defined` with their common matrix
/// when the orders agree, else [`SaltationStatus::OneSided`] naming the guards.
fn simultaneous_event(
    ev: &mut Evaluator,
    (before, after): (&Segment, &Segment),
    (event, guards): (&Event, &[usize]),
    y: &[f64],
) -> Result<EventSensitivity, SensitivityError> {
    let pieces = match one_sided_saltations(ev, (before, after), event, guards, y)? {
        Ok(p) => p,
        Err(NotDifferentiated(reason)) => {
            return Ok(unsupported(
                event,
                format!(
                    "the guards of contacts {guards:?} fired at once; their orders are not \
                     formed: {reason}"
                ),
            ))
        }
    };
    let mut es = unsupported(event, "");
    if orders_agree(&pieces) {
        es.status = SaltationStatus::Defined;
        es.saltation = Some(pieces[0].saltation.clone());
    } else {
        es.status = SaltationStatus::OneSided {
            guards: guards.to_vec(),
        };
    }
    es.impact_mode = (event.kind == EventKind::Touchdown).then_some(event.mode_after);
    es.one_sided = pieces;
    Ok(es)
}

/// The saltation matrix of `event`, which ended `before` (and started `after`, if any; with
/// the Zeno truncation `trunc` taken at once after it, the pair's).
fn event_sensitivity(
    ev: &mut Evaluator,
    (before, after): (&Segment, Option<&Segment>),
    (event, trunc): (&Event, Option<&Event>),
    body: &[BodyParameter],
) -> Result<(EventSensitivity, Option<EventParts>), SensitivityError> {
    let (model, terrain) = (ev.model, ev.terrain);
    let n2 = 2 * model.nq();
    let t = event.t;
    let mut y = vec![0.0; n2];
    before.eval(t, &mut y);
    let guards = guards_at_once(ev, before, event, &y)?;
    let single = guards.len() <= 1;
    if let (false, Some(_)) = (single, trunc) {
        let reason = format!(
            "a Zeno truncation after the guards of contacts {guards:?} fired at once: not \
             differentiated"
        );
        return Ok((unsupported(event, reason), None));
    }
    if let (false, Some(a)) = (single, after) {
        return Ok((
            simultaneous_event(ev, (before, a), (event, &guards), &y)?,
            None,
        ));
    }
    let fm = ev.eval(FlowPoint::on(before, t, &y))?;
    let mut simultaneous = !single;
    let at = EventAt::new((model, terrain), before, event, body, &y);
    let mut gr = match guard_and_reset(&at, &fm)? {
        Ok(gr) => gr,
        Err(NotDifferentiated(reason)) => return Ok((unsupported(event, reason), None)),
    };
    let first = match trunc.map(|z| compose((model, terrain), &mut gr, z, body)) {
        Some(Err(NotDifferentiated(reason))) => return Ok((unsupported(event, reason), None)),
        Some(Ok(r)) => Some(r),
        None => None,
    };
    let mode_after = trunc.map_or(event.mode_after, |z| z.mode_after);
    if event.kind == EventKind::Touchdown && event.triggered.is_empty() {
        simultaneous = true;
    }
    let GuardReset {
        dg,
        dg_dt,
        dr,
        dr_p,
        y_plus,
        impact_mode,
        dr_mu,
    } = gr;
    let mut es = EventSensitivity {
        t,
        kind: event.kind,
        status: SaltationStatus::Defined,
        saltation: None,
        guard_gradient: Some(dg.clone()),
        time_gradient: None,
        impact_mode,
        one_sided: Vec::new(),
    };
    if let Err(status) = saltation_with_rate(&dr, &fm.f, &fm.f, &dg, dg_dt) {
        es.status = status;
        return Ok((es, None));
    }
    if simultaneous {
        es.status = SaltationStatus::Simultaneous;
        return Ok((es, None));
    }
    let f_plus = match (event.kind, after) {
        // the terminal apex: the end state is the state at the apex, whose time moves
        (EventKind::Apex, None) => DVector::zeros(n2),
        // an apex passed on the way is no reset (the controller is not told of it): the flow
        // after it is the next segment's, and the saltation the identity up to round-off
        (_, Some(a)) => ev.flow(FlowPoint {
            mode: mode_after,
            ..FlowPoint::on(a, t, &y_plus)
        })?,
        (_, None) => {
            // the run ended at this event (its event budget): no flow after it to salt with
            es.status = SaltationStatus::Unsupported {
                reason: "no flow after the run's last event".into(),
            };
            return Ok((es, None));
        }
    };
    let parts = match saltation_with_rate(&dr, &fm.f, &f_plus, &dg, dg_dt) {
        Ok(x) => {
            es.saltation = Some(x);
            Some(EventParts {
                den: (&dg * &fm.f)[0] + dg_dt,
                f_minus: fm.f,
                f_plus,
                dr,
                dr_p,
                dr_mu,
                y_minus: y,
                first,
            })
        }
        Err(status) => {
            es.status = status;
            None
        }
    };
    Ok((es, parts))
}

/// The guard's gradient and the reset's Jacobians of the event at `at`, by its kind, with the
/// flow `fm` before it.
fn guard_and_reset(at: &EventAt, fm: &FlowJacobian) -> KindOutcome<GuardReset> {
    let (model, event) = (at.model, at.event);
    let nq = model.nq();
    let n2 = 2 * nq;
    let mut gr = GuardReset {
        dg: RowDVector::zeros(0),
        dg_dt: 0.0,
        dr: DMatrix::identity(n2, n2),
        dr_p: DMatrix::zeros(n2, at.body.len()),
        y_plus: at.y.to_vec(),
        impact_mode: None,
        dr_mu: Vec::new(),
    };
    let dg = match event.kind {
        EventKind::Touchdown => touchdown(at, &mut gr),
        EventKind::Liftoff | EventKind::Slip => force_guard(at, fm, &mut gr.dg_dt),
        EventKind::Stick => {
            let k = event.triggered[0];
            let geo = contact_geometry(model, &at.kin, at.terrain, k);
            let (dq, dqd) = sliding_velocity_gradient(model, &at.kin, &geo, k, at.qd_minus())?;
            let mut dg = RowDVector::zeros(n2);
            dg.columns_mut(0, nq).copy_from(&dq.transpose());
            dg.columns_mut(nq, nq).copy_from(&dqd.transpose());
            Ok(dg)
        }
        EventKind::Apex => {
            let mut dg = RowDVector::zeros(n2);
            dg[nq + model.ix_z()] = -1.0;
            Ok(dg)
        }
        EventKind::Jam => jam(at, &mut gr),
        EventKind::ZenoTruncation => Err(NotDifferentiated(
            "Zeno truncations are not differentiated".into(),
        )),
        EventKind::Fold | EventKind::FoldPassed => Err(NotDifferentiated(
            "fold events are not differentiated yet".into(),
        )),
    };
    let dg = match dg {
        Ok(dg) => dg,
        Err(e) => return Ok(Err(e)),
    };
    if !matches!(event.kind, EventKind::Touchdown | EventKind::Jam) {
        if let Err(e) = drift_reset(at, &mut gr) {
            return Ok(Err(e));
        }
    }
    gr.dg = dg;
    Ok(Ok(gr))
}
