//! Lemma 5.1 singularities as transitions (`selfmanip_hybrid::fold`,
//! `docs/singular-transitions.md`), against closed forms.
//!
//! The system: a body (mass `m`, an inertia so large that it does not turn) on one massless
//! stick leg of length `L` hinged at its centre, the toe sliding on frictionless level ground,
//! under a joint torque. The toe on the ground ties the hip height to the leg's angle `β`
//! from straight down, `h = L cos β`; the fold is `β = 0`, the leg at full reach, where the
//! normal force has no moment about the hip and the sliding mode's KKT matrix is singular.
//!
//! - **Constant torque** `τ` (chapter 3's saturated torque): no other force does work (the
//!   toe slides level and frictionless; the body does not turn), so
//!   `½ m ḣ² + m g h = m g h₀ + τ (|β₀| − |β|)`. The contact force `τ / (L sin|β|)` grows
//!   without bound towards the fold: the leg cannot pass it, and the impulsive stick would
//!   have to pull the rising body back; complementarity releases the leg where its pin
//!   `sin|β|` reaches `ε`, and the body flies to the apex `h₀ + τ (|β₀| − asin ε) / (m g)`.
//! - **A torque–speed line** `τ = k (ω₀ − θ̇)`: the leg's speed is slaved to `ω₀` near the
//!   fold, and it passes the fold at that speed. The hip then follows `h = L cos β(t)`,
//!   `β̇ = ω₀`, so the ground's normal force is `N = m (g + ḧ) = m (g − L ω₀² cos β)`: for
//!   `L ω₀² < g` the leg passes the fold (from `−asin ε_p` to `+asin ε_p` in
//!   `2 asin ε_p / ω₀`); for `L ω₀² > g` the toe lifts off where `cos β = g / (L ω₀²)`.
mod systems;

use selfmanip_core::description::FrictionDescription;
use selfmanip_core::{ContactMode, FlatGround, Model};
use selfmanip_hybrid::{
    energy_report, ConstantTorque, Controller, EventKind, Execution, HybridOptions, Termination,
};
use systems::{fold_options, massless_leg, sliding, toe_sliding_run, G};

const M: f64 = 1.0;
const L: f64 = 0.2;
/// The body's inertia: large enough that the torque's reaction does not turn it (over the
/// run its rotation stores `τ² t² / (2 I) < 1e-7 J`).
const I_BODY: f64 = 1e6;

fn leg_robot(friction: FrictionDescription) -> Model {
    massless_leg(M, I_BODY, L, friction)
}

/// The leg at `β₀ < 0` (φ = 0, so `β = θ`), its toe on the ground, the joint turning at
/// `omega` towards the fold and the hip following (`ż = L sin β₀ · ω`, NED: up is `−z`).
fn start(beta0: f64, omega: f64) -> ([f64; 4], [f64; 4]) {
    let q = [beta0, 0.0, -L * beta0.cos(), 0.0];
    let qd = [omega, 0.0, L * beta0.sin() * omega, 0.0];
    (q, qd)
}

/// A motor's torque–speed line, `τ = k (ω₀ − θ̇)`.
#[derive(Clone)]
struct SpeedLine {
    k: f64,
    omega0: f64,
}

impl Controller for SpeedLine {
    fn torque(&self, _t: f64, _q: &[f64], qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        tau[0] = self.k * (self.omega0 - qd[0]);
    }
}

/// How closely a guard located to `event_tol_s` (1e-10 s) finds the leg's angle `β` on its
/// way to the fold under constant torque: the leg turns at `ḣ / (L sin|β|)`, `ḣ` from the
/// energy balance (1); twice that over the tolerance.
fn located(h0: f64, tau: f64, beta0: f64, beta: f64) -> f64 {
    let hdot2 = 2.0 * (tau * (beta0.abs() - beta) / M - G * (L * beta.cos() - h0));
    2.0 * 1e-10 * hdot2.sqrt() / (L * beta.sin()) * beta.cos()
}

/// Height of the hip (the body's centre) above the ground.
fn height(exec: &Execution) -> f64 {
    -exec.q[2]
}

