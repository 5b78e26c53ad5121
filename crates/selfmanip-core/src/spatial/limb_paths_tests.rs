//! The constant-size paths fixed when `SpatialData` is made against the general routes they
//! stand in for: a limb joint's column of `M` ([`super::kinematics::LimbJoint`]) against the
//! ancestor walk, bit for bit, and a coordinate axis's turn and world axis
//! ([`super::kinematics`]'s `CoordinateAxis`) against Rodrigues' rotation and `R axis` — on
//! the quadruped (every joint on a path) and on a robot where most are not (a four-joint
//! limb, a prismatic joint, an oblique axis, a massless link, a rotated joint origin, a fixed
//! base).
use super::kinematics::{forward_kinematics_velocity, SpatialData};
use super::liegroup::neutral;
use super::model::{BaseKind, JointKind, SpatialModel};
use super::rigid_body::mass_matrix_and_bias_from_kinematics;
use nalgebra::{DVector, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A link `name` of mass `mass` (none when 0) at `com` with principal inertias `inertia`.
fn link(name: &str, mass: f64, com: [f64; 3], inertia: [f64; 3]) -> String {
    if mass == 0.0 {
        return format!(r#"<link name="{name}"/>"#);
    }
    let [x, y, z] = com;
    let [ixx, iyy, izz] = inertia;
    format!(
        r#"<link name="{name}"><inertial><origin xyz="{x} {y} {z}"/><mass value="{mass}"/>
        <inertia ixx="{ixx}" ixy="0.0001" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/></inertial></link>"#
    )
}

/// A joint `name` of `kind` from `parent` to `child` at `xyz`, `rpy` about `axis`.
fn joint(
    name: &str,
    kind: &str,
    [parent, child]: [&str; 2],
    xyz: &str,
    rpy: &str,
    axis: &str,
) -> String {
    format!(
        r#"<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>
        <origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>
        <limit effort="1" velocity="1" lower="-3" upper="3"/></joint>"#
    )
}

/// A body with three limbs: four revolute joints in a chain (about x, −y, y, z), a prismatic
/// joint along z then an oblique revolute joint (0, 0.6, 0.8) to a massless link and a joint
/// about x, and one joint about −z whose origin is rotated.
fn limbs() -> String {
    let links = [
        link("body", 4.0, [0.02, -0.01, 0.03], [0.05, 0.08, 0.09]),
        link("a1", 0.5, [0.0, 0.02, 0.0], [0.001, 0.002, 0.001]),
        link("a2", 0.8, [0.01, 0.0, -0.1], [0.004, 0.004, 0.001]),
        link("a3", 0.3, [0.0, 0.0, -0.1], [0.002, 0.002, 0.0002]),
        link("a4", 0.1, [0.03, 0.0, -0.02], [0.0001, 0.0002, 0.0001]),
        link("b1", 0.6, [0.0, 0.0, -0.05], [0.002, 0.002, 0.001]),
        link("b2", 0.0, [0.0; 3], [0.0; 3]),
        link("b3", 0.2, [0.0, 0.04, -0.05], [0.0003, 0.0002, 0.0001]),
        link("c1", 0.4, [0.05, 0.0, 0.0], [0.001, 0.001, 0.001]),
    ];
    let joints = [
        joint(
            "a_hip",
            "revolute",
            ["body", "a1"],
            "0.2 0.1 0",
            "0 0 0",
            "1 0 0",
        ),
        joint(
            "a_thigh",
            "revolute",
            ["a1", "a2"],
            "0 0.05 0",
            "0 0 0",
            "0 -1 0",
        ),
        joint(
            "a_knee",
            "revolute",
            ["a2", "a3"],
            "0 0 -0.2",
            "0 0 0",
            "0 1 0",
        ),
        joint(
            "a_ankle",
            "revolute",
            ["a3", "a4"],
            "0 0 -0.2",
            "0 0 0",
            "0 0 1",
        ),
        joint(
            "b_slide",
            "prismatic",
            ["body", "b1"],
            "-0.2 0 0",
            "0 0 0",
            "0 0 1",
        ),
        joint(
            "b_turn",
            "revolute",
            ["b1", "b2"],
            "0 0 -0.1",
            "0 0 0",
            "0 0.6 0.8",
        ),
        joint(
            "b_end",
            "revolute",
            ["b2", "b3"],
            "0 0 -0.1",
            "0 0 0",
            "1 0 0",
        ),
        joint(
            "c_hip",
            "revolute",
            ["body", "c1"],
            "0 -0.2 0",
            "0.3 -0.2 0.1",
            "0 0 -1",
        ),
    ];
    format!(
        r#"<robot name="limbs">{}{}</robot>"#,
        links.concat(),
        joints.concat()
    )
}

const QUADRUPED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/urdf/quadruped12.urdf"
);

/// The quadruped and [`limbs`] on a free-flying and on a fixed base.
fn models() -> Vec<SpatialModel> {
    vec![
        SpatialModel::from_urdf_file(QUADRUPED, BaseKind::FreeFlyer, None).unwrap(),
        SpatialModel::from_urdf_str(&limbs(), BaseKind::FreeFlyer, None).unwrap(),
        SpatialModel::from_urdf_str(&limbs(), BaseKind::Fixed, None).unwrap(),
    ]
}

/// A random configuration and rates of `model`.
fn random_state(model: &SpatialModel, rng: &mut ChaCha8Rng) -> (DVector<f64>, DVector<f64>) {
    let mut q = neutral(model);
    for x in q.iter_mut() {
        *x = rng.gen_range(-1.5..1.5);
    }
    if model.joints[0].kind == JointKind::FreeFlyer {
        let axis = Vector3::from_fn(|_, _| rng.gen_range(-1.0..1.0));
        let r = UnitQuaternion::from_scaled_axis(axis * 2.0);
        q.as_mut_slice()[3..7].copy_from_slice(&[r.i, r.j, r.k, r.w]);
    }
    let v = DVector::from_fn(model.nv, |_, _| rng.gen_range(-2.0..2.0));
    (q, v)
}

/// `M` and `h` by the backward sweep into `data`.
fn sweep(model: &SpatialModel, data: &mut SpatialData, q: &DVector<f64>, v: &DVector<f64>) {
    forward_kinematics_velocity(model, data, q.as_slice(), v.as_slice()).unwrap();
    mass_matrix_and_bias_from_kinematics(model, data);
}

/// A limb joint's column of `M` by constant bounds equals the ancestor walk's to the bit;
/// the quadruped's twelve joints take the path, [`limbs`] seven (any one-rate joint within
/// three of the free-flying root: the prismatic and oblique ones too, not the four-joint
/// limb's ankle), none on a fixed base.
#[test]
fn limb_columns_match_the_ancestor_walk() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let on_path = [12, 7, 0];
    for (model, expected) in models().iter().zip(on_path) {
        let mut fixed = SpatialData::new(model);
        let mut general = SpatialData::new(model);
        general.limb_joints.iter_mut().for_each(|l| *l = None);
        let taken = fixed.limb_joints.iter().filter(|l| l.is_some()).count();
        assert_eq!(taken, expected, "{}: joints on the path", model.name);
        for _ in 0..4 {
            let (q, v) = random_state(model, &mut rng);
            sweep(model, &mut fixed, &q, &v);
            sweep(model, &mut general, &q, &v);
            assert_eq!(fixed.M, general.M, "{}: M", model.name);
            assert_eq!(fixed.h, general.h, "{}: h", model.name);
        }
    }
}

