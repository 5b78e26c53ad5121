//! Joint armature (`armature_kg_m2`, a drive's rotors reflected to the joint, `n J G²`): a
//! constant on `M̄`'s diagonal at the joint's coordinate (MuJoCo's `armature`), with no
//! coupling to the body's rotation.
//!
//! Independent routes:
//! - **(a) a pendulum on a pinned body**: its Lagrangian by hand,
//!   `L = ½ (I + m l_c² + a) θ̇² + m g l_c cos θ`, gives `θ̈ = −m g l_c sin θ / (I + m l_c² + a)`
//!   at every angle, and the small-oscillation period `2π √((I + m l_c² + a)/(m g l_c))`
//!   (with the amplitude correction `1 + θ₀²/16`), measured on the core's accelerations
//!   integrated by RK4.
//! - **(b) a free body and one link in flight**: `M̄ = Σ m JᵀJ + I J_ωᵀJ_ω + a e_θe_θᵀ`,
//!   `C̄q̇ = Σ m Jᵀ(J̇q̇)` and `N̄` assembled by hand from the closed-form positions
//!   `X + R(φ) h + R(β) c` (`docs/conventions.md`), and `M̄ q̈ = τ e_θ − C̄q̇ − N̄` solved by
//!   LU; the energy balance `E(t) − E(0) = τ (θ(t) − θ(0))` (constant internal torque) along
//!   an RK4 flight; the angular momentum about the robot's centre of mass from first
//!   principles (the pieces only: the armature's rotors carry none of their own) stays zero;
//!   and the body's pitch as a function of the leg's angle is the bare link's (the armature
//!   adds no coupling), while the leg turns slower. A rotor on its joint's axis (link mass
//!   at the hip) and a massless link with armature have closed forms.
//! - **(c) the tangent** (`selfmanip_core::tangent`): the exact Jacobians of the flow and of
//!   the plastic impact against central differences, with armature on a massive hip and on a
//!   massless knee whose toe is on the ground.
mod common;

use common::test_robot;
use nalgebra::{DMatrix, DVector, Vector2};
use selfmanip_core::tangent::{dynamics_jacobian, plastic_impact_jacobian};
use selfmanip_core::{
    contact_points, energy, forward_dynamics, plastic_impact, ContactMode, CoreError, Data,
    FlatGround, Model, RobotDescription,
};

const G: f64 = 9.81;

/// `R(β) v` (`frames.rs`: `R(β) = [[cos β, sin β], [−sin β, cos β]]`).
fn rot(b: f64, v: [f64; 2]) -> Vector2<f64> {
    let (s, c) = b.sin_cos();
    Vector2::new(c * v[0] + s * v[1], -s * v[0] + c * v[1])
}

/// `d/dβ R(β) v`.
fn drot(b: f64, v: [f64; 2]) -> Vector2<f64> {
    let (s, c) = b.sin_cos();
    Vector2::new(-s * v[0] + c * v[1], -c * v[0] - s * v[1])
}

// ------------------------------------------------------------------------------------------
// (a) a pendulum on a pinned body

const PEND_M: f64 = 0.5;
const PEND_I: f64 = 0.004;
const PEND_LC: f64 = 0.2;

/// The body of `pinned_pendulum.toml`, pinned to the ground by a sticking point and a sliding
/// one, with a pendulum hanging from its centre whose joint has `armature`; the file's
/// numbers are checked against the constants the closed form uses.
fn pinned_pendulum(armature: f64) -> Model {
    let mut d = test_robot("pinned_pendulum.toml");
    let link = &mut d.legs[0].links[0];
    assert_eq!(d.gravity_m_s2, G);
    assert_eq!((link.mass_kg, link.inertia_kg_m2), (PEND_M, PEND_I));
    assert_eq!(link.com_m, Some([0.0, PEND_LC]));
    link.armature_kg_m2 = armature;
    d.build().unwrap()
}

