//! A plastic impact with Coulomb friction at every contact: the velocity-level complementarity
//! problem of the time-stepping schemes (Stewart & Trinkle 1996; Anitescu & Potra 1997;
//! Stewart 2000, "Rigid-body dynamics with friction and impact", section 4), taken over one
//! instant. It resolves a Painlevé end that the engine's own impact law (5.10) with
//! Assumption 5.9 (a sliding contact takes a frictionless impulse, a sticking one a
//! plastic stick) cannot: a leg touching down while another holds, where the frictionless
//! impulse leaves the holder on a slide with no consistent continuation and the stick pulls
//! or leaves its cone (`docs/singular-transitions.md`, section 8).
//!
//! ```text
//! candidates C (the contacts held, and those touching down), at (q, q̇⁻)
//!   rows A (normal; tangential where μ > 0), W = A M̄⁻¹ Aᵀ, v⁻ = A q̇⁻
//!   p = −P the impulse on the robot in row coordinates: q̇⁺ = q̇⁻ + M̄⁻¹ Aᵀ p, v⁺ = v⁻ + W p
//! each contact k takes one state:
//!   separate   p_k = 0,                         v_n⁺ ≥ 0
//!   stick      v_n⁺ = 0, v_t⁺ = 0,              p_n ≥ 0, |p_t| ≤ μ p_n
//!   slip σ     v_n⁺ = 0, p_t = −μ σ p_n,         p_n ≥ 0, σ v_t⁺ ≥ 0       (σ = ±1)
//!   (frictionless: separate, or slide: v_n⁺ = 0, p_n ≥ 0; μ = ∞: separate or stick)
//! every combination of states is one square linear solve; the solutions are all the
//! complementarity problem's solutions (4^|C| combinations, |C| ≤ 4 on a planar robot)
//! ```
//!
//! **Energy.** With `Δq̇ = M̄⁻¹Aᵀp`, `ΔT = ½(q̇⁺ + q̇⁻)ᵀAᵀp = (v⁺)ᵀp − ½ pᵀWp`, and each
//! contact's `v⁺ · p_k` is `v_n⁺ p_n + v_t⁺ p_t = 0 − μ p_n |v_t⁺| ≤ 0` by its state, so
//! `ΔT = −Σ μ p_n |v_t⁺| − ½ pᵀWp ≤ 0`: the impact never adds kinetic energy (checked on
//! each solution, and an outcome that would is refused).
//!
//! **Which solution.** The velocity problem of a Painlevé configuration may have several
//! solutions (its matrix is not a P-matrix); solutions with the same `q̇⁺` (a slip whose
//! velocity after is zero is a stick at its cone's edge) are one outcome. The caller keeps
//! the outcomes after which the contacts kept also hold in force (5.19)–(5.20), and accepts
//! only a single survivor.
//!
//! **Derivative.** On its active set (each contact's state, a slip's `σ`, held) the impact
//! is a smooth map of `(q, q̇⁻)`, the inertia parameters and each `μ`: the implicit function
//! theorem on its linear system gives [`coulomb_impact_jacobian`], the reset Jacobian of the
//! sensitivity pass at a jam (`crate::sensitivity`).
//!
//! Offered only where the Delassus operator exists: every coordinate carries inertia
//! (no free massless joint, no locked joint) — a massless leg's contact has no finite
//! impulse response (thesis 5.1.3), and its own impacts are the thesis's.
use nalgebra::{DMatrix, DVector};
use selfmanip_core::constraint::Constraints;
use selfmanip_core::contact::{ContactKind, RowDirection};
use selfmanip_core::model::Friction;
use selfmanip_core::tangent::{impact_partials, BodyParameter, StatePartials, TangentError};
use selfmanip_core::{ContactMode, CoreError, Data, Model, Terrain};

/// The state a contact takes in the impact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactImpact {
    /// No impulse; its normal velocity after is non-negative (separating or grazing).
    Separate,
    /// Its velocity after is zero; its impulse pushes and lies in its cone.
    Stick,
    /// Its normal velocity after is zero and its impulse lies on the cone edge that opposes
    /// its sliding velocity after; `sigma` is the sign of that velocity in the tangential
    /// row, `A_t q̇⁺` (frictionless contacts: `sigma = 0`).
    Slip { sigma: f64 },
}

