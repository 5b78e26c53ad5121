//! Sensitivities of an execution to its initial state and to named parameters: the
//! variational equations along each flow, the saltation matrix at each event, and their
//! chain rule
//! `dx(t_f)/dx(0) = Φ_k Ξ_k ⋯ Φ_1 Ξ_1 Φ_0` over the state `x = (q, q̇)` (dimension `2 nq`).
//!
//! **Variational equations.** Along a segment in mode `J`, `ẋ = f(t, x) = (q̇, q̈)` with
//! `q̈` from (5.3)–(5.4) at the controller's `Υ(t, q, q̇)`; its Jacobian
//! `F = [[0, I], [∂q̈/∂q, ∂q̈/∂q̇]]` comes from the exact derivatives of
//! [`selfmanip_core::tangent`] and the controller's own ([`Controller::partials`]), and
//! `Φ̇ = F Φ`. Free massless joints (thesis 5.1.1) are states like any other: their `q̈` is
//! the controller's prescription, so their rows of `F` are its partials (zero for the
//! default prescription `q̈ = 0`); locked joints (a fold passage) have `q̈ = 0`.
//!
//! `Φ` is integrated *on the execution's own DOPRI5 steps*: for every accepted step of the
//! record, from its start state, the same Butcher tableau gives the state's stages and, with
//! `F` at those stages, the stages of `Φ` (internal differentiation: `Φ` is the derivative of
//! the step map the engine applied, the step sizes held fixed). The last step of a segment,
//! which the engine cut at its event by dense output, is taken from its start to the event.
//! The sensitivity states are **excluded from step-size control**, for three reasons: the
//! execution is then bit-identical with or without sensitivities (it is computed first,
//! unchanged); `Φ` solves a linear equation whose coefficients are as smooth as the state's
//! flow, so the state's steps resolve it to the same order; and the derivative of the step
//! map with the step sequence frozen is the quantity a finite difference of whole executions
//! converges to when perturbations do not change the step sequence's smoothness.
//!
//! **Saltation.** At an event with guard `g` and reset `R`:
//! `Ξ = D_xR + (f⁺ − D_xR f⁻) D_xg / (D_xg f⁻)`, with `f⁻`, `f⁺` the flows before and after
//! (each with its segment's controller, locked joints and fixed sliding directions of its
//! Coulomb-sliding sites: the flow and its Jacobian include the kinetic friction force and
//! the passive springs, [`selfmanip_core::tangent`]). Touchdown: `g` the contact's height
//! (5.49), `R` the plastic impact (5.10)/(5.52) into the mode the event took — or into a
//! larger set whose extra contacts force complementarity (5.19)–(5.20) released at once (a
//! contact of the mode before, the contact that touched down, or a sliding toe that the
//! impact stuck), whichever reproduces the recorded `q̇⁺` (else the event is flagged) — with
//! its Jacobian from [`selfmanip_core::tangent::plastic_impact_jacobian`]; the pseudo-impulse
//! (5.39) only selects that mode, it does not change `q̇⁺`. Liftoff: `g = −λ_n` (5.50),
//! `R = I`. Slip: `g = μ(−λ_n) − |λ_t|`, `R = I`. Stick: `g` the sliding velocity, `R = I`.
//! Where a force event's reset projected the integrator's drift away (`crate::reset`: at a
//! slip, or a liftoff whose contact's slip guard fired with it as its cone shrank to a
//! point), `R` is that plastic impact into the mode before and `D_xR` its Jacobian
//! ([`DRIFT_JUMP_TOL`]); any other velocity jump at a force event is flagged. Apex (terminal):
//! `g = −ż`, and the end state is the state at the apex, `Ξ = I − f⁻ D_xg / (D_xg f⁻)`.
//! Each event also gives its time's gradient `dt_e/dx(0) = −D_xg X⁻ / (D_xg f⁻)`. An
//! active arc whose rolling contact reaches the arc's end inside a segment (no event, but
//! `Ȧ`, hence `q̈`, changes form there) gets a saltation of its own ([`TouchSwitch`]).
//!
//! **Kinks of the controller's law** (a servo's saturation, a motor's current limit: the
//! outputs continuous, their partials not; [`Controller::partials_piece`]) need no saltation
//! (`f⁺ = f⁻`), but a step that straddles one integrates `Ẋ = F X` only to first order in the
//! step (the quadrature weights the jump of `F` by the tableau's `b_i`, not by the kink's
//! place). The tangent's steps are split there as at a touch switch — the change bracketed
//! on the dense output to a few ulps — and a stage of the two sub-steps that the tableau put
//! past the kink takes the record's state at its time, so that every stage has its side's
//! partials (`docs/sensitivity.md`, "Kinks of a controller's law").
//!
//! **Where Ξ is not defined** the event says so ([`SaltationStatus`]) instead of carrying a
//! number: grazing (`|D_xg f⁻|` below [`GRAZING_TOL`] relative to `|D_xg| |f⁻|`), several
//! guards at once or a mode held for zero time (two orders of simultaneous events may give
//! different outcomes: the Bouligand derivative is not formed yet), and events not covered
//! yet (folds, a fold passage's end, a segment that ended on a terrain feature change).
//! [`Sensitivity::state_jacobian`] is then `None`.
//!
//! **Parameters and selected columns** ([`execution_sensitivity_columns`]): named parameters
//! `p` are constant states (`x̃ = (x, p)`, `ṗ = 0`), so the same variational equations and
//! saltation matrices carry `X_p = dx/dp`: along a flow `Ẋ_p = F X_p + ∂f/∂p`; at an event
//! `X_p⁺ = Ξ X_p + D_pR + (f⁺ − D_xR f⁻) D_pg / (D_xg f⁻)` and
//! `dt_e/dp = −(D_xg X_p + D_pg)/(D_xg f⁻)`. `∂f/∂p` comes from the controller
//! ([`Controller::parameter_partials`], through `∂q̈/∂Υ`) or, for the body's mass and
//! inertia, from `∂M̄/∂p`, `∂N̄/∂p` by implicit differentiation of the KKT system; `D_pg` of
//! a force guard from `∂λ/∂p`; `D_pR` of a plastic impact from `∂M̄/∂p`. A controller's
//! **time events** ([`Controller::time_events`], e.g. a motor switched on at `t2`) add
//! `(f⁻ − f⁺) dt_b/dp` where the flow jumps; the tangent is split at them (and `∂f/∂p` may
//! jump there even when `f` does not). Only the columns asked for are propagated, by
//! Jacobian-times-matrix products ([`selfmanip_core::tangent::dynamics_jvp`]): never the
//! full `2nq × 2nq` matrices along the flows.
//!
//! **A controller's memory of events** ([`Controller::has_event_memory`]: a motion started
//! from an event's state, a phase that starts a delay after an event) is part of the tangent:
//! the memory is the remembered events' `(t_k, x_k⁺)`, whose tangents
//! `M_k = (Dt_k, X⁺ + f⁺ Dt_k)` the columns carry; along a flow `Ẋ = F X + ∂f/∂m M`
//! ([`Controller::memory_partials`]), at an event `Dt_e = −(D_xg X + D_mg M)/ġ` and
//! `X⁺ = Ξ X + (f⁺ − D_xR f⁻) D_mg M / ġ`, at a time event whose instant moves with the memory
//! `X += (f⁻ − f⁺) dt_b/dm M` ([`Controller::memory_time_events`]). A force guard's rate
//! `ġ = D_xg f⁻ + ∂g/∂t` includes the torques' explicit time dependence
//! ([`Controller::time_partials`], or a central difference of the torques in time when not
//! given). [`execution_sensitivity`] takes its
//! state Jacobian and event time gradients from the columns when a controller has memory;
//! a controller with memory and no memory partials is a typed error
//! ([`SensitivityError::EventMemoryWithoutPartials`]). `docs/sensitivity.md` derives it.
//!
//! **Not covered yet.** A run whose state sits on a guard that does not fire — a contact set
//! chosen at a complementarity boundary, e.g. a sliding contact started at zero sliding
//! velocity — gets the one-sided derivative of the sequence it realised, unflagged;
//! controllers without [`Controller::partials`] (the generic actuator models of
//! [`crate::Actuated`]) stop with a typed error; a controller with event memory that does not
//! say so ([`Controller::has_event_memory`] false, the default — the RHex leap controller
//! for a massless leg whose motion ends in the air, where it acts on nothing) is
//! differentiated with that memory held fixed.
use crate::controller::{Controller, ControllerPartials, EventMemoryPartials, TimeEvent};
use crate::error::HybridError;
use crate::event::{Event, EventKind};
use crate::execution::{Execution, Segment, Termination};
use crate::integrate::{A as RK_A, C as RK_C};
use crate::options::HybridOptions;
use crate::simulate::simulate;
use nalgebra::{DMatrix, DVector, RowDVector};
use selfmanip_core::contact::{contact_geometry, ContactKind, RowDirection, TouchKind};
use selfmanip_core::friction::SlideDirection;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::model::Friction;
use selfmanip_core::tangent::{
    dynamics_jacobian_solved_into, dynamics_jvp_into, height_gradient,
    plastic_impact_body_derivatives, plastic_impact_jacobian, sliding_velocity_gradient,
    BodyParameter, DynamicsJacobian, FlowDirections, JacobianWorkspace, JvpWorkspace, TangentError,
};
use selfmanip_core::{forward_dynamics_prepared, ContactMode, Data, Model, Terrain};

