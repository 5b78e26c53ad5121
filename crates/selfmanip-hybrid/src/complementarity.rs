//! Which contacts an event keeps: impulse–velocity complementarity at an impact (thesis
//! (5.28)–(5.29)) and force–acceleration complementarity when a force reaches zero
//! ((5.19)–(5.20)).
//!
//! **Enumeration** (up to [`ENUMERATION_LIMIT`] candidates, as the thesis does): every subset
//! `J` of the candidates is tried ([`ResetWorkspace::outcome`]). `J` is accepted when each of
//! its contacts pushes, $U_j \ge 0$ (impulses judged by (5.40), or forces), and each
//! left-out contact `k` would need a pull in `J ∪ {k}`, $U_k \lt 0$ — or cannot be held there
//! at all (its KKT matrix singular). Exactly one accepted set is the answer; none or several
//! end the execution with a typed [`Termination`].
//!
//! **Contacts an impact leaves at rest** (at `delta_t_s = 0`, the default). The
//! pseudo-impulse rule (5.39)–(5.40) judges a contact by what it transmits over the impact's
//! duration δt, `Π_k = P_k + δt F_k + o(δt)`: the plastic impulse `P` of (5.28)–(5.29) and
//! then the force `F` of (5.19)–(5.20) in the mode after. Its limit δt → 0⁺ orders the two
//! lexicographically: `Π_k ≥ 0` when `P_k > 0`, or `P_k = 0` and `F_k ≥ 0`; so does the
//! contact's normal velocity after the duration, `v⁺_k + δt a_k`. Impulse complementarity
//! (order 0) thus decides every contact of the touching set (at zero gap, not separating:
//! [`ResetWorkspace::touching`]) except those it leaves at rest — zero impulse, zero normal
//! velocity —, and force complementarity in the mode after (order δt) decides those: one
//! whose force there is compressive stays, else it is released (its acceleration separates
//! it). "Zero" is judged on the contact's own time scale: released by a pull `P_k < 0` (its
//! impulse in `J ∪ {k}`) with the force `F_k > 0` holding it in that set, the contact leaves
//! at `v⁺_k = W̃_kk |P_k|` and falls back at `a_k = W̃_kk F_k` (`W̃_kk` its Delassus
//! operator with `J` held): its flight lasts `2 |P_k| / F_k`, independent of its inertia.
//! A flight shorter than the run's time resolution `τ` ([`crate::HybridOptions::rest_time_s`],
//! the mean event spacing at which the Zeno window stops the run) is no flight at that
//! resolution: the contact is at rest, `|P_k| ≤ (τ/2) F_k` — (5.40) with `δt = τ/2` for it
//! alone, the actuators' pseudo-impulse on the others staying of order δt → 0. The impact
//! then goes into `J` and the resting contacts (5.52), and the mode after is what force
//! complementarity keeps of them. A positive `delta_t_s` keeps (5.40) as the thesis states it.
//!
//! **Beyond the limit** (all frictionless) the same problems are solved as a convex QP with
//! clarabel ([`crate::impact_qp`]): the LCP with the Delassus operator, whose KKT conditions
//! are complementarity itself.
use crate::contact_set::normal_push;
use crate::error::HybridError;
use crate::execution::Termination;
use crate::impact::SetOutcome;
use crate::impact_qp::{self, ContactQpError, QpOutcome};
use crate::limits::ENUMERATION_LIMIT;
use crate::reset_workspace::ResetWorkspace;
use selfmanip_core::contact::ContactKind;
use selfmanip_core::model::Friction;
use selfmanip_core::{plastic_impact, ContactMode, CoreError};

/// What complementarity selects at an event: the mode after it with the contact impulses
/// (forces at a force event) and pseudo-impulses in its rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Selected {
    pub mode: ContactMode,
    pub value: Vec<f64>,
    pub pseudo_impulse: Vec<f64>,
}

/// A [`Selected`] mode, or the typed end of the execution when no or several contact sets
/// qualify.
pub type Selection = Result<Selected, Termination>;

