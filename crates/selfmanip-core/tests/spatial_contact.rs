//! Constrained dynamics and plastic impact of point contacts: the statics of a body on four
//! feet by hand, the Schur-complement closed form for a massive robot, and exact, finite,
//! constraint-satisfying answers with massless shins.
mod spatial_support;
use nalgebra::{DMatrix, DVector, Vector3};
use selfmanip_core::spatial::*;
use selfmanip_core::{CoreError, SingularityKind};
use spatial_support::*;

const THIGH_SHIN_M: f64 = 0.22;

/// The trunk (12 kg) and IMU (0.2 kg) on four massless legs, standing level on bent legs.
/// By hand: the foot forces `f_i` solve the body's statics, `Σ f = m g`, `Σ (p_i − c) × f = 0`,
/// with an internal squeeze (vertical `α(1, −1, −1, 1)` and a fore–aft pinch of the left feet)
/// that the statics leave free; the joint torques that hold them are, by virtual work,
/// `τ_j = −a_j · ((p − x_j) × f)` for each joint axis `a_j` through `x_j`. With those torques the
/// robot must stay at rest (`q̈ = 0`) with exactly those contact forces.
#[test]
fn four_feet_statics_by_hand() {
    let model = quadruped_scaled(&["_hip", "_thigh", "_shin", "_foot"], 0.0);
    let mut data = SpatialData::new(&model);
    let (theta, l) = (0.5f64, THIGH_SHIN_M);
    let h = 2.0 * l * theta.cos();
    let q = standing_q(&model, h, theta);
    // body mass and centre of mass from the URDF's numbers
    let m = 12.0 + 0.2;
    let c = (Vector3::new(0.01, -0.005, 0.012) * 12.0 + Vector3::new(-0.05, 0.02, 0.06) * 0.2) / m
        + Vector3::new(0.0, 0.0, h);
    let signs = [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)];
    let hip = |(sx, sy): (f64, f64)| Vector3::new(0.25 * sx, 0.12 * sy, h);
    let foot = |s: (f64, f64)| hip(s) + Vector3::new(0.0, 0.06 * s.1, -h);
    // vertical forces: Σ F = m g, Σ F (x − c_x) = 0, Σ F (y − c_y) = 0, plus α (1, −1, −1, 1)
    let mut statics = DMatrix::zeros(3, 4);
    for (i, &s) in signs.iter().enumerate() {
        let p = foot(s);
        statics[(0, i)] = 1.0;
        statics[(1, i)] = p.x - c.x;
        statics[(2, i)] = p.y - c.y;
    }
    let g = 9.81;
    let particular = statics
        .clone()
        .svd(true, true)
        .solve(&DVector::from_vec(vec![m * g, 0.0, 0.0]), 1e-14)
        .unwrap();
    let vertical = particular + DVector::from_vec(vec![1.0, -1.0, -1.0, 1.0]) * 7.0;
    let pinch = 5.0;
    let forces: Vec<Vector3<f64>> = (0..4)
        .map(|i| Vector3::new([pinch, 0.0, -pinch, 0.0][i], 0.0, vertical[i]))
        .collect();
    // torques by virtual work; joints per leg: abduction (x) at the hip, flexion (y) at
    // F = hip + (0, ±0.06, 0), knee (y) at F + (−l sin θ, 0, −l cos θ)
    let mut tau = DVector::zeros(model.nv);
    for (i, &s) in signs.iter().enumerate() {
        let f_at = hip(s) + Vector3::new(0.0, 0.06 * s.1, 0.0);
        let knee = f_at + Vector3::new(-l * theta.sin(), 0.0, -l * theta.cos());
        let p = foot(s);
        for (k, (axis, x)) in [
            (Vector3::x(), hip(s)),
            (Vector3::y(), f_at),
            (Vector3::y(), knee),
        ]
        .into_iter()
        .enumerate()
        {
            tau[6 + 3 * i + k] = -axis.dot(&(p - x).cross(&forces[i]));
        }
    }
    let contacts = feet(&model, [true; 4]);
    forward_dynamics(
        &model,
        &mut data,
        &contacts,
        q.as_slice(),
        &vec![0.0; model.nv],
        tau.as_slice(),
    )
    .unwrap();
    let expected = DVector::from_iterator(12, forces.iter().flat_map(|f| f.iter().copied()));
    let (e_qdd, e_lam) = (data.qdd.amax(), (&data.lam - &expected).amax());
    eprintln!(
        "statics: |q̈| {e_qdd:.2e}, |λ − λ_hand| {e_lam:.2e} (forces up to {:.1} N)",
        expected.amax()
    );
    assert!(e_qdd < 1e-12 && e_lam < 1e-11, "{e_qdd} {e_lam}");
}

