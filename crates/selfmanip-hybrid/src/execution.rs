//! Executions of the hybrid system: integrate a mode's flow, locate the first guard on the
//! dense output, apply the reset (impact or liftoff) chosen by complementarity, repeat.
//!
//! Guards (all *positive-to-nonpositive*, armed only once strictly positive so that a contact
//! that has just been made or broken cannot re-trigger at once — no chattering at zero):
//! - touchdown of an inactive contact: its height `a_k(q)` above the ground (Definition 5.4);
//! - liftoff of an active contact: its normal force `U λ_n` (pushing positive) (5.51);
//! - apex (terminal, optional): the upward body speed `−ż` in flight.
//!
//! Resets: a touchdown is a plastic impact. Every candidate contact set `J` among the active
//! and touching contacts is tried (exact enumeration): `J` is accepted when each of its
//! contacts has a non-negative normal impulse, either `U(P_λ)` or — the pseudo-impulse —
//! `U(P_λ + P_δ)` (5.40), and each left-out contact `k` would need a negative one in
//! `J ∪ {k}` (5.28)–(5.29). The same rule on forces instead of impulses selects the contacts
//! that persist when a normal force reaches zero (5.19)–(5.20). Exactly one accepted set is
//! applied; none or several end the execution with a typed [`Termination`]. A contact set
//! whose rows are redundant (two sticking corners on a plane) drops tangential rows, as the
//! thesis does for the rocking block (footnote 8 of section 5.1.4).
use crate::dopri::{DenseStep, Dopri5, StepError, StepOptions};
use selfmanip_core::contact::{contact_geometry, ContactKind, RowDirection};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{
    forward_dynamics, kinetic_energy, plastic_impact, pseudo_impulse, ContactMode, CoreError, Data,
    Model, SingularityKind, Terrain,
};
use thiserror::Error;

/// Joint torques (and the motion of free massless joints) as functions of time and state.
pub trait Controller {
    fn torque(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode, tau: &mut [f64]);
    /// Prescribed accelerations of free massless joints (thesis 5.1.1); default 0.
    fn free_joint_qdd(
        &self,
        _t: f64,
        _q: &[f64],
        _qd: &[f64],
        _free_joints: &[usize],
        out: &mut [f64],
    ) {
        out.fill(0.0);
    }
}

/// No actuation.
#[derive(Debug, Clone, Copy, Default)]
pub struct ZeroTorque;

impl Controller for ZeroTorque {
    fn torque(&self, _t: f64, _q: &[f64], _qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        tau.fill(0.0);
    }
}

/// Options of an execution.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HybridOptions {
    pub step: StepOptions,
    /// Width of the bracket that locates a guard's zero (s).
    pub event_tol_s: f64,
    /// Pseudo-impulse duration δt of (5.39) (s); 0 disables it.
    pub delta_t_s: f64,
    /// Zeno detection: more than `zeno_max_events` events within `zeno_window_s` stops the run.
    pub zeno_window_s: f64,
    pub zeno_max_events: usize,
    /// Total event budget.
    pub max_events: usize,
    /// Stop at the first apex of a flight phase.
    pub stop_at_apex: bool,
    /// A guard arms once it exceeds this margin (m for heights, N for forces).
    pub arm_margin: f64,
}

impl Default for HybridOptions {
    fn default() -> Self {
        HybridOptions {
            step: StepOptions::default(),
            event_tol_s: 1e-10,
            delta_t_s: 0.0,
            zeno_window_s: 0.01,
            zeno_max_events: 50,
            max_events: 10_000,
            stop_at_apex: false,
            arm_margin: 1e-9,
        }
    }
}

