//! Plastic impact (5.10) of spatial contacts, every row held ([`impact`]), with Coulomb
//! friction on the circular cone, and with contacts free to leave the ground
//! ([`impact_with`], [`impact_outcomes`]): the spatial form of the planar engine's
//! velocity-level impact complementarity (`selfmanip_hybrid::coulomb_impact`, Stewart 2000 §4;
//! thesis (5.28)–(5.29) for the normal rows).
//!
//! ```text
//! contacts k with impact friction μ_k (PointContact::with_impact_friction), at (q, q̇⁻):
//!   M (q̇⁺ − q̇⁻) = Aᵀ P
//!   separate  P_k = 0,  n_kᵀ J_k q̇⁺ ≥ 0                      (Separation::Allowed only)
//!   held      n_kᵀ J_k q̇⁺ = 0,  P_n,k ≥ 0, and
//!     stick   t_kᵀ J_k q̇⁺ = 0 (both tangents),   |P_t,k| ≤ μ_k P_n,k
//!     slip    P_t,k = −μ_k P_n,k ŝ_k,  ŝ_k = v_t,k⁺/|v_t,k⁺|
//!   (μ = ∞: separate or stick, (5.10); μ = 0 or no tangent rows: separate or the normal row)
//! ```
//!
//! This is Coulomb's law itself, not a relaxation of it: the tangential impulse of a sliding
//! contact lies on the cone's edge exactly opposite the slip after the impact, and the normal
//! velocity after is zero whether the contact sticks or slips. (The convex second-order-cone
//! relaxation of Anitescu and of MuJoCo solves instead `p ∈ K_μ, W p + v⁻ ∈ K_μ*, p ⊥ W p + v⁻`,
//! whose sliding contacts leave the ground with `v_n⁺ = μ |v_t⁺|`: the normal and tangential
//! velocities are coupled, and that is not Coulomb's impact.)
//!
//! **How it is solved.** As the planar engine, by enumerating each contact's state (at most
//! [`MAX_COMBINATIONS`] combinations): a separating contact holds no row; a contact with a
//! finite `μ > 0` sticks or slips (with two tangent rows, `[t₁, t₂, n]`, the slip direction is
//! an angle `φ`, `ŝ = cos φ t₁ + sin φ t₂`; with one, `[t, n]`, it is `±t`, as in the planar
//! engine). For given states and directions the impact is one square linear system, the
//! sliding KKT system of [`super::coulomb`] with the impulse on the right:
//!
//! ```text
//! [M  −(A_h + B)ᵀ] [Δq̇]   [    0    ]      A_h: the rows held; B: −μ ŝᵀJ_p in each
//! [A_h     0     ] [P_h] = [−A_h q̇⁻ ]      slipping contact's normal row
//! ```
//!
//! (exact for a singular `M`, as the dynamics: the massless limbs without a held contact keep
//! their rates; without slips it is (5.10) on `A_h`, solved by [`super::contact`]'s
//! factorization). The slip angles solve `ŝ_k^⊥ · v_t,k⁺(φ) = 0` together with the linear
//! system, by Newton's method on both with the exact derivative `∂K/∂φ_k x = [μ_k P_n,k J_kᵀ
//! ŝ_k^⊥; 0]`: the bordered iteration stays regular where `K` alone is singular, a massless
//! stance limb slipping (the slip direction's equation fixes its rate, the light limb's
//! limit). It starts from the directions opposite the sticking impulse, of the frictionless
//! impact's slip, and of the slip before. A solution is kept when its inequalities hold (to
//! 1e-9 of the impulses' and velocities' scale) and the kinetic energy does not rise;
//! solutions with the same `q̇⁺` are one (the one holding more contacts, then sticking more,
//! names it). Redundant rows (four feet of a table) fix `Δq̇` and leave the impulse's split
//! open: the least-norm split where it satisfies the contacts' laws, else the minimum-norm
//! split that does ([`super::impulse_split`]). Why not an interior-point solve of the whole
//! cone program: it needs the Delassus operator `A M⁻¹ Aᵀ`, which a massless limb does not
//! have (thesis §5.1.3), and it would give the impulse to the solver's tolerance, where the
//! enumeration gives it to round-off.
//!
//! **Energy.** `ΔT = ½ (q̇⁺ + q̇⁻)ᵀ Aᵀ P = ½ (v⁺ + v⁻) · P` over the rows, which the states make
//! `−Σ μ P_n |v_t⁺| − ½ Δq̇ᵀ M Δq̇ ≤ 0` (a separating contact has `P = 0`).
#![allow(non_snake_case)]
use super::contact::{
    factor, free_rates, pin_free_rates, prepare, solve, unpin_free_rates, PointContact,
};
use super::coulomb::SINGULAR_PIVOT_RATIO;
use super::error::{SpatialError, SpatialResult};
use super::impulse_split::{cone_split, null_basis, SplitLaw};
use super::kinematics::SpatialData;
use super::model::SpatialModel;
use crate::error::check_result;
use nalgebra::DVectorView;
use nalgebra::{DMatrix, DVector, RowDVector, Vector3};
use std::cmp::Ordering;

