//! Point contacts and the constrained dynamics of a spatial robot: the KKT system of thesis
//! (5.2) for the rows of a contact set, solved by the planar core's null-space block inverse
//! ([`crate::kkt::KktFactorization`], (5.3)–(5.4)), which needs `A` of full row rank and `M`
//! positive definite only on `ker A` (Lemma 5.1), never `M` invertible: massless limbs are
//! exact. Plastic impact (5.10) is [`super::impact`].
//!
//! Sign convention (Pinocchio's): `M q̈ + h = τ + Aᵀλ`, `λ` the ground's force on the robot
//! along the rows' world directions — for a contact with friction `[t₁, t₂, n]`, tangents
//! first, `n` the ground normal pointing out of the ground (so a pushing normal force is
//! positive); a frictionless contact has the row `n` alone. In the thesis's form (5.2),
//! `M̄q̈ + Aᵀλ_thesis = Υ − C̄q̇ − N̄` with `λ_thesis = −λ`.
#![allow(non_snake_case)]
use super::coulomb::{solve_sliding, MIN_SLIDING_SPEED};
use super::error::{SpatialError, SpatialResult};
use super::kinematics::{
    forward_kinematics_velocity, frame_origin, frame_placement, point_linear_drift, Matrix6xX,
    SpatialData,
};
use super::model::SpatialModel;
use super::rigid_body::mass_matrix_and_bias_from_kinematics;
use super::tree_kkt::KktRoute;
use crate::error::check_result;
use crate::error::check_vector;
use nalgebra::{DMatrix, DVector, Vector3};
use std::cmp::Ordering;

/// Where on its frame a contact touches the ground.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactShape {
    /// The frame's origin (a toe, a foot of zero radius).
    Point,
    /// A circle of radius `radius_m` about the frame's origin in the plane normal to `axis`
    /// (a unit vector in the frame's axes): a C-leg's arc or a body's rounded end, touching at
    /// the circle's lowest point `c + r d`, `d` the unit vector of the circle's plane closest to
    /// `−n`. The rows constrain the velocity of the material point there (rolling with
    /// friction; the normal row alone when frictionless), and the drift is that point's
    /// acceleration `a_c + α × r d + ω × r ḋ` at `q̈ = 0`, the time derivative of those rows
    /// (thesis (5.2)'s `Ȧq̇` for a rolling contact: the centre's acceleration, not the
    /// material point's, whose centripetal part the contact point does not follow).
    Circle { radius_m: f64, axis: Vector3<f64> },
    /// A sphere of radius `radius_m` about the frame's origin (a rounded foot), touching at
    /// `c − r n`; the rows constrain the material point there, and the contact point stays
    /// below the centre (`ṙ = 0` in the world), so the drift is `a_c + α × (−r n)`.
    Sphere { radius_m: f64 },
    /// The arc of the [`Self::Circle`] of radius `radius_m` normal to `axis` that spans the
    /// angles `[from_rad, to_rad]` about `axis` from the unit direction `zero` (frame axes,
    /// normal to `axis`): RHex's C-leg. It touches at the circle's lowest point while that
    /// point's angle lies in the range (rolling, as the circle), and otherwise at the lower of
    /// its two ends, a material point of the frame (drift `a + α × r + ω × (ω × r)`).
    Arc {
        radius_m: f64,
        axis: Vector3<f64>,
        zero: Vector3<f64>,
        from_rad: f64,
        to_rad: f64,
    },
}

/// A point of a frame touching the ground.
#[derive(Debug, Clone, PartialEq)]
pub struct PointContact {
    /// The frame whose origin touches (or carries the [`ContactShape::Circle`]).
    pub frame: usize,
    /// With friction (tangent rows, then the normal) or frictionless (the normal).
    pub friction: bool,
    /// Unit ground normal in the world, pointing out of the ground.
    pub normal: Vector3<f64>,
    /// With friction: `None` constrains both tangents (3 rows); `Some(t)` only the tangent
    /// along `t` (2 rows `[t, n]`, the contact of a planar model embedded in the spatial one,
    /// whose ground holds no force across its plane). Unit, normal to `normal`.
    pub tangent: Option<Vector3<f64>>,
    pub shape: ContactShape,
    /// Coulomb's kinetic coefficient of a contact without tangent rows (`friction` false):
    /// `μ > 0` makes it slide with the ground's tangential force `μ λ_n` on the circular
    /// cone's edge, opposite its sliding velocity ([`super::coulomb`]); 0 is frictionless.
    pub kinetic_friction: f64,
    /// Coulomb's coefficient of a contact with tangent rows in a plastic impact: its impulse
    /// lies in the circular cone of this `μ` ([`super::impact`]). `f64::INFINITY` (the
    /// default) holds every row, thesis (5.10); 0 leaves the normal row alone.
    pub impact_friction: f64,
}

