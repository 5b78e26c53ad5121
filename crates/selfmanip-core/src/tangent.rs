//! Exact first derivatives of the constrained dynamics (5.3)–(5.4) and of the plastic impact
//! (5.10)/(5.52) with respect to the state `(q, q̇)` and the joint torques `Υ`: the engine-level
//! derivatives behind the variational equations and saltation matrices of
//! `selfmanip_hybrid::sensitivity`.
//!
//! **Assembly, by closed forms.** Every angle of a planar tree is linear in `q`
//! (`β_Q = φ + Σ_{k ≤ Q} s_k θ_k`), so a material point `p` of part `P` is
//! `p = X + Σ_Q R(β_Q) l_Q` over the parts `Q` from the body to `P` (with `r_Q = R(β_Q) l_Q` the
//! world lever from `Q`'s origin to the next origin, or to `p`). Writing `ω_Q(a) = ∂β_Q · a`
//! (constant in `q`) and `S = perp` (`S r = (r_z, −r_x)`, `S² = −I`):
//!
//! ```text
//! Dp[a]       = (a_x, a_z) + Σ_Q ω_Q(a) S r_Q                  (= J_p a)
//! D²p[a,b]    = −Σ_Q ω_Q(a) ω_Q(b) r_Q                          (J̇_p q̇ = D²p[q̇,q̇])
//! D³p[a,b,c]  = −Σ_Q ω_Q(a) ω_Q(b) ω_Q(c) S r_Q
//! ```
//!
//! From these, with the core's own assembly `M̄ = Σ m JᵀJ + I J_ωᵀJ_ω`, `C̄q̇ = Σ m Jᵀ D²p[q̇,q̇]`,
//! `N̄ = −Σ m g J_zᵀ` and the rows `A_r x = −d_r · J_c x`, `Ȧq̇_r = −d_r · D²c[q̇,q̇]` (where `c` is
//! the contact's material point, or the centre of a rolling arc, whose contact point is the
//! centre plus a constant offset on a plane):
//!
//! ```text
//! (D_q M̄[v] x)_i   = Σ m (D²p[e_i,v]·Dp[x] + Dp[e_i]·D²p[x,v])      (J_ω is constant)
//! D_q(C̄q̇)[v]_i   = Σ m (D²p[e_i,v]·D²p[q̇,q̇] + Dp[e_i]·D³p[q̇,q̇,v])
//! D_q̇(C̄q̇)[w]_i   = Σ m Dp[e_i]·2D²p[q̇,w]
//! D_q N̄[v]_i      = −Σ m g D²p[e_i,v]_z
//! (D_q A[v] x)_r   = −d_r·D²c[x,v]          D_q(Ȧq̇)[v]_r = −d_r·D³c[q̇,q̇,v]
//!                                           D_q̇(Ȧq̇)[w]_r = −2 d_r·D²c[q̇,w]
//! ```
//!
//! **The KKT solution, by implicit differentiation** with the factorization the forward
//! solve already made: `K z = b ⇒ K dz = db − dK z`, i.e.
//! `K [dq̈; dλ] = [dΥ − d(C̄q̇) − dN̄ − dM̄ q̈ − dAᵀλ; −d(Ȧq̇) − dA q̈]`. The factorization is the
//! null-space one of Lemma 5.1 ([`crate::kkt`]), so a singular `M̄` (massless limbs in contact)
//! is covered as long as `K` is regular. Free massless joints (thesis 5.1.1) have prescribed
//! accelerations: their rows of the Jacobians are zero here (a caller whose prescription
//! depends on the state adds its own derivative), and their columns of `M̄` and `A` vanish
//! identically, so they do not enter the other rows. Locked joints' prescribed `q̈ = 0`
//! enters through `dA q̈` with its own column.
//!
//! **Kinetic (Coulomb) friction** of a sliding site ([`crate::friction`]), with its sliding
//! direction `σ` and `μ_k` constant along the arc:
//! - on a single-joint massless leg, its force `f^fr = −μ_kσ λ_n A_tᵀ` has `λ_n = f_j/den`
//!   from the leg's statics, a known generalized force: `δf^fr` enters the right-hand side
//!   (`applied_terms_along`);
//! - at a general site (a body end, a massive or multi-joint leg, a leg with another contact)
//!   the forward solve is the folded nonsymmetric system `K' = [M̄ (A + B)ᵀ; A 0]`, `B`'s
//!   row of the site's normal `μ_kσ A_t`. Its derivative is `K' dz = db − dK' z` with the
//!   extra `dBᵀλ`, `(D_q B_k[v])_i = −μ_kσ_k t̂_k·D²c[e_i, v]` (the tangential row's
//!   derivative, the normal row's formula with `t̂` for `d_r`; `B` does not depend on `q̇`,
//!   `Υ` or the body's inertia), solved with `K'` by the forward solve's own block
//!   elimination on the symmetric factorization (`friction::Fold`). Massless joints
//!   in contact inside the fold are covered as the forward solve covers them: `K` is the
//!   same null-space factorization, and the fold is exact on it.
//!
//! The plastic impact carries no kinetic friction (Assumption 5.9, kept for sliding sites):
//! its derivative involves none, and a mode with general sliding sites is differentiated as
//! any other.
//!
//! Geometric parameters (a link's length, a point contact's position) move `A` and `Ȧ` too:
//! their partials are in `crate::geometry_partials`.
//!
//! Not covered: a contact on a terrain corner (its frame turns with the site; a typed
//! [`TangentError::TurningFrame`]); a sliding site whose friction is a sticking force at
//! rest ([`TangentError::FrictionAtRest`]).
use crate::constraint::geometry_of;
use crate::contact::{row_direction, ContactGeometry, ContactMode, RowDirection, TouchKind};
use crate::dynamics::{forward_dynamics, plastic_impact, Data, Impact};
use crate::error::CoreError;
use crate::frames::perp;
use crate::friction::fold::Fold;
use crate::kinematics::{Kinematics, Part};
use crate::model::{ContactShape, Model};
use crate::Terrain;
use nalgebra::{DMatrix, DVector, Vector2};

/// Why a derivative could not be formed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TangentError {
    #[error(transparent)]
    Core(#[from] CoreError),
    /// The contact's frame turns with the site (a terrain corner): `Ḃ ≠ 0` terms are not
    /// differentiated yet.
    #[error("contact {contact} is on a terrain corner; its turning frame is not differentiated")]
    TurningFrame { contact: usize },
    /// A sliding site with kinetic friction whose force comes from sticking (a site at
    /// rest, or jammed at a wedge, `selfmanip_core::friction`): not differentiated.
    #[error(
        "the friction force of contact {contact} is a sticking force at rest; not differentiated"
    )]
    FrictionAtRest { contact: usize },
    /// A parameter that is not one of this model's: a joint index out of range, or the
    /// armature of a joint without it (a free massless joint's armature is not a parameter
    /// of its dynamics: any armature takes the joint out of the massless ones).
    #[error("{parameter:?} is not a parameter of this model: {reason}")]
    NotAParameter {
        parameter: BodyParameter,
        reason: &'static str,
    },
}

/// The levers of one material point: per part `Q` from the body out to the point's part,
/// the coefficients of `ω_Q` (coordinate, factor) and the world lever `r_Q`. The
/// coefficients of each part's `ω_Q` are a prefix of those of the next part out, so they are
/// kept once (`coef`), each segment holding its prefix's length; the buffers are reused by
/// [`Self::reset`].
#[derive(Debug, Clone, Default)]
struct Lever {
    n: usize,
    coef: Vec<(usize, f64)>,
    segs: Vec<Segment>,
}

/// One part of a lever: the length of its prefix of [`Lever::coef`] (the coefficients
/// `(coordinate, factor)` of its `ω_Q`) and its `r_Q`.
type Segment = (usize, Vector2<f64>);

impl Lever {
    fn new(model: &Model, kin: &Kinematics, part: Part, p: Vector2<f64>) -> Self {
        let mut lever = Lever::default();
        lever.reset(model, kin, part, p);
        lever
    }