/// The state a contact takes in a plastic impact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ImpactState {
    /// No impulse; its normal velocity after is non-negative: it leaves the ground (or grazes
    /// it). Only with [`Separation::Allowed`].
    Separate,
    /// Every row held: the contact point stops (μ = ∞, (5.10); or inside its cone).
    Stick,
    /// The normal row held; the impulse on the cone's edge, its tangential part
    /// `−μ P_n ŝ` opposing the contact point's slip `ŝ` after the impact (world, unit).
    Slip { direction: Vector3<f64> },
    /// The normal row held, no tangential impulse (a frictionless contact, or `μ = 0`).
    Frictionless,
}

/// Whether a contact may leave the ground in the impact.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Separation {
    /// Every contact is held (its normal velocity after zero), as (5.10).
    Forbidden,
    /// Each contact separates (`P = 0`, `v_n⁺ ≥ 0`) or is held (`P_n ≥ 0`, `v_n⁺ = 0`), by
    /// complementarity, `0 ≤ P_n ⊥ v_n⁺ ≥ 0` (the planar engine's impact, (5.28)–(5.29)).
    Allowed,
}

/// The outcome of a plastic impact.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialImpact {
    /// Post-impact rates `q̇⁺` (nv).
    pub v_plus: DVector<f64>,
    /// The ground's impulse on the robot along the rows (N·s), same sign as `λ`.
    pub impulse: DVector<f64>,
    /// Each contact's state, in the contacts' order.
    pub states: Vec<ImpactState>,
}

/// Plastic impact, thesis (5.10), every contact held: [`impact_with`] with
/// [`Separation::Forbidden`].
pub fn impact(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
    v_minus: &[f64],
) -> SpatialResult<SpatialImpact> {
    impact_with(model, data, contacts, q, v_minus, Separation::Forbidden)
}

/// Plastic impact into `contacts` at `(q, q̇⁻)`. With every contact held and no finite impact
/// friction it is (5.10): `[M Aᵀ; A 0][Δq̇; −P] = [0; −A q̇⁻]`, `q̇⁺ = q̇⁻ + Δq̇`, so `A q̇⁺ = 0`
/// and `M(q̇⁺ − q̇⁻) = Aᵀ P`. A massless limb in the air ([`free_rates`]) keeps its rates, as
/// in the planar core. Otherwise (a contact with a finite impact friction,
/// [`PointContact::with_impact_friction`], or `separation` [`Separation::Allowed`]) it is the
/// complementarity problem of the module's docs, whose outcome must be unique: none, or
/// several, is a typed error naming `contacts` ([`impact_outcomes`] lists them).
pub fn impact_with(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
    v_minus: &[f64],
    separation: Separation,
) -> SpatialResult<SpatialImpact> {
    let cones = contacts
        .iter()
        .any(|c| c.friction && c.impact_friction.is_finite());
    if cones || separation == Separation::Allowed {
        let all = impact_outcomes(model, data, contacts, q, v_minus, separation)?;
        return the_only(all, separation);
    }
    prepare(model, data, contacts, q, v_minus)?;
    let free = free_rates(model, contacts);
    let (delta_v, impulse) = held_rows_impact(data, &free, v_minus)?;
    let v_plus = DVector::from_column_slice(v_minus) + delta_v;
    check_result("q̇⁺", v_plus.as_slice())?;
    check_result("P", impulse.as_slice())?;
    let states = contacts
        .iter()
        .map(|c| match c.friction {
            true => ImpactState::Stick,
            false => ImpactState::Frictionless,
        })
        .collect();
    Ok(SpatialImpact {
        v_plus,
        impulse,
        states,
    })
}

/// `(Δq̇, P)` of (5.10) with every row of `data.A` held, at the prepared state: the free
/// rates (`free`) keep their values.
fn held_rows_impact(
    data: &mut SpatialData,
    free: &[usize],
    v_minus: &[f64],
) -> SpatialResult<(DVector<f64>, DVector<f64>)> {
    pin_free_rates(data, free);
    let factored = factor(data);
    unpin_free_rates(data, free);
    factored?;
    data.rhs_f.fill(0.0);
    let v = DVectorView::from_slice(v_minus, data.A.ncols());
    data.rhs_g.gemv(-1.0, &data.A, &v, 0.0);
    solve(data)?;
    Ok((data.qdd.clone(), -&data.lam))
}

/// How a contact's impulse is bounded in the impact.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Law {
    /// Every row held: `μ = ∞` with tangent rows, or a frictionless contact's normal row.
    Held,
    /// `μ = 0` on a contact with tangent rows: the normal row alone.
    NormalOnly,
    /// A finite `μ > 0`: stick or slip.
    Cone { mu: f64 },
}

