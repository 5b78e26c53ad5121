//! Lemma 5.1 singularities as transitions: the *fold* of a massless chain held by one
//! contact, its guard, and the rules by which the reset resolves it (the derivation is in
//! `docs/singular-transitions.md`).
//!
//! **Where the flow becomes singular.** A massless chain (thesis 5.1.1) in contact is
//! pinned by its contact's rows alone: Lemma 5.1 holds iff the block $B_k = A_k[:, J_k]$ of
//! those rows on the chain's massless joints $J_k$ has full column rank. When $B_k$ is square
//! (a one-joint leg sliding: one normal row; a two-joint chain sticking: two rows) its
//! determinant can pass through zero: the chain reaches a critical point of its contact's
//! gap in the massless coordinates — a *fold* of the constraint manifold, e.g. a leg
//! sliding through the pose where its contact normal passes through its hip (full
//! extension: the contact force has no moment about the joint), or a two-link chain
//! stretched straight. (A non-square $B_k$ is either always of full column rank — a
//! one-joint leg sticking — or never, a mode that cannot hold at all.)
//!
//! **The pin.** The guard measures how firmly the contact pins its chain, dimensionless:
//! $$ \pi_k(q) = \frac{|\det B_k|^{1/m}}{\ell_k}, \qquad \ell_k = \max_{j \in J_k} |p_k - o_j|, $$
//! with $m = |J_k|$, $p_k$ the contact point and $o_j$ the joint positions. Each column of
//! $B_k$ is the contact row applied to $S(p_k - o_j)$, so for one joint sliding
//! $\pi_k = |\sin\psi|$, $\psi$ the angle between the contact normal and the line from the
//! joint to the contact; for two joints sticking $\pi_k^2 \ell_k^2 = |r_1 \times r_2|$,
//! $r_j = p_k - o_j$. $\pi_k$ is a smooth function of $q$ away from $0$, and it reaches $0$
//! exactly where $B_k$ loses rank — it is zero there linearly (transversally) at a generic
//! fold, so it crosses any small threshold with a definite sign on the way in.
//!
//! **With kinetic friction** (a sliding site with $\mu_k > 0$, `selfmanip_core::friction`)
//! the force on the robot lies on the cone edge $e = n + \mu_k\sigma t$ against the
//! sliding, and the massless joint's row of the system becomes the leg's statics
//! $\tilde A_j \lambda_n = f_j$, $\tilde A_j = (A_n)_j + \mu_k\sigma(A_t)_j = -e\cdot S(r)$.
//! With the friction folded in, the system is $[\bar M\ \tilde A^{\mathsf T};\ A\ 0]$, and
//! expanding along the massless joint's column (whose only entry is $(A_n)_j$) gives its
//! determinant as $\pm(A_n)_j\,\tilde A_j \det \bar M_{mm}$: it is singular where the normal
//! passes through the joint (the fold above: the leg's rate is unbounded there) **and** where
//! the cone edge does (a *wedge*: $\lambda_n = f_j / \tilde A_j$ is unbounded there). The pin
//! of such a contact is the smaller of the two, $\min(|\sin\psi|, |\sin\psi_e|)$, $\psi_e$
//! the angle between $e$ and $r$ ($\sigma$ from the sliding velocity; a site at rest forms no
//! denominator). The passage below needs the force's moment arm to vanish at the fold;
//! with friction it is $\mu_k\sigma(A_t)_j \ne 0$ at the normal's fold and the leg's rate is
//! set by the contact at the wedge, so a contact with kinetic friction is not passed: its
//! fold or wedge is resolved by complementarity (the impulsive stick — the unbounded
//! friction of a wedge stops the sliding — or the release).
//!
//! **The guard** ([`crate::guard::Guard::Fold`]) is $\pi_k - \varepsilon$, positive then
//! non-positive, with $\varepsilon$ = [`crate::HybridOptions::fold_threshold`]. It fires
//! *before* the singularity, where the flow is still regular, because the flow degenerates
//! on the way in: with a torque independent of speed the contact force grows like
//! $\tau / (\ell \sin\psi)$ and the chain's speed like $1/\sin\psi$ (the fold is reached at a
//! finite time with a square-root singularity), and with a torque–speed line the flow
//! turns stiff, its explicit steps shrinking like $\sin^2\psi$ (the runs that took minutes).
//! Stopping at $\varepsilon$ leaves out the last $\arcsin\varepsilon$ of the chain's rotation:
//! at most the work $|\tau| \arcsin\varepsilon$ of its joint torque (the closed-form test
//! reproduces the released state exactly for any $\varepsilon$).
//!
//! **The reset** first tries the *passage* of a sliding one-joint leg through its fold
//! ([`ResetWorkspace::passage`]): when the leg's torque falls with its speed (a motor's
//! torque–speed line), the moment balance at the fold holds the leg at the speed where its
//! torque vanishes, and the leg passes the fold sliding, its joint locked at that speed until
//! it is `ε` past the fold ([`crate::guard::Guard::FoldPassed`]), if the body stays supported.
//! Otherwise the contact may not keep the kind it had (that kind is the singular mode at the
//! fold) and complementarity chooses among what is left: an *impulsive stick* of a sliding
//! contact (a plastic impact into the mode where it sticks, (5.10), judged by (5.28)–(5.29)
//! with the pseudo-impulse (5.40)), or its *release* — the massless chain "rotates out of
//! the way" (Assumption 5.9: any conflict is resolved by removing the contact). A released chain's joint velocities are set to zero (at rest relative to its
//! parent): a massless chain carries no momentum, so its velocity after the release is not
//! determined by mechanics, and the flow's value there grows like $1/\varepsilon$.
use crate::bracketing::locate_crossing;
use crate::controller::Controller;
use crate::options::HybridOptions;
use crate::reset_workspace::ResetWorkspace;
use selfmanip_core::contact::{contact_geometry, ContactKind, RowDirection};
use selfmanip_core::frames::perp;
use selfmanip_core::friction::SlideDirection;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{plastic_impact, ContactMode, CoreError, Model, Terrain};

