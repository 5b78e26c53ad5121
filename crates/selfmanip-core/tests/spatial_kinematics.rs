//! Frame Jacobians against central finite differences of the frame placements along
//! `q ⊕ εv`, in all three reference frames, and the contact drift `Ȧq̇` against differences of
//! the frame's velocity.
mod spatial_support;
use nalgebra::{DVector, Vector6};
use rand_chacha::ChaCha8Rng;
use selfmanip_core::spatial::explog::log6;
use selfmanip_core::spatial::kinematics::*;
use selfmanip_core::spatial::*;
use spatial_support::*;

/// `check(q, v, f)` for each frame `f` of `frames` at `n` random motions `(q, v)`, rates
/// within `scale` (`(n, scale)`).
fn each_frame_at_random_motions(
    model: &SpatialModel,
    rng: &mut ChaCha8Rng,
    (n, scale): (usize, f64),
    frames: &[&str],
    mut check: impl FnMut(&DVector<f64>, &DVector<f64>, usize),
) {
    for _ in 0..n {
        let (q, v) = random_motion(model, scale, rng);
        for name in frames {
            check(&q, &v, model.frame_id(name).unwrap());
        }
    }
}

#[test]
fn jacobians_match_finite_differences_of_placements() {
    let (model, mut data, mut rng) = setup(quadruped(), 6);
    let frames = [
        "FL_foot",
        "HR_foot",
        "FR_thigh",
        "imu",
        "trunk",
        "HL_knee",
        "FL_foot_fixed",
    ];
    let eps = 1e-5;
    let mut worst = [0.0f64; 3];
    each_frame_at_random_motions(&model, &mut rng, (20, 1.0), &frames, |q, v, f| {
        let mut place = |s: f64| {
            forward_kinematics(&model, &mut data, along(&model, q, v, s).as_slice()).unwrap();
            frame_placement(&model, &data, f)
        };
        let (m0, mp, mm) = (place(0.0), place(eps), place(-eps));
        let local = (log6(&m0.inverse_compose(&mp)).to_vector()
            - log6(&m0.inverse_compose(&mm)).to_vector())
            / (2.0 * eps);
        let world = (log6(&mp.compose(&m0.inverse())).to_vector()
            - log6(&mm.compose(&m0.inverse())).to_vector())
            / (2.0 * eps);
        let mut aligned = Vector6::zeros();
        aligned
            .fixed_rows_mut::<3>(0)
            .copy_from(&((mp.translation - mm.translation) / (2.0 * eps)));
        aligned
            .fixed_rows_mut::<3>(3)
            .copy_from(&world.fixed_rows::<3>(3));
        forward_kinematics(&model, &mut data, q.as_slice()).unwrap();
        for (k, (reference, fd)) in [
            (ReferenceFrame::Local, local),
            (ReferenceFrame::World, world),
            (ReferenceFrame::LocalWorldAligned, aligned),
        ]
        .into_iter()
        .enumerate()
        {
            frame_jacobian(&model, &mut data, f, reference);
            worst[k] = worst[k].max((&data.J * v - fd).amax());
        }
    });
    assert_worst(
        "|J v − finite difference|:",
        &["local", "world", "local_world_aligned"],
        &worst,
        1e-8,
    );
}

/// The classical acceleration of a frame origin at `q̈ = 0` is `d/dt (J_lin v)` along
/// `(q ⊕ tv, v)`, by central differences of the frame velocity.
#[test]
fn frame_drift_is_the_derivative_of_the_velocity() {
    let (model, mut data, mut rng) = setup(quadruped(), 7);
    let eps = 1e-5;
    let mut worst = 0.0f64;
    each_frame_at_random_motions(&model, &mut rng, (20, 2.0), &FEET, |q, v, f| {
        let mut vel = |s: f64| {
            let qs = along(&model, q, v, s);
            forward_kinematics_velocity(&model, &mut data, qs.as_slice(), v.as_slice()).unwrap();
            frame_linear_velocity(&model, &data, f)
        };
        let fd = (vel(eps) - vel(-eps)) / (2.0 * eps);
        forward_kinematics_velocity(&model, &mut data, q.as_slice(), v.as_slice()).unwrap();
        worst = worst.max((frame_linear_drift(&model, &data, f) - fd).amax());
    });
    eprintln!("|drift − d/dt v_frame| {worst:.2e}");
    assert!(worst < 1e-7, "{worst}");
}

