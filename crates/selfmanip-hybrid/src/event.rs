//! The events of an execution (thesis Definition 5.2): what kind of guard fired, the reset
//! it made, and why a Painlevé inconsistency was not resolved as a jam. Below the
//! controllers, which may remember events ([`crate::controller::Controller::on_event`]).
use selfmanip_core::ContactMode;

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
    /// A Zeno execution truncated ([`crate::zeno::truncate`]): the plastic impact into every
    /// contact of the Zeno window on its surface, and the mode force complementarity keeps of
    /// them — the limit of the pseudo-impulse (5.39)–(5.40) at the accumulation.
    ZenoTruncation,
}

impl EventKind {
    /// The kind's name in tables, records and messages (`touchdown`, `fold_passed`, …).
    pub fn name(self) -> &'static str {
        match self {
            EventKind::Touchdown => "touchdown",
            EventKind::Liftoff => "liftoff",
            EventKind::Slip => "slip",
            EventKind::Stick => "stick",
            EventKind::Apex => "apex",
            EventKind::Fold => "fold",
            EventKind::FoldPassed => "fold_passed",
            EventKind::Jam => "jam",
            EventKind::ZenoTruncation => "zeno_truncation",
        }
    }

    /// Whether the event is a plastic impact that may lose kinetic energy (a touchdown, a
    /// fold, a jam, a Zeno truncation): the events of [`crate::Execution::impact_losses`].
    pub fn is_impulsive(self) -> bool {
        matches!(
            self,
            EventKind::Touchdown | EventKind::Fold | EventKind::Jam | EventKind::ZenoTruncation
        )
    }
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
    /// Contact impulse `P_λ` of the event's plastic impact (N s, rows of `impulse_mode`;
    /// ground on robot, the sign of `λ`): only for an impact ([`EventKind::is_impulsive`]: a
    /// touchdown, a fold that stops its slide, a jam, a Zeno truncation), empty otherwise.
    pub impulse: Vec<f64>,
    /// The mode of the impact's rows (`impulse`, `pseudo_impulse`): the mode the plastic
    /// impact went into, which is `mode_after` unless the kept contacts' forces then released
    /// one or let it slide (a Coulomb jam's, [`crate::jam::coulomb_jam`], has each of its
    /// contacts sticking: a slipping contact's friction impulse has a row there);
    /// [`ContactMode::FLIGHT`] without an impact.
    pub impulse_mode: ContactMode,
    /// Pseudo-impulse `P_δ` (5.39)–(5.40) (N s, rows of `impulse_mode`; empty when δt = 0).
    pub pseudo_impulse: Vec<f64>,
    /// Contact force `λ` right after the reset (N, rows of `mode_after`, the sign of `λ`; a
    /// sliding contact's one row is its normal force, its friction `μ_k` of it against the
    /// slide); empty in flight and where the reset solves no forces (an apex, a fold's
    /// passage or its end).
    pub force: Vec<f64>,
    pub kinetic_before: f64,
    pub kinetic_after: f64,
    /// Configuration at the event.
    pub q: Vec<f64>,
    /// Velocity after the reset (before it for liftoff, slip, stick and apex: no jump).
    pub qd_after: Vec<f64>,
}

impl Event {
    /// An event that changes neither the contact mode nor the velocity (a fold passed, an
    /// apex): no impulses, and no kinetic energies (NaN) since nothing is lost.
    pub fn without_jump(
        t: f64,
        kind: EventKind,
        mode: ContactMode,
        triggered: Vec<usize>,
        (q, qd): (&[f64], &[f64]),
    ) -> Self {
        Event {
            t,
            kind,
            mode_before: mode,
            mode_after: mode,
            triggered,
            impulse: vec![],
            impulse_mode: ContactMode::FLIGHT,
            pseudo_impulse: vec![],
            force: vec![],
            kinetic_before: f64::NAN,
            kinetic_after: f64::NAN,
            q: q.to_vec(),
            qd_after: qd.to_vec(),
        }
    }
}

impl Event {
    /// Whether the event is a transition of Definition 5.2 between distinct modes: its mode
    /// changes, or it is a **re-touch** — an impact that kept a contact (`impulse_mode`) which
    /// force complementarity then let go at once (`mode_after`), two transitions (into the
    /// impact's mode and out of it) in one event that leaves the mode as it was: a leg whose
    /// own law lifts its foot off the ground after its impact and puts it back (thesis
    /// Fig. 5.7). Not an apex, a fold passed, or a touchdown whose impact kept nothing new.
    pub fn makes_transitions(&self) -> bool {
        self.mode_before != self.mode_after
            || (self.kind.is_impulsive()
                && self
                    .impulse_mode
                    .active()
                    .any(|k| !self.mode_after.contains(k)))
    }

    /// Whether the event is a **re-touch**: it leaves the mode as it was and makes
    /// transitions ([`Self::makes_transitions`]) — an impact that kept a contact which force
    /// complementarity let go at once.
    pub fn is_retouch(&self) -> bool {
        self.mode_before == self.mode_after && self.makes_transitions()
    }

    /// Whether the event changes no contact mode and carries no impulse: a touchdown whose
    /// contact complementarity let go at once, its impulse zero (`|P_λ| ≤`
    /// [`IMPULSE_TOL_N_S`]: a massless chain's foot, whose stop needs none, thesis 5.1.3 —
    /// the chain's own rates may jump, at no cost in energy), or a liftoff that kept every
    /// contact. Such a reset is no transition of Definition 5.2 (its edges join distinct
    /// modes): the run does not report it, and it still counts in the Zeno window. A
    /// touchdown that leaves the mode as it was but carries an impulse is reported, and so
    /// are a stick the cone refused and a slip it held (the sliding direction, which the mode
    /// does not name, turns), an apex, a fold or its passage's end, a jam and a truncation.
    pub fn changes_nothing(&self) -> bool {
        let same = self.mode_before == self.mode_after;
        match self.kind {
            EventKind::Touchdown => same && self.impulse.iter().all(|p| p.abs() <= IMPULSE_TOL_N_S),
            EventKind::Liftoff => same,
            _ => false,
        }
    }
}

/// An impulse this small (N s) is none: no verdict of its own at an impact (the
/// pseudo-impulse decides (5.40), `crate::contact_set`), and a touchdown carrying no larger
/// one changes nothing ([`Event::changes_nothing`]).
pub const IMPULSE_TOL_N_S: f64 = 1e-12;

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

/// `max |a − b|` over the components of two states, e.g. an event's `q` or `q̇⁺` against
/// another's or against a reset's.
pub(crate) fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}
