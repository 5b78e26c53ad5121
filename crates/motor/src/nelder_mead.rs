//! Nelder–Mead simplex minimization (Nelder & Mead 1965; the adaptive coefficients of
//! Gao & Han 2012 for higher dimensions), used by the thermal case fit and the observer
//! calibration (thesis section 2.2.1 calibrates the observer "via the Nelder–Mead algorithm").
//!
//! Written here rather than taken from `argmin`: the method is seventy lines, and argmin
//! would pull a math backend and a dozen crates into an otherwise small crate.

/// Options of [`minimize`].
#[derive(Debug, Clone, Copy)]
pub struct NelderMeadOptions {
    /// Stop when the spread of objective values over the simplex is below this.
    pub f_tolerance: f64,
    /// Stop when every vertex is within this distance (max-norm) of the best vertex.
    pub x_tolerance: f64,
    /// Objective evaluations allowed.
    pub max_evaluations: usize,
}

impl Default for NelderMeadOptions {
    fn default() -> Self {
        Self {
            f_tolerance: 1e-12,
            x_tolerance: 1e-10,
            max_evaluations: 20_000,
        }
    }
}

/// Result of [`minimize`].
#[derive(Debug, Clone)]
pub struct NelderMeadResult {
    pub x: Vec<f64>,
    pub f: f64,
    pub evaluations: usize,
    /// False when the evaluation budget ran out before the tolerances were met.
    pub converged: bool,
}

/// Minimizes `f` from `x0` with an initial simplex of steps `step[i]` along each axis.
/// A non-finite objective value is treated as +∞ (an infeasible point), so callers can
/// reject parameter vectors outside their domain by returning `f64::INFINITY`.
pub fn minimize(
    mut f: impl FnMut(&[f64]) -> f64,
    x0: &[f64],
    step: &[f64],
    options: NelderMeadOptions,
) -> NelderMeadResult {
    let n = x0.len();
    debug_assert_eq!(step.len(), n);
    let nf = n as f64;
    // Gao–Han adaptive coefficients (equal to the classic 1, 2, 1/2, 1/2 for n = 2).
    let (alpha, beta, gamma, delta) = (1.0, 1.0 + 2.0 / nf, 0.75 - 0.5 / nf, 1.0 - 1.0 / nf);
    let mut eval = |x: &[f64], count: &mut usize| {
        *count += 1;
        let v = f(x);
        if v.is_finite() {
            v
        } else {
            f64::INFINITY
        }
    };
    let mut evaluations = 0;
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((x0.to_vec(), eval(x0, &mut evaluations)));
    for i in 0..n {
        let mut x = x0.to_vec();
        x[i] += step[i];
        let fx = eval(&x, &mut evaluations);
        simplex.push((x, fx));
    }
    let mut converged = false;
    while evaluations < options.max_evaluations {
        // Stable order (ties by index) keeps the method deterministic.
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[n].1);
        let x_spread = simplex[1..]
            .iter()
            .flat_map(|(x, _)| x.iter().zip(&simplex[0].0).map(|(a, b)| (a - b).abs()))
            .fold(0.0_f64, f64::max);
        if (worst - best).abs() <= options.f_tolerance && x_spread <= options.x_tolerance {
            converged = true;
            break;
        }
        // centroid of all but the worst
        let mut centroid = vec![0.0; n];
        for (x, _) in &simplex[..n] {
            for (c, xi) in centroid.iter_mut().zip(x) {
                *c += xi / nf;
            }
        }
        let along = |t: f64| -> Vec<f64> {
            centroid
                .iter()
                .zip(&simplex[n].0)
                .map(|(c, w)| c + t * (c - w))
                .collect()
        };
        let xr = along(alpha);
        let fr = eval(&xr, &mut evaluations);
        if fr < best {
            let xe = along(beta);
            let fe = eval(&xe, &mut evaluations);
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (xc, fc) = if fr < worst {
                let xc = along(gamma);
                let fc = eval(&xc, &mut evaluations);
                (xc, fc)
            } else {
                let xc = along(-gamma);
                let fc = eval(&xc, &mut evaluations);
                (xc, fc)
            };
            if fc < fr.min(worst) {
                simplex[n] = (xc, fc);
            } else {
                // shrink towards the best vertex
                let x_best = simplex[0].0.clone();
                for vertex in simplex.iter_mut().skip(1) {
                    for (xi, bi) in vertex.0.iter_mut().zip(&x_best) {
                        *xi = bi + delta * (*xi - bi);
                    }
                    vertex.1 = eval(&vertex.0, &mut evaluations);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, f) = simplex.swap_remove(0);
    NelderMeadResult {
        x,
        f,
        evaluations,
        converged,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rosenbrock's valley: minimum 0 at (1, 1), a classic hard case for simplex methods.
    #[test]
    fn finds_the_rosenbrock_minimum() {
        let r = minimize(
            |x| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2),
            &[-1.2, 1.0],
            &[0.1, 0.1],
            NelderMeadOptions::default(),
        );
        assert!(r.converged);
        assert!(
            (r.x[0] - 1.0).abs() < 1e-5 && (r.x[1] - 1.0).abs() < 1e-5,
            "{:?}",
            r.x
        );
    }

    /// A 6-dimensional convex quadratic with distinct curvatures: the minimizer is known.
    #[test]
    fn finds_a_six_dimensional_quadratic_minimum() {
        let target = [0.3, -1.0, 2.0, 0.5, -0.7, 1.5];
        let r = minimize(
            |x| {
                x.iter()
                    .zip(&target)
                    .enumerate()
                    .map(|(i, (a, b))| (i as f64 + 1.0) * (a - b).powi(2))
                    .sum()
            },
            &[0.0; 6],
            &[0.5; 6],
            NelderMeadOptions::default(),
        );
        for (a, b) in r.x.iter().zip(&target) {
            assert!((a - b).abs() < 1e-5, "{:?}", r.x);
        }
    }

    #[test]
    fn infeasible_points_are_rejected() {
        // minimum of (x-2)^2 subject to x <= 1 (infeasible returns NaN) is at the boundary
        let r = minimize(
            |x| {
                if x[0] > 1.0 {
                    f64::NAN
                } else {
                    (x[0] - 2.0).powi(2)
                }
            },
            &[0.0],
            &[0.3],
            NelderMeadOptions::default(),
        );
        assert!(r.x[0] <= 1.0 && r.x[0] > 1.0 - 1e-6, "{:?}", r.x);
    }
}