/// Errors that prevent an execution from starting or continuing.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum HybridError {
    #[error(transparent)]
    Core(#[from] CoreError),
    #[error("initial state is off the constraint manifold of its mode: `{field}` residual {residual:.3e}")]
    OffManifold { field: &'static str, residual: f64 },
    #[error("invalid option `{field}`: {reason}")]
    InvalidOption { field: &'static str, reason: String },
    #[error("step size fell to {h_s:.3e} s at t = {t_s} s")]
    StepTooSmall { t_s: f64, h_s: f64 },
    #[error("{n} candidate contacts are too many for exact enumeration (at most 10)")]
    TooManyContacts { n: usize },
}

/// What kind of guard fired.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum EventKind {
    /// New contacts touched down: a plastic impact.
    Touchdown,
    /// Normal forces reached zero: contacts released without impact.
    Liftoff,
    /// The body reached its highest point in flight (terminal).
    Apex,
}

/// One reset of the execution.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    pub t: f64,
    pub kind: EventKind,
    pub mode_before: ContactMode,
    pub mode_after: ContactMode,
    /// Contacts that fired the guard.
    pub triggered: Vec<usize>,
    /// Contact impulse `P_λ` into `mode_after` (rows of `mode_after`; empty for liftoff).
    pub impulse: Vec<f64>,
    /// Pseudo-impulse `P_δ` into `mode_after` (empty when δt = 0).
    pub pseudo_impulse: Vec<f64>,
    pub kinetic_before: f64,
    pub kinetic_after: f64,
}

/// A stretch of flow in one mode, with its dense output.
#[derive(Debug, Clone)]
pub struct Segment {
    pub mode: ContactMode,
    pub t0: f64,
    pub t1: f64,
    pub steps: Vec<DenseStep>,
}

impl Segment {
    /// State `[q; q̇]` at `t` in the segment.
    pub fn eval(&self, t: f64, y: &mut [f64]) {
        let i = self
            .steps
            .partition_point(|s| s.t1() < t)
            .min(self.steps.len().saturating_sub(1));
        self.steps[i].eval(t, y);
    }
}

/// Why an execution ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Termination {
    FinalTime,
    Apex,
    /// More than the allowed number of events in the Zeno window.
    Zeno {
        t: f64,
        events_in_window: usize,
    },
    EventBudget,
    /// No contact set satisfies complementarity.
    NoContactSolution {
        t: f64,
    },
    /// Several contact sets satisfy complementarity.
    SeveralContactSolutions {
        t: f64,
        candidates: Vec<ContactMode>,
    },
}

/// The record of one execution.
#[derive(Debug, Clone)]
pub struct Execution {
    pub segments: Vec<Segment>,
    pub events: Vec<Event>,
    pub termination: Termination,
    pub t: f64,
    pub q: Vec<f64>,
    pub qd: Vec<f64>,
    pub mode: ContactMode,
}

impl Execution {
    /// Kinetic energy lost in each impact (never negative for a correct reset).
    pub fn impact_losses(&self) -> Vec<f64> {
        self.events
            .iter()
            .filter(|e| e.kind == EventKind::Touchdown)
            .map(|e| e.kinetic_before - e.kinetic_after)
            .collect()
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Guard {
    Touchdown(usize),
    Liftoff { contact: usize, row: usize },
    Apex,
}

struct Sim<'a> {
    model: &'a Model,
    terrain: &'a dyn Terrain,
    ctrl: &'a dyn Controller,
    opts: HybridOptions,
    data: Data,
    kin: Kinematics,
    tau: Vec<f64>,
    free: Vec<f64>,
}

impl<'a> Sim<'a> {
    fn nq(&self) -> usize {
        self.model.nq()
    }

    fn dynamics(
        &mut self,
        t: f64,
        mode: ContactMode,
        q: &[f64],
        qd: &[f64],
    ) -> Result<(), CoreError> {
        flow(
            self.model,
            self.terrain,
            self.ctrl,
            &mut self.data,
            &mut self.tau,
            &mut self.free,
            t,
            mode,
            q,
            qd,
        )
    }

