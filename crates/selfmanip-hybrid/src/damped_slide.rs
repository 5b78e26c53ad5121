//! The damped slide's chain law from a controller: the torques `T_c` a chain of massless
//! joints carries at its current rates and its damping `K = −∂T/∂θ̇`, by differences of the
//! controller's torque in the chain's rates (exact for the behaviours' servos and a
//! torque–speed line, whose torque is affine in the rate), with the joints' passive springs
//! and dampers ([`selfmanip_core::passive`]). The contact problem itself is the core's
//! ([`selfmanip_core::damped_slide`]).
//!
//! A law without damping — no servo, a rate-independent torque, every servo of the chain at
//! its limit — has no damped slide: its [`chain_law`] does not hold and the contact keeps
//! the rigid engine's modes (`docs/singular-transitions.md` §10). A law with one servo at
//! its limit holds on that saturated piece ([`ChainLaw::saturated`], solved by the core).
//! The law is affine on each piece and kinks between them, so a slide is solved on the piece
//! where its own rates lie: where a reset judges the contact and where a segment starts, the
//! law is linearized at the state — or, where it holds on no piece there (a stop that took
//! the servos past their limits), on the chain's torque-free manifold
//! ([`torque_free_rates`]) — and moved to the piece of the slide's rates until it stays
//! there ([`prepare_on_pieces`], [`laws_on_slide_pieces`]).
use crate::controller::Controller;
use nalgebra::{DMatrix, DVector};
use selfmanip_core::damped_slide::{
    contact_rows_and_rates, damped_chain, exact, saturated_split, stick_rates, ChainLaw,
    DampedSlide,
};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::passive::joint_torque;
use selfmanip_core::{ContactMode, CoreError, Data, Model, SingularityKind, Terrain};
use std::borrow::Cow;

/// The relative step in a joint's rate by which `K` is differenced (the torque is affine in
/// the rate for every law the behaviours write, so the step only needs to stay clear of
/// round-off).
const RATE_STEP: f64 = 1e-6;

/// The law of contact `k`'s massless chain ([`damped_chain`]) under `ctrl` in `mode` at
/// `(t, q, q̇)`, [`ChainLaw::holds`] where the law's damping `K` is positive definite (its
/// symmetric part has a Cholesky factor): `None` for a contact without such a chain, or a
/// law that is not finite.
pub fn chain_law(
    model: &Model,
    ctrl: &dyn Controller,
    state: (f64, &[f64], &[f64]),
    mode: ContactMode,
    k: usize,
) -> Option<ChainLaw> {
    let joints = damped_chain(model, k)?;
    law_in(
        model,
        ctrl,
        (state, false),
        mode,
        empty_law(joints),
        &mut LawScratch::default(),
    )
}

/// A law of the chain `joints` with no numbers yet: the buffers [`law_in`] sets.
fn empty_law(joints: std::ops::Range<usize>) -> ChainLaw {
    ChainLaw {
        rates: DVector::zeros(0),
        torque: DVector::zeros(0),
        damping: DMatrix::zeros(0, 0),
        joints,
        holds: false,
        saturated: None,
    }
}

/// [`chain_law`] of the chain `law.joints`, in the buffers of `law` (whose numbers it
/// replaces) and `scratch`; with `off_state`, linearized on the chain's torque-free manifold
/// where the law has no damping at the state's rates ([`law_off_state_into`]).
fn law_in(
    model: &Model,
    ctrl: &dyn Controller,
    (state, off_state): ((f64, &[f64], &[f64]), bool),
    mode: ContactMode,
    mut law: ChainLaw,
    scratch: &mut LawScratch,
) -> Option<ChainLaw> {
    law.holds = law_off_state_into(model, ctrl, (state, off_state), mode, &mut law, scratch)?;
    std::mem::swap(&mut law.damping, &mut scratch.damping);
    law.saturated = scratch.saturated;
    Some(law)
}

/// The buffers of the chain laws ([`set_laws`]), kept by a caller that sets them
/// often.
#[derive(Debug, Clone, Default)]
pub struct LawScratch {
    tau: Vec<f64>,
    v: Vec<f64>,
    up: Vec<f64>,
    /// The law's own damping `K` at the state.
    damping: DMatrix<f64>,
    /// The lower triangle of the symmetric part of `K` (column-major `n × n`), factored in
    /// place.
    sym: Vec<f64>,
    /// The law's saturated joint at the state ([`ChainLaw::saturated`]).
    saturated: Option<usize>,
}

/// The law of the chain `law.joints` at `(t, q, q̇)` ([`chain_law`]): its `θ̇_c` and `T_c`
/// into `law`, its damping `K` into `scratch.damping` and its saturated joint into
/// `scratch.saturated`; whether the slide holds on the law's piece there — `K` positive
/// definite, or one joint saturated ([`saturated_joint`]) —, or `None` for a law that is
/// not finite.
fn law_into(
    model: &Model,
    ctrl: &dyn Controller,
    state: (f64, &[f64], &[f64]),
    mode: ContactMode,
    law: &mut ChainLaw,
    scratch: &mut LawScratch,
) -> Option<bool> {
    // a chain of two joints (the usual one) in code for its own length
    match law.joints.len() {
        2 => law_of_len(model, ctrl, state, mode, (law, 2), scratch),
        n => law_of_len(model, ctrl, state, mode, (law, n), scratch),
    }
}

/// [`law_into`]; with `off_state`, where the law holds at the state's rates (on any piece),
/// and where it holds on none there (its servos at their torque limits), the law linearized
/// on the chain's torque-free manifold ([`torque_free_rates`]), the rest of the state as it
/// is, where it holds there. A massless chain's rates are algebraic, not a state: they are
/// whatever its contact problem makes them, and where a stop has taken them to a servo's
/// limits (a plastic impact stops a foot by a jump of its chain's rates that costs no
/// impulse, thesis 5.1.3) the law at them has no damping, although the slide lies on a
/// piece with damping — the manifold's, its torque zero, is a start from which the slide's
/// own piece is found ([`prepare_on_pieces`]). Where neither holds, the law at the state.
fn law_off_state_into(
    model: &Model,
    ctrl: &dyn Controller,
    ((t, q, qd), off_state): ((f64, &[f64], &[f64]), bool),
    mode: ContactMode,
    law: &mut ChainLaw,
    scratch: &mut LawScratch,
) -> Option<bool> {
    let holds = law_into(model, ctrl, (t, q, qd), mode, law, scratch)?;
    if holds || !off_state {
        return Some(holds);
    }
    let joints = law.joints.clone();
    if let Some(rates) = torque_free_rates(model, ctrl, (t, q, qd), mode, joints.clone()) {
        let mut v = qd.to_vec();
        v[joints].copy_from_slice(&rates);
        if law_into(model, ctrl, (t, q, &v), mode, law, scratch) == Some(true) {
            return Some(true);
        }
    }
    law_into(model, ctrl, (t, q, qd), mode, law, scratch)
}

