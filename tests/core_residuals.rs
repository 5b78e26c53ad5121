//! Physics residuals in every contact mode, exact derivatives (Ȧ, C̄) against independent
//! routes, and the grasp-map formulation of the constraint (thesis 4.11–4.17).
mod common;
use common::*;
use nalgebra::{DMatrix, DVector};
use selfmanip::core::grasp::grasp_maps;
use selfmanip::core::inertia::{coriolis_christoffel, coriolis_matrix, mass_matrix_partials};
use selfmanip::core::kinematics::Kinematics;
use selfmanip::core::{forward_dynamics, frames, ContactMode, Data, FlatGround, Model};
use selfmanip::rhex::LegShape;

/// `A q̈ + Ȧ q̇ = 0` and `M̄ q̈ + C̄ q̇ + N̄ + Aᵀ λ = Υ` (4.32) on the dynamic coordinates.
fn check_residuals(model: &Model, modes: &[ContactMode], seed: u64) -> usize {
    let mut r = rng(seed);
    let mut data = Data::new(model);
    let mut checked = 0;
    for &mode in modes {
        for _ in 0..25 {
            let q = random_q(model, &mut r);
            let qd = project_to_constraints(model, mode, &q, &random_vec(model.nq(), 2.0, &mut r));
            let tau = random_vec(model.n_joints(), 10.0, &mut r);
            if forward_dynamics(model, &mut data, &FlatGround, mode, &q, &qd, &tau, None).is_err() {
                continue;
            }
            let a = &data.constraints.a;
            let qdd = &data.qdd;
            let acc = a * qdd + &data.constraints.a_dot_qd;
            let scale = 1.0 + qdd.norm();
            assert!(
                acc.norm() < 1e-9 * scale * (1.0 + a.norm()),
                "A q̈ + Ȧ q̇ = {acc} in {mode:?}"
            );
            let f = data.generalized_force(model, &tau);
            let res = &data.m_bar * qdd + a.transpose() * &data.lambda - &f;
            for &i in &data.dynamic_coords {
                assert!(
                    res[i].abs() < 1e-8 * (1.0 + f.norm() + data.lambda.norm()),
                    "EoM row {i}: {res} in {mode:?}"
                );
            }
            // free massless joints: nothing acts on them (no inertia, no contact)
            for &j in &data.free_joints {
                assert_eq!(qdd[j], 0.0);
                assert!(a.column(j).iter().all(|&x| x == 0.0));
            }
            checked += 1;
        }
    }
    checked
}

#[test]
fn residuals_every_rhex_mode() {
    for shape in [LegShape::HalfCircle, LegShape::Stick] {
        for rhex in [rhex_massless(shape), rhex_massive(shape)] {
            let labels = feasible_labels(&rhex);
            let modes: Vec<_> = labels.iter().map(|l| rhex.mode(l).unwrap()).collect();
            // and the toe-slip variants of section 5.1.5
            let mut all = modes.clone();
            for l in ["0s01", "010s", "0s0s", "0s11", "1s0s"] {
                all.push(rhex.mode(l).unwrap());
            }
            let n = check_residuals(&rhex.model, &all, 7);
            assert!(n > 200, "{n}");
        }
    }
}

#[test]
fn residuals_user_quadruped_from_file() {
    let model = quadruped();
    let specs = [
        "",
        "fore_foot",
        "hind_foot",
        "fore_foot,hind_foot",
        "fore_foot:slide,hind_foot",
        "belly",
        "fore_knee,belly",
        "fore_knee,hind_foot,belly",
    ];
    let modes: Vec<_> = specs
        .iter()
        .map(|s| ContactMode::parse_names(&model, s).unwrap())
        .collect();
    assert!(check_residuals(&model, &modes, 8) > 150);
}

