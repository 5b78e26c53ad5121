//! What one candidate contact set does at an event: its plastic impact (thesis (5.10),
//! (5.52)) with the pseudo-impulse rule (5.39)–(5.40), or at a force event its contact
//! forces (5.19)–(5.20); in either case the mode it takes once the friction cone and the
//! massless-link tie-break have had their say ([`crate::contact_set`]).
//!
//! A plastic impact into mode $J$ at $q$ with incoming velocity $\dot q^-$:
//! $$ \dot q^+ = \dot q^- - A^{\dagger T} A \dot q^-, \qquad P_\lambda = -\Lambda A \dot q^-, $$
//! and the pseudo-impulse of the actuators acting through the impact's duration δt
//! $$ P_\delta = A^\dagger (\Upsilon - \bar C \dot q^- - \bar N) \ \delta t, $$
//! with $\Upsilon$ taken at $\dot q^+$ (the thesis leaves its argument open; see the errata).
//! A contact is held when its own impulse pushes, $U(P_\lambda) > 0$; any other — including
//! a zero-speed touchdown, whose impulse vanishes — is judged by $U(P_\lambda + P_\delta)$
//! (5.40).
use crate::contact_set::{normal_push, IMPULSE_TOL_N_S};
use crate::reset_workspace::ResetWorkspace;
use selfmanip_core::contact::{ContactKind, RowDirection};
use selfmanip_core::{plastic_impact_prepared, pseudo_impulse_prepared, ContactMode, CoreError};

/// What a candidate set does: the mode it takes, its impulse `P_λ` (or force `λ`) and
/// pseudo-impulse `P_δ` in the mode's rows, what each contact is judged by (an impact's
/// `P_λ` or `P_λ + P_δ` by (5.40), or the force), and that judge's pushing normal component
/// by contact.
#[derive(Debug, Clone, PartialEq)]
pub struct SetOutcome {
    pub mode: ContactMode,
    pub value: Vec<f64>,
    pub pseudo_impulse: Vec<f64>,
    pub judged: Vec<f64>,
    pub push: Vec<(usize, f64)>,
}

impl SetOutcome {
    fn new(mode: ContactMode, value: Vec<f64>, pseudo_impulse: Vec<f64>, judged: Vec<f64>) -> Self {
        SetOutcome {
            mode,
            push: normal_push(mode, &judged),
            value,
            pseudo_impulse,
            judged,
        }
    }
}

