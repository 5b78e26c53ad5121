//! The events of an execution in a robot's own names, as logs and tables show them.
use crate::labels::ContactLabels;
use selfmanip_core::{ContactMode, Model};
use selfmanip_hybrid::{EventKind, Execution};
use serde::Serialize;

/// A record of one event in the robot's own names.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EventRecord {
    pub t_s: f64,
    /// `touchdown`, `liftoff`, `slip`, `stick`, `fold` (a leg reached the pose where its
    /// contact stops pinning it: an impulsive stick, a release, or the start of its passage
    /// through that pose), `fold_passed` (the passage's end), `jam` (a Painlevé slide stopped
    /// by an impact without collision, `selfmanip_hybrid::jam`), `zeno_truncation` (a Zeno
    /// execution truncated, `selfmanip_hybrid::zeno`) or `apex`
    /// ([`EventKind::name`]).
    pub kind: &'static str,
    pub mode_before: String,
    pub mode_after: String,
    /// Contacts that fired the guard.
    pub contacts: Vec<String>,
    /// Kinetic energy lost in the event (J): `T⁻ − T⁺` for the impulsive events
    /// ([`EventKind::is_impulsive`], those of [`Execution::impact_losses`]), zero for the others; round-off,
    /// within [`ENERGY_ROUND_OFF`] `· (T⁻ + 1 J)`, reported as zero. Never negative for a
    /// touchdown; a `fold` that starts a passage may gain energy from a motor.
    pub energy_loss_j: f64,
    /// Contact impulse into `mode_after` (N s, rows of `mode_after`).
    pub impulse: Vec<f64>,
}

/// Round-off of a kinetic energy evaluated twice (`½ q̇ᵀ M̄ q̇` at the two velocities of one
/// projection), relative to the energy, and its floor (J): an event's loss within
/// `ENERGY_ROUND_OFF · (T⁻ + 1 J)` is reported as zero.
pub const ENERGY_ROUND_OFF: f64 = 1e-12;

/// The kinetic energy an event lost, `T⁻ − T⁺`, with round-off ([`ENERGY_ROUND_OFF`])
/// reported as zero: a zero-speed touchdown loses nothing, and its computed loss is a few
/// 1e-13 J of either sign.
pub fn energy_loss(before: f64, after: f64) -> f64 {
    let loss = before - after;
    if loss.abs() <= ENERGY_ROUND_OFF * (before.abs() + 1.0) {
        0.0
    } else {
        loss
    }
}

/// The events of `exec` in the names of `model` and `labels`, times minus `time_offset_s`.
pub fn event_records(
    model: &Model,
    exec: &Execution,
    labels: &ContactLabels,
    time_offset_s: f64,
) -> Vec<EventRecord> {
    event_records_labelled(model, exec, &|m| labels.label(m), time_offset_s)
}

/// [`event_records`] with the modes labelled by `label` (a robot's own mode labels).
pub fn event_records_labelled(
    model: &Model,
    exec: &Execution,
    label: &dyn Fn(ContactMode) -> String,
    time_offset_s: f64,
) -> Vec<EventRecord> {
    exec.events
        .iter()
        .map(|e| EventRecord {
            t_s: e.t - time_offset_s,
            kind: e.kind.name(),
            mode_before: label(e.mode_before),
            mode_after: label(e.mode_after),
            contacts: e
                .triggered
                .iter()
                .map(|&k| model.contacts[k].name.clone())
                .collect(),
            energy_loss_j: if EventKind::is_impulsive(e.kind) {
                energy_loss(e.kinetic_before, e.kinetic_after)
            } else {
                0.0
            },
            impulse: e.impulse.clone(),
        })
        .collect()
}