fn unit(field: &'static str, x: Vector3<f64>) -> SpatialResult<Vector3<f64>> {
    check_vector(field, x.as_slice(), 3)?;
    if x.norm() < 1e-12 {
        return Err(SpatialError::InvalidArgument {
            field: field.into(),
            reason: "zero vector".into(),
        });
    }
    Ok(x.normalize())
}

fn non_negative(field: &'static str, x: f64) -> SpatialResult<f64> {
    if !x.is_finite() || x < 0.0 {
        return Err(SpatialError::InvalidArgument {
            field: field.into(),
            reason: format!("must be finite and non-negative, got {x}"),
        });
    }
    Ok(x)
}

impl PointContact {
    /// A contact at the origin of the frame named `frame_name` on flat z-up ground.
    pub fn new(model: &SpatialModel, frame_name: &str, friction: bool) -> SpatialResult<Self> {
        Self::with_normal(model, frame_name, friction, Vector3::z())
    }

    /// A contact on ground of normal `normal` (normalized). On a robot with a planar base the
    /// normal lies in the base's plane and a contact with friction has the rows `[t, n]`,
    /// `t = e × n` for the plane's normal `e` ([`SpatialModel::plane_normal`]): the planar
    /// model's contact, whose ground holds no force across the plane ([`Self::in_plane`]).
    pub fn with_normal(
        model: &SpatialModel,
        frame_name: &str,
        friction: bool,
        normal: Vector3<f64>,
    ) -> SpatialResult<Self> {
        let frame = model.frame_id_of(&format!("contacts[{frame_name}]"), frame_name)?;
        let normal = unit("normal", normal)?;
        let tangent = match model.plane_normal() {
            None => None,
            Some(e) if e.dot(&normal).abs() > 1e-9 => {
                return Err(SpatialError::InvalidArgument {
                    field: "normal".into(),
                    reason: format!(
                        "{normal:?} leaves the planar base's plane (normal {e:?}): \
                         a planar robot's ground normal lies in its plane"
                    ),
                })
            }
            Some(e) => Some(e.cross(&normal).normalize()),
        };
        Ok(Self {
            frame,
            friction,
            normal,
            tangent,
            shape: ContactShape::Point,
            kinetic_friction: 0.0,
            impact_friction: f64::INFINITY,
        })
    }

    /// `self` touching on a sphere of radius `radius_m` (m, finite, ≥ 0) about the frame's
    /// origin: see [`ContactShape::Sphere`].
    pub fn on_sphere(self, radius_m: f64) -> SpatialResult<Self> {
        Ok(Self {
            shape: ContactShape::Sphere {
                radius_m: non_negative("radius_m", radius_m)?,
            },
            ..self
        })
    }

    /// `self` touching on the arc of radius `radius_m` normal to `axis` spanning
    /// `[from_rad, to_rad]` about `axis` from `zero` (frame axes): see [`ContactShape::Arc`].
    /// `zero` is made normal to `axis`; the range must be increasing and at most `2π` wide.
    pub fn on_arc(
        self,
        radius_m: f64,
        axis: Vector3<f64>,
        zero: Vector3<f64>,
        (from_rad, to_rad): (f64, f64),
    ) -> SpatialResult<Self> {
        let radius_m = non_negative("radius_m", radius_m)?;
        let axis = unit("axis", axis)?;
        let zero = unit("zero", zero)?;
        let zero = zero - axis * axis.dot(&zero);
        if zero.norm() < 1e-9 {
            return Err(SpatialError::InvalidArgument {
                field: "zero".into(),
                reason: "parallel to the arc's axis".into(),
            });
        }
        check_vector("angle_range_rad", &[from_rad, to_rad], 2)?;
        if !(to_rad > from_rad && to_rad - from_rad <= std::f64::consts::TAU) {
            return Err(SpatialError::InvalidArgument {
                field: "angle_range_rad".into(),
                reason: format!(
                    "must be increasing and at most 2π wide, got [{from_rad}, {to_rad}]"
                ),
            });
        }
        Ok(Self {
            shape: ContactShape::Arc {
                radius_m,
                axis,
                zero: zero.normalize(),
                from_rad,
                to_rad,
            },
            ..self
        })
    }