/// [`law_into`] for a chain of `n` joints.
#[inline(always)]
fn law_of_len(
    model: &Model,
    ctrl: &dyn Controller,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
    (law, n): (&mut ChainLaw, usize),
    scratch: &mut LawScratch,
) -> Option<bool> {
    let LawScratch {
        tau,
        v,
        up,
        damping,
        sym,
        saturated,
    } = scratch;
    let joints = law.joints.clone();
    debug_assert_eq!(n, joints.len());
    // every buffer below is written in full before it is read
    tau.resize(model.n_joints(), 0.0);
    let mut torque_at = |qd: &[f64], out: &mut [f64]| {
        tau.fill(0.0);
        ctrl.torque_of(t, (q, qd), mode, joints.clone(), tau);
        law_torques_into(model, joints.clone(), tau, (q, qd), out);
    };
    if law.torque.len() != n {
        law.torque = DVector::zeros(n);
    }
    let torque = &mut law.torque.as_mut_slice()[..n];
    torque_at(qd, torque);
    let torque = &*torque;
    if damping.shape() != (n, n) {
        *damping = DMatrix::zeros(n, n);
    }
    let k = &mut damping.as_mut_slice()[..n * n];
    v.clear();
    v.extend_from_slice(qd);
    up.resize(n, 0.0);
    let up = &mut up[..n];
    for c in 0..n {
        let j = joints.start + c;
        let h = RATE_STEP * qd[j].abs().max(1.0);
        v[j] = qd[j] + h;
        torque_at(v, up);
        v[j] = qd[j];
        for ((k, u), t) in k[c * n..(c + 1) * n].iter_mut().zip(&*up).zip(torque) {
            *k = -(u - t) / h;
        }
    }
    let k = &*k;
    let finite = torque.iter().chain(k).all(|x| x.is_finite());
    // the symmetric part (K + Kᵀ)/2, its lower triangle factored in its own buffer
    sym.resize(n * n, 0.0);
    let sym = &mut sym[..n * n];
    for c in 0..n {
        for r in c..n {
            sym[c * n + r] = (k[c * n + r] + k[r * n + c]) * 0.5;
        }
    }
    let mut holds = cholesky_in_place(sym, n);
    *saturated = None;
    if !holds {
        *saturated = saturated_joint(k, torque, n, sym);
        holds = saturated.is_some();
    }
    if law.rates.len() != n {
        law.rates = DVector::zeros(n);
    }
    law.rates
        .copy_from_slice(&qd[joints.start..joints.start + n]);
    finite.then_some(holds)
}

/// The joint of a chain of `n` joints whose row of the damping `k` (column-major) is zero
/// while the symmetric part of `K` over the other joints is positive definite (factored in
/// `sym`): the law's saturated piece ([`ChainLaw::saturated`]). A row counts as zero below
/// the differences' round-off, [`SATURATED_ROW`] of the law's largest torque (at least
/// 1 N m) per unit rate. `None` where no row or more than one is zero.
fn saturated_joint(k: &[f64], torque: &[f64], n: usize, sym: &mut [f64]) -> Option<usize> {
    let scale = torque.iter().fold(1.0f64, |m, t| m.max(t.abs())) * SATURATED_ROW;
    let zero = |r: usize| (0..n).all(|c| k[c * n + r].abs() <= scale);
    let mut rows = (0..n).filter(|&r| zero(r));
    let p = rows.next()?;
    if rows.next().is_some() || n < 2 {
        return None;
    }
    let m = n - 1;
    let free = |i: usize| if i < p { i } else { i + 1 };
    for c in 0..m {
        for r in c..m {
            let (i, j) = (free(r), free(c));
            sym[c * m + r] = (k[j * n + i] + k[i * n + j]) * 0.5;
        }
    }
    cholesky_in_place(&mut sym[..m * m], m).then_some(p)
}

/// The bound below which a row of the differenced damping is zero, per N m of the law's
/// torque ([`saturated_joint`]): the differences' round-off, `ε_mach |T| / h` with the
/// step `h` = [`RATE_STEP`], is some `1e-10` per N m; a joint damped by less than a
/// millionth of its torque per rad/s counts as saturated.
const SATURATED_ROW: f64 = 1e-6;

/// The Cholesky factor `L` of the symmetric `n × n` matrix whose lower triangle `m`
/// holds (column-major; the upper triangle is neither read nor written), in place: whether
/// it exists (every pivot positive). The operations of nalgebra's `Cholesky::new` in its
/// order, so that the two agree on every matrix, bit for bit.
#[inline(always)]
fn cholesky_in_place(m: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        for k in 0..j {
            // column j from row j on: += −L[j, k] · column k (nalgebra's axpy, whose
            // `a x + y` is this sum: addition commutes bit for bit)
            let factor = -m[k * n + j];
            for i in j..n {
                m[j * n + i] += factor * m[k * n + i];
            }
        }
        let diag = m[j * n + j];
        // nalgebra's test: a pivot that is zero or has no square root (negative, NaN)
        if diag.is_nan() || diag <= 0.0 {
            return false;
        }
        let denom = diag.sqrt();
        m[j * n + j] = denom;
        for x in &mut m[j * n + j + 1..(j + 1) * n] {
            *x /= denom;
        }
    }
    true
}

/// The contacts of `model` (below 32) at the end of a chain of two or more massless joints
/// ([`damped_chain`]), as a bit set: the only ones that can slide damped.
pub fn damped_contacts(model: &Model) -> u32 {
    (0..model.n_contacts().min(32))
        .filter(|&k| damped_chain(model, k).is_some())
        .fold(0, |m, k| m | 1 << k)
}

