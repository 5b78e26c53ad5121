//! Kinetic (Coulomb) friction of a sliding site carried by a single-joint massless leg.
//!
//! The thesis slides every slipping contact without friction (Assumption 5.9, "all contact
//! points that are sliding have no kinetic coefficient of friction"), so that the impact
//! problem keeps a unique solution. The price is a force that jumps when a toe starts to
//! slip: just before, the sticking force lies on the edge of the friction cone,
//! $|\lambda_t| = \mu|\lambda_n|$; just after, it is normal, and the motor torque that the toe
//! balanced with both components must now be balanced by the normal one alone. Coulomb's law
//! with a kinetic coefficient $\mu_k$ (equal to the static one, the law's single-coefficient
//! form) keeps the force on the cone edge, continuous through the slip.
//!
//! **Why the statics of the leg resolve it.** Let the sliding site `k` lie on the link of
//! joint `j`, the only joint of a massless leg, and be the leg's only active contact. Its
//! friction force on the robot opposes the sliding velocity
//! $v_t = \hat t\cdot J_p\dot q = -A_t\dot q$ ($A_t = -\hat t^{\mathsf T}J_p$ the site's
//! tangential row, $J_p$ the Jacobian of the material point at the contact):
//!
//! $$ F_t = -\mu_k |\lambda_n| \sigma \hat t = \mu_k \sigma \lambda_n \hat t , \qquad
//!    \sigma = \operatorname{sign} v_t , \qquad
//!    f^{fr} = J_p^{\mathsf T} F_t = -\mu_k\sigma\lambda_n A_t^{\mathsf T} $$
//!
//! (pushing normal forces are negative, `λ_n ≤ 0`). The massless joint's row of the KKT system
//! $\bar M\ddot q + A^{\mathsf T}\lambda = f + f^{fr}$ has no inertia and only this row's entry,
//! so it is the leg's statics,
//!
//! $$ (A_n)_j\lambda_n = f_j - \mu_k\sigma\lambda_n (A_t)_j
//!    \;\Longrightarrow\;
//!    \lambda_n = \frac{f_j}{(A_n)_j + \mu_k\sigma (A_t)_j} , $$
//!
//! with $f_j = \tau_j + \tau^p_j$ the joint's applied torque (motor and passive). The friction
//! force is then a known generalized force, added to $f$ before the unchanged symmetric KKT
//! solve — whose own normal multiplier reproduces $\lambda_n$ (substitute $f^{fr}$ in the row).
//! The rank condition is $(A_n)_j + \mu_k\sigma(A_t)_j \neq 0$: the cone edge along which the
//! force acts must not pass through the hip. There the leg wedges — no sliding force can
//! balance its torque, `λ_n` grows without bound on the way in — and Lemma 5.1 fails for
//! the system with the friction folded in (`[M̄ Ãᵀ; A 0]`, determinant `± (A_n)_j Ã_j det M̄`);
//! it fails too where the site's *normal* passes through the hip (the toe straight under a
//! point-toed leg), where the leg's rate is not fixed by the contact. The hybrid engine's
//! fold guard locates both before they are reached and resolves them as transitions
//! (`selfmanip_hybrid::fold`); within a relative [`WEDGE_TOL`] of the wedge — inside that
//! guard — a site is resolved as at rest (below), i.e. it jams.
//!
//! **Where it applies.** Only sites with $\mu_k > 0$ in a sliding mode (no tangential row) on
//! a single-joint massless leg, as the leg's only active contact (the description rejects
//! $\mu_k > 0$ elsewhere; [`collect`] rejects a second contact on the leg). Impacts are
//! unaffected: a sliding site on a massless leg carries no impulse ($((A_n)_j + \mu_k\sigma
//! (A_t)_j) P_n = 0$). The pseudo-impulse (5.39) includes $f^{fr}$ through
//! $\Upsilon - \bar C\dot q - \bar N$. Energy: $f^{fr\,\mathsf T}\dot q = F_t v_t \le 0$ is the
//! friction's dissipation, which an energy balance must count.
//!
//! **At zero sliding speed** — the instant of slip, or a site whose sliding has died away —
//! $\sigma$ is not defined by $v_t$. Coulomb's law then asks for the force that keeps the
//! site at rest if the cone allows it, and otherwise for the cone edge on the side of that
//! force: with $(\lambda_n^s, \lambda_t^s)$ the site's force when it sticks for the instant
//! (its tangential row added to the prepared rows, those of every other site at rest too:
//! one more KKT solve), the site is held by $\lambda^s_t$ itself when $|\lambda^s_t| \le \mu_k|\lambda^s_n|$ (a known
//! tangential force, $f^{fr} = -A_t^{\mathsf T}\lambda^s_t$, and the normal row then returns
//! $\lambda^s_n$), and otherwise takes the cone edge on the side of $\lambda^s_t$,
//! $\mu_k\sigma = -\mu_k\operatorname{sign}\lambda^s_t$ in the formula above. At a slip the
//! sticking force lies on the cone edge, so the force is continuous through it; a site that
//! has come to rest with its force inside the cone is held (the flow is that of sticking)
//! without the chatter of a sign that flips at $v_t = 0$, and without the $0/0$ of the
//! statics formula for a leg whose torque vanishes. "Zero" is the band
//! $|v_t| \le \varepsilon$ = [`SLIDING_SPEED_EPS_M_S`] (1 µm/s: above the drift of a
//! sticking constraint at a slip event, far below any sliding that matters). Within it,
//! "sticking" asks for $\dot v_t = -v_t/\tau_r$ ($\tau_r$ = [`REST_RELAXATION_S`]) rather
//! than $\dot v_t = 0$, so that a held site stays at rest instead of drifting out of the band
//! (where the kinetic force would push it back: chatter). Only a site at the drift level
//! ([`HELD_SPEED_M_S`]) is held; one that is still coming to rest keeps its kinetic force
//! until its velocity crosses zero, where the engine's slip→stick event takes over — held at
//! the band's edge instead, it would hover there between the two forces. The edge taken when the cone does
//! not hold the site must also start it sliding *against* the edge force; where the side of
//! the sticking force does not (the slip is degenerate there, `v̇_t = 0` to first order, or a
//! massless toe's Painlevé-type conflict), the other edge is taken if it does, else no
//! friction for the instant (the thesis's Assumption 5.9) — two trial solves, only then.
use crate::contact::{row_direction, row_direction_rate, RowDirection};
use crate::dynamics::Data;
use crate::error::{CoreError, Result, SingularityKind};
use crate::model::Model;
use nalgebra::Vector2;

