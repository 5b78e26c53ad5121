//! The tangent over one segment on its own steps: each step split at the controller's time
//! events, at rolling/point switches (with their saltations) and at kinks of the controller's
//! law.
use super::evaluator::{controller_names, Evaluator};
use super::tangent::Tangent;
use super::time_events::time_event;
use super::touch_switch::touch_switch;
use super::types::{SensitivityError, TimeEventSensitivity, TouchSwitch};
use crate::controller::TimeEvent;
use crate::execution::Segment;

/// The tangent of one segment on its own steps (see the module docs), with the saltation of
/// every rolling/point switch inside it (appended to `switches`) and, for columns with
/// parameters, the controller's time events inside it (appended to `time_events`).
pub(super) fn segment_flow(
    ev: &mut Evaluator,
    seg: &Segment,
    tangent: &mut Tangent,
    switches: &mut Vec<TouchSwitch>,
    time_events: &mut Vec<TimeEventSensitivity>,
) -> Result<(), SensitivityError> {
    if seg.dense.has_implicit_steps() {
        return Err(SensitivityError::ImplicitSteps { t: seg.t0 });
    }
    let n2 = seg.y0.len();
    let (mut ya, mut yb, mut ym) = (vec![0.0; n2], vec![0.0; n2], vec![0.0; n2]);
    let mut pending: Vec<TimeEvent> = match tangent {
        Tangent::Columns { params, .. } if !params.is_empty() || ev.memory_mode => {
            let names = controller_names(params);
            let mut v = seg.controller.time_events(&names);
            v.retain(|e| e.t >= seg.t0 && e.t < seg.t1);
            v.sort_by(|a, b| a.t.total_cmp(&b.t));
            v
        }
        _ => Vec::new(),
    };
    // stages after the last time event passed take the right-hand limit there
    let mut t_floor = f64::NEG_INFINITY;
    let (mut start_touches, mut end_touches, mut mid_touches) =
        (Vec::new(), Vec::new(), Vec::new());
    for step in seg.dense.steps() {
        if step.t0 >= seg.t1 {
            break;
        }
        let step_end = step.t1().min(seg.t1);
        // the step is split at the controller's time events inside it: `∂f/∂p` (and `f`,
        // where the flow jumps) changes there, so the tangent is integrated up to the instant
        // from the dense output's state, jumps there, and goes on
        let mut ta = step.t0;
        loop {
            while let Some(te) = pending.first().filter(|e| e.t <= ta).cloned() {
                pending.remove(0);
                t_floor = te.t.next_up();
                step.eval(ta, &mut ym);
                time_events.push(time_event(ev, seg, tangent, &te, &ym)?);
            }
            let t_end = pending.first().map_or(step_end, |e| e.t.min(step_end));
            // stages at the next time event take the flow's left limit
            let t_cap = pending.first().map_or(f64::INFINITY, |e| e.t.next_down());
            step.eval(ta, &mut ya);
            step.eval(t_end, &mut yb);
            ev.touches_into(seg.mode, &yb, &mut end_touches);
            // the controller's smooth piece, at the times its stages take
            let piece = move |t: f64, y: &[f64]| {
                let t = t.max(t_floor).min(t_cap);
                let (q, qd) = y.split_at(n2 / 2);
                seg.controller.partials_piece(t, q, qd, seg.mode)
            };
            let end_piece = piece(t_end, &yb);
            let record = |t: f64, y: &mut [f64]| step.eval(t, y);
            // whether the last sub-step ended at a kink (the next one starts there)
            let mut at_kink = false;
            loop {
                ev.touches_into(seg.mode, &ya, &mut start_touches);
                let start_piece = piece(ta, &ya);
                if start_touches == end_touches && start_piece == end_piece {
                    let hold =
                        at_kink.then_some((start_piece, &record as &dyn Fn(f64, &mut [f64])));
                    tangent.step(ev, seg, (ta, t_end - ta, t_floor, t_cap), &ya, hold)?;
                    break;
                }
                // the first change of touch kinds or of the controller's piece after ta,
                // bracketed to a few ulps
                let (mut lo, mut hi) = (ta, t_end);
                loop {
                    let mid = 0.5 * (lo + hi);
                    if mid <= lo || mid >= hi {
                        break;
                    }
                    step.eval(mid, &mut ym);
                    ev.touches_into(seg.mode, &ym, &mut mid_touches);
                    if mid_touches == start_touches && piece(mid, &ym) == start_piece {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let hold = (start_piece, &record as &dyn Fn(f64, &mut [f64]));
                tangent.step(ev, seg, (ta, lo - ta, t_floor, t_cap), &ya, Some(hold))?;
                step.eval(lo, &mut ym);
                step.eval(hi, &mut ya);
                at_kink = true;
                ev.touches_into(seg.mode, &ya, &mut mid_touches);
                if mid_touches != start_touches {
                    let sw = touch_switch(ev, seg, (lo, &ym), (hi, &ya), &start_touches)?;
                    if let Some(x) = &sw.saltation {
                        tangent.salt(x);
                    }
                    switches.push(sw);
                }
                // a kink of the controller's law alone (its outputs continuous, their
                // partials not): the tangent goes on from it, each side on its own steps
                ta = hi;
            }
            if t_end >= step_end {
                break;
            }
            ta = t_end;
        }
    }
    Ok(())
}
