//! The Coulomb plastic impact of spatial robots (`spatial::coulomb_impact`), each against an
//! independent route: the closed form of a ball striking the ground obliquely (sticking inside
//! the cone, sliding on its edge outside it), the two limits `μ = 0` (the frictionless impact
//! (5.10)) and `μ → ∞` (the sticking one), and the massless-leg limit of RHex with legs of
//! mass ε. The planar engine's Coulomb impact is the route of `tests/spatial_planar_rhex.rs`.
mod spatial_support;
use nalgebra::{DVector, UnitQuaternion, Vector3};
use rand::Rng;
use selfmanip_core::spatial::rhex::RhexSixLegs;
use selfmanip_core::spatial::*;
use spatial_support::*;

fn rel(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    (a - b).amax() / b.amax().max(1e-300)
}

/// A ball (mass `m`, `I = k m r²`) strikes flat ground at the contact-point velocity
/// `u = v + ω × (−r ẑ)` with `u_n < 0`. The impulse `P` at the contact point changes it by
/// `W P`, `W = (1/m)(ẑẑᵀ + (1 + 1/k)(1 − ẑẑᵀ))`: the normal and tangential parts decouple, so
/// `P_n = −m u_n`; sticking needs `P_t = −m k/(1+k) u_t`, inside the cone iff
/// `k/(1+k)|u_t| ≤ μ|u_n|`; otherwise the contact slides with `P_t = −μ P_n ŝ`, and
/// `u_t⁺ = u_t − (1 + 1/k) μ |u_n| ŝ` keeps the direction `ŝ = u_t/|u_t|`. Then
/// `v⁺ = v + P/m`, `ω⁺ = ω + (r × P)/(k m r²)` (world axes; the twist of `q̇` is in the ball's
/// axes). At random orientations and rates, `μ` 5 % above and below the threshold.
#[test]
fn ball_striking_the_ground_obliquely_sticks_or_slides_as_the_closed_form() {
    let model = SpatialModel::from_urdf_str(BALL, BaseKind::FreeFlyer, None).unwrap();
    let mut data = SpatialData::new(&model);
    let (r, m, k) = (0.1, 1.5, 0.4);
    let mut rng = rng(61);
    let (mut worst, mut sticks, mut slides) = (0.0f64, 0, 0);
    for trial in 0..20 {
        let mut q = neutral(&model);
        q[2] = r;
        let axis = random_vector(3, 1.5, &mut rng);
        let rot = UnitQuaternion::from_scaled_axis(Vector3::new(axis[0], axis[1], axis[2]));
        q.as_mut_slice()[3..7].copy_from_slice(&[rot.i, rot.j, rot.k, rot.w]);
        let (mut v, w) = (
            Vector3::new(rng.gen_range(-2.0..2.0), rng.gen_range(-2.0..2.0), 0.0),
            Vector3::new(
                rng.gen_range(-20.0..20.0),
                rng.gen_range(-20.0..20.0),
                rng.gen_range(-20.0..20.0),
            ),
        );
        v.z = -rng.gen_range(0.5..3.0);
        let arm = Vector3::new(0.0, 0.0, -r);
        let u = v + w.cross(&arm);
        let u_t = Vector3::new(u.x, u.y, 0.0);
        let threshold = k / (1.0 + k) * u_t.norm() / -u.z;
        let stick = trial % 2 == 0;
        let mu = threshold * if stick { 1.05 } else { 0.95 };
        let p_n = -m * u.z;
        let p_t = if stick {
            -u_t * (m * k / (1.0 + k))
        } else {
            -u_t / u_t.norm() * (mu * p_n)
        };
        let p = p_t + Vector3::z() * p_n;
        let (v_plus, w_plus) = (v + p / m, w + arm.cross(&p) / (k * m * r * r));
        let to_body = |x: Vector3<f64>| rot.inverse() * x;
        let (vb, wb) = (to_body(v), to_body(w));
        let v_minus = DVector::from_column_slice(&[vb.x, vb.y, vb.z, wb.x, wb.y, wb.z]);
        let (vb, wb) = (to_body(v_plus), to_body(w_plus));
        let want = DVector::from_column_slice(&[vb.x, vb.y, vb.z, wb.x, wb.y, wb.z]);
        let contact = PointContact::new(&model, "ball", true)
            .unwrap()
            .on_sphere(r)
            .unwrap()
            .with_impact_friction(mu)
            .unwrap();
        let out = impact(
            &model,
            &mut data,
            &[contact],
            q.as_slice(),
            v_minus.as_slice(),
        )
        .unwrap();
        let want_p = DVector::from_column_slice(&[p.x, p.y, p.z]);
        worst = worst
            .max(rel(&out.v_plus, &want))
            .max(rel(&out.impulse, &want_p));
        match out.states[0] {
            ImpactState::Stick => {
                assert!(stick, "trial {trial} sticks");
                sticks += 1;
            }
            ImpactState::Slip { direction } => {
                assert!(!stick, "trial {trial} slides");
                worst = worst.max((direction - u_t / u_t.norm()).amax());
                slides += 1;
            }
            other => panic!("{other:?}"),
        }
    }
    eprintln!(
        "ball: {sticks} sticking, {slides} sliding; |closed form − ours| (relative) {worst:.1e}"
    );
    assert!(worst < 1e-13, "{worst}");
}

