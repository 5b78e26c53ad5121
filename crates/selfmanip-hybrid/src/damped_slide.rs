//! The damped slide of a two-joint massless chain (derivation:
//! `docs/singular-transitions.md` section 12).
//!
//! A massless chain of two joints whose foot slides has one contact row for two massless
//! coordinates: its slide is singular (Lemma 5.1, the `1×2` block of [`crate::fold`]), so
//! rigid-body mechanics alone cannot continue a sticking foot that reaches its friction
//! cone's edge. With a servo on each joint, `τ_j = −kd_j (θ̇_j − v_j)` near its torque-free
//! rate `v_j` (`kd_j > 0`), the limit of links of small inertia `ε → 0` is regular: the
//! chain's two moment balances `τ_j = Ã_j λ_n` (`Ã_j` the contact's force direction
//! `e = n + μ_k σ t` applied to `S(p − o_j)`) fix both the force and the chain's rates,
//!
//! $$ \dot\theta = v - D^{-1}\tilde A^{\mathsf T}\lambda_n, \qquad
//!    \lambda_n = \frac{\tilde A\,\ldots}{A_n D^{-1}\tilde A^{\mathsf T}}, $$
//!
//! so the contact force is a function of the state and the chain moves on the manifold
//! where the torque component that the contact cannot balance vanishes,
//!
//! $$ \rho(t, q, \dot q) = \tilde A_p\,\tau_l - \tilde A_l\,\tau_p = 0 . $$
//!
//! **How the engine integrates it.** One joint of the chain, `l`, is locked
//! ([`selfmanip_core::Data::locked`]): the KKT system keeps the other, `p` (*pinned*), whose
//! massless row is the force law `τ_p = Ã_p λ_n`, and the contact's normal row, which sets
//! `q̈_p`. The locked joint's acceleration is prescribed so that the manifold is kept,
//! `ρ̇ = −r ρ` ([`FlowWorkspace::damped_slide`]); `λ_n` and the massive coordinates'
//! accelerations do not depend on it (the pinned row fixes `λ_n`), only `q̈_p` does, through
//! the normal row. `ρ̇` is affine in `q̈_l`; its two coefficients are directional differences
//! of `ρ` along the flow. The locked joint is the one with the smaller moment arm of the
//! normal ([`lock_joint`]); a chain whose torques do not fall with speed (no damping, a
//! saturated servo) has no such limit and is not offered the slide ([`locks_for`]).
//!
//! At a reset into the slide the chain's rates are put on the manifold
//! ([`onto_manifold`]): the chain is massless, so this costs no kinetic energy.
use crate::controller::Controller;
use selfmanip_core::contact::{contact_geometry, ContactKind};
use selfmanip_core::frames::perp;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{ContactMode, CoreError, Data, Model, Terrain};

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

/// The time step (s) of the directional difference of `ρ` along the flow.
const DT_S: f64 = 1e-6;

/// Whether active contact `k` of `mode` slides on a two-joint massless chain: the slide the
/// damped limit continues.
pub fn applies(model: &Model, mode: ContactMode, k: usize) -> bool {
    mode.kind(k) == Some(ContactKind::Slide) && massless_chain(model, k).len() == 2
}

/// The arms `e · S(p − o_j)` of contact `k`'s force direction `e = n + μ_k σ t` about the two
/// joints of its chain (first, second), at the kinematics `kin`.
fn arms(model: &Model, kin: &Kinematics, terrain: &dyn Terrain, k: usize, sigma: f64) -> [f64; 2] {
    let geom = contact_geometry(model, kin, terrain, k);
    let e = geom.plane.normal() + model.contacts[k].kinetic_mu * sigma * geom.plane.tangent();
    let j0 = massless_chain(model, k).start;
    [0, 1].map(|i| e.dot(&perp(geom.point - kin.origin[j0 + i])))
}

