//! The immutable, validated robot model (built from a [`crate::RobotDescription`]).
//!
//! Generalized coordinates follow the thesis (section 4.1.2): `q = [θ, x]` with the `n`
//! joint angles first (leg by leg, proximal to distal) and then the body pose
//! `x = (x, z, φ)` in the world frame (z down, φ nose-up).
use nalgebra::Vector2;

/// A leg: a planar serial chain of revolute joints attached at `hip_m` in the body frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Leg {
    pub name: String,
    pub hip_m: Vector2<f64>,
    /// Index of the leg's first joint in `q`.
    pub first_joint: usize,
    pub n_links: usize,
}

/// Joint `j` and the link it drives (one link per joint).
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    pub leg: usize,
    pub index_in_leg: usize,
    /// `+1` if a positive angle rotates about `+y` (nose-up sense), `−1` about `−y`.
    pub axis_sign: f64,
    pub length_m: f64,
    pub mass_kg: f64,
    pub inertia_kg_m2: f64,
    /// Centre of mass in the link frame.
    pub com_m: Vector2<f64>,
    /// A passive spring–damper acting across the joint, if any ([`crate::passive`]).
    pub spring: Option<JointSpring>,
    /// Armature `a_j ≥ 0` (kg·m²): a constant added to `M̄`'s diagonal at this joint's
    /// coordinate, `M̄_jj += a_j` (MuJoCo's `armature`, Drake's `reflected_inertia`). It is
    /// the inertia of a drive's rotors seen through its gearbox, `n J G²` for `n` rotors of
    /// inertia `J` behind a ratio `G`: a rotor turning at `G θ̇_j` relative to the link's
    /// parent has kinetic energy `½ J (G θ̇_j + ω_parent)²`, of which the armature keeps only
    /// `½ J G² θ̇_j²`. The dropped terms — the rotor's coupling `J G θ̇_j ω_parent` with the
    /// parent's rotation and its own `½ J ω_parent²` — are small beside `J G²` for `G ≫ 1`
    /// (a factor `1/G` and `1/G²`), so the rotor adds inertia to the joint's own coordinate
    /// only: no coupling with the body's rotation, no gyroscopic term, nothing in `C̄` or
    /// `N̄`, and no change to the robot's mass or centre of mass.
    pub armature_kg_m2: f64,
}

/// A passive torsional spring–damper across a joint (thesis footnote 2 of chapter 3:
/// "compliance can easily be added back"): with `d = q_j − rest_angle_rad`, it applies
/// `τ = −k d − k₃ d³ − c q̇_j` to the joint ([`crate::passive::spring_torque`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSpring {
    /// `k` (N·m/rad), linear stiffness.
    pub stiffness_n_m_per_rad: f64,
    /// `k₃` (N·m/rad³), cubic (hardening) stiffness.
    pub cubic_stiffness_n_m_per_rad3: f64,
    /// `c` (N·m·s/rad), viscous damping.
    pub damping_n_m_s_per_rad: f64,
    /// Joint angle at which the spring is relaxed (rad).
    pub rest_angle_rad: f64,
}

impl Joint {
    /// Whether the joint's coordinate carries no inertia of its own: its link has neither
    /// mass nor inertia and the joint has no armature. A joint with armature is not
    /// massless even on a massless link (its coordinate has inertia `a_j`), so it is never
    /// a free massless joint (thesis 5.1.1) and its leg's statics do not resolve its forces.
    pub fn is_massless(&self) -> bool {
        self.mass_kg == 0.0 && self.inertia_kg_m2 == 0.0 && self.armature_kg_m2 == 0.0
    }
}

/// Shape of a contact site in the frame of its part.
#[derive(Debug, Clone, PartialEq)]
pub enum ContactShape {
    Point {
        position_m: Vector2<f64>,
    },
    /// A circle (`normal_range_rad = None`) or an arc of outward-normal angles `[α0, α1]`.
    Arc {
        center_m: Vector2<f64>,
        radius_m: f64,
        normal_range_rad: Option<[f64; 2]>,
    },
}

/// Friction model of a contact site.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Friction {
    /// Normal and tangential rows while the force stays in the Coulomb cone `|λ_t| ≤ μ|λ_n|`.
    Sticking { mu: f64 },
    /// Normal row only (frictionless sliding).
    Sliding,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    pub name: String,
    /// The joint whose link carries the contact, or `None` for the body.
    pub link: Option<usize>,
    pub shape: ContactShape,
    pub friction: Friction,
    /// Coefficient of kinetic (Coulomb) friction while the site slides, `μ_k ≥ 0`. Zero is
    /// the thesis's Assumption 5.9 ("all contact points that are sliding have no kinetic
    /// coefficient of friction"); a positive value is supported at any site: by the leg's
    /// statics on a single-joint massless leg, folded into the dynamics solve elsewhere
    /// ([`crate::friction`]).
    pub kinetic_mu: f64,
}

