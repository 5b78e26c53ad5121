//! Sensitivities of an execution to its initial state: the variational equations along each
//! flow, the saltation matrix at each event, and their chain rule
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
//! (each with its segment's controller and locked joints). Touchdown: `g` the contact's height
//! (5.49), `R` the plastic impact (5.10)/(5.52) into the mode the event took — or into the
//! larger set whose extra contacts force complementarity (5.19)–(5.20) released at once,
//! whichever reproduces the recorded `q̇⁺` (else the event is flagged) — with its Jacobian
//! from [`selfmanip_core::tangent::plastic_impact_jacobian`]; the pseudo-impulse (5.39) only
//! selects that mode, it does not change `q̇⁺`. Liftoff: `g = −λ_n` (5.50), `R = I`. Slip:
//! `g = μ(−λ_n) − |λ_t|`, `R = I`. Stick: `g` the sliding velocity, `R = I`. Apex (terminal):
//! `g = −ż`, and the end state is the state at the apex, `Ξ = I − f⁻ D_xg / (D_xg f⁻)`.
//! Each event also gives its time's gradient `dt_e/dx(0) = −D_xg X⁻ / (D_xg f⁻)`. An
//! active arc whose rolling contact reaches the arc's end inside a segment (no event, but
//! `Ȧ`, hence `q̈`, changes form there) gets a saltation of its own ([`TouchSwitch`]).
//!
//! **Where Ξ is not defined** the event says so ([`SaltationStatus`]) instead of carrying a
//! number: grazing (`|D_xg f⁻|` below [`GRAZING_TOL`] relative to `|D_xg| |f⁻|`), several
//! guards at once or a mode held for zero time (two orders of simultaneous events may give
//! different outcomes: the Bouligand derivative is not formed yet), and events not covered
//! yet (folds, a fold passage's end, a segment that ended on a terrain feature change).
//! [`Sensitivity::state_jacobian`] is then `None`.
//!
//! **Not covered yet.** A run whose state sits on a guard that does not fire — a contact set
//! chosen at a complementarity boundary, e.g. a sliding contact started at zero sliding
//! velocity — gets the one-sided derivative of the sequence it realised, unflagged;
//! sensitivities to named parameters (masses, lengths, gear ratio, δt, …) and controllers
//! without [`Controller::partials`] (the actuator models, the RHex leap controller) are for
//! later.
use crate::controller::{Controller, ControllerPartials};
use crate::error::HybridError;
use crate::execution::{Event, EventKind, Execution, Segment, Termination};
use crate::integrate::{A as RK_A, C as RK_C};
use crate::options::HybridOptions;
use crate::simulate::simulate;
use nalgebra::{DMatrix, DVector, RowDVector};
use selfmanip_core::contact::{contact_geometry, ContactKind, RowDirection, TouchKind};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::model::Friction;
use selfmanip_core::tangent::{
    dynamics_jacobian_solved, height_gradient, plastic_impact_jacobian, sliding_velocity_gradient,
    TangentError,
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
    /// `Φ` of each segment (`2nq × 2nq`; the identity for a segment of zero duration).
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
struct FlowJacobian {
    /// `f = (q̇, q̈)`.
    f: DVector<f64>,
    /// `F = ∂f/∂x`.
    jac: DMatrix<f64>,
    /// `∂λ/∂x` (rows of the mode) and `λ`.
    dlambda: DMatrix<f64>,
    lambda: DVector<f64>,
}

/// Evaluates flows and their Jacobians on a workspace of its own.
struct Evaluator<'a> {
    model: &'a Model,
    terrain: &'a dyn Terrain,
    data: Data,
    tau: Vec<f64>,
    free: Vec<f64>,
    kin: Kinematics,
}

impl<'a> Evaluator<'a> {
    fn new(model: &'a Model, terrain: &'a dyn Terrain) -> Self {
        Evaluator {
            model,
            terrain,
            data: Data::new(model),
            tau: vec![0.0; model.n_joints()],
            free: Vec::new(),
            kin: Kinematics::default(),
        }
    }