impl ResetWorkspace<'_> {
    /// The outcome of contact set `set` at `(t, q, q̇)` (an impact when `impact`, else a
    /// force event), in the mode that `set` takes: kinds from `prefer`, and a sticking
    /// contact whose impulse (force) leaves its friction cone slides instead (Assumption
    /// 5.9, 5.1.5), as does a sticking toe touching down whose impulse would pull
    /// ([`ResetWorkspace::touchdown_pull`]); at a force event a sticking contact whose force
    /// pulls slides instead ([`ResetWorkspace::pulling_sticking`]), and a sliding contact at
    /// rest whose sticking force the cone holds sticks instead
    /// ([`ResetWorkspace::held_at_rest`]).
    /// `None` when the set's KKT matrix is singular.
    pub fn outcome(
        &mut self,
        t: f64,
        set: &[usize],
        prefer: ContactMode,
        q: &[f64],
        qd: &[f64],
        impact: bool,
    ) -> Result<Option<SetOutcome>, CoreError> {
        self.ws.data.prepare_state(self.model, q, qd)?;
        self.outcome_at_state((t, q, qd), set, prefer, impact)
    }

    /// [`Self::outcome`] at `(t, q, q̇)` with `ws.data`'s state stages already prepared at
    /// `(q, q̇)` ([`selfmanip_core::Data::prepare_state`]), as an enumeration over the sets
    /// at one event prepares them once for all.
    pub(crate) fn outcome_at_state(
        &mut self,
        (t, q, qd): (f64, &[f64], &[f64]),
        set: &[usize],
        prefer: ContactMode,
        impact: bool,
    ) -> Result<Option<SetOutcome>, CoreError> {
        // contacts that `prefer` does not hold are the ones touching down now
        let before = prefer;
        let mut prefer = prefer;
        // contacts offered the stick because the cone holds them at rest (once each)
        let mut offered: Vec<usize> = Vec::new();
        // the mode of `prefer`, prepared already (by the damped-slide test below)
        let mut prepared: Option<ContactMode> = None;
        for _ in 0..=2 * set.len() {
            // `mode_for` leaves `ws.data` prepared at `(mode, q, q̇)`
            let mode = match prepared.take() {
                Some(mode) => mode,
                None => match self.mode_for(set, prefer, (t, q, qd))? {
                    Some(mode) => mode,
                    None => return Ok(None),
                },
            };
            let outcome = if impact {
                self.impact_outcome(t, mode, q, qd)?
            } else {
                self.ws
                    .solve_prepared(self.model, self.ctrl, t, mode, q, qd)?;
                let l: Vec<f64> = self.ws.data.lambda.iter().copied().collect();
                SetOutcome::new(mode, l.clone(), Vec::new(), l)
            };
            // a jammed contact keeps its stick whatever its force (crate::jam_hold)
            let (zeroed, push_zeroed);
            let (judged, push): (&[f64], &[(usize, f64)]) = if self.jammed.is_empty() {
                (&outcome.judged, &outcome.push)
            } else {
                zeroed = self.without_jammed(mode, &outcome.judged);
                push_zeroed = normal_push(mode, &zeroed);
                (&zeroed, &push_zeroed)
            };
            let slides = self.outside_cone(mode, judged).or_else(|| {
                if impact {
                    self.touchdown_pull(mode, before, push)
                } else {
                    self.pulling_sticking(mode, judged)
                }
            });
            if let Some(k) = slides {
                let slide = mode.with(k, ContactKind::Slide);
                // a contact that can slide damped: the slide's mode, prepared, is the next
                // pass's; a sticking force at the cone's edge whose damped slide is
                // consistent on neither side keeps it sticking (`mode_for` keeps such a
                // slide sticking, ResetWorkspace::wedged_stick; crate::damped_slide)
                if !impact && self.ws.damped >> k & 1 == 1 {
                    match self.mode_for(set, slide, (t, q, qd))? {
                        Some(m) if m.kind(k) == Some(ContactKind::Stick) => {
                            return Ok(Some(outcome))
                        }
                        Some(m) => prepared = Some(m),
                        None => return Ok(None),
                    }
                }
                prefer = slide;
                continue;
            }
            // a sliding contact at rest whose sticking force the cone holds sticks
            // (complementarity at rest: it may not slide on a cone edge that would push it
            // along, selfmanip_core::friction)
            let sticks = (!impact)
                .then(|| self.held_at_rest(mode))
                .flatten()
                .filter(|k| !offered.contains(k));
            match sticks {
                Some(k) => {
                    offered.push(k);
                    prefer = mode.with(k, ContactKind::Stick);
                }
                None => return Ok(Some(outcome)),
            }
        }
        Ok(None)
    }

    /// The plastic impact (5.10) into `mode` (prepared in `ws.data` at `(mode, q, q̇⁻)`) with its
    /// pseudo-impulse (5.39) when δt > 0, the pushes judged by (5.40).
    fn impact_outcome(
        &mut self,
        t: f64,
        mode: ContactMode,
        q: &[f64],
        qd: &[f64],
    ) -> Result<SetOutcome, CoreError> {
        // [M̄ Aᵀ; A 0][Δq̇; P] = [0; −A q̇⁻]
        let imp = plastic_impact_prepared(self.model, &mut self.ws.data, qd)?;
        let p: Vec<f64> = imp.impulse.iter().copied().collect();
        if self.delta_t_s <= 0.0 {
            return Ok(SetOutcome::new(mode, p.clone(), Vec::new(), p));
        }
        // (5.38) leaves the argument of Υ open: the actuators act through the impact's δt
        // at the velocity the impact leaves, q̇⁺ — it matters for a torque–speed line, and
        // for a servo, whose damping resists the jump
        let ws = &mut self.ws;
        ws.tau.resize(self.model.n_joints(), 0.0);
        self.ctrl
            .torque(t, q, imp.qd_plus.as_slice(), mode, &mut ws.tau);
        let d = pseudo_impulse_prepared(self.model, &mut ws.data, &ws.tau, self.delta_t_s)?;
        let pd: Vec<f64> = d.iter().copied().collect();
        let total = total_impulse(mode, &p, &pd);
        Ok(SetOutcome::new(mode, p, pd, total))
    }
}

/// The impulse by which (5.40) judges each contact, in the rows of `mode`: `P_λ` for a
/// contact whose own normal impulse pushes, `P_λ + P_δ` for every other.
fn total_impulse(mode: ContactMode, p: &[f64], pd: &[f64]) -> Vec<f64> {
    let rows: Vec<_> = mode.rows().collect();
    let mut total = p.to_vec();
    for (i, r) in rows.iter().enumerate() {
        let normal = rows
            .iter()
            .position(|x| x.contact == r.contact && x.direction == RowDirection::Normal)
            .expect("every contact has a normal row");
        if -p[normal] <= IMPULSE_TOL_N_S {
            total[i] = p[i] + pd[i];
        }
    }
    total
}
