//! The immutable spatial model: a kinematic tree of joints with body inertias and named
//! frames (Featherstone 2008, §4.1 "model of a kinematic tree"; Pinocchio's `Model`).
//!
//! Joint `i` moves its body relative to its parent joint's body; `placement` is the joint
//! frame in the parent's frame at `q = 0` (URDF's `<origin>`), and the body frame coincides with
//! the joint frame. Joints are stored parents first (depth first, children in URDF order, as
//! Pinocchio's URDF parser orders them), so one forward sweep and one backward sweep visit the
//! tree.
use super::error::{SpatialError, SpatialResult};
use super::inertia::Inertia;
use super::se3::SE3;
use nalgebra::Vector3;

/// How a joint moves its body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointKind {
    /// Six degrees of freedom: `q = [p, qx, qy, qz, qw]` (position and unit quaternion of the
    /// body in the parent frame), `v = [v, ω]` the body's twist in its own frame.
    FreeFlyer,
    /// Rotation about a unit axis of the joint frame (URDF revolute and continuous).
    Revolute { axis: Vector3<f64> },
    /// Translation along a unit axis of the joint frame.
    Prismatic { axis: Vector3<f64> },
    /// Three degrees of freedom in the joint frame's x–z plane (a sagittal-plane base):
    /// `q = [x, z, θ]`, the translations along the frame's x and z axes, then the turn `θ`
    /// about its y axis (Pinocchio's composite of `PX`, `PZ`, `RY`; MuJoCo's slide, slide,
    /// hinge; Drake's `PlanarJoint` in that plane), and `v = q̇` (`ẋ`, `ż` along the joint
    /// frame's axes, `θ̇`). Its translation columns are fixed in the parent body, its turn's in
    /// its own ([`super::kinematics::forward_kinematics_velocity`] differentiates each so).
    Planar,
}

impl JointKind {
    pub fn nq(&self) -> usize {
        match self {
            JointKind::FreeFlyer => 7,
            JointKind::Planar => 3,
            _ => 1,
        }
    }
    pub fn nv(&self) -> usize {
        match self {
            JointKind::FreeFlyer => 6,
            JointKind::Planar => 3,
            _ => 1,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    pub name: String,
    pub kind: JointKind,
    /// Parent joint, `None` for the world.
    pub parent: Option<usize>,
    /// The joint frame in the parent body's frame at zero joint coordinate.
    pub placement: SE3,
    /// First index of this joint in `q` and in `v`.
    pub idx_q: usize,
    pub idx_v: usize,
    /// A URDF `continuous` joint (a revolute joint without limits): one coordinate, the angle
    /// `θ`, here, and two, `(cos θ, sin θ)`, in Pinocchio's layout
    /// ([`super::liegroup::to_pinocchio`]).
    pub continuous: bool,
}

/// What a frame marks (Pinocchio's `FrameType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameKind {
    /// A link of the URDF.
    Body,
    /// A moving joint.
    Joint,
    /// A fixed joint, merged into its parent body.
    FixedJoint,
    /// A frame added to the description by its user ([`SpatialModel::add_frame`]): a foot's
    /// corner, a tool tip (Pinocchio's `OP_FRAME`).
    Operational,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    pub name: String,
    pub kind: FrameKind,
    /// The joint whose body carries the frame, `None` for the world.
    pub joint: Option<usize>,
    /// The frame in that joint's frame.
    pub placement: SE3,
}

/// How the robot's root link is attached to the world.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BaseKind {
    /// A free-flying base: a [`JointKind::FreeFlyer`] joint named `root_joint`.
    FreeFlyer,
    /// The root link is the world (a manipulator bolted down).
    Fixed,
    /// The root link moves in the world's x–z plane (x forward, z up, the turn about y): a
    /// [`JointKind::Planar`] joint named `root_joint` — the sagittal model of a robot on a
    /// planarizing boom, the planar model (`d = 2`) of a URDF robot. The joints below it move
    /// as the URDF says, in or out of the plane.
    Planar,
}

impl BaseKind {
    /// `"free_flyer"`, `"planar"` or `"fixed"` (the names of the Python API).
    pub fn from_name(name: &str) -> SpatialResult<Self> {
        match name {
            "free_flyer" => Ok(BaseKind::FreeFlyer),
            "planar" => Ok(BaseKind::Planar),
            "fixed" => Ok(BaseKind::Fixed),
            other => Err(SpatialError::InvalidArgument {
                field: "base".into(),
                reason: format!(
                    "unknown base `{other}` (expected `free_flyer`, `planar` or `fixed`)"
                ),
            }),
        }
    }
}

