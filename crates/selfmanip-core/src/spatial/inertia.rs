//! Spatial rigid-body inertia `(m, c, I_c)` (Featherstone 2008, §2.13; Pinocchio's
//! `Inertia`): mass `m`, centre of mass `c` in the body frame and the rotational inertia `I_c`
//! about the centre of mass. A zero mass is allowed and stays zero: sums and transforms never
//! divide by a mass that may vanish (a massless link contributes nothing, not an epsilon).
#![allow(non_snake_case)]
use super::motion::{Force, Motion};
use super::se3::{skew, SE3};
use nalgebra::{Matrix3, Matrix6, Vector3};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inertia {
    /// kg, `≥ 0`.
    pub mass: f64,
    /// Centre of mass in the body frame (m).
    pub com: Vector3<f64>,
    /// Rotational inertia about the centre of mass, in body axes (kg·m²), symmetric PSD.
    pub inertia_com: Matrix3<f64>,
}

impl Default for Inertia {
    fn default() -> Self {
        Self::zero()
    }
}

impl Inertia {
    pub fn new(mass: f64, com: Vector3<f64>, inertia_com: Matrix3<f64>) -> Self {
        Self {
            mass,
            com,
            inertia_com,
        }
    }
    pub fn zero() -> Self {
        Self::new(0.0, Vector3::zeros(), Matrix3::zeros())
    }
    /// `I v = [m(v − c×ω); I_c ω + c × m(v − c×ω)]` (Featherstone 2008, (2.63) at the frame
    /// origin, linear first).
    pub fn apply(&self, v: &Motion) -> Force {
        let f = (v.linear - self.com.cross(&v.angular)) * self.mass;
        Force::new(f, self.inertia_com * v.angular + self.com.cross(&f))
    }
    /// The 6×6 matrix `[m 1, −m[c]ₓ; m[c]ₓ, I_c − m[c]ₓ²]` of [`Self::apply`].
    pub fn matrix(&self) -> Matrix6<f64> {
        let (m, cx) = (self.mass, skew(&self.com));
        let mut y = Matrix6::zeros();
        y.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * m));
        y.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-cx * m));
        y.fixed_view_mut::<3, 3>(3, 0).copy_from(&(cx * m));
        y.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(self.inertia_com - cx * cx * m));
        y
    }
    /// The same body's inertia expressed in the frame `A` when it is given in `B` and
    /// `g = g_ab`: `(m, R c + p, R I_c Rᵀ)` (Featherstone 2008, (2.66)).
    pub fn transformed(&self, g: &SE3) -> Inertia {
        Inertia::new(
            self.mass,
            g.act_point(&self.com),
            g.rotation * self.inertia_com * g.rotation.transpose(),
        )
    }
    /// The inertia of two bodies rigidly joined (both in the same frame): masses add, the
    /// centre of mass is the mass-weighted mean, and each `I_c` moves to the new centre by the
    /// parallel-axis theorem. Two massless parts give a massless part whose rotational inertia
    /// is the sum (it is the same about every point).
    pub fn combined(&self, other: &Inertia) -> Inertia {
        let mass = self.mass + other.mass;
        if mass == 0.0 {
            return Inertia::new(0.0, Vector3::zeros(), self.inertia_com + other.inertia_com);
        }
        let com = (self.com * self.mass + other.com * other.mass) / mass;
        let shift = |b: &Inertia| {
            let d = skew(&(b.com - com));
            b.inertia_com - d * d * b.mass
        };
        Inertia::new(mass, com, shift(self) + shift(other))
    }
}

/// A rigid body's inertia at a frame's origin in the frame's axes as the ten numbers the
/// composite-rigid-body and Newton–Euler sweeps use (Featherstone 2008, (2.63); Pinocchio's
/// world-frame `oYcrb`): mass `m`, first moment `h = m c` and the rotational inertia
/// `I_o = I_c − m[c]ₓ²` about the origin. Sums of bodies are sums of the numbers (no division
/// by a mass that may vanish), and [`Self::apply`] costs two cross products and a 3 × 3
/// product, against the 6 × 6 matrix's 36 products.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OriginInertia {
    pub mass: f64,
    pub first_moment: Vector3<f64>,
    pub rotational: Matrix3<f64>,
}