/// Sliding speed at or below which a site counts as at rest (m/s).
pub const SLIDING_SPEED_EPS_M_S: f64 = 1e-6;
/// Sliding speed at or below which a site whose force the cone holds is held at rest (m/s):
/// the drift of a sticking constraint. Faster, it is coming to rest under kinetic friction,
/// and the engine's slip→stick event stops it when its velocity crosses zero.
pub const HELD_SPEED_M_S: f64 = 1e-6;
/// A sliding acceleration this large along the edge force (m/s²) makes that edge clearly
/// inconsistent; smaller ones are the degenerate first-order start of a slip.
pub const INCONSISTENT_ACCEL_M_S2: f64 = 1e-3;
/// Time constant with which a site within the rest band is brought to rest (s).
pub const REST_RELAXATION_S: f64 = 1e-3;
/// Relative size of `(A_n)_j + μ_k σ (A_t)_j` below which a sliding site is wedged.
pub const WEDGE_TOL: f64 = 1e-3;

/// One sliding site with kinetic friction at the prepared state.
#[derive(Debug, Clone, Default)]
pub struct SlidingSite {
    /// Its normal row in `data.constraints.rows`.
    pub row: usize,
    /// The joint of the massless leg that carries it.
    pub joint: usize,
    pub mu_k: f64,
    /// `(coordinate, A_t entry)` over the coordinates the site's point depends on.
    pub a_t: Vec<(usize, f64)>,
    /// `Ȧ_t q̇`.
    pub a_t_dot_qd: f64,
    /// Sliding velocity `v_t = −A_t q̇` (m/s).
    pub v_t: f64,
    /// The ratio `λ_t/λ_n` of the site's force: `μ_k σ` while it slides with `σ = sign v_t`,
    /// `±μ_k` on the side of its sticking force at zero sliding speed when that force leaves
    /// the cone ([`resolve`]); 0 when `held` applies.
    pub coef: f64,
    /// At zero sliding speed with its sticking force inside the cone: that tangential force
    /// (N, along `t̂`), which holds the site at rest.
    pub held: Option<f64>,
    /// Whether `|v_t| ≤` [`SLIDING_SPEED_EPS_M_S`] (or the site slides into a wedge), so
    /// that its force comes from sticking ([`resolve`]).
    pub at_rest: bool,
    /// Whether it slides into a wedge (the cone edge against its sliding through the hip).
    pub wedged: bool,
    /// The friction force on the robot along the site's tangent `t̂` (the row direction of a
    /// tangential row), `μ_k σ λ_n` (N), at the last assembly.
    pub force_t: f64,
}