    /// Re-forms the lever in place (no allocation once its buffers are large enough).
    fn reset(&mut self, model: &Model, kin: &Kinematics, part: Part, p: Vector2<f64>) {
        let n = model.n_joints();
        self.n = n;
        self.coef.clear();
        self.coef.push((n + 2, 1.0));
        self.segs.clear();
        match part {
            Part::Body => self.segs.push((1, p - kin.body_pos)),
            Part::Link(j) => {
                let first = *model.chain(j).start();
                self.segs.push((1, kin.origin[first] - kin.body_pos));
                for k in first..=j {
                    self.coef.push((k, model.joints[k].axis_sign));
                    let end = if k == j { p } else { kin.origin[k + 1] };
                    self.segs.push((self.coef.len(), end - kin.origin[k]));
                }
            }
        }
    }

    /// `ω_Q(a)` for every part `Q` of the lever.
    fn omegas(&self, a: &[f64]) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.segs.len());
        self.omegas_into(a, &mut out);
        out
    }

    /// [`Self::omegas`] into `out` (cleared first).
    fn omegas_into(&self, a: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend(
            self.segs
                .iter()
                .map(|&(len, _)| self.coef[..len].iter().map(|&(k, s)| s * a[k]).sum::<f64>()),
        );
    }

    /// `Dp[a]`.
    fn d1(&self, wa: &[f64], a: &[f64]) -> Vector2<f64> {
        let mut v = Vector2::new(a[self.n], a[self.n + 1]);
        for ((_, r), w) in self.segs.iter().zip(wa) {
            v += *w * perp(*r);
        }
        v
    }

    /// `D²p[a, b]`.
    fn d2(&self, wa: &[f64], wb: &[f64]) -> Vector2<f64> {
        let mut v = Vector2::zeros();
        for (((_, r), x), y) in self.segs.iter().zip(wa).zip(wb) {
            v -= (x * y) * r;
        }
        v
    }

    /// `D³p[a, b, c]`.
    fn d3(&self, wa: &[f64], wb: &[f64], wc: &[f64]) -> Vector2<f64> {
        let mut v = Vector2::zeros();
        for ((((_, r), x), y), z) in self.segs.iter().zip(wa).zip(wb).zip(wc) {
            v -= (x * y * z) * perp(*r);
        }
        v
    }
}

/// A lever with its values along the unit coordinates and the velocity.
#[derive(Debug, Clone, Default)]
struct Point {
    lever: Lever,
    /// `ω(e_i)` for every coordinate `i` (one run of the lever's length each) and `Dp[e_i]`.
    w_e: Vec<f64>,
    j_e: Vec<Vector2<f64>>,
    /// `ω(q̇)` and `D²p[q̇, q̇]`.
    w_qd: Vec<f64>,
    acc0: Vector2<f64>,
    /// `ω(x)` and `Dp[x]` of the vector `x` the derivatives act on ([`Assembly::set_x`]).
    w_x: Vec<f64>,
    px: Vector2<f64>,
    /// Whether every lever `r_Q` is the zero vector (the body's centre of mass, its frame's
    /// origin): then `D²p` and `D³p` vanish, and its terms in [`Assembly::dq_terms_along`]
    /// and [`Assembly::dqd_terms_along`] are zeros (of either sign) added to sums that start
    /// at `+0`, which leaves them as they are; they are not formed.
    zero_lever: bool,
}

impl Point {
    /// Re-forms the point in place (no allocation once its buffers are large enough). Only a
    /// `mass`'s point carries `Dp[e_i]` and `D²p[q̇, q̇]` (a constraint row's terms do not
    /// use them), and a mass's point with a zero lever nothing beyond its lever (its terms
    /// are not formed: [`Self::zero_lever`]).
    fn reset(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        part: Part,
        p: Vector2<f64>,
        qd: &[f64],
        mass: bool,
    ) {
        self.lever.reset(model, kin, part, p);
        let lever = &self.lever;
        self.zero_lever = lever.segs.iter().all(|(_, r)| r.x == 0.0 && r.y == 0.0);
        if mass && self.zero_lever {
            return;
        }
        let nq = model.nq();
        let ns = lever.segs.len();
        self.w_e.clear();
        self.w_e.resize(nq * ns, 0.0);
        for (s, &(len, _)) in lever.segs.iter().enumerate() {
            for &(k, f) in &lever.coef[..len] {
                self.w_e[k * ns + s] += f;
            }
        }
        let w_e = &self.w_e;
        self.j_e.clear();
        self.j_e.extend((0..if mass { nq } else { 0 }).map(|i| {
            let mut v = Vector2::zeros();
            if i == lever.n {
                v.x = 1.0;
            } else if i == lever.n + 1 {
                v.y = 1.0;
            }
            for ((_, r), w) in lever.segs.iter().zip(&w_e[i * ns..(i + 1) * ns]) {
                v += *w * perp(*r);
            }
            v
        }));
        lever.omegas_into(qd, &mut self.w_qd);
        if mass {
            self.acc0 = lever.d2(&self.w_qd, &self.w_qd);
        }
        self.w_x.clear();
        self.w_x.resize(ns, 0.0);
        self.px = Vector2::zeros();
    }

    /// Becomes a copy of `other` (no allocation once its buffers are large enough).
    fn copy_from(&mut self, other: &Point) {
        self.lever.n = other.lever.n;
        self.lever.coef.clone_from(&other.lever.coef);
        self.lever.segs.clone_from(&other.lever.segs);
        self.w_e.clone_from(&other.w_e);
        self.j_e.clone_from(&other.j_e);
        self.w_qd.clone_from(&other.w_qd);
        self.acc0 = other.acc0;
        self.w_x.clone_from(&other.w_x);
        self.px = other.px;
        self.zero_lever = other.zero_lever;
    }

    /// `ω(e_i)`.
    fn we(&self, i: usize) -> &[f64] {
        let ns = self.lever.segs.len();
        &self.w_e[i * ns..(i + 1) * ns]
    }
}

/// The assembly's directional derivatives at one state (see the module docs). Its buffers
/// are kept across states ([`Self::reset`]): only the first `n_masses` masses and `n_rows`
/// rows are the current state's.
#[derive(Debug, Clone, Default)]
struct Assembly {
    nq: usize,
    gravity: f64,
    /// Massive parts: mass and centre of mass.
    masses: Vec<(f64, Point)>,
    n_masses: usize,
    /// Constraint rows: direction `d_r` and the contact's material point (or rolling centre).
    rows: Vec<(Vector2<f64>, Point)>,
    n_rows: usize,
    /// Per row of the current state: whether its point is the previous row's (the normal
    /// and tangential rows of one contact), so that the directional terms formed for the
    /// one serve the other.
    shared: Vec<bool>,
    /// Passive joint springs: `(joint, ∂τ^p/∂q_j, ∂τ^p/∂q̇_j)` at the current state.
    springs: Vec<(usize, f64, f64)>,
    /// Sliding sites with kinetic friction at the current state ([`SlidingTerm`]): the first
    /// `n_sliding` (buffers kept across states).
    sliding: Vec<SlidingTerm>,
    n_sliding: usize,
    /// General sliding sites whose friction is folded into the dynamics solve
    /// (`crate::friction`, "The general sliding site"): `(row, μ_k σ, t̂)` with `row` its
    /// normal row (an index of [`Self::rows`], whose point it shares) and `t̂` its tangential
    /// row's direction, so that its row of `B` is `μ_k σ A_t`, `A_t x = −t̂ · J_c x`.
    general: Vec<(usize, f64, Vector2<f64>)>,
    /// A sliding site whose friction force is a sticking force at rest (its contact).
    at_rest: Option<usize>,
}

