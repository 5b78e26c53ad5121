//! Lemma 5.2, Lemma 5.3 and the massless limit (thesis section 5.1.1–5.1.2).
mod common;
use approx::assert_relative_eq;
use common::*;
use nalgebra::{DMatrix, DVector};
use selfmanip::core::{forward_dynamics, plastic_impact, ContactMode, Data, FlatGround, Model};
use selfmanip::rhex::LegShape;

/// (5.8)–(5.9) with an explicit `M̄⁻¹` (valid only for massive legs).
/// Also returns the scale of the problem, `‖M̄⁻¹(Υ − C̄q̇ − N̄)‖`, against which the errors of
/// accelerations are measured (a fully constrained mode has q̈ = 0 exactly, and the classical
/// formula reproduces that only to its own rounding).
fn classical(data: &Data, model: &Model, tau: &[f64]) -> (DVector<f64>, DVector<f64>, f64) {
    let minv = data
        .m_bar
        .clone()
        .try_inverse()
        .expect("massive legs: M̄ invertible");
    let a = &data.constraints.a;
    let f = data.generalized_force(model, tau);
    let s = a * &minv * a.transpose();
    // (nalgebra's LU cannot solve a 0×0 system: flight has no multipliers)
    let lambda = if a.nrows() == 0 {
        DVector::zeros(0)
    } else {
        s.lu()
            .solve(&(a * &minv * &f + &data.constraints.a_dot_qd))
            .unwrap()
    };
    let qdd = &minv * (&f - a.transpose() * &lambda);
    let scale = (&minv * &f).norm();
    (qdd, lambda, scale)
}

fn check_lemmas(model: &Model, modes: &[ContactMode], seed: u64) {
    let mut r = rng(seed);
    let mut data = Data::new(model);
    let mut checked = 0;
    for _ in 0..40 {
        for &mode in modes {
            let q = random_q(model, &mut r);
            let qd = project_to_constraints(model, mode, &q, &random_vec(model.nq(), 2.0, &mut r));
            let tau = random_vec(model.n_joints(), 10.0, &mut r);
            if forward_dynamics(model, &mut data, &FlatGround, mode, &q, &qd, &tau, None).is_err() {
                continue; // kinematically singular sample
            }
            if data.kkt.info().constraint_condition > 100.0 {
                // Near a kinematic singularity both formulas lose digits (the classical one
                // through M̄⁻¹, whose condition is ~10⁴ with Table 4.2 legs, cf. Fig. 5.2), so
                // 1e-10 agreement is only meaningful on well-conditioned samples.
                continue;
            }
            let (qdd, lambda, scale) = classical(&data, model, &tau);
            // Lemma 5.2: (5.3)–(5.4) ≡ (5.8)–(5.9)
            assert!(
                rel_err_v(&data.qdd, &qdd, scale) < 1e-10,
                "q̈ differs in {mode:?}: {} vs {}",
                data.qdd,
                qdd
            );
            assert!(
                rel_err_v(&data.lambda, &lambda, 1.0) < 1e-10,
                "λ differs in {mode:?}: {} vs {} (cond {:?})",
                data.lambda,
                lambda,
                data.kkt.info()
            );
            // Lemma 5.3: (5.10) ≡ (5.11) for an arbitrary incoming velocity
            let qd_minus = random_vec(model.nq(), 2.0, &mut r);
            let imp = plastic_impact(model, &mut data, &FlatGround, mode, &q, &qd_minus).unwrap();
            let minv = data.m_bar.clone().try_inverse().unwrap();
            let a = &data.constraints.a;
            let v = DVector::from_column_slice(&qd_minus);
            let p = if a.nrows() == 0 {
                DVector::zeros(0)
            } else {
                (a * &minv * a.transpose()).lu().solve(&(a * &v)).unwrap()
            };
            assert!(
                rel_err_v(&imp.impulse, &p, 1.0) < 1e-10,
                "P_λ differs in {mode:?}"
            );
            checked += 1;
        }
    }
    assert!(checked > 40, "too few non-singular samples: {checked}");
}