/// The contacts of `damped` (a [`damped_contacts`] set) that slide in `mode`: the ones
/// that may slide damped there.
#[inline]
pub fn sliding_damped(damped: u32, mode: ContactMode) -> u32 {
    mode.normal_bits() & !mode.tangential_bits() & damped
}

/// Sets `data`'s chain laws ([`Data::damped_laws`]) for `mode` at `(t, q, q̇)` under `ctrl`:
/// one for each contact of `damped` (a [`damped_contacts`] set) that slides in `mode`, whose
/// chain carries no other active contact, and whose law has damping ([`chain_law`]). To be
/// called before `data` is prepared for `mode`. The laws are set in the buffers of the ones
/// `data` holds, with buffers `scratch`: no allocation where the contacts that slide damped
/// stay the same. With `off_state` (where a segment starts, [`consistent_rates`]) a law
/// without damping at the state's rates is linearized on its torque-free manifold
/// ([`law_off_state_into`]); inside a segment (the flow) it is not, and keeps the damping it
/// last held with up to its guard.
pub fn set_laws(
    model: &Model,
    data: &mut Data,
    (damped, off_state): (u32, bool),
    ctrl: &dyn Controller,
    state: (f64, &[f64], &[f64]),
    mode: ContactMode,
    scratch: &mut LawScratch,
) {
    let sliding = sliding_damped(damped, mode);
    if sliding == 0 {
        if !data.damped_laws.is_empty() {
            data.damped_laws.clear();
        }
        return;
    }
    // the laws set so far lead `laws` (`set` of them), the ones held before follow; a law
    // that stops holding inside a step keeps the damping it last held with, so that the
    // flow stays defined up to its guard (ChainLaw::holds, the liftoff guard)
    let laws = &mut data.damped_laws;
    let mut set = 0;
    for k in mode.active().filter(|&k| sliding >> k & 1 == 1) {
        // a law held for the contact has its chain (`data` is the model's)
        let before = laws[set..].iter().position(|(c, _)| *c == k);
        let joints = match before {
            Some(i) => laws[set + i].1.joints.clone(),
            None => match damped_chain(model, k) {
                Some(joints) => joints,
                None => continue,
            },
        };
        debug_assert_eq!(Some(&joints), damped_chain(model, k).as_ref());
        if shares_chain(model, mode, k, &joints) {
            continue;
        }
        let at = match before {
            Some(i) => set + i,
            None => {
                laws.push((k, empty_law(joints)));
                laws.len() - 1
            }
        };
        if at != set {
            laws.swap(set, at);
        }
        let law = &mut laws[set].1;
        let Some(holds) = law_off_state_into(model, ctrl, (state, off_state), mode, law, scratch)
        else {
            continue;
        };
        law.holds = holds;
        if holds {
            std::mem::swap(&mut law.damping, &mut scratch.damping);
            law.saturated = scratch.saturated;
        } else if before.is_none() {
            continue;
        }
        set += 1;
    }
    laws.truncate(set);
}

/// The contacts of `set` (of [`damped_contacts`], active in `mode`) alone on their chain in
/// `mode`, with their chains: of a [`sliding_damped`] set, those that slide damped there.
fn lone_slides(
    model: &Model,
    set: u32,
    mode: ContactMode,
) -> impl Iterator<Item = (usize, std::ops::Range<usize>)> + '_ {
    mode.active()
        .filter(move |&k| set >> k & 1 == 1)
        .filter_map(move |k| {
            let chain = damped_chain(model, k)?;
            (!shares_chain(model, mode, k, &chain)).then_some((k, chain))
        })
}

/// Whether another active contact of `mode` sits on contact `k`'s massless chain `chain`
/// (the chain is then held by both, and its slide is not the damped one).
fn shares_chain(
    model: &Model,
    mode: ContactMode,
    k: usize,
    chain: &std::ops::Range<usize>,
) -> bool {
    mode.active()
        .any(|c| c != k && model.contacts[c].link.is_some_and(|l| chain.contains(&l)))
}

/// [`set_laws`] without letting go of the laws `data` holds for other contacts (a reset
/// evaluates several modes at one state, and prepares the one it selects again), and only
/// where the law holds — at the state, or on the chain's torque-free manifold
/// ([`law_off_state_into`]): a candidate of a reset is a damped slide only there.
pub fn add_laws(
    model: &Model,
    data: &mut Data,
    damped: u32,
    ctrl: &dyn Controller,
    state: (f64, &[f64], &[f64]),
    mode: ContactMode,
) {
    let sliding = sliding_damped(damped, mode);
    if sliding == 0 {
        return;
    }
    let mut scratch = LawScratch::default();
    for (k, joints) in lone_slides(model, sliding, mode) {
        // the law held for the contact (one at most) lets go, its buffers kept for the new
        let laws = &mut data.damped_laws;
        let held = laws
            .iter()
            .position(|(c, _)| *c == k)
            .map(|i| laws.remove(i).1);
        let law = match held {
            Some(law) => ChainLaw { joints, ..law },
            None => empty_law(joints),
        };
        if let Some(law) =
            law_in(model, ctrl, (state, true), mode, law, &mut scratch).filter(|l| l.holds)
        {
            laws.push((k, law));
        }
    }
}

