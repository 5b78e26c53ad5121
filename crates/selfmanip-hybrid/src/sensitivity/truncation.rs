//! A Zeno truncation's derivative ([`crate::zeno::truncate`]): the truncation is taken at
//! once after the event that filled the window or repeated the chatter (a re-touch, mostly),
//! at its instant and with no flow between them, and its dwell ends `dwell_s` later.
//!
//! **The truncation** is the touchdown saltation of thesis section 5.1 with another reset:
//! the instant is the event's own (its guard `g`, e.g. the re-touching contact's gap), and
//! the reset is the event's `R₁` followed by the plastic impact (5.52) into the held mode,
//! `R = R₂ ∘ R₁`, `D_xR = D_xR₂ D_xR₁`, `D_pR = D_xR₂ D_pR₁ + D_pR₂`; `f⁺` is the held
//! mode's flow. The mode between them lasts no time, so its flow drops out: the pair is
//! one event `Ξ = D_xR + (f⁺ − D_xR f⁻) D_xg / (D_xg f⁻)`. The controller is told of both;
//! each remembered state moves as `Dx_i⁺ = D_xR_i (X⁻ + f⁻ Dt) + D_pR_i` with `R_i` the
//! resets up to it (`R₁`, then `R`).
//!
//! **The dwell's end** is a time event that moves with the truncation's time,
//! `dt_end/dx = dt_trunc/dx`, where the hold lets go into the mode force complementarity
//! gives (no velocity jump): `X⁺ = X⁻ + (f⁻ − f⁺) Dt_trunc`, the guard-time saltation of a
//! mode switch with the identity reset; its event, when the complementarity changed the
//! mode, is remembered as `(Dt_trunc, X⁻ + f⁻ Dt_trunc)`.
use super::evaluator::{Evaluator, FlowPoint};
use super::force_events::DRIFT_JUMP_TOL;
use super::reset_jacobian::{GuardReset, KindOutcome, NotDifferentiated};
use super::types::{EventSensitivity, SaltationStatus};
use crate::event::{max_diff, Event};
use crate::execution::Execution;
use nalgebra::{DMatrix, DVector, RowDVector};
use selfmanip_core::tangent::{
    plastic_impact_body_derivatives, plastic_impact_jacobian, BodyParameter,
};
use selfmanip_core::{Data, Model, Terrain};

/// The reset of the event before a truncation, kept for the controller's memory of it when
/// the pair is differentiated as one: `D_xR₁` and `D_pR₁`.
pub(super) struct FirstReset {
    pub(super) dr: DMatrix<f64>,
    pub(super) dr_p: DMatrix<f64>,
}

/// Composes `gr` (the reset `R₁` of the event before the truncation `trunc`, at the state
/// `y` before it) with the truncation's plastic impact into its held mode, at the state
/// `R₁` left (module docs); returns `R₁`'s Jacobians. Not differentiated when that impact
/// does not reproduce the recorded `q̇⁺` or the event moved the configuration.
pub(super) fn compose(
    (model, terrain): (&Model, &dyn Terrain),
    gr: &mut GuardReset,
    trunc: &Event,
    body: &[BodyParameter],
) -> Result<FirstReset, NotDifferentiated> {
    let nq = model.nq();
    let (q, qd1) = gr.y_plus.split_at(nq);
    if q != trunc.q.as_slice() {
        return Err(NotDifferentiated(
            "a Zeno truncation at another configuration than the event before it".into(),
        ));
    }
    let mut data = Data::new(model);
    let ij = plastic_impact_jacobian(model, &mut data, terrain, trunc.mode_after, q, qd1).map_err(
        |e| NotDifferentiated(format!("a Zeno truncation's impact has no Jacobian: {e}")),
    )?;
    let scale = 1.0 + trunc.qd_after.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mismatch = max_diff(ij.impact.qd_plus.as_slice(), &trunc.qd_after);
    if mismatch > 1e-9 * scale {
        return Err(NotDifferentiated(format!(
            "a Zeno truncation's q̇⁺ is not the plastic impact into its held mode \
             ({mismatch:.2e})"
        )));
    }
    let dp2 = plastic_impact_body_derivatives(model, &mut data, &ij.impact, qd1, body);
    // D_xR₂ = [[I, 0], [∂q̇⁺/∂q, ∂q̇⁺/∂q̇⁻]] and D_pR₂ = [0; ∂q̇⁺/∂p]
    let mut dr2 = DMatrix::identity(2 * nq, 2 * nq);
    dr2.view_mut((nq, 0), (nq, nq)).copy_from(&ij.dqd_plus.dq);
    dr2.view_mut((nq, nq), (nq, nq)).copy_from(&ij.dqd_plus.dqd);
    let first = FirstReset {
        dr: gr.dr.clone(),
        dr_p: gr.dr_p.clone(),
    };
    gr.dr = &dr2 * &first.dr;
    gr.dr_p = &dr2 * &first.dr_p;
    let mut rows = gr.dr_p.view_mut((nq, 0), (nq, dp2.ncols()));
    rows += &dp2;
    for (_, d) in &mut gr.dr_mu {
        *d = &dr2 * &*d;
    }
    gr.y_plus[nq..].copy_from_slice(ij.impact.qd_plus.as_slice());
    Ok(first)
}