/// One solution of the impact's complementarity problem.
#[derive(Debug, Clone, PartialEq)]
pub struct CoulombImpact {
    /// The candidates and the state each takes (ascending contact index).
    pub states: Vec<(usize, ContactImpact)>,
    /// The mode after: sticking contacts stick, slipping ones slide, separating ones leave.
    pub mode: ContactMode,
    /// The contact impulse in the rows of [`Self::mode`], in the core's convention
    /// (`P = −p`: a pushing normal impulse is negative, `docs/conventions.md`). A slipping
    /// contact has only its normal row there (its friction is no row of the mode, as a
    /// sliding contact's kinetic friction is none in the flow): its whole impulse is in
    /// [`Self::contact_impulses`].
    pub impulse: Vec<f64>,
    /// Each candidate's impulse `(contact, P_t, P_n)` in the rows' convention: the world
    /// impulse on the robot is `P_t t̂ + P_n n̂` (`n̂` into the ground, `t̂` the plane's tangent,
    /// [`selfmanip_core::contact::row_direction`]).
    pub contact_impulses: Vec<(usize, f64, f64)>,
    /// `q̇⁺`.
    pub qd_plus: Vec<f64>,
    /// Row velocities after the impact of every candidate, `(contact, v_t⁺, v_n⁺)` (`v_t⁺`
    /// zero for frictionless contacts; `v_n⁺` positive away from the ground).
    pub velocity_after: Vec<(usize, f64, f64)>,
    /// `ΔT = (v⁺)ᵀp − ½ pᵀWp` (J), never positive.
    pub kinetic_change: f64,
}

/// Why the problem was not set up.
#[derive(Debug, Clone, PartialEq)]
pub enum NotOffered {
    /// A coordinate without inertia (a free or locked massless joint): no Delassus operator.
    Massless,
    /// More candidates than [`MAX_CANDIDATES`].
    TooMany,
}

/// The enumeration's limit: `4^6 = 4096` small solves.
pub const MAX_CANDIDATES: usize = 6;

/// The contact's friction coefficient for the impact (0 for a frictionless contact).
pub(crate) fn mu_of(model: &Model, k: usize) -> f64 {
    match model.contacts[k].friction {
        Friction::Sticking { mu } => mu,
        Friction::Sliding => 0.0,
    }
}

/// Every solution of the Coulomb plastic impact among `candidates` at `(q, q̇⁻)` (module
/// docs), distinct in `q̇⁺`, or why it is not offered. `data` is prepared in flight.
pub fn coulomb_impacts(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    candidates: &[usize],
    q: &[f64],
    qd_minus: &[f64],
) -> Result<Result<Vec<CoulombImpact>, NotOffered>, CoreError> {
    let mut cand = candidates.to_vec();
    cand.sort_unstable();
    cand.dedup();
    if cand.len() > MAX_CANDIDATES {
        return Ok(Err(NotOffered::TooMany));
    }
    if !data.locked.is_empty() {
        return Ok(Err(NotOffered::Massless));
    }
    data.prepare_geometry(model, terrain, ContactMode::FLIGHT, q, qd_minus)?;
    let (all, idx) = impact_rows(model, &cand);
    let mut cons = Constraints::default();
    cons.assemble(model, &data.kin, terrain, all, qd_minus);
    let Some(chol) = data.m_bar.clone().cholesky() else {
        return Ok(Err(NotOffered::Massless));
    };
    let y = chol.solve(&cons.a.transpose()); // M̄⁻¹ Aᵀ (nq × rows)
    let w = &cons.a * &y;
    let w = (&w + w.transpose()) * 0.5;
    let qd0 = DVector::from_column_slice(qd_minus);
    let v0 = &cons.a * &qd0;
    let scale_v = v0.amax().max(1e-9);
    let tol_v = 1e-9 * scale_v + 1e-12;
    // states per candidate: 0 separate, 1 stick, 2 slip +, 3 slip −; frictionless: 0, 2
    let n = cand.len();
    let mut out: Vec<CoulombImpact> = Vec::new();
    let mut code = vec![0usize; n];
    'combos: loop {
        if let Some(sol) = solve_combo(model, &cand, &idx, &code, &w, &y, &v0, &qd0, tol_v) {
            let dup = out.iter().position(|o| {
                o.qd_plus
                    .iter()
                    .zip(&sol.qd_plus)
                    .all(|(a, b)| (a - b).abs() <= 1e-8 * (1.0 + qd0.amax()))
            });
            match dup {
                None => out.push(sol),
                // the same motion: keep the one with more contacts held, sticking first
                Some(i) if rank(&sol) > rank(&out[i]) => out[i] = sol,
                Some(_) => {}
            }
        }
        // next combination
        for (i, c) in code.iter_mut().enumerate() {
            let frictionless = idx[i].1.is_none();
            // a contact that never slips (μ = ∞) separates or sticks
            let never_slips = !mu_of(model, cand[i]).is_finite();
            *c = match (*c, frictionless, never_slips) {
                (0, true, _) => 2,
                (2, true, _) => 4,
                (1, _, true) => 4,
                (x, _, _) => x + 1,
            };
            if *c < 4 {
                continue 'combos;
            }
            *c = 0;
        }
        break;
    }
    Ok(Ok(out))
}