/// A passage through a fold: the velocity after it and the locked joints, the passing
/// contact's joint among them.
pub type Passage = (Vec<f64>, Vec<usize>);

/// The massless joints that pin contact `k` (the distal, all-massless part of the chain of
/// its link), as a range of joint indices; empty for a body contact or a massive chain.
pub fn massless_chain(model: &Model, k: usize) -> std::ops::Range<usize> {
    let Some(j) = model.contacts[k].link else {
        return 0..0;
    };
    let chain = model.chain(j);
    let first = chain
        .clone()
        .find(|&i| model.distal_massless(i))
        .unwrap_or(j + 1);
    first..j + 1
}

/// Keeps in `lock` the joints whose massless chain is still pinned by a contact of `mode`:
/// a locked chain stays locked while its contact holds.
pub(crate) fn retain_held_locks(model: &Model, mode: ContactMode, lock: &mut Vec<usize>) {
    lock.retain(|&j| mode.active().any(|k| massless_chain(model, k).contains(&j)));
}

/// Whether active contact `k` of `mode` can reach a fold: it pins a massless chain with as
/// many rows as the chain has joints (a square block `B_k`).
pub fn has_fold(model: &Model, mode: ContactMode, k: usize) -> bool {
    let rows = match mode.kind(k) {
        Some(ContactKind::Stick) => 2,
        Some(ContactKind::Slide) => 1,
        None => return false,
    };
    massless_chain(model, k).len() == rows
}