/// `Ȧ` against a central difference of `A(q)` along `q̇` (valid for every contact kind:
/// the rolling contact point is a function of `q` alone on a plane).
#[test]
fn a_dot_matches_directional_difference() {
    let mut r = rng(11);
    for (model, modes) in [
        {
            let rh = rhex_massive(LegShape::HalfCircle);
            let m: Vec<_> = ["0101", "1001", "0110", "0100", "0001"]
                .iter()
                .map(|l| rh.mode(l).unwrap())
                .collect();
            (rh.model, m)
        },
        quadruped_with_all_contacts(),
    ] {
        let mut d = Data::new(&model);
        let (mut checked, mut total) = (0, 0);
        for &mode in &modes {
            for _ in 0..20 {
                total += 1;
                let q = random_q(&model, &mut r);
                let qd = random_vec(model.nq(), 1.5, &mut r);
                let _ = d.prepare(&model, &FlatGround, mode, &q, &qd);
                let a_dot = d.constraints.a_dot.clone();
                let h = 1e-6;
                let shifted = |s: f64, d: &mut Data| {
                    let qs: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a + s * b).collect();
                    let _ = d.prepare(&model, &FlatGround, mode, &qs, &qd);
                    d.constraints.a.clone()
                };
                let fd = (shifted(h, &mut d) - shifted(-h, &mut d)) / (2.0 * h);
                // skip samples where a contact switches between arc and end inside ±h
                if (&fd - &a_dot).norm() > 1e-3 {
                    continue;
                }
                assert!(
                    (&fd - &a_dot).norm() < 1e-6 * (1.0 + a_dot.norm()),
                    "Ȧ:\n{a_dot}\nFD:\n{fd}"
                );
                checked += 1;
            }
        }
        assert!(
            checked * 10 >= total * 9,
            "only {checked}/{total} samples away from a shape switch"
        );
    }
}

/// The rolling `Ȧ` differs from the stick-leg one (thesis 4.1.6), by `β̇² r n` per row:
/// a round leg and a stick leg through the same contact point share `A` but not `Ȧq̇`.
#[test]
fn rolling_and_stick_share_a_but_not_a_dot() {
    let round = rhex_massless(LegShape::HalfCircle);
    let mode = round.mode("0100").unwrap(); // front leg only
    let q = [-0.8, 0.0, 0.0, -0.2, 0.1];
    let qd = [2.0, 0.0, 0.3, -0.1, 0.5];
    let mut d = Data::new(&round.model);
    let _ = d.prepare(&round.model, &FlatGround, mode, &q, &qd);
    let (a_round, adq_round) = (d.constraints.a.clone(), d.constraints.a_dot_qd.clone());
    let (_, geo) = d.constraints.geometry[0];
    // a stick leg whose toe is the rolling contact point: a one-link leg from the hip
    let hip = d.kin.origin[0];
    let virtual_leg = geo.point - hip;
    let mut kin = Kinematics::default();
    kin.compute(&round.model, &q, &qd);
    let mut row = vec![0.0; 5];
    let part = selfmanip::core::kinematics::Part::Link(0);
    kin.point_jacobian_row(
        &round.model,
        part,
        geo.point,
        nalgebra::Vector2::new(0.0, 1.0),
        &mut row,
    );
    assert!(
        (a_round[(1, 0)] + row[0]).abs() < 1e-14,
        "same normal row as a stick at the contact point"
    );
    // stick: Ȧq̇ uses the material velocity of the contact point
    let v_mat = kin.material_velocity(part, geo.point);
    kin.point_jacobian_rate_row(
        &round.model,
        part,
        v_mat,
        nalgebra::Vector2::new(0.0, 1.0),
        &mut row,
    );
    let adq_stick: f64 = -row.iter().zip(&qd).map(|(a, b)| a * b).sum::<f64>();
    let beta_dot = kin.beta_dot[0];
    let radius = 0.5 * round.params.rho1;
    // difference = −β̇² r (n-component of n) = −β̇² r
    assert!(((adq_round[1] - adq_stick) - (-beta_dot * beta_dot * radius)).abs() < 1e-12);
    assert!(virtual_leg.norm() < round.params.rho1);
}

