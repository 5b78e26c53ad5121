//! Maximisation of a scalar function that is not convex: golden section on a bracket, a grid
//! followed by golden section, and a pattern search in the plane.

/// Golden-section maximisation of a unimodal `f` on `[a, b]`.
pub fn golden_max(mut a: f64, mut b: f64, tol: f64, f: &mut dyn FnMut(f64) -> f64) -> (f64, f64) {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    while (b - a).abs() > tol {
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    let x = 0.5 * (a + b);
    (x, f(x))
}

/// Grid then golden section: the maximiser of `f` over `[a, b]`.
pub fn grid_golden_max(a: f64, b: f64, n: usize, f: &mut dyn FnMut(f64) -> f64) -> (f64, f64) {
    let n = n.max(3);
    let h = (b - a) / (n - 1) as f64;
    let (mut bi, mut bv) = (0, f64::MIN);
    for i in 0..n {
        let v = f(a + h * i as f64);
        if v > bv {
            bv = v;
            bi = i;
        }
    }
    let lo = a + h * (bi.saturating_sub(1)) as f64;
    let hi = (a + h * (bi + 1) as f64).min(b);
    golden_max(lo, hi, 1e-6 * (b - a).abs().max(1e-9), f)
}

/// Pattern search (coordinate steps of 0.05 halving down to 1e-9) maximising `f` from
/// `start`; `f` is `None` where it is not defined. Returns the maximiser and `f` there
/// (`f64::MIN` when `f` is not defined at `start` and no step finds it defined).
pub fn pattern_search_max(
    start: [f64; 2],
    f: &mut dyn FnMut([f64; 2]) -> Option<f64>,
) -> ([f64; 2], f64) {
    let mut best = start;
    let mut val = f(best).unwrap_or(f64::MIN);
    let mut step = 0.05;
    while step > 1e-9 {
        let mut improved = false;
        for d in [[step, 0.0], [-step, 0.0], [0.0, step], [0.0, -step]] {
            let c = [best[0] + d[0], best[1] + d[1]];
            if let Some(v) = f(c) {
                if v > val {
                    val = v;
                    best = c;
                    improved = true;
                }
            }
        }
        if !improved {
            step *= 0.5;
        }
    }
    (best, val)
}
