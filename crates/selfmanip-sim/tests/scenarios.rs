//! Robots that are not RHex, from their description files and behaviour files, through
//! simulate, trajectories, energy reports, sweeps and MCAP logs. Each number asserted comes
//! from an independent route: free fall in closed form, the energy balance
//! `E₁ − E₀ = W − L` (a conservation law the engine does not impose), the behaviour's own
//! torque laws re-evaluated on sampled states, runs repeated alone or on other thread
//! counts, and the MCAP file read back with the `mcap` crate's reader.
mod common;

use common::data;
use selfmanip_core::RobotDescription;
use selfmanip_hybrid::EventKind;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::sweep::{grid, sweep, PointFailure, SweepPoint};
use selfmanip_sim::{Scenario, SimError, Simulation};
use serde_json::json;
use std::collections::BTreeMap;

/// The hopper of the examples dropped from `drop_m` (foot above the ground), hopping.
fn hopper(drop_m: f64, t_final_s: f64) -> Scenario {
    let robot = RobotDescription::from_file(&data("hopper.toml")).unwrap();
    let a: f64 = 0.5;
    // foot circle of radius 0.02 under the hip at 2 L cos a
    let q0 = vec![a, -2.0 * a, 0.0, -(drop_m + 0.4 * a.cos() + 0.02), 0.0];
    let mut s = Scenario::new(robot, q0);
    s.behaviour = Behaviour::from_file(&data("hop.toml")).unwrap();
    s.options.t_final_s = t_final_s;
    s
}

/// The quadruped of the examples (massive legs) dropped level, pronking.
fn quadruped(drop_m: f64, t_final_s: f64) -> Scenario {
    let mut s = common::examples::dropped_quadruped(drop_m, 0.0).unwrap();
    s.behaviour = Behaviour::from_file(&data("pronk.toml")).unwrap();
    s.options.t_final_s = t_final_s;
    s
}

/// A box with two frictionless feet at its bottom corners (no legs).
fn block() -> RobotDescription {
    common::test_robot("block_on_two_feet.toml")
}

/// Free fall from rest through `h` takes `√(2h/g)`; a level block lands on both corners at
/// once, and the plastic impact takes all its kinetic energy, `m g h`.
#[test]
fn a_dropped_block_lands_flat_at_the_free_fall_time() {
    let (h, g, m) = (0.3, 9.81, 2.0);
    let mut s = Scenario::new(block(), vec![0.0, -(h + 0.05), 0.0]);
    s.options.t_final_s = 0.5;
    let run = Simulation::new(&s).unwrap().run().unwrap();
    let e = &run.execution.events[0];
    let t_fall = (2.0 * h / g).sqrt();
    assert_eq!(e.kind, EventKind::Touchdown);
    assert!((e.t - t_fall).abs() < 1e-9, "{} vs {t_fall}", e.t);
    assert_eq!(e.triggered, vec![0, 1], "both corners at once");
    assert!((e.kinetic_before - m * g * h).abs() < 1e-9 * m * g * h);
    assert!(e.kinetic_after.abs() < 1e-12);
    assert_eq!(run.outcome.word, ["00", "11"]);
    // at rest on the ground to the end: one event, no drift
    assert_eq!(run.execution.events.len(), 1);
    assert!((run.outcome.q_end[1] + 0.05).abs() < 1e-9);
    let landing = run.outcome.landing.expect("a landing after the drop");
    assert!((landing.before.zdot_m_s - g * t_fall).abs() < 1e-8);
    assert!((landing.energy_loss_j - m * g * h).abs() < 1e-9 * m * g * h);
}

/// `E₁ − E₀ = W − L` over a landing and a hop, for the massless-legged hopper (lossless
/// touchdowns: a massless foot stops without an impulse on the body) and the massive-legged
/// quadruped (plastic touchdowns lose energy).
#[test]
fn energy_balances_over_a_landing_and_a_hop() {
    for (name, s, lossy) in [
        ("hopper", hopper(0.1, 0.45), false),
        ("quadruped", quadruped(0.05, 0.3), true),
    ] {
        let run = Simulation::new(&s).unwrap().run().unwrap();
        let w = &run.outcome.word;
        // flight, stance, flight: a landing and a hop
        let flights = w
            .iter()
            .filter(|c| !c.contains('1') && !c.contains('s'))
            .count();
        assert!(flights >= 2, "{name}: {w:?}");
        let r = run.energy_report().unwrap();
        let scale = r.initial_j.abs() + r.joint_work_j.abs() + r.impact_loss_j;
        assert!(
            r.residual_j().abs() < 1e-7 * scale,
            "{name}: residual {:.3e} J of {scale:.3} J ({r:?})",
            r.residual_j()
        );
        assert!(r.joint_work_j.abs() > 0.1, "{name}: the legs work");
        assert_eq!(
            r.impact_loss_j > 1e-3,
            lossy,
            "{name}: losses {}",
            r.impact_loss_j
        );
    }
}

