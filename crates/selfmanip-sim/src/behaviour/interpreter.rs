//! The behaviour interpreter: a [`Controller`] that runs a compiled behaviour.
//!
//! Its immutable plan (programs, actuators, constants) is shared behind an `Arc`; its memory
//! — the named events that have happened, each phase's start time once known, each joint's
//! prescribed motions — lives in plain fields that only [`Controller::on_event`] changes, so
//! the engine's copy per segment is the behaviour exactly as it ran there.
//!
//! ```text
//! torque(t, q, q̇, mode):  per program: phase = last phase started by t (a joint-angle phase
//!                          overlays while its level holds) => its torque law
//! free_joint_qdd:          α_ref + kp (θ_ref − q) + kd (ω_ref − q̇), the reference being the
//!                          joint's last motion started by t
//! on_event(e):             named events => phase latches => start times resolved =>
//!                          motions (re)started at e, and those of later timed phases
//! ```
use super::tangent::{axpy, Grad, NumberPartials, PlanTangent, TorqueTangent};
use crate::expr::Expr;
use crate::motion::{JointMotion, StartedLaw};
use motor::Actuator;
use nalgebra::DMatrix;
use selfmanip_core::ContactMode;
use selfmanip_hybrid::{
    ControlPoint, Controller, ControllerPartials, Event, EventKind, EventMemoryPartials,
    MemoryTimeEvent, TimeEvent,
};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};

/// A number known when the behaviour is compiled, or one that depends on the joint's angle
/// and rate where a motion starts (`theta`, `omega`).
#[derive(Debug, Clone)]
pub(crate) enum Value {
    Const(f64),
    AtStart(Arc<Expr>, Arc<Vec<(String, f64)>>),
}

impl Value {
    fn at(&self, theta: f64, omega: f64) -> f64 {
        match self {
            Value::Const(x) => *x,
            Value::AtStart(e, consts) => e
                .eval(&|n| match n {
                    "theta" => Some(theta),
                    "omega" => Some(omega),
                    _ => consts.iter().find(|(k, _)| k == n).map(|(_, v)| *v),
                })
                .unwrap_or(f64::NAN),
        }
    }
}

/// Which events a trigger matches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum MatchKind {
    Kind(EventKind),
    Release,
    Touch,
    Flight,
    Any,
}

/// A trigger on the events of the execution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct EventMatch {
    pub kind: MatchKind,
    /// Contacts (bit k = contact k) the event must concern.
    pub contacts: u32,
    pub not_before_s: f64,
}

impl EventMatch {
    pub(crate) fn matches(&self, e: &Event) -> bool {
        if e.t < self.not_before_s {
            return false;
        }
        let (before, after) = (e.mode_before.normal_bits(), e.mode_after.normal_bits());
        match self.kind {
            MatchKind::Kind(k) => {
                e.kind == k && e.triggered.iter().any(|&c| self.contacts >> c & 1 == 1)
            }
            MatchKind::Release => before & !after & self.contacts != 0,
            MatchKind::Touch => after & !before & self.contacts != 0,
            MatchKind::Flight => e.mode_after.is_flight(),
            MatchKind::Any => true,
        }
    }
}

/// `direction · q_joint > direction · angle`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Level {
    pub joint: usize,
    pub direction: f64,
    pub angle: f64,
}

impl Level {
    #[inline]
    fn holds(&self, q: &[f64]) -> bool {
        self.direction * q[self.joint] > self.direction * self.angle
    }
}

/// How a phase starts: the first of its alternatives.
#[derive(Debug, Clone, Default)]
pub(crate) struct Start {
    /// At these times (s).
    pub times: Vec<f64>,
    /// At the first matching event once armed.
    pub events: Vec<EventMatch>,
    /// When these named events have happened.
    pub named: Vec<usize>,
    /// This long after these phases `(program, phase, delay)` started.
    pub phases: Vec<(usize, usize, f64)>,
    /// A level (a joint-angle phase; no other alternative).
    pub level: Option<Level>,
}

#[derive(Debug, Clone)]
pub(crate) enum TorqueLaw {
    Zero,
    Constant(f64),
    Schedule {
        times: Vec<f64>,
        torques: Vec<f64>,
        hold: bool,
    },
    Servo(ServoLaw),
    Motor {
        actuator: usize,
        command: f64,
        reverse_beyond: Option<f64>,
    },
}

/// A `servo` torque law: the command `kp (θ* − θ) + kd (ω* − ω)` to a fixed target at rest
/// or along the joint's motion, clamped to `±limit`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ServoLaw {
    /// `None`: the joint's motion.
    pub target: Option<f64>,
    pub kp: f64,
    pub kd: f64,
    pub limit: f64,
    pub only_in_contact: bool,
}

impl ServoLaw {
    /// Whether the servo is switched off in `mode`: `only_in_contact` with none of the
    /// program's `contacts` (bits) closed.
    #[inline]
    fn is_off(&self, mode: ContactMode, contacts: u32) -> bool {
        self.only_in_contact && mode.normal_bits() & contacts == 0
    }
}

#[derive(Debug, Clone)]
pub(crate) enum MotionLaw {
    Hold {
        angle: Value,
    },
    Swing {
        target: Value,
        speed: Value,
        accel: Value,
    },
    Park {
        target: Value,
        accel: Value,
    },
}

impl MotionLaw {
    /// Whether a motion of this law depends on the state it starts from: every swing and
    /// park, a hold at an angle of `theta`/`omega` (not a hold at a constant angle).
    fn depends_on_start(&self) -> bool {
        !matches!(
            self,
            MotionLaw::Hold {
                angle: Value::Const(_)
            }
        )
    }

    /// The law with its numbers at the start `(θ₀, ω₀)`; `None` for a hold.
    fn law_at(&self, theta: f64, omega: f64) -> Option<StartedLaw> {
        match self {
            MotionLaw::Hold { .. } => None,
            MotionLaw::Swing {
                target,
                speed,
                accel,
            } => Some(StartedLaw::Swing {
                target: target.at(theta, omega),
                speed: speed.at(theta, omega),
                accel: accel.at(theta, omega),
            }),
            MotionLaw::Park { target, accel } => Some(StartedLaw::Park {
                target: target.at(theta, omega),
                accel: accel.at(theta, omega),
            }),
        }
    }

    fn start(&self, t0: f64, theta: f64, omega: f64) -> JointMotion {
        match self {
            MotionLaw::Hold { angle } => JointMotion::hold(t0, angle.at(theta, omega)),
            MotionLaw::Swing {
                target,
                speed,
                accel,
            } => JointMotion::swing(
                t0,
                theta,
                omega,
                target.at(theta, omega),
                speed.at(theta, omega),
                accel.at(theta, omega),
            ),
            MotionLaw::Park { target, accel } => JointMotion::park(
                t0,
                theta,
                omega,
                target.at(theta, omega),
                accel.at(theta, omega),
            ),
        }
    }
}

/// The servo `(target, kp, kd)` whose torque-free manifold a free massless joint in
/// `phase` follows ([`BehaviourController::free_law`]): a servo with damping that acts in
/// the air.
pub(crate) fn servo_manifold(phase: &PhasePlan) -> Option<(Option<f64>, f64, f64)> {
    match phase.torque {
        TorqueLaw::Servo(ServoLaw {
            target,
            kp,
            kd,
            only_in_contact: false,
            ..
        }) if kd > 0.0 => Some((target, kp, kd)),
        _ => None,
    }
}

#[derive(Debug, Clone)]
pub(crate) struct PhasePlan {
    pub name: String,
    pub start: Start,
    pub torque: TorqueLaw,
    pub motion: MotionLaw,
    /// Whether the phase has a motion of its own (one that starts with the phase).
    pub own_motion: bool,
    pub restart_on: Vec<EventMatch>,
    pub restart_named: Vec<usize>,
}

#[derive(Debug, Clone)]
pub(crate) struct Program {
    pub joint: usize,
    /// The joint's contacts (carried by its link or the links beyond it).
    pub contacts: u32,
    pub phases: Vec<PhasePlan>,
    /// The phase that follows the last one (a repeating program), if any.
    pub repeat_from: Option<usize>,
    /// Whether any phase is a joint-angle level.
    pub has_levels: bool,
    /// Whether any phase has a servo whose torque-free manifold a free massless joint
    /// follows ([`servo_manifold`]); without one, the joint always takes the tracking law.
    pub has_servo_manifold: bool,
}

/// A named event: its trigger and the named event it waits for.
#[derive(Debug, Clone)]
pub(crate) struct NamedPlan {
    pub name: String,
    pub trigger: EventMatch,
    pub after: Option<usize>,
}

/// What a compiled behaviour runs: immutable, shared by every copy of the controller.
pub(crate) struct Plan {
    /// The partials of its numbers over the behaviour's parameters (read by the
    /// sensitivities only), built on first use by [`Self::tangent_source`].
    pub tangent: OnceLock<PlanTangent>,
    /// What builds [`Self::tangent`] (the behaviour compiled again with gradients).
    pub tangent_source: OnceLock<TangentSource>,
    pub programs: Vec<Program>,
    pub actuators: Vec<Arc<dyn Actuator>>,
    /// Named events in an order where each comes after the one it waits for.
    pub named: Vec<NamedPlan>,
    pub program_of_joint: Vec<Option<usize>>,
    pub kp_free: f64,
    pub kd_free: f64,
    /// Joints without a program (zero torque).
    pub idle_joints: Vec<usize>,
    /// Phases that start at known times are planned up to here (the run's final time).
    pub horizon_s: f64,
}