/// The pin `π_k(q)` of active contact `k` of `mode` at the kinematics `kin` (see the module
/// docs); `None` when the contact has no fold ([`has_fold`]). A sliding contact's cone edge
/// takes its direction `σ` from `slide_directions` (the segment's fixed directions,
/// [`selfmanip_core::Data::slide_directions`]) when it has one there, so that the fold
/// guard sees the force law the flow integrates; without one (a candidate mode at a reset,
/// whose direction is not fixed yet) from `sign v_t` outside the rest band.
pub fn pin(
    model: &Model,
    kin: &Kinematics,
    terrain: &dyn Terrain,
    mode: ContactMode,
    k: usize,
    slide_directions: &[(usize, SlideDirection)],
) -> Option<f64> {
    if !has_fold(model, mode, k) {
        return None;
    }
    let geom = contact_geometry(model, kin, terrain, k);
    let n = geom.plane.normal();
    let chain = massless_chain(model, k);
    // the columns S(p − o_j) of the chain's joints (their signs do not change |det B|)
    let col = |j: usize| perp(geom.point - kin.origin[j]);
    let reach = chain
        .clone()
        .map(|j| (geom.point - kin.origin[j]).norm())
        .fold(0.0, f64::max);
    if reach == 0.0 {
        return Some(0.0);
    }
    let measure = match chain.len() {
        // one joint, the normal row: |n · S(r)|, and with kinetic friction the cone edge
        // e = n + μ_k σ t along which the sliding force acts: |e · S(r)| / |e|
        1 => {
            let c = col(chain.start);
            let kinematic = n.dot(&c).abs();
            match sliding_edge(model, kin, &geom, k, slide_directions) {
                Some(e) => kinematic.min(e.dot(&c).abs() / e.norm()),
                None => kinematic,
            }
        }
        // two joints, both rows: |det [t; n][c₁ c₂]| = |det [c₁ c₂]| (t, n orthonormal)
        2 => {
            let (c1, c2) = (col(chain.start), col(chain.start + 1));
            (c1.x * c2.y - c1.y * c2.x).abs().sqrt()
        }
        _ => unreachable!("a contact has at most two rows"),
    };
    Some(measure / reach)
}

/// The direction `e = n + μ_k σ t` of the ground force on a sliding site with kinetic
/// friction (pushing normal forces are negative, so the force `λ_n e` opposes the sliding
/// along `σ t`), or `None` when the site has no kinetic friction or no edge.
///
/// `σ` is the site's fixed direction in `slide_directions` (the segment's, set by
/// [`crate::flow::Flow::fix_slide_directions`]; `σ = 0`: no edge). A site without a fixed
/// direction there takes `σ = sign v_t` along the tangent `t`, and has no edge at rest
/// (`|v_t|` within [`selfmanip_core::friction::SLIDING_SPEED_EPS_M_S`], where the friction
/// module takes the sticking force or a cone edge chosen by it, and no statics denominator
/// is formed).
fn sliding_edge(
    model: &Model,
    kin: &Kinematics,
    geom: &selfmanip_core::contact::ContactGeometry,
    k: usize,
    slide_directions: &[(usize, SlideDirection)],
) -> Option<nalgebra::Vector2<f64>> {
    let mu_k = model.contacts[k].kinetic_mu;
    if mu_k == 0.0 {
        return None;
    }
    let t = geom.plane.tangent();
    let fixed = slide_directions.iter().find_map(|&(c, d)| match d {
        SlideDirection::Fixed(s) if c == k => Some(s),
        _ => None,
    });
    let sigma = match fixed {
        Some(s) => s,
        None => {
            let v_t = kin.material_velocity(geom.part, geom.point).dot(&t);
            if v_t.abs() > selfmanip_core::friction::SLIDING_SPEED_EPS_M_S {
                v_t.signum()
            } else {
                0.0
            }
        }
    };
    (sigma != 0.0).then(|| geom.plane.normal() + mu_k * sigma * t)
}

