//! A touchdown's guard and reset: `g` the contact's height (5.49), `R` the plastic impact
//! (5.10)/(5.52) into the mode the event took — or into a larger set whose extra contacts
//! force complementarity (5.19)–(5.20) released at once — whichever reproduces the recorded
//! `q̇⁺`, with its Jacobian from [`plastic_impact_jacobian`]; else the Coulomb impact among
//! the contacts held and those touching down ([`super::coulomb_impact`]). A jam fired by a
//! touchdown (a touchdown whose impact left a slide inconsistent, `crate::jam`) has the same
//! guard and its reset is one of the same impacts (the stick jam a plastic impact, the
//! Coulomb jam a Coulomb impact).
use super::coulomb_impact::coulomb_reset;
use super::reset_jacobian::{EventAt, GuardReset, NotDifferentiated};
use crate::event::{max_diff, Event};
use nalgebra::RowDVector;
use selfmanip_core::contact::{contact_geometry, ContactKind};
use selfmanip_core::model::Friction;
use selfmanip_core::tangent::{height_gradient, plastic_impact_jacobian};
use selfmanip_core::{ContactMode, Data, Model};

/// The touchdown's guard gradient `D_xg`; its impact's Jacobians, the state after it and the
/// impact's mode go into `gr`.
pub(super) fn touchdown(
    at: &EventAt,
    gr: &mut GuardReset,
) -> Result<RowDVector<f64>, NotDifferentiated> {
    let dg = height_row(at, at.event.triggered[0]);
    impact_reset(at, gr)?;
    Ok(dg)
}

/// A jam's guard gradient and reset: those of the touchdown that fired it (the first
/// contact it names that the mode before did not hold). A jam met by the flow — a slide's
/// Painlevé inconsistency at a segment's start or mid-flow, no touchdown — has no crossing
/// guard here and is not differentiated.
pub(super) fn jam(at: &EventAt, gr: &mut GuardReset) -> Result<RowDVector<f64>, NotDifferentiated> {
    let Some(k) = at
        .event
        .triggered
        .iter()
        .copied()
        .find(|&c| !at.before.mode.contains(c))
    else {
        return Err(NotDifferentiated(
            "a jam met by the flow (a slide inconsistent with Coulomb friction, no touchdown) \
             has no crossing guard: not differentiated"
                .into(),
        ));
    };
    let dg = height_row(at, k);
    impact_reset(at, gr)?;
    Ok(dg)
}

/// `D_xg` of contact `k`'s height (5.49) at the event.
fn height_row(at: &EventAt, k: usize) -> RowDVector<f64> {
    let model = at.model;
    let nq = model.nq();
    let geo = contact_geometry(model, &at.kin, at.terrain, k);
    let mut dg = RowDVector::zeros(2 * nq);
    dg.columns_mut(0, nq)
        .copy_from(&height_gradient(model, &at.kin, &geo).transpose());
    dg
}

/// The impact that reproduces the recorded `q̇⁺` — a plastic impact into one of
/// [`impact_candidates`], else the Coulomb impact — and its Jacobians, into `gr`.
fn impact_reset(at: &EventAt, gr: &mut GuardReset) -> Result<(), NotDifferentiated> {
    let (model, event) = (at.model, at.event);
    let (q, qd_minus) = (at.q(), at.qd_minus());
    let candidates = impact_candidates(model, at.before.mode, event);
    let mut data = Data::new(model);
    let scale = 1.0 + event.qd_after.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mut found = None;
    let mut worst = f64::INFINITY;
    for m in candidates {
        let Ok(ij) = plastic_impact_jacobian(model, &mut data, at.terrain, m, q, qd_minus) else {
            continue;
        };
        let mismatch = max_diff(ij.impact.qd_plus.as_slice(), &event.qd_after);
        worst = worst.min(mismatch);
        if mismatch <= 1e-9 * scale {
            found = Some((m, ij));
            break;
        }
    }
    let Some((m, ij)) = found else {
        return coulomb_reset(at, gr, 1e-9 * scale).map_err(|NotDifferentiated(why)| {
            NotDifferentiated(format!(
                "q̇⁺ is not a plastic impact into the mode after or a superset \
                 ({worst:.2e}), {why}"
            ))
        });
    };
    gr.impact_mode = Some(m);
    // data holds the factorization of the impact just found
    gr.plastic_impact(at, &mut data, &ij, ij.impact.qd_plus.as_slice());
    Ok(())
}

/// The modes a touchdown's impact may have gone into, in the order they are tried: the mode
/// after, or a larger set whose extra contacts the force complementarity then released
/// (5.19)–(5.20).
fn impact_candidates(model: &Model, before: ContactMode, event: &Event) -> Vec<ContactMode> {
    let released: Vec<usize> = before
        .active()
        .filter(|&c| !event.mode_after.contains(c))
        .collect();
    let mut candidates = vec![event.mode_after];
    for kind in [None, Some(ContactKind::Slide)] {
        let mut m = event.mode_after;
        for &c in &released {
            let kc = kind.or(before.kind(c)).expect("active contact");
            m = m.with(c, kc);
        }
        if !candidates.contains(&m) {
            candidates.push(m);
        }
    }
    // … or into one that also holds the contact that touched down, released at once by
    // the forces (a body end that bounces off: its impulse stops it, its force pulls)
    let n0 = candidates.len();
    for i in 0..n0 {
        for &k in &event.triggered {
            if candidates[i].contains(k) {
                continue;
            }
            for kind in [ContactKind::Slide, ContactKind::Stick] {
                if kind == ContactKind::Stick
                    && !matches!(model.contacts[k].friction, Friction::Sticking { .. })
                {
                    continue;
                }
                let m = candidates[i].with(k, kind);
                if !candidates.contains(&m) {
                    candidates.push(m);
                }
            }
        }
    }
    // … or into a set in which a contact that slides after the event stuck for the
    // impact: the impact's sticking force outside the cone, the contact slides on
    // from the velocity the impact left it (crate::reset: the kept contacts must
    // also hold in force)
    let n0 = candidates.len();
    for i in 0..n0 {
        let base = candidates[i];
        let sliding: Vec<usize> = base
            .active()
            .filter(|&c| {
                base.kind(c) == Some(ContactKind::Slide)
                    && matches!(model.contacts[c].friction, Friction::Sticking { .. })
            })
            .collect();
        for &c in &sliding {
            let m = base.with(c, ContactKind::Stick);
            if !candidates.contains(&m) {
                candidates.push(m);
            }
        }
        let all = sliding
            .iter()
            .fold(base, |m, &c| m.with(c, ContactKind::Stick));
        if !candidates.contains(&all) {
            candidates.push(all);
        }
    }
    candidates
}
