//! Bad behaviour files are refused with a typed error that names the field at fault; and
//! the parts of the schema the examples do not exercise — joint-angle levels, named events
//! after named events, scheduled and constant torques, motors — do what the schema says,
//! checked against the laws re-evaluated on the sampled states.
mod common;

use common::data;
use selfmanip_core::RobotDescription;
use selfmanip_sim::behaviour::{compile, Behaviour};
use selfmanip_sim::{Scenario, SimError, Simulation};

fn hopper() -> (selfmanip_core::Model, Vec<f64>) {
    let d = RobotDescription::from_file(&data("hopper.toml")).unwrap();
    let q0 = vec![0.5, -1.0, 0.0, -0.5, 0.0];
    (d.build().unwrap(), q0)
}

/// Compiles a behaviour for the hopper (joints `leg[0]`, `leg[1]`, contact `foot`).
fn check(text: &str) -> Result<(), SimError> {
    let (m, q0) = hopper();
    let b = Behaviour::from_toml_str(text)?;
    compile(&b, &m, &q0, &[0.0; 5], 1.0).map(|_| ())
}

/// Asserts that `check(text)` refuses the behaviour with an error that `is` accepts.
fn assert_refused(text: &str, is: impl Fn(&SimError) -> bool) {
    let err = check(text).unwrap_err();
    assert!(is(&err), "{err:?}");
}

const KNEE: &str = r#"
[[joints]]
joint = "leg[1]"
[[joints.phases]]
name = "a"
"#;

#[test]
fn unknown_names_are_typed_errors_naming_the_field() {
    // the knee's one-phase program on a joint the hopper does not have
    let err = check(&KNEE.replace("leg[1]", "arm[0]")).unwrap_err();
    match err {
        SimError::UnknownJoint { field, name, known } => {
            assert_eq!(
                (field.as_str(), name.as_str()),
                ("joints[0].joint", "arm[0]")
            );
            assert!(known.contains("leg[1]"));
        }
        other => panic!("{other:?}"),
    }
    assert_refused(
        &format!(
            "{KNEE}[[joints.phases]]\nname = \"b\"\nstart = {{ on = \"touchdown\", contacts = [\"hand\"] }}"
        ),
        |e| {
            matches!(e, SimError::UnknownContact { field, name, .. }
                if field == "joints[0].phases[1].start.contacts[0]" && name == "hand")
        },
    );
    assert_refused(
        &format!("{KNEE}[[joints.phases]]\nname = \"b\"\nstart = {{ event = \"takeoff\" }}"),
        |e| {
            matches!(e, SimError::UnknownReference { field, kind: "event", name, .. }
                if field == "joints[0].phases[1].start.event" && name == "takeoff")
        },
    );
    assert_refused(
        &format!(
            "{KNEE}[[joints.phases]]\nname = \"b\"\nstart = {{ on = \"phase\", phase = \"leg[0].push\" }}"
        ),
        |e| matches!(e, SimError::UnknownReference { kind: "phase", .. }),
    );
    assert_refused(
        &format!("{KNEE}torque = {{ kind = \"motor\", actuator = \"big\", command = 1.0 }}"),
        |e| {
            matches!(e, SimError::UnknownReference { field, kind: "actuator", .. }
                if field == "joints[0].phases[0].torque.actuator")
        },
    );
    assert_refused(
        &format!("{KNEE}torque = {{ kind = \"constant\", torque_n_m = \"2 * stiffness\" }}"),
        |e| {
            matches!(e, SimError::UnknownReference { kind: "parameter", name, .. }
                if name == "stiffness")
        },
    );
    // an event kind that does not exist, and a misspelt field, are parse errors
    assert!(matches!(
        check(&format!(
            "{KNEE}[[joints.phases]]\nname = \"b\"\nstart = {{ on = \"landing\" }}"
        )),
        Err(SimError::Parse { .. })
    ));
    assert!(matches!(
        check(&format!(
            "{KNEE}torque = {{ kind = \"servo\", kp = 1.0, kd_n_m_s_per_rad = 1.0 }}"
        )),
        Err(SimError::Parse { .. })
    ));
    // a motor or gearbox the catalog does not have
    assert_refused(
        r#"
        [actuators.big]
        kind = "dc_motor"
        motor = "x-rhex"
        gearbox = "no-such-gearbox"
        "#,
        |e| matches!(e, SimError::Motor { field, .. } if field == "actuators.big.gearbox"),
    );
}

#[test]
fn cycles_are_refused_with_the_cycle() {
    // phases that can only start after each other
    let err = check(
        r#"
        [[joints]]
        joint = "leg[0]"
        phases = [{ name = "a" }, { name = "b", start = { on = "phase", phase = "leg[1].d" } }]
        [[joints]]
        joint = "leg[1]"
        phases = [
            { name = "c" },
            { name = "d", start = { on = "phase", phase = "leg[0].b", delay_s = 0.1 } },
        ]
        "#,
    )
    .unwrap_err();
    match err {
        SimError::Cycle { field, cycle } => {
            assert_eq!(field, "joints[0].phases[1].start");
            assert_eq!(cycle, ["leg[0].b", "leg[1].d", "leg[0].b"]);
        }
        other => panic!("{other:?}"),
    }
    // parameters
    assert_refused(
        "[parameters]\na = \"b + 1\"\nb = \"2 * a\"",
        |e| matches!(e, SimError::Cycle { cycle, .. } if cycle.len() == 3),
    );
    // named events
    assert_refused(
        r#"
        [events.first]
        on = "touchdown"
        after_event = "second"
        [events.second]
        on = "liftoff"
        after_event = "first"
        "#,
        |e| matches!(e, SimError::Cycle { field, .. } if field.starts_with("events.")),
    );
    // a timed loop that never advances
    assert_refused(
        r#"
        [[joints]]
        joint = "leg[0]"
        repeat_from = "b"
        [[joints.phases]]
        name = "a"
        [[joints.phases]]
        name = "b"
        start = { at_s = 0.1 }
        [[joints.phases]]
        name = "c"
        start = { at_s = 0.1 }
        "#,
        |e| matches!(e, SimError::InvalidValue { field, .. } if field == "joints[0]"),
    );
}

