//! Derivatives of a user's run (the hopper of `examples/data/hopper.toml` under `hop.toml`,
//! dropped 10 cm moving forward: touchdown, a push `t_compress` after it, liftoff, the apex,
//! on in flight) against central differences of whole runs (Richardson-extrapolated, every
//! run with the reference's event kinds; rtol 1e-12, events to 1e-14 s, free joints in the
//! step-size control):
//!
//! - the state Jacobian through an apex passed on the way (no reset: its saltation the
//!   identity), where `run_sensitivity` used to withhold it;
//! - parameters by path (`selfmanip_sim::sensitivity::scenario_parameter_sensitivity`): a
//!   behaviour parameter, behaviour numbers given as formulas and as literals (a servo's
//!   gain, its target, a phase's delay), the body's mass; the final state and every event's
//!   time; and the honest flags of paths without an exact derivative (a link's mass and
//!   length, a behaviour field that holds no number), NaN columns, never a
//!   difference.
use nalgebra::DMatrix;
use selfmanip_hybrid::sensitivity::SaltationStatus;
use selfmanip_hybrid::EventKind;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::periodic::run_sensitivity;
use selfmanip_sim::sensitivity::{scenario_parameter_sensitivity, ParameterPathError};
use selfmanip_sim::{Scenario, Simulation};
mod common;
use common::{data, fd, hopper, path_column_error};
use fd::{end_state_and_events, run_jacobian_fd};

/// The hopper under `hop.toml` to `t_final` (tight tolerances: [`hopper`]).
fn hop(t_final: f64) -> Scenario {
    hopper(Behaviour::from_file(&data("hop.toml")).unwrap(), t_final)
}

/// The simulation of `s` with the free joints in the step-size control.
fn sim(s: &Scenario) -> Simulation {
    let mut sim = Simulation::new(s).unwrap();
    sim.options.control_free_joints = true;
    sim
}

/// The end state `(q, q̇)`, event kinds and event times of `s`'s run.
fn end(s: &Scenario) -> (Vec<f64>, Vec<EventKind>, Vec<f64>) {
    let run = sim(s).run().unwrap();
    let (x, k) = end_state_and_events(&run.execution);
    (x, k, run.execution.events.iter().map(|e| e.t).collect())
}

/// The run of `sim` from the state `x` (its controller as compiled for the scenario's start).
fn from(sim: &Simulation, x: &[f64]) -> selfmanip_hybrid::Execution {
    selfmanip_hybrid::simulate(
        &sim.model,
        &sim.terrain,
        &*sim.controller,
        sim.mode0,
        &x[..5],
        &x[5..],
        sim.t_final_s,
        sim.options,
    )
    .unwrap()
}

const T_AFTER_APEX: f64 = 0.35;

/// Through touchdown (0.087 s), the delayed push, liftoff (0.189 s) and the apex (0.294 s)
/// to 0.35 s in flight, and on through the next touchdown (0.401 s) to 0.45 s: the state
/// Jacobian in all ten directions against central differences, and the apex's own saltation
/// the identity.
#[test]
fn state_jacobian_through_a_passed_apex_matches_central_differences() {
    for t_final in [T_AFTER_APEX, 0.45] {
        let sim = sim(&hop(t_final));
        let run = sim.run().unwrap();
        let kinds: Vec<_> = run.execution.events.iter().map(|e| e.kind).collect();
        assert_eq!(
            kinds[..3],
            [EventKind::Touchdown, EventKind::Liftoff, EventKind::Apex]
        );
        let s = run_sensitivity(&run).unwrap();
        let apex = &s.events[2];
        assert_eq!(apex.status, SaltationStatus::Defined);
        let xi = apex.saltation.as_ref().unwrap();
        let id_err = (xi - DMatrix::identity(10, 10)).amax();
        assert!(id_err < 1e-12, "apex saltation − I: {id_err:e}");
        let jac = s.state_jacobian.expect("defined through the apex");
        let x0: Vec<f64> = sim.q0.iter().chain(&sim.qd0).copied().collect();
        let at = |x: &[f64]| {
            let e = from(&sim, x);
            end_state_and_events(&e)
        };
        let fd = run_jacobian_fd(at, &x0, &(0..10).collect::<Vec<_>>(), &kinds, 1e-6);
        let err = (&jac - &fd).amax() / fd.amax();
        eprintln!("T = {t_final}: |J − FD| / |FD| = {err:e}");
        assert!(err < 1e-5, "{err:e}");
    }
}

