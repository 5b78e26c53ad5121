//! Kinetic (Coulomb) friction of a sliding site: on a single-joint massless leg by the leg's
//! statics, anywhere else (a body end, a massive or multi-joint leg, a leg with a second
//! contact) folded into the dynamics solve.
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
//! **Where the statics apply.** Sites with $\mu_k > 0$ in a sliding mode (no tangential row)
//! on a single-joint massless leg, as the leg's only active contact. Impacts are
//! unaffected: a sliding site on a massless leg carries no impulse ($((A_n)_j + \mu_k\sigma
//! (A_t)_j) P_n = 0$). The pseudo-impulse (5.39) includes $f^{fr}$ through
//! $\Upsilon - \bar C\dot q - \bar N$. Energy: $f^{fr\,\mathsf T}\dot q = F_t v_t \le 0$ is the
//! friction's dissipation, which an energy balance must count.
//!
//! **The general sliding site.** Every other sliding site `k ∈ S` with $\mu_k > 0$ (its
//! [`SlidingSite::general`]) has no statics to give its $\lambda_{n,k}$ ahead of the solve,
//! but its friction is linear in it, $f^{fr} = -\sum_{k\in S}\mu_k\sigma_k\lambda_{n,k}
//! A_{t,k}^{\mathsf T} = -B^{\mathsf T}\lambda$ ($B$: $\mu_k\sigma_k A_{t,k}$ in the rows of
//! the sliding normals, zero elsewhere), so (5.2) becomes the square **nonsymmetric** system
//!
//! $$ \begin{bmatrix}\bar M & (A+B)^{\mathsf T}\\ A & 0\end{bmatrix}
//!    \begin{bmatrix}\ddot q\\ \lambda\end{bmatrix} =
//!    \begin{bmatrix}f\\ -\dot A\dot q\end{bmatrix}. $$
//!
//! It is solved by folding, not by a new factorization: the symmetric KKT matrix of (5.2) is
//! factored as always (Lemma 5.1 on it), and its solution is linear in the friction's
//! right-hand side. With $(x_0, y_0)$ the solution without the general sites' friction and
//! $(x_k, y_k)$ the response to $f = -\mu_k\sigma_k A_{t,k}^{\mathsf T}$, $g = 0$ (a unit normal
//! force's friction), $\lambda_S$ solves the small dense system
//! $(I - Y_{SS})\lambda_S = y_{0,S}$, $Y_{SS,ab} = (y_b)_{\text{row}(a)}$ (an LU with partial
//! pivoting, nalgebra's), and $\ddot q = x_0 + \sum_k\lambda_{n,k}x_k$,
//! $\lambda = y_0 + \sum_k\lambda_{n,k}y_k$ — the block elimination of the nonsymmetric
//! system, exact. `I − Y_SS` is its Schur complement: the folded system is regular iff the
//! symmetric one is and `det(I − Y_SS) ≠ 0` ([`FOLD_SINGULAR_TOL`] on its smallest singular
//! value relative to `1 + max|Y_SS|` — the SVD's, where the bound
//! `|det| / ‖I − Y_SS‖_F^(n−1)` from the LU does not clear it twice over — else
//! [`CoreError::SingularKkt`]; at Painlevé's threshold `W = 0` it is singular). A massless
//! coordinate is determined by the symmetric system exactly when it is by the folded one
//! unless `I − Y_SS` is singular, so Lemma 5.1 for the folded system is these two checks (a
//! massless chain whose only pin is a sliding row the symmetric system already rejects; a
//! folded system that would be regular where the symmetric one is not — only a site whose
//! cone edge, not its normal, pins a massless leg with a second contact — is reported
//! singular). The default RHex leap has no general site: its path is unchanged, bit for bit.
//!
//! **Consistency (Painlevé).** The normal accelerations `a_S = A_S q̈ + Ȧ_S q̇` of the sliding
//! sites (separation positive) respond to their forces as `a_S = W(λ_S⁰ − λ_S)`: with
//! $H_{SS} = \partial\lambda_S/\partial g_S$ of the symmetric system ($= -\Lambda_{SS}$, the
//! inverse of the frictionless Delassus Schur complement $W_0$, for a massive system) the
//! folded response is $W^{-1} = -(I - Y_{SS})^{-1}H_{SS}$, i.e. $W = W_0 (I - Y_{SS})$; for one
//! site $W = A_nM^{-1}(A_n + \mu_k\sigma A_t)^{\mathsf T}$ with the other rows held. Contact
//! complementarity ($a \ge 0$, $-\lambda \ge 0$, $a\lambda = 0$) has a unique solution for
//! every right-hand side iff $W$ is a P-matrix; where it is not, a pushing force *draws the
//! site into the ground* and the sliding mode has no solution (a penetrating free
//! acceleration) or two (a separating one) — Painlevé's paradox. So every principal minor of
//! $W^{-1}$ must be `≥ 0` (P₀: a massless pin gives `W⁻¹ = 0`, infinitely stiff, which is
//! fine; [`PAINLEVE_TOL`] relative); else [`CoreError::PainleveInconsistent`] names the site.
//! Painlevé's rod (a uniform rod of half-length `l`, one end sliding at angle θ to the
//! ground) gives $W \propto 1 + 3\cos^2\theta - 3\mu\sigma'\sin\theta\cos\theta$ (σ' = +1
//! for the end sliding away from the rod's centre): inconsistent iff
//! $\mu > (1 + 3\cos^2\theta)/(3\sin\theta\cos\theta)$, at least 4/3 (test
//! `painleve_rod`).
//!
//! **A contact that pulls.** Coulomb's cone bounds the friction by the force that presses the
//! site on the ground, `|λ_t| ≤ μ_k max(0, −λ_n)`. In the flow a sliding site's liftoff
//! guard ends its mode where `λ_n` reaches zero, so the law `μ_k σ λ_n` meets a pulling
//! `λ_n` only past that zero, inside the step that locates it (kept smooth there, which the
//! step's accuracy needs). A Zeno truncation's dwell, though, holds its contacts closed
//! whatever their force (`selfmanip_hybrid::zeno`); that force is the pseudo-impulse (5.39)
//! applied as a force, which carries no kinetic friction (below), and with `μ_k σ λ_n` a
//! pulling `λ_n` would push the site *along* its slide and feed it energy (a user's
//! quadruped gained 3.2 J of "friction work" so, its foot sliding up to 4 m/s). So the
//! engine gives a general site that the dwell holds sliding while it pulls at the segment's
//! start the direction `σ = 0` for that segment (`selfmanip_hybrid::flow::Flow::fix_slide_directions`):
//! it slides without friction there. One that pushes at the segment's start keeps its
//! liftoff guard through the dwell: where its `λ_n` comes to pull, the segment ends (no
//! event) and the dwell holds it on, sliding without friction until the dwell ends
//! (`selfmanip_hybrid::flow::Flow::pulled`; with its friction, a user's biped foot was driven
//! from 0.04 to 29 m/s and gained 1.4 J).
//!
//! **Impacts** keep Assumption 5.9 for sliding sites: the plastic impact (5.10) and the
//! pseudo-impulse (5.39) carry no kinetic friction (a Coulomb impact law with sliding
//! sites is not unique in general — the impulse analogue of Painlevé's paradox — so no rule
//! is taken here). **Derivatives** of a general site's friction (`crate::tangent`) are the
//! implicit differentiation of the folded system, `K' dz = db − dK' z` with
//! `dK' z = [dM̄ q̈ + dAᵀλ + dBᵀλ; dA q̈]`, `dB = μ_kσ_k dA_t` (`σ_k` and `μ_k` constant along
//! a sliding arc), solved by the same block elimination (`Fold`, formed once per state
//! and applied to every right-hand side). A site whose force comes from sticking (at rest)
//! is not differentiated (`tangent::TangentError::FrictionAtRest`).
//!
//! **The sliding direction is a discrete state.** $\sigma$ is constant along a stretch of
//! sliding: the friction force changes side only where $v_t$ passes through zero, and there
//! Coulomb's law must be decided afresh (stick, or slide on one edge). A right-hand side with
//! $\operatorname{sign} v_t$ inside it is discontinuous at $v_t = 0$, and one with a rest band
//! ($|v_t| \le \varepsilon$ held, the kinetic force outside) is discontinuous at the band's
//! edge, where trajectories hover: step counts and stick times then scale with the
//! integration tolerance. So a caller that integrates the flow (the hybrid engine) fixes
//! $\sigma$ for each segment in [`Data::slide_directions`]
//! ([`SlideDirection::Fixed`]): the force is the smooth $\mu_k\sigma\lambda_n$ on
//! both sides of $v_t = 0$, the engine's slip→stick guard locates the zero crossing of $v_t$
//! as an event, and its reset decides there by complementarity — the site sticks (a mode
//! with its tangential row) if the cone holds its sticking force, else it slides on. The
//! friction law itself never holds a site in a sliding mode.
//!
//! **At zero sliding speed** — a segment that starts at a slip, or at a stick the cone
//! refused ([`SlideDirection::FromRest`]) — $\sigma$ is not defined by $v_t$, and Coulomb's
//! law asks for the cone edge on the side of the force that would keep the site at rest:
//! with $(\lambda_n^s, \lambda_t^s)$ the site's force when it sticks for the instant (its
//! tangential row added to the prepared rows, those of every other site at rest too: one more
//! KKT solve, with $\dot v_t = 0$), the edge $\mu_k\sigma = -\mu_k\operatorname{sign}\lambda^s_t$
//! in the formula above. At a slip the sticking force lies on the cone edge, so the force is
//! continuous through it. The edge must also start the site sliding *against* its force,
//! $\sigma\dot v_t \ge 0$; where the side of the sticking force does not (the slip is
//! degenerate there, `v̇_t = 0` to first order, or a massless toe's Painlevé-type conflict),
//! the other edge is taken if it does, else no friction (the thesis's Assumption 5.9) — two
//! trial solves, only then. The engine reads the edge taken ([`SlidingSite::sigma`]) at the
//! segment's start and fixes it for the segment. This is the only place where the law looks
//! at rest, and only for that instant: a site whose sticking force the cone holds is given
//! no edge (both are inconsistent), so the reset must not leave it sliding.
//!
//! **Without fixed directions** (a single evaluation, e.g. `Model::dynamics` of a sliding
//! mode) the law is the instantaneous one: $\sigma = \operatorname{sign} v_t$ outside
//! $|v_t| \le$ [`SLIDING_SPEED_EPS_M_S`] (1 µm/s, above the drift of a sticking constraint
//! at an event located to 1e-10 s, far below any sliding that matters); within it the site
//! is at rest: held by its sticking force $\lambda^s_t$ if $|\lambda^s_t| \le
//! \mu_k|\lambda^s_n|$ (a known tangential force, $f^{fr} = -A_t^{\mathsf T}\lambda^s_t$, and
//! the normal row then returns $\lambda^s_n$), else the edge as above. The engine's resets
//! evaluate candidate modes this way, at one instant.
use crate::contact::{row_direction, row_direction_rate, RowDirection};
use crate::data::Data;
use crate::error::{CoreError, Result, SingularityKind};
use crate::model::Model;
pub use crate::sliding::{SlideDirection, SlidingSite};
use fold::{folds, Fold};
pub use fold::{FOLD_SINGULAR_TOL, PAINLEVE_TOL};
use nalgebra::Vector2;