    /// The touch kind of every active contact of `mode` at `y`.
    fn touches(&mut self, mode: ContactMode, y: &[f64]) -> Vec<(usize, TouchKind)> {
        let nq = self.model.nq();
        self.kin.compute(self.model, &y[..nq], &y[nq..]);
        mode.active()
            .map(|k| {
                (
                    k,
                    contact_geometry(self.model, &self.kin, self.terrain, k).touch,
                )
            })
            .collect()
    }

    /// The flow of `mode` at `(t, y)` under `ctrl` with `locked` joints, and its Jacobian.
    fn eval(
        &mut self,
        ctrl: &dyn Controller,
        locked: &[usize],
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<FlowJacobian, SensitivityError> {
        let (model, nq, n) = (self.model, self.model.nq(), self.model.n_joints());
        let (q, qd) = y.split_at(nq);
        self.data.locked.clear();
        self.data.locked.extend_from_slice(locked);
        self.data
            .prepare(model, self.terrain, mode, q, qd)
            .map_err(TangentError::from)?;
        let free_joints = self.data.free_joints.clone();
        ctrl.torque(t, q, qd, mode, &mut self.tau);
        self.free.resize(free_joints.len(), 0.0);
        ctrl.free_joint_qdd(t, q, qd, &free_joints, &mut self.free);
        for (x, j) in self.free.iter_mut().zip(&free_joints) {
            if locked.contains(j) {
                *x = 0.0;
            }
        }
        let mut p = ControllerPartials::zeros(n, nq, free_joints.len());
        if !ctrl.partials(t, q, qd, mode, &free_joints, &mut p) {
            return Err(SensitivityError::ControllerWithoutPartials { t });
        }
        forward_dynamics_prepared(model, &mut self.data, &self.tau, Some(&self.free))
            .map_err(TangentError::from)?;
        let dj = dynamics_jacobian_solved(model, &mut self.data, qd)?;
        let mut dqdd_dq = &dj.dqdd_dq + &dj.dqdd_dtau * &p.dtau_dq;
        let mut dqdd_dqd = &dj.dqdd_dqd + &dj.dqdd_dtau * &p.dtau_dqd;
        for (i, &j) in free_joints.iter().enumerate() {
            if !locked.contains(&j) {
                dqdd_dq.set_row(j, &p.dfree_dq.row(i));
                dqdd_dqd.set_row(j, &p.dfree_dqd.row(i));
            }
        }
        let mut jac = DMatrix::zeros(2 * nq, 2 * nq);
        jac.view_mut((0, nq), (nq, nq))
            .copy_from(&DMatrix::identity(nq, nq));
        jac.view_mut((nq, 0), (nq, nq)).copy_from(&dqdd_dq);
        jac.view_mut((nq, nq), (nq, nq)).copy_from(&dqdd_dqd);
        let c = dj.dlambda_dq.nrows();
        let mut dlambda = DMatrix::zeros(c, 2 * nq);
        dlambda
            .view_mut((0, 0), (c, nq))
            .copy_from(&(&dj.dlambda_dq + &dj.dlambda_dtau * &p.dtau_dq));
        dlambda
            .view_mut((0, nq), (c, nq))
            .copy_from(&(&dj.dlambda_dqd + &dj.dlambda_dtau * &p.dtau_dqd));
        let mut f = DVector::zeros(2 * nq);
        f.rows_mut(0, nq).copy_from_slice(qd);
        f.rows_mut(nq, nq).copy_from(&self.data.qdd);
        Ok(FlowJacobian {
            f,
            jac,
            dlambda,
            lambda: self.data.lambda.clone(),
        })
    }
}

/// One step of `Φ` from `(t0, y0)` of size `h` with the DOPRI5 tableau (its six stages that
/// enter the 5th-order solution; the 7th is FSAL's).
#[allow(clippy::too_many_arguments)]
fn phi_step(
    ev: &mut Evaluator,
    seg: &Segment,
    t0: f64,
    h: f64,
    y0: &[f64],
    phi: &mut DMatrix<f64>,
) -> Result<(), SensitivityError> {
    if h <= 0.0 {
        return Ok(());
    }
    let mut k: Vec<DVector<f64>> = Vec::with_capacity(6);
    let mut kphi: Vec<DMatrix<f64>> = Vec::with_capacity(6);
    for s in 0..6 {
        let mut ys = DVector::from_column_slice(y0);
        let mut ps = phi.clone();
        for j in 0..s {
            ys.axpy(h * RK_A[s][j], &k[j], 1.0);
            ps += h * RK_A[s][j] * &kphi[j];
        }
        let fj = ev.eval(
            &*seg.controller,
            &seg.locked,
            t0 + RK_C[s] * h,
            seg.mode,
            ys.as_slice(),
        )?;
        kphi.push(&fj.jac * ps);
        k.push(fj.f);
    }
    for s in 0..6 {
        *phi += h * RK_A[6][s] * &kphi[s];
    }
    Ok(())
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

/// `Φ` of one segment on its own steps (see the module docs), with the saltation of every
/// rolling/point switch inside it (appended to `switches`).
fn segment_flow(
    ev: &mut Evaluator,
    seg: &Segment,
    switches: &mut Vec<TouchSwitch>,
) -> Result<DMatrix<f64>, SensitivityError> {
    let n2 = seg.y0.len();
    let mut phi = DMatrix::identity(n2, n2);
    let (mut ya, mut yb, mut ym) = (vec![0.0; n2], vec![0.0; n2], vec![0.0; n2]);
    for step in seg.dense.steps() {
        if step.t0 >= seg.t1 {
            break;
        }
        let t_end = step.t1().min(seg.t1);
        let mut ta = step.t0;
        step.eval(ta, &mut ya);
        step.eval(t_end, &mut yb);
        let end_touches = ev.touches(seg.mode, &yb);
        loop {
            let start_touches = ev.touches(seg.mode, &ya);
            if start_touches == end_touches {
                phi_step(ev, seg, ta, t_end - ta, &ya, &mut phi)?;
                break;
            }
            // the first change of touch kinds after ta, bracketed to a few ulps
            let (mut lo, mut hi) = (ta, t_end);
            loop {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                step.eval(mid, &mut ym);
                if ev.touches(seg.mode, &ym) == start_touches {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            phi_step(ev, seg, ta, lo - ta, &ya, &mut phi)?;
            step.eval(lo, &mut ym);
            step.eval(hi, &mut ya);
            let sw = touch_switch(ev, seg, (lo, &ym), (hi, &ya), &start_touches)?;
            if let Some(x) = &sw.saltation {
                phi = x * phi;
            }
            switches.push(sw);
            ta = hi;
        }
    }
    Ok(phi)
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
    let fm = ev.eval(&*seg.controller, &seg.locked, tm, seg.mode, ym)?.f;
    let fp = ev.eval(&*seg.controller, &seg.locked, tp, seg.mode, yp)?.f;
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
    let den = (dg * f_minus)[0];
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
        let phi = segment_flow(&mut ev, seg, &mut out.touch_switches)?;
        total = &phi * total;
        out.segment_flows.push(phi);
        let event = exec.events.get(next_event).filter(|e| {
            e.t == seg.t1
                && (si + 1 < nseg
                    || e.kind == EventKind::Apex
                    || exec.termination == Termination::EventBudget)
        });
        let Some(event) = event else {
            if si + 1 < nseg {
                out.feature_changes.push(si);
                defined = false;
            }
            continue;
        };
        next_event += 1;
        let after = exec.segments.get(si + 1);
        let zero_time = seg.t1 == seg.t0 || after.is_some_and(|a| a.t1 == a.t0);
        let mut es = event_sensitivity(&mut ev, model, terrain, seg, after, event)?;
        if zero_time && es.status == SaltationStatus::Defined {
            es.status = SaltationStatus::Simultaneous;
            es.saltation = None;
        }
        if let (Some(dg), true) = (&es.guard_gradient, es.saltation.is_some()) {
            let mut y = vec![0.0; n2];
            seg.eval(seg.t1, &mut y);
            let f = ev
                .eval(&*seg.controller, &seg.locked, seg.t1, seg.mode, &y)?
                .f;
            let den = (dg * &f)[0];
            es.time_gradient = Some(-(dg * &total) / den);
        }
        match &es.saltation {
            Some(x) => total = x * total,
            None => defined = false,
        }
        out.events.push(es);
    }
    // events not matched to a segment end, switches not differentiated
    if next_event != exec.events.len()
        || out
            .touch_switches
            .iter()
            .any(|s| s.status != SaltationStatus::Defined)
    {
        defined = false;
    }
    let ends_cleanly = matches!(
        exec.termination,
        Termination::FinalTime | Termination::Apex
    );
    if defined && ends_cleanly {
        out.state_jacobian = Some(total);
    }
    Ok(out)
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
) -> Result<EventSensitivity, SensitivityError> {
    let nq = model.nq();
    let n2 = 2 * nq;
    let t = event.t;
    let mut y = vec![0.0; n2];
    before.eval(t, &mut y);
    let (q, qd_minus) = y.split_at(nq);
    let fm = ev.eval(&*before.controller, &before.locked, t, before.mode, &y)?;
    let single = event.triggered.len() <= 1;
    let mut simultaneous = !single;
    // the guard's gradient and the reset's Jacobian
    let mut dr = DMatrix::identity(n2, n2);
    let mut y_plus = y.clone();
    let mut kin = Kinematics::default();
    kin.compute(model, q, qd_minus);
    let mut impact_mode = None;
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
                return Ok(unsupported(
                    event,
                    format!("q̇⁺ is not a plastic impact into the mode after or a superset ({worst:.2e})"),
                ));
            };
            impact_mode = Some(m);
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
                return Ok(unsupported(event, "no normal row"));
            };
            if event.kind == EventKind::Liftoff {
                -fm.dlambda.row(rn)
            } else {
                let (Some(rt), Friction::Sticking { mu }) = (rt, model.contacts[k].friction) else {
                    return Ok(unsupported(
                        event,
                        "slip of a contact without a tangential row",
                    ));
                };
                -mu * fm.dlambda.row(rn) - fm.lambda[rt].signum() * fm.dlambda.row(rt)
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
        EventKind::Fold | EventKind::FoldPassed => {
            return Ok(unsupported(event, "fold events are not differentiated yet"));
        }
    };
    if event.kind != EventKind::Touchdown {
        // no velocity jump: the reset is the identity in state
        let jump = qd_minus
            .iter()
            .zip(&event.qd_after)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if jump > 0.0 {
            return Ok(unsupported(
                event,
                format!("velocity jump {jump:.2e} at a non-impact event"),
            ));
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
    if let Err(status) = saltation(&dr, &fm.f, &fm.f, &dg) {
        es.status = status;
        return Ok(es);
    }
    if simultaneous {
        es.status = SaltationStatus::Simultaneous;
        return Ok(es);
    }
    let f_plus = match (event.kind, after) {
        (EventKind::Apex, _) => DVector::zeros(n2),
        (_, Some(a)) => {
            ev.eval(&*a.controller, &a.locked, t, event.mode_after, &y_plus)?
                .f
        }
        (_, None) => {
            // the run ended at this event (its event budget): no flow after it to salt with
            es.status = SaltationStatus::Unsupported {
                reason: "no flow after the run's last event".into(),
            };
            return Ok(es);
        }
    };
    match saltation(&dr, &fm.f, &f_plus, &dg) {
        Ok(x) => es.saltation = Some(x),
        Err(status) => es.status = status,
    }
    Ok(es)
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
