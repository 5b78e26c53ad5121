//! The flow and its derivatives at one state, on a workspace of its own: the full Jacobian
//! `F = ∂f/∂x` with `∂λ/∂x` ([`Evaluator::eval`]), the flow alone ([`Evaluator::flow`]), and
//! the tangent `F X + ∂f/∂p` along selected columns by Jacobian-times-matrix products
//! ([`Evaluator::eval_columns_into`]), each at a [`FlowPoint`].
use super::types::{Parameter, SensitivityError};
use crate::controller::{ControlPoint, Controller, ControllerPartials, EventMemoryPartials};
use crate::execution::Segment;
use nalgebra::{DMatrix, DVector};
use selfmanip_core::contact::{contact_geometry, TouchKind};
use selfmanip_core::friction::SlideDirection;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::tangent::{
    dynamics_jacobian_solved_into, dynamics_jvp_into, BodyParameter, DynamicsJacobian,
    FlowDirections, JacobianWorkspace, JvpWorkspace, StatePartials, TangentError,
};
use selfmanip_core::{forward_dynamics_prepared, ContactMode, Data, Model, Terrain};

/// Where a flow is evaluated: a segment's controller, its locked joints and the sliding
/// directions of its Coulomb-sliding sites (as its flow had them, [`crate::flow`]), and the
/// time, mode and state `y = [q; q̇]`. The arguments every evaluation takes together.
#[derive(Clone, Copy)]
pub(super) struct FlowPoint<'a> {
    pub(super) ctrl: &'a dyn Controller,
    pub(super) locked: &'a [usize],
    pub(super) dirs: &'a [(usize, SlideDirection)],
    pub(super) t: f64,
    pub(super) mode: ContactMode,
    pub(super) y: &'a [f64],
}

impl<'a> FlowPoint<'a> {
    /// The flow of segment `seg` (its controller, locks, sliding directions and mode) at
    /// `(t, y)`.
    pub(super) fn on(seg: &'a Segment, t: f64, y: &'a [f64]) -> Self {
        FlowPoint {
            ctrl: &*seg.controller,
            locked: &seg.locked,
            dirs: &seg.slide_directions,
            t,
            mode: seg.mode,
            y,
        }
    }
}

/// The flow and its Jacobian at one state.
#[derive(Clone, Default)]
pub(super) struct FlowJacobian {
    /// `f = (q̇, q̈)`.
    pub(super) f: DVector<f64>,
    /// `F = ∂f/∂x`.
    pub(super) jac: DMatrix<f64>,
    /// `∂λ/∂x` (rows of the mode) and `λ`.
    pub(super) dlambda: DMatrix<f64>,
    pub(super) lambda: DVector<f64>,
    /// `∂λ/∂Υ`: a force event's rate takes `∂λ/∂t = ∂λ/∂Υ ∂Υ/∂t` from it
    /// ([`torque_time_derivative`]), formed at the event only.
    pub(super) dlambda_dtau: DMatrix<f64>,
}

/// Evaluates flows and their Jacobians on a workspace of its own.
pub(super) struct Evaluator<'a> {
    pub(super) model: &'a Model,
    pub(super) terrain: &'a dyn Terrain,
    pub(super) data: Data,
    pub(super) tau: Vec<f64>,
    pub(super) free: Vec<f64>,
    pub(super) kin: Kinematics,
    /// The buffers of [`Self::eval_columns_into`] and of [`Tangent::step`]'s stages, kept
    /// across evaluations so that a step allocates nothing once they are sized.
    pub(super) cols: ColumnBuffers,
    pub(super) stages: StageBuffers,
    /// The buffers of [`Self::eval_into`] and its result.
    pub(super) full: FullBuffers,
    /// Whether the controllers' event memory is differentiated (some segment's controller
    /// has it, [`Controller::has_event_memory`]); then `memory[k]` holds
    /// `d(t_k, q_k, q̇_k⁺)/d(columns)` (`(1 + 2nq) × m`) of the `k`-th event the controllers
    /// were told of.
    pub(super) memory_mode: bool,
    pub(super) memory: Vec<DMatrix<f64>>,
}