/// A contact's rows in `A` and its law.
#[derive(Debug, Clone, Copy)]
struct Site {
    row: usize,
    n_rows: usize,
    law: Law,
    /// The rows' world directions ([`PointContact::directions`]).
    directions: [Vector3<f64>; 3],
}

impl Site {
    fn normal(&self) -> usize {
        self.row + self.n_rows - 1
    }
}

/// A contact's state in one combination.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Choice {
    /// No rows held, no impulse (with [`Separation::Allowed`]).
    Separate,
    /// Its law's fixed rows: every row of a [`Law::Held`] contact, the normal row alone of
    /// the others (on a cone: the frictionless impact that seeds the slip angles).
    Fixed,
    Stick,
    /// One tangent row: slipping along `sigma t` (σ = ±1).
    SlipSign {
        sigma: f64,
    },
    /// Two tangent rows: slipping at an angle found by Newton's method.
    SlipAngle,
}

/// The choices of a site, in enumeration order.
fn choices(site: &Site, separation: Separation) -> &'static [Choice] {
    use Choice::*;
    let allowed = separation == Separation::Allowed;
    match (site.law, site.n_rows, allowed) {
        (Law::Cone { .. }, 3, false) => &[Stick, SlipAngle],
        (Law::Cone { .. }, 3, true) => &[Separate, Stick, SlipAngle],
        (Law::Cone { .. }, _, false) => &[Stick, SlipSign { sigma: 1.0 }, SlipSign { sigma: -1.0 }],
        (Law::Cone { .. }, _, true) => &[
            Separate,
            Stick,
            SlipSign { sigma: 1.0 },
            SlipSign { sigma: -1.0 },
        ],
        (_, _, false) => &[Fixed],
        (_, _, true) => &[Separate, Fixed],
    }
}

/// The enumeration's bound: at most this many combinations of states (`∏_k` of each
/// contact's choices: 2 for a frictionless or `μ ∈ {0, ∞}` contact, 3 for a cone with two
/// tangents, 4 for a cone in a plane, with separation allowed). Each is one LU of
/// `nv + rows` unknowns, or Newton's method from at most three starts where a slip has an
/// angle: `3⁷ = 2187` combinations for seven feet in cones.
pub const MAX_COMBINATIONS: usize = 4096;

/// The prepared impact: `A` of every row, `q̇⁻`, `A q̇⁻`, `M` as prepared (free rates' columns
/// zero), and the contacts (whose held subset fixes the free rates of a combination).
struct Problem<'a> {
    model: &'a SpatialModel,
    contacts: &'a [PointContact],
    A: DMatrix<f64>,
    v_minus: DVector<f64>,
    v0: DVector<f64>,
    M: DMatrix<f64>,
    sites: Vec<Site>,
}

/// One solved combination: `Δq̇`, the impulse on every row, and the map `C = −(A_h + B)ᵀ`
/// from the held rows' impulses to the generalized impulse (its null space: the splits).
struct Trial {
    delta_v: DVector<f64>,
    impulse: DVector<f64>,
    coupling: DMatrix<f64>,
}

/// The solution of the square system `K x = b`: by LU, or where `K` is singular (redundant
/// rows: four body ends on the ground) the least-norm solution of its consistent equations
/// (`None` if they are not), which fixes `Δq̇` and leaves no impulse in the rows' internal
/// (indeterminate) combinations, as [`super::contact`]'s row-space factorization.
fn solve_square(K: DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let lu = K.clone().lu();
    let diag = lu.u().diagonal().map(f64::abs);
    if diag.min() > SINGULAR_PIVOT_RATIO * diag.max() {
        return lu.solve(b);
    }
    let svd = K.clone().svd(true, true);
    let top = svd.singular_values.max();
    if top.partial_cmp(&0.0) != Some(Ordering::Greater) {
        return None;
    }
    let x = svd.solve(b, 1e-12 * top).ok()?;
    let scale = (K.abs() * x.abs()).amax() + b.amax();
    ((&K * &x - b).amax() <= 1e-9 * scale).then_some(x)
}

/// What a trial's inequalities say ([`Problem::verdict`]).
enum Verdict {
    /// Every one holds: each contact's state.
    Holds(Vec<ImpactState>),
    /// Only impulses fail (a pull, a sticking impulse outside its cone): another split of
    /// redundant rows may pass.
    Impulse,
    /// A velocity fails (a separating contact approaching, a slip against its direction).
    Motion,
}

/// Newton's iteration limit for the slip angles.
const MAX_NEWTON: usize = 60;
/// Relative tolerance of the states' inequalities and of the energy check.
const INEQUALITY_TOLERANCE: f64 = 1e-9;