fn pinned_qdd(model: &Model, data: &mut Data, theta: f64, theta_dot: f64) -> f64 {
    let mode = ContactMode::with_defaults(model, &[0, 1]).unwrap();
    let (q, qd) = ([theta, 0.0, 0.0, 0.0], [theta_dot, 0.0, 0.0, 0.0]);
    forward_dynamics(model, data, &FlatGround, mode, &q, &qd, &[0.0], None).unwrap();
    // the body stays pinned
    for k in 1..4 {
        assert!(
            data.qdd[k].abs() < 1e-12,
            "body coordinate {k}: {}",
            data.qdd[k]
        );
    }
    data.qdd[0]
}

#[test]
fn armature_slows_a_pinned_pendulum_by_its_closed_form() {
    for a in [0.0, 0.006, 0.05] {
        let model = pinned_pendulum(a);
        assert!(!model.joints[0].is_massless());
        let mut data = Data::new(&model);
        let inertia = PEND_I + PEND_M * PEND_LC * PEND_LC + a;
        // θ̈(θ) at any angle, at rest and moving (a pinned body: no Coriolis on θ)
        for theta in [-2.0, -0.3, 0.01, 0.7, 2.5] {
            for theta_dot in [0.0, 3.0] {
                let qdd = pinned_qdd(&model, &mut data, theta, theta_dot);
                let expected = -PEND_M * G * PEND_LC * f64::sin(theta) / inertia;
                assert!(
                    (qdd - expected).abs() < 1e-12 * expected.abs().max(1.0),
                    "a = {a}, θ = {theta}: θ̈ = {qdd}, closed form {expected}"
                );
            }
        }
        // the small-oscillation period, by RK4 on the core's θ̈ from θ₀ at rest
        let theta0 = 0.02;
        let t0 = std::f64::consts::TAU * (inertia / (PEND_M * G * PEND_LC)).sqrt();
        let expected = t0 * (1.0 + theta0 * theta0 / 16.0);
        let dt = t0 / 4000.0;
        let (mut th, mut w, mut t) = (theta0, 0.0, 0.0);
        let mut crossings = Vec::new();
        while crossings.len() < 3 {
            let mut f = |th: f64, w: f64| pinned_qdd(&model, &mut data, th, w);
            let (k1x, k1v) = (w, f(th, w));
            let (k2x, k2v) = (
                w + 0.5 * dt * k1v,
                f(th + 0.5 * dt * k1x, w + 0.5 * dt * k1v),
            );
            let (k3x, k3v) = (
                w + 0.5 * dt * k2v,
                f(th + 0.5 * dt * k2x, w + 0.5 * dt * k2v),
            );
            let (k4x, k4v) = (w + dt * k3v, f(th + dt * k3x, w + dt * k3v));
            let th1 = th + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
            let w1 = w + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            if th.signum() != th1.signum() {
                crossings.push(t + dt * th / (th - th1));
            }
            (th, w, t) = (th1, w1, t + dt);
        }
        let period = crossings[2] - crossings[0];
        assert!(
            (period - expected).abs() < 1e-6 * expected,
            "a = {a}: period {period} s, closed form {expected} s"
        );
        if a > 0.0 {
            let bare = t0 * ((inertia - a) / inertia).sqrt();
            assert!(
                period > bare * (1.0 + 0.5 * a / inertia),
                "{period} against {bare}"
            );
        }
    }
}

// ------------------------------------------------------------------------------------------
// (b) a free body and one link in flight

const MB: f64 = 3.0;
const IB: f64 = 0.06;
const HIP: [f64; 2] = [0.15, -0.02];
const ML: f64 = 0.3;
const IL: f64 = 0.002;
const COM: [f64; 2] = [0.01, 0.1];
const ARM: f64 = 0.015;