/// The joint of contact `k`'s two-joint chain to lock at the kinematics `kin`: the one about
/// which the contact normal has the smaller moment arm (the other is pinned and carries the
/// force law, best conditioned).
pub fn lock_joint(model: &Model, kin: &Kinematics, terrain: &dyn Terrain, k: usize) -> usize {
    let j0 = massless_chain(model, k).start;
    let [a0, a1] = arms(model, kin, terrain, k, 0.0);
    if a0.abs() <= a1.abs() {
        j0
    } else {
        j0 + 1
    }
}

/// Which of the joints `chain` have a torque that falls with their own speed at
/// `(t, q, q̇)` (a servo below its torque limit): the damping the limit needs.
fn damped(
    ctrl: &dyn Controller,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
    chain: std::ops::Range<usize>,
    tau: &mut [f64],
) -> Vec<bool> {
    let mut v = qd.to_vec();
    chain
        .map(|j| {
            let dv = 1e-6 * (1.0 + qd[j].abs());
            v[j] = qd[j] + dv;
            ctrl.torque(t, q, &v, mode, tau);
            let up = tau[j];
            v[j] = qd[j] - dv;
            ctrl.torque(t, q, &v, mode, tau);
            let down = tau[j];
            v[j] = qd[j];
            let slope = -(up - down) / (2.0 * dv);
            slope.is_finite() && slope > 0.0
        })
        .collect()
}

/// The locks of `mode` at `(t, q, q̇)` (kinematics `kin` there) in `lock`: every lock on a
/// two-joint chain is taken out, and every damped slide of `mode` ([`applies`]) gets one: its
/// [`lock_joint`] when both joints' torques fall with speed, the damped one when only one
/// does (the other, saturated, is pinned: its constant torque sets the force), none when
/// neither does (no limit: the slide stays singular) when the slide is being `offered`, its
/// [`lock_joint`] when the mode was chosen already. Other locks (a fold passage's) stay.
/// Sorted.
#[allow(clippy::too_many_arguments)]
pub fn locks_for(
    model: &Model,
    terrain: &dyn Terrain,
    ctrl: &dyn Controller,
    kin: &Kinematics,
    (t, q, qd): (f64, &[f64], &[f64]),
    (mode, offered): (ContactMode, bool),
    lock: &mut Vec<usize>,
    tau: &mut [f64],
) {
    lock.retain(|&j| {
        !(0..model.n_contacts()).any(|k| {
            let chain = massless_chain(model, k);
            chain.len() == 2 && chain.contains(&j)
        })
    });
    for k in mode.active() {
        if !applies(model, mode, k) {
            continue;
        }
        let chain = massless_chain(model, k);
        // the locked joint's law needs its own damping; with both damped, the better pin
        match damped(ctrl, (t, q, qd), mode, chain.clone(), tau)[..] {
            [true, true] => lock.push(lock_joint(model, kin, terrain, k)),
            [true, false] => lock.push(chain.start),
            [false, true] => lock.push(chain.start + 1),
            // a mode chosen already keeps its slide locked (its damping judged where it was
            // offered, before the reset's velocity jump)
            _ if !offered => lock.push(lock_joint(model, kin, terrain, k)),
            _ => {}
        }
    }
    lock.sort_unstable();
    lock.dedup();
}

/// The damped slides of `mode` under the locks `locked`: `(contact, locked joint, pinned
/// joint)`.
pub fn slides<'a>(
    model: &'a Model,
    mode: ContactMode,
    locked: &'a [usize],
) -> impl Iterator<Item = (usize, usize, usize)> + 'a {
    mode.active().filter_map(move |k| {
        if !applies(model, mode, k) {
            return None;
        }
        let chain = massless_chain(model, k);
        let l = chain.clone().find(|j| locked.contains(j))?;
        let p = chain.clone().find(|&j| j != l)?;
        Some((k, l, p))
    })
}