/// The quadruped's four feet coming down (base falling at 1 m/s, small random rates) at the
/// standing pose and at random joint angles near it.
fn landing_states(n: usize, seed: u64) -> Vec<(DVector<f64>, DVector<f64>)> {
    let model = quadruped();
    let mut rng = rng(seed);
    (0..n)
        .map(|_| {
            let mut q = standing_q(&model, 0.4, 0.5);
            for x in q.iter_mut().skip(7) {
                *x += rng.gen_range(-0.2..0.2);
            }
            let mut v = random_vector(model.nv, 0.3, &mut rng);
            v[2] -= 1.0;
            (q, v)
        })
        .collect()
}

/// `μ = 0` on the feet's tangent rows is the frictionless impact (5.10) of their normal rows
/// (no tangential impulse), and a large `μ` is the sticking impact of every row, the impulses
/// well inside the cone: the same `q̇⁺` and impulse (the sticking one to the last bit: the
/// same factorization of the same rows).
#[test]
fn the_limits_mu_zero_and_mu_large_are_the_frictionless_and_sticking_impacts() {
    let model = quadruped();
    let mut data = SpatialData::new(&model);
    let with_mu = |mu: f64| -> Vec<PointContact> {
        feet(&model, [true; 4])
            .into_iter()
            .map(|c| c.with_impact_friction(mu).unwrap())
            .collect()
    };
    let (mut worst_zero, mut compared) = (0.0f64, 0);
    for (q, v) in landing_states(8, 62) {
        let (q, v) = (q.as_slice(), v.as_slice());
        let frictionless = impact(&model, &mut data, &feet(&model, [false; 4]), q, v).unwrap();
        let zero = impact(&model, &mut data, &with_mu(0.0), q, v).unwrap();
        assert!(zero.states.iter().all(|s| *s == ImpactState::Frictionless));
        let normals = DVector::from_fn(4, |i, _| zero.impulse[3 * i + 2]);
        let tangents = DVector::from_fn(8, |i, _| zero.impulse[3 * (i / 2) + i % 2]);
        assert_eq!(tangents.amax(), 0.0);
        worst_zero = worst_zero
            .max(rel(&zero.v_plus, &frictionless.v_plus))
            .max(rel(&normals, &frictionless.impulse));

        let sticking = impact(&model, &mut data, &feet(&model, [true; 4]), q, v).unwrap();
        let large = impact(&model, &mut data, &with_mu(1e3), q, v).unwrap();
        assert!(large.states.iter().all(|s| *s == ImpactState::Stick));
        assert_eq!(large.v_plus, sticking.v_plus);
        assert_eq!(large.impulse, sticking.impulse);
        compared += 1;
    }
    eprintln!("quadruped landing: μ = 0 vs frictionless {worst_zero:.1e} (relative), μ = 1e3 vs sticking identical ({compared} states)");
    assert!(worst_zero < 1e-13, "{worst_zero}");
}