/// The reusable buffers of one [`Evaluator::eval_into`] (the full Jacobian), and its result.
#[derive(Default)]
pub(super) struct FullBuffers {
    partials: Option<ControllerPartials>,
    free_joints: Vec<usize>,
    ws: JacobianWorkspace,
    dj: DynamicsJacobian,
    /// `∂q̈/∂x` with the controller's torques and free joints' motions.
    dqdd: StatePartials,
    /// `∂λ/∂x` with the controller's torques.
    dlambda: StatePartials,
    /// The flow and its Jacobian at the last state evaluated.
    pub(super) out: FlowJacobian,
}

/// The reusable buffers of one [`Evaluator::eval_columns_into`].
#[derive(Default)]
pub(super) struct ColumnBuffers {
    partials: Option<ControllerPartials>,
    free_joints: Vec<usize>,
    dq: DMatrix<f64>,
    dqd: DMatrix<f64>,
    dtau: DMatrix<f64>,
    dtau2: DMatrix<f64>,
    dfree: DMatrix<f64>,
    dfree2: DMatrix<f64>,
    body: Vec<Option<BodyParameter>>,
    /// `∂Q^fr/∂μ_k` of the kinetic friction coefficients' columns (`nq × m`,
    /// [`kinetic_friction_force`]).
    force: DMatrix<f64>,
    dqdd: DMatrix<f64>,
    /// `∂λ/∂x X + ∂λ/∂p` of the last evaluation, `c × m`.
    dlambda: DMatrix<f64>,
    jvp: JvpWorkspace,
    /// The controller's memory partials of the last evaluation.
    mem: Vec<EventMemoryPartials>,
}

/// The stages of one [`Tangent::step`]: their flows, their tangents, and the stage state.
#[derive(Default)]
pub(super) struct StageBuffers {
    pub(super) k: Vec<DVector<f64>>,
    pub(super) kphi: Vec<DMatrix<f64>>,
    pub(super) ys: DVector<f64>,
    pub(super) ps: DMatrix<f64>,
}

/// `a` shaped `r × c`, reallocated only when its shape changes (its entries are to be
/// overwritten).
#[inline]
pub(super) fn fit(a: &mut DMatrix<f64>, r: usize, c: usize) {
    if a.shape() != (r, c) {
        *a = DMatrix::zeros(r, c);
    }
}

/// `out = ∂y/∂Υ ∂Υ/∂x + ∂y/∂x` for `x = q` and `x = q̇`: the partials of `y(x, Υ(x))` from
/// its own (`direct`), its columns over the torques `dy_dtau` and the torques' `dtau` (the
/// product, then the sum, as `a * b + c` forms them by value). Allocates only when `out`'s
/// shape changes.
fn chain_through_torque(
    out: &mut StatePartials,
    direct: &StatePartials,
    dy_dtau: &DMatrix<f64>,
    dtau: &StatePartials,
) {
    for (o, (d, t)) in [
        (&mut out.dq, (&direct.dq, &dtau.dq)),
        (&mut out.dqd, (&direct.dqd, &dtau.dqd)),
    ] {
        fit(o, d.nrows(), d.ncols());
        o.gemm(1.0, dy_dtau, t, 0.0);
        *o += d;
    }
}

/// `v` of length `n`, reallocated only when its length changes (its entries are to be
/// overwritten).
#[inline]
pub(super) fn fit_vec(v: &mut DVector<f64>, n: usize) {
    if v.len() != n {
        *v = DVector::zeros(n);
    }
}