/// `C̄q̇` of the fast form equals the Christoffel form (4.30), and `dM̄/dt − 2C̄` is
/// skew-symmetric, with `dM̄/dt` from the exact partials.
#[test]
fn coriolis_forms_agree() {
    let mut r = rng(21);
    for model in [rhex_massive(LegShape::HalfCircle).model, quadruped()] {
        for _ in 0..20 {
            let q = random_q(&model, &mut r);
            let qd = random_vec(model.nq(), 2.0, &mut r);
            let mut kin = Kinematics::default();
            kin.compute(&model, &q, &qd);
            let c_fast = coriolis_matrix(&model, &kin);
            let c_chr = coriolis_christoffel(&model, &q, &qd);
            let v = DVector::from_column_slice(&qd);
            assert!((&c_fast * &v - &c_chr * &v).norm() < 1e-10 * (1.0 + (&c_chr * &v).norm()));
            let dm: DMatrix<f64> = mass_matrix_partials(&model, &q)
                .iter()
                .zip(&qd)
                .map(|(p, v)| p * *v)
                .fold(DMatrix::zeros(model.nq(), model.nq()), |a, b| a + b);
            for c in [&c_fast, &c_chr] {
                let s = &dm - 2.0 * c;
                assert!((&s + s.transpose()).norm() < 1e-10 * (1.0 + dm.norm()));
            }
            // and ∂M̄/∂q_k against a central difference of M̄
            let mut d = Data::new(&model);
            let k = r_index(&mut r, model.nq());
            let h = 1e-6;
            let mut mq = |s: f64| {
                let mut qs = q.clone();
                qs[k] += s;
                let _ = d.prepare(&model, &FlatGround, ContactMode::FLIGHT, &qs, &qd);
                d.m_bar.clone()
            };
            let fd = (mq(h) - mq(-h)) / (2.0 * h);
            assert!((&fd - &mass_matrix_partials(&model, &q)[k]).norm() < 1e-7);
        }
    }
}

fn r_index(r: &mut rand_chacha::ChaCha8Rng, n: usize) -> usize {
    use rand::Rng;
    r.gen_range(0..n)
}

/// Thesis (4.17): `A = [−J_h, G_sᵀ R_wpᵀ]` with `G_s`, `J_h` built from adjoints, equals the
/// point-Jacobian `A` in every mode (the printed `R_pwᵀ` is a slip: see errata).
#[test]
fn grasp_map_formulation_equals_direct_constraint() {
    let mut r = rng(31);
    for (model, modes) in [
        {
            let rh = rhex_massless(LegShape::HalfCircle);
            let m: Vec<_> = feasible_labels(&rh)
                .iter()
                .map(|l| rh.mode(l).unwrap())
                .collect();
            (rh.model, m)
        },
        quadruped_with_all_contacts(),
    ] {
        let n = model.n_joints();
        for &mode in &modes {
            for _ in 0..10 {
                let q = random_q(&model, &mut r);
                let mut kin = Kinematics::default();
                kin.compute(&model, &q, &vec![0.0; model.nq()]);
                let maps = grasp_maps(&model, &kin, &FlatGround, mode);
                let mut d = Data::new(&model);
                let _ = d.prepare(&model, &FlatGround, mode, &q, &vec![0.0; model.nq()]);
                let a = &d.constraints.a;
                let r_wp = frames::rot3(q[n + 2]);
                let body = maps.g_s.transpose() * r_wp.transpose();
                for row in 0..a.nrows() {
                    for j in 0..n {
                        assert!((a[(row, j)] + maps.j_h[(row, j)]).abs() < 1e-12);
                    }
                    for k in 0..3 {
                        assert!(
                            (a[(row, n + k)] - body[(row, k)]).abs() < 1e-12,
                            "row {row} col {k}"
                        );
                    }
                }
            }
        }
    }
}

/// The quadruped with every contact active: more constraint rows than any RHex mode.
fn quadruped_with_all_contacts() -> (Model, Vec<ContactMode>) {
    let q = quadruped();
    let m = vec![ContactMode::parse_names(&q, "fore_foot,hind_foot,fore_knee,belly").unwrap()];
    (q, m)
}
