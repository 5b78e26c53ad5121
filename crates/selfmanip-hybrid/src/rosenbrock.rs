//! RODAS4, the L-stable linearly implicit (Rosenbrock) method of order 4 with an embedded
//! solution of order 3 and a continuous extension of order 3 (Hairer & Wanner, *Solving
//! ODEs II*, IV.7, code RODAS): what [`crate::integrate::Dopri5`] switches to on a stiff
//! stretch of a flow, where DOPRI5's stability region and not its accuracy sets the step (a
//! servo's damping `k_d / I` of 10⁴–10⁵ /s on a light link holds DOPRI5 near `3.3 I / k_d`).
//!
//! With `W = I / (h γ) − J` (`J ≈ ∂f/∂y` at the step's start, `γ = 1/4`), stage `i` solves
//! $$ W u_i = f\big(t + c_i h,\ y + \textstyle\sum_{j<i} a_{ij} u_j\big)
//!          + \textstyle\sum_{j<i} \tfrac{c_{ij}}{h} u_j + d_i h\, \partial_t f, $$
//! the step is `y₁ = y + Σ_{j<6} a_{6j} u_j + u₆` (the method is stiffly accurate: `y₁` is the
//! last stage point plus `u₆`), and `u₆` is the difference to the embedded solution: the
//! error estimate. The continuous extension is
//! `y(t + θh) = y + θ (y₁ − y) + θ (1 − θ) (k₁ + θ k₂)`, `k₁, k₂` fixed combinations of the
//! `u_i` — the quartic form of DOPRI5's dense output with `r₄ = 0`, so that a step of either
//! method is stored, sampled and located on in one format.
//!
//! The Jacobian `∂f/∂y` is the right-hand side's own where it gives one
//! ([`OdeSystem::jacobian`]: the flow's exact Jacobian, [`crate::flow::FlowSystem`]), else
//! taken by forward differences (`n` evaluations per step, `δ_j = √(ε max(10⁻⁵, |y_j|))` as
//! in RODAS); `∂f/∂t` by one forward difference; the linear
//! systems by one LU factorization with partial pivoting (nalgebra's `LU`) per trial step.
//! Coefficients: Hairer & Wanner's `RODAS` (method 1), as tabulated in the public `rodas.f`.
use crate::ode_system::OdeSystem;
use nalgebra::{DMatrix, DVectorViewMut, Dyn, LU};

/// `γ`.
pub(crate) const GAMMA: f64 = 0.25;
/// Stage times `c_i`.
pub(crate) const C: [f64; 6] = [0.0, 0.386, 0.21, 0.63, 1.0, 1.0];
/// `d_i` (the `∂f/∂t` weights).
pub(crate) const D: [f64; 6] = [0.25, -0.1043, 0.1035, -0.0362, 0.0, 0.0];
/// `a_ij`: row `i` gives stage `i`'s point; row 6 (index 5 plus `u₆`) the solution.
pub(crate) const A: [[f64; 5]; 6] = [
    [0.0; 5],
    [1.544, 0.0, 0.0, 0.0, 0.0],
    [0.9466785280815826, 0.2557011698983284, 0.0, 0.0, 0.0],
    [
        3.314825187068521,
        2.896124015972201,
        0.9986419139977817,
        0.0,
        0.0,
    ],
    [
        1.221224509226641,
        6.019134481288629,
        12.53708332932087,
        -0.687886036105895,
        0.0,
    ],
    [
        1.221224509226641,
        6.019134481288629,
        12.53708332932087,
        -0.687886036105895,
        1.0,
    ],
];
/// `c_ij` (divided by `h` in the stages).
pub(crate) const CC: [[f64; 5]; 6] = [
    [0.0; 5],
    [-5.6688, 0.0, 0.0, 0.0, 0.0],
    [-2.430093356833875, -0.2063599157091915, 0.0, 0.0, 0.0],
    [
        -0.1073529058151375,
        -9.594562251023355,
        -20.47028614809616,
        0.0,
        0.0,
    ],
    [
        7.496443313967647,
        -10.24680431464352,
        -33.99990352819905,
        11.7089089320616,
        0.0,
    ],
    [
        8.083246795921522,
        -7.981132988064893,
        -31.52159432874371,
        16.31930543123136,
        -6.058818238834054,
    ],
];
/// The dense output's `k₁` and `k₂` as combinations of `u₁ … u₆`.
const H: [[f64; 6]; 2] = [
    [
        10.12623508344586,
        -7.487995877610167,
        -34.80091861555747,
        -7.992771707568823,
        1.025137723295662,
        0.0,
    ],
    [
        -0.6762803392801253,
        6.087714651680015,
        16.43084320892478,
        24.76722511418386,
        -6.594389125716872,
        0.0,
    ],
];