/// Collects the sliding sites with kinetic friction of the prepared mode into
/// `data.sliding` (empty — the common case — costs one pass over the rows).
pub(crate) fn collect(model: &Model, data: &mut Data, qd: &[f64]) -> Result<()> {
    data.sliding.clear();
    data.friction.fill(0.0);
    for (r, row) in data.constraints.rows.iter().enumerate() {
        let k = row.contact;
        let mu_k = model.contacts[k].kinetic_mu;
        if mu_k == 0.0 || row.direction != RowDirection::Normal {
            continue;
        }
        let tangential_row_active = data
            .constraints
            .rows
            .iter()
            .any(|o| o.contact == k && o.direction == RowDirection::Tangential);
        if tangential_row_active {
            continue; // sticking: the cone, not kinetic friction
        }
        let joint = model.contacts[k]
            .link
            .expect("validated: kinetic friction only on leg sites");
        // the leg's statics resolve the force only if this is the leg's only row
        let c = data.constraints.n_rows();
        let a = data.constraints.a.as_slice();
        if (0..c).any(|o| o != r && a[joint * c + o] != 0.0) {
            return Err(CoreError::InvalidMode {
                reason: format!(
                    "kinetic friction at `{}` needs it to be its leg's only active contact",
                    model.contacts[k].name
                ),
            });
        }
        let geo = data
            .constraints
            .geometry
            .iter()
            .find(|(kk, _)| *kk == k)
            .expect("active contact")
            .1;
        let d = row_direction(&geo.plane, RowDirection::Tangential);
        let d_rate = row_direction_rate(geo.normal_rate, RowDirection::Tangential);
        let mut site = SlidingSite {
            row: r,
            joint,
            mu_k,
            ..Default::default()
        };
        let (mut v_t, mut acc) = (0.0, 0.0);
        let kin = &data.kin;
        kin.point_jacobian_columns(model, geo.part, geo.point, |col_k, col| {
            let a_tk = -d.dot(&col);
            site.a_t.push((col_k, a_tk));
            v_t -= a_tk * qd[col_k];
            if d_rate != Vector2::zeros() {
                acc -= d_rate.dot(&col) * qd[col_k];
            }
        });
        kin.point_jacobian_rate_columns(model, geo.part, geo.point_rate, |col_k, col| {
            acc -= d.dot(&col) * qd[col_k];
        });
        site.v_t = v_t;
        site.a_t_dot_qd = acc;
        site.at_rest = v_t.abs() <= SLIDING_SPEED_EPS_M_S;
        site.coef = if site.at_rest { 0.0 } else { mu_k * v_t.signum() };
        site.held = None;
        site.wedged = false;
        // sliding into a wedge (the cone edge through the hip): the statics cannot balance
        // the joint torque with a sliding force, so the site jams — it is resolved as at rest
        if !site.at_rest {
            let c = data.constraints.n_rows();
            let a_n = data.constraints.a.as_slice()[joint * c + r];
            let a_t = site.a_t.iter().find(|(k, _)| *k == joint).map_or(0.0, |e| e.1);
            let den = a_n + site.coef * a_t;
            site.wedged = den.abs() <= WEDGE_TOL * (a_n.abs() + mu_k * a_t.abs());
            site.at_rest = site.wedged;
        }
        data.sliding.push(site);
    }
    Ok(())
}

