//! Frictionless impact and liftoff complementarity as convex QPs (Clarabel), for contact sets
//! too large to enumerate.
//!
//! **Problem.** For frictionless contacts (normal rows only) the impulse–velocity
//! complementarity (5.28)–(5.29) and the force–acceleration complementarity (5.19)–(5.20) are
//! linear complementarity problems with the Delassus operator of the candidate contacts. With
//! `p = U(·)` the pushing normal impulse (or force) of each candidate (`U(x) = −x` on a normal
//! row, so `p ≥ 0` is pushing):
//!
//! ```text
//! find p ≥ 0 with v = W p + b ≥ 0 and pᵢ vᵢ = 0         (the LCP)
//! ⇔ p ∈ argmin { ½ pᵀ W p + bᵀ p : p ≥ 0 }                (its convex QP, W ⪰ 0)
//! ```
//!
//! where `v` is the normal separation velocity (impact) or acceleration (liftoff) of each
//! candidate, positive away from the ground. The KKT conditions of the QP *are* the LCP (the
//! multiplier of `p ≥ 0` is `v`), so every QP minimiser is a complementary solution and vice
//! versa; Theorem 5.6 (5.33)–(5.37) shows that `v_k > 0` for a left-out contact is the
//! thesis's "`U_k(P_{λ,K}) < 0` in `K = J ∪ {k}`" (Theorem 5.5 for forces).
//!
//! **Delassus operator.** Let `d` be the coordinates that the core keeps in the KKT system in
//! flight ([`Data::prepare`] with [`ContactMode::FLIGHT`]: every coordinate except the free
//! massless joints of thesis 5.1.1), `A` the normal rows of the candidates (each one a
//! [`ContactKind::Slide`] contact, assembled by the core's [`Constraints`], rows in ascending
//! contact order as in [`ContactMode::rows`]), and `M̄_dd⁻¹` the flight block `M†` of the core's
//! [`selfmanip_core::KktFactorization`] (thesis (5.2) with no constraint rows). Then
//!
//! ```text
//! Y = M̄_dd⁻¹ A_dᵀ            (one KKT solve per candidate; q̇ changes by Y p)
//! W = A_d Y = A_d M̄_dd⁻¹ A_dᵀ (n×n, symmetric positive semi-definite, rank ≤ |d|)
//! ```
//!
//! For any contact set `J` with independent rows this reproduces the core: the plastic impulse
//! (5.10) `P_{λ,J} = −Λ_J A_J q̇⁻` equals `−p_J` with `W_JJ p_J = −A_J q̇⁻`, because
//! `Λ_J = −W_JJ⁻¹` when `M̄_dd` is invertible. A candidate on a massless limb that is free in
//! flight has no finite Delassus column (the thesis's point in 5.1.3 that its separation
//! velocity is undefined); such candidates are rejected with
//! [`ContactQpError::MasslessCandidate`] — leave them to the enumeration with the
//! pseudo-impulse. Massless limbs that carry no candidate are fine (they keep their velocity,
//! as in [`selfmanip_core::plastic_impact`]).
//!
//! **Solve.** Clarabel solves the QP in its low-rank form (`u = F p`, `W = FᵀF` with
//! `F = L⁻¹A_dᵀ`, `M̄_dd = LLᵀ`): `min ½uᵀu + bᵀp` s.t. `Fp − u = 0`, `p ≥ 0`. Its answer
//! only *classifies* the contacts; a basic set `B` (independent rows) is extracted from its
//! support by walking along null directions of `W`, and the returned numbers come from the
//! exact equality solve `W_BB p_B = −b_B`, checked against complementarity (`p_B ≥ 0`,
//! `v ≥ 0` off `B`) with a relative tolerance. A failed check is repaired by single
//! principal pivots (add the most penetrating contact, drop the most pulling one); if that
//! does not settle, the outcome is a typed [`ContactQpError::Inconsistent`], never a guess.
//!
//! **Uniqueness.** `q̇⁺ = q̇⁻ + Y p` (and `q̈`) is the same for every solution (`W p` is unique
//! for a convex QP, and `Y p` with it), but the impulses are not always. From the exact
//! solution: a left-out contact that touches with zero velocity either has its row in the
//! span of the basis's rows — impulse can then be shifted onto it (more than two points of a
//! rigid body on a flat floor): [`Ambiguity::dependent`] — or not — then it may join or
//! leave the set at no cost: [`Ambiguity::ties`] (so may a basis contact with zero impulse).
//! With neither, `B` is independent, `p_B > 0` and every other contact separates strictly:
//! the solution is unique ([`QpOutcome::Unique`]). Otherwise the outcome is
//! [`QpOutcome::Ambiguous`] and the solution returned is the basic one, whose mode has
//! independent rows and can be prepared and flowed.
#![allow(non_snake_case)]
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};
use nalgebra::{DMatrix, DVector};
use selfmanip_core::constraint::Constraints;
use selfmanip_core::{ContactKind, ContactMode, CoreError, Data, Model, Terrain};
use thiserror::Error;

