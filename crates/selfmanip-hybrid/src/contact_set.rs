//! Candidate contact sets at an event: the contact mode a set takes (each contact's kind,
//! sticking or sliding, and the rows kept when they are redundant), the Coulomb friction
//! cone (section 5.1.5, Assumption 5.9), and the tie-break for a massless link touching
//! down. Evaluated on the [`ResetWorkspace`], the resets' own copy of the core's workspace.
use crate::fold;
use crate::reset_workspace::ResetWorkspace;
use crate::surface_tolerances::TERRAIN_STEP_M;
use selfmanip_core::contact::{contact_geometry, ContactKind, RowDirection};
use selfmanip_core::model::Friction;
use selfmanip_core::{ContactMode, CoreError, SingularityKind};

pub use crate::event::IMPULSE_TOL_N_S;

impl ResetWorkspace<'_> {
    /// The mode for contact set `set`: each contact's kind from `prefer` where it is active
    /// there (a sliding contact keeps sliding), its own default otherwise; a sticking
    /// contact whose tangential row is redundant (two sticking corners on a plane) slides
    /// instead, as the thesis does for the rocking block (footnote 8 of section 5.1.4).
    /// `ws.data`'s state stages must be prepared at `(q, q̇)` ([`Data::prepare_state`]:
    /// every set at one event shares them); leaves `ws.data` prepared at the mode. `None` if
    /// its KKT matrix is singular otherwise (Lemma 5.1) — or within the fold threshold of
    /// it: a contact whose pin is at most `ε` ([`crate::fold`]) — or if the set would need a
    /// contact in a kind [`Self::barred`] bars.
    ///
    /// [`Data::prepare_state`]: selfmanip_core::Data::prepare_state
    pub fn mode_for(
        &mut self,
        set: &[usize],
        prefer: ContactMode,
        (t, q, qd): (f64, &[f64], &[f64]),
    ) -> Result<Option<ContactMode>, CoreError> {
        let mut base = ContactMode::with_defaults(self.model, set)?;
        for &k in set {
            if let Some(kind) = prefer.kind(k) {
                base = base.with(k, kind);
            }
        }
        let mut candidates = vec![base];
        for &k in set {
            let last = *candidates.last().expect("non-empty");
            if last.kind(k) == Some(ContactKind::Stick) {
                candidates.push(last.with(k, ContactKind::Slide));
            }
        }
        for m in candidates {
            if self.barred.iter().any(|&(k, kind)| m.kind(k) == Some(kind)) {
                continue;
            }
            // a sliding contact on a chain of massless joints slides damped, where its law
            // has damping (crate::damped_slide)
            if self.ws.damped != 0 {
                crate::damped_slide::add_laws(
                    self.model,
                    &mut self.ws.data,
                    self.ws.damped,
                    self.ctrl,
                    (t, q, qd),
                    m,
                );
            }
            // a damped slide is solved on the piece of its law where its own rates lie, and
            // one whose law holds on none is no candidate
            let prepared = crate::damped_slide::prepare_on_pieces(
                self.model,
                self.terrain,
                self.ctrl,
                (t, q, qd),
                m,
                &mut self.ws.data,
            )?;
            let Some(prepared) = prepared else {
                return Ok(None);
            };
            match prepared {
                Ok(()) if self.within_fold(m) => return Ok(None),
                // one wedged on both sides (inconsistent) is kept sticking, marked for the
                // jam hold (reset::wedged_holds)
                Ok(()) if self.ws.data.damped.iter().any(|d| !d.consistent) => {
                    return self.wedged_stick(m, qd);
                }
                Ok(()) => return Ok(Some(m)),
                Err(SingularityKind::RedundantConstraints) => continue,
                Err(SingularityKind::UnconstrainedMasslessMotion) => return Ok(None),
            }
        }
        Ok(None)
    }

    /// `mode` (prepared in `ws.data`) with its damped slides that are consistent on neither
    /// side sticking instead, marked in `ws.wedged`; prepared as [`Self::mode_for`] leaves it.
    fn wedged_stick(
        &mut self,
        mode: ContactMode,
        qd: &[f64],
    ) -> Result<Option<ContactMode>, CoreError> {
        let mut stuck = mode;
        for d in self.ws.data.damped.iter().filter(|d| !d.consistent) {
            stuck = stuck.with(d.contact, ContactKind::Stick);
            if !self.ws.wedged.contains(&d.contact) {
                self.ws.wedged.push(d.contact);
            }
        }
        if self
            .barred
            .iter()
            .any(|&(k, kind)| stuck.kind(k) == Some(kind))
        {
            return Ok(None);
        }
        match self
            .ws
            .data
            .prepare_mode(self.model, self.terrain, stuck, qd)?
        {
            Ok(()) if self.within_fold(stuck) => Ok(None),
            Ok(()) => Ok(Some(stuck)),
            Err(_) => Ok(None),
        }
    }

    /// Whether a contact of `mode` (prepared in `ws.data`) is within the fold threshold of
    /// its fold: the mode counts as singular there, as at the fold itself.
    pub(crate) fn within_fold(&self, mode: ContactMode) -> bool {
        let locked = &self.ws.data.locked;
        mode.active().any(|k| {
            // a chain passing its fold (locked) is within it by design
            !fold::massless_chain(self.model, k).any(|j| locked.contains(&j))
                // a candidate's sliding direction is not fixed before its segment starts
                && fold::pin(self.model, &self.ws.data.kin, self.terrain, mode, k, &[])
                    .is_some_and(|p| p <= self.fold_threshold)
        })
    }

    /// The sticking contacts of `mode` with finite `μ`, each with `μ`, its tangential
    /// component and its push `U = −v_n` in the row vector `v`, in row order.
    fn sticking_rows<'v>(
        &'v self,
        mode: ContactMode,
        v: &'v [f64],
    ) -> impl Iterator<Item = (usize, f64, f64, f64)> + 'v {
        let rows: Vec<_> = mode.rows().collect();
        (1..rows.len()).filter_map(move |i| {
            let (rt, rn) = (rows[i - 1], rows[i]);
            if rt.direction != RowDirection::Tangential || rn.contact != rt.contact {
                return None;
            }
            match self.model.contacts[rn.contact].friction {
                Friction::Sticking { mu } if mu.is_finite() => {
                    Some((rn.contact, mu, v[i - 1], -v[i]))
                }
                _ => None,
            }
        })
    }

    /// The first sticking contact with finite `μ` whose row vector `v` (force or impulse)
    /// leaves the Coulomb cone $|v_t| \le \mu \ U(v_n)$.
    pub fn outside_cone(&self, mode: ContactMode, v: &[f64]) -> Option<usize> {
        self.sticking_rows(mode, v)
            .find(|&(_, mu, t, push)| push >= 0.0 && t.abs() > mu * push * (1.0 + 1e-12) + 1e-12)
            .map(|(k, ..)| k)
    }

    /// The sticking contact with finite `μ` whose force `v` (a force event's) pulls the most
    /// with a tangential component: it is outside the cone too (`U < 0`), so sticking is not
    /// its solution in the set; sliding may be, and the set is judged by its push either way
    /// (a contact that pulls sliding too is let go by complementarity). The largest pull, not
    /// the first, so that the choice does not depend on the contacts' order (mirror images).
    pub fn pulling_sticking(&self, mode: ContactMode, v: &[f64]) -> Option<usize> {
        self.sticking_rows(mode, v)
            .filter(|&(_, _, t, push)| push < -1e-12 && t.abs() > 1e-12)
            .min_by(|a, b| a.3.total_cmp(&b.3))
            .map(|(k, ..)| k)
    }

    /// A sliding contact of `mode` (solved in `ws.data`) at rest whose sticking force its
    /// cone holds, and which may stick: it must stick, since neither cone edge starts it
    /// sliding against its force ([`selfmanip_core::friction`]).
    pub fn held_at_rest(&self, mode: ContactMode) -> Option<usize> {
        self.ws
            .data
            .sliding
            .iter()
            .filter(|s| s.at_rest && s.cone_holds && !s.wedged)
            .map(|s| s.contact)
            .find(|&k| {
                matches!(self.model.contacts[k].friction, Friction::Sticking { mu } if mu.is_finite())
                    && !self
                        .barred
                        .iter()
                        .any(|&(b, kind)| b == k && kind == ContactKind::Stick)
                    && mode.kind(k) == Some(ContactKind::Slide)
            })
    }

    /// A contact touching down now (not held by `before`), sticking, whose push pulls at the
    /// impact: it slides instead of letting go (a pulling impulse is outside its friction
    /// cone, 5.1.5). Released, a massless link keeps the motion its controller gives it in
    /// the air, which is what brought it into the ground: its touchdown would fire again at
    /// the same instant, for ever. So would a massive leg's toe whose sticking impulse pulls
    /// while it approaches the ground (issue 16: a flipped robot's parked front toe met the
    /// ground at 1.0 m/s; stuck, the impact pulled, 7.0 N s along and −2.0 N s normal;
    /// sliding, it pushes 0.07 N s and swings the light leg about its hip) — the slide is
    /// tried for any link.
    /// Sliding, it "rotates out of the way" (Assumption 5.9) by following the surface, and
    /// its normal force is whatever its joint torque makes it — zero for a limp leg; whether
    /// it is kept is then decided as for any contact, by the sign of that push. Contacts
    /// already held are released on a pull as the thesis's rule says (Fig. 5.7's chatter).
    pub fn touchdown_pull(
        &self,
        mode: ContactMode,
        before: ContactMode,
        push: &[(usize, f64)],
    ) -> Option<usize> {
        push.iter()
            .filter(|&&(k, _)| !before.contains(k))
            .find_map(|&(k, u)| {
                let c = &self.model.contacts[k];
                let slidable = matches!(c.friction, Friction::Sticking { mu } if mu.is_finite());
                (u < -IMPULSE_TOL_N_S && slidable && mode.kind(k) == Some(ContactKind::Stick))
                    .then_some(k)
            })
    }
}

