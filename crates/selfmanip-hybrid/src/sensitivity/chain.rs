//! How an execution's events chain its segments' tangents: the event that ended a segment,
//! whether the chain reaches the run's end, and whether the controllers' memory couples it.
use super::types::{SaltationStatus, TouchSwitch};
use crate::event::{Event, EventKind};
use crate::execution::{Execution, Termination};

/// The walk along an execution's segments: how many of its events the segments have
/// matched, and whether the chain of their tangents is still defined.
pub(super) struct EventChain {
    pub(super) next_event: usize,
    pub(super) defined: bool,
}

impl EventChain {
    pub(super) fn new() -> Self {
        EventChain {
            next_event: 0,
            defined: true,
        }
    }

    /// The event that ended segment `si`, if it is the next one not matched yet (then
    /// matched): a segment ends on an event unless it ended on a terrain feature change
    /// (then recorded in `feature_changes`, and the chain is not defined); the last one only
    /// on the apex or when the event budget ran out.
    pub(super) fn ending<'e>(
        &mut self,
        exec: &'e Execution,
        si: usize,
        feature_changes: &mut Vec<usize>,
    ) -> Option<&'e Event> {
        let seg = &exec.segments[si];
        let last = si + 1 == exec.segments.len();
        let event = exec.events.get(self.next_event).filter(|e| {
            e.t == seg.t1
                && (!last
                    || e.kind == EventKind::Apex
                    || exec.termination == Termination::EventBudget)
        });
        match event {
            Some(_) => self.next_event += 1,
            // a truncation's dwell that ended by its length and kept its contacts: a time
            // event with no event recorded (super::truncation)
            None if !last && exec.dwell_ends.contains(&seg.t1) => {}
            None if !last => {
                feature_changes.push(si);
                self.defined = false;
            }
            None => {}
        }
        event
    }

    /// The Zeno truncation taken at once after `event` (the event just matched, at the same
    /// instant, with no segment between them), if any (then matched): the two are
    /// differentiated as one event ([`super::truncation`]).
    pub(super) fn truncation<'e>(
        &mut self,
        exec: &'e Execution,
        event: &Event,
    ) -> Option<&'e Event> {
        let next = exec
            .events
            .get(self.next_event)
            .filter(|e| e.kind == EventKind::ZenoTruncation && e.t == event.t)?;
        self.next_event += 1;
        Some(next)
    }
}

/// Whether any segment's controller remembers events' times or states
/// ([`Controller::has_event_memory`]).
pub(super) fn has_event_memory(exec: &Execution) -> bool {
    exec.segments
        .iter()
        .any(|s| s.controller.has_event_memory())
}

/// Whether the chain of an execution's derivative reaches its end: every event was matched
/// to a segment end, every rolling/point switch inside a segment was differentiated, and the
/// run ended at its final time or at the apex (a run cut by a budget ends on an event with
/// no flow after it).
pub(super) fn chain_complete(
    exec: &Execution,
    next_event: usize,
    touch_switches: &[TouchSwitch],
) -> bool {
    next_event == exec.events.len()
        && touch_switches
            .iter()
            .all(|s| s.status == SaltationStatus::Defined)
        && matches!(exec.termination, Termination::FinalTime | Termination::Apex)
}
