//! The exact Jacobian of the Coulomb impact on its active set
//! (`selfmanip_hybrid::coulomb_impact::coulomb_impact_jacobian`, the reset Jacobian of a
//! Coulomb jam) against central differences of the impact map itself.
//!
//! The robot: a body (3 kg, 0.05 kg m²) with one massive leg of one link (0.2 m, 0.4 kg) whose
//! toe has Coulomb friction `μ = 0.6`, and a body point (`nose`, `μ = 0.4`) ahead of the hip:
//! two candidates, four coordinates, rows whose directions turn with the body and the leg.
//! At seeded random states `(q, q̇⁻)` every solution of the impact whose contacts are strictly
//! inside their states' regions is differentiated; the differences take, at `x ± h e_j`, the
//! solution with the same states (the same active set, each slip's `σ`) — the map the
//! Jacobian is of — with the model rebuilt for a parameter's column (the body's mass, the
//! link's mass with its inertia held, each contact's `μ`). Agreement to 1e-7 relative to the Jacobian's size.
use selfmanip_core::description::{FrictionDescription, RobotDescription};
use selfmanip_core::tangent::BodyParameter;
use selfmanip_core::{Data, GroundPlane, Model};
use selfmanip_hybrid::coulomb_impact::{
    coulomb_impact_jacobian, coulomb_impacts, ContactImpact, CoulombImpact, NotDifferentiable,
};

mod systems;
use systems::{body_point, one_link_leg, uniform_link, Lcg, G};

/// The robot with body mass `m_b`, link mass `m_l` and friction coefficients `(μ_toe, μ_nose)`.
fn robot(m_b: f64, m_l: f64, mu: (f64, f64)) -> Model {
    let coulomb = |mu: f64| FrictionDescription::Sticking {
        mu: Some(mu),
        mu_kinetic: None,
    };
    // the link's inertia held at the nominal link's (its mass alone is the parameter)
    let mut link = uniform_link(0.2, m_l);
    link.inertia_kg_m2 = NOMINAL.1 * 0.2 * 0.2 / 12.0;
    let mut d: RobotDescription = one_link_leg(m_b, 0.05, G, link, coulomb(mu.0));
    d.contacts
        .push(body_point("nose", [0.25, 0.05], coulomb(mu.1)));
    d.build().unwrap()
}

const NOMINAL: (f64, f64, (f64, f64)) = (3.0, 0.4, (0.6, 0.4));

/// The solutions of the impact among both contacts at `(q, q̇⁻)`.
fn solutions(model: &Model, q: &[f64], qd: &[f64]) -> Vec<CoulombImpact> {
    let mut data = Data::new(model);
    coulomb_impacts(model, &mut data, &GroundPlane::level(0.0), &[0, 1], q, qd)
        .unwrap()
        .unwrap()
}

/// `q̇⁺` of the solution with the active set `states`, if there is one.
fn same_set(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    states: &[(usize, ContactImpact)],
) -> Option<Vec<f64>> {
    solutions(model, q, qd)
        .into_iter()
        .find(|o| o.states == states)
        .map(|o| o.qd_plus)
}

/// Central difference of `f` (a `q̇⁺` on the same active set) at step `h`, or `None` when the
/// active set does not hold on both sides.
fn central(f: impl Fn(f64) -> Option<Vec<f64>>, h: f64) -> Option<Vec<f64>> {
    let (a, b) = (f(h)?, f(-h)?);
    Some(a.iter().zip(&b).map(|(x, y)| (x - y) / (2.0 * h)).collect())
}

