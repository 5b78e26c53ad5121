//! The sensitivity engine's exact flow Jacobian `F = ∂f/∂x` ([`Evaluator::eval_into`]) for
//! the integrator's linearly implicit steps ([`crate::rosenbrock`]): one evaluation with
//! closed-form assembly derivatives and `2 nq + n` solves on one KKT factorization, where
//! forward differences take `2 nq` evaluations of the flow, each with its own factorization.
use super::evaluator::{Evaluator, FlowPoint};
use crate::controller::Controller;
use selfmanip_core::friction::SlideDirection;
use selfmanip_core::{ContactMode, Model, Terrain};

/// An evaluator of the flow's exact Jacobian on a workspace of its own (the flow's cache is
/// not touched).
pub(crate) struct EngineJacobian<'a> {
    eval: Evaluator<'a>,
}

impl<'a> EngineJacobian<'a> {
    pub(crate) fn new(model: &'a Model, terrain: &'a dyn Terrain) -> Self {
        EngineJacobian {
            eval: Evaluator::new(model, terrain),
        }
    }

    /// `∂f/∂x` of the flow of `mode` under `ctrl` (joints `locked` at their speed, Coulomb
    /// sites sliding along `dirs`) at `(t, y)`, column-major into `jac` (`2nq × 2nq`).
    /// `false` (nothing written) where it has none: the controller gives no partials
    /// ([`Controller::partials`]) or the dynamics are singular here.
    pub(crate) fn jacobian(
        &mut self,
        (ctrl, locked, dirs): (&dyn Controller, &[usize], &[(usize, SlideDirection)]),
        (t, mode): (f64, ContactMode),
        y: &[f64],
        jac: &mut [f64],
    ) -> bool {
        let at = FlowPoint {
            ctrl,
            locked,
            dirs,
            t,
            mode,
            y,
        };
        if self.eval.eval_into(at).is_err() {
            return false;
        }
        let f = &self.eval.full.out.jac;
        if f.len() != jac.len() || !f.iter().all(|v| v.is_finite()) {
            return false;
        }
        jac.copy_from_slice(f.as_slice());
        true
    }
}
