//! The damped slide of a massless two-link chain (`selfmanip_core::damped_slide`,
//! `docs/singular-transitions.md` §10): a body with one servoed leg of two massless links,
//! its foot on level ground.
//!
//! - its force and its chain's rates against the 3 × 3 linear system of the zero-inertia
//!   limit written from the leg's closed-form kinematics — the servo's balance
//!   `τ(θ̇) = Bᵀλ` with `τ = kp (θ* − θ) − kd θ̇`, and `u_n = 0` — on the cone's edge, and
//!   its consistency flag against the friction's power;
//! - the power the force delivers to the body: the friction's and the servo's;
//! - the chain law the engine reads off a servo controller: `K = diag kd`;
//! - a servo saturating at its limit: its torque-free rates against the closed form of its
//!   manifold, and the slide of a chain whose stop saturated it, linearized there, against
//!   the unsaturated servo's;
//! - none fires on a leg whose chain has one massless joint.
mod systems;

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use selfmanip_core::damped_slide::{contact_rows, damped_chain, solve};
use selfmanip_core::description::{FrictionDescription, JointAxis, LinkDescription};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{ContactKind, ContactMode, FlatGround, Model};
use selfmanip_hybrid::damped_slide::{
    add_laws, chain_accelerations, chain_law, damped_contacts, laws_on_slide_pieces, liftoff_value,
    prepare_on_pieces, torque_free_rates,
};
use selfmanip_hybrid::flow::FlowWorkspace;
use selfmanip_hybrid::Controller;
use systems::{one_link_leg, G};

const L1: f64 = 0.15;
const L2: f64 = 0.12;
const MU: f64 = 0.6;
const KP: [f64; 2] = [40.0, 25.0];
const KD: [f64; 2] = [1.1, 0.7];
const TARGET: [f64; 2] = [0.4, -0.3];

fn link(length_m: f64, mass_kg: f64) -> LinkDescription {
    LinkDescription {
        length_m,
        mass_kg,
        inertia_kg_m2: mass_kg * length_m * length_m / 12.0,
        com_m: (mass_kg > 0.0).then_some([0.0, length_m / 2.0]),
        axis: JointAxis::PlusY,
        spring: None,
        armature_kg_m2: 0.0,
        collision: Vec::new(),
    }
}

/// A 2 kg body with one leg at its centre of two links (`thigh_kg` and a massless shin),
/// the toe at the shin's end with Coulomb friction `MU`. `q = [θ₁, θ₂, x, z, φ]`.
fn robot(thigh_kg: f64) -> Model {
    let friction = FrictionDescription::Sticking {
        mu: Some(MU),
        mu_kinetic: Some(MU),
    };
    let mut d = one_link_leg(2.0, 0.03, G, link(L1, thigh_kg), friction);
    d.legs[0].links.push(link(L2, 0.0));
    if let selfmanip_core::description::ShapeDescription::Point { position_m } =
        &mut d.contacts[0].shape
    {
        *position_m = [0.0, L2];
    }
    d.build().unwrap()
}

/// A servo on both joints, `τ = kp (θ* − θ) − kd θ̇`.
#[derive(Clone)]
struct Servo;

impl Controller for Servo {
    fn torque(&self, _t: f64, q: &[f64], qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        for j in 0..2 {
            tau[j] = KP[j] * (TARGET[j] - q[j]) - KD[j] * qd[j];
        }
    }
}

/// The toe's position relative to the hip, NED, from the closed-form kinematics of the
/// chain (links along +z at zero angle, `R(a)` of the test systems), and its Jacobian
/// in `(θ₁, θ₂)` at body pitch `φ`.
fn toe(phi: f64, th: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
    // R(a) [0, l] = (l sin a, l cos a)
    let (a1, a2) = (phi + th[0], phi + th[0] + th[1]);
    let p = [L1 * a1.sin() + L2 * a2.sin(), L1 * a1.cos() + L2 * a2.cos()];
    // columns ∂p/∂θ₁, ∂p/∂θ₂
    let j = [
        [
            L1 * a1.cos() + L2 * a2.cos(),
            -L1 * a1.sin() - L2 * a2.sin(),
        ],
        [L2 * a2.cos(), -L2 * a2.sin()],
    ];
    (p, j)
}