#[test]
fn lemma_5_2_and_5_3_rhex_massive_legs() {
    for shape in [LegShape::HalfCircle, LegShape::Stick] {
        let rhex = rhex_massive(shape);
        let modes: Vec<_> = feasible_labels(&rhex)
            .iter()
            .map(|l| rhex.mode(l).unwrap())
            .collect();
        check_lemmas(&rhex.model, &modes, 52);
    }
}

#[test]
fn lemma_5_2_and_5_3_quadruped() {
    let model = quadruped();
    let modes: Vec<_> = [
        "",
        "fore_foot",
        "fore_foot,hind_foot",
        "hind_foot,belly",
        "fore_knee,hind_foot",
    ]
    .iter()
    .map(|s| ContactMode::parse_names(&model, s).unwrap())
    .collect();
    check_lemmas(&model, &modes, 53);
}

/// Thesis (5.2): the ε-solution converges to the massless one as the leg mass ε → 0.
/// The error must shrink at least linearly in ε.
#[test]
fn massless_limit_converges() {
    let massless = rhex_massless(LegShape::HalfCircle);
    let (model, mode) = (&massless.model, massless.mode("0101").unwrap());
    let q = [-0.4, 0.5, 0.0, -0.15, 0.05];
    let qd = project_to_constraints(model, mode, &q, &[1.0, -2.0, 0.3, 0.1, 0.4]);
    let tau = [12.0, 7.0];
    let mut data = Data::new(model);
    forward_dynamics(model, &mut data, &FlatGround, mode, &q, &qd, &tau, None).unwrap();
    let (qdd0, lam0) = (data.qdd.clone(), data.lambda.clone());
    let mut errors = vec![];
    for eps in [1e-1, 1e-2, 1e-3, 1e-4] {
        let p = selfmanip::rhex::RhexParams {
            m_l: eps,
            I_l: 0.007 * eps,
            ..massless.params.clone()
        };
        let r = selfmanip::rhex::Rhex::new(p).unwrap();
        let mut d = Data::new(&r.model);
        forward_dynamics(&r.model, &mut d, &FlatGround, mode, &q, &qd, &tau, None).unwrap();
        errors.push(rel_err_v(&d.qdd, &qdd0, 1.0) + rel_err_v(&d.lambda, &lam0, 1.0));
    }
    for w in errors.windows(2) {
        assert!(
            w[1] < 0.2 * w[0],
            "error must shrink ~linearly with ε: {errors:?}"
        );
    }
    assert!(errors[3] < 1e-3, "{errors:?}");
}

/// The inverse blocks satisfy their defining identities (5.2) and the explicit forms
/// (5.5)–(5.7) when M̄ is invertible; Λ is negative definite (the thesis says "positive").
#[test]
fn kkt_blocks_match_explicit_forms() {
    let rhex = rhex_massive(LegShape::HalfCircle);
    let model = &rhex.model;
    let mode = rhex.mode("0101").unwrap();
    let q = [-0.3, 0.4, 0.0, -0.15, 0.05];
    let mut data = Data::new(model);
    data.prepare(model, &FlatGround, mode, &q, &[0.0; 5])
        .unwrap();
    let b = data.kkt.blocks();
    let a = data.constraints.a.clone();
    let minv = data.m_bar.clone().try_inverse().unwrap();
    let s = (&a * &minv * a.transpose()).try_inverse().unwrap();
    let m_dagger = &minv - &minv * a.transpose() * &s * &a * &minv;
    let a_dagger_t = &minv * a.transpose() * &s;
    assert!(rel_err(&b.m_dagger, &m_dagger, 1e-12) < 1e-10);
    assert!(rel_err(&b.a_dagger.transpose(), &a_dagger_t, 1e-12) < 1e-10);
    assert!(rel_err(&b.lambda, &(-&s), 1e-12) < 1e-10);
    // A† Aᵀ = I (left inverse), symmetric Λ, negative definite
    let c = a.nrows();
    assert_relative_eq!(
        &b.a_dagger * a.transpose(),
        DMatrix::identity(c, c),
        epsilon = 1e-10
    );
    assert!(b
        .lambda
        .clone()
        .symmetric_eigenvalues()
        .iter()
        .all(|&e| e < 0.0));
}