    /// `self` sliding with Coulomb's kinetic coefficient `mu` (finite, ≥ 0): the normal row
    /// alone, the friction force on the cone's edge ([`super::coulomb`]).
    pub fn sliding(self, mu: f64) -> SpatialResult<Self> {
        Ok(Self {
            friction: false,
            tangent: None,
            kinetic_friction: non_negative("friction", mu)?,
            ..self
        })
    }

    /// `self`, a contact with tangent rows, meeting Coulomb friction `mu` (finite, ≥ 0, or
    /// `f64::INFINITY` to stick) in a plastic impact ([`super::impact`]); its
    /// dynamics keep the tangent rows (sticking).
    pub fn with_impact_friction(self, mu: f64) -> SpatialResult<Self> {
        if !self.friction {
            return Err(SpatialError::InvalidArgument {
                field: "friction".into(),
                reason: "an impact friction cone needs the contact's tangent rows".into(),
            });
        }
        if mu.is_nan() || mu < 0.0 {
            return Err(SpatialError::InvalidArgument {
                field: "friction".into(),
                reason: format!("must be non-negative (∞ sticks), got {mu}"),
            });
        }
        Ok(Self {
            impact_friction: mu,
            ..self
        })
    }

    /// A contact without tangent rows whose sliding meets Coulomb friction (`μ > 0`).
    pub fn slides_with_friction(&self) -> bool {
        !self.friction && self.kinetic_friction > 0.0
    }

    /// `self` touching on a circle of radius `radius_m` (m, finite, ≥ 0) about the frame's
    /// origin, normal to `axis` (frame axes): see [`ContactShape::Circle`].
    pub fn on_circle(self, radius_m: f64, axis: Vector3<f64>) -> SpatialResult<Self> {
        let radius_m = non_negative("radius_m", radius_m)?;
        let axis = unit("axis", axis)?;
        Ok(Self {
            shape: ContactShape::Circle { radius_m, axis },
            ..self
        })
    }

    /// `self` with friction along the ground tangent `tangent` only (two rows `[t, n]`): the
    /// tangent is projected on the ground plane and normalized.
    pub fn in_plane(self, tangent: Vector3<f64>) -> SpatialResult<Self> {
        let t = unit("tangent", tangent)?;
        let t = t - self.normal * self.normal.dot(&t);
        if t.norm() < 1e-9 {
            return Err(SpatialError::InvalidArgument {
                field: "tangent".into(),
                reason: "parallel to the ground normal".into(),
            });
        }
        Ok(Self {
            friction: true,
            tangent: Some(t.normalize()),
            ..self
        })
    }

    pub fn n_rows(&self) -> usize {
        match (self.friction, self.tangent) {
            (false, _) => 1,
            (true, Some(_)) => 2,
            (true, None) => 3,
        }
    }

    /// The row directions, the first [`Self::n_rows`] entries: `[t₁, t₂, n]` with friction,
    /// `[t, n]` with friction in a plane, `[n]` without. `t₁` is the world `x` axis projected
    /// on the ground plane (the `y` axis if `n` is near `x`), `t₂ = n × t₁`: on flat z-up
    /// ground the rows are world `x, y, z`.
    pub fn directions(&self) -> [Vector3<f64>; 3] {
        let n = self.normal;
        if !self.friction {
            return [n, Vector3::zeros(), Vector3::zeros()];
        }
        if let Some(t) = self.tangent {
            return [t, n, Vector3::zeros()];
        }
        if n == Vector3::z() {
            // flat z-up ground: the general construction's rows, exactly, without its norm
            return [Vector3::x(), Vector3::y(), n];
        }
        let e = if n.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let t1 = (e - n * n.dot(&e)).normalize();
        [t1, n.cross(&t1), n]
    }