/// For a massive robot `M` is invertible and the KKT solution has the closed form of Gauss's
/// principle: `λ = (A M⁻¹ Aᵀ)⁻¹(−Ȧq̇ − A M⁻¹(τ − h))`, `q̈ = M⁻¹(τ − h + Aᵀλ)`; the plastic
/// impact is `P = −(A M⁻¹ Aᵀ)⁻¹ A q̇⁻`, `q̇⁺ = q̇⁻ + M⁻¹AᵀP`, and loses kinetic energy.
#[test]
fn massive_robot_matches_the_schur_complement() {
    let (model, mut data, mut rng) = setup(quadruped(), 8);
    let modes = [
        [true; 4],
        [true, false, false, true],
        [false; 4],
        [true, true, false, false],
    ];
    let (mut w_fd, mut w_imp) = (0.0f64, 0.0f64);
    for k in 0..40 {
        let mode = modes[k % modes.len()];
        let contacts = feet(&model, mode);
        let (q, v, tau) = random_state(&model, &mut rng);
        dynamics_at(&model, &mut data, &contacts, (&q, &v, &tau)).unwrap();
        let (m, h, a, drift) = (
            data.M.clone(),
            data.h.clone(),
            data.A.clone(),
            data.A_drift.clone(),
        );
        let minv = m.clone().try_inverse().unwrap();
        let schur = (&a * &minv * a.transpose()).try_inverse().unwrap();
        let lam = &schur * (-&drift - &a * &minv * (&tau - &h));
        let qdd = &minv * (&tau - &h + a.transpose() * &lam);
        w_fd = w_fd
            .max((&data.qdd - qdd).amax().max((&data.lam - lam).amax()) / data.lam.amax().max(1.0));
        let imp = impact(&model, &mut data, &contacts, q.as_slice(), v.as_slice()).unwrap();
        let p = -(&schur * &a * &v);
        let v_plus = &v + &minv * a.transpose() * &p;
        w_imp = w_imp.max((imp.v_plus - &v_plus).amax().max((imp.impulse - p).amax()));
        assert!(v_plus.dot(&(&m * &v_plus)) <= v.dot(&(&m * &v)));
    }
    eprintln!(
        "massive: |(q̈, λ) − Schur| {w_fd:.2e} (relative to |λ|), |impact − Schur| {w_imp:.2e}"
    );
    assert!(w_fd < 1e-10 && w_imp < 1e-10, "{w_fd} {w_imp}");
}

/// With massless shins (M singular, rank 14 of 18) and the feet down in several modes, `q̈`,
/// `λ` and the impact are finite, satisfy `A q̈ + Ȧq̇ = 0` and `A q̇⁺ = 0` to round-off, and the
/// equations of motion `M q̈ + h = τ + Aᵀλ` hold (each relative to the size of its terms); a massless shin off the ground is a typed
/// singular-KKT error (Lemma 5.1).
#[test]
fn massless_shins_give_exact_finite_answers() {
    let (model, mut data, mut rng) = setup(quadruped_massless_shins(), 9);
    let modes = [[true; 4], [true, false, false, true], [false; 4]];
    let (mut w_acc, mut w_eom, mut w_imp) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..60 {
        let contacts = feet(&model, modes[k % modes.len()]);
        let (q, v, tau) = random_state(&model, &mut rng);
        dynamics_at(&model, &mut data, &contacts, (&q, &v, &tau)).unwrap();
        let (acc, eom) = dynamics_residuals(&data, &tau);
        (w_acc, w_eom) = (w_acc.max(acc), w_eom.max(eom));
        let imp = impact(&model, &mut data, &contacts, q.as_slice(), v.as_slice()).unwrap();
        w_imp = w_imp.max((&data.A * &imp.v_plus).amax() / v.amax());
    }
    eprintln!(
        "massless shins: |A q̈ + Ȧq̇| {w_acc:.2e}, |EOM| {w_eom:.2e}, |A q̇⁺| {w_imp:.2e} (relative)"
    );
    assert!(
        w_acc < 1e-12 && w_eom < 1e-12 && w_imp < 1e-12,
        "{w_acc} {w_eom} {w_imp}"
    );

    let q = random_q(&model, &mut rng);
    let three = feet(&model, [true; 4])[..3].to_vec();
    let err = forward_dynamics(
        &model,
        &mut data,
        &three,
        q.as_slice(),
        &[0.0; 18],
        &[0.0; 18],
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            SpatialError::Core(CoreError::SingularKkt {
                kind: SingularityKind::UnconstrainedMasslessMotion,
                ..
            })
        ),
        "{err:?}"
    );
}