/// The quadruped landing with `μ = 0.3`: the outcome is unique and Coulomb's — every normal
/// velocity after is zero, a sticking foot stops with its impulse in the cone, a sliding
/// foot's impulse lies on the cone's edge opposite its slip after — the kinetic energy falls,
/// and `M(q̇⁺ − q̇⁻) = Aᵀ P` (the impulse is the generalized one applied).
#[test]
fn landing_quadruped_takes_the_coulomb_impulse() {
    let model = quadruped();
    let mut data = SpatialData::new(&model);
    let mu = 0.3;
    let contacts: Vec<PointContact> = feet(&model, [true; 4])
        .into_iter()
        .map(|c| c.with_impact_friction(mu).unwrap())
        .collect();
    let (mut worst, mut slips, mut sticks) = (0.0f64, 0, 0);
    for (q, v) in landing_states(8, 63) {
        let out = impact(&model, &mut data, &contacts, q.as_slice(), v.as_slice()).unwrap();
        // data holds M and the rows at (q, v⁻)
        let rows = &data.A * &out.v_plus;
        let scale = (&data.A * &v).amax();
        let momentum = &data.M * (&out.v_plus - &v) - data.A.transpose() * &out.impulse;
        worst = worst.max(momentum.amax() / out.impulse.amax());
        for (k, state) in out.states.iter().enumerate() {
            let (p_t, p_n) = (
                out.impulse.rows(3 * k, 2).into_owned(),
                out.impulse[3 * k + 2],
            );
            let v_t = rows.rows(3 * k, 2).into_owned();
            worst = worst.max(rows[3 * k + 2].abs() / scale);
            assert!(p_n > 0.0);
            match state {
                ImpactState::Stick => {
                    sticks += 1;
                    worst = worst.max(v_t.amax() / scale);
                    assert!(p_t.norm() <= mu * p_n);
                }
                ImpactState::Slip { direction } => {
                    slips += 1;
                    let s = v_t.normalize();
                    worst = worst
                        .max((&p_t + &s * (mu * p_n)).amax() / p_n)
                        .max((direction.x - s[0]).abs().max((direction.y - s[1]).abs()));
                }
                other => panic!("{other:?}"),
            }
        }
        let t = |x: &DVector<f64>| 0.5 * x.dot(&(&data.M * x));
        assert!(t(&out.v_plus) < t(&v));
    }
    eprintln!(
        "quadruped μ = {mu}: {sticks} feet stick, {slips} slide; Coulomb residuals {worst:.1e}"
    );
    assert!(slips > 0 && sticks > 0);
    assert!(worst < 1e-12, "{worst}");
}

