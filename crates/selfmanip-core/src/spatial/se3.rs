//! Rigid transformations `g = (R, p) ∈ SE(3)` and their actions on points, motions, forces
//! (thesis §4.1.1, `g_ab ∈ SE(d)` with `d = 3`; Featherstone 2008, §2.8; Pinocchio's `SE3`).
//!
//! `g_ab` takes frame `A` into frame `B`: it maps coordinates in `B` to coordinates in `A`,
//! `x_a = R x_b + p`. Its action on a motion expressed in `B` is the same motion expressed in
//! `A` (the adjoint `Ad_g`), and dually on forces (`Ad_g⁻ᵀ`).
#![allow(non_snake_case)]
use super::motion::{Force, Motion};
use nalgebra::{Matrix3, Matrix6, Rotation3, UnitQuaternion, Vector3};

/// A rigid transformation `(R, p)`: `x ↦ R x + p`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SE3 {
    pub rotation: Matrix3<f64>,
    pub translation: Vector3<f64>,
}

impl Default for SE3 {
    fn default() -> Self {
        Self::identity()
    }
}

/// The skew matrix `[a]ₓ` with `[a]ₓ b = a × b`.
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

impl SE3 {
    pub fn new(rotation: Matrix3<f64>, translation: Vector3<f64>) -> Self {
        Self {
            rotation,
            translation,
        }
    }
    pub fn identity() -> Self {
        Self::new(Matrix3::identity(), Vector3::zeros())
    }
    /// From a unit quaternion and a translation.
    pub fn from_quaternion(q: &UnitQuaternion<f64>, translation: Vector3<f64>) -> Self {
        Self::new(*q.to_rotation_matrix().matrix(), translation)
    }
    /// URDF's `<origin xyz rpy>`: `R = R_z(yaw) R_y(pitch) R_x(roll)` (fixed axes x, y, z).
    pub fn from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Self {
        let r = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
        Self::new(*r.matrix(), Vector3::from(xyz))
    }
    /// `g₁ g₂ = (R₁R₂, R₁p₂ + p₁)`.
    pub fn compose(&self, other: &SE3) -> SE3 {
        SE3::new(
            self.rotation * other.rotation,
            self.rotation * other.translation + self.translation,
        )
    }
    /// `g⁻¹ = (Rᵀ, −Rᵀp)`.
    pub fn inverse(&self) -> SE3 {
        let rt = self.rotation.transpose();
        SE3::new(rt, -(rt * self.translation))
    }
    /// `g⁻¹ h` without forming `g⁻¹`.
    pub fn inverse_compose(&self, other: &SE3) -> SE3 {
        let rt = self.rotation.transpose();
        SE3::new(
            rt * other.rotation,
            rt * (other.translation - self.translation),
        )
    }
    /// A point: `R x + p`.
    pub fn act_point(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * x + self.translation
    }
    /// `Ad_g m = [R v + p × Rω; Rω]` (Featherstone 2008, (2.24) with `X = Ad_g`).
    pub fn act_motion(&self, m: &Motion) -> Motion {
        let w = self.rotation * m.angular;
        Motion::new(self.rotation * m.linear + self.translation.cross(&w), w)
    }
    /// `Ad_g⁻¹ m = [Rᵀ(v − p × ω); Rᵀω]`.
    pub fn act_inv_motion(&self, m: &Motion) -> Motion {
        let rt = self.rotation.transpose();
        Motion::new(
            rt * (m.linear - self.translation.cross(&m.angular)),
            rt * m.angular,
        )
    }
    /// `Ad_g⁻ᵀ f = [R f; R n + p × R f]` (Featherstone 2008, (2.25)).
    pub fn act_force(&self, f: &Force) -> Force {
        let lin = self.rotation * f.linear;
        Force::new(
            lin,
            self.rotation * f.angular + self.translation.cross(&lin),
        )
    }
    /// `Ad_gᵀ f = [Rᵀ f; Rᵀ(n − p × f)]`.
    pub fn act_inv_force(&self, f: &Force) -> Force {
        let rt = self.rotation.transpose();
        Force::new(
            rt * f.linear,
            rt * (f.angular - self.translation.cross(&f.linear)),
        )
    }
    /// The 6×6 adjoint `Ad_g = [R [p]ₓR; 0 R]` acting on `[v; ω]` (linear first).
    pub fn action_matrix(&self) -> Matrix6<f64> {
        let mut x = Matrix6::zeros();
        x.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.rotation);
        x.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(skew(&self.translation) * self.rotation));
        x.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.rotation);
        x
    }
    /// Largest entry-wise difference from `other`, for tests and round-trip checks.
    pub fn max_abs_diff(&self, other: &SE3) -> f64 {
        (self.rotation - other.rotation)
            .abs()
            .max()
            .max((self.translation - other.translation).abs().max())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> SE3 {
        SE3::from_xyz_rpy([0.3, -0.7, 1.1], [0.4, -1.2, 2.5])
    }

    /// `Ad_g` by its matrix equals `act_motion`, and `act_inv_motion` undoes it; the force
    /// action preserves power: `(Ad_g m)·(Ad_g⁻ᵀ f) = m·f` (Featherstone 2008, (2.26)).
    #[test]
    fn actions_are_consistent() {
        let g = sample();
        let m = Motion::new(Vector3::new(0.2, -1.0, 0.5), Vector3::new(1.3, 0.1, -0.6));
        let f = Force::new(Vector3::new(-0.4, 2.0, 0.9), Vector3::new(0.7, -0.3, 1.5));
        let by_matrix = g.action_matrix() * m.to_vector();
        assert!((by_matrix - g.act_motion(&m).to_vector()).norm() < 1e-14);
        assert!((g.act_inv_motion(&g.act_motion(&m)).to_vector() - m.to_vector()).norm() < 1e-14);
        assert!((g.act_inv_force(&g.act_force(&f)).to_vector() - f.to_vector()).norm() < 1e-14);
        assert!((g.act_motion(&m).dot(&g.act_force(&f)) - m.dot(&f)).abs() < 1e-14);
        // the action of a composition is the composition of the actions
        let h = SE3::from_xyz_rpy([-1.0, 0.2, 0.0], [0.0, 0.3, -0.9]);
        let gh = g.compose(&h);
        assert!(
            (gh.act_motion(&m).to_vector() - g.act_motion(&h.act_motion(&m)).to_vector()).norm()
                < 1e-14
        );
        assert!(g.compose(&g.inverse()).max_abs_diff(&SE3::identity()) < 1e-15);
        assert!(g.inverse_compose(&gh).max_abs_diff(&h) < 1e-15);
    }

    /// URDF's rpy: a pure yaw of 90° maps x to y.
    #[test]
    fn rpy_is_fixed_axis_xyz() {
        let g = SE3::from_xyz_rpy([0.0; 3], [0.0, 0.0, std::f64::consts::FRAC_PI_2]);
        assert!((g.act_point(&Vector3::x()) - Vector3::y()).norm() < 1e-15);
        let g = SE3::from_xyz_rpy([0.0; 3], [0.3, 0.0, 0.0]);
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), 0.3);
        assert!((g.rotation - rx.matrix()).norm() < 1e-15);
    }
}
