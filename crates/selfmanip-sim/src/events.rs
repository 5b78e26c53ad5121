//! The events of an execution in a robot's own names, as logs and tables show them, with
//! the contact forces after each event and the impulses of impacts in the one presentation
//! of contact forces (`docs/conventions.md`): per contact site in the description's order,
//! world NED `[x, z]`, the ground's action on the robot.
//!
//! ```text
//! event (q, q̇⁺, mode after, P_λ in the impact's rows)
//!   => the flow of the segment the run continued in (its controller, locked joints and
//!      sliding directions) at (t, q, q̇⁺) => λ => force_n per site (crate::trajectory)
//!   => P_λ along its rows' directions at q => impulse_n_s per site
//! ```
use crate::labels::ContactLabels;
use crate::trajectory::{site_points_and_forces, site_vectors};
use selfmanip_core::{ContactMode, CoreError, Model, Terrain};
use selfmanip_hybrid::flow::FlowWorkspace;
use selfmanip_hybrid::{Event, EventKind, Execution};
use serde::Serialize;

pub use crate::trajectory::SiteVectors;

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
    /// The impulse of the ground on the robot at each contact site in the event's plastic
    /// impact (N s, world NED `[x, z]`, description order): only for an impact (a
    /// touchdown, a fold that stops its slide, a jam, a Zeno truncation), `None` at every
    /// site otherwise and at the sites the impact does not hold. `Σ_k J_kᵀ p_k = M̄ (q̇⁺ − q̇⁻)`
    /// with `J_k` the world Jacobian of site `k`'s contact point.
    pub impulse_n_s: SiteVectors,
    /// The force of the ground on the robot at each contact site right after the event (N,
    /// world NED `[x, z]`, description order; a sliding site's includes its kinetic
    /// friction): that of the flow the run continued in, at the event's state; `None` at the
    /// sites out of contact after it (all of them in flight, and where that flow has no
    /// solution).
    pub force_n: SiteVectors,
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

/// The events of `exec` of `model` on `terrain` in the names of `labels`, times minus
/// `time_offset_s`.
pub fn event_records(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
    labels: &ContactLabels,
    time_offset_s: f64,
) -> Vec<EventRecord> {
    event_records_labelled(model, terrain, exec, &|m| labels.label(m), time_offset_s)
}

/// [`event_records`] with the modes labelled by `label` (a robot's own mode labels).
pub fn event_records_labelled(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
    label: &dyn Fn(ContactMode) -> String,
    time_offset_s: f64,
) -> Vec<EventRecord> {
    let mut ws = FlowWorkspace::new(model);
    exec.events
        .iter()
        .map(|e| {
            let (impulse_n_s, force_n) = event_vectors(model, terrain, exec, e, &mut ws);
            EventRecord {
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
                impulse_n_s,
                force_n,
            }
        })
        .collect()
}

/// The impulse and the force after event `e` of `exec` per contact site (see
/// [`EventRecord`]), evaluated on the workspace `ws`.
fn event_vectors(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
    e: &Event,
    ws: &mut FlowWorkspace,
) -> (SiteVectors, SiteVectors) {
    let nq = model.nq();
    let (q, qd) = (&e.q[..nq], &e.qd_after[..nq]);
    // the segment the run continued in from this event (its start, in its mode), else the
    // one the event ended, for the controller only (a run's last event, or one followed at
    // the same instant by another)
    let after = exec
        .segments
        .iter()
        .find(|s| s.t0 == e.t && s.mode == e.mode_after);
    let seg = after.or_else(|| exec.segments.iter().rev().find(|s| s.t0 <= e.t));
    ws.data.locked.clear();
    ws.data.slide_directions.clear();
    if let Some(s) = after {
        ws.data.locked.clone_from(&s.locked);
        ws.data.slide_directions.clone_from(&s.slide_directions);
    }
    let none = vec![None; model.n_contacts()];
    // the kinematics are complete even where the KKT matrix is singular (its factorization
    // is the last stage)
    let prepared = match seg {
        Some(s) => ws.prepare(model, terrain, &*s.controller, (e.t, e.mode_after), q, qd),
        None => ws.data.prepare(model, terrain, e.mode_after, q, qd),
    };
    let factored = match prepared {
        Ok(()) => true,
        Err(CoreError::SingularKkt { .. }) => false,
        Err(_) => return (none.clone(), none),
    };
    let impulse = site_vectors(model, terrain, &ws.data.kin, e.impulse_mode, &e.impulse);
    let solved = match seg {
        Some(s) if factored && !e.mode_after.is_flight() => ws
            .solve_prepared(model, &*s.controller, e.t, e.mode_after, q, qd)
            .is_ok(),
        _ => false,
    };
    let force = if solved {
        site_points_and_forces(model, terrain, &ws.data, e.mode_after).1
    } else {
        none
    };
    (impulse, force)
}