/// Builds a plan's parameter tangent.
pub(crate) type TangentSource = Box<dyn Fn() -> PlanTangent + Send + Sync>;

impl Plan {
    /// The parameter tangent, built on first use.
    fn tangent(&self) -> &PlanTangent {
        self.tangent.get_or_init(|| {
            let make = self
                .tangent_source
                .get()
                .expect("a plan without a tangent has its source");
            make()
        })
    }
}

/// Most phase starts planned ahead per program and pass (a loop of timed phases with no
/// delay would otherwise plan forever).
pub(crate) const PLAN_CAP: usize = 10_000;

/// The memory of one joint program.
#[derive(Debug, Clone)]
struct ProgramMemory {
    /// `(start time, phase, origin)` of every phase the program has entered or will enter at
    /// a time already known, in order (the first: phase 0 from the start); the origin is the
    /// event `(number, time)` whose time the start is (a delay after), if any.
    timeline: Vec<Entry>,
    /// The joint's prescribed motions by start time; the reference at `t` is the last one
    /// started by `t`.
    motions: Vec<JointMotion>,
    /// How each motion started, one per motion.
    records: Vec<MotionRecord>,
    /// The start time and torque law of each timeline entry's phase, its numbers read out
    /// of the plan ([`ActiveLaw`]): what [`Controller::torque`] evaluates, made again
    /// whenever the timeline changes ([`BehaviourController::resolve`]).
    laws: Vec<(f64, ActiveLaw)>,
}

impl ProgramMemory {
    /// The last timeline entry started by `t` (searched from the end: the engine asks about
    /// the present, near the end of the planned timeline).
    #[inline]
    fn entry(&self, t: f64) -> (f64, usize) {
        let tl = &self.timeline;
        let e = tl.iter().rev().find(|e| e.0 <= t).unwrap_or(&tl[0]);
        (e.0, e.1)
    }

    /// The phase of `prog` (the program of this memory) at `(t, q)`: that of the last
    /// timeline entry started by `t`, or a joint-angle phase right after it while its level
    /// holds.
    #[inline]
    fn phase(&self, prog: &Program, t: f64, q: &[f64]) -> usize {
        let k = self.entry(t).1;
        if !prog.has_levels {
            return k;
        }
        level_phase(prog, k, q)
    }

    /// The torque law of the last timeline entry started by `t` (that of [`Self::entry`]).
    #[inline]
    fn law(&self, t: f64) -> &ActiveLaw {
        let laws = &self.laws[..];
        // (an index walk: the iterator's search and fallback cost more per joint)
        let mut i = laws.len() - 1;
        while i > 0 {
            if laws[i].0 <= t {
                break;
            }
            i -= 1;
        }
        &laws[i].1
    }

    /// Makes [`Self::laws`] again from the timeline of `prog` (the program of this memory).
    fn refresh_laws(&mut self, prog: &Program) {
        self.laws.clear();
        let laws = self
            .timeline
            .iter()
            .map(|e| (e.0, ActiveLaw::of(prog, e.1)));
        self.laws.extend(laws);
    }

    /// The index of the motion in force at `t`: the last one started by `t`.
    #[inline]
    fn motion_index(&self, t: f64) -> usize {
        self.motions.iter().rposition(|m| m.t0() <= t).unwrap_or(0)
    }

    /// The reference `(θ, ω, α)` at `t`: the motion in force.
    #[inline]
    fn reference(&self, t: f64) -> (f64, f64, f64) {
        let m = self.motions.iter().rev().find(|m| m.t0() <= t);
        m.unwrap_or(&self.motions[0]).eval(t)
    }

    /// The unsaturated servo command `−kp (q − θ*) − kd (q̇ − ω*)` at `t`: the target at
    /// rest, or (`None`) the joint's motion `(θ_ref, ω_ref)`.
    #[inline]
    fn servo_command(
        &self,
        t: f64,
        target: Option<f64>,
        (kp, kd): (f64, f64),
        q: f64,
        qd: f64,
    ) -> f64 {
        let (theta, omega) = match target {
            Some(a) => (a, 0.0),
            None => {
                let (th, om, _) = self.reference(t);
                (th, om)
            }
        };
        -kp * (q - theta) - kd * (qd - omega)
    }

    /// Drops the motions (and their records) that start after `now`.
    fn keep_motions_started_by(&mut self, now: f64) {
        let mut started = self.motions.iter().map(|m| m.t0() <= now);
        self.records
            .retain(|_| started.next().expect("one record per motion"));
        self.motions.retain(|m| m.t0() <= now);
    }
}

/// A phase's torque law with its numbers read out of the plan once, when the timeline is
/// planned, rather than at each evaluation ([`ProgramMemory::laws`]): a segment evaluates it
/// at every stage of every step. Laws whose phase depends on the state (a program with
/// joint-angle levels) and schedules take the general path ([`law_torque`]).
#[derive(Debug, Clone, Copy)]
enum ActiveLaw {
    Zero,
    Constant(f64),
    /// A motor at a constant command.
    Motor {
        actuator: usize,
        command: f64,
    },
    /// A motor whose command reverses while `sign · q_joint > reverse_beyond`, `sign` the
    /// command's sign.
    MotorReversing {
        actuator: usize,
        command: f64,
        sign: f64,
        reverse_beyond: f64,
    },
    /// A servo to a fixed target at rest.
    ServoAt {
        target: f64,
        gains: (f64, f64),
        limit: f64,
        only_in_contact: bool,
    },
    /// A servo that tracks the joint's motion.
    ServoTracking {
        gains: (f64, f64),
        limit: f64,
        only_in_contact: bool,
    },
    /// Any other: [`law_torque`] of the phase in force.
    General,
}

impl ActiveLaw {
    /// The law of phase `k` of `prog`.
    fn of(prog: &Program, k: usize) -> Self {
        if prog.has_levels {
            return ActiveLaw::General;
        }
        match prog.phases[k].torque {
            TorqueLaw::Zero => ActiveLaw::Zero,
            TorqueLaw::Constant(c) => ActiveLaw::Constant(c),
            TorqueLaw::Schedule { .. } => ActiveLaw::General,
            TorqueLaw::Servo(s) => {
                let (gains, limit, only_in_contact) = ((s.kp, s.kd), s.limit, s.only_in_contact);
                match s.target {
                    Some(target) => ActiveLaw::ServoAt {
                        target,
                        gains,
                        limit,
                        only_in_contact,
                    },
                    None => ActiveLaw::ServoTracking {
                        gains,
                        limit,
                        only_in_contact,
                    },
                }
            }
            TorqueLaw::Motor {
                actuator,
                command,
                reverse_beyond: None,
            } => ActiveLaw::Motor { actuator, command },
            TorqueLaw::Motor {
                actuator,
                command,
                reverse_beyond: Some(angle),
            } => ActiveLaw::MotorReversing {
                actuator,
                command,
                sign: command.signum(),
                reverse_beyond: angle,
            },
        }
    }
}

/// The event (its number among those told, its time) a start time is offset from.
type TimeOrigin = Option<(usize, f64)>;

/// A timeline entry: a phase's start time, the phase, the event the time is offset from, and
/// the time's gradient over the parameters at fixed memory (`None`: zero).
type Entry = (f64, usize, TimeOrigin, StartGrad);

/// Where a planned start time's gradient over the parameters (at fixed memory) comes from,
/// resolved against the plan's tangent only when the sensitivities ask
/// ([`BehaviourController::start_grad`]): the forward run never builds the tangent.
#[derive(Debug, Clone, Copy, PartialEq)]
enum StartGrad {
    /// Zero: a start at an event (its time is memory), phase 0's.
    Zero,
    /// `times[i]` of the start of phase `j` of program `p`: `(p, j, i)`.
    Time(usize, usize, usize),
    /// Another start's (zero, or a time's), plus `delays[i]` of the start of phase `j` of
    /// program `p`.
    Delay(Option<(usize, usize, usize)>, (usize, usize, usize)),
    /// A delay after a delayed start: not differentiated (`parameter_partials` refuses it).
    Deeper,
}

/// How a prescribed motion started: for its derivatives.
#[derive(Debug, Clone)]
struct MotionRecord {
    /// How it depends on the events the controller was told of (its memory).
    origin: MotionOrigin,
    /// The phase whose motion law it runs.
    phase: usize,
    /// The joint's angle and rate it started from.
    theta0: f64,
    omega0: f64,
    /// A timed phase's own motion: the motion whose reference it started from, and the
    /// gradient of its start time over the parameters at fixed memory (`None`: zero).
    timed: Option<(usize, StartGrad)>,
    /// The partials of its numbers at its start ([`BehaviourController::numbers_at`]),
    /// evaluated at the first ask: they do not change while it runs (boxed: a forward run
    /// never asks, and moves and copies the record at each event).
    numbers: OnceLock<Box<[NumberPartials; 3]>>,
    /// Its law with the numbers at its start ([`MotionLaw::law_at`]), at the first ask.
    law: OnceLock<Option<StartedLaw>>,
}

/// How a prescribed motion depends on the events the controller was told of.
#[derive(Debug, Clone, Copy, PartialEq)]
enum MotionOrigin {
    /// Not at all (the initial motion from the run's `q0`, an input; a hold at a constant
    /// angle; a timed phase's motion from a reference that does not depend on events). A
    /// timed phase's motion whose start and whose previous motion depend on two different
    /// events is `Timed` and not differentiated (`motion_memory`).
    Fixed,
    /// Started at event `event` from `(t_k, q_k[joint], q̇_k⁺[joint])`.
    Event {
        event: usize,
        joint: usize,
        nq: usize,
    },
    /// A timed phase's own motion started at `s` — `t_k + δ` when `event` is the event `k`
    /// whose time it is offset from, else a known time — from the reference of motion
    /// `prev` (an earlier motion of the program) at `s`: it moves with `s` and with that
    /// reference where either depends on an event.
    Timed {
        event: Option<usize>,
        prev: usize,
        nq: usize,
    },
}