pub(crate) mod fold;

/// Sliding speed at or below which a site without a fixed direction counts as at rest
/// (m/s): the instantaneous law only (module docs).
pub const SLIDING_SPEED_EPS_M_S: f64 = 1e-6;
/// A sliding acceleration this large along the edge force (m/s²) makes that edge clearly
/// inconsistent; smaller ones are the degenerate first-order start of a slip.
pub const INCONSISTENT_ACCEL_M_S2: f64 = 1e-3;
/// Relative size of `(A_n)_j + μ_k σ (A_t)_j` below which a sliding site is wedged.
pub const WEDGE_TOL: f64 = 1e-3;

/// Collects the sliding sites with kinetic friction of the prepared mode into
/// `data.sliding` (empty — the common case — costs one pass over the rows).
pub(crate) fn collect(model: &Model, data: &mut Data, qd: &[f64]) -> Result<()> {
    // the sites are rewritten in place (their `a_t` buffers kept) and the list cut to the
    // sites found: a mode's sites are collected at every evaluation of its flow
    let mut n = 0;
    data.has_general = false;
    let result = collect_into(model, data, qd, &mut n);
    data.sliding.truncate(n);
    result
}

/// [`collect`]'s pass, with `n` the sites written so far.
fn collect_into(model: &Model, data: &mut Data, qd: &[f64], n: &mut usize) -> Result<()> {
    data.friction.as_mut_slice().fill(0.0);
    for (r, row) in data.constraints.rows.iter().enumerate() {
        let k = row.contact;
        let mu_k = model.contacts[k].kinetic_mu;
        if mu_k == 0.0 || row.direction != RowDirection::Normal {
            continue;
        }
        // the rows are by contact, a tangential row right before its normal row
        // (`ContactMode::rows`)
        let tangential_row_active = r > 0 && {
            let before = data.constraints.rows[r - 1];
            before.contact == k && before.direction == RowDirection::Tangential
        };
        if tangential_row_active {
            continue; // sticking: the cone, not kinetic friction
        }
        // the leg's statics resolve the force only on a single-joint massless leg whose only
        // row this is; every other site is folded into the dynamics solve (`fold_general`)
        let c = data.constraints.n_rows();
        let a = data.constraints.a.as_slice();
        let statics_joint = model.contacts[k].link.filter(|&j| {
            let joint = &model.joints[j];
            joint.is_massless()
                && model.legs[joint.leg].n_links == 1
                && (0..c).all(|o| o == r || a[j * c + o] == 0.0)
        });
        let general = statics_joint.is_none();
        data.has_general |= general;
        let joint = statics_joint.unwrap_or(usize::MAX);
        let geo = data
            .constraints
            .geometry
            .iter()
            .find(|(kk, _)| *kk == k)
            .expect("active contact")
            .1;
        let d = row_direction(&geo.plane, RowDirection::Tangential);
        let d_rate = row_direction_rate(geo.normal_rate, RowDirection::Tangential);
        let preset = data
            .slide_directions
            .iter()
            .find(|(c, _)| *c == k)
            .map(|&(_, d)| d);
        if *n == data.sliding.len() {
            data.sliding.push(SlidingSite::default());
        }
        let site = &mut data.sliding[*n];
        *n += 1;
        let mut a_t = std::mem::take(&mut site.a_t);
        a_t.clear();
        *site = SlidingSite {
            row: r,
            contact: k,
            preset,
            joint,
            general,
            mu_k,
            a_t,
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
        (site.at_rest, site.sigma) = match preset {
            Some(SlideDirection::Fixed(sigma)) => (false, sigma),
            Some(SlideDirection::FromRest) => (true, 0.0),
            None if v_t.abs() <= SLIDING_SPEED_EPS_M_S => (true, 0.0),
            None => (false, v_t.signum()),
        };
        site.coef = mu_k * site.sigma;
        site.held = None;
        site.cone_holds = false;
        site.wedged = false;
        // sliding into a wedge (the cone edge through the hip): the statics cannot balance
        // the joint torque with a sliding force, so the site jams — it is resolved as at rest
        if !site.at_rest && site.coef != 0.0 && !general {
            let c = data.constraints.n_rows();
            let a_n = data.constraints.a.as_slice()[joint * c + r];
            let a_t = site
                .a_t
                .iter()
                .find(|(k, _)| *k == joint)
                .map_or(0.0, |e| e.1);
            let den = a_n + site.coef * a_t;
            site.wedged = den.abs() <= WEDGE_TOL * (a_n.abs() + mu_k * a_t.abs());
            site.at_rest = site.wedged;
        }
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
    data.friction.as_mut_slice().fill(0.0);
    let c = data.constraints.n_rows();
    for s in data.sliding.iter_mut() {
        s.force_t = 0.0;
        if let Some(f_t) = s.held {
            // f^fr = J_pᵀ t̂ λ_t = −A_tᵀ λ_t
            s.force_t = f_t;
            let friction = data.friction.as_mut_slice();
            for &(k, a_tk) in &s.a_t {
                friction[k] -= f_t * a_tk;
            }
            continue;
        }
        if s.coef == 0.0 || s.general {
            // a general site's force is folded into the dynamics solve (`fold_general`)
            continue;
        }
        let j = s.joint;
        let a_n = data.constraints.a.as_slice()[j * c + s.row];
        let a_t = s.a_t.iter().find(|(k, _)| *k == j).map_or(0.0, |e| e.1);
        let f_j =
            tau.get(j).copied().unwrap_or(0.0) - data.c_qd.as_slice()[j] - data.n_bar.as_slice()[j];
        let den = a_n + s.coef * a_t;
        if den.abs() <= 1e-12 * (a_n.abs() + s.coef.abs() * a_t.abs()) {
            return Err(CoreError::SingularKkt {
                kind: SingularityKind::UnconstrainedMasslessMotion,
                condition_estimate: f64::INFINITY,
            });
        }
        let lambda_n = f_j / den;
        s.force_t = s.coef * lambda_n;
        let friction = data.friction.as_mut_slice();
        for &(k, a_tk) in &s.a_t {
            friction[k] -= s.coef * lambda_n * a_tk;
        }
    }
    // the damped slides' forces, applied (crate::damped_slide)
    for d in data.damped.iter() {
        let friction = data.friction.as_mut_slice();
        for (k, f) in friction.iter_mut().enumerate() {
            // −Aᵀλ, as every contact force enters (5.3)
            *f -= d.rows[(0, k)] * d.lambda[0] + d.rows[(1, k)] * d.lambda[1];
        }
    }
    Ok(())
}

/// Sets `coef` of every collected site at rest from its sticking force (module docs), then
/// assembles `data.friction` for the joint torques `tau`.
pub(crate) fn resolve(model: &Model, data: &mut Data, tau: &[f64]) -> Result<()> {
    if !data.sliding.iter().any(|s| s.at_rest) {
        // the common case: every site slides
        return assemble(model, data, tau);
    }
    let rest: Vec<usize> = (0..data.sliding.len())
        .filter(|&i| data.sliding[i].at_rest)
        .collect();
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
    // every site at rest sticks for the instant, together: [A; A_t…] and [−Ȧq̇; −Ȧ_t q̇…]
    let c = data.constraints.n_rows();
    let mut a = data
        .constraints
        .a
        .clone()
        .resize_vertically(c + rest.len(), 0.0);
    let mut g: Vec<f64> = data.constraints.a_dot_qd.iter().map(|v| -v).collect();
    for (m, &i) in rest.iter().enumerate() {
        let s = &data.sliding[i];
        for &(k, v) in &s.a_t {
            a[(c + m, k)] = v;
        }
        g.push(-s.a_t_dot_qd);
    }
    let coords = &data.dynamic_coords;
    let mut kkt = crate::kkt::KktFactorization::default();
    // the failure's condition number is not wanted: only whether it factors
    let y = match kkt.try_factor_on(&data.m_bar, &a, coords) {
        Ok(()) => {
            let f: Vec<f64> = coords.iter().map(|&k| f_full[k]).collect();
            let (mut x, mut y) = (vec![0.0; coords.len()], vec![0.0; c + rest.len()]);
            kkt.solve(&f, &g, &mut x, &mut y);
            // the general sites that slide meanwhile: their friction folded in (on the
            // fold's buffers: the next solve forms its own)
            let fold = &mut data.fold;
            fold_into(model, &mut kkt, coords, &data.sliding, fold, &mut x, &mut y)
                .ok()
                .map(|_| y)
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
        let (held, sigma) = match forces[m] {
            Some((lambda_n, lambda_t)) if lambda_n.is_finite() && lambda_t.is_finite() => {
                let s = &data.sliding[i];
                let slides =
                    (data.slide_at_rest || s.preset == Some(SlideDirection::FromRest)) && !s.wedged;
                // the cone test of the engine's resets (contact_set::outside_cone)
                let push = -lambda_n;
                let holds = push >= 0.0 && lambda_t.abs() <= mu_k * push * (1.0 + 1e-12) + 1e-12;
                data.sliding[i].cone_holds = holds;
                if holds && !slides {
                    // the cone holds it for the instant: the sticking force itself
                    (Some(lambda_t), 0.0)
                } else {
                    // it slides: the cone edge on the side of the sticking force (continuity;
                    // a pushing λ_n < 0 turns λ_t = coef λ_n the same way as λ_t), if the
                    // site then starts sliding against that force; else the other edge, if
                    // consistent; else (a Painlevé-type conflict) no friction
                    // — preferring an edge whose leg statics push (on one that pulls, the
                    // contact is let go by complementarity: where both edges are
                    // consistent, the law does not choose between them, the contact does)
                    let side = lambda_t.signum();
                    let mut consistent = Vec::with_capacity(2);
                    for side in [side, -side] {
                        if data.sliding[i].general {
                            // its edge folded into the solve: λ_n from the solution
                            set_edge(data, i, tau, -side);
                            let Ok(vdot) = sliding_acceleration(model, data, tau, i) else {
                                continue;
                            };
                            if vdot * side <= INCONSISTENT_ACCEL_M_S2 {
                                let pushes = data.lambda[data.sliding[i].row] <= 0.0;
                                consistent.push((None, -side, pushes));
                            }
                            continue;
                        }
                        let Some(f) = edge_force(data, i, tau, -mu_k * side) else {
                            continue;
                        };
                        data.sliding[i].held = Some(f);
                        let Ok(vdot) = sliding_acceleration(model, data, tau, i) else {
                            continue;
                        };
                        if vdot * side <= INCONSISTENT_ACCEL_M_S2 {
                            // λ_n = f / coef, pushing when negative
                            let pushes = f * side >= 0.0;
                            consistent.push((Some(f), -side, pushes));
                        }
                    }
                    consistent
                        .iter()
                        .find(|c| c.2)
                        .or(consistent.first())
                        .map_or((None, 0.0), |c| (c.0, c.1))
                }
            }
            _ => {
                data.sliding[i].cone_holds = false;
                (None, 0.0)
            }
        };
        let s = &mut data.sliding[i];
        if s.general && sigma != 0.0 {
            // on a cone edge, its force folded into the solve
            (s.held, s.coef) = (None, s.mu_k * sigma);
        } else {
            // no force to hold it with (sticking singular, or a wedge): none
            s.held = Some(held.unwrap_or(0.0));
            if s.general {
                s.coef = 0.0;
            }
        }
        s.sigma = sigma;
    }
    jointly_consistent_edges(model, data, tau, &rest)?;
    assemble(model, data, tau)
}

/// Several sites leaving rest (`rest`, the sites at rest): each edge was checked with the
/// sites after it still free of friction; together they must each start sliding against
/// their force too, else the edge combinations are searched (2ⁿ, n the sites leaving rest on
/// an edge: two for a pair of toes) for one that does, the sticking forces' sides first; if
/// none does, the edges first chosen stay.
fn jointly_consistent_edges(
    model: &Model,
    data: &mut Data,
    tau: &[f64],
    rest: &[usize],
) -> Result<()> {
    let edged: Vec<usize> = rest
        .iter()
        .copied()
        .filter(|&i| data.sliding[i].sigma != 0.0)
        .collect();
    if edged.len() >= 2 && !jointly_consistent(model, data, tau, &edged)? {
        let chosen: Vec<(Option<f64>, f64)> = edged
            .iter()
            .map(|&i| (data.sliding[i].held, data.sliding[i].sigma))
            .collect();
        let mut found = false;
        for flips in 1u32..(1 << edged.len()) {
            let mut valid = true;
            for (b, &i) in edged.iter().enumerate() {
                let sigma = if flips >> b & 1 == 1 {
                    -chosen[b].1
                } else {
                    chosen[b].1
                };
                valid &= set_edge(data, i, tau, sigma);
            }
            if valid && jointly_consistent(model, data, tau, &edged)? {
                found = true;
                break;
            }
        }
        if !found {
            for (b, &i) in edged.iter().enumerate() {
                let s = &mut data.sliding[i];
                (s.held, s.sigma) = chosen[b];
                if s.general {
                    s.coef = s.mu_k * s.sigma;
                }
            }
        }
    }
    Ok(())
}

/// Whether every site of `sites`, each on the edge `σ` set on it, starts sliding against
/// its force, `σ v̇_t ≥ −`[`INCONSISTENT_ACCEL_M_S2`], under the forces set on every site (one
/// KKT solve).
fn jointly_consistent(
    model: &Model,
    data: &mut Data,
    tau: &[f64],
    sites: &[usize],
) -> Result<bool> {
    let i0 = sites[0];
    match sliding_acceleration(model, data, tau, i0) {
        Err(CoreError::PainleveInconsistent { .. }) => return Ok(false),
        r => r?,
    };
    Ok(sites.iter().all(|&i| {
        let s = &data.sliding[i];
        let a_t_qdd: f64 = s.a_t.iter().map(|&(k, a)| a * data.qdd[k]).sum();
        let vdot = -(a_t_qdd + s.a_t_dot_qd);
        // and pushes: λ_n = held / (μ_k σ) ≤ 0 (a folded site: its own λ_n)
        let pushes = match s.held {
            Some(f) => f * s.sigma <= 0.0,
            None => !s.general || data.lambda[s.row] <= 0.0,
        };
        s.sigma * vdot >= -INCONSISTENT_ACCEL_M_S2 && pushes
    }))
}

/// `v̇_t` of site `i` under the forces currently set on every site (one KKT solve).
fn sliding_acceleration(model: &Model, data: &mut Data, tau: &[f64], i: usize) -> Result<f64> {
    assemble(model, data, tau)?;
    solve_dynamics(model, data, tau, None)?;
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

/// Puts site `i` on the cone edge `σ` (`sigma`): a statics site with its force from its
/// leg's statics (`false` at a wedge), a general one with `coef = μ_k σ` to be folded in.
fn set_edge(data: &mut Data, i: usize, tau: &[f64], sigma: f64) -> bool {
    let mu_k = data.sliding[i].mu_k;
    if data.sliding[i].general {
        let s = &mut data.sliding[i];
        (s.held, s.coef, s.sigma) = (None, mu_k * sigma, sigma);
        return true;
    }
    match edge_force(data, i, tau, mu_k * sigma) {
        Some(f) => {
            data.sliding[i].held = Some(f);
            data.sliding[i].sigma = sigma;
            true
        }
        None => false,
    }
}

/// `(Υ − C̄q̇ − N̄ + f^fr, −Ȧq̇) ⇒ (q̈, λ)` into `data.qdd`, `data.lambda` at the prepared
/// state, with the friction force as last assembled, and the friction of the general
/// sliding sites folded in (a typed error where that system is singular or inconsistent).
pub(crate) fn solve_dynamics(
    model: &Model,
    data: &mut Data,
    tau: &[f64],
    free_joint_qdd: Option<&[f64]>,
) -> Result<()> {
    let (mut x, mut y) = (
        std::mem::take(&mut data.qdd),
        std::mem::take(&mut data.lambda),
    );
    data.solve_prepared(
        |d, a| d.generalized_force_at(model, tau, a),
        |d, r| -d.constraints.a_dot_qd.as_slice()[r],
        free_joint_qdd,
        &mut x,
        &mut y,
    );
    (data.qdd, data.lambda) = (x, y);
    // general sliding sites: their friction, linear in their λ_n, folded in
    if data.has_general {
        fold_general(model, data)?;
    }
    Ok(())
}

/// Folds the friction of the general sliding sites into the solved dynamics at the prepared
/// state: `data.qdd`, `data.lambda` become the solution of the nonsymmetric system
/// `[M̄ (A + B)ᵀ; A 0]`, `data.friction` gains their force and each site's `force_t` is set
/// (module docs, "The general sliding site"), on the fold's buffers kept in `data.fold`.
// cold: the default leap has no general site, and its solve stays as small as before
#[cold]
#[inline(never)]
pub(crate) fn fold_general(model: &Model, data: &mut Data) -> Result<()> {
    if !data.sliding.iter().any(folds) {
        return Ok(());
    }
    let mut x = std::mem::take(&mut data.fold.x);
    x.clear();
    x.extend(data.dynamic_coords.iter().map(|&k| data.qdd[k]));
    let folded = fold_into(
        model,
        &mut data.kkt,
        &data.dynamic_coords,
        &data.sliding,
        &mut data.fold,
        &mut x,
        data.lambda.as_mut_slice(),
    );
    for (p, &k) in data.dynamic_coords.iter().enumerate() {
        data.qdd[k] = x[p];
    }
    data.fold.x = x;
    if !folded? {
        return Ok(());
    }
    let friction = data.friction.as_mut_slice();
    for (i, l) in data.fold.forces() {
        let s = &mut data.sliding[i];
        s.force_t = s.coef * l;
        for &(k, a_tk) in &s.a_t {
            friction[k] -= s.coef * l * a_tk;
        }
    }
    Ok(())
}

/// The fold itself on a factored symmetric KKT system (`kkt` on `coords`, with the solution
/// `x` (on `coords`), `y` (rows) for the force without the friction of the sites that fold,
/// [`folds`]), formed in `fold`: the solution of the system with it, and each such site's
/// `λ_n` in `fold` ([`Fold::forces`]); `false`, and `x`, `y` untouched, when no site
/// folds. A typed error, `x` and `y` untouched, where `I − Y` is singular
/// (Lemma 5.1 for the folded system) or the mode is inconsistent (Painlevé).
fn fold_into(
    model: &Model,
    kkt: &mut crate::kkt::KktFactorization,
    coords: &[usize],
    sliding: &[SlidingSite],
    fold: &mut Fold,
    x: &mut [f64],
    y: &mut [f64],
) -> Result<bool> {
    if !fold.form(model, kkt, coords, sliding)? {
        return Ok(false);
    }
    fold.solve(model, kkt, coords.len(), sliding, x, y)?;
    Ok(true)
}
