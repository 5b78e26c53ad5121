//! Derivatives of whole runs with respect to a behaviour's named parameters (its
//! `[parameters]` table): the behaviour interpreter's exact parameter partials
//! (`Controller::parameter_partials`, `time_events`' `dt/dp`) carried through every event by
//! `execution_sensitivity_columns`, against an independent route: central differences of
//! whole runs with the parameter set to `p ± h` in the behaviour (recompiled, so every number
//! that depends on it moves), at two steps to show the difference has converged in `h`.
//!
//! - the hopper under `examples/data/hop.toml` (a knee spring, a push `t_compress` after the
//!   touchdown, swings started at the liftoff), every parameter, including `k_land`, a
//!   formula of `a_land` (to differentiate with respect to it is to override it);
//! - a variant with a knee servo that saturates in stance, a push at a fixed time `t_push`
//!   (a timed phase: the target jumps there, `dt/dp` a time event's), a hip torque schedule
//!   whose breakpoints and torque are parameters, and the hip's own flight swing;
//! - a name the behaviour does not have is a typed error, never a zero.
use nalgebra::DMatrix;
use selfmanip_hybrid::sensitivity::{execution_sensitivity_columns, Parameter, SensitivityError};
use selfmanip_hybrid::EventKind;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::expr::Scalar;
use selfmanip_sim::{Scenario, Simulation};
mod common;
use common::{data, hopper};

/// The final state `(q, q̇)` and the event kinds of the scenario's run.
fn run(s: &Scenario) -> (Vec<f64>, Vec<EventKind>, selfmanip_sim::Run) {
    let mut sim = Simulation::new(s).unwrap();
    sim.options.control_free_joints = true;
    let run = sim.run().unwrap();
    let e = &run.execution;
    let x = e.q.iter().chain(&e.qd).copied().collect();
    let kinds = e.events.iter().map(|e| e.kind).collect();
    (x, kinds, run)
}

/// The value of parameter `name` (a number, or a formula of numbers).
fn value(b: &Behaviour, name: &str) -> f64 {
    let num = |s: &Scalar| match s {
        Scalar::Number(x) => Some(*x),
        Scalar::Expr(_) => None,
    };
    let s = &b.parameters[name];
    num(s).unwrap_or_else(|| {
        let e = s.parse(name).unwrap();
        e.eval(&|n| num(&b.parameters[n])).unwrap()
    })
}

/// `dx(T)/dp` by central differences of whole runs with step `h` (each run keeps the
/// reference's event kinds).
fn central_difference(s: &Scenario, name: &str, h: f64, kinds: &[EventKind]) -> Vec<f64> {
    let p = value(&s.behaviour, name);
    let at = |v: f64| {
        let mut t = s.clone();
        t.behaviour
            .parameters
            .insert(name.into(), Scalar::Number(v));
        let (x, k, _) = run(&t);
        assert_eq!(k, kinds, "{name} = {v}: another event sequence");
        x
    };
    let (xp, xm) = (at(p + h), at(p - h));
    xp.iter()
        .zip(&xm)
        .map(|(a, b)| (a - b) / (2.0 * h))
        .collect()
}

/// Every named parameter's column against central differences `D(h)` of whole runs,
/// Richardson-extrapolated from `h = 1e-3 |p|` and `h/2` (`(4 D(h/2) − D(h))/3`, the
/// differences' `h²` term removed; round-off of runs at `rtol = 1e-12` stays ~1e-9 at these
/// steps). That the differences have converged in `h` is shown by `|D(h) − D(h/2)|` (three
/// times the truncation left in `D(h/2)`, and what the extrapolation removes) staying small.
/// Returns the worst relative error (max norm over the state, relative to the column's
/// size plus `floor`).
fn check_every_parameter(s: &Scenario, names: &[&str], step: f64, tol: f64) -> f64 {
    let floor = 1e-3;
    let (x0, kinds, run0) = run(s);
    let n2 = x0.len();
    let params: Vec<Parameter> = names
        .iter()
        .map(|n| Parameter::Controller((*n).into()))
        .collect();
    let cs = execution_sensitivity_columns(
        &run0.model,
        &run0.terrain,
        &run0.execution,
        &DMatrix::zeros(n2, 0),
        &params,
    )
    .unwrap();
    let cols = cs.columns.expect("defined along the run");
    let mut worst: f64 = 0.0;
    for (k, name) in names.iter().enumerate() {
        let p = value(&s.behaviour, name);
        let h = step * p.abs().max(0.1);
        let d1 = central_difference(s, name, h, &kinds);
        let d2 = central_difference(s, name, 0.5 * h, &kinds);
        let fd: Vec<f64> = d1
            .iter()
            .zip(&d2)
            .map(|(a, b)| (4.0 * b - a) / 3.0)
            .collect();
        let scale = fd.iter().fold(0.0f64, |m, x| m.max(x.abs())) + floor;
        let gap = d1
            .iter()
            .zip(&d2)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
            / scale;
        let err = (0..n2)
            .map(|i| (cols[(i, k)] - fd[i]).abs())
            .fold(0.0, f64::max)
            / scale;
        eprintln!("d x(T)/d {name}: error {err:.2e} (|D(h) - D(h/2)| {gap:.2e})");
        assert!(gap < 1e-3, "{name}: the differences have not converged");
        assert!(err < tol, "{name}: {:?} vs {fd:?}", cols.column(k));
        worst = worst.max(err);
    }
    worst
}