/// The buffers of RODAS4 steps on a state of `n` numbers (allocated on the first stiff
/// stretch of a run; the factors of `W`, once per trial).
#[derive(Debug, Clone)]
pub(crate) struct Rodas4 {
    n: usize,
    /// `∂f/∂y` at the step's start, column-major.
    jac: Vec<f64>,
    /// `∂f/∂t` at the step's start.
    ft: Vec<f64>,
    /// The LU factors of `W` with partial pivoting, of the last trial.
    lu: Option<LU<f64, Dyn, Dyn>>,
    u: [Vec<f64>; 6],
    ytmp: Vec<f64>,
    ftmp: Vec<f64>,
    rhs: Vec<f64>,
}

/// Why a RODAS4 step could not be formed at its start (the caller takes an explicit step
/// instead): the right-hand side failed at a differenced state, or `W` is singular.
#[derive(Debug)]
pub(crate) struct NoJacobian;

impl Rodas4 {
    pub(crate) fn new(n: usize) -> Self {
        Rodas4 {
            n,
            jac: vec![0.0; n * n],
            ft: vec![0.0; n],
            lu: None,
            u: std::array::from_fn(|_| vec![0.0; n]),
            ytmp: vec![0.0; n],
            ftmp: vec![0.0; n],
            rhs: vec![0.0; n],
        }
    }

