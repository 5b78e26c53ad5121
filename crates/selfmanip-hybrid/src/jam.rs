//! A Painlevé end resolved as the rigid-body theory resolves it: a **jam** — an impact
//! without collision, or tangential impact (Génot & Brogliato 1999, "New results on Painlevé
//! paradoxes"; Stewart 2000, "Rigid-body dynamics with friction and impact", section 5;
//! Nordmark, Dankowicz & Champneys' "dynamic jamming").
//!
//! ```text
//! a sliding contact k whose slide has no consistent continuation   (selfmanip_core::friction,
//!   (the flow's Painlevé check, at a segment's start or mid-flow)    CoreError::PainleveInconsistent)
//!     => plastic impact into the mode with k sticking, both rows (5.10)/(5.52):
//!        P = −(A M̄⁻¹ Aᵀ)⁻¹ A q̇⁻,  q̇⁺ = q̇⁻ + M̄⁻¹ Aᵀ P
//!     => accepted when P lies in k's cone and pushes, |P_t| ≤ μ U(P_n);
//!        else complementarity over the active contacts (k may stick or leave, not slide)
//!     => the kept contacts must also hold in force (5.19)–(5.20), as after any impact
//! a sticking contact k at its cone's edge whose slide is inconsistent (at a slip's reset)
//!     => no impulse can act (A q̇⁻ = 0 in k's rows): force complementarity with k
//!        sticking or leaving, not sliding
//! no accepted outcome (here, or for a touchdown's impact retried with k sticking)
//!     => the plastic impact with Coulomb friction at every contact ([`coulomb_jam`],
//!        crate::coulomb_impact): its single outcome that also holds in force
//! none or several of those, or the same jam again at the same instant
//!     => the typed end, Termination::Painleve, as before
//! ```
//!
//! Why a stick: where the sliding mode's normal response `W` is negative (Painlevé's
//! region), a pushing normal force draws the contact into the ground; the only
//! rigid-body motion left is one in which the normal force is unbounded for an instant. Its
//! impulse stops the sliding at once — with a single contact, the impulse of the plastic
//! impact with both rows: `P_t/P_n = −D_nn/D_tn` (`D = A M̄⁻¹ Aᵀ`), inside the cone exactly
//! where the sliding mode on that edge is inconsistent, `μ |D_tn| > D_nn` (the rod's
//! `μ > (1 + 3cos²θ)/(3 sinθ cosθ)`, test `painleve_jam`). Being a plastic impact — an
//! `M̄`-orthogonal projection of q̇ — it never adds kinetic energy; the event records what it
//! takes ([`crate::Execution::impact_losses`]).
use crate::contact_set::IMPULSE_TOL_N_S;
use crate::energy::kinetic_energy_at;
use crate::error::HybridError;
use crate::event::{Event, EventKind, PainleveReason};
use crate::flow::{Flow, FlowWorkspace};
use crate::jam_hold::{gap_acceleration, SEPARATION_TOL_M_S2};
use crate::options::HybridOptions;
use crate::reset::{reset_workspace, Reset};
use crate::reset_workspace::ResetWorkspace;
use selfmanip_core::contact::{ContactKind, RowDirection};
use selfmanip_core::friction::SLIDING_SPEED_EPS_M_S;
use selfmanip_core::{plastic_impact, ContactMode, CoreError, Model};

/// Relative tolerance on "never adds kinetic energy": a jam whose kinetic energy after
/// exceeds the one before by more than this share (plus 1e-12 J) is refused (round-off of a
/// projection is far below it; anything above it would be an error of the solve).
const ENERGY_TOL: f64 = 1e-9;

/// Whether a jam's reset from kinetic energy `before` to `after` (J) gains energy beyond
/// round-off ([`ENERGY_TOL`] relative, 1e-12 J absolute), or came out NaN: refused.
fn gains_energy(before: f64, after: f64) -> bool {
    after.is_nan() || after > before * (1.0 + ENERGY_TOL) + 1e-12
}