impl Assembly {
    /// The assembly at the state `data` was prepared at with rates `qd`, for the flow's
    /// derivatives: [`Self::reset`], refused with friction at rest ([`Self::check_flow`]),
    /// and the fold of its general sliding sites ([`Self::fold`]).
    fn prepare_flow(
        &mut self,
        model: &Model,
        data: &mut Data,
        qd: &[f64],
    ) -> Result<Option<Box<Fold>>, TangentError> {
        self.reset(model, data, qd)?;
        self.check_flow()?;
        self.fold(model, data)
    }

    /// [`Self::prepare_flow`] for the derivatives of the flow's solution in `data` (after
    /// [`forward_dynamics`] at rates `qd`): the evaluation point `x = q̈` ([`Self::set_x`])
    /// and a copy of `λ` in `lambda`.
    fn prepare_flow_solution(
        &mut self,
        model: &Model,
        data: &mut Data,
        qd: &[f64],
        lambda: &mut Vec<f64>,
    ) -> Result<Option<Box<Fold>>, TangentError> {
        let fold = self.prepare_flow(model, data, qd)?;
        self.set_x(data.qdd.as_slice());
        lambda.clear();
        lambda.extend_from_slice(data.lambda.as_slice());
        Ok(fold)
    }

    /// Whether the flow's friction forces are differentiated here (none at rest).
    fn check_flow(&self) -> Result<(), TangentError> {
        match self.at_rest {
            Some(contact) => Err(TangentError::FrictionAtRest { contact }),
            None => Ok(()),
        }
    }
}

/// A sliding site with kinetic friction at one state, as its derivative needs it: the
/// friction force `f^fr = −μ_k σ λ_n A_tᵀ` with `λ_n = f_j / den`,
/// `den = (A_n)_j + μ_k σ (A_t)_j` ([`crate::friction`], the statics of its massless leg).
#[derive(Debug, Clone, Default)]
struct SlidingTerm {
    /// Its normal row (an index of [`Assembly::rows`], whose point it shares).
    row: usize,
    joint: usize,
    /// `μ_k σ`.
    coef: f64,
    /// The tangential row's direction `t̂` and the row `A_t` (dense, `nq`).
    d_t: Vector2<f64>,
    a_t: Vec<f64>,
    den: f64,
    lambda_n: f64,
}

/// The next slot of `v` (a new one only when all are in use).
fn next_slot<T: Default>(v: &mut Vec<T>, used: &mut usize) -> usize {
    if *used == v.len() {
        v.push(T::default());
    }
    *used += 1;
    *used - 1
}

impl Assembly {
    fn new(model: &Model, data: &Data, qd: &[f64]) -> Result<Self, TangentError> {
        let mut asm = Assembly::default();
        asm.reset(model, data, qd)?;
        Ok(asm)
    }

    /// Re-forms the assembly at `data`'s state in place.
    fn reset(&mut self, model: &Model, data: &Data, qd: &[f64]) -> Result<(), TangentError> {
        let kin = &data.kin;
        self.nq = model.nq();
        self.gravity = model.gravity_m_s2;
        self.n_masses = 0;
        self.n_rows = 0;
        let s = next_slot(&mut self.masses, &mut self.n_masses);
        self.masses[s].0 = model.body_mass_kg;
        self.masses[s]
            .1
            .reset(model, kin, Part::Body, kin.body_pos, qd, true);
        for (i, j) in model.joints.iter().enumerate() {
            if !j.is_massless() {
                let p = kin.point(Part::Link(i), j.com_m);
                let s = next_slot(&mut self.masses, &mut self.n_masses);
                self.masses[s].0 = j.mass_kg;
                self.masses[s]
                    .1
                    .reset(model, kin, Part::Link(i), p, qd, true);
            }
        }
        let cons = &data.constraints;
        self.shared.clear();
        let mut prev = None;
        for row in &cons.rows {
            let geo = geometry_of(&cons.geometry, row.contact);
            let shared = prev == Some(row.contact);
            let c = if shared {
                None
            } else {
                Some(differentiable_point(model, kin, row.contact, geo)?)
            };
            let d = row_direction(&geo.plane, row.direction);
            let s = next_slot(&mut self.rows, &mut self.n_rows);
            self.rows[s].0 = d;
            match c {
                // the same contact's point as the row before: the same numbers
                None => {
                    let (done, this) = self.rows.split_at_mut(s);
                    this[0].1.copy_from(&done[s - 1].1);
                }
                Some(c) => self.rows[s].1.reset(model, kin, geo.part, c, qd, false),
            }
            self.shared.push(shared);
            prev = Some(row.contact);
        }
        self.springs.clear();
        for (j, joint) in model.joints.iter().enumerate() {
            if let Some(sp) = &joint.spring {
                // θ_j from the link angles (β_j = β_parent + s_j θ_j)
                let parent = if j == *model.chain(j).start() {
                    kin.phi
                } else {
                    kin.beta[j - 1]
                };
                let theta = model.joints[j].axis_sign * (kin.beta[j] - parent);
                let d = theta - sp.rest_angle_rad;
                self.springs.push((
                    j,
                    -sp.stiffness_n_m_per_rad - 3.0 * sp.cubic_stiffness_n_m_per_rad3 * d * d,
                    -sp.damping_n_m_s_per_rad,
                ));
            }
        }
        self.n_sliding = 0;
        self.at_rest = None;
        self.general.clear();
        for site in &data.sliding {
            if site.held.is_some() || site.at_rest || site.wedged {
                // a force from sticking (a site at rest, or jammed at a wedge): its
                // derivative is that of a sticking row, not formed here (an error of the
                // flow's derivatives only: an impact involves no force)
                self.at_rest.get_or_insert(site.contact);
                continue;
            }
            if site.coef == 0.0 {
                continue;
            }
            let geo = geometry_of(&cons.geometry, site.contact);
            if site.general {
                // folded into the solve (`crate::friction::fold_general`): a row of `B`
                let d_t = row_direction(&geo.plane, RowDirection::Tangential);
                self.general.push((site.row, site.coef, d_t));
                continue;
            }
            let slot = next_slot(&mut self.sliding, &mut self.n_sliding);
            let term = &mut self.sliding[slot];
            term.a_t.clear();
            term.a_t.resize(self.nq, 0.0);
            for &(k, v) in &site.a_t {
                term.a_t[k] += v;
            }
            let c = cons.n_rows();
            let a_nj = cons.a.as_slice()[site.joint * c + site.row];
            term.den = a_nj + site.coef * term.a_t[site.joint];
            term.row = site.row;
            term.joint = site.joint;
            term.coef = site.coef;
            term.d_t = row_direction(&geo.plane, RowDirection::Tangential);
            term.lambda_n = site.force_t / site.coef;
        }
        Ok(())
    }

    /// `f −= d(τ^p) + d(f^fr)`: the passive springs' and the kinetic friction's derivatives
    /// along a direction `v` of `q`, `w` of `q̇` and `δΥ` of the torques (`dtau(j)`), added
    /// to a right-hand side `f` of [`Self::dq_terms_along`]'s sign (`K δz = −f`), with `wv` a
    /// scratch buffer. With `λ_n = f_j/den` and `f^fr = −μ_kσ λ_n A_tᵀ`:
    /// `δλ_n = (δf_j − λ_n δden)/den`, `δf_j = δΥ_j + δτ^p_j`,
    /// `δden = (D_qA_n[v])_j + μ_kσ (D_qA_t[v])_j`, `(D_qA_r[v])_i = −d_r·D²c[e_i, v]`, and
    /// `δf^fr = −μ_kσ (δλ_n A_tᵀ + λ_n D_qA_t[v]ᵀ)`.
    fn applied_terms_along(
        &self,
        v: Option<&[f64]>,
        w: Option<&[f64]>,
        dtau: &dyn Fn(usize) -> f64,
        wv: &mut Vec<f64>,
        f: &mut DVector<f64>,
    ) {
        let spring = |j: usize| -> f64 {
            self.springs
                .iter()
                .filter(|s| s.0 == j)
                .map(|&(_, kq, kqd)| v.map_or(0.0, |v| kq * v[j]) + w.map_or(0.0, |w| kqd * w[j]))
                .sum()
        };
        for &(j, _, _) in &self.springs {
            f[j] -= spring(j);
        }
        for s in &self.sliding[..self.n_sliding] {
            let (d_n, p) = &self.rows[s.row];
            let lv = &p.lever;
            let j = s.joint;
            let df_j = dtau(j) + spring(j);
            let mut dden = 0.0;
            if let Some(v) = v {
                lv.omegas_into(v, wv);
                let d2 = lv.d2(p.we(j), wv);
                dden = -d_n.dot(&d2) - s.coef * s.d_t.dot(&d2);
            }
            let dlam = (df_j - s.lambda_n * dden) / s.den;
            for i in 0..self.nq {
                let mut di = dlam * s.a_t[i];
                if v.is_some() {
                    di -= s.lambda_n * s.d_t.dot(&lv.d2(p.we(i), wv));
                }
                f[i] += s.coef * di;
            }
        }
    }

