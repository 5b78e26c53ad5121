//! Contact sites, contact modes and the constraint rows `A`, `Ȧ` (thesis 4.1.3–4.1.6, 5.2.2).
//!
//! **Contact frame.** Each active contact has a frame aligned with its ground plane: the
//! normal axis `n` points *into* the ground (on level ground, world `+z`), the tangent is
//! `t = S(n) = (n_z, −n_x)` (world `+x` on level ground). A contact contributes a tangential
//! row (if sticking) before its normal row.
//!
//! **Constraint.** Thesis (4.11)/(4.17): `a_k = π(g_{c_k w}) − x̂`, i.e. the *negative* of the
//! contact point in the contact frame, so `A_k = −Bᵀ J_p` with `J_p` the Jacobian of the
//! material point of the robot at the contact. Consequently `λ` is the force the ground
//! exerts on the robot in the contact frame, and a pushing normal force is **negative**
//! (`U = −1` on the normal row, thesis (4.76)).
//!
//! **Rolling.** For a circle or arc on a plane the contact point is `c + r n` with `c` the
//! centre; `A` is the stick-leg row at that point, while `Ȧ` uses the rate of the contact
//! point `ċ` instead of the (zero) material velocity (thesis 4.1.6, 4.4.3).
use crate::arc_range::ArcRange;
use crate::error::{CoreError, Result};
use crate::frames::{perp, rotate_sc};
use crate::kinematics::{Kinematics, Part};
use crate::model::{ContactShape, Friction, Model, Outline, OutlineShape};
use nalgebra::Vector2;
use serde::Serialize;

/// A plane of the ground: a point on it and the unit normal pointing into the ground.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GroundPlane {
    pub point_m: [f64; 2],
    pub normal_into_ground: [f64; 2],
}

impl GroundPlane {
    /// Level ground whose surface is at world `z = height_z_m` (z down).
    pub fn level(height_z_m: f64) -> Self {
        GroundPlane {
            point_m: [0.0, height_z_m],
            normal_into_ground: [0.0, 1.0],
        }
    }
    pub fn normal(&self) -> Vector2<f64> {
        Vector2::new(self.normal_into_ground[0], self.normal_into_ground[1])
    }
    pub fn tangent(&self) -> Vector2<f64> {
        perp(self.normal())
    }
    /// Signed height of a point above the plane (positive above, negative penetrating).
    pub fn height_of(&self, p: Vector2<f64>) -> f64 {
        -(p - Vector2::new(self.point_m[0], self.point_m[1])).dot(&self.normal())
    }
}

/// What the ground looks like near a contact site. Implementations must be deterministic.
///
/// A site touches the surface [`Terrain::plane_under`] its reference point (a point contact's
/// point, an arc's or circle's centre), or — where the terrain has a step — the vertical
/// face [`Terrain::face_near`] offers, or the step's convex edge [`Terrain::corner_near`],
/// whichever its shape comes nearest to (the smallest gap).
///
/// Faces are planes, so a site on a face has the same constraint rows as one on the ground,
/// with the face's normal. A circle or arc on a convex corner `v` touches it along the
/// normal `n = (v − c)/|v − c|` from its centre `c`: its rows are those of the tangent plane
/// there, which turns with the site (`ṅ = −(I − n nᵀ) ċ / |v − c|`, carried into `Ȧ`), so a
/// rolling or sliding site passes from a face over the edge onto the top with its gap and
/// its normal continuous. A *point* site has no normal on a corner: a free point that
/// crosses an edge shows as a jump of its gap through zero, and a point in contact that
/// reaches one leaves its surface; so does any site reaching a concave corner (it would
/// touch two surfaces). The hybrid simulation reports those instead of resolving them.
pub trait Terrain: Send + Sync {
    /// The ground plane that a part centred at world `x_m` would touch.
    fn plane_under(&self, x_m: f64) -> GroundPlane;

    /// A vertical face (a step's riser) that a site with reference point `p` (world, z down)
    /// may touch; `None` (the default) on terrain without steps. Offered only while `p` is
    /// below the face's top edge and on its open side.
    fn face_near(&self, _p: Vector2<f64>) -> Option<GroundPlane> {
        None
    }

    /// The convex corner (world point, z down) that a circle or arc centred at `c` may
    /// touch: offered only while `c` is past the ends of both surfaces that meet there (above
    /// a step's top and on the open side of its face), where the corner is the nearest point
    /// of the terrain. `None` (the default) on terrain without convex corners.
    fn corner_near(&self, _c: Vector2<f64>) -> Option<Vector2<f64>> {
        None
    }

