//! Roots of a scalar that a whole run reports, over one input of the run: a secant search
//! that keeps the best run it made (for example, the motor start at which a second leg
//! touches down a given time after the first).

/// The secant search for `d(s) = 0` on runs `run(s) = (result, d(s))`, starting at `start`
/// and then `start − d(start)` (the first step assumes slope 1), at most `runs` runs, ending
/// once `|d| ≤ tol` or the next input leaves `|s| < limit`. A slope below 10⁻⁶ in magnitude
/// (or not finite) takes the unit step `s − d` instead. Returns the result of the run with
/// the smallest `|d|` found (the first run's when it has no `d`, or a later one has none).
pub fn secant_search<R, E>(
    start: f64,
    runs: usize,
    tol: f64,
    limit: f64,
    mut run: impl FnMut(f64) -> Result<(R, Option<f64>), E>,
) -> Result<R, E> {
    let mut s0 = start;
    let (mut r0, d0) = run(s0)?;
    let Some(mut d0) = d0 else {
        return Ok(r0);
    };
    let mut s1 = s0 - d0;
    for _ in 1..runs {
        if d0.abs() <= tol || s1.abs() >= limit {
            break;
        }
        let (r1, d1) = run(s1)?;
        let Some(d1) = d1 else {
            break;
        };
        let better = d1.abs() < d0.abs();
        let slope = (d1 - d0) / (s1 - s0);
        let next = if slope.is_finite() && slope.abs() > 1e-6 {
            s1 - d1 / slope
        } else {
            s1 - d1
        };
        (s0, d0) = (s1, d1);
        if better {
            r0 = r1;
        }
        s1 = next;
    }
    Ok(r0)
}