/// A kinematic tree with inertias, frames and gravity.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialModel {
    pub name: String,
    pub joints: Vec<Joint>,
    /// The inertia carried by each joint's body (fixed-joint children merged in), in the
    /// joint frame.
    pub inertias: Vec<Inertia>,
    pub frames: Vec<Frame>,
    /// Gravity acceleration in the world frame (m/s²): URDF robots get z up, `[0, 0, −9.81]`.
    pub gravity: Vector3<f64>,
    /// Lengths of `q` and `v`.
    pub nq: usize,
    pub nv: usize,
}

impl SpatialModel {
    /// The standard gravity of URDF's z-up world.
    pub const URDF_GRAVITY: [f64; 3] = [0.0, 0.0, -9.81];

    /// The index of the frame named `name` (the first of that name: a link and a joint may
    /// share a name only in distinct URDF namespaces, which URDF forbids for links); an
    /// unknown name is an error naming the field `frame`.
    pub fn frame_id(&self, name: &str) -> SpatialResult<usize> {
        self.frame_id_of("frame", name)
    }

    /// [`Self::frame_id`] for a frame given as `field` of the caller's input.
    pub fn frame_id_of(&self, field: &str, name: &str) -> SpatialResult<usize> {
        self.frames
            .iter()
            .position(|f| f.name == name)
            .ok_or_else(|| SpatialError::UnknownFrame {
                field: field.into(),
                name: name.into(),
            })
    }

    /// Adds the frame `name` fixed to the frame `parent` at `xyz` (m) and `rpy` (rad, URDF's
    /// roll–pitch–yaw) in `parent`'s axes, as a URDF joint origin places its child: a point
    /// of the robot to name as a contact (a flat foot's corners) or to read. Returns its index.
    /// Errors name `frames[name]…`: an empty or taken name, an unknown parent, a non-finite
    /// offset.
    pub fn add_frame(
        &mut self,
        name: &str,
        parent: &str,
        xyz: [f64; 3],
        rpy: [f64; 3],
    ) -> SpatialResult<usize> {
        let field = |key: &str| format!("frames[{name}]{key}");
        let taken = self.frames.iter().any(|f| f.name == name);
        if name.is_empty() || taken {
            return Err(SpatialError::InvalidArgument {
                field: field(""),
                reason: if taken {
                    "a frame of this name exists".into()
                } else {
                    "an empty name".into()
                },
            });
        }
        let parent_id = self.frame_id_of(&field(".parent"), parent)?;
        for (key, values) in [(".xyz_m", xyz), (".rpy_rad", rpy)] {
            if let Some(x) = values.iter().find(|x| !x.is_finite()) {
                return Err(SpatialError::InvalidArgument {
                    field: field(key),
                    reason: format!("non-finite value {x}"),
                });
            }
        }
        let parent = &self.frames[parent_id];
        let frame = Frame {
            name: name.into(),
            kind: FrameKind::Operational,
            joint: parent.joint,
            placement: parent.placement.compose(&SE3::from_xyz_rpy(xyz, rpy)),
        };
        self.frames.push(frame);
        Ok(self.frames.len() - 1)
    }

    /// Total mass (kg).
    pub fn total_mass(&self) -> f64 {
        self.inertias.iter().map(|y| y.mass).sum()
    }

    /// The root joint's kind when it moves freely in the world (a free flyer or a planar
    /// base): its rates are the base's, `v[..kind.nv()]`, which no actuator drives.
    pub fn floating_base(&self) -> Option<JointKind> {
        self.joints
            .first()
            .filter(|j| j.parent.is_none())
            .map(|j| j.kind)
            .filter(|k| matches!(k, JointKind::FreeFlyer | JointKind::Planar))
    }

    /// The world normal of the plane a planar base moves in (its joint frame's y axis; `None`
    /// for other bases). Its contacts hold no force along it: a contact with friction has the
    /// rows `[t, n]`, `t = y × n` ([`super::contact::PointContact::with_normal`]).
    pub fn plane_normal(&self) -> Option<Vector3<f64>> {
        let root = self.joints.first()?;
        (root.kind == JointKind::Planar && root.parent.is_none())
            .then(|| root.placement.rotation * Vector3::y())
    }
}
