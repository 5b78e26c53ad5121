//! A [`SpatialModel`] from a URDF file (parsed by `urdf-rs`), built the way Pinocchio's URDF
//! parser builds it: the tree rooted at the one link that is no joint's child (or a chosen
//! link), joints depth first with a link's child joints in the order of their names (as
//! urdfdom, which Pinocchio reads URDF through, keeps them: not the file's order), each moving
//! joint's child link as its body, fixed joints merged into the parent body (their child's
//! inertia added, its frames kept), every link and joint a named frame. A link with zero mass
//! stays massless. `urdf-rs` parses the XML as urdfdom reads it, and a field it refuses is
//! named ([`super::urdf_xml`]).
use super::error::{SpatialError, SpatialResult};
use super::inertia::Inertia;
use super::model::{BaseKind, Frame, FrameKind, Joint, JointKind, SpatialModel};
use super::se3::SE3;
use super::urdf_xml::{as_urdfdom_reads_it, malformed_field};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use std::collections::HashMap;
use std::path::Path;

fn invalid(field: String, reason: impl Into<String>) -> SpatialError {
    SpatialError::InvalidUrdf {
        field,
        reason: reason.into(),
    }
}

fn finite(field: String, values: &[f64]) -> SpatialResult<()> {
    match values.iter().find(|x| !x.is_finite()) {
        Some(x) => Err(invalid(field, format!("non-finite value {x}"))),
        None => Ok(()),
    }
}

fn pose(field: String, p: &urdf_rs::Pose) -> SpatialResult<SE3> {
    finite(field.clone() + ".xyz", &p.xyz.0)?;
    finite(field + ".rpy", &p.rpy.0)?;
    Ok(SE3::from_xyz_rpy(p.xyz.0, p.rpy.0))
}

/// A link's inertial block as an [`Inertia`] in the link frame; checks mass ≥ 0, finite
/// entries and a positive semi-definite rotational inertia (to round-off: an eigenvalue
/// above `−10⁻¹²` times the larger of its largest entry and the mass times 1 m²).
fn link_inertia(link: &urdf_rs::Link) -> SpatialResult<Inertia> {
    let field = format!("link[{}].inertial", link.name);
    let (m, i) = (link.inertial.mass.value, &link.inertial.inertia);
    finite(field.clone() + ".mass", &[m])?;
    if m < 0.0 {
        return Err(invalid(field + ".mass", format!("negative mass {m}")));
    }
    let entries = [i.ixx, i.ixy, i.ixz, i.iyy, i.iyz, i.izz];
    finite(field.clone() + ".inertia", &entries)?;
    let ic = Matrix3::new(
        i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz,
    );
    // round-off at the scale of the matrix or of the mass over a metre (a point mass written
    // with off-diagonal entries of 1e-20 kg m², as iCub's ankles are, is a point mass)
    let scale = ic.abs().max().max(m * 1.0);
    let smallest = SymmetricEigen::new(ic).eigenvalues.min();
    if smallest < -1e-12 * scale {
        return Err(invalid(
            field + ".inertia",
            format!("not positive semi-definite (an eigenvalue of {smallest:.3e} kg m²)"),
        ));
    }
    let origin = pose(field + ".origin", &link.inertial.origin)?;
    Ok(Inertia::new(m, Vector3::zeros(), ic).transformed(&origin))
}

/// A moving joint's kind from its URDF type and axis (normalized).
fn joint_kind(joint: &urdf_rs::Joint) -> SpatialResult<Option<JointKind>> {
    let field = format!("joint[{}]", joint.name);
    let axis = || -> SpatialResult<Vector3<f64>> {
        finite(field.clone() + ".axis", &joint.axis.xyz.0)?;
        let a = Vector3::from(joint.axis.xyz.0);
        if a.norm() < 1e-12 {
            return Err(invalid(field.clone() + ".axis", "zero axis"));
        }
        Ok(a.normalize())
    };
    use urdf_rs::JointType as T;
    Ok(match joint.joint_type {
        T::Revolute | T::Continuous => Some(JointKind::Revolute { axis: axis()? }),
        T::Prismatic => Some(JointKind::Prismatic { axis: axis()? }),
        // six degrees of freedom, as Pinocchio's parser reads it: a free flyer placed at the
        // joint's origin (a `world` link's `floating` child on a fixed base is the robot's
        // free-flying base)
        T::Floating => Some(JointKind::FreeFlyer),
        T::Fixed => None,
        ref other => {
            return Err(invalid(
                field + ".type",
                format!(
                    "joint type `{other:?}` is not supported (revolute, continuous, prismatic, \
                     floating, fixed; a `planar` URDF joint moves in its frame's x–y plane, \
                     unlike `base=\"planar\"`)"
                ),
            ))
        }
    })
}

