//! A point mass on a massless two-link leg whose knee is a torsional spring (passive joints,
//! `selfmanip_core::passive`): dropped with the toe under the hip, it bounces vertically.
//! The leg's hip is free (no torque), so the ground force passes through the hip; the knee's
//! statics make the leg a radial spring
//! `F(r) = k (δ − δ₀) / (L sin(δ/2))` with `r = 2L cos(δ/2)` (module docs of
//! `selfmanip_core::passive`: `A_ℓᵀλ = τ + τᵖ`). Checked against routes that do not use the
//! engine's KKT: the 1-D ODE `m r̈ = F(r) − m g` integrated by hand (stance duration, deepest
//! compression), the linear closed form of a stiff spring, conservation of
//! `T + V_g + V_s` without damping, and the damper's dissipation `∫ c δ̇² dt` with it.
mod common;

use selfmanip::core::description::SpringDescription;
use selfmanip::core::passive;
use selfmanip::core::{ContactMode, FlatGround, Model, RobotDescription};
use selfmanip::hybrid::{simulate, Controller, EventKind, HybridOptions, Termination};

const G: f64 = 9.81;
const M: f64 = 2.0;
const L: f64 = 0.15;
/// Downward speed at the drop (m/s).
const V_START: f64 = 0.3;

/// Touchdown speed after falling `drop_m` from `V_START`.
fn touchdown_speed(drop_m: f64) -> f64 {
    (V_START * V_START + 2.0 * G * drop_m).sqrt()
}

/// The hopper of `tests/data/robots/spring_hopper.toml` (its numbers checked against the
/// constants the closed forms use) with a knee spring of stiffness `k`, rest angle `rest`
/// and damping `c`.
fn hopper(k: f64, rest: f64, c: f64) -> Model {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/robots/spring_hopper.toml"
    );
    let mut d = RobotDescription::from_file(std::path::Path::new(path)).unwrap();
    assert_eq!((d.gravity_m_s2, d.body.mass_kg), (G, M));
    let lengths: Vec<f64> = d.legs[0].links.iter().map(|l| l.length_m).collect();
    assert_eq!(lengths, [L, L]);
    d.legs[0].links[1].spring = Some(SpringDescription {
        stiffness_n_m_per_rad: k,
        cubic_stiffness_n_m_per_rad3: 0.0,
        damping_n_m_s_per_rad: c,
        rest_angle_rad: rest,
    });
    d.build().unwrap()
}

/// No torque at the joints; in the air the massless leg returns to its rest shape (knee
/// at rest, toe under the hip) by [`passive::relaxation_qdd`]-style servoing — a massless
/// spring has nothing to load there (module docs of `selfmanip_core::passive`).
#[derive(Clone)]
struct Limp {
    rest: f64,
}

impl Controller for Limp {
    fn torque(&self, _t: f64, _q: &[f64], _qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        tau.fill(0.0);
    }
    fn free_joint_qdd(&self, _t: f64, q: &[f64], qd: &[f64], free: &[usize], out: &mut [f64]) {
        let w = 400.0;
        for (o, &j) in out.iter_mut().zip(free) {
            let target = if j == 0 { -0.5 * self.rest } else { self.rest };
            *o = -w * w * (q[j] - target) - 2.0 * w * qd[j];
        }
    }
}

/// Hip height of the leg with knee bend `δ` and the toe under the hip.
fn reach(delta: f64) -> f64 {
    2.0 * L * (0.5 * delta).cos()
}

/// The radial force of the leg at hip height `r` (the knee's statics).
fn radial_force(k: f64, rest: f64, r: f64) -> f64 {
    let delta = 2.0 * (r / (2.0 * L)).acos();
    k * (delta - rest) / (L * (0.5 * delta).sin())
}

/// `m r̈ = F(r) − m g` from touchdown at `r0` with `ṙ = −v0` until `r` is back at `r0`:
/// (stance duration, deepest compression) by classical RK4 at `h`.
fn stance_by_hand(k: f64, rest: f64, v0: f64, h: f64) -> (f64, f64) {
    let r0 = reach(rest);
    let acc = |r: f64| radial_force(k, rest, r) / M - G;
    let (mut t, mut r, mut v, mut r_min) = (0.0, r0, -v0, r0);
    loop {
        let k1 = (v, acc(r));
        let k2 = (v + 0.5 * h * k1.1, acc(r + 0.5 * h * k1.0));
        let k3 = (v + 0.5 * h * k2.1, acc(r + 0.5 * h * k2.0));
        let k4 = (v + h * k3.1, acc(r + h * k3.0));
        let (r1, v1) = (
            r + h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0),
            v + h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1),
        );
        if v > 0.0 && r1 >= r0 {
            // back at r0 within this step: interpolate the crossing linearly in r
            return (t + h * (r0 - r) / (r1 - r), r_min);
        }
        (t, r, v) = (t + h, r1, v1);
        r_min = r_min.min(r);
    }
}