    /// What a site with reference point `p` may touch, asked at once: the
    /// [`Terrain::plane_under`] `p.x`, the [`Terrain::face_near`] `p` and, if `corner`, the
    /// [`Terrain::corner_near`] `p` (`None` otherwise). A terrain that finds them with one
    /// look-up overrides it; the answers are those of the three methods, bit for bit.
    fn features_near(&self, p: Vector2<f64>, corner: bool) -> NearbyFeatures {
        NearbyFeatures {
            plane: self.plane_under(p.x),
            face: self.face_near(p),
            corner: if corner { self.corner_near(p) } else { None },
        }
    }
}

/// The terrain's surfaces near a site's reference point ([`Terrain::features_near`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearbyFeatures {
    pub plane: GroundPlane,
    pub face: Option<GroundPlane>,
    pub corner: Option<Vector2<f64>>,
}

/// Level ground at world `z = 0`.
#[derive(Debug, Clone, Copy, Default)]
pub struct FlatGround;

impl Terrain for FlatGround {
    fn plane_under(&self, _x_m: f64) -> GroundPlane {
        GroundPlane::level(0.0)
    }
}

impl Terrain for GroundPlane {
    fn plane_under(&self, _x_m: f64) -> GroundPlane {
        *self
    }
}

/// Which constraint rows are active: a bitset over normal rows and one over tangential rows
/// (a tangential row only with its normal row, Definition 5.2 / eq. 5.45).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, PartialOrd, Ord, Serialize)]
pub struct ContactMode {
    normal: u32,
    tangential: u32,
}

/// How an active contact is constrained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum ContactKind {
    /// Normal and tangential rows.
    Stick,
    /// Normal row only.
    Slide,
}

/// Direction of one constraint row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum RowDirection {
    Tangential,
    Normal,
}

/// One row of `A` / one entry of `λ`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ConstraintRow {
    pub contact: usize,
    pub direction: RowDirection,
}

impl ContactMode {
    /// No contact (flight).
    pub const FLIGHT: ContactMode = ContactMode {
        normal: 0,
        tangential: 0,
    };

    /// From raw bitsets; `tangential ⊆ normal` is required.
    pub fn from_bits(normal: u32, tangential: u32) -> Result<Self> {
        if tangential & !normal != 0 {
            return Err(CoreError::InvalidMode {
                reason: format!(
                    "tangential rows {tangential:#b} without their normal rows {normal:#b}"
                ),
            });
        }
        Ok(ContactMode { normal, tangential })
    }

    pub fn normal_bits(self) -> u32 {
        self.normal
    }
    pub fn tangential_bits(self) -> u32 {
        self.tangential
    }

    /// Each listed contact active with its own friction model (sticking contacts stick).
    pub fn with_defaults(model: &Model, contacts: &[usize]) -> Result<Self> {
        let mut m = ContactMode::FLIGHT;
        for &k in contacts {
            let kind = match model.contacts.get(k).map(|c| c.friction) {
                None => {
                    return Err(CoreError::InvalidMode {
                        reason: format!("no contact with index {k}"),
                    })
                }
                Some(Friction::Sticking { .. }) => ContactKind::Stick,
                Some(Friction::Sliding) => ContactKind::Slide,
            };
            m = m.with(k, kind);
        }
        Ok(m)
    }

    /// Parses `"front_leg,rear_leg:slide"`-style lists of contact names (empty = flight).
    /// An empty item (`",,,"`, `"foot,"`) or a contact listed twice is refused: it is a
    /// list that says something other than what it seems to.
    pub fn parse_names(model: &Model, spec: &str) -> Result<Self> {
        let mut m = ContactMode::FLIGHT;
        if spec.trim().is_empty() {
            return Ok(m);
        }
        let mut seen = Vec::new();
        for (i, item) in spec.split(',').map(str::trim).enumerate() {
            if item.is_empty() {
                return Err(CoreError::InvalidMode {
                    reason: format!("item {i} of `{spec}` names no contact"),
                });
            }
            let (name, kind) = match item.split_once(':') {
                Some((n, "slide")) => (n, Some(ContactKind::Slide)),
                Some((n, "stick")) => (n, Some(ContactKind::Stick)),
                Some((_, other)) => {
                    return Err(CoreError::InvalidMode {
                        reason: format!("unknown contact kind `{other}`"),
                    })
                }
                None => (item, None),
            };
            let k = model.contact_index(name)?;
            if seen.contains(&k) {
                return Err(CoreError::InvalidMode {
                    reason: format!("contact `{name}` is listed twice in `{spec}`"),
                });
            }
            seen.push(k);
            m = match kind {
                Some(kind) => m.with(k, kind),
                None => m.union(ContactMode::with_defaults(model, &[k])?),
            };
        }
        m.validate(model)?;
        Ok(m)
    }

