//! The sweeps under the spatial forward dynamics against second formulations: `M` of the
//! one backward sweep (a free flyer's columns by its adjoint, one-rate ancestors by their
//! columns) against `Σᵢ Jᵢᵀ Yᵢ Jᵢ` of the bodies' own Jacobians and inertias; the fused
//! kinematics pass against the position pass and finite differences of the placements; the
//! rows of a flat z-up ground against the general tangent construction.
mod spatial_support;
use nalgebra::{DMatrix, Vector3};
use selfmanip_core::spatial::kinematics::{
    forward_kinematics, forward_kinematics_velocity, frame_jacobian, ReferenceFrame,
};
use selfmanip_core::spatial::model::FrameKind;
use selfmanip_core::spatial::rigid_body::crba;
use selfmanip_core::spatial::*;
use spatial_support::*;

/// A branching tree of five joints: a revolute joint about z, then one about the oblique
/// axis (0.6, 0.8, 0) to a massless link, a prismatic joint along x; and a branch off the
/// first link about y, then a revolute joint about −x.
const BRANCHING: &str = r#"<robot name="branching">
  <link name="base"><inertial><origin xyz="0.01 0.02 -0.03" rpy="0.1 0.2 0.3"/><mass value="3.0"/>
    <inertia ixx="0.05" ixy="0.001" ixz="0" iyy="0.06" iyz="0.002" izz="0.07"/></inertial></link>
  <link name="l1"><inertial><origin xyz="0.1 0 0.05" rpy="0 0 0"/><mass value="1.2"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.015"/></inertial></link>
  <link name="l2"/>
  <link name="l3"><inertial><origin xyz="0.05 0.02 0" rpy="0.4 0 -0.2"/><mass value="0.7"/>
    <inertia ixx="0.003" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.005"/></inertial></link>
  <link name="l4"><inertial><origin xyz="0 0.1 0" rpy="0 0 0"/><mass value="0.9"/>
    <inertia ixx="0.004" ixy="0" ixz="0.0005" iyy="0.003" iyz="0" izz="0.006"/></inertial></link>
  <link name="l5"><inertial><origin xyz="0 0 -0.12" rpy="0 0 0"/><mass value="0.4"/>
    <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.001"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0.2 0.1 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit effort="1" velocity="1" lower="-3" upper="3"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0" rpy="0.2 0 0"/><axis xyz="0.6 0.8 0"/><limit effort="1" velocity="1" lower="-3" upper="3"/></joint>
  <joint name="j3" type="prismatic"><parent link="l2"/><child link="l3"/>
    <origin xyz="0 0 0.1" rpy="0 0.3 0"/><axis xyz="1 0 0"/><limit effort="1" velocity="1" lower="-1" upper="1"/></joint>
  <joint name="j4" type="revolute"><parent link="l1"/><child link="l4"/>
    <origin xyz="0 0.2 0" rpy="0 0 0.5"/><axis xyz="0 1 0"/><limit effort="1" velocity="1" lower="-3" upper="3"/></joint>
  <joint name="j5" type="revolute"><parent link="l4"/><child link="l5"/>
    <origin xyz="0 0.1 -0.2" rpy="0 0 0"/><axis xyz="-1 0 0"/><limit effort="1" velocity="1" lower="-3" upper="3"/></joint>
</robot>"#;

/// `M = Σᵢ Jᵢᵀ Yᵢ Jᵢ` with `Jᵢ` the local Jacobian of joint `i`'s body frame and `Yᵢ` its
/// inertia's 6 × 6 matrix in that frame: the kinetic energy `½ Σᵢ vᵢᵀ Yᵢ vᵢ` summed body by
/// body, with no composite inertia and no world-frame transform.
fn mass_matrix_by_bodies(model: &SpatialModel, data: &mut SpatialData) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(model.nv, model.nv);
    for (i, inertia) in model.inertias.iter().enumerate() {
        let frame = model
            .frames
            .iter()
            .position(|f| f.kind == FrameKind::Body && f.joint == Some(i))
            .expect("each joint carries a body frame");
        assert_eq!(
            model.frames[frame].placement.max_abs_diff(&SE3::identity()),
            0.0,
            "a body frame is its joint's frame"
        );
        frame_jacobian(model, data, frame, ReferenceFrame::Local);
        let j = DMatrix::from_column_slice(6, model.nv, data.J.as_slice());
        m += j.transpose() * inertia.matrix() * &j;
    }
    m
}

/// `M` of the backward sweep (through `forward_dynamics`'s preparation and `crba`) equals
/// the sum over bodies on the quadruped (a free flyer above every leg), the branching tree
/// on a free-flying and on a fixed base (oblique axis, prismatic joint, massless link), at
/// random states.
#[test]
fn mass_matrix_is_the_sum_over_bodies() {
    let mut rng = rng(16);
    let models = [
        quadruped(),
        quadruped_massless_shins(),
        SpatialModel::from_urdf_str(BRANCHING, BaseKind::FreeFlyer, None).unwrap(),
        SpatialModel::from_urdf_str(BRANCHING, BaseKind::Fixed, None).unwrap(),
    ];
    for model in &models {
        let mut data = SpatialData::new(model);
        for _ in 0..5 {
            let q = match model.nq == model.nv {
                true => random_vector(model.nq, 1.5, &mut rng),
                false => random_q(model, &mut rng),
            };
            crba(model, &mut data, q.as_slice()).unwrap();
            let by_sweep = data.M.clone();
            let by_bodies = mass_matrix_by_bodies(model, &mut data);
            let scale = by_bodies.amax().max(1.0);
            assert!(
                (&by_sweep - &by_bodies).amax() < 1e-13 * scale,
                "{}: M off by {:.2e}",
                model.name,
                (&by_sweep - &by_bodies).amax()
            );
            assert_eq!(by_sweep, by_sweep.transpose(), "M is symmetric to the bit");
        }
    }
}