/// Zero controller partials of the given sizes in `slot`, reusing its matrices when they
/// have those shapes (the same as [`ControllerPartials::with_parameters`]).
fn zero_partials(
    slot: &mut Option<ControllerPartials>,
    n: usize,
    nq: usize,
    n_free: usize,
    k: usize,
) -> &mut ControllerPartials {
    let fits = slot.as_ref().is_some_and(|p| {
        p.dtau.dq.shape() == (n, nq)
            && p.dfree.dq.shape() == (n_free, nq)
            && p.dtau_dp.shape() == (n, k)
    });
    if fits {
        let p = slot.as_mut().expect("checked");
        for a in [
            &mut p.dtau.dq,
            &mut p.dtau.dqd,
            &mut p.dfree.dq,
            &mut p.dfree.dqd,
            &mut p.dtau_dp,
            &mut p.dfree_dp,
        ] {
            a.as_mut_slice().fill(0.0);
        }
    } else {
        *slot = Some(ControllerPartials::with_parameters(n, nq, n_free, k));
    }
    slot.as_mut().expect("set")
}

impl<'a> Evaluator<'a> {
    pub(super) fn new(model: &'a Model, terrain: &'a dyn Terrain) -> Self {
        // as the flow's workspace (crate::flow::FlowWorkspace): a site at rest takes an edge
        let mut data = Data::new(model);
        data.slide_at_rest = true;
        Evaluator {
            model,
            terrain,
            data,
            tau: vec![0.0; model.n_joints()],
            free: Vec::new(),
            kin: Kinematics::default(),
            cols: ColumnBuffers::default(),
            stages: StageBuffers::default(),
            full: FullBuffers::default(),
            memory_mode: false,
            memory: Vec::new(),
        }
    }

    /// The touch kind of every active contact of `mode` at `y`.
    pub(super) fn touches(&mut self, mode: ContactMode, y: &[f64]) -> Vec<(usize, TouchKind)> {
        let mut out = Vec::new();
        self.touches_into(mode, y, &mut out);
        out
    }

    /// [`Self::touches`] into `out` (cleared first; no allocation once it is large enough).
    #[inline]
    pub(super) fn touches_into(
        &mut self,
        mode: ContactMode,
        y: &[f64],
        out: &mut Vec<(usize, TouchKind)>,
    ) {
        let nq = self.model.nq();
        self.kin.compute(self.model, &y[..nq], &y[nq..]);
        out.clear();
        out.extend(mode.active().map(|k| {
            (
                k,
                contact_geometry(self.model, &self.kin, self.terrain, k).touch,
            )
        }));
    }

    /// The flow at `at`, and its Jacobian (a copy of [`Self::eval_into`]'s result).
    pub(super) fn eval(&mut self, at: FlowPoint) -> Result<FlowJacobian, SensitivityError> {
        self.eval_into(at)?;
        Ok(self.full.out.clone())
    }

    /// Prepares `self.data` at `at` (its mode, state, locked joints and sliding directions),
    /// and evaluates the controller's torques and free joints' accelerations there
    /// (into `self.tau`, `self.free`) and its state partials (into `slot`, `k` parameter
    /// columns zeroed); the free joints are left in `free_joints`. What every evaluation
    /// starts with.
    pub(super) fn prepare_controller(
        &mut self,
        at: FlowPoint,
        slot: &mut Option<ControllerPartials>,
        free_joints: &mut Vec<usize>,
        k: usize,
    ) -> Result<(), SensitivityError> {
        let FlowPoint {
            ctrl,
            locked,
            dirs,
            t,
            mode,
            y,
        } = at;
        let (model, nq, n) = (self.model, self.model.nq(), self.model.n_joints());
        let (q, qd) = y.split_at(nq);
        self.data.locked.clear();
        self.data.locked.extend_from_slice(locked);
        // the segment's sliding directions, as its flow had them (crate::flow)
        self.data.set_slide_directions(dirs);
        self.data
            .prepare(model, self.terrain, mode, q, qd)
            .map_err(TangentError::from)?;
        free_joints.clear();
        free_joints.extend_from_slice(&self.data.free_joints);
        let point = ControlPoint::new(t, q, qd, mode).with_free_joints(free_joints);
        ctrl.torque(t, q, qd, mode, &mut self.tau);
        self.free.resize(free_joints.len(), 0.0);
        ctrl.free_joint_qdd(t, q, qd, free_joints, &mut self.free);
        for (x, j) in self.free.iter_mut().zip(free_joints.iter()) {
            if locked.contains(j) {
                *x = 0.0;
            }
        }
        let p = zero_partials(slot, n, nq, free_joints.len(), k);
        if !ctrl.partials(&point, p) {
            return Err(SensitivityError::ControllerWithoutPartials { t });
        }
        Ok(())
    }