impl ResetWorkspace<'_> {
    /// Complementarity over the subsets of `candidates` at `(t, q, q̇)`, with contact kinds
    /// from `prefer`; an impact when `impact`, else a force event.
    ///
    /// `leaving` are contacts whose liftoff guard located the root of their force here: the
    /// force is zero to round-off and on its way to pulling, so a force at that level counts
    /// as separating, not as holding (else the contact would stay with zero force and its
    /// guard fire again moments later, an event that changes nothing).
    #[allow(clippy::too_many_arguments)]
    pub fn select(
        &mut self,
        t: f64,
        candidates: &[usize],
        leaving: &[usize],
        prefer: ContactMode,
        q: &[f64],
        qd: &[f64],
        impact: bool,
    ) -> Result<Selection, HybridError> {
        let n = candidates.len();
        if n > ENUMERATION_LIMIT {
            return self.select_by_qp(t, candidates, prefer, q, qd, impact);
        }
        // every subset is needed, as a candidate and as `J ∪ {k}` of others: solve each once,
        // on the state stages (kinematics, M̄ C̄q̇ N̄) they all share
        self.ws.data.prepare_state(self.model, q, qd)?;
        let mut outcomes: Vec<Option<SetOutcome>> = Vec::with_capacity(1 << n);
        let mut set: Vec<usize> = Vec::with_capacity(n);
        for bits in 0u32..(1 << n) {
            set.clear();
            set.extend((0..n).filter(|i| bits >> i & 1 == 1).map(|i| candidates[i]));
            outcomes.push(self.outcome_at_state((t, q, qd), &set, prefer, impact)?);
        }
        let mut accepted = accepted_sets(&outcomes, candidates, leaving, &self.held);
        // no set keeps every held contact: the hold gives way to complementarity (the
        // outcomes do not depend on the hold)
        if accepted.is_empty() && !self.held.is_empty() {
            accepted = accepted_sets(&outcomes, candidates, leaving, &[]);
        }
        Ok(match accepted[..] {
            [one] => Ok(Selected {
                mode: one.mode,
                value: one.value.clone(),
                pseudo_impulse: one.pseudo_impulse.clone(),
            }),
            [] => Err(Termination::NoContactSolution { t }),
            _ => Err(Termination::SeveralContactSolutions {
                t,
                candidates: accepted.iter().map(|a| a.mode).collect(),
            }),
        })
    }

    /// The contacts of `released` (left out of the impact into `held` from `(q, q̇⁻)`) that
    /// the impact leaves at rest on the time scale `rest_time_s` (module docs): each pulls in
    /// `held ∪ {k}` by at most `(rest_time_s / 2) F_k`, its compressive force there after
    /// that set's impact. Kinds from `prefer`, as in [`Self::select`].
    #[allow(clippy::too_many_arguments)]
    pub fn resting(
        &mut self,
        t: f64,
        released: &[usize],
        (held, prefer): (ContactMode, ContactMode),
        q: &[f64],
        qd_minus: &[f64],
        rest_time_s: f64,
    ) -> Result<Vec<usize>, CoreError> {
        let mut resting = Vec::new();
        for &k in released {
            let mut set: Vec<usize> = held.active().chain([k]).collect();
            set.sort_unstable();
            let Some(imp) = self.outcome(t, &set, prefer, q, qd_minus, true)? else {
                continue;
            };
            let pull = -push_of(&imp.push, k);
            if pull.is_nan() || pull < 0.0 {
                continue;
            }
            let qd_plus = plastic_impact(
                self.model,
                &mut self.ws.data,
                self.terrain,
                imp.mode,
                q,
                qd_minus,
            )?;
            let Some(force) =
                self.outcome(t, &set, imp.mode, q, qd_plus.qd_plus.as_slice(), false)?
            else {
                continue;
            };
            let f = push_of(&normal_push(force.mode, &force.judged), k);
            if f > 0.0 && pull <= 0.5 * rest_time_s * f {
                resting.push(k);
            }
        }
        Ok(resting)
    }

    /// [`Self::select`] for more than [`ENUMERATION_LIMIT`] candidates, all frictionless: the
    /// complementarity problem as a convex QP ([`crate::impact_qp`], clarabel). Differences
    /// from the enumeration: the pseudo-impulse rule is `U(P + P_δ) ≥ 0` for every contact
    /// (the enumeration lets a contact that its own impulse holds stay on `U(P)`), the
    /// actuators' torque in `P_δ` is taken at q̇⁻ (q̇⁺ depends on the contact set, the QP's
    /// unknown; the enumeration takes it at each candidate's q̇⁺), and a
    /// problem whose contact set is not unique (e.g. three points of a rigid body on a
    /// plane) is reported as several solutions with the one basic set the QP found.
    fn select_by_qp(
        &mut self,
        t: f64,
        candidates: &[usize],
        prefer: ContactMode,
        q: &[f64],
        qd: &[f64],
        impact: bool,
    ) -> Result<Selection, HybridError> {
        let sliding = |k: usize| {
            prefer.kind(k) == Some(ContactKind::Slide)
                || matches!(self.model.contacts[k].friction, Friction::Sliding)
        };
        if let Some(&sticking) = candidates.iter().find(|&&k| !sliding(k)) {
            return Err(HybridError::TooManyContacts {
                n: candidates.len(),
                sticking,
            });
        }
        let ws = &mut self.ws;
        ws.tau.resize(self.model.n_joints(), 0.0);
        self.ctrl.torque(t, q, qd, prefer, &mut ws.tau);
        let outcome = if impact {
            let pseudo = (self.delta_t_s > 0.0).then_some((&ws.tau[..], self.delta_t_s));
            impact_qp::frictionless_impact(
                self.model,
                &mut ws.data,
                self.terrain,
                candidates,
                q,
                qd,
                pseudo,
            )
            .map(|o| match o {
                QpOutcome::Unique(s) => Ok(Selected {
                    mode: s.set.mode,
                    value: s.set.in_mode(&s.impulse),
                    // empty without a pseudo-impulse
                    pseudo_impulse: s.set.in_mode(&s.pseudo_impulse),
                }),
                QpOutcome::Ambiguous(s, _) => Err(s.set.mode),
            })
        } else {
            ws.data
                .prepare_geometry(self.model, self.terrain, ContactMode::FLIGHT, q, qd)?;
            ws.free.resize(ws.data.free_joints.len(), 0.0);
            self.ctrl
                .free_joint_qdd(t, q, qd, &ws.data.free_joints, &mut ws.free);
            impact_qp::frictionless_liftoff(
                self.model,
                &mut ws.data,
                self.terrain,
                candidates,
                q,
                qd,
                &ws.tau,
                Some(&ws.free),
            )
            .map(|o| match o {
                QpOutcome::Unique(s) => Ok(Selected {
                    mode: s.set.mode,
                    value: s.set.in_mode(&s.lambda),
                    pseudo_impulse: Vec::new(),
                }),
                QpOutcome::Ambiguous(s, _) => Err(s.set.mode),
            })
        };
        match outcome {
            Ok(Ok(x)) => Ok(Ok(x)),
            Ok(Err(mode)) => Ok(Err(Termination::SeveralContactSolutions {
                t,
                candidates: vec![mode],
            })),
            Err(ContactQpError::NoSolution { .. }) => Ok(Err(Termination::NoContactSolution { t })),
            Err(e) => Err(e.into()),
        }
    }
}