/// Contact `k`'s entry of a segment's `slide_directions`, if any (what [`pin`] needs of
/// them, without borrowing the flow).
pub fn own_direction(
    slide_directions: &[(usize, SlideDirection)],
    k: usize,
) -> Option<(usize, SlideDirection)> {
    slide_directions.iter().find(|d| d.0 == k).copied()
}

/// The kind a contact at its fold may no longer take (the singular one), and the kind the
/// reset offers it instead, if any: a sliding contact that can stick is offered the stick;
/// otherwise only the release is left.
pub fn fold_options(
    model: &Model,
    mode: ContactMode,
    k: usize,
) -> (ContactKind, Option<ContactKind>) {
    use selfmanip_core::model::Friction;
    let barred = mode.kind(k).expect("an active contact");
    let can_stick = matches!(model.contacts[k].friction, Friction::Sticking { .. });
    let offered = (barred == ContactKind::Slide && can_stick).then_some(ContactKind::Stick);
    (barred, offered)
}

/// How many times the relaxation time of a leg's speed must fit into its passage for the
/// passage to count as slaved ([`ResetWorkspace::passage`]).
const SLAVING_RATIO: f64 = 10.0;

/// The speed `ω₀` at which joint `j`'s torque vanishes, falling through zero as the speed
/// grows (positive below `ω₀`, negative above), with the slope `k = −∂τ_j/∂θ̇_j > 0` there;
/// `None` when there is none (a saturated torque never changes sign). Searched from `q̇_j`
/// in the direction the torque points, with steps doubling up to `MAX_SPEED`, then located
/// by regula falsi ([`crate::bracketing::locate_crossing`]).
pub fn torque_free_speed(
    ctrl: &dyn Controller,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
    j: usize,
    tau: &mut [f64],
) -> Option<(f64, f64)> {
    /// The search gives up beyond this joint speed (rad/s).
    const MAX_SPEED: f64 = 1e4;
    let mut v = qd.to_vec();
    let mut torque = |w: f64| {
        v[j] = w;
        ctrl.torque(t, q, &v, mode, tau);
        tau[j]
    };
    let w = qd[j];
    let t0 = torque(w);
    if !t0.is_finite() {
        return None;
    }
    // a falling torque crosses zero above w when it pushes forward, below when backward
    let dir = if t0 > 0.0 { 1.0 } else { -1.0 };
    let (mut near, mut t_near) = (w, t0);
    let mut step = 1e-3 * (1.0 + w.abs());
    let far = loop {
        let x = near + dir * step;
        let tx = torque(x);
        if (tx > 0.0) != (t_near > 0.0) {
            break x;
        }
        if x.abs() > MAX_SPEED || !tx.is_finite() {
            return None;
        }
        (near, t_near) = (x, tx);
        step *= 2.0;
    };
    // the bracket [lo, hi]: τ > 0 at lo, τ ≤ 0 at hi
    let (lo, hi) = if dir > 0.0 { (near, far) } else { (far, near) };
    let (f_lo, f_hi) = (torque(lo), torque(hi));
    let tol = 1e-12 * (1.0 + w.abs());
    let mut f = |x: f64| -> Result<f64, ()> { Ok(torque(x)) };
    let (_, w0) = locate_crossing(&mut f, (lo, f_lo), (hi, f_hi), tol).ok()?;
    let dw = 1e-6 * (1.0 + w0.abs());
    let k = -(torque(w0 + dw) - torque(w0 - dw)) / (2.0 * dw);
    (k > 0.0 && k.is_finite()).then_some((w0, k))
}