/// Why the QP path could not produce a solution.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum ContactQpError {
    #[error(transparent)]
    Core(#[from] CoreError),
    #[error("invalid candidate contacts: {reason}")]
    InvalidCandidates { reason: String },
    #[error("invalid argument `{field}`: {reason}")]
    InvalidArgument { field: &'static str, reason: String },
    /// The candidate sits on a massless limb that is free in flight: its Delassus column is
    /// undefined (thesis 5.1.3). Use the enumeration with the pseudo-impulse.
    #[error("candidate contact {contact} lies on a massless limb that is free in flight: no finite Delassus column (thesis 5.1.3); enumerate instead")]
    MasslessCandidate { contact: usize },
    /// No complementary contact set exists: the QP is unbounded below (some pushing
    /// combination lowers the objective forever) or infeasible. For a frictionless impact
    /// this cannot happen in exact arithmetic; for liftoff it can (curved terrain, `Ȧq̇`).
    #[error("no complementary contact set: Clarabel reports {status:?}")]
    NoSolution { status: SolverStatus },
    /// Clarabel stopped without a solution of full accuracy (iteration limit, numerical
    /// error, insufficient progress, reduced accuracy).
    #[error("Clarabel failed ({status:?}) after {iterations} iterations")]
    SolverFailed {
        status: SolverStatus,
        iterations: u32,
    },
    /// The exact solve on the basis chosen from the QP violates complementarity beyond the
    /// tolerance: `quantity` is `"push"` (a contact of the basis would pull) or `"separation"`
    /// (a left-out contact would penetrate), `value` is relative to the problem's scale.
    #[error("the QP's contact set fails the exact complementarity check at contact {contact}: {quantity} = {value:.3e} (relative)")]
    Inconsistent {
        contact: usize,
        quantity: &'static str,
        value: f64,
    },
}

/// Tolerances of the QP path (all relative: impulses to `‖b‖∞ / max Wᵢᵢ`, velocities to
/// `‖b‖∞`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactQpOptions {
    /// Below this, an impulse (force) or a separation velocity (acceleration) counts as zero
    /// when reporting ties, and a negative one is still accepted by the exact check.
    pub zero_tolerance: f64,
    /// Relative eigenvalue of a Delassus block below which its contacts are dependent.
    pub rank_tolerance: f64,
    /// Clarabel's gap and feasibility tolerances.
    pub solver_tolerance: f64,
    pub max_iterations: u32,
}

impl Default for ContactQpOptions {
    fn default() -> Self {
        ContactQpOptions {
            zero_tolerance: 1e-9,
            rank_tolerance: 1e-9,
            solver_tolerance: 1e-8,
            max_iterations: 100,
        }
    }
}

/// Why a solution is not the only one.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Ambiguity {
    /// The contacts that carry impulse (force) in *some* solution, when their Delassus block
    /// is singular (rank [`Ambiguity::dependent_rank`], the size of the returned basis): the
    /// distribution among them — and hence the active set — is not unique. `q̇⁺` (`q̈`) is.
    /// Empty otherwise.
    pub dependent: Vec<usize>,
    pub dependent_rank: usize,
    /// Contacts with zero impulse (force) *and* zero separation velocity (acceleration):
    /// keeping or dropping them both satisfy complementarity.
    pub ties: Vec<usize>,
}

/// A unique solution, or one of several.
#[derive(Debug, Clone, PartialEq)]
pub enum QpOutcome<S> {
    /// The active set, the impulses (forces) and the velocities are unique.
    Unique(S),
    /// Several complementary contact sets: `S` is one of them (a basic one, whose mode has
    /// independent rows), with the same `q̇⁺` (`q̈`) as all the others.
    Ambiguous(S, Ambiguity),
}

impl<S> QpOutcome<S> {
    pub fn solution(&self) -> &S {
        match self {
            QpOutcome::Unique(s) | QpOutcome::Ambiguous(s, _) => s,
        }
    }
    pub fn into_solution(self) -> S {
        match self {
            QpOutcome::Unique(s) | QpOutcome::Ambiguous(s, _) => s,
        }
    }
    pub fn ambiguity(&self) -> Option<&Ambiguity> {
        match self {
            QpOutcome::Unique(_) => None,
            QpOutcome::Ambiguous(_, a) => Some(a),
        }
    }
    pub fn is_unique(&self) -> bool {
        matches!(self, QpOutcome::Unique(_))
    }
}

/// Diagnostics of one QP solve.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct QpInfo {
    pub iterations: u32,
    /// Clarabel's own solve time (s), excluding the Delassus assembly.
    pub solve_time_s: f64,
    /// Rank of the full Delassus operator `W` of the candidates.
    pub delassus_rank: usize,
    /// Exact-check pivots after the IPM's classification (0 when it was right).
    pub pivots: usize,
}

/// The contact set a QP keeps at an impact or a liftoff, and how the solve went.
#[derive(Debug, Clone, PartialEq)]
pub struct QpContactSet {
    /// The contact set after the event (a basic one, see [`Ambiguity`]), every contact
    /// [`ContactKind::Slide`]. Ties whose rows are independent of the others are kept, as in
    /// the enumeration: a contact is dropped only if holding it needs a pulling impulse
    /// (5.29) or force (5.20).
    pub mode: ContactMode,
    /// Contacts that carry impulse (force) in some solution: the contacts of `mode` except
    /// ties, or [`Ambiguity::dependent`] when that is non-empty.
    pub active: Vec<usize>,
    /// The candidates, ascending: the order of every per-candidate vector of the solution.
    pub candidates: Vec<usize>,
    pub info: QpInfo,
}

