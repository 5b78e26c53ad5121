//! A URDF `continuous` joint: one coordinate `θ` here, `(cos θ, sin θ)` in Pinocchio's layout.
//! The converters are checked against the joint's geometry (the wheel frame turned by `θ`
//! about its axis, a closed form) and against each other; Pinocchio itself is the route of
//! `python/tests/test_spatial_continuous.py`.
use nalgebra::{Rotation3, Unit, Vector3};
use selfmanip_core::spatial::kinematics::{forward_kinematics, frame_placement};
use selfmanip_core::spatial::*;

/// `tests/data/urdf/cart_continuous.urdf`: a free-flying cart with a revolute arm (axis z), a
/// continuous joint on the arm (axis x) and a continuous wheel (axis y), siblings in name
/// order (Pinocchio's).
pub const CART: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/urdf/cart_continuous.urdf"
);

fn cart() -> SpatialModel {
    SpatialModel::from_urdf_file(CART, BaseKind::FreeFlyer, None).unwrap()
}

#[test]
fn continuous_joints_are_cos_sin_pairs_in_pinocchio_layout() {
    let model = cart();
    assert_eq!((model.nq, model.nv), (10, 9));
    assert_eq!(pinocchio_nq(&model), 12);
    let mut q = neutral(&model);
    q.as_mut_slice()[0..7].copy_from_slice(&[0.1, -0.2, 0.3, 0.0, 0.0, 0.6f64.sin(), 0.6f64.cos()]);
    let (arm, tip, wheel) = (-0.7, -3.0, 2.5);
    q.as_mut_slice()[7..].copy_from_slice(&[arm, tip, wheel]);
    let p = to_pinocchio(&model, q.as_slice()).unwrap();
    let expected = [
        &q.as_slice()[..7],
        &[arm, tip.cos(), tip.sin(), wheel.cos(), wheel.sin()][..],
    ]
    .concat();
    assert_eq!(p.as_slice(), expected.as_slice());
    let back = from_pinocchio(&model, p.as_slice()).unwrap();
    assert!((&back - &q).amax() < 1e-15, "{back} vs {q}");

    // an angle outside (−π, π] comes back as the same rotation
    q[9] = wheel + 2.0 * std::f64::consts::PI;
    let back = from_pinocchio(
        &model,
        to_pinocchio(&model, q.as_slice()).unwrap().as_slice(),
    )
    .unwrap();
    assert!((back[9] - wheel).abs() < 1e-14);

    // the wheel frame is turned by θ about y from its placement on the base
    let mut data = SpatialData::new(&model);
    forward_kinematics(&model, &mut data, q.as_slice()).unwrap();
    let (base, w) = (
        model.frame_id("base").unwrap(),
        model.frame_id("wheel").unwrap(),
    );
    let relative = frame_placement(&model, &data, base)
        .inverse()
        .compose(&frame_placement(&model, &data, w));
    let turn = Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::y()), p[11].atan2(p[10]));
    assert!((relative.rotation - turn.matrix()).amax() < 1e-14);
}

#[test]
fn off_circle_pinocchio_coordinates_are_a_typed_error() {
    let model = cart();
    let mut p = to_pinocchio(&model, neutral(&model).as_slice()).unwrap();
    p[10] = 0.9;
    match from_pinocchio(&model, p.as_slice()) {
        Err(SpatialError::InvalidArgument { field, .. }) => {
            assert!(field.contains("wheel_joint"), "{field}")
        }
        other => panic!("{other:?}"),
    }
    assert!(
        from_pinocchio(&model, &p.as_slice()[1..]).is_err(),
        "wrong length"
    );
}