    /// The flow `f = (q̇, q̈)` at `at` alone: [`Self::eval`]'s `f`, bit for bit,
    /// without the Jacobian (a time event's or a switch's jump, the flow after an event).
    pub(super) fn flow(&mut self, at: FlowPoint) -> Result<DVector<f64>, SensitivityError> {
        let (nq, y) = (self.model.nq(), at.y);
        let mut fb = std::mem::take(&mut self.full);
        let r = self.solve_flow(&mut fb, at);
        self.full = fb;
        r?;
        let mut f = DVector::zeros(2 * nq);
        f.rows_mut(0, nq).copy_from_slice(&y[nq..]);
        f.rows_mut(nq, nq).copy_from(&self.data.qdd);
        Ok(f)
    }

    /// The flow at `at` and its Jacobian, into `self.full.out` (on the evaluator's buffers: no allocation once they are sized).
    pub(super) fn eval_into(&mut self, at: FlowPoint) -> Result<(), SensitivityError> {
        let mut fb = std::mem::take(&mut self.full);
        let r = self.eval_on(&mut fb, at);
        self.full = fb;
        r
    }

    /// [`Self::prepare_controller`] on the buffers `fb` and the forward dynamics (`q̈` and
    /// `λ` in `self.data`), with the controller's state partials in `fb.partials`.
    pub(super) fn solve_flow(
        &mut self,
        fb: &mut FullBuffers,
        at: FlowPoint,
    ) -> Result<(), SensitivityError> {
        let (slot, free_joints) = (&mut fb.partials, &mut fb.free_joints);
        self.prepare_controller(at, slot, free_joints, 0)?;
        forward_dynamics_prepared(self.model, &mut self.data, &self.tau, Some(&self.free))
            .map_err(TangentError::from)?;
        Ok(())
    }

    /// [`Self::eval_into`] on the buffers `fb` (taken out of `self` for the evaluation).
    pub(super) fn eval_on(
        &mut self,
        fb: &mut FullBuffers,
        at: FlowPoint,
    ) -> Result<(), SensitivityError> {
        let (model, nq) = (self.model, self.model.nq());
        let (qd, locked) = (&at.y[nq..], at.locked);
        self.solve_flow(fb, at)?;
        let p = fb.partials.as_ref().expect("set by prepare_controller");
        dynamics_jacobian_solved_into(model, &mut self.data, qd, &mut fb.ws, &mut fb.dj)?;
        let dj = &fb.dj;
        // the same products and sums as `∂q̈/∂q + ∂q̈/∂Υ ∂Υ/∂q` formed by value
        let c = dj.dlambda.dq.nrows();
        chain_through_torque(&mut fb.dqdd, &dj.dqdd, &dj.dqdd_dtau, &p.dtau);
        for (i, &j) in fb.free_joints.iter().enumerate() {
            if !locked.contains(&j) {
                fb.dqdd.dq.set_row(j, &p.dfree.dq.row(i));
                fb.dqdd.dqd.set_row(j, &p.dfree.dqd.row(i));
            }
        }
        let out = &mut fb.out;
        fit(&mut out.jac, 2 * nq, 2 * nq);
        out.jac.fill(0.0);
        for i in 0..nq {
            out.jac[(i, nq + i)] = 1.0;
        }
        out.jac.view_mut((nq, 0), (nq, nq)).copy_from(&fb.dqdd.dq);
        out.jac.view_mut((nq, nq), (nq, nq)).copy_from(&fb.dqdd.dqd);
        chain_through_torque(&mut fb.dlambda, &dj.dlambda, &dj.dlambda_dtau, &p.dtau);
        fit(&mut out.dlambda, c, 2 * nq);
        out.dlambda
            .view_mut((0, 0), (c, nq))
            .copy_from(&fb.dlambda.dq);
        out.dlambda
            .view_mut((0, nq), (c, nq))
            .copy_from(&fb.dlambda.dqd);
        fit_vec(&mut out.f, 2 * nq);
        out.f.rows_mut(0, nq).copy_from_slice(qd);
        out.f.rows_mut(nq, nq).copy_from(&self.data.qdd);
        fit_vec(&mut out.lambda, c);
        out.lambda.copy_from(&self.data.lambda);
        fit(&mut out.dlambda_dtau, c, dj.dlambda_dtau.ncols());
        out.dlambda_dtau.copy_from(&dj.dlambda_dtau);
        Ok(())
    }
}