/// The generalized kinetic friction force `f^fr` of the collected sites for joint torques
/// `tau` (into `data.friction`), each with its `sigma`.
pub(crate) fn assemble(model: &Model, data: &mut Data, tau: &[f64]) -> Result<()> {
    let nq = model.nq();
    if data.friction.len() != nq {
        data.friction = nalgebra::DVector::zeros(nq);
    }
    data.friction.fill(0.0);
    let c = data.constraints.n_rows();
    for s in data.sliding.iter_mut() {
        s.force_t = 0.0;
        if let Some(f_t) = s.held {
            // f^fr = J_pᵀ t̂ λ_t = −A_tᵀ λ_t
            s.force_t = f_t;
            for &(k, a_tk) in &s.a_t {
                data.friction[k] -= f_t * a_tk;
            }
            continue;
        }
        if s.coef == 0.0 {
            continue;
        }
        let j = s.joint;
        let a_n = data.constraints.a.as_slice()[j * c + s.row];
        let a_t = s.a_t.iter().find(|(k, _)| *k == j).map_or(0.0, |e| e.1);
        let f_j = tau.get(j).copied().unwrap_or(0.0) - data.c_qd[j] - data.n_bar[j];
        let den = a_n + s.coef * a_t;
        if den.abs() <= 1e-12 * (a_n.abs() + s.coef.abs() * a_t.abs()) {
            return Err(CoreError::SingularKkt {
                kind: SingularityKind::UnconstrainedMasslessMotion,
                condition_estimate: f64::INFINITY,
            });
        }
        let lambda_n = f_j / den;
        s.force_t = s.coef * lambda_n;
        for &(k, a_tk) in &s.a_t {
            data.friction[k] -= s.coef * lambda_n * a_tk;
        }
    }
    Ok(())
}

