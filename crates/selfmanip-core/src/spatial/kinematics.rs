//! Forward kinematics, frame placements and frame Jacobians, all in the world frame
//! (Featherstone 2008, §4.4 and §8.3; Pinocchio's `forwardKinematics`, `updateFramePlacement`,
//! `getFrameJacobian`), and [`SpatialData`], the workspace every algorithm writes into (the
//! model/data split: the model is immutable, the data holds every buffer, so repeated
//! evaluations allocate nothing once the data exists).
#![allow(non_snake_case)]
use super::error::{SpatialError, SpatialResult};
use super::inertia::OriginInertia;
use super::liegroup::{check_configuration, quaternion_at};
use super::limb_kkt::LimbKkt;
use super::model::{JointKind, SpatialModel};
use super::motion::{Force, Motion};
use super::se3::SE3;
use super::tree_kkt::{KktRoute, TreeKkt};
use crate::kkt::KktFactorization;
use nalgebra::{DMatrix, DVector, Dyn, OMatrix, Rotation3, Unit, UnitQuaternion, Vector3, U6};

/// A 6 × n matrix of spatial columns (linear rows first).
pub type Matrix6xX = OMatrix<f64, U6, Dyn>;

/// In which frame a Jacobian expresses a frame's velocity (Pinocchio's `ReferenceFrame`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceFrame {
    /// The spatial velocity in world axes at the world origin.
    World,
    /// The frame's own twist, in its own axes at its origin.
    Local,
    /// The velocity of the frame's origin and its angular velocity, in world axes.
    LocalWorldAligned,
}

impl ReferenceFrame {
    /// `"world"`, `"local"` or `"local_world_aligned"`.
    pub fn from_name(name: &str) -> SpatialResult<Self> {
        match name {
            "world" => Ok(Self::World),
            "local" => Ok(Self::Local),
            "local_world_aligned" => Ok(Self::LocalWorldAligned),
            other => Err(SpatialError::InvalidArgument {
                field: "frame".into(),
                reason: format!(
                    "unknown reference frame `{other}` (world, local, local_world_aligned)"
                ),
            }),
        }
    }
}

/// Workspace of the spatial algorithms, sized for one model.
#[derive(Debug, Clone)]
pub struct SpatialData {
    /// Joint placements in the world `⁰Mᵢ`.
    pub oMi: Vec<SE3>,
    /// World motion subspaces: the columns `⁰Sᵢ` of every joint (6 × nv).
    pub oS: Matrix6xX,
    /// Body inertias at the world origin in world axes, and their subtree sums (the composite
    /// inertias of the CRBA).
    pub oI: Vec<OriginInertia>,
    pub oIc: Vec<OriginInertia>,
    /// Body velocities in the world, and their spatial accelerations at `q̈ = 0` without
    /// gravity (the velocity-product part `Σ v × S q̇`).
    pub ov: Vec<Motion>,
    pub oa_drift: Vec<Motion>,
    /// The `Σ ⁰S q̈` part of the body accelerations in the last RNEA sweep.
    pub oa: Vec<Motion>,
    /// Body forces of the last RNEA sweep (world).
    pub of: Vec<Force>,
    /// Joint-space mass matrix `M(q)` (nv × nv, CRBA) and bias forces `h(q, v)` (RNEA). The
    /// CRBA writes `M`'s entries on the tree's sparsity only (a rate and its ancestors): the
    /// others are zero from [`SpatialData::new`], and nothing may write them.
    pub M: DMatrix<f64>,
    pub h: DVector<f64>,
    /// A frame Jacobian (6 × nv).
    pub J: Matrix6xX,
    /// Contact Jacobian `A` (c × nv), its drift `Ȧq̇` (c), and the KKT factorization.
    pub A: DMatrix<f64>,
    pub A_drift: DVector<f64>,
    pub kkt: KktFactorization,
    /// Results of the last constrained solve: `q̈` (or `Δq̇` of an impact) and `λ`.
    pub qdd: DVector<f64>,
    pub lam: DVector<f64>,
    /// With a redundant contact set, the orthonormal basis `U_r` (c × r) of `A`'s range the
    /// KKT system was factored on ([`super::contact`]); `None` when `A` has full row rank.
    pub row_basis: Option<DMatrix<f64>>,
    /// The range-space factorizations, tried first: the limb elimination
    /// ([`super::limb_kkt`]) and the tree's `LᵀDL` ([`super::tree_kkt`]); the route the last
    /// solve took, and whether it was the range-space route by the limb elimination.
    pub limb_kkt: LimbKkt,
    pub tree_kkt: TreeKkt,
    pub kkt_route: KktRoute,
    pub limbs_eliminated: bool,
    /// Whether each joint's placement in its parent is a translation alone (its rotation the
    /// identity), fixed by the model.
    pub(crate) shift_only: Vec<bool>,
    /// Each joint's coordinate axis when it turns about `±e_k` (most URDF joints), fixed by
    /// the model ([`turned`]).
    pub(crate) axis_index: Vec<Option<CoordinateAxis>>,
    /// Each joint's place in a limb below a free-flying root, fixed by the model
    /// ([`limb_joints`]).
    pub(crate) limb_joints: Vec<Option<LimbJoint>>,
    /// Right-hand sides of the KKT solve.
    pub(crate) rhs_f: DVector<f64>,
    pub(crate) rhs_g: DVector<f64>,
}