/// `kkt_blocks` is the inverse of `[M Aᵀ; A 0]` (thesis (5.2)): the assembled matrix times
/// `[M† A†ᵀ; A† Λ]` is the identity, on the rates it keeps — the quadruped on four feet, with
/// massless shins on four feet (`M` singular, the system regular) and on three (the fourth
/// shin's free rate left out: zero rows and columns), and on a planar base.
#[test]
fn kkt_blocks_invert_the_kkt_matrix() {
    let cases = [
        (quadruped(), [true; 4]),
        (quadruped_massless_shins(), [true; 4]),
        (quadruped_massless_shins(), [false, true, true, true]),
        (quadruped_scaled_on(BaseKind::Planar, &[], 1.0), [true; 4]),
    ];
    let mut worst = 0.0f64;
    for (k, (model, down)) in cases.into_iter().enumerate() {
        let (model, mut data, mut rng) = setup(model, 90 + k as u64);
        let contacts: Vec<PointContact> = feet(&model, [true; 4])
            .into_iter()
            .zip(down)
            .filter_map(|(c, d)| d.then_some(c))
            .collect();
        for _ in 0..5 {
            let q = if model.joints[0].kind == JointKind::Planar {
                DVector::from_fn(model.nq, |_, _| rand::Rng::gen_range(&mut rng, -1.0..1.0))
            } else {
                random_q(&model, &mut rng)
            };
            let out = kkt_blocks(&model, &mut data, &contacts, q.as_slice()).unwrap();
            assert_eq!(out.free_rates, free_rates(&model, &contacts));
            assert_eq!(out.free_rates.is_empty(), down[0]);
            let kept: Vec<usize> = (0..model.nv)
                .filter(|i| !out.free_rates.contains(i))
                .collect();
            let (n, c) = (kept.len(), data.A.nrows());
            let mut kkt = DMatrix::zeros(n + c, n + c);
            let mut inverse = DMatrix::zeros(n + c, n + c);
            let b = &out.blocks;
            for (j, &kj) in kept.iter().enumerate() {
                for (i, &ki) in kept.iter().enumerate() {
                    kkt[(i, j)] = data.M[(ki, kj)];
                    inverse[(i, j)] = b.m_dagger[(ki, kj)];
                }
                for r in 0..c {
                    kkt[(n + r, j)] = data.A[(r, kj)];
                    kkt[(j, n + r)] = data.A[(r, kj)];
                    inverse[(n + r, j)] = b.a_dagger[(r, kj)];
                    inverse[(j, n + r)] = b.a_dagger[(r, kj)];
                }
            }
            inverse.view_mut((n, n), (c, c)).copy_from(&b.lambda);
            let product = &kkt * &inverse;
            let gap = (product - DMatrix::identity(n + c, n + c)).amax();
            worst = worst.max(gap / inverse.amax().max(1.0));
            for &f in &out.free_rates {
                assert!(b
                    .m_dagger
                    .row(f)
                    .iter()
                    .chain(b.a_dagger.column(f).iter())
                    .all(|&x| x == 0.0));
            }
        }
    }
    assert_worst("[M Aᵀ; A 0] [M† A†ᵀ; A† Λ] − I:", &["max"], &[worst], 1e-10);
}