/// The flows `(f⁻, f⁺)` either side of the dwell's end that ended segment `si` of `exec`
/// (a time event: [`Execution::dwell_ends`]), the hold let go into the mode of the next
/// segment; not differentiated when there is no next segment or the velocity jumped there
/// by more than the drift ([`DRIFT_JUMP_TOL`]).
pub(super) fn dwell_end_flows(
    ev: &mut Evaluator,
    exec: &Execution,
    si: usize,
) -> KindOutcome<(DVector<f64>, DVector<f64>)> {
    let seg = &exec.segments[si];
    let Some(next) = exec.segments.get(si + 1) else {
        return Ok(Err(NotDifferentiated(
            "no flow after a Zeno truncation's dwell".into(),
        )));
    };
    let mut y = vec![0.0; seg.y0.len()];
    seg.eval(seg.t1, &mut y);
    let jump = max_diff(&y, &next.y0);
    if jump > DRIFT_JUMP_TOL {
        return Ok(Err(NotDifferentiated(format!(
            "the state jumped by {jump:.2e} at a Zeno truncation's dwell end"
        ))));
    }
    let fm = ev.flow(FlowPoint::on(seg, seg.t1, &y))?;
    let fp = ev.flow(FlowPoint::on(next, seg.t1, &next.y0))?;
    Ok(Ok((fm, fp)))
}

/// The dwell's end that ended segment `si` (its event, if the complementarity changed the
/// mode there) across the columns `x`, with `time` the truncation's time row: the event
/// remembered as `(Dt, X⁻ + f⁻ Dt)` when the controllers remember events, then
/// `X⁺ = X⁻ + (f⁻ − f⁺) Dt` (module docs).
pub(super) fn dwell_end(
    ev: &mut Evaluator,
    exec: &Execution,
    si: usize,
    (event, time): (Option<&Event>, Option<&RowDVector<f64>>),
    x: &mut DMatrix<f64>,
) -> KindOutcome<()> {
    let Some(time) = time else {
        return Ok(Err(NotDifferentiated(
            "the end of a dwell whose truncation was not differentiated".into(),
        )));
    };
    let (fm, fp) = match dwell_end_flows(ev, exec, si)? {
        Ok(f) => f,
        Err(e) => return Ok(Err(e)),
    };
    if ev.memory_mode && event.is_some() {
        let n2 = x.nrows();
        let mut d = DMatrix::zeros(1 + n2, x.ncols());
        d.row_mut(0).copy_from(time);
        let moved = &*x + &fm * time;
        d.rows_mut(1, n2).copy_from(&moved);
        ev.memory.push(d);
    }
    *x += (&fm - &fp) * time;
    Ok(Ok(()))
}

/// The entry of a truncation differentiated with the event before it (its saltation the
/// pair's, carried by that event): the identity, of state dimension `n2`.
pub(super) fn truncation_defined(z: &Event, n2: usize) -> EventSensitivity {
    EventSensitivity {
        t: z.t,
        kind: z.kind,
        status: SaltationStatus::Defined,
        saltation: Some(DMatrix::identity(n2, n2)),
        guard_gradient: None,
        time_gradient: None,
        impact_mode: Some(z.mode_after),
        one_sided: Vec::new(),
    }
}

/// The entry of an event not differentiated for `reason`.
pub(super) fn not_differentiated(e: &Event, reason: String) -> EventSensitivity {
    EventSensitivity {
        t: e.t,
        kind: e.kind,
        status: SaltationStatus::Unsupported { reason },
        saltation: None,
        guard_gradient: None,
        time_gradient: None,
        impact_mode: None,
        one_sided: Vec::new(),
    }
}

/// Why `es` is not differentiated, for the truncation that followed it.
pub(super) fn reason_after(es: &EventSensitivity) -> String {
    format!(
        "a Zeno truncation after an event not differentiated ({:?})",
        es.status
    )
}