/// The pin `ε` at which the fold guard of active contact `k` of `mode` fires, chosen at the
/// start of a segment: the passage threshold for a one-joint leg sliding under a torque that
/// falls through zero with speed ([`torque_free_speed`]: its approach to the fold is stiff and
/// its passage slaved, see [`ResetWorkspace::passage`]), the fold threshold otherwise.
pub fn guard_threshold(
    model: &Model,
    ctrl: &dyn Controller,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
    k: usize,
    opts: &HybridOptions,
    tau: &mut [f64],
) -> f64 {
    let chain = massless_chain(model, k);
    let slides = mode.kind(k) == Some(ContactKind::Slide);
    if slides
        && chain.len() == 1
        && model.contacts[k].kinetic_mu == 0.0
        && torque_free_speed(ctrl, (t, q, qd), mode, chain.start, tau).is_some()
    {
        opts.passage_threshold
    } else {
        opts.fold_threshold
    }
}

impl ResetWorkspace<'_> {
    /// Whether active sliding contact `k` of `mode` passes its fold from `(t, q, q̇)`, where its
    /// pin is `pin`, with the joints `lock` already locked: `None` when it cannot, else the
    /// velocity after the entry and the lock with `k`'s joint added. Which contacts then
    /// hold is for force complementarity in the locked flow (the reset's business).
    ///
    /// A massless leg's joint torque is balanced by its contact force's moment,
    /// $\tau(\dot\theta) = \ell \sin\psi\, U(\lambda)$, which vanishes at the fold. A torque
    /// that falls with speed, slope $k = -\partial\tau/\partial\dot\theta > 0$ (a motor's
    /// torque–speed line), holds the leg's speed at $\omega_0 + O(\sin\psi)$, $\tau(\omega_0) = 0$:
    /// a deviation relaxes in $m\,\ell^2 \sin^2\psi / k$ ($m$: the effective mass of the
    /// contact's normal row, $-\Lambda_{nn}$). When that time is short against the passage,
    /// $2\arcsin(\text{pin}) / |\omega_0|$, the leg passes the fold sliding with its joint
    /// locked at $\omega_0$ (the singular-perturbation limit of the stiff flow). A torque
    /// independent of speed ($k = 0$) has no such speed: its contact force grows without
    /// bound towards the fold, and the leg cannot pass.
    pub fn passage(
        &mut self,
        t: f64,
        mode: ContactMode,
        lock: &[usize],
        (k, pin): (usize, f64),
        (q, qd): (&[f64], &[f64]),
    ) -> Result<Option<Passage>, CoreError> {
        let chain = massless_chain(self.model, k);
        // the slaving needs the force's moment arm to vanish at the fold: with kinetic
        // friction it is μ_k σ (A_t)_j there, not zero (module docs)
        if chain.len() != 1
            || mode.kind(k) != Some(ContactKind::Slide)
            || self.model.contacts[k].kinetic_mu > 0.0
        {
            return Ok(None);
        }
        let j = chain.start;
        let (model, terrain) = (self.model, self.terrain);
        self.ws.tau.resize(model.n_joints(), 0.0);
        let Some((w0, slope)) = torque_free_speed(self.ctrl, (t, q, qd), mode, j, &mut self.ws.tau)
        else {
            return Ok(None);
        };
        let mut lock: Vec<usize> = lock.iter().copied().chain([j]).collect();
        lock.sort_unstable();
        lock.dedup();
        // the speed set to ω₀, the body's velocity projected onto the constraints with it
        let mut v = qd.to_vec();
        v[j] = w0;
        self.ws.data.locked.clone_from(&lock);
        let imp = plastic_impact(model, &mut self.ws.data, terrain, mode, q, &v)?;
        // the relaxation of the leg's speed against the passage
        let row = mode
            .rows()
            .position(|r| r.contact == k && r.direction == RowDirection::Normal)
            .expect("an active contact has a normal row");
        let m_eff = -self.ws.data.kkt.blocks().lambda[(row, row)];
        let arm = self.ws.data.constraints.a[(row, j)];
        let relaxation = m_eff * arm * arm / slope;
        let passage = 2.0 * pin.clamp(0.0, 1.0).asin() / w0.abs();
        Ok((SLAVING_RATIO * relaxation < passage)
            .then(|| (imp.qd_plus.iter().copied().collect(), lock)))
    }
}