/// Drops the hopper from `drop_m` above touchdown (leg at rest, toe under the hip), falling
/// at `V_START`, and runs to `t_final`.
fn bounce(model: &Model, rest: f64, drop_m: f64, t_final: f64) -> selfmanip::hybrid::Execution {
    let r0 = reach(rest);
    let q = [-0.5 * rest, rest, 0.0, -(r0 + drop_m), 0.0];
    let qd = [0.0, 0.0, 0.0, V_START, 0.0];
    let opts = HybridOptions {
        stop_at_apex: false,
        step: selfmanip::hybrid::StepOptions {
            rtol: 1e-10,
            atol: 1e-12,
            ..Default::default()
        },
        ..HybridOptions::default()
    };
    simulate(
        model,
        &FlatGround,
        &Limp { rest },
        ContactMode::FLIGHT,
        &q,
        &qd,
        t_final,
        opts,
    )
    .unwrap()
}

/// The time of the first touchdown (free fall) and a final time a little after the
/// liftoff that the hand-integrated stance predicts.
fn times(k: f64, rest: f64, drop_m: f64) -> (f64, f64) {
    let t_td = (touchdown_speed(drop_m) - V_START) / G;
    let (stance, _) = stance_by_hand(k, rest, touchdown_speed(drop_m), 1e-5);
    (t_td, t_td + stance + 0.01)
}

fn energy(model: &Model, q: &[f64], qd: &[f64]) -> f64 {
    0.5 * M * (qd[3] * qd[3] + qd[2] * qd[2]) + 0.5 * 0.02 * qd[4] * qd[4] - M * G * q[3]
        + passive::potential_energy(model, q)
}

#[test]
fn undamped_spring_leg_bounces_back_to_its_drop_height_with_the_ode_stance_time() {
    let (k, rest, drop_m) = (6.0, 1.2, 0.05);
    let model = hopper(k, rest, 0.0);
    let (t_td, t_final) = times(k, rest, drop_m);
    let exec = bounce(&model, rest, drop_m, t_final);
    assert_eq!(
        exec.termination,
        Termination::FinalTime,
        "{:?}",
        exec.events
    );
    let kinds: Vec<_> = exec.events.iter().map(|e| e.kind).collect();
    assert_eq!(
        kinds,
        [EventKind::Touchdown, EventKind::Liftoff],
        "{:?}",
        exec.events
    );
    assert!((exec.events[0].t - t_td).abs() < 1e-8, "free fall");
    let (td, lo) = (&exec.events[0], &exec.events[1]);
    // the massless leg lands without an impulse: no energy lost at touchdown
    assert!((td.kinetic_after - td.kinetic_before).abs() < 1e-9 * td.kinetic_before);
    let v0 = touchdown_speed(drop_m);
    assert!(
        (td.qd_after[3] - v0).abs() < 1e-6,
        "{} vs {v0}",
        td.qd_after[3]
    );
    // stance: the 1-D ODE integrated by hand
    let (t_stance, r_min) = stance_by_hand(k, rest, v0, 1e-6);
    assert!(
        ((lo.t - td.t) - t_stance).abs() < 1e-6,
        "stance {} vs {t_stance}",
        lo.t - td.t
    );
    // deepest compression: the largest hip depth on the stance segment's dense output
    let stance = &exec.segments[1];
    let mut y = vec![0.0; 10];
    let mut deepest = f64::INFINITY;
    let mut e_range = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..=2000 {
        let t = stance.t0 + (stance.t1 - stance.t0) * i as f64 / 2000.0;
        stance.eval(t, &mut y);
        deepest = deepest.min(-y[3]);
        let e = energy(&model, &y[..5], &y[5..]);
        e_range = (e_range.0.min(e), e_range.1.max(e));
        // the body neither pitches nor drifts: the force passes through the hip
        assert!(y[2].abs() < 1e-9 && y[4].abs() < 1e-9, "{y:?}");
    }
    assert!((deepest - r_min).abs() < 1e-6, "{deepest} vs {r_min}");
    // T + V_g + V_s is conserved through stance
    let e0 = energy(&model, &td.q, &td.qd_after);
    assert!(e_range.1 - e_range.0 < 1e-8 * e0, "{e_range:?}");
    // the leg leaves at its rest length, and the body rises back to where it fell from
    // (the apex of the ballistic flight after liftoff)
    assert!((lo.q[1] - rest).abs() < 1e-6, "knee {} at liftoff", lo.q[1]);
    let apex_height = -lo.q[3] + lo.qd_after[3].powi(2) / (2.0 * G);
    let start = reach(rest) + drop_m + V_START * V_START / (2.0 * G);
    assert!(
        (apex_height - start).abs() < 1e-7,
        "{apex_height} vs {start}"
    );
}