/// The jam of contact `contact` (named as in [`selfmanip_core::CoreError::PainleveInconsistent`])
/// at `(t, y = [q; q̇])` in `mode`: the reset the execution continues with, or why no
/// consistent outcome was found here (the run then ends [`crate::Termination::Painleve`]).
pub fn jam(
    ws: &mut FlowWorkspace,
    flow: &mut Flow,
    opts: &HybridOptions,
    mode: ContactMode,
    contact: &str,
    (t, y): (f64, &[f64]),
) -> Result<Result<Reset, PainleveReason>, HybridError> {
    let model = flow.model();
    let Some(k) = model.contacts.iter().position(|c| c.name == contact) else {
        return Ok(Err(PainleveReason::Inactive));
    };
    let Some(kind) = mode.kind(k) else {
        return Ok(Err(PainleveReason::Inactive));
    };
    let (q, qd) = y.split_at(model.nq());
    // the contact's sliding speed: a contact at rest (a sticking one at its cone's edge, or
    // a slide that starts from rest) gives a jam no velocity to take
    let terrain = flow.terrain();
    let at_rest = crate::flow::sliding_velocity(model, flow.kinematics(q, qd), terrain, k).abs()
        <= SLIDING_SPEED_EPS_M_S;
    // k may stick or leave; sliding is what has no consistent continuation. A sticking k
    // (its force at the cone's edge) cannot stick on either: it may only leave
    let barred_slide = [(k, ContactKind::Slide)];
    let barred_both = [(k, ContactKind::Slide), (k, ContactKind::Stick)];
    let barred: &[(usize, ContactKind)] = if kind == ContactKind::Slide {
        &barred_slide
    } else {
        &barred_both
    };
    let ctrl = flow.controller().clone();
    let lock = flow.lock().to_vec();
    let cx = &mut reset_workspace(flow, &*ctrl, opts, ws, barred, &lock);
    let ke_before = kinetic_energy_at(model, cx.terrain, &mut cx.ws.data, q, qd)?;
    let candidates: Vec<usize> = mode.active().collect();
    // a sliding contact: the tangential impact into its stick (an impact: 5.28–5.29, 5.40)
    let impact = kind == ContactKind::Slide;
    let prefer = mode.with(k, ContactKind::Stick);
    let (impulse, pseudo_impulse, mut mode_after, mut qd_after) = if impact {
        let Ok(sel) = cx.select(t, &candidates, &[], prefer, q, qd, true)? else {
            return Ok(Err(PainleveReason::NoJamOutcome));
        };
        // k's own impulse must push and lie in its cone (the pseudo-impulse (5.40), which
        // may hold a contact at a touchdown, is no part of an impact without collision)
        // (a set without k — k let go with no impulse — is no jam: the slide it leaves was
        // inconsistent because its force pushes, and a contact let go there falls back in)
        if sel.mode.kind(k) != Some(ContactKind::Stick)
            || !own_impulse_in_cone(model, sel.mode, k, &sel.value)
        {
            return Ok(Err(if at_rest {
                PainleveReason::AtRest
            } else {
                PainleveReason::JamOutsideCone
            }));
        }
        let imp = plastic_impact(model, &mut cx.ws.data, cx.terrain, sel.mode, q, qd)?;
        let v: Vec<f64> = imp.qd_plus.iter().copied().collect();
        (sel.value, sel.pseudo_impulse, sel.mode, v)
    } else {
        (Vec::new(), Vec::new(), prefer, qd.to_vec())
    };
    // the kept contacts must hold in force (5.19)–(5.20); k still may not slide
    let impulse_mode = if impact {
        mode_after
    } else {
        ContactMode::FLIGHT
    };
    let mut force = Vec::new();
    if !mode_after.is_flight() {
        let kept: Vec<usize> = mode_after.active().collect();
        // a slide of the kept contacts inconsistent in turn (Painlevé): no jam outcome
        match cx.select(t, &kept, &[], mode_after, q, &qd_after, false) {
            Ok(Ok(s)) => (mode_after, force) = (s.mode, s.value),
            Ok(Err(_)) => return Ok(Err(PainleveReason::NoJamOutcome)),
            Err(HybridError::Core(CoreError::PainleveInconsistent { .. })) => {
                return Ok(Err(PainleveReason::NoJamOutcome))
            }
            Err(e) => return Err(e),
        }
    }
    if !impact {
        // no velocity jump: the state satisfies the mode before's constraints up to drift
        qd_after.copy_from_slice(qd);
    }
    let ke_after = kinetic_energy_at(model, cx.terrain, &mut cx.ws.data, q, &qd_after)?;
    if gains_energy(ke_before, ke_after) {
        return Ok(Err(PainleveReason::EnergyGain));
    }
    // a contact let go without an impulse must separate: its free normal acceleration in
    // the mode after may not draw it into the ground (else the liftoff is no solution)
    let mut y_after = y.to_vec();
    y_after[model.nq()..].copy_from_slice(&qd_after);
    for c in mode.active().filter(|&c| !mode_after.contains(c)) {
        if !separates(flow, mode_after, c, t, &y_after)? {
            return Ok(Err(if at_rest {
                PainleveReason::AtRest
            } else {
                PainleveReason::NoJamOutcome
            }));
        }
    }
    let mut lock = lock;
    crate::fold::retain_held_locks(model, mode_after, &mut lock);
    // without a velocity jump a contact that stuck until now and slides after starts from
    // rest (as at a reset); after the impact every slide has the velocity it leaves
    let from_rest = mode_after
        .active()
        .filter(|&c| {
            !impact
                && mode_after.kind(c) == Some(ContactKind::Slide)
                && mode.kind(c) == Some(ContactKind::Stick)
        })
        .collect();
    Ok(Ok(Reset::Continue {
        event: Event {
            t,
            kind: EventKind::Jam,
            mode_before: mode,
            mode_after,
            triggered: vec![k],
            impulse,
            impulse_mode,
            pseudo_impulse,
            force,
            kinetic_before: ke_before,
            kinetic_after: ke_after,
            q: q.to_vec(),
            qd_after,
        },
        from_rest,
        lock,
    }))
}

