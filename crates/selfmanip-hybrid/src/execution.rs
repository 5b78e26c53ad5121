//! The record of an execution of the hybrid system (thesis Definition 5.2): the segments of
//! flow with their dense output, the events (resets) between them, and why the run ended.
use crate::controller::Controller;
use crate::event::{Event, PainleveReason};
use crate::integrate::DenseOutput;
use selfmanip_core::{ContactMode, SingularityKind};
use std::sync::Arc;

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

/// Why an execution ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Termination {
    FinalTime,
    Apex,
    /// More than the allowed number of events in the Zeno window; `contacts` are the
    /// contacts that triggered them.
    Zeno {
        t: f64,
        events_in_window: usize,
        contacts: Vec<usize>,
    },
    /// A chattering execution ([`crate::zeno::ChatterDetector`]): the same cycle of
    /// `period` events ran `cycles` times in a row, over `duration_s` ending at `t`, while
    /// the configuration stayed where it was; `contacts` are the contacts that triggered the
    /// cycle's events. The end only when the chatter has nothing to truncate: otherwise the
    /// run goes on truncated, as after a Zeno window ([`crate::zeno`]).
    Chatter {
        t: f64,
        period: usize,
        cycles: usize,
        duration_s: f64,
        contacts: Vec<usize>,
    },
    /// The run made [`crate::HybridOptions::max_events`] events.
    EventBudget,
    /// The run took [`crate::HybridOptions::max_steps`] accepted steps (`steps`), ending at
    /// `t`: a flow that crawls (step sizes collapsing) cannot hold a caller for long.
    StepBudget {
        t: f64,
        steps: usize,
    },
    /// The integrator's step size fell below its floor (`h_s`, s) at `t`: the flow stalls
    /// there (a mode whose accelerations grow without bound, e.g. a massless foot held in a
    /// slide). The run ends typed rather than crawling on.
    StepTooSmall {
        t: f64,
        h_s: f64,
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
    /// A collision outline of the description (`outline`, named where it is declared, e.g.
    /// `body.collision[0]`) is inside the terrain by `depth_m` at `t` — an event or the run's
    /// end — deeper than the drift the engine corrects
    /// ([`crate::surface_tolerances::MAX_DRIFT_M`]): a penetration the engine did not
    /// resolve ([`selfmanip_core::contact::outline_penetration`]).
    Penetration {
        t: f64,
        outline: String,
        depth_m: f64,
    },
}

/// `", triggered by contacts `a`, `b`"` for the contacts of a Zeno or chatter report (nothing
/// when there are none: feature passages alone).
fn involving(contacts: &[usize], name: &dyn Fn(usize) -> String) -> String {
    if contacts.is_empty() {
        return String::new();
    }
    let names: Vec<String> = contacts.iter().map(|&k| format!("`{}`", name(k))).collect();
    format!(", triggered by contacts {}", names.join(", "))
}

impl Termination {
    /// How a run ended, in words, for status messages: `at(t)` writes an instant of the run
    /// (e.g. on the caller's own clock), `contact(k)` names contact `k`, and `mode` labels
    /// the mode that was flowing (e.g. with its sliding contacts marked); without it, the
    /// mode a termination carries is written by its normal bits, and none where it carries
    /// none.
    pub fn describe(
        &self,
        at: &dyn Fn(f64) -> String,
        contact: &dyn Fn(usize) -> String,
        mode: Option<&str>,
    ) -> String {
        let own =
            |m: &ContactMode| mode.map_or_else(|| format!("{:b}", m.normal_bits()), Into::into);
        let flowing = mode.map_or_else(String::new, |m| format!(" (mode {m})"));
        match self {
            Termination::FinalTime => "the run reached its final time".into(),
            Termination::Apex => "the run reached its apex".into(),
            Termination::Zeno {
                t,
                events_in_window,
                contacts,
            } => format!(
                "Zeno: {events_in_window} events within the Zeno window (zeno_window_s) at {}{}",
                at(*t),
                involving(contacts, contact)
            ),
            Termination::Chatter {
                t,
                period,
                cycles,
                duration_s,
                contacts,
            } => format!(
                "chatter (a generalized Zeno execution): the same cycle of {period} events ran \
                 {cycles} times over {duration_s:.6} s with the robot staying where it was, \
                 ending at {}{}",
                at(*t),
                involving(contacts, contact)
            ),
            Termination::EventBudget => {
                "the execution used up its event budget (max_events)".into()
            }
            Termination::StepBudget { t, steps } => format!(
                "the execution used up its step budget (max_steps: {steps} accepted steps) at {}",
                at(*t)
            ),
            Termination::StepTooSmall { t, h_s } => format!(
                "the flow stalled: the step size fell to {h_s:.3e} s at {}",
                at(*t)
            ),
            Termination::Interrupted { t } => format!("interrupted at {}", at(*t)),
            Termination::NoContactSolution { t } => format!(
                "no contact set satisfies the complementarity conditions at {}{flowing}",
                at(*t)
            ),
            Termination::SeveralContactSolutions { t, candidates } => format!(
                "{} contact sets satisfy the complementarity conditions at {}{flowing}",
                candidates.len(),
                at(*t)
            ),
            Termination::SingularFlow {
                t,
                mode: m,
                kind,
                condition_estimate,
            } => format!(
                "the KKT matrix of mode {} became singular (Lemma 5.1: {}; condition \
                 estimate {condition_estimate:.3e}) at {}",
                own(m),
                match kind {
                    SingularityKind::RedundantConstraints => "redundant constraints",
                    SingularityKind::UnconstrainedMasslessMotion => {
                        "a massless motion no contact pins down"
                    }
                },
                at(*t)
            ),
            Termination::Painleve {
                t,
                mode: m,
                contact: name,
                reason,
            } => format!(
                "the sliding contact `{name}` is inconsistent with Coulomb friction in or after \
                 mode {} (Painlevé's paradox: a pushing force would draw it into the ground) \
                 at {}; not resolved as a jam: {}",
                own(m),
                at(*t),
                reason.describe()
            ),
            Termination::TerrainDiscontinuity {
                t,
                contact: k,
                gap_m,
            } => format!(
                "contact `{}` met a terrain edge or corner that is not a contact feature for it \
                 at {} (gap {gap_m:.3e} m)",
                contact(*k),
                at(*t)
            ),
            Termination::Penetration {
                t,
                outline,
                depth_m,
            } => format!(
                "the collision outline `{outline}` is {depth_m:.3e} m inside the terrain at {}, \
                 a penetration the engine did not resolve",
                at(*t)
            ),
        }
    }
}