    /// The contact point's offset `r` from the frame origin (world axes) and its rate `ṙ` in
    /// the world, after the velocity kinematics: zero for a point; `−r n` and 0 for a sphere;
    /// for a circle of world axis `a`, `r d` with `d = u/|u|`, `u = −n + (n·a)a`, and
    /// `ḋ = (u̇ − d(d·u̇))/|u|`, `u̇ = (n·ȧ)a + (n·a)ȧ`, `ȧ = ω × a`; for an arc, the circle's
    /// while `d` lies in its range, else its lower end `r` with `ṙ = ω × r`.
    pub fn offset(&self, model: &SpatialModel, data: &SpatialData) -> (Vector3<f64>, Vector3<f64>) {
        let n = self.normal;
        let (radius_m, axis) = match self.shape {
            ContactShape::Point => return (Vector3::zeros(), Vector3::zeros()),
            ContactShape::Sphere { radius_m } => return (-n * radius_m, Vector3::zeros()),
            ContactShape::Circle { radius_m, axis } | ContactShape::Arc { radius_m, axis, .. } => {
                (radius_m, axis)
            }
        };
        let Some(j) = model.frames[self.frame].joint else {
            return (-n * radius_m, Vector3::zeros());
        };
        let rotation = frame_placement(model, data, self.frame).rotation;
        let a = rotation * axis;
        let w = data.ov[j].angular;
        let u = -n + a * n.dot(&a);
        let norm = u.norm();
        let d = u / norm.max(f64::MIN_POSITIVE);
        if let ContactShape::Arc {
            zero,
            from_rad,
            to_rad,
            ..
        } = self.shape
        {
            let e0 = rotation * zero;
            let e1 = a.cross(&e0);
            let angle = d.dot(&e1).atan2(d.dot(&e0));
            let inside = (angle - from_rad).rem_euclid(std::f64::consts::TAU) <= to_rad - from_rad;
            if norm < 1e-12 || !inside {
                // the lower end, a material point of the frame
                let end = |t: f64| (e0 * t.cos() + e1 * t.sin()) * radius_m;
                let (p, q) = (end(from_rad), end(to_rad));
                let r = if n.dot(&p) <= n.dot(&q) { p } else { q };
                return (r, w.cross(&r));
            }
        }
        if norm < 1e-12 {
            // the circle lies flat on the ground, every point of it lowest: the contact is
            // taken at its centre, at the same height
            return (Vector3::zeros(), Vector3::zeros());
        }
        let a_dot = w.cross(&a);
        let u_dot = a * n.dot(&a_dot) + a_dot * n.dot(&a);
        let d_dot = (u_dot - d * d.dot(&u_dot)) / norm;
        (d * radius_m, d_dot * radius_m)
    }

    /// The contact point `x` (world) and the velocity of the material point there, after the
    /// velocity kinematics.
    pub fn point_velocity(
        &self,
        model: &SpatialModel,
        data: &SpatialData,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let (r, _) = self.offset(model, data);
        let x = frame_placement(model, data, self.frame).translation + r;
        let v = match model.frames[self.frame].joint {
            Some(j) => data.ov[j].linear + data.ov[j].angular.cross(&x),
            None => Vector3::zeros(),
        };
        (x, v)
    }
}