/// Whether contact `k`'s impulse in `value` (rows of `mode`, `k` sticking) pushes and lies
/// in its Coulomb cone, `|P_t| ≤ μ U(P_n)` (`U = −P_n`, `docs/conventions.md`), to the
/// resets' tolerance ([`ResetWorkspace::outside_cone`]).
pub fn own_impulse_in_cone(model: &Model, mode: ContactMode, k: usize, value: &[f64]) -> bool {
    let (mut p_t, mut p_n) = (0.0, 0.0);
    for (r, &v) in mode.rows().zip(value) {
        if r.contact == k {
            match r.direction {
                RowDirection::Tangential => p_t = v,
                RowDirection::Normal => p_n = v,
            }
        }
    }
    let push = -p_n;
    let mu = crate::coulomb_impact::mu_of(model, k);
    push >= -IMPULSE_TOL_N_S && p_t.abs() <= mu * push * (1.0 + 1e-12) + IMPULSE_TOL_N_S
}

/// Whether contact `c`, not active in `mode`, separates from `(t, y)` in the flow of `mode`:
/// the second derivative of its gap along the flow, `g̈ ≥ −`[`SEPARATION_TOL_M_S2`] (a
/// central second difference on `q ± h q̇ + ½ h² q̈`).
pub(crate) fn separates(
    flow: &mut Flow,
    mode: ContactMode,
    c: usize,
    t: f64,
    y: &[f64],
) -> Result<bool, HybridError> {
    Ok(gap_acceleration(flow, mode, c, t, y)? >= -SEPARATION_TOL_M_S2)
}