/// The tree's structure: children joints of each link (in the order of their names) and the
/// root link.
struct Tree<'a> {
    links: HashMap<&'a str, &'a urdf_rs::Link>,
    children: HashMap<&'a str, Vec<&'a urdf_rs::Joint>>,
    root: &'a str,
}

fn tree<'a>(robot: &'a urdf_rs::Robot, root: Option<&'a str>) -> SpatialResult<Tree<'a>> {
    if robot.links.is_empty() {
        return Err(invalid("link".into(), "the URDF has no link"));
    }
    let mut links = HashMap::new();
    for link in &robot.links {
        if links.insert(link.name.as_str(), link).is_some() {
            return Err(invalid(
                format!("link[{}]", link.name),
                "duplicate link name",
            ));
        }
    }
    let mut children: HashMap<&str, Vec<&urdf_rs::Joint>> = HashMap::new();
    let mut parent_of: HashMap<&str, &str> = HashMap::new();
    for joint in &robot.joints {
        let field = format!("joint[{}]", joint.name);
        for (end, link) in [("parent", &joint.parent.link), ("child", &joint.child.link)] {
            if !links.contains_key(link.as_str()) {
                return Err(invalid(
                    format!("{field}.{end}"),
                    format!("no link named `{link}`"),
                ));
            }
        }
        if let Some(first) = parent_of.insert(&joint.child.link, &joint.name) {
            return Err(invalid(
                format!("{field}.child"),
                format!(
                    "link `{}` is already the child of joint `{first}`: a cycle or a second parent",
                    joint.child.link
                ),
            ));
        }
        children
            .entry(joint.parent.link.as_str())
            .or_default()
            .push(joint);
    }
    // urdfdom keeps a link's child joints in a map by name: Pinocchio's joint order
    for siblings in children.values_mut() {
        siblings.sort_by(|a, b| a.name.cmp(&b.name));
    }
    let root = match root {
        Some(name) if links.contains_key(name) => name,
        Some(name) => {
            return Err(SpatialError::UnknownFrame {
                field: "root_link".into(),
                name: name.into(),
            })
        }
        None => {
            let roots: Vec<&str> = robot
                .links
                .iter()
                .map(|l| l.name.as_str())
                .filter(|l| !parent_of.contains_key(l))
                .collect();
            match roots.as_slice() {
                [one] => *one,
                [] => return Err(cycle(robot, &parent_of)),
                many => {
                    return Err(invalid(
                        "link".into(),
                        format!("several root links {many:?}: the tree is not connected"),
                    ))
                }
            }
        }
    };
    Ok(Tree {
        links,
        children,
        root,
    })
}

/// The error for a URDF whose every link is some joint's child: walks up from the first link
/// until a link repeats and names the joint that closes the cycle.
fn cycle(robot: &urdf_rs::Robot, parent_of: &HashMap<&str, &str>) -> SpatialError {
    let mut seen = std::collections::HashSet::new();
    let mut link = robot.links.first().map_or("", |l| l.name.as_str());
    loop {
        let joint = parent_of[link];
        if !seen.insert(link) {
            return invalid(
                format!("joint[{joint}].child"),
                format!("link `{link}` is its own ancestor: the joints form a cycle"),
            );
        }
        link = robot
            .joints
            .iter()
            .find(|j| j.name == joint)
            .map_or("", |j| j.parent.link.as_str());
    }
}

/// Building state: the model so far and where the current link hangs.
struct Builder<'a> {
    model: SpatialModel,
    tree: Tree<'a>,
    visited: usize,
}