/// A state with the toe on the ground (z = 0) and the body moving so that the foot's damped
/// slide pushes: the first of a few body velocities.
fn state() -> (Vec<f64>, Vec<f64>) {
    let model = robot(0.0);
    let (phi, th) = (0.1, [0.4, -0.9]);
    let (p, _) = toe(phi, th);
    let q = vec![th[0], th[1], 0.0, -p[1], phi];
    let mode = ContactMode::FLIGHT.with(0, ContactKind::Slide);
    let mut kin = Kinematics::default();
    for vx in [0.8, -0.8, 0.2, -0.2] {
        for vz in [0.6, -0.6, 0.1, -0.1] {
            for w in [0.4, -0.4] {
                let qd = vec![0.3, -0.5, vx, vz, w];
                let law = chain_law(&model, &Servo, (0.0, &q, &qd), mode, 0).unwrap();
                kin.compute(&model, &q, &qd);
                let d = solve(&model, &kin, &FlatGround, 0, &qd, &law, MU, None).unwrap();
                if d.is_some_and(|d| d.push() > 0.0) {
                    return (q, qd);
                }
            }
        }
    }
    panic!("no state slides damped");
}

/// The robot with two massless links at [`state`], its slide mode and the servo's chain law
/// there.
fn slide_law() -> (
    Model,
    Vec<f64>,
    Vec<f64>,
    ContactMode,
    selfmanip_core::damped_slide::ChainLaw,
) {
    let model = robot(0.0);
    let (q, qd) = state();
    let mode = ContactMode::FLIGHT.with(0, ContactKind::Slide);
    let law = chain_law(&model, &Servo, (0.0, &q, &qd), mode, 0).expect("a damped law");
    (model, q, qd, mode, law)
}

#[test]
fn force_and_rates_match_the_zero_inertia_limit() {
    let (model, q, qd, _, law) = slide_law();
    let mut kin = Kinematics::default();
    kin.compute(&model, &q, &qd);
    // the toe on the ground
    let gap = selfmanip_core::contact::contact_gap(&model, &kin, &FlatGround, 0);
    assert!(gap.abs() < 1e-12, "gap {gap}");
    let d = solve(&model, &kin, &FlatGround, 0, &qd, &law, MU, None)
        .unwrap()
        .expect("a slide");

    // closed form: toe velocity v = (ẋ, ż) + φ̇ (r_z, −r_x) + J θ̇ (NED, the systems'
    // rotation convention); the rows u = −(t·v, n·v) with n = (0, 1) into the ground and
    // t = S(n); unknowns (θ̇₁, θ̇₂, λ_n) with λ = λ_n (c, 1):
    //   kp (θ* − θ) − kd θ̇ = Bᵀ λ,   u_n(θ̇) = 0
    let (phi, th) = (q[4], [q[0], q[1]]);
    let (r, jac) = toe(phi, th);
    let n = [0.0, 1.0];
    let tan = {
        let t = selfmanip_core::GroundPlane::level(0.0).tangent();
        [t[0], t[1]]
    };
    let body_v = [qd[2] + qd[4] * r[1], qd[3] - qd[4] * r[0]];
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    // B: rows (t, n) over (θ₁, θ₂): −d · ∂p/∂θ_j
    let b = [
        [-dot(tan, jac[0]), -dot(tan, jac[1])],
        [-dot(n, jac[0]), -dot(n, jac[1])],
    ];
    let c = d.coef;
    // row j: kd_j θ̇_j + (B_tj c + B_nj) λ_n = kp_j (θ*_j − θ_j); last: −n·(v_b + J θ̇) = 0
    let m = Matrix3::new(
        KD[0],
        0.0,
        b[0][0] * c + b[1][0],
        0.0,
        KD[1],
        b[0][1] * c + b[1][1],
        -dot(n, jac[0]),
        -dot(n, jac[1]),
        0.0,
    );
    let rhs = Vector3::new(
        KP[0] * (TARGET[0] - th[0]),
        KP[1] * (TARGET[1] - th[1]),
        dot(n, body_v),
    );
    let x = m.lu().solve(&rhs).unwrap();
    let tol = 1e-9 * x.amax();
    assert!((d.rates[0] - x[0]).abs() < tol, "{} {}", d.rates[0], x[0]);
    assert!((d.rates[1] - x[1]).abs() < tol, "{} {}", d.rates[1], x[1]);
    assert!((d.lambda[1] - x[2]).abs() < tol, "{} {}", d.lambda[1], x[2]);
    // the rows of the engine are those of the closed form
    let a = contact_rows(&model, &kin, &FlatGround, 0, &qd);
    for (row, br) in b.iter().enumerate() {
        for (col, v) in br.iter().enumerate() {
            assert!((a[(row, col)] - v).abs() < 1e-12);
        }
    }
    // on the cone's edge, pushing, and its friction dissipates: −λ_t u_t ≤ 0 with
    // u_t = −t·v at the slide's rates
    let v = [
        body_v[0] + jac[0][0] * x[0] + jac[1][0] * x[1],
        body_v[1] + jac[0][1] * x[0] + jac[1][1] * x[1],
    ];
    let u_t = -dot(tan, v);
    assert!(
        (d.u_t - u_t).abs() < 1e-8 * u_t.abs().max(1.0),
        "{} {} {:?} {}",
        d.u_t,
        u_t,
        d.lambda,
        d.consistent
    );
    assert!((c.abs() - MU).abs() < 1e-15);
    assert!(d.push() > 0.0);
    // consistent: its friction dissipates, −λ_t u_t < 0, beyond the rest band
    let power = -d.lambda[0] * u_t;
    assert_eq!(
        d.consistent,
        power < 0.0 && u_t.abs() > 1e-6,
        "friction power {power}"
    );
}