impl QpContactSet {
    /// The entries of the per-candidate vector `per_candidate` that belong to the contacts
    /// of `mode`, in row order (ascending contact index).
    pub fn in_mode(&self, per_candidate: &[f64]) -> Vec<f64> {
        self.candidates
            .iter()
            .zip(per_candidate)
            .filter(|(k, _)| self.mode.contains(**k))
            .map(|(_, &x)| x)
            .collect()
    }
}

/// A frictionless plastic impact among the candidates (thesis (5.10), (5.28)–(5.29)).
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactSolution {
    pub set: QpContactSet,
    /// Plastic normal impulse `P_λ` (5.10) of each candidate in `set.mode` (N·s, row
    /// convention: negative = pushing; zero off the mode). Equals
    /// [`selfmanip_core::plastic_impact`] into that mode.
    pub impulse: Vec<f64>,
    /// Pseudo-impulse `P_δ` (5.39) of each candidate in `set.mode` (zero off it); empty
    /// without a pseudo-impulse.
    pub pseudo_impulse: Vec<f64>,
    /// Normal separation velocity `A_k q̇⁺` of each candidate (m/s, positive = separating).
    pub normal_velocity: Vec<f64>,
    /// Post-impact velocity (5.52): the plastic impact into `set.mode`.
    pub qd_plus: DVector<f64>,
}

/// Contacts kept at a liftoff event (thesis (5.19)–(5.20)).
#[derive(Debug, Clone, PartialEq)]
pub struct LiftoffSolution {
    pub set: QpContactSet,
    /// Normal force `λ` of each candidate in `set.mode` (N, row convention: negative =
    /// pushing; zero off the mode). Equals [`selfmanip_core::forward_dynamics`] in that mode.
    pub lambda: Vec<f64>,
    /// Normal separation acceleration `A_k q̈ + Ȧ_k q̇` of each candidate (m/s²).
    pub normal_acceleration: Vec<f64>,
    /// `q̈` in `set.mode` (free massless joints: their prescribed acceleration).
    pub qdd: DVector<f64>,
}

/// [`frictionless_impact_with`] with default options.
#[allow(clippy::too_many_arguments)]
pub fn frictionless_impact(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    candidates: &[usize],
    q: &[f64],
    qd_minus: &[f64],
    pseudo: Option<(&[f64], f64)>,
) -> Result<QpOutcome<ImpactSolution>, ContactQpError> {
    frictionless_impact_with(
        model,
        data,
        terrain,
        candidates,
        q,
        qd_minus,
        pseudo,
        &ContactQpOptions::default(),
    )
}

/// Impulse–velocity complementarity (5.28)–(5.29) of a frictionless plastic impact (5.10)
/// among `candidates` (contact indices, any order, no repeats), solved as the QP
/// `min ½ pᵀWp + bᵀp, p ≥ 0` with `b = A q̇⁻` (module docs).
///
/// **Pseudo-impulse.** With `pseudo = Some((tau, δt))` the target velocity also receives the
/// free motion that the smooth forces `f = Υ − C̄q̇⁻ − N̄` (5.38) produce over `δt`:
/// `b = A (q̇⁻ + δt M̄_dd⁻¹ f)`. For a set `J` the QP's impulse is then exactly
/// `−U(P_{λ,J} + P_{δ,J})` of (5.39) — `P_δ = A_J† f δt` solves the same KKT system with `f δt`
/// on the right — and, by the argument of Theorem 5.6, a left-out contact separates iff
/// `U_k(P_{λ,K} + P_{δ,K}) < 0` in `K = J ∪ {k}`. So the QP applies the thesis's (5.40)
/// test `U(P_λ + P_δ) ≥ 0` to *every* contact. The enumeration in `execution.rs` uses
/// `U(P_λ)` for contacts that their own impulse holds and `U(P_λ + P_δ)` only for the others;
/// the two agree except when a contact's own impulse pushes but `P_λ + P_δ` pulls (a smooth
/// force over `δt` larger than the impact: rare for small `δt`). The pseudo-impulse only
/// selects the set (5.40): `q̇⁺`, `impulse` and `normal_velocity` are those of the plastic
/// impact into `mode`, and `pseudo_impulse` is `P_δ` in `mode`.
#[allow(clippy::too_many_arguments)]
pub fn frictionless_impact_with(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    candidates: &[usize],
    q: &[f64],
    qd_minus: &[f64],
    pseudo: Option<(&[f64], f64)>,
    options: &ContactQpOptions,
) -> Result<QpOutcome<ImpactSolution>, ContactQpError> {
    check_options(options)?;
    if let Some((tau, dt)) = pseudo {
        check_tau(model, tau)?;
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(ContactQpError::InvalidArgument {
                field: "delta_t",
                reason: format!("must be finite and non-negative, got {dt}"),
            });
        }
    }
    let cand = sorted_candidates(model, candidates)?;
    let del = Delassus::assemble(model, data, terrain, &cand, q, qd_minus)?;
    // b⁰ = A q̇⁻ : normal velocities before the impact
    let b0 = &del.a * DVector::from_column_slice(qd_minus);
    // b = A (q̇⁻ + δt M̄_dd⁻¹ f) with the pseudo-impulse
    let (b, free_motion) = match pseudo {
        Some((tau, dt)) if dt > 0.0 => {
            let x = del.free_acceleration(data, model, tau, None);
            (&b0 + dt * (&del.a * &x), Some(dt))
        }
        _ => (b0.clone(), None),
    };
    let sol = solve_lcp(&del.w, &del.f, &b, options)?;
    // the reset is the plastic impact into the basis: W_BB p⁰_B = −b⁰_B
    let p0 = match free_motion {
        None => sol.p.clone(),
        Some(_) => solve_on_basis(&del.w, &del.f, &b0, &sol.basis, options)?,
    };
    let qd_plus = DVector::from_column_slice(qd_minus) + &del.y * &p0;
    let normal_velocity = (&b0 + &del.w * &p0).iter().copied().collect();
    let pseudo_impulse = match free_motion {
        None => Vec::new(),
        Some(_) => (0..cand.len()).map(|i| -(sol.p[i] - p0[i])).collect(),
    };
    let solution = ImpactSolution {
        set: sol.contact_set(&cand, del.rank(options)),
        impulse: p0.iter().map(|&p| -p).collect(),
        pseudo_impulse,
        normal_velocity,
        qd_plus,
    };
    Ok(sol.outcome(solution, &cand))
}

