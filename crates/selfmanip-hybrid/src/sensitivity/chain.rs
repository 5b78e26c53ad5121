//! How an execution's events chain its segments' tangents: the event that ended a segment,
//! whether the chain reaches the run's end, and whether the controllers' memory couples it.
use super::types::{SaltationStatus, TouchSwitch};
use crate::event::{Event, EventKind};
use crate::execution::{Execution, Termination};

/// The event that ended segment `si`, if it is the next one not matched yet (`next_event`):
/// a segment ends on an event unless it ended on a terrain feature change; the last one only
/// on the apex or when the event budget ran out.
pub(super) fn event_ending(exec: &Execution, si: usize, next_event: usize) -> Option<&Event> {
    let seg = &exec.segments[si];
    let last = si + 1 == exec.segments.len();
    exec.events.get(next_event).filter(|e| {
        e.t == seg.t1
            && (!last || e.kind == EventKind::Apex || exec.termination == Termination::EventBudget)
    })
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