/// The fused pass gives the position pass's placements to the bit, and the bodies'
/// velocities are the placements' rates: `Ad(⁰Mᵢ)⁻¹ ⁰vᵢ` against a central difference of
/// `⁰Mᵢ` along `q ⊕ v t` (the body twist `(Rᵀ Ṙ)ˇ`, `Rᵀ ṗ`), on the branching tree with a
/// free-flying base.
#[test]
fn fused_pass_matches_positions_and_their_rates() {
    let model = SpatialModel::from_urdf_str(BRANCHING, BaseKind::FreeFlyer, None).unwrap();
    let mut rng = rng(17);
    let (q, v) = (
        random_q(&model, &mut rng),
        random_vector(model.nv, 1.0, &mut rng),
    );
    let mut data = SpatialData::new(&model);
    let mut positions = SpatialData::new(&model);
    forward_kinematics_velocity(&model, &mut data, q.as_slice(), v.as_slice()).unwrap();
    forward_kinematics(&model, &mut positions, q.as_slice()).unwrap();
    assert_eq!(data.oMi, positions.oMi);
    assert_eq!(data.oS, positions.oS);
    assert_eq!(data.oI, positions.oI);
    let dt = 1e-6;
    let at = |t: f64| {
        let qt = integrate(&model, q.as_slice(), (&v * t).as_slice()).unwrap();
        let mut d = SpatialData::new(&model);
        forward_kinematics(&model, &mut d, qt.as_slice()).unwrap();
        d.oMi
    };
    let (plus, minus) = (at(dt), at(-dt));
    for i in 0..model.joints.len() {
        let g = &data.oMi[i];
        let r_dot = (plus[i].rotation - minus[i].rotation) / (2.0 * dt);
        let p_dot = (plus[i].translation - minus[i].translation) / (2.0 * dt);
        let w = g.rotation.transpose() * r_dot;
        let body = g.act_inv_motion(&data.ov[i]);
        let by_difference = Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
        assert!((body.angular - by_difference).norm() < 1e-8, "joint {i} ω");
        assert!(
            (body.linear - g.rotation.transpose() * p_dot).norm() < 1e-8,
            "joint {i} v"
        );
    }
}

/// On flat z-up ground the rows are world `x, y, z`, and a normal tilted by a small angle
/// gives rows within that angle of them (the general construction is continuous there).
#[test]
fn flat_ground_rows_are_the_world_axes() {
    let model = quadruped();
    let flat = PointContact::new(&model, "FL_foot", true).unwrap();
    assert_eq!(
        flat.directions(),
        [Vector3::x(), Vector3::y(), Vector3::z()]
    );
    for tilt in [1e-3, 1e-7] {
        let n = Vector3::new(tilt, -0.5 * tilt, 1.0);
        let tilted = PointContact::with_normal(&model, "FL_foot", true, n).unwrap();
        for (a, b) in tilted.directions().iter().zip(flat.directions().iter()) {
            assert!((a - b).norm() < 2.0 * tilt, "tilt {tilt}: {a} vs {b}");
            assert!((a.norm() - 1.0).abs() < 1e-15);
        }
    }
    let frictionless = PointContact::new(&model, "FL_foot", false).unwrap();
    assert_eq!(frictionless.directions()[0], Vector3::z());
}

/// Each contact's rows of `A` are its directions on the point's world linear Jacobian
/// (`frame_jacobian`, local-world-aligned, a second formulation): for feet with friction on
/// flat z-up ground (the rows are then `J_p`'s own entries, no products) and for the general
/// route's directions — a tilted normal with friction, a frictionless foot, a foot held in a
/// plane — at random states of the quadruped and of its massless-shin variant.
#[test]
fn contact_rows_are_directions_on_the_point_jacobian() {
    let mut rng = rng(18);
    for model in [quadruped(), quadruped_massless_shins()] {
        let tilted = Vector3::new(0.3, -0.2, 1.0);
        let contacts = vec![
            PointContact::new(&model, "FL_foot", true).unwrap(),
            PointContact::new(&model, "FR_foot", true).unwrap(),
            PointContact::with_normal(&model, "HL_foot", true, tilted).unwrap(),
            PointContact::new(&model, "HR_foot", false).unwrap(),
        ];
        let in_plane = PointContact::new(&model, "HR_foot", true)
            .unwrap()
            .in_plane(Vector3::x())
            .unwrap();
        for set in [contacts.clone(), vec![contacts[0].clone(), in_plane]] {
            let mut data = SpatialData::new(&model);
            let (q, v, tau) = random_state(&model, &mut rng);
            // the rows are formed before the solve, which massless shins on two feet refuse
            let solved = dynamics_at(&model, &mut data, &set, (&q, &v, &tau));
            assert!(solved.is_ok() || set.len() == 2, "{solved:?}");
            let a = data.A.clone();
            let mut row = 0;
            for contact in &set {
                frame_jacobian(
                    &model,
                    &mut data,
                    contact.frame,
                    ReferenceFrame::LocalWorldAligned,
                );
                let jp = data.J.fixed_rows::<3>(0).into_owned();
                for d in &contact.directions()[..contact.n_rows()] {
                    let expected = d.transpose() * &jp;
                    let off = (a.row(row) - &expected).amax();
                    assert!(
                        off < 1e-12 * expected.amax().max(1.0),
                        "row {row}: off {off:.2e}"
                    );
                    row += 1;
                }
            }
            assert_eq!(row, a.nrows());
        }
    }
}
