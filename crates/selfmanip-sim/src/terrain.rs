//! Terrains: level ground, an incline, a ledge, a flight of stairs (thesis Figs. 5.1 and
//! 5.9, section 3.4.3, for a ledge).
//!
//! Heights are given positive **up**; internally the ground planes are in the NED world frame
//! (z down) of `selfmanip-core`. Horizontal positions are world `x`.
//!
//! A step has three surfaces a contact can be on: the ground before it, its level top, and
//! its vertical face (the riser between them); and its top edge, the convex corner where the
//! face meets the top, on which a circle or an arc of the robot can rest, roll or slide (a
//! body end sliding up the face passes over it onto the top). Two places end an execution
//! ([`selfmanip_hybrid::Termination::TerrainDiscontinuity`]) instead of moving a contact onto
//! the wrong surface: the edge met by a *point* of the robot (a leg's tip), which has no
//! normal there, and the concave corner where the face meets the ground below it (a contact
//! site touches one surface at a time). Surfaces take each contact's own friction.
use crate::error::SimError;
use nalgebra::Vector2;
use selfmanip_core::contact::NearbyFeatures;
use selfmanip_core::{GroundPlane, Terrain};
use serde::{Deserialize, Serialize};

/// The ground an execution runs on. Read strictly ([`StrictTerrain`]): a key that the kind
/// does not have is refused with the keys it has.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(
    tag = "kind",
    rename_all = "snake_case",
    deny_unknown_fields,
    from = "StrictTerrain"
)]
pub enum TerrainSpec {
    /// Level ground at world `z = 0`.
    #[default]
    Flat,
    /// A plane through the world origin rising by `slope_rad` towards `+x`.
    Incline { slope_rad: f64 },
    /// Level ground, and a raised level top `height_m` higher beyond a vertical face at
    /// world `x = distance_m`: ahead (`x ≥ distance_m`) when `distance_m > 0`, behind
    /// (`x ≤ distance_m`) when `distance_m < 0`.
    Ledge { height_m: f64, distance_m: f64 },
    /// `count` steps up, each `rise_m` high and `run_m` deep, the first face at world
    /// `x = distance_m` (ahead when positive, behind when negative, the next faces further
    /// on); the last top is level to infinity.
    Stairs {
        rise_m: f64,
        run_m: f64,
        count: u32,
        distance_m: f64,
    },
}

/// [`TerrainSpec`] as it is read: `flat` as a struct of no fields, since serde lets an
/// internally tagged unit variant ignore any other key (`{"kind": "flat", "extra": 1}`
/// passed silently); every kind refuses keys it does not have.
#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
enum StrictTerrain {
    Flat {},
    Incline {
        slope_rad: f64,
    },
    Ledge {
        height_m: f64,
        distance_m: f64,
    },
    Stairs {
        rise_m: f64,
        run_m: f64,
        count: u32,
        distance_m: f64,
    },
}

impl From<StrictTerrain> for TerrainSpec {
    fn from(t: StrictTerrain) -> Self {
        match t {
            StrictTerrain::Flat {} => TerrainSpec::Flat,
            StrictTerrain::Incline { slope_rad } => TerrainSpec::Incline { slope_rad },
            StrictTerrain::Ledge {
                height_m,
                distance_m,
            } => TerrainSpec::Ledge {
                height_m,
                distance_m,
            },
            StrictTerrain::Stairs {
                rise_m,
                run_m,
                count,
                distance_m,
            } => TerrainSpec::Stairs {
                rise_m,
                run_m,
                count,
                distance_m,
            },
        }
    }
}

/// The steps of a ledge or a flight of stairs: `count` faces, the first at world
/// `x = first_face_m`, each next one `run_m` further from the origin, each top `rise_m` above
/// the one before.
#[derive(Debug, Clone, Copy)]
struct Steps {
    rise_m: f64,
    run_m: f64,
    count: u32,
    first_face_m: f64,
}

fn bad(field: &str, reason: String) -> SimError {
    SimError::InvalidValue {
        field: field.into(),
        reason,
    }
}

