//! `M(q)` (CRBA) and `h(q, v)` (RNEA) against closed forms and second routes: Euler's
//! equations of a free asymmetric body (Dzhanibekov), the power balance and the potential's
//! gradient by finite differences, and the null space of massless limbs.
mod spatial_support;
use nalgebra::{DMatrix, DVector, Matrix3, SymmetricEigen, UnitQuaternion, Vector3};
use selfmanip_core::spatial::kinematics::{forward_kinematics, forward_kinematics_velocity};
use selfmanip_core::spatial::liegroup::quaternion_at;
use selfmanip_core::spatial::rigid_body::{
    crba, kinetic_energy, nonlinear_effects, potential_energy, rnea,
};
use selfmanip_core::spatial::*;
use spatial_support::*;

/// One free body, mass 2 kg, principal moments 0.1, 0.2, 0.3 kg·m² about axes rotated by the
/// inertial origin's rpy, centre of mass at the link origin.
const BODY: &str = r#"<robot name="tbar"><link name="body"><inertial>
  <origin xyz="0 0 0" rpy="0.3 -0.5 0.8"/><mass value="2.0"/>
  <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"/></inertial></link></robot>"#;

fn body() -> (SpatialModel, Matrix3<f64>) {
    let model = SpatialModel::from_urdf_str(BODY, BaseKind::FreeFlyer, None).unwrap();
    let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.5, 0.8);
    let i_body =
        r.matrix() * Matrix3::from_diagonal(&Vector3::new(0.1, 0.2, 0.3)) * r.matrix().transpose();
    (model, i_body)
}

/// Euler's equations in the body frame: `v̇ = −ω×v + Rᵀg`, `I ω̇ = −ω × Iω` (zero torque).
fn euler_rates(q: &[f64], v: &[f64], i_body: &Matrix3<f64>, g: &Vector3<f64>) -> DVector<f64> {
    let r = UnitQuaternion::new_normalize(quaternion_at(q, 3));
    let (lin, w) = (
        Vector3::from_column_slice(&v[0..3]),
        Vector3::from_column_slice(&v[3..6]),
    );
    let vd = -w.cross(&lin) + r.inverse() * g;
    let wd = -(i_body.try_inverse().unwrap() * w.cross(&(i_body * w)));
    DVector::from_iterator(6, vd.iter().chain(wd.iter()).copied())
}

/// `M = diag(m 1, I)`, `h = [m(ω×v − Rᵀg); ω × Iω]` and the free `v̇` equal Euler's equations.
#[test]
fn free_body_matches_euler_equations() {
    let (model, i_body) = body();
    let mut data = SpatialData::new(&model);
    let mut rng = rng(3);
    let mut worst = [0.0f64; 3];
    for _ in 0..50 {
        let q = random_q(&model, &mut rng);
        let v = random_vector(6, 3.0, &mut rng);
        crba(&model, &mut data, q.as_slice()).unwrap();
        let mut m = DMatrix::zeros(6, 6);
        m.view_mut((0, 0), (3, 3))
            .copy_from(&(Matrix3::identity() * 2.0));
        m.view_mut((3, 3), (3, 3)).copy_from(&i_body);
        worst[0] = worst[0].max((&data.M - m).amax());
        nonlinear_effects(&model, &mut data, q.as_slice(), v.as_slice()).unwrap();
        let r = UnitQuaternion::new_normalize(quaternion_at(q.as_slice(), 3));
        let (lin, w) = (
            Vector3::from_column_slice(&v.as_slice()[0..3]),
            Vector3::from_column_slice(&v.as_slice()[3..6]),
        );
        let h_lin = (w.cross(&lin) - r.inverse() * model.gravity) * 2.0;
        let h_ang = w.cross(&(i_body * w));
        let h = DVector::from_iterator(6, h_lin.iter().chain(h_ang.iter()).copied());
        worst[1] = worst[1].max((&data.h - h).amax());
        forward_dynamics(
            &model,
            &mut data,
            &[],
            q.as_slice(),
            v.as_slice(),
            &[0.0; 6],
        )
        .unwrap();
        worst[2] = worst[2].max(
            (&data.qdd - euler_rates(q.as_slice(), v.as_slice(), &i_body, &model.gravity)).amax(),
        );
    }
    assert_worst(
        "free body: worst",
        &["|M − M_euler|", "|h − h_euler|", "|v̇ − v̇_euler|"],
        &worst,
        1e-12,
    );
}

