//! Event location on an accepted step's dense output, to the event tolerance `event_tol_s`:
//! the earliest of several guards' crossings ([`first_event`]), each bracketed by Illinois
//! regula falsi ([`crate::bracketing::locate_crossing`]).
use crate::bracketing::locate_crossing;
use crate::flow::Flow;
use crate::guard::{Guard, GuardSet};
use crate::integrate::DenseStep;
use selfmanip_core::{ContactMode, CoreError};

/// The first event of the step `dense`, in which `guards` found crossings by the sample at
/// `hi`: each crossing located on the dense output, the earliest kept; returns its time (the
/// non-positive end of its bracket), the state there in `y`, and every guard that has fired
/// by then.
pub fn first_event(
    guards: &GuardSet,
    flow: &mut Flow,
    mode: ContactMode,
    (dense, hi): (&DenseStep, f64),
    y: &mut [f64],
    tol: f64,
) -> Result<(f64, Vec<Guard>), CoreError> {
    let mut first: Option<(f64, usize)> = None;
    for c in guards.crossings() {
        if first.is_some_and(|(t_first, _)| c.lo >= t_first) {
            continue; // crosses after the earliest one found so far
        }
        let st = guards.states[c.guard];
        let mut value = |tt: f64| -> Result<f64, CoreError> {
            dense.eval(tt, y);
            Ok(st.direction.orient(st.guard.value(flow, tt, mode, y)?) + c.shift)
        };
        let (_, at) = locate_crossing(&mut value, (c.lo, c.f_lo), (hi, c.f_hi), tol)?;
        if first.is_none_or(|(t_first, _)| at < t_first) {
            first = Some((at, c.guard));
        }
    }
    let (t, gi) = first.expect("a crossing guard");
    dense.eval(t, y);
    Ok((t, guards.fired_with(gi, flow, t, mode, y)?))
}
