//! Fixtures the sim's tests share.
#![allow(dead_code)]
use nalgebra::{Complex, DMatrix};
use selfmanip_core::ContactMode;
use selfmanip_core::RobotDescription;
use selfmanip_hybrid::periodic::{
    find_periodic_orbit, return_map, PeriodicOptions, PeriodicOrbit, ReturnMap,
};
use selfmanip_hybrid::{simulate, EventKind, Execution, HybridOptions};
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::sensitivity::scenario_parameter_sensitivity;
use selfmanip_sim::{Run, Scenario, Simulation};
use std::path::Path;

#[path = "../../examples/common/mod.rs"]
pub mod examples;
#[path = "../../../selfmanip-hybrid/tests/systems/fd.rs"]
pub mod fd;
#[allow(unused_imports)] // not every test reads the examples' data
pub use examples::data;

/// Runs `run` twice and asserts the events of the two executions bit-identical (as many, and
/// each one's time, mode after and rates after), then `more` on the two executions.
pub fn assert_deterministic(run: impl Fn() -> Run, more: impl Fn(&Execution, &Execution)) {
    let (a, b) = (run().execution, run().execution);
    assert_eq!(a.events.len(), b.events.len());
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (x, y) in a.events.iter().zip(&b.events) {
        assert_eq!(x.t.to_bits(), y.t.to_bits());
        assert_eq!(x.mode_after, y.mode_after);
        assert_eq!(bits(&x.qd_after), bits(&y.qd_after));
    }
    more(&a, &b);
}

/// A robot of the workspace's `tests/data/robots`.
pub fn test_robot(name: &str) -> RobotDescription {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/robots");
    RobotDescription::from_file(&dir.join(name)).unwrap()
}

/// The execution of `sim`'s robot, terrain and controller from the stacked state
/// `x = [q; q̇]` in `mode` to `t_final` under `options`.
pub fn run_from_state(
    sim: &Simulation,
    mode: ContactMode,
    x: &[f64],
    t_final: f64,
    options: HybridOptions,
) -> Execution {
    let nq = sim.model.nq();
    let (q, qd) = x.split_at(nq);
    simulate(
        &sim.model,
        &sim.terrain,
        &*sim.controller,
        mode,
        q,
        qd,
        t_final,
        options,
    )
    .unwrap()
}

/// The hopper of `examples/hopper.rs` (dropped 10 cm, leg at its landing pose) moving
/// forward at 0.3 m/s and falling at 0.5 m/s under `behaviour`, at tight tolerances (what
/// differences of whole runs need), every component to the same absolute tolerance (the
/// default scaling by mass loosens the light leg's velocities, which a difference of whole
/// runs resolves no better than each run).
pub fn hopper(behaviour: Behaviour, t_final: f64) -> Scenario {
    let mut s = examples::dropped_hopper(0.1).unwrap();
    s.initial.qd = Some(vec![0.0, 0.0, 0.3, 0.5, 0.0]);
    s.behaviour = behaviour;
    s.options.t_final_s = t_final;
    s.options.rtol = 1e-12;
    s.options.velocity_tolerance = selfmanip_hybrid::VelocityTolerance::Uniform;
    s.options.event_tol_s = 1e-14;
    s
}

/// Column `k` of a parameter sensitivity by path (the final state, then every event's time)
/// against central differences `fd` of the same: the worst difference relative to `fd`'s
/// size, and that size.
pub fn path_column_error(
    p: &selfmanip_sim::sensitivity::ParameterSensitivity,
    k: usize,
    fd: &[f64],
) -> (f64, f64) {
    let x = p.state.as_ref().expect("the state's columns");
    let times = p.event_times.iter().map(|t| t.as_ref().unwrap()[k]);
    let exact: Vec<f64> = x.column(k).iter().copied().chain(times).collect();
    let scale = fd.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = exact
        .iter()
        .zip(fd)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    (err / scale, scale)
}