/// A body with one link (axis `−y`, `s = −1`) and a point site at the link's centre of mass
/// (never active: it reads the engine's kinematics for the cross-check).
fn floating(
    armature: f64,
    link_mass: f64,
    link_inertia: f64,
    hip: [f64; 2],
    com: [f64; 2],
) -> Model {
    RobotDescription::from_toml_str(&format!(
        r#"
name = "floating link"
gravity_m_s2 = {G}
[body]
mass_kg = {MB}
inertia_kg_m2 = {IB}
[[legs]]
name = "arm"
hip_m = [{}, {}]
[[legs.links]]
length_m = 0.25
mass_kg = {link_mass}
inertia_kg_m2 = {link_inertia}
com_m = [{}, {}]
axis = "-y"
armature_kg_m2 = {armature}
[[contacts]]
name = "link_com"
leg = "arm"
shape = {{ kind = "point", position_m = [{}, {}] }}
friction = {{ kind = "sticking" }}
"#,
        hip[0], hip[1], com[0], com[1], com[0], com[1]
    ))
    .unwrap()
    .build()
    .unwrap()
}

/// `(M̄, τ e_θ − C̄q̇ − N̄)` by hand, `q = [θ, x, z, φ]`, `s = −1`.
fn by_hand(
    a: f64,
    (ml, il, hip, com): (f64, f64, [f64; 2], [f64; 2]),
    q: &[f64],
    qd: &[f64],
    tau: f64,
) -> (DMatrix<f64>, DVector<f64>) {
    let s = -1.0;
    let (phi, beta) = (q[3], q[3] + s * q[0]);
    let (phid, betad) = (qd[3], qd[3] + s * qd[0]);
    // link COM: p = X + R(φ) h + R(β) c
    let dc = drot(beta, com);
    let dh = drot(phi, hip);
    let cols = [
        s * dc,
        Vector2::new(1.0, 0.0),
        Vector2::new(0.0, 1.0),
        dh + dc,
    ];
    let jw = [s, 0.0, 0.0, 1.0];
    // J̇q̇ = −β̇² R(β) c − φ̇² R(φ) h
    let jdqd = -betad * betad * rot(beta, com) - phid * phid * rot(phi, hip);
    let mut m = DMatrix::zeros(4, 4);
    for i in 0..4 {
        for j in 0..4 {
            m[(i, j)] = ml * cols[i].dot(&cols[j]) + il * jw[i] * jw[j];
        }
    }
    m[(1, 1)] += MB;
    m[(2, 2)] += MB;
    m[(3, 3)] += IB;
    m[(0, 0)] += a;
    let mut f = DVector::zeros(4);
    f[0] = tau;
    for i in 0..4 {
        // − m Jᵀ J̇q̇ + m g J_zᵀ (z down)
        f[i] += -ml * cols[i].dot(&jdqd) + ml * G * cols[i].y;
    }
    f[2] += MB * G;
    (m, f)
}

fn flight_qdd(model: &Model, data: &mut Data, q: &[f64], qd: &[f64], tau: f64) -> DVector<f64> {
    forward_dynamics(
        model,
        data,
        &FlatGround,
        ContactMode::FLIGHT,
        q,
        qd,
        &[tau],
        None,
    )
    .unwrap();
    data.qdd.clone()
}

#[test]
fn flight_accelerations_are_the_hand_assembled_mass_matrix_with_armature_solved() {
    let shape = (ML, IL, HIP, COM);
    let model = floating(ARM, ML, IL, HIP, COM);
    let mut data = Data::new(&model);
    let states: [([f64; 4], [f64; 4], f64); 3] = [
        ([0.3, 0.1, -0.5, 0.2], [2.0, 0.4, -1.0, 1.5], 0.7),
        ([-1.9, 0.0, 0.0, -0.6], [-4.0, 0.0, 0.3, 0.8], -1.3),
        ([2.8, 1.0, 2.0, 3.0], [0.0, 0.0, 0.0, 0.0], 0.0),
    ];
    for (q, qd, tau) in states {
        // the engine's kinematics are the closed form's (the site at the link's COM)
        let pts = contact_points(&model, &FlatGround, &q, &qd).unwrap();
        let p = Vector2::new(q[1], q[2]) + rot(q[3], HIP) + rot(q[3] - q[0], COM);
        let site = Vector2::from(pts[0].position_m);
        assert!((site - p).norm() < 1e-14, "{site:?} against {p:?}");
        let qdd = flight_qdd(&model, &mut data, &q, &qd, tau);
        let (m, f) = by_hand(ARM, shape, &q, &qd, tau);
        assert!(
            (&data.m_bar - &m).amax() < 1e-14,
            "M̄ {} against {m}",
            data.m_bar
        );
        let expected = m.clone().lu().solve(&f).unwrap();
        assert!(
            (&qdd - &expected).amax() < 1e-10 * expected.amax().max(1.0),
            "q̈ {qdd} against {expected}"
        );
        // the armature changes the joint's response, not the assembly of the rest
        let bare = by_hand(0.0, shape, &q, &qd, tau).0;
        let mut diff = &m - &bare;
        diff[(0, 0)] -= ARM;
        assert!(diff.amax() < 1e-15, "{diff}");
    }
}