impl SpatialData {
    pub fn new(model: &SpatialModel) -> Self {
        let (n, nv) = (model.joints.len(), model.nv);
        Self {
            oMi: vec![SE3::identity(); n],
            oS: Matrix6xX::zeros(nv),
            oI: vec![OriginInertia::default(); n],
            oIc: vec![OriginInertia::default(); n],
            ov: vec![Motion::zero(); n],
            oa_drift: vec![Motion::zero(); n],
            oa: vec![Motion::zero(); n],
            of: vec![Force::zero(); n],
            M: DMatrix::zeros(nv, nv),
            h: DVector::zeros(nv),
            J: Matrix6xX::zeros(nv),
            A: DMatrix::zeros(0, nv),
            A_drift: DVector::zeros(0),
            kkt: KktFactorization::default(),
            qdd: DVector::zeros(nv),
            lam: DVector::zeros(0),
            row_basis: None,
            limb_kkt: LimbKkt::new(model),
            tree_kkt: TreeKkt::new(model),
            kkt_route: KktRoute::RangeSpace,
            limbs_eliminated: false,
            shift_only: model
                .joints
                .iter()
                .map(|j| j.placement.rotation == nalgebra::Matrix3::identity())
                .collect(),
            axis_index: model
                .joints
                .iter()
                .map(|j| match j.kind {
                    JointKind::Revolute { axis } => coordinate_axis(&axis),
                    _ => None,
                })
                .collect(),
            limb_joints: limb_joints(model),
            rhs_f: DVector::zeros(nv),
            rhs_g: DVector::zeros(0),
        }
    }
}

/// A one-rate joint hanging from a free-flying root through `n_above ≤ 2` one-rate joints
/// (a leg's hip, thigh or knee): its rate, the rates of those joints, the root joint and its
/// first rate. Fixed when `SpatialData` is made ([`limb_joints`]); [`mass_columns`] then writes the
/// joint's column with constant bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct LimbJoint {
    pub(crate) rate: usize,
    pub(crate) above: [usize; 2],
    pub(crate) n_above: usize,
    pub(crate) root: usize,
    pub(crate) root_v: usize,
}

/// Each joint's [`LimbJoint`], `None` for the others (the root, a joint of several rates, a
/// joint deeper than three in its limb, a tree on a fixed base).
pub(crate) fn limb_joints(model: &SpatialModel) -> Vec<Option<LimbJoint>> {
    let limb_joint = |joint: &super::model::Joint| {
        if joint.kind.nv() != 1 {
            return None;
        }
        let (mut above, mut n_above) = ([0; 2], 0);
        let mut ancestor = joint.parent;
        while let Some(a) = ancestor {
            let aj = &model.joints[a];
            if aj.kind == JointKind::FreeFlyer {
                return aj.parent.is_none().then_some(LimbJoint {
                    rate: joint.idx_v,
                    above,
                    n_above,
                    root: a,
                    root_v: aj.idx_v,
                });
            }
            if aj.kind.nv() != 1 || n_above == above.len() {
                return None;
            }
            above[n_above] = aj.idx_v;
            n_above += 1;
            ancestor = aj.parent;
        }
        None
    };
    model.joints.iter().map(limb_joint).collect()
}

/// A free flyer's own transform `ʲ⁻Mⱼ(q)` (parent-side joint frame to body frame; Featherstone
/// 2008, Table 4.1): `q = [p, qx, qy, qz, qw]`. One-rate joints turn or shift in place
/// ([`turned`], [`place_joint`]).
fn free_flyer_transform(q: &[f64]) -> SE3 {
    let r = UnitQuaternion::new_normalize(quaternion_at(q, 3));
    SE3::from_quaternion(&r, Vector3::new(q[0], q[1], q[2]))
}

