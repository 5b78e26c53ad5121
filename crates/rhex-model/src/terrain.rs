//! Terrain for leaps: level ground, or level ground with a ledge ahead or behind (thesis
//! Figs. 5.1 and 5.9, section 3.4.3).
//!
//! Heights are given positive **up** (the ledge's height in metres); internally the ground
//! planes are in the NED world frame (z down) of `selfmanip-core`.
//!
//! A ledge has three surfaces a contact can be on: the lower ground, the ledge's level top,
//! and its vertical face (the riser between them), all frictionless for the body and with the
//! legs' toe friction for the legs; and its top edge, the convex corner where the face meets
//! the top, on which a body end or a leg's arc can rest, roll or slide (a body end sliding up
//! the face passes over it onto the top). Two places end the leap as
//! [`crate::leap::LeapStatus::TerrainEdge`] instead of moving a contact onto the wrong
//! surface: the edge met by a *point* of the robot (a leg's tip), which has no normal there,
//! and the concave corner where the face meets the lower ground (a contact site touches one
//! surface at a time, so a body end sliding into the face's foot cannot be held by both).
use crate::RhexError;
use nalgebra::Vector2;
use selfmanip_core::{GroundPlane, Terrain};
use serde::{Deserialize, Serialize};

/// Which ground a leap starts on.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TerrainSpec {
    /// Level ground at world `z = 0`.
    #[default]
    Flat,
    /// Level ground, and a raised level top `height_m` higher beyond a vertical face at
    /// world `x = distance_m` (the origin is the body centre at the start): ahead of the
    /// robot (`x ≥ distance_m`) when `distance_m > 0`, behind it (`x ≤ distance_m`) when
    /// `distance_m < 0`.
    Ledge { height_m: f64, distance_m: f64 },
}

impl TerrainSpec {
    pub fn validate(&self) -> Result<(), RhexError> {
        match *self {
            TerrainSpec::Flat => Ok(()),
            TerrainSpec::Ledge {
                height_m,
                distance_m,
            } => {
                if !height_m.is_finite() || height_m <= 0.0 {
                    return Err(RhexError::Params {
                        field: "terrain.height_m".into(),
                        reason: format!("must be finite and positive, got {height_m}"),
                    });
                }
                if !distance_m.is_finite() || distance_m == 0.0 {
                    return Err(RhexError::Params {
                        field: "terrain.distance_m".into(),
                        reason: format!(
                            "must be finite and non-zero (positive: ahead, negative: behind), \
                             got {distance_m}"
                        ),
                    });
                }
                Ok(())
            }
        }
    }

    /// Height (up) of the ground surface at world `x_m`.
    pub fn height_at(&self, x_m: f64) -> f64 {
        match self.ledge() {
            Some((height_m, distance_m)) if Self::beyond(x_m, distance_m) => height_m,
            _ => 0.0,
        }
    }

    /// `(height_m, distance_m)` of a ledge.
    fn ledge(&self) -> Option<(f64, f64)> {
        match *self {
            TerrainSpec::Flat => None,
            TerrainSpec::Ledge {
                height_m,
                distance_m,
            } => Some((height_m, distance_m)),
        }
    }

    /// Whether world `x_m` is over a ledge whose face is at `distance_m` (on the far side
    /// of the face from the start).
    fn beyond(x_m: f64, distance_m: f64) -> bool {
        if distance_m > 0.0 {
            x_m >= distance_m
        } else {
            x_m <= distance_m
        }
    }
}

impl Terrain for TerrainSpec {
    fn plane_under(&self, x_m: f64) -> GroundPlane {
        GroundPlane::level(-self.height_at(x_m))
    }

    fn face_near(&self, p: Vector2<f64>) -> Option<GroundPlane> {
        let (height_m, distance_m) = self.ledge()?;
        // below the top edge (z down) and on the open side of the face
        (p.y > -height_m && !Self::beyond(p.x, distance_m)).then(|| GroundPlane {
            point_m: [distance_m, 0.0],
            normal_into_ground: [distance_m.signum(), 0.0],
        })
    }

    fn corner_near(&self, c: Vector2<f64>) -> Option<Vector2<f64>> {
        let (height_m, distance_m) = self.ledge()?;
        // above the top (z down) and on the open side of the face
        (c.y <= -height_m && !Self::beyond(c.x, distance_m))
            .then(|| Vector2::new(distance_m, -height_m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ledge_behind_mirrors_a_ledge_ahead() {
        let ahead = TerrainSpec::Ledge {
            height_m: 0.3,
            distance_m: 0.5,
        };
        let behind = TerrainSpec::Ledge {
            height_m: 0.3,
            distance_m: -0.5,
        };
        for x in [-0.8, -0.5, -0.2, 0.2, 0.5, 0.8] {
            assert_eq!(ahead.height_at(x), behind.height_at(-x));
            let (fa, fb) = (
                ahead.face_near(Vector2::new(x, -0.1)),
                behind.face_near(Vector2::new(-x, -0.1)),
            );
            assert_eq!(fa.is_some(), x < 0.5);
            assert_eq!(fa.is_some(), fb.is_some());
            if let (Some(a), Some(b)) = (fa, fb) {
                assert_eq!(a.normal_into_ground[0], -b.normal_into_ground[0]);
                // the face is the plane x = 0.5 (mirrored: −0.5): a point at x is 0.5 − x from it
                let p = Vector2::new(x, -0.1);
                assert!((a.height_of(p) - (0.5 - x)).abs() < 1e-15);
            }
        }
        // above the top edge there is no face to touch, only the edge itself (or the ground
        // or the top below)
        assert!(ahead.face_near(Vector2::new(0.4, -0.31)).is_none());
        assert_eq!(
            ahead.corner_near(Vector2::new(0.4, -0.31)),
            Some(Vector2::new(0.5, -0.3))
        );
        assert_eq!(
            behind.corner_near(Vector2::new(-0.4, -0.31)),
            Some(Vector2::new(-0.5, -0.3))
        );
        assert!(ahead.corner_near(Vector2::new(0.4, -0.29)).is_none());
        assert!(ahead.corner_near(Vector2::new(0.6, -0.31)).is_none());
        assert!(behind.validate().is_ok());
        assert!(TerrainSpec::Ledge {
            height_m: 0.3,
            distance_m: 0.0
        }
        .validate()
        .is_err());
    }
}