/// Energy `T + V` and the angular momentum about the centre of mass in the world, `R I ω`,
/// of the tumbling body integrated on the group by RKMK4 (Runge–Kutta–Munthe-Kaas, stages by
/// `q ⊕ v dt`): their drift over 4 s falls at least 2^3.5 per halving of the step, and is below
/// 1e-8 at the finest.
#[test]
fn dzhanibekov_conserves_energy_and_angular_momentum() {
    let (model, i_body) = body();
    let mut data = SpatialData::new(&model);
    let invariants = |data: &mut SpatialData, q: &DVector<f64>, v: &DVector<f64>| {
        forward_kinematics_velocity(&model, data, q.as_slice(), v.as_slice()).unwrap();
        let energy = kinetic_energy(&model, data) + potential_energy(&model, data);
        let r = UnitQuaternion::new_normalize(quaternion_at(q.as_slice(), 3));
        (
            energy,
            r * (i_body * Vector3::from_column_slice(&v.as_slice()[3..6])),
        )
    };
    let accel = |data: &mut SpatialData, q: &DVector<f64>, v: &DVector<f64>| {
        forward_dynamics(&model, data, &[], q.as_slice(), v.as_slice(), &[0.0; 6]).unwrap();
        data.qdd.clone()
    };
    // spin near the intermediate axis: the body flips (the Dzhanibekov effect)
    let mut q0 = neutral(&model);
    q0[2] = 1.0;
    let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.5, 0.8);
    let w0 = r * Vector3::new(0.01, 6.0, 0.02);
    let v0 = DVector::from_vec(vec![0.5, -0.2, 3.0, w0.x, w0.y, w0.z]);
    let (e0, l0) = invariants(&mut data, &q0, &v0);
    let mut drifts = Vec::new();
    // RKMK4 (Munthe-Kaas 1998): stages q ⊕ Θᵢ with Θ̇ = dexp⁻¹_Θ(v) = v + ½[Θ, v] + [Θ,[Θ, v]]/12
    // on the base twist (the motion cross product is the bracket of se(3) in body coordinates)
    let dexpinv = |theta: &DVector<f64>, v: &DVector<f64>| {
        let t = Motion::from_vector(&theta.fixed_rows::<6>(0).into_owned());
        let u = Motion::from_vector(&v.fixed_rows::<6>(0).into_owned());
        let tu = t.cross(&u);
        DVector::from_column_slice(
            (u + tu * 0.5 + t.cross(&tu) * (1.0 / 12.0))
                .to_vector()
                .as_slice(),
        )
    };
    for &n in &[2000usize, 4000, 8000] {
        let dt = 4.0 / n as f64;
        let (mut q, mut v, mut worst) = (q0.clone(), v0.clone(), (0.0f64, 0.0f64));
        let step = |q: &DVector<f64>, dq: &DVector<f64>| {
            integrate(&model, q.as_slice(), dq.as_slice()).unwrap()
        };
        for _ in 0..n {
            let (k1q, k1v) = (v.clone(), accel(&mut data, &q, &v));
            let th2 = &k1q * (dt / 2.0);
            let (q2, v2) = (step(&q, &th2), &v + &k1v * (dt / 2.0));
            let (k2q, k2v) = (dexpinv(&th2, &v2), accel(&mut data, &q2, &v2));
            let th3 = &k2q * (dt / 2.0);
            let (q3, v3) = (step(&q, &th3), &v + &k2v * (dt / 2.0));
            let (k3q, k3v) = (dexpinv(&th3, &v3), accel(&mut data, &q3, &v3));
            let th4 = &k3q * dt;
            let (q4, v4) = (step(&q, &th4), &v + &k3v * dt);
            let (k4q, k4v) = (dexpinv(&th4, &v4), accel(&mut data, &q4, &v4));
            q = step(&q, &((k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (dt / 6.0)));
            v += (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (dt / 6.0);
            let (e, l) = invariants(&mut data, &q, &v);
            worst = (worst.0.max((e - e0).abs()), worst.1.max((l - l0).norm()));
        }
        drifts.push(worst);
    }
    eprintln!("drift of (energy J, |L| kg m²/s) at dt = 2, 1, 0.5 ms: {drifts:?}");
    for k in 0..2 {
        assert!(drifts[k].0 / drifts[k + 1].0 > 2f64.powf(3.5), "{drifts:?}");
        assert!(drifts[k].1 / drifts[k + 1].1 > 2f64.powf(3.5), "{drifts:?}");
    }
    assert!(drifts[2].0 < 1e-8 && drifts[2].1 < 1e-8, "{drifts:?}");
}

/// CRBA and RNEA agree: `τ(q, v, a) = M a + h` (two algorithms); `g(q)` is the gradient of the
/// potential along `q ⊕ εδv` and `vᵀ(τ(q, v, a) − g) = dT/dt` along `(q ⊕ tv, v + ta)` (the
/// power balance, `vᵀ(Ṁ − 2C)v = 0`), both by central differences.
#[test]
fn mass_matrix_and_bias_forces_agree_with_energy() {
    let (model, mut data, mut rng) = setup(quadruped(), 4);
    let (mut w_rnea, mut w_grav, mut w_power) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..20 {
        let q = random_q(&model, &mut rng);
        let (v, a, dv) = (
            random_vector(18, 2.0, &mut rng),
            random_vector(18, 2.0, &mut rng),
            random_vector(18, 1.0, &mut rng),
        );
        crba(&model, &mut data, q.as_slice()).unwrap();
        let m = data.M.clone();
        nonlinear_effects(&model, &mut data, q.as_slice(), v.as_slice()).unwrap();
        let h = data.h.clone();
        let tau = rnea(&model, &mut data, q.as_slice(), v.as_slice(), a.as_slice()).unwrap();
        w_rnea = w_rnea.max((&tau - (&m * &a + &h)).amax());

        let zero = DVector::zeros(18);
        let g = rnea(
            &model,
            &mut data,
            q.as_slice(),
            zero.as_slice(),
            zero.as_slice(),
        )
        .unwrap();
        let eps = 1e-5;
        let mut pot = |s: f64| {
            let qs = integrate(&model, q.as_slice(), (&dv * s).as_slice()).unwrap();
            forward_kinematics(&model, &mut data, qs.as_slice()).unwrap();
            potential_energy(&model, &data)
        };
        let dpot = (pot(eps) - pot(-eps)) / (2.0 * eps);
        w_grav = w_grav.max((g.dot(&dv) - dpot).abs());

        let mut kin = |t: f64| {
            let qs = along(&model, &q, &v, t);
            let vs = &v + &a * t;
            forward_kinematics_velocity(&model, &mut data, qs.as_slice(), vs.as_slice()).unwrap();
            kinetic_energy(&model, &data)
        };
        let dkin = (kin(eps) - kin(-eps)) / (2.0 * eps);
        w_power = w_power.max((v.dot(&(&tau - &g)) - dkin).abs() / dkin.abs().max(1.0));
    }
    eprintln!("|τ − (Ma + h)| {w_rnea:.2e}; |g·δv − dV| {w_grav:.2e}; power balance {w_power:.2e}");
    assert!(w_rnea < 1e-12, "{w_rnea}");
    assert!(w_grav < 1e-8, "{w_grav}");
    assert!(w_power < 1e-8, "{w_power}");
}

/// With massless shins `M` is symmetric positive semi-definite, its null space is exactly the
/// four knee rates (`M e_knee = 0`, rank 14 of 18), and the massive model's `M` is definite.
#[test]
fn massless_shins_span_the_null_space_of_m() {
    let model = quadruped_massless_shins();
    let massive = quadruped();
    let knees: Vec<usize> = KNEES
        .iter()
        .map(|k| model.joints.iter().find(|j| j.name == *k).unwrap().idx_v)
        .collect();
    let (mut data, mut data_m) = (SpatialData::new(&model), SpatialData::new(&massive));
    let mut rng = rng(5);
    for _ in 0..20 {
        let q = random_q(&model, &mut rng);
        crba(&model, &mut data, q.as_slice()).unwrap();
        let m = &data.M;
        assert_eq!((m - m.transpose()).amax(), 0.0);
        for &k in &knees {
            assert_eq!(m.column(k).amax(), 0.0, "knee column {k}");
        }
        let eig = SymmetricEigen::new(m.clone()).eigenvalues;
        let scale = eig.amax();
        assert!(eig.min() > -1e-14 * scale, "{}", eig.min());
        let rank = eig.iter().filter(|&&e| e > 1e-12 * scale).count();
        assert_eq!(rank, 14);
        crba(&massive, &mut data_m, q.as_slice()).unwrap();
        assert!(SymmetricEigen::new(data_m.M.clone()).eigenvalues.min() > 0.0);
    }
}

/// `forward_dynamics` forms `M` and `h` in one backward sweep; the separate sweeps
/// (`crba`, then `nonlinear_effects`) are the second route. The same operations in the same
/// order: equal to the last bit, on the quadruped and with massless shins (zero columns).
#[test]
fn one_sweep_gives_the_separate_sweeps_m_and_h() {
    for model in [quadruped(), quadruped_massless_shins()] {
        let contacts = feet(&model, [true; 4]);
        let (mut fused, mut separate) = (SpatialData::new(&model), SpatialData::new(&model));
        let mut rng = rng(6);
        for _ in 0..5 {
            let (q, v, tau) = random_state(&model, &mut rng);
            // a singular KKT system (massless shins at a stretched knee) still leaves M and h
            let _ = dynamics_at(&model, &mut fused, &contacts, (&q, &v, &tau));
            crba(&model, &mut separate, q.as_slice()).unwrap();
            nonlinear_effects(&model, &mut separate, q.as_slice(), v.as_slice()).unwrap();
            assert_eq!(fused.M, separate.M);
            assert_eq!(fused.h, separate.h);
        }
    }
}
