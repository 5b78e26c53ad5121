//! Behaviours built in Rust (`selfmanip_sim::behaviour::build`) are the values the same
//! behaviour read from its file gives: a two-joint behaviour for the quadruped of
//! `tests/data/quadruped.toml` (not RHex) with every constructor, against the TOML parser.
use selfmanip_sim::behaviour::*;

const FILE: &str = r#"
name = "trot-kick"
description = "hold, kick on a timer, rest once lifted"
[parameters]
t_kick = 0.1
k = "2 * t_kick"
[actuators.hip]
kind = "dc_motor"
motor = "x-rhex"
gearbox = "x-rhex-28"
gear_ratio = 20.0
count = 2.0
[events.airborne]
on = "flight"
not_before_s = "t_kick"
[[joints]]
joint = "fore[0]"
[[joints.phases]]
name = "wait"
torque = { kind = "servo", kp_n_m_per_rad = "k", kd_n_m_s_per_rad = 0.5, torque_limit_n_m = 3.0, only_in_contact = true }
motion = { kind = "hold", angle_rad = "q0" }
[[joints.phases]]
name = "kick"
start = { at_s = "t_kick" }
torque = { kind = "motor", actuator = "hip", command = 1.0, reverse_beyond_rad = 0.4 }
motion = { kind = "swing", target_rad = 1.2, speed_rad_s = "hip.no_load_speed_rad_s", accel_rad_s2 = 300.0 }
restart_on = [{ on = "release" }]
[[joints.phases]]
name = "rest"
start = { any = [{ on = "liftoff" }, { event = "airborne" }] }
torque = { kind = "constant", torque_n_m = -0.2 }
motion = { kind = "park", target_rad = "theta", accel_rad_s2 = 100.0 }
restart_on = []
[[joints]]
joint = "hind[1]"
[[joints.phases]]
name = "still"
torque = { kind = "zero" }
"#;

#[test]
fn a_built_behaviour_is_its_file() {
    let hip = ActuatorSpec::dc_motor("x-rhex", "x-rhex-28", Some(20.0.into()), None, 2.0);
    let airborne = NamedEvent::on(On::Flight, Some("t_kick".into()));
    let servo = Torque::servo("k", 0.5, Some(3.0.into()), true);
    let rest = Trigger::any(vec![Trigger::on(On::Liftoff), Trigger::event("airborne")]);
    let built = Behaviour::new("trot-kick", "hold, kick on a timer, rest once lifted")
        .parameter("t_kick", 0.1)
        .parameter("k", "2 * t_kick")
        .actuator("hip", hip)
        .event("airborne", airborne)
        .program(JointProgram::new(
            "fore[0]",
            vec![
                Phase::new("wait", servo).moving(Motion::hold("q0")),
                Phase::new("kick", Torque::motor("hip", 1.0, Some(0.4.into())))
                    .starting(Trigger::at("t_kick"))
                    .moving(Motion::swing(1.2, "hip.no_load_speed_rad_s", 300.0))
                    .restarting_on(vec![Trigger::on(On::Release)]),
                Phase::new("rest", Torque::constant(-0.2))
                    .starting(rest)
                    .moving(Motion::park("theta", 100.0))
                    .restarting_on(Vec::new()),
            ],
        ))
        .program(JointProgram::new(
            "hind[1]",
            vec![Phase::new("still", Torque::Zero)],
        ));
    assert_eq!(built, Behaviour::from_toml_str(FILE).unwrap());
    // and it compiles for a robot that is not RHex
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/quadruped.toml"
    );
    let robot = selfmanip_core::RobotDescription::from_file(std::path::Path::new(path)).unwrap();
    let model = robot.build().unwrap();
    let zero = vec![0.0; model.nq()];
    assert!(compile(&built, &model, &zero, &zero, 1.0).is_ok());
}