impl OriginInertia {
    /// The body `y` (given in frame `B`) at the origin of frame `A`, `g = g_ab`: the centre of
    /// mass `c_a = R c + p`, `I_o = R I_c Rᵀ + m (|c_a|² 1 − c_a c_aᵀ)`. A zero inertia stays zero.
    pub fn of_body(y: &Inertia, g: &SE3) -> Self {
        if y.mass == 0.0 && y.inertia_com == Matrix3::zeros() {
            return Self::default();
        }
        let c = g.act_point(&y.com);
        let r = &g.rotation;
        let mut rotational = r * y.inertia_com * r.transpose();
        let m = y.mass;
        let cc = c.norm_squared();
        for i in 0..3 {
            for j in 0..3 {
                let d = if i == j { cc } else { 0.0 };
                rotational[(i, j)] += m * (d - c[i] * c[j]);
            }
        }
        Self {
            mass: m,
            first_moment: c * m,
            rotational,
        }
    }
    /// `I v = [m v − h × ω; h × v + I_o ω]`, [`Inertia::apply`] at the frame's origin.
    pub fn apply(&self, v: &Motion) -> Force {
        let h = &self.first_moment;
        Force::new(
            v.linear * self.mass - h.cross(&v.angular),
            h.cross(&v.linear) + self.rotational * v.angular,
        )
    }
    /// The sum of two bodies at the same origin.
    pub fn add(&mut self, other: &Self) {
        self.mass += other.mass;
        self.first_moment += other.first_moment;
        self.rotational += other.rotational;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body() -> Inertia {
        let i = Matrix3::new(0.4, 0.02, -0.01, 0.02, 0.3, 0.03, -0.01, 0.03, 0.2);
        Inertia::new(2.5, Vector3::new(0.1, -0.2, 0.05), i)
    }

    /// [`body`], a placement and a motion, shared by the transform tests.
    fn moved_body() -> (Inertia, SE3, Motion) {
        let g = SE3::from_xyz_rpy([0.5, 0.1, -0.3], [1.0, -0.4, 0.2]);
        let v = Motion::new(Vector3::new(0.3, -1.1, 0.8), Vector3::new(0.9, 0.4, -0.7));
        (body(), g, v)
    }

    /// The kinetic energy `½ vᵀ I v` equals `½ m |v_c|² + ½ ωᵀ I_c ω` with `v_c` the velocity of
    /// the centre of mass (König's theorem), and the matrix form equals `apply`.
    #[test]
    fn energy_is_koenig() {
        let y = body();
        let v = Motion::new(Vector3::new(0.3, -1.1, 0.8), Vector3::new(0.9, 0.4, -0.7));
        let vc = v.linear + v.angular.cross(&y.com);
        let koenig =
            0.5 * y.mass * vc.norm_squared() + 0.5 * v.angular.dot(&(y.inertia_com * v.angular));
        assert!((0.5 * v.dot(&y.apply(&v)) - koenig).abs() < 1e-14);
        assert!((y.matrix() * v.to_vector() - y.apply(&v).to_vector()).norm() < 1e-14);
    }

    /// The origin form applies as the body's matrix moved to the new frame (`Ad_g⁻ᵀ Y Ad_g⁻¹`,
    /// a second formulation), sums as the joined bodies, and a massless body stays zero.
    #[test]
    fn origin_form_matches_the_matrix() {
        let (y, g, v) = moved_body();
        let by_origin = OriginInertia::of_body(&y, &g).apply(&v).to_vector();
        let moved = g.act_force(&y.apply(&g.act_inv_motion(&v))).to_vector();
        assert!((by_origin - moved).norm() < 1e-13);
        let z = Inertia::new(
            0.7,
            Vector3::new(-0.4, 0.3, 0.2),
            Matrix3::identity() * 0.01,
        );
        let mut sum = OriginInertia::of_body(&y, &g);
        sum.add(&OriginInertia::of_body(&z, &g));
        let joined = OriginInertia::of_body(&y.combined(&z), &g)
            .apply(&v)
            .to_vector();
        assert!((sum.apply(&v).to_vector() - joined).norm() < 1e-13);
        assert_eq!(
            OriginInertia::of_body(&Inertia::zero(), &g),
            OriginInertia::default()
        );
    }

    /// Transforming commutes with the action: `(g·Y)(Ad_g v) = Ad_g⁻ᵀ (Y v)`; joining two
    /// bodies adds their 6×6 matrices (a second formulation); massless parts stay massless.
    #[test]
    fn transform_and_combine() {
        let (y, g, v) = moved_body();
        let lhs = y.transformed(&g).apply(&g.act_motion(&v)).to_vector();
        assert!((lhs - g.act_force(&y.apply(&v)).to_vector()).norm() < 1e-14);
        let z = Inertia::new(
            0.7,
            Vector3::new(-0.4, 0.3, 0.2),
            Matrix3::from_diagonal(&Vector3::new(0.01, 0.02, 0.03)),
        );
        let sum = y.combined(&z).matrix();
        assert!((sum - (y.matrix() + z.matrix())).norm() < 1e-13);
        let massless = Inertia::new(0.0, Vector3::zeros(), Matrix3::identity() * 1e-3);
        let both = massless.combined(&massless);
        assert_eq!(both.mass, 0.0);
        assert!((both.matrix() - massless.matrix() * 2.0).norm() < 1e-18);
        assert!((y.combined(&Inertia::zero()).matrix() - y.matrix()).norm() < 1e-15);
    }
}