impl Problem<'_> {
    /// The rows held under `choice`: all of a sticking or held contact's, the normal of the
    /// rest, none of a separating one.
    fn held(&self, choice: &[Choice]) -> Vec<usize> {
        let mut rows = Vec::new();
        for (site, c) in self.sites.iter().zip(choice) {
            match (c, site.law) {
                (Choice::Separate, _) => {}
                (Choice::Stick, _) | (Choice::Fixed, Law::Held) => {
                    rows.extend(site.row..site.row + site.n_rows)
                }
                _ => rows.push(site.normal()),
            }
        }
        rows
    }

    /// The massless limbs in the air under `choice`: [`free_rates`] of the contacts held (a
    /// massless limb whose contact separates keeps its rates, as one in the air).
    fn free(&self, choice: &[Choice]) -> Vec<usize> {
        let held: Vec<PointContact> = self
            .contacts
            .iter()
            .zip(choice)
            .filter(|(_, &c)| c != Choice::Separate)
            .map(|(c, _)| c.clone())
            .collect();
        free_rates(self.model, &held)
    }

    /// `ŝᵀJ_p` and `ŝ^⊥ᵀJ_p` of a two-tangent site at angle `phi`.
    fn slip_rows(&self, site: &Site, phi: f64) -> (RowDVector<f64>, RowDVector<f64>) {
        let (t1, t2) = (self.A.row(site.row), self.A.row(site.row + 1));
        let (c, s) = (phi.cos(), phi.sin());
        (t1 * c + t2 * s, t2 * c - t1 * s)
    }

    /// `ŝᵀJ_p` of a slipping site (`None` if it does not slip).
    fn slip_row(&self, site: &Site, choice: Choice, phi: f64) -> Option<RowDVector<f64>> {
        match choice {
            Choice::SlipSign { sigma } => Some(self.A.row(site.row) * sigma),
            Choice::SlipAngle => Some(self.slip_rows(site, phi).0),
            _ => None,
        }
    }

    /// The impulse on every row from the held rows' `P_h` (slips on the cone's edge).
    fn full_impulse(
        &self,
        choice: &[Choice],
        held: &[usize],
        P_h: &DVector<f64>,
        phi: &[f64],
    ) -> DVector<f64> {
        let mut P = DVector::zeros(self.A.nrows());
        for (&r, &p) in held.iter().zip(P_h.iter()) {
            P[r] = p;
        }
        for ((site, &c), &phi) in self.sites.iter().zip(choice).zip(phi) {
            let (Law::Cone { mu }, n) = (site.law, site.normal()) else {
                continue;
            };
            match c {
                Choice::SlipSign { sigma } => P[site.row] = -mu * sigma * P[n],
                Choice::SlipAngle => {
                    P[site.row] = -mu * P[n] * phi.cos();
                    P[site.row + 1] = -mu * P[n] * phi.sin();
                }
                _ => {}
            }
        }
        P
    }

    /// The combination without slips: (5.10) on the held rows, by [`super::contact`]'s
    /// factorization (redundant rows on `A`'s row space, massless limbs exact); no rows held,
    /// no change.
    fn solve_held(&self, data: &mut SpatialData, choice: &[Choice]) -> SpatialResult<Trial> {
        let held = self.held(choice);
        let A_h = self.A.select_rows(&held);
        let coupling = -A_h.transpose();
        if held.is_empty() {
            return Ok(Trial {
                delta_v: DVector::zeros(self.A.ncols()),
                impulse: DVector::zeros(self.A.nrows()),
                coupling,
            });
        }
        data.A = A_h;
        data.rhs_g = DVector::zeros(held.len());
        data.lam = DVector::zeros(held.len());
        let free = self.free(choice);
        let (delta_v, P_h) = held_rows_impact(data, &free, self.v_minus.as_slice())?;
        let impulse = self.full_impulse(choice, &held, &P_h, &vec![0.0; choice.len()]);
        Ok(Trial {
            delta_v,
            impulse,
            coupling,
        })
    }

    /// The linear system of the module's doc at slip angles `phi` (per site): the rows held,
    /// `K` and its right-hand side (`M` with the combination's free rates pinned).
    fn assemble(&self, choice: &[Choice], phi: &[f64]) -> (Vec<usize>, DMatrix<f64>, DVector<f64>) {
        let held = self.held(choice);
        let (nv, m) = (self.A.ncols(), held.len());
        let mut K = DMatrix::zeros(nv + m, nv + m);
        K.view_mut((0, 0), (nv, nv)).copy_from(&self.M);
        let unit = (0..nv).map(|k| self.M[(k, k)]).fold(1.0, f64::max);
        for k in self.free(choice) {
            K[(k, k)] = unit;
        }
        let mut rhs = DVector::zeros(nv + m);
        for (i, &r) in held.iter().enumerate() {
            for c in 0..nv {
                K[(nv + i, c)] = self.A[(r, c)];
                K[(c, nv + i)] = -self.A[(r, c)];
            }
            rhs[nv + i] = -self.v0[r];
        }
        for ((site, &c), &phi) in self.sites.iter().zip(choice).zip(phi) {
            let (Law::Cone { mu }, Some(s)) = (site.law, self.slip_row(site, c, phi)) else {
                continue;
            };
            let i = held
                .iter()
                .position(|&r| r == site.normal())
                .expect("a slipping site's normal row is held");
            for col in 0..nv {
                K[(col, nv + i)] += mu * s[col];
            }
        }
        (held, K, rhs)
    }

    /// The trial of a combination whose slips have known directions (`phi`), by LU; `None`
    /// where the system is singular.
    fn solve_slipping(&self, choice: &[Choice], phi: &[f64]) -> Option<Trial> {
        let (held, K, rhs) = self.assemble(choice, phi);
        let nv = self.A.ncols();
        let coupling = K.view((0, nv), (nv, held.len())).into_owned();
        let x = solve_square(K, &rhs)?;
        let impulse = self.full_impulse(choice, &held, &x.rows(nv, held.len()).into_owned(), phi);
        Some(Trial {
            delta_v: x.rows(0, nv).into_owned(),
            impulse,
            coupling,
        })
    }

    /// The trial of a combination with slip angles to find: Newton's method on the linear
    /// system and the angles' equations `ŝ_k^⊥ · v_t,k⁺ = 0` together, from the angles `phi`
    /// (the least-squares solution of the system there to start). Solving both at once keeps
    /// the iteration regular where `K` alone is singular: a massless limb slipping on the
    /// ground, whose rate the slip direction's equation fixes (the light limb's limit).
    fn solve_angles(&self, choice: &[Choice], mut phi: Vec<f64>) -> Option<(Trial, Vec<f64>)> {
        let slipping: Vec<usize> = (0..choice.len())
            .filter(|&k| choice[k] == Choice::SlipAngle)
            .collect();
        let nv = self.A.ncols();
        let scale = self.v0.amax().max(1e-9);
        let (held, K, rhs) = self.assemble(choice, &phi);
        let (n, s) = (K.nrows(), slipping.len());
        let svd = K.svd(true, true);
        let mut x = svd.solve(&rhs, 1e-12 * svd.singular_values.max()).ok()?;
        let normal_of: Vec<usize> = slipping
            .iter()
            .map(|&k| held.iter().position(|&r| r == self.sites[k].normal()))
            .collect::<Option<_>>()?;
        for _ in 0..MAX_NEWTON {
            let (_, K, rhs) = self.assemble(choice, &phi);
            let v_plus = &self.v_minus + x.rows(0, nv);
            let rows: Vec<_> = slipping
                .iter()
                .map(|&k| self.slip_rows(&self.sites[k], phi[k]))
                .collect();
            let mut F = DVector::zeros(n + s);
            F.rows_mut(0, n).copy_from(&(&K * &x - &rhs));
            let mut J = DMatrix::zeros(n + s, n + s);
            J.view_mut((0, 0), (n, n)).copy_from(&K);
            for (j, (&k, (along, perp))) in slipping.iter().zip(&rows).enumerate() {
                let Law::Cone { mu } = self.sites[k].law else {
                    unreachable!("a slipping site has a cone")
                };
                F[n + j] = (perp * &v_plus)[0];
                let p_n = x[nv + normal_of[j]];
                for col in 0..nv {
                    J[(col, n + j)] = mu * p_n * perp[col];
                    J[(n + j, col)] = perp[col];
                }
                J[(n + j, n + j)] = -(along * &v_plus)[0];
            }
            let step = solve_square(J, &(-&F))?;
            if step.amax() <= 1e-13 * (1.0 + x.amax()) {
                // converged (to round-off); a root, not a stall, if the residuals are too
                let k_scale = (K.abs() * x.abs()).amax() + rhs.amax();
                let root =
                    F.rows(0, n).amax() <= 1e-10 * k_scale && F.rows(n, s).amax() <= 1e-10 * scale;
                x += step.rows(0, n);
                for (j, &k) in slipping.iter().enumerate() {
                    phi[k] += step[n + j];
                }
                let P_h = x.rows(nv, held.len()).into_owned();
                let impulse = self.full_impulse(choice, &held, &P_h, &phi);
                let delta_v = x.rows(0, nv).into_owned();
                let (_, K, _) = self.assemble(choice, &phi);
                let coupling = K.view((0, nv), (nv, held.len())).into_owned();
                let trial = Trial {
                    delta_v,
                    impulse,
                    coupling,
                };
                return root.then_some((trial, phi));
            }
            let big = step.rows(n, s).amax();
            let damp = if big > 0.5 { 0.5 / big } else { 1.0 };
            x += step.rows(0, n) * damp;
            for (j, &k) in slipping.iter().enumerate() {
                phi[k] += damp * step[n + j];
            }
        }
        None
    }

    /// The impact of a trial if every state's inequality holds and the energy does not rise.
    /// Where only impulses fail (a normal impulse pulls, a sticking impulse leaves its cone)
    /// and the held rows are redundant, the split of [`super::impulse_split`] is tried: the
    /// minimum-norm impulse with the same `Δq̇` that satisfies every contact's law.
    fn accept(&self, choice: &[Choice], trial: &Trial, phi: &[f64]) -> Option<SpatialImpact> {
        let v_plus = &self.v_minus + &trial.delta_v;
        let v_rows = &self.A * &v_plus;
        let (states, P) = match self.verdict(choice, (&v_plus, &v_rows), &trial.impulse, phi) {
            Verdict::Holds(states) => (states, trial.impulse.clone()),
            Verdict::Motion => return None,
            Verdict::Impulse => {
                let P = self.split(choice, trial, phi)?;
                match self.verdict(choice, (&v_plus, &v_rows), &P, phi) {
                    Verdict::Holds(states) => (states, P),
                    _ => return None,
                }
            }
        };
        // ΔT = ½ (v⁺ + v⁻) · P (module docs): the split moves P along ker (A_h + B)ᵀ, which
        // leaves the generalized impulse, and so ΔT, as it is
        let (after, before) = (v_rows.dot(&P), self.v0.dot(&P));
        let change = 0.5 * (after + before);
        let bound = INEQUALITY_TOLERANCE * (after.abs() + before.abs());
        if change.partial_cmp(&bound).is_none_or(Ordering::is_gt) {
            return None;
        }
        Some(SpatialImpact {
            v_plus,
            impulse: P,
            states,
        })
    }

    /// Each contact's state if its inequalities hold at `q̇⁺` and row velocities `v_rows`
    /// (after) with impulse `P`, else which kind fails.
    fn verdict(
        &self,
        choice: &[Choice],
        (v_plus, v_rows): (&DVector<f64>, &DVector<f64>),
        P: &DVector<f64>,
        phi: &[f64],
    ) -> Verdict {
        let (tol_p, tol_v) = (
            INEQUALITY_TOLERANCE * P.amax(),
            INEQUALITY_TOLERANCE * self.v0.amax() + 1e-12,
        );
        let mut states = Vec::with_capacity(self.sites.len());
        let mut pulls = false;
        for ((site, &c), &phi) in self.sites.iter().zip(choice).zip(phi) {
            let (r, n) = (site.row, site.normal());
            if c == Choice::Separate {
                // no impulse; leaving or grazing, never approaching
                if v_rows[n].partial_cmp(&-tol_v).is_none_or(Ordering::is_lt) {
                    return Verdict::Motion;
                }
                states.push(ImpactState::Separate);
                continue;
            }
            // every held contact's normal impulse pushes (held, frictionless or in a cone)
            pulls |= P[n].partial_cmp(&-tol_p).is_none_or(Ordering::is_lt);
            let state = match (site.law, c) {
                (Law::Held, _) if site.n_rows > 1 => ImpactState::Stick,
                (Law::Held | Law::NormalOnly, _) => ImpactState::Frictionless,
                (Law::Cone { mu }, Choice::Stick) => {
                    let tangential = P.rows(r, site.n_rows - 1).norm();
                    pulls |= tangential
                        .partial_cmp(&(mu * P[n] + tol_p))
                        .is_none_or(Ordering::is_gt);
                    ImpactState::Stick
                }
                (Law::Cone { .. }, _) => {
                    let s = self.slip_row(site, c, phi).expect("a slip");
                    if (s * v_plus)[0]
                        .partial_cmp(&-tol_v)
                        .is_none_or(Ordering::is_lt)
                    {
                        return Verdict::Motion;
                    }
                    ImpactState::Slip {
                        direction: self.slip_direction(site, c, phi),
                    }
                }
            };
            states.push(state);
        }
        if pulls {
            Verdict::Impulse
        } else {
            Verdict::Holds(states)
        }
    }

    /// The minimum-norm impulse of the trial's motion that satisfies every held contact's
    /// law ([`super::impulse_split`]), `None` without redundant rows or without such a split.
    fn split(&self, choice: &[Choice], trial: &Trial, phi: &[f64]) -> Option<DVector<f64>> {
        let held = self.held(choice);
        let N_h = null_basis(&trial.coupling);
        if N_h.ncols() == 0 {
            return None;
        }
        let columns: Vec<DVector<f64>> = N_h
            .column_iter()
            .map(|c| self.full_impulse(choice, &held, &c.into_owned(), phi))
            .collect();
        let N = DMatrix::from_columns(&columns);
        let laws: Vec<SplitLaw> = self
            .sites
            .iter()
            .zip(choice)
            .filter(|(_, &c)| c != Choice::Separate)
            .map(|(site, &c)| SplitLaw {
                normal: site.normal(),
                cone: match (site.law, c) {
                    (Law::Cone { mu }, Choice::Stick) => {
                        Some((mu, (site.row..site.normal()).collect()))
                    }
                    _ => None,
                },
            })
            .collect();
        cone_split(&trial.impulse, &N, &laws)
    }

    /// The world slip direction `ŝ` of a slipping site, from the contact's rows' directions.
    fn slip_direction(&self, site: &Site, c: Choice, phi: f64) -> Vector3<f64> {
        let [t1, t2, _] = site.directions;
        match c {
            Choice::SlipSign { sigma } => t1 * sigma,
            _ => t1 * phi.cos() + t2 * phi.sin(),
        }
    }
}