/// Scratch of the damped slide's law: kinematics, state and torques at probe states.
#[derive(Debug, Clone, Default)]
pub struct DampedScratch {
    kin: Kinematics,
    q: Vec<f64>,
    qd: Vec<f64>,
    tau: Vec<f64>,
}

/// One damped slide: its contact, locked and pinned joints, and its sliding direction.
#[derive(Debug, Clone, Copy)]
struct Slide {
    k: usize,
    l: usize,
    p: usize,
    sigma: f64,
}

impl DampedScratch {
    /// `ρ = Ã_p τ_l − Ã_l τ_p` of `s` at `(t, q, q̇)` (module docs), and the direction
    /// `(1, −A_nl / A_np)` of `(θ̇_l, θ̇_p)` that keeps the contact's normal rate, as the
    /// ratio `−A_nl / A_np`.
    #[allow(clippy::too_many_arguments)]
    fn imbalance(
        &mut self,
        model: &Model,
        terrain: &dyn Terrain,
        ctrl: &dyn Controller,
        (t, q, qd): (f64, &[f64], &[f64]),
        mode: ContactMode,
        s: Slide,
    ) -> (f64, f64) {
        self.kin.compute(model, q, qd);
        let j0 = massless_chain(model, s.k).start;
        let edge = arms(model, &self.kin, terrain, s.k, s.sigma);
        let normal = arms(model, &self.kin, terrain, s.k, 0.0);
        self.tau.resize(model.n_joints(), 0.0);
        ctrl.torque(t, q, qd, mode, &mut self.tau);
        let (il, ip) = (s.l - j0, s.p - j0);
        let rho = edge[ip] * self.tau[s.l] - edge[il] * self.tau[s.p];
        (rho, -normal[il] / normal[ip])
    }

    /// `ρ` at `(t, q, q̇)` with `q̇` moved by `δ` along the direction that keeps the normal
    /// rate (`ratio` its pinned component), and `q` moved by `h q̇` first.
    #[allow(clippy::too_many_arguments)]
    fn probe(
        &mut self,
        model: &Model,
        terrain: &dyn Terrain,
        ctrl: &dyn Controller,
        (t, q, qd, qdd): (f64, &[f64], &[f64], Option<&[f64]>),
        mode: ContactMode,
        s: Slide,
        (h, delta_q, delta_qd, ratio): (f64, f64, f64, f64),
    ) -> f64 {
        let mut y_q = std::mem::take(&mut self.q);
        let mut y_qd = std::mem::take(&mut self.qd);
        y_q.clear();
        y_qd.clear();
        y_q.extend(q.iter().zip(qd).map(|(a, b)| a + h * b));
        y_qd.extend_from_slice(qd);
        if let Some(a) = qdd {
            for (v, acc) in y_qd.iter_mut().zip(a) {
                *v += h * acc;
            }
        }
        y_q[s.l] += delta_q;
        y_q[s.p] += delta_q * ratio;
        y_qd[s.l] += delta_qd;
        y_qd[s.p] += delta_qd * ratio;
        let (rho, _) = self.imbalance(model, terrain, ctrl, (t + h, &y_q, &y_qd), mode, s);
        self.q = y_q;
        self.qd = y_qd;
        rho
    }
}

/// The sliding direction `σ` of contact `k`'s force in the prepared `data` (0: none).
fn sigma_of(data: &Data, k: usize) -> f64 {
    data.sliding
        .iter()
        .find(|s| s.contact == k)
        .map_or(0.0, |s| s.sigma)
}