impl TerrainSpec {
    pub fn validate(&self) -> Result<(), SimError> {
        let positive = |field: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(bad(field, format!("must be finite and positive, got {v}")))
            }
        };
        let face = |v: f64| {
            if v.is_finite() && v != 0.0 {
                Ok(())
            } else {
                Err(bad(
                    "terrain.distance_m",
                    format!(
                        "must be finite and non-zero (positive: ahead, negative: behind), got {v}"
                    ),
                ))
            }
        };
        match *self {
            TerrainSpec::Flat => Ok(()),
            TerrainSpec::Incline { slope_rad } => {
                if slope_rad.is_finite() && slope_rad.abs() < std::f64::consts::FRAC_PI_2 {
                    Ok(())
                } else {
                    Err(bad(
                        "terrain.slope_rad",
                        format!("must lie in (−π/2, π/2), got {slope_rad}"),
                    ))
                }
            }
            TerrainSpec::Ledge {
                height_m,
                distance_m,
            } => {
                positive("terrain.height_m", height_m)?;
                face(distance_m)
            }
            TerrainSpec::Stairs {
                rise_m,
                run_m,
                count,
                distance_m,
            } => {
                positive("terrain.rise_m", rise_m)?;
                positive("terrain.run_m", run_m)?;
                if count == 0 {
                    return Err(bad("terrain.count", "must be at least 1".into()));
                }
                face(distance_m)
            }
        }
    }

    /// Height (up) of the ground surface at world `x_m`.
    pub fn height_at(&self, x_m: f64) -> f64 {
        match *self {
            TerrainSpec::Incline { slope_rad } => x_m * slope_rad.tan(),
            _ => self.height_of_top(self.next_step(x_m).0),
        }
    }

    /// Height (up) of the level ground with `passed` steps behind (not on an incline).
    fn height_of_top(&self, passed: u32) -> f64 {
        match passed {
            0 => 0.0,
            passed => self.rise() * passed as f64,
        }
    }

    /// The rise of each step (0 without steps).
    fn rise(&self) -> f64 {
        self.steps().map_or(0.0, |s| s.rise_m)
    }

    /// A ledge as one step (of no run), stairs as theirs; none on flat ground or an incline.
    fn steps(&self) -> Option<Steps> {
        match *self {
            TerrainSpec::Flat | TerrainSpec::Incline { .. } => None,
            TerrainSpec::Ledge {
                height_m,
                distance_m,
            } => Some(Steps {
                rise_m: height_m,
                run_m: 0.0,
                count: 1,
                first_face_m: distance_m,
            }),
            TerrainSpec::Stairs {
                rise_m,
                run_m,
                count,
                distance_m,
            } => Some(Steps {
                rise_m,
                run_m,
                count,
                first_face_m: distance_m,
            }),
        }
    }

    /// The steps already passed at `x_m` (faces on whose far side `x_m` is), and the face
    /// still ahead, `(x of the face, height of its top)`.
    fn next_step(&self, x_m: f64) -> (u32, Option<(f64, f64)>) {
        let Some(steps) = self.steps() else {
            return (0, None);
        };
        let dir = steps.first_face_m.signum();
        for k in 0..steps.count {
            let face = steps.first_face_m + dir * steps.run_m * f64::from(k);
            if !Self::beyond(x_m, face) {
                return (k, Some((face, steps.rise_m * f64::from(k + 1))));
            }
        }
        (steps.count, None)
    }

    /// Whether world `x_m` is on the far side (from the origin) of a face at `face_m`.
    fn beyond(x_m: f64, face_m: f64) -> bool {
        if face_m > 0.0 {
            x_m >= face_m
        } else {
            x_m <= face_m
        }
    }
}

impl TerrainSpec {
    /// The face still ahead of world `p` (`(x of the face, height of its top)`, from
    /// [`Self::next_step`]) as one `p` touches: below its top edge (z down).
    fn face_ahead(p: Vector2<f64>, ahead: Option<(f64, f64)>) -> Option<GroundPlane> {
        let (face, top) = ahead?;
        (p.y > -top).then(|| GroundPlane {
            point_m: [face, 0.0],
            normal_into_ground: [face.signum(), 0.0],
        })
    }

    /// The top edge of the face still ahead of world `c` as a corner `c` faces: `c` above
    /// the top (z down).
    fn corner_ahead(c: Vector2<f64>, ahead: Option<(f64, f64)>) -> Option<Vector2<f64>> {
        let (face, top) = ahead?;
        (c.y <= -top).then(|| Vector2::new(face, -top))
    }
}

impl Terrain for TerrainSpec {
    fn plane_under(&self, x_m: f64) -> GroundPlane {
        match *self {
            // tangent (cos s, −sin s) (z down: rising ahead); normal into the ground ⟂ it
            TerrainSpec::Incline { slope_rad } => GroundPlane {
                point_m: [0.0, 0.0],
                normal_into_ground: [slope_rad.sin(), slope_rad.cos()],
            },
            _ => GroundPlane::level(-self.height_at(x_m)),
        }
    }

    fn face_near(&self, p: Vector2<f64>) -> Option<GroundPlane> {
        Self::face_ahead(p, self.next_step(p.x).1)
    }

    fn corner_near(&self, c: Vector2<f64>) -> Option<Vector2<f64>> {
        Self::corner_ahead(c, self.next_step(c.x).1)
    }