#[test]
fn stiff_spring_leg_tends_to_the_linear_spring_mass_closed_form() {
    // radial stiffness k_r = k / (L sin(δ₀/2))² at the rest bend: as the knee stiffens the
    // compression shrinks and the stance time tends to the linear spring–mass closed form,
    // x'' = −ω² x + g from x = 0, ẋ = v0 back to x = 0: T = (π + 2 atan(g/(ω v0)))/ω; the
    // leg's geometric nonlinearity is first order in the compression (∝ k^(−1/2))
    let (rest, drop_m) = (1.2, 0.002);
    let error = |k: f64| {
        let model = hopper(k, rest, 0.0);
        let exec = bounce(&model, rest, drop_m, times(k, rest, drop_m).1);
        let (td, lo) = (&exec.events[0], &exec.events[1]);
        let k_r = k / (L * (0.5 * rest).sin()).powi(2);
        let (w, v0) = ((k_r / M).sqrt(), touchdown_speed(drop_m));
        let t_lin = (std::f64::consts::PI + 2.0 * (G / (w * v0)).atan()) / w;
        ((lo.t - td.t) - t_lin).abs() / t_lin
    };
    let (e1, e4) = (error(500.0), error(2000.0));
    assert!(e4 < 0.6 * e1, "first order: {e1} then {e4}");
    assert!(e4 < 0.01, "{e4}");
}

#[test]
fn damped_spring_leg_loses_exactly_the_damper_work() {
    let (k, rest, c, drop_m) = (6.0, 1.2, 0.05, 0.05);
    let model = hopper(k, rest, c);
    // the undamped stance bounds the damped one's length
    let exec = bounce(&model, rest, drop_m, times(k, rest, drop_m).1);
    assert_eq!(exec.events[1].kind, EventKind::Liftoff, "{:?}", exec.events);
    let (td, lo) = (&exec.events[0], &exec.events[1]);
    let e_td = energy(&model, &td.q, &td.qd_after);
    let e_lo = energy(&model, &lo.q, &lo.qd_after);
    // ∫ c δ̇² dt over stance by Simpson's rule on the dense output
    let stance = &exec.segments[1];
    let n = 4000;
    let h = (stance.t1 - stance.t0) / n as f64;
    let mut y = vec![0.0; 10];
    let mut dissipated = 0.0;
    for i in 0..=n {
        stance.eval(stance.t0 + h * i as f64, &mut y);
        let w = common::simpson_weight(i, n);
        dissipated += w * c * y[6] * y[6];
    }
    dissipated *= h / 3.0;
    assert!(dissipated > 0.01 * e_td.abs().max(1e-3), "{dissipated}");
    assert!(
        ((e_td - e_lo) - dissipated).abs() < 1e-6 * dissipated.max(1e-9) + 1e-9,
        "lost {} vs ∫cδ̇² {dissipated}",
        e_td - e_lo
    );
    // the leg leaves when spring and damper cancel (zero force), still compressed
    let tau = passive::joint_torques(&model, &lo.q, &lo.qd_after);
    assert!(tau[1].abs() < 1e-6 * k, "knee torque {} at liftoff", tau[1]);
    assert!(lo.q[1] > rest, "knee {} still bent past rest", lo.q[1]);
    // and the body does not rise back to where it fell from
    let apex_height = -lo.q[3] + lo.qd_after[3].powi(2) / (2.0 * G);
    assert!(apex_height < reach(rest) + drop_m + V_START * V_START / (2.0 * G) - 1e-4);
}

#[test]
fn compliant_massless_leg_cannot_slide_lemma_5_1() {
    // sliding toe: one row for two massless joints — the KKT matrix is singular
    let model = hopper(6.0, 1.2, 0.0);
    let q = [-0.6, 1.2, 0.0, -reach(1.2), 0.0];
    let mut data = selfmanip::core::Data::new(&model);
    let sliding = ContactMode::FLIGHT.with(0, selfmanip::core::ContactKind::Slide);
    let err = data.prepare(&model, &FlatGround, sliding, &q, &[0.0; 5]);
    assert!(
        matches!(
            err,
            Err(selfmanip::core::CoreError::SingularKkt {
                kind: selfmanip::core::SingularityKind::UnconstrainedMasslessMotion,
                ..
            })
        ),
        "{err:?}"
    );
    // sticking: two rows for the two massless joints, regular while the leg is bent
    let sticking = ContactMode::FLIGHT.with(0, selfmanip::core::ContactKind::Stick);
    data.prepare(&model, &FlatGround, sticking, &q, &[0.0; 5])
        .unwrap();
    // and singular when it is straight (hip, knee and toe collinear)
    let straight = [0.0, 0.0, 0.0, -2.0 * L, 0.0];
    assert!(data
        .prepare(&model, &FlatGround, sticking, &straight, &[0.0; 5])
        .is_err());
}
