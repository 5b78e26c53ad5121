//! Terrain for leaps: level ground, or level ground with a ledge ahead (thesis Figs. 5.1 and
//! 5.9, section 3.4.3).
//!
//! Heights are given positive **up** (the ledge's height in metres); internally the ground
//! planes are in the NED world frame (z down) of `selfmanip-core`.
use crate::RhexError;
use selfmanip_core::{GroundPlane, Terrain};
use serde::{Deserialize, Serialize};

/// Which ground a leap starts on.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TerrainSpec {
    /// Level ground at world `z = 0`.
    #[default]
    Flat,
    /// Level ground, and from `distance_m` ahead of the world origin (the body centre at the
    /// start) a raised level top `height_m` higher. Only the top and the lower ground are
    /// contact surfaces: a contact that would cross the vertical face below the top is
    /// reported as [`crate::leap::LeapStatus::TerrainFace`], never silently moved onto it.
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
                for (field, v) in [
                    ("terrain.height_m", height_m),
                    ("terrain.distance_m", distance_m),
                ] {
                    if !v.is_finite() || v <= 0.0 {
                        return Err(RhexError::Params {
                            field: field.into(),
                            reason: format!("must be finite and positive, got {v}"),
                        });
                    }
                }
                Ok(())
            }
        }
    }

    /// Height (up) of the ground surface at world `x_m`.
    pub fn height_at(&self, x_m: f64) -> f64 {
        match *self {
            TerrainSpec::Flat => 0.0,
            TerrainSpec::Ledge {
                height_m,
                distance_m,
            } => {
                if x_m >= distance_m {
                    height_m
                } else {
                    0.0
                }
            }
        }
    }
}

impl Terrain for TerrainSpec {
    fn plane_under(&self, x_m: f64) -> GroundPlane {
        GroundPlane::level(-self.height_at(x_m))
    }
}