/// The rows of the impact among the candidates `cand` (ascending): the mode whose rows they
/// are (a tangential row where the contact has friction, and its normal row) and each
/// candidate's `(normal row, tangential row)`.
fn impact_rows(model: &Model, cand: &[usize]) -> (ContactMode, Vec<(usize, Option<usize>)>) {
    let mut all = ContactMode::FLIGHT;
    for &k in cand {
        let kind = if mu_of(model, k) > 0.0 {
            ContactKind::Stick
        } else {
            ContactKind::Slide
        };
        all = all.with(k, kind);
    }
    let rows: Vec<_> = all.rows().collect();
    let row_of = |k: usize, dir: RowDirection| {
        rows.iter()
            .position(|r| r.contact == k && r.direction == dir)
    };
    let idx = cand
        .iter()
        .map(|&k| {
            (
                row_of(k, RowDirection::Normal).expect("a normal row"),
                row_of(k, RowDirection::Tangential),
            )
        })
        .collect();
    (all, idx)
}

/// Contacts held, then sticking ones: which of several equal motions names the outcome.
fn rank(s: &CoulombImpact) -> (usize, usize) {
    let held = s
        .states
        .iter()
        .filter(|(_, st)| *st != ContactImpact::Separate)
        .count();
    let stuck = s
        .states
        .iter()
        .filter(|(_, st)| *st == ContactImpact::Stick)
        .count();
    (held, stuck)
}

/// The state of enumeration code `code` (0 separate, 1 stick, 2 slip +, 3 slip −) of a
/// contact with (`frictional`) or without a tangential row (whose slip has `σ = 0`).
fn state_of(code: usize, frictional: bool) -> ContactImpact {
    match code {
        0 => ContactImpact::Separate,
        1 => ContactImpact::Stick,
        _ if !frictional => ContactImpact::Slip { sigma: 0.0 },
        2 => ContactImpact::Slip { sigma: 1.0 },
        _ => ContactImpact::Slip { sigma: -1.0 },
    }
}