/// The power the foot's force delivers to the massive part, `−λ·A_b q̇_b`, is the friction's
/// `−λ_t u_t` plus the servo's `τ(θ̇)·θ̇` at the slide's rates (module docs of
/// `selfmanip_core::damped_slide`), with `τ` the servo's closed form.
#[test]
fn the_force_does_the_friction_and_servo_work() {
    let (model, q, qd, _, law) = slide_law();
    let mut kin = Kinematics::default();
    kin.compute(&model, &q, &qd);
    let d = solve(&model, &kin, &FlatGround, 0, &qd, &law, MU, None)
        .unwrap()
        .unwrap();
    let lambda = DVector::from_column_slice(&d.lambda);
    let mut qb = DVector::from_column_slice(&qd);
    qb[0] = 0.0;
    qb[1] = 0.0;
    let body_power = -lambda.dot(&(&d.rows * &qb));
    let servo: f64 = (0..2)
        .map(|j| (KP[j] * (TARGET[j] - q[j]) - KD[j] * d.rates[j]) * d.rates[j])
        .sum();
    let friction = -d.lambda[0] * d.u_t;
    let scale = body_power.abs().max(servo.abs());
    assert!((body_power - (friction + servo)).abs() < 1e-9 * scale);
}

#[test]
fn the_chain_law_is_the_servos_damping() {
    let (model, q, qd, mode, law) = slide_law();
    let k = DMatrix::from_diagonal(&DVector::from_column_slice(&KD));
    assert!((law.damping - k).amax() < 1e-6);
    for j in 0..2 {
        let tau = KP[j] * (TARGET[j] - q[j]) - KD[j] * qd[j];
        assert!((law.torque[j] - tau).abs() < 1e-12);
    }
    // no damping, no damped slide
    assert!(
        !chain_law(&model, &Stiff, (0.0, &q, &qd), mode, 0)
            .unwrap()
            .holds
    );
}

/// A servo without damping (`τ = −θ`): the law does not hold.
#[derive(Clone)]
struct Stiff;

impl Controller for Stiff {
    fn torque(&self, _t: f64, q: &[f64], _qd: &[f64], _m: ContactMode, tau: &mut [f64]) {
        tau[0] = -q[0];
        tau[1] = -q[1];
    }
}

/// The flow of the slide at a state: the workspace prepared and solved under `ctrl`.
fn flow_at(
    model: &Model,
    ws: &mut FlowWorkspace,
    ctrl: &dyn Controller,
    (q, qd): (&[f64], &[f64]),
) {
    let mode = ContactMode::FLIGHT.with(0, ContactKind::Slide);
    ws.prepare(model, &FlatGround, ctrl, (0.0, mode), q, qd)
        .unwrap();
    ws.solve_prepared(model, ctrl, 0.0, mode, q, qd).unwrap();
}

/// The chain's acceleration in closed form (`chain_accelerations`) is the derivative of
/// the slide's rates along the flow: against a central difference of `solve`'s rates on
/// `(q ± h q̇, q̇ ± h q̈)` with the side kept.
#[test]
fn the_chain_acceleration_is_the_rates_derivative() {
    let model = robot(0.0);
    let (q, qd) = state();
    let mode = ContactMode::FLIGHT.with(0, ContactKind::Slide);
    assert_acceleration_is_rates_derivative(&model, &Servo, (&q, &qd), mode, false);
}