/// A planar joint's own transform: the shift `(x, 0, z)`, then the turn `θ` about `y`
/// (`q = [x, z, θ]`).
fn planar_transform(q: &[f64]) -> SE3 {
    let r = Rotation3::from_axis_angle(&Vector3::y_axis(), q[2]);
    SE3::new(*r.matrix(), Vector3::new(q[0], 0.0, q[1]))
}

/// A revolute joint's axis `±e_k`: `k` and the two columns `a = k + 1`, `b = k + 2` (mod 3)
/// a turn about it mixes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct CoordinateAxis {
    k: usize,
    a: usize,
    b: usize,
}

/// The [`CoordinateAxis`] of a unit `axis` that is a coordinate axis `±e_k`.
fn coordinate_axis(axis: &Vector3<f64>) -> Option<CoordinateAxis> {
    (0..3)
        .find(|&k| axis[k].abs() == 1.0)
        .map(|k| CoordinateAxis {
            k,
            a: (k + 1) % 3,
            b: (k + 2) % 3,
        })
}

/// `g R(axis, θ)`: `g` turned about the unit `axis` of its own frame by `θ`. A coordinate axis
/// `±e_k` (most URDF joints) mixes two columns of `g`'s rotation (Featherstone 2008, Table
/// 4.1's `rot`), any other axis takes Rodrigues' rotation matrix; `k`, the coordinate axis's
/// index, is fixed when `SpatialData` is made. With it, the turned frame's world axis
/// `R axis` is column `k` of its rotation times `±1` (the product's other terms are zeros).
fn turned(
    g: &SE3,
    axis: &Vector3<f64>,
    angle: f64,
    k: Option<CoordinateAxis>,
) -> (SE3, Vector3<f64>) {
    let Some(CoordinateAxis { k, a, b }) = k else {
        let r = Rotation3::from_axis_angle(&Unit::new_unchecked(*axis), angle);
        let rotation = g.rotation * r.matrix();
        return (SE3::new(rotation, g.translation), rotation * axis);
    };
    let (s, c) = (angle * axis[k]).sin_cos();
    let mut rotation = g.rotation;
    let (ra, rb) = (g.rotation.column(a), g.rotation.column(b));
    rotation.set_column(a, &(ra * c + rb * s));
    rotation.set_column(b, &(rb * c - ra * s));
    let w = g.rotation.column(k) * axis[k];
    (SE3::new(rotation, g.translation), w)
}

/// Forward kinematics (Featherstone 2008, §4.4): `⁰Mᵢ = ⁰M_λ(i) Xᵢ Mⱼ(qᵢ)`, the world motion
/// subspaces `⁰Sᵢ = Ad(⁰Mᵢ) Sᵢ` (a revolute joint's column `[p × ω; ω]`, `ω = ⁰Rᵢ axis`), and
/// the bodies' inertias at the world origin.
pub fn forward_kinematics(
    model: &SpatialModel,
    data: &mut SpatialData,
    q: &[f64],
) -> SpatialResult<()> {
    check_configuration(model, "q", q)?;
    kinematics_pass(model, data, q, None);
    Ok(())
}

/// Joint `i`'s placement, world motion columns and body inertia at the world origin
/// ([`forward_kinematics`]'s step, its parent's placement known).
fn place_joint(model: &SpatialModel, data: &mut SpatialData, i: usize, q: &[f64]) {
    let joint = &model.joints[i];
    let before = match joint.parent {
        // most URDF origins only shift (rpy = 0): `⁰M_λ X` keeps the parent's rotation
        Some(p) if data.shift_only[i] => {
            let g = &data.oMi[p];
            SE3::new(g.rotation, g.act_point(&joint.placement.translation))
        }
        Some(p) => data.oMi[p].compose(&joint.placement),
        None => joint.placement,
    };
    let qi = &q[joint.idx_q..];
    let col = &mut data.oS.as_mut_slice()[6 * joint.idx_v..];
    let oMi = match joint.kind {
        JointKind::FreeFlyer => {
            let oMi = before.compose(&free_flyer_transform(qi));
            col[..36].copy_from_slice(oMi.action_matrix().as_slice());
            oMi
        }
        JointKind::Revolute { axis } => {
            let (oMi, w) = turned(&before, &axis, qi[0], data.axis_index[i]);
            let v = oMi.translation.cross(&w);
            col[..6].copy_from_slice(&[v.x, v.y, v.z, w.x, w.y, w.z]);
            oMi
        }
        JointKind::Prismatic { axis } => {
            let u = before.rotation * axis;
            let oMi = SE3::new(before.rotation, before.translation + u * qi[0]);
            col[..6].copy_from_slice(&[u.x, u.y, u.z, 0.0, 0.0, 0.0]);
            oMi
        }
        JointKind::Planar => {
            // the joint frame's x and z (translations), then the turn about its y axis, which
            // the turn keeps: `[p × w; w]` at the body's origin `p`
            let oMi = before.compose(&planar_transform(qi));
            let r = &before.rotation;
            let (x, z, w) = (r.column(0), r.column(2), r.column(1));
            let v = oMi.translation.cross(&w);
            col[..18].copy_from_slice(&[
                x[0], x[1], x[2], 0.0, 0.0, 0.0, z[0], z[1], z[2], 0.0, 0.0, 0.0, v.x, v.y, v.z,
                w[0], w[1], w[2],
            ]);
            oMi
        }
    };
    data.oI[i] = OriginInertia::of_body(&model.inertias[i], &oMi);
    data.oMi[i] = oMi;
}

