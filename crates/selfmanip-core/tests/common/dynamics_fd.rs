//! The exact dynamics Jacobian against central differences of `(q̈, λ)`: shared by the
//! core's tests and the workspace's (which include this file by path).
use nalgebra::DMatrix;
use selfmanip_core::tangent::DynamicsJacobian;

/// Worst error of `exact` against `fd`, relative to the largest entry of `fd` (or 1).
pub fn rel_err(exact: &DMatrix<f64>, fd: &DMatrix<f64>) -> f64 {
    (exact - fd).amax() / fd.amax().max(1.0)
}

/// The worst [`rel_err`] of the blocks of `jac` (`∂(q̈, λ)/∂(q, q̇, Υ)`) at `(q, q̇, Υ)`
/// against central differences of `eval`, which gives `(q̈, λ)` at a state or `None` where
/// it is not defined (then the answer is `None`). The differences are summed over `steps`
/// `(h, weight)`: `[(h, 1.0)]` plain, `[(h, −1/3), (h/2, 4/3)]` Richardson's extrapolation
/// `(4 D(h/2) − D(h))/3` (truncation `O(h⁴)`).
pub fn dynamics_jacobian_error(
    jac: &DynamicsJacobian,
    (q, qd, tau): (&[f64], &[f64], &[f64]),
    steps: &[(f64, f64)],
    mut eval: impl FnMut(&[f64], &[f64], &[f64]) -> Option<(Vec<f64>, Vec<f64>)>,
) -> Option<f64> {
    let (nq, c) = (q.len(), jac.dlambda.dq.nrows());
    let mut worst: f64 = 0.0;
    for (which, n) in [(0, nq), (1, nq), (2, tau.len())] {
        let (mut fq, mut fl) = (DMatrix::zeros(nq, n), DMatrix::zeros(c, n));
        for k in 0..n {
            for &(h, w) in steps {
                let mut plus = [q.to_vec(), qd.to_vec(), tau.to_vec()];
                let mut minus = plus.clone();
                plus[which][k] += h;
                minus[which][k] -= h;
                let (qp, lp) = eval(&plus[0], &plus[1], &plus[2])?;
                let (qm, lm) = eval(&minus[0], &minus[1], &minus[2])?;
                for i in 0..nq {
                    fq[(i, k)] += w * (qp[i] - qm[i]) / (2.0 * h);
                }
                for r in 0..c {
                    fl[(r, k)] += w * (lp[r] - lm[r]) / (2.0 * h);
                }
            }
        }
        let (eq, el) = match which {
            0 => (&jac.dqdd.dq, &jac.dlambda.dq),
            1 => (&jac.dqdd.dqd, &jac.dlambda.dqd),
            _ => (&jac.dqdd_dtau, &jac.dlambda_dtau),
        };
        worst = worst.max(rel_err(eq, &fq)).max(rel_err(el, &fl));
    }
    Some(worst)
}