/// The chain's acceleration (`chain_accelerations`) of the one damped slide at `(q, q̇)`
/// in `mode` against a central difference of `solve`'s rates on `(q ± h q̇, q̇ ± h q̈)`,
/// its side kept; every law on the way on a saturated piece or none, as `saturated` says.
fn assert_acceleration_is_rates_derivative(
    model: &Model,
    ctrl: &dyn Controller,
    (q, qd): (&[f64], &[f64]),
    mode: ContactMode,
    saturated: bool,
) {
    let mut ws = FlowWorkspace::new(model);
    flow_at(model, &mut ws, ctrl, (q, qd));
    assert_eq!(ws.data.damped.len(), 1);
    assert_eq!(ws.data.damped_laws[0].1.saturated.is_some(), saturated);
    let side = ws.data.damped[0].side;
    chain_accelerations(model, &FlatGround, ctrl, (0.0, mode), (q, qd), &mut ws.data).unwrap();
    let qdd: Vec<f64> = ws.data.qdd.iter().copied().collect();
    let h = 1e-6;
    let mut kin = Kinematics::default();
    let mut rates = |s: f64| {
        let qs: Vec<f64> = q.iter().zip(qd).map(|(x, v)| x + s * h * v).collect();
        let vs: Vec<f64> = qd.iter().zip(&qdd).map(|(v, a)| v + s * h * a).collect();
        kin.compute(model, &qs, &vs);
        let law = chain_law(model, ctrl, (s * h, &qs, &vs), mode, 0).unwrap();
        assert_eq!(law.saturated.is_some(), saturated);
        solve(model, &kin, &FlatGround, 0, &vs, &law, MU, Some(side))
            .unwrap()
            .unwrap()
            .rates
    };
    let fd = (rates(1.0) - rates(-1.0)) / (2.0 * h);
    for j in 0..2 {
        let tol = 1e-5 * fd.amax().max(1.0);
        assert!(
            (qdd[j] - fd[j]).abs() < tol,
            "joint {j}: {} {}",
            qdd[j],
            fd[j]
        );
    }
}

/// Where the law stops holding (no damping) the slide's liftoff guard is negative, so the
/// slide ends there by an event; with the damped law it is the foot's push.
#[test]
fn a_law_without_damping_ends_the_slide() {
    let model = robot(0.0);
    let (q, qd) = state();
    let mut ws = FlowWorkspace::new(&model);
    flow_at(&model, &mut ws, &Servo, (&q, &qd));
    let push = ws.data.damped[0].push();
    assert!(push > 0.0);
    assert_eq!(liftoff_value(&ws.data, 0, 0), push);
    assert_eq!(-ws.data.lambda[0], push);
    // the same state under a law without damping: the flow stays defined (the damping
    // last held is carried), the guard is negative
    flow_at(&model, &mut ws, &Stiff, (&q, &qd));
    assert!(!ws.data.damped_laws[0].1.holds);
    assert!(liftoff_value(&ws.data, 0, 0) < 0.0);
    // without a law that held before, there is no damped slide: the rigid slide of a
    // two-joint massless chain is singular
    let mut fresh = FlowWorkspace::new(&model);
    let mode = ContactMode::FLIGHT.with(0, ContactKind::Slide);
    let r = fresh.prepare(&model, &FlatGround, &Stiff, (0.0, mode), &q, &qd);
    assert!(
        matches!(r, Err(selfmanip_core::CoreError::SingularKkt { .. })),
        "{r:?}"
    );
}

/// A leg with a massive thigh and a massless shin has a one-joint chain: its slide is the
/// rigid engine's, and no contact of it can slide damped.
#[test]
fn a_one_joint_chain_never_slides_damped() {
    let model = robot(0.3);
    assert_eq!(damped_chain(&model, 0), None);
    assert_eq!(damped_contacts(&model), 0);
    assert_eq!(damped_contacts(&robot(0.0)), 1);
    let (q, qd) = state();
    let mode = ContactMode::FLIGHT.with(0, ContactKind::Slide);
    assert!(chain_law(&model, &Servo, (0.0, &q, &qd), mode, 0).is_none());
}

/// A slide kept on a side inside Painlevé's region (`G_nn + c G_nt ≤ 0`, here with `K = I`
/// and the rows `b_t = (1, 0)`, `b_n = (0.3, 0.1)` over the chain: `G = B Bᵀ`, `G_nn =
/// 0.1`, `G_nt = 0.3`, so `c = −μ s = −0.6` on `s = +1` gives `0.1 − 0.18 < 0`) is flagged
/// wedged with a finite force, and its liftoff guard is negative there: the flow ends it by
/// an event. On the other side (`0.1 + 0.18 > 0`) it is not, and the guard is its push.
#[test]
fn a_wedged_side_ends_the_slide_at_its_liftoff_guard() {
    use selfmanip_core::damped_slide::{solve_rows, ChainLaw};
    let a = DMatrix::from_row_slice(2, 5, &[1.0, 0.0, 0.0, 0.0, 0.0, 0.3, 0.1, 0.0, 1.0, 0.0]);
    let law = ChainLaw {
        joints: 0..2,
        rates: DVector::from_vec(vec![0.0, 0.0]),
        torque: DVector::from_vec(vec![0.0, 0.0]),
        damping: DMatrix::identity(2, 2),
        holds: true,
        saturated: None,
    };
    // the foot moving into the ground with no force: `w_n = −1` (rows `u = w − G λ`,
    // `λ_n < 0` pushes)
    let qd = [0.0, 0.0, 0.0, -1.0, 0.0];
    let (g_nn, g_nt) = (0.3 * 0.3 + 0.1 * 0.1, 0.3);
    for s in [1.0, -1.0] {
        let d = solve_rows(0, a.clone(), &qd, &law, MU, Some(s))
            .unwrap()
            .unwrap();
        let den = g_nn - MU * s * g_nt;
        assert_eq!(d.wedged, den <= 0.0, "side {s}: G_nn + c G_nt = {den}");
        assert!(d.lambda.iter().all(|l| l.is_finite()));
        let mut data = selfmanip_core::Data::default();
        data.lambda = DVector::from_vec(vec![d.lambda[0], d.lambda[1]]);
        data.damped_laws.push((0, law.clone()));
        let push = d.push();
        data.damped.push(d);
        let guard = liftoff_value(&data, 0, 1);
        if den <= 0.0 {
            assert!(guard < 0.0, "side {s}: guard {guard}");
        } else {
            // off the wedge the force is the closed form λ_n = w_n / (G_nn + c G_nt)
            assert!(
                (push - 1.0 / den).abs() < 1e-12,
                "push {push} against {}",
                1.0 / den
            );
            assert_eq!(guard, push);
        }
    }
}

