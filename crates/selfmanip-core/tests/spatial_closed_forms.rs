//! Closed forms of spatial mechanics: a torque-free asymmetric body (the Dzhanibekov flip,
//! conserved energy and angular momentum; its `M`, `h` and `q̈` against Euler's equations are
//! `spatial_rigid_body.rs`'s `free_body_matches_euler_equations`), `q ⊕ v` undone by `⊕ (−v)`, and
//! the quasi-static forces of a plate on four feet.
mod spatial_support;
use nalgebra::{DVector, Matrix3, UnitQuaternion, Vector3};
use selfmanip_core::spatial::kinematics::forward_kinematics_velocity;
use selfmanip_core::spatial::rigid_body::kinetic_energy;
use selfmanip_core::spatial::*;
use spatial_support::*;

const MASS: f64 = 2.5;

/// An asymmetric body (principal moments 0.2 < 0.5 < 0.9 kg m², turned off the URDF axes so
/// the tensor is full) floating without gravity.
fn tumbling_body() -> (SpatialModel, Matrix3<f64>) {
    let r = UnitQuaternion::from_euler_angles(0.3, -0.5, 0.8);
    let i = r.to_rotation_matrix().matrix()
        * Matrix3::from_diagonal(&Vector3::new(0.2, 0.5, 0.9))
        * r.to_rotation_matrix().matrix().transpose();
    let urdf = format!(
        r#"<robot name="t"><link name="b"><inertial><mass value="{MASS}"/><inertia ixx="{}" ixy="{}" ixz="{}" iyy="{}" iyz="{}" izz="{}"/></inertial></link></robot>"#,
        i[(0, 0)],
        i[(0, 1)],
        i[(0, 2)],
        i[(1, 1)],
        i[(1, 2)],
        i[(2, 2)]
    );
    let mut model = SpatialModel::from_urdf_str(&urdf, BaseKind::FreeFlyer, None).unwrap();
    model.gravity = Vector3::zeros();
    (model, i)
}

/// The conserved quantities: kinetic energy and the world angular momentum about the origin
/// `L = p × R m v + R I ω` (and the linear momentum `R m v`).
fn invariants(
    model: &SpatialModel,
    data: &mut SpatialData,
    i: &Matrix3<f64>,
    q: &DVector<f64>,
    v: &DVector<f64>,
) -> (f64, Vector3<f64>, Vector3<f64>) {
    forward_kinematics_velocity(model, data, q.as_slice(), v.as_slice()).unwrap();
    let energy = kinetic_energy(model, data);
    let r = UnitQuaternion::new_normalize(liegroup::quaternion_at(q.as_slice(), 3));
    let p = Vector3::new(q[0], q[1], q[2]);
    let momentum = r * Vector3::new(v[0], v[1], v[2]) * MASS;
    let angular = p.cross(&momentum) + r * (i * Vector3::new(v[3], v[4], v[5]));
    (energy, momentum, angular)
}

/// The largest drift of the invariants over `t_end` with steps `dt` of the explicit midpoint
/// rule on the group (RKMK of order 2: `q ⊕ dt v(t + dt/2)`), and whether the body's rate about
/// its intermediate axis changed sign (the Dzhanibekov flip).
fn run(dt: f64, t_end: f64) -> (f64, bool) {
    let (model, i) = tumbling_body();
    let mut data = SpatialData::new(&model);
    let mut q = neutral(&model);
    // spinning about the intermediate principal axis, slightly off it
    let r = UnitQuaternion::from_euler_angles(0.3, -0.5, 0.8);
    let w0 = r * Vector3::new(0.01, 4.0, 0.01);
    let mut v = DVector::from_column_slice(&[0.3, -0.2, 0.1, w0.x, w0.y, w0.z]);
    let axis = r * Vector3::y();
    let start = invariants(&model, &mut data, &i, &q, &v);
    let accel = |data: &mut SpatialData, q: &DVector<f64>, v: &DVector<f64>| {
        forward_dynamics(&model, data, &[], q.as_slice(), v.as_slice(), &[0.0; 6]).unwrap();
        data.qdd.clone()
    };
    let (mut worst, mut flipped) = (0.0f64, false);
    for _ in 0..(t_end / dt).round() as usize {
        let a1 = accel(&mut data, &q, &v);
        let q_half = along(&model, &q, &v, 0.5 * dt);
        let v_half = &v + a1 * (0.5 * dt);
        let a2 = accel(&mut data, &q_half, &v_half);
        q = integrate(&model, q.as_slice(), (&v_half * dt).as_slice()).unwrap();
        v += a2 * dt;
        let (e, p, l) = invariants(&model, &mut data, &i, &q, &v);
        worst = worst
            .max((e - start.0).abs() / start.0)
            .max((p - start.1).norm() / start.1.norm())
            .max((l - start.2).norm() / start.2.norm());
        flipped |= Vector3::new(v[3], v[4], v[5]).dot(&axis) < 0.0;
    }
    (worst, flipped)
}

/// Along an integration on the group the energy and both momenta are conserved to the
/// method's order (the drift falls ≈ 4× when the step halves), and the spin about the
/// intermediate axis flips, as the Dzhanibekov effect says it must.
#[test]
fn dzhanibekov_flip_conserves_energy_and_momentum() {
    let (coarse, flipped) = run(2e-3, 6.0);
    let (fine, _) = run(1e-3, 6.0);
    eprintln!(
        "invariant drift: {coarse:.2e} at dt 2e-3, {fine:.2e} at dt 1e-3 (ratio {:.2})",
        coarse / fine
    );
    assert!(flipped, "the intermediate-axis spin flips");
    assert!(fine < 1e-4, "{fine}");
    assert!(
        (3.5..4.5).contains(&(coarse / fine)),
        "second order: {coarse} / {fine}"
    );
}