/// Sets `coef` of every collected site at rest from its sticking force (module docs), then
/// assembles `data.friction` for the joint torques `tau`.
pub(crate) fn resolve(model: &Model, data: &mut Data, tau: &[f64]) -> Result<()> {
    let rest: Vec<usize> = (0..data.sliding.len())
        .filter(|&i| data.sliding[i].at_rest)
        .collect();
    if rest.is_empty() {
        return assemble(model, data, tau);
    }
    // f = Υ − C̄q̇ − N̄ + the kinetic friction of the sites that slide
    for &i in &rest {
        data.sliding[i].coef = 0.0;
        data.sliding[i].held = None;
    }
    assemble(model, data, tau)?;
    let f_full: Vec<f64> = (0..model.nq())
        .map(|a| {
            let t = if a < model.n_joints() { tau[a] } else { 0.0 };
            t - data.c_qd[a] - data.n_bar[a] + data.friction[a]
        })
        .collect();
    // every site at rest sticks for the instant, together: [A; A_t…] and [−Ȧq̇; −Ȧ_t q̇…],
    // with the band's residual sliding brought to rest (v̇_t = −v_t/τ_r)
    let c = data.constraints.n_rows();
    let mut a = data.constraints.a.clone().resize_vertically(c + rest.len(), 0.0);
    let mut g: Vec<f64> = data.constraints.a_dot_qd.iter().map(|v| -v).collect();
    for (m, &i) in rest.iter().enumerate() {
        let s = &data.sliding[i];
        for &(k, v) in &s.a_t {
            a[(c + m, k)] = v;
        }
        g.push(-s.a_t_dot_qd + s.v_t / REST_RELAXATION_S);
    }
    let coords = &data.dynamic_coords;
    let mut kkt = crate::kkt::KktFactorization::default();
    let y = match kkt.factor_on(&data.m_bar, &a, coords) {
        Ok(()) => {
            let f: Vec<f64> = coords.iter().map(|&k| f_full[k]).collect();
            let (mut x, mut y) = (vec![0.0; coords.len()], vec![0.0; c + rest.len()]);
            kkt.solve(&f, &g, &mut x, &mut y);
            Some(y)
        }
        // sticking is itself singular here
        Err(_) => None,
    };
    let forces: Vec<Option<(f64, f64)>> = rest
        .iter()
        .enumerate()
        .map(|(m, &i)| y.as_ref().map(|y| (y[data.sliding[i].row], y[c + m])))
        .collect();
    for (m, &i) in rest.iter().enumerate() {
        let mu_k = data.sliding[i].mu_k;
        let held = match forces[m] {
            Some((lambda_n, lambda_t)) if lambda_n.is_finite() && lambda_t.is_finite() => {
                let (v_t, wedged) = (data.sliding[i].v_t, data.sliding[i].wedged);
                if lambda_t.abs() <= -mu_k * lambda_n {
                    if v_t.abs() <= HELD_SPEED_M_S || wedged {
                        // the cone holds it: the sticking force itself
                        Some(lambda_t)
                    } else {
                        // still sliding, coming to rest: the kinetic force, until the sliding
                        // velocity crosses zero (the engine's slip→stick event)
                        edge_force(data, i, tau, mu_k * v_t.signum())
                    }
                } else {
                    // it slides: the cone edge on the side of the sticking force (continuity;
                    // a pushing λ_n < 0 turns λ_t = coef λ_n the same way as λ_t), if the
                    // site then starts sliding against that force; else the other edge, if
                    // consistent; else (a Painlevé-type conflict) no friction for the instant
                    let side = lambda_t.signum();
                    [side, -side].into_iter().find_map(|side| {
                        let f = edge_force(data, i, tau, -mu_k * side)?;
                        data.sliding[i].held = Some(f);
                        let vdot = sliding_acceleration(model, data, tau, i).ok()?;
                        (vdot * side <= INCONSISTENT_ACCEL_M_S2).then_some(f)
                    })
                }
            }
            _ => None,
        };
        // no force to hold it with (sticking singular, or a wedge): none for the instant
        data.sliding[i].held = Some(held.unwrap_or(0.0));
    }
    assemble(model, data, tau)
}

/// `v̇_t` of site `i` under the forces currently set on every site (one KKT solve).
fn sliding_acceleration(model: &Model, data: &mut Data, tau: &[f64], i: usize) -> Result<f64> {
    assemble(model, data, tau)?;
    let (mut x, mut y) = (
        std::mem::take(&mut data.qdd),
        std::mem::take(&mut data.lambda),
    );
    data.solve_prepared(
        |d, a| d.generalized_force_at(model, tau, a),
        |d, r| -d.constraints.a_dot_qd.as_slice()[r],
        None,
        &mut x,
        &mut y,
    );
    (data.qdd, data.lambda) = (x, y);
    let s = &data.sliding[i];
    let a_t_qdd: f64 = s.a_t.iter().map(|&(k, a)| a * data.qdd[k]).sum();
    Ok(-(a_t_qdd + s.a_t_dot_qd))
}

/// The tangential force `coef λ_n` of site `i` with `λ_n` from its leg's statics (module
/// docs); `None` at a wedge.
fn edge_force(data: &Data, i: usize, tau: &[f64], coef: f64) -> Option<f64> {
    let s = &data.sliding[i];
    let c = data.constraints.n_rows();
    let j = s.joint;
    let a_n = data.constraints.a.as_slice()[j * c + s.row];
    let a_t = s.a_t.iter().find(|(k, _)| *k == j).map_or(0.0, |e| e.1);
    let f_j = tau.get(j).copied().unwrap_or(0.0) - data.c_qd[j] - data.n_bar[j];
    let den = a_n + coef * a_t;
    (den.abs() > WEDGE_TOL * (a_n.abs() + coef.abs() * a_t.abs())).then(|| coef * f_j / den)
}