    /// `f += δ(f^fr terms)` of the kinetic friction under a unit step of the geometric
    /// parameter `p` (`crate::geometry_partials`), of [`Self::applied_terms_along`]'s sign:
    /// a general site's `δBᵀλ = μ_kσ λ_n δA_tᵀ`, a single-joint massless leg's
    /// `μ_kσ (δλ_n A_tᵀ + λ_n δA_tᵀ)` with `δλ_n = −λ_n δden/den`,
    /// `δden = (δA_n)_j + μ_kσ (δA_t)_j`, `δA_r = −(d_r · S u) J_ω,Q`.
    fn geometric_friction_terms(
        &self,
        p: BodyParameter,
        model: &Model,
        data: &Data,
        y: &[f64],
        f: &mut DVector<f64>,
    ) {
        let (kin, cons) = (&data.kin, &data.constraints);
        for &(row, coef, d_t) in &self.general {
            let l = coef * y[row];
            if l == 0.0 {
                continue;
            }
            let contact = cons.rows[row].contact;
            let st = p.row_shift(model, kin, contact, d_t, |_, _| {});
            p.row_shift(model, kin, contact, d_t, |i, w| f[i] -= l * w * st);
        }
        for s in &self.sliding[..self.n_sliding] {
            let contact = cons.rows[s.row].contact;
            let d_n = self.rows[s.row].0;
            let mut wj = 0.0;
            let sn = p.row_shift(model, kin, contact, d_n, |i, w| {
                if i == s.joint {
                    wj = w
                }
            });
            let st = p.row_shift(model, kin, contact, s.d_t, |_, _| {});
            if sn == 0.0 && st == 0.0 {
                continue;
            }
            let dden = -(sn + s.coef * st) * wj;
            let dlam = -s.lambda_n * dden / s.den;
            for i in 0..self.nq {
                f[i] += s.coef * dlam * s.a_t[i];
            }
            let l = s.coef * s.lambda_n;
            p.row_shift(model, kin, contact, s.d_t, |i, w| f[i] -= l * w * st);
        }
    }

    /// `f += D_q B[v]ᵀ y`: the folded friction's part of `dK' z` along a direction `v` of
    /// `q` (`K' = [M̄ (A + B)ᵀ; A 0]`, `z = (q̈, λ)`, module docs), added to a right-hand side
    /// `f` of [`Self::dq_terms_along`]'s sign, with `wv` a scratch buffer. Row `k` of `B` is
    /// `μ_k σ_k A_t,k` with `σ_k`, `μ_k` constant along a sliding arc, so
    /// `(D_q B_k[v])_i = −μ_k σ_k t̂_k · D²c[e_i, v]` — the tangential row's derivative, of the
    /// same form as a normal row's with `t̂` for `d_r` — and its weight is the site's normal
    /// force `y_row(k)`. The flow only: an impact carries no kinetic friction
    /// (Assumption 5.9).
    fn general_terms_along(&self, v: &[f64], y: &[f64], wv: &mut Vec<f64>, f: &mut DVector<f64>) {
        for &(row, coef, d_t) in &self.general {
            let l = coef * y[row];
            if l == 0.0 {
                continue;
            }
            let p = &self.rows[row].1;
            let lv = &p.lever;
            lv.omegas_into(v, wv);
            for i in 0..self.nq {
                f[i] -= l * d_t.dot(&lv.d2(p.we(i), wv));
            }
        }
    }

    /// The fold of the general sliding sites' friction at the prepared state
    /// (`friction::Fold`: the solve with `K'` from the symmetric factorization), if
    /// any site folds.
    fn fold(&self, model: &Model, data: &mut Data) -> Result<Option<Box<Fold>>, TangentError> {
        if self.general.is_empty() {
            return Ok(None);
        }
        // boxed: the fold's buffers stay put while the result moves through the callers
        Ok(Fold::new(model, &mut data.kkt, &data.dynamic_coords, &data.sliding)?.map(Box::new))
    }

    /// The current state's masses.
    fn masses(&self) -> &[(f64, Point)] {
        &self.masses[..self.n_masses]
    }

    /// The current state's rows.
    fn rows(&self) -> &[(Vector2<f64>, Point)] {
        &self.rows[..self.n_rows]
    }

    /// Sets the vector `x` that [`Self::dq_terms`] differentiates `M̄ x`, `A x` along.
    fn set_x(&mut self, x: &[f64]) {
        // `Dp[x]` enters the masses' terms only (none for a zero lever)
        for (_, p) in self.masses[..self.n_masses].iter_mut() {
            if !p.zero_lever {
                p.lever.omegas_into(x, &mut p.w_x);
                p.px = p.lever.d1(&p.w_x, x);
            }
        }
        for (_, p) in self.rows[..self.n_rows].iter_mut() {
            p.lever.omegas_into(x, &mut p.w_x);
        }
    }

    /// Along the coordinate `q_k`: `(D_q M̄ x + D_q(C̄q̇) + D_q N̄ + D_q Aᵀ y, D_q A x + D_q(Ȧq̇))`
    /// for the `x` of [`Self::set_x`] and `y` given (the `C̄q̇`, `N̄`, `Ȧq̇` terms only when
    /// `with_velocity`: an impact has none).
    fn dq_terms(&self, k: usize, y: &[f64], with_velocity: bool) -> (DVector<f64>, DVector<f64>) {
        let mut e = vec![0.0; self.nq];
        e[k] = 1.0;
        let (mut f, mut g) = (DVector::zeros(0), DVector::zeros(0));
        let mut scratch = Scratch::default();
        self.dq_terms_along(&e, y, with_velocity, &mut scratch, &mut f, &mut g);
        (f, g)
    }

    /// [`Self::dq_terms`] along an arbitrary direction `v` of `q` (the terms are linear in
    /// the direction: `ω(e_k)` becomes `ω(v)`), into `f`, `g` (zeroed and sized here), with
    /// `scratch` buffers. A row whose point is the previous row's ([`Self::shared`]) reuses
    /// the previous row's `ω(v)`, `D²c[x, v]`, `D³c[q̇, q̇, v]` and `D²c[e_i, v]` (the same
    /// numbers: the same point and direction).
    fn dq_terms_along(
        &self,
        v: &[f64],
        y: &[f64],
        with_velocity: bool,
        scratch: &mut Scratch,
        f: &mut DVector<f64>,
        g: &mut DVector<f64>,
    ) {
        let nq = self.nq;
        zero_sized(f, nq);
        let Scratch { w: wv, d2: d2s } = scratch;
        for (m, p) in self.masses().iter().filter(|(_, p)| !p.zero_lever) {
            let lv = &p.lever;
            lv.omegas_into(v, wv);
            let wv = &wv[..];
            let pxv = lv.d2(&p.w_x, wv);
            let d3 = with_velocity.then(|| lv.d3(&p.w_qd, &p.w_qd, wv));
            for i in 0..nq {
                let pie = lv.d2(p.we(i), wv);
                let mut s = pie.dot(&p.px) + p.j_e[i].dot(&pxv);
                if let Some(d3) = d3 {
                    s += pie.dot(&p.acc0) + p.j_e[i].dot(&d3) - self.gravity * pie.y;
                }
                f[i] += m * s;
            }
        }
        zero_sized(g, self.n_rows);
        // `D²c[x, v]`, `D³c[q̇, q̇, v]` of the last point, and whether `d2s` holds its
        // `D²c[e_i, v]`
        let (mut dxv, mut d3v, mut have_e) = (Vector2::zeros(), Vector2::zeros(), false);
        for (r, (d, p)) in self.rows().iter().enumerate() {
            let lv = &p.lever;
            if !self.shared[r] {
                lv.omegas_into(v, wv);
                dxv = lv.d2(&p.w_x, wv);
                if with_velocity {
                    d3v = lv.d3(&p.w_qd, &p.w_qd, wv);
                }
                have_e = false;
            }
            let mut s = -d.dot(&dxv);
            if with_velocity {
                s -= d.dot(&d3v);
            }
            g[r] = s;
            if y[r] != 0.0 {
                if !have_e {
                    d2s.clear();
                    d2s.extend((0..nq).map(|i| lv.d2(p.we(i), wv)));
                    have_e = true;
                }
                for i in 0..nq {
                    f[i] -= y[r] * d.dot(&d2s[i]);
                }
            }
        }
    }