/// The trajectory's torques are those of the behaviour as it ran: the hopper's knee torque
/// in each sample equals the servo law of the phase the sample is in, re-evaluated here from
/// the sampled state (spring before `t_compress` after each touchdown, push after it).
#[test]
fn sampled_torques_follow_the_behaviour_laws() {
    let s = hopper(0.1, 0.7);
    let run = Simulation::new(&s).unwrap().run().unwrap();
    let tr = run.trajectory(1e-3).unwrap();
    let touchdowns: Vec<f64> = run
        .execution
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Touchdown)
        .map(|e| e.t)
        .collect();
    assert!(touchdowns.len() >= 2);
    let (k_land, k_push, kd) = (-1.0, -0.8, 0.6);
    let (kp_spring, kp_push) = (60.0, 45.0);
    let mut checked = 0;
    for (i, &t) in tr.t_s.iter().enumerate() {
        if tr.mode[i] != "1" {
            continue;
        }
        let td = touchdowns.iter().rev().find(|&&x| x <= t).copied().unwrap();
        let (q, qd) = (tr.q[i][1], tr.qd[i][1]);
        let expected = if t - td < 0.05 {
            -kp_spring * (q - k_land) - kd * qd
        } else {
            -kp_push * (q - k_push) - kd * qd
        };
        // skip samples within a step of the switch (which phase a sample at the switch is
        // in is a matter of rounding)
        if (t - td - 0.05).abs() > 1e-6 {
            assert!(
                (tr.tau[i][1] - expected).abs() < 1e-9,
                "t {t}: {} vs {expected}",
                tr.tau[i][1]
            );
            checked += 1;
        }
        assert_eq!(tr.tau[i][0], 0.0, "a limp hip");
    }
    assert!(checked > 50, "{checked} stance samples");
}

/// A sweep is bit-identical for any thread count and equal, point by point, to the runs
/// made alone.
#[test]
fn sweeps_are_deterministic_across_thread_counts() {
    let base = hopper(0.1, 0.5);
    let points = grid(&[
        (
            "kp_push".into(),
            vec![json!(35.0), json!(45.0), json!(55.0)],
        ),
        ("t_compress".into(), vec![json!(0.04), json!(0.06)]),
    ])
    .unwrap();
    assert_eq!(points.len(), 6);
    let text = |threads| format!("{:?}", sweep(&base, &points, threads).unwrap());
    let one = text(1);
    assert_eq!(one, text(2));
    assert_eq!(one, text(3));
    let rows = sweep(&base, &points, 2).unwrap();
    for (p, row) in points.iter().zip(&rows) {
        let alone = Simulation::new(&base.with_values(&p.values).unwrap())
            .unwrap()
            .run()
            .unwrap()
            .outcome;
        assert_eq!(
            format!("{:?}", row.outcome().unwrap()),
            format!("{alone:?}")
        );
    }
    // different parameters, different hops
    let apexes: Vec<f64> = rows
        .iter()
        .map(|r| r.outcome().unwrap().apex.unwrap().z_m)
        .collect();
    assert!(apexes.windows(2).any(|w| w[0] != w[1]));
}

/// Failed points get a status of their own and leave the good ones as they are; a name that
/// names nothing fails the whole sweep before it runs.
#[test]
fn sweep_points_fail_alone_with_typed_statuses() {
    let base = hopper(0.1, 0.4);
    let good = SweepPoint {
        values: vec![("kp_push".into(), json!(45.0))],
    };
    let points = vec![
        good.clone(),
        SweepPoint {
            values: vec![("kp_spring".into(), json!(-5.0))],
        },
        SweepPoint {
            values: vec![("t_compress".into(), json!("soon"))],
        },
        SweepPoint {
            values: vec![("initial.q[3]".into(), json!(0.1))],
        },
        good,
    ];
    let rows = sweep(&base, &points, 2).unwrap();
    let statuses: Vec<&str> = rows.iter().map(|r| r.status()).collect();
    assert_eq!(statuses[0], "final_time");
    assert_eq!(statuses[1], "invalid_value", "a negative gain");
    assert_eq!(
        statuses[2], "unknown_reference",
        "a word where a number is due: no such parameter"
    );
    // the foot starts below the ground
    assert!(
        matches!(&rows[3].result, Err(PointFailure::Error(SimError::InvalidValue { field, .. })) if field == "initial.q"),
        "{:?}",
        rows[3]
    );
    assert_eq!(format!("{:?}", rows[0]), format!("{:?}", rows[4]));
    match &rows[1].result {
        Err(PointFailure::Error(SimError::InvalidValue { field, .. })) => {
            assert!(field.ends_with("kp_n_m_per_rad"), "{field}")
        }
        other => panic!("{other:?}"),
    }
    // an unknown name is an error of the whole sweep, naming it
    let bad = vec![SweepPoint {
        values: vec![("legs.middle.links[0].length_m".into(), json!(0.1))],
    }];
    match sweep(&base, &bad, 1) {
        Err(SimError::UnknownParameter { path, .. }) => {
            assert_eq!(path, "legs.middle.links[0].length_m")
        }
        other => panic!("{other:?}"),
    }
    assert!(sweep(&base, &[], 0).is_err(), "zero threads");
}

