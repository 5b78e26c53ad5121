//! The variational equation over one linearly implicit (RODAS4) step of the record: the
//! tangent is advanced by a RODAS4 step of its own, on the same step size.
//!
//! An explicit tangent step need not be stable at the sizes RODAS4 took on a stiff stretch
//! (that is why the engine switched), so the tangent uses the same L-stable method. The
//! variational equation is linear in the tangent: along the record's state `ŷ(t)` (the
//! step's dense output), `Ẋ = G(t, X) = F(t) X + B(t)` with `F(t) = ∂f/∂x(t, ŷ(t))` and
//! `B` the forcing of the parameter (and memory) columns. RODAS4 on this equation
//! (`crate::rosenbrock`) takes `W = I / (h γ) − F(t₀)` — the *exact* Jacobian of `G` in `X`,
//! from [`selfmanip_core::tangent`], where the engine's own step used forward differences of
//! the flow — and `∂G/∂t` at the start, by a forward difference of `G(·, X₀)` along the
//! record over `10⁻³ h` (the stage states are the record's, a polynomial in `t`: the
//! difference's truncation error is third order in `h`, its rounding far below the tangent's
//! own error). Stage `i` evaluates `G` at the record's state at `t₀ + c_i h`, so every stage
//! lies on the record (a kink's or switch's side, as the sub-steps of
//! [`super::segment_tangent`] need it) and the stage times keep their clamps.
//!
//! This is an accurate integration of the variational equation of the exact flow (order 4
//! in `h`, as the state's step), not the derivative of the engine's step map: RODAS4's
//! finite-difference Jacobian depends on the state in a way no exact derivative follows.
//! Finite differences of whole runs converge to the same derivative up to the runs'
//! tolerance (`tests/stiff_sensitivity.rs`).
use super::evaluator::{fit, Evaluator, FlowPoint};
use super::tangent::Tangent;
use super::types::SensitivityError;
use crate::execution::Segment;
use crate::rosenbrock::{A as RA, C as RC, CC as RCC, D as RD, GAMMA};
use nalgebra::{DMatrix, DVector};

/// `∂G/∂t` is differenced over this fraction of the step.
const TIME_DIFFERENCE: f64 = 1e-3;

impl Tangent<'_> {
    /// One RODAS4 step of the tangent from `t0` of size `h` along the record `record`
    /// (`record(t, y)`: the state at `t`), stage times kept within `[t_floor, t_cap]` (as
    /// [`Tangent::step`]'s).
    pub(super) fn step_implicit(
        &mut self,
        ev: &mut Evaluator,
        seg: &Segment,
        (t0, h, t_floor, t_cap): (f64, f64, f64, f64),
        record: &dyn Fn(f64, &mut [f64]),
    ) -> Result<(), SensitivityError> {
        if h <= 0.0 {
            return Ok(());
        }
        let n2 = seg.y0.len();
        let clamp = |t: f64| t.max(t_floor).min(t_cap);
        let mut y = vec![0.0; n2];
        let ta = clamp(t0);
        record(ta, &mut y);
        ev.eval_into(FlowPoint::on(seg, ta, &y))?;
        let diag = 1.0 / (h * GAMMA);
        let jac = &ev.full.out.jac;
        let w = DMatrix::from_fn(n2, n2, |i, j| {
            if i == j {
                diag - jac[(i, j)]
            } else {
                -jac[(i, j)]
            }
        });
        let lu = w.lu();
        if !lu.u().diagonal().iter().all(|p| *p != 0.0 && p.is_finite()) {
            return Err(SensitivityError::SingularImplicitStep { t: t0 });
        }
        let x0 = self.columns().clone();
        let m = x0.ncols();
        let mut fbuf = DVector::zeros(0);
        // G(t, X) at the record's state at t
        let mut g = |ev: &mut Evaluator,
                     t: f64,
                     x: &DMatrix<f64>,
                     out: &mut DMatrix<f64>|
         -> Result<(), SensitivityError> {
            let mut ys = vec![0.0; n2];
            record(t, &mut ys);
            match &*self {
                Tangent::Full(_) => {
                    ev.eval_into(FlowPoint::on(seg, t, &ys))?;
                    fit(out, n2, m);
                    out.gemm(1.0, &ev.full.out.jac, x, 0.0);
                }
                Tangent::Columns { params, names, .. } => {
                    let at = FlowPoint::on(seg, t, &ys);
                    ev.eval_columns_into(at, x, params, names, &mut fbuf, out)?;
                }
            }
            Ok(())
        };
        // G at the start (stage 1's) and ∂G/∂t there
        let mut g0 = DMatrix::zeros(n2, m);
        g(ev, ta, &x0, &mut g0)?;
        let tb = clamp(t0 + TIME_DIFFERENCE * h);
        let mut gt = DMatrix::zeros(n2, m);
        if tb > ta {
            g(ev, tb, &x0, &mut gt)?;
            gt -= &g0;
            gt /= tb - ta;
        }
        let mut u: Vec<DMatrix<f64>> = Vec::with_capacity(6);
        let mut xs = x0.clone();
        let mut gs = DMatrix::zeros(n2, m);
        for s in 0..6 {
            xs.copy_from(&x0);
            for (j, uj) in u.iter().enumerate() {
                if RA[s][j] != 0.0 {
                    xs.zip_apply(uj, |v, w| *v += RA[s][j] * w);
                }
            }
            let mut rhs = if s == 0 {
                g0.clone()
            } else {
                g(ev, clamp(t0 + RC[s] * h), &xs, &mut gs)?;
                gs.clone()
            };
            if RD[s] != 0.0 {
                rhs.zip_apply(&gt, |v, w| *v += RD[s] * h * w);
            }
            for (j, uj) in u.iter().enumerate() {
                rhs.zip_apply(uj, |v, w| *v += RCC[s][j] / h * w);
            }
            lu.solve_mut(&mut rhs);
            u.push(rhs);
        }
        // X₁ = the 6th stage point + u₆ (stiffly accurate)
        xs += &u[5];
        self.columns_mut().copy_from(&xs);
        Ok(())
    }

    /// The matrix the tangent carries (`Φ` or the columns `X`).
    fn columns(&self) -> &DMatrix<f64> {
        match self {
            Tangent::Full(phi) => phi,
            Tangent::Columns { x, .. } => x,
        }
    }

    fn columns_mut(&mut self) -> &mut DMatrix<f64> {
        match self {
            Tangent::Full(phi) => phi,
            Tangent::Columns { x, .. } => x,
        }
    }
}
