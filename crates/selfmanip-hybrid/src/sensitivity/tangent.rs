//! The variational equation `Ẋ = F X (+ ∂f/∂p)` over one DOPRI5 step of the record: the
//! tangent [`Tangent`] (the full `Φ` or selected columns) and its step on the execution's own
//! step sizes, with the stages' time clamps and a kink's hold (see the module docs of
//! [`crate::sensitivity`]).
use super::evaluator::{fit, fit_vec, Evaluator, FlowPoint, StageBuffers};
use super::types::{Parameter, SensitivityError};
use crate::execution::Segment;
use crate::integrate::{A as RK_A, C as RK_C};
use nalgebra::{DMatrix, DVector};

/// A tangent step's smooth piece of the controller's law and the record's state at a time
/// (see [`Tangent::step`]).
pub(super) type Hold<'a> = Option<(u64, &'a dyn Fn(f64, &mut [f64]))>;

/// What the variational equations carry along a segment: the full `Φ` (`2nq × 2nq`) of
/// [`execution_sensitivity`], or the selected columns `X` (`2nq × m`) of
/// [`execution_sensitivity_columns`], whose last `params.len()` columns are forced by
/// `∂f/∂p` (the parameters are constant states: `ṗ = 0`).
pub(super) enum Tangent<'p> {
    Full(DMatrix<f64>),
    Columns {
        x: DMatrix<f64>,
        params: &'p [Parameter],
        /// [`controller_names`] of `params`.
        names: Vec<&'p str>,
    },
}

impl Tangent<'_> {
    /// Left-multiplies by a saltation matrix over the state (a reset that does not depend on
    /// the parameters, at a guard that does not either).
    pub(super) fn salt(&mut self, xi: &DMatrix<f64>) {
        match self {
            Tangent::Full(phi) => *phi = xi * &*phi,
            Tangent::Columns { x, .. } => *x = xi * &*x,
        }
    }

    /// One step of the tangent from `(t0, y0)` of size `h` with the DOPRI5 tableau (its six
    /// stages that enter the 5th-order solution; the 7th is FSAL's); stage times are kept
    /// within `[t_floor, t_cap]`: one ulp after a time event the step starts on and one
    /// before one it ends on, so that each stage takes the one-sided limit of the flow and
    /// of its partials (`∂f/∂p` may jump there even where `f` does not, e.g. a jerk at a
    /// knot), whatever side a controller gives the instant itself.
    ///
    /// With `hold = Some((piece, record))` the step lies on one smooth piece of the
    /// controller's law ([`Controller::partials_piece`]) and ends or starts at a kink: a
    /// stage whose state the tableau put past the kink by the step's local error (the kink
    /// is bracketed to a few ulps in time, the stage states are not that close) takes the
    /// record's state at its time instead, so that every stage has the piece's partials.
    pub(super) fn step(
        &mut self,
        ev: &mut Evaluator,
        seg: &Segment,
        (t0, h, t_floor, t_cap): (f64, f64, f64, f64),
        y0: &[f64],
        hold: Hold<'_>,
    ) -> Result<(), SensitivityError> {
        if h <= 0.0 {
            return Ok(());
        }
        let mut st = std::mem::take(&mut ev.stages);
        let r = self.step_on(ev, &mut st, seg, (t0, h, t_floor, t_cap), y0, hold);
        ev.stages = st;
        r
    }

    /// [`Self::step`] on the stage buffers `st` (taken out of `ev` for the step).
    pub(super) fn step_on(
        &mut self,
        ev: &mut Evaluator,
        st: &mut StageBuffers,
        seg: &Segment,
        (t0, h, t_floor, t_cap): (f64, f64, f64, f64),
        y0: &[f64],
        hold: Hold<'_>,
    ) -> Result<(), SensitivityError> {
        let (phi, params) = match self {
            Tangent::Full(phi) => (phi, None),
            Tangent::Columns { x, params, names } => (x, Some((*params, &names[..]))),
        };
        st.k.resize_with(6, || DVector::zeros(0));
        st.kphi.resize_with(6, || DMatrix::zeros(0, 0));
        let StageBuffers { k, kphi, ys, ps } = st;
        for s in 0..6 {
            fit_vec(ys, y0.len());
            ys.copy_from_slice(y0);
            fit(ps, phi.nrows(), phi.ncols());
            ps.as_mut_slice().copy_from_slice(phi.as_slice());
            for j in 0..s {
                // `ys += (h a_sj) k_j` and `ps += (h a_sj) kphi_j`, in place (as `axpy`
                // forms them: `a x + y`)
                let c = h * RK_A[s][j];
                for (y, v) in ys.as_mut_slice().iter_mut().zip(k[j].as_slice()) {
                    *y += c * v;
                }
                for (p, v) in ps.as_mut_slice().iter_mut().zip(kphi[j].as_slice()) {
                    *p += c * v;
                }
            }
            let ts = (t0 + RK_C[s] * h).max(t_floor).min(t_cap);
            if let Some((piece, record)) = hold {
                let (q, qd) = ys.as_slice().split_at(y0.len() / 2);
                if seg.controller.partials_piece(ts, q, qd, seg.mode) != piece {
                    record(ts, ys.as_mut_slice());
                }
            }
            match params {
                None => {
                    ev.eval_into(FlowPoint::on(seg, ts, ys.as_slice()))?;
                    let fj = &ev.full.out;
                    // `F Φ` into the stage's buffer (the product `&F * &Φ` forms)
                    fit(&mut kphi[s], fj.jac.nrows(), ps.ncols());
                    kphi[s].gemm(1.0, &fj.jac, &*ps, 0.0);
                    fit_vec(&mut k[s], fj.f.len());
                    k[s].copy_from(&fj.f);
                }
                Some((params, names)) => {
                    ev.eval_columns_into(
                        FlowPoint::on(seg, ts, ys.as_slice()),
                        ps,
                        params,
                        names,
                        &mut k[s],
                        &mut kphi[s],
                    )?;
                }
            }
        }
        for (s, kp) in kphi.iter().enumerate() {
            let c = h * RK_A[6][s];
            for (p, v) in phi.as_mut_slice().iter_mut().zip(kp.as_slice()) {
                *p += c * v;
            }
        }
        Ok(())
    }
}