/// The behaviour interpreter (see the module documentation).
#[derive(Clone)]
pub struct BehaviourController {
    plan: Arc<Plan>,
    named: Vec<Option<f64>>,
    /// The event each named event happened at (its number among those told).
    named_from: Vec<Option<usize>>,
    programs: Vec<ProgramMemory>,
    /// How many events the controller was told of.
    events_seen: usize,
    /// The number of coordinates, once an event told it.
    nq: Option<usize>,
    /// Buffers the partials reuse from call to call.
    workspace: Workspace,
}

/// Gradient buffers lent to the partials ([`BehaviourController::parameter_partials`],
/// [`BehaviourController::memory_partials`]) and given back after use, so that a call
/// allocates nothing once the buffers exist.
#[derive(Default)]
struct Scratch(Vec<Vec<f64>>, Vec<usize>);

impl Scratch {
    /// A buffer of `n` zeros.
    fn zeros(&mut self, n: usize) -> Vec<f64> {
        let mut v = self.0.pop().unwrap_or_default();
        v.clear();
        v.resize(n, 0.0);
        v
    }

    /// A buffer holding a copy of `g`.
    fn copy_of(&mut self, g: &[f64]) -> Vec<f64> {
        let mut v = self.0.pop().unwrap_or_default();
        v.clear();
        v.extend_from_slice(g);
        v
    }

    /// Takes back buffers lent.
    fn give<const K: usize>(&mut self, vs: [Vec<f64>; K]) {
        self.0.extend(vs);
    }
}

/// A controller's [`Scratch`], its own (a clone starts with none).
#[derive(Default)]
struct Workspace(Mutex<Scratch>);

impl Clone for Workspace {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl Workspace {
    /// The buffers, for one call of the partials.
    fn lend(&self) -> std::sync::MutexGuard<'_, Scratch> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl std::fmt::Debug for BehaviourController {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BehaviourController")
            .field("named", &self.named)
            .finish_non_exhaustive()
    }
}

const NEVER: f64 = f64::NEG_INFINITY;

impl BehaviourController {
    /// A fresh controller: phase 0 everywhere, each joint on its phase-0 motion from
    /// `(q0, qd0)`, and the phases (and their motions) that start at known times planned.
    /// `Err(program)` when a program plans more than [`PLAN_CAP`] phases ahead.
    pub(crate) fn new(plan: Plan, q0: &[f64], qd0: &[f64]) -> Result<Self, usize> {
        let programs = plan
            .programs
            .iter()
            .map(|p| {
                // room for a motion per phase and one more (a restart) before any event
                let n = p.phases.len() + 1;
                let mut memory = ProgramMemory {
                    timeline: Vec::with_capacity(n),
                    motions: Vec::with_capacity(n),
                    records: Vec::with_capacity(n),
                    laws: Vec::with_capacity(n),
                };
                memory.timeline.push((NEVER, 0, None, StartGrad::Zero));
                let motion = p.phases[0].motion.start(0.0, q0[p.joint], qd0[p.joint]);
                memory.motions.push(motion);
                memory.records.push(MotionRecord {
                    origin: MotionOrigin::Fixed,
                    phase: 0,
                    theta0: q0[p.joint],
                    omega0: qd0[p.joint],
                    timed: None,
                    numbers: OnceLock::new(),
                    law: OnceLock::new(),
                });
                memory
            })
            .collect();
        let mut c = BehaviourController {
            named: vec![None; plan.named.len()],
            named_from: vec![None; plan.named.len()],
            plan: Arc::new(plan),
            programs,
            events_seen: 0,
            nq: None,
            workspace: Workspace::default(),
        };
        c.resolve(NEVER);
        if let Some(p) = c.programs.iter().position(|m| m.timeline.len() > PLAN_CAP) {
            return Err(p);
        }
        c.plan_timed_motions(NEVER);
        Ok(c)
    }

    /// Where the plan's parameter tangent comes from when first used (`compile_shared`).
    pub(crate) fn set_tangent_source(&self, make: TangentSource) {
        // a plan compiled with its tangent has no source
        let _ = self.plan.tangent_source.set(make);
    }

    /// The plan's parameter tangent (of a controller just compiled with it).
    pub(crate) fn take_tangent(self) -> PlanTangent {
        Arc::try_unwrap(self.plan)
            .ok()
            .and_then(|p| p.tangent.into_inner())
            .expect("a controller compiled with its tangent, not shared")
    }

    /// The name of the phase the program of `joint` is in at `(t, q)`.
    pub fn phase_name(&self, joint: usize, t: f64, q: &[f64]) -> Option<&str> {
        let p = self.plan.program_of_joint.get(joint).copied().flatten()?;
        Some(&self.plan.programs[p].phases[self.current(p, t, q)].name)
    }

    /// When each named event happened.
    pub fn named_events(&self) -> Vec<(String, Option<f64>)> {
        self.plan
            .named
            .iter()
            .zip(&self.named)
            .map(|(n, t)| (n.name.clone(), *t))
            .collect()
    }

    /// The phase that follows phase `k` of program `p` (joint-angle phases are overlays,
    /// not steps): the next one in order, or the one the program repeats from.
    fn successor(&self, p: usize, k: usize) -> Option<usize> {
        let prog = &self.plan.programs[p];
        (k + 1..prog.phases.len())
            .find(|&i| prog.phases[i].start.level.is_none())
            .or(prog.repeat_from)
    }

    /// The last timeline entry of program `p` started by `t` ([`ProgramMemory::entry`]).
    #[inline]
    fn entry(&self, p: usize, t: f64) -> (f64, usize) {
        self.programs[p].entry(t)
    }

    /// The phase of program `p` at `(t, q)` ([`ProgramMemory::phase`]).
    #[inline]
    fn current(&self, p: usize, t: f64, q: &[f64]) -> usize {
        self.programs[p].phase(&self.plan.programs[p], t, q)
    }

    /// The reference `(θ, ω, α)` of program `p` at `t`.
    #[inline]
    fn reference(&self, p: usize, t: f64) -> (f64, f64, f64) {
        self.programs[p].reference(t)
    }

    /// The law a free massless joint of program `p` follows at `(t, q)`: the reference
    /// `(θ*, ω*, α*)` and gains `(kp_f, kd_f)` of `q̈ = α* + kp_f (θ* − q) + kd_f (ω* − q̇)`.
    ///
    /// A phase with a servo (`kd > 0`, acting in the air): the joint follows the servo's
    /// **torque-free manifold**, towards the servo's target (or the joint's motion, which a
    /// servo without a target tracks). A link of inertia
    /// `ε` under `τ = kp (θ* − θ) + kd (ω* − θ̇)` obeys `ε θ̈ = τ + O(ε)`; as `ε → 0` its fast
    /// motion relaxes in `ε / kd` onto `τ = 0` (Tikhonov: `∂τ/∂θ̇ = −kd < 0`), i.e.
    /// `θ̇ = v(t, θ) = ω* + r (θ* − θ)`, `r = kp / kd`. At a liftoff of the massless chain its
    /// contact force, and with it `τ`, reaches zero, so the rate it leaves with is already
    /// `v`: the law is continuous with stance (docs/singular-transitions.md §9). Written in
    /// second order with a relaxation `c (v − θ̇)` onto the manifold at the law's own rate
    /// `c = r`: `θ̈ = dv/dt + r (v − θ̇) = α* + 2r (ω* − θ̇) + r² (θ* − θ)`, critically damped
    /// at `r` (roots `−c` and `−r`). The massless link's torque acts on nothing else, so a
    /// tracking law with other gains would leave the manifold at the liftoff and could drive
    /// the foot back into the ground. Otherwise (no servo acting in the air) the motion's
    /// reference with the behaviour's `free_joints` gains.
    pub(crate) fn free_law(&self, p: usize, t: f64, q: &[f64]) -> ((f64, f64, f64), (f64, f64)) {
        let plan = &*self.plan;
        let reference = self.reference(p, t);
        let phase = &plan.programs[p].phases[self.current(p, t, q)];
        match servo_manifold(phase) {
            Some((target, kp, kd)) => {
                let r = kp / kd;
                let (theta, omega, alpha) = target.map_or(reference, |a| (a, 0.0, 0.0));
                ((theta, omega, alpha), (r * r, 2.0 * r))
            }
            None => (reference, (plan.kp_free, plan.kd_free)),
        }
    }

    /// Whether a joint of `free_joints` follows its servo's torque-free manifold at `(t, q)`
    /// ([`Self::free_law`]): its parameter and memory partials are not formed yet.
    fn follows_servo_manifold(&self, free_joints: &[usize], t: f64, q: &[f64]) -> bool {
        let plan = &*self.plan;
        free_joints.iter().any(|&j| {
            plan.program_of_joint
                .get(j)
                .copied()
                .flatten()
                .is_some_and(|p| {
                    plan.programs[p].has_servo_manifold
                        && servo_manifold(&plan.programs[p].phases[self.current(p, t, q)]).is_some()
                })
        })
    }

    /// The index of program `p`'s motion in force at `t`: the last one started by `t`.
    #[inline]
    fn motion_index(&self, p: usize, t: f64) -> usize {
        self.programs[p].motion_index(t)
    }