/// [`frictionless_liftoff_with`] with default options.
#[allow(clippy::too_many_arguments)]
pub fn frictionless_liftoff(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    active: &[usize],
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    free_qdd: Option<&[f64]>,
) -> Result<QpOutcome<LiftoffSolution>, ContactQpError> {
    frictionless_liftoff_with(
        model,
        data,
        terrain,
        active,
        q,
        qd,
        tau,
        free_qdd,
        &ContactQpOptions::default(),
    )
}

/// Force–acceleration complementarity (5.19)–(5.20) (equivalently (5.21)–(5.22), Theorem 5.5)
/// among the contacts `active` at a state where their normal velocities vanish, as the QP
/// `min ½ λ̂ᵀWλ̂ + bᵀλ̂, λ̂ = U(λ) ≥ 0` with the same Delassus operator and
/// `b = A_d M̄_dd⁻¹ (Υ − C̄q̇ − N̄ − M̄_df q̈_f) + A_f q̈_f + Ȧq̇`: the separation accelerations
/// in flight (thesis (5.3) with no contact, `q̈_f` the prescribed accelerations of free massless
/// joints, `free_qdd`, default 0). For any set `J` the QP's force is the core's (5.4)
/// `λ_J = A_J†(Υ − C̄q̇ − N̄) − Λ_J Ȧ_J q̇`.
#[allow(clippy::too_many_arguments)]
pub fn frictionless_liftoff_with(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    active: &[usize],
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    free_qdd: Option<&[f64]>,
    options: &ContactQpOptions,
) -> Result<QpOutcome<LiftoffSolution>, ContactQpError> {
    check_options(options)?;
    check_tau(model, tau)?;
    let cand = sorted_candidates(model, active)?;
    let del = Delassus::assemble(model, data, terrain, &cand, q, qd)?;
    if let Some(xf) = free_qdd {
        if xf.len() != data.free_joints.len() {
            return Err(CoreError::WrongLength {
                field: "free_qdd",
                expected: data.free_joints.len(),
                actual: xf.len(),
            }
            .into());
        }
        check_finite("free_qdd", xf)?;
    }
    // q̈_free: the flight acceleration (5.3) with prescribed free joints
    let x = del.free_acceleration(data, model, tau, free_qdd);
    // b = A q̈_free + Ȧq̇ : separation accelerations in flight
    let b = &del.a * &x + &del.a_dot_qd;
    let sol = solve_lcp(&del.w, &del.f, &b, options)?;
    let qdd = &x + &del.y * &sol.p;
    let normal_acceleration = (&b + &del.w * &sol.p).iter().copied().collect();
    let solution = LiftoffSolution {
        set: sol.contact_set(&cand, del.rank(options)),
        lambda: sol.p.iter().map(|&p| -p).collect(),
        normal_acceleration,
        qdd,
    };
    Ok(sol.outcome(solution, &cand))
}

fn check_options(o: &ContactQpOptions) -> Result<(), ContactQpError> {
    let bad = |field, v: f64| ContactQpError::InvalidArgument {
        field,
        reason: format!("must be finite and in (0, 1), got {v}"),
    };
    for (field, v) in [
        ("zero_tolerance", o.zero_tolerance),
        ("rank_tolerance", o.rank_tolerance),
        ("solver_tolerance", o.solver_tolerance),
    ] {
        if !(v > 0.0 && v < 1.0) {
            return Err(bad(field, v));
        }
    }
    if o.max_iterations == 0 {
        return Err(ContactQpError::InvalidArgument {
            field: "max_iterations",
            reason: "must be positive".into(),
        });
    }
    Ok(())
}

fn check_tau(model: &Model, tau: &[f64]) -> Result<(), ContactQpError> {
    if tau.len() != model.n_joints() {
        return Err(CoreError::WrongLength {
            field: "tau",
            expected: model.n_joints(),
            actual: tau.len(),
        }
        .into());
    }
    check_finite("tau", tau)
}