/// Description fields set by name change the model: a longer shank makes a longer leg.
#[test]
fn description_fields_are_parameters_by_name() {
    let mut s = hopper(0.1, 0.2);
    s.set("legs.leg.links[1].length_m", 0.25).unwrap();
    s.set("robot.body.mass_kg", 5.0).unwrap();
    let sim = Simulation::new(&s).unwrap();
    assert_eq!(sim.model.joints[1].length_m, 0.25);
    assert_eq!(sim.model.body_mass_kg, 5.0);
    assert!(s.settable_names().unwrap().iter().any(|n| n == "kp_push"));
    assert!(matches!(
        s.set("behaviour.parameters.no_such", 1.0),
        Err(SimError::UnknownParameter { .. })
    ));
}

/// The MCAP log read back with the `mcap` crate: every topic with its schema, one message
/// per sample on the sampled topics, the states and events as the run has them, the
/// transform tree world → ned → body → each link, and the metadata.
#[test]
fn mcap_logs_read_back() {
    let s = hopper(0.1, 0.6);
    let run = Simulation::new(&s).unwrap().run().unwrap();
    let dir = std::env::temp_dir().join(format!("selfmanip-sim-mcap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("hopper.mcap");
    let mut md = BTreeMap::new();
    md.insert("robot".to_string(), "hopper".to_string());
    let dt = 0.01;
    run.write_mcap(&path, dt, md).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let tr = run.trajectory(dt).unwrap();
    let events = run.events();
    let mut by_topic: BTreeMap<String, Vec<serde_json::Value>> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().unwrap().name.clone();
        let expected = match m.channel.topic.as_str() {
            "/tf" => "foxglove.FrameTransforms",
            "/scene" => "foxglove.SceneUpdate",
            "/state" => "selfmanip.State",
            "/contact_forces" => "selfmanip.ContactForces",
            "/mode" => "selfmanip.Mode",
            "/events" => "selfmanip.Event",
            other => panic!("unexpected topic {other}"),
        };
        assert_eq!(schema, expected);
        by_topic
            .entry(m.channel.topic.clone())
            .or_default()
            .push(serde_json::from_slice(&m.data).unwrap());
    }
    let n = tr.t_s.len();
    for topic in ["/tf", "/scene", "/state", "/contact_forces"] {
        assert_eq!(by_topic[topic].len(), n, "{topic}");
    }
    assert_eq!(by_topic["/events"].len(), events.len());
    for (k, st) in by_topic["/state"].iter().enumerate() {
        let q: Vec<f64> = serde_json::from_value(st["q"].clone()).unwrap();
        assert_eq!(q, tr.q[k]);
        let tau: Vec<f64> = serde_json::from_value(st["tau"].clone()).unwrap();
        assert_eq!(tau, tr.tau[k]);
    }
    for (msg, e) in by_topic["/events"].iter().zip(&events) {
        assert_eq!(msg["t_s"], json!(e.t_s));
        assert_eq!(msg["kind"], json!(e.kind));
    }
    let tf0 = by_topic["/tf"][0]["transforms"].as_array().unwrap().clone();
    let pairs: Vec<(String, String)> = tf0
        .iter()
        .map(|t| {
            (
                t["parent_frame_id"].as_str().unwrap().into(),
                t["child_frame_id"].as_str().unwrap().into(),
            )
        })
        .collect();
    let want = [
        ("world", "ned"),
        ("ned", "body"),
        ("body", "leg_link0"),
        ("leg_link0", "leg_link1"),
    ];
    assert_eq!(pairs.len(), want.len());
    for ((p, c), (wp, wc)) in pairs.iter().zip(want) {
        assert_eq!((p.as_str(), c.as_str()), (wp, wc));
    }
    // the shank's frame sits at the end of the thigh
    assert_eq!(tf0[3]["translation"]["z"], json!(0.2));
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    assert!(summary
        .metadata_indexes
        .iter()
        .any(|m| m.name == "selfmanip"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A scenario file (robot, terrain, initial state, behaviour, options in one TOML) runs as
/// the same scenario built in code.
#[test]
fn a_scenario_file_is_the_scenario() {
    let s = hopper(0.1, 0.3);
    let text = toml::to_string(&s).unwrap();
    let back = Scenario::from_toml_str(&text).unwrap();
    assert_eq!(back, s);
    let a = Simulation::new(&s).unwrap().run().unwrap();
    let b = Simulation::new(&back).unwrap().run().unwrap();
    assert_eq!(format!("{:?}", a.outcome), format!("{:?}", b.outcome));
}

/// A coordinate to solve for that the robot does not have is refused naming its entry and
/// listing the coordinates there are (the hopper's: its two joints, then `x`, `z`, `phi`).
#[test]
fn an_unknown_coordinate_to_solve_names_its_entry() {
    let mut s = hopper(0.1, 0.1);
    s.initial.solve = vec!["z".into(), "knee".into()];
    match Simulation::new(&s) {
        Err(SimError::InvalidValue { field, reason }) => {
            assert_eq!(field, "initial.solve[1]");
            assert!(
                reason.contains("`knee`") && reason.contains("x, z, phi"),
                "{reason}"
            );
        }
        other => panic!("{:?}", other.err()),
    }
}