/// Constant torque, frictionless toe: the leg is released at its fold guard and the apex is
/// `h₀ + τ (|β₀| − asin ε) / (m g)` for every threshold `ε` — without the guard the run ended
/// at the singular KKT matrix.
#[test]
fn constant_torque_leg_is_released_at_its_fold_to_the_energy_apex() {
    let model = leg_robot(FrictionDescription::Sliding);
    let (beta0, tau) = (-0.5_f64, 2.0);
    let h0 = L * beta0.cos();
    // the torque turns the leg towards the fold, pushing: N = τ / (L sin|β|) > m g at the start
    assert!(tau / (L * beta0.abs().sin()) > M * G);
    let (q, qd) = start(beta0, 0.0);
    for eps in [1e-2, 1e-3, 1e-4] {
        let press = ConstantTorque::first_joint(tau);
        let exec = toe_sliding_run(&model, &press, &q, &qd, 2.0, fold_options(eps));
        assert_eq!(exec.termination, Termination::Apex, "ε = {eps}");
        let kinds: Vec<EventKind> = exec.events.iter().map(|e| e.kind).collect();
        assert_eq!(kinds, [EventKind::Fold, EventKind::Apex], "ε = {eps}");
        let fold = &exec.events[0];
        assert!(fold.mode_after.is_flight(), "released, not stuck");
        let beta_off = fold.q[0].abs();
        assert!(
            (beta_off.sin() - eps).abs() < located(h0, tau, beta0, beta_off),
            "released where sin|β| = ε: {beta_off}"
        );
        assert_eq!(fold.qd_after[0], 0.0, "the released leg is left at rest");
        // (1) at the release, then ballistic: the torque's work τ (|β₀| − |β|) all in height
        let apex = h0 + tau * (beta0.abs() - beta_off) / (M * G);
        assert!(
            (height(&exec) - apex).abs() < 1e-8,
            "ε = {eps}: apex {} vs {apex}",
            height(&exec)
        );
        // nothing pushes the body sideways
        assert!(exec.qd[1].abs() < 1e-9 && exec.q[1].abs() < 1e-9);
        let report = energy_report(&model, &FlatGround, &exec).unwrap();
        assert!(report.residual_j().abs() < 1e-7, "{report:?}");
    }
}

/// Constant torque, toe with Coulomb friction: the fold offers the impulsive stick, which
/// would have to stop the hip rising along the leg — a pull, refused by (5.28)–(5.29); the
/// leg is released as without friction, to the same apex.
#[test]
fn impulsive_stick_that_would_pull_is_refused_at_the_fold() {
    let model = leg_robot(FrictionDescription::Sticking {
        mu: Some(1.0),
        mu_kinetic: Some(0.0),
    });
    let (beta0, tau, eps) = (-0.5_f64, 2.0, 1e-3);
    let (q, qd) = start(beta0, 0.0);
    let press = ConstantTorque::first_joint(tau);
    let exec = toe_sliding_run(&model, &press, &q, &qd, 2.0, fold_options(eps));
    assert_eq!(exec.termination, Termination::Apex);
    let fold = &exec.events[0];
    assert_eq!(fold.kind, EventKind::Fold);
    assert!(fold.mode_after.is_flight());
    let beta_off = fold.q[0].abs();
    let h0 = L * beta0.cos();
    assert!((beta_off.sin() - eps).abs() < located(h0, tau, beta0, beta_off));
    let apex = h0 + tau * (beta0.abs() - beta_off) / (M * G);
    assert!((height(&exec) - apex).abs() < 1e-8);
}

/// The options of a run through the fold (at `ε_p = 1e-2`), past any apex.
fn through_fold() -> HybridOptions {
    HybridOptions {
        stop_at_apex: false,
        ..fold_options(1e-2)
    }
}

/// A run of the leg under `ctrl` from `(q, q̇)` to `t_final` [`through_fold`], and its
/// event kinds.
fn speed_line_run(
    model: &Model,
    ctrl: &SpeedLine,
    (q, qd): (&[f64], &[f64]),
    t_final: f64,
) -> (Execution, Vec<EventKind>) {
    let exec = toe_sliding_run(model, ctrl, q, qd, t_final, through_fold());
    let kinds = exec.events.iter().map(|e| e.kind).collect();
    (exec, kinds)
}