    pub fn with(self, k: usize, kind: ContactKind) -> Self {
        let bit = 1u32 << k;
        match kind {
            ContactKind::Stick => ContactMode {
                normal: self.normal | bit,
                tangential: self.tangential | bit,
            },
            ContactKind::Slide => ContactMode {
                normal: self.normal | bit,
                tangential: self.tangential & !bit,
            },
        }
    }

    pub fn without(self, k: usize) -> Self {
        let bit = !(1u32 << k);
        ContactMode {
            normal: self.normal & bit,
            tangential: self.tangential & bit,
        }
    }

    pub fn union(self, o: Self) -> Self {
        ContactMode {
            normal: self.normal | o.normal,
            tangential: self.tangential | o.tangential,
        }
    }

    pub fn contains(self, k: usize) -> bool {
        self.normal >> k & 1 == 1
    }

    pub fn kind(self, k: usize) -> Option<ContactKind> {
        if !self.contains(k) {
            None
        } else if self.tangential >> k & 1 == 1 {
            Some(ContactKind::Stick)
        } else {
            Some(ContactKind::Slide)
        }
    }

    pub fn is_flight(self) -> bool {
        self.normal == 0
    }

    /// Number of constraint rows `c`.
    pub fn n_rows(self) -> usize {
        (self.normal.count_ones() + self.tangential.count_ones()) as usize
    }

    /// Active contacts in ascending order.
    pub fn active(self) -> impl Iterator<Item = usize> {
        let mut bits = self.normal;
        std::iter::from_fn(move || {
            (bits != 0).then(|| {
                let k = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                k
            })
        })
    }

    /// How many rows contact `k` has: 2 sticking, 1 sliding, 0 inactive. [`Self::rows`]
    /// gives each active contact's rows together, the contacts ascending.
    #[inline]
    pub fn n_rows_of(self, k: usize) -> usize {
        ((self.normal >> k & 1) + (self.tangential >> k & 1)) as usize
    }

    /// The rows in order: by contact, tangential before normal.
    pub fn rows(self) -> impl Iterator<Item = ConstraintRow> {
        let mut active = self.active();
        // the normal row still due after a contact's tangential row
        let mut normal_due: Option<usize> = None;
        std::iter::from_fn(move || {
            let (contact, direction) = match normal_due.take() {
                Some(k) => (k, RowDirection::Normal),
                None => {
                    let k = active.next()?;
                    if self.tangential >> k & 1 == 1 {
                        normal_due = Some(k);
                        (k, RowDirection::Tangential)
                    } else {
                        (k, RowDirection::Normal)
                    }
                }
            };
            Some(ConstraintRow { contact, direction })
        })
    }

    /// Checks the mode against a model: contacts exist, sliding-only sites have no
    /// tangential row.
    pub fn validate(self, model: &Model) -> Result<()> {
        let nc = model.n_contacts();
        if nc < 32 && self.normal >> nc != 0 {
            return Err(CoreError::InvalidMode {
                reason: format!("mode names contact indices ≥ {nc} (the model has {nc} contacts)"),
            });
        }
        for k in self.active() {
            if self.kind(k) == Some(ContactKind::Stick)
                && model.contacts[k].friction == Friction::Sliding
            {
                return Err(CoreError::InvalidMode {
                    reason: format!(
                        "contact `{}` is frictionless and cannot stick",
                        model.contacts[k].name
                    ),
                });
            }
        }
        Ok(())
    }
}

/// Where a contact site touches (or would touch) the ground.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum TouchKind {
    /// A point: a toe, a body point, or an end of an arc.
    Point,
    /// The interior of an arc or circle: rolling.
    Rolling,
}