/// Relative transversality `|D_xg f⁻| / (|D_xg| |f⁻|)` below which an event is grazing.
pub const GRAZING_TOL: f64 = 1e-8;

/// Why sensitivities could not be computed at all.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SensitivityError {
    #[error(transparent)]
    Hybrid(#[from] HybridError),
    #[error(transparent)]
    Tangent(#[from] TangentError),
    /// A segment's controller does not give its partial derivatives.
    #[error("the controller of the segment starting at t = {t} s gives no partial derivatives")]
    ControllerWithoutPartials { t: f64 },
    /// A parameter name that the segment's controller does not know.
    #[error(
        "parameter `{name}` is not a parameter of the controller (segment starting at t = {t} s)"
    )]
    UnknownParameter { name: String, t: f64 },
    /// A segment's controller remembers the time or state of an event
    /// ([`Controller::has_event_memory`]) but does not give the partial derivatives of its
    /// outputs with respect to them ([`Controller::memory_partials`]), or refers to an event
    /// the execution did not record: holding that memory fixed would give a wrong derivative.
    #[error(
        "the controller at t = {t} s remembers events' times or states but gives no partial \
         derivatives with respect to them ({reason})"
    )]
    EventMemoryWithoutPartials { t: f64, reason: String },
}

/// Whether an event's saltation matrix is defined.
#[derive(Debug, Clone, PartialEq)]
pub enum SaltationStatus {
    Defined,
    /// The flow meets the guard tangentially: `D_xg f⁻ ≈ 0` (relative value given).
    Grazing {
        transversality: f64,
    },
    /// Several guards fired at once, or the event's neighbouring mode lasted zero time: the
    /// outcome may depend on the order (one-sided and Bouligand derivatives not formed yet).
    Simultaneous,
    /// An event kind or situation not differentiated yet.
    Unsupported {
        reason: String,
    },
}

impl SaltationStatus {
    /// The status's name (`defined`, `grazing`, `simultaneous`, `unsupported`).
    pub fn name(&self) -> &'static str {
        match self {
            SaltationStatus::Defined => "defined",
            SaltationStatus::Grazing { .. } => "grazing",
            SaltationStatus::Simultaneous => "simultaneous",
            SaltationStatus::Unsupported { .. } => "unsupported",
        }
    }

    /// Why the saltation matrix is not defined, in words (`None` when it is).
    pub fn reason(&self) -> Option<String> {
        match self {
            SaltationStatus::Defined => None,
            SaltationStatus::Grazing { transversality } => Some(format!(
                "the flow meets the guard tangentially (|D_xg f| / (|D_xg| |f|) = \
                 {transversality:e})"
            )),
            SaltationStatus::Simultaneous => {
                Some("several guards at once, or a mode held for zero time".to_string())
            }
            SaltationStatus::Unsupported { reason } => Some(reason.clone()),
        }
    }
}

/// The sensitivity of one event.
#[derive(Debug, Clone, PartialEq)]
pub struct EventSensitivity {
    pub t: f64,
    pub kind: EventKind,
    pub status: SaltationStatus,
    /// `Ξ` (`2nq × 2nq`) when defined.
    pub saltation: Option<DMatrix<f64>>,
    /// `D_xg` of the guard that fired (when a single guard fired).
    pub guard_gradient: Option<RowDVector<f64>>,
    /// `dt_e / dx(0)` when defined.
    pub time_gradient: Option<RowDVector<f64>>,
    /// For a touchdown, the mode of the plastic impact the reset applied: the mode after,
    /// or a larger set whose extra contacts force complementarity released at once.
    pub impact_mode: Option<ContactMode>,
}

/// Sensitivities of an execution to its initial state `x(0) = (q0, q̇0)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivity {
    /// `Φ` of each segment (`2nq × 2nq`; the identity for a segment of zero duration), with
    /// the controller's event memory held fixed (when a controller has memory, the state
    /// Jacobian is not their product with the saltations: see the module docs).
    pub segment_flows: Vec<DMatrix<f64>>,
    /// One entry per event of the execution, in order.
    pub events: Vec<EventSensitivity>,
    /// Switches between an arc's rolling and its end's point touch inside segments, in
    /// order ([`TouchSwitch`]); their saltation matrices are part of `segment_flows`.
    pub touch_switches: Vec<TouchSwitch>,
    /// Segment ends without an event (terrain feature changes), by segment index: not
    /// differentiated yet.
    pub feature_changes: Vec<usize>,
    /// `dx(t_end)/dx(0)`, `None` unless every event's saltation is defined and the run ended
    /// at its final time or at the apex (a run cut by its event budget ends on an event
    /// with no flow after it, whose saltation is not formed).
    pub state_jacobian: Option<DMatrix<f64>>,
}

/// Runs [`simulate`] and then [`execution_sensitivity`] on its result. The execution is
/// the one [`simulate`] returns, bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn simulate_with_sensitivity(
    model: &Model,
    terrain: &dyn Terrain,
    controller: &dyn Controller,
    mode0: ContactMode,
    q0: &[f64],
    qd0: &[f64],
    t_final: f64,
    opts: HybridOptions,
) -> Result<(Execution, Sensitivity), SensitivityError> {
    let exec = simulate(model, terrain, controller, mode0, q0, qd0, t_final, opts)?;
    let s = execution_sensitivity(model, terrain, &exec)?;
    Ok((exec, s))
}

/// The flow and its Jacobian at one state.
#[derive(Clone, Default)]
struct FlowJacobian {
    /// `f = (q̇, q̈)`.
    f: DVector<f64>,
    /// `F = ∂f/∂x`.
    jac: DMatrix<f64>,
    /// `∂λ/∂x` (rows of the mode) and `λ`.
    dlambda: DMatrix<f64>,
    lambda: DVector<f64>,
    /// `∂λ/∂Υ`: a force event's rate takes `∂λ/∂t = ∂λ/∂Υ ∂Υ/∂t` from it
    /// ([`torque_time_derivative`]), formed at the event only.
    dlambda_dtau: DMatrix<f64>,
}

/// Evaluates flows and their Jacobians on a workspace of its own.
struct Evaluator<'a> {
    model: &'a Model,
    terrain: &'a dyn Terrain,
    data: Data,
    tau: Vec<f64>,
    free: Vec<f64>,
    kin: Kinematics,
    /// The buffers of [`Self::eval_columns_into`] and of [`Tangent::step`]'s stages, kept
    /// across evaluations so that a step allocates nothing once they are sized.
    cols: ColumnBuffers,
    stages: StageBuffers,
    /// The buffers of [`Self::eval_into`] and its result.
    full: FullBuffers,
    /// Whether the controllers' event memory is differentiated (some segment's controller
    /// has it, [`Controller::has_event_memory`]); then `memory[k]` holds
    /// `d(t_k, q_k, q̇_k⁺)/d(columns)` (`(1 + 2nq) × m`) of the `k`-th event the controllers
    /// were told of.
    memory_mode: bool,
    memory: Vec<DMatrix<f64>>,
}

/// The reusable buffers of one [`Evaluator::eval_into`] (the full Jacobian), and its result.
#[derive(Default)]
struct FullBuffers {
    partials: Option<ControllerPartials>,
    free_joints: Vec<usize>,
    ws: JacobianWorkspace,
    dj: DynamicsJacobian,
    dqdd_dq: DMatrix<f64>,
    dqdd_dqd: DMatrix<f64>,
    /// `∂λ/∂Υ ∂Υ/∂q` and `∂λ/∂Υ ∂Υ/∂q̇`.
    dl_q: DMatrix<f64>,
    dl_qd: DMatrix<f64>,
    /// The flow and its Jacobian at the last state evaluated.
    out: FlowJacobian,
}

/// The reusable buffers of one [`Evaluator::eval_columns_into`].
#[derive(Default)]
struct ColumnBuffers {
    partials: Option<ControllerPartials>,
    free_joints: Vec<usize>,
    dq: DMatrix<f64>,
    dqd: DMatrix<f64>,
    dtau: DMatrix<f64>,
    dtau2: DMatrix<f64>,
    dfree: DMatrix<f64>,
    dfree2: DMatrix<f64>,
    body: Vec<Option<BodyParameter>>,
    dqdd: DMatrix<f64>,
    /// `∂λ/∂x X + ∂λ/∂p` of the last evaluation, `c × m`.
    dlambda: DMatrix<f64>,
    jvp: JvpWorkspace,
    /// The controller's memory partials of the last evaluation.
    mem: Vec<EventMemoryPartials>,
}

/// The stages of one [`Tangent::step`]: their flows, their tangents, and the stage state.
#[derive(Default)]
struct StageBuffers {
    k: Vec<DVector<f64>>,
    kphi: Vec<DMatrix<f64>>,
    ys: DVector<f64>,
    ps: DMatrix<f64>,
}

/// `a` shaped `r × c`, reallocated only when its shape changes (its entries are to be
/// overwritten).
fn fit(a: &mut DMatrix<f64>, r: usize, c: usize) {
    if a.shape() != (r, c) {
        *a = DMatrix::zeros(r, c);
    }
}