/// The rates of the chain `joints` at which its law's torque vanishes, `T(t, q, θ̇) = 0`, the
/// rest of `q̇` held: the chain's torque-free manifold (`docs/singular-transitions.md` §10).
/// Joint by joint (sweeps over the chain, for a law that couples its joints), each by
/// Newton's steps on the torque's difference in the joint's own rate where the law has
/// damping there, and by steps doubling from `max(1, |θ̇|)` rad/s along the torque's sign
/// where it has none (a saturated servo's flat piece: a law with damping falls with its
/// rate), bisecting once the torque's sign has turned. `None` where the torque does not
/// vanish to [`TORQUE_FREE_TOL`] within the sweeps (a law without damping anywhere, one
/// that rises with the rate).
pub fn torque_free_rates(
    model: &Model,
    ctrl: &dyn Controller,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
    joints: std::ops::Range<usize>,
) -> Option<Vec<f64>> {
    const SWEEPS: usize = 4;
    const STEPS: usize = 64;
    let n = joints.len();
    let mut v = qd.to_vec();
    let (mut tau, mut out) = (vec![0.0; model.n_joints()], vec![0.0; n]);
    let mut torque = |v: &[f64], p: usize| {
        tau.fill(0.0);
        ctrl.torque_of(t, (q, v), mode, joints.clone(), &mut tau);
        law_torques_into(model, joints.clone(), &tau, (q, v), &mut out);
        out[p]
    };
    let scale = (0..n).map(|p| torque(&v, p).abs()).fold(1.0, f64::max);
    let tol = TORQUE_FREE_TOL * scale;
    for _ in 0..SWEEPS {
        for (p, j) in joints.clone().enumerate() {
            let (mut x, mut tx) = (v[j], torque(&v, p));
            // the last rates found with a positive and with a negative torque: a bracket
            // once both are
            let (mut pos, mut neg) = (None, None);
            let mut reach = x.abs().max(1.0);
            for _ in 0..STEPS {
                if !tx.is_finite() {
                    return None;
                }
                if tx.abs() <= tol {
                    break;
                }
                if tx > 0.0 {
                    pos = Some(x);
                } else {
                    neg = Some(x);
                }
                let h = RATE_STEP * x.abs().max(1.0);
                v[j] = x + h;
                let slope = (torque(&v, p) - tx) / h;
                let newton = x - tx / slope;
                x = match (pos, neg) {
                    (Some(a), Some(b)) if newton > a.min(b) && newton < a.max(b) => newton,
                    (Some(a), Some(b)) => 0.5 * (a + b),
                    _ if slope < 0.0 && newton.is_finite() => newton,
                    _ => {
                        reach *= 2.0;
                        x + 0.5 * reach * tx.signum()
                    }
                };
                v[j] = x;
                tx = torque(&v, p);
            }
        }
        if (0..n).all(|p| torque(&v, p).abs() <= tol) {
            return Some(v[joints].to_vec());
        }
    }
    None
}

/// The share of the chain's largest torque (at least 1 N m) within which its law counts as
/// torque-free ([`torque_free_rates`]): Newton's step on the law's affine piece lands within
/// round-off of zero.
const TORQUE_FREE_TOL: f64 = 1e-10;

/// The relative time step of the central difference by which the law's torque is
/// differentiated along the flow with the chain's rates held (`Ṫ`; exact for a law affine
/// in time and state, its rounding `ε_mach |T| / h` far below the integrator's tolerances).
const FLOW_STEP: f64 = 1e-6;

/// The accelerations of the damped slides' chains in `data` (solved at `(t, q, q̇)` in
/// `mode`, `q̈` of the rest of the robot in `data.qdd`), written into `data.qdd`. The rates
/// of each chain are algebraic ([`selfmanip_core::damped_slide`]),
///
/// ```text
/// θ̇ = v − K⁻¹ Bᵀ d λ_n,   v = θ̇_c + K⁻¹ T_c,   λ_n = N / D,
/// N = a_{n,r}ᵀ q̇_r + b_nᵀ v,   D = b_nᵀ K⁻¹ Bᵀ d,   d = (c, 1),
/// ```
///
/// (`r` the joints off the chain, `b_n` the normal row over the chain, `v` the rates of the
/// torque-free manifold), so `q̈` of the chain is their derivative along the flow in closed
/// form, with `K` constant (the law affine in the rates) and the side `c` kept:
///
/// ```text
/// v̇ = K⁻¹ Ṫ,   Ṅ = ȧ_{n,r}ᵀ q̇_r + a_{n,r}ᵀ q̈_r + ḃ_nᵀ v + b_nᵀ v̇,
/// Ḋ = ḃ_nᵀ K⁻¹ Bᵀ d + b_nᵀ K⁻¹ Ḃᵀ d,   λ̇_n = (Ṅ − λ_n Ḋ) / D,
/// θ̈ = v̇ − K⁻¹ (Ḃᵀ d λ_n + Bᵀ d λ̇_n),
/// ```
///
/// `Ȧ` the rows' rate along `q̇` ([`selfmanip_core::damped_slide::contact_rows_and_rates`])
/// and `Ṫ` the law's own rate with the chain's rates held — the controller's torque (and the
/// joints' passive torques) differenced on `(t ± h, q ± h q̇, q̇_r ± h q̈_r)`, the one
/// quantity of a controller known only by its values. The state's rates are set to the
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
    let mut events = Vec::new();
    event_instants(ctrl, &mut events);
    let mut scratch = ChainScratch::default();
    chain_accelerations_clear_of(
        model,
        terrain,
        ctrl,
        (t, mode),
        (q, qd),
        (&events, &mut scratch),
        data,
    )
}

/// The buffers of [`chain_accelerations`], kept by a caller that evaluates it often.
#[derive(Debug, Clone, Default)]
pub struct ChainScratch {
    qdd: Vec<f64>,
    qs: Vec<f64>,
    vs: Vec<f64>,
    tau: Vec<f64>,
    work: Vec<f64>,
}

/// The instants of `ctrl`'s time events ([`Controller::time_events`]) into `out`, in
/// ascending order, without a NaN (which no stencil would stay clear of): what
/// [`Stencil::clear_of`] searches.
pub(crate) fn event_instants(ctrl: &dyn Controller, out: &mut Vec<f64>) {
    out.clear();
    out.extend(
        ctrl.time_events(&[])
            .iter()
            .map(|e| e.t)
            .filter(|t| !t.is_nan()),
    );
    out.sort_by(f64::total_cmp);
}

