//! The reset at an event (thesis Definition 5.2): from the guards that fired, the mode and
//! velocity the execution continues with.
//!
//! ```text
//! fired guards      => touched, released, slipped, stuck contacts
//! touched           => a plastic impact: complementarity on impulses (5.28)–(5.29), (5.40)
//!                      => q̇⁺ (5.52) => the kept contacts must also hold in force (5.19)–(5.20)
//! otherwise         => complementarity on forces (5.19)–(5.20), no velocity jump
//! ```
//!
//! Contacts that reached their friction cone slide, contacts whose sliding stopped try to
//! stick; a touchdown whose contact is already found below its ground met a step of the
//! terrain.
use crate::complementarity::Selected;
use crate::contact_set::ResetWorkspace;
use crate::energy::kinetic_energy_at;
use crate::error::HybridError;
use crate::execution::{Event, EventKind, Termination};
use crate::features::TERRAIN_STEP_M;
use crate::flow::{Flow, FlowWorkspace};
use crate::guard::Guard;
use selfmanip_core::contact::ContactKind;
use selfmanip_core::{plastic_impact, ContactMode};

/// What a reset leads to.
#[derive(Debug, Clone, PartialEq)]
pub enum Reset {
    /// The run goes on in `event.mode_after` from `event.qd_after`; `from_rest` are the
    /// sliding contacts whose sliding velocity starts from zero (up to drift).
    Continue { event: Event, from_rest: Vec<usize> },
    /// The run ends here, with the event that ended it (the apex) if any.
    End {
        event: Option<Event>,
        termination: Termination,
    },
}

/// The reset of the guards `fired` at `(t, y = [q; q̇])` in `mode` of `flow`, evaluated on
/// the workspace `ws`, with the pseudo-impulse duration `delta_t_s`.
pub fn reset(
    ws: &mut FlowWorkspace,
    flow: &mut Flow,
    delta_t_s: f64,
    fired: &[Guard],
    mode: ContactMode,
    (t, y): (f64, &[f64]),
) -> Result<Reset, HybridError> {
    let model = flow.model();
    let (q, qd) = y.split_at(model.nq());
    if fired.contains(&Guard::Apex) {
        let event = Event {
            t,
            kind: EventKind::Apex,
            mode_before: mode,
            mode_after: mode,
            triggered: vec![],
            impulse: vec![],
            pseudo_impulse: vec![],
            kinetic_before: f64::NAN,
            kinetic_after: f64::NAN,
            q: q.to_vec(),
            qd_after: qd.to_vec(),
        };
        return Ok(Reset::End {
            event: Some(event),
            termination: Termination::Apex,
        });
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
    let end = |termination| {
        Ok(Reset::End {
            event: None,
            termination,
        })
    };
    // a contact whose height jumped through zero met a step of the terrain
    for &k in &touched {
        let gap = flow.geometry(k, y).gap_m;
        if gap < -TERRAIN_STEP_M {
            return end(Termination::TerrainDiscontinuity {
                t,
                contact: k,
                gap_m: gap,
            });
        }
    }
    let ctrl = flow.controller().clone();
    let cx = &mut ResetWorkspace {
        model,
        terrain: flow.terrain(),
        ctrl: &*ctrl,
        delta_t_s,
        ws,
    };
    let ke_before = kinetic_energy_at(model, cx.terrain, &mut cx.ws.data, q, qd)?;
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
    let Selected {
        mode: new_mode,
        value: impulse,
        pseudo_impulse,
    } = match cx.select(t, &candidates, &released, prefer, q, qd, impact)? {
        Ok(s) => s,
        Err(term) => return end(term),
    };
    // q̇⁺ of the impact into the selected mode (5.52)
    let mut qd_after = qd.to_vec();
    if impact {
        let imp = plastic_impact(model, &mut cx.ws.data, cx.terrain, new_mode, q, qd)?;
        qd_after.copy_from_slice(imp.qd_plus.as_slice());
    }
    // contacts kept by the impact must also hold in force (5.19)–(5.20)
    let mut mode_after = new_mode;
    if impact && !mode_after.is_flight() {
        let kept: Vec<usize> = mode_after.active().collect();
        match cx.select(t, &kept, &[], mode_after, q, &qd_after, false)? {
            Ok(s) => mode_after = s.mode,
            Err(term) => return end(term),
        }
    }
    let ke_after = kinetic_energy_at(model, cx.terrain, &mut cx.ws.data, q, &qd_after)?;
    // without a velocity jump, a contact that stuck until now starts sliding from rest;
    // so does one whose stick the cone refused (its velocity just crossed zero)
    let from_rest = mode_after
        .active()
        .filter(|&k| {
            mode_after.kind(k) == Some(ContactKind::Slide)
                && (stuck.contains(&k) || (!impact && mode.kind(k) == Some(ContactKind::Stick)))
        })
        .collect();
    let (kind, triggered) = if impact {
        (EventKind::Touchdown, touched)
    } else if !released.is_empty() {
        (EventKind::Liftoff, released)
    } else if !slipped.is_empty() {
        (EventKind::Slip, slipped)
    } else {
        (EventKind::Stick, stuck)
    };
    Ok(Reset::Continue {
        event: Event {
            t,
            kind,
            mode_before: mode,
            mode_after,
            triggered,
            impulse,
            pseudo_impulse,
            kinetic_before: ke_before,
            kinetic_after: ke_after,
            q: q.to_vec(),
            qd_after,
        },
        from_rest,
    })
}
