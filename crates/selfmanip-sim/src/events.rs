//! The events of an execution in a robot's own names, as logs and tables show them.
use crate::labels::ContactLabels;
use selfmanip_core::Model;
use selfmanip_hybrid::{EventKind, Execution};
use serde::Serialize;

/// A record of one event in the robot's own names.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EventRecord {
    pub t_s: f64,
    /// `touchdown`, `liftoff`, `slip`, `stick` or `apex`.
    pub kind: &'static str,
    pub mode_before: String,
    pub mode_after: String,
    /// Contacts that fired the guard.
    pub contacts: Vec<String>,
    /// Kinetic energy lost (J; zero but for touchdowns).
    pub energy_loss_j: f64,
    /// Contact impulse into `mode_after` (N s, rows of `mode_after`).
    pub impulse: Vec<f64>,
}

/// The events of `exec` in the names of `model` and `labels`, times minus `time_offset_s`.
pub fn event_records(
    model: &Model,
    exec: &Execution,
    labels: &ContactLabels,
    time_offset_s: f64,
) -> Vec<EventRecord> {
    exec.events
        .iter()
        .map(|e| EventRecord {
            t_s: e.t - time_offset_s,
            kind: e.kind.name(),
            mode_before: labels.label(e.mode_before),
            mode_after: labels.label(e.mode_after),
            contacts: e
                .triggered
                .iter()
                .map(|&k| model.contacts[k].name.clone())
                .collect(),
            energy_loss_j: if e.kind == EventKind::Touchdown {
                e.kinetic_before - e.kinetic_after
            } else {
                0.0
            },
            impulse: e.impulse.clone(),
        })
        .collect()
}