    /// [`Self::dqd_terms`] along an arbitrary direction `w` of `q̇`, into `f`, `g` (zeroed and
    /// sized here), with `ww` a scratch buffer.
    fn dqd_terms_along(
        &self,
        w: &[f64],
        ww: &mut Vec<f64>,
        f: &mut DVector<f64>,
        g: &mut DVector<f64>,
    ) {
        let nq = self.nq;
        zero_sized(f, nq);
        for (m, p) in self.masses().iter().filter(|(_, p)| !p.zero_lever) {
            p.lever.omegas_into(w, ww);
            let a = 2.0 * p.lever.d2(&p.w_qd, ww);
            for i in 0..nq {
                f[i] += m * p.j_e[i].dot(&a);
            }
        }
        zero_sized(g, self.n_rows);
        let mut a = Vector2::zeros();
        for (r, (d, p)) in self.rows().iter().enumerate() {
            // a row whose point is the previous row's: the same `D²c[q̇, w]`
            if !self.shared[r] {
                p.lever.omegas_into(w, ww);
                a = p.lever.d2(&p.w_qd, ww);
            }
            g[r] = -2.0 * d.dot(&a);
        }
    }
}

/// Scratch buffers of the directional terms: `ω` along a direction, and `D²c[e_i, v]` of a
/// point for every coordinate `i` ([`Assembly::dq_terms_along`]).
#[derive(Debug, Clone, Default)]
struct Scratch {
    w: Vec<f64>,
    d2: Vec<Vector2<f64>>,
}

/// `a += b` (as nalgebra's `+=` forms it, entry by entry, on the slices).
fn add_to(a: &mut DVector<f64>, b: &DVector<f64>) {
    assert_eq!(a.len(), b.len(), "add_to: mismatched lengths");
    for (x, y) in a.as_mut_slice().iter_mut().zip(b.as_slice()) {
        *x += y;
    }
}

/// Sets `v` to `n` zeros, allocating only when its length changes.
#[inline]
pub(crate) fn zero_sized(v: &mut DVector<f64>, n: usize) {
    if v.len() == n {
        v.as_mut_slice().fill(0.0);
    } else {
        *v = DVector::zeros(n);
    }
}

/// Sets `a` to `r × c` zeros, allocating only when its shape changes.
fn zero_shaped(a: &mut DMatrix<f64>, r: usize, c: usize) {
    if a.shape() == (r, c) {
        a.as_mut_slice().fill(0.0);
    } else {
        *a = DMatrix::zeros(r, c);
    }
}

/// The material point whose second and third derivatives give a contact row's: the contact
/// point itself for a point touch, the centre of a rolling arc on a plane (the contact point
/// is the centre plus a constant offset there).
pub(crate) fn differentiable_point(
    model: &Model,
    kin: &Kinematics,
    contact: usize,
    geo: &ContactGeometry,
) -> Result<Vector2<f64>, TangentError> {
    if geo.on_corner || geo.normal_rate != Vector2::zeros() {
        return Err(TangentError::TurningFrame { contact });
    }
    Ok(match (geo.touch, &model.contacts[contact].shape) {
        (TouchKind::Rolling, ContactShape::Arc { center_m, .. }) => kin.point(geo.part, *center_m),
        _ => geo.point,
    })
}

/// Solves `K [x; y] = [σf; σg]` with `data`'s factorization into column `k` of `x_out`
/// (prescribed joints get 0) and of `y_out` (if given), on reusable buffers; with a
/// [`Fold`], the folded system `K' = [M̄ (A + B)ᵀ; A 0]` of the general sliding sites
/// instead ([`Self::solve_folded`]).
#[derive(Debug, Default)]
struct Solver {
    fr: Vec<f64>,
    gr: Vec<f64>,
    xr: Vec<f64>,
    y: Vec<f64>,
    /// The folded sites' normal forces ([`Fold::lambda`]).
    lambda: Vec<f64>,
}

impl Solver {
    #[allow(clippy::too_many_arguments)]
    fn solve(
        &mut self,
        data: &mut Data,
        sigma: f64,
        f: &DVector<f64>,
        g: &DVector<f64>,
        k: usize,
        x_out: &mut DMatrix<f64>,
        y_out: Option<&mut DMatrix<f64>>,
    ) {
        self.solve_reduced(data, sigma, f, g);
        self.scatter(data, k, x_out, y_out);
    }

    /// [`Self::solve`] with the system `K'` of `fold` when given (the flow with general
    /// sliding sites), `K` otherwise.
    #[allow(clippy::too_many_arguments)]
    fn solve_folded(
        &mut self,
        data: &mut Data,
        fold: Option<&Fold>,
        sigma: f64,
        f: &DVector<f64>,
        g: &DVector<f64>,
        k: usize,
        x_out: &mut DMatrix<f64>,
        y_out: Option<&mut DMatrix<f64>>,
    ) -> Result<(), TangentError> {
        self.solve_reduced(data, sigma, f, g);
        if let Some(fold) = fold {
            fold.lambda(&self.y, &mut self.lambda)?;
            fold.add(&self.lambda, &mut self.xr, &mut self.y);
        }
        self.scatter(data, k, x_out, y_out);
        Ok(())
    }

    /// `K [x; y] = [σf; σg]` on the dynamic coordinates into `xr`, `y`.
    fn solve_reduced(&mut self, data: &mut Data, sigma: f64, f: &DVector<f64>, g: &DVector<f64>) {
        self.fr.clear();
        self.fr
            .extend(data.dynamic_coords.iter().map(|&a| sigma * f[a]));
        self.gr.clear();
        self.gr.extend(g.iter().map(|v| sigma * v));
        self.xr.resize(self.fr.len(), 0.0);
        self.y.resize(g.len(), 0.0);
        data.kkt
            .solve(&self.fr, &self.gr, &mut self.xr, &mut self.y);
    }

    /// `xr`, `y` into column `k` of `x_out` (prescribed joints 0) and of `y_out`.
    fn scatter(
        &self,
        data: &Data,
        k: usize,
        x_out: &mut DMatrix<f64>,
        y_out: Option<&mut DMatrix<f64>>,
    ) {
        let nr = x_out.nrows();
        let col = &mut x_out.as_mut_slice()[k * nr..(k + 1) * nr];
        col.fill(0.0);
        for (&a, v) in data.dynamic_coords.iter().zip(&self.xr) {
            col[a] = *v;
        }
        if let Some(y_out) = y_out {
            let nr = y_out.nrows();
            y_out.as_mut_slice()[k * nr..(k + 1) * nr].copy_from_slice(&self.y);
        }
    }
}