#[test]
fn coulomb_impact_jacobian_matches_central_differences_of_the_impact() {
    let (m_b, m_l, mu) = NOMINAL;
    let model = robot(m_b, m_l, mu);
    let nq = model.nq();
    let ground = GroundPlane::level(0.0);
    let body = [BodyParameter::Mass, BodyParameter::LinkMass(0)];
    let mut rng = Lcg(30);
    let h = 1e-6;
    let (mut checked, mut slips, mut worst) = (0, 0, 0.0_f64);
    for _ in 0..60 {
        // q = [θ, x, z, φ]: the leg swung, the body pitched and moving down and along
        let q = vec![rng.uniform(-0.8, 0.8), 0.0, -0.2, rng.uniform(-0.4, 0.4)];
        let qd = vec![
            rng.uniform(-3.0, 3.0),
            rng.uniform(-2.0, 2.0),
            rng.uniform(0.2, 2.0),
            rng.uniform(-3.0, 3.0),
        ];
        for o in solutions(&model, &q, &qd) {
            let mut data = Data::new(&model);
            let Ok(jac) =
                coulomb_impact_jacobian(&model, &mut data, &ground, &o, &q, &qd, &body).unwrap()
            else {
                continue;
            };
            let states = &o.states[..];
            // the columns: q, q̇⁻, the body parameters, each μ
            let mut cols: Vec<(Vec<f64>, Option<Vec<f64>>)> = Vec::new();
            for j in 0..nq {
                let fq = |s: f64| {
                    let mut qs = q.clone();
                    qs[j] += s;
                    same_set(&model, &qs, &qd, states)
                };
                let fqd = |s: f64| {
                    let mut qds = qd.clone();
                    qds[j] += s;
                    same_set(&model, &q, &qds, states)
                };
                cols.push((
                    jac.dqd_plus.dq.column(j).iter().copied().collect(),
                    central(fq, h),
                ));
                cols.push((
                    jac.dqd_plus.dqd.column(j).iter().copied().collect(),
                    central(fqd, h),
                ));
            }
            let fb = |s: f64| same_set(&robot(m_b + s, m_l, mu), &q, &qd, states);
            let fl = |s: f64| same_set(&robot(m_b, m_l + s, mu), &q, &qd, states);
            cols.push((
                jac.dqd_plus_dbody.column(0).iter().copied().collect(),
                central(fb, h),
            ));
            cols.push((
                jac.dqd_plus_dbody.column(1).iter().copied().collect(),
                central(fl, h),
            ));
            for (k, d) in &jac.dqd_plus_dmu {
                let fm = |s: f64| {
                    let mu_s = if *k == 0 {
                        (mu.0 + s, mu.1)
                    } else {
                        (mu.0, mu.1 + s)
                    };
                    same_set(&robot(m_b, m_l, mu_s), &q, &qd, states)
                };
                cols.push((d.iter().copied().collect(), central(fm, h)));
            }
            if cols.iter().any(|(_, fd)| fd.is_none()) {
                // the active set changes within h: a state too close to its boundary
                continue;
            }
            let scale = 1.0
                + cols
                    .iter()
                    .flat_map(|(e, _)| e.iter())
                    .fold(0.0_f64, |m, v| m.max(v.abs()));
            for (exact, fd) in &cols {
                for (a, b) in exact.iter().zip(fd.as_ref().unwrap()) {
                    worst = worst.max((a - b).abs() / scale);
                }
            }
            checked += 1;
            if states
                .iter()
                .any(|(_, s)| matches!(s, ContactImpact::Slip { sigma } if *sigma != 0.0))
            {
                slips += 1;
                // a slip's impulse moves with its μ: the column is not zero
                assert!(
                    jac.dqd_plus_dmu.iter().any(|(_, d)| d.amax() > 1e-6),
                    "{o:?}"
                );
            }
        }
    }
    eprintln!("checked {checked} solutions ({slips} with a slip), worst {worst:.1e}");
    assert!(checked >= 20 && slips >= 10, "{checked} {slips}");
    assert!(worst < 1e-7, "{worst:e}");
}

/// A geometric parameter moves `A` too, which the Coulomb impact's columns do not carry: asked
/// for one, the Jacobian is refused by name rather than formed without those terms.
#[test]
fn a_geometric_parameter_is_refused_by_name() {
    let (m_b, m_l, mu) = NOMINAL;
    let model = robot(m_b, m_l, mu);
    let ground = GroundPlane::level(0.0);
    let (q, qd) = (vec![0.3, 0.0, -0.2, 0.1], vec![1.0, 1.5, 1.0, -1.0]);
    let outcomes = solutions(&model, &q, &qd);
    assert!(!outcomes.is_empty());
    for p in [
        BodyParameter::LinkLength {
            joint: 0,
            com_follows: false,
        },
        BodyParameter::ContactPosition(0, 1),
    ] {
        let mut data = Data::new(&model);
        let got = coulomb_impact_jacobian(&model, &mut data, &ground, &outcomes[0], &q, &qd, &[p]);
        assert_eq!(
            got.unwrap().err(),
            Some(NotDifferentiable::GeometricParameter(p))
        );
    }
}