#[test]
fn a_rotor_on_its_joint_axis_and_a_massless_link_with_armature_have_closed_forms() {
    let tau = 0.9;
    let q = [0.4, 0.0, 0.0, 0.1];
    let qd = [0.0; 4];
    // link mass at the hip (h = 0, c = 0): (I + a) θ̈ + s I φ̈ = τ,  s I θ̈ + (I_b + I) φ̈ = 0
    let model = floating(ARM, ML, IL, [0.0, 0.0], [0.0, 0.0]);
    let qdd = flight_qdd(&model, &mut Data::new(&model), &q, &qd, tau);
    let s = -1.0;
    let theta_dd = tau / (IL + ARM - IL * IL / (IB + IL));
    let phi_dd = -s * IL * theta_dd / (IB + IL);
    assert!((qdd[0] - theta_dd).abs() < 1e-12 * theta_dd, "{qdd}");
    assert!((qdd[3] - phi_dd).abs() < 1e-12 * phi_dd.abs(), "{qdd}");
    // a massless link with armature is not a free joint: a θ̈ = τ, and nothing else moves
    // (the rotor's reaction on the body is the coupling the armature drops)
    let model = floating(ARM, 0.0, 0.0, HIP, COM);
    assert!(!model.joints[0].is_massless() && !model.distal_massless(0));
    let mut data = Data::new(&model);
    let qdd = flight_qdd(&model, &mut data, &q, &qd, tau);
    assert!(data.free_joints.is_empty(), "{:?}", data.free_joints);
    assert!((qdd[0] - tau / ARM).abs() < 1e-12 * tau / ARM, "{qdd}");
    assert!(
        qdd[1].abs() + (qdd[2] - G).abs() + qdd[3].abs() < 1e-13,
        "{qdd}"
    );
    // and without armature the same link is free: its θ̈ is prescribed (0), not τ / a
    let model = floating(0.0, 0.0, 0.0, HIP, COM);
    let mut data = Data::new(&model);
    let qdd = flight_qdd(&model, &mut data, &q, &qd, tau);
    assert_eq!(data.free_joints, vec![0]);
    assert_eq!(qdd[0], 0.0);
}