/// One forward sweep over the tree (inputs checked): each joint's [`place_joint`] and, with
/// rates `v`, its body's velocity and drift ([`forward_kinematics_velocity`]) at the same step.
fn kinematics_pass(model: &SpatialModel, data: &mut SpatialData, q: &[f64], v: Option<&[f64]>) {
    for (i, joint) in model.joints.iter().enumerate() {
        place_joint(model, data, i, q);
        let Some(v) = v else { continue };
        let vj = joint_motion(model, data, i, v);
        let (vp, ap) = match joint.parent {
            Some(p) => (data.ov[p], data.oa_drift[p]),
            None => (Motion::zero(), Motion::zero()),
        };
        data.ov[i] = vp + vj;
        // `d/dt(⁰Sᵢ) q̇ᵢ`: `⁰vᵢ × vj` for columns fixed in the joint's body (Featherstone
        // 2008, (5.7)), every joint's but a planar one's
        let column_drift = match joint.kind {
            JointKind::Planar => planar_column_drift(data, i, joint.idx_v, vp, vj, v),
            _ => data.ov[i].cross(&vj),
        };
        data.oa_drift[i] = ap + column_drift;
    }
}

/// `d/dt(⁰Sᵢ) q̇ᵢ` of the planar joint `i` (first rate `iv`) with world motion `vj = ⁰Sᵢ q̇ᵢ`
/// and parent velocity `vp`: its translation columns are fixed in the parent body,
/// `vp × ⁰S_t q̇_t`, and only its turn's column moves with its own body, `⁰vᵢ × ⁰S_θ θ̇`.
#[cold]
fn planar_column_drift(
    data: &SpatialData,
    i: usize,
    iv: usize,
    vp: Motion,
    vj: Motion,
    v: &[f64],
) -> Motion {
    let c = iv + 2;
    let s = &data.oS.as_slice()[6 * c..6 * c + 6];
    let turn = Motion::new(
        Vector3::new(s[0], s[1], s[2]) * v[c],
        Vector3::new(s[3], s[4], s[5]) * v[c],
    );
    vp.cross(&(vj - turn)) + data.ov[i].cross(&turn)
}

/// The joint's world motion `⁰Sᵢ q̇ᵢ` for the rates `x` (length nv).
#[inline]
pub(crate) fn joint_motion(
    model: &SpatialModel,
    data: &SpatialData,
    i: usize,
    x: &[f64],
) -> Motion {
    let j = &model.joints[i];
    let s = &data.oS.as_slice()[6 * j.idx_v..];
    if j.kind.nv() == 1 {
        // one rate (every joint below a free-flying root): ⁰Sᵢ q̇ᵢ
        let x = x[j.idx_v];
        return Motion::new(
            Vector3::new(s[0] * x, s[1] * x, s[2] * x),
            Vector3::new(s[3] * x, s[4] * x, s[5] * x),
        );
    }
    let mut m = [0.0; 6];
    for (k, &xk) in x[j.idx_v..j.idx_v + j.kind.nv()].iter().enumerate() {
        for (mr, sr) in m.iter_mut().zip(&s[6 * k..6 * k + 6]) {
            *mr += sr * xk;
        }
    }
    Motion::new(
        Vector3::new(m[0], m[1], m[2]),
        Vector3::new(m[3], m[4], m[5]),
    )
}