/// The contact Jacobian `A` (rows of the contact points' world linear Jacobians along the
/// row directions) and its drift `Ȧq̇` (the points' accelerations at `q̈ = 0` along the same
/// directions, [`ContactShape`]) into `data.A`, `data.A_drift`, after the velocity kinematics.
/// A row `d` of the contact point `x` (world) is `d·v_x = d·v + (x × d)·ω` on each
/// supporting joint's world column `⁰S = [v; ω]` (Featherstone 2008, (2.20)), zero elsewhere.
pub(crate) fn contact_rows(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
) {
    let c: usize = contacts.iter().map(PointContact::n_rows).sum();
    if data.A.nrows() != c {
        data.A = nalgebra::DMatrix::zeros(c, model.nv);
        data.A_drift = DVector::zeros(c);
        data.lam = DVector::zeros(c);
        data.rhs_g = DVector::zeros(c);
    }
    data.A.as_mut_slice().fill(0.0);
    let mut row = 0;
    for contact in contacts {
        let (r, r_dot) = contact.offset(model, data);
        // the frame's origin once, for its drift and the rows' point
        let origin = frame_origin(model, data, contact.frame);
        let joint = model.frames[contact.frame].joint;
        let mut drift = Vector3::zeros();
        if let Some(j) = joint {
            let (w, alpha) = (data.ov[j].angular, data.oa_drift[j].angular);
            drift = point_linear_drift(data, j, &origin) + (alpha.cross(&r) + w.cross(&r_dot));
        }
        let x = origin + r;
        let dirs = contact.directions();
        let n = contact.n_rows();
        let a = data.A.as_mut_slice();
        point_rows(model, &data.oS, joint, &x, &dirs[..n], |k, col, value| {
            a[col * c + row + k] = value
        });
        for (k, d) in dirs[..n].iter().enumerate() {
            data.A_drift[row + k] = d.dot(&drift);
        }
        row += n;
    }
}
/// The rows `d·J_p` of the material point `x` (world) of joint `joint`'s body along the world
/// directions `dirs`, `d·(v + ω × x)` on each supporting joint's world column `⁰S = [v; ω]`
/// (Featherstone 2008, (2.20)), through `put(direction index, column, value)`; the columns of
/// other joints (zero) are not visited. Directions that are the world axes `x, y, z` in order
/// (a foot with friction on flat z-up ground) give `J_p`'s own entries without the products.
pub(crate) fn point_rows(
    model: &SpatialModel,
    oS: &Matrix6xX,
    joint: Option<usize>,
    x: &Vector3<f64>,
    dirs: &[Vector3<f64>],
    mut put: impl FnMut(usize, usize, f64),
) {
    let axes = dirs == [Vector3::x(), Vector3::y(), Vector3::z()];
    let s = oS.as_slice();
    let mut j = joint;
    while let Some(i) = j {
        let jt = &model.joints[i];
        for col in jt.idx_v..jt.idx_v + jt.kind.nv() {
            let c = &s[6 * col..6 * col + 6];
            let jp = Vector3::new(c[0], c[1], c[2]) + Vector3::new(c[3], c[4], c[5]).cross(x);
            if axes {
                put(0, col, jp.x);
                put(1, col, jp.y);
                put(2, col, jp.z);
                continue;
            }
            for (k, d) in dirs.iter().enumerate() {
                put(k, col, d.dot(&jp));
            }
        }
        j = jt.parent;
    }
}

/// Whether any contact slides with friction (`μ > 0` on a contact without tangent rows).
pub fn has_coulomb_sliding(contacts: &[PointContact]) -> bool {
    contacts.iter().any(PointContact::slides_with_friction)
}

/// `B` (c × nv, the rows of [`contact_rows`]): each sliding contact's normal
/// row `−μ ŝᵀ J_p`, after the contact rows. A contact with `μ > 0` that does not slide
/// (`|v_t| ≤` [`MIN_SLIDING_SPEED`]) is an error naming `v`.
pub fn friction_rows(
    model: &SpatialModel,
    data: &SpatialData,
    contacts: &[PointContact],
) -> SpatialResult<DMatrix<f64>> {
    let mut B = DMatrix::zeros(data.A.nrows(), model.nv);
    let mut row = 0;
    for contact in contacts {
        if contact.slides_with_friction() {
            let (x, v_x) = contact.point_velocity(model, data);
            let n = contact.normal;
            let v_t = v_x - n * n.dot(&v_x);
            let speed = v_t.norm();
            if speed.partial_cmp(&MIN_SLIDING_SPEED) != Some(Ordering::Greater) {
                return Err(SpatialError::InvalidArgument {
                    field: "v".into(),
                    reason: format!(
                        "the contact on frame `{}` does not slide (|v_t| = {speed:.3e} m/s): \
                         give it tangent rows (sticking)",
                        model.frames[contact.frame].name
                    ),
                });
            }
            let s = v_t / speed;
            let mu = contact.kinetic_friction;
            let joint = model.frames[contact.frame].joint;
            point_rows(model, &data.oS, joint, &x, &[s], |_, col, value| {
                B[(row, col)] = -mu * value
            });
        }
        row += contact.n_rows();
    }
    Ok(B)
}