/// The partial derivatives `∂y/∂q`, `∂y/∂q̇` of one quantity `y` over the state `(q, q̇)`
/// (each `dim y × nq`): the flow's `q̈` and `λ` ([`DynamicsJacobian`]), an impact's `q̇⁺`
/// over `(q, q̇⁻)` ([`ImpactJacobian`]), a controller's torques and free joints' `q̈`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StatePartials {
    /// `∂y/∂q`.
    pub dq: DMatrix<f64>,
    /// `∂y/∂q̇`.
    pub dqd: DMatrix<f64>,
}

impl StatePartials {
    /// Zero partials of a quantity with `rows` entries over `nq` coordinates.
    pub fn zeros(rows: usize, nq: usize) -> Self {
        StatePartials {
            dq: DMatrix::zeros(rows, nq),
            dqd: DMatrix::zeros(rows, nq),
        }
    }

    /// Both blocks set to zero at `rows × nq`, resized only when their shape changes.
    pub fn zero_shaped(&mut self, rows: usize, nq: usize) {
        zero_shaped(&mut self.dq, rows, nq);
        zero_shaped(&mut self.dqd, rows, nq);
    }
}

/// `∂(q̈, λ)/∂(q, q̇, Υ)` of the flow (5.3)–(5.4) at one state (rows of `λ` as in
/// `data.constraints.rows`). Rows of free and locked massless joints are zero: their `q̈` is
/// prescribed.
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicsJacobian {
    /// `∂q̈/∂(q, q̇)` (`nq × nq` each).
    pub dqdd: StatePartials,
    /// `nq × n`: one column per joint torque.
    pub dqdd_dtau: DMatrix<f64>,
    /// `∂λ/∂(q, q̇)` (`c × nq` each).
    pub dlambda: StatePartials,
    pub dlambda_dtau: DMatrix<f64>,
}

/// [`forward_dynamics`] at `(mode, q, q̇, Υ)` (results in `data` as usual) and its exact
/// Jacobian: closed-form assembly derivatives and one solve with the KKT factorization per
/// direction (`2 nq + n` solves).
#[allow(clippy::too_many_arguments)]
pub fn dynamics_jacobian(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    free_joint_qdd: Option<&[f64]>,
) -> Result<DynamicsJacobian, TangentError> {
    forward_dynamics(model, data, terrain, mode, q, qd, tau, free_joint_qdd)?;
    dynamics_jacobian_solved(model, data, qd)
}

/// [`dynamics_jacobian`] after [`forward_dynamics`] (or [`crate::forward_dynamics_prepared`])
/// at the same state, whose `q̇` is given again: `data` holds the factorization, `q̈` and `λ`.
pub fn dynamics_jacobian_solved(
    model: &Model,
    data: &mut Data,
    qd: &[f64],
) -> Result<DynamicsJacobian, TangentError> {
    let mut ws = JacobianWorkspace::default();
    let mut out = DynamicsJacobian::default();
    dynamics_jacobian_solved_into(model, data, qd, &mut ws, &mut out)?;
    Ok(out)
}

impl Default for DynamicsJacobian {
    /// Empty (`0 × 0`) blocks, to be sized by [`dynamics_jacobian_solved_into`].
    fn default() -> Self {
        DynamicsJacobian {
            dqdd: StatePartials::zeros(0, 0),
            dqdd_dtau: DMatrix::zeros(0, 0),
            dlambda: StatePartials::zeros(0, 0),
            dlambda_dtau: DMatrix::zeros(0, 0),
        }
    }
}

/// The reusable buffers of [`dynamics_jacobian_solved_into`]: the assembly at the current
/// state, a copy of `λ`, the unit direction, the right-hand sides and the KKT solve's. Kept
/// by a caller that forms many Jacobians (an integrator's stages), so that after the first
/// call of a given size no call allocates.
#[derive(Debug, Default)]
pub struct JacobianWorkspace {
    asm: Assembly,
    lambda: Vec<f64>,
    e: Vec<f64>,
    scratch: Scratch,
    f: DVector<f64>,
    g: DVector<f64>,
    zeros: DVector<f64>,
    solver: Solver,
}

/// [`dynamics_jacobian_solved`] on the buffers of `ws`, into `out` (whose blocks are resized
/// only when their shapes change): the same arithmetic, in the same order, so the results
/// are bit-identical to [`dynamics_jacobian_solved`]'s.
pub fn dynamics_jacobian_solved_into(
    model: &Model,
    data: &mut Data,
    qd: &[f64],
    ws: &mut JacobianWorkspace,
    out: &mut DynamicsJacobian,
) -> Result<(), TangentError> {
    let JacobianWorkspace {
        asm,
        lambda,
        e,
        scratch,
        f,
        g,
        zeros,
        solver,
    } = ws;
    let fold = asm.prepare_flow_solution(model, data, qd, lambda)?;
    let fold = fold.as_deref();
    let (nq, n, c) = (model.nq(), model.n_joints(), data.constraints.n_rows());
    out.dqdd.zero_shaped(nq, nq);
    zero_shaped(&mut out.dqdd_dtau, nq, n);
    out.dlambda.zero_shaped(c, nq);
    zero_shaped(&mut out.dlambda_dtau, c, n);
    e.clear();
    e.resize(nq, 0.0);
    let no_tau = |_: usize| 0.0;
    for k in 0..nq {
        e[k] = 1.0;
        asm.dq_terms_along(e, lambda, true, scratch, f, g);
        let wv = &mut scratch.w;
        asm.applied_terms_along(Some(e), None, &no_tau, wv, f);
        asm.general_terms_along(e, lambda, wv, f);
        let (x, y) = (&mut out.dqdd.dq, &mut out.dlambda.dq);
        solver.solve_folded(data, fold, -1.0, f, g, k, x, Some(y))?;
        asm.dqd_terms_along(e, wv, f, g);
        asm.applied_terms_along(None, Some(e), &no_tau, wv, f);
        let (x, y) = (&mut out.dqdd.dqd, &mut out.dlambda.dqd);
        solver.solve_folded(data, fold, -1.0, f, g, k, x, Some(y))?;
        e[k] = 0.0;
    }
    zero_sized(zeros, c);
    for j in 0..n {
        // δ(Υ + f^fr) along the unit torque of joint j (the friction's through f_j)
        zero_sized(f, nq);
        asm.applied_terms_along(
            None,
            None,
            &|i| if i == j { 1.0 } else { 0.0 },
            &mut scratch.w,
            f,
        );
        f.neg_mut();
        f[j] += 1.0;
        let (x, y) = (&mut out.dqdd_dtau, &mut out.dlambda_dtau);
        solver.solve_folded(data, fold, 1.0, f, zeros, j, x, Some(y))?;
    }
    Ok(())
}

/// The plastic impact (5.10)/(5.52) into a mode and the Jacobian of its velocity map
/// `q̇⁺(q, q̇⁻)`.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactJacobian {
    pub impact: Impact,
    /// `∂q̇⁺/∂(q, q̇⁻)` (`nq × nq` each).
    pub dqd_plus: StatePartials,
}