/// [`forward_kinematics`] and the first- and second-order velocity terms: body velocities
/// `⁰vᵢ = ⁰v_λ(i) + ⁰Sᵢ q̇ᵢ` and the accelerations at `q̈ = 0`,
/// `⁰aᵢ = ⁰a_λ(i) + ⁰vᵢ × ⁰Sᵢ q̇ᵢ` (Featherstone 2008, (5.7) in world coordinates, where
/// `d/dt ⁰Sᵢ = ⁰vᵢ × ⁰Sᵢ`; a planar joint's translations, fixed in its parent, give
/// `⁰v_λ(i) × ⁰S_t q̇_t` instead).
pub fn forward_kinematics_velocity(
    model: &SpatialModel,
    data: &mut SpatialData,
    q: &[f64],
    v: &[f64],
) -> SpatialResult<()> {
    check_configuration(model, "q", q)?;
    crate::error::check_vector("v", v, model.nv)?;
    kinematics_pass(model, data, q, Some(v));
    Ok(())
}

/// The placement `⁰M_f` of frame `frame` (after [`forward_kinematics`]).
pub fn frame_placement(model: &SpatialModel, data: &SpatialData, frame: usize) -> SE3 {
    let f = &model.frames[frame];
    match f.joint {
        Some(j) => data.oMi[j].compose(&f.placement),
        None => f.placement,
    }
}

/// The 6 × nv Jacobian of frame `frame` in `reference` into `data.J` (after
/// [`forward_kinematics`]): the world columns `⁰Sⱼ` of the joints supporting the frame
/// (Featherstone 2008, (8.4)), then moved to the frame: `Local` by `Ad(⁰M_f)⁻¹`,
/// `LocalWorldAligned` by shifting the point to the frame origin `p`: `v_p = v − p × ω`.
pub fn frame_jacobian(
    model: &SpatialModel,
    data: &mut SpatialData,
    frame: usize,
    reference: ReferenceFrame,
) {
    data.J.fill(0.0);
    let joint = model.frames[frame].joint;
    let oMf = frame_placement(model, data, frame);
    let mut j = joint;
    while let Some(i) = j {
        let jt = &model.joints[i];
        for c in jt.idx_v..jt.idx_v + jt.kind.nv() {
            let world = Motion::from_vector(&data.oS.column(c).into_owned());
            let col = match reference {
                ReferenceFrame::World => world,
                ReferenceFrame::Local => oMf.act_inv_motion(&world),
                ReferenceFrame::LocalWorldAligned => Motion::new(
                    world.linear - oMf.translation.cross(&world.angular),
                    world.angular,
                ),
            };
            data.J.column_mut(c).copy_from(&col.to_vector());
        }
        j = jt.parent;
    }
}

/// The origin of frame `frame` in the world (after [`forward_kinematics`]): the translation
/// of [`frame_placement`] without its rotation.
pub fn frame_origin(model: &SpatialModel, data: &SpatialData, frame: usize) -> Vector3<f64> {
    let f = &model.frames[frame];
    match f.joint {
        Some(j) => data.oMi[j].act_point(&f.placement.translation),
        None => f.placement.translation,
    }
}

/// The classical acceleration of frame `frame`'s origin at `q̈ = 0` (world axes), after
/// [`forward_kinematics_velocity`]: `a_p = a + α × p + ω × v_p` from the body's spatial
/// drift `(a, α)` and velocity `(v, ω)` at the world origin, `v_p = v + ω × p`
/// (Featherstone 2008, (2.45)). This is `J̇ q̇` of the frame's linear rows.
pub fn frame_linear_drift(model: &SpatialModel, data: &SpatialData, frame: usize) -> Vector3<f64> {
    let Some(j) = model.frames[frame].joint else {
        return Vector3::zeros();
    };
    point_linear_drift(data, j, &frame_origin(model, data, frame))
}

/// [`frame_linear_drift`] of the material point `p` (world) of joint `j`'s body.
pub(crate) fn point_linear_drift(data: &SpatialData, j: usize, p: &Vector3<f64>) -> Vector3<f64> {
    let (v, a) = (data.ov[j], data.oa_drift[j]);
    let vp = v.linear + v.angular.cross(p);
    a.linear + a.angular.cross(p) + v.angular.cross(&vp)
}

/// The classical velocity of frame `frame`'s origin (world axes).
pub fn frame_linear_velocity(
    model: &SpatialModel,
    data: &SpatialData,
    frame: usize,
) -> Vector3<f64> {
    let Some(j) = model.frames[frame].joint else {
        return Vector3::zeros();
    };
    let p = frame_origin(model, data, frame);
    data.ov[j].linear + data.ov[j].angular.cross(&p)
}
