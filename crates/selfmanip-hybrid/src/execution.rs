//! Executions of the hybrid system: integrate a mode's flow, locate the first guard on the
//! dense output, apply the reset (impact or liftoff) chosen by complementarity, repeat.
//!
//! Guards (all *positive-to-nonpositive*, armed only once strictly positive so that a contact
//! that has just been made or broken cannot re-trigger at once — no chattering at zero):
//! - touchdown of an inactive contact: its height `a_k(q)` above the ground (Definition 5.4);
//! - liftoff of an active contact: its normal force `U λ_n` (pushing positive) (5.51);
//! - apex (terminal, optional): the upward body speed `−ż` in flight;
//! - stick→slip of a sticking contact with finite Coulomb `μ` (section 5.1.5): the cone margin
//!   `μ U(λ_n) − |λ_t|` (Drake's positive-then-non-positive);
//! - slip→stick of a sliding contact that can stick: its tangential sliding velocity `v_t`
//!   crosses zero (armed once `|v_t|` exceeds the margin, oriented by its sign then).
//!
//! Friction (Assumption 5.9): sliding contacts have no kinetic friction (`μ_k = 0`). A
//! sticking contact is kept sticking only while its force — or, at an impact, its impulse —
//! lies in the cone `|λ_t| ≤ μ U(λ_n)`; otherwise it slides. A contact that starts to slide
//! stays sliding until its velocity crosses zero; it then sticks only if the sticking force
//! lies in the cone, so stick and slip cannot cycle at zero velocity.
//!
//! Resets: a touchdown is a plastic impact. Every candidate contact set `J` among the active
//! and touching contacts is tried (exact enumeration): `J` is accepted when each of its
//! contacts has a non-negative normal impulse, either `U(P_λ)` or — the pseudo-impulse —
//! `U(P_λ + P_δ)` (5.40), and each left-out contact `k` would need a negative one in
//! `J ∪ {k}` (5.28)–(5.29). The same rule on forces instead of impulses selects the contacts
//! that persist when a normal force reaches zero (5.19)–(5.20). Exactly one accepted set is
//! applied; none or several end the execution with a typed [`Termination`]. Beyond
//! [`ENUMERATION_LIMIT`] candidates (all frictionless) the same problems are solved as a
//! convex QP with clarabel ([`crate::impact_qp`]). A contact set
//! whose rows are redundant (two sticking corners on a plane) drops tangential rows, as the
//! thesis does for the rocking block (footnote 8 of section 5.1.4).
//!
//! Two tie-breaks keep events from repeating on round-off: a contact whose liftoff guard
//! located its force root is released there (a force at round-off level does not hold it),
//! and a contact touching down on a massless link whose sticking impulse would pull slides
//! along the surface instead of letting go (released, the link's prescribed motion would
//! carry it into the ground again at the same instant).
//!
//! Terrain: an active contact stays on the feature (plane or convex corner) it had at the
//! start of its segment, or passes onto the next one continuously — a circle from a face
//! onto the edge at its top, and on over it onto the top, its gap and normal continuous:
//! the segment ends there (located to the event tolerance, the step taken again up to it,
//! no event) and the next one starts on the new feature. A contact that leaves its surface
//! otherwise (a point crossing an edge, any site reaching a concave corner, where it would
//! touch two surfaces) ends the execution with [`Termination::TerrainDiscontinuity`].
use crate::dopri::{DenseStep, Dopri5, StepError, StepOptions};
use crate::impact_qp::{self, ContactQpError, QpOutcome};
use selfmanip_core::contact::{contact_geometry, ContactGeometry, ContactKind, RowDirection};
use selfmanip_core::inertia::potential_energy;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::model::Friction;
use selfmanip_core::{
    forward_dynamics_prepared, free_massless_joints, kinetic_energy, plastic_impact,
    plastic_impact_prepared, pseudo_impulse_prepared, ContactMode, CoreError, Data, Model,
    SingularityKind, Terrain,
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
    /// Called after every reset with the event just applied (for controllers whose phase
    /// depends on the contact history, e.g. a leg that retracts once it has lifted off).
    fn on_event(&self, _event: &Event) {}
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
    /// More candidates than [`ENUMERATION_LIMIT`], not all frictionless: the convex QP that
    /// takes over beyond the limit covers frictionless contacts only.
    #[error("{n} candidate contacts are too many for exact enumeration (at most {ENUMERATION_LIMIT}) and contact {sticking} can stick: the QP path is frictionless only")]
    TooManyContacts { n: usize, sticking: usize },
    #[error(transparent)]
    ContactQp(#[from] ContactQpError),
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
    /// Sticking contacts reached the friction cone and started to slide.
    Slip,
    /// Sliding contacts reached zero sliding velocity (and stuck, if `mode_after` says so).
    Stick,
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
    /// Configuration at the event.
    pub q: Vec<f64>,
    /// Velocity after the reset (before it for liftoff, slip, stick and apex: no jump).
    pub qd_after: Vec<f64>,
}

/// A stretch of flow in one mode, with its dense output. A segment ends at an event, or
/// where a contact passes onto the next feature of the terrain (no event); one of zero
/// duration (a mode passed through at one instant) has no steps.
#[derive(Debug, Clone)]
pub struct Segment {
    pub mode: ContactMode,
    pub t0: f64,
    pub t1: f64,
    /// State `[q; q̇]` at `t0`.
    pub y0: Vec<f64>,
    pub steps: Vec<DenseStep>,
}

impl Segment {
    /// State `[q; q̇]` at `t` in the segment (its start state if it has no steps).
    pub fn eval(&self, t: f64, y: &mut [f64]) {
        if self.steps.is_empty() {
            y.copy_from_slice(&self.y0);
            return;
        }
        let i = self
            .steps
            .partition_point(|s| s.t1() < t)
            .min(self.steps.len() - 1);
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
    /// The flow of `mode` reached a state where its KKT matrix is singular (Lemma 5.1), e.g.
    /// a massless leg whose sliding contact stops pinning it; `t` is the start of the step
    /// that met it.
    SingularFlow {
        t: f64,
        mode: ContactMode,
        kind: SingularityKind,
        condition_estimate: f64,
    },
    /// A contact met a place of the terrain that is not a contact feature for it (a point
    /// at a ledge's edge, any site at the concave foot of its face): an inactive contact's
    /// height jumped through zero, or an active contact left the surface it was on other
    /// than onto a continuing feature (located to the event tolerance); `t` is
    /// when, `gap_m` the contact's height there.
    TerrainDiscontinuity {
        t: f64,
        contact: usize,
        gap_m: f64,
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
    Liftoff {
        contact: usize,
        row: usize,
    },
    Apex,
    /// Cone margin `μ U(λ_n) − |λ_t|` of a sticking contact.
    Slip {
        contact: usize,
        t_row: usize,
        n_row: usize,
        mu: f64,
    },
    /// Tangential sliding velocity of a sliding contact that can stick.
    Stick(usize),
}

impl Guard {
    /// Whether the guard's value needs the flow (the contact forces), not just kinematics.
    fn needs_flow(self) -> bool {
        matches!(self, Guard::Liftoff { .. } | Guard::Slip { .. })
    }
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
    /// `(t, mode)` of the flow whose results `data` holds, at the state `flow_y`: the
    /// integrator's stages and the guards share them (the last stage of a step is its end
    /// point, where the guards are sampled; several force guards share one sample).
    flow_key: Option<(f64, ContactMode)>,
    flow_y: Vec<f64>,
    /// The state `[q; q̇]` at which `kin` was computed, if it is current.
    kin_y: Option<Vec<f64>>,
}

impl<'a> Sim<'a> {
    fn nq(&self) -> usize {
        self.model.nq()
    }

    /// Whether `data` holds the flow (and so the kinematics) at state `(q, q̇)`.
    fn flow_at(&self, q: &[f64], qd: &[f64]) -> bool {
        self.flow_key.is_some() && self.flow_y[..q.len()] == *q && self.flow_y[q.len()..] == *qd
    }

    /// The flow of `mode` at `(t, q, q̇)` into `data`, unless it holds it already.
    fn dynamics(
        &mut self,
        t: f64,
        mode: ContactMode,
        q: &[f64],
        qd: &[f64],
    ) -> Result<(), CoreError> {
        if self.flow_key == Some((t, mode)) && self.flow_at(q, qd) {
            return Ok(());
        }
        self.flow_key = None;
        self.data.prepare(self.model, self.terrain, mode, q, qd)?;
        self.dynamics_prepared(t, mode, q, qd)
    }

    /// Records that `data` holds the flow of `mode` at `(t, q, q̇)`.
    fn holds_flow(&mut self, t: f64, mode: ContactMode, q: &[f64], qd: &[f64]) {
        self.flow_y.clear();
        self.flow_y.extend_from_slice(q);
        self.flow_y.extend_from_slice(qd);
        self.flow_key = Some((t, mode));
    }

    /// [`Self::dynamics`] when `data` was just prepared at `(mode, q, q̇)`: the solve only.
    fn dynamics_prepared(
        &mut self,
        t: f64,
        mode: ContactMode,
        q: &[f64],
        qd: &[f64],
    ) -> Result<(), CoreError> {
        flow_prepared(
            self.model,
            self.ctrl,
            &mut self.data,
            &mut self.tau,
            &mut self.free,
            t,
            mode,
            q,
            qd,
        )?;
        self.holds_flow(t, mode, q, qd);
        Ok(())
    }

    /// The integrator's right-hand side `ẏ = [q̇; q̈]` of the flow of `mode`.
    fn rhs(
        &mut self,
        t: f64,
        mode: ContactMode,
        y: &[f64],
        dy: &mut [f64],
    ) -> Result<(), CoreError> {
        let nq = self.nq();
        let (q, qd) = y.split_at(nq);
        self.dynamics(t, mode, q, qd)?;
        dy[..nq].copy_from_slice(qd);
        dy[nq..].copy_from_slice(self.data.qdd.as_slice());
        Ok(())
    }

    /// Poses and velocities at `(q, q̇)`: those of the flow if `data` holds it there, else
    /// computed once per state.
    fn kinematics(&mut self, q: &[f64], qd: &[f64]) -> &Kinematics {
        if self.flow_at(q, qd) {
            return &self.data.kin;
        }
        let nq = q.len();
        let current = self
            .kin_y
            .as_ref()
            .is_some_and(|y| y[..nq] == *q && y[nq..] == *qd);
        if !current {
            self.kin.compute(self.model, q, qd);
            let y = self.kin_y.get_or_insert_with(Vec::new);
            y.clear();
            y.extend_from_slice(q);
            y.extend_from_slice(qd);
        }
        &self.kin
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
        let (model, terrain) = (self.model, self.terrain);
        Ok(match g {
            Guard::Touchdown(k) => {
                contact_geometry(model, self.kinematics(q, qd), terrain, k).gap_m
            }
            Guard::Liftoff { row, .. } => {
                self.dynamics(t, mode, q, qd)?;
                -self.data.lambda[row]
            }
            Guard::Apex => -qd[self.model.ix_z()],
            Guard::Slip {
                t_row, n_row, mu, ..
            } => {
                self.dynamics(t, mode, q, qd)?;
                mu * (-self.data.lambda[n_row]) - self.data.lambda[t_row].abs()
            }
            Guard::Stick(k) => sliding_velocity(model, self.kinematics(q, qd), terrain, k),
        })
    }

    /// The geometry of contact `k` at `y = [q; q̇]`.
    fn geometry(&mut self, k: usize, y: &[f64]) -> ContactGeometry {
        let (q, qd) = y.split_at(self.nq());
        let (model, terrain) = (self.model, self.terrain);
        contact_geometry(model, self.kinematics(q, qd), terrain, k)
    }

    /// The terrain feature (plane or corner) each active contact of `mode` is on at
    /// `y = [q; q̇]`.
    fn surfaces(&mut self, mode: ContactMode, y: &[f64]) -> Vec<(usize, ContactGeometry)> {
        mode.active().map(|k| (k, self.geometry(k, y))).collect()
    }

    /// An active contact that is no longer on the feature it had at the segment's start
    /// (`surfaces`, from [`Sim::surfaces`]), with its geometry at `y`: its height further
    /// than [`TERRAIN_STEP_M`] from zero (the surface ended under it: a point crossed a
    /// convex edge), or another feature is now nearer — the next face, the corner between
    /// two faces, or (at a concave corner, where one site would touch two surfaces) a face
    /// at an angle.
    fn off_surface(
        &mut self,
        surfaces: &[(usize, ContactGeometry)],
        y: &[f64],
    ) -> Option<(usize, ContactGeometry)> {
        surfaces.iter().find_map(|(k, start)| {
            let g = self.geometry(*k, y);
            (!g.same_feature(start) || g.gap_m.abs() > TERRAIN_STEP_M).then_some((*k, g))
        })
    }

    fn guards(&self, mode: ContactMode) -> Vec<Guard> {
        let mut g: Vec<Guard> = (0..self.model.n_contacts())
            .filter(|&k| !mode.contains(k))
            .map(Guard::Touchdown)
            .collect();
        let rows: Vec<_> = mode.rows().collect();
        for (row, r) in rows.iter().enumerate() {
            if r.direction != RowDirection::Normal {
                continue;
            }
            let k = r.contact;
            g.push(Guard::Liftoff { contact: k, row });
            let Friction::Sticking { mu } = self.model.contacts[k].friction else {
                continue;
            };
            match mode.kind(k) {
                Some(ContactKind::Stick) if mu.is_finite() => g.push(Guard::Slip {
                    contact: k,
                    t_row: row - 1,
                    n_row: row,
                    mu,
                }),
                Some(ContactKind::Slide) => g.push(Guard::Stick(k)),
                _ => {}
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

    /// The mode for contact set `set`: each contact's kind from `prefer` where it is active
    /// there (a sliding contact keeps sliding), its own default otherwise; tangential rows
    /// are dropped while they are redundant.
    fn mode_for(
        &mut self,
        set: &[usize],
        prefer: ContactMode,
        q: &[f64],
        qd: &[f64],
    ) -> Result<Option<ContactMode>, CoreError> {
        self.flow_key = None;
        let mut base = ContactMode::with_defaults(self.model, set)?;
        for &k in set {
            if let Some(kind) = prefer.kind(k) {
                base = base.with(k, kind);
            }
        }
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

    /// The first sticking contact with finite `μ` whose row vector `v` (force or impulse)
    /// leaves the Coulomb cone `|v_t| ≤ μ U(v_n)`.
    fn outside_cone(&self, mode: ContactMode, v: &[f64]) -> Option<usize> {
        let rows: Vec<_> = mode.rows().collect();
        (1..rows.len()).find_map(|i| {
            let (rt, rn) = (rows[i - 1], rows[i]);
            if rt.direction != RowDirection::Tangential || rn.contact != rt.contact {
                return None;
            }
            let Friction::Sticking { mu } = self.model.contacts[rn.contact].friction else {
                return None;
            };
            let push = -v[i];
            (mu.is_finite() && push >= 0.0 && v[i - 1].abs() > mu * push * (1.0 + 1e-12) + 1e-12)
                .then_some(rn.contact)
        })
    }

    /// Normal pushes (impacts: `U P` where it holds the contact, `U (P + P_δ)` otherwise,
    /// (5.40); forces: `U λ`) of each contact of `set`, in the mode that `set` takes: kinds from `prefer`, and a sticking contact whose
    /// impulse (force) leaves its friction cone slides instead (Assumption 5.9, 5.1.5).
    #[allow(clippy::type_complexity)]
    fn pushes(
        &mut self,
        t: f64,
        set: &[usize],
        prefer: ContactMode,
        q: &[f64],
        qd: &[f64],
        impact: bool,
    ) -> Result<Option<(ContactMode, Vec<(usize, f64)>, Vec<f64>, Vec<f64>)>, CoreError> {
        // contacts that `prefer` does not hold are the ones touching down now
        let before = prefer;
        let mut prefer = prefer;
        for _ in 0..=set.len() {
            // `mode_for` leaves `data` prepared at `(mode, q, q̇)`
            let Some(mode) = self.mode_for(set, prefer, q, qd)? else {
                return Ok(None);
            };
            let (push, p, pd, total) = if impact {
                let imp = plastic_impact_prepared(self.model, &mut self.data, qd)?;
                let p: Vec<f64> = imp.impulse.iter().copied().collect();
                let mut pd = Vec::new();
                let mut total = p.clone();
                if self.opts.delta_t_s > 0.0 {
                    // (5.38) leaves the argument of Υ open: the actuators act through the
                    // impact's δt at the velocity the impact leaves, q̇⁺ — it matters for a
                    // torque–speed line, and for a servo, whose damping resists the jump
                    self.tau.resize(self.model.n_joints(), 0.0);
                    self.ctrl
                        .torque(t, q, imp.qd_plus.as_slice(), mode, &mut self.tau);
                    let d = pseudo_impulse_prepared(
                        self.model,
                        &mut self.data,
                        &self.tau,
                        self.opts.delta_t_s,
                    )?;
                    pd = d.iter().copied().collect();
                    // (5.40): a contact whose own impulse holds it (U(P) > 0) stays; any
                    // other is judged by P + P_δ — including the zero-speed touchdowns whose
                    // impulse vanishes, where the pseudo-impulse is the force over δt
                    let rows: Vec<_> = mode.rows().collect();
                    for (i, r) in rows.iter().enumerate() {
                        let normal = rows
                            .iter()
                            .position(|x| {
                                x.contact == r.contact && x.direction == RowDirection::Normal
                            })
                            .expect("every contact has a normal row");
                        if -p[normal] <= IMPULSE_TOL_N_S {
                            total[i] = p[i] + pd[i];
                        }
                    }
                }
                let push = Self::normal_push(mode, &total);
                (push, p, pd, total)
            } else {
                self.dynamics_prepared(t, mode, q, qd)?;
                let l: Vec<f64> = self.data.lambda.iter().copied().collect();
                (Self::normal_push(mode, &l), l.clone(), Vec::new(), l)
            };
            let slides = self.outside_cone(mode, &total).or_else(|| {
                impact
                    .then(|| self.massless_pull(mode, before, &push))
                    .flatten()
            });
            match slides {
                Some(k) => prefer = mode.with(k, ContactKind::Slide),
                None => return Ok(Some((mode, push, p, pd))),
            }
        }
        Ok(None)
    }

    /// A contact touching down now (not held by `before`), sticking, on a massless link,
    /// whose push pulls at the impact: it slides instead of letting go. Released, a massless
    /// link keeps the motion its controller gives it in the air, which is what brought it
    /// into the ground: its touchdown would fire again at the same instant, for ever.
    /// Sliding, it "rotates out of the way" (Assumption 5.9) by following the surface, and
    /// its normal force is whatever its joint torque makes it — zero for a limp leg; whether
    /// it is kept is then decided as for any contact, by the sign of that push. Contacts
    /// already held are released on a pull as the thesis's rule says (Fig. 5.7's chatter).
    fn massless_pull(
        &self,
        mode: ContactMode,
        before: ContactMode,
        push: &[(usize, f64)],
    ) -> Option<usize> {
        push.iter()
            .filter(|&&(k, _)| !before.contains(k))
            .find_map(|&(k, u)| {
                let c = &self.model.contacts[k];
                let slidable = matches!(c.friction, Friction::Sticking { mu } if mu.is_finite());
                let massless = c.link.is_some_and(|j| self.model.distal_massless(j));
                (u < -IMPULSE_TOL_N_S
                    && slidable
                    && massless
                    && mode.kind(k) == Some(ContactKind::Stick))
                .then_some(k)
            })
    }

    /// Complementarity over the subsets of `candidates` (contacts that must be in: none),
    /// with contact kinds from `prefer`.
    ///
    /// `leaving` are contacts whose liftoff guard located the root of their force here: the
    /// force is zero to round-off and on its way to pulling, so a force at that level counts
    /// as separating, not as holding (else the contact would stay with zero force and its
    /// guard fire again moments later, an event that changes nothing).
    #[allow(clippy::too_many_arguments)]
    fn select(
        &mut self,
        t: f64,
        candidates: &[usize],
        leaving: &[usize],
        prefer: ContactMode,
        q: &[f64],
        qd: &[f64],
        impact: bool,
    ) -> Result<Selection, HybridError> {
        let n = candidates.len();
        if n > ENUMERATION_LIMIT {
            return self.select_by_qp(t, candidates, prefer, q, qd, impact);
        }
        let tol = 1e-12;
        // every subset is needed, as a candidate and as `J ∪ {k}` of others: solve each once
        let mut outcomes = Vec::with_capacity(1 << n);
        for bits in 0u32..(1 << n) {
            let set: Vec<usize> = (0..n)
                .filter(|i| bits >> i & 1 == 1)
                .map(|i| candidates[i])
                .collect();
            outcomes.push(self.pushes(t, &set, prefer, q, qd, impact)?);
        }
        let mut accepted = Vec::new();
        for bits in 0u32..(1 << n) {
            let Some((mode, push, p, pd)) = &outcomes[bits as usize] else {
                continue;
            };
            // the push a contact needs to be held: a leaving one must push clearly
            let holds = |c: usize, u: f64| {
                if leaving.contains(&c) {
                    u > tol
                } else {
                    u >= -tol
                }
            };
            if push.iter().any(|&(c, u)| !holds(c, u)) {
                continue;
            }
            // each left-out contact k must separate: singular with k means k cannot be held
            let separates = (0..n).filter(|i| bits >> i & 1 == 0).all(|i| {
                outcomes[(bits | 1 << i) as usize]
                    .as_ref()
                    .is_none_or(|(_, pk, _, _)| {
                        let uk = pk
                            .iter()
                            .find(|(c, _)| *c == candidates[i])
                            .map_or(0.0, |x| x.1);
                        !holds(candidates[i], uk)
                    })
            });
            if separates {
                accepted.push((*mode, p.clone(), pd.clone()));
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

    /// [`Sim::select`] for more than [`ENUMERATION_LIMIT`] candidates, all frictionless: the
    /// complementarity problem as a convex QP ([`crate::impact_qp`], clarabel). Differences
    /// from the enumeration: the pseudo-impulse rule is `U(P + P_δ) ≥ 0` for every contact
    /// (the enumeration lets a contact that its own impulse holds stay on `U(P)`), the
    /// actuators' torque in `P_δ` is taken at q̇⁻ (q̇⁺ depends on the contact set, the QP's
    /// unknown; the enumeration takes it at each candidate's q̇⁺), and a
    /// problem whose contact set is not unique (e.g. three points of a rigid body on a
    /// plane) is reported as several solutions with the one basic set the QP found.
    fn select_by_qp(
        &mut self,
        t: f64,
        candidates: &[usize],
        prefer: ContactMode,
        q: &[f64],
        qd: &[f64],
        impact: bool,
    ) -> Result<Selection, HybridError> {
        let sliding = |k: usize| {
            prefer.kind(k) == Some(ContactKind::Slide)
                || matches!(self.model.contacts[k].friction, Friction::Sliding)
        };
        if let Some(&sticking) = candidates.iter().find(|&&k| !sliding(k)) {
            return Err(HybridError::TooManyContacts {
                n: candidates.len(),
                sticking,
            });
        }
        self.flow_key = None;
        self.tau.resize(self.model.n_joints(), 0.0);
        self.ctrl.torque(t, q, qd, prefer, &mut self.tau);
        // the per-candidate values of the contacts in `mode`, in row order
        let rows = |mode: ContactMode, cands: &[usize], v: &[f64]| -> Vec<f64> {
            cands
                .iter()
                .zip(v)
                .filter(|(k, _)| mode.contains(**k))
                .map(|(_, &x)| x)
                .collect()
        };
        let outcome = if impact {
            let pseudo =
                (self.opts.delta_t_s > 0.0).then_some((&self.tau[..], self.opts.delta_t_s));
            impact_qp::frictionless_impact(
                self.model,
                &mut self.data,
                self.terrain,
                candidates,
                q,
                qd,
                pseudo,
            )
            .map(|o| match o {
                QpOutcome::Unique(s) => Ok((
                    s.mode,
                    rows(s.mode, &s.candidates, &s.impulse),
                    // empty without a pseudo-impulse
                    rows(s.mode, &s.candidates, &s.pseudo_impulse),
                )),
                QpOutcome::Ambiguous(s, _) => Err(s.mode),
            })
        } else {
            self.data
                .prepare_geometry(self.model, self.terrain, ContactMode::FLIGHT, q, qd)?;
            let free_joints = self.data.free_joints.clone();
            self.free.resize(free_joints.len(), 0.0);
            self.ctrl
                .free_joint_qdd(t, q, qd, &free_joints, &mut self.free);
            impact_qp::frictionless_liftoff(
                self.model,
                &mut self.data,
                self.terrain,
                candidates,
                q,
                qd,
                &self.tau,
                Some(&self.free),
            )
            .map(|o| match o {
                QpOutcome::Unique(s) => {
                    Ok((s.mode, rows(s.mode, &s.candidates, &s.lambda), Vec::new()))
                }
                QpOutcome::Ambiguous(s, _) => Err(s.mode),
            })
        };
        self.flow_key = None;
        match outcome {
            Ok(Ok(x)) => Ok(Ok(x)),
            Ok(Err(mode)) => Ok(Err(Termination::SeveralContactSolutions {
                t,
                candidates: vec![mode],
            })),
            Err(ContactQpError::NoSolution { .. }) => Ok(Err(Termination::NoContactSolution { t })),
            Err(e) => Err(e.into()),
        }
    }
}

/// The bracket `[lo, hi]`, at most `tol` wide, of the first crossing of `f` from positive (at
/// `lo`) to non-positive (at `hi`), by Illinois regula falsi: superlinear on smooth guards (a
/// handful of evaluations where bisection needs ~30). Every trial stays `tol/2` inside the
/// bracket, so once the estimate has converged the next trial lands on its other side and
/// the bracket closes; after `SECANT_TRIALS` trials it bisects, which always terminates.
fn locate_crossing<E>(
    f: &mut dyn FnMut(f64) -> Result<f64, E>,
    (mut lo, mut f_lo): (f64, f64),
    (mut hi, mut f_hi): (f64, f64),
    tol: f64,
) -> Result<(f64, f64), E> {
    const SECANT_TRIALS: usize = 16;
    // which end the last trial moved (Illinois: an end kept twice has its value halved)
    let mut last_side = 0i8;
    let mut trials = 0;
    while hi - lo > tol {
        trials += 1;
        let secant = lo + (hi - lo) * f_lo / (f_lo - f_hi);
        let trial = if trials <= SECANT_TRIALS && secant.is_finite() {
            secant.clamp(lo + 0.5 * tol, hi - 0.5 * tol)
        } else {
            0.5 * (lo + hi)
        };
        let v = f(trial)?;
        if v > 0.0 {
            (lo, f_lo) = (trial, v);
            if last_side == 1 {
                f_hi *= 0.5;
            }
            last_side = 1;
        } else {
            (hi, f_hi) = (trial, v);
            if last_side == -1 {
                f_lo *= 0.5;
            }
            last_side = -1;
        }
    }
    Ok((lo, hi))
}

/// Tangential velocity `t · v` of the material point of contact `k` at its contact point
/// (the sliding velocity; zero while it sticks or rolls).
fn sliding_velocity(model: &Model, kin: &Kinematics, terrain: &dyn Terrain, k: usize) -> f64 {
    let geom = contact_geometry(model, kin, terrain, k);
    kin.material_velocity(geom.part, geom.point)
        .dot(&geom.plane.tangent())
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
    // which joints are free (massless, untouched) is known after `prepare`
    data.prepare(model, terrain, mode, q, qd)?;
    flow_prepared(model, ctrl, data, tau, free, t, mode, q, qd)
}

/// [`flow`] when `data` has been prepared at `(mode, q, q̇)`.
#[allow(clippy::too_many_arguments)]
fn flow_prepared(
    model: &Model,
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
    free.resize(data.free_joints.len(), 0.0);
    ctrl.free_joint_qdd(t, q, qd, &data.free_joints, free);
    forward_dynamics_prepared(model, data, tau, Some(free))
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
    data.prepare_geometry(model, terrain, ContactMode::FLIGHT, q, qd)?;
    Ok(kinetic_energy(data, qd))
}

/// What complementarity selects at an event: the mode after it with the contact impulses
/// (forces at liftoff) and pseudo-impulses in its rows, or the typed end of the execution
/// when no or several contact sets qualify.
type Selection = Result<(ContactMode, Vec<f64>, Vec<f64>), Termination>;

/// Where the guards are sampled in each step (fractions of it; the last is its end point).
const SAMPLES: [f64; 4] = [0.25, 0.5, 0.75, 1.0];

/// Up to this many candidate contacts the complementarity problems are solved by exact
/// enumeration of their `2ⁿ` subsets; beyond it by the convex QP of [`crate::impact_qp`].
pub const ENUMERATION_LIMIT: usize = 10;

/// An impulse this small (N s) is no verdict of its own: the pseudo-impulse decides (5.40).
const IMPULSE_TOL_N_S: f64 = 1e-12;

/// A contact found this far below its ground at a located touchdown did not reach it
/// continuously: its ground stepped (m).
const TERRAIN_STEP_M: f64 = 1e-6;
/// Largest change of a contact's normal (a unit vector) across the event bracket at which
/// it passes onto the next terrain feature for the two to count as one continuous surface
/// (a face and its edge: the change is the turning over the bracket, ~1e-9; a concave
/// corner turns it by a right angle).
const FEATURE_NORMAL_TOL: f64 = 1e-6;

/// How many of `times_latest_first` (times in decreasing order) are after `since`: the
/// transitions in the Zeno window.
fn count_after(times_latest_first: impl Iterator<Item = f64>, since: f64) -> usize {
    times_latest_first.take_while(|&t| t > since).count()
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
        flow_key: None,
        flow_y: Vec::with_capacity(2 * nq),
        kin_y: None,
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
    let kin = sim.kinematics(q0, qd0);
    for k in mode0.active() {
        let gap = contact_geometry(model, kin, terrain, k).gap_m;
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
    // times at which a contact passed onto the next feature of the terrain
    let mut feature_changes: Vec<f64> = Vec::new();
    let mut ydense = vec![0.0; 2 * nq];
    let mut h_carry = opts.step.h_initial_s;
    let mut ode = Dopri5::new(2 * nq, opts.step);
    let mut weights = vec![1.0; 2 * nq];
    let mut dense = DenseStep::default();
    // sliding contacts whose sliding velocity is zero at the start of the next segment up to
    // drift (they stuck until the last reset, or their stick was just refused)
    let mut from_rest: Vec<usize> = Vec::new();
    let (mut free_joints, mut dynamic_coords) = (Vec::new(), Vec::new());
    let termination = 'run: loop {
        // ---- flow in `mode` until a guard fires or t_final
        // free massless joints follow the controller's prescribed motion (thesis 5.1.1): it
        // feeds back into nothing, so it does not set the step size
        mode.validate(model)?;
        free_massless_joints(model, mode, &mut free_joints, &mut dynamic_coords);
        weights.fill(1.0);
        for &j in &free_joints {
            // joint j is coordinate j (q = [θ…, x, z, φ])
            weights[j] = 0.0;
            weights[nq + j] = 0.0;
        }
        let guards = sim.guards(mode);
        let ng = guards.len();
        // A guard fires when `orient·g + shift` goes from positive to non-positive. Armed
        // guards fire at zero. An unarmed one (not yet clearly positive, e.g. a contact just
        // released at zero height) fires only once clearly negative, `arm_margin` below its
        // start: no chatter at zero, and no tunnelling through the ground when a swing is too
        // small or too short to arm it. A slip→stick guard of a contact sliding clearly
        // (beyond the margin) is armed with the sign of its velocity; one that starts from
        // rest — its velocity within the margin, or the contact stuck until the reset, whose
        // sliding velocity is then only the drift of the sticking constraint, possibly beyond
        // the margin — cannot fire until the velocity has moved `arm_margin` away from its
        // start (`stick_ref`), and takes the sign of that motion.
        let mut armed = vec![false; ng];
        let mut orient = vec![1.0; ng];
        let mut unarmed_shift = vec![0.0; ng];
        let mut stick_ref = vec![0.0; ng];
        let mut last = vec![0.0; ng];
        let mut end_value = vec![0.0; ng];
        let mut end_t = vec![0.0; ng];
        let mut sample_raw = vec![0.0; SAMPLES.len() * ng];
        for (gi, &g) in guards.iter().enumerate() {
            let raw = sim.guard_value(g, t, mode, &y)?;
            if let Guard::Stick(k) = g {
                if raw.abs() > opts.arm_margin && !from_rest.contains(&k) {
                    orient[gi] = raw.signum();
                    armed[gi] = true;
                } else {
                    orient[gi] = 0.0;
                    unarmed_shift[gi] = f64::INFINITY;
                    stick_ref[gi] = raw;
                }
            } else {
                armed[gi] = raw > opts.arm_margin;
                unarmed_shift[gi] = opts.arm_margin + (-raw).max(0.0);
            }
            last[gi] = orient[gi] * raw;
        }
        // a sticking contact whose force already lies outside its cone (an inconsistent start,
        // or a cone that a reset left violated) slips at once
        let slipping_now: Vec<Guard> = guards
            .iter()
            .zip(&last)
            .filter(|(g, &v)| matches!(g, Guard::Slip { .. }) && v < -opts.arm_margin)
            .map(|(g, _)| *g)
            .collect();
        let surfaces = sim.surfaces(mode, &y);
        // the time a contact passes continuously onto the next terrain feature in this
        // segment's last step, once located
        let mut feature_change: Option<f64> = None;
        let mut seg = Segment {
            mode,
            t0: t,
            t1: t,
            y0: y.clone(),
            steps: Vec::new(),
        };
        // a segment starts with the step size the last one reached (a reset changes the
        // flow, not its time scale; a step too long is rejected and shrunk)
        ode.reset(h_carry);
        ode.set_error_weights(&weights);
        let fired: Option<(f64, Vec<Guard>)> = loop {
            if !slipping_now.is_empty() {
                break Some((t, slipping_now));
            }
            if t >= t_final {
                break None;
            }
            let step = ode.step(
                &mut |tt, yy, dy| sim.rhs(tt, mode, yy, dy),
                t,
                &mut y,
                feature_change.unwrap_or(t_final),
                &mut dense,
            );
            match step {
                Ok(()) if feature_change.is_none() => {
                    // an active contact stays on its feature (the flow holds a_k = 0); one
                    // that left it met an edge or a corner of the terrain: locate where
                    if sim.off_surface(&surfaces, &y).is_some() {
                        let (mut on, mut off) = (dense.t0, dense.t1());
                        while off - on > opts.event_tol_s {
                            let mid = 0.5 * (on + off);
                            dense.eval(mid, &mut ydense);
                            if sim.off_surface(&surfaces, &ydense).is_some() {
                                off = mid;
                            } else {
                                on = mid;
                            }
                        }
                        dense.eval(off, &mut ydense);
                        let (contact, after) = sim
                            .off_surface(&surfaces, &ydense)
                            .expect("off its feature at `off`");
                        // the next feature continues the surface (a face, its edge, the top:
                        // height and normal continuous): the flow changes there, so the step
                        // is taken again up to that instant and the segment ends with it
                        dense.eval(on, &mut ydense);
                        let before = sim.geometry(contact, &ydense);
                        let continuous = after.gap_m.abs() <= TERRAIN_STEP_M
                            && (after.plane.normal() - before.plane.normal()).norm()
                                <= FEATURE_NORMAL_TOL;
                        if continuous {
                            dense.eval(dense.t0, &mut y);
                            feature_change = Some(off);
                            ode.reset(off - dense.t0);
                            continue;
                        }
                        dense.eval(off, &mut y);
                        seg.steps.push(dense.clone());
                        seg.t1 = off;
                        t = off;
                        segments.push(seg);
                        break 'run Termination::TerrainDiscontinuity {
                            t: off,
                            contact,
                            gap_m: after.gap_m,
                        };
                    }
                }
                Ok(()) => {}
                Err(StepError::Rhs(CoreError::SingularKkt {
                    kind,
                    condition_estimate,
                })) => {
                    // Lemma 5.1 fails on the way (e.g. a massless leg sliding through the
                    // pose where its contact no longer pins it): the flow ends here
                    segments.push(seg);
                    break 'run Termination::SingularFlow {
                        t,
                        mode,
                        kind,
                        condition_estimate,
                    };
                }
                Err(StepError::Rhs(e)) => return Err(e.into()),
                Err(StepError::StepTooSmall(h)) => {
                    return Err(HybridError::StepTooSmall { t_s: t, h_s: h })
                }
            }
            // sample the guards inside the step, all guards at each sample (the force guards
            // at one sample share one flow evaluation); stop at the first interval in which
            // any guard crosses.
            // An unarmed guard (one that has not yet been clearly positive, e.g. a contact
            // just released at zero height) fires only once it is clearly negative, at
            // `−arm_margin`: no chatter at zero, and no tunnelling through the ground when a
            // swing is too small or too short to arm it.
            // The last sample is the step's end point `(t + h, y_new)` itself, where the
            // integrator's last stage has just evaluated the flow: its force guards cost
            // nothing when it is sampled first. Force guards (a flow evaluation each sample)
            // are sampled at the coarse samples (mid-step and end), and also at a fine sample
            // where a cheap guard crosses, so that none of them can cross unseen before the
            // earliest event; the cheap (kinematic) guards at every sample.
            let coarse = |si: usize| si % 2 == 1;
            let mut sample_t = [0.0; SAMPLES.len()];
            for si in [3, 1, 0, 2] {
                let s = SAMPLES[si];
                let ts = if s == 1.0 {
                    ydense.copy_from_slice(&y);
                    dense.t1()
                } else {
                    let ts = dense.t0 + s * dense.h;
                    dense.eval(ts, &mut ydense);
                    ts
                };
                sample_t[si] = ts;
                for (gi, &g) in guards.iter().enumerate() {
                    if coarse(si) || !g.needs_flow() {
                        sample_raw[si * ng + gi] = sim.guard_value(g, ts, mode, &ydense)?;
                    }
                }
            }
            end_value.copy_from_slice(&last);
            end_t.fill(dense.t0);
            // (guard, shift, its last sample time, value there, value at ts) of the guards
            // crossing by ts
            let mut crossing: Vec<(usize, f64, f64, f64, f64)> = Vec::new();
            let mut hi = dense.t0;
            'samples: for (si, &ts) in sample_t.iter().enumerate() {
                // pass 0: the guards sampled here; pass 1 (a fine sample where a cheap guard
                // crossed): the force guards too
                for pass in 0..2 {
                    if pass == 1 {
                        if crossing.is_empty() || coarse(si) {
                            break;
                        }
                        dense.eval(ts, &mut ydense);
                    }
                    for gi in 0..ng {
                        let g = guards[gi];
                        let sampled = coarse(si) || !g.needs_flow();
                        if sampled != (pass == 0) {
                            continue;
                        }
                        let raw = if pass == 0 {
                            sample_raw[si * ng + gi]
                        } else {
                            sim.guard_value(g, ts, mode, &ydense)?
                        };
                        let (prev_t, prev_v) = (end_t[gi], end_value[gi]);
                        end_t[gi] = ts;
                        if orient[gi] == 0.0 {
                            // a slip→stick guard arms once the sliding velocity has moved
                            // clear of its start
                            let moved = raw - stick_ref[gi];
                            if moved.abs() > opts.arm_margin {
                                orient[gi] = moved.signum();
                                armed[gi] = true;
                            }
                            end_value[gi] = orient[gi] * raw;
                            continue;
                        }
                        let v = orient[gi] * raw;
                        let sh = if armed[gi] { 0.0 } else { unarmed_shift[gi] };
                        if prev_v + sh > 0.0 && v + sh <= 0.0 {
                            crossing.push((gi, sh, prev_t, prev_v + sh, v + sh));
                        }
                        if v > opts.arm_margin {
                            armed[gi] = true;
                        }
                        end_value[gi] = v;
                    }
                }
                if !crossing.is_empty() {
                    hi = ts;
                    break 'samples;
                }
            }
            if !crossing.is_empty() {
                // locate each crossing guard; the earliest fires
                let mut first: Option<(f64, usize)> = None;
                for &(gi, sh, lo, f_lo, f_hi) in &crossing {
                    if first.is_some_and(|(t_first, _)| lo >= t_first) {
                        continue; // crosses after the earliest one found so far
                    }
                    let (g, o) = (guards[gi], orient[gi]);
                    let mut value = |tt: f64| -> Result<f64, CoreError> {
                        dense.eval(tt, &mut ydense);
                        Ok(o * sim.guard_value(g, tt, mode, &ydense)? + sh)
                    };
                    let (_, at) =
                        locate_crossing(&mut value, (lo, f_lo), (hi, f_hi), opts.event_tol_s)?;
                    if first.is_none_or(|(t_first, _)| at < t_first) {
                        first = Some((at, gi));
                    }
                }
                let (hi, gi) = first.expect("a crossing guard");
                // every other guard that has also crossed by `hi` fires with it
                dense.eval(hi, &mut ydense);
                let mut set = Vec::new();
                for (gj, &g) in guards.iter().enumerate() {
                    let sh = if armed[gj] { 0.0 } else { unarmed_shift[gj] };
                    if gj == gi
                        || (orient[gj] != 0.0
                            && orient[gj] * sim.guard_value(g, hi, mode, &ydense)? + sh <= 0.0)
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
            last.copy_from_slice(&end_value);
            if feature_change.is_some_and(|tc| t >= tc) {
                break None;
            }
        };
        h_carry = ode.next_step_size().max(opts.step.h_initial_s);
        segments.push(seg);
        if fired.is_none() && feature_change.is_some_and(|tc| t >= tc) {
            // a contact moved on to the next feature of the terrain: a new segment, no event;
            // these count with the events towards Zeno detection (a site rocking across the
            // boundary between two features could otherwise split the flow without end)
            feature_changes.push(t);
            let since = t - opts.zeno_window_s;
            let recent = count_after(feature_changes.iter().rev().copied(), since)
                + count_after(events.iter().rev().map(|e| e.t), since);
            if recent > opts.zeno_max_events {
                break 'run Termination::Zeno {
                    t,
                    events_in_window: recent,
                };
            }
            continue 'run;
        }
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
                q: q.clone(),
                qd_after: qd.clone(),
            });
            break 'run Termination::Apex;
        }
        let fired_contacts = |pick: fn(&Guard) -> Option<usize>| -> Vec<usize> {
            fired.iter().filter_map(pick).collect()
        };
        let touched = fired_contacts(|g| match g {
            Guard::Touchdown(k) => Some(*k),
            _ => None,
        });
        let released = fired_contacts(|g| match g {
            Guard::Liftoff { contact, .. } => Some(*contact),
            _ => None,
        });
        let slipped = fired_contacts(|g| match g {
            Guard::Slip { contact, .. } => Some(*contact),
            _ => None,
        });
        let stuck = fired_contacts(|g| match g {
            Guard::Stick(k) => Some(*k),
            _ => None,
        });
        // a contact whose height jumped through zero met a step of the terrain
        let kin = sim.kinematics(&q, &qd);
        for &k in &touched {
            let gap = contact_geometry(model, kin, terrain, k).gap_m;
            if gap < -TERRAIN_STEP_M {
                break 'run Termination::TerrainDiscontinuity {
                    t: te,
                    contact: k,
                    gap_m: gap,
                };
            }
        }
        sim.flow_key = None; // the reset below reuses `sim.data` for other modes
        let ke_before = kinetic_energy_at(model, terrain, &mut sim.data, &q, &qd)?;
        let impact = !touched.is_empty();
        // contacts that reached the cone slide; contacts whose sliding stopped try to stick
        let mut prefer = mode;
        for &k in &slipped {
            prefer = prefer.with(k, ContactKind::Slide);
        }
        for &k in &stuck {
            prefer = prefer.with(k, ContactKind::Stick);
        }
        let mut candidates: Vec<usize> = mode.active().chain(touched.iter().copied()).collect();
        candidates.sort_unstable();
        candidates.dedup();
        let (new_mode, p, pd) =
            match sim.select(te, &candidates, &released, prefer, &q, &qd, impact)? {
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
            match sim.select(te, &kept, &[], after_mode, &q, &qd_new, false)? {
                Ok((m, _, _)) => after_mode = m,
                Err(term) => break 'run term,
            }
        }
        let ke_after = kinetic_energy_at(model, terrain, &mut sim.data, &q, &qd_new)?;
        sim.flow_key = None;
        // without a velocity jump, a contact that stuck until now starts sliding from rest;
        // so does one whose stick the cone refused (its velocity just crossed zero)
        from_rest.clear();
        from_rest.extend(after_mode.active().filter(|&k| {
            after_mode.kind(k) == Some(ContactKind::Slide)
                && (stuck.contains(&k) || (!impact && mode.kind(k) == Some(ContactKind::Stick)))
        }));
        let (kind, triggered) = if impact {
            (EventKind::Touchdown, touched)
        } else if !released.is_empty() {
            (EventKind::Liftoff, released)
        } else if !slipped.is_empty() {
            (EventKind::Slip, slipped)
        } else {
            (EventKind::Stick, stuck)
        };
        let event = Event {
            t: te,
            kind,
            mode_before: mode,
            mode_after: after_mode,
            triggered,
            impulse: p,
            pseudo_impulse: pd,
            kinetic_before: ke_before,
            kinetic_after: ke_after,
            q: q.clone(),
            qd_after: qd_new.clone(),
        };
        controller.on_event(&event);
        events.push(event);
        y[nq..].copy_from_slice(&qd_new);
        mode = after_mode;
        if events.len() >= opts.max_events {
            break 'run Termination::EventBudget;
        }
        let in_window = count_after(events.iter().rev().map(|e| e.t), te - opts.zeno_window_s);
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

/// Energy bookkeeping of an execution (J): the total energy `E = T + V` (4.24) at its start
/// and end, the work of the joint torques along the flow, and the kinetic energy lost in its
/// impacts. A correct execution balances: `E₁ − E₀ = W − L` (`residual_j` ≈ 0), with `L ≥ 0`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct EnergyReport {
    pub initial_j: f64,
    pub final_j: f64,
    /// `∫ τ·θ̇ dt` over the joints in the dynamics (free massless joints carry no load).
    pub joint_work_j: f64,
    /// `Σ (T⁻ − T⁺)` over the touchdown events.
    pub impact_loss_j: f64,
}

impl EnergyReport {
    /// `E₁ − E₀ − W + L`.
    pub fn residual_j(&self) -> f64 {
        self.final_j - self.initial_j - self.joint_work_j + self.impact_loss_j
    }
}

/// The [`EnergyReport`] of `exec` (which started at `(q0, q̇0)`), re-evaluating the
/// controller's torques on each step's dense output with 3-point Gauss–Legendre quadrature
/// (exact to the interpolant's order). The controller must answer as it did during the run
/// (its torques a function of time, state and mode, or of the events it was told about).
pub fn energy_report(
    model: &Model,
    terrain: &dyn Terrain,
    controller: &dyn Controller,
    exec: &Execution,
    q0: &[f64],
    qd0: &[f64],
) -> Result<EnergyReport, HybridError> {
    let nq = model.nq();
    let mut data = Data::new(model);
    let total = |data: &mut Data, q: &[f64], qd: &[f64]| -> Result<f64, CoreError> {
        let t = kinetic_energy_at(model, terrain, data, q, qd)?;
        Ok(t + potential_energy(model, &data.kin))
    };
    let initial_j = total(&mut data, q0, qd0)?;
    let final_j = total(&mut data, &exec.q, &exec.qd)?;
    let nodes = [
        (0.5 - 0.5 * (0.6f64).sqrt(), 5.0 / 18.0),
        (0.5, 8.0 / 18.0),
        (0.5 + 0.5 * (0.6f64).sqrt(), 5.0 / 18.0),
    ];
    let (mut tau, mut free) = (vec![0.0; model.n_joints()], Vec::new());
    let mut y = vec![0.0; 2 * nq];
    let mut joint_work_j = 0.0;
    for seg in &exec.segments {
        for step in &seg.steps {
            let (a, b) = (step.t0, step.t1().min(seg.t1));
            if b <= a {
                continue;
            }
            for &(x, w) in &nodes {
                let t = a + x * (b - a);
                step.eval(t, &mut y);
                let (q, qd) = y.split_at(nq);
                flow(
                    model, terrain, controller, &mut data, &mut tau, &mut free, t, seg.mode, q, qd,
                )?;
                let power: f64 = (0..model.n_joints())
                    .filter(|j| !data.free_joints.contains(j))
                    .map(|j| tau[j] * qd[j])
                    .sum();
                joint_work_j += w * (b - a) * power;
            }
        }
    }
    Ok(EnergyReport {
        initial_j,
        final_j,
        joint_work_j,
        impact_loss_j: exec.impact_losses().iter().sum(),
    })
}

fn nalgebra_vec(v: &[f64]) -> nalgebra::DVector<f64> {
    nalgebra::DVector::from_column_slice(v)
}