fn check_finite(field: &'static str, v: &[f64]) -> Result<(), ContactQpError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(CoreError::NonFinite {
            field,
            index,
            value: v[index],
        }
        .into()),
        None => Ok(()),
    }
}

/// Candidates sorted ascending; each must exist (and fit the 32-bit mode), none repeated.
fn sorted_candidates(model: &Model, candidates: &[usize]) -> Result<Vec<usize>, ContactQpError> {
    let nc = model.n_contacts();
    if let Some(&k) = candidates.iter().find(|&&k| k >= nc || k >= 32) {
        return Err(ContactQpError::InvalidCandidates {
            reason: format!(
                "no contact with index {k} (the model has {nc}; modes hold at most 32)"
            ),
        });
    }
    let mut c = candidates.to_vec();
    c.sort_unstable();
    if let Some(w) = c.windows(2).find(|w| w[0] == w[1]) {
        return Err(ContactQpError::InvalidCandidates {
            reason: format!("contact {} listed twice", w[0]),
        });
    }
    Ok(c)
}

/// The candidates at positions `basis` as frictionless contacts.
fn slide_mode(cand: &[usize], basis: &[usize]) -> ContactMode {
    basis.iter().fold(ContactMode::FLIGHT, |m, &i| {
        m.with(cand[i], ContactKind::Slide)
    })
}

/// The flight-mode Delassus operator of the candidates and its ingredients.
struct Delassus {
    /// Normal rows `A` (n×nq) and `Ȧq̇` of the candidates.
    a: DMatrix<f64>,
    a_dot_qd: DVector<f64>,
    /// `Y = M̄_dd⁻¹ A_dᵀ` scattered to all coordinates (nq×n; zero rows on free joints).
    y: DMatrix<f64>,
    /// `W = A Y` (n×n).
    w: DMatrix<f64>,
    /// Low-rank factor `F = L⁻¹ A_dᵀ` (|d|×n) with `M̄_dd = L Lᵀ`, so `W = FᵀF`.
    f: DMatrix<f64>,
}

impl Delassus {
    /// `(q, q̇)` => flight KKT (core) => candidate rows (core) => `Y`, `W`.
    fn assemble(
        model: &Model,
        data: &mut Data,
        terrain: &dyn Terrain,
        cand: &[usize],
        q: &[f64],
        qd: &[f64],
    ) -> Result<Self, ContactQpError> {
        // (q, q̇) => kinematics, M̄, C̄q̇, N̄, free massless joints, KKT of flight (c = 0)
        data.prepare(model, terrain, ContactMode::FLIGHT, q, qd)?;
        // => A, Ȧq̇ of the candidates as sliding (normal-row-only) contacts
        let mode = slide_mode(cand, &(0..cand.len()).collect::<Vec<_>>());
        mode.validate(model)?;
        let mut cons = Constraints::default();
        cons.assemble(model, &data.kin, terrain, mode, qd);
        let (n, nq) = (cand.len(), model.nq());
        debug_assert_eq!(cons.n_rows(), n);
        // a candidate that moves a free massless joint has no finite Delassus column
        for (r, &k) in cand.iter().enumerate() {
            if data.free_joints.iter().any(|&j| cons.a[(r, j)] != 0.0) {
                return Err(ContactQpError::MasslessCandidate { contact: k });
            }
        }
        // Y[:, r] = M̄_dd⁻¹ A_d[r, :]ᵀ  (KKT solve with f = A_rᵀ, no constraint rows)
        let dyn_c = &data.dynamic_coords;
        let m = dyn_c.len();
        let (mut f, mut x) = (vec![0.0; m], vec![0.0; m]);
        let mut y = DMatrix::zeros(nq, n);
        for r in 0..n {
            for (i, &c) in dyn_c.iter().enumerate() {
                f[i] = cons.a[(r, c)];
            }
            data.kkt.solve(&f, &[], &mut x, &mut []);
            for (i, &c) in dyn_c.iter().enumerate() {
                y[(c, r)] = x[i];
            }
        }
        // W = A Y, symmetrised
        let w = &cons.a * &y;
        let w = (&w + w.transpose()) * 0.5;
        // F = L⁻¹ A_dᵀ with M̄_dd = L Lᵀ: the flight KKT system has no constraint rows, so its
        // reduced mass matrix is M̄_dd itself, positive definite since `prepare` succeeded
        let m_dd = DMatrix::from_fn(m, m, |i, j| data.m_bar[(dyn_c[i], dyn_c[j])]);
        let a_dt = DMatrix::from_fn(m, n, |i, r| cons.a[(r, dyn_c[i])]);
        let chol = m_dd.cholesky().ok_or(CoreError::SingularKkt {
            kind: selfmanip_core::SingularityKind::UnconstrainedMasslessMotion,
            condition_estimate: f64::INFINITY,
        })?;
        let f = chol
            .l_dirty()
            .solve_lower_triangular(&a_dt)
            .expect("non-zero Cholesky diagonal");
        Ok(Delassus {
            a: cons.a,
            a_dot_qd: cons.a_dot_qd,
            y,
            w,
            f,
        })
    }

