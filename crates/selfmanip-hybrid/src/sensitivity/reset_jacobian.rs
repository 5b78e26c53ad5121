//! What an event's saltation is formed from: the state before it ([`EventAt`]), the guard's
//! gradient and the reset's Jacobians ([`GuardReset`]) that each kind of event fills in, and
//! why an event is not differentiated ([`NotDifferentiated`]).
use super::types::SensitivityError;
use crate::event::Event;
use crate::execution::Segment;
use nalgebra::{DMatrix, DVector, RowDVector};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::tangent::{plastic_impact_body_derivatives, BodyParameter, ImpactJacobian};
use selfmanip_core::{ContactMode, Data, Model, Terrain};

/// An event and the state `[q; q̇⁻]` just before it, with the kinematics there.
pub(super) struct EventAt<'a> {
    pub(super) model: &'a Model,
    pub(super) terrain: &'a dyn Terrain,
    /// The segment the event ended.
    pub(super) before: &'a Segment,
    pub(super) event: &'a Event,
    /// The body parameters whose `D_pR` is formed.
    pub(super) body: &'a [BodyParameter],
    pub(super) y: &'a [f64],
    pub(super) kin: Kinematics,
}

impl<'a> EventAt<'a> {
    pub(super) fn new(
        (model, terrain): (&'a Model, &'a dyn Terrain),
        before: &'a Segment,
        event: &'a Event,
        body: &'a [BodyParameter],
        y: &'a [f64],
    ) -> Self {
        let (q, qd_minus) = y.split_at(model.nq());
        let mut kin = Kinematics::default();
        kin.compute(model, q, qd_minus);
        EventAt {
            model,
            terrain,
            before,
            event,
            body,
            y,
            kin,
        }
    }

    /// `q` at the event.
    pub(super) fn q(&self) -> &'a [f64] {
        &self.y[..self.model.nq()]
    }

    /// `q̇⁻`, the velocity before the reset.
    pub(super) fn qd_minus(&self) -> &'a [f64] {
        &self.y[self.model.nq()..]
    }
}

/// The guard's gradient at an event and the reset's Jacobians: what the saltation
/// `Ξ = D_xR + (f⁺ − D_xR f⁻) D_xg / ġ` is formed from.
pub(super) struct GuardReset {
    /// `D_xg`.
    pub(super) dg: RowDVector<f64>,
    /// `∂g/∂t` at a fixed state (a force guard under torques that change with time).
    pub(super) dg_dt: f64,
    /// `D_xR` (the identity unless the reset jumps the velocity) and `D_pR` (body
    /// parameters' columns).
    pub(super) dr: DMatrix<f64>,
    pub(super) dr_p: DMatrix<f64>,
    /// The state after the reset.
    pub(super) y_plus: Vec<f64>,
    /// For a touchdown, the mode of the plastic impact the reset applied.
    pub(super) impact_mode: Option<ContactMode>,
    /// `∂R/∂μ` of the static friction coefficients the reset depends on, `(contact, column)`
    /// (a Coulomb impact's slipping contacts, [`super::coulomb_impact`]); empty otherwise.
    pub(super) dr_mu: Vec<(usize, DVector<f64>)>,
}

impl GuardReset {
    /// The reset is the plastic impact `ij` (its factorization left in `data`) into the
    /// velocity `qd_plus`: `D_xR` from its Jacobian, `D_pR` of the body parameters from
    /// [`plastic_impact_body_derivatives`].
    pub(super) fn plastic_impact(
        &mut self,
        at: &EventAt,
        data: &mut Data,
        ij: &ImpactJacobian,
        qd_plus: &[f64],
    ) {
        let dqd_dp =
            plastic_impact_body_derivatives(at.model, data, &ij.impact, at.qd_minus(), at.body);
        self.velocity_jump((&ij.dqd_plus.dq, &ij.dqd_plus.dqd, &dqd_dp), qd_plus);
    }

    /// The reset jumps the velocity to `qd_plus` with `∂q̇⁺/∂q`, `∂q̇⁺/∂q̇⁻` and `∂q̇⁺/∂p` of
    /// the body parameters (`nq` rows each): the velocity rows of `D_xR`, `D_pR` and `y⁺`.
    pub(super) fn velocity_jump(
        &mut self,
        (dq, dqd_minus, dp): (&DMatrix<f64>, &DMatrix<f64>, &DMatrix<f64>),
        qd_plus: &[f64],
    ) {
        let nq = qd_plus.len();
        self.dr_p.view_mut((nq, 0), (nq, dp.ncols())).copy_from(dp);
        self.dr.view_mut((nq, 0), (nq, nq)).copy_from(dq);
        self.dr.view_mut((nq, nq), (nq, nq)).copy_from(dqd_minus);
        self.y_plus[nq..].copy_from_slice(qd_plus);
    }
}

/// Why an event is not differentiated (recorded as its status's reason).
pub(super) struct NotDifferentiated(pub(super) String);

/// A kind of event's part of the saltation, or why it is not formed.
pub(super) type KindOutcome<T> = Result<Result<T, NotDifferentiated>, SensitivityError>;