/// RHex with massless legs on a tripod of toes (`μ = 0.2`, three rows each) and three legs in
/// the air: the legs in the air keep their rates through the impact, and the other rates and
/// the impulse are the limit of the same robot with legs of mass `ε` times Table 4.2's (the
/// gap falling as ε; at smaller ε the light legs make the toes' lateral impulses nearly
/// indeterminate and a second outcome appears, within round-off of the first in `q̇⁺`).
#[test]
fn massless_legs_keep_their_free_rates_and_are_the_light_legs_limit() {
    let tripod = ["front_left", "middle_right", "rear_left"];
    let robot = |eps: f64| {
        let mut p = RhexSixLegs::table_4_2().with_table_4_2_legs();
        p.leg_mass_kg *= eps;
        p.leg_inertia_kg_m2 *= eps;
        p.model().unwrap()
    };
    let contacts = |model: &SpatialModel| -> Vec<PointContact> {
        tripod
            .iter()
            .map(|leg| {
                PointContact::new(model, &format!("{leg}_toe"), true)
                    .unwrap()
                    .with_impact_friction(0.2)
                    .unwrap()
            })
            .collect()
    };
    let massless = robot(0.0);
    let mut data = SpatialData::new(&massless);
    let mut q = neutral(&massless);
    q[2] = 0.17;
    let mut rng = rng(64);
    let mut states = Vec::new();
    for _ in 0..4 {
        let mut v = random_vector(massless.nv, 0.5, &mut rng);
        v[2] -= 1.0;
        let out = impact(
            &massless,
            &mut data,
            &contacts(&massless),
            q.as_slice(),
            v.as_slice(),
        )
        .unwrap();
        let free = free_rates(&massless, &contacts(&massless));
        assert_eq!(free.len(), 3);
        for &k in &free {
            assert_eq!(out.v_plus[k], v[k], "free rate {k}");
        }
        states.push((v, out, free));
    }
    let mut gaps = Vec::new();
    for eps in [1e-1, 1e-2, 1e-3] {
        let model = robot(eps);
        let mut data = SpatialData::new(&model);
        let mut gap = 0.0f64;
        for (v, exact, free) in &states {
            let out = impact(
                &model,
                &mut data,
                &contacts(&model),
                q.as_slice(),
                v.as_slice(),
            )
            .unwrap();
            let held = |x: &DVector<f64>| {
                DVector::from_iterator(
                    x.len() - free.len(),
                    x.iter()
                        .enumerate()
                        .filter(|(i, _)| !free.contains(i))
                        .map(|(_, x)| *x),
                )
            };
            gap = gap
                .max(rel(&held(&out.v_plus), &held(&exact.v_plus)))
                .max(rel(&out.impulse, &exact.impulse));
            assert_eq!(out.states.len(), exact.states.len());
        }
        gaps.push(gap);
    }
    eprintln!(
        "RHex tripod, legs of mass ε: gap to the massless impact at ε = 1e-1, 1e-2, 1e-3: {gaps:?}"
    );
    assert!(
        gaps[1] < 0.2 * gaps[0] && gaps[2] < 0.2 * gaps[1] && gaps[2] < 1e-4,
        "{gaps:?}"
    );
    // a massless stance leg slipping is among the states (the slip fixes its hip's rate)
    assert!(states.iter().any(|(_, out, _)| out
        .states
        .iter()
        .any(|s| matches!(s, ImpactState::Slip { .. }))));
}

/// Bad impact friction names its field: negative or NaN, or on a contact without tangent rows.
#[test]
fn bad_impact_friction_names_the_field() {
    let model = SpatialModel::from_urdf_str(BALL, BaseKind::FreeFlyer, None).unwrap();
    let c = PointContact::new(&model, "ball", true).unwrap();
    for mu in [-0.1, f64::NAN] {
        let e = c.clone().with_impact_friction(mu).unwrap_err();
        assert!(
            matches!(&e, SpatialError::InvalidArgument { field, .. } if field == "friction"),
            "{e}"
        );
    }
    let e = PointContact::new(&model, "ball", false)
        .unwrap()
        .with_impact_friction(0.5)
        .unwrap_err();
    assert!(
        matches!(&e, SpatialError::InvalidArgument { field, .. } if field == "friction"),
        "{e}"
    );
    // a contact that would pull: no Coulomb impact holds it
    let mut data = SpatialData::new(&model);
    let mut q = neutral(&model);
    q[2] = 0.1;
    let c = c.on_sphere(0.1).unwrap().with_impact_friction(0.5).unwrap();
    let e = impact(
        &model,
        &mut data,
        &[c],
        q.as_slice(),
        &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
    )
    .unwrap_err();
    assert!(
        matches!(&e, SpatialError::InvalidArgument { field, .. } if field == "contacts"),
        "{e}"
    );
}