/// Every solution of the Coulomb plastic impact into `contacts` at `(q, q̇⁻)` with every
/// contact held: [`impact_outcomes`] with [`Separation::Forbidden`].
pub fn coulomb_impacts(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
    v_minus: &[f64],
) -> SpatialResult<Vec<SpatialImpact>> {
    impact_outcomes(model, data, contacts, q, v_minus, Separation::Forbidden)
}

/// Every solution of the plastic impact's complementarity problem into `contacts` at
/// `(q, q̇⁻)` (module docs), distinct in `q̇⁺`, in enumeration order; with
/// [`Separation::Allowed`] each contact may also leave the ground. More than
/// [`MAX_COMBINATIONS`] combinations of states is a typed error naming `contacts`. `data` is
/// left prepared at `(q, q̇⁻)`.
pub fn impact_outcomes(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
    v_minus: &[f64],
    separation: Separation,
) -> SpatialResult<Vec<SpatialImpact>> {
    prepare(model, data, contacts, q, v_minus)?;
    let mut row = 0;
    let sites: Vec<Site> = contacts
        .iter()
        .map(|c| {
            let law = match (c.friction, c.impact_friction) {
                (false, _) => Law::Held,
                (true, mu) if mu == f64::INFINITY => Law::Held,
                (true, 0.0) => Law::NormalOnly,
                (true, mu) => Law::Cone { mu },
            };
            let site = Site {
                row,
                n_rows: c.n_rows(),
                law,
                directions: c.directions(),
            };
            row += c.n_rows();
            site
        })
        .collect();
    let combinations = sites
        .iter()
        .try_fold(1usize, |n, s| n.checked_mul(choices(s, separation).len()))
        .filter(|&n| n <= MAX_COMBINATIONS);
    if combinations.is_none() {
        return Err(SpatialError::InvalidArgument {
            field: "contacts".into(),
            reason: format!(
                "{} contacts have more than {MAX_COMBINATIONS} combinations of impact states \
                 to enumerate",
                contacts.len()
            ),
        });
    }
    let v_minus = DVector::from_column_slice(v_minus);
    let problem = Problem {
        model,
        contacts,
        v0: &data.A * &v_minus,
        A: data.A.clone(),
        v_minus,
        M: data.M.clone(),
        sites,
    };
    let found = enumerate(&problem, data, separation);
    // the full rows back in `data`
    data.A = problem.A.clone();
    data.rhs_g = DVector::zeros(row);
    data.lam = DVector::zeros(row);
    let found = found?;
    for out in &found {
        check_result("q̇⁺", out.v_plus.as_slice())?;
        check_result("P", out.impulse.as_slice())?;
    }
    Ok(found)
}