/// A torque–speed line whose torque-free speed satisfies `L ω₀² < g`: the leg passes the
/// fold sliding, locked at `ω₀`, from `β = −asin ε_p` to `+asin ε_p` in `2 asin ε_p / ω₀`,
/// the hip at `L cos β` all the while.
#[test]
fn leg_on_a_torque_speed_line_passes_its_fold_at_the_torque_free_speed() {
    let model = leg_robot(FrictionDescription::Sliding);
    let ctrl = SpeedLine {
        k: 5.0,
        omega0: 3.0,
    };
    assert!(L * ctrl.omega0.powi(2) < G);
    let (q, qd) = start(-0.3, ctrl.omega0);
    let (exec, kinds) = speed_line_run(&model, &ctrl, (&q, &qd), 0.15);
    assert_eq!(
        kinds[..2],
        [EventKind::Fold, EventKind::FoldPassed],
        "{kinds:?}"
    );
    let (entry, exit) = (&exec.events[0], &exec.events[1]);
    let eps_p = through_fold().passage_threshold;
    assert_eq!(entry.mode_after, sliding(&[0]), "passes sliding");
    // located to event_tol_s = 1e-10 s at ~3 rad/s
    assert!(
        (entry.q[0] + eps_p.asin()).abs() < 1e-8,
        "entry {}",
        entry.q[0]
    );
    assert!(
        (exit.q[0] - eps_p.asin()).abs() < 1e-8,
        "exit {}",
        exit.q[0]
    );
    assert!(
        (entry.qd_after[0] - ctrl.omega0).abs() < 1e-9,
        "locked at the torque-free speed: {}",
        entry.qd_after[0]
    );
    let duration = (exit.q[0] - entry.q[0]) / ctrl.omega0;
    assert!((duration - 2.0 * eps_p.asin() / ctrl.omega0).abs() < 1e-8);
    assert!(
        (exit.t - entry.t - duration).abs() < 1e-9,
        "passage {} vs {duration}",
        exit.t - entry.t
    );
    // the hip on the toe, at the height of the leg's angle, and moving with it
    for e in [entry, exit] {
        assert!((-e.q[2] - L * e.q[0].cos()).abs() < 1e-9);
        let zdot = L * e.q[0].sin() * ctrl.omega0;
        assert!(
            (e.qd_after[2] - zdot).abs() < 1e-8,
            "{:?}: ż {} vs {zdot}, {:?}",
            e.kind,
            e.qd_after[2],
            e.qd_after
        );
    }
    // the segment between them is the passage: the joint locked
    let passage = exec
        .segments
        .iter()
        .find(|s| s.t0 == entry.t)
        .expect("the passage's segment");
    assert_eq!(passage.locked, vec![0]);
    // energy balances through the passage: the lock's work is that of the torque holding it,
    // and the entry's jump (the leg's fast relaxation to ω₀, in which the motor works too)
    // is booked with the impulsive events
    let report = energy_report(&model, &FlatGround, &exec).unwrap();
    assert!(
        report.residual_j().abs() < 1e-7,
        "energy residual {:e} ({report:?})",
        report.residual_j()
    );
}

/// A torque–speed line with `L ω₀² > g`: turning at `ω₀`, the leg lowers the hip faster than
/// gravity can follow, and the toe lifts off in the passage where the normal force
/// `m (g − L ω₀² cos β)` reaches zero, at `β = −acos(g / (L ω₀²))`.
#[test]
fn leg_turning_faster_than_the_body_falls_lifts_off_in_its_passage() {
    let model = leg_robot(FrictionDescription::Sliding);
    let beta_off: f64 = 0.05;
    let omega0 = (G / (L * beta_off.cos())).sqrt();
    let ctrl = SpeedLine { k: 5.0, omega0 };
    let (q, qd) = start(-0.3, omega0);
    let (exec, kinds) = speed_line_run(&model, &ctrl, (&q, &qd), 0.1);
    assert_eq!(
        kinds[..2],
        [EventKind::Fold, EventKind::Liftoff],
        "{kinds:?}"
    );
    let off = &exec.events[1];
    assert!(off.mode_after.is_flight());
    assert!(
        (off.q[0] + beta_off).abs() < 1e-6,
        "liftoff at β = {} vs {}",
        off.q[0],
        -beta_off
    );
}
