//! The configuration space as a Lie group: `q ⊕ v` ([`integrate`]), `q₁ ⊖ q₀`
//! ([`difference`]) and the identity ([`neutral`]), joint by joint (Pinocchio's
//! `integrate`/`difference`/`neutral`).
//!
//! Layout (Pinocchio's, so arrays pass between the two unchanged): `q` stacks each joint's
//! coordinates in joint order, `v` its rates. A free flyer has `q = [x, y, z, qx, qy, qz, qw]`
//! (the base position in the world and the unit quaternion of its orientation) and
//! `v = [v_x, v_y, v_z, ω_x, ω_y, ω_z]`, the base twist **in the base frame**; so `nq = nv + 1`.
//! A free flyer integrates on SE(3): `g(q ⊕ v) = g(q) exp6(v)` (the body-frame exponential,
//! [`super::explog::exp6`]), and the quaternion is renormalized, so its norm stays 1 to
//! round-off along any run. Revolute and prismatic joints are vector spaces.
//!
//! Pinocchio's layout differs in one joint: a URDF `continuous` joint (unbounded revolute) has
//! the angle `θ` here and `(cos θ, sin θ)` there (`nq` one larger per such joint, `v` the
//! same); [`to_pinocchio`] and [`from_pinocchio`] convert `q`.
use super::error::{SpatialError, SpatialResult};
use super::explog::{exp6_quaternion, log6_quaternion};
use super::model::{JointKind, SpatialModel};
use super::motion::Motion;
use crate::error::check_vector;
use nalgebra::{DVector, Quaternion, UnitQuaternion, Vector3};

/// Tolerance on `|‖quaternion‖ − 1|` accepted in an input `q`.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-9;

/// The base orientation quaternion stored at `q[i..i+4]` (`[qx, qy, qz, qw]`), unnormalized.
pub fn quaternion_at(q: &[f64], i: usize) -> Quaternion<f64> {
    Quaternion::new(q[i + 3], q[i], q[i + 1], q[i + 2])
}

fn store_quaternion(q: &mut [f64], i: usize, r: &UnitQuaternion<f64>) {
    q[i..i + 4].copy_from_slice(&[r.i, r.j, r.k, r.w]);
}

/// Checks `q`: length `nq`, finite, and every free flyer's quaternion of unit norm.
pub fn check_configuration(
    model: &SpatialModel,
    field: &'static str,
    q: &[f64],
) -> SpatialResult<()> {
    check_vector(field, q, model.nq)?;
    for joint in &model.joints {
        if joint.kind == JointKind::FreeFlyer {
            let norm = quaternion_at(q, joint.idx_q + 3).norm();
            if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                return Err(SpatialError::NonUnitQuaternion { field, norm });
            }
        }
    }
    Ok(())
}

/// The identity configuration: zero joint coordinates, base at the origin with `qw = 1`.
pub fn neutral(model: &SpatialModel) -> DVector<f64> {
    let mut q = DVector::zeros(model.nq);
    for joint in &model.joints {
        if joint.kind == JointKind::FreeFlyer {
            q[joint.idx_q + 6] = 1.0;
        }
    }
    q
}

/// `q ⊕ v`: the configuration reached from `q` by moving with the constant rates `v` for unit
/// time (`v dt` for a step `dt`). A free flyer's quaternion stays in the hemisphere of `q`'s
/// (`q₁ · q₀ ≥ 0`, as Pinocchio keeps it): the same rotation as its negative, and the same
/// numbers as Pinocchio's `integrate` where a step turns the base by more than π.
pub fn integrate(model: &SpatialModel, q: &[f64], v: &[f64]) -> SpatialResult<DVector<f64>> {
    check_configuration(model, "q", q)?;
    check_vector("v", v, model.nv)?;
    let mut out = DVector::from_column_slice(q);
    for joint in &model.joints {
        let (iq, iv) = (joint.idx_q, joint.idx_v);
        match joint.kind {
            JointKind::FreeFlyer => {
                let r0 = UnitQuaternion::new_normalize(quaternion_at(q, iq + 3));
                let twist = Motion::new(
                    Vector3::from_column_slice(&v[iv..iv + 3]),
                    Vector3::from_column_slice(&v[iv + 3..iv + 6]),
                );
                let (dr, dp) = exp6_quaternion(&twist);
                let p = Vector3::from_column_slice(&q[iq..iq + 3]) + r0 * dp;
                out.as_mut_slice()[iq..iq + 3].copy_from_slice(p.as_slice());
                let mut r1 = *(r0 * dr).quaternion();
                if r1.coords.dot(&r0.coords) < 0.0 {
                    r1 = -r1;
                }
                store_quaternion(
                    out.as_mut_slice(),
                    iq + 3,
                    &UnitQuaternion::new_normalize(r1),
                );
            }
            // vector-space coordinates: a one-rate joint's, a planar joint's `[x, z, θ]`
            kind => (0..kind.nv()).for_each(|k| out[iq + k] += v[iv + k]),
        }
    }
    Ok(out)
}

