//! A test terrain shared by the core's and the hybrid engine's collision tests.
use nalgebra::Vector2;
use selfmanip_core::{GroundPlane, Terrain};

/// Level ground at `z = 0` and a spike: one convex corner at `tip`, offered everywhere.
pub struct Spike {
    pub tip: Vector2<f64>,
}

impl Terrain for Spike {
    fn plane_under(&self, _x_m: f64) -> GroundPlane {
        GroundPlane::level(0.0)
    }
    fn corner_near(&self, _c: Vector2<f64>) -> Option<Vector2<f64>> {
        Some(self.tip)
    }
}