/// The apex's time gradient `dt_apex/dx₀` against central differences of its time.
#[test]
fn passed_apex_time_gradient_matches_central_differences() {
    let sim = sim(&hop(T_AFTER_APEX));
    let run = sim.run().unwrap();
    let s = run_sensitivity(&run).unwrap();
    let g = s.events[2].time_gradient.clone().unwrap();
    let x0: Vec<f64> = sim.q0.iter().chain(&sim.qd0).copied().collect();
    let t_apex = |x: &[f64]| {
        let e = from(&sim, x);
        assert_eq!(e.events[2].kind, EventKind::Apex);
        e.events[2].t
    };
    let mut worst = 0.0f64;
    for c in 0..10 {
        let d = |h: f64| {
            let (mut p, mut m) = (x0.clone(), x0.clone());
            p[c] += h;
            m[c] -= h;
            (t_apex(&p) - t_apex(&m)) / (2.0 * h)
        };
        let fd = (4.0 * d(5e-7) - d(1e-6)) / 3.0;
        worst = worst.max((g[c] - fd).abs());
    }
    eprintln!(
        "dt_apex/dx0: worst |g − FD| = {worst:e} (|g| = {:e})",
        g.amax()
    );
    assert!(worst < 1e-5 * g.amax(), "{worst:e}");
}

/// `d(x(T), t_e)/dp` by central differences of whole runs with the field `path` set to
/// `p ± h` (and `p ± h/2`, Richardson).
fn central(s: &Scenario, path: &str, p: f64, h: f64, kinds: &[EventKind]) -> Vec<f64> {
    let d = |h: f64| {
        let at = |v: f64| {
            let mut t = s.clone();
            t.set(path, v).unwrap();
            let (x, k, te) = end(&t);
            assert_eq!(k, kinds, "{path} = {v}: another event sequence");
            x.into_iter().chain(te).collect::<Vec<f64>>()
        };
        fd::central_difference(&at(p + h), &at(p - h), h)
    };
    fd::richardson(d, h)
}

/// Parameters by path through the passed apex: each column (final state and event times)
/// against central differences of whole runs to 1e-5 relative; a gain given as a formula
/// (`"kp_push"`) and the parameter itself agree; the paths without an exact derivative are
/// flagged with NaN columns.
#[test]
fn parameters_by_path_match_central_differences() {
    let mut s = hop(T_AFTER_APEX);
    // a literal number of the behaviour: the stance servo's target as a number
    s.set("joints[1].phases[1].torque.target_rad", -1.0)
        .unwrap();
    let sim = sim(&s);
    let run = sim.run().unwrap();
    let kinds: Vec<_> = run.execution.events.iter().map(|e| e.kind).collect();
    assert_eq!(
        kinds,
        [EventKind::Touchdown, EventKind::Liftoff, EventKind::Apex]
    );
    let cases: [(&str, f64); 6] = [
        ("parameters.kp_push", 45.0),
        ("joints[1].phases[2].torque.kp_n_m_per_rad", 45.0),
        ("joints[1].phases[1].torque.kd_n_m_s_per_rad", 0.6),
        ("joints[1].phases[1].torque.target_rad", -1.0),
        ("joints[1].phases[2].start.delay_s", 0.05),
        ("body.mass_kg", 4.0),
    ];
    let flagged = [
        "legs[0].links[1].mass_kg",
        "legs.leg.hip_m[0]",
        "joints[1].phases[2].torque.kind",
        "behaviour.name",
    ];
    let names: Vec<&str> = cases.iter().map(|c| c.0).chain(flagged).collect();
    let p = scenario_parameter_sensitivity(&s, &sim.options, &run, &names).unwrap();
    assert_eq!(p.reason, None);
    let x = p.state.as_ref().unwrap();
    assert_eq!(x.shape(), (10, names.len()));
    for (k, &(path, value)) in cases.iter().enumerate() {
        assert_eq!(p.not_differentiated[k], None, "{path}");
        let fd = central(&s, path, value, 1e-4 * value.abs(), &kinds);
        let (err, _) = path_column_error(&p, k, &fd);
        eprintln!("{path}: |exact − FD| / |FD| = {err:e}");
        assert!(err < 1e-5, "{path}: {err:e} ({fd:?})");
    }
    // the gain's formula `kp_push` is its only use: the field's derivative is the
    // parameter's
    let same = (x.column(0) - x.column(1)).amax() / x.column(0).amax();
    assert!(same < 1e-12, "{same:e}");
    for (k, path) in flagged.iter().enumerate() {
        let k = cases.len() + k;
        let why = p.not_differentiated[k].as_ref().expect(path);
        assert!(x.column(k).iter().all(|v| v.is_nan()), "{path}");
        assert!(!why.is_empty());
    }
}

/// A path that names nothing is an error naming its place among the names.
#[test]
fn unknown_path_is_a_typed_error_naming_its_index() {
    let s = hop(0.2);
    let sim = sim(&s);
    let run = sim.run().unwrap();
    let e = scenario_parameter_sensitivity(&s, &sim.options, &run, &["kp_push", "legs[0].wings"])
        .unwrap_err();
    assert!(
        matches!(e, ParameterPathError::Unknown { index: 1, .. }),
        "{e}"
    );
}