impl<'a> Builder<'a> {
    /// Adds `link` carried by `joint` at `placement` (in the joint frame), then its subtree.
    fn add_link(
        &mut self,
        link: &'a str,
        joint: Option<usize>,
        placement: SE3,
        depth: usize,
    ) -> SpatialResult<()> {
        if depth > self.tree.links.len() {
            return Err(invalid(format!("link[{link}]"), "the joints form a cycle"));
        }
        self.visited += 1;
        let inertia = link_inertia(self.tree.links[link])?.transformed(&placement);
        if let Some(j) = joint {
            self.model.inertias[j] = self.model.inertias[j].combined(&inertia);
        }
        self.model.frames.push(Frame {
            name: link.into(),
            kind: FrameKind::Body,
            joint,
            placement,
        });
        let children = self.tree.children.get(link).cloned().unwrap_or_default();
        for child in children {
            let origin = pose(format!("joint[{}].origin", child.name), &child.origin)?;
            let at = placement.compose(&origin);
            match joint_kind(child)? {
                None => {
                    self.model.frames.push(Frame {
                        name: child.name.clone(),
                        kind: FrameKind::FixedJoint,
                        joint,
                        placement: at,
                    });
                    self.add_link(&child.child.link, joint, at, depth + 1)?;
                }
                Some(kind) => {
                    let j = self.add_joint(child.name.clone(), kind, joint, at);
                    self.model.joints[j].continuous =
                        child.joint_type == urdf_rs::JointType::Continuous;
                    self.add_link(&child.child.link, Some(j), SE3::identity(), depth + 1)?;
                }
            }
        }
        Ok(())
    }

    fn add_joint(
        &mut self,
        name: String,
        kind: JointKind,
        parent: Option<usize>,
        placement: SE3,
    ) -> usize {
        let m = &mut self.model;
        m.joints.push(Joint {
            name: name.clone(),
            kind,
            parent,
            placement,
            idx_q: m.nq,
            idx_v: m.nv,
            continuous: false,
        });
        m.inertias.push(Inertia::zero());
        m.nq += kind.nq();
        m.nv += kind.nv();
        let j = m.joints.len() - 1;
        m.frames.push(Frame {
            name,
            kind: FrameKind::Joint,
            joint: Some(j),
            placement: SE3::identity(),
        });
        j
    }
}

impl SpatialModel {
    /// From URDF text. `base` attaches the root link to the world; `root_link` chooses the
    /// root (default: the one link that is no joint's child). Gravity is URDF's z-up
    /// [`SpatialModel::URDF_GRAVITY`].
    pub fn from_urdf_str(
        text: &str,
        base: BaseKind,
        root_link: Option<&str>,
    ) -> SpatialResult<Self> {
        let parse_error = |message: String| SpatialError::UrdfParse { message };
        let text = as_urdfdom_reads_it(text).map_err(parse_error)?;
        let robot = urdf_rs::read_from_string(&text)
            .map_err(|e| malformed_field(&text).unwrap_or_else(|| parse_error(e.to_string())))?;
        Self::from_urdf_robot(&robot, base, root_link)
    }

    /// From a URDF file (see [`Self::from_urdf_str`]).
    pub fn from_urdf_file(
        path: impl AsRef<Path>,
        base: BaseKind,
        root_link: Option<&str>,
    ) -> SpatialResult<Self> {
        let text = std::fs::read_to_string(path.as_ref()).map_err(|e| SpatialError::UrdfParse {
            message: format!("{}: {e}", path.as_ref().display()),
        })?;
        Self::from_urdf_str(&text, base, root_link)
    }

    /// From a parsed `urdf_rs::Robot`.
    pub fn from_urdf_robot(
        robot: &urdf_rs::Robot,
        base: BaseKind,
        root_link: Option<&str>,
    ) -> SpatialResult<Self> {
        let tree = tree(robot, root_link)?;
        let model = SpatialModel {
            name: robot.name.clone(),
            joints: Vec::new(),
            inertias: Vec::new(),
            frames: vec![Frame {
                name: "universe".into(),
                kind: FrameKind::FixedJoint,
                joint: None,
                placement: SE3::identity(),
            }],
            gravity: Vector3::from(Self::URDF_GRAVITY),
            nq: 0,
            nv: 0,
        };
        let root = tree.root;
        let mut b = Builder {
            model,
            tree,
            visited: 0,
        };
        let root_kind = match base {
            BaseKind::FreeFlyer => Some(JointKind::FreeFlyer),
            BaseKind::Planar => Some(JointKind::Planar),
            BaseKind::Fixed => None,
        };
        let joint =
            root_kind.map(|kind| b.add_joint("root_joint".into(), kind, None, SE3::identity()));
        b.add_link(root, joint, SE3::identity(), 0)?;
        if b.visited != robot.links.len() {
            let unreached = robot.links.iter().find(|l| {
                !b.model
                    .frames
                    .iter()
                    .any(|f| f.kind == FrameKind::Body && f.name == l.name)
            });
            let name = unreached.map_or(String::new(), |l| l.name.clone());
            return Err(invalid(
                format!("link[{name}]"),
                "not reachable from the root: the joints form a cycle",
            ));
        }
        Ok(b.model)
    }
}
