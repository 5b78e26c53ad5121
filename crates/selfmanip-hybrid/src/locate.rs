//! Event location on an accepted step's dense output, to the event tolerance `event_tol_s`:
//! the crossing of a guard by Illinois regula falsi ([`locate_crossing`]), the earliest of
//! several crossings ([`first_event`]), and the instant a predicate of the state first holds
//! by bisection ([`bisect_first`], for a contact leaving its terrain feature, whose test is
//! not a smooth function).
use crate::flow::Flow;
use crate::guard::{Guard, GuardSet};
use crate::integrate::DenseStep;
use selfmanip_core::{ContactMode, CoreError};

/// The bracket `[lo, hi]`, at most `tol` wide, of the first crossing of `f` from positive (at
/// `lo`) to non-positive (at `hi`), by Illinois regula falsi: superlinear on smooth guards (a
/// handful of evaluations where bisection needs ~30). Every trial stays `tol/2` inside the
/// bracket, so once the estimate has converged the next trial lands on its other side and
/// the bracket closes; after `SECANT_TRIALS` trials it bisects, which always terminates —
/// also for a tolerance below the resolution of time near `t` (e.g. `1e-308`): the search
/// stops when the bracket's ends are adjacent floating-point numbers.
///
/// The secant trial through the bracket's ends is
/// $$ t = t_{lo} + (t_{hi} - t_{lo}) \frac{f_{lo}}{f_{lo} - f_{hi}}, $$
/// and an end kept twice in a row has its value halved (Illinois; Dowell & Jarratt 1971).
pub fn locate_crossing<E>(
    f: &mut dyn FnMut(f64) -> Result<f64, E>,
    (mut lo, mut f_lo): (f64, f64),
    (mut hi, mut f_hi): (f64, f64),
    tol: f64,
) -> Result<(f64, f64), E> {
    const SECANT_TRIALS: usize = 16;
    // which end the last trial moved (Illinois: an end kept twice has its value halved)
    let mut last_side = 0i8;
    let mut trials = 0;
    while hi - lo > tol && !adjacent(lo, hi) {
        trials += 1;
        let secant = lo + (hi - lo) * f_lo / (f_lo - f_hi);
        let trial = if trials <= SECANT_TRIALS && secant.is_finite() {
            secant.clamp(lo + 0.5 * tol, hi - 0.5 * tol)
        } else {
            0.5 * (lo + hi)
        };
        // (the clamp leaves a bracket narrower than `tol` at its middle, strictly inside)
        let trial = if trial > lo && trial < hi {
            trial
        } else {
            lo + 0.5 * (hi - lo)
        };
        let v = f(trial)?;
        if v > 0.0 {
            (lo, f_lo) = (trial, v);
            if last_side == 1 {
                f_hi *= 0.5;
            }
            last_side = 1;
        } else {
            (hi, f_hi) = (trial, v);
            if last_side == -1 {
                f_lo *= 0.5;
            }
            last_side = -1;
        }
    }
    Ok((lo, hi))
}

/// Whether `b` is the next floating-point number after `a` (or not after it): a bracket that
/// cannot be split any more.
fn adjacent(a: f64, b: f64) -> bool {
    let mid = a + 0.5 * (b - a);
    mid <= a || mid >= b
}

/// The bracket `[on, off]`, at most `tol` wide, of the first instant in `[lo, hi]` at which
/// `holds` becomes true, by bisection; `holds(hi)` must be true and `holds(lo)` false.
pub fn bisect_first(
    holds: &mut dyn FnMut(f64) -> bool,
    (mut on, mut off): (f64, f64),
    tol: f64,
) -> (f64, f64) {
    while off - on > tol && !adjacent(on, off) {
        let mid = 0.5 * (on + off);
        if holds(mid) {
            off = mid;
        } else {
            on = mid;
        }
    }
    (on, off)
}

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