    /// Flight acceleration `q̈ = M̄_dd⁻¹ (Υ − C̄q̇ − N̄ − M̄_df q̈_f)` on the dynamic coordinates,
    /// `q̈_f` on the free massless joints (thesis (5.3) with no contact; `Data` prepared in
    /// flight).
    fn free_acceleration(
        &self,
        data: &mut Data,
        model: &Model,
        tau: &[f64],
        free_qdd: Option<&[f64]>,
    ) -> DVector<f64> {
        let f_full = data.generalized_force(model, tau);
        let mut out = DVector::zeros(model.nq());
        if let Some(xf) = free_qdd {
            for (i, &j) in data.free_joints.iter().enumerate() {
                out[j] = xf[i];
            }
        }
        let f: Vec<f64> = data
            .dynamic_coords
            .iter()
            .map(|&a| {
                let coupling: f64 = data
                    .free_joints
                    .iter()
                    .map(|&j| data.m_bar[(a, j)] * out[j])
                    .sum();
                f_full[a] - coupling
            })
            .collect();
        let mut x = vec![0.0; f.len()];
        data.kkt.solve(&f, &[], &mut x, &mut []);
        for (i, &a) in data.dynamic_coords.iter().enumerate() {
            out[a] = x[i];
        }
        out
    }

    fn rank(&self, o: &ContactQpOptions) -> usize {
        rank_of_columns(
            &self.f,
            &(0..self.f.ncols()).collect::<Vec<_>>(),
            o.rank_tolerance,
        )
    }
}

/// Rank of `W_SS = F_Sᵀ F_S`: singular values of the columns `idx` of `F` with `σ² > tol σ²_max`.
fn rank_of_columns(f: &DMatrix<f64>, idx: &[usize], tol: f64) -> usize {
    if idx.is_empty() {
        return 0;
    }
    let sv = f.select_columns(idx).singular_values();
    let max = sv.iter().fold(0.0f64, |a, &b| a.max(b));
    sv.iter().filter(|&&x| x * x > tol * max * max).count()
}

/// Result of the LCP in Delassus space (indices are positions in the candidate list).
struct LcpSolution {
    /// Exact basic solution: `p` (zero off the basis).
    p: DVector<f64>,
    basis: Vec<usize>,
    /// Contacts that carry impulse in some solution (basis, or the dependent set).
    active: Vec<usize>,
    ambiguity: Option<(Vec<usize>, usize, Vec<usize>)>,
    info: QpInfo,
}

impl LcpSolution {
    /// The contact set of the basis among `cand`, with the rank of the full Delassus operator.
    fn contact_set(&self, cand: &[usize], delassus_rank: usize) -> QpContactSet {
        QpContactSet {
            mode: slide_mode(cand, &self.basis),
            active: self.active.iter().map(|&i| cand[i]).collect(),
            candidates: cand.to_vec(),
            info: QpInfo {
                delassus_rank,
                ..self.info
            },
        }
    }

    fn outcome<S>(&self, s: S, cand: &[usize]) -> QpOutcome<S> {
        match &self.ambiguity {
            None => QpOutcome::Unique(s),
            Some((dep, rank, ties)) => QpOutcome::Ambiguous(
                s,
                Ambiguity {
                    dependent: dep.iter().map(|&i| cand[i]).collect(),
                    dependent_rank: *rank,
                    ties: ties.iter().map(|&i| cand[i]).collect(),
                },
            ),
        }
    }
}

/// `min ½ pᵀWp + bᵀp, p ≥ 0` by Clarabel, then classification, a basic solution on
/// independent rows, the exact solve on it and the complementarity check.
fn solve_lcp(
    w: &DMatrix<f64>,
    f: &DMatrix<f64>,
    b: &DVector<f64>,
    o: &ContactQpOptions,
) -> Result<LcpSolution, ContactQpError> {
    let n = b.len();
    check_finite("delassus", w.as_slice())?;
    check_finite("b", b.as_slice())?;
    let v_scale = if n == 0 { 0.0 } else { b.amax() };
    // nothing approaches or separates: p = 0, every candidate a tie
    if v_scale == 0.0 {
        return Ok(LcpSolution {
            p: DVector::zeros(n),
            basis: Vec::new(),
            active: Vec::new(),
            ambiguity: (n > 0).then(|| (Vec::new(), 0, (0..n).collect())),
            info: QpInfo::default(),
        });
    }
    let w_max = (0..n).map(|i| w[(i, i)]).fold(0.0f64, f64::max);
    if w_max <= 0.0 {
        return Err(ContactQpError::InvalidCandidates {
            reason: "the candidates' Delassus operator is zero".into(),
        });
    }
    let p_scale = v_scale / w_max;

    let (p_ipm, mut info) = clarabel_qp(f, b, o)?;
    let v_ipm = w * &p_ipm + b;

    // --- classify: the larger of the normalised impulse and velocity wins (complementarity
    // makes the other one small); Clarabel's support approximates the largest active set
    let support: Vec<usize> = (0..n)
        .filter(|&i| p_ipm[i] / p_scale > (v_ipm[i] / v_scale).max(0.0))
        .collect();

    let mut basis = basic_solution(w, f, support, &p_ipm, o);

    // --- exact solve on the basis and complementarity check; a wrong classification (near
    // ties) is repaired by single principal pivots
    let tol = o.zero_tolerance;
    let mut p = DVector::zeros(n);
    for _ in 0..=n {
        p = solve_on_basis(w, f, b, &basis, o)?;
        let v = w * &p + b;
        let pull = basis
            .iter()
            .map(|&i| (i, p[i] / p_scale))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let penetrate = (0..n)
            .filter(|i| !basis.contains(i))
            .map(|i| (i, v[i] / v_scale))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match (pull, penetrate) {
            (Some((i, x)), _) if x < -tol => {
                basis.retain(|&k| k != i);
                info.pivots += 1;
            }
            (_, Some((i, x))) if x < -tol => {
                basis.push(i);
                basis.sort_unstable();
                info.pivots += 1;
            }
            _ => {
                let scales = (p_scale, v_scale);
                return unique_or_ambiguous(w, f, b, (basis, p, &v), scales, info, o);
            }
        }
    }
    // pivoting did not settle: report the worst violation
    let v = w * &p + b;
    let (contact, quantity, value) = (0..n)
        .map(|i| {
            if basis.contains(&i) {
                (i, "push", p[i] / p_scale)
            } else {
                (i, "separation", v[i] / v_scale)
            }
        })
        .min_by(|a, b| a.2.total_cmp(&b.2))
        .expect("n > 0");
    Err(ContactQpError::Inconsistent {
        contact,
        quantity,
        value,
    })
}