    /// `∂(θ*, ω*, α*)/∂m_k` of program `p`'s reference at `t` (rows `θ*, ω*, α*` of
    /// `1 + 2nq` columns each, one after the other, in a buffer of `ws`) and the event `k` it
    /// depends on; `None` when it depends on no event, `Err(())` when it depends on one in a
    /// way not differentiated.
    fn reference_memory(
        &self,
        ws: &mut Scratch,
        p: usize,
        t: f64,
    ) -> Result<Option<(usize, Vec<f64>)>, ()> {
        self.motion_memory(ws, p, self.motion_index(p, t), t)
    }

    /// [`Self::reference_memory`] of program `p`'s motion `i` at `t`.
    fn motion_memory(
        &self,
        ws: &mut Scratch,
        p: usize,
        i: usize,
        t: f64,
    ) -> Result<Option<(usize, Vec<f64>)>, ()> {
        let mem = &self.programs[p];
        match mem.records[i].origin {
            MotionOrigin::Timed { event, prev, nq } => {
                // θ₀ = θ_prev(s), ω₀ = ω_prev(s) at s = t_k + δ (or a known time): with
                // D the derivative over m_k, Ds = e_t (or 0),
                // Dθ₀ = Dθ_prev(s) + ω_prev(s) Ds, Dω₀ = Dω_prev(s) + α_prev(s) Ds
                let m = &mem.motions[i];
                let s = m.t0();
                let before = self.motion_memory(ws, p, prev, s)?;
                let k = match (event, &before) {
                    (Some(a), Some((b, _))) if a != *b => return Err(()),
                    (Some(a), _) => a,
                    (None, Some((b, _))) => *b,
                    (None, None) => return Ok(None),
                };
                let cols = 1 + 2 * nq;
                let (_, w_prev, a_prev) = mem.motions[prev].eval(s);
                let d = self.start_columns(p, i, t);
                let mut out = ws.zeros(3 * cols);
                for c in 0..cols {
                    let ds = if c == 0 && event.is_some() { 1.0 } else { 0.0 };
                    let (th, w) = before
                        .as_ref()
                        .map_or((0.0, 0.0), |(_, b)| (b[c], b[cols + c]));
                    let dth0 = th + w_prev * ds;
                    let dw0 = w + a_prev * ds;
                    for (r, row) in d.iter().enumerate() {
                        out[r * cols + c] = row[0] * ds + row[1] * dth0 + row[2] * dw0;
                    }
                }
                if let Some((_, b)) = before {
                    ws.give([b]);
                }
                Ok(Some((k, out)))
            }
            MotionOrigin::Fixed => Ok(None),
            MotionOrigin::Event { event, joint, nq } => {
                let d = self.start_columns(p, i, t);
                let cols = 1 + 2 * nq;
                let mut out = ws.zeros(3 * cols);
                for (r, row) in d.iter().enumerate() {
                    out[r * cols] = row[0];
                    out[r * cols + 1 + joint] = row[1];
                    out[r * cols + 1 + nq + joint] = row[2];
                }
                Ok(Some((event, out)))
            }
        }
    }

    /// Program `p`'s motion `i` at `t`: `∂(θ*, ω*, α*)/∂(t₀, θ₀, ω₀, speed, accel, target)`
    /// (rows `θ*, ω*, α*`; a hold is its angle, its target) and the partials of its numbers
    /// `(speed, accel, target)` at its start over the parameters and `(θ₀, ω₀)`.
    fn law_partials(&self, p: usize, i: usize, t: f64) -> ([[f64; 6]; 3], &[NumberPartials; 3]) {
        let mem = &self.programs[p];
        let rec = &mem.records[i];
        let (th0, w0) = (rec.theta0, rec.omega0);
        let numbers = self.numbers_at(p, i);
        let d = match self.started_law(p, i) {
            Some(l) => l.partials_full(&mem.motions[i], th0, w0, t),
            None => {
                let mut d = [[0.0; 6]; 3];
                d[0][5] = 1.0;
                d
            }
        };
        (d, numbers)
    }

    /// The law of program `p`'s motion `i` with its numbers at its start (`None` for a
    /// hold), evaluated once per motion.
    fn started_law(&self, p: usize, i: usize) -> Option<StartedLaw> {
        let rec = &self.programs[p].records[i];
        *rec.law.get_or_init(|| {
            let law = &self.plan.programs[p].phases[rec.phase].motion;
            law.law_at(rec.theta0, rec.omega0)
        })
    }

    /// The partials of program `p`'s motion `i`'s numbers `(speed, accel, target)` at its
    /// start, over the parameters and `(θ₀, ω₀)`: evaluated once per motion (the
    /// sensitivities ask at every step it runs), kept with its record.
    fn numbers_at(&self, p: usize, i: usize) -> &[NumberPartials; 3] {
        let rec = &self.programs[p].records[i];
        rec.numbers.get_or_init(|| {
            let tan = self.plan.tangent();
            Box::new(
                tan.phases[p][rec.phase]
                    .motion
                    .each_ref()
                    .map(|nt| nt.at(rec.theta0, rec.omega0, &tan.values, tan.names.len())),
            )
        })
    }

    /// `∂τ/∂p` over every parameter of program `p`'s torque in phase `k` at fixed state and
    /// memory ([`Controller::parameter_partials`]): `Some(None)` where it is zero, `None`
    /// where it is not differentiated (a `motor` that reverses past an angle).
    fn torque_dp(
        &self,
        ws: &mut Scratch,
        (p, k): (usize, usize),
        t: f64,
        (q, qd): (&[f64], &[f64]),
        mode: ContactMode,
    ) -> Option<Option<Vec<f64>>> {
        let plan = &*self.plan;
        let prog = &plan.programs[p];
        let j = prog.joint;
        let n = plan.tangent().names.len();
        let law = &prog.phases[k].torque;
        Some(Some(match (law, &plan.tangent().phases[p][k].torque) {
            (TorqueLaw::Zero, _) => return Some(None),
            (TorqueLaw::Constant(_), TorqueTangent::Constant(g)) => ws.copy_of(g),
            (
                TorqueLaw::Schedule {
                    times,
                    torques,
                    hold,
                },
                TorqueTangent::Schedule {
                    times: dtimes,
                    torques: dtorques,
                },
            ) => schedule_dp(ws, (times, torques, *hold), t, dtimes, dtorques),
            (
                TorqueLaw::Servo(s),
                TorqueTangent::Servo {
                    target: dtarget,
                    kp: dkp,
                    kd: dkd,
                    limit: dlimit,
                },
            ) => {
                if s.is_off(mode, prog.contacts) {
                    return Some(None);
                }
                let u = self.servo_command(p, t, s.target, (s.kp, s.kd), q[j], qd[j]);
                if servo_piece(u, s.limit) != 0 {
                    let mut d = ws.copy_of(dlimit);
                    d.iter_mut().for_each(|x| *x *= u.signum());
                    return Some(Some(d));
                }
                let (theta, omega, dth, dw) = match (s.target, dtarget) {
                    (Some(a), Some(g)) => (a, 0.0, ws.copy_of(g), ws.zeros(n)),
                    _ => {
                        let (th, om, _) = self.reference(p, t);
                        let [dth, dw, da] = self.motion_dp(ws, p, self.motion_index(p, t), t);
                        ws.give([da]);
                        (th, om, dth, dw)
                    }
                };
                let mut d = ws.zeros(n);
                axpy(&mut d, theta - q[j], dkp);
                axpy(&mut d, omega - qd[j], dkd);
                axpy(&mut d, s.kp, &dth);
                axpy(&mut d, s.kd, &dw);
                ws.give([dth, dw]);
                d
            }
            (
                TorqueLaw::Motor {
                    reverse_beyond: Some(_),
                    ..
                },
                _,
            ) => return None,
            (
                TorqueLaw::Motor {
                    actuator, command, ..
                },
                TorqueTangent::Motor { command: du },
            ) => {
                let mut d = ws.zeros(0);
                plan.tangent().actuators[*actuator].partials(*command, du, qd[j], &mut d);
                d
            }
            _ => unreachable!("a law and its tangent are compiled together"),
        }))
    }

    /// The time events of program `p`'s motion `i`, appended to `out`: its start and its
    /// knots, with `dt/dp` (computed when `with_dp`, else `pick`'s zeros).
    fn motion_time_events(
        &self,
        p: usize,
        i: usize,
        with_dp: bool,
        pick: &dyn Fn(Option<&[f64]>) -> Vec<f64>,
        (ws, out): (&mut Scratch, &mut Vec<TimeEvent>),
    ) {
        let mem = &self.programs[p];
        let m = &mem.motions[i];
        let knots = m.knot_slice();
        if !with_dp {
            out.push(TimeEvent {
                t: m.t0(),
                dt_dp: pick(None),
            });
            out.extend(knots.iter().map(|&t| TimeEvent {
                t,
                dt_dp: pick(None),
            }));
            return;
        }
        let rec = &mem.records[i];
        let start = self.start_dp(ws, p, i);
        out.push(TimeEvent {
            t: m.t0(),
            dt_dp: pick(start.as_ref().map(|s| &s[0][..])),
        });
        let Some(law) = self.started_law(p, i) else {
            return;
        };
        let numbers = self.numbers_at(p, i);
        let n = self.plan.tangent().names.len();
        for (&t, row) in knots
            .iter()
            .zip(law.knot_partials(m, rec.theta0, rec.omega0))
        {
            let mut d = vec![0.0; n];
            for (k, num) in numbers.iter().enumerate() {
                axpy(&mut d, row[3 + k], &num.dp);
            }
            if let Some(start) = &start {
                for (w, g) in fold_row(&row, numbers).iter().zip(start) {
                    axpy(&mut d, *w, g);
                }
            }
            out.push(TimeEvent {
                t,
                dt_dp: pick(Some(&d)),
            });
        }
    }