/// A stick that ends a damped slide at a force event (a controller's phase, another
/// contact's guard: no impact) starts with the foot at rest: the chain carries no
/// momentum, and its rates are set so that the toe's velocity — `(ẋ, ż) + φ̇ (r_z, −r_x) +
/// J θ̇` by the leg's closed-form kinematics — is zero, the body's rates untouched
/// ([`selfmanip_hybrid::damped_slide::consistent_rates`]). A foot left moving would be held
/// at that velocity by the stick, its sticking force working on the robot.
#[test]
fn a_stick_starts_with_the_foot_at_rest() {
    use selfmanip_hybrid::damped_slide::consistent_rates;
    let model = robot(0.0);
    let (q, qd0) = state();
    let toe_velocity = |qd: &[f64]| {
        let (r, jac) = toe(q[4], [q[0], q[1]]);
        [0, 1].map(|i| {
            [qd[2] + qd[4] * r[1], qd[3] - qd[4] * r[0]][i] + jac[0][i] * qd[0] + jac[1][i] * qd[1]
        })
    };
    let before = toe_velocity(&qd0);
    assert!(before[0].hypot(before[1]) > 0.1, "{before:?}");
    let mut data = selfmanip_core::Data::new(&model);
    let mut rates_in = |kind: ContactKind| {
        let mut qd = qd0.clone();
        let mode = ContactMode::FLIGHT.with(0, kind);
        consistent_rates(
            &model,
            &FlatGround,
            &Servo,
            (0.0, mode),
            (&q, &mut qd),
            &mut data,
        )
        .unwrap();
        qd
    };
    let qd = rates_in(ContactKind::Stick);
    let after = toe_velocity(&qd);
    assert!(
        after[0].abs() < 1e-12 && after[1].abs() < 1e-12,
        "{after:?}"
    );
    assert_eq!(qd[2..], qd0[2..]);
    // a slide keeps the slide's own rates (not the stick's)
    let qd = rates_in(ContactKind::Slide);
    let sliding = toe_velocity(&qd);
    assert!(
        sliding[0].abs() > 1e-3 && sliding[1].abs() < 1e-9,
        "{sliding:?}"
    );
}

/// The laws [`set_laws`] sets in the buffers of the ones a workspace holds are the
/// fresh laws of [`chain_law`] bit for bit, state after state; a law that stops holding (the
/// servo without damping) keeps the damping it last held with, and a mode without the slide
/// lets go of it.
#[test]
fn laws_set_in_place_are_the_fresh_laws() {
    use selfmanip_hybrid::damped_slide::{set_laws, LawScratch};
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let (model, q, qd, mode, _) = slide_law();
    let damped = damped_contacts(&model);
    let mut data = selfmanip_core::Data::new(&model);
    let mut scratch = LawScratch::default();
    let mut held = None;
    for i in 0..6 {
        let s = f64::from(i) * 0.37;
        let qd_i: Vec<f64> = qd.iter().map(|v| v * (1.0 + s)).collect();
        let state = (0.01 * s, &q[..], &qd_i[..]);
        let ctrl: &dyn Controller = if i == 4 { &Stiff } else { &Servo };
        set_laws(
            &model,
            &mut data,
            (damped, false),
            ctrl,
            state,
            mode,
            &mut scratch,
        );
        let fresh = chain_law(&model, ctrl, state, mode, 0).unwrap();
        let [(k, law)] = &data.damped_laws[..] else {
            panic!("one law: {:?}", data.damped_laws);
        };
        assert_eq!(*k, 0);
        assert_eq!(law.joints, fresh.joints);
        assert_eq!(law.holds, fresh.holds);
        assert_eq!(bits(law.torque.as_slice()), bits(fresh.torque.as_slice()));
        assert_eq!(bits(law.rates.as_slice()), bits(fresh.rates.as_slice()));
        let damping = if fresh.holds {
            bits(fresh.damping.as_slice())
        } else {
            held.clone().expect("a law held before")
        };
        assert_eq!(bits(law.damping.as_slice()), damping, "state {i}");
        held = Some(damping);
    }
    set_laws(
        &model,
        &mut data,
        (damped, false),
        &Servo,
        (0.0, &q, &qd),
        ContactMode::FLIGHT,
        &mut scratch,
    );
    assert!(data.damped_laws.is_empty());
}