/// `∂Υ/∂t` at a fixed state ([`Controller::time_partials`]), or for a controller that does
/// not give it a central difference of [`Controller::torque`] in time: the torques are smooth
/// in time between the controller's time events, where a guard's crossing generically is
/// not, so the difference (step `1e-6 max(1, |t|)` s) has a relative error of about 1e-9
/// where taking it as 0 would drop the term.
pub(super) fn torque_time_derivative(
    ctrl: &dyn Controller,
    n: usize,
    t: f64,
    (q, qd): (&[f64], &[f64]),
    mode: ContactMode,
) -> DVector<f64> {
    let mut out = DVector::zeros(n);
    if ctrl.time_partials(&ControlPoint::new(t, q, qd, mode), out.as_mut_slice()) {
        return out;
    }
    let h = 1e-6 * t.abs().max(1.0);
    let mut up = vec![0.0; n];
    ctrl.torque(t + h, q, qd, mode, &mut up);
    ctrl.torque(t - h, q, qd, mode, out.as_mut_slice());
    for (o, u) in out.iter_mut().zip(&up) {
        *o = (u - *o) / (2.0 * h);
    }
    out
}

/// The multipliers at one state and their tangent along selected columns (what an event's
/// force guard needs of [`Evaluator::eval_columns`]).
pub(super) struct FlowColumns {
    /// `∂λ/∂x X + ∂λ/∂p`, `c × m`.
    pub(super) dlambda: DMatrix<f64>,
    pub(super) lambda: DVector<f64>,
}

