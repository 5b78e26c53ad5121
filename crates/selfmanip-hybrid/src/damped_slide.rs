//! The damped slide's chain law from a controller: the torques `T_c` a chain of massless
//! joints carries at its current rates and its damping `K = −∂T/∂θ̇`, by differences of the
//! controller's torque in the chain's rates (exact for the behaviours' servos and a
//! torque–speed line, whose torque is affine in the rate), with the joints' passive springs
//! and dampers ([`selfmanip_core::passive`]). The contact problem itself is the core's
//! ([`selfmanip_core::damped_slide`]).
//!
//! A law without damping — no servo, a saturated one, a rate-independent torque — has no
//! damped slide: [`chain_law`] is `None` and the contact keeps the rigid engine's modes
//! (`docs/singular-transitions.md` §10).
use crate::controller::Controller;
use nalgebra::{DMatrix, DVector};
use selfmanip_core::damped_slide::{damped_chain, solve, ChainLaw};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::passive::joint_torques;
use selfmanip_core::{ContactMode, CoreError, Data, Model, Terrain};

/// The relative step in a joint's rate by which `K` is differenced (the torque is affine in
/// the rate for every law the behaviours write, so the step only needs to stay clear of
/// round-off).
const RATE_STEP: f64 = 1e-6;

/// The law of contact `k`'s massless chain ([`damped_chain`]) under `ctrl` in `mode` at
/// `(t, q, q̇)`: `None` for a contact without such a chain, or where the law's damping `K`
/// is not positive definite (its symmetric part has no Cholesky factor), or not finite.
pub fn chain_law(
    model: &Model,
    ctrl: &dyn Controller,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
    k: usize,
) -> Option<ChainLaw> {
    let joints = damped_chain(model, k)?;
    let n = joints.len();
    let torque_at = |qd: &[f64]| {
        let mut tau = vec![0.0; model.n_joints()];
        ctrl.torque(t, q, qd, mode, &mut tau);
        let passive = joint_torques(model, q, qd);
        joints
            .clone()
            .map(|j| tau[j] + passive.get(j).copied().unwrap_or(0.0))
            .collect::<Vec<f64>>()
    };
    let torque = DVector::from_vec(torque_at(qd));
    let mut damping = DMatrix::zeros(n, n);
    let mut v = qd.to_vec();
    for (c, j) in joints.clone().enumerate() {
        let h = RATE_STEP * qd[j].abs().max(1.0);
        v[j] = qd[j] + h;
        let up = torque_at(&v);
        v[j] = qd[j];
        for r in 0..n {
            damping[(r, c)] = -(up[r] - torque[r]) / h;
        }
    }
    let finite = torque.iter().chain(damping.iter()).all(|x| x.is_finite());
    let sym = (&damping + damping.transpose()) * 0.5;
    (finite && sym.cholesky().is_some()).then_some(ChainLaw {
        rates: DVector::from_iterator(n, joints.clone().map(|j| qd[j])),
        joints,
        torque,
        damping,
    })
}

/// The contacts of `model` (below 32) at the end of a chain of two or more massless joints
/// ([`damped_chain`]), as a bit set: the only ones that can slide damped.
pub fn damped_contacts(model: &Model) -> u32 {
    (0..model.n_contacts().min(32))
        .filter(|&k| damped_chain(model, k).is_some())
        .fold(0, |m, k| m | 1 << k)
}

/// Sets `data`'s chain laws ([`Data::damped_laws`]) for `mode` at `(t, q, q̇)` under `ctrl`:
/// one for each contact of `damped` (a [`damped_contacts`] set) that slides in `mode`, whose
/// chain carries no other active contact, and whose law has damping ([`chain_law`]). To be
/// called before `data` is prepared for `mode`.
pub fn set_laws(
    model: &Model,
    data: &mut Data,
    damped: u32,
    ctrl: &dyn Controller,
    state: (f64, &[f64], &[f64]),
    mode: ContactMode,
) {
    let sliding = mode.normal_bits() & !mode.tangential_bits() & damped;
    if sliding == 0 {
        if !data.damped_laws.is_empty() {
            data.damped_laws.clear();
        }
        return;
    }
    data.damped_laws.clear();
    add_laws(model, data, damped, ctrl, state, mode);
}