/// The servo saturating at `±limit` (joint `j` at `±limit · share[j]`),
/// `τ = sat(kp (θ* − θ) − kd θ̇, ±limit)`.
#[derive(Clone)]
struct Saturating {
    limit: f64,
    share: [f64; 2],
}

impl Controller for Saturating {
    fn torque(&self, _t: f64, q: &[f64], qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        for j in 0..2 {
            let u = KP[j] * (TARGET[j] - q[j]) - KD[j] * qd[j];
            let limit = self.limit * self.share[j];
            tau[j] = u.clamp(-limit, limit);
        }
    }
}

/// The chain's torque-free rates (`torque_free_rates`) are the servo's manifold in closed
/// form, `θ̇ = kp (θ* − θ) / kd` (the saturated torque vanishes where its command does),
/// from rates deep in saturation on either side, inside it, and on one joint's piece and
/// the other's; a law without damping has none.
#[test]
fn the_torque_free_rates_are_the_servos_manifold() {
    let (model, q, _, mode, _) = slide_law();
    let ctrl = Saturating {
        limit: 0.5,
        share: [1.0, 1.0],
    };
    let manifold: Vec<f64> = (0..2).map(|j| KP[j] * (TARGET[j] - q[j]) / KD[j]).collect();
    let mut tried = 0;
    for start in [
        [40.0, -35.0],
        [-60.0, 80.0],
        [0.1, -0.2],
        [1e3, 0.0],
        [manifold[0], -1e4],
    ] {
        let qd = vec![start[0], start[1], 0.3, -0.2, 0.1];
        let rates = torque_free_rates(&model, &ctrl, (0.0, &q, &qd), mode, 0..2)
            .expect("the servo's manifold");
        for j in 0..2 {
            assert!(
                (rates[j] - manifold[j]).abs() < 1e-9 * manifold[j].abs().max(1.0),
                "from {start:?}: {rates:?} against {manifold:?}"
            );
        }
        tried += 1;
    }
    assert_eq!(tried, 5);
    let qd = vec![3.0, -2.0, 0.3, -0.2, 0.1];
    assert!(torque_free_rates(&model, &Stiff, (0.0, &q, &qd), mode, 0..2).is_none());
}

/// A chain whose rates a stop has taken to its servos' limit has no damping there (`K = 0`),
/// and its slide lies on the servo's linear piece: the reset's candidate law
/// (`add_laws`) is the servo's linearized on its torque-free manifold, and the slide it
/// gives is the one of the unsaturated servo (`force_and_rates_match_the_zero_inertia_limit`
/// checks that one against the closed form), which the reset's passes over the law's pieces
/// (`prepare_on_pieces`) keep: its rates lie inside the limit.
#[test]
fn a_saturated_stop_slides_on_the_servos_linear_piece() {
    let (model, q, qd, mode, linear) = slide_law();
    let mut kin = Kinematics::default();
    kin.compute(&model, &q, &qd);
    let want = solve(&model, &kin, &FlatGround, 0, &qd, &linear, MU, None)
        .unwrap()
        .expect("the unsaturated servo's slide");
    let torques = (0..2).map(|j| KP[j] * (TARGET[j] - q[j]) - KD[j] * want.rates[j]);
    let peak = torques.fold(0.0f64, |m, t| m.max(t.abs()));
    // the stop's rates: the servo's command beyond the limit on both joints
    let mut stopped = qd.clone();
    stopped[0] = qd[0] + 1e3;
    stopped[1] = qd[1] - 1e3;
    let ctrl = Saturating {
        limit: 2.0 * peak,
        share: [1.0, 1.0],
    };
    let at_stop = chain_law(&model, &ctrl, (0.0, &q, &stopped), mode, 0).unwrap();
    assert!(!at_stop.holds, "saturated at the stop's rates");
    let mut ws = FlowWorkspace::new(&model);
    add_laws(&model, &mut ws.data, 1, &ctrl, (0.0, &q, &stopped), mode);
    let [(0, law)] = &ws.data.damped_laws[..] else {
        panic!("one law for contact 0: {:?}", ws.data.damped_laws);
    };
    assert!(law.holds && law.saturated.is_none());
    let k = DMatrix::from_diagonal(&DVector::from_column_slice(&KD));
    assert!((&law.damping - k).amax() < 1e-6, "{}", law.damping);
    let got = solve(&model, &kin, &FlatGround, 0, &stopped, law, MU, None)
        .unwrap()
        .expect("a slide");
    let tol = 1e-9 * want.rates.amax().max(want.lambda[1].abs());
    assert!(
        (&got.rates - &want.rates).amax() < tol,
        "{} {}",
        got.rates,
        want.rates
    );
    assert!((got.lambda[1] - want.lambda[1]).abs() < tol);
    prepare_at(&model, &ctrl, (&q, &stopped), mode, &mut ws);
    assert!(ws.data.damped_laws[0].1.saturated.is_none());
    assert!((&ws.data.damped[0].rates - &want.rates).amax() < tol);
}