    /// `∂f/∂y` at `(t, y)` from the system where it gives it ([`OdeSystem::jacobian`]), else
    /// by forward differences; `∂f/∂t` by a forward difference; `f0 = f(t, y)`.
    pub(crate) fn jacobian<E, S: OdeSystem<E> + ?Sized>(
        &mut self,
        f: &mut S,
        t: f64,
        y: &[f64],
        f0: &[f64],
    ) -> Result<(), NoJacobian> {
        let n = self.n;
        if !f.jacobian(t, y, &mut self.jac) {
            self.ytmp.copy_from_slice(y);
            for (j, &yj) in y[..n].iter().enumerate() {
                let dj = (f64::EPSILON * yj.abs().max(1e-5)).sqrt();
                self.ytmp[j] = yj + dj;
                let r = f.rhs(t, &self.ytmp, &mut self.ftmp);
                self.ytmp[j] = yj;
                r.map_err(|_| NoJacobian)?;
                let col = &mut self.jac[j * n..(j + 1) * n];
                for i in 0..n {
                    col[i] = (self.ftmp[i] - f0[i]) / dj;
                }
            }
        }
        let dt = (f64::EPSILON * t.abs().max(1e-5)).sqrt();
        f.rhs(t + dt, y, &mut self.ftmp).map_err(|_| NoJacobian)?;
        for ((ft, fp), f0) in self.ft.iter_mut().zip(&self.ftmp).zip(f0) {
            *ft = (fp - f0) / dt;
        }
        if self.jac.iter().chain(&self.ft).all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(NoJacobian)
        }
    }

    /// An estimate of the spectral radius of the Jacobian (s⁻¹): the mean growth per
    /// application over the last half of a few power iterations from a fixed start. It
    /// tells whether an explicit step of a given size would be stable.
    pub(crate) fn spectral_radius(&mut self) -> f64 {
        const ITERATIONS: usize = 12;
        let n = self.n;
        for (i, v) in self.ytmp.iter_mut().enumerate() {
            *v = 1.0 + i as f64 / n as f64;
        }
        let mut log_growth = 0.0;
        for it in 0..ITERATIONS {
            self.ftmp.fill(0.0);
            for j in 0..n {
                let x = self.ytmp[j];
                for (o, a) in self.ftmp.iter_mut().zip(&self.jac[j * n..(j + 1) * n]) {
                    *o += a * x;
                }
            }
            let before = norm(&self.ytmp);
            let after = norm(&self.ftmp);
            if after == 0.0 || before == 0.0 || !after.is_finite() {
                return if after.is_finite() {
                    0.0
                } else {
                    f64::INFINITY
                };
            }
            if it >= ITERATIONS / 2 {
                log_growth += (after / before).ln();
            }
            for (v, w) in self.ytmp.iter_mut().zip(&self.ftmp) {
                *v = w / after;
            }
        }
        (log_growth / (ITERATIONS - ITERATIONS / 2) as f64).exp()
    }

    /// Factors `W = I / (h γ) − J`; `false` where it is singular (a zero or non-finite
    /// pivot).
    fn factor(&mut self, h: f64) -> bool {
        let n = self.n;
        let diag = 1.0 / (h * GAMMA);
        let w = DMatrix::from_fn(n, n, |i, j| {
            let d = if i == j { diag } else { 0.0 };
            d - self.jac[j * n + i]
        });
        let lu = w.lu();
        let regular = lu.u().diagonal().iter().all(|p| *p != 0.0 && p.is_finite());
        self.lu = Some(lu);
        regular
    }

    /// One trial step of size `h` from `(t, y)` (`f0 = f(t, y)`, the Jacobian taken there):
    /// the solution into `ynew`, the error estimate `u₆` into `err`, and the dense output's
    /// coefficients `r₀ … r₄` into `r` (`5 n`). `Err(Some(e))`: the right-hand side failed at
    /// a stage; `Err(None)`: `W` is singular at this `h`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn trial<E, S: OdeSystem<E> + ?Sized>(
        &mut self,
        f: &mut S,
        t: f64,
        y: &[f64],
        f0: &[f64],
        h: f64,
        ynew: &mut [f64],
        r: &mut [f64],
    ) -> Result<(), Option<E>> {
        let n = self.n;
        if !self.factor(h) {
            return Err(None);
        }
        for s in 0..6 {
            // the stage point and its right-hand side
            self.ytmp.copy_from_slice(y);
            for (&a, uj) in A[s][..s].iter().zip(&self.u) {
                if a != 0.0 {
                    for (v, u) in self.ytmp.iter_mut().zip(uj) {
                        *v += a * u;
                    }
                }
            }
            if s == 0 {
                self.rhs.copy_from_slice(f0);
            } else {
                f.rhs(t + C[s] * h, &self.ytmp, &mut self.rhs)
                    .map_err(Some)?;
            }
            let dh = D[s] * h;
            for i in 0..n {
                let mut acc = self.rhs[i] + dh * self.ft[i];
                for (cc, uj) in CC[s][..s].iter().zip(&self.u) {
                    acc += cc / h * uj[i];
                }
                self.rhs[i] = acc;
            }
            let lu = self.lu.as_ref().expect("factored above");
            lu.solve_mut(&mut DVectorViewMut::from_slice(&mut self.rhs, n));
            self.u[s].copy_from_slice(&self.rhs);
        }
        // y₁ = the 6th stage point + u₆
        for ((yn, yt), u) in ynew[..n].iter_mut().zip(&self.ytmp).zip(&self.u[5]) {
            *yn = yt + u;
        }
        let (r0, rest) = r.split_at_mut(n);
        let (r1, rest) = rest.split_at_mut(n);
        let (r2, rest) = rest.split_at_mut(n);
        let (r3, r4) = rest.split_at_mut(n);
        for i in 0..n {
            r0[i] = y[i];
            r1[i] = ynew[i] - y[i];
            r2[i] = (0..6).map(|j| H[0][j] * self.u[j][i]).sum();
            r3[i] = (0..6).map(|j| H[1][j] * self.u[j][i]).sum();
            r4[i] = 0.0;
        }
        Ok(())
    }

    /// The error estimate of the last trial (`u₆`).
    pub(crate) fn error(&self) -> &[f64] {
        &self.u[5]
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Order 4 at the step's end on `y' = λ (y − cos t) − sin t` (solution
    /// `cos t + e^{λt}(y₀ − 1)`): halving the step divides the error by about 16.
    #[test]
    fn fourth_order_on_a_nonautonomous_linear_equation() {
        let lam = -3.0;
        let exact = |t: f64| t.cos() + (lam * t).exp();
        let mut errs = Vec::new();
        for steps in [10, 20, 40] {
            let h = 1.0 / steps as f64;
            let mut ros = Rodas4::new(1);
            let (mut t, mut y) = (0.0, [2.0]);
            let mut f = |t: f64, y: &[f64], dy: &mut [f64]| -> Result<(), ()> {
                dy[0] = lam * (y[0] - t.cos()) - t.sin();
                Ok(())
            };
            for _ in 0..steps {
                let mut f0 = [0.0];
                f(t, &y, &mut f0).unwrap();
                ros.jacobian(&mut f, t, &y, &f0).unwrap();
                let (mut ynew, mut r) = ([0.0], [0.0; 5]);
                ros.trial(&mut f, t, &y, &f0, h, &mut ynew, &mut r).unwrap();
                y = ynew;
                t += h;
            }
            errs.push((y[0] - exact(1.0)).abs());
        }
        for w in errs.windows(2) {
            let ratio = w[0] / w[1];
            assert!(ratio > 12.0 && ratio < 20.0, "{errs:?}");
        }
    }
}