    /// `∂(θ*, ω*, α*)/∂(t₀, θ₀, ω₀)` of program `p`'s motion `i` at `t` (rows `θ*, ω*, α*`),
    /// through its numbers where they depend on `θ₀`, `ω₀` (`theta`, `omega`).
    fn start_columns(&self, p: usize, i: usize, t: f64) -> [[f64; 3]; 3] {
        let (d, numbers) = self.law_partials(p, i, t);
        fold_start(&d, numbers)
    }

    /// The gradients over the parameters, at fixed memory, of program `p`'s motion `i`'s
    /// start: `(ds, dθ₀, dω₀)` — zero but for a timed phase's motion, which starts at `s`
    /// from the reference of the motion before it, `dθ₀ = ∂θ_prev(s)/∂p + ω_prev(s) ds`,
    /// `dω₀ = ∂ω_prev(s)/∂p + α_prev(s) ds`.
    fn start_dp(&self, ws: &mut Scratch, p: usize, i: usize) -> Option<[Vec<f64>; 3]> {
        let mem = &self.programs[p];
        let (prev, g) = mem.records[i].timed.as_ref()?;
        let s = mem.motions[i].t0();
        let n = self.plan.tangent().names.len();
        let ds = self.start_grad(ws, g).unwrap_or_else(|| ws.zeros(n));
        let [mut dth, mut dw, da] = self.motion_dp(ws, p, *prev, s);
        ws.give([da]);
        let (_, w, a) = mem.motions[*prev].eval(s);
        axpy(&mut dth, w, &ds);
        axpy(&mut dw, a, &ds);
        Some([ds, dth, dw])
    }

    /// `∂(θ*, ω*, α*)/∂p` of program `p`'s motion `i` at `t` over the parameters, at fixed
    /// memory: through its numbers, and for a timed phase's motion through its start
    /// ([`Self::start_dp`]).
    fn motion_dp(&self, ws: &mut Scratch, p: usize, i: usize, t: f64) -> [Vec<f64>; 3] {
        let (d, numbers) = self.law_partials(p, i, t);
        let n = self.plan.tangent().names.len();
        let mut out = [ws.zeros(n), ws.zeros(n), ws.zeros(n)];
        for (r, row) in d.iter().enumerate() {
            for (k, num) in numbers.iter().enumerate() {
                axpy(&mut out[r], row[3 + k], &num.dp);
            }
        }
        if let Some(start) = self.start_dp(ws, p, i) {
            let cols = fold_start(&d, numbers);
            for (r, c) in cols.iter().enumerate() {
                for (w, g) in c.iter().zip(&start) {
                    axpy(&mut out[r], *w, g);
                }
            }
            ws.give(start);
        }
        out
    }

    /// A `servo` law `torque` of program `p` in force at `(t, q, q̇, mode)`; `None` for another
    /// law or a servo switched off (`only_in_contact` with none of the program's contacts
    /// closed in `mode`).
    #[inline]
    fn servo_in_force(
        &self,
        p: usize,
        torque: &TorqueLaw,
        t: f64,
        (q, qd): (&[f64], &[f64]),
        mode: ContactMode,
    ) -> Option<ServoInForce> {
        let prog = &self.plan.programs[p];
        let TorqueLaw::Servo(s) = torque else {
            return None;
        };
        if s.is_off(mode, prog.contacts) {
            return None;
        }
        let j = prog.joint;
        Some(ServoInForce {
            u: self.servo_command(p, t, s.target, (s.kp, s.kd), q[j], qd[j]),
            limit: s.limit,
            gains: (s.kp, s.kd),
            tracks_motion: s.target.is_none(),
        })
    }

    /// The unsaturated servo command of program `p` at `t`
    /// ([`ProgramMemory::servo_command`]).
    #[inline]
    fn servo_command(
        &self,
        p: usize,
        t: f64,
        target: Option<f64>,
        gains: (f64, f64),
        q: f64,
        qd: f64,
    ) -> f64 {
        self.programs[p].servo_command(t, target, gains, q, qd)
    }

    /// When phase `j` of program `p`, armed at `armed` (the entry before it), starts without
    /// waiting for an event of the execution: at a time, after a named event that has
    /// happened, or after another phase's start that is known; `None` if it has to wait for
    /// an event. With the start, the event its time is offset from (see [`TimeOrigin`]) and
    /// its gradient over the parameters: the alternative that wins, or the arming start when
    /// it is later.
    fn known_start(&self, p: usize, j: usize, armed: &Entry) -> Option<Entry> {
        /// The alternative that gives the start.
        enum Which {
            Armed,
            Time(usize),
            Named,
            Phase(usize, StartGrad),
        }
        let s = &self.plan.programs[p].phases[j].start;
        let mut best: Option<(f64, TimeOrigin, Which)> = None;
        let mut offer = |c: f64, from: TimeOrigin, which: Which| {
            let c = if armed.0 > c {
                (armed.0, armed.2, Which::Armed)
            } else {
                (c, from, which)
            };
            if best.as_ref().is_none_or(|b| c.0 < b.0) {
                best = Some(c);
            }
        };
        for (i, &t) in s.times.iter().enumerate() {
            offer(t, None, Which::Time(i));
        }
        for &n in &s.named {
            if let Some(t) = self.named[n] {
                offer(t, self.named_from[n].map(|k| (k, t)), Which::Named);
            }
        }
        for (i, &(p2, k2, delay)) in s.phases.iter().enumerate() {
            let starts = self.programs[p2].timeline.iter().filter(|e| e.1 == k2);
            if let Some(e) = starts.map(|e| (e.0 + delay, e)).find(|e| e.0 >= armed.0) {
                offer(e.0, e.1 .2, Which::Phase(i, e.1 .3));
            }
        }
        best.map(|(t, from, which)| {
            let grad = match which {
                Which::Armed => armed.3,
                Which::Time(i) => StartGrad::Time(p, j, i),
                Which::Named => StartGrad::Zero,
                Which::Phase(i, g) => match g {
                    StartGrad::Zero => StartGrad::Delay(None, (p, j, i)),
                    StartGrad::Time(a, b, c) => StartGrad::Delay(Some((a, b, c)), (p, j, i)),
                    _ => StartGrad::Deeper,
                },
            };
            (t, j, from, grad)
        })
    }

    /// The gradient of a planned start (`None`: zero), from the plan's tangent; NaN for a
    /// start not differentiated ([`StartGrad::Deeper`]).
    fn start_grad(&self, ws: &mut Scratch, g: &StartGrad) -> Option<Vec<f64>> {
        let tan = self.plan.tangent();
        let n = tan.names.len();
        match *g {
            StartGrad::Zero => None,
            StartGrad::Time(p, j, i) => Some(ws.copy_of(&tan.phases[p][j].times[i])),
            StartGrad::Delay(before, (p, j, i)) => {
                let mut d = match before {
                    Some((bp, bj, bi)) => ws.copy_of(&tan.phases[bp][bj].times[bi]),
                    None => ws.zeros(n),
                };
                axpy(&mut d, 1.0, &tan.phases[p][j].delays[i]);
                Some(d)
            }
            StartGrad::Deeper => {
                let mut d = ws.zeros(n);
                d.fill(f64::NAN);
                Some(d)
            }
        }
    }

