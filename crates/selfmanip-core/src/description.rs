//! The serde robot description (TOML or JSON) and its validation into a [`Model`].
//!
//! A description is a rigid body, legs as planar serial chains of revolute joints, and
//! contact sites with shapes and friction. Lengths in metres, masses in kg, inertias in
//! kg·m² about the link's centre of mass, angles in radians, all in the frames of
//! [`crate::frames`]. A link's frame sits at its joint and, at zero joint angle, is aligned
//! with its parent; the link extends along its own `+z` axis to the next joint.
//!
//! ```toml
//! name = "two-leg RHex"
//! gravity_m_s2 = 9.81
//! [body]
//! mass_kg = 7.15
//! inertia_kg_m2 = 0.15
//! [[legs]]
//! name = "front"
//! hip_m = [0.205, 0.0]
//! [[legs.links]]
//! length_m = 0.17
//! axis = "-y"              # thesis θ is clockwise: rotation about −y
//! # armature_kg_m2 = 0.011 # the motors' rotors reflected to the joint, n J G² (omit: 0)
//! [[contacts]]
//! name = "front_leg"
//! leg = "front"            # omit for a body contact
//! shape = { kind = "arc", center_m = [0.0, 0.085], radius_m = 0.085, normal_range_rad = [-3.141592653589793, 0.0] }
//! friction = { kind = "sticking", mu = 1.8 }
//! ```
use crate::error::{CoreError, Result};
use crate::model::{
    Contact, ContactShape, Friction, Joint, JointSpring, Leg, Model, Outline, OutlineShape,
};
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::hash::Hash;

/// A planar vector `[a, b]` read as exactly two numbers: a longer or shorter list is an error
/// (serde's fixed-size arrays let some formats drop extra entries silently, so that
/// `hip_m = [0.2, 0.0, 99.0]` read as `[0.2, 0.0]`).
mod pair {
    use serde::{de::Error, Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &[f64; 2], s: S) -> Result<S::Ok, S::Error> {
        v.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        <[f64; 2]>::try_from(v.as_slice())
            .map_err(|_| D::Error::invalid_length(v.len(), &"a planar vector of exactly 2 numbers"))
    }
}

/// [`pair`] for an optional field.
mod optional_pair {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<[f64; 2]>, s: S) -> Result<S::Ok, S::Error> {
        v.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
        #[derive(Deserialize)]
        struct Pair(#[serde(with = "super::pair")] [f64; 2]);
        Ok(Option::<Pair>::deserialize(d)?.map(|p| p.0))
    }
}

fn default_gravity() -> f64 {
    9.81
}

/// Top-level robot description.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotDescription {
    pub name: String,
    #[serde(default = "default_gravity")]
    pub gravity_m_s2: f64,
    pub body: BodyDescription,
    #[serde(default)]
    pub legs: Vec<LegDescription>,
    #[serde(default)]
    pub contacts: Vec<ContactDescription>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyDescription {
    pub mass_kg: f64,
    /// Inertia about the body's centre of mass (the palm frame `P`).
    pub inertia_kg_m2: f64,
    /// The body's collision shapes (omit for none): each becomes contact sites
    /// ([`CollisionDescription`]).
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        with = "collision_list"
    )]
    pub collision: Vec<CollisionDescription>,
}

/// A collision shape of the body or of a link, in its part's frame: its outline's lowest
/// points become contact sites like any other (guarded, impacting, with `friction`), named
/// after where the shape is declared — a box's four corners `….corner[j]`, a stadium's two
/// end circles `….end[j]`, a circle itself. The shape's long axis is the part's: the body's
/// `x` (forward), a link's `z` (along the link).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CollisionDescription {
    pub shape: CollisionShapeDescription,
    /// The shape's centre in the part's frame; omitted: the body's origin, a link's middle
    /// `[0, length/2]`.
    #[serde(
        default,
        with = "optional_pair",
        skip_serializing_if = "Option::is_none"
    )]
    pub center_m: Option<[f64; 2]>,
    pub friction: FrictionDescription,
}