/// [`chain_accelerations`] with the controller's time events `events` (their instants,
/// [`event_instants`]), which a caller that evaluates one controller many times asks for
/// once, and buffers `scratch`.
pub(crate) fn chain_accelerations_clear_of(
    model: &Model,
    terrain: &dyn Terrain,
    ctrl: &dyn Controller,
    (t, mode): (f64, ContactMode),
    (q, qd): (&[f64], &[f64]),
    (events, scratch): (&[f64], &mut ChainScratch),
    data: &mut Data,
) -> Result<(), CoreError> {
    if data.damped.is_empty() {
        return Ok(());
    }
    let h = FLOW_STEP * t.abs().max(1.0);
    let side = Stencil::clear_of(events, t, h);
    // q̈ of the rest of the robot, and the stencil's states and torques (every buffer
    // written in full before it is read)
    let ChainScratch {
        qdd,
        qs,
        vs,
        tau,
        work,
    } = scratch;
    qdd.clear();
    qdd.extend_from_slice(data.qdd.as_slice());
    let qdd = &qdd[..];
    let on = (model, terrain, ctrl, (t, mode), (h, side));
    tau.resize(model.n_joints(), 0.0);
    qs.resize(q.len(), 0.0);
    vs.resize(qd.len(), 0.0);
    for i in 0..data.damped.len() {
        let d = &data.damped[i];
        let Some((_, law)) = data.damped_laws.iter().find(|(c, _)| *c == d.contact) else {
            continue;
        };
        let n = law.joints.len();
        if work.len() < 13 * n {
            work.resize(13 * n, 0.0);
        }
        // K⁻¹ as the slide was solved with it
        let slide = (d, law, &data.kin, &d.k_inv[..]);
        let bufs = (&mut qs[..], &mut vs[..], &mut tau[..], &mut work[..]);
        let out = data.qdd.as_mut_slice();
        // a chain of two joints (the usual one) in code for its own length
        match n {
            2 => slide_accelerations(on, (q, qd, qdd), (slide, 2), bufs, out),
            n => slide_accelerations(on, (q, qd, qdd), (slide, n), bufs, out),
        }
    }
    Ok(())
}

/// The accelerations of the chain of one damped slide `d` under its law `law` (of `n`
/// joints, `K⁻¹` in `ki`; [`chain_accelerations_clear_of`]) into `out` (`q̈`), with the
/// rest of the robot's `q̈` in `qdd`, the stencil `side` of step `h` and buffers `bufs`.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn slide_accelerations(
    (model, terrain, ctrl, (t, mode), (h, side)): (
        &Model,
        &dyn Terrain,
        &dyn Controller,
        (f64, ContactMode),
        (f64, Stencil),
    ),
    (q, qd, qdd): (&[f64], &[f64], &[f64]),
    ((d, law, kin, ki), n): ((&DampedSlide, &ChainLaw, &Kinematics, &[f64]), usize),
    (qs, vs, tau, work): (&mut [f64], &mut [f64], &mut [f64], &mut [f64]),
    out: &mut [f64],
) {
    let [t_up, t_mid, t_down, t_dot, v, v_dot, bn, bn_dot, bd, bd_dot, kbd, kbd_dot, w] =
        split_n(&mut work[..13 * n], n);
    let (coef, lambda_n) = (d.coef, d.lambda[1]);
    let joints = law.joints.clone();
    let j0 = joints.start;
    debug_assert_eq!(n, joints.len());
    // Ṫ: the law's torque along the flow, the chain's rates held
    let mut torque_at = |s: f64, into: &mut [f64]| {
        let step = s * h;
        for ((x, qj), vj) in qs.iter_mut().zip(q).zip(qd) {
            *x = qj + step * vj;
        }
        for ((x, vj), aj) in vs.iter_mut().zip(qd).zip(qdd) {
            *x = vj + step * aj;
        }
        vs[joints.clone()].copy_from_slice(&qd[joints.clone()]);
        tau.fill(0.0);
        ctrl.torque_of(t + s * h, (qs, vs), mode, joints.clone(), tau);
        law_torques_into(model, joints.clone(), tau, (qs, vs), into);
    };
    match side {
        Stencil::Central => {
            torque_at(1.0, t_up);
            torque_at(-1.0, t_down);
            for p in 0..n {
                t_dot[p] = (t_up[p] - t_down[p]) / (2.0 * h);
            }
        }
        Stencil::Forward => {
            torque_at(1.0, t_up);
            torque_at(2.0, t_mid);
            torque_at(0.0, t_down);
            for p in 0..n {
                t_dot[p] = (t_up[p] * 4.0 - t_mid[p] - t_down[p] * 3.0) / (2.0 * h);
            }
        }
        Stencil::Backward => {
            torque_at(0.0, t_up);
            torque_at(-1.0, t_mid);
            torque_at(-2.0, t_down);
            for p in 0..n {
                t_dot[p] = (t_up[p] * 3.0 - t_mid[p] * 4.0 + t_down[p]) / (2.0 * h);
            }
        }
    }
    let (a, a_dot) = rows_and_rates(d, (model, kin, terrain), qd);
    let (a, a_dot) = (&*a, &*a_dot);
    if let Some(p) = law.saturated {
        return saturated_accelerations((qd, qdd), (d, law, p), (a, a_dot), t_dot, out);
    }
    // B, Ḃ: the rows over the chain (2 × n, column-major)
    let b = &a.as_slice()[2 * j0..2 * (j0 + n)];
    let b_dot = &a_dot.as_slice()[2 * j0..2 * (j0 + n)];
    // v = θ̇_c + K⁻¹ T_c, v̇ = K⁻¹ Ṫ (the torque-free manifold's rates and their rate)
    exact::gemv(ki, law.torque.as_slice(), v);
    for (p, x) in v.iter_mut().enumerate() {
        *x += qd[j0 + p];
    }
    exact::gemv(ki, t_dot, v_dot);
    // N, D and their rates; Bᵀd = (c b_t + b_n) with d = (c, 1)
    let off = |m: &DMatrix<f64>, x: &[f64]| normal_off_chain(m.as_slice(), x, &joints);
    for p in 0..n {
        bn[p] = b[2 * p + 1];
        bn_dot[p] = b_dot[2 * p + 1];
        bd[p] = b[2 * p + 1] + coef * b[2 * p];
        bd_dot[p] = b_dot[2 * p + 1] + coef * b_dot[2 * p];
    }
    exact::gemv(ki, bd, kbd);
    exact::gemv(ki, bd_dot, kbd_dot);
    let den = exact::dot(bn, kbd);
    let n_dot = off(a_dot, qd) + off(a, qdd) + exact::dot(bn_dot, v) + exact::dot(bn, v_dot);
    let den_dot = exact::dot(bn_dot, kbd) + exact::dot(bn, kbd_dot);
    let lambda_n_dot = (n_dot - lambda_n * den_dot) / den;
    // θ̈ = v̇ − K⁻¹ (Ḃᵀd λ_n + Bᵀd λ̇_n)
    for p in 0..n {
        w[p] = bd_dot[p] * lambda_n + bd[p] * lambda_n_dot;
    }
    exact::gemv(ki, w, kbd);
    for p in 0..n {
        out[j0 + p] = v_dot[p] - kbd[p];
    }
}

