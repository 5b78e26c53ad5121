//! The configuration group of a floating-base robot: `q ⊕ v` and `q₁ ⊖ q₀` are inverse to
//! round-off, and the base quaternion keeps unit norm along long runs.
mod spatial_support;
use selfmanip_core::spatial::{difference, integrate, liegroup::quaternion_at};
use spatial_support::*;

/// `integrate(q, difference(q, q₁)) = q₁` and `difference(q, integrate(q, v)) = v` at random
/// states and step sizes from 1e-9 to 1 (rotations up to ~2 rad).
#[test]
fn integrate_and_difference_are_inverse() {
    let model = quadruped();
    let mut rng = rng(1);
    let (mut worst_q, mut worst_v) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let q = random_q(&model, &mut rng);
        let q1 = random_q(&model, &mut rng);
        let back = integrate(
            &model,
            q.as_slice(),
            difference(&model, q.as_slice(), q1.as_slice())
                .unwrap()
                .as_slice(),
        )
        .unwrap();
        // q and −q are the same rotation: compare the quaternion up to sign
        let sign = if quaternion_at(back.as_slice(), 3).dot(&quaternion_at(q1.as_slice(), 3)) < 0.0
        {
            -1.0
        } else {
            1.0
        };
        let mut d = back.clone() - &q1;
        for k in 3..7 {
            d[k] = back[k] * sign - q1[k];
        }
        worst_q = worst_q.max(d.amax());
        for &dt in &[1e-9, 1e-4, 1e-2, 0.3] {
            let v = random_vector(model.nv, 3.0, &mut rng) * dt;
            let q2 = integrate(&model, q.as_slice(), v.as_slice()).unwrap();
            let dv = difference(&model, q.as_slice(), q2.as_slice()).unwrap() - &v;
            worst_v = worst_v.max(dv.amax() / v.amax().max(1.0));
        }
    }
    eprintln!("worst |q ⊕ (q₁ ⊖ q) − q₁| = {worst_q:.2e}, worst |(q ⊕ v) ⊖ q − v| = {worst_v:.2e}");
    assert!(worst_q < 4e-15, "{worst_q}");
    assert!(worst_v < 2e-15, "{worst_v}");
}

/// 10⁶ steps of `q ← q ⊕ v dt` with a tumbling twist keep `‖quaternion‖ = 1` to round-off
/// (no drift: each step renormalizes), and the base returns to its start after a whole number
/// of turns about a fixed body axis (a closed form: `exp(2π ω̂) = 1`).
#[test]
fn quaternion_norm_stays_one() {
    let model = quadruped();
    let mut rng = rng(2);
    let mut q = random_q(&model, &mut rng);
    let v = random_vector(model.nv, 2.0, &mut rng);
    let mut worst = 0.0f64;
    for _ in 0..1_000_000 {
        q = integrate(&model, q.as_slice(), (&v * 1e-3).as_slice()).unwrap();
        worst = worst.max((quaternion_at(q.as_slice(), 3).norm() - 1.0).abs());
    }
    eprintln!("worst |‖quaternion‖ − 1| over 1e6 steps = {worst:.2e}");
    assert!(worst < 1e-15, "{worst}");

    // a pure spin about the body z axis at 1 rad/s for 2π s, in N steps, returns the pose
    let q0 = random_q(&model, &mut rng);
    let mut spin = nalgebra::DVector::zeros(model.nv);
    spin[5] = 1.0;
    let n = 1000;
    let mut q = q0.clone();
    for _ in 0..n {
        q = integrate(
            &model,
            q.as_slice(),
            (&spin * (std::f64::consts::TAU / n as f64)).as_slice(),
        )
        .unwrap();
    }
    let sign = if quaternion_at(q.as_slice(), 3).dot(&quaternion_at(q0.as_slice(), 3)) < 0.0 {
        -1.0
    } else {
        1.0
    };
    let err = (0..7)
        .map(|k| (if k >= 3 { q[k] * sign } else { q[k] } - q0[k]).abs())
        .fold(0.0, f64::max);
    eprintln!("full turn in {n} steps returns the pose to {err:.2e}");
    assert!(err < 1e-12, "{err}");
}

/// A step that turns the base by more than π keeps the quaternion in its start's hemisphere
/// (Pinocchio's convention: the same numbers as its `integrate`), and the rotation is still
/// the step's, `R(q₁) = R(q₀) exp(θ a)` by Rodrigues' formula.
#[test]
fn a_turn_beyond_pi_keeps_the_quaternion_in_its_hemisphere() {
    let model = quadruped();
    let mut rng = rng(7);
    for _ in 0..50 {
        let q0 = random_q(&model, &mut rng);
        let axis = random_vector(3, 1.0, &mut rng).normalize();
        for theta in [0.5, 3.0, 3.5, 5.0, 6.2] {
            let mut v = nalgebra::DVector::zeros(model.nv);
            v.rows_mut(3, 3).copy_from(&(axis.clone() * theta));
            let q1 = integrate(&model, q0.as_slice(), v.as_slice()).unwrap();
            let (r0, r1) = (
                quaternion_at(q0.as_slice(), 3),
                quaternion_at(q1.as_slice(), 3),
            );
            assert!(r1.dot(&r0) >= 0.0, "θ = {theta}");
            let a = nalgebra::Vector3::new(axis[0], axis[1], axis[2]);
            let k = a.cross_matrix();
            let turn =
                nalgebra::Matrix3::identity() + k * theta.sin() + k * k * (1.0 - theta.cos());
            let expected = nalgebra::UnitQuaternion::from_quaternion(r0)
                .to_rotation_matrix()
                .matrix()
                * turn;
            let got = nalgebra::UnitQuaternion::from_quaternion(r1).to_rotation_matrix();
            assert!((got.matrix() - expected).amax() < 1e-12, "θ = {theta}");
        }
    }
}