/// Geometry of one contact site against its ground plane.
#[derive(Debug, Clone, Copy)]
pub struct ContactGeometry {
    pub part: Part,
    pub plane: GroundPlane,
    /// World position of the lowest point of the shape (the contact point).
    pub point: Vector2<f64>,
    /// Height of that point above the plane (`a_k` of the guard (5.49); negative = penetrating).
    pub gap_m: f64,
    pub touch: TouchKind,
    /// Rate of the evaluation point used in `Ȧ` (material velocity for a point; the centre's
    /// velocity for rolling on a plane; on a corner, the rate of the contact point as it
    /// moves round the arc, `ċ + r ṅ`).
    pub point_rate: Vector2<f64>,
    /// Rate of the plane's normal `ṅ`: zero on a plane, the turning of the tangent plane on
    /// a corner.
    pub normal_rate: Vector2<f64>,
    /// Whether the site touches a convex corner of the terrain (`plane` is then the tangent
    /// plane there, through the corner, and turns with the site).
    pub on_corner: bool,
}

impl ContactGeometry {
    /// Whether `self` and `other` are on the same terrain feature: the same plane, or the
    /// same corner (whose tangent plane turns).
    pub fn same_feature(&self, other: &ContactGeometry) -> bool {
        match (self.on_corner, other.on_corner) {
            (true, true) => self.plane.point_m == other.plane.point_m,
            (false, false) => self.plane == other.plane,
            _ => false,
        }
    }
}

/// Site `k`, the part it is on, and the world position of its reference point (a point
/// site's point, an arc's centre), near which the terrain's features are looked up.
#[inline]
fn site_reference<'m>(
    model: &'m Model,
    kin: &Kinematics,
    k: usize,
) -> (&'m crate::model::Contact, Part, Vector2<f64>) {
    let site = &model.contacts[k];
    let part = match site.link {
        None => Part::Body,
        Some(j) => Part::Link(j),
    };
    let reference = match &site.shape {
        ContactShape::Point { position_m } => *position_m,
        ContactShape::Arc { center_m, .. } => *center_m,
    };
    (site, part, kin.point(part, reference))
}

/// Where a site touches or would touch the terrain: on the feature its shape comes nearest
/// to (the smallest gap), as [`Terrain`] describes; [`contact_geometry`] without the rates.
struct NearestTouch<'m> {
    site: &'m crate::model::Contact,
    part: Part,
    /// The site's reference point (world): a point site's point, an arc's centre.
    reference: Vector2<f64>,
    plane: GroundPlane,
    /// The touching point (world).
    point: Vector2<f64>,
    gap_m: f64,
    touch: TouchKind,
    /// On a convex corner: the unit normal `n` from the centre to it, the centre's distance
    /// from it and the arc's radius.
    corner: Option<(Vector2<f64>, f64, f64)>,
}

/// [`NearestTouch`] of site `k` at the current kinematics: the plane under its reference
/// point, a face that is nearer, a convex corner that a circle or arc faces (touching it in
/// its interior) and is nearer still; ties keep the earlier.
fn nearest_touch<'m>(
    model: &'m Model,
    kin: &Kinematics,
    terrain: &dyn Terrain,
    k: usize,
) -> NearestTouch<'m> {
    let (site, part, reference) = site_reference(model, kin, k);
    let radius = match site.shape {
        ContactShape::Point { .. } => None,
        ContactShape::Arc { radius_m, .. } => Some(radius_m),
    };
    // a point has no normal on a corner: its corner is not asked for
    let near = terrain.features_near(reference, radius.is_some());
    let (point, gap_m, touch) = touch_on(site, k, part, kin, reference, &near.plane);
    let mut best = NearestTouch {
        site,
        part,
        reference,
        plane: near.plane,
        point,
        gap_m,
        touch,
        corner: None,
    };
    if let Some(face) = near.face {
        let (point, gap_m, touch) = touch_on(site, k, part, kin, reference, &face);
        if gap_m < best.gap_m {
            (best.plane, best.point, best.gap_m, best.touch) = (face, point, gap_m, touch);
        }
    }
    // the tangent plane at the corner `v`, normal `n = (v − c)/|v − c|`, when the arc faces
    // it (its end, a point, would touch otherwise) and the centre is off it
    if let (Some(v), Some(radius_m)) = (near.corner, radius) {
        let to_corner = v - reference;
        let dist = to_corner.norm();
        if dist > 0.0 {
            let n = to_corner / dist;
            let plane = GroundPlane {
                point_m: [v.x, v.y],
                normal_into_ground: [n.x, n.y],
            };
            let (point, gap_m, touch) = touch_on(site, k, part, kin, reference, &plane);
            if touch == TouchKind::Rolling && gap_m < best.gap_m {
                (best.plane, best.point, best.gap_m, best.touch) = (plane, point, gap_m, touch);
                best.corner = Some((n, dist, radius_m));
            }
        }
    }
    best
}