/// `M`, `h`, `A`, `Ȧq̇` at `(q, v)`.
pub(super) fn prepare(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
    v: &[f64],
) -> SpatialResult<()> {
    forward_kinematics_velocity(model, data, q, v)?;
    mass_matrix_and_bias_from_kinematics(model, data);
    contact_rows(model, data, contacts);
    Ok(())
}

/// Relative size (to the largest) below which a singular value of `A` marks a redundant
/// row combination.
pub const REDUNDANT_ROW_TOLERANCE: f64 = 1e-9;

/// Factors `[M Aᵀ; A 0]`. A contact set whose rows are dependent (statically indeterminate:
/// both toes of a pair held in the sagittal plane with three pairs down, six toes with
/// friction) is factored on `A`'s row space instead: `A = U Σ Vᵀ`, the `r` singular values
/// above [`REDUNDANT_ROW_TOLERANCE`]` σ₁` kept, `Ã = Σ_r V_rᵀ`, the right-hand side
/// `g̃ = U_rᵀ g`, and `λ = U_r λ̃` — `q̈` is unique (`M` positive definite on `ker A`), and `λ`
/// is the solution with no component in `ker Aᵀ`, the internal forces that rigid contacts
/// leave undetermined (thesis §4.1.8's internal forces, here set to zero). Only a
/// singular `A` pays for the decomposition (it allocates).
///
/// A positive definite `M` with independent rows takes the range-space route: the limb
/// elimination ([`super::limb_kkt`]) where rows pin each limb they touch, else the tree's
/// sparse `LᵀDL` and the rows' `A M⁻¹ Aᵀ` ([`super::tree_kkt`]); only a singular `M` or
/// dependent rows take the null-space block inverse.
pub(super) fn factor(data: &mut SpatialData) -> SpatialResult<()> {
    data.row_basis = None;
    data.limbs_eliminated = false;
    if data.limb_kkt.factor(&data.M, &data.A) {
        data.limbs_eliminated = true;
        data.kkt_route = KktRoute::RangeSpace;
        return Ok(());
    }
    if data.tree_kkt.factor(&data.M, &data.A) {
        data.kkt_route = KktRoute::RangeSpace;
        return Ok(());
    }
    data.kkt_route = KktRoute::NullSpace;
    match data.kkt.factor(&data.M, &data.A) {
        Err(crate::CoreError::SingularKkt {
            kind: crate::SingularityKind::RedundantConstraints,
            ..
        }) if data.A.nrows() > 0 => {
            let svd = data.A.clone().svd(true, true);
            let (u, vt) = (svd.u.expect("asked for"), svd.v_t.expect("asked for"));
            let top = svd.singular_values.max();
            let kept: Vec<usize> = (0..svd.singular_values.len())
                .filter(|&k| svd.singular_values[k] > REDUNDANT_ROW_TOLERANCE * top)
                .collect();
            let mut reduced = DMatrix::zeros(kept.len(), data.A.ncols());
            let mut basis = DMatrix::zeros(data.A.nrows(), kept.len());
            for (i, &k) in kept.iter().enumerate() {
                reduced
                    .row_mut(i)
                    .copy_from(&(vt.row(k) * svd.singular_values[k]));
                basis.column_mut(i).copy_from(&u.column(k));
            }
            data.kkt.factor(&data.M, &reduced)?;
            data.row_basis = Some(basis);
            Ok(())
        }
        other => Ok(other?),
    }
}

