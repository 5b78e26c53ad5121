//! The partials of the dynamics (5.3) in the model's inertia parameters
//! ([`BodyParameter`]): at fixed `(q, q̇)` the terms `M̄ x + C̄q̇ + N̄` that depend on them are
//! a sum over the parts, a part of mass `m` whose centre `p` has Jacobians `J_p`, `J_ω`
//! contributing
//!
//! ```text
//! J_pᵀ m (J_p x + J̇_p q̇ − g e_z) + J_ωᵀ I J_ω x        (z down)
//! ```
//!
//! (the core's assembly, `crate::tangent`'s module docs). `A` and `Ȧq̇` do not depend on
//! them, so a parameter's column of the flow solves `K [δq̈; δλ] = [−∂(M̄q̈ + C̄q̇ + N̄)/∂p; 0]`,
//! and of the plastic impact (5.10) `K [δΔq̇; δP] = [−∂M̄/∂p Δq̇; 0]` (no rates, no gravity).
//!
//! - the body's `m_b`, `I_b` (its centre is its frame's origin: `J_p = [e_x; e_z]`, `J̇ = 0`,
//!   `J_ω = e_φ`) and a joint's armature (`∂M̄/∂a_j = e_j e_jᵀ`);
//! - a link's mass: `J_pᵀ (a_p − g e_z)`, `a_p = J_p x + J̇_p q̇` the acceleration of its
//!   centre; its inertia: `J_ωᵀ J_ω x = J_ωᵀ β̈`;
//! - a link's centre of mass moved by `δc` in the link's frame, `δp = R(β) δc` in the world:
//!   `J_p`'s columns are `ω_k (p − o_k)^⊥` (`ω_k` the entries of `J_ω`), so
//!   `δJ_p = δp^⊥ J_ω`, and the centre's acceleration `a_p = a_o + β̈ (p − o)^⊥ − β̇² (p − o)`
//!   moves by `δa_p = β̈ δp^⊥ − β̇² δp`:
//!   `δ(J_pᵀ F) = J_ωᵀ (δp^⊥ · F) + J_pᵀ m δa_p`, `F = m (a_p − g e_z)`. Its inertia is about
//!   the centre, so it moves with it.
use crate::frames::{perp, rotate_sc};
use crate::kinematics::{Kinematics, Part};
use crate::model::Model;
use crate::tangent::{zero_sized, BodyParameter, TangentError};
use nalgebra::{DVector, Vector2};

impl BodyParameter {
    /// Whether `self` is a parameter of `model`'s dynamics ([`TangentError::NotAParameter`]
    /// otherwise): a joint that exists, an armature, a link mass or a link inertia that is
    /// not zero. At zero each is the edge of its domain (no negative masses), and a link
    /// with no mass, inertia or armature is massless: the dynamics remove its joint (free
    /// massless joints, thesis 5.1.1) or solve it by Lemma 5.1's `M̄†`, another model, so
    /// the derivative there is one-sided at best.
    pub fn check(self, model: &Model) -> Result<(), TangentError> {
        let bad = |reason| {
            Err(TangentError::NotAParameter {
                parameter: self,
                reason,
            })
        };
        if self.is_geometric() {
            return self.check_geometric(model);
        }
        let joint = match self {
            BodyParameter::Mass | BodyParameter::Inertia => return Ok(()),
            BodyParameter::LinkLength { .. } | BodyParameter::ContactPosition(..) => {
                unreachable!("checked above")
            }
            BodyParameter::Armature(j)
            | BodyParameter::LinkMass(j)
            | BodyParameter::LinkInertia(j)
            | BodyParameter::LinkCom(j, _) => match model.joints.get(j) {
                Some(joint) => joint,
                None => return bad("no such joint"),
            },
        };
        match self {
            BodyParameter::Armature(_) if joint.armature_kg_m2 <= 0.0 => {
                bad("the joint has no armature")
            }
            BodyParameter::LinkMass(_) if joint.mass_kg <= 0.0 => bad(
                "the link has no mass: 0 is the edge of its domain, and a link without mass, \
                 inertia or armature is massless (another model, Lemma 5.1): one-sided there",
            ),
            BodyParameter::LinkInertia(_) if joint.inertia_kg_m2 <= 0.0 => bad(
                "the link has no inertia: 0 is the edge of its domain, and a link without \
                 mass, inertia or armature is massless (another model, Lemma 5.1): one-sided \
                 there",
            ),
            BodyParameter::LinkCom(_, axis) if axis > 1 => bad("a centre of mass has two axes"),
            _ => Ok(()),
        }
    }

