//! The jam hold: a massless chain's foot that touches down wedged, held sticking by
//! consistency instead of by a timer (docs/singular-transitions.md section 10, the decision
//! 2026-11-29-massless-shin-wedge-chatter).
//!
//! **Where.** A leg whose massless part is one joint `j` hung from a massive link (a
//! massive thigh, a massless shin: [`held_joint`])
//! is *wedged* where `|b_n| < μ |b_t|`, `b` the foot's velocity per unit rate of `j` in the
//! contact's rows: the chain carries no impulse (`bᵀP = 0`), so every impulse it lets through
//! lies along `b⊥`, inside the cone — its touchdown always sticks. The sticking force may
//! then leave the cone (the massless knee's torque balance `τ_j = bᵀλ` tilts it there) or pull, the
//! slide pull, and the release — the chain moved by its law in the air from the rate the
//! stick left it — draw the foot straight back into the ground: no mode of the rigid model
//! keeps it, and touchdown, release and touchdown again follow one another in microseconds
//! (Painlevé's case (a) of section 7 for a massless chain).
//!
//! **The hold.** At such a touchdown — the impact sticks the contact (its impulse pushes and
//! lies in its cone), force complementarity (5.19)–(5.20) lets it go, and the released foot
//! does not separate (its gap's second derivative along the flow without it is below
//! `−0.01 m/s²`, as for a contact a jam lets go, [`crate::jam`]) — the contact
//! stays sticking, *held*: complementarity keeps it in every set at a later reset, as a Zeno
//! truncation keeps its contacts (section 9), and its own force or impulse does not turn it
//! to sliding. Its forces do no work (`A q̇ = 0`), so the energy balance
//! `E1 − E0 = W + W_fr − L` closes across the hold. The hold has no duration: it ends at
//! the first of its guards ([`crate::guard::Guard::Jammed`], [`guard_value`]), positive
//! while held,
//!
//! ```text
//! g = −max( min(U(λ_n), μ U(λ_n) − |λ_t|),   the cone holds the sticking force again (N)
//!           ä_k )                            the released foot separates (m/s²)
//! ```
//!
//! with `ä_k` the gap's second derivative in the flow of the mode without the contact, from
//! the held state (where `ȧ_k = 0`). There the reset judges the contact by force
//! complementarity as at a liftoff: it keeps sticking (the cone holds it: an event that
//! changes nothing), slides (a consistent slide that pushes) or is released, now
//! separating. Each event of the cycle is then a mode change of its own: one touchdown, one
//! release, instead of a re-touch every microsecond until the event budget.
use crate::contact_set::rows_of;
use crate::event::Event;
use crate::flow::Flow;
use crate::fold;
use crate::reset_workspace::ResetWorkspace;
use selfmanip_core::contact::ContactKind;
use selfmanip_core::model::Friction;
use selfmanip_core::{ContactMode, CoreError, Model};

/// The one massless joint of contact `k`'s chain, if its massless part is one joint hung
/// from a massive link of its leg (a massless shin on a massive thigh) and the contact has a
/// finite friction cone: a contact that may be held jammed. A massless leg hung from the
/// body itself (RHex's C-legs) is left out (see the decision record).
pub fn held_joint(model: &Model, k: usize) -> Option<usize> {
    let link = model.contacts[k].link?;
    let chain = fold::massless_chain(model, k);
    let on_thigh = *model.chain(link).start() < chain.start;
    let finite = matches!(model.contacts[k].friction, Friction::Sticking { mu } if mu.is_finite());
    (chain.len() == 1 && on_thigh && finite).then_some(chain.start)
}

/// The contact `event` put into a jam hold, if any: a contact that may be held
/// ([`held_joint`]) sticking after the event with a force its cone does not hold (pulling,
/// or outside the cone) — the force complementarity would have let it go. The sensitivity
/// pass refuses what follows such an event (its entry and its guard are not differentiated).
pub fn entered(model: &Model, event: &Event) -> Option<usize> {
    let mode = event.mode_after;
    (0..model.contacts.len()).find(|&k| {
        if mode.kind(k) != Some(ContactKind::Stick) || held_joint(model, k).is_none() {
            return false;
        }
        let Friction::Sticking { mu } = model.contacts[k].friction else {
            return false;
        };
        let (Some(t_row), Some(n_row)) = rows_of(mode, k) else {
            return false;
        };
        let (Some(&lt), Some(&ln)) = (event.force.get(t_row), event.force.get(n_row)) else {
            return false;
        };
        let push = -ln;
        push < 0.0 || lt.abs() > mu * push
    })
}