/// Solves the factored KKT system for `data.rhs_f`, `data.rhs_g` into `data.qdd` and
/// `data.lam` (the second block `y`, `λ = −y`), through the row space when [`factor`] found
/// `A` redundant; a right-hand side `g` outside `A`'s range (redundant rows that contradict
/// each other) is the typed redundant-constraints error.
pub(super) fn solve(data: &mut SpatialData) -> SpatialResult<()> {
    let Some(basis) = &data.row_basis else {
        // independent rows: the route [`factor`] took solves in place
        let (f, g) = (data.rhs_f.as_slice(), data.rhs_g.as_slice());
        let (x, y) = (data.qdd.as_mut_slice(), data.lam.as_mut_slice());
        if data.limbs_eliminated {
            data.limb_kkt.solve(f, g, x, y);
        } else if data.kkt_route == KktRoute::RangeSpace {
            data.tree_kkt.solve(f, g, x, y);
        } else {
            data.kkt.solve(f, g, x, y);
        }
        return Ok(());
    };
    let g = basis.transpose() * &data.rhs_g;
    let off_range = (&data.rhs_g - basis * &g).amax();
    if off_range > 1e-9 * data.rhs_g.amax().max(1.0) {
        return Err(crate::CoreError::SingularKkt {
            kind: crate::SingularityKind::RedundantConstraints,
            condition_estimate: f64::INFINITY,
        }
        .into());
    }
    let mut y = DVector::zeros(g.len());
    data.kkt.solve(
        data.rhs_f.as_slice(),
        g.as_slice(),
        data.qdd.as_mut_slice(),
        y.as_mut_slice(),
    );
    data.lam = basis * y;
    Ok(())
}

/// Constrained forward dynamics, thesis (5.3)–(5.4): `q̈` and `λ` into `data.qdd`,
/// `data.lam` from `[M Aᵀ; A 0][q̈; −λ] = [τ − h; −Ȧq̇]`, with `tau` the nv generalized forces
/// (zero on a free flyer's six rates for an unactuated base). Contacts that slide with
/// friction ([`PointContact::sliding`]) make it the nonsymmetric system of [`super::coulomb`].
/// A massless limb no contact pins ([`free_rates`]) has no dynamics: Lemma 5.1's typed error
/// (give its motion to [`forward_dynamics_prescribed`]).
pub fn forward_dynamics(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
    v: &[f64],
    tau: &[f64],
) -> SpatialResult<()> {
    check_vector("tau", tau, model.nv)?;
    prepare(model, data, contacts, q, v)?;
    solve_dynamics(model, data, contacts, tau)
}

/// The rates that move no mass and that no contact of `contacts` pins, ascending: those of
/// every joint whose subtree (the joint and its descendants) has zero inertia and carries
/// none of the contacts' frames — a massless limb in the air. Their columns of `M`, `A` and
/// their entries of `h` are zero, so the constrained dynamics leaves their accelerations
/// open; the thesis prescribes their motion (§5.1.1), as the planar core's
/// `dynamics::free_massless_joints` does.
pub fn free_rates(model: &SpatialModel, contacts: &[PointContact]) -> Vec<usize> {
    // a joint is held when its subtree has mass or a contact: mark each such joint's chain
    let mut held = vec![false; model.joints.len()];
    let mut mark = |mut joint: Option<usize>| {
        while let Some(j) = joint {
            if std::mem::replace(&mut held[j], true) {
                break;
            }
            joint = model.joints[j].parent;
        }
    };
    for (j, inertia) in model.inertias.iter().enumerate() {
        if inertia.mass != 0.0 || inertia.inertia_com.iter().any(|&x| x != 0.0) {
            mark(Some(j));
        }
    }
    for contact in contacts {
        mark(model.frames[contact.frame].joint);
    }
    model
        .joints
        .iter()
        .zip(&held)
        .filter(|(_, &h)| !h)
        .flat_map(|(joint, _)| joint.idx_v..joint.idx_v + joint.kind.nv())
        .collect()
}

/// [`forward_dynamics`] with the massless limbs in the air following a prescribed motion
/// (given before the state): `free_qdd[i]` is the acceleration of the `i`-th rate of [`free_rates`] (rad/s² or m/s²),
/// as the planar core's `free_joint_qdd`; the other rates and `λ` are those of the KKT system
/// without the free rates (their columns of `M` and `A` vanish, so the two decouple exactly).
/// The free rates' entries of `tau` are not used (a massless limb takes no torque).
pub fn forward_dynamics_prescribed(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    free_qdd: &[f64],
    q: &[f64],
    v: &[f64],
    tau: &[f64],
) -> SpatialResult<()> {
    let free = free_rates(model, contacts);
    check_vector("free_qdd", free_qdd, free.len())?;
    check_vector("tau", tau, model.nv)?;
    prepare(model, data, contacts, q, v)?;
    let mut tau = tau.to_vec();
    let unit = pin_free_rates(data, &free);
    for (&k, &a) in free.iter().zip(free_qdd) {
        tau[k] = unit * a;
    }
    let solved = solve_dynamics(model, data, contacts, &tau);
    unpin_free_rates(data, &free);
    solved
}