/// The convex outline of a collision shape in its part's frame: the contact sites it
/// expands to keep it above the ground, and the whole outline checks what those sites cannot
/// see (a terrain edge pressed into a box's side) with [`crate::contact::outline_penetration`].
#[derive(Debug, Clone, PartialEq)]
pub enum OutlineShape {
    /// A rectangle centred at `center_m` with half-extents `half_m[0]` along the unit axis
    /// `axis` and `half_m[1]` across it.
    Box {
        center_m: Vector2<f64>,
        axis: Vector2<f64>,
        half_m: [f64; 2],
    },
    /// The points within `radius_m` of the segment `ends_m[0]`–`ends_m[1]`: a stadium, or a
    /// circle when the two ends coincide.
    Round {
        ends_m: [Vector2<f64>; 2],
        radius_m: f64,
    },
}

/// A collision shape of the body or of a link: its outline, and the contact sites
/// (`model.contacts[contacts]`) it expands to.
#[derive(Debug, Clone, PartialEq)]
pub struct Outline {
    /// Where it was declared: `body.collision[i]` or `<leg>[<k>].collision[i]`.
    pub name: String,
    /// The joint whose link carries it, or `None` for the body.
    pub link: Option<usize>,
    pub shape: OutlineShape,
    /// Its contact sites, in `model.contacts`.
    pub contacts: std::ops::Range<usize>,
}

/// The validated robot. Cheap to share between threads (`Send + Sync`, no interior mutability).
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub name: String,
    pub gravity_m_s2: f64,
    pub body_mass_kg: f64,
    pub body_inertia_kg_m2: f64,
    pub legs: Vec<Leg>,
    pub joints: Vec<Joint>,
    pub contacts: Vec<Contact>,
    /// The collision shapes of the body and links (empty unless described): their sites are
    /// among `contacts`.
    pub outlines: Vec<Outline>,
}

impl Model {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        name: String,
        gravity_m_s2: f64,
        body_mass_kg: f64,
        body_inertia_kg_m2: f64,
        legs: Vec<Leg>,
        joints: Vec<Joint>,
        contacts: Vec<Contact>,
        outlines: Vec<Outline>,
    ) -> Self {
        Model {
            name,
            gravity_m_s2,
            body_mass_kg,
            body_inertia_kg_m2,
            legs,
            joints,
            contacts,
            outlines,
        }
    }

    /// Number of joints `n`.
    pub fn n_joints(&self) -> usize {
        self.joints.len()
    }
    /// Dimension of `q`: `n + 3`.
    pub fn nq(&self) -> usize {
        self.joints.len() + 3
    }
    pub fn ix_x(&self) -> usize {
        self.joints.len()
    }
    pub fn ix_z(&self) -> usize {
        self.joints.len() + 1
    }
    pub fn ix_phi(&self) -> usize {
        self.joints.len() + 2
    }
    pub fn n_contacts(&self) -> usize {
        self.contacts.len()
    }

    pub fn contact_index(&self, name: &str) -> crate::Result<usize> {
        self.contacts
            .iter()
            .position(|c| c.name == name)
            .ok_or_else(|| crate::CoreError::UnknownContact {
                name: name.to_string(),
            })
    }

    /// The leg carrying contact `k` (`None` for a contact on the body).
    pub fn contact_leg(&self, k: usize) -> Option<usize> {
        self.contacts[k].link.map(|j| self.joints[j].leg)
    }

    /// Joints `first..=j` of the leg of joint `j`: the chain that moves link `j`.
    pub fn chain(&self, j: usize) -> std::ops::RangeInclusive<usize> {
        self.legs[self.joints[j].leg].first_joint..=j
    }

    /// Joints of the leg that holds joint `j`, from `j` to the tip.
    pub fn distal(&self, j: usize) -> std::ops::Range<usize> {
        let leg = &self.legs[self.joints[j].leg];
        j..leg.first_joint + leg.n_links
    }

    /// Whether joint `j` moves only massless links, with no armature at any joint from `j`
    /// to the tip ([`Joint::is_massless`]).
    pub fn distal_massless(&self, j: usize) -> bool {
        self.distal(j).all(|k| self.joints[k].is_massless())
    }

    /// Total mass including links.
    pub fn total_mass_kg(&self) -> f64 {
        self.body_mass_kg + self.joints.iter().map(|j| j.mass_kg).sum::<f64>()
    }

    pub fn has_massless_links(&self) -> bool {
        self.joints.iter().any(Joint::is_massless)
    }
}