/// [`Termination::describe`] on the run's own clock, contacts by number.
impl std::fmt::Display for Termination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let text = self.describe(&|t| format!("t = {t} s"), &|k| format!("#{k}"), None);
        f.write_str(&text)
    }
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
    /// The times at which a Zeno truncation's dwell ended by its length ([`crate::zeno`],
    /// `dwell_end`): each ends a segment, with the event of the force complementarity that
    /// judged the held contacts there, or none when it kept them all. The latest truncation
    /// before each sets it: it moves with that truncation's time (the sensitivities).
    pub dwell_ends: Vec<f64>,
}

impl Execution {
    /// Kinetic energy lost in each impulsive event ([`crate::EventKind::is_impulsive`]). Never
    /// negative for a plastic impact (a touchdown, an impulsive stick, a jam); a fold passage's entry, the leg's
    /// fast relaxation to its torque-free speed, may also gain energy from the joint torque
    /// that drives it ([`crate::fold`]).
    pub fn impact_losses(&self) -> Vec<f64> {
        self.events
            .iter()
            .filter(|e| e.kind.is_impulsive())
            .map(|e| e.kinetic_before - e.kinetic_after)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every way a run ends reads as words with its own numbers in it — the instant, the
    /// counts, the contact's name — never as the enum's debug form (`StepBudget { t: … }`
    /// reached users of the leap and of `periodic_orbit`).
    #[test]
    fn every_termination_is_described_in_words_with_its_numbers() {
        let mode = ContactMode::FLIGHT.with(1, selfmanip_core::ContactKind::Slide);
        let cases = [
            (Termination::FinalTime, vec!["final time"]),
            (Termination::Apex, vec!["apex"]),
            (
                Termination::Zeno {
                    t: 0.25,
                    events_in_window: 41,
                    contacts: vec![3],
                },
                vec!["41 events", "t = 0.25 s", "contacts `#3`"],
            ),
            (
                Termination::Chatter {
                    t: 0.5,
                    period: 2,
                    cycles: 7,
                    duration_s: 0.001,
                    contacts: vec![0, 3],
                },
                vec!["2 events", "7 times", "t = 0.5 s", "contacts `#0`, `#3`"],
            ),
            (Termination::EventBudget, vec!["event budget"]),
            (
                Termination::StepBudget {
                    t: 0.75,
                    steps: 300,
                },
                vec!["300", "t = 0.75 s"],
            ),
            (
                Termination::StepTooSmall {
                    t: 0.625,
                    h_s: 1e-14,
                },
                vec!["stalled", "1.000e-14 s", "t = 0.625 s"],
            ),
            (
                Termination::Interrupted { t: 1.5 },
                vec!["interrupted", "t = 1.5 s"],
            ),
            (
                Termination::NoContactSolution { t: 0.125 },
                vec!["no contact set", "t = 0.125 s"],
            ),
            (
                Termination::SeveralContactSolutions {
                    t: 2.0,
                    candidates: vec![mode, mode],
                },
                vec!["2 contact sets", "t = 2 s"],
            ),
            (
                Termination::SingularFlow {
                    t: 3.0,
                    mode,
                    kind: SingularityKind::UnconstrainedMasslessMotion,
                    condition_estimate: 1e17,
                },
                vec!["mode 10 ", "massless", "1.000e17", "t = 3 s"],
            ),
            (
                Termination::Painleve {
                    t: 4.0,
                    mode,
                    contact: "toe".into(),
                    reason: PainleveReason::AtRest,
                },
                vec!["`toe`", "mode 10 ", "t = 4 s"],
            ),
            (
                Termination::TerrainDiscontinuity {
                    t: 5.0,
                    contact: 3,
                    gap_m: -0.01,
                },
                vec!["`#3`", "-1.000e-2 m", "t = 5 s"],
            ),
            (
                Termination::Penetration {
                    t: 6.0,
                    outline: "body.collision[0]".into(),
                    depth_m: 0.27,
                },
                vec!["`body.collision[0]`", "2.700e-1 m", "t = 6 s"],
            ),
        ];
        for (term, parts) in cases {
            let text = term.to_string();
            assert!(!text.contains('{') && !text.contains("::"), "{text}");
            for p in parts {
                assert!(text.contains(p), "`{p}` not in: {text}");
            }
        }
        // a caller's clock, names and mode label
        let t = Termination::TerrainDiscontinuity {
            t: 5.0,
            contact: 3,
            gap_m: -0.01,
        };
        let text = t.describe(
            &|t| format!("{:.1} s in", t - 1.0),
            &|_| "front_leg".into(),
            Some("0s01"),
        );
        assert!(
            text.contains("`front_leg`") && text.contains("4.0 s in"),
            "{text}"
        );
        let t = Termination::NoContactSolution { t: 0.0 };
        assert!(t
            .describe(&|_| "now".into(), &|_| String::new(), Some("0s01"))
            .contains("(mode 0s01)"));
    }
}