/// The accelerations of the chain of one damped slide `d` on its law's saturated piece
/// (joint `p` saturated, [`ChainLaw::saturated`]; `K` singular) into `out` (`q̈`), with
/// the rest of the robot's `q̈` in `qdd` and the law's rate `Ṫ` (the chain's rates held)
/// in `t_dot`: the balance `T = Bᵀd λ_n` and `u_n = 0` differentiated along the flow, the
/// side `c` kept,
///
/// ```text
/// K θ̈ + Bᵀd λ̇_n = Ṫ − Ḃᵀd λ_n,
/// b_nᵀ θ̈ = −(ȧ_{n,r}ᵀ q̇_r + a_{n,r}ᵀ q̈_r + ḃ_nᵀ θ̇),
/// ```
///
/// whose row `p` sets `λ̇_n`, the other rows `θ̈` up to the saturated joint's free motion
/// `r` ([`saturated_split`]), and the last row that motion.
fn saturated_accelerations(
    (qd, qdd): (&[f64], &[f64]),
    (d, law, p): (&DampedSlide, &ChainLaw, usize),
    (a, a_dot): (&DMatrix<f64>, &DMatrix<f64>),
    t_dot: &[f64],
    out: &mut [f64],
) {
    let joints = law.joints.clone();
    let (j0, n) = (joints.start, joints.len());
    let (b, b_dot) = (
        &a.as_slice()[2 * j0..2 * (j0 + n)],
        &a_dot.as_slice()[2 * j0..2 * (j0 + n)],
    );
    let (coef, lambda_n) = (d.coef, d.lambda[1]);
    let bd = |m: &[f64], i: usize| m[2 * i + 1] + coef * m[2 * i];
    let lambda_n_dot = (t_dot[p] - bd(b_dot, p) * lambda_n) / bd(b, p);
    let y: Vec<f64> = (0..n)
        .map(|i| t_dot[i] - bd(b_dot, i) * lambda_n - bd(b, i) * lambda_n_dot)
        .collect();
    // K_FF is nonsingular where the law held (its symmetric part positive definite)
    let Some((x0, r)) = saturated_split(&law.damping, p, &y) else {
        out[joints].fill(f64::NAN);
        return;
    };
    let off = |m: &DMatrix<f64>, x: &[f64]| normal_off_chain(m.as_slice(), x, &joints);
    let rates = d.rates.as_slice();
    let normal =
        -(off(a_dot, qd) + off(a, qdd) + (0..n).map(|i| b_dot[2 * i + 1] * rates[i]).sum::<f64>());
    let bn_r: f64 = (0..n).map(|i| b[2 * i + 1] * r[i]).sum();
    let bn_x0: f64 = (0..n).map(|i| b[2 * i + 1] * x0[i]).sum();
    let sigma = (normal - bn_x0) / bn_r;
    for i in 0..n {
        out[j0 + i] = x0[i] + sigma * r[i];
    }
}

/// The rows `A` of damped slide `d` and their rate `Ȧ`: as the split assembled them at
/// this state, else assembled here at `(kin, q̇)`.
fn rows_and_rates<'d>(
    d: &'d DampedSlide,
    (model, kin, terrain): (&Model, &Kinematics, &dyn Terrain),
    qd: &[f64],
) -> (Cow<'d, DMatrix<f64>>, Cow<'d, DMatrix<f64>>) {
    match &d.rows_dot {
        Some(a_dot) => (Cow::Borrowed(&d.rows), Cow::Borrowed(a_dot)),
        None => {
            let (a, a_dot, _) = contact_rows_and_rates(model, kin, terrain, d.contact, qd);
            (Cow::Owned(a), Cow::Owned(a_dot))
        }
    }
}

/// `Σ_j A_{n,j} x_j` over the joints `j` off `chain` in order (`A` the contact's rows, `2 × nq`
/// column-major, its normal row second), summed as `Iterator::sum` sums: from `−0`.
fn normal_off_chain(a: &[f64], x: &[f64], chain: &std::ops::Range<usize>) -> f64 {
    let mut s = -0.0;
    for j in 0..chain.start {
        s += a[2 * j + 1] * x[j];
    }
    for j in chain.end..x.len() {
        s += a[2 * j + 1] * x[j];
    }
    s
}

/// `work` (of length `13 n`) as thirteen slices of `n`.
fn split_n(work: &mut [f64], n: usize) -> [&mut [f64]; 13] {
    let mut parts = work.chunks_mut(n);
    std::array::from_fn(|_| parts.next().expect("13 n entries"))
}

/// The torques of the chain `joints` under its law into `out`: the controller's `tau` and
/// the joints' passive torques at `(q, q̇)` ([`joint_torque`]).
#[inline]
fn law_torques_into(
    model: &Model,
    joints: std::ops::Range<usize>,
    tau: &[f64],
    (q, qd): (&[f64], &[f64]),
    out: &mut [f64],
) {
    for (o, j) in out.iter_mut().zip(joints) {
        *o = tau[j] + joint_torque(model, j, q, qd);
    }
}

/// The difference stencil of the law's rate `Ṫ` at `t`: central, or one-sided on the side
/// of `t` where the controller's law is one smooth piece in time — a time event of the
/// controller (a phase that starts at a set instant) within the stencil's two steps `h`
/// would difference the law across its jump (a rate of order `ΔT / h`), and put the chain's
/// rates through the ground within a nanosecond.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stencil {
    Central,
    Forward,
    Backward,
}

impl Stencil {
    /// The stencil at `t` clear of the time events `events` (ascending, no NaN:
    /// [`event_instants`]; a controller's law holds from a time event on: one at `t` itself
    /// lies behind). The first event after `t` and the last one up to it decide.
    fn clear_of(events: &[f64], t: f64, h: f64) -> Self {
        let reach = 2.0 * h;
        let after = events.partition_point(|&e| e <= t);
        if events.get(after).is_some_and(|&e| e <= t + reach) {
            Stencil::Backward
        } else if after > 0 && events[after - 1] > t - reach {
            Stencil::Forward
        } else {
            Stencil::Central
        }
    }
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
    stuck_rates(model, terrain, damped, mode, q, qd);
    let mut scratch = LawScratch::default();
    set_laws(
        model,
        data,
        (damped, true),
        ctrl,
        (t, q, qd),
        mode,
        &mut scratch,
    );
    if data.damped_laws.is_empty() {
        return Ok(());
    }
    data.prepare_geometry(model, terrain, mode, q, qd)?;
    // each slide on the law's piece where its rates lie
    for _ in 0..PIECE_PASSES {
        if laws_on_slide_pieces(model, ctrl, (t, q, qd), mode, data) != Some(false) {
            break;
        }
        data.prepare_geometry(model, terrain, mode, q, qd)?;
    }
    slide_rates_into(model, data, qd);
    data.damped.clear();
    Ok(())
}