    fn guard_value(
        &mut self,
        g: Guard,
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<f64, CoreError> {
        let nq = self.nq();
        let (q, qd) = y.split_at(nq);
        Ok(match g {
            Guard::Touchdown(k) => {
                self.kin.compute(self.model, q, qd);
                contact_geometry(self.model, &self.kin, self.terrain, k).gap_m
            }
            Guard::Liftoff { row, .. } => {
                self.dynamics(t, mode, q, qd)?;
                -self.data.lambda[row]
            }
            Guard::Apex => -qd[self.model.ix_z()],
        })
    }

    fn guards(&self, mode: ContactMode) -> Vec<Guard> {
        let mut g: Vec<Guard> = (0..self.model.n_contacts())
            .filter(|&k| !mode.contains(k))
            .map(Guard::Touchdown)
            .collect();
        for (row, r) in mode.rows().enumerate() {
            if r.direction == RowDirection::Normal {
                g.push(Guard::Liftoff {
                    contact: r.contact,
                    row,
                });
            }
        }
        if self.opts.stop_at_apex && mode.is_flight() {
            g.push(Guard::Apex);
        }
        g
    }

    /// Normal components `U(·)_n` (pushing positive) of a row vector in `mode`, by contact.
    fn normal_push(mode: ContactMode, v: &[f64]) -> Vec<(usize, f64)> {
        mode.rows()
            .zip(v)
            .filter(|(r, _)| r.direction == RowDirection::Normal)
            .map(|(r, &x)| (r.contact, -x))
            .collect()
    }

    /// The mode for contact set `set`, dropping tangential rows if they are redundant.
    fn mode_for(
        &mut self,
        set: &[usize],
        q: &[f64],
        qd: &[f64],
    ) -> Result<Option<ContactMode>, CoreError> {
        let base = ContactMode::with_defaults(self.model, set)?;
        let mut candidates = vec![base];
        for &k in set {
            let last = *candidates.last().expect("non-empty");
            if last.kind(k) == Some(ContactKind::Stick) {
                candidates.push(last.with(k, ContactKind::Slide));
            }
        }
        for m in candidates {
            match self.data.prepare(self.model, self.terrain, m, q, qd) {
                Ok(()) => return Ok(Some(m)),
                Err(CoreError::SingularKkt {
                    kind: SingularityKind::RedundantConstraints,
                    ..
                }) => continue,
                Err(CoreError::SingularKkt { .. }) => return Ok(None),
                Err(e) => return Err(e),
            }
        }
        Ok(None)
    }

    /// Normal pushes `max(U P, U (P + P_δ))` (impacts) or `U λ` (forces) of each contact of `set`.
    fn pushes(
        &mut self,
        t: f64,
        set: &[usize],
        q: &[f64],
        qd: &[f64],
        impact: bool,
    ) -> Result<Option<(ContactMode, Vec<(usize, f64)>, Vec<f64>, Vec<f64>)>, CoreError> {
        let Some(mode) = self.mode_for(set, q, qd)? else {
            return Ok(None);
        };
        if impact {
            let imp = plastic_impact(self.model, &mut self.data, self.terrain, mode, q, qd)?;
            let p: Vec<f64> = imp.impulse.iter().copied().collect();
            let mut push = Self::normal_push(mode, &p);
            let mut pd = Vec::new();
            if self.opts.delta_t_s > 0.0 {
                self.tau.resize(self.model.n_joints(), 0.0);
                self.ctrl.torque(t, q, qd, mode, &mut self.tau);
                let d = pseudo_impulse(
                    self.model,
                    &mut self.data,
                    self.terrain,
                    mode,
                    q,
                    qd,
                    &self.tau,
                    self.opts.delta_t_s,
                )?;
                pd = d.iter().copied().collect();
                let sum: Vec<f64> = p.iter().zip(&pd).map(|(a, b)| a + b).collect();
                for ((_, u), (_, u2)) in push.iter_mut().zip(Self::normal_push(mode, &sum)) {
                    *u = u.max(u2);
                }
            }
            Ok(Some((mode, push, p, pd)))
        } else {
            self.dynamics(t, mode, q, qd)?;
            let l: Vec<f64> = self.data.lambda.iter().copied().collect();
            Ok(Some((mode, Self::normal_push(mode, &l), l, Vec::new())))
        }
    }

    /// Complementarity over the subsets of `candidates` (contacts that must be in: none).
    fn select(
        &mut self,
        t: f64,
        candidates: &[usize],
        q: &[f64],
        qd: &[f64],
        impact: bool,
    ) -> Result<Result<(ContactMode, Vec<f64>, Vec<f64>), Termination>, HybridError> {
        let n = candidates.len();
        if n > 10 {
            return Err(HybridError::TooManyContacts { n });
        }
        let tol = 1e-12;
        let mut accepted = Vec::new();
        for bits in 0u32..(1 << n) {
            let set: Vec<usize> = (0..n)
                .filter(|i| bits >> i & 1 == 1)
                .map(|i| candidates[i])
                .collect();
            let Some((mode, push, p, pd)) = self.pushes(t, &set, q, qd, impact)? else {
                continue;
            };
            if push.iter().any(|&(_, u)| u < -tol) {
                continue;
            }
            let mut separates = true;
            for i in (0..n).filter(|i| bits >> i & 1 == 0) {
                let mut with_k = set.clone();
                with_k.push(candidates[i]);
                with_k.sort_unstable();
                match self.pushes(t, &with_k, q, qd, impact)? {
                    Some((_, pk, _, _)) => {
                        let uk = pk
                            .iter()
                            .find(|(c, _)| *c == candidates[i])
                            .map(|x| x.1)
                            .unwrap_or(0.0);
                        if uk >= -tol {
                            separates = false;
                        }
                    }
                    None => {} // singular with k: k cannot be held, it separates
                }
            }
            if separates {
                accepted.push((mode, p, pd));
            }
        }
        match accepted.len() {
            1 => Ok(Ok(accepted.pop().expect("one"))),
            0 => Ok(Err(Termination::NoContactSolution { t })),
            _ => Ok(Err(Termination::SeveralContactSolutions {
                t,
                candidates: accepted.into_iter().map(|a| a.0).collect(),
            })),
        }
    }
}

/// The flow (5.48) of `mode` at `(t, q, q̇)`: the controller's torques and free-joint
/// accelerations, then (5.3)–(5.4); results in `data.qdd`, `data.lambda`.
#[allow(clippy::too_many_arguments)]
fn flow(
    model: &Model,
    terrain: &dyn Terrain,
    ctrl: &dyn Controller,
    data: &mut Data,
    tau: &mut Vec<f64>,
    free: &mut Vec<f64>,
    t: f64,
    mode: ContactMode,
    q: &[f64],
    qd: &[f64],
) -> Result<(), CoreError> {
    tau.resize(model.n_joints(), 0.0);
    ctrl.torque(t, q, qd, mode, tau);
    // which joints are free (massless, untouched) is known after `prepare`
    data.prepare(model, terrain, mode, q, qd)?;
    free.resize(data.free_joints.len(), 0.0);
    ctrl.free_joint_qdd(t, q, qd, &data.free_joints, free);
    forward_dynamics(model, data, terrain, mode, q, qd, tau, Some(free))
}

/// `T = ½ q̇ᵀ M̄ q̇` at `(q, q̇)`. `M̄` does not depend on the contacts, so the flight mode is
/// prepared; its KKT may be singular (free massless legs), which does not matter here.
fn kinetic_energy_at(
    model: &Model,
    terrain: &dyn Terrain,
    data: &mut Data,
    q: &[f64],
    qd: &[f64],
) -> Result<f64, CoreError> {
    data.prepare(model, terrain, ContactMode::FLIGHT, q, qd)
        .or_else(|e| match e {
            CoreError::SingularKkt { .. } => Ok(()),
            e => Err(e),
        })?;
    Ok(kinetic_energy(data, qd))
}

/// Runs the hybrid system from `(q0, qd0)` in `mode0` until `t_final` or a terminal event.
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    model: &Model,
    terrain: &dyn Terrain,
    controller: &dyn Controller,
    mode0: ContactMode,
    q0: &[f64],
    qd0: &[f64],
    t_final: f64,
    opts: HybridOptions,
) -> Result<Execution, HybridError> {
    if !(opts.event_tol_s > 0.0) {
        return Err(HybridError::InvalidOption {
            field: "event_tol_s",
            reason: "must be positive".into(),
        });
    }
    if !(opts.delta_t_s >= 0.0) || !opts.delta_t_s.is_finite() {
        return Err(HybridError::InvalidOption {
            field: "delta_t_s",
            reason: "must be finite and non-negative".into(),
        });
    }
    if !t_final.is_finite() {
        return Err(HybridError::InvalidOption {
            field: "t_final",
            reason: "must be finite".into(),
        });
    }
    let nq = model.nq();
    let mut sim = Sim {
        model,
        terrain,
        ctrl: controller,
        opts,
        data: Data::new(model),
        kin: Kinematics::default(),
        tau: vec![0.0; model.n_joints()],
        free: Vec::new(),
    };
    // the initial state must satisfy its mode's constraints
    sim.data.prepare(model, terrain, mode0, q0, qd0)?;
    let vres = (&sim.data.constraints.a * nalgebra_vec(qd0)).amax();
    if vres > 1e-8 {
        return Err(HybridError::OffManifold {
            field: "qd",
            residual: vres,
        });
    }
    sim.kin.compute(model, q0, qd0);
    for k in mode0.active() {
        let gap = contact_geometry(model, &sim.kin, terrain, k).gap_m;
        if gap.abs() > 1e-8 {
            return Err(HybridError::OffManifold {
                field: "q",
                residual: gap.abs(),
            });
        }
    }

    let mut y: Vec<f64> = q0.iter().chain(qd0).copied().collect();
    let mut t = 0.0;
    let mut mode = mode0;
    let mut segments = Vec::new();
    let mut events: Vec<Event> = Vec::new();
    let mut ydense = vec![0.0; 2 * nq];
    let termination = 'run: loop {
        // ---- flow in `mode` until a guard fires or t_final
        let guards = sim.guards(mode);
        let mut armed: Vec<bool> = Vec::with_capacity(guards.len());
        let mut last: Vec<f64> = Vec::with_capacity(guards.len());
        // how far below zero an unarmed guard must go to fire: `arm_margin` below its start
        // when it starts at or below zero (a contact released slightly inside the ground)
        let mut unarmed_shift: Vec<f64> = Vec::with_capacity(guards.len());
        for &g in &guards {
            let v = sim.guard_value(g, t, mode, &y)?;
            armed.push(v > opts.arm_margin);
            last.push(v);
            unarmed_shift.push(opts.arm_margin + (-v).max(0.0));
        }
        let mut seg = Segment {
            mode,
            t0: t,
            t1: t,
            steps: Vec::new(),
        };
        let mut rhs_data = Data::new(model);
        let ctrl = controller;
        let mut tau = vec![0.0; model.n_joints()];
        let mut free = Vec::new();
        let mut rhs = |tt: f64, yy: &[f64], dy: &mut [f64]| -> Result<(), CoreError> {
            let (q, qd) = yy.split_at(nq);
            flow(
                model,
                terrain,
                ctrl,
                &mut rhs_data,
                &mut tau,
                &mut free,
                tt,
                mode,
                q,
                qd,
            )?;
            dy[..nq].copy_from_slice(qd);
            dy[nq..].copy_from_slice(rhs_data.qdd.as_slice());
            Ok(())
        };
        let mut ode = Dopri5::new(&mut rhs, 2 * nq, opts.step);
        let mut dense = DenseStep::default();
        let fired: Option<(f64, Vec<Guard>)> = loop {
            if t >= t_final {
                break None;
            }
            match ode.step(t, &mut y, t_final, &mut dense) {
                Ok(()) => {}
                Err(StepError::Rhs(e)) => return Err(e.into()),
                Err(StepError::StepTooSmall(h)) => {
                    return Err(HybridError::StepTooSmall { t_s: t, h_s: h })
                }
            }
            // sample each guard inside the step; find the earliest sign change
            let samples = [0.25, 0.5, 0.75, 1.0];
            // an unarmed guard (one that has not yet been clearly positive, e.g. a contact
            // just released at zero height) fires only once it is clearly negative, at
            // `−arm_margin`: no chatter at zero, and no tunnelling through the ground when a
            // swing is too small or too short to arm it
            let shift = |armed: bool, gi: usize| if armed { 0.0 } else { unarmed_shift[gi] };
            let mut earliest: Option<(f64, f64, usize, f64)> = None; // (lo, hi, guard, shift)
            for (gi, &g) in guards.iter().enumerate() {
                let mut prev_t = dense.t0;
                let mut prev_v = last[gi];
                for &s in &samples {
                    let ts = dense.t0 + s * dense.h;
                    dense.eval(ts, &mut ydense);
                    let v = sim.guard_value(g, ts, mode, &ydense)?;
                    let sh = shift(armed[gi], gi);
                    if prev_v + sh > 0.0 && v + sh <= 0.0 {
                        if earliest.is_none_or(|(lo, _, _, _)| prev_t < lo) {
                            earliest = Some((prev_t, ts, gi, sh));
                        }
                        break;
                    }
                    if v > opts.arm_margin {
                        armed[gi] = true;
                    }
                    prev_t = ts;
                    prev_v = v;
                }
            }
            if let Some((mut lo, mut hi, gi, sh)) = earliest {
                // bisection on the interpolant (robust; ~30 halvings reach 1e-10 s)
                while hi - lo > opts.event_tol_s {
                    let mid = 0.5 * (lo + hi);
                    dense.eval(mid, &mut ydense);
                    if sim.guard_value(guards[gi], mid, mode, &ydense)? + sh > 0.0 {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                // every other armed guard that has also crossed by `hi` fires with it
                dense.eval(hi, &mut ydense);
                let mut set = Vec::new();
                for (gj, &g) in guards.iter().enumerate() {
                    if gj == gi
                        || sim.guard_value(g, hi, mode, &ydense)? + shift(armed[gj], gj) <= 0.0
                    {
                        set.push(g);
                    }
                }
                seg.steps.push(dense.clone());
                seg.t1 = hi;
                t = hi;
                y.copy_from_slice(&ydense);
                break Some((hi, set));
            }
            seg.steps.push(dense.clone());
            t = dense.t1();
            seg.t1 = t;
            for (gi, &g) in guards.iter().enumerate() {
                last[gi] = sim.guard_value(g, t, mode, &y)?;
            }
        };
        drop(ode);
        segments.push(seg);
        let Some((te, fired)) = fired else {
            break 'run Termination::FinalTime;
        };

        // ---- reset
        let (q, qd) = y.split_at(nq);
        let (q, qd) = (q.to_vec(), qd.to_vec());
        if fired.contains(&Guard::Apex) {
            events.push(Event {
                t: te,
                kind: EventKind::Apex,
                mode_before: mode,
                mode_after: mode,
                triggered: vec![],
                impulse: vec![],
                pseudo_impulse: vec![],
                kinetic_before: f64::NAN,
                kinetic_after: f64::NAN,
            });
            break 'run Termination::Apex;
        }
        let touched: Vec<usize> = fired
            .iter()
            .filter_map(|g| {
                if let Guard::Touchdown(k) = g {
                    Some(*k)
                } else {
                    None
                }
            })
            .collect();
        let released: Vec<usize> = fired
            .iter()
            .filter_map(|g| {
                if let Guard::Liftoff { contact, .. } = g {
                    Some(*contact)
                } else {
                    None
                }
            })
            .collect();
        let ke_before = kinetic_energy_at(model, terrain, &mut sim.data, &q, &qd)?;
        let impact = !touched.is_empty();
        let mut candidates: Vec<usize> = mode.active().chain(touched.iter().copied()).collect();
        candidates.sort_unstable();
        candidates.dedup();
        let (new_mode, p, pd) = match sim.select(te, &candidates, &q, &qd, impact)? {
            Ok(x) => x,
            Err(term) => break 'run term,
        };
        let mut qd_new = qd.clone();
        if impact {
            let imp = plastic_impact(model, &mut sim.data, terrain, new_mode, &q, &qd)?;
            qd_new.copy_from_slice(imp.qd_plus.as_slice());
        }
        // contacts kept by the impact must also hold in force (5.19)–(5.20)
        let mut after_mode = new_mode;
        if impact && !after_mode.is_flight() {
            let kept: Vec<usize> = after_mode.active().collect();
            match sim.select(te, &kept, &q, &qd_new, false)? {
                Ok((m, _, _)) => after_mode = m,
                Err(term) => break 'run term,
            }
        }
        let ke_after = kinetic_energy_at(model, terrain, &mut sim.data, &q, &qd_new)?;
        events.push(Event {
            t: te,
            kind: if impact {
                EventKind::Touchdown
            } else {
                EventKind::Liftoff
            },
            mode_before: mode,
            mode_after: after_mode,
            triggered: if impact { touched } else { released },
            impulse: p,
            pseudo_impulse: pd,
            kinetic_before: ke_before,
            kinetic_after: ke_after,
        });
        y[nq..].copy_from_slice(&qd_new);
        mode = after_mode;
        if events.len() >= opts.max_events {
            break 'run Termination::EventBudget;
        }
        let in_window = events
            .iter()
            .rev()
            .take_while(|e| e.t > te - opts.zeno_window_s)
            .count();
        if in_window > opts.zeno_max_events {
            break 'run Termination::Zeno {
                t: te,
                events_in_window: in_window,
            };
        }
    };
    Ok(Execution {
        segments,
        events,
        termination,
        t,
        q: y[..nq].to_vec(),
        qd: y[nq..].to_vec(),
        mode,
    })
}

fn nalgebra_vec(v: &[f64]) -> nalgebra::DVector<f64> {
    nalgebra::DVector::from_column_slice(v)
}