impl Evaluator<'_> {
    /// The multipliers at `at` and their tangent along the columns of `x`
    /// (`2nq × m`), whose last `params.len()` columns are the parameters' (see [`Tangent`]),
    /// by [`Self::eval_columns_into`].
    pub(super) fn eval_columns(
        &mut self,
        at: FlowPoint,
        x: &DMatrix<f64>,
        params: &[Parameter],
    ) -> Result<FlowColumns, SensitivityError> {
        let names = controller_names(params);
        let (mut f, mut dx) = (DVector::zeros(0), DMatrix::zeros(0, 0));
        self.eval_columns_into(at, x, params, &names, &mut f, &mut dx)?;
        Ok(FlowColumns {
            dlambda: self.cols.dlambda.clone(),
            lambda: self.data.lambda.clone(),
        })
    }

    /// [`Self::eval_columns`] into `f` and `dx` (resized only when their shapes change) on the
    /// evaluator's buffers, with `names` the controller parameters' names of `params`
    /// ([`controller_names`]); `∂λ/∂x X + ∂λ/∂p` is left in `self.cols.dlambda` and `λ` in
    /// `self.data`. Allocates nothing once the buffers are sized.
    pub(super) fn eval_columns_into(
        &mut self,
        at: FlowPoint,
        x: &DMatrix<f64>,
        params: &[Parameter],
        names: &[&str],
        f: &mut DVector<f64>,
        dx: &mut DMatrix<f64>,
    ) -> Result<(), SensitivityError> {
        let FlowPoint {
            ctrl,
            locked,
            t,
            mode,
            y,
            ..
        } = at;
        let (model, nq, n) = (self.model, self.model.nq(), self.model.n_joints());
        let (q, qd) = y.split_at(nq);
        let mut slot = std::mem::take(&mut self.cols.partials);
        let mut free_joints = std::mem::take(&mut self.cols.free_joints);
        let k = names.len();
        let r = self.prepare_controller(at, &mut slot, &mut free_joints, k);
        let cb = &mut self.cols;
        (cb.partials, cb.free_joints) = (slot, free_joints);
        r?;
        let free_joints = &cb.free_joints;
        let p = cb.partials.as_mut().expect("set by prepare_controller");
        let point = ControlPoint::new(t, q, qd, mode).with_free_joints(free_joints);
        if !ctrl.parameter_partials(&point, names, p) {
            return Err(SensitivityError::UnknownParameter {
                name: names.join(", "),
                t,
            });
        }
        forward_dynamics_prepared(model, &mut self.data, &self.tau, Some(&self.free))
            .map_err(TangentError::from)?;
        let m = x.ncols();
        let nd = m - params.len();
        fit(&mut cb.dq, nq, m);
        fit(&mut cb.dqd, nq, m);
        for j in 0..m {
            let xj = &x.as_slice()[j * 2 * nq..(j + 1) * 2 * nq];
            cb.dq.as_mut_slice()[j * nq..(j + 1) * nq].copy_from_slice(&xj[..nq]);
            cb.dqd.as_mut_slice()[j * nq..(j + 1) * nq].copy_from_slice(&xj[nq..]);
        }
        // `∂Υ/∂q δq + ∂Υ/∂q̇ δq̇`, the products and their sum as nalgebra forms them
        fit(&mut cb.dtau, n, m);
        fit(&mut cb.dtau2, n, m);
        gemm_pair(
            &mut cb.dtau,
            &mut cb.dtau2,
            (&p.dtau.dq, &cb.dq),
            (&p.dtau.dqd, &cb.dqd),
        );
        let nf = free_joints.len();
        fit(&mut cb.dfree, nf, m);
        fit(&mut cb.dfree2, nf, m);
        gemm_pair(
            &mut cb.dfree,
            &mut cb.dfree2,
            (&p.dfree.dq, &cb.dq),
            (&p.dfree.dqd, &cb.dqd),
        );
        if self.memory_mode {
            let tangents = (&mut cb.mem, &mut cb.dtau, &mut cb.dfree);
            add_memory_tangents(tangents, free_joints, &self.memory, at, n)?;
        }
        cb.body.clear();
        cb.body.resize(m, None);
        let mut ci = 0;
        let mut with_force = false;
        for (k, par) in params.iter().enumerate() {
            match par {
                Parameter::Body(b) => cb.body[nd + k] = Some(*b),
                Parameter::Controller(_) => {
                    cb.dtau
                        .column_mut(nd + k)
                        .axpy(1.0, &p.dtau_dp.column(ci), 1.0);
                    cb.dfree
                        .column_mut(nd + k)
                        .axpy(1.0, &p.dfree_dp.column(ci), 1.0);
                    ci += 1;
                }
                Parameter::Friction {
                    contact,
                    coefficient,
                } if coefficient.moves_kinetic() => {
                    if !with_force {
                        fit(&mut cb.force, nq, m);
                        cb.force.fill(0.0);
                        with_force = true;
                    }
                    kinetic_friction_force(&self.data, *contact, &mut cb.force, nd + k);
                }
                // the static μ enters the slip guard only; δt the impact's selection only
                Parameter::Friction { .. } | Parameter::PseudoImpulseDuration => {}
            }
        }
        let dirs = FlowDirections {
            dq: &cb.dq,
            dqd: &cb.dqd,
            dtau: &cb.dtau,
            body: &cb.body,
            force: with_force.then_some(&cb.force),
        };
        dynamics_jvp_into(
            model,
            &mut self.data,
            qd,
            &dirs,
            &mut cb.jvp,
            &mut cb.dqdd,
            &mut cb.dlambda,
        )?;
        for (i, &j) in free_joints.iter().enumerate() {
            if !locked.contains(&j) {
                cb.dqdd.set_row(j, &cb.dfree.row(i));
            }
        }
        fit(dx, 2 * nq, m);
        for ((dxj, dqdj), dqddj) in dx
            .as_mut_slice()
            .chunks_exact_mut(2 * nq)
            .zip(cb.dqd.as_slice().chunks_exact(nq))
            .zip(cb.dqdd.as_slice().chunks_exact(nq))
        {
            dxj[..nq].copy_from_slice(dqdj);
            dxj[nq..].copy_from_slice(dqddj);
        }
        fit_vec(f, 2 * nq);
        f.as_mut_slice()[..nq].copy_from_slice(qd);
        f.as_mut_slice()[nq..].copy_from_slice(self.data.qdd.as_slice());
        Ok(())
    }
}

