//! The partials of the dynamics (5.3)–(5.4), of the plastic impact (5.10) and of the
//! touchdown and stick guards in the model's geometric parameters ([`BodyParameter::
//! LinkLength`], [`BodyParameter::ContactPosition`]).
//!
//! **Each moves points rigidly.** A link's length `l_k` is the lever `(0, l_k)` in the link's
//! frame from its joint to the next one, so the points on the links beyond it (their centres
//! of mass and contacts) move by `u = R(β_k) e_z` per unit length, and nothing else does (the
//! contacts on the link itself are given in its frame; its centre of mass moves by `u/2` when
//! it is the description's default `[0, l_k/2]`). A point contact's position moves that point
//! alone, by `u = R(β_P) e_axis` on its part `P`. In the closed forms of `crate::tangent`
//! (`p = X + Σ_Q r_Q`, `r_Q` the world lever of part `Q`) a moved point has one lever changed,
//! `δr_Q = u` with `Q` the link whose length moves (or the contact's part), and `u` turns with
//! `Q`: `∂u/∂q [a] = ω_Q(a) S u`. So
//!
//! ```text
//! δp = u      δDp[a] = ω_Q(a) S u      δD²p[a, b] = −ω_Q(a) ω_Q(b) u
//! ```
//!
//! and, with the core's assembly (`M̄ x + C̄q̇ + N̄ = Σ J_pᵀ m (J_p x + J̇_p q̇ − g e_z) +
//! J_ωᵀ I J_ω x`, `A_r x = −d_r · J_c x`, `Ȧq̇_r = −d_r · D²c[q̇, q̇]`), writing
//! `a = J_p x + J̇_p q̇ − g e_z` for a moved centre and `J_ω,Q` for `Q`'s angular row:
//!
//! ```text
//! δ(M̄x + C̄q̇ + N̄) = J_ω,Qᵀ (S u · m a) + J_pᵀ m (ω_Q(x) S u − ω_Q(q̇)² u)
//! δA_r x   = −ω_Q(x) d_r · S u           δ(Ȧq̇)_r = ω_Q(q̇)² d_r · u
//! δAᵀλ     = −J_ω,Qᵀ Σ_r λ_r d_r · S u
//! ```
//!
//! (the same form as a centre of mass moved in its link's frame, `crate::inertia_partials`,
//! with `Q` for the link whose angle turns `u`). The flow's column solves
//! `K [δq̈; δλ] = −[δ(M̄q̈ + C̄q̇ + N̄) + δAᵀλ; δA q̈ + δ(Ȧq̇)]`, the impact's (rates and
//! gravity zero) `K [δΔq̇; δP] = −[δM̄ Δq̇ + δAᵀP; δA q̇⁺]`. A contact's height `g = −n · c`
//! moves by `−n · u`, its sliding velocity `t · J_c q̇` by `ω_Q(q̇) t · S u`.
//!
//! The Coulomb friction of a sliding site moves with its tangential row: at a general site
//! (folded, `B_k = μ_kσ A_t,k`) by `δBᵀλ = μ_kσ λ_n δA_tᵀ`; on a single-joint massless leg
//! (`f^fr = −μ_kσ λ_n A_tᵀ`, `λ_n = f_j/den`, `den = (A_n)_j + μ_kσ (A_t)_j`) by
//! `δf^fr = −μ_kσ (δλ_n A_tᵀ + λ_n δA_tᵀ)`, `δλ_n = −λ_n δden/den` (`crate::tangent`).
//!
//! A rolling arc's centre translates with its part like a point (a length moves it
//! rigidly); an arc's own centre and radius are not parameters here.
use crate::constraint::{geometry_of, Constraints};
use crate::contact::row_direction;
use crate::frames::{perp, rotate_sc};
use crate::inertia_partials::Centre;
use crate::kinematics::{Kinematics, Part};
use crate::model::{ContactShape, Model};
use crate::tangent::{differentiable_point, zero_sized, BodyParameter, TangentError};
use nalgebra::{DVector, Vector2};

/// A point of the model whose position a parameter may move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Site {
    /// The centre of mass of joint `j`'s link.
    Com(usize),
    /// Contact `k`'s point (or rolling centre).
    Contact(usize),
}

impl BodyParameter {
    /// Whether `self` moves the kinematics (`A`, `Ȧ`, the guards) rather than the inertia.
    pub fn is_geometric(self) -> bool {
        matches!(
            self,
            BodyParameter::LinkLength { .. } | BodyParameter::ContactPosition(..)
        )
    }

    /// How a unit step of the geometric parameter `self` moves `site`: the part `Q` whose
    /// world lever changes and its change `u` (world), or `None` if the site stays.
    fn shift(self, model: &Model, kin: &Kinematics, site: Site) -> Option<(Part, Vector2<f64>)> {
        let part_of = |site| match site {
            Site::Com(j) => Some(j),
            Site::Contact(k) => model.contacts[k].link,
        };
        match self {
            BodyParameter::LinkLength { joint, com_follows } => {
                let u = rotate_sc(kin.part_sin_cos(Part::Link(joint)), Vector2::new(0.0, 1.0));
                let j = part_of(site)?;
                if j != joint && model.chain(j).contains(&joint) {
                    Some((Part::Link(joint), u))
                } else if j == joint && com_follows && site == Site::Com(j) {
                    Some((Part::Link(joint), 0.5 * u))
                } else {
                    None
                }
            }
            BodyParameter::ContactPosition(k, axis) if site == Site::Contact(k) => {
                let part = model.contacts[k].link.map_or(Part::Body, Part::Link);
                let mut unit = Vector2::zeros();
                unit[axis] = 1.0;
                Some((part, rotate_sc(kin.part_sin_cos(part), unit)))
            }
            _ => None,
        }
    }