/// Checks each `(path, value)` of `cases` (column `k` of `p`) against central differences
/// `fd(path, value)`: differentiated, the run depending on it (|FD| > 1e-3), and within 1e-5
/// relative. Returns the worst relative difference.
pub fn worst_path_error(
    p: &selfmanip_sim::sensitivity::ParameterSensitivity,
    cases: &[(&str, f64)],
    fd: impl Fn(&str, f64) -> Vec<f64>,
) -> f64 {
    let mut worst: f64 = 0.0;
    for (k, &(path, value)) in cases.iter().enumerate() {
        assert_eq!(p.not_differentiated[k], None, "{path}");
        let (err, scale) = path_column_error(p, k, &fd(path, value));
        eprintln!("{path}: |exact − FD| / |FD| = {err:.1e} (|FD| = {scale:.2e})");
        assert!(
            scale > 1e-3,
            "{path}: the run does not depend on it ({scale:e})"
        );
        assert!(err < 1e-5, "{path}: {err:e}");
        worst = worst.max(err);
    }
    worst
}

/// Central differences (step `h`) of the section coordinates `idx` of a return map
/// `map(x) = (x₁, the run's event kinds)` at `x`: `∂x₁[idx[i]]/∂x[idx[k]]`. Every perturbed
/// run must meet the events `kinds`.
pub fn section_jacobian_fd<Y: std::ops::Index<usize, Output = f64>>(
    map: impl Fn(&[f64]) -> (Y, Vec<EventKind>),
    x: &[f64],
    idx: &[usize],
    kinds: &[EventKind],
    h: f64,
) -> DMatrix<f64> {
    let mut fd = DMatrix::zeros(idx.len(), idx.len());
    for (k, &c) in idx.iter().enumerate() {
        let (yp, ym) = fd::runs_either_side(&map, x, c, kinds, h);
        for (i, &r) in idx.iter().enumerate() {
            fd[(i, k)] = (yp[r] - ym[r]) / (2.0 * h);
        }
    }
    fd
}

/// The event kinds of a period of the orbit `o`, checked to be a hop's (touchdown, liftoff,
/// apex: the feet land and lift off together), its residual at most 1e-9; its section
/// multipliers printed.
pub fn hop_events(o: &PeriodicOrbit) -> Vec<EventKind> {
    eprintln!(
        "section multipliers {:?} ({:?})",
        o.section_multipliers, o.stability
    );
    let kinds: Vec<_> = o.events.iter().map(|e| e.0).collect();
    assert_eq!(
        kinds,
        [EventKind::Touchdown, EventKind::Liftoff, EventKind::Apex]
    );
    assert!(o.residual <= 1e-9);
    kinds
}

/// The periodic orbit of `sim`'s robot and controller found from `guess` (default options).
pub fn orbit(sim: &Simulation, guess: &[f64]) -> PeriodicOrbit {
    let opts = PeriodicOptions::default();
    find_periodic_orbit(&sim.model, &sim.terrain, &*sim.controller, guess, &opts).unwrap()
}

/// The apex return map of `sim` from `x` (default options), with its Jacobian if `jacobian`.
pub fn apex_return_map(sim: &Simulation, x: &[f64], jacobian: bool) -> ReturnMap {
    let opts = PeriodicOptions::default();
    return_map(
        &sim.model,
        &sim.terrain,
        &*sim.controller,
        x,
        jacobian,
        &opts,
    )
    .unwrap()
}