/// The outline of a [`CollisionDescription`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum CollisionShapeDescription {
    /// A rectangle `size_m = [l, h]`: `l` along the part's long axis, `h` across; its four
    /// corners are point contacts.
    Box {
        #[serde(with = "pair")]
        size_m: [f64; 2],
    },
    /// A rectangle of length `length_m` capped by two half-circles of radius `radius_m` (the
    /// points within `radius_m` of a segment of length `length_m` along the long axis): its
    /// two end circles are rolling contacts.
    Stadium { length_m: f64, radius_m: f64 },
    /// A circle: a rolling contact.
    Circle { radius_m: f64 },
}

/// A list of collision shapes whose errors name the entry (`collision[1]: unknown variant …`):
/// serde's own messages say what is wrong, not where.
mod collision_list {
    use super::CollisionDescription;
    use serde::de::{Error, SeqAccess, Visitor};
    use serde::{Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &[CollisionDescription], s: S) -> Result<S::Ok, S::Error> {
        v.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Vec<CollisionDescription>, D::Error> {
        struct List;
        impl<'de> Visitor<'de> for List {
            type Value = Vec<CollisionDescription>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a list of collision shapes")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut out = Vec::new();
                while let Some(c) = seq
                    .next_element()
                    .map_err(|e| A::Error::custom(format!("collision[{}]: {e}", out.len())))?
                {
                    out.push(c);
                }
                Ok(out)
            }
        }
        d.deserialize_seq(List)
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LegDescription {
    pub name: String,
    /// Hip (first joint) position in the body frame.
    #[serde(with = "pair")]
    pub hip_m: [f64; 2],
    pub links: Vec<LinkDescription>,
}

/// Sense of a revolute joint's positive angle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum JointAxis {
    /// Positive angle = rotation about `+y`, the same sense as nose-up pitch.
    #[default]
    #[serde(rename = "+y")]
    PlusY,
    /// Positive angle = rotation about `−y` (clockwise in the side view): the thesis's θ.
    #[serde(rename = "-y")]
    MinusY,
}

impl JointAxis {
    pub fn sign(self) -> f64 {
        match self {
            JointAxis::PlusY => 1.0,
            JointAxis::MinusY => -1.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkDescription {
    pub length_m: f64,
    #[serde(default)]
    pub mass_kg: f64,
    /// Inertia about the link's own centre of mass.
    #[serde(default)]
    pub inertia_kg_m2: f64,
    /// Centre of mass in the link frame; defaults to the middle of the link `[0, length/2]`.
    #[serde(default, with = "optional_pair")]
    pub com_m: Option<[f64; 2]>,
    #[serde(default)]
    pub axis: JointAxis,
    /// A passive spring–damper across this link's joint (omit for none).
    #[serde(default)]
    pub spring: Option<SpringDescription>,
    /// Armature of this link's joint (kg·m², `≥ 0`, omit for 0): the inertia of the drive's
    /// rotors reflected to the joint, `n J G²`, added to `M̄`'s diagonal at the joint's
    /// coordinate only ([`crate::model::Joint::armature_kg_m2`]). A joint with armature is
    /// not massless, whatever its link's mass.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub armature_kg_m2: f64,
    /// The link's collision shapes (omit for none), long axis along the link
    /// ([`CollisionDescription`]).
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        with = "collision_list"
    )]
    pub collision: Vec<CollisionDescription>,
}

/// Whether an optional number is at its default (so that descriptions without it serialize
/// as before).
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// A passive torsional spring–damper across a joint: `τ = −k d − k₃ d³ − c θ̇` with
/// `d = θ − rest_angle_rad` (see [`crate::passive`]). Omitted terms are zero.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringDescription {
    /// `k ≥ 0` (N·m/rad).
    pub stiffness_n_m_per_rad: f64,
    /// `k₃ ≥ 0` (N·m/rad³): a hardening cubic term.
    #[serde(default)]
    pub cubic_stiffness_n_m_per_rad3: f64,
    /// `c ≥ 0` (N·m·s/rad).
    #[serde(default)]
    pub damping_n_m_s_per_rad: f64,
    /// The joint angle at which the spring is relaxed (rad).
    #[serde(default)]
    pub rest_angle_rad: f64,
}

/// Contact shape, in the frame of the part it is attached to (body or link).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeDescription {
    /// A point (a toe).
    Point {
        #[serde(with = "pair")]
        position_m: [f64; 2],
    },
    /// A full circle that rolls (e.g. RHex's rounded body ends).
    Circle {
        #[serde(with = "pair")]
        center_m: [f64; 2],
        radius_m: f64,
    },
    /// A circular arc that rolls on its interior and acts as a point at its two ends. The
    /// range holds the angles `α` of the outward normals `(sin α, cos α)` in the part's frame
    /// (`α = 0` points along the link, `+z`), from `normal_range_rad[0]` to `[1]`
    /// counter-clockwise. RHex's half-circle leg is `[-π, 0]`.
    Arc {
        #[serde(with = "pair")]
        center_m: [f64; 2],
        radius_m: f64,
        #[serde(with = "pair")]
        normal_range_rad: [f64; 2],
    },
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum FrictionDescription {
    /// Resists sliding: a normal and a tangential constraint row, Coulomb coefficient `mu`
    /// (omit for "never slips"). Once it slips it slides with kinetic coefficient
    /// `mu_kinetic` (omit for `mu`: Coulomb sliding; `0` for the thesis's frictionless
    /// sliding of Assumption 5.9; any site, see [`crate::friction`]).
    Sticking {
        #[serde(default)]
        mu: Option<f64>,
        #[serde(default)]
        mu_kinetic: Option<f64>,
    },
    /// Never resists sliding: a normal row only (kinetic friction zero, thesis assumption 5.9).
    Sliding,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactDescription {
    pub name: String,
    /// The leg the contact belongs to; omitted for a body contact.
    #[serde(default)]
    pub leg: Option<String>,
    /// Link index within the leg (default: the last link).
    #[serde(default)]
    pub link: Option<usize>,
    pub shape: ShapeDescription,
    pub friction: FrictionDescription,
}

/// The error of an invalid description field.
fn bad(field: String, reason: &str) -> CoreError {
    CoreError::InvalidDescription {
        field,
        reason: reason.into(),
    }
}

fn finite_nonneg(field: String, v: f64) -> Result<()> {
    if !v.is_finite() {
        Err(bad(field, "must be finite"))
    } else if v < 0.0 {
        Err(bad(field, "must be non-negative"))
    } else {
        Ok(())
    }
}

fn finite2(field: String, v: [f64; 2]) -> Result<Vector2<f64>> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(Vector2::new(v[0], v[1]))
    } else {
        Err(bad(field, "must be finite"))
    }
}