impl ResetWorkspace<'_> {
    /// The contacts that land with the touchdowns `touched` of a landing from `mode` at
    /// `(q, q̇⁻)` without a pseudo-impulse (δt = 0, [`crate::complementarity`]): every other
    /// contact not in `mode` within [`TERRAIN_STEP_M`] of its surface (on it, as an active
    /// contact would be) whose normal velocity does not separate it. None with δt > 0 (the
    /// thesis's rule (5.40) as it stands) or without a touchdown.
    pub fn touching(
        &mut self,
        mode: ContactMode,
        touched: &[usize],
        q: &[f64],
        qd: &[f64],
    ) -> Result<Vec<usize>, CoreError> {
        if self.delta_t_s > 0.0 || touched.is_empty() {
            return Ok(Vec::new());
        }
        let others =
            (0..self.model.n_contacts()).filter(|&k| !mode.contains(k) && !touched.contains(&k));
        Ok(self
            .gaps_and_approach(others, q, qd)?
            .into_iter()
            .filter(|&(_, gap, approach)| gap.abs() <= TERRAIN_STEP_M && approach >= 0.0)
            .map(|(k, ..)| k)
            .collect())
    }

    /// The normal velocity `ȧ_k = n · v_k` (m/s, positive into the ground: approaching) and
    /// the gap `a_k` (m) of each contact in `contacts` at `(q, q̇)`.
    fn gaps_and_approach(
        &mut self,
        contacts: impl Iterator<Item = usize>,
        q: &[f64],
        qd: &[f64],
    ) -> Result<Vec<(usize, f64, f64)>, CoreError> {
        self.ws
            .data
            .prepare_geometry(self.model, self.terrain, ContactMode::FLIGHT, q, qd)?;
        let kin = &self.ws.data.kin;
        Ok(contacts
            .map(|k| {
                let g = contact_geometry(self.model, kin, self.terrain, k);
                (k, g.gap_m, g.point_rate.dot(&g.plane.normal()))
            })
            .collect())
    }
}

/// Normal components `U(·)_n` (pushing positive) of a row vector in `mode`, by contact.
pub fn normal_push(mode: ContactMode, v: &[f64]) -> Vec<(usize, f64)> {
    mode.rows()
        .zip(v)
        .filter(|(r, _)| r.direction == RowDirection::Normal)
        .map(|(r, &x)| (r.contact, -x))
        .collect()
}

/// Row indices, in the rows of `mode`, of contact `k`'s tangential and normal rows.
pub(crate) fn rows_of(mode: ContactMode, k: usize) -> (Option<usize>, Option<usize>) {
    let (mut t, mut n) = (None, None);
    for (i, r) in mode.rows().enumerate() {
        if r.contact == k {
            match r.direction {
                RowDirection::Tangential => t = Some(i),
                RowDirection::Normal => n = Some(i),
            }
        }
    }
    (t, n)
}