/// `min ½ pᵀWp + bᵀp, p ≥ 0` by Clarabel on the low-rank form (`x = [p; u]`, `u = F p`,
/// `W = FᵀF`): its `p` and the solver's figures.
fn clarabel_qp(
    f: &DMatrix<f64>,
    b: &DVector<f64>,
    o: &ContactQpOptions,
) -> Result<(DVector<f64>, QpInfo), ContactQpError> {
    let n = b.len();
    // --- Clarabel on the low-rank form (x = [p; u], u = F p, W = FᵀF):
    // min ½ uᵀu + bᵀp  s.t.  F p − u = 0 (zero cone),  p ≥ 0 (s = p, non-negative cone)
    let r = f.nrows();
    let P = CscMatrix::new(
        n + r,
        n + r,
        (0..=n + r).map(|j| j.saturating_sub(n)).collect(),
        (n..n + r).collect(),
        vec![1.0; r],
    );
    let (mut ti, mut tj, mut tv) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..n {
        for i in 0..r {
            if f[(i, j)] != 0.0 {
                ti.push(i);
                tj.push(j);
                tv.push(f[(i, j)]);
            }
        }
        ti.push(r + j);
        tj.push(j);
        tv.push(-1.0);
    }
    for i in 0..r {
        ti.push(i);
        tj.push(n + i);
        tv.push(-1.0);
    }
    let A = CscMatrix::new_from_triplets(r + n, n + r, ti, tj, tv);
    let q: Vec<f64> = b
        .iter()
        .copied()
        .chain(std::iter::repeat_n(0.0, r))
        .collect();
    let zeros = vec![0.0; r + n];
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .max_iter(o.max_iterations)
        .tol_gap_abs(o.solver_tolerance)
        .tol_gap_rel(o.solver_tolerance)
        .tol_feas(o.solver_tolerance)
        .build()
        .map_err(|e| ContactQpError::InvalidArgument {
            field: "options",
            reason: e.to_string(),
        })?;
    let cones = [
        SupportedConeT::ZeroConeT(r),
        SupportedConeT::NonnegativeConeT(n),
    ];
    let mut solver = DefaultSolver::new(&P, &q, &A, &zeros, &cones, settings).map_err(|e| {
        ContactQpError::InvalidArgument {
            field: "qp",
            reason: e.to_string(),
        }
    })?;
    solver.solve();
    let sol = &solver.solution;
    match sol.status {
        SolverStatus::Solved => {}
        s @ (SolverStatus::PrimalInfeasible
        | SolverStatus::DualInfeasible
        | SolverStatus::AlmostPrimalInfeasible
        | SolverStatus::AlmostDualInfeasible) => {
            return Err(ContactQpError::NoSolution { status: s })
        }
        s => {
            return Err(ContactQpError::SolverFailed {
                status: s,
                iterations: sol.iterations,
            })
        }
    }
    let info = QpInfo {
        iterations: sol.iterations,
        solve_time_s: sol.solve_time,
        ..QpInfo::default()
    };
    Ok((DVector::from_column_slice(&sol.x[..n]), info))
}