/// The solution for one combination of states (`code`: 0 separate, 1 stick, 2 slip +,
/// 3 slip −), if its linear system is regular and every inequality holds.
#[allow(clippy::too_many_arguments)]
fn solve_combo(
    model: &Model,
    cand: &[usize],
    idx: &[(usize, Option<usize>)],
    code: &[usize],
    w: &DMatrix<f64>,
    y: &DMatrix<f64>,
    v0: &DVector<f64>,
    qd0: &DVector<f64>,
    tol_v: f64,
) -> Option<CoulombImpact> {
    let nr = w.nrows();
    // unknowns x, impulse p = G x, equations on rows E: (W G x)_E = −v0_E
    let mut g_cols: Vec<DVector<f64>> = Vec::new();
    let mut eqs: Vec<usize> = Vec::new();
    for (i, &k) in cand.iter().enumerate() {
        let (rn, rt) = idx[i];
        let mu = mu_of(model, k);
        match code[i] {
            0 => {}
            1 => {
                let rt = rt?;
                let mut c = DVector::zeros(nr);
                c[rt] = 1.0;
                g_cols.push(c);
                let mut c = DVector::zeros(nr);
                c[rn] = 1.0;
                g_cols.push(c);
                eqs.push(rt);
                eqs.push(rn);
            }
            s => {
                let ContactImpact::Slip { sigma } = state_of(s, rt.is_some()) else {
                    unreachable!("codes 2 and 3 are slips")
                };
                let mut c = DVector::zeros(nr);
                c[rn] = 1.0;
                if let Some(rt) = rt {
                    c[rt] = -mu * sigma;
                }
                g_cols.push(c);
                eqs.push(rn);
            }
        }
    }
    let m = g_cols.len();
    let p = if m == 0 {
        DVector::zeros(nr)
    } else {
        let g = DMatrix::from_columns(&g_cols);
        let wg = w * &g;
        let mat = DMatrix::from_fn(m, m, |r, c| wg[(eqs[r], c)]);
        let rhs = DVector::from_fn(m, |r, _| -v0[eqs[r]]);
        // dependent rows (two sticking ends of a flat bar: their tangential rows are one):
        // the impulse's split among them is not determined, q̇⁺ is; take the least-norm
        // split, provided the equations are consistent
        let svd = mat.clone().svd(true, true);
        let smax = svd.singular_values.max();
        if smax.is_nan() || smax <= 0.0 {
            return None;
        }
        let x = svd.solve(&rhs, 1e-10 * smax).ok()?;
        if (&mat * &x - &rhs).amax() > 1e-9 * (rhs.amax() + 1e-12) {
            return None;
        }
        &g * x
    };
    let v = v0 + w * &p;
    let scale_p = p.amax().max(1e-12);
    let tol_p = 1e-9 * scale_p;
    let mut states = Vec::with_capacity(cand.len());
    let mut velocity_after = Vec::with_capacity(cand.len());
    let mut contact_impulses = Vec::with_capacity(cand.len());
    for (i, &k) in cand.iter().enumerate() {
        let (rn, rt) = idx[i];
        let mu = mu_of(model, k);
        let (pn, pt) = (p[rn], rt.map_or(0.0, |r| p[r]));
        let (vn, vt) = (v[rn], rt.map_or(0.0, |r| v[r]));
        velocity_after.push((k, vt, vn));
        contact_impulses.push((k, -pt, -pn));
        let ok = match code[i] {
            0 => vn >= -tol_v,
            1 => pn >= -tol_p && (mu == f64::INFINITY || pt.abs() <= mu * pn + tol_p),
            s => {
                let ContactImpact::Slip { sigma } = state_of(s, rt.is_some()) else {
                    unreachable!("codes 2 and 3 are slips")
                };
                pn >= -tol_p && sigma * vt >= -tol_v
            }
        };
        if !ok {
            return None;
        }
        states.push((k, state_of(code[i], rt.is_some())));
    }
    // ΔT = (v⁺)ᵀp − ½ pᵀWp ≤ 0 by the states (module docs); round-off relative to its terms
    let (work, quad) = (v.dot(&p), 0.5 * p.dot(&(w * &p)));
    let kinetic_change = work - quad;
    if kinetic_change.is_nan() || kinetic_change > 1e-9 * (work.abs() + quad.abs()) {
        return None;
    }
    let qd_plus = qd0 + y * &p;
    // the mode after and its impulse in the mode's rows (core convention P = −p)
    let mut mode = ContactMode::FLIGHT;
    for &(k, st) in &states {
        match st {
            ContactImpact::Separate => {}
            ContactImpact::Stick => mode = mode.with(k, ContactKind::Stick),
            ContactImpact::Slip { .. } => mode = mode.with(k, ContactKind::Slide),
        }
    }
    let impulse = mode
        .rows()
        .map(|r| {
            let i = cand
                .iter()
                .position(|&c| c == r.contact)
                .expect("a candidate");
            let (rn, rt) = idx[i];
            match r.direction {
                RowDirection::Normal => -p[rn],
                RowDirection::Tangential => -rt.map_or(0.0, |t| p[t]),
            }
        })
        .collect();
    Some(CoulombImpact {
        states,
        mode,
        impulse,
        contact_impulses,
        qd_plus: qd_plus.iter().copied().collect(),
        velocity_after,
        kinetic_change,
    })
}

/// The derivatives of a Coulomb impact's `q̇⁺` on its active set ([`coulomb_impact_jacobian`]).
#[derive(Debug, Clone, PartialEq)]
pub struct CoulombImpactJacobian {
    /// `∂q̇⁺/∂(q, q̇⁻)` (`nq × nq` each).
    pub dqd_plus: StatePartials,
    /// `∂q̇⁺/∂p` of each body parameter asked for (`nq × |ps|`).
    pub dqd_plus_dbody: DMatrix<f64>,
    /// `∂q̇⁺/∂μ` of each candidate's static friction coefficient `μ` (the cone the impulse
    /// lies in; zero unless the contact slips), `(contact, column)` in ascending contact.
    pub dqd_plus_dmu: Vec<(usize, DVector<f64>)>,
}