/// `q̇` with the rates of every chain that slides damped in `data` set to its slide's.
fn slide_rates_into(model: &Model, data: &Data, qd: &mut [f64]) {
    for d in &data.damped {
        set_chain_rates(model, d.contact, d.rates.as_slice(), qd);
    }
}

/// Sets the rates of every chain that slides damped in `data` (solved at the state of `q̇`)
/// to its slide's where one of them has drifted from its slide's by more than the tolerance
/// `(atol, rtol)`, `atol + rtol |θ̇|`: whether it did. The chain's rates are algebraic; the
/// flow carries them by their derivative, which jumps where a servo meets or leaves its
/// torque limit, and which an error norm does not watch (the chain has no mass).
pub fn project_drifted_rates(
    model: &Model,
    data: &Data,
    qd: &mut [f64],
    (atol, rtol): (f64, f64),
) -> bool {
    let drifted = data.damped.iter().any(|d| {
        damped_chain(model, d.contact).is_some_and(|chain| {
            let tol = |r: f64| atol + rtol * r.abs();
            chain
                .zip(d.rates.iter())
                .any(|(j, r)| (qd[j] - r).abs() > tol(*r))
        })
    });
    if drifted {
        slide_rates_into(model, data, qd);
    }
    drifted
}

/// Writes `rates` into `q̇` at the joints of contact `k`'s massless chain ([`damped_chain`]).
fn set_chain_rates(model: &Model, k: usize, rates: &[f64], qd: &mut [f64]) {
    let first = damped_chain(model, k).map_or(0, |c| c.start);
    qd[first..first + rates.len()].copy_from_slice(rates);
}

/// `q̇` with the rates of every two-joint massless chain whose foot sticks alone on it in
/// `mode` set to hold the foot at rest ([`selfmanip_core::damped_slide::stick_rates`]): a
/// stick that ends a damped slide at a force event (a controller's phase, a guard of
/// another contact) finds the foot at its slide's velocity, and no impact stops it.
fn stuck_rates(
    model: &Model,
    terrain: &dyn Terrain,
    damped: u32,
    mode: ContactMode,
    q: &[f64],
    qd: &mut [f64],
) {
    let stuck = mode.tangential_bits() & damped;
    if stuck == 0 {
        return;
    }
    let mut kin = selfmanip_core::kinematics::Kinematics::default();
    kin.compute(model, q, qd);
    for (k, _) in lone_slides(model, stuck, mode) {
        if let Some(rates) = stick_rates(model, &kin, terrain, k, qd) {
            set_chain_rates(model, k, rates.as_slice(), qd);
        }
    }
}

/// The value of the liftoff guard of active contact `contact` (its normal row `row`) from
/// `data` evaluated in the flow: its push `U = −λ_n` — for a damped slide, while its law
/// holds ([`ChainLaw::holds`]) and its side stays out of Painlevé's region; where the law
/// stops holding (its damping no longer positive definite: a servo saturated, a phase
/// without damping) or the slide wedges ([`selfmanip_core::damped_slide::DampedSlide::wedged`])
/// the guard is negative, and the slide ends there as at a liftoff: the reset judges the
/// contact by complementarity.
#[inline]
pub fn liftoff_value(data: &Data, contact: usize, row: usize) -> f64 {
    let push = -data.lambda[row];
    if data.damped.is_empty() {
        return push;
    }
    let wedged = || data.damped.iter().any(|d| d.contact == contact && d.wedged);
    match data.damped_laws.iter().find(|(c, _)| *c == contact) {
        Some((_, law)) if !law.holds || wedged() => -push.abs().max(LAW_LOST_N),
        _ => push,
    }
}

/// The value of a damped slide's liftoff guard where its law has stopped holding (N): a
/// clear negative, past any arming margin.
const LAW_LOST_N: f64 = 1.0;

/// Moves the law of each damped slide of `mode` (prepared in `data` at `(t, q, q̇)`) to the
/// piece where the slide's own rates lie — the rates the segment starts from
/// ([`consistent_rates`]): a servo that the slide's rates saturate (or release) puts the
/// slide on another affine piece of the law than the one it was solved on. Whether every
/// law was on its slide's piece already (`Some(true)`; a mode without damped slides too);
/// `Some(false)` where one moved (the caller solves the slides again); `None` where a law
/// does not hold at its slide's rates (both servos saturated, no damping: no damped slide).
pub fn laws_on_slide_pieces(
    model: &Model,
    ctrl: &dyn Controller,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
    data: &mut Data,
) -> Option<bool> {
    if data.damped.is_empty() {
        return Some(true);
    }
    let mut v = qd.to_vec();
    for d in &data.damped {
        let Some(chain) = damped_chain(model, d.contact) else {
            continue;
        };
        for (j, r) in chain.zip(d.rates.iter()) {
            v[j] = *r;
        }
    }
    let mut scratch = LawScratch::default();
    let mut settled = true;
    for d in &data.damped {
        let Some((_, law)) = data.damped_laws.iter_mut().find(|(c, _)| *c == d.contact) else {
            continue;
        };
        let mut fresh = empty_law(law.joints.clone());
        if law_into(model, ctrl, (t, q, &v), mode, &mut fresh, &mut scratch) != Some(true) {
            return None;
        }
        if law.holds && same_piece(law, &fresh, &scratch.damping) {
            continue;
        }
        std::mem::swap(&mut fresh.damping, &mut scratch.damping);
        fresh.saturated = scratch.saturated;
        fresh.holds = true;
        *law = fresh;
        settled = false;
    }
    Some(settled)
}

