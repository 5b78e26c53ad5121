//! The two numerical routines the models share: a classical RK4 step of a two-state ODE (the
//! observer's flight model, the tail's joint dynamics) and bisection on a bracket.

/// One classical RK4 step of length `h` of `(ẋ, ẏ) = f(x, y)` from `(x, y)`.
pub fn rk4_step(x: f64, y: f64, h: f64, mut f: impl FnMut(f64, f64) -> (f64, f64)) -> (f64, f64) {
    let (a1, b1) = f(x, y);
    let (a2, b2) = f(x + 0.5 * h * a1, y + 0.5 * h * b1);
    let (a3, b3) = f(x + 0.5 * h * a2, y + 0.5 * h * b2);
    let (a4, b4) = f(x + h * a3, y + h * b3);
    (
        x + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
        y + h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
    )
}

/// Where `below` stops holding in `[lo, hi]` (it holds at `lo`, not at `hi`): the midpoint of
/// the bracket after `halvings` bisection steps.
pub fn bisect(mut below: impl FnMut(f64) -> bool, lo: f64, hi: f64, halvings: usize) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    for _ in 0..halvings {
        let mid = 0.5 * (lo + hi);
        if below(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