/// The remembered events' tangents `∂Υ/∂m_k Dm_k` added to the columns' torque and free
/// joints' tangents `dtau`, `dfree`: the controller's memory partials at `at` (into `mem`)
/// times the tangents of the events it remembers (`memory`), for `n` joints.
fn add_memory_tangents(
    (mem, dtau, dfree): (
        &mut Vec<EventMemoryPartials>,
        &mut DMatrix<f64>,
        &mut DMatrix<f64>,
    ),
    free_joints: &[usize],
    memory: &[DMatrix<f64>],
    at: FlowPoint,
    n: usize,
) -> Result<(), SensitivityError> {
    let FlowPoint {
        ctrl, t, mode, y, ..
    } = at;
    let nq = y.len() / 2;
    let (q, qd) = y.split_at(nq);
    // the remembered events' tangents force every column: `∂Υ/∂m_k Dm_k`
    mem.clear();
    let point = ControlPoint::new(t, q, qd, mode).with_free_joints(free_joints);
    if !ctrl.memory_partials(&point, mem) {
        return Err(SensitivityError::EventMemoryWithoutPartials {
            t,
            reason: "the controller gives no memory partials".into(),
        });
    }
    for mp in mem.iter() {
        let cols = 1 + 2 * nq;
        if mp.dtau.shape() != (n, cols) || mp.dfree.shape() != (free_joints.len(), cols) {
            return Err(SensitivityError::EventMemoryWithoutPartials {
                t,
                reason: format!(
                    "memory partials of event {} sized {:?} and {:?}, not {:?} and {:?}",
                    mp.event,
                    mp.dtau.shape(),
                    mp.dfree.shape(),
                    (n, cols),
                    (free_joints.len(), cols)
                ),
            });
        }
        let Some(d) = memory.get(mp.event) else {
            return Err(SensitivityError::EventMemoryWithoutPartials {
                t,
                reason: format!("event {} is not one the run recorded", mp.event),
            });
        };
        dtau.gemm(1.0, &mp.dtau, d, 1.0);
        dfree.gemm(1.0, &mp.dfree, d, 1.0);
    }
    Ok(())
}

/// `out = a₁ b₁ + a₂ b₂` with `tmp` a buffer of `out`'s shape: bit for bit what
/// `out.gemm(1, a₁, b₁, 0); tmp.gemm(1, a₂, b₂, 0); out += tmp` gives, without nalgebra's
/// generic loops for the small products the stages form (nalgebra's small-size `gemm` sums
/// `a_ik b_kj` over `k` in order, starting from the first product; for larger ones, which
/// it hands to `matrixmultiply`, its own `gemm` is called).
fn gemm_pair(
    out: &mut DMatrix<f64>,
    tmp: &mut DMatrix<f64>,
    (a1, b1): (&DMatrix<f64>, &DMatrix<f64>),
    (a2, b2): (&DMatrix<f64>, &DMatrix<f64>),
) {
    const SMALL_DIM: usize = 5;
    let big = |a: &DMatrix<f64>| {
        out.nrows() > SMALL_DIM
            && out.ncols() > SMALL_DIM
            && a.nrows() > SMALL_DIM
            && a.ncols() > SMALL_DIM
    };
    if big(a1) || big(a2) || a1.ncols() == 0 || a2.ncols() == 0 {
        out.gemm(1.0, a1, b1, 0.0);
        tmp.gemm(1.0, a2, b2, 0.0);
        *out += &*tmp;
        return;
    }
    let r = out.nrows();
    let (k1, k2) = (a1.ncols(), a2.ncols());
    let (a1, b1, a2, b2) = (a1.as_slice(), b1.as_slice(), a2.as_slice(), b2.as_slice());
    if r == 0 {
        return;
    }
    // entry by entry, in the order of nalgebra's `gemv`: `s = a_i0 b_0j`, then
    // `s = a_ik b_kj + s` for k = 1, 2, …; then `o = s₁ + s₂`
    let dot = |a: &[f64], bj: &[f64], i: usize| {
        let mut s = a[i] * bj[0];
        let mut idx = i;
        for &bk in &bj[1..] {
            idx += r;
            s += a[idx] * bk;
        }
        s
    };
    for ((oj, b1j), b2j) in out
        .as_mut_slice()
        .chunks_exact_mut(r)
        .zip(b1.chunks_exact(k1))
        .zip(b2.chunks_exact(k2))
    {
        for (i, o) in oj.iter_mut().enumerate() {
            *o = dot(a1, b1j, i) + dot(a2, b2j, i);
        }
    }
}