/// The point of site `k` (on `part`, reference point `reference`) that touches or would
/// touch `plane` (world), its gap and how it touches.
#[inline(always)]
fn touch_on(
    site: &crate::model::Contact,
    k: usize,
    part: Part,
    kin: &Kinematics,
    reference: Vector2<f64>,
    plane: &GroundPlane,
) -> (Vector2<f64>, f64, TouchKind) {
    let (point, touch) = match site.shape {
        // a point site touches with its reference point, whatever the plane
        ContactShape::Point { .. } => (reference, TouchKind::Point),
        ContactShape::Arc { .. } => {
            let (local, touch) = touch_point(site, k, part, kin, plane);
            (kin.point(part, local), touch)
        }
    };
    (point, plane.height_of(point), touch)
}

/// Contact geometry for site `k` at the current kinematics ([`Terrain`] says which feature
/// it is on). On a convex corner the tangent plane turns at `ṅ = −(I − n nᵀ) ċ / |v − c|` as
/// the centre `c` moves, and the contact point `c + r n` moves at `ċ + r ṅ`.
pub fn contact_geometry(
    model: &Model,
    kin: &Kinematics,
    terrain: &dyn Terrain,
    k: usize,
) -> ContactGeometry {
    let t = nearest_touch(model, kin, terrain, k);
    let (point_rate, normal_rate) = match t.corner {
        Some((n, dist, radius_m)) => {
            let c_rate = kin.material_velocity(t.part, t.reference);
            let n_rate = -(c_rate - n * n.dot(&c_rate)) / dist;
            (c_rate + radius_m * n_rate, n_rate)
        }
        // rolling: the centre's velocity; a point: its material velocity
        None => match (t.touch, &t.site.shape) {
            (TouchKind::Rolling, ContactShape::Arc { .. }) => {
                (kin.material_velocity(t.part, t.reference), Vector2::zeros())
            }
            _ => (kin.material_velocity(t.part, t.point), Vector2::zeros()),
        },
    };
    ContactGeometry {
        part: t.part,
        plane: t.plane,
        point: t.point,
        gap_m: t.gap_m,
        touch: t.touch,
        point_rate,
        normal_rate,
        on_corner: t.corner.is_some(),
    }
}

/// The gap `a_k(q)` of [`contact_geometry`] alone, without the rates: what a touchdown
/// guard samples several times per step.
pub fn contact_gap(model: &Model, kin: &Kinematics, terrain: &dyn Terrain, k: usize) -> f64 {
    nearest_touch(model, kin, terrain, k).gap_m
}

/// The point of site `k` (on `part`, in the part's frame) that touches or would touch
/// `plane`, and how it touches.
#[inline]
fn touch_point(
    site: &crate::model::Contact,
    k: usize,
    part: Part,
    kin: &Kinematics,
    plane: &GroundPlane,
) -> (Vector2<f64>, TouchKind) {
    let n = plane.normal();
    match &site.shape {
        ContactShape::Point { position_m } => (*position_m, TouchKind::Point),
        ContactShape::Arc {
            center_m,
            radius_m,
            normal_range_rad,
        } => {
            // direction into the ground in the part frame, and its normal angle α
            let (sb, cb) = kin.part_sin_cos(part);
            let d = rotate_sc((-sb, cb), n);
            // (kept by the kinematics; built here if it was computed for another model)
            let arc = normal_range_rad.map(|r| {
                kin.arc_range(k)
                    .filter(|a| a.range == r)
                    .unwrap_or_else(|| ArcRange::new(r))
            });
            match arc {
                Some(arc) if !arc.contains(d) => {
                    // the lower of the two ends acts as a point
                    let [e0, e1] = arc.ends.map(|u| center_m + *radius_m * u);
                    (
                        if e0.dot(&d) >= e1.dot(&d) { e0 } else { e1 },
                        TouchKind::Point,
                    )
                }
                _ => (center_m + *radius_m * d, TouchKind::Rolling),
            }
        }
    }
}

/// A collision outline found inside the terrain ([`outline_penetration`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Penetration {
    /// The outline, in `model.outlines`.
    pub outline: usize,
    /// How deep its deepest point is inside the terrain (m, positive).
    pub depth_m: f64,
}