/// A basic solution from the support of Clarabel's `p`: walk along null directions of `W_SS`
/// until the rows are independent (each walk takes one entry of `p` to zero).
fn basic_solution(
    w: &DMatrix<f64>,
    f: &DMatrix<f64>,
    support: Vec<usize>,
    p_ipm: &DVector<f64>,
    o: &ContactQpOptions,
) -> Vec<usize> {
    let mut basis = support;
    let mut p_s: Vec<f64> = basis.iter().map(|&i| p_ipm[i].max(0.0)).collect();
    loop {
        let rank = rank_of_columns(f, &basis, o.rank_tolerance);
        if rank == basis.len() {
            break;
        }
        // the first rank + 1 columns are dependent: a null vector of their block of W
        let eig = sub(w, &basis[..=rank]).symmetric_eigen();
        let imin = eig.eigenvalues.imin();
        let mut d = vec![0.0; basis.len()];
        for (i, x) in eig.eigenvectors.column(imin).iter().enumerate() {
            d[i] = *x;
        }
        if d.iter().all(|&x| x <= 0.0) {
            d.iter_mut().for_each(|x| *x = -*x);
        }
        // p ← p − t d with the largest t keeping p ≥ 0: one entry reaches zero
        let (drop, t) = (0..basis.len())
            .filter(|&i| d[i] > 0.0)
            .map(|i| (i, p_s[i] / d[i]))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("a positive entry");
        for i in 0..basis.len() {
            p_s[i] = (p_s[i] - t * d[i]).max(0.0);
        }
        basis.remove(drop);
        p_s.remove(drop);
    }

    basis
}

/// The LCP's solution on a settled `basis` (its exact `p`, velocities `v`): uniqueness from
/// the exact solution alone, the ties whose rows stay independent kept, as the enumeration
/// does.
fn unique_or_ambiguous(
    w: &DMatrix<f64>,
    f: &DMatrix<f64>,
    b: &DVector<f64>,
    (mut basis, mut p, v): (Vec<usize>, DVector<f64>, &DVector<f64>),
    (p_scale, v_scale): (f64, f64),
    info: QpInfo,
    o: &ContactQpOptions,
) -> Result<LcpSolution, ContactQpError> {
    let (n, tol) = (b.len(), o.zero_tolerance);
    // --- uniqueness, from the exact solution alone. Off the basis, a contact that
    // touches with zero impulse (v ≈ 0) either lies in the span of the basis's
    // rows — then impulse can be shifted onto it along a null direction of W:
    // dependent — or not — then it may join or leave the set at no cost: a tie.
    // A basis contact whose impulse vanishes is a tie too. Without any of these,
    // B is independent with p_B > 0 and every other contact separates strictly:
    // the solution is unique.
    let rank = basis.len();
    let (mut dependent, mut ties) = (Vec::new(), Vec::new());
    for i in 0..n {
        if basis.contains(&i) {
            if p[i] / p_scale <= tol {
                ties.push(i);
            }
        } else if v[i] / v_scale <= tol {
            let mut with_i = basis.clone();
            with_i.push(i);
            if rank_of_columns(f, &with_i, o.rank_tolerance) == rank {
                dependent.push(i);
            } else {
                ties.push(i);
            }
        }
    }
    if !dependent.is_empty() {
        dependent.extend(&basis);
        dependent.sort_unstable();
    }
    let active: Vec<usize> = if dependent.is_empty() {
        &basis
    } else {
        &dependent
    }
    .iter()
    .copied()
    .filter(|i| !ties.contains(i))
    .collect();
    // keep the ties whose rows stay independent, as the enumeration does: a
    // contact is dropped only if holding it needs a pulling impulse (5.29)
    let mut keep = basis.clone();
    for &i in &ties {
        if !keep.contains(&i) {
            keep.push(i);
            if rank_of_columns(f, &keep, o.rank_tolerance) < keep.len() {
                keep.pop();
            }
        }
    }
    if keep.len() > basis.len() {
        keep.sort_unstable();
        let p2 = solve_on_basis(w, f, b, &keep, o)?;
        let v2 = w * &p2 + b;
        let complementary = (0..n).all(|i| {
            if keep.contains(&i) {
                p2[i] / p_scale >= -tol
            } else {
                v2[i] / v_scale >= -tol
            }
        });
        if complementary {
            (basis, p) = (keep, p2);
        }
    }
    let ambiguity = (!dependent.is_empty() || !ties.is_empty()).then_some((dependent, rank, ties));
    Ok(LcpSolution {
        p,
        basis,
        active,
        ambiguity,
        info,
    })
}

/// `p` with `W_BB p_B = −b_B` on the basis and zero elsewhere (Cholesky; the basis has
/// independent rows by construction).
fn solve_on_basis(
    w: &DMatrix<f64>,
    f: &DMatrix<f64>,
    b: &DVector<f64>,
    basis: &[usize],
    o: &ContactQpOptions,
) -> Result<DVector<f64>, ContactQpError> {
    let mut p = DVector::zeros(b.len());
    if basis.is_empty() {
        return Ok(p);
    }
    let wbb = sub(w, basis);
    let singular = || ContactQpError::Inconsistent {
        contact: basis[0],
        quantity: "independence",
        value: 0.0,
    };
    if rank_of_columns(f, basis, o.rank_tolerance) < basis.len() {
        return Err(singular());
    }
    let chol = wbb.cholesky().ok_or_else(singular)?;
    let rhs = DVector::from_iterator(basis.len(), basis.iter().map(|&i| -b[i]));
    let pb = chol.solve(&rhs);
    for (k, &i) in basis.iter().enumerate() {
        p[i] = pb[k];
    }
    Ok(p)
}

/// The principal submatrix `W[idx, idx]`.
fn sub(w: &DMatrix<f64>, idx: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(idx.len(), idx.len(), |i, j| w[(idx[i], idx[j])])
}