/// Each name's index in `names`, or the index of the first name that repeats an earlier one.
/// One hashed look-up per name keeps loading linear in the number of legs (comparing each name
/// with all before it took minutes for 120,000 legs).
fn index_names<K: Hash + Eq>(
    names: impl ExactSizeIterator<Item = K>,
) -> std::result::Result<HashMap<K, usize>, usize> {
    let mut index = HashMap::with_capacity(names.len());
    for (i, name) in names.enumerate() {
        if index.insert(name, i).is_some() {
            return Err(i);
        }
    }
    Ok(index)
}

impl Model {
    /// The validated model of a description: [`RobotDescription::build`], from the model's
    /// side (here, beside the validation, so that the model does not depend on its source).
    pub fn from_description(d: &RobotDescription) -> Result<Self> {
        d.build()
    }
}

impl RobotDescription {
    pub fn from_toml_str(s: &str) -> Result<Self> {
        toml::from_str(s).map_err(|e| CoreError::Parse {
            format: "toml",
            message: e.to_string(),
        })
    }

    pub fn from_json_str(s: &str) -> Result<Self> {
        serde_json::from_str(s).map_err(|e| CoreError::Parse {
            format: "json",
            message: e.to_string(),
        })
    }

    /// Reads a `.toml` or `.json` file (by extension).
    pub fn from_file(path: &std::path::Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| CoreError::Parse {
            format: "file",
            message: format!("{}: {e}", path.display()),
        })?;
        match path.extension().and_then(|e| e.to_str()) {
            Some("json") => Self::from_json_str(&text),
            _ => Self::from_toml_str(&text),
        }
    }

    pub fn to_toml_string(&self) -> String {
        toml::to_string_pretty(self).expect("a validated description always serializes")
    }

    /// Validates every field and builds the immutable [`Model`].
    pub fn build(&self) -> Result<Model> {
        if !(self.gravity_m_s2.is_finite()) {
            return Err(bad("gravity_m_s2".into(), "must be finite"));
        }
        finite_nonneg("body.mass_kg".into(), self.body.mass_kg)?;
        finite_nonneg("body.inertia_kg_m2".into(), self.body.inertia_kg_m2)?;
        if self.body.mass_kg == 0.0 {
            return Err(bad(
                "body.mass_kg".into(),
                "the body (palm frame P) must have positive mass",
            ));
        }

        let mut legs = Vec::with_capacity(self.legs.len());
        let mut joints = Vec::new();
        for (li, leg) in self.legs.iter().enumerate() {
            let f = |s: &str| format!("legs[{li}].{s}");
            if leg.name.is_empty() {
                return Err(bad(f("name"), "must not be empty"));
            }
            if leg.links.is_empty() {
                return Err(bad(f("links"), "a leg needs at least one link"));
            }
            let hip = finite2(f("hip_m"), leg.hip_m)?;
            let first_joint = joints.len();
            for (k, link) in leg.links.iter().enumerate() {
                let g = |s: &str| format!("legs[{li}].links[{k}].{s}");
                finite_nonneg(g("length_m"), link.length_m)?;
                finite_nonneg(g("mass_kg"), link.mass_kg)?;
                finite_nonneg(g("inertia_kg_m2"), link.inertia_kg_m2)?;
                finite_nonneg(g("armature_kg_m2"), link.armature_kg_m2)?;
                let com = match link.com_m {
                    Some(c) => finite2(g("com_m"), c)?,
                    None => Vector2::new(0.0, 0.5 * link.length_m),
                };
                let spring = match link.spring {
                    None => None,
                    Some(sp) => {
                        for (name, v) in [
                            ("spring.stiffness_n_m_per_rad", sp.stiffness_n_m_per_rad),
                            (
                                "spring.cubic_stiffness_n_m_per_rad3",
                                sp.cubic_stiffness_n_m_per_rad3,
                            ),
                            ("spring.damping_n_m_s_per_rad", sp.damping_n_m_s_per_rad),
                        ] {
                            finite_nonneg(g(name), v)?;
                        }
                        if !sp.rest_angle_rad.is_finite() {
                            return Err(bad(g("spring.rest_angle_rad"), "must be finite"));
                        }
                        Some(JointSpring {
                            stiffness_n_m_per_rad: sp.stiffness_n_m_per_rad,
                            cubic_stiffness_n_m_per_rad3: sp.cubic_stiffness_n_m_per_rad3,
                            damping_n_m_s_per_rad: sp.damping_n_m_s_per_rad,
                            rest_angle_rad: sp.rest_angle_rad,
                        })
                    }
                };
                joints.push(Joint {
                    leg: li,
                    index_in_leg: k,
                    axis_sign: link.axis.sign(),
                    length_m: link.length_m,
                    mass_kg: link.mass_kg,
                    inertia_kg_m2: link.inertia_kg_m2,
                    com_m: com,
                    spring,
                    armature_kg_m2: link.armature_kg_m2,
                });
            }
            legs.push(Leg {
                name: leg.name.clone(),
                hip_m: hip,
                first_joint,
                n_links: leg.links.len(),
            });
        }

        let leg_index = index_names(self.legs.iter().map(|l| l.name.as_str()))
            .map_err(|li| bad(format!("legs[{li}].name"), "duplicate leg name"))?;

        if self.contacts.len() > 32 {
            return Err(bad(
                "contacts".into(),
                "at most 32 contact sites are supported",
            ));
        }
        index_names(self.contacts.iter().map(|c| c.name.as_str()))
            .map_err(|ci| bad(format!("contacts[{ci}].name"), "duplicate contact name"))?;
        let mut contacts = self
            .contacts
            .iter()
            .enumerate()
            .map(|(ci, c)| build_contact(ci, c, &legs, &leg_index))
            .collect::<Result<Vec<_>>>()?;
        let outlines = self.build_collisions(&legs, &joints, &mut contacts)?;

        Ok(Model::new(
            self.name.clone(),
            self.gravity_m_s2,
            self.body.mass_kg,
            self.body.inertia_kg_m2,
            legs,
            joints,
            contacts,
            outlines,
        ))
    }

    /// The collision shapes of the body and of every link, validated, their sites appended
    /// to `contacts` (after the described contacts, body first, then leg by leg).
    fn build_collisions(
        &self,
        legs: &[Leg],
        joints: &[Joint],
        contacts: &mut Vec<Contact>,
    ) -> Result<Vec<Outline>> {
        let mut outlines = Vec::new();
        // each outline's field, for the errors that name it
        let mut fields = Vec::new();
        let body = self.body.collision.iter().enumerate().map(|(i, c)| {
            let field = format!("body.collision[{i}]");
            (field.clone(), field, None, Vector2::zeros(), c)
        });
        let links = legs.iter().enumerate().flat_map(|(li, leg)| {
            self.legs[li]
                .links
                .iter()
                .enumerate()
                .flat_map(move |(k, link)| {
                    let j = leg.first_joint + k;
                    link.collision.iter().enumerate().map(move |(i, c)| {
                        (
                            format!("legs[{li}].links[{k}].collision[{i}]"),
                            format!("{}[{k}].collision[{i}]", leg.name),
                            Some(j),
                            Vector2::new(0.0, 0.5 * joints[j].length_m),
                            c,
                        )
                    })
                })
        });
        for (field, name, link, default_center, c) in body.chain(links) {
            let outline = build_collision(&field, name, link, default_center, c, contacts)?;
            if contacts.len() > 32 {
                return Err(bad(
                    field,
                    "at most 32 contact sites are supported, described and collision sites \
                     together",
                ));
            }
            outlines.push(outline);
            fields.push(field);
        }
        if let Err(k) = index_names(contacts.iter().map(|c| c.name.as_str())) {
            let field = match outlines.iter().position(|o| o.contacts.contains(&k)) {
                Some(o) => fields[o].clone(),
                None => format!("contacts[{k}].name"),
            };
            let reason = format!(
                "its site `{}` repeats another contact's name",
                contacts[k].name
            );
            return Err(bad(field, &reason));
        }
        Ok(outlines)
    }
}