/// `v` of length `n`, reallocated only when its length changes (its entries are to be
/// overwritten).
fn fit_vec(v: &mut DVector<f64>, n: usize) {
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
        p.dtau_dq.shape() == (n, nq)
            && p.dfree_dq.shape() == (n_free, nq)
            && p.dtau_dp.shape() == (n, k)
    });
    if fits {
        let p = slot.as_mut().expect("checked");
        for a in [
            &mut p.dtau_dq,
            &mut p.dtau_dqd,
            &mut p.dfree_dq,
            &mut p.dfree_dqd,
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
    fn new(model: &'a Model, terrain: &'a dyn Terrain) -> Self {
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
    fn touches(&mut self, mode: ContactMode, y: &[f64]) -> Vec<(usize, TouchKind)> {
        let mut out = Vec::new();
        self.touches_into(mode, y, &mut out);
        out
    }

    /// [`Self::touches`] into `out` (cleared first; no allocation once it is large enough).
    fn touches_into(&mut self, mode: ContactMode, y: &[f64], out: &mut Vec<(usize, TouchKind)>) {
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

    /// The flow of `mode` at `(t, y)` under `ctrl` with `locked` joints, and its Jacobian
    /// (a copy of [`Self::eval_into`]'s result).
    fn eval(
        &mut self,
        ctrl: &dyn Controller,
        locked: &[usize],
        dirs: &[(usize, SlideDirection)],
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<FlowJacobian, SensitivityError> {
        self.eval_into(ctrl, locked, dirs, t, mode, y)?;
        Ok(self.full.out.clone())
    }

    /// Prepares `self.data` at `(mode, y)` with `locked` joints and the sliding directions
    /// `dirs`, and evaluates the controller's torques and free joints' accelerations there
    /// (into `self.tau`, `self.free`) and its state partials (into `slot`, `k` parameter
    /// columns zeroed); the free joints are left in `free_joints`. What every evaluation
    /// starts with.
    #[allow(clippy::too_many_arguments)]
    fn prepare_controller(
        &mut self,
        ctrl: &dyn Controller,
        locked: &[usize],
        dirs: &[(usize, SlideDirection)],
        t: f64,
        mode: ContactMode,
        y: &[f64],
        slot: &mut Option<ControllerPartials>,
        free_joints: &mut Vec<usize>,
        k: usize,
    ) -> Result<(), SensitivityError> {
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
        ctrl.torque(t, q, qd, mode, &mut self.tau);
        self.free.resize(free_joints.len(), 0.0);
        ctrl.free_joint_qdd(t, q, qd, free_joints, &mut self.free);
        for (x, j) in self.free.iter_mut().zip(free_joints.iter()) {
            if locked.contains(j) {
                *x = 0.0;
            }
        }
        let p = zero_partials(slot, n, nq, free_joints.len(), k);
        if !ctrl.partials(t, q, qd, mode, free_joints, p) {
            return Err(SensitivityError::ControllerWithoutPartials { t });
        }
        Ok(())
    }

    /// The flow `f = (q̇, q̈)` of `mode` at `(t, y)` alone: [`Self::eval`]'s `f`, bit for bit,
    /// without the Jacobian (a time event's or a switch's jump, the flow after an event).
    fn flow(
        &mut self,
        ctrl: &dyn Controller,
        locked: &[usize],
        dirs: &[(usize, SlideDirection)],
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<DVector<f64>, SensitivityError> {
        let nq = self.model.nq();
        let mut fb = std::mem::take(&mut self.full);
        let r = self.solve_flow(&mut fb, ctrl, locked, dirs, t, mode, y);
        self.full = fb;
        r?;
        let mut f = DVector::zeros(2 * nq);
        f.rows_mut(0, nq).copy_from_slice(&y[nq..]);
        f.rows_mut(nq, nq).copy_from(&self.data.qdd);
        Ok(f)
    }

    /// The flow of `mode` at `(t, y)` under `ctrl` with `locked` joints, and its Jacobian,
    /// into `self.full.out` (on the evaluator's buffers: no allocation once they are sized).
    fn eval_into(
        &mut self,
        ctrl: &dyn Controller,
        locked: &[usize],
        dirs: &[(usize, SlideDirection)],
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<(), SensitivityError> {
        let mut fb = std::mem::take(&mut self.full);
        let r = self.eval_on(&mut fb, ctrl, locked, dirs, t, mode, y);
        self.full = fb;
        r
    }

    /// [`Self::prepare_controller`] on the buffers `fb` and the forward dynamics (`q̈` and
    /// `λ` in `self.data`), with the controller's state partials in `fb.partials`.
    #[allow(clippy::too_many_arguments)]
    fn solve_flow(
        &mut self,
        fb: &mut FullBuffers,
        ctrl: &dyn Controller,
        locked: &[usize],
        dirs: &[(usize, SlideDirection)],
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<(), SensitivityError> {
        let (slot, free_joints) = (&mut fb.partials, &mut fb.free_joints);
        self.prepare_controller(ctrl, locked, dirs, t, mode, y, slot, free_joints, 0)?;
        forward_dynamics_prepared(self.model, &mut self.data, &self.tau, Some(&self.free))
            .map_err(TangentError::from)?;
        Ok(())
    }

    /// [`Self::eval_into`] on the buffers `fb` (taken out of `self` for the evaluation).
    #[allow(clippy::too_many_arguments)]
    fn eval_on(
        &mut self,
        fb: &mut FullBuffers,
        ctrl: &dyn Controller,
        locked: &[usize],
        dirs: &[(usize, SlideDirection)],
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<(), SensitivityError> {
        let (model, nq) = (self.model, self.model.nq());
        let qd = &y[nq..];
        self.solve_flow(fb, ctrl, locked, dirs, t, mode, y)?;
        let p = fb.partials.as_ref().expect("set by prepare_controller");
        dynamics_jacobian_solved_into(model, &mut self.data, qd, &mut fb.ws, &mut fb.dj)?;
        let dj = &fb.dj;
        // the same products and sums as `∂q̈/∂q + ∂q̈/∂Υ ∂Υ/∂q` formed by value
        let c = dj.dlambda_dq.nrows();
        fit(&mut fb.dqdd_dq, nq, nq);
        fb.dqdd_dq.gemm(1.0, &dj.dqdd_dtau, &p.dtau_dq, 0.0);
        fb.dqdd_dq += &dj.dqdd_dq;
        fit(&mut fb.dqdd_dqd, nq, nq);
        fb.dqdd_dqd.gemm(1.0, &dj.dqdd_dtau, &p.dtau_dqd, 0.0);
        fb.dqdd_dqd += &dj.dqdd_dqd;
        for (i, &j) in fb.free_joints.iter().enumerate() {
            if !locked.contains(&j) {
                fb.dqdd_dq.set_row(j, &p.dfree_dq.row(i));
                fb.dqdd_dqd.set_row(j, &p.dfree_dqd.row(i));
            }
        }
        let out = &mut fb.out;
        fit(&mut out.jac, 2 * nq, 2 * nq);
        out.jac.fill(0.0);
        for i in 0..nq {
            out.jac[(i, nq + i)] = 1.0;
        }
        out.jac.view_mut((nq, 0), (nq, nq)).copy_from(&fb.dqdd_dq);
        out.jac.view_mut((nq, nq), (nq, nq)).copy_from(&fb.dqdd_dqd);
        fit(&mut fb.dl_q, c, nq);
        fb.dl_q.gemm(1.0, &dj.dlambda_dtau, &p.dtau_dq, 0.0);
        fb.dl_q += &dj.dlambda_dq;
        fit(&mut fb.dl_qd, c, nq);
        fb.dl_qd.gemm(1.0, &dj.dlambda_dtau, &p.dtau_dqd, 0.0);
        fb.dl_qd += &dj.dlambda_dqd;
        fit(&mut out.dlambda, c, 2 * nq);
        out.dlambda.view_mut((0, 0), (c, nq)).copy_from(&fb.dl_q);
        out.dlambda.view_mut((0, nq), (c, nq)).copy_from(&fb.dl_qd);
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
fn torque_time_derivative(
    ctrl: &dyn Controller,
    n: usize,
    t: f64,
    (q, qd): (&[f64], &[f64]),
    mode: ContactMode,
) -> DVector<f64> {
    let mut out = DVector::zeros(n);
    if ctrl.time_partials(t, q, qd, mode, out.as_mut_slice()) {
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
struct FlowColumns {
    /// `∂λ/∂x X + ∂λ/∂p`, `c × m`.
    dlambda: DMatrix<f64>,
    lambda: DVector<f64>,
}

impl Evaluator<'_> {
    /// The multipliers of `mode` at `(t, y)` and their tangent along the columns of `x`
    /// (`2nq × m`), whose last `params.len()` columns are the parameters' (see [`Tangent`]),
    /// by [`Self::eval_columns_into`].
    #[allow(clippy::too_many_arguments)]
    fn eval_columns(
        &mut self,
        ctrl: &dyn Controller,
        locked: &[usize],
        dirs: &[(usize, SlideDirection)],
        t: f64,
        mode: ContactMode,
        y: &[f64],
        x: &DMatrix<f64>,
        params: &[Parameter],
    ) -> Result<FlowColumns, SensitivityError> {
        let names = controller_names(params);
        let (mut f, mut dx) = (DVector::zeros(0), DMatrix::zeros(0, 0));
        self.eval_columns_into(
            ctrl, locked, dirs, t, mode, y, x, params, &names, &mut f, &mut dx,
        )?;
        Ok(FlowColumns {
            dlambda: self.cols.dlambda.clone(),
            lambda: self.data.lambda.clone(),
        })
    }

    /// [`Self::eval_columns`] into `f` and `dx` (resized only when their shapes change) on the
    /// evaluator's buffers, with `names` the controller parameters' names of `params`
    /// ([`controller_names`]); `∂λ/∂x X + ∂λ/∂p` is left in `self.cols.dlambda` and `λ` in
    /// `self.data`. Allocates nothing once the buffers are sized.
    #[allow(clippy::too_many_arguments)]
    fn eval_columns_into(
        &mut self,
        ctrl: &dyn Controller,
        locked: &[usize],
        dirs: &[(usize, SlideDirection)],
        t: f64,
        mode: ContactMode,
        y: &[f64],
        x: &DMatrix<f64>,
        params: &[Parameter],
        names: &[&str],
        f: &mut DVector<f64>,
        dx: &mut DMatrix<f64>,
    ) -> Result<(), SensitivityError> {
        let (model, nq, n) = (self.model, self.model.nq(), self.model.n_joints());
        let (q, qd) = y.split_at(nq);
        let mut slot = std::mem::take(&mut self.cols.partials);
        let mut free_joints = std::mem::take(&mut self.cols.free_joints);
        let k = names.len();
        let r = self.prepare_controller(
            ctrl,
            locked,
            dirs,
            t,
            mode,
            y,
            &mut slot,
            &mut free_joints,
            k,
        );
        let cb = &mut self.cols;
        (cb.partials, cb.free_joints) = (slot, free_joints);
        r?;
        let free_joints = &cb.free_joints;
        let p = cb.partials.as_mut().expect("set by prepare_controller");
        if !ctrl.parameter_partials(t, q, qd, mode, free_joints, names, p) {
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
            (&p.dtau_dq, &cb.dq),
            (&p.dtau_dqd, &cb.dqd),
        );
        let nf = free_joints.len();
        fit(&mut cb.dfree, nf, m);
        fit(&mut cb.dfree2, nf, m);
        gemm_pair(
            &mut cb.dfree,
            &mut cb.dfree2,
            (&p.dfree_dq, &cb.dq),
            (&p.dfree_dqd, &cb.dqd),
        );
        if self.memory_mode {
            // the remembered events' tangents force every column: `∂Υ/∂m_k Dm_k`
            cb.mem.clear();
            if !ctrl.memory_partials(t, q, qd, mode, free_joints, &mut cb.mem) {
                return Err(SensitivityError::EventMemoryWithoutPartials {
                    t,
                    reason: "the controller gives no memory partials".into(),
                });
            }
            for mp in &cb.mem {
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
                let Some(d) = self.memory.get(mp.event) else {
                    return Err(SensitivityError::EventMemoryWithoutPartials {
                        t,
                        reason: format!("event {} is not one the run recorded", mp.event),
                    });
                };
                cb.dtau.gemm(1.0, &mp.dtau, d, 1.0);
                cb.dfree.gemm(1.0, &mp.dfree, d, 1.0);
            }
        }
        cb.body.clear();
        cb.body.resize(m, None);
        let mut ci = 0;
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
            }
        }
        let dirs = FlowDirections {
            dq: &cb.dq,
            dqd: &cb.dqd,
            dtau: &cb.dtau,
            body: &cb.body,
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

/// A tangent step's smooth piece of the controller's law and the record's state at a time
/// (see [`Tangent::step`]).
type Hold<'a> = Option<(u64, &'a dyn Fn(f64, &mut [f64]))>;

/// What the variational equations carry along a segment: the full `Φ` (`2nq × 2nq`) of
/// [`execution_sensitivity`], or the selected columns `X` (`2nq × m`) of
/// [`execution_sensitivity_columns`], whose last `params.len()` columns are forced by
/// `∂f/∂p` (the parameters are constant states: `ṗ = 0`).
enum Tangent<'p> {
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
    fn salt(&mut self, xi: &DMatrix<f64>) {
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
    fn step(
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
    fn step_on(
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
                    ev.eval_into(
                        &*seg.controller,
                        &seg.locked,
                        &seg.slide_directions,
                        ts,
                        seg.mode,
                        ys.as_slice(),
                    )?;
                    let fj = &ev.full.out;
                    // `F Φ` into the stage's buffer (the product `&F * &Φ` forms)
                    fit(&mut kphi[s], fj.jac.nrows(), ps.ncols());
                    kphi[s].gemm(1.0, &fj.jac, &*ps, 0.0);
                    fit_vec(&mut k[s], fj.f.len());
                    k[s].copy_from(&fj.f);
                }
                Some((params, names)) => {
                    ev.eval_columns_into(
                        &*seg.controller,
                        &seg.locked,
                        &seg.slide_directions,
                        ts,
                        seg.mode,
                        ys.as_slice(),
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

/// A switch inside a segment between an active arc's rolling and its end's point touch:
/// no event (the contact stays), but the flow's constraint rate `Ȧ` changes form there, so
/// `q̈` jumps and the crossing has a saltation `Ξ = I + (f⁺ − f⁻) D_xg / (D_xg f⁻)` (the reset
/// is the identity), `g` the angle between the ground's normal and the arc's end in the
/// part's frame (`D_qg = −∂β/∂q` of the part's angle). `f⁻`, `f⁺` are the flows at the two
/// ends of the bracket the crossing is located in by bisection on the dense output (a few
/// ulps apart).
#[derive(Debug, Clone, PartialEq)]
pub struct TouchSwitch {
    pub t: f64,
    pub contact: usize,
    pub status: SaltationStatus,
    pub saltation: Option<DMatrix<f64>>,
}

/// The tangent of one segment on its own steps (see the module docs), with the saltation of
/// every rolling/point switch inside it (appended to `switches`) and, for columns with
/// parameters, the controller's time events inside it (appended to `time_events`).
fn segment_flow(
    ev: &mut Evaluator,
    seg: &Segment,
    tangent: &mut Tangent,
    switches: &mut Vec<TouchSwitch>,
    time_events: &mut Vec<TimeEventSensitivity>,
) -> Result<(), SensitivityError> {
    let n2 = seg.y0.len();
    let (mut ya, mut yb, mut ym) = (vec![0.0; n2], vec![0.0; n2], vec![0.0; n2]);
    let mut pending: Vec<TimeEvent> = match tangent {
        Tangent::Columns { params, .. } if !params.is_empty() || ev.memory_mode => {
            let names = controller_names(params);
            let mut v = seg.controller.time_events(&names);
            v.retain(|e| e.t >= seg.t0 && e.t < seg.t1);
            v.sort_by(|a, b| a.t.total_cmp(&b.t));
            v
        }
        _ => Vec::new(),
    };
    // stages after the last time event passed take the right-hand limit there
    let mut t_floor = f64::NEG_INFINITY;
    let (mut start_touches, mut end_touches, mut mid_touches) =
        (Vec::new(), Vec::new(), Vec::new());
    for step in seg.dense.steps() {
        if step.t0 >= seg.t1 {
            break;
        }
        let step_end = step.t1().min(seg.t1);
        // the step is split at the controller's time events inside it: `∂f/∂p` (and `f`,
        // where the flow jumps) changes there, so the tangent is integrated up to the instant
        // from the dense output's state, jumps there, and goes on
        let mut ta = step.t0;
        loop {
            while let Some(te) = pending.first().filter(|e| e.t <= ta).cloned() {
                pending.remove(0);
                t_floor = te.t.next_up();
                step.eval(ta, &mut ym);
                time_events.push(time_event(ev, seg, tangent, &te, &ym)?);
            }
            let t_end = pending.first().map_or(step_end, |e| e.t.min(step_end));
            // stages at the next time event take the flow's left limit
            let t_cap = pending.first().map_or(f64::INFINITY, |e| e.t.next_down());
            step.eval(ta, &mut ya);
            step.eval(t_end, &mut yb);
            ev.touches_into(seg.mode, &yb, &mut end_touches);
            // the controller's smooth piece, at the times its stages take
            let piece = move |t: f64, y: &[f64]| {
                let t = t.max(t_floor).min(t_cap);
                let (q, qd) = y.split_at(n2 / 2);
                seg.controller.partials_piece(t, q, qd, seg.mode)
            };
            let end_piece = piece(t_end, &yb);
            let record = |t: f64, y: &mut [f64]| step.eval(t, y);
            // whether the last sub-step ended at a kink (the next one starts there)
            let mut at_kink = false;
            loop {
                ev.touches_into(seg.mode, &ya, &mut start_touches);
                let start_piece = piece(ta, &ya);
                if start_touches == end_touches && start_piece == end_piece {
                    let hold =
                        at_kink.then_some((start_piece, &record as &dyn Fn(f64, &mut [f64])));
                    tangent.step(ev, seg, (ta, t_end - ta, t_floor, t_cap), &ya, hold)?;
                    break;
                }
                // the first change of touch kinds or of the controller's piece after ta,
                // bracketed to a few ulps
                let (mut lo, mut hi) = (ta, t_end);
                loop {
                    let mid = 0.5 * (lo + hi);
                    if mid <= lo || mid >= hi {
                        break;
                    }
                    step.eval(mid, &mut ym);
                    ev.touches_into(seg.mode, &ym, &mut mid_touches);
                    if mid_touches == start_touches && piece(mid, &ym) == start_piece {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let hold = (start_piece, &record as &dyn Fn(f64, &mut [f64]));
                tangent.step(ev, seg, (ta, lo - ta, t_floor, t_cap), &ya, Some(hold))?;
                step.eval(lo, &mut ym);
                step.eval(hi, &mut ya);
                at_kink = true;
                ev.touches_into(seg.mode, &ya, &mut mid_touches);
                if mid_touches != start_touches {
                    let sw = touch_switch(ev, seg, (lo, &ym), (hi, &ya), &start_touches)?;
                    if let Some(x) = &sw.saltation {
                        tangent.salt(x);
                    }
                    switches.push(sw);
                }
                // a kink of the controller's law alone (its outputs continuous, their
                // partials not): the tangent goes on from it, each side on its own steps
                ta = hi;
            }
            if t_end >= step_end {
                break;
            }
            ta = t_end;
        }
    }
    Ok(())
}

/// The names of the controller parameters among `params`, in order.
fn controller_names(params: &[Parameter]) -> Vec<&str> {
    params
        .iter()
        .filter_map(|p| match p {
            Parameter::Controller(n) => Some(n.as_str()),
            Parameter::Body(_) => None,
        })
        .collect()
}

/// A controller's time event at `(te.t, y)` inside a segment: the jump `f⁺ − f⁻` of the flow
/// there (`f⁻` evaluated at the previous float, the same state) moves with the instant,
/// `X_p += (f⁻ − f⁺) dt_b/dp` on the parameter columns (the state columns have
/// `dt_b/dx = 0`). The execution's steps land on the instant (a step stop of
/// [`crate::segment`], its stages there at the left limit), and so do the tangent's; a
/// step of a record that straddles one (a controller whose events are not all known at the
/// segment's start) is split there (see [`segment_flow`]).
fn time_event(
    ev: &mut Evaluator,
    seg: &Segment,
    tangent: &mut Tangent,
    te: &TimeEvent,
    y: &[f64],
) -> Result<TimeEventSensitivity, SensitivityError> {
    let ctrl = &*seg.controller;
    let fm = ev.flow(
        ctrl,
        &seg.locked,
        &seg.slide_directions,
        te.t.next_down(),
        seg.mode,
        y,
    )?;
    let fp = ev.flow(ctrl, &seg.locked, &seg.slide_directions, te.t, seg.mode, y)?;
    let jump = (&fp - &fm).amax();
    let scale = 1.0 + fm.amax().max(fp.amax());
    let out = TimeEventSensitivity {
        t: te.t,
        jump,
        status: SaltationStatus::Defined,
    };
    if jump <= TIME_EVENT_TOL * scale {
        return Ok(out);
    }
    if let Tangent::Columns { x, params, .. } = tangent {
        let nd = x.ncols() - params.len();
        let mut ci = 0;
        for (k, p) in params.iter().enumerate() {
            if let Parameter::Controller(_) = p {
                let d = te.dt_dp[ci];
                ci += 1;
                if d != 0.0 {
                    let mut col = x.column_mut(nd + k);
                    col.axpy(d, &(&fm - &fp), 1.0);
                }
            }
        }
        if ev.memory_mode {
            // an instant that moves with a remembered event: `X += (f⁻ − f⁺) dt_b/dm_k Dm_k`
            for me in ctrl.memory_time_events().iter().filter(|e| e.t == te.t) {
                let Some(d) = ev.memory.get(me.event) else {
                    return Err(SensitivityError::EventMemoryWithoutPartials {
                        t: te.t,
                        reason: format!("event {} is not one the run recorded", me.event),
                    });
                };
                let row = RowDVector::from_row_slice(&me.dt_dm) * d;
                *x += (&fm - &fp) * row;
            }
        }
    }
    Ok(out)
}

/// Relative jump `|f⁺ − f⁻| / (1 + |f|)` (max norms) below which a controller's time event is
/// continuous (no contribution to the parameter columns).
pub const TIME_EVENT_TOL: f64 = 1e-12;

/// A controller's time event met by an execution ([`Controller::time_events`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TimeEventSensitivity {
    pub t: f64,
    /// `max |f⁺ − f⁻|` there.
    pub jump: f64,
    /// Always `Defined` today (kept for time events that cannot be differentiated).
    pub status: SaltationStatus,
}

/// The saltation of a rolling/point switch bracketed by `(t⁻, y⁻)`, `(t⁺, y⁺)`.
fn touch_switch(
    ev: &mut Evaluator,
    seg: &Segment,
    (tm, ym): (f64, &[f64]),
    (tp, yp): (f64, &[f64]),
    before: &[(usize, TouchKind)],
) -> Result<TouchSwitch, SensitivityError> {
    let model = ev.model;
    let n2 = ym.len();
    let after = ev.touches(seg.mode, yp);
    let changed: Vec<usize> = before
        .iter()
        .zip(&after)
        .filter(|(a, b)| a != b)
        .map(|(a, _)| a.0)
        .collect();
    let mut sw = TouchSwitch {
        t: tp,
        contact: changed.first().copied().unwrap_or(usize::MAX),
        status: SaltationStatus::Defined,
        saltation: None,
    };
    if changed.len() != 1 {
        sw.status = SaltationStatus::Simultaneous;
        return Ok(sw);
    }
    let fm = ev.flow(
        &*seg.controller,
        &seg.locked,
        &seg.slide_directions,
        tm,
        seg.mode,
        ym,
    )?;
    let fp = ev.flow(
        &*seg.controller,
        &seg.locked,
        &seg.slide_directions,
        tp,
        seg.mode,
        yp,
    )?;
    // g = α_n − β_part(q) − α_end: D_qg = −∂β/∂q
    let mut dg = RowDVector::zeros(n2);
    dg[model.ix_phi()] = -1.0;
    if let Some(j) = model.contacts[sw.contact].link {
        for k in model.chain(j) {
            dg[k] = -model.joints[k].axis_sign;
        }
    }
    match saltation(&DMatrix::identity(n2, n2), &fm, &fp, &dg) {
        Ok(x) => sw.saltation = Some(x),
        Err(status) => sw.status = status,
    }
    Ok(sw)
}

/// The saltation matrix `Ξ = D_xR + (f⁺ − D_xR f⁻) D_xg / (D_xg f⁻)` of a reset with
/// Jacobian `dr` and a guard with gradient `dg`, between the flows `f⁻` and `f⁺`; or
/// [`SaltationStatus::Grazing`] when `|D_xg f⁻| < GRAZING_TOL |D_xg| |f⁻|` (the flow meets the
/// guard tangentially, where `Ξ` is not defined).
pub fn saltation(
    dr: &DMatrix<f64>,
    f_minus: &DVector<f64>,
    f_plus: &DVector<f64>,
    dg: &RowDVector<f64>,
) -> Result<DMatrix<f64>, SaltationStatus> {
    saltation_with_rate(dr, f_minus, f_plus, dg, 0.0)
}

/// [`saltation`] of a guard that also depends on time: `ġ = D_xg f⁻ + dg_dt` in place of
/// `D_xg f⁻` (the time is a state with `ṫ = 1`), e.g. a force guard under a controller
/// whose torques change with time at a fixed state.
fn saltation_with_rate(
    dr: &DMatrix<f64>,
    f_minus: &DVector<f64>,
    f_plus: &DVector<f64>,
    dg: &RowDVector<f64>,
    dg_dt: f64,
) -> Result<DMatrix<f64>, SaltationStatus> {
    let den = (dg * f_minus)[0] + dg_dt;
    let rel = den.abs() / (dg.norm() * f_minus.norm()).max(f64::MIN_POSITIVE);
    if rel.is_nan() || rel < GRAZING_TOL {
        return Err(SaltationStatus::Grazing {
            transversality: rel,
        });
    }
    Ok(dr + (f_plus - dr * f_minus) * dg / den)
}

/// The sensitivities of a recorded execution to its initial state (see the module docs).
/// Each segment is re-evaluated with the controller it ran with.
pub fn execution_sensitivity(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
) -> Result<Sensitivity, SensitivityError> {
    let n2 = 2 * model.nq();
    let mut ev = Evaluator::new(model, terrain);
    let mut out = Sensitivity {
        segment_flows: Vec::new(),
        events: Vec::new(),
        touch_switches: Vec::new(),
        feature_changes: Vec::new(),
        state_jacobian: None,
    };
    let mut total = DMatrix::identity(n2, n2);
    let mut defined = true;
    let mut next_event = 0;
    let nseg = exec.segments.len();
    for (si, seg) in exec.segments.iter().enumerate() {
        let mut tangent = Tangent::Full(DMatrix::identity(n2, n2));
        segment_flow(
            &mut ev,
            seg,
            &mut tangent,
            &mut out.touch_switches,
            &mut Vec::new(),
        )?;
        let Tangent::Full(phi) = tangent else {
            unreachable!("a full tangent stays full")
        };
        total = &phi * total;
        out.segment_flows.push(phi);
        let Some(event) = event_ending(exec, si, next_event) else {
            if si + 1 < nseg {
                out.feature_changes.push(si);
                defined = false;
            }
            continue;
        };
        next_event += 1;
        let (mut es, parts) = segment_event(&mut ev, model, terrain, exec, si, event, &[])?;
        if let (Some(dg), Some(parts)) = (&es.guard_gradient, &parts) {
            // `ġ = D_xg f⁻ (+ ∂g/∂t)` at the event, as its saltation had it
            es.time_gradient = Some(-(dg * &total) / parts.den);
        }
        match &es.saltation {
            Some(x) => total = x * total,
            None => defined = false,
        }
        out.events.push(es);
    }
    // events not matched to a segment end, switches not differentiated
    if defined && chain_complete(exec, next_event, &out.touch_switches) {
        out.state_jacobian = Some(total);
    }
    if has_event_memory(exec) {
        // the memory couples the segments: the chain is no longer the product of the
        // segments' flows and saltations (which hold it fixed); the columns carry it
        let cols =
            execution_sensitivity_columns(model, terrain, exec, &DMatrix::identity(n2, n2), &[])?;
        for (e, tc) in out.events.iter_mut().zip(cols.event_time_columns) {
            if e.time_gradient.is_some() {
                e.time_gradient = tc;
            }
        }
        out.state_jacobian = out.state_jacobian.and(cols.columns);
    }
    Ok(out)
}

/// Whether any segment's controller remembers events' times or states
/// ([`Controller::has_event_memory`]).
fn has_event_memory(exec: &Execution) -> bool {
    exec.segments
        .iter()
        .any(|s| s.controller.has_event_memory())
}

/// Whether the chain of an execution's derivative reaches its end: every event was matched
/// to a segment end, every rolling/point switch inside a segment was differentiated, and the
/// run ended at its final time or at the apex (a run cut by a budget ends on an event with
/// no flow after it).
fn chain_complete(exec: &Execution, next_event: usize, touch_switches: &[TouchSwitch]) -> bool {
    next_event == exec.events.len()
        && touch_switches
            .iter()
            .all(|s| s.status == SaltationStatus::Defined)
        && matches!(exec.termination, Termination::FinalTime | Termination::Apex)
}

/// A named parameter of an execution's sensitivities ([`execution_sensitivity_columns`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Parameter {
    /// The body's mass or inertia, or a joint's armature (`M̄`, `N̄` and the impacts depend
    /// on it).
    Body(BodyParameter),
    /// A parameter the segments' controllers know by this name
    /// ([`Controller::parameter_partials`], [`Controller::time_events`]).
    Controller(String),
}

/// Sensitivities of an execution along selected columns: directions of the initial state
/// and named parameters ([`execution_sensitivity_columns`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnSensitivity {
    /// How many leading columns are initial-state directions (the rest are parameters).
    pub n_directions: usize,
    pub parameters: Vec<Parameter>,
    /// One entry per event of the execution, in order, as in [`Sensitivity::events`]
    /// (`time_gradient` is left `None`: see [`Self::event_time_columns`]).
    pub events: Vec<EventSensitivity>,
    /// `dt_e/d(columns)` of each event (`1 × m`), `None` where its saltation is undefined.
    pub event_time_columns: Vec<Option<RowDVector<f64>>>,
    pub touch_switches: Vec<TouchSwitch>,
    /// The controllers' time events met (see [`Controller::time_events`]).
    pub time_events: Vec<TimeEventSensitivity>,
    pub feature_changes: Vec<usize>,
    /// `dx(t_end)/d(columns)` (`2nq × m`), `None` under the conditions of
    /// [`Sensitivity::state_jacobian`] or when a time event was flagged.
    pub columns: Option<DMatrix<f64>>,
}

/// The sensitivities of a recorded execution along the columns of `directions` (`2nq × d`,
/// directions of the initial state; `d` may be 0) and to the named `params`, propagated
/// without forming the full `2nq × 2nq` matrices along the flows (see the module docs). With
/// the augmented state `x̃ = (x, p)`, `ṗ = 0`:
///
/// - along a flow `Ẋ_p = F X_p + ∂f/∂p` (`∂f/∂p` from the controller's
///   [`Controller::parameter_partials`] through `∂q̈/∂Υ`, or from `∂M̄/∂p`, `∂N̄/∂p` for body
///   parameters, by implicit differentiation of the KKT system);
/// - at an event, `X⁺ = Ξ X + [0 | D_pR + (f⁺ − D_xR f⁻) D_pg / (D_xg f⁻)]`, and
///   `dt_e/d(columns) = −(D_xg X⁻ + [0 | D_pg]) / (D_xg f⁻)` (`D_pg` of a force guard from
///   `∂λ/∂p`; `D_pR` of a plastic impact from `∂M̄/∂p`);
/// - at a controller's time event `t_b(p)` where the flow jumps, `X_p += (f⁻ − f⁺) dt_b/dp`.
pub fn execution_sensitivity_columns(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
    directions: &DMatrix<f64>,
    params: &[Parameter],
) -> Result<ColumnSensitivity, SensitivityError> {
    let n2 = 2 * model.nq();
    let nd = directions.ncols();
    let m = nd + params.len();
    let body: Vec<BodyParameter> = params
        .iter()
        .filter_map(|p| match p {
            Parameter::Body(b) => Some(*b),
            Parameter::Controller(_) => None,
        })
        .collect();
    for b in &body {
        b.check(model)?;
    }
    let mut ev = Evaluator::new(model, terrain);
    ev.memory_mode = has_event_memory(exec);
    let mut out = ColumnSensitivity {
        n_directions: nd,
        parameters: params.to_vec(),
        events: Vec::new(),
        event_time_columns: Vec::new(),
        touch_switches: Vec::new(),
        time_events: Vec::new(),
        feature_changes: Vec::new(),
        columns: None,
    };
    let mut x0 = DMatrix::zeros(n2, m);
    if nd > 0 {
        x0.columns_mut(0, nd).copy_from(directions);
    }
    let mut tangent = Tangent::Columns {
        x: x0,
        params,
        names: controller_names(params),
    };
    let mut defined = true;
    let mut next_event = 0;
    let nseg = exec.segments.len();
    for (si, seg) in exec.segments.iter().enumerate() {
        segment_flow(
            &mut ev,
            seg,
            &mut tangent,
            &mut out.touch_switches,
            &mut out.time_events,
        )?;
        let Some(event) = event_ending(exec, si, next_event) else {
            if si + 1 < nseg {
                out.feature_changes.push(si);
                defined = false;
            }
            continue;
        };
        next_event += 1;
        let (es, parts) = segment_event(&mut ev, model, terrain, exec, si, event, &body)?;
        let (Some(xi), Some(parts), Some(dg)) = (&es.saltation, parts, &es.guard_gradient) else {
            defined = false;
            if ev.memory_mode && event.kind != EventKind::Apex {
                // the event's memory has no derivative: the run's columns are not returned
                ev.memory.push(DMatrix::from_element(1 + n2, m, f64::NAN));
            }
            out.event_time_columns.push(None);
            out.events.push(es);
            continue;
        };
        let Tangent::Columns { x, .. } = &mut tangent else {
            unreachable!("columns stay columns")
        };
        // D_pg: a force guard's from ∂λ/∂p at the state before; geometric guards have none
        let mut dpg = RowDVector::zeros(m);
        if matches!(event.kind, EventKind::Liftoff | EventKind::Slip)
            && (!params.is_empty() || ev.memory_mode)
        {
            let k = event.triggered[0];
            let (rt, rn) = rows_of(seg.mode, k);
            let zero = DMatrix::zeros(n2, m);
            let c = ev.eval_columns(
                &*seg.controller,
                &seg.locked,
                &seg.slide_directions,
                event.t,
                seg.mode,
                &parts.y_minus,
                &zero,
                params,
            )?;
            if let Some(g) = rn.and_then(|rn| {
                force_guard_gradient(model, event.kind, k, (rt, rn), &c.lambda, &c.dlambda)
            }) {
                dpg = g;
            }
        }
        let dgx = dg * &*x;
        let time = -(&dgx + &dpg) / parts.den;
        let jump = &parts.f_plus - &parts.dr * &parts.f_minus;
        let mut xn = xi * &*x;
        let mut bi = 0;
        for (k, p) in params.iter().enumerate() {
            let col = nd + k;
            if let Parameter::Body(_) = p {
                xn.column_mut(col).axpy(1.0, &parts.dr_p.column(bi), 1.0);
                bi += 1;
            }
            if dpg[col] != 0.0 {
                xn.column_mut(col).axpy(dpg[col] / parts.den, &jump, 1.0);
            }
        }
        if ev.memory_mode {
            // the guard moves with the memory too (a force guard's `∂λ/∂m Dm`), in the
            // directions' columns as in the parameters'
            for col in 0..nd {
                if dpg[col] != 0.0 {
                    xn.column_mut(col).axpy(dpg[col] / parts.den, &jump, 1.0);
                }
            }
            if event.kind != EventKind::Apex {
                // the event as the controller remembers it: `(t_e, x⁺)` with
                // `Dx⁺ = X⁺ + f⁺ Dt_e` (X⁺ is the tangent at a fixed time just after it)
                let mut d = DMatrix::zeros(1 + n2, m);
                d.row_mut(0).copy_from(&time);
                let moved = &xn + &parts.f_plus * &time;
                d.rows_mut(1, n2).copy_from(&moved);
                ev.memory.push(d);
            }
        }
        *x = xn;
        out.event_time_columns.push(Some(time));
        out.events.push(es);
    }
    // a controller's time event moves the parameter columns only (its instant does not
    // depend on the state), so only this path needs its statuses
    let time_events_defined = out
        .time_events
        .iter()
        .all(|e| e.status == SaltationStatus::Defined);
    if defined && time_events_defined && chain_complete(exec, next_event, &out.touch_switches) {
        let Tangent::Columns { x, .. } = tangent else {
            unreachable!("columns stay columns")
        };
        out.columns = Some(x);
    }
    Ok(out)
}

/// The event that ended segment `si`, if it is the next one not matched yet (`next_event`):
/// a segment ends on an event unless it ended on a terrain feature change; the last one only
/// on the apex or when the event budget ran out.
fn event_ending(exec: &Execution, si: usize, next_event: usize) -> Option<&Event> {
    let seg = &exec.segments[si];
    let last = si + 1 == exec.segments.len();
    exec.events.get(next_event).filter(|e| {
        e.t == seg.t1
            && (!last || e.kind == EventKind::Apex || exec.termination == Termination::EventBudget)
    })
}

/// [`event_sensitivity`] of the event that ended segment `si`, flagged simultaneous (without
/// parts) when a neighbouring mode lasted zero time.
#[allow(clippy::too_many_arguments)]
fn segment_event(
    ev: &mut Evaluator,
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
    si: usize,
    event: &Event,
    body: &[BodyParameter],
) -> Result<(EventSensitivity, Option<EventParts>), SensitivityError> {
    let seg = &exec.segments[si];
    let after = exec.segments.get(si + 1);
    let zero_time = seg.t1 == seg.t0 || after.is_some_and(|a| a.t1 == a.t0);
    let (mut es, parts) = event_sensitivity(ev, model, terrain, seg, after, event, body)?;
    // an event at a time event of the controller that ran up to it was fired by the flow's
    // jump there (a torque switched on pushes a force to its cone at once), not by a
    // crossing: its instant follows the time event's, which the state event's
    // `−D_xg X / D_xg f⁻` does not give (the controller after it may start motions at the
    // event itself: those follow the event, they do not fire it)
    let at_time_event = seg
        .controller
        .time_events(&[])
        .iter()
        .any(|te| (te.t - event.t).abs() <= 1e-12 * (1.0 + event.t.abs()));
    if es.status == SaltationStatus::Defined && event.kind != EventKind::Apex && at_time_event {
        return Ok((
            unsupported(
                event,
                "fired at a controller's time event (the flow's jump there), not by a \
                 crossing: not differentiated",
            ),
            None,
        ));
    }
    if zero_time && es.status == SaltationStatus::Defined {
        es.status = SaltationStatus::Simultaneous;
        es.saltation = None;
        return Ok((es, None));
    }
    Ok((es, parts))
}

/// Row indices, in the rows of `mode`, of contact `k`'s tangential and normal rows.
fn rows_of(mode: ContactMode, k: usize) -> (Option<usize>, Option<usize>) {
    let (mut t, mut n) = (None, None);
    for (i, r) in mode.rows().enumerate() {
        if r.contact == k {
            match r.direction {
                RowDirection::Tangential => t = Some(i),
                RowDirection::Normal => n = Some(i),
            }
        }
    }
    (t, n)
}

fn unsupported(event: &Event, reason: impl Into<String>) -> EventSensitivity {
    EventSensitivity {
        t: event.t,
        kind: event.kind,
        status: SaltationStatus::Unsupported {
            reason: reason.into(),
        },
        saltation: None,
        guard_gradient: None,
        time_gradient: None,
        impact_mode: None,
    }
}

/// The saltation matrix of `event`, which ended `before` (and started `after`, if any).
fn event_sensitivity(
    ev: &mut Evaluator,
    model: &Model,
    terrain: &dyn Terrain,
    before: &Segment,
    after: Option<&Segment>,
    event: &Event,
    body: &[BodyParameter],
) -> Result<(EventSensitivity, Option<EventParts>), SensitivityError> {
    let nq = model.nq();
    let n2 = 2 * nq;
    let t = event.t;
    let mut y = vec![0.0; n2];
    before.eval(t, &mut y);
    let (q, qd_minus) = y.split_at(nq);
    let fm = ev.eval(
        &*before.controller,
        &before.locked,
        &before.slide_directions,
        t,
        before.mode,
        &y,
    )?;
    let single = event.triggered.len() <= 1;
    let mut simultaneous = !single;
    // the guard's gradient and the reset's Jacobian
    let mut dr = DMatrix::identity(n2, n2);
    let mut dr_p = DMatrix::zeros(n2, body.len());
    let mut y_plus = y.clone();
    let mut kin = Kinematics::default();
    kin.compute(model, q, qd_minus);
    let mut impact_mode = None;
    let mut dg_dt = 0.0;
    let dg: RowDVector<f64> = match event.kind {
        EventKind::Touchdown => {
            let k = event.triggered[0];
            let geo = contact_geometry(model, &kin, terrain, k);
            let mut dg = RowDVector::zeros(n2);
            dg.columns_mut(0, nq)
                .copy_from(&height_gradient(model, &kin, &geo).transpose());
            // the impact the reset applied: into the mode after, or into a larger set whose
            // extra contacts the force complementarity then released (5.19)–(5.20)
            let released: Vec<usize> = before
                .mode
                .active()
                .filter(|&c| !event.mode_after.contains(c))
                .collect();
            let mut candidates = vec![event.mode_after];
            for kind in [None, Some(ContactKind::Slide)] {
                let mut m = event.mode_after;
                for &c in &released {
                    let kc = kind.or(before.mode.kind(c)).expect("active contact");
                    m = m.with(c, kc);
                }
                if !candidates.contains(&m) {
                    candidates.push(m);
                }
            }
            // … or into one that also holds the contact that touched down, released at once by
            // the forces (a body end that bounces off: its impulse stops it, its force pulls)
            let n0 = candidates.len();
            for i in 0..n0 {
                for &k in &event.triggered {
                    if candidates[i].contains(k) {
                        continue;
                    }
                    for kind in [ContactKind::Slide, ContactKind::Stick] {
                        if kind == ContactKind::Stick
                            && !matches!(model.contacts[k].friction, Friction::Sticking { .. })
                        {
                            continue;
                        }
                        let m = candidates[i].with(k, kind);
                        if !candidates.contains(&m) {
                            candidates.push(m);
                        }
                    }
                }
            }
            // … or into a set in which a contact that slides after the event stuck for the
            // impact: the impact's sticking force outside the cone, the contact slides on
            // from the velocity the impact left it (crate::reset: the kept contacts must
            // also hold in force)
            let n0 = candidates.len();
            for i in 0..n0 {
                let base = candidates[i];
                let sliding: Vec<usize> = base
                    .active()
                    .filter(|&c| {
                        base.kind(c) == Some(ContactKind::Slide)
                            && matches!(model.contacts[c].friction, Friction::Sticking { .. })
                    })
                    .collect();
                for &c in &sliding {
                    let m = base.with(c, ContactKind::Stick);
                    if !candidates.contains(&m) {
                        candidates.push(m);
                    }
                }
                let all = sliding
                    .iter()
                    .fold(base, |m, &c| m.with(c, ContactKind::Stick));
                if !candidates.contains(&all) {
                    candidates.push(all);
                }
            }
            let mut data = Data::new(model);
            let scale = 1.0 + event.qd_after.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let mut found = None;
            let mut worst = f64::INFINITY;
            for m in candidates {
                let Ok(ij) = plastic_impact_jacobian(model, &mut data, terrain, m, q, qd_minus)
                else {
                    continue;
                };
                let mismatch = ij
                    .impact
                    .qd_plus
                    .iter()
                    .zip(&event.qd_after)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                worst = worst.min(mismatch);
                if mismatch <= 1e-9 * scale {
                    found = Some((m, ij));
                    break;
                }
            }
            let Some((m, ij)) = found else {
                return Ok((unsupported(
                    event,
                    format!("q̇⁺ is not a plastic impact into the mode after or a superset ({worst:.2e})"),
                ), None));
            };
            impact_mode = Some(m);
            // data holds the factorization of the impact just found
            let dqd_dp =
                plastic_impact_body_derivatives(model, &mut data, &ij.impact, qd_minus, body);
            dr_p.view_mut((nq, 0), (nq, body.len())).copy_from(&dqd_dp);
            dr.view_mut((nq, 0), (nq, nq)).copy_from(&ij.dqd_plus_dq);
            dr.view_mut((nq, nq), (nq, nq))
                .copy_from(&ij.dqd_plus_dqd_minus);
            y_plus[nq..].copy_from_slice(ij.impact.qd_plus.as_slice());
            dg
        }
        EventKind::Liftoff | EventKind::Slip => {
            let k = event.triggered[0];
            let (rt, rn) = rows_of(before.mode, k);
            let Some(rn) = rn else {
                return Ok((unsupported(event, "no normal row"), None));
            };
            match force_guard_gradient(model, event.kind, k, (rt, rn), &fm.lambda, &fm.dlambda) {
                Some(dg) => {
                    // the guard's explicit time dependence through the torques
                    let dtau_dt = torque_time_derivative(
                        &*before.controller,
                        model.n_joints(),
                        t,
                        (q, qd_minus),
                        before.mode,
                    );
                    let dt = &fm.dlambda_dtau
                        * DMatrix::from_column_slice(model.n_joints(), 1, dtau_dt.as_slice());
                    if let Some(r) =
                        force_guard_gradient(model, event.kind, k, (rt, rn), &fm.lambda, &dt)
                    {
                        dg_dt = r[0];
                    }
                    dg
                }
                None => {
                    return Ok((
                        unsupported(event, "slip of a contact without a tangential row"),
                        None,
                    ))
                }
            }
        }
        EventKind::Stick => {
            let k = event.triggered[0];
            let geo = contact_geometry(model, &kin, terrain, k);
            let (dq, dqd) = sliding_velocity_gradient(model, &kin, &geo, k, qd_minus)?;
            let mut dg = RowDVector::zeros(n2);
            dg.columns_mut(0, nq).copy_from(&dq.transpose());
            dg.columns_mut(nq, nq).copy_from(&dqd.transpose());
            dg
        }
        EventKind::Apex => {
            let mut dg = RowDVector::zeros(n2);
            dg[nq + model.ix_z()] = -1.0;
            dg
        }
        EventKind::Jam => {
            return Ok((unsupported(event, "jams are not differentiated"), None));
        }
        EventKind::Fold | EventKind::FoldPassed => {
            return Ok((
                unsupported(event, "fold events are not differentiated yet"),
                None,
            ));
        }
    };
    if event.kind != EventKind::Touchdown {
        // no velocity jump but the drift's: the reset is the identity in state, or (at a
        // slip, crate::reset) the projection of the integrator's drift `A q̇ ≠ 0` away, a
        // plastic impact into the mode before (5.52)
        let jump = max_diff(qd_minus, &event.qd_after);
        if jump > 0.0 {
            let mut data = Data::new(model);
            let proj = drift_projection(
                model,
                terrain,
                &mut data,
                before.mode,
                q,
                qd_minus,
                &event.qd_after,
            );
            match proj {
                Some(ij) => {
                    // its body parameters' `D_pR` (of the order of the drift)
                    let dqd_dp = plastic_impact_body_derivatives(
                        model, &mut data, &ij.impact, qd_minus, body,
                    );
                    dr_p.view_mut((nq, 0), (nq, body.len())).copy_from(&dqd_dp);
                    dr.view_mut((nq, 0), (nq, nq)).copy_from(&ij.dqd_plus_dq);
                    dr.view_mut((nq, nq), (nq, nq))
                        .copy_from(&ij.dqd_plus_dqd_minus);
                    y_plus[nq..].copy_from_slice(&event.qd_after);
                }
                None => {
                    return Ok((
                        unsupported(
                            event,
                            format!("velocity jump {jump:.2e} at a non-impact event"),
                        ),
                        None,
                    ))
                }
            }
        }
    }
    if event.kind == EventKind::Touchdown && event.triggered.is_empty() {
        simultaneous = true;
    }
    let mut es = EventSensitivity {
        t,
        kind: event.kind,
        status: SaltationStatus::Defined,
        saltation: None,
        guard_gradient: Some(dg.clone()),
        time_gradient: None,
        impact_mode,
    };
    if let Err(status) = saltation_with_rate(&dr, &fm.f, &fm.f, &dg, dg_dt) {
        es.status = status;
        return Ok((es, None));
    }
    if simultaneous {
        es.status = SaltationStatus::Simultaneous;
        return Ok((es, None));
    }
    let f_plus = match (event.kind, after) {
        (EventKind::Apex, _) => DVector::zeros(n2),
        (_, Some(a)) => ev.flow(
            &*a.controller,
            &a.locked,
            &a.slide_directions,
            t,
            event.mode_after,
            &y_plus,
        )?,
        (_, None) => {
            // the run ended at this event (its event budget): no flow after it to salt with
            es.status = SaltationStatus::Unsupported {
                reason: "no flow after the run's last event".into(),
            };
            return Ok((es, None));
        }
    };
    let parts = match saltation_with_rate(&dr, &fm.f, &f_plus, &dg, dg_dt) {
        Ok(x) => {
            es.saltation = Some(x);
            Some(EventParts {
                den: (&dg * &fm.f)[0] + dg_dt,
                f_minus: fm.f,
                f_plus,
                dr,
                dr_p,
                y_minus: y,
            })
        }
        Err(status) => {
            es.status = status;
            None
        }
    };
    Ok((es, parts))
}

/// `max |a − b|`.
fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

/// Relative size `|q̇⁺ − q̇⁻| / (1 + |q̇⁻|)` (max norms) up to which a velocity jump at a
/// force event is the projection of the integrator's drift (the constraint velocity `A q̇`
/// of a located event is of the order of the tolerances; a sliding speed this small counts
/// as rest, `selfmanip_core::friction::SLIDING_SPEED_EPS_M_S`).
pub const DRIFT_JUMP_TOL: f64 = 1e-6;

/// The drift projection a force event's reset applied (`crate::reset`): the plastic impact
/// (5.52) into `mode` (the mode before) from `q̇⁻`, with its Jacobian, if it reproduces the
/// recorded `q̇⁺` and the jump is within [`DRIFT_JUMP_TOL`]; `None` for any other jump. `data`
/// is left with the impact's factorization (for [`plastic_impact_body_derivatives`]).
///
/// Its Jacobian is the reset's `D_xR` exactly. On a tangent that satisfies the linearized
/// constraints of the mode, `D_qA[δq] q̇ + A δq̇ = 0`, it is the identity up to the drift:
/// `q̇⁺ = q̇ − M̄⁻¹Aᵀ(AM̄⁻¹Aᵀ)⁻¹A q̇` gives
/// `δq̇⁺ = δq̇ − M̄⁻¹Aᵀ(AM̄⁻¹Aᵀ)⁻¹(A δq̇ + D_qA[δq] q̇) + O(|A q̇|)`; on one that drifted off
/// them it projects that drift away too, as the reset does to the state.
fn drift_projection(
    model: &Model,
    terrain: &dyn Terrain,
    data: &mut Data,
    mode: ContactMode,
    q: &[f64],
    qd_minus: &[f64],
    qd_after: &[f64],
) -> Option<selfmanip_core::tangent::ImpactJacobian> {
    let scale = 1.0 + qd_minus.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if max_diff(qd_minus, qd_after) > DRIFT_JUMP_TOL * scale {
        return None;
    }
    let ij = plastic_impact_jacobian(model, data, terrain, mode, q, qd_minus).ok()?;
    (max_diff(ij.impact.qd_plus.as_slice(), qd_after) <= 1e-12 * scale).then_some(ij)
}

/// What the parameter columns need of an event whose saltation is defined.
struct EventParts {
    f_minus: DVector<f64>,
    f_plus: DVector<f64>,
    /// `D_xR` and `D_pR` (body parameters' columns) of the reset.
    dr: DMatrix<f64>,
    dr_p: DMatrix<f64>,
    /// `D_xg f⁻`.
    den: f64,
    y_minus: Vec<f64>,
}

/// The gradient of a force guard (liftoff `g = −λ_n` (5.50), slip `g = μ(−λ_n) − |λ_t|`) of
/// contact `k` with rows `(tangential, normal)` from `∂λ` along any columns; `None` for a
/// slip without a tangential row or friction coefficient.
fn force_guard_gradient(
    model: &Model,
    kind: EventKind,
    k: usize,
    (rt, rn): (Option<usize>, usize),
    lambda: &DVector<f64>,
    dlambda: &DMatrix<f64>,
) -> Option<RowDVector<f64>> {
    if kind == EventKind::Liftoff {
        return Some(-dlambda.row(rn));
    }
    let (Some(rt), Friction::Sticking { mu }) = (rt, model.contacts[k].friction) else {
        return None;
    };
    Some(-mu * dlambda.row(rn) - lambda[rt].signum() * dlambda.row(rt))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A guard met tangentially is flagged, not divided by: `D_xg f⁻ = 0` exactly and at
    /// 1e-12 of `|D_xg| |f⁻|`; at 1e-6 the formula applies (a closed form: with `D_xR = I`,
    /// `Ξ e_0 = e_0 + (f⁺ − f⁻)/(D_xg f⁻)` for `D_xg = e_0ᵀ`).
    #[test]
    fn grazing_is_flagged() {
        let dr = DMatrix::identity(2, 2);
        let dg = RowDVector::from_vec(vec![1.0, 0.0]);
        let fp = DVector::from_vec(vec![0.0, 3.0]);
        for (eps, grazing) in [(0.0, true), (1e-12, true), (1e-6, false)] {
            let fm = DVector::from_vec(vec![eps, 1.0]);
            match saltation(&dr, &fm, &fp, &dg) {
                Err(SaltationStatus::Grazing { transversality }) => {
                    assert!(grazing && transversality <= eps, "{eps}")
                }
                Ok(x) => {
                    assert!(!grazing, "{eps}");
                    assert!((x[(0, 0)] - (1.0 + (0.0 - eps) / eps)).abs() < 1e-9);
                    assert!((x[(1, 0)] - (3.0 - 1.0) / eps).abs() < 1e-9 * 2.0 / eps);
                }
                Err(other) => panic!("{other:?}"),
            }
        }
    }
}