/// Gives each free rate (a zero row and column of `M`, a zero column of `A`, `h_k = 0`) the
/// inertia `M_kk` = the largest diagonal entry of `M` (at least 1), so that its row of the KKT
/// system reads `M_kk q̈_k = τ_k` and decouples from the rest; returns that inertia.
pub(super) fn pin_free_rates(data: &mut SpatialData, free: &[usize]) -> f64 {
    let unit = (0..data.M.nrows())
        .map(|k| data.M[(k, k)])
        .fold(1.0, f64::max);
    for &k in free {
        debug_assert!(data.M.column(k).iter().all(|&x| x == 0.0) && data.h[k] == 0.0);
        data.M[(k, k)] = unit;
    }
    unit
}

/// Restores the free rates' zero diagonal of `M` after [`pin_free_rates`].
pub(super) fn unpin_free_rates(data: &mut SpatialData, free: &[usize]) {
    for &k in free {
        data.M[(k, k)] = 0.0;
    }
}

/// The KKT solve of [`forward_dynamics`] at the prepared state.
fn solve_dynamics(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    tau: &[f64],
) -> SpatialResult<()> {
    if has_coulomb_sliding(contacts) {
        let B = friction_rows(model, data, contacts)?;
        solve_sliding(data, &B, tau)?;
        check_result("q̈", data.qdd.as_slice())?;
        check_result("λ", data.lam.as_slice())?;
        return Ok(());
    }
    factor(data)?;
    let (f, h) = (data.rhs_f.as_mut_slice(), data.h.as_slice());
    for (f, (t, h)) in f.iter_mut().zip(tau.iter().zip(h)) {
        *f = t - h;
    }
    for (g, d) in data
        .rhs_g
        .as_mut_slice()
        .iter_mut()
        .zip(data.A_drift.as_slice())
    {
        *g = -d;
    }
    solve(data)?;
    data.lam.neg_mut();
    check_result("q̈", data.qdd.as_slice())?;
    check_result("λ", data.lam.as_slice())?;
    Ok(())
}

/// The blocks of the KKT inverse of a contact set at `q` (thesis (5.2)): with
/// `[M Aᵀ; A 0]⁻¹ = [M† A†ᵀ; A† Λ]`, `M†` (nv × nv), `A†` (c × nv) and `Λ` (c × c), by the
/// planar core's null-space block inverse (Lemma 5.1), exact for a singular `M`. The rows
/// are [`contact_rows`]'; in this engine's sign (`M q̈ + h = τ + Aᵀλ`) the dynamics read
/// `q̈ = M†(τ − h) − A†ᵀ Ȧq̇` and `λ = −A†(τ − h) + Λ Ȧq̇`. The free rates of a massless limb
/// in the air ([`free_rates`]) leave the system out (their rows and columns of the blocks are
/// zero), as the planar core's prescribed joints; a contact set whose rows are dependent is
/// the typed redundant-constraints error.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialKkt {
    pub blocks: crate::KktBlocks,
    /// The rates left out, [`free_rates`].
    pub free_rates: Vec<usize>,
    /// The condition numbers of the rows and of the motion they leave free.
    pub info: crate::KktInfo,
}

/// [`SpatialKkt`] of `contacts` at `q` (the factorization uses `data`'s `M` and `A`, and
/// leaves them there).
pub fn kkt_blocks(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
) -> SpatialResult<SpatialKkt> {
    let nv = model.nv;
    prepare(model, data, contacts, q, &vec![0.0; nv])?;
    let free = free_rates(model, contacts);
    let kept: Vec<usize> = (0..nv).filter(|k| !free.contains(k)).collect();
    let mut kkt = crate::KktFactorization::default();
    kkt.factor_on(&data.M, &data.A, &kept)?;
    Ok(SpatialKkt {
        blocks: kkt.blocks().embedded(&kept, nv),
        free_rates: free,
        info: kkt.info(),
    })
}