/// A Painlevé end at `(t, y)` in `mode` — the slide of contact `k` inconsistent after the
/// reset the engine's own impact law chose, and the stick of [`jam`] refused — resolved by
/// the plastic impact with Coulomb friction at every candidate, the contacts of `mode` and
/// those `touched` down ([`crate::coulomb_impact`]): each of its solutions after which the
/// contacts kept hold in force (5.19)–(5.20), and those let go with no impulse separate, is
/// an outcome; a single outcome is the reset ([`EventKind::Jam`], triggered by `touched` and
/// `k`), none or several leave the end typed with `reason`.
pub fn coulomb_jam(
    ws: &mut FlowWorkspace,
    flow: &mut Flow,
    opts: &HybridOptions,
    mode: ContactMode,
    (touched, k): (&[usize], usize),
    (t, y): (f64, &[f64]),
    reason: PainleveReason,
) -> Result<Result<Reset, PainleveReason>, HybridError> {
    let mut candidates: Vec<usize> = mode.active().chain(touched.iter().copied()).collect();
    candidates.sort_unstable();
    candidates.dedup();
    let candidates = &candidates[..];
    let model = flow.model();
    let (q, qd) = y.split_at(model.nq());
    if !flow.lock().is_empty() {
        return Ok(Err(reason));
    }
    ws.data.locked.clear();
    let terrain = flow.terrain();
    let outcomes = match crate::coulomb_impact::coulomb_impacts(
        model,
        &mut ws.data,
        terrain,
        candidates,
        q,
        qd,
    )? {
        Ok(o) => o,
        Err(_) => return Ok(Err(reason)),
    };
    let ke_before = kinetic_energy_at(model, terrain, &mut ws.data, q, qd)?;
    let ctrl = flow.controller().clone();
    let mut survivors: Vec<(ContactMode, Vec<f64>, crate::coulomb_impact::CoulombImpact)> =
        Vec::new();
    for o in outcomes {
        let mut mode_after = o.mode;
        let mut force = Vec::new();
        let mut y_after = y.to_vec();
        y_after[model.nq()..].copy_from_slice(&o.qd_plus);
        if !mode_after.is_flight() {
            let cx = &mut ResetWorkspace {
                model,
                terrain,
                ctrl: &*ctrl,
                delta_t_s: opts.delta_t_s,
                ws,
                barred: &[],
                fold_threshold: opts.fold_threshold,
                held: Vec::new(),
                jammed: Vec::new(),
            };
            let kept: Vec<usize> = mode_after.active().collect();
            match cx.select(t, &kept, &[], mode_after, q, &o.qd_plus, false) {
                Ok(Ok(s)) => (mode_after, force) = (s.mode, s.value),
                _ => continue,
            }
            // the forces after must not be Painlevé-inconsistent either
            let mut dy = vec![0.0; y.len()];
            if flow.rhs(t, mode_after, &y_after, &mut dy).is_err() {
                continue;
            }
        }
        let mut all_separate = true;
        for c in candidates
            .iter()
            .copied()
            .filter(|&c| !mode_after.contains(c))
        {
            let grazing = o
                .velocity_after
                .iter()
                .find(|v| v.0 == c)
                .is_some_and(|v| v.2 <= 1e-9);
            if grazing && !separates(flow, mode_after, c, t, &y_after)? {
                all_separate = false;
                break;
            }
        }
        if all_separate {
            survivors.push((mode_after, force, o));
        }
    }
    let [(mode_after, force, o)] = &survivors[..] else {
        return Ok(Err(reason));
    };
    let ke_after = kinetic_energy_at(model, terrain, &mut ws.data, q, &o.qd_plus)?;
    if gains_energy(ke_before, ke_after) {
        return Ok(Err(PainleveReason::EnergyGain));
    }
    let mut triggered: Vec<usize> = touched.to_vec();
    if !triggered.contains(&k) {
        triggered.push(k);
    }
    // each contact's whole impulse: a slipping contact's friction is no row of `o.mode`, so
    // the rows are those of its contacts sticking
    let impulse_mode = o
        .mode
        .active()
        .fold(ContactMode::FLIGHT, |m, c| m.with(c, ContactKind::Stick));
    let impulse = impulse_mode
        .rows()
        .map(|r| {
            let (_, p_t, p_n) = o.contact_impulses.iter().find(|p| p.0 == r.contact)?;
            Some(match r.direction {
                RowDirection::Tangential => *p_t,
                RowDirection::Normal => *p_n,
            })
        })
        .map(|p| p.unwrap_or(0.0))
        .collect();
    Ok(Ok(Reset::Continue {
        event: Event {
            t,
            kind: EventKind::Jam,
            mode_before: mode,
            mode_after: *mode_after,
            triggered,
            impulse,
            impulse_mode,
            pseudo_impulse: Vec::new(),
            force: force.clone(),
            kinetic_before: ke_before,
            kinetic_after: ke_after,
            q: q.to_vec(),
            qd_after: o.qd_plus.clone(),
        },
        from_rest: Vec::new(),
        lock: Vec::new(),
    }))
}
