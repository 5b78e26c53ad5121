//! Brackets of a scalar function's root on an interval of time, to a tolerance: the crossing
//! of a guard by Illinois regula falsi ([`locate_crossing`]), and the instant a predicate of
//! the state first holds by bisection ([`bisect_first`], for a contact leaving its terrain
//! feature, whose test is not a smooth function). Event location ([`crate::locate`]) and the
//! fold's torque-free speed ([`crate::fold`]) use them.

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
