//! Plain bisection, the tests' own route to a crossing time (shared by the hybrid engine's and
//! the simulator's tests; no engine code: the engine's locator is what they check).

/// The bracket `(lo, hi)` of a sign change of `g`, positive at `lo` and not at `hi`, halved
/// until it is at most `tol` wide, or 200 times (`tol = 0`: to the resolution of a double).
pub fn bisect(mut lo: f64, mut hi: f64, tol: f64, mut g: impl FnMut(f64) -> f64) -> (f64, f64) {
    for _ in 0..200 {
        if hi - lo <= tol {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if g(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo, hi)
}