/// [`set_laws`] without letting go of the laws `data` holds for other contacts (a reset
/// evaluates several modes at one state, and prepares the one it selects again).
pub fn add_laws(
    model: &Model,
    data: &mut Data,
    damped: u32,
    ctrl: &dyn Controller,
    state: (f64, &[f64], &[f64]),
    mode: ContactMode,
) {
    let sliding = mode.normal_bits() & !mode.tangential_bits() & damped;
    for k in mode.active().filter(|&k| sliding >> k & 1 == 1) {
        let chain = damped_chain(model, k).expect("a damped contact has a chain");
        let shared = mode
            .active()
            .any(|c| c != k && model.contacts[c].link.is_some_and(|l| chain.contains(&l)));
        if shared {
            continue;
        }
        data.damped_laws.retain(|(c, _)| *c != k);
        if let Some(law) = chain_law(model, ctrl, state, mode, k) {
            data.damped_laws.push((k, law));
        }
    }
}

/// The relative time step of the central difference by which the chain's rates are
/// differentiated along the flow (their rounding, `ε_mach |θ̇| / h`, and the difference's
/// `h² θ⃛` both far below the integrator's tolerances).
const FLOW_STEP: f64 = 1e-6;

/// The accelerations of the damped slides' chains in `data` (solved at `(t, q, q̇)` in
/// `mode`, `q̈` of the rest of the robot in `data.qdd`): the rates of each chain are
/// algebraic ([`selfmanip_core::damped_slide`]), so its `q̈` is their derivative along the
/// flow, `d θ̇(t, q, q̇)/dt`, by a central difference on `(t ± h, q ± h q̇, q̇ ± h q̈)` with
/// the slide's side kept; written into `data.qdd`. The state's rates are set to the
/// slide's at every reset ([`consistent_rates`]), and the derivative keeps them there.
pub fn chain_accelerations(
    model: &Model,
    terrain: &dyn Terrain,
    ctrl: &dyn Controller,
    (t, mode): (f64, ContactMode),
    (q, qd): (&[f64], &[f64]),
    data: &mut Data,
) -> Result<(), CoreError> {
    if data.damped.is_empty() {
        return Ok(());
    }
    let h = FLOW_STEP * t.abs().max(1.0);
    let qdd: Vec<f64> = data.qdd.iter().copied().collect();
    let mut kin = Kinematics::default();
    let mut rates = |s: f64, k: usize, side: f64| -> Result<Option<DVector<f64>>, CoreError> {
        let qs: Vec<f64> = q.iter().zip(qd).map(|(x, v)| x + s * h * v).collect();
        let vs: Vec<f64> = qd.iter().zip(&qdd).map(|(v, a)| v + s * h * a).collect();
        kin.compute(model, &qs, &vs);
        let Some(law) = chain_law(model, ctrl, (t + s * h, &qs, &vs), mode, k) else {
            return Ok(None);
        };
        let mu_k = model.contacts[k].kinetic_mu;
        Ok(solve(model, &kin, terrain, k, &vs, &law, mu_k, Some(side))?.map(|d| d.rates))
    };
    let slides: Vec<(usize, f64, usize)> = data
        .damped
        .iter()
        .map(|d| {
            (
                d.contact,
                d.side,
                damped_chain(model, d.contact).map_or(0, |c| c.start),
            )
        })
        .collect();
    for (k, side, first) in slides {
        let (Some(up), Some(down)) = (rates(1.0, k, side)?, rates(-1.0, k, side)?) else {
            continue;
        };
        for (i, (u, d)) in up.iter().zip(down.iter()).enumerate() {
            data.qdd[first + i] = (u - d) / (2.0 * h);
        }
    }
    Ok(())
}

/// `q̇` with the rates of every chain that slides damped in `mode` at `(t, q, q̇)` set to the
/// slide's (a force event leaves the rest of the velocity as it is; the chain carries no
/// momentum): what a segment in `mode` starts from. `data` is a workspace to evaluate on.
pub fn consistent_rates(
    model: &Model,
    terrain: &dyn Terrain,
    ctrl: &dyn Controller,
    (t, mode): (f64, ContactMode),
    (q, qd): (&[f64], &mut [f64]),
    data: &mut Data,
) -> Result<(), CoreError> {
    let damped = damped_contacts(model);
    set_laws(model, data, damped, ctrl, (t, q, qd), mode);
    if data.damped_laws.is_empty() {
        return Ok(());
    }
    data.prepare_geometry(model, terrain, mode, q, qd)?;
    let slides = std::mem::take(&mut data.damped);
    for d in &slides {
        let first = damped_chain(model, d.contact).map_or(0, |c| c.start);
        for (i, r) in d.rates.iter().enumerate() {
            qd[first + i] = *r;
        }
    }
    Ok(())
}