/// A stop that takes both servos past their limits, where the foot's slide lies on a
/// saturated piece (one servo at its limit, [`saturated_slide`], which
/// `a_saturated_servo_slides_on_its_piece` checks against the closed form): the reset's
/// passes (`prepare_on_pieces`) go from the torque-free manifold's linear piece to the
/// saturated one and find that slide, its rates on the piece it was solved on
/// (`laws_on_slide_pieces` moves nothing more).
#[test]
fn a_saturated_stop_finds_the_saturated_piece() {
    let (model, q, qd, mode, ctrl, p) = saturated_slide();
    let mut stopped = qd.clone();
    stopped[0] = qd[0] + 1e3;
    stopped[1] = qd[1] - 1e3;
    assert!(
        !chain_law(&model, &ctrl, (0.0, &q, &stopped), mode, 0)
            .unwrap()
            .holds
    );
    let mut ws = FlowWorkspace::new(&model);
    add_laws(&model, &mut ws.data, 1, &ctrl, (0.0, &q, &stopped), mode);
    assert!(ws.data.damped_laws[0].1.saturated.is_none());
    prepare_at(&model, &ctrl, (&q, &stopped), mode, &mut ws);
    assert_eq!(ws.data.damped_laws[0].1.saturated, Some(p));
    let d = &ws.data.damped[0];
    let want = DVector::from_column_slice(&qd[..2]);
    assert!(
        (&d.rates - &want).amax() < 1e-9 * want.amax(),
        "{} {want}",
        d.rates
    );
    assert_eq!(
        laws_on_slide_pieces(&model, &ctrl, (0.0, &q, &stopped), mode, &mut ws.data),
        Some(true)
    );
}

/// `ws.data` prepared at `(q, q̇)` in `mode` with its slides solved on the pieces where
/// their rates lie (`prepare_on_pieces`), which must find them.
fn prepare_at(
    model: &Model,
    ctrl: &dyn Controller,
    (q, qd): (&[f64], &[f64]),
    mode: ContactMode,
    ws: &mut FlowWorkspace,
) {
    ws.data.prepare_state(model, q, qd).unwrap();
    prepare_on_pieces(model, &FlatGround, ctrl, (0.0, q, qd), mode, &mut ws.data)
        .unwrap()
        .expect("a piece")
        .unwrap();
}

/// A state of the robot at which the foot's damped slide lies on a saturated piece of the
/// [`Saturating`] servo — one joint at its limit, the other inside it — with the chain's
/// rates the slide's own ([`consistent_rates`](selfmanip_hybrid::damped_slide::consistent_rates)):
/// over the body velocities of [`state`], the limit between the unsaturated slide's two
/// torques, the first state whose slide settles there. The model, `q`, `q̇`, the mode, the
/// servo and the saturated joint.
fn saturated_slide() -> (Model, Vec<f64>, Vec<f64>, ContactMode, Saturating, usize) {
    use selfmanip_hybrid::damped_slide::consistent_rates;
    let (model, q, _) = {
        let (q, qd) = state();
        (robot(0.0), q, qd)
    };
    let mode = ContactMode::FLIGHT.with(0, ContactKind::Slide);
    let mut kin = Kinematics::default();
    let mut data = selfmanip_core::Data::new(&model);
    for vx in [3.0, -3.0, 1.0, -1.0] {
        for vz in [0.6, -0.6, 0.1, -0.1] {
            for w in [0.4, -0.4] {
                let qd = vec![0.3, -0.5, vx, vz, w];
                let linear = chain_law(&model, &Servo, (0.0, &q, &qd), mode, 0).unwrap();
                kin.compute(&model, &q, &qd);
                let Some(free) =
                    solve(&model, &kin, &FlatGround, 0, &qd, &linear, MU, None).unwrap()
                else {
                    continue;
                };
                if !free.consistent {
                    continue;
                }
                let torque = |j: usize| (KP[j] * (TARGET[j] - q[j]) - KD[j] * free.rates[j]).abs();
                for p in [1, 0] {
                    // joint p's limit below its torque, the other's far above its own
                    let limit = 0.9 * torque(p);
                    let mut share = [1.0; 2];
                    share[1 - p] = 4.0 * torque(1 - p).max(1.0) / limit;
                    let ctrl = Saturating { limit, share };
                    let mut at = qd.clone();
                    at[..2].copy_from_slice(free.rates.as_slice());
                    consistent_rates(
                        &model,
                        &FlatGround,
                        &ctrl,
                        (0.0, mode),
                        (&q, &mut at),
                        &mut data,
                    )
                    .unwrap();
                    let law = chain_law(&model, &ctrl, (0.0, &q, &at), mode, 0).unwrap();
                    kin.compute(&model, &q, &at);
                    let settled = solve(&model, &kin, &FlatGround, 0, &at, &law, MU, None)
                        .unwrap()
                        .is_some_and(|d| {
                            d.consistent
                                && (&d.rates - DVector::from_column_slice(&at[..2])).amax() < 1e-9
                        });
                    if law.holds && law.saturated == Some(p) && settled {
                        return (model, q, at, mode, ctrl, p);
                    }
                }
            }
        }
    }
    panic!("no state's slide settles on a saturated piece");
}