/// The collision shape `c` declared at `field` (named `name`; on joint `link`'s link or the
/// body), validated, its contact sites appended to `contacts`. The shape's long axis is the
/// part's: the body's `x`, a link's `z`; its centre defaults to `default_center`.
fn build_collision(
    field: &str,
    name: String,
    link: Option<usize>,
    default_center: Vector2<f64>,
    c: &CollisionDescription,
    contacts: &mut Vec<Contact>,
) -> Result<Outline> {
    let f = |s: &str| format!("{field}.{s}");
    let positive = |s: &str, v: f64| {
        finite_nonneg(f(s), v)?;
        if v == 0.0 {
            return Err(bad(f(s), "must be positive"));
        }
        Ok(())
    };
    let center = match c.center_m {
        Some(p) => finite2(f("center_m"), p)?,
        None => default_center,
    };
    let axis = if link.is_some() {
        Vector2::new(0.0, 1.0)
    } else {
        Vector2::new(1.0, 0.0)
    };
    let across = crate::frames::perp(axis);
    let (friction, kinetic_mu) = build_friction(&f("friction"), &c.friction)?;
    let site = |suffix: String, shape: ContactShape| Contact {
        name: format!("{name}{suffix}"),
        link,
        shape,
        friction,
        kinetic_mu,
    };
    let first = contacts.len();
    let shape = match c.shape {
        CollisionShapeDescription::Box { size_m } => {
            positive("shape.size_m[0]", size_m[0])?;
            positive("shape.size_m[1]", size_m[1])?;
            let half_m = [0.5 * size_m[0], 0.5 * size_m[1]];
            let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
            for (j, (sa, sb)) in corners.into_iter().enumerate() {
                let p = center + sa * half_m[0] * axis + sb * half_m[1] * across;
                contacts.push(site(
                    format!(".corner[{j}]"),
                    ContactShape::Point { position_m: p },
                ));
            }
            OutlineShape::Box {
                center_m: center,
                axis,
                half_m,
            }
        }
        CollisionShapeDescription::Stadium { length_m, radius_m } => {
            positive("shape.length_m", length_m)?;
            positive("shape.radius_m", radius_m)?;
            let ends_m = [-1.0, 1.0].map(|s| center + s * 0.5 * length_m * axis);
            for (j, e) in ends_m.into_iter().enumerate() {
                contacts.push(site(format!(".end[{j}]"), circle(e, radius_m)));
            }
            OutlineShape::Round { ends_m, radius_m }
        }
        CollisionShapeDescription::Circle { radius_m } => {
            positive("shape.radius_m", radius_m)?;
            contacts.push(site(String::new(), circle(center, radius_m)));
            OutlineShape::Round {
                ends_m: [center, center],
                radius_m,
            }
        }
    };
    Ok(Outline {
        name,
        link,
        shape,
        contacts: first..contacts.len(),
    })
}