/// `tests/data/urdf/tilted_arm.urdf`: a free-flying body with an arm of a revolute joint about
/// a tilted axis, one about a negative coordinate axis and a prismatic joint along a negative
/// axis: every kind of joint transform of the forward kinematics (a coordinate axis mixes two
/// columns, any other takes Rodrigues' matrix).
const TILTED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/urdf/tilted_arm.urdf"
);

/// On [`TILTED`] at random states: each joint placement equals the composition
/// `⁰M_λ Xᵢ Mⱼ(qᵢ)` with nalgebra's axis–angle rotation, and `½ vᵀ M v` equals the bodies'
/// kinetic energy from central differences of their placements along `q ⊕ εv` with each
/// body's inertia moved to the world (`Inertia::transformed`), a route that shares neither the
/// motion subspaces nor the origin-form inertias of the CRBA.
#[test]
fn tilted_negative_and_prismatic_axes_match_composition_and_energy() {
    let (model, mut data, mut rng) = setup(
        SpatialModel::from_urdf_file(TILTED, BaseKind::FreeFlyer, None).unwrap(),
        32,
    );
    let eps = 1e-6;
    for _ in 0..10 {
        let (q, v) = random_motion(&model, 1.0, &mut rng);
        forward_kinematics(&model, &mut data, q.as_slice()).unwrap();
        let o_mi = data.oMi.clone();
        for (i, joint) in model.joints.iter().enumerate().skip(1) {
            let qi = q[joint.idx_q];
            let local = match joint.kind {
                JointKind::Revolute { axis } => {
                    let r = nalgebra::Rotation3::from_axis_angle(
                        &nalgebra::Unit::new_normalize(axis),
                        qi,
                    );
                    SE3::new(*r.matrix(), nalgebra::Vector3::zeros())
                }
                JointKind::Prismatic { axis } => SE3::new(nalgebra::Matrix3::identity(), axis * qi),
                JointKind::FreeFlyer | JointKind::Planar => unreachable!("the root only"),
            };
            let expected = o_mi[joint.parent.unwrap()]
                .compose(&joint.placement)
                .compose(&local);
            assert!(o_mi[i].max_abs_diff(&expected) < 1e-14, "joint {i}");
        }
        rigid_body::crba(&model, &mut data, q.as_slice()).unwrap();
        let by_m = 0.5 * v.dot(&(&data.M * &v));
        let mut place = |s: f64| {
            forward_kinematics(&model, &mut data, along(&model, &q, &v, s).as_slice()).unwrap();
            data.oMi.clone()
        };
        let (mp, mm) = (place(eps), place(-eps));
        let by_bodies: f64 = (0..model.joints.len())
            .map(|i| {
                let (g, r_dot, p_dot) = (
                    &o_mi[i],
                    (mp[i].rotation - mm[i].rotation) / (2.0 * eps),
                    (mp[i].translation - mm[i].translation) / (2.0 * eps),
                );
                let w = r_dot * g.rotation.transpose();
                let w = nalgebra::Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
                let twist = Motion::new(p_dot - w.cross(&g.translation), w);
                0.5 * twist.dot(&model.inertias[i].transformed(g).apply(&twist))
            })
            .sum();
        assert!(
            (by_m - by_bodies).abs() < 1e-8 * by_m.max(1.0),
            "{by_m} against {by_bodies}"
        );
    }
}
