//! Stage `locate`: regula falsi and bisection against closed-form roots.
use selfmanip_hybrid::bracketing::{bisect_first, locate_crossing};

/// A ball dropped from `h0` is at height `h0 − g t²/2`: the Illinois bracket closes on
/// `sqrt(2 h0 / g)` to the tolerance, in far fewer evaluations than bisection's
/// `log2(1 / tol) ≈ 33`.
#[test]
fn regula_falsi_brackets_the_bouncing_balls_touchdown() {
    let (h0, g, tol) = (1.3_f64, 9.81, 1e-10);
    let root = (2.0 * h0 / g).sqrt();
    let mut evals = 0;
    let mut height = |t: f64| -> Result<f64, ()> {
        evals += 1;
        Ok(h0 - 0.5 * g * t * t)
    };
    let (lo, hi) = locate_crossing(&mut height, (0.0, h0), (1.0, h0 - 0.5 * g), tol).unwrap();
    assert!(hi - lo <= tol);
    assert!(lo < root && root <= hi, "[{lo}, {hi}] misses {root}");
    assert!(evals <= 12, "{evals} evaluations");
}

/// A guard that jumps (no secant can converge on it) is still bracketed: after the secant
/// trials the search bisects, which always terminates.
#[test]
fn regula_falsi_falls_back_to_bisection_on_a_step() {
    let step_at = 0.7123;
    let mut f = |t: f64| -> Result<f64, ()> { Ok(if t < step_at { 1.0 } else { -1.0 }) };
    let (lo, hi) = locate_crossing(&mut f, (0.0, 1.0), (1.0, -1.0), 1e-12).unwrap();
    assert!(hi - lo <= 1e-12 && lo < step_at && step_at <= hi);
}

/// Errors of the guard's evaluation stop the search and come back to the caller.
#[test]
fn regula_falsi_passes_guard_errors_on() {
    let mut f = |t: f64| -> Result<f64, &'static str> {
        if t > 0.0 && t < 1.0 {
            Err("singular")
        } else {
            Ok(1.0 - 2.0 * t)
        }
    };
    assert_eq!(
        locate_crossing(&mut f, (0.0, 1.0), (1.0, -1.0), 1e-9),
        Err("singular")
    );
}

/// Bisection brackets the first instant a predicate holds.
#[test]
fn bisection_brackets_the_first_instant_a_predicate_holds() {
    let edge = 0.123456789;
    let (on, off) = bisect_first(&mut |t| t >= edge, (0.0, 1.0), 1e-10);
    assert!(off - on <= 1e-10 && on < edge && edge <= off);
}