    /// `∂(M̄ x + C̄q̇ + N̄)/∂p` at the state of `kin`, with `rates = Some(q̇)` (the flow: `kin`
    /// formed with those rates); `∂M̄/∂p x` alone with `None` (an impact). Zero for a
    /// geometric parameter, whose terms ([`Self::geometry_terms_into`]) need the
    /// constraint rows too.
    pub(crate) fn dm_x(
        self,
        model: &Model,
        kin: &Kinematics,
        x: &[f64],
        rates: Option<&[f64]>,
    ) -> DVector<f64> {
        let mut f = DVector::zeros(model.nq());
        self.dm_x_into(model, kin, x, rates, &mut f);
        f
    }

    /// [`Self::dm_x`] into `f` (zeroed and sized here).
    pub(crate) fn dm_x_into(
        self,
        model: &Model,
        kin: &Kinematics,
        x: &[f64],
        rates: Option<&[f64]>,
        f: &mut DVector<f64>,
    ) {
        zero_sized(f, model.nq());
        let g = if rates.is_some() {
            model.gravity_m_s2
        } else {
            0.0
        };
        match self {
            BodyParameter::Mass => {
                f[model.ix_x()] = x[model.ix_x()];
                f[model.ix_z()] = x[model.ix_z()] - g;
            }
            BodyParameter::Inertia => f[model.ix_phi()] = x[model.ix_phi()],
            BodyParameter::Armature(j) => f[j] = x[j],
            BodyParameter::LinkMass(j) => {
                let c = Centre::of(model, kin, j, x, rates);
                kin.point_jacobian_columns(model, c.part, c.p, |k, col| f[k] += col.dot(&c.a));
            }
            BodyParameter::LinkInertia(j) => {
                let c = Centre::of(model, kin, j, x, rates);
                kin.angular_jacobian_entries(model, c.part, |k, w| f[k] += w * c.beta_dd);
            }
            BodyParameter::LinkLength { .. } | BodyParameter::ContactPosition(..) => {}
            BodyParameter::LinkCom(j, axis) => {
                let c = Centre::of(model, kin, j, x, rates);
                let m = model.joints[j].mass_kg;
                let mut unit = Vector2::zeros();
                unit[axis] = 1.0;
                let dp = rotate_sc(kin.part_sin_cos(c.part), unit);
                let force = m * c.a;
                let da = m * (c.beta_dd * perp(dp) - c.beta_d * c.beta_d * dp);
                let lever = perp(dp).dot(&force);
                kin.angular_jacobian_entries(model, c.part, |k, w| f[k] += w * lever);
                kin.point_jacobian_columns(model, c.part, c.p, |k, col| f[k] += col.dot(&da));
            }
        }
    }
}

/// A link's centre of mass at one state, for its parameters' partials: where it is (`p`),
/// `a = J_p x + J̇_p q̇ − g e_z` (only `J_p x` for an impact), `β̈ = J_ω x` and `β̇`
/// (0 for an impact).
pub(crate) struct Centre {
    pub(crate) part: Part,
    pub(crate) p: Vector2<f64>,
    pub(crate) a: Vector2<f64>,
    beta_dd: f64,
    beta_d: f64,
}

impl Centre {
    pub(crate) fn of(
        model: &Model,
        kin: &Kinematics,
        j: usize,
        x: &[f64],
        rates: Option<&[f64]>,
    ) -> Self {
        let part = Part::Link(j);
        let p = kin.point(part, model.joints[j].com_m);
        let mut a = Vector2::zeros();
        kin.point_jacobian_columns(model, part, p, |k, col| a += col * x[k]);
        let mut beta_dd = 0.0;
        kin.angular_jacobian_entries(model, part, |k, w| beta_dd += w * x[k]);
        let mut beta_d = 0.0;
        if let Some(qd) = rates {
            let p_dot = kin.material_velocity(part, p);
            kin.point_jacobian_rate_columns(model, part, p_dot, |k, col| a += col * qd[k]);
            a.y -= model.gravity_m_s2;
            beta_d = kin.part_angle_rate(part);
        }
        Centre {
            part,
            p,
            a,
            beta_dd,
            beta_d,
        }
    }
}