/// `q₁ ⊖ q₀`: the rates `v` with `q₀ ⊕ v = q₁` (the free flyer's `log6(g(q₀)⁻¹ g(q₁))`, in
/// the base frame at `q₀`; unique for relative rotations below π).
pub fn difference(model: &SpatialModel, q0: &[f64], q1: &[f64]) -> SpatialResult<DVector<f64>> {
    check_configuration(model, "q0", q0)?;
    check_configuration(model, "q1", q1)?;
    let mut v = DVector::zeros(model.nv);
    for joint in &model.joints {
        let (iq, iv) = (joint.idx_q, joint.idx_v);
        match joint.kind {
            JointKind::FreeFlyer => {
                let r0 = UnitQuaternion::new_normalize(quaternion_at(q0, iq + 3));
                let r1 = UnitQuaternion::new_normalize(quaternion_at(q1, iq + 3));
                let dp = r0.inverse()
                    * (Vector3::from_column_slice(&q1[iq..iq + 3])
                        - Vector3::from_column_slice(&q0[iq..iq + 3]));
                let m = log6_quaternion(&(r0.inverse() * r1), &dp);
                v.as_mut_slice()[iv..iv + 6].copy_from_slice(m.to_vector().as_slice());
            }
            kind => (0..kind.nv()).for_each(|k| v[iv + k] = q1[iq + k] - q0[iq + k]),
        }
    }
    Ok(v)
}

/// Tolerance on `|cos² θ + sin² θ − 1|` accepted from a continuous joint's Pinocchio
/// coordinates.
pub const UNIT_CIRCLE_TOLERANCE: f64 = 1e-9;

/// The length of `q` in Pinocchio's layout: `nq` plus one per continuous joint.
pub fn pinocchio_nq(model: &SpatialModel) -> usize {
    model.nq + model.joints.iter().filter(|j| j.continuous).count()
}

/// This layout's `q` in Pinocchio's: each continuous joint's angle `θ` becomes
/// `(cos θ, sin θ)`, every other coordinate is copied.
pub fn to_pinocchio(model: &SpatialModel, q: &[f64]) -> SpatialResult<DVector<f64>> {
    check_configuration(model, "q", q)?;
    let mut out = DVector::zeros(pinocchio_nq(model));
    let mut at = 0;
    for joint in &model.joints {
        let (iq, nq) = (joint.idx_q, joint.kind.nq());
        if joint.continuous {
            let (s, c) = q[iq].sin_cos();
            out[at] = c;
            out[at + 1] = s;
            at += 2;
        } else {
            out.as_mut_slice()[at..at + nq].copy_from_slice(&q[iq..iq + nq]);
            at += nq;
        }
    }
    Ok(out)
}

/// Pinocchio's `q` in this layout: each continuous joint's `(cos θ, sin θ)` (of unit norm to
/// [`UNIT_CIRCLE_TOLERANCE`]) becomes `θ = atan2(sin θ, cos θ)` in `(−π, π]`.
pub fn from_pinocchio(model: &SpatialModel, q_pinocchio: &[f64]) -> SpatialResult<DVector<f64>> {
    check_vector("q", q_pinocchio, pinocchio_nq(model))?;
    let mut q = DVector::zeros(model.nq);
    let mut at = 0;
    for joint in &model.joints {
        let (iq, nq) = (joint.idx_q, joint.kind.nq());
        if joint.continuous {
            let (c, s) = (q_pinocchio[at], q_pinocchio[at + 1]);
            let norm = c.hypot(s);
            if (norm - 1.0).abs() > UNIT_CIRCLE_TOLERANCE {
                return Err(SpatialError::InvalidArgument {
                    field: format!("q[{at}..{}] (joint `{}`)", at + 2, joint.name),
                    reason: format!("(cos θ, sin θ) of norm {norm}, not 1"),
                });
            }
            q[iq] = s.atan2(c);
            at += 2;
        } else {
            q.as_mut_slice()[iq..iq + nq].copy_from_slice(&q_pinocchio[at..at + nq]);
            at += nq;
        }
    }
    check_configuration(model, "q", q.as_slice())?;
    Ok(q)
}