/// `(q ⊕ v dt) ⊕ (−v dt) = q` to 1e-15 (`g exp(ξ) exp(−ξ) = g`), for steps from 1e-9 to 1
/// (relative to the step where it exceeds 1).
#[test]
fn integrate_then_its_inverse_returns_q() {
    let model = quadruped();
    let mut rng = rng(51);
    let mut worst = 0.0f64;
    for k in 0..200 {
        let (q, v, _) = random_state(&model, &mut rng);
        let dt = 10f64.powi(-(k % 10));
        let step = &v * dt;
        let there = integrate(&model, q.as_slice(), step.as_slice()).unwrap();
        let back = integrate(&model, there.as_slice(), (-&step).as_slice()).unwrap();
        // round-off of the step's own size: |v dt| reaches 2 (rotations of 3 rad) at dt = 1
        worst = worst.max((back - &q).amax() / step.amax().max(1.0));
    }
    eprintln!("|(q ⊕ v dt) ⊕ (−v dt) − q| / max(1, |v dt|) {worst:.1e}");
    assert!(worst <= 1e-15, "{worst}");
}

/// A plate on four point feet (the quadruped's trunk on massless legs, frictionless feet,
/// standing level): statically indeterminate, three equations for four forces. The external
/// part is the plate's `f_i = m g/4 (1 + c_x x_i/a² + c_y y_i/b²)` (feet at `(±a, ±b)` from the
/// trunk's centre, centre of mass at `c`: the minimum-norm forces, those of four equally stiff
/// legs); the internal part spans `ker G`, the squeeze `(1, −1, −1, 1)/2`. With friction
/// (12 rows) the external forces are the same and `ker G` has dimension 6.
#[test]
fn plate_on_four_feet_has_its_quasi_static_forces() {
    let model = quadruped_scaled(&["_hip", "_thigh", "_shin", "_foot"], 0.0);
    let mut data = SpatialData::new(&model);
    let (theta, l) = (0.5f64, 0.22);
    let h = 2.0 * l * theta.cos();
    let q = standing_q(&model, h, theta);
    // the URDF's trunk (12 kg) and IMU (0.2 kg); feet below the flexion axes at (±0.25, ±0.18)
    let m = 12.2;
    let c = (Vector3::new(0.01, -0.005, 0.012) * 12.0 + Vector3::new(-0.05, 0.02, 0.06) * 0.2) / m;
    let (a, b) = (0.25, 0.12 + 0.06);
    let feet_xy = [(a, b), (a, -b), (-a, b), (-a, -b)];
    let plate: Vec<f64> = feet_xy
        .iter()
        .map(|(x, y)| m * 9.81 / 4.0 * (1.0 + c.x * x / (a * a) + c.y * y / (b * b)))
        .collect();
    let qs = quasi_static(&model, &mut data, &feet(&model, [false; 4]), q.as_slice()).unwrap();
    let e_ext = (&qs.lambda_external - DVector::from_vec(plate.clone())).amax();
    let squeeze = DVector::from_vec(vec![0.5, -0.5, -0.5, 0.5]);
    assert_eq!(qs.internal_basis.ncols(), 1);
    let e_int = 1.0 - qs.internal_basis.column(0).dot(&squeeze).abs();
    let e_null = (&qs.grasp * &qs.internal_basis).amax();
    eprintln!("plate: |λ_e − plate| {e_ext:.1e}, 1 − |N·squeeze| {e_int:.1e}, |G N| {e_null:.1e}");
    assert!(e_ext < 1e-11 && e_int < 1e-14 && e_null < 1e-13);

    let qs = quasi_static(&model, &mut data, &feet(&model, [true; 4]), q.as_slice()).unwrap();
    let normals: Vec<f64> = (0..4).map(|k| qs.lambda_external[3 * k + 2]).collect();
    assert_eq!(qs.internal_basis.ncols(), 6);
    let e_null = (&qs.grasp * &qs.internal_basis).amax();
    // the minimum-norm forces with friction rows: their normal parts are the plate's only if
    // no tangential force helps hold the body; the base wrench is balanced either way
    let balance = (&qs.grasp * &qs.lambda_external - &qs.gravity_wrench).amax();
    eprintln!("with friction: normals {normals:.3?} vs plate {plate:.3?}, |G N| {e_null:.1e}, |G λ − g_b| {balance:.1e}");
    assert!(e_null < 1e-13 && balance < 1e-11);
    // the joints hold the forces: with τ = τ_e + (internal torques) α the robot stays at rest
    // with exactly λ_e + N α (the constrained dynamics as the second route)
    let alpha = DVector::from_fn(6, |i, _| 3.0 * (i as f64 - 2.5));
    let lam = &qs.lambda_external + &qs.internal_basis * &alpha;
    let mut tau = DVector::zeros(model.nv);
    tau.rows_mut(6, model.nv - 6)
        .copy_from(&(&qs.tau_external + &qs.internal_torques * &alpha));
    let zero = DVector::zeros(model.nv);
    dynamics_at(
        &model,
        &mut data,
        &feet(&model, [true; 4]),
        (&q, &zero, &tau),
    )
    .unwrap();
    let (e_qdd, e_lam) = (data.qdd.amax(), (&data.lam - &lam).amax());
    eprintln!("held at rest: |q̈| {e_qdd:.1e}, |λ − (λ_e + N α)| {e_lam:.1e}");
    assert!(e_qdd < 1e-12 && e_lam < 1e-11, "{e_qdd} {e_lam}");
}