    /// Plans again, after `now`, the phases whose starts are known (to the horizon), for
    /// every program, to a fixed point (phases may wait for other programs' phases).
    fn resolve(&mut self, now: f64) {
        let passes = self.plan.programs.len() + 2;
        let mut planned = Vec::new();
        for _ in 0..passes {
            let mut changed = false;
            for p in 0..self.plan.programs.len() {
                let keep = self.programs[p]
                    .timeline
                    .partition_point(|e| e.0 <= now)
                    .max(1);
                let mut last = self.programs[p].timeline[keep - 1];
                planned.clear();
                while planned.len() <= PLAN_CAP {
                    let Some(j) = self.successor(p, last.1) else {
                        break;
                    };
                    let Some(entry) = self.known_start(p, j, &last) else {
                        break;
                    };
                    let start = entry.0;
                    planned.push(entry);
                    last = entry;
                    if start > self.plan.horizon_s {
                        break;
                    }
                }
                let tl = &mut self.programs[p].timeline;
                if tl[keep..] != planned[..] {
                    tl.truncate(keep);
                    tl.extend_from_slice(&planned);
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        for (mem, prog) in self.programs.iter_mut().zip(&self.plan.programs) {
            mem.refresh_laws(prog);
        }
    }

    /// Drops the motions planned after `now` and plans again those of the phases that start
    /// at known times after it, each from the reference where it starts.
    fn plan_timed_motions(&mut self, now: f64) {
        let plan = Arc::clone(&self.plan);
        let nq = self.nq.unwrap_or(0);
        for (p, prog) in plan.programs.iter().enumerate() {
            let mem = &mut self.programs[p];
            if now > NEVER {
                mem.keep_motions_started_by(now);
            }
            let first = mem.timeline.partition_point(|e| e.0 <= now);
            for (s, k, from, grad) in &mem.timeline[first..] {
                let (s, k) = (*s, *k);
                let phase = &prog.phases[k];
                if !phase.own_motion {
                    continue;
                }
                let i = mem.motions.iter().rposition(|m| m.t0() <= s).unwrap_or(0);
                let (theta, omega, _) = mem.motions[i].eval(s);
                // at a time or from a reference that depends on an event: it moves with them
                let fixed = from.is_none() && mem.records[i].origin == MotionOrigin::Fixed;
                let origin = if fixed || !phase.motion.depends_on_start() {
                    MotionOrigin::Fixed
                } else {
                    MotionOrigin::Timed {
                        event: from.map(|f| f.0),
                        prev: i,
                        nq,
                    }
                };
                mem.motions.push(phase.motion.start(s, theta, omega));
                mem.records.push(MotionRecord {
                    origin,
                    phase: k,
                    theta0: theta,
                    omega0: omega,
                    timed: Some((i, *grad)),
                    numbers: OnceLock::new(),
                    law: OnceLock::new(),
                });
            }
        }
    }

    /// The torque of program `p`'s joint at `(t, q, q̇)` in `mode`: the law in force.
    #[inline]
    fn program_torque(
        &self,
        p: usize,
        t: f64,
        (q, qd): (&[f64], &[f64]),
        mode: ContactMode,
    ) -> f64 {
        let plan = &*self.plan;
        let (prog, mem) = (&plan.programs[p], &self.programs[p]);
        let j = prog.joint;
        let servo_off =
            |only_in_contact: bool| only_in_contact && mode.normal_bits() & prog.contacts == 0;
        match *mem.law(t) {
            ActiveLaw::Zero => 0.0,
            ActiveLaw::Constant(c) => c,
            ActiveLaw::Motor { actuator, command } => {
                plan.actuators[actuator].joint_torque_n_m(command, qd[j])
            }
            ActiveLaw::MotorReversing {
                actuator,
                command,
                sign,
                reverse_beyond,
            } => {
                let reversed = sign * q[j] > reverse_beyond;
                let u = if reversed { -command } else { command };
                plan.actuators[actuator].joint_torque_n_m(u, qd[j])
            }
            ActiveLaw::ServoAt {
                only_in_contact, ..
            }
            | ActiveLaw::ServoTracking {
                only_in_contact, ..
            } if servo_off(only_in_contact) => 0.0,
            ActiveLaw::ServoAt {
                target,
                gains,
                limit,
                ..
            } => mem
                .servo_command(t, Some(target), gains, q[j], qd[j])
                .clamp(-limit, limit),
            ActiveLaw::ServoTracking { gains, limit, .. } => mem
                .servo_command(t, None, gains, q[j], qd[j])
                .clamp(-limit, limit),
            ActiveLaw::General => law_torque(plan, prog, mem, (t, q, qd), mode),
        }
    }
}

/// The joint-angle phase right after phase `k` of `prog` whose level holds at `q`, else `k`.
#[inline(never)]
fn level_phase(prog: &Program, k: usize, q: &[f64]) -> usize {
    let phases = &prog.phases;
    let mut j = k + 1;
    while j < phases.len() {
        match &phases[j].start.level {
            Some(level) if level.holds(q) => return j,
            Some(_) => j += 1,
            None => break,
        }
    }
    k
}

/// `∂(θ*, ω*, α*)/∂(t₀, θ₀, ω₀)` from the partials `d` over the start and the numbers
/// `(speed, accel, target)` and the numbers' partials over `(θ₀, ω₀)`: the chain through
/// `theta`, `omega`.
fn fold_start(d: &[[f64; 6]; 3], numbers: &[NumberPartials; 3]) -> [[f64; 3]; 3] {
    d.map(|row| fold_row(&row, numbers))
}

/// [`fold_start`] of one row.
fn fold_row(row: &[f64; 6], numbers: &[NumberPartials; 3]) -> [f64; 3] {
    let mut c = [row[0], row[1], row[2]];
    for (k, num) in numbers.iter().enumerate() {
        c[1] += row[3 + k] * num.dtheta;
        c[2] += row[3 + k] * num.domega;
    }
    c
}

/// `∂τ/∂p` of a schedule at `t` ([`schedule`]) over its torques' and times' gradients:
/// between breakpoints `a < t < b`, `τ = τ_a + s (τ_b − τ_a)` with `s = (t − a)/(b − a)`,
/// `∂s/∂a = (s − 1)/(b − a)`, `∂s/∂b = −s/(b − a)`; beyond the ends (and held) the torque's.
fn schedule_dp(
    ws: &mut Scratch,
    (times, torques, hold): (&[f64], &[f64], bool),
    t: f64,
    dtimes: &[Grad],
    dtorques: &[Grad],
) -> Vec<f64> {
    let i = times.partition_point(|&x| x <= t);
    if i == 0 {
        return ws.copy_of(&dtorques[0]);
    }
    if i == times.len() || hold {
        return ws.copy_of(&dtorques[i - 1]);
    }
    let (a, b) = (times[i - 1], times[i]);
    let s = (t - a) / (b - a);
    let rise = torques[i] - torques[i - 1];
    let mut d = ws.zeros(dtorques[0].len());
    axpy(&mut d, 1.0 - s, &dtorques[i - 1]);
    axpy(&mut d, s, &dtorques[i]);
    axpy(&mut d, rise * (s - 1.0) / (b - a), &dtimes[i - 1]);
    axpy(&mut d, -rise * s / (b - a), &dtimes[i]);
    d
}

/// The piece of a servo's law `sat(u, ±limit)` at command `u`: linear (0), saturated at
/// `+limit` (1) or `−limit` (2); a value exactly at the limit counts as saturated (the side
/// the clamp returns). Its partials switch exactly there.
fn servo_piece(u: f64, limit: f64) -> u64 {
    if u.abs() < limit {
        0
    } else if u > 0.0 {
        1
    } else {
        2
    }
}

/// A servo law in force at a state ([`BehaviourController::servo_in_force`]).
#[derive(Clone, Copy)]
struct ServoInForce {
    /// The unsaturated command `u = −kp (q_j − θ*) − kd (q̇_j − ω*)`.
    u: f64,
    limit: f64,
    gains: (f64, f64),
    /// It tracks the joint's motion (no fixed target).
    tracks_motion: bool,
}

impl ServoInForce {
    /// `(kp, kd)` when the servo tracks the joint's motion inside its limit: where the torque
    /// moves with the motion's reference.
    fn tracking_gains(self) -> Option<(f64, f64)> {
        (self.tracks_motion && self.u.abs() < self.limit).then_some(self.gains)
    }
}

impl Controller for BehaviourController {
    fn torque(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode, tau: &mut [f64]) {
        let plan = &*self.plan;
        for &j in &plan.idle_joints {
            tau[j] = 0.0;
        }
        for p in 0..plan.programs.len() {
            tau[plan.programs[p].joint] = self.program_torque(p, t, (q, qd), mode);
        }
    }

    /// Each joint's law is its program's alone: only the programs of `joints` run.
    fn torque_of(
        &self,
        t: f64,
        (q, qd): (&[f64], &[f64]),
        mode: ContactMode,
        joints: std::ops::Range<usize>,
        tau: &mut [f64],
    ) {
        for j in joints {
            tau[j] = match self.plan.program_of_joint.get(j).copied().flatten() {
                Some(p) => self.program_torque(p, t, (q, qd), mode),
                None => 0.0,
            };
        }
    }

    fn free_joint_qdd(&self, t: f64, q: &[f64], qd: &[f64], free: &[usize], out: &mut [f64]) {
        let plan = &*self.plan;
        for (slot, &j) in out.iter_mut().zip(free) {
            *slot = match plan.program_of_joint.get(j).copied().flatten() {
                // no servo manifold in the program: the tracking law, without the phase
                // lookup of `free_law` (a leap's legs in the air take this path every step)
                Some(p) if !plan.programs[p].has_servo_manifold => {
                    let (theta, omega, alpha) = self.reference(p, t);
                    alpha + plan.kp_free * (theta - q[j]) + plan.kd_free * (omega - qd[j])
                }
                Some(p) => {
                    let ((theta, omega, alpha), (kp_f, kd_f)) = self.free_law(p, t, q);
                    alpha + kp_f * (theta - q[j]) + kd_f * (omega - qd[j])
                }
                None => 0.0,
            };
        }
    }

    /// `∂Υ/∂(q, q̇)` and `∂q̈_free/∂(q, q̇)` of the laws in force at `(t, q, q̇, mode)`, over the
    /// state only (a motion's reference and a schedule are functions of time):
    ///
    /// - `zero`, `constant`, `schedule`: 0;
    /// - `servo` `τ = sat(−kp (q_j − θ*) − kd (q̇_j − ω*), ±limit)`: `−kp`, `−kd` on joint `j`'s
    ///   own row and column inside the limit, 0 on the saturated branch (the side the clamp
    ///   returns: a value exactly at the limit counts as saturated), 0 out of contact with
    ///   `only_in_contact`;
    /// - `motor`: `∂τ/∂q̇_j` of the actuator's law on its branch (`tangent.rs`,
    ///   `ActuatorLaw::partials`: the torque–speed line or the current limit, one-sided at the
    ///   kink a joint leaves; driving or back-driven under the power-flow gearbox law);
    /// - a free joint `q̈ = α_ref + kp_f (θ_ref − q_j) + kd_f (ω_ref − q̇_j)`: `−kp_f`, `−kd_f`.
    ///
    /// No partials (`false`) for a `motor` that reverses past an angle (`reverse_beyond_rad`:
    /// its torque jumps at a crossing without an event), for a `motor` whose power-flow
    /// gearbox law is at its jump (the joint's speed changing sign under load:
    /// `ActuatorLaw::at_power_flow_jump`) or for a program with a
    /// `joint_angle` level (its torque switches inside a flow at a crossing the engine does
    /// not locate, where no saltation matrix could be formed).
    fn partials(&self, at: &ControlPoint, out: &mut ControllerPartials) -> bool {
        let ControlPoint { t, q, qd, mode, .. } = *at;
        let free_joints = at.free_joints;
        let plan = &*self.plan;
        for (p, prog) in plan.programs.iter().enumerate() {
            if prog.has_levels {
                return false;
            }
            let j = prog.joint;
            match &prog.phases[self.current(p, t, q)].torque {
                TorqueLaw::Zero | TorqueLaw::Constant(_) | TorqueLaw::Schedule { .. } => {}
                TorqueLaw::Motor {
                    reverse_beyond: Some(_),
                    ..
                } => return false,
                TorqueLaw::Motor {
                    actuator, command, ..
                } => {
                    let law = &plan.tangent().actuators[*actuator];
                    if law.at_power_flow_jump(*command, qd[j]) {
                        return false;
                    }
                    out.dtau.dqd[(j, j)] = law.partials(*command, &[], qd[j], &mut Vec::new());
                }
                law @ TorqueLaw::Servo(servo) => {
                    let in_force = self.servo_in_force(p, law, t, (q, qd), mode);
                    if in_force.is_some_and(|s| servo_piece(s.u, servo.limit) == 0) {
                        out.dtau.dq[(j, j)] = -servo.kp;
                        out.dtau.dqd[(j, j)] = -servo.kd;
                    }
                }
            }
        }
        for (i, &j) in free_joints.iter().enumerate() {
            if let Some(p) = plan.program_of_joint.get(j).copied().flatten() {
                let (_, (kp_f, kd_f)) = self.free_law(p, t, q);
                out.dfree.dq[(i, j)] = -kp_f;
                out.dfree.dqd[(i, j)] = -kd_f;
            }
        }
        true
    }

    /// Per program, two bits: a servo in its linear range (0) or saturated at `+limit` (1)
    /// or `−limit` (2), a motor on its torque–speed line (0) or at its current limit (1),
    /// plus 2 where its power-flow gearbox law is back-driven — where [`Self::partials`]
    /// switch branch (the tangent's steps are split there); the
    /// other laws 0. Programs past the 32nd fold into the same bits.
    fn partials_piece(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode) -> u64 {
        let plan = &*self.plan;
        let mut out = 0u64;
        for (p, prog) in plan.programs.iter().enumerate() {
            let torque = &prog.phases[self.current(p, t, q)].torque;
            if let TorqueLaw::Motor {
                actuator, command, ..
            } = torque
            {
                let piece = plan.tangent().actuators[*actuator].piece(*command, qd[prog.joint]);
                let bits = u64::from(piece.on_limit) | u64::from(piece.back_driven) << 1;
                out ^= bits << (2 * (p % 32));
                continue;
            }
            if let Some(s) = self.servo_in_force(p, torque, t, (q, qd), mode) {
                out ^= servo_piece(s.u, s.limit) << (2 * (p % 32));
            }
        }
        out
    }

    /// `∂Υ/∂p` and `∂q̈_free/∂p` over the named parameters of the behaviour (its
    /// `[parameters]`) at fixed state and memory, each law through the gradients of its
    /// numbers (`tangent.rs`: formulas forward-mode, actuator data in closed form):
    ///
    /// - `constant` its torque's gradient; `schedule` the interpolation's over its torques
    ///   and breakpoints;
    /// - `servo` inside its limit `(θ* − q) ∂kp + (ω* − q̇) ∂kd + kp ∂θ* + kd ∂ω*` (a fixed
    ///   target's gradient, or the motion's, `motion_dp`), saturated `±∂limit`, 0 out of
    ///   contact with `only_in_contact`;
    /// - `motor` the actuator law's over its data (`gear_ratio`, `current_limit_a`, `count`,
    ///   `supply_voltage_v`) and its command (`ActuatorLaw::partials`);
    /// - a free joint `∂α* + (θ* − q) ∂kp_f + (ω* − q̇) ∂kd_f + kp_f ∂θ* + kd_f ∂ω*`.
    ///
    /// `false` for a name that is not a parameter of the behaviour, wherever
    /// [`Controller::partials`] gives none, and for a phase planned a delay after a phase
    /// itself planned a delay after another (not differentiated yet).
    fn parameter_partials(
        &self,
        at: &ControlPoint,
        names: &[&str],
        out: &mut ControllerPartials,
    ) -> bool {
        let ControlPoint { t, q, qd, mode, .. } = *at;
        let free_joints = at.free_joints;
        let plan = &*self.plan;
        let tan = plan.tangent();
        let mut ws = self.workspace.lend();
        // the indices' buffer, given back on success (a refusal drops it)
        let mut idx = std::mem::take(&mut ws.1);
        if !tan.indices_into(names, &mut idx) {
            return false;
        }
        let deeper = |m: &ProgramMemory| m.timeline.iter().any(|e| e.3 == StartGrad::Deeper);
        if self.programs.iter().any(deeper) {
            return false;
        }
        for (p, prog) in plan.programs.iter().enumerate() {
            if prog.has_levels {
                return false;
            }
            let k = self.current(p, t, q);
            match self.torque_dp(&mut ws, (p, k), t, (q, qd), mode) {
                None => return false,
                Some(None) => {}
                Some(Some(d)) => {
                    for (c, &i) in idx.iter().enumerate() {
                        out.dtau_dp[(prog.joint, c)] = d[i];
                    }
                    ws.give([d]);
                }
            }
        }
        if self.follows_servo_manifold(free_joints, t, q) {
            return false;
        }
        for (r, &j) in free_joints.iter().enumerate() {
            let Some(p) = plan.program_of_joint.get(j).copied().flatten() else {
                continue;
            };
            let [dth, dw, mut d] = self.motion_dp(&mut ws, p, self.motion_index(p, t), t);
            let (theta, omega, _) = self.reference(p, t);
            axpy(&mut d, theta - q[j], &tan.kp_free);
            axpy(&mut d, omega - qd[j], &tan.kd_free);
            axpy(&mut d, plan.kp_free, &dth);
            axpy(&mut d, plan.kd_free, &dw);
            for (c, &i) in idx.iter().enumerate() {
                out.dfree_dp[(r, c)] = d[i];
            }
            ws.give([dth, dw, d]);
        }
        ws.1 = idx;
        true
    }

    /// The instants where the outputs may jump in time alone: each phase start already known,
    /// each prescribed motion's start and knots (its jerk jumps there), and the breakpoints
    /// of torque schedules, once each (the first listed where several coincide), each with
    /// `dt_b/dp` over the named parameters at fixed memory (an instant that moves with a
    /// remembered event is also a memory time event, [`Self::memory_time_events`]): a start
    /// planned at a time its gradient; a motion's start its phase's, its knots that plus the
    /// durations' (`StartedLaw::knot_partials`); a breakpoint its time's. Names the behaviour
    /// does not have get zeros ([`Self::parameter_partials`] refuses them). The engine's
    /// steps land on these instants.
    fn time_events(&self, names: &[&str]) -> Vec<TimeEvent> {
        // the forward run asks with no names: the tangent is not built for it
        let tan = (!names.is_empty()).then(|| self.plan.tangent());
        let idx = tan.and_then(|t| t.indices(names));
        let pick = |g: Option<&[f64]>| -> Vec<f64> {
            match (&idx, g) {
                (Some(ix), Some(g)) => ix.iter().map(|&i| g[i]).collect(),
                _ => vec![0.0; names.len()],
            }
        };
        // each timeline entry, each motion's start and its (at most three) knots, each
        // breakpoint: one allocation
        let breakpoints = |prog: &Program| -> usize {
            let times = |ph: &PhasePlan| match &ph.torque {
                TorqueLaw::Schedule { times, .. } => times.len(),
                _ => 0,
            };
            prog.phases.iter().map(times).sum()
        };
        let capacity = (self.programs.iter())
            .zip(&self.plan.programs)
            .map(|(m, prog)| m.timeline.len() + 4 * m.motions.len() + breakpoints(prog))
            .sum();
        let mut out = Vec::with_capacity(capacity);
        let mut ws = self.workspace.lend();
        for mem in &self.programs {
            out.extend(mem.timeline.iter().map(|e| TimeEvent {
                t: e.0,
                dt_dp: match idx {
                    Some(_) => pick(self.start_grad(&mut ws, &e.3).as_deref()),
                    None => pick(None),
                },
            }));
        }
        for (p, prog) in self.plan.programs.iter().enumerate() {
            for i in 0..self.programs[p].motions.len() {
                self.motion_time_events(p, i, idx.is_some(), &pick, (&mut ws, &mut out));
            }
            for (k, phase) in prog.phases.iter().enumerate() {
                let TorqueLaw::Schedule { times, .. } = &phase.torque else {
                    continue;
                };
                let dtimes = match tan
                    .filter(|_| idx.is_some())
                    .map(|t| &t.phases[p][k].torque)
                {
                    Some(TorqueTangent::Schedule { times: d, .. }) => Some(d),
                    _ => None,
                };
                out.extend(times.iter().enumerate().map(|(i, &t)| TimeEvent {
                    t,
                    dt_dp: pick(dtimes.map(|d| &d[i][..])),
                }));
            }
        }
        out.retain(|e| e.t.is_finite());
        out.sort_by(|a, b| a.t.total_cmp(&b.t));
        out.dedup_by(|b, a| a.t == b.t);
        out
    }

    /// `∂Υ/∂t` at a fixed state: a `servo` that tracks the joint's motion (inside its limit)
    /// `kp ω* + kd α*`; a `schedule` between breakpoints (interpolated) its slope; every other
    /// law 0 (`motor`: its command is constant, a function of the state only).
    fn time_partials(&self, at: &ControlPoint, dtau_dt: &mut [f64]) -> bool {
        let ControlPoint { t, q, qd, mode, .. } = *at;
        let plan = &*self.plan;
        for (p, prog) in plan.programs.iter().enumerate() {
            let j = prog.joint;
            let torque = &prog.phases[self.current(p, t, q)].torque;
            if let Some((kp, kd)) = self
                .servo_in_force(p, torque, t, (q, qd), mode)
                .and_then(ServoInForce::tracking_gains)
            {
                let (_, w, a) = self.reference(p, t);
                dtau_dt[j] = kp * w + kd * a;
                continue;
            }
            dtau_dt[j] = match torque {
                TorqueLaw::Schedule {
                    times,
                    torques,
                    hold: false,
                } => {
                    let i = times.partition_point(|&x| x <= t);
                    if i == 0 || i == times.len() {
                        0.0
                    } else {
                        (torques[i] - torques[i - 1]) / (times[i] - times[i - 1])
                    }
                }
                _ => 0.0,
            };
        }
        true
    }

    /// Whether a motion depends on an event's start, or a phase starts a delay after an event (a named event's, or another phase's start).
    fn has_event_memory(&self) -> bool {
        self.programs.iter().any(|m| {
            m.records.iter().any(|r| r.origin != MotionOrigin::Fixed)
                || m.timeline
                    .iter()
                    .any(|e| e.2.is_some_and(|(_, tk)| e.0 != tk))
        })
    }

    /// `∂Υ/∂m_k`, `∂q̈_free/∂m_k` of the motion in force of each program, where it started
    /// at event `k` from the event's state, or (a timed phase's own motion) at a time or
    /// from a reference that depends on it (`motion::StartedLaw`): a `servo` that tracks the
    /// motion (inside its limit) `kp ∂θ*/∂m_k + kd ∂ω*/∂m_k` on its joint's row, a free joint
    /// `∂α*/∂m_k + kp_f ∂θ*/∂m_k + kd_f ∂ω*/∂m_k`; numbers of `theta`/`omega` through the
    /// start. `false` where the motion in force depends on an event in a way not
    /// differentiated (a timed phase's motion whose start and whose previous motion depend
    /// on two different events), or where [`Controller::partials`] gives none (a `motor`
    /// that reverses past an angle).
    fn memory_partials(&self, at: &ControlPoint, out: &mut Vec<EventMemoryPartials>) -> bool {
        let ControlPoint { t, q, qd, mode, .. } = *at;
        let free_joints = at.free_joints;
        let plan = &*self.plan;
        let n = plan.program_of_joint.len();
        if self.follows_servo_manifold(free_joints, t, q) {
            return false;
        }
        let mut ws = self.workspace.lend();
        for (p, prog) in plan.programs.iter().enumerate() {
            let j = prog.joint;
            let free = free_joints.iter().position(|&f| f == j);
            let torque = &prog.phases[self.current(p, t, q)].torque;
            if matches!(
                torque,
                TorqueLaw::Motor {
                    reverse_beyond: Some(_),
                    ..
                }
            ) {
                return false;
            }
            let servo = self
                .servo_in_force(p, torque, t, (q, qd), mode)
                .and_then(ServoInForce::tracking_gains);
            if servo.is_none() && free.is_none() {
                continue;
            }
            let (event, d) = match self.reference_memory(&mut ws, p, t) {
                Ok(Some(x)) => x,
                Ok(None) => continue,
                Err(()) => return false,
            };
            let cols = d.len() / 3;
            let (th, rest) = d.split_at(cols);
            let (w, a) = rest.split_at(cols);
            let mut dtau = DMatrix::zeros(n, cols);
            let mut dfree = DMatrix::zeros(free_joints.len(), cols);
            if let Some((kp, kd)) = servo {
                for c in 0..cols {
                    dtau[(j, c)] = kp * th[c] + kd * w[c];
                }
            }
            if let Some(i) = free {
                for c in 0..cols {
                    dfree[(i, c)] = a[c] + plan.kp_free * th[c] + plan.kd_free * w[c];
                }
            }
            ws.give([d]);
            out.push(EventMemoryPartials { event, dtau, dfree });
        }
        true
    }

    /// The phase starts offset from an event's time by a delay (`t_b = t_k + δ`, so
    /// `dt_b/dt_k = 1`); a phase the event itself started is the event.
    fn memory_time_events(&self) -> Vec<MemoryTimeEvent> {
        let mut out = Vec::new();
        for m in &self.programs {
            for &(t, _, from, _) in &m.timeline {
                let Some((k, tk)) = from else { continue };
                if t == tk || !t.is_finite() {
                    continue;
                }
                let nq = self.nq.unwrap_or(0);
                let mut dt_dm = vec![0.0; 1 + 2 * nq];
                dt_dm[0] = 1.0;
                out.push(MemoryTimeEvent { t, event: k, dt_dm });
            }
        }
        out
    }

    fn on_event(&mut self, e: &Event) {
        let plan = Arc::clone(&self.plan);
        let ev_k = self.events_seen;
        self.events_seen += 1;
        self.nq = Some(e.q.len());
        // => named events (in an order where each comes after the one it waits for)
        let mut fired_now = vec![false; plan.named.len()];
        for (n, named) in plan.named.iter().enumerate() {
            let ready = named.after.is_none_or(|a| self.named[a].is_some());
            if self.named[n].is_none() && ready && named.trigger.matches(e) {
                self.named[n] = Some(e.t);
                self.named_from[n] = Some(ev_k);
                fired_now[n] = true;
            }
        }
        // => the phases the event starts: the successor of each program's phase, armed
        let entries_before: Vec<usize> = self
            .programs
            .iter()
            .map(|m| m.timeline.partition_point(|x| x.0 <= e.t))
            .collect();
        for (p, prog) in plan.programs.iter().enumerate() {
            let len = entries_before[p];
            self.programs[p].timeline.truncate(len);
            for _ in 0..prog.phases.len() {
                let k = self.entry(p, e.t).1;
                let Some(j) = self.successor(p, k) else { break };
                if !prog.phases[j].start.events.iter().any(|m| m.matches(e)) {
                    break;
                }
                self.programs[p]
                    .timeline
                    .push((e.t, j, Some((ev_k, e.t)), StartGrad::Zero));
            }
        }
        // => the starts this makes known, and those of the phases after them
        self.resolve(e.t);
        // => motions started by the event, or restarted at it, for joints it leaves free
        for (p, prog) in plan.programs.iter().enumerate() {
            if e.mode_after.normal_bits() & prog.contacts != 0 {
                continue;
            }
            let mem = &self.programs[p];
            let entered = mem.timeline.partition_point(|x| x.0 <= e.t) > entries_before[p];
            let k = self.current(p, e.t, &e.q);
            let phase = &prog.phases[k];
            // a phase without a motion of its own keeps the one running
            let started_now = entered && phase.own_motion;
            let restart = phase.restart_on.iter().any(|m| m.matches(e))
                || phase.restart_named.iter().any(|&n| fired_now[n]);
            if started_now || restart {
                let j = prog.joint;
                let origin = if phase.motion.depends_on_start() {
                    MotionOrigin::Event {
                        event: ev_k,
                        joint: j,
                        nq: e.q.len(),
                    }
                } else {
                    MotionOrigin::Fixed
                };
                let mem = &mut self.programs[p];
                mem.keep_motions_started_by(e.t);
                mem.motions
                    .push(phase.motion.start(e.t, e.q[j], e.qd_after[j]));
                mem.records.push(MotionRecord {
                    origin,
                    phase: k,
                    theta0: e.q[j],
                    omega0: e.qd_after[j],
                    timed: None,
                    numbers: OnceLock::new(),
                    law: OnceLock::new(),
                });
            }
        }
        self.plan_timed_motions(e.t);
    }
}

/// The torque of program `prog` (with its memory `mem`) at `(t, q, q̇, mode)`: the law of
/// its phase there ([`ProgramMemory::phase`]), read from the plan.
#[inline(never)]
fn law_torque(
    plan: &Plan,
    prog: &Program,
    mem: &ProgramMemory,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
) -> f64 {
    let j = prog.joint;
    match &prog.phases[mem.phase(prog, t, q)].torque {
        TorqueLaw::Zero => 0.0,
        TorqueLaw::Constant(c) => *c,
        TorqueLaw::Schedule {
            times,
            torques,
            hold,
        } => schedule(times, torques, *hold, t),
        TorqueLaw::Servo(s) => {
            if s.is_off(mode, prog.contacts) {
                0.0
            } else {
                let u = mem.servo_command(t, s.target, (s.kp, s.kd), q[j], qd[j]);
                u.clamp(-s.limit, s.limit)
            }
        }
        TorqueLaw::Motor {
            actuator,
            command,
            reverse_beyond,
        } => {
            let reversed = reverse_beyond.is_some_and(|a| command.signum() * q[j] > a);
            let u = if reversed { -command } else { *command };
            plan.actuators[*actuator].joint_torque_n_m(u, qd[j])
        }
    }
}

/// The torque of a schedule at `t` (constant beyond its ends).
fn schedule(times: &[f64], torques: &[f64], hold: bool, t: f64) -> f64 {
    let i = times.partition_point(|&x| x <= t);
    if i == 0 {
        return torques[0];
    }
    if i == times.len() || hold {
        return torques[i - 1];
    }
    let (t0, t1) = (times[i - 1], times[i]);
    let s = (t - t0) / (t1 - t0);
    torques[i - 1] + s * (torques[i] - torques[i - 1])
}