/// A turn about a coordinate axis `±e_k` mixes two columns of the parent's rotation and
/// takes its world axis as `±` column `k`: the world axis equals `R axis` exactly, and the
/// placements, world columns and `M` equal Rodrigues' route (every joint's `CoordinateAxis`
/// removed) to 1e-12; the oblique and prismatic joints of [`limbs`] take the general route
/// in both.
#[test]
fn coordinate_axes_match_rodrigues() {
    let mut rng = ChaCha8Rng::seed_from_u64(29);
    for model in &models() {
        let mut fixed = SpatialData::new(model);
        let mut general = SpatialData::new(model);
        general.axis_index.iter_mut().for_each(|k| *k = None);
        let oblique = model
            .joints
            .iter()
            .zip(&fixed.axis_index)
            .any(|(j, k)| matches!(j.kind, JointKind::Revolute { .. }) && k.is_none());
        assert_eq!(oblique, model.name == "limbs", "{}", model.name);
        for _ in 0..4 {
            let (q, v) = random_state(model, &mut rng);
            sweep(model, &mut fixed, &q, &v);
            sweep(model, &mut general, &q, &v);
            for (i, joint) in model.joints.iter().enumerate() {
                if let JointKind::Revolute { axis } = joint.kind {
                    let w = fixed.oS.fixed_view::<3, 1>(3, joint.idx_v).into_owned();
                    assert_eq!(
                        w,
                        fixed.oMi[i].rotation * axis,
                        "{}: {}",
                        model.name,
                        joint.name
                    );
                }
                assert!(fixed.oMi[i].max_abs_diff(&general.oMi[i]) < 1e-12);
            }
            assert!((&fixed.oS - &general.oS).amax() < 1e-12, "{}", model.name);
            let scale = general.M.amax().max(1.0);
            assert!(
                (&fixed.M - &general.M).amax() < 1e-12 * scale,
                "{}",
                model.name
            );
            assert!((&fixed.h - &general.h).amax() < 1e-12 * general.h.amax().max(1.0));
        }
    }
}