/// `∂Q^fr/∂μ_k` of contact `contact`'s sliding sites at the state `data` was solved at
/// (after [`forward_dynamics_prepared`]), into column `col` of `force`: the derivative of
/// the Coulomb force on the cone's edge with respect to the kinetic coefficient, a
/// generalized force direction of the flow's tangent (`selfmanip_core::tangent`'s
/// `FlowDirections::force`). The force of a site sliding with direction `σ` lies on the
/// edge `n + μ_kσ t` ([`selfmanip_core::friction`]), so `μ_k` enters where `μ_kσ` does:
///
/// - a general site, folded into the solve: its row of `B` in `K' = [M̄ (A + B)ᵀ; A 0]` is
///   `μ_kσ A_t`, so `∂B/∂μ_k = σ A_t` and `K' δz = −[(∂B/∂μ_k)ᵀ λ_n; 0]`: the force
///   direction `δQ = −σ λ_n A_tᵀ`;
/// - a single-joint massless leg's site, resolved by the leg's statics: `f^fr = −μ_kσ λ_n
///   A_tᵀ`, `λ_n = f_j/den`, `den = (A_n)_j + μ_kσ (A_t)_j`, so `∂λ_n/∂μ_k = −λ_n σ
///   (A_t)_j/den` and `δQ = ∂f^fr/∂μ_k = −σ λ_n ((A_n)_j/den) A_tᵀ`.
///
/// A site at rest or wedged has a sticking force (no `μ_k` in it); its flow is not
/// differentiated anyway (`TangentError::FrictionAtRest`).
fn kinetic_friction_force(data: &Data, contact: usize, force: &mut DMatrix<f64>, col: usize) {
    let cons = &data.constraints;
    let c = cons.n_rows();
    for site in data.sliding.iter().filter(|s| s.contact == contact) {
        if site.held.is_some() || site.at_rest || site.wedged || site.coef == 0.0 {
            continue;
        }
        let sigma = site.sigma;
        let scale = if site.general {
            -sigma * data.lambda[site.row]
        } else {
            let lambda_n = site.force_t / site.coef;
            let a_t_j: f64 = site
                .a_t
                .iter()
                .filter(|(k, _)| *k == site.joint)
                .map(|(_, v)| v)
                .sum();
            let a_nj = cons.a.as_slice()[site.joint * c + site.row];
            let den = a_nj + site.coef * a_t_j;
            -sigma * lambda_n * a_nj / den
        };
        for &(k, v) in &site.a_t {
            force[(k, col)] += scale * v;
        }
    }
}

/// The names of the controller parameters among `params`, in order.
pub(super) fn controller_names(params: &[Parameter]) -> Vec<&str> {
    params
        .iter()
        .filter_map(|p| match p {
            Parameter::Controller(n) => Some(n.as_str()),
            _ => None,
        })
        .collect()
}
