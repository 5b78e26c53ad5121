//! A user's behaviour with a `dc_motor` on a battery (`battery_resistance_ohm > 0`): the
//! hopper of `hop.toml` whose knee pushes with a geared motor at a partial command and
//! whose legs swing in the air at an acceleration set by the motor's stall torque (so the
//! loss options enter both the torque law and a prescribed motion with knots). Parameters by
//! path and by name — the battery resistance, the gearbox efficiency, the command, the supply
//! voltage — through
//! touchdown, the push, liftoff and the apex passed on the way, against Richardson central
//! differences of whole runs (final state and every event time) to 1e-5; and the energy
//! balance of the same run.
use selfmanip_hybrid::EventKind;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::sensitivity::scenario_parameter_sensitivity;
use selfmanip_sim::{Scenario, Simulation};
mod common;
use common::{data, hopper};

/// `hop.toml` with the push by `knee` (x-rhex behind its 28:1 gearbox, on a battery of
/// `r_b` Ω, efficiency `eta`, command `u_push`) and the swings' acceleration the motor's
/// stall torque over `swing_inertia` (kg m²).
fn scenario() -> Scenario {
    let text = std::fs::read_to_string(data("hop.toml")).unwrap();
    let text = text
        .replace(
            "swing_accel = 600.0",
            "swing_inertia = 0.015\nr_b = 0.3\neta = 0.8\nu_push = 0.9",
        )
        .replace(
            r#"accel_rad_s2 = "swing_accel""#,
            r#"accel_rad_s2 = "knee.stall_torque_n_m / swing_inertia""#,
        )
        .replace(
            r#"torque = { kind = "servo", target_rad = "k_push", kp_n_m_per_rad = "kp_push", kd_n_m_s_per_rad = "kd_spring" }"#,
            r#"torque = { kind = "motor", actuator = "knee", command = "u_push" }"#,
        );
    let text = format!(
        "{text}\n[actuators.knee]\nkind = \"dc_motor\"\nmotor = \"x-rhex\"\n\
         gearbox = \"x-rhex-28\"\ncurrent_limit_a = 20.0\nsupply_voltage_v = 37.0\n\
         gearbox_efficiency = \"eta\"\nbattery_resistance_ohm = \"r_b\"\n"
    );
    let b: Behaviour = Behaviour::from_toml_str(&text).unwrap();
    hopper(b, T_FINAL)
}

/// Past the apex, before the next touchdown.
const T_FINAL: f64 = 0.45;

fn sim(s: &Scenario) -> Simulation {
    let mut sim = Simulation::new(s).unwrap();
    sim.options.control_free_joints = true;
    sim
}

/// The end state `(q, q̇)` followed by the event times, and the event kinds.
fn end(s: &Scenario) -> (Vec<f64>, Vec<EventKind>) {
    let run = sim(s).run().unwrap();
    let e = &run.execution;
    let x = e.q.iter().chain(&e.qd).copied();
    let t = e.events.iter().map(|ev| ev.t);
    (
        x.chain(t).collect(),
        e.events.iter().map(|ev| ev.kind).collect(),
    )
}

/// Richardson-extrapolated central differences in `path` at `p` (steps `h`, `h/2`).
fn central(s: &Scenario, path: &str, p: f64, h: f64, kinds: &[EventKind]) -> Vec<f64> {
    common::central_in_path(s, (path, p, h), kinds, end)
}

#[test]
fn drive_loss_parameters_match_central_differences() {
    let s = scenario();
    let sim = sim(&s);
    let run = sim.run().unwrap();
    let kinds: Vec<_> = run.execution.events.iter().map(|e| e.kind).collect();
    assert_eq!(
        kinds,
        [EventKind::Touchdown, EventKind::Liftoff, EventKind::Apex],
        "the hop's events: {:?}",
        run.execution.events.iter().map(|e| e.t).collect::<Vec<_>>()
    );
    let cases: [(&str, f64); 4] = [
        ("parameters.r_b", 0.3),
        ("parameters.eta", 0.8),
        ("parameters.u_push", 0.9),
        ("actuators.knee.supply_voltage_v", 37.0),
    ];
    let names: Vec<&str> = cases.iter().map(|c| c.0).collect();
    let p = scenario_parameter_sensitivity(&s, &sim.options, &run, &names).unwrap();
    assert_eq!(p.reason, None);
    let worst = common::worst_path_error(&p, &cases, |path, value| {
        central(&s, path, value, 1e-4 * value, &kinds)
    });
    eprintln!("worst {worst:.1e}");
}

/// The same hop (a lossy gearbox, η = 0.8, on a 0.3 Ω battery): `E₁ − E₀ = W + W_d + W_fr − L`
/// to 1e-6 J, with `W` the work of the torques at the joints (the gearbox's output, after
/// its loss and the battery's sag) and the push's motor doing work on the knee (the
/// massless leg lands without an impact loss).
#[test]
fn energy_balances_with_a_lossy_gearbox_on_a_battery() {
    let run = sim(&scenario()).run().unwrap();
    let r = run.energy_report().unwrap();
    eprintln!("{r:?}: residual {:e} J", r.residual_j());
    assert!(r.joint_work_j.abs() > 1e-2, "{r:?}");
    assert!(r.residual_j().abs() < 1e-6, "{:e}", r.residual_j());
}