/// One RK4 step of the flight with constant joint torque.
fn rk4(model: &Model, data: &mut Data, y: &[f64], tau: f64, dt: f64) -> Vec<f64> {
    let mut f = |y: &[f64]| -> Vec<f64> {
        let qdd = flight_qdd(model, data, &y[..4], &y[4..], tau);
        y[4..].iter().copied().chain(qdd.iter().copied()).collect()
    };
    let add = |y: &[f64], k: &[f64], h: f64| -> Vec<f64> {
        y.iter().zip(k).map(|(a, b)| a + h * b).collect()
    };
    let k1 = f(y);
    let k2 = f(&add(y, &k1, 0.5 * dt));
    let k3 = f(&add(y, &k2, 0.5 * dt));
    let k4 = f(&add(y, &k3, dt));
    (0..y.len())
        .map(|i| y[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
        .collect()
}

/// `(r × v)_y = r_z v_x − r_x v_z` for planar `(x, z)` vectors: the moment about `+y`, the
/// sense of `φ` (a point turning at `ω` about `+y` moves at `ω (r_z, −r_x)`).
fn moment_y(r: Vector2<f64>, v: Vector2<f64>) -> f64 {
    r.y * v.x - r.x * v.y
}

/// The angular momentum about `+y` and about the centre of mass of the body and the link
/// (`I ω + m ((r − C) × (ṙ − Ċ))_y` of each piece, positions and rates in closed form), and
/// the sum of its pieces' magnitudes.
fn momentum_about_com(q: &[f64], qd: &[f64]) -> (f64, f64) {
    let s = -1.0;
    let (phi, beta) = (q[3], q[3] + s * q[0]);
    let (phid, betad) = (qd[3], qd[3] + s * qd[0]);
    let xb = Vector2::new(q[1], q[2]);
    let vb = Vector2::new(qd[1], qd[2]);
    let xl = xb + rot(phi, HIP) + rot(beta, COM);
    let vl = vb + phid * drot(phi, HIP) + betad * drot(beta, COM);
    let c = (MB * xb + ML * xl) / (MB + ML);
    let cd = (MB * vb + ML * vl) / (MB + ML);
    let pieces = [
        IB * phid + MB * moment_y(xb - c, vb - cd),
        IL * betad + ML * moment_y(xl - c, vl - cd),
    ];
    (pieces[0] + pieces[1], pieces[0].abs() + pieces[1].abs())
}

/// A flight from rest under a constant internal torque: `(t, y)` at every step.
fn flight(model: &Model, tau: f64, dt: f64, steps: usize) -> Vec<(f64, Vec<f64>)> {
    let mut data = Data::new(model);
    let mut y = vec![0.2, 0.0, -1.0, 0.1, 0.0, 0.0, 0.0, 0.0];
    let mut out = vec![(0.0, y.clone())];
    for k in 1..=steps {
        y = rk4(model, &mut data, &y, tau, dt);
        out.push((k as f64 * dt, y.clone()));
    }
    out
}

#[test]
fn flight_with_armature_conserves_energy_and_momentum_and_keeps_the_bare_links_coupling() {
    let tau = 0.25;
    let model = floating(ARM, ML, IL, HIP, COM);
    let mut data = Data::new(&model);
    let run = flight(&model, tau, 1e-4, 3000);
    let (y0, yt) = (&run[0].1, &run.last().unwrap().1);
    let (t0, v0) = energy(&model, &mut data, &y0[..4], &y0[4..]).unwrap();
    let mut seen = 0.0f64;
    for (_, y) in run.iter().step_by(100) {
        let (q, qd) = y.split_at(4);
        // E(t) − E(0) = τ (θ(t) − θ(0)): the torque's work, the armature's ½ a θ̇² included
        let (t, v) = energy(&model, &mut data, q, qd).unwrap();
        let work = tau * (q[0] - y0[0]);
        let de = t + v - (t0 + v0);
        assert!(
            (de - work).abs() < 1e-10 * (t.abs() + v0.abs()),
            "{de} against {work}"
        );
        // (the rotors' share of the torque's work: what the armature takes from the link)
        let arm_ke = 0.5 * ARM * qd[0] * qd[0];
        seen = seen.max(arm_ke / work.abs().max(1e-300));
        // angular momentum about the COM: zero from rest (no rotor momentum of its own)
        let (h, scale) = momentum_about_com(q, qd);
        assert!(h.abs() < 1e-9 * scale.max(1e-9), "H = {h:e} of {scale:e}");
    }
    assert!(
        seen > 0.3,
        "the rotors hold a good share of the torque's work: {seen}"
    );
    // the bare link (same torque): faster, but the body pitch as a function of the leg angle
    // is the same (the armature adds no coupling with the body's rotation)
    let bare = floating(0.0, ML, IL, HIP, COM);
    let run0 = flight(&bare, tau, 2e-5, 20000);
    let (theta_a, phi_a) = (yt[0], yt[3]);
    let k = run0
        .iter()
        .position(|(_, y)| (y[0] - y0[0]) >= (theta_a - y0[0]))
        .expect("the bare link turns further in the same time");
    assert!(
        run0[k].0 < 0.6 * run.last().unwrap().0,
        "the bare link is faster"
    );
    // cubic Hermite of φ in time at θ = θ_a (θ linear in t over one step)
    let (ya, yb) = (&run0[k - 1].1, &run0[k].1);
    let h = run0[k].0 - run0[k - 1].0;
    let u = (theta_a - ya[0]) / (yb[0] - ya[0]);
    let (h00, h10, h01, h11) = (
        2.0 * u.powi(3) - 3.0 * u * u + 1.0,
        u.powi(3) - 2.0 * u * u + u,
        -2.0 * u.powi(3) + 3.0 * u * u,
        u.powi(3) - u * u,
    );
    let phi_bare = h00 * ya[3] + h10 * h * ya[7] + h01 * yb[3] + h11 * h * yb[7];
    let turned = phi_a - y0[3];
    assert!(turned.abs() > 0.01, "the body turned back: {turned}");
    assert!(
        (phi_bare - phi_a).abs() < 1e-6 * turned.abs(),
        "φ at θ = {theta_a}: {phi_a} with armature, {phi_bare} bare"
    );
}

// ------------------------------------------------------------------------------------------
// (c) the tangent

/// A body with a two-link leg: a massive hip with armature and a massless knee with
/// armature, its toe a sticking point.
fn two_link() -> Model {
    test_robot("armature_two_link_leg.toml").build().unwrap()
}

/// `x` with entry `k` moved by `s`.
fn nudged<const N: usize>(mut x: [f64; N], k: usize, s: f64) -> [f64; N] {
    x[k] += s;
    x
}

#[test]
fn tangent_with_armature_matches_central_differences() {
    let model = two_link();
    assert!((0..2).all(|j| !model.distal_massless(j)));
    let mut data = Data::new(&model);
    // toe on the ground: body at z = −(0.15 cos θ1 + 0.15 cos(θ1 + θ2)) for φ = 0, hip x 0.1
    let (t1, t2) = (0.3f64, -0.7f64);
    let z = -(0.15 * t1.cos() + 0.15 * (t1 + t2).cos());
    let q = [t1, t2, 0.0, z, 0.0];
    let qd = [1.2, -0.8, 0.3, 0.1, 0.5];
    let tau = [0.6, -0.2];
    let stance = ContactMode::with_defaults(&model, &[0]).unwrap();
    let h = 1e-6;
    for mode in [ContactMode::FLIGHT, stance] {
        let jac =
            dynamics_jacobian(&model, &mut data, &FlatGround, mode, &q, &qd, &tau, None).unwrap();
        let mut eval = |q: &[f64], qd: &[f64], tau: &[f64]| {
            forward_dynamics(&model, &mut data, &FlatGround, mode, q, qd, tau, None).unwrap();
            (data.qdd.clone(), data.lambda.clone())
        };
        let check = |name: &str, exact: &DMatrix<f64>, fd: &DMatrix<f64>| {
            let scale = fd.amax().max(1.0);
            assert!(
                (exact - fd).amax() < 1e-6 * scale,
                "{name}: exact {exact} against differences {fd}"
            );
        };
        let (mut fq, mut fqd, mut ft) = (
            DMatrix::zeros(5, 5),
            DMatrix::zeros(5, 5),
            DMatrix::zeros(5, 2),
        );
        let c = jac.dlambda.dq.nrows();
        let (mut lq, mut lqd) = (DMatrix::zeros(c, 5), DMatrix::zeros(c, 5));
        for k in 0..5 {
            let (a, la) = eval(&nudged(q, k, h), &qd, &tau);
            let (b, lb) = eval(&nudged(q, k, -h), &qd, &tau);
            fq.set_column(k, &((a - b) / (2.0 * h)));
            lq.set_column(k, &((la - lb) / (2.0 * h)));
            let (a, la) = eval(&q, &nudged(qd, k, h), &tau);
            let (b, lb) = eval(&q, &nudged(qd, k, -h), &tau);
            fqd.set_column(k, &((a - b) / (2.0 * h)));
            lqd.set_column(k, &((la - lb) / (2.0 * h)));
        }
        for j in 0..2 {
            let a = eval(&q, &qd, &nudged(tau, j, h)).0;
            let b = eval(&q, &qd, &nudged(tau, j, -h)).0;
            ft.set_column(j, &((a - b) / (2.0 * h)));
        }
        check("∂q̈/∂q", &jac.dqdd.dq, &fq);
        check("∂q̈/∂q̇", &jac.dqdd.dqd, &fqd);
        check("∂q̈/∂τ", &jac.dqdd_dtau, &ft);
        if c > 0 {
            check("∂λ/∂q", &jac.dlambda.dq, &lq);
            check("∂λ/∂q̇", &jac.dlambda.dqd, &lqd);
        }
    }
    // the plastic impact into stance
    let qd_minus = [1.2, -0.8, 0.3, 0.9, 0.5];
    let jac =
        plastic_impact_jacobian(&model, &mut data, &FlatGround, stance, &q, &qd_minus).unwrap();
    let mut fq = DMatrix::zeros(5, 5);
    let mut fqd = DMatrix::zeros(5, 5);
    for k in 0..5 {
        let mut eval = |q: &[f64], qd: &[f64]| {
            plastic_impact(&model, &mut data, &FlatGround, stance, q, qd)
                .unwrap()
                .qd_plus
        };
        let (p, m) = (nudged(q, k, h), nudged(q, k, -h));
        fq.set_column(
            k,
            &((eval(&p, &qd_minus) - eval(&m, &qd_minus)) / (2.0 * h)),
        );
        let (p, m) = (nudged(qd_minus, k, h), nudged(qd_minus, k, -h));
        fqd.set_column(k, &((eval(&q, &p) - eval(&q, &m)) / (2.0 * h)));
    }
    assert!(
        (&jac.dqd_plus.dq - &fq).amax() < 1e-6 * fq.amax().max(1.0),
        "{fq}"
    );
    assert!((&jac.dqd_plus.dqd - &fqd).amax() < 1e-6, "{fqd}");
    // the impact's energy loss: the armature's kinetic energy is in ½ q̇ᵀM̄q̇ (the toe stops)
    let plus = jac.impact.qd_plus.as_slice().to_vec();
    let ke = |qd: &[f64]| energy(&model, &mut Data::new(&model), &q, qd).unwrap().0;
    assert!(ke(&plus) < ke(&qd_minus), "a plastic impact loses energy");
}

// ------------------------------------------------------------------------------------------
// the description

#[test]
fn bad_armature_is_a_typed_error_naming_the_field() {
    for bad in ["-0.01", "nan", "inf"] {
        let text = format!(
            "name = \"r\"\n[body]\nmass_kg = 1.0\ninertia_kg_m2 = 0.1\n[[legs]]\nname = \"l\"\n\
             hip_m = [0.0, 0.0]\n[[legs.links]]\nlength_m = 0.1\narmature_kg_m2 = {bad}\n"
        );
        match RobotDescription::from_toml_str(&text).unwrap().build() {
            Err(CoreError::InvalidDescription { field, .. }) => {
                assert_eq!(field, "legs[0].links[0].armature_kg_m2")
            }
            other => panic!("{bad}: {other:?}"),
        }
    }
}

#[test]
fn armature_round_trips_and_is_omitted_at_zero() {
    let d = RobotDescription::from_toml_str(&two_link_text_for_roundtrip()).unwrap();
    let text = d.to_toml_string();
    assert!(text.contains("armature_kg_m2 = 0.01"), "{text}");
    assert_eq!(text.matches("armature_kg_m2").count(), 1, "{text}");
    assert_eq!(RobotDescription::from_toml_str(&text).unwrap(), d);
    let json = serde_json::to_string(&d).unwrap();
    assert_eq!(RobotDescription::from_json_str(&json).unwrap(), d);
}

fn two_link_text_for_roundtrip() -> String {
    "name = \"r\"\n[body]\nmass_kg = 1.0\ninertia_kg_m2 = 0.1\n[[legs]]\nname = \"l\"\n\
     hip_m = [0.0, 0.0]\n[[legs.links]]\nlength_m = 0.1\narmature_kg_m2 = 0.01\n\
     [[legs.links]]\nlength_m = 0.1\n"
        .into()
}