/// Why a Coulomb impact has no derivative at its state.
#[derive(Debug, Clone, PartialEq)]
pub enum NotDifferentiable {
    /// Contact `contact` sits on the boundary of its state's region (a separating contact
    /// leaving at zero normal velocity, a sticking impulse on its cone's edge or without
    /// push, a slip ending at zero sliding velocity): a perturbation may change its state,
    /// so the map is only piecewise smooth there.
    Boundary {
        contact: usize,
        state: ContactImpact,
    },
    /// The active set's linear system is singular (dependent rows: `q̇⁺` is determined, its
    /// derivative by this system is not).
    Singular,
    /// A geometric body parameter ([`BodyParameter::is_geometric`]: a link's length, a
    /// contact's position) moves `A` as well as `M̄`; the Coulomb impact's column for it is not
    /// formed (the plastic impact's is, `selfmanip_core::tangent::plastic_impact_body_derivatives`).
    GeometricParameter(BodyParameter),
}

/// The exact Jacobian of the Coulomb impact `outcome` (one of [`coulomb_impacts`]' solutions
/// at `(q, q̇⁻)`) on its active set, by the implicit function theorem, with the columns of
/// the body parameters `ps` and of each candidate's `μ`.
///
/// ```text
/// active set: the states of `outcome` (σ of each slip fixed), p = G(μ, σ) x,
///   G: a sticking contact's two rows, a slip's normal row with −μσ in its tangential row
///   M̄ Δ − Aᵀ G x = 0,   E A (q̇⁻ + Δ) = 0        (E: the rows whose velocity after is zero)
/// differentiated, [M̄  −AᵀG; E A  0] [dΔ; dx] =
///   along q_k:  [−D_k(M̄ Δ − Aᵀ p);  −E D_k(A q̇⁺)]
///   along q̇⁻:   [0;  −E A w]            (dq̇⁺ = w + dΔ)
///   along p_b:  [−∂M̄/∂p_b Δ;  0]          (A does not depend on inertia)
///   along μ_c:  [Aᵀ ∂G/∂μ_c x;  0] = [−σ x_c A_tᵀ;  0]   (slipping c)
/// ```
///
/// `D_k(M̄Δ − Aᵀp)` and `D_k(A q̇⁺)` are the core's closed forms
/// ([`selfmanip_core::tangent::impact_partials`]). Defined where every candidate is strictly
/// inside its state's region ([`NotDifferentiable::Boundary`] else, relative margin `1e-9`).
#[allow(clippy::too_many_arguments)]
pub fn coulomb_impact_jacobian(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    outcome: &CoulombImpact,
    q: &[f64],
    qd_minus: &[f64],
    ps: &[BodyParameter],
) -> Result<Result<CoulombImpactJacobian, NotDifferentiable>, TangentError> {
    if let Some(&p) = ps.iter().find(|p| p.is_geometric()) {
        return Ok(Err(NotDifferentiable::GeometricParameter(p)));
    }
    let nq = model.nq();
    let cand: Vec<usize> = outcome.states.iter().map(|s| s.0).collect();
    let (all, idx) = impact_rows(model, &cand);
    data.prepare_geometry(model, terrain, all, q, qd_minus)?;
    let a = data.constraints.a.clone();
    let nr = a.nrows();
    // the impulse in row coordinates p = −P, and the velocities after
    let mut p = DVector::zeros(nr);
    for (i, &(k, pt, pn)) in outcome.contact_impulses.iter().enumerate() {
        debug_assert_eq!(k, cand[i]);
        p[idx[i].0] = -pn;
        if let Some(rt) = idx[i].1 {
            p[rt] = -pt;
        }
    }
    let scale_p = p.amax().max(1e-12);
    // the margins of the enumeration's own tests (`solve_combo`)
    let scale_v = (&a * DVector::from_column_slice(qd_minus)).amax().max(1e-9);
    let (tol_p, tol_v) = (1e-9 * scale_p, 1e-9 * scale_v + 1e-12);
    // unknowns x (G's columns), equations on rows E; each μ's ∂G/∂μ x column
    let mut g_cols: Vec<DVector<f64>> = Vec::new();
    let mut eqs: Vec<usize> = Vec::new();
    let mut dg_mu: Vec<(usize, DVector<f64>)> = Vec::new();
    for (i, &(k, state)) in outcome.states.iter().enumerate() {
        let (rn, rt) = idx[i];
        let mu = mu_of(model, k);
        let (_, vt, vn) = outcome.velocity_after[i];
        let (pn, pt) = (p[rn], rt.map_or(0.0, |r| p[r]));
        let mut dg = DVector::zeros(nr);
        let inside = match state {
            ContactImpact::Separate => vn > tol_v,
            ContactImpact::Stick => {
                let rt = rt.expect("a sticking contact has friction");
                g_cols.push(unit(nr, rt));
                g_cols.push(unit(nr, rn));
                eqs.extend([rt, rn]);
                pn > tol_p && (!mu.is_finite() || pt.abs() < mu * pn - tol_p)
            }
            ContactImpact::Slip { sigma } => {
                let mut c = unit(nr, rn);
                if let Some(rt) = rt {
                    c[rt] = -mu * sigma;
                    // ∂(G x)/∂μ = −σ x_c e_t, x_c = p_n
                    dg[rt] = -sigma * pn;
                }
                g_cols.push(c);
                eqs.push(rn);
                pn > tol_p && (rt.is_none() || sigma * vt > tol_v)
            }
        };
        if !inside {
            return Ok(Err(NotDifferentiable::Boundary { contact: k, state }));
        }
        dg_mu.push((k, dg));
    }
    let m = g_cols.len();
    let g = DMatrix::from_columns(&g_cols);
    let e_a = DMatrix::from_fn(m, nq, |r, c| a[(eqs[r], c)]);
    // [M̄ −AᵀG; E A 0]
    let at_g = a.transpose() * &g;
    let mut kmat = DMatrix::zeros(nq + m, nq + m);
    kmat.view_mut((0, 0), (nq, nq)).copy_from(&data.m_bar);
    kmat.view_mut((0, nq), (nq, m)).copy_from(&(-&at_g));
    kmat.view_mut((nq, 0), (m, nq)).copy_from(&e_a);
    let svd = kmat.clone().svd(false, false);
    let smax = svd.singular_values.max();
    if smax.is_nan() || smax <= 0.0 || svd.singular_values.min() <= 1e-12 * smax {
        return Ok(Err(NotDifferentiable::Singular));
    }
    let lu = kmat.lu();
    // right-hand sides: q (nq), q̇⁻ (nq), body parameters, μ of each candidate
    let dqd: Vec<f64> = (0..nq).map(|i| outcome.qd_plus[i] - qd_minus[i]).collect();
    let minus_p: Vec<f64> = p.iter().map(|v| -v).collect();
    let parts = impact_partials(
        model,
        data,
        qd_minus,
        (&dqd, &minus_p, &outcome.qd_plus),
        ps,
    )?;
    let nb = ps.len();
    let nc = dg_mu.len();
    let mut rhs = DMatrix::zeros(nq + m, 2 * nq + nb + nc);
    for k in 0..nq {
        // along q_k
        for i in 0..nq {
            rhs[(i, k)] = -parts.dq_mx_aty[(i, k)];
        }
        for r in 0..m {
            rhs[(nq + r, k)] = -parts.dq_az[(eqs[r], k)];
            // along q̇⁻ = e_k
            rhs[(nq + r, nq + k)] = -e_a[(r, k)];
        }
    }
    for b in 0..nb {
        for i in 0..nq {
            rhs[(i, 2 * nq + b)] = -parts.dp_mx[(i, b)];
        }
    }
    for (c, (_, dg)) in dg_mu.iter().enumerate() {
        let col = a.transpose() * dg;
        rhs.view_mut((0, 2 * nq + nb + c), (nq, 1)).copy_from(&col);
    }
    let Some(sol) = lu.solve(&rhs) else {
        return Ok(Err(NotDifferentiable::Singular));
    };
    let d = sol.rows(0, nq);
    let mut dqd_minus = d.columns(nq, nq).clone_owned();
    for i in 0..nq {
        dqd_minus[(i, i)] += 1.0;
    }
    Ok(Ok(CoulombImpactJacobian {
        dqd_plus: StatePartials {
            dq: d.columns(0, nq).clone_owned(),
            dqd: dqd_minus,
        },
        dqd_plus_dbody: d.columns(2 * nq, nb).clone_owned(),
        dqd_plus_dmu: dg_mu
            .iter()
            .enumerate()
            .map(|(c, (k, _))| (*k, d.column(2 * nq + nb + c).clone_owned()))
            .collect(),
    }))
}

fn unit(n: usize, i: usize) -> DVector<f64> {
    let mut v = DVector::zeros(n);
    v[i] = 1.0;
    v
}