/// On a saturated piece (one servo at its limit `L`, the other inside it) the slide is the
/// zero-inertia limit's 3 × 3 system written from the leg's closed-form kinematics, with the
/// saturated joint's row `(Bᵀd)_p λ_n = ±L` (its torque no longer moves with its rate) in
/// place of its servo balance; its law's damping has that joint's row zero; and the
/// commands at the slide's rates put that joint beyond its limit and the other inside it
/// (the slide lies on the piece it was solved on).
#[test]
fn a_saturated_servo_slides_on_its_piece() {
    let (model, q, qd, mode, ctrl, p) = saturated_slide();
    let law = chain_law(&model, &ctrl, (0.0, &q, &qd), mode, 0).unwrap();
    assert!(
        (0..2).all(|c| law.damping[(p, c)] == 0.0),
        "{}",
        law.damping
    );
    let mut kin = Kinematics::default();
    kin.compute(&model, &q, &qd);
    let d = solve(&model, &kin, &FlatGround, 0, &qd, &law, MU, None)
        .unwrap()
        .expect("a slide");
    assert!(d.consistent && !d.wedged && d.push() > 0.0, "{d:?}");
    let (phi, th) = (q[4], [q[0], q[1]]);
    let (r, jac) = toe(phi, th);
    let n = [0.0, 1.0];
    let tan = {
        let t = selfmanip_core::GroundPlane::level(0.0).tangent();
        [t[0], t[1]]
    };
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    let body_v = [qd[2] + qd[4] * r[1], qd[3] - qd[4] * r[0]];
    let b = [
        [-dot(tan, jac[0]), -dot(tan, jac[1])],
        [-dot(n, jac[0]), -dot(n, jac[1])],
    ];
    let c = d.coef;
    let command = |j: usize, rate: f64| KP[j] * (TARGET[j] - th[j]) - KD[j] * rate;
    let limit = |j: usize| ctrl.limit * ctrl.share[j];
    let held = command(p, d.rates[p]).clamp(-limit(p), limit(p));
    let mut m = Matrix3::zeros();
    let mut rhs = Vector3::zeros();
    for j in 0..2 {
        m[(j, 2)] = b[0][j] * c + b[1][j];
        if j == p {
            rhs[j] = held;
        } else {
            m[(j, j)] = KD[j];
            rhs[j] = KP[j] * (TARGET[j] - th[j]);
        }
        m[(2, j)] = -dot(n, jac[j]);
    }
    rhs[2] = dot(n, body_v);
    let x = m.lu().solve(&rhs).unwrap();
    let tol = 1e-9 * x.amax();
    for j in 0..2 {
        assert!(
            (d.rates[j] - x[j]).abs() < tol,
            "θ̇{j}: {} {}",
            d.rates[j],
            x[j]
        );
    }
    assert!((d.lambda[1] - x[2]).abs() < tol, "{} {}", d.lambda[1], x[2]);
    assert!(command(p, x[p]).abs() > limit(p));
    assert!(command(1 - p, x[1 - p]).abs() < limit(1 - p));
}

/// The chain's acceleration on a saturated piece (`chain_accelerations`, the bordered
/// system differentiated) is the derivative of the slide's rates along the flow: against a
/// central difference of `solve`'s rates on `(q ± h q̇, q̇ ± h q̈)` with the side kept.
#[test]
fn the_saturated_chain_acceleration_is_the_rates_derivative() {
    let (model, q, qd, mode, ctrl, _) = saturated_slide();
    assert_acceleration_is_rates_derivative(&model, &ctrl, (&q, &qd), mode, true);
}