/// The damped slide's law at `(t, q, q̇)` in `mode`, on `data` solved with the locked joints'
/// `q̈ = 0`: sets each damped slide's locked `q̈_l = a` with `ρ̇ = −r ρ` and moves its pinned
/// `q̈_p` by `−(A_nl/A_np) a` (module docs). `r` is the chain's own relaxation rate,
/// `|∂ρ/∂θ_l| / |∂ρ/∂θ̇_l|` along the direction that keeps the normal rate (a servo's
/// `kp/kd`). A chain whose `ρ` does not depend on its rates (its damping lost within the
/// segment) keeps its locked joint's rate (`a = 0`).
#[allow(clippy::too_many_arguments)]
pub fn apply_law(
    data: &mut Data,
    scratch: &mut DampedScratch,
    model: &Model,
    terrain: &dyn Terrain,
    ctrl: &dyn Controller,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
) -> Result<(), CoreError> {
    let found: Vec<Slide> = slides(model, mode, &data.locked)
        .map(|(k, l, p)| Slide {
            k,
            l,
            p,
            sigma: sigma_of(data, k),
        })
        .collect();
    for s in found {
        let qdd: Vec<f64> = data.qdd.iter().copied().collect();
        let (rho0, ratio) = scratch.imbalance(model, terrain, ctrl, (t, q, qd), mode, s);
        let dv = 1e-6 * (1.0 + qd[s.l].abs());
        let at = |h| (t, q, qd, h);
        let along = scratch.probe(model, terrain, ctrl, at(Some(&qdd[..])), mode, s, (DT_S, 0.0, 0.0, ratio));
        let by_rate = scratch.probe(model, terrain, ctrl, at(None), mode, s, (0.0, 0.0, dv, ratio));
        let by_angle = scratch.probe(model, terrain, ctrl, at(None), mode, s, (0.0, dv, 0.0, ratio));
        let rho_dot0 = (along - rho0) / DT_S;
        let slope = (by_rate - rho0) / dv;
        let r = ((by_angle - rho0) / (by_rate - rho0)).abs();
        // a chain whose ρ no longer depends on its rates (its damping lost within the
        // segment) keeps its locked joint's rate: the guards end the segment
        if !(slope.is_finite() && slope != 0.0 && r.is_finite()) {
            continue;
        }
        let a = (-r * rho0 - rho_dot0) / slope;
        data.qdd[s.l] = a;
        data.qdd[s.p] += ratio * a;
    }
    Ok(())
}

/// Puts the rates of each damped slide's chain of `mode` (locks `locked`) on its manifold
/// `ρ = 0` at `(t, q, q̇)`, along the direction that keeps the contact's normal rate: the
/// chain is massless, so its rates are not fixed by momentum (thesis 5.1.1), and the damped
/// limit fixes them. Kinetic energy is unchanged.
#[allow(clippy::too_many_arguments)]
pub fn onto_manifold(
    scratch: &mut DampedScratch,
    model: &Model,
    terrain: &dyn Terrain,
    ctrl: &dyn Controller,
    (t, q): (f64, &[f64]),
    mode: ContactMode,
    locked: &[usize],
    qd: &mut [f64],
) {
    let found: Vec<(usize, usize, usize)> = slides(model, mode, locked).collect();
    for (k, l, p) in found {
        // the side of the force: against the sliding; a foot at rest has its edge chosen by
        // the friction law when its flow starts, continuous with its stick (left as it is)
        scratch.kin.compute(model, q, qd);
        let geom = contact_geometry(model, &scratch.kin, terrain, k);
        let v_t = scratch.kin.material_velocity(geom.part, geom.point).dot(&geom.plane.tangent());
        if v_t.abs() <= selfmanip_core::friction::SLIDING_SPEED_EPS_M_S {
            continue;
        }
        let s = Slide { k, l, p, sigma: v_t.signum() };
        let (rho0, ratio) = scratch.imbalance(model, terrain, ctrl, (t, q, qd), mode, s);
        let dv = 1e-6 * (1.0 + qd[l].abs());
        let by_rate = scratch.probe(model, terrain, ctrl, (t, q, qd, None), mode, s, (0.0, 0.0, dv, ratio));
        let slope = (by_rate - rho0) / dv;
        if slope.is_finite() && slope != 0.0 {
            let step = -rho0 / slope;
            qd[l] += step;
            qd[p] += step * ratio;
        }
    }
}