/// Each multiplier of `a` matched to the nearest of `b`: the worst distance.
pub fn multiplier_error<'a>(
    a: impl IntoIterator<Item = &'a Complex<f64>>,
    b: &[Complex<f64>],
) -> f64 {
    a.into_iter()
        .map(|l| {
            b.iter()
                .map(|m| (l - m).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

/// Richardson-extrapolated central differences of `end` (a run's end state and event times,
/// and its event kinds) in the scenario field `path` at `p` (steps `h`, `h/2`), every run
/// checked to meet the events `kinds` (`fd::runs_either_side`).
pub fn central_in_path(
    s: &Scenario,
    (path, p, h): (&str, f64, f64),
    kinds: &[EventKind],
    end: impl Fn(&Scenario) -> (Vec<f64>, Vec<EventKind>),
) -> Vec<f64> {
    let run = |x: &[f64]| {
        let mut t = s.clone();
        t.set(path, x[0]).unwrap();
        end(&t)
    };
    let d = |h: f64| {
        let (a, b) = fd::runs_either_side(&run, &[p], 0, kinds, h);
        fd::central_difference(&a, &b, h)
    };
    fd::richardson(d, h)
}

/// The end state `(q, q̇)` of `s`'s run followed by the event times, and the event kinds.
pub fn run_end(s: &Scenario) -> (Vec<f64>, Vec<EventKind>) {
    let run = Simulation::new(s).unwrap().run().unwrap();
    fd::end_state_and_events(&run.execution)
}

/// `s`'s run differentiated in the paths of `cases` (`(path, value)`), every column against
/// Richardson central differences (steps `1e-4 |p|`, `h/2`): the worst relative difference.
/// The run meets the events `expected`.
pub fn worst_run_path_error(s: &Scenario, cases: &[(&str, f64)], expected: &[EventKind]) -> f64 {
    let sim = Simulation::new(s).unwrap();
    let run = sim.run().unwrap();
    let kinds: Vec<_> = run.execution.events.iter().map(|e| e.kind).collect();
    eprintln!(
        "{:?}",
        run.execution
            .events
            .iter()
            .map(|e| (e.kind, e.t))
            .collect::<Vec<_>>()
    );
    assert_eq!(kinds, expected);
    let names: Vec<&str> = cases.iter().map(|c| c.0).collect();
    let p = scenario_parameter_sensitivity(s, &sim.options, &run, &names).unwrap();
    assert_eq!(p.reason, None);
    worst_path_error(&p, cases, |path, value| {
        central_in_path(s, (path, value, 1e-4 * value.abs()), &kinds, run_end)
    })
}

/// The re-touching robot of `retouch_chatter.rs` as scenario JSON (robot and behaviour): a
/// 9.5 kg body on two legs of two massive links (a 0.35 kg thigh, a 0.17 kg shin of
/// `I = 1.17·10⁻⁴` kg m²) under stiff servos (`k_p = 385.65` N m/rad, `k_d = 16.33`
/// N m s/rad) holding their pose; the hind knee's `k_p` is `hind_knee_kp` (a number, or a
/// behaviour parameter's name). The caller adds `initial` and `options`.
pub fn retouch_robot(hind_knee_kp: serde_json::Value) -> serde_json::Value {
    let link = |m: f64, i: f64, l: f64| serde_json::json!({"length_m": l, "mass_kg": m, "inertia_kg_m2": i});
    let leg = |name: &str, x: f64| {
        serde_json::json!({"name": name, "hip_m": [x, 0.0],
            "links": [link(0.35, 1.5e-3, 0.2312), link(0.17, 1.17e-4, 0.0904)]})
    };
    let foot = |name: &str| {
        serde_json::json!({"name": format!("{name}_foot"), "leg": name,
            "shape": {"kind": "point", "position_m": [0.0, 0.0904]},
            "friction": {"kind": "sticking", "mu": 1.18}})
    };
    let joint = |j: &str, kp: serde_json::Value, target: f64| {
        let servo = serde_json::json!({"kind": "servo", "kp_n_m_per_rad": kp,
            "kd_n_m_s_per_rad": 16.33, "torque_limit_n_m": 20.2, "target_rad": target});
        serde_json::json!({"joint": j, "phases": [{"name": "hold", "torque": servo}]})
    };
    let (hip, knee, kp) = (0.46, -0.7254, serde_json::json!(385.65));
    serde_json::json!({
        "robot": {"name": "retouch", "body": {"mass_kg": 9.5, "inertia_kg_m2": 0.22},
                  "legs": [leg("front", 0.25), leg("hind", -0.25)],
                  "contacts": [foot("front"), foot("hind")]},
        "behaviour": {"joints": [joint("front[0]", kp.clone(), hip),
                                 joint("front[1]", kp.clone(), knee),
                                 joint("hind[0]", kp, hip),
                                 joint("hind[1]", hind_knee_kp, knee)]}
    })
}