/// The slip angles to start Newton's method from: per site, the direction opposite the
/// tangential impulse of `stick`, along the slip after `frictionless`, and along the slip
/// before the impact (each where it is defined; 0 otherwise).
fn starting_angles(
    p: &Problem,
    stick: Option<&Trial>,
    frictionless: Option<&Trial>,
) -> Vec<Vec<f64>> {
    let angle = |t1: f64, t2: f64| {
        if t1 == 0.0 && t2 == 0.0 {
            0.0
        } else {
            t2.atan2(t1)
        }
    };
    // the angle of the pair of rows (t₁, t₂) at a two-tangent site, 0 at the others
    let per_site = |f: &dyn Fn(&Site) -> f64| {
        p.sites
            .iter()
            .map(|s| if s.n_rows == 3 { f(s) } else { 0.0 })
            .collect::<Vec<f64>>()
    };
    let velocity = |trial: Option<&Trial>| {
        let v = trial.map(|t| &p.A * (&p.v_minus + &t.delta_v));
        per_site(&|s: &Site| match &v {
            Some(v) => angle(v[s.row], v[s.row + 1]),
            None => angle(p.v0[s.row], p.v0[s.row + 1]),
        })
    };
    let mut out = Vec::new();
    if let Some(t) = stick {
        out.push(per_site(&|s: &Site| {
            angle(-t.impulse[s.row], -t.impulse[s.row + 1])
        }));
    }
    if frictionless.is_some() {
        out.push(velocity(frictionless));
    }
    out.push(velocity(None));
    out
}