#[test]
fn bad_values_are_refused_naming_the_field() {
    let field_of = |text: &str| match check(text) {
        Err(SimError::InvalidValue { field, .. }) => field,
        other => panic!("{text}: {other:?}"),
    };
    assert_eq!(
        field_of(&format!(
            "{KNEE}torque = {{ kind = \"servo\", kp_n_m_per_rad = -3.0, kd_n_m_s_per_rad = 1.0 }}"
        )),
        "joints[0].phases[0].torque.kp_n_m_per_rad"
    );
    assert_eq!(
        field_of(&format!(
            "{KNEE}torque = {{ kind = \"servo\", kp_n_m_per_rad = 3.0, kd_n_m_s_per_rad = nan }}"
        )),
        "joints[0].phases[0].torque.kd_n_m_s_per_rad"
    );
    assert_eq!(
        field_of("[parameters]\nx = \"1 / 0\""),
        "parameters.x",
        "an infinite parameter"
    );
    assert_eq!(
        field_of(
            "[actuators.m]\nkind = \"saturated\"\nmax_torque_n_m = 2.0\n[[joints]]\njoint = \"leg[1]\"\n[[joints.phases]]\nname = \"a\"\ntorque = { kind = \"motor\", actuator = \"m\", command = 1.5 }"
        ),
        "joints[0].phases[0].torque.command"
    );
    assert_eq!(
        field_of(&format!(
            "{KNEE}motion = {{ kind = \"swing\", target_rad = 1.0, speed_rad_s = 0.0, accel_rad_s2 = 10.0 }}"
        )),
        "joints[0].phases[0].motion.speed_rad_s"
    );
    assert_eq!(
        field_of(&format!("{KNEE}[[joints.phases]]\nname = \"b\"")),
        "joints[0].phases[1].start"
    );
    assert_eq!(
        field_of(&format!(
            "{KNEE}[[joints.phases]]\nname = \"b\"\nstart = {{ at_s = 0.1, on = \"touchdown\" }}"
        )),
        "joints[0].phases[1].start"
    );
    assert_eq!(
        field_of("[free_joints]\nkp_per_s2 = -1.0\nkd_per_s = 1.0"),
        "free_joints.kp_per_s2"
    );
    assert_eq!(
        field_of(&format!(
            "{KNEE}torque = {{ kind = \"schedule\", times_s = [0.0, 0.0], torques_n_m = [1.0, 2.0] }}"
        )),
        "joints[0].phases[0].torque.times_s"
    );
    // empty and unreadable files say so
    let dir = std::env::temp_dir().join(format!("selfmanip-sim-empty-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let empty = dir.join("empty.toml");
    std::fs::write(&empty, "").unwrap();
    assert!(
        matches!(Behaviour::from_file(&empty), Err(SimError::Io { message, .. }) if message.contains("empty"))
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A joint-angle phase holds while the joint is past its angle: a knee held by a servo in
/// the air whose torque switches to a constant beyond an angle, against the sampled states;
/// a scheduled torque, linear in time between its knots.
#[test]
fn levels_and_schedules_do_what_the_schema_says() {
    let robot = common::test_robot("two_link_arm.toml");
    let mut s = Scenario::new(robot, vec![0.0, 0.0, 0.0, -2.0, 0.0]);
    s.options.t_final_s = 0.4;
    s.behaviour = Behaviour::from_toml_str(
        r#"
        [[joints]]
        joint = "arm[1]"
        [[joints.phases]]
        name = "drive"
        torque = { kind = "constant", torque_n_m = 1.5 }
        [[joints.phases]]
        name = "past"
        start = { on = "joint_angle", angle_rad = 0.6, direction = 1 }
        torque = { kind = "constant", torque_n_m = -4.0 }

        [[joints]]
        joint = "arm[0]"
        [[joints.phases]]
        name = "ramp"
        torque = { kind = "schedule", times_s = [0.1, 0.3], torques_n_m = [0.0, 2.0] }
        "#,
    )
    .unwrap();
    let run = Simulation::new(&s).unwrap().run().unwrap();
    let tr = run.trajectory(2e-3).unwrap();
    let (mut past, mut before) = (0, 0);
    for (i, &t) in tr.t_s.iter().enumerate() {
        let knee = tr.q[i][1];
        let want = if knee > 0.6 { -4.0 } else { 1.5 };
        assert_eq!(tr.tau[i][1], want, "t {t}, knee {knee}");
        if knee > 0.6 {
            past += 1
        } else {
            before += 1
        }
        let ramp = if t <= 0.1 {
            0.0
        } else if t >= 0.3 {
            2.0
        } else {
            (t - 0.1) / 0.2 * 2.0
        };
        assert!((tr.tau[i][0] - ramp).abs() < 1e-12, "t {t}");
    }
    assert!(
        past > 10 && before > 10,
        "{past} past, {before} before: the knee crossed"
    );
}