/// [`plastic_impact`] into `mode` at `(q, q̇⁻)` and its exact Jacobian. With
/// `K [Δq̇; P] = [0; −A q̇⁻]` and `q̇⁺ = q̇⁻ + Δq̇`:
/// `K [dΔ; dP] = [−dM̄ Δq̇ − dAᵀ P; −dA q̇⁺]` along `q` and `[0; −A w]` along `q̇⁻ = w`
/// (so `∂q̇⁺/∂q̇⁻ = I − A†ᵀA`, the projection of (5.52)). Free massless joints keep their
/// velocity, as in the impact itself.
pub fn plastic_impact_jacobian(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    qd_minus: &[f64],
) -> Result<ImpactJacobian, TangentError> {
    let impact = plastic_impact(model, data, terrain, mode, q, qd_minus)?;
    let mut asm = Assembly::new(model, data, qd_minus)?;
    let nq = model.nq();
    let c = data.constraints.n_rows();
    let dx: Vec<f64> = (0..nq).map(|i| impact.qd_plus[i] - qd_minus[i]).collect();
    let p: Vec<f64> = impact.impulse.iter().copied().collect();
    let qd_plus: Vec<f64> = impact.qd_plus.iter().copied().collect();
    let mut out = ImpactJacobian {
        impact,
        dqd_plus: StatePartials {
            dq: DMatrix::zeros(nq, nq),
            dqd: DMatrix::identity(nq, nq),
        },
    };
    // −dM̄ Δ − dAᵀ P  and  −dA Δ − dA q̇⁻ = −dA q̇⁺ (by linearity in the vector)
    asm.set_x(&dx);
    let f1: Vec<DVector<f64>> = (0..nq).map(|k| asm.dq_terms(k, &p, false).0).collect();
    asm.set_x(&qd_plus);
    let zeros = vec![0.0; c];
    let mut solver = Solver::default();
    let mut x = DMatrix::zeros(nq, 1);
    let zero_f = DVector::zeros(nq);
    for (k, f1) in f1.into_iter().enumerate() {
        let (_, g1) = asm.dq_terms(k, &zeros, false);
        solver.solve(data, -1.0, &f1, &g1, k, &mut out.dqd_plus.dq, None);
        let g = data.constraints.a.column(k).clone_owned();
        solver.solve(data, -1.0, &zero_f, &g, 0, &mut x, None);
        for i in 0..nq {
            out.dqd_plus.dqd[(i, k)] += x[i];
        }
    }
    Ok(out)
}

/// The gradient over `q` of contact `k`'s height above its plane (the touchdown guard
/// (5.49)), `−n · J_c`: at a rolling arc the offset from the centre is along `n`, so its
/// turning adds nothing.
pub fn height_gradient(model: &Model, kin: &Kinematics, geo: &ContactGeometry) -> DVector<f64> {
    let mut row = vec![0.0; model.nq()];
    kin.point_jacobian_row(model, geo.part, geo.point, geo.plane.normal(), &mut row);
    DVector::from_iterator(row.len(), row.into_iter().map(|v| -v))
}

/// The gradient over `(q, q̇)` of contact `k`'s sliding velocity `t · v` (the material
/// velocity of its part at the contact point along the plane's tangent; the stick guard):
/// `∂/∂q̇ = t · J_c` and `∂/∂q [v] = t · D²c[q̇, v]` with `c` the material point, or the
/// centre of a rolling arc (the contact point's offset from it is constant on a plane).
pub fn sliding_velocity_gradient(
    model: &Model,
    kin: &Kinematics,
    geo: &ContactGeometry,
    k: usize,
    qd: &[f64],
) -> Result<(DVector<f64>, DVector<f64>), TangentError> {
    let nq = model.nq();
    let t = geo.plane.tangent();
    let mut row = vec![0.0; nq];
    kin.point_jacobian_row(model, geo.part, geo.point, t, &mut row);
    let c = differentiable_point(model, kin, k, geo)?;
    let lever = Lever::new(model, kin, geo.part, c);
    let w_qd = lever.omegas(qd);
    let mut e = vec![0.0; nq];
    let mut dq = DVector::zeros(nq);
    for i in 0..nq {
        e[i] = 1.0;
        dq[i] = t.dot(&lever.d2(&w_qd, &lever.omegas(&e)));
        e[i] = 0.0;
    }
    Ok((dq, DVector::from_vec(row)))
}

/// A parameter of the model's bodies: its inertia — the body's mass and inertia, a joint's
/// armature, a link's mass, inertia and centre of mass (`M̄`, `C̄q̇` and `N̄` depend on them
/// at fixed geometry, `A` and `Ȧq̇` do not; partials in [`crate::inertia_partials`]) — or its
/// geometry — a link's length, a point contact's position (they move `A`, `Ȧq̇` and the
/// guards too; partials in `crate::geometry_partials`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BodyParameter {
    /// `m_b` (kg).
    Mass,
    /// `I_b` (kg m²).
    Inertia,
    /// The armature `a_j` of joint `j` (kg m²), a joint that has armature: at `a_j = 0` a
    /// joint on massless links is removed from the dynamics, so the derivative there is not
    /// the limit of this one ([`Self::check`]).
    Armature(usize),
    /// The mass `m_j` of joint `j`'s link (kg), a link that has mass.
    LinkMass(usize),
    /// The inertia `I_j` of joint `j`'s link about its centre of mass (kg m²), a link that
    /// has inertia.
    LinkInertia(usize),
    /// Coordinate `axis` (0 or 1) of the centre of mass of joint `j`'s link in the link's
    /// frame (m): `LinkCom(j, axis)`.
    LinkCom(usize, usize),
    /// The length of joint `j`'s link (m), its lever `(0, l)` to the next joint: it moves the
    /// links beyond it (their centres and contacts), so `A`, `Ȧ`, the impacts and the
    /// guards (`crate::geometry_partials`). With `com_follows` the link's own centre of
    /// mass is at its middle `[0, l/2]` (a description's default) and moves with it.
    LinkLength { joint: usize, com_follows: bool },
    /// Coordinate `axis` (0 or 1) of point contact `k`'s position in its part's frame (m):
    /// `ContactPosition(k, axis)`; it moves `A`, `Ȧ`, the impacts and the contact's guards.
    ContactPosition(usize, usize),
}

/// The directions of a Jacobian-times-matrix product of the flow ([`dynamics_jvp`]): `m`
/// columns, each a direction `(δq, δq̇)` of the state (`nq × m` each), a direction `δΥ` of the
/// joint torques (`n × m`), optionally one body parameter per column (its unit
/// direction added to the column), and optionally a direction `δQ` of a generalized force
/// on the robot (`nq × m`, entering as a torque does; a friction coefficient's column,
/// `selfmanip_hybrid::sensitivity`).
#[derive(Debug, Clone)]
pub struct FlowDirections<'a> {
    pub dq: &'a DMatrix<f64>,
    pub dqd: &'a DMatrix<f64>,
    pub dtau: &'a DMatrix<f64>,
    pub body: &'a [Option<BodyParameter>],
    pub force: Option<&'a DMatrix<f64>>,
}

/// `(δq̈, δλ)` along each column of `dirs` (`nq × m`, `c × m`), after [`forward_dynamics`] (or
/// [`crate::forward_dynamics_prepared`]) at the same state, whose `q̇` is given again: the
/// product of the exact Jacobian of [`dynamics_jacobian_solved`] with the directions, formed
/// without the Jacobian (the assembly's derivatives are linear in the direction, so each
/// column costs one set of directional terms and one solve with the KKT factorization,
/// instead of `2 nq + n` solves for the full Jacobian). A body parameter adds
/// `K [δq̈; δλ] = [−∂M̄/∂p q̈ − ∂N̄/∂p; 0]` to its column. Rows of free and locked massless
/// joints are zero, as in [`DynamicsJacobian`].
pub fn dynamics_jvp(
    model: &Model,
    data: &mut Data,
    qd: &[f64],
    dirs: &FlowDirections,
) -> Result<(DMatrix<f64>, DMatrix<f64>), TangentError> {
    let mut ws = JvpWorkspace::default();
    let (mut dqdd, mut dlambda) = (DMatrix::zeros(0, 0), DMatrix::zeros(0, 0));
    dynamics_jvp_into(model, data, qd, dirs, &mut ws, &mut dqdd, &mut dlambda)?;
    Ok((dqdd, dlambda))
}

/// The reusable buffers of [`dynamics_jvp_into`]: the assembly at the current state, copies of
/// `q̈` and `λ`, the right-hand sides of each column and the KKT solve's. Kept by a caller that
/// evaluates many products (an integrator's stages), so that after the first call of a given
/// size no call allocates.
#[derive(Debug, Default)]
pub struct JvpWorkspace {
    asm: Assembly,
    qdd: Vec<f64>,
    lambda: Vec<f64>,
    scratch: Scratch,
    f: DVector<f64>,
    g: DVector<f64>,
    fv: DVector<f64>,
    gv: DVector<f64>,
    fw: DVector<f64>,
    gw: DVector<f64>,
    fb: DVector<f64>,
    gb: DVector<f64>,
    solver: Solver,
}