/// The sets that complementarity accepts among `outcomes` (by subset of `candidates`, bit `i`
/// for `candidates[i]`; `None`: singular): each of its contacts pushes (a `leaving` one
/// clearly), a `held` one is in it, and each left-out contact `k` would pull in `J ∪ {k}`
/// or cannot be held there at all (module docs).
fn accepted_sets<'o>(
    outcomes: &'o [Option<SetOutcome>],
    candidates: &[usize],
    leaving: &[usize],
    held: &[usize],
) -> Vec<&'o SetOutcome> {
    let n = candidates.len();
    let tol = 1e-12;
    // the push a contact needs to be held: a leaving one must push clearly
    let holds = |c: usize, u: f64| {
        if held.contains(&c) {
            true
        } else if leaving.contains(&c) {
            u > tol
        } else {
            u >= -tol
        }
    };
    let mut accepted: Vec<&SetOutcome> = Vec::new();
    for bits in 0u32..(1 << n) {
        let Some(o) = &outcomes[bits as usize] else {
            continue;
        };
        if o.push.iter().any(|&(c, u)| !holds(c, u)) {
            continue;
        }
        // a held contact stays in every accepted set
        let left_out = |i: usize| bits >> i & 1 == 0;
        if (0..n).any(|i| left_out(i) && held.contains(&candidates[i])) {
            continue;
        }
        // each left-out contact k must separate: singular with k means k cannot be held
        let separates = (0..n).filter(|&i| left_out(i)).all(|i| {
            outcomes[(bits | 1 << i) as usize]
                .as_ref()
                .is_none_or(|ok| !holds(candidates[i], push_of(&ok.push, candidates[i])))
        });
        if separates {
            accepted.push(o);
        }
    }
    accepted
}

/// The push of contact `k` in `push` (0 if it is not there).
fn push_of(push: &[(usize, f64)], k: usize) -> f64 {
    push.iter().find(|(c, _)| *c == k).map_or(0.0, |x| x.1)
}
