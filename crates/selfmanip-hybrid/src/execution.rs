//! The record of an execution of the hybrid system (thesis Definition 5.2): the segments of
//! flow with their dense output, the events (resets) between them, and why the run ended.
use crate::controller::Controller;
use crate::integrate::DenseOutput;
use selfmanip_core::{ContactMode, SingularityKind};
use std::sync::Arc;

/// What kind of guard fired.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum EventKind {
    /// New contacts touched down: a plastic impact.
    Touchdown,
    /// Normal forces reached zero: contacts released without impact.
    Liftoff,
    /// The body reached its highest point in flight (terminal when the run stops at the
    /// apex; otherwise recorded, changing nothing).
    Apex,
    /// Sticking contacts reached the friction cone and started to slide.
    Slip,
    /// Sliding contacts reached zero sliding velocity (and stuck, if `mode_after` says so).
    Stick,
    /// A contact's massless chain reached its fold (Lemma 5.1, [`crate::fold`]): the contact
    /// stuck impulsively or was released, as `mode_after` says, or (mode unchanged) it
    /// passes the fold sliding, its joint locked at the speed where its torque vanishes.
    Fold,
    /// A fold passage ended on the far side of the fold: the joint is unlocked.
    FoldPassed,
    /// A sliding contact whose slide had no consistent continuation (Painlevé) jammed: a
    /// plastic impact into the mode with it sticking, an impact without collision
    /// ([`crate::jam`]); or, no impulse acting, it stuck or left by force complementarity.
    Jam,
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
    /// The controller as it ran in this segment (its memory of the events before it).
    pub controller: Arc<dyn Controller>,
    /// Massless joints locked at their speed in this segment: a leg passing the fold of its
    /// sliding contact ([`crate::fold`]); empty otherwise.
    pub locked: Vec<usize>,
    /// The sliding direction of each sliding contact with kinetic friction in this segment
    /// ([`crate::flow::Flow::fix_slide_directions`]); empty otherwise.
    pub slide_directions: Vec<(usize, selfmanip_core::friction::SlideDirection)>,
    /// The accepted steps' continuous extensions (the last may reach past `t1`: the
    /// segment ends inside it, where its event was located).
    pub dense: DenseOutput,
}

impl Segment {
    /// State `[q; q̇]` at `t` in the segment (its start state if it has no steps).
    pub fn eval(&self, t: f64, y: &mut [f64]) {
        if self.dense.is_empty() {
            y.copy_from_slice(&self.y0);
            return;
        }
        self.dense.eval(t, y);
    }
}

/// Why a Painlevé inconsistency was not resolved as a jam ([`crate::jam`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PainleveReason {
    /// The tangential impact into the contact's stick needs an impulse that pulls or leaves
    /// its friction cone — the sliding mode was still (barely) consistent, the approach to
    /// Painlevé's singular point where `W → 0` and the normal force grows without bound
    /// ("dynamic jam"): the rigid-body theory leaves it ambiguous.
    JamOutsideCone,
    /// The contact is at rest (a sticking contact at its cone's edge, or a slide from rest):
    /// sticking leaves its cone, sliding is inconsistent, and letting it go would draw it
    /// into the ground — Painlevé's inconsistent case from rest. The rigid-body theory's
    /// answer is an impact without collision *that slips* (a Coulomb impact, Darboux–Keller
    /// in the normal impulse, ending in a jump of the normal velocity), which the engine's
    /// frictionless impact law (Assumption 5.9) does not carry.
    AtRest,
    /// Complementarity has no or several outcomes for the jam (or for the forces after it),
    /// or the contact it lets go would be drawn into the ground.
    NoJamOutcome,
    /// The jam taken at this instant led straight back into the same inconsistency.
    Repeated,
    /// Met while a guard was evaluated inside a step (not at a state the run reached): not
    /// resolved, the step's work would be lost.
    InsideStep,
    /// The jam would have added kinetic energy (a failed solve; never a plastic impact's).
    EnergyGain,
    /// The contact is not active in the mode (no jam can act on it).
    Inactive,
}

impl PainleveReason {
    /// A short description, for status messages.
    pub fn describe(self) -> &'static str {
        match self {
            PainleveReason::JamOutsideCone => {
                "its jam (an impact without collision) would need an impulse that pulls or \
                 leaves its friction cone: the approach to Painlevé's singular point, which the \
                 rigid-body theory leaves ambiguous"
            }
            PainleveReason::NoJamOutcome => {
                "complementarity has no single consistent outcome for its jam"
            }
            PainleveReason::AtRest => {
                "it is at rest, its stick leaves the cone and its liftoff would draw it into the \
                 ground: an impact without collision that slips, which the frictionless impact \
                 law (Assumption 5.9) does not carry"
            }
            PainleveReason::Repeated => "its jam led straight back into the inconsistency",
            PainleveReason::InsideStep => "met inside an integration step",
            PainleveReason::EnergyGain => "its jam would have added kinetic energy",
            PainleveReason::Inactive => "the contact is not active",
        }
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
    /// A chattering execution ([`crate::zeno::ChatterDetector`]): the same cycle of
    /// `period` events ran `cycles` times in a row, over `duration_s` ending at `t`, while
    /// the configuration stayed where it was.
    Chatter {
        t: f64,
        period: usize,
        cycles: usize,
        duration_s: f64,
    },
    /// The run made [`crate::HybridOptions::max_events`] events.
    EventBudget,
    /// The run took [`crate::HybridOptions::max_steps`] accepted steps (`steps`), ending at
    /// `t`: a flow that crawls (step sizes collapsing) cannot hold a caller for long.
    StepBudget {
        t: f64,
        steps: usize,
    },
    /// The caller raised the stop flag ([`crate::simulate_with`]); the run ended at `t`.
    Interrupted {
        t: f64,
    },
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
    /// The flow of `mode` (or the mode a reset chose) is inconsistent with Coulomb friction
    /// at the sliding contact `contact` (Painlevé's paradox, `selfmanip_core::friction`):
    /// a pushing force would draw it into the ground, so the sliding mode has no solution or
    /// several; `t` is the start of the step that met it.
    ///
    /// Such an end is first resolved as a jam ([`crate::jam`]); `reason` says why that
    /// could not be done here.
    Painleve {
        t: f64,
        mode: ContactMode,
        contact: String,
        reason: PainleveReason,
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

/// The record of one execution (its first segment starts at the initial state).
#[derive(Debug, Clone)]
pub struct Execution {
    pub segments: Vec<Segment>,
    pub events: Vec<Event>,
    pub termination: Termination,
    pub t: f64,
    pub q: Vec<f64>,
    pub qd: Vec<f64>,
    pub mode: ContactMode,
    /// Accepted integration steps of the run (what [`crate::HybridOptions::max_steps`]
    /// bounds).
    pub steps: usize,
}

impl Execution {
    /// Kinetic energy lost in each impulsive event: touchdowns, folds and jams. Never
    /// negative for a plastic impact (a touchdown, an impulsive stick, a jam); a fold passage's entry, the leg's
    /// fast relaxation to its torque-free speed, may also gain energy from the joint torque
    /// that drives it ([`crate::fold`]).
    pub fn impact_losses(&self) -> Vec<f64> {
        self.events
            .iter()
            .filter(|e| {
                matches!(
                    e.kind,
                    EventKind::Touchdown | EventKind::Fold | EventKind::Jam
                )
            })
            .map(|e| e.kinetic_before - e.kinetic_after)
            .collect()
    }
}