    /// `∂(gap of contact k)/∂p` at fixed `q`, `−n · u` (`n` the plane's normal).
    pub fn height_partial(
        self,
        model: &Model,
        kin: &Kinematics,
        contact: usize,
        normal: Vector2<f64>,
    ) -> f64 {
        self.shift(model, kin, Site::Contact(contact))
            .map_or(0.0, |(_, u)| -normal.dot(&u))
    }

    /// `∂(t · v_c)/∂p` of contact `k`'s sliding velocity at fixed `(q, q̇)` (`kin` formed with
    /// the rates): `ω_Q(q̇) t · S u`.
    pub fn sliding_velocity_partial(
        self,
        model: &Model,
        kin: &Kinematics,
        contact: usize,
        tangent: Vector2<f64>,
    ) -> f64 {
        self.shift(model, kin, Site::Contact(contact))
            .map_or(0.0, |(q, u)| kin.part_angle_rate(q) * tangent.dot(&perp(u)))
    }

    /// The right-hand side of a parameter's column (`K δz = −[f; g]`) for a geometric `self`
    /// (module docs): `f = δ(M̄ x + C̄q̇ + N̄) + δAᵀλ`, `g = δA x_g + δ(Ȧq̇)` at the state of
    /// `kin` with the constraint rows `cons`, with `rates = Some(q̇)` (the flow, `x_g = x`);
    /// `f = δM̄ x + δAᵀλ`, `g = δA x_g` with `None` (an impact, `λ` its impulse, `x` the
    /// velocity jump, `x_g` the velocity after). `f`, `g` are zeroed and sized here.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn geometry_terms_into(
        self,
        model: &Model,
        kin: &Kinematics,
        cons: &Constraints,
        (x, x_g): (&[f64], &[f64]),
        lambda: &[f64],
        rates: Option<&[f64]>,
        (f, g): (&mut DVector<f64>, &mut DVector<f64>),
    ) -> Result<(), TangentError> {
        zero_sized(f, model.nq());
        zero_sized(g, cons.n_rows());
        let omega = |part: Part, v: &[f64]| {
            let mut w = 0.0;
            kin.angular_jacobian_entries(model, part, |k, s| w += s * v[k]);
            w
        };
        let rate = |part: Part| rates.map_or(0.0, |_| kin.part_angle_rate(part));
        for (j, joint) in model.joints.iter().enumerate() {
            if joint.mass_kg <= 0.0 {
                continue;
            }
            let Some((q, u)) = self.shift(model, kin, Site::Com(j)) else {
                continue;
            };
            // J_ω,Qᵀ (S u · m a) + J_pᵀ m (ω_Q(x) S u − ω_Q(q̇)² u)
            let c = Centre::of(model, kin, j, x, rates);
            let m = joint.mass_kg;
            let lever = perp(u).dot(&(m * c.a));
            let (wx, wd) = (omega(q, x), rate(q));
            let da = m * (wx * perp(u) - wd * wd * u);
            kin.angular_jacobian_entries(model, q, |k, w| f[k] += w * lever);
            kin.point_jacobian_columns(model, c.part, c.p, |k, col| f[k] += col.dot(&da));
        }
        for (r, row) in cons.rows.iter().enumerate() {
            let Some((q, u)) = self.shift(model, kin, Site::Contact(row.contact)) else {
                continue;
            };
            let geo = geometry_of(&cons.geometry, row.contact);
            differentiable_point(model, kin, row.contact, geo)?;
            let d = row_direction(&geo.plane, row.direction);
            let su = d.dot(&perp(u));
            let wd = rate(q);
            g[r] = -omega(q, x_g) * su + wd * wd * d.dot(&u);
            if lambda[r] != 0.0 {
                let l = -lambda[r] * su;
                kin.angular_jacobian_entries(model, q, |k, w| f[k] += w * l);
            }
        }
        Ok(())
    }

    /// `(J_ω,Q, d · S u)` of contact `k`'s row of direction `d` under a unit step of a
    /// geometric `self`: the row moves by `δA_r = −(d · S u) J_ω,Q` (none if the contact
    /// stays), calling `f(i, (J_ω,Q)_i)` for its nonzero entries and returning `d · S u`.
    pub(crate) fn row_shift(
        self,
        model: &Model,
        kin: &Kinematics,
        contact: usize,
        d: Vector2<f64>,
        f: impl FnMut(usize, f64),
    ) -> f64 {
        match self.shift(model, kin, Site::Contact(contact)) {
            Some((q, u)) => {
                kin.angular_jacobian_entries(model, q, f);
                d.dot(&perp(u))
            }
            None => 0.0,
        }
    }

    /// Whether a geometric `self` is one of `model`'s (see [`Self::check`]).
    pub(crate) fn check_geometric(self, model: &Model) -> Result<(), TangentError> {
        let bad = |reason| {
            Err(TangentError::NotAParameter {
                parameter: self,
                reason,
            })
        };
        match self {
            BodyParameter::LinkLength { joint, .. } if joint >= model.n_joints() => {
                bad("no such joint")
            }
            BodyParameter::ContactPosition(k, axis) => match model.contacts.get(k) {
                None => bad("no such contact"),
                Some(_) if axis > 1 => bad("a contact's position has two axes"),
                Some(c) if !matches!(c.shape, ContactShape::Point { .. }) => bad(
                    "the contact is an arc: its centre and radius are not differentiated (a \
                     point contact's position is)",
                ),
                Some(_) => Ok(()),
            },
            _ => Ok(()),
        }
    }
}
