//! Exponential and logarithm of SO(3) (as unit quaternions) and SE(3) (Murray, Li & Sastry
//! 1994, §2.3–2.4 (2.36); Pinocchio's `exp6`/`log6`), accurate to round-off down to zero
//! angle: every coefficient with a removable singularity at `θ = 0` switches to its Taylor
//! series below a threshold where the series is exact in double precision.
#![allow(non_snake_case)]
use super::motion::Motion;
use super::se3::{skew, SE3};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// `sin(θ/2)/θ`, exact to round-off for every `θ ≥ 0`.
fn half_sinc(theta: f64) -> f64 {
    if theta < 1e-3 {
        let t2 = theta * theta;
        0.5 - t2 / 48.0 + t2 * t2 / 3840.0
    } else {
        (0.5 * theta).sin() / theta
    }
}

/// `(θ − sin θ)/θ³`, the coefficient of `[ω]ₓ²` in `V(ω)` (series below θ = 1: the alternating
/// series `Σ (−θ²)ᵏ/(2k+3)!` to k = 8 has a remainder under 1e-18).
fn v_coefficient(theta: f64) -> f64 {
    if theta < 1.0 {
        let t2 = theta * theta;
        let (mut term, mut sum) = (1.0 / 6.0, 0.0);
        for k in 0..9 {
            sum += term;
            term *= -t2 / (((2 * k + 4) * (2 * k + 5)) as f64);
        }
        sum
    } else {
        (theta - theta.sin()) / (theta * theta * theta)
    }
}

/// `(1 − (θ/2) cot(θ/2))/θ²`, the coefficient of `[ω]ₓ²` in `V(ω)⁻¹` (series
/// `1/12 + θ²/720 + θ⁴/30240 + θ⁶/1209600` below θ = 0.1; above, the cancellation error is
/// multiplied by `θ²|[ω]ₓ² p|/θ²` and stays at round-off of the result).
fn v_inverse_coefficient(theta: f64) -> f64 {
    if theta < 0.1 {
        let t2 = theta * theta;
        1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1_209_600.0
    } else {
        let x = 0.5 * theta;
        (1.0 - x * x.cos() / x.sin()) / (theta * theta)
    }
}

/// `exp: so(3) → S³`, `ω ↦ (cos(θ/2), sin(θ/2) ω/θ)` with `θ = |ω|`.
pub fn quaternion_exp(w: &Vector3<f64>) -> UnitQuaternion<f64> {
    let theta = w.norm();
    let s = half_sinc(theta);
    UnitQuaternion::new_unchecked(Quaternion::new(
        (0.5 * theta).cos(),
        s * w.x,
        s * w.y,
        s * w.z,
    ))
}

/// `log: S³ → so(3)`, the rotation vector of smallest angle (`θ ∈ [0, π]`).
pub fn quaternion_log(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let (mut w, mut xyz) = (q.w, q.imag());
    if w < 0.0 {
        w = -w;
        xyz = -xyz;
    }
    let s = xyz.norm();
    // θ = 2 atan2(s, w); the factor θ/s → 2/w (1 − s²/(3w²)) as s → 0
    let factor = if s < 1e-5 * w {
        2.0 / w * (1.0 - s * s / (3.0 * w * w))
    } else {
        2.0 * s.atan2(w) / s
    };
    xyz * factor
}

/// `V(ω) = 1 + (1 − cos θ)/θ² [ω]ₓ + (θ − sin θ)/θ³ [ω]ₓ²`, so that `exp([v; ω]) = (exp ω, V v)`.
fn v_matrix(w: &Vector3<f64>) -> Matrix3<f64> {
    let theta = w.norm();
    let hs = half_sinc(theta);
    let a = 2.0 * hs * hs; // (1 − cos θ)/θ² = 2 sin²(θ/2)/θ², no cancellation
    let wx = skew(w);
    Matrix3::identity() + wx * a + wx * wx * v_coefficient(theta)
}

/// `V(ω)⁻¹ = 1 − ½[ω]ₓ + (1 − (θ/2)cot(θ/2))/θ² [ω]ₓ²`.
fn v_inverse_matrix(w: &Vector3<f64>) -> Matrix3<f64> {
    let wx = skew(w);
    Matrix3::identity() - wx * 0.5 + wx * wx * v_inverse_coefficient(w.norm())
}

/// `exp6: se(3) → SE(3)` as `(rotation quaternion, translation)`: the displacement of a body
/// moving with the constant body twist `[v; ω]` for unit time (Murray–Li–Sastry (2.36)).
pub fn exp6_quaternion(m: &Motion) -> (UnitQuaternion<f64>, Vector3<f64>) {
    (quaternion_exp(&m.angular), v_matrix(&m.angular) * m.linear)
}

/// `exp6` as an [`SE3`].
pub fn exp6(m: &Motion) -> SE3 {
    let (q, p) = exp6_quaternion(m);
    SE3::from_quaternion(&q, p)
}

/// `log6: SE(3) → se(3)` from a rotation quaternion and a translation, the inverse of
/// [`exp6_quaternion`] for angles below π.
pub fn log6_quaternion(q: &UnitQuaternion<f64>, p: &Vector3<f64>) -> Motion {
    let w = quaternion_log(q);
    Motion::new(v_inverse_matrix(&w) * p, w)
}

/// `log6` of an [`SE3`] (its rotation converted to a quaternion first).
pub fn log6(g: &SE3) -> Motion {
    let r = nalgebra::Rotation3::from_matrix_unchecked(g.rotation);
    log6_quaternion(&UnitQuaternion::from_rotation_matrix(&r), &g.translation)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `exp6` against the matrix exponential of the 4×4 twist matrix by its Taylor series
    /// (a second formulation), and `log6 ∘ exp6 = id` at angles from 0 to 3 rad.
    #[test]
    fn exp_matches_matrix_exponential_and_log_inverts_it() {
        for &scale in &[0.0, 1e-9, 1e-4, 0.05, 0.7, 1.5, 3.0] {
            let m = Motion::new(
                Vector3::new(0.3, -1.2, 0.5),
                Vector3::new(0.6, 0.2, -0.75) * scale,
            );
            let mut xi = nalgebra::Matrix4::zeros();
            xi.fixed_view_mut::<3, 3>(0, 0).copy_from(&skew(&m.angular));
            xi.fixed_view_mut::<3, 1>(0, 3).copy_from(&m.linear);
            let (mut term, mut sum) =
                (nalgebra::Matrix4::identity(), nalgebra::Matrix4::identity());
            for k in 1..40 {
                term = term * xi / k as f64;
                sum += term;
            }
            let g = exp6(&m);
            assert!(
                (g.rotation - sum.fixed_view::<3, 3>(0, 0)).norm() < 1e-14,
                "{scale}"
            );
            assert!(
                (g.translation - sum.fixed_view::<3, 1>(0, 3)).norm() < 1e-14,
                "{scale}"
            );
            let (q, p) = exp6_quaternion(&m);
            let back = log6_quaternion(&q, &p);
            assert!(
                (back.to_vector() - m.to_vector()).norm() < 4e-15,
                "{scale}: {}",
                (back.to_vector() - m.to_vector()).norm()
            );
        }
    }
}