/// Every combination of states, solved and checked; distinct outcomes in `q̇⁺`.
fn enumerate(
    p: &Problem,
    data: &mut SpatialData,
    separation: Separation,
) -> SpatialResult<Vec<SpatialImpact>> {
    let n = p.sites.len();
    let options: Vec<&[Choice]> = p.sites.iter().map(|s| choices(s, separation)).collect();
    let uniform = |c: Choice| -> Vec<Choice> {
        p.sites
            .iter()
            .map(|s| match s.law {
                Law::Cone { .. } => c,
                _ => Choice::Fixed,
            })
            .collect()
    };
    // the two linear combinations that seed the slip angles: every cone sticking, and every
    // cone on its normal row alone (`Fixed` on a cone site: a frictionless impact)
    let stick = p.solve_held(data, &uniform(Choice::Stick));
    let frictionless = p.solve_held(data, &vec![Choice::Fixed; n]).ok();
    let starts = starting_angles(p, stick.as_ref().ok(), frictionless.as_ref());
    let mut first_error = stick.as_ref().err().cloned();
    let mut solved_any = false;
    let mut out: Vec<(SpatialImpact, (usize, usize))> = Vec::new();
    let mut code = vec![0usize; n];
    loop {
        let choice: Vec<Choice> = (0..n).map(|k| options[k][code[k]]).collect();
        let mut trials: Vec<(Trial, Vec<f64>)> = Vec::new();
        if choice.contains(&Choice::SlipAngle) {
            for start in &starts {
                trials.extend(p.solve_angles(&choice, start.clone()));
            }
        } else if choice.iter().any(|c| matches!(c, Choice::SlipSign { .. })) {
            let phi = vec![0.0; n];
            if let Some(trial) = p.solve_slipping(&choice, &phi) {
                trials.push((trial, phi));
            }
        } else {
            match p.solve_held(data, &choice) {
                Ok(t) => trials.push((t, vec![0.0; n])),
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        solved_any |= !trials.is_empty();
        for (trial, phi) in &trials {
            if let Some(imp) = p.accept(&choice, trial, phi) {
                keep_distinct(&mut out, imp, p.v_minus.amax());
            }
        }
        // next combination
        let mut k = 0;
        loop {
            if k == n {
                return match (solved_any, first_error) {
                    (false, Some(e)) => Err(e),
                    _ => Ok(out.into_iter().map(|(imp, _)| imp).collect()),
                };
            }
            code[k] += 1;
            if code[k] < options[k].len() {
                break;
            }
            code[k] = 0;
            k += 1;
        }
    }
}

/// Adds `imp` to `out` unless an outcome with the same `q̇⁺` is there; of two, the one with
/// more contacts held, then more sticking, stays (a contact held with no impulse is one
/// grazing; a slip whose velocity after is zero a stick on its cone's edge).
fn keep_distinct(out: &mut Vec<(SpatialImpact, (usize, usize))>, imp: SpatialImpact, v_scale: f64) {
    let count = |f: fn(&ImpactState) -> bool| imp.states.iter().filter(|s| f(s)).count();
    let rank = (
        count(|s| *s != ImpactState::Separate),
        count(|s| *s == ImpactState::Stick),
    );
    let same = out
        .iter()
        .position(|(o, _)| (&o.v_plus - &imp.v_plus).amax() <= 1e-8 * (1.0 + v_scale));
    match same {
        None => out.push((imp, rank)),
        Some(i) if rank > out[i].1 => out[i] = (imp, rank),
        Some(_) => {}
    }
}

/// The single outcome of [`impact_outcomes`], or a typed error naming `contacts` when there
/// is none (held: a contact's normal impulse would pull, it leaves the ground; with
/// separation allowed, no state of the contacts satisfies them all) or several (a Painlevé
/// configuration: [`impact_outcomes`] lists them).
fn the_only(mut all: Vec<SpatialImpact>, separation: Separation) -> SpatialResult<SpatialImpact> {
    let reason = match (all.len(), separation) {
        (1, _) => return Ok(all.pop().expect("one")),
        (0, Separation::Forbidden) => "no plastic impact holds every contact: a normal impulse \
                                       would pull (that contact leaves the ground: allow \
                                       separation)"
            .to_string(),
        (0, Separation::Allowed) => "no plastic impact satisfies every contact's \
                                     complementarity (separate, stick or slip)"
            .to_string(),
        (n, _) => format!(
            "{n} plastic impacts satisfy these contacts (a Painlevé configuration): \
             impact_outcomes lists them"
        ),
    };
    Err(SpatialError::InvalidArgument {
        field: "contacts".into(),
        reason,
    })
}