/// The value of the guard of a jam hold of `contact` (its tangential and normal rows
/// `rows` in `mode`, its cone `mu`; [`crate::guard::Guard::Jammed`]) at `(t, y = [q; q̇])`
/// in the flow of `mode` (module docs): positive while the hold lasts.
pub fn guard_value(
    flow: &mut Flow,
    (t, mode, y): (f64, ContactMode, &[f64]),
    contact: usize,
    (t_row, n_row): (usize, usize),
    mu: f64,
) -> Result<f64, CoreError> {
    let model = flow.model();
    let (q, qd) = y.split_at(model.nq());
    let lambda = &flow.eval(t, mode, q, qd)?.lambda;
    let push = -lambda[n_row];
    let cone = (mu * push - lambda[t_row].abs()).min(push);
    let separating = release_acceleration(flow, mode.without(contact), contact, t, y);
    Ok(-cone.max(separating))
}

/// The contacts of `touched` that the impact at `(t, q)` stuck (`impact_mode`, from `q̇⁻`)
/// and force complementarity then let go (`mode_after`, at `q̇⁺`) although, released, they
/// would not separate ([`gap_acceleration`] below the jam's tolerance; a flow
/// without them that cannot be evaluated separates nothing either): held jammed (module
/// docs). Evaluated on `flow` (the resets' complementarity on their own workspace).
pub fn entries(
    flow: &mut Flow,
    t: f64,
    touched: &[usize],
    (impact_mode, mode_after): (ContactMode, ContactMode),
    q: &[f64],
    qd_plus: &[f64],
) -> Vec<usize> {
    let mut held = Vec::new();
    for &k in touched {
        let stuck = impact_mode.kind(k) == Some(ContactKind::Stick) && !mode_after.contains(k);
        if !stuck || held_joint(flow.model(), k).is_none() {
            continue;
        }
        let y: Vec<f64> = q.iter().chain(qd_plus).copied().collect();
        if release_acceleration(flow, mode_after, k, t, &y) < -SEPARATION_TOL_M_S2 {
            held.push(k);
        }
    }
    held
}

/// The second derivative of contact `k`'s gap (m/s²) from `(t, y)` in the flow of
/// `released` (a mode without it); `−∞` where that flow cannot be evaluated (a release
/// into a singular or inconsistent mode separates nothing).
fn release_acceleration(
    flow: &mut Flow,
    released: ContactMode,
    k: usize,
    t: f64,
    y: &[f64],
) -> f64 {
    gap_acceleration(flow, released, k, t, y).unwrap_or(f64::NEG_INFINITY)
}

/// The normal acceleration below which a contact let go counts as drawn into the ground
/// (m/s²): far above the second difference's error (`O(h)` with `h` = 0.1 ms), far below
/// gravity. (The jam's test of a contact it lets go, [`crate::jam`], and the hold's entry.)
pub(crate) const SEPARATION_TOL_M_S2: f64 = 1e-2;

/// The second derivative of contact `c`'s gap (m/s², positive: separating) from `(t, y)`
/// along the flow of `mode`, by a central second difference on `q ± h q̇ + ½ h² q̈`.
pub fn gap_acceleration(
    flow: &mut Flow,
    mode: ContactMode,
    c: usize,
    t: f64,
    y: &[f64],
) -> Result<f64, CoreError> {
    let n = y.len();
    let nq = n / 2;
    let mut dy = vec![0.0; n];
    flow.rhs(t, mode, y, &mut dy)?;
    let h = 1e-4;
    let mut yy = vec![0.0; n];
    let mut gap_at = |s: f64| {
        for (i, v) in yy.iter_mut().enumerate() {
            *v = if i < nq {
                y[i] + s * dy[i] + 0.5 * s * s * dy[nq + i]
            } else {
                y[i] + s * dy[i]
            };
        }
        flow.leg_geometry(c, &yy).gap_m
    };
    Ok((gap_at(h) - 2.0 * gap_at(0.0) + gap_at(-h)) / (h * h))
}

impl ResetWorkspace<'_> {
    /// `v` (an outcome's judged impulses or forces, rows of `mode`) with the rows of the
    /// jammed contacts zeroed: their kind is not turned by their own force or impulse.
    pub(crate) fn without_jammed(&self, mode: ContactMode, v: &[f64]) -> Vec<f64> {
        mode.rows()
            .zip(v)
            .map(|(r, &x)| {
                if self.jammed.contains(&r.contact) {
                    0.0
                } else {
                    x
                }
            })
            .collect()
    }
}