#[test]
fn hop_parameters_match_central_differences() {
    let b = Behaviour::from_file(&data("hop.toml")).unwrap();
    let names = [
        "a_land",
        "lean",
        "k_land",
        "k_push",
        "kp_spring",
        "kd_spring",
        "kp_push",
        "t_compress",
        "swing_speed",
        "swing_accel",
    ];
    for t_final in [0.25, 0.28] {
        let worst = check_every_parameter(&hopper(b.clone(), t_final), &names, 1e-3, 1e-6);
        eprintln!("T = {t_final}: worst {worst:.2e}");
    }
}

/// The variant: a knee servo that saturates in stance, a push at a fixed time, a hip torque
/// schedule in stance and a hip swing of its own in flight.
fn saturating_timed_behaviour() -> Behaviour {
    let text = std::fs::read_to_string(data("hop.toml"))
        .unwrap()
        .replace(
            r#"kd_n_m_s_per_rad = "kd_spring" }"#,
            r#"kd_n_m_s_per_rad = "kd_spring", torque_limit_n_m = "tau_limit" }"#,
        )
        .replace(
            r#"start = { on = "phase", phase = "leg[1].stance", delay_s = "t_compress" }"#,
            r#"start = { at_s = "t_push" }"#,
        )
        .replace(
            "swing_accel = 600.0\n",
            "swing_accel = 600.0\ntau_limit = 12.0\nt_push = 0.13\ntau_hip = 0.05\nt_ramp = 0.02\nhip_air = \"a_land + 0.1\"\n",
        )
        .replace(
            r#"restart_on = [{ on = "release" }]

[[joints]]
joint = "leg[1]""#,
            r#"restart_on = [{ on = "release" }]
[[joints.phases]]
name = "stance"
start = { on = "touch" }
torque = { kind = "schedule", times_s = ["t_push - t_ramp", "t_push"], torques_n_m = [0.0, "tau_hip"] }
[[joints.phases]]
name = "flight"
start = { on = "release" }
motion = { kind = "park", target_rad = "hip_air", accel_rad_s2 = "swing_accel" }

[[joints]]
joint = "leg[1]""#,
        );
    Behaviour::from_toml_str(&text).unwrap()
}

#[test]
fn a_saturating_servo_a_timed_push_and_a_schedule_match_central_differences() {
    let b = saturating_timed_behaviour();
    let names = [
        "a_land",
        "k_push",
        "kp_spring",
        "kp_push",
        "tau_limit",
        "t_push",
        "tau_hip",
        "t_ramp",
        "hip_air",
        "swing_accel",
    ];
    // touchdown at 0.087 s, the push at 0.13 s (the knee's servo saturated at 12 N m for
    // most of it), the foot slips and leaves at 0.27 s; in the push and in the air before
    // the apex, once the swings are over (a park's duration is searched in steps of 2 %: a
    // motion in progress moves by a jump where the count changes, which differences of
    // whole runs over steps ≥ 1e-4 cross)
    for (t_final, kinds) in [
        (0.2, vec![EventKind::Touchdown]),
        (0.375, vec![EventKind::Touchdown, EventKind::Slip]),
    ] {
        let s = hopper(b.clone(), t_final);
        let (_, k, _) = run(&s);
        assert_eq!(k, kinds);
        let worst = check_every_parameter(&s, &names, 1e-3, 1e-6);
        eprintln!("T = {t_final}: worst {worst:.2e}");
    }
}

#[test]
fn a_name_the_behaviour_does_not_have_is_a_typed_error() {
    let s = hopper(Behaviour::from_file(&data("hop.toml")).unwrap(), 0.25);
    let (x, _, r) = run(&s);
    for bad in ["kp_sprin", "t2", "leg.stall_torque_n_m"] {
        let e = execution_sensitivity_columns(
            &r.model,
            &r.terrain,
            &r.execution,
            &DMatrix::zeros(x.len(), 0),
            &[
                Parameter::Controller("kp_spring".into()),
                Parameter::Controller(bad.into()),
            ],
        );
        match e {
            Err(SensitivityError::UnknownParameter { name, .. }) => {
                assert!(name.contains(bad), "{name}")
            }
            other => panic!("{bad}: {other:?}"),
        }
    }
}
