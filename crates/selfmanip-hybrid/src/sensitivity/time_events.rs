//! A controller's time events inside a segment ([`crate::Controller::time_events`]): the jump
//! of the flow there and what it does to the parameter columns.
use super::evaluator::{Evaluator, FlowPoint};
use super::tangent::Tangent;
use super::types::{Parameter, SaltationStatus, SensitivityError, TimeEventSensitivity};
use crate::controller::TimeEvent;
use crate::execution::Segment;
use nalgebra::RowDVector;

/// Relative jump `|f⁺ − f⁻| / (1 + |f|)` (max norms) below which a controller's time event is
/// continuous (no contribution to the parameter columns).
pub const TIME_EVENT_TOL: f64 = 1e-12;

/// A controller's time event at `(te.t, y)` inside a segment: the jump `f⁺ − f⁻` of the flow
/// there (`f⁻` evaluated at the previous float, the same state) moves with the instant,
/// `X_p += (f⁻ − f⁺) dt_b/dp` on the parameter columns (the state columns have
/// `dt_b/dx = 0`). The execution's steps land on the instant (a step stop of
/// [`crate::segment`], its stages there at the left limit), and so do the tangent's; a
/// step of a record that straddles one (a controller whose events are not all known at the
/// segment's start) is split there (see [`segment_flow`]).
pub(super) fn time_event(
    ev: &mut Evaluator,
    seg: &Segment,
    tangent: &mut Tangent,
    te: &TimeEvent,
    y: &[f64],
) -> Result<TimeEventSensitivity, SensitivityError> {
    let ctrl = &*seg.controller;
    let fm = ev.flow(FlowPoint::on(seg, te.t.next_down(), y))?;
    let fp = ev.flow(FlowPoint::on(seg, te.t, y))?;
    let jump = (&fp - &fm).amax();
    let scale = 1.0 + fm.amax().max(fp.amax());
    let out = TimeEventSensitivity {
        t: te.t,
        jump,
        status: SaltationStatus::Defined,
    };
    if jump <= TIME_EVENT_TOL * scale {
        return Ok(out);
    }
    if let Tangent::Columns { x, params, .. } = tangent {
        let nd = x.ncols() - params.len();
        let mut ci = 0;
        for (k, p) in params.iter().enumerate() {
            if let Parameter::Controller(_) = p {
                let d = te.dt_dp[ci];
                ci += 1;
                if d != 0.0 {
                    let mut col = x.column_mut(nd + k);
                    col.axpy(d, &(&fm - &fp), 1.0);
                }
            }
        }
        if ev.memory_mode {
            // an instant that moves with a remembered event: `X += (f⁻ − f⁺) dt_b/dm_k Dm_k`
            for me in ctrl.memory_time_events().iter().filter(|e| e.t == te.t) {
                let Some(d) = ev.memory.get(me.event) else {
                    return Err(SensitivityError::EventMemoryWithoutPartials {
                        t: te.t,
                        reason: format!("event {} is not one the run recorded", me.event),
                    });
                };
                let row = RowDVector::from_row_slice(&me.dt_dm) * d;
                *x += (&fm - &fp) * row;
            }
        }
    }
    Ok(out)
}