/// A full circle that rolls.
fn circle(center_m: Vector2<f64>, radius_m: f64) -> ContactShape {
    ContactShape::Arc {
        center_m,
        radius_m,
        normal_range_rad: None,
    }
}

/// Contact `ci` of a description, validated, its leg found by name in `leg_index`.
fn build_contact(
    ci: usize,
    c: &ContactDescription,
    legs: &[Leg],
    leg_index: &HashMap<&str, usize>,
) -> Result<Contact> {
    let f = |s: &str| format!("contacts[{ci}].{s}");
    if c.name.is_empty() {
        return Err(bad(f("name"), "must not be empty"));
    }
    let link = match &c.leg {
        None => {
            if c.link.is_some() {
                return Err(bad(f("link"), "a body contact has no link index"));
            }
            None
        }
        Some(name) => {
            let li = *leg_index
                .get(name.as_str())
                .ok_or_else(|| bad(f("leg"), &format!("no leg named `{name}`")))?;
            let leg = &legs[li];
            let k = c.link.unwrap_or(leg.n_links - 1);
            if k >= leg.n_links {
                return Err(bad(f("link"), "link index out of range"));
            }
            Some(leg.first_joint + k)
        }
    };
    let shape = match &c.shape {
        ShapeDescription::Point { position_m } => ContactShape::Point {
            position_m: finite2(f("shape.position_m"), *position_m)?,
        },
        ShapeDescription::Circle { center_m, radius_m } => {
            finite_nonneg(f("shape.radius_m"), *radius_m)?;
            ContactShape::Arc {
                center_m: finite2(f("shape.center_m"), *center_m)?,
                radius_m: *radius_m,
                normal_range_rad: None,
            }
        }
        ShapeDescription::Arc {
            center_m,
            radius_m,
            normal_range_rad,
        } => {
            finite_nonneg(f("shape.radius_m"), *radius_m)?;
            let [a0, a1] = *normal_range_rad;
            if !(a0.is_finite() && a1.is_finite()) || a1 <= a0 || a1 - a0 > std::f64::consts::TAU {
                return Err(bad(
                    f("shape.normal_range_rad"),
                    "must be finite with start < end and span at most 2π",
                ));
            }
            ContactShape::Arc {
                center_m: finite2(f("shape.center_m"), *center_m)?,
                radius_m: *radius_m,
                normal_range_rad: Some([a0, a1]),
            }
        }
    };
    let (friction, kinetic_mu) = build_friction(&f("friction"), &c.friction)?;
    Ok(Contact {
        name: c.name.clone(),
        link,
        shape,
        friction,
        kinetic_mu,
    })
}

