//! Planar frames in the sagittal (x–z) plane, thesis conventions (section 4.2.1).
//!
//! * World and body frames are "North-East-Down": `+x` forward, `+z` **down**, `+y` to the
//!   robot's right. Seen from the robot's right side the nose points right and `+y` points at
//!   the viewer, so a positive rotation about `+y` is counter-clockwise on the page: **nose-up**.
//! * A rotation by `β` about `+y` acts on `(x, z)` coordinates as
//!   `R(β) = [[cos β, sin β], [−sin β, cos β]]`. The body pitch `φ` is such a rotation:
//!   `R_wp = R(φ)` maps body coordinates to world coordinates.
//! * A planar twist is `(v_x, v_z, ω)` with `ω` about `+y`; a wrench is `(f_x, f_z, m)`; their
//!   pairing is power. The velocity of a point at offset `r` from a frame rotating at `ω` is
//!   `v + ω S(r)` with `S(r) = (r_z, −r_x)` (this is `ŷ × r`).
use nalgebra::{Matrix2, Matrix3, Vector2};

/// `R(β)`: rotation by `β` about `+y`, acting on `(x, z)`.
#[inline]
pub fn rot(beta: f64) -> Matrix2<f64> {
    let (s, c) = beta.sin_cos();
    Matrix2::new(c, s, -s, c)
}

/// `R(β) r` without forming the matrix.
#[inline]
pub fn rotate(beta: f64, r: Vector2<f64>) -> Vector2<f64> {
    rotate_sc(beta.sin_cos(), r)
}

/// [`rotate`] with `(sin β, cos β)` already known.
#[inline]
pub fn rotate_sc((s, c): (f64, f64), r: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(c * r.x + s * r.y, -s * r.x + c * r.y)
}

/// `S(r) = ŷ × r = (r_z, −r_x)`: velocity of the point `r` under a unit rotation rate about `+y`.
#[inline]
pub fn perp(r: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(r.y, -r.x)
}

/// Block rotation `diag(R(φ), 1)` taking body twists to world coordinate rates
/// (thesis `R_wp` in 4.1.1: `V^b_wp = R_wpᵀ ẋ`).
pub fn rot3(phi: f64) -> Matrix3<f64> {
    let r = rot(phi);
    Matrix3::new(
        r[(0, 0)],
        r[(0, 1)],
        0.0,
        r[(1, 0)],
        r[(1, 1)],
        0.0,
        0.0,
        0.0,
        1.0,
    )
}

/// Planar adjoint `Ad_g` of `g_ab = (p, R(β))` (frame B seen from A) acting on twists
/// `(v_x, v_z, ω)`: `Ad_g [v; ω] = [R v − ω S(p); ω]`, i.e. Murray–Li–Sastry eq. (2.58)
/// `[R, p̂R; 0, R]` in the x–z plane (`p × ωŷ = −ω S(p)`). It maps a body twist of B to the
/// twist of the material point at A's origin, in A's axes; `Ad_gᵀ` maps wrenches back.
pub fn adjoint(p: Vector2<f64>, beta: f64) -> Matrix3<f64> {
    let r = rot(beta);
    let s = perp(p);
    Matrix3::new(
        r[(0, 0)],
        r[(0, 1)],
        -s.x,
        r[(1, 0)],
        r[(1, 1)],
        -s.y,
        0.0,
        0.0,
        1.0,
    )
}

/// Wraps an angle to `(−π, π]`.
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let mut w = a.rem_euclid(two_pi);
    if w > std::f64::consts::PI {
        w -= two_pi;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn rotation_is_nose_up_for_positive_pitch() {
        // The front hip at +x in the body must rise (world z decreases, z is down) for φ > 0.
        let front = rotate(0.3, Vector2::new(1.0, 0.0));
        assert!(front.y < 0.0);
        assert_relative_eq!(rot(0.3) * Vector2::new(1.0, 0.0), front, epsilon = 1e-15);
    }

    #[test]
    fn perp_is_derivative_of_rotation() {
        // d/dβ R(β) r = S(R(β) r), checked against a central difference.
        let r = Vector2::new(0.3, -0.7);
        let b = 0.4;
        let h = 1e-6;
        let fd = (rotate(b + h, r) - rotate(b - h, r)) / (2.0 * h);
        assert_relative_eq!(fd, perp(rotate(b, r)), epsilon = 1e-9);
    }

    #[test]
    fn adjoint_gives_velocity_of_point_at_parent_origin() {
        // B sits at p in A, rotated by β; it moves with body twist (v, ω). The material point
        // of B at A's origin has B-coordinates −R(β)ᵀp and A-velocity R(β)(v + ω S(−R(β)ᵀp)).
        let (p, beta) = (Vector2::new(0.2, 0.1), 0.3);
        let tw = nalgebra::Vector3::new(1.0, -2.0, 0.5);
        let out = adjoint(p, beta) * tw;
        let local = -(rot(beta).transpose() * p);
        let expect = rotate(beta, Vector2::new(tw.x, tw.y) + tw.z * perp(local));
        assert_relative_eq!(Vector2::new(out.x, out.y), expect, epsilon = 1e-14);
        assert_relative_eq!(out.z, tw.z);
    }

    #[test]
    fn wrap_is_half_open() {
        assert_relative_eq!(wrap_angle(std::f64::consts::PI), std::f64::consts::PI);
        assert_relative_eq!(wrap_angle(-std::f64::consts::PI), std::f64::consts::PI);
        assert_relative_eq!(
            wrap_angle(7.0),
            7.0 - std::f64::consts::TAU,
            epsilon = 1e-15
        );
    }
}