/// The deepest of the model's collision outlines ([`crate::model::Outline`]) inside the
/// terrain, if deeper than `tol_m`; `None` at once for a model without outlines. An
/// outline's depth is the larger of its sites' depths below their surfaces (`−a_k`, the
/// gap [`contact_gap`] the guards watch) and the depth inside it of a convex terrain corner
/// near it — what its sites cannot see, such as a step's edge pressed into a box's side.
pub fn outline_penetration(
    model: &Model,
    kin: &Kinematics,
    terrain: &dyn Terrain,
    tol_m: f64,
) -> Option<Penetration> {
    let mut deepest: Option<Penetration> = None;
    for (o, outline) in model.outlines.iter().enumerate() {
        let depth_m = outline_depth(model, kin, terrain, outline);
        if depth_m > tol_m && deepest.is_none_or(|d| depth_m > d.depth_m) {
            deepest = Some(Penetration {
                outline: o,
                depth_m,
            });
        }
    }
    deepest
}

/// How deep `outline` is inside the terrain (negative: its clearance from it, as far as its
/// sites see).
fn outline_depth(model: &Model, kin: &Kinematics, terrain: &dyn Terrain, outline: &Outline) -> f64 {
    let part = match outline.link {
        None => Part::Body,
        Some(j) => Part::Link(j),
    };
    let (s, c) = kin.part_sin_cos(part);
    let origin = kin.part_origin(part);
    // a world point in the part's frame: R(β)ᵀ (p − o)
    let local = |p: Vector2<f64>| rotate_sc((-s, c), p - origin);
    let center = match &outline.shape {
        OutlineShape::Box { center_m, .. } => *center_m,
        OutlineShape::Round { ends_m, .. } => 0.5 * (ends_m[0] + ends_m[1]),
    };
    let mut depth = f64::NEG_INFINITY;
    let references = outline
        .contacts
        .clone()
        .map(|k| site_reference(model, kin, k).2)
        .chain(std::iter::once(kin.point(part, center)));
    for r in references {
        if let Some(v) = terrain.corner_near(r) {
            depth = depth.max(depth_inside(&outline.shape, local(v)));
        }
    }
    for k in outline.contacts.clone() {
        depth = depth.max(-contact_gap(model, kin, terrain, k));
    }
    depth
}

/// How deep the point `p` (part frame) is inside `shape` (negative outside).
fn depth_inside(shape: &OutlineShape, p: Vector2<f64>) -> f64 {
    match shape {
        OutlineShape::Box {
            center_m,
            axis,
            half_m,
        } => {
            let d = p - center_m;
            let (u, w) = (d.dot(axis), d.dot(&perp(*axis)));
            (half_m[0] - u.abs()).min(half_m[1] - w.abs())
        }
        OutlineShape::Round { ends_m, radius_m } => {
            let [a, b] = *ends_m;
            let ab = b - a;
            let len2 = ab.norm_squared();
            let t = if len2 > 0.0 {
                ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            radius_m - (p - (a + t * ab)).norm()
        }
    }
}

/// Direction (world) of a constraint row in its contact frame.
pub fn row_direction(plane: &GroundPlane, dir: RowDirection) -> Vector2<f64> {
    match dir {
        RowDirection::Tangential => plane.tangent(),
        RowDirection::Normal => plane.normal(),
    }
}

/// Rate of [`row_direction`] for a contact whose normal turns at `normal_rate` (the tangent
/// `S(n)` is linear in `n`).
pub fn row_direction_rate(normal_rate: Vector2<f64>, dir: RowDirection) -> Vector2<f64> {
    match dir {
        RowDirection::Tangential => perp(normal_rate),
        RowDirection::Normal => normal_rate,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_by_contact_tangential_first() {
        let mode = ContactMode::FLIGHT
            .with(3, ContactKind::Stick)
            .with(0, ContactKind::Stick)
            .with(2, ContactKind::Slide);
        let rows: Vec<_> = mode.rows().map(|r| (r.contact, r.direction)).collect();
        use RowDirection::{Normal as N, Tangential as T};
        assert_eq!(rows, [(0, T), (0, N), (2, N), (3, T), (3, N)]);
        assert_eq!(rows.len(), mode.n_rows());
        assert_eq!(ContactMode::FLIGHT.rows().count(), 0);
        // each contact's rows together, as many as n_rows_of counts
        for k in 0..5 {
            let of_k = rows.iter().filter(|r| r.0 == k).count();
            assert_eq!(mode.n_rows_of(k), of_k);
        }
    }
}