/// A site's friction (declared at `field`), validated: the model's friction and the kinetic
/// coefficient `μ_k`.
fn build_friction(field: &str, friction: &FrictionDescription) -> Result<(Friction, f64)> {
    match *friction {
        FrictionDescription::Sliding => Ok((Friction::Sliding, 0.0)),
        FrictionDescription::Sticking { mu, mu_kinetic } => {
            let mu = mu.unwrap_or(f64::INFINITY);
            if mu.is_nan() || mu < 0.0 {
                return Err(bad(format!("{field}.mu"), "must be non-negative"));
            }
            // Coulomb sliding unless declared (a site that never slips needs none)
            let mu_k = mu_kinetic.unwrap_or(if mu.is_finite() { mu } else { 0.0 });
            if !mu_k.is_finite() || mu_k < 0.0 {
                return Err(bad(
                    format!("{field}.mu_kinetic"),
                    "must be finite and non-negative",
                ));
            }
            Ok((Friction::Sticking { mu }, mu_k))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::index_names;
    use std::cell::Cell;
    use std::hash::{Hash, Hasher};

    thread_local! {
        static COMPARISONS: Cell<usize> = const { Cell::new(0) };
    }

    /// A name that counts how often it is compared with another.
    #[derive(Debug)]
    struct Counted(String);
    impl PartialEq for Counted {
        fn eq(&self, other: &Self) -> bool {
            COMPARISONS.with(|c| c.set(c.get() + 1));
            self.0 == other.0
        }
    }
    impl Eq for Counted {}
    impl Hash for Counted {
        fn hash<H: Hasher>(&self, h: &mut H) {
            self.0.hash(h)
        }
    }

    fn comparisons(n: usize) -> usize {
        COMPARISONS.with(|c| c.set(0));
        let index = index_names((0..n).map(|i| Counted(format!("leg{i}")))).unwrap();
        assert_eq!(index.len(), n);
        COMPARISONS.with(|c| c.get())
    }

    /// Issue 31: 120,000 one-link legs took over a minute to load, each leg's name compared
    /// with every earlier one (n(n−1)/2 = 7.2e9 comparisons). Distinct names are now compared
    /// only on a hash collision: far fewer comparisons than names, at any size.
    #[test]
    fn checking_leg_names_for_repeats_is_linear_in_the_legs() {
        for n in [1_000, 20_000] {
            let c = comparisons(n);
            assert!(c < n / 10, "{c} comparisons for {n} distinct names");
        }
    }

    #[test]
    fn a_repeated_name_is_reported_at_its_second_occurrence() {
        assert_eq!(
            index_names(["a", "b", "c", "b", "a"].into_iter()).unwrap_err(),
            3
        );
        assert_eq!(index_names(["a", "b"].into_iter()).unwrap()["b"], 1);
    }
}
