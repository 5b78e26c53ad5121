//! Spatial motion (twist) and force (wrench) vectors, linear part first as in Pinocchio.
//!
//! A [`Motion`] `[v; ω]` is the velocity of a rigid body expressed at the origin of some
//! frame: `v` the velocity of the body point at that origin, `ω` the angular velocity
//! (Featherstone 2008, §2.3; thesis §4.1.1, the body velocity `V` of Table 4.1 for `d = 3`).
//! A [`Force`] `[f; n]` is a force `f` and the moment `n` about the same origin (Featherstone
//! 2008, §2.4). Their pairing `m·f = v·f + ω·n` is power.
#![allow(non_snake_case)]
use nalgebra::{Vector3, Vector6};

/// A spatial motion vector `[v; ω]` (m/s, rad/s).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    pub linear: Vector3<f64>,
    pub angular: Vector3<f64>,
}

/// A spatial force vector `[f; n]` (N, N·m).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Force {
    pub linear: Vector3<f64>,
    pub angular: Vector3<f64>,
}

impl Motion {
    pub fn new(linear: Vector3<f64>, angular: Vector3<f64>) -> Self {
        Self { linear, angular }
    }
    pub fn zero() -> Self {
        Self::default()
    }
    /// From `[v; ω]` stacked (linear first).
    pub fn from_vector(x: &Vector6<f64>) -> Self {
        Self::new(x.fixed_rows::<3>(0).into(), x.fixed_rows::<3>(3).into())
    }
    /// `[v; ω]` stacked (linear first).
    pub fn to_vector(&self) -> Vector6<f64> {
        let mut x = Vector6::zeros();
        x.fixed_rows_mut::<3>(0).copy_from(&self.linear);
        x.fixed_rows_mut::<3>(3).copy_from(&self.angular);
        x
    }
    /// The motion cross product `m₁ × m₂ = [ω₁×v₂ + v₁×ω₂; ω₁×ω₂]` (Featherstone 2008, (2.31)):
    /// the rate of change of `m₂` carried by a frame moving with `m₁`.
    pub fn cross(&self, other: &Motion) -> Motion {
        Motion::new(
            self.angular.cross(&other.linear) + self.linear.cross(&other.angular),
            self.angular.cross(&other.angular),
        )
    }
    /// The force cross product `m ×* f = [ω×f; ω×n + v×f]` (Featherstone 2008, (2.32)), the
    /// dual of [`Self::cross`]: `(m × m')·f = −m'·(m ×* f)`.
    pub fn cross_force(&self, f: &Force) -> Force {
        Force::new(
            self.angular.cross(&f.linear),
            self.angular.cross(&f.angular) + self.linear.cross(&f.linear),
        )
    }
    /// The power `v·f + ω·n` of a force on this motion.
    pub fn dot(&self, f: &Force) -> f64 {
        self.linear.dot(&f.linear) + self.angular.dot(&f.angular)
    }
}

impl Force {
    pub fn new(linear: Vector3<f64>, angular: Vector3<f64>) -> Self {
        Self { linear, angular }
    }
    pub fn zero() -> Self {
        Self::default()
    }
    /// `[f; n]` stacked (linear first).
    pub fn to_vector(&self) -> Vector6<f64> {
        let mut x = Vector6::zeros();
        x.fixed_rows_mut::<3>(0).copy_from(&self.linear);
        x.fixed_rows_mut::<3>(3).copy_from(&self.angular);
        x
    }
    pub fn from_vector(x: &Vector6<f64>) -> Self {
        Self::new(x.fixed_rows::<3>(0).into(), x.fixed_rows::<3>(3).into())
    }
}

macro_rules! spatial_ops {
    ($t:ident) => {
        impl std::ops::Add for $t {
            type Output = $t;
            fn add(self, o: $t) -> $t {
                $t::new(self.linear + o.linear, self.angular + o.angular)
            }
        }
        impl std::ops::Sub for $t {
            type Output = $t;
            fn sub(self, o: $t) -> $t {
                $t::new(self.linear - o.linear, self.angular - o.angular)
            }
        }
        impl std::ops::AddAssign for $t {
            fn add_assign(&mut self, o: $t) {
                self.linear += o.linear;
                self.angular += o.angular;
            }
        }
        impl std::ops::Mul<f64> for $t {
            type Output = $t;
            fn mul(self, s: f64) -> $t {
                $t::new(self.linear * s, self.angular * s)
            }
        }
        impl std::ops::Neg for $t {
            type Output = $t;
            fn neg(self) -> $t {
                $t::new(-self.linear, -self.angular)
            }
        }
    };
}
spatial_ops!(Motion);
spatial_ops!(Force);

#[cfg(test)]
mod tests {
    use super::*;

    fn m(a: [f64; 6]) -> Motion {
        Motion::from_vector(&Vector6::from_column_slice(&a))
    }

    /// The duality `(m × m')·f = −m'·(m ×* f)` (Featherstone 2008, (2.33)): the two cross
    /// products are written independently, so this pins both.
    #[test]
    fn force_cross_is_the_dual_of_motion_cross() {
        let (a, b) = (
            m([0.3, -1.2, 0.7, 2.0, -0.4, 1.1]),
            m([-0.8, 0.5, 1.9, -0.2, 0.9, -1.4]),
        );
        let f = Force::from_vector(&Vector6::new(1.5, -0.3, 0.8, -2.2, 0.6, 0.4));
        let lhs = a.cross(&b).dot(&f);
        let rhs = -b.dot(&a.cross_force(&f));
        assert!((lhs - rhs).abs() < 1e-14, "{lhs} vs {rhs}");
        // a motion crossed with itself is zero
        assert!(a.cross(&a).to_vector().norm() < 1e-15);
    }
}