    /// The three answers from one look-up of the steps passed at `p.x`.
    fn features_near(&self, p: Vector2<f64>, corner: bool) -> NearbyFeatures {
        if let TerrainSpec::Incline { .. } = self {
            return NearbyFeatures {
                plane: self.plane_under(p.x),
                face: None,
                corner: None,
            };
        }
        let (passed, ahead) = self.next_step(p.x);
        NearbyFeatures {
            plane: GroundPlane::level(-self.height_of_top(passed)),
            face: Self::face_ahead(p, ahead),
            corner: if corner {
                Self::corner_ahead(p, ahead)
            } else {
                None
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unknown and repeated keys are refused, naming the key and the kind's keys; every kind
    /// reads back what it wrote.
    #[test]
    fn terrains_refuse_keys_they_do_not_have() {
        let read = |s: &str| serde_json::from_str::<TerrainSpec>(s).map_err(|e| e.to_string());
        let e = read(r#"{"kind": "flat", "extra": 1}"#).unwrap_err();
        assert!(e.contains("unknown field `extra`"), "{e}");
        let e =
            read(r#"{"kind": "ledge", "height_m": 0.1, "distance_m": 0.2, "x": 1}"#).unwrap_err();
        assert!(
            e.contains("`x`") && e.contains("`height_m`") && e.contains("`distance_m`"),
            "{e}"
        );
        let e = read(r#"{"kind": "ledge", "height_m": 0.1, "height_m": 0.2, "distance_m": 0.3}"#)
            .unwrap_err();
        assert!(e.contains("duplicate field `height_m`"), "{e}");
        for t in [
            TerrainSpec::Flat,
            TerrainSpec::Incline { slope_rad: 0.1 },
            TerrainSpec::Ledge {
                height_m: 0.04,
                distance_m: -0.3,
            },
            TerrainSpec::Stairs {
                rise_m: 0.05,
                run_m: 0.3,
                count: 3,
                distance_m: 0.2,
            },
        ] {
            let text = serde_json::to_string(&t).unwrap();
            assert_eq!(read(&text).unwrap(), t, "{text}");
        }
    }

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

    /// The terrain as its three separate look-ups (`plane_under`, `face_near`,
    /// `corner_near`), without the one-look-up [`Terrain::features_near`].
    struct Separately<'t>(&'t TerrainSpec);

    impl Terrain for Separately<'_> {
        fn plane_under(&self, x_m: f64) -> GroundPlane {
            self.0.plane_under(x_m)
        }
        fn face_near(&self, p: Vector2<f64>) -> Option<GroundPlane> {
            self.0.face_near(p)
        }
        fn corner_near(&self, c: Vector2<f64>) -> Option<Vector2<f64>> {
            self.0.corner_near(c)
        }
    }

    /// The touchdown guards' gap ([`selfmanip_core::contact::contact_gap`]) is the gap of
    /// the full contact geometry ([`selfmanip_core::contact::contact_geometry`]) bit for
    /// bit, and the geometry on the terrain's one look-up of its features
    /// ([`Terrain::features_near`]) is that on its three separate look-ups, bit for bit:
    /// for a toe, a rolling foot and an arc body end, over random poses near a ledge's face
    /// and corner, on stairs, an incline and flat ground. The poses reach every feature
    /// (plane, face, corner) and both kinds of touch of the arc (interior and end).
    #[test]
    fn contact_gap_is_the_geometry_gap_bit_for_bit() {
        use selfmanip_core::contact::{contact_gap, contact_geometry, TouchKind};
        use selfmanip_core::kinematics::Kinematics;
        use selfmanip_core::RobotDescription;
        let model = RobotDescription::from_toml_str(include_str!(
            "../../../tests/data/robots/knee_foot_tail.toml"
        ))
        .unwrap()
        .build()
        .unwrap();
        let terrains = [
            TerrainSpec::Flat,
            TerrainSpec::Incline { slope_rad: 0.2 },
            TerrainSpec::Ledge {
                height_m: 0.1,
                distance_m: 0.3,
            },
            TerrainSpec::Ledge {
                height_m: 0.1,
                distance_m: -0.3,
            },
            TerrainSpec::Stairs {
                rise_m: 0.05,
                run_m: 0.1,
                count: 4,
                distance_m: 0.2,
            },
        ];
        // xorshift64: a fixed sequence of uniform numbers in [0, 1)
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut u = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut kin = Kinematics::default();
        let (mut corners, mut faces, mut arc_ends, mut rolling) = (0, 0, 0, 0);
        for terrain in &terrains {
            for _ in 0..4000 {
                let (a0, a1) = (u() * 6.4 - 3.2, u() * 6.4 - 3.2);
                let q = [a0, a1, u() * 1.4 - 0.7, u() * 0.5 - 0.4, u() * 6.4 - 3.2];
                let qd = [u() - 0.5, u() - 0.5, u() - 0.5, u() - 0.5, u() - 0.5];
                kin.compute(&model, &q, &qd);
                for k in 0..model.n_contacts() {
                    let geo = contact_geometry(&model, &kin, terrain, k);
                    let gap = contact_gap(&model, &kin, terrain, k);
                    assert_eq!(gap.to_bits(), geo.gap_m.to_bits(), "{terrain:?} {q:?} {k}");
                    let apart = contact_geometry(&model, &kin, &Separately(terrain), k);
                    let bits = |g: &selfmanip_core::contact::ContactGeometry| {
                        let [p, n] = [g.plane.point_m, g.plane.normal_into_ground];
                        [
                            p[0],
                            p[1],
                            n[0],
                            n[1],
                            g.point.x,
                            g.point.y,
                            g.gap_m,
                            g.point_rate.x,
                            g.point_rate.y,
                            g.normal_rate.x,
                            g.normal_rate.y,
                        ]
                        .map(f64::to_bits)
                    };
                    assert_eq!(bits(&apart), bits(&geo), "{terrain:?} {q:?} {k}");
                    assert_eq!((apart.touch, apart.on_corner), (geo.touch, geo.on_corner));
                    corners += usize::from(geo.on_corner);
                    faces += usize::from(geo.plane.normal_into_ground[1] == 0.0 && !geo.on_corner);
                    if k == 2 {
                        arc_ends += usize::from(geo.touch == TouchKind::Point);
                        rolling += usize::from(geo.touch == TouchKind::Rolling);
                    }
                }
            }
        }
        assert!(
            corners > 20 && faces > 20,
            "corners {corners}, faces {faces}"
        );
        assert!(
            arc_ends > 20 && rolling > 20,
            "ends {arc_ends}, rolling {rolling}"
        );
    }

    /// One stair of a flight is a ledge: the same surfaces, faces and corners; and each
    /// next step repeats the first, `run` further and `rise` higher.
    #[test]
    fn a_flight_of_stairs_repeats_its_first_step() {
        let (rise, run) = (0.1, 0.3);
        let stairs = TerrainSpec::Stairs {
            rise_m: rise,
            run_m: run,
            count: 3,
            distance_m: 0.5,
        };
        let ledge = TerrainSpec::Ledge {
            height_m: rise,
            distance_m: 0.5,
        };
        // before the second face the first step is the ledge: the same ground and top;
        // before the first face, the same face and edge too
        for x in [-0.3, 0.1, 0.45, 0.5, 0.7] {
            assert_eq!(stairs.plane_under(x), ledge.plane_under(x), "x {x}");
            for y in [-0.05, -0.15] {
                let p = Vector2::new(x, y);
                if x < 0.5 {
                    assert_eq!(stairs.face_near(p), ledge.face_near(p), "{p:?}");
                    assert_eq!(stairs.corner_near(p), ledge.corner_near(p), "{p:?}");
                }
            }
        }
        for k in 0..3u32 {
            let face = 0.5 + run * f64::from(k);
            let top = rise * f64::from(k + 1);
            // just before the face: the tread below, the face, the edge above it
            let p = Vector2::new(face - 0.01, -(top - rise) - 0.02);
            assert!((stairs.height_at(p.x) - (top - rise)).abs() < 1e-15);
            assert_eq!(stairs.face_near(p).unwrap().point_m, [face, 0.0]);
            let c = Vector2::new(face - 0.01, -top - 0.01);
            assert_eq!(stairs.corner_near(c), Some(Vector2::new(face, -top)));
            assert!((stairs.height_at(face + 0.01) - top).abs() < 1e-15);
        }
        // beyond the last step: level, no faces
        assert!(stairs.face_near(Vector2::new(2.0, -0.5)).is_none());
        assert!((stairs.height_at(5.0) - 3.0 * rise).abs() < 1e-15);
        assert!(TerrainSpec::Stairs {
            rise_m: rise,
            run_m: run,
            count: 0,
            distance_m: 0.5
        }
        .validate()
        .is_err());
    }

    /// The incline's plane: a point on the surface at `x` is at height `x tan s` and has
    /// zero gap; its normal is perpendicular to the rising tangent.
    #[test]
    fn the_incline_rises_at_its_slope() {
        let s = 0.2f64;
        let t = TerrainSpec::Incline { slope_rad: s };
        for x in [-1.0, 0.0, 0.7] {
            let on = Vector2::new(x, -x * s.tan());
            assert!(t.plane_under(x).height_of(on).abs() < 1e-15);
            let above = Vector2::new(x, on.y - 0.1);
            assert!((t.plane_under(x).height_of(above) - 0.1 * s.cos()).abs() < 1e-15);
        }
        assert!(TerrainSpec::Incline { slope_rad: 2.0 }.validate().is_err());
    }
}
