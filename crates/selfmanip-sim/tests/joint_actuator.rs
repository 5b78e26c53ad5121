//! The generic actuator choice of a preset (`drive::JointActuator` with a `CatalogDrive`) on a
//! robot that is not RHex: the hopper of `hop.toml` whose knee pushes with a geared catalog
//! motor bound as behaviour parameters. A simulation built with one geared motor and
//! rebound to another's values runs what a fresh build of the other runs, bit for bit; the
//! joint's drive figures against the catalog's motor data; the serde form of the choice.
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::drive::{CatalogDrive, GearedMotor, JointActuator};
use selfmanip_sim::{Scenario, SimError, Simulation};
mod common;
use common::{data, hopper};

/// The research RHex's motor behind its 33:1 gearbox, one per joint, 10 A.
const RESEARCH: CatalogDrive = CatalogDrive {
    motor: "research-rhex",
    gearbox: "research-rhex-33",
    default: GearedMotor {
        gear_ratio: 33.0,
        current_limit_a: 10.0,
        motors_per_leg: 1,
        gearbox_efficiency: None,
        gearbox_loss: motor::GearboxLoss::Derating,
        battery_resistance_ohm: None,
    },
};

/// `hop.toml` with the push by the knee's geared motor `m` at full command.
fn scenario(m: &GearedMotor) -> Scenario {
    let text = std::fs::read_to_string(data("hop.toml")).unwrap();
    let text = text.replace(
        r#"torque = { kind = "servo", target_rad = "k_push", kp_n_m_per_rad = "kp_push", kd_n_m_s_per_rad = "kd_spring" }"#,
        r#"torque = { kind = "motor", actuator = "knee", command = "1.0" }"#,
    );
    let text = format!(
        "{text}\n[actuators.knee]\nkind = \"dc_motor\"\nmotor = \"{}\"\ngearbox = \"{}\"\n",
        RESEARCH.motor, RESEARCH.gearbox
    );
    let mut b: Behaviour = Behaviour::from_toml_str(&text).unwrap();
    let knee = b.actuators.get_mut("knee").unwrap();
    m.bind(knee, &mut b.parameters);
    hopper(b, 0.45)
}

/// The end state and every event time of a run, as bits.
fn bits(sim: &Simulation) -> Vec<u64> {
    let e = sim.run().unwrap().execution;
    let t = e.events.iter().map(|ev| ev.t);
    let x = e.q.iter().chain(&e.qd).copied().chain(t);
    x.map(f64::to_bits).collect()
}

/// Rebinding a geared motor's values to a simulation built with another geared motor of the
/// same loss options gives the fresh build's run bit for bit (the second route: the fresh
/// build); a motor with a loss option set that the build lacks does not bind as it.
#[test]
fn a_geared_motor_rebinds_as_a_fresh_build() {
    let a = RESEARCH.default;
    let b = GearedMotor {
        gear_ratio: 21.0,
        current_limit_a: 15.0,
        motors_per_leg: 2,
        ..a
    };
    let (ja, jb) = (JointActuator::GearedMotor(a), JointActuator::GearedMotor(b));
    assert!(ja.binds_as(&jb) && jb.binds_as(&ja));
    let built = Simulation::new(&scenario(&a)).unwrap();
    let fresh = Simulation::new(&scenario(&b)).unwrap();
    let mut rebound = built.clone();
    rebound.rebind(&jb.values(), built.t_final_s).unwrap();
    let (r, f) = (bits(&rebound), bits(&fresh));
    assert!(r.len() > 2 * 5, "the hop has events");
    assert_eq!(r, f);
    assert_ne!(bits(&built), f, "the motors push differently");
    // a loss option set is a parameter the build does not have
    let lossy = JointActuator::GearedMotor(GearedMotor {
        battery_resistance_ohm: Some(0.1),
        ..b
    });
    assert!(!ja.binds_as(&lossy));
    let mut rebound = built.clone();
    assert!(rebound.rebind(&lossy.values(), built.t_final_s).is_err());
    assert!(!ja.binds_as(&JointActuator::SaturatedTorque));
    assert!(JointActuator::SaturatedTorque.binds_as(&JointActuator::SaturatedTorque));
}

/// The joint's drive against the catalog's motor data: the no-load speed `ω₀ / G`, the
/// rotors' inertia `n τ_m k² / R · G²` (Table 2.1's mechanical time constant), the stall
/// torque the saturated torque keeps as its own value; a gear ratio at which they overflow is
/// an error naming `gear_ratio`.
#[test]
fn joint_drive_reads_the_catalog() {
    let catalog = motor::Catalog::thesis();
    let spec = catalog.motor_spec(RESEARCH.motor).unwrap();
    let m = spec.motor().unwrap();
    let k = m.torque_constant_n_m_per_a;
    let tau_m = spec.mechanical_time_constant_s.unwrap();
    let j = tau_m * k * k / m.terminal_resistance_ohm();
    let geared = RESEARCH.at_gear_ratio(40.0);
    let d = RESEARCH.joint_drive(&geared, 7.0).unwrap();
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    assert!(close(d.reflected_inertia_kg_m2, j * 40.0 * 40.0));
    assert!(close(
        d.drive.no_load_speed_rad_s(),
        m.no_load_speed_rad_s / 40.0
    ));
    assert!(d.stall_torque_n_m > 0.0 && d.stall_torque_n_m != 7.0);
    let sat = RESEARCH
        .joint_drive(&JointActuator::SaturatedTorque, 7.0)
        .unwrap();
    assert_eq!(sat.stall_torque_n_m, 7.0);
    assert!(close(sat.reflected_inertia_kg_m2, j * 33.0 * 33.0));
    match RESEARCH.joint_drive(&RESEARCH.at_gear_ratio(1e300), 7.0) {
        Err(SimError::InvalidValue { field, .. }) => assert_eq!(field, "gear_ratio"),
        other => panic!("{:?}", other.map(|d| d.stall_torque_n_m)),
    }
    assert_eq!(
        RESEARCH.motor(&JointActuator::SaturatedTorque),
        RESEARCH.default
    );
    assert_eq!(JointActuator::SaturatedTorque.gear_ratio(), None);
    assert_eq!(geared.gear_ratio(), Some(40.0));
}

/// The choice reads and writes as `{"kind": "saturated_torque"}` or the geared motor's
/// fields with `"kind": "geared_motor"`; an unknown field is refused.
#[test]
fn serde_form_of_the_choice() {
    let sat: JointActuator =
        serde_json::from_value(serde_json::json!({"kind": "saturated_torque"})).unwrap();
    assert_eq!(sat, JointActuator::SaturatedTorque);
    let g = RESEARCH.actuator();
    let v = serde_json::to_value(&g).unwrap();
    assert_eq!(v["kind"], "geared_motor");
    assert_eq!(v["gear_ratio"], 33.0);
    assert_eq!(serde_json::from_value::<JointActuator>(v).unwrap(), g);
    let bad = serde_json::json!({"kind": "geared_motor", "gear_ratio": 3.0, "current_limit_a": 1.0,
        "motors_per_leg": 1, "colour": "red"});
    assert!(serde_json::from_value::<JointActuator>(bad).is_err());
}