/// Whether the law `fresh` (its damping `k`), linearized at other rates, is the affine
/// piece `law` is: the same damping, and the same torque at `law`'s rates,
/// `T_f − K (θ̇_c − θ̇_f) = T_c`, within [`PIECE_TOL`] — a servo saturated at either end of
/// its range, or inside it, is each its own piece.
fn same_piece(law: &ChainLaw, fresh: &ChainLaw, k: &DMatrix<f64>) -> bool {
    let n = law.joints.len();
    if law.damping.shape() != (n, n) || k.shape() != (n, n) {
        return false;
    }
    let scale = |m: &[f64]| m.iter().fold(1.0f64, |a, x| a.max(x.abs()));
    let k_tol = PIECE_TOL * scale(k.as_slice());
    if (law.damping.as_slice().iter().zip(k.as_slice())).any(|(a, b)| (a - b).abs() > k_tol) {
        return false;
    }
    let t_tol = PIECE_TOL * scale(law.torque.as_slice()).max(scale(fresh.torque.as_slice()));
    (0..n).all(|i| {
        let dk: f64 = (0..n)
            .map(|j| k[(i, j)] * (law.rates[j] - fresh.rates[j]))
            .sum();
        (fresh.torque[i] - dk - law.torque[i]).abs() <= t_tol
    })
}

/// The relative tolerance of [`same_piece`]: far above the differenced damping's round-off
/// (some `1e-10` per N m), far below a servo's jump between its limits.
const PIECE_TOL: f64 = 1e-6;

/// The passes of [`prepare_on_pieces`]: each solves the slides on the pieces the last
/// pass's rates lie on (a Newton step on the piecewise affine law, exact within a piece).
const PIECE_PASSES: usize = 4;

/// `data` (its state prepared at `(q, q̇)`) prepared in `mode` ([`Data::prepare_mode`]) with
/// each damped slide solved on the piece of its law where its own rates lie
/// ([`laws_on_slide_pieces`]), within [`PIECE_PASSES`] passes: the preparation's result, or
/// `None` where a slide finds no such piece.
pub fn prepare_on_pieces(
    model: &Model,
    terrain: &dyn Terrain,
    ctrl: &dyn Controller,
    (t, q, qd): (f64, &[f64], &[f64]),
    mode: ContactMode,
    data: &mut Data,
) -> Result<Option<Result<(), SingularityKind>>, CoreError> {
    let mut prepared = data.prepare_mode(model, terrain, mode, qd)?;
    for _ in 0..PIECE_PASSES {
        if prepared.is_err() {
            return Ok(Some(prepared));
        }
        match laws_on_slide_pieces(model, ctrl, (t, q, qd), mode, data) {
            Some(true) => return Ok(Some(prepared)),
            Some(false) => prepared = data.prepare_mode(model, terrain, mode, qd)?,
            None => return Ok(None),
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::{cholesky_in_place, Stencil};
    use nalgebra::DMatrix;

    /// The Cholesky factor in place is nalgebra's (`Cholesky::new`, what it replaces) bit
    /// for bit — whether it exists, and its lower triangle where it does — on symmetric
    /// matrices of 1 to 6 rows: positive definite, indefinite, and singular positive
    /// semidefinite ones (`C Cᵀ` of a rank below `n`, whose last pivots are round-off of
    /// either sign or exactly zero), with the upper triangle left out of the buffer.
    #[test]
    fn the_factor_in_place_is_nalgebras_bit_for_bit() {
        // entries spread over [lo, hi) by the fractional parts of a sine's large multiples
        let mut drawn = 0.0_f64;
        let mut uniform = |lo: f64, hi: f64| {
            drawn += 1.0;
            lo + (hi - lo) * ((drawn * 12.9898).sin() * 43758.5453).rem_euclid(1.0)
        };
        let (mut held, mut failed) = (0, 0);
        for n in 1..=6 {
            for case in 0..300 {
                let rank = if case % 3 == 2 { n - 1 } else { n };
                let c = DMatrix::from_fn(n, rank.max(1), |_, _| uniform(-1.0, 1.0));
                let mut m = &c * c.transpose();
                if case % 3 == 1 {
                    // indefinite, or definite with a small margin
                    m -= DMatrix::identity(n, n) * uniform(0.0, 0.5);
                }
                if rank == 0 {
                    m.fill(0.0);
                }
                let mut lower = m.as_slice().to_vec();
                for col in 0..n {
                    for row in 0..col {
                        lower[col * n + row] = f64::NAN;
                    }
                }
                let ours = cholesky_in_place(&mut lower, n);
                let theirs = m.clone().cholesky().map(|f| f.unpack_dirty());
                assert_eq!(ours, theirs.is_some(), "n = {n}, {m}");
                let Some(l) = theirs else {
                    failed += 1;
                    continue;
                };
                for col in 0..n {
                    for row in col..n {
                        let i = col * n + row;
                        assert_eq!(lower[i].to_bits(), l[(row, col)].to_bits(), "n = {n}, {m}");
                    }
                }
                held += 1;
            }
        }
        assert!(held > 600 && failed > 300, "{held} held, {failed} failed");
    }

    /// The stencil read off the sorted instants by bisection is the one of the rule itself —
    /// backward where an event lies in `(t, t + 2h]`, else forward where one lies in
    /// `(t − 2h, t]`, else central — scanned over the events in any order, at instants on,
    /// between and at the reach of events (the reach's bounds included and excluded).
    #[test]
    fn the_bisected_stencil_is_the_rule() {
        let rule = |events: &[f64], t: f64, h: f64| {
            let reach = 2.0 * h;
            if events.iter().any(|&e| e > t && e <= t + reach) {
                Stencil::Backward
            } else if events.iter().any(|&e| e <= t && e > t - reach) {
                Stencil::Forward
            } else {
                Stencil::Central
            }
        };
        let h = 0.25;
        let events = [3.0, -1.0, 0.5, 0.75, 2.0, 0.0, 3.0];
        let mut sorted = events.to_vec();
        sorted.sort_by(f64::total_cmp);
        let mut seen = [0; 3];
        for i in -16..=20 {
            let t = f64::from(i) * 0.125 - 0.0625 * f64::from(i % 2);
            let s = Stencil::clear_of(&sorted, t, h);
            assert_eq!(s, rule(&events, t, h), "t = {t}");
            seen[s as usize] += 1;
        }
        assert!(seen.iter().all(|&n| n > 0), "{seen:?}");
        assert_eq!(Stencil::clear_of(&[], 0.0, h), Stencil::Central);
    }
}