/// [`dynamics_jvp`] on the buffers of `ws`, into `dqdd` (`nq × m`) and `dlambda` (`c × m`),
/// which are resized only when their shapes change: the same arithmetic, in the same order,
/// so the results are bit-identical to [`dynamics_jvp`]'s.
#[allow(clippy::too_many_arguments)]
pub fn dynamics_jvp_into(
    model: &Model,
    data: &mut Data,
    qd: &[f64],
    dirs: &FlowDirections,
    ws: &mut JvpWorkspace,
    dqdd: &mut DMatrix<f64>,
    dlambda: &mut DMatrix<f64>,
) -> Result<(), TangentError> {
    let JvpWorkspace {
        asm,
        qdd,
        lambda,
        scratch,
        f,
        g,
        fv,
        gv,
        fw,
        gw,
        fb,
        gb,
        solver,
    } = ws;
    let fold = asm.prepare_flow_solution(model, data, qd, lambda)?;
    let (nq, c, m) = (model.nq(), data.constraints.n_rows(), dirs.dq.ncols());
    qdd.clear();
    qdd.extend_from_slice(data.qdd.as_slice());
    zero_shaped(dqdd, nq, m);
    zero_shaped(dlambda, c, m);
    let (dq, dqd) = (dirs.dq.as_slice(), dirs.dqd.as_slice());
    for col in 0..m {
        let v = &dq[col * nq..(col + 1) * nq];
        let w = &dqd[col * nq..(col + 1) * nq];
        zero_sized(f, nq);
        zero_sized(g, c);
        if v.iter().any(|x| *x != 0.0) {
            asm.dq_terms_along(v, lambda, true, scratch, fv, gv);
            add_to(f, fv);
            add_to(g, gv);
            asm.general_terms_along(v, lambda, &mut scratch.w, f);
        }
        if w.iter().any(|x| *x != 0.0) {
            asm.dqd_terms_along(w, &mut scratch.w, fw, gw);
            add_to(f, fw);
            add_to(g, gw);
        }
        let nt = dirs.dtau.nrows();
        let dtau_col = &dirs.dtau.as_slice()[col * nt..(col + 1) * nt];
        for (fj, t) in f.as_mut_slice().iter_mut().zip(dtau_col) {
            *fj -= t;
        }
        if !asm.springs.is_empty() || asm.n_sliding > 0 {
            let dtau = |j: usize| dirs.dtau.get((j, col)).copied().unwrap_or(0.0);
            let nz = |x: &[f64]| x.iter().any(|v| *v != 0.0);
            asm.applied_terms_along(
                nz(v).then_some(v),
                nz(w).then_some(w),
                &dtau,
                &mut scratch.w,
                f,
            );
        }
        if let Some(p) = dirs.body.get(col).copied().flatten() {
            if p.is_geometric() {
                let x = (&qdd[..], &qdd[..]);
                let cons = &data.constraints;
                p.geometry_terms_into(model, &data.kin, cons, x, lambda, Some(qd), (fb, gb))?;
                asm.geometric_friction_terms(p, model, data, lambda, fb);
                *g += &*gb;
            } else {
                p.dm_x_into(model, &data.kin, qdd, Some(qd), fb);
            }
            *f += &*fb;
        }
        if let Some(dq_force) = dirs.force {
            *f -= dq_force.column(col);
        }
        solver.solve_folded(data, fold.as_deref(), -1.0, f, g, col, dqdd, Some(dlambda))?;
    }
    Ok(())
}

/// `∂q̇⁺/∂p` of the plastic impact for body parameters `ps`, right after
/// [`plastic_impact_jacobian`] (or [`plastic_impact`]) returned `impact` from `q̇⁻`: `data`
/// still holds the impact's factorization, and `K [δΔ; δP] = [−∂M̄/∂p Δq̇; 0]` for an inertia
/// parameter (`A` does not depend on masses), `−[∂M̄/∂p Δq̇ + ∂Aᵀ/∂p P; ∂A/∂p q̇⁺]` for a
/// geometric one (`crate::geometry_partials`); free massless joints keep their velocity.
/// One column per parameter.
pub fn plastic_impact_body_derivatives(
    model: &Model,
    data: &mut Data,
    impact: &Impact,
    qd_minus: &[f64],
    ps: &[BodyParameter],
) -> DMatrix<f64> {
    let nq = model.nq();
    let c = data.constraints.n_rows();
    let dx: Vec<f64> = (0..nq).map(|i| impact.qd_plus[i] - qd_minus[i]).collect();
    let mut out = DMatrix::zeros(nq, ps.len());
    let zeros = DVector::zeros(c);
    let mut solver = Solver::default();
    for (k, p) in ps.iter().enumerate() {
        if p.is_geometric() {
            let qd_plus = impact.qd_plus.as_slice();
            let (mut f, mut g) = (DVector::zeros(0), DVector::zeros(0));
            let terms = p.geometry_terms_into(
                model,
                &data.kin,
                &data.constraints,
                (&dx, qd_plus),
                impact.impulse.as_slice(),
                None,
                (&mut f, &mut g),
            );
            match terms {
                Ok(()) => solver.solve(data, -1.0, &f, &g, k, &mut out, None),
                // a site on a terrain corner: the column is not formed
                Err(_) => out.column_mut(k).fill(f64::NAN),
            }
            continue;
        }
        let f = p.dm_x(model, &data.kin, &dx, None);
        solver.solve(data, -1.0, &f, &zeros, k, &mut out, None);
    }
    out
}

/// The partial derivatives of an impact's terms at the state and rows `data` was prepared at
/// ([`Data::prepare`] or [`Data::prepare_geometry`], any mode), for impacts other than
/// [`plastic_impact_jacobian`]'s (the Coulomb impact's, whose impulse lies on cone edges:
/// `selfmanip_hybrid::coulomb_impact`). For vectors `x`, `z` (`nq`) and `y` (rows):
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactPartials {
    /// `D_q(M̄ x + Aᵀ y)` (`nq × nq`; column `k` along `q_k`).
    pub dq_mx_aty: DMatrix<f64>,
    /// `D_q(A z)` (`rows × nq`).
    pub dq_az: DMatrix<f64>,
    /// `∂M̄/∂p x` for each body parameter (`nq × |ps|`).
    pub dp_mx: DMatrix<f64>,
}

/// [`ImpactPartials`] at `data`'s state (its `q̇` given again as `qd`), by the closed forms of
/// the module docs (`(D_q M̄[v] x)`, `(D_q A[v] x)_r = −d_r·D²c[x, v]`).
pub fn impact_partials(
    model: &Model,
    data: &Data,
    qd: &[f64],
    (x, y, z): (&[f64], &[f64], &[f64]),
    ps: &[BodyParameter],
) -> Result<ImpactPartials, TangentError> {
    let nq = model.nq();
    let c = data.constraints.n_rows();
    debug_assert!(x.len() == nq && z.len() == nq && y.len() == c);
    let mut asm = Assembly::new(model, data, qd)?;
    let mut out = ImpactPartials {
        dq_mx_aty: DMatrix::zeros(nq, nq),
        dq_az: DMatrix::zeros(c, nq),
        dp_mx: DMatrix::zeros(nq, ps.len()),
    };
    asm.set_x(x);
    for k in 0..nq {
        out.dq_mx_aty.set_column(k, &asm.dq_terms(k, y, false).0);
    }
    asm.set_x(z);
    let zeros = vec![0.0; c];
    for k in 0..nq {
        out.dq_az.set_column(k, &asm.dq_terms(k, &zeros, false).1);
    }
    for (i, p) in ps.iter().enumerate() {
        out.dp_mx.set_column(i, &p.dm_x(model, &data.kin, x, None));
    }
    Ok(out)
}
