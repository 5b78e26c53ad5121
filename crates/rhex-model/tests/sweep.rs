//! Sweeps (issue 5): determinism across thread counts, per-point failure isolation,
//! parameter overrides by name, and MCAP logs read back.
use rhex_model::leap::{
    leap_params, GearedMotor, LeapConfig, LegActuator, Push, Strategy, X_RHEX_LEG,
};
use rhex_model::mcap_log::{write_leap_mcap, write_leap_mcap_to, LeapLog};
use rhex_model::sweep::{
    check_override_names, grid, point_inputs, run_row, sweep, sweepable_names, LeapPoint,
    LeapSweep, SweepRow,
};
use selfmanip_hybrid::budget::NEVER;
use selfmanip_sim::Trajectory;
use serde_json::json;
use std::collections::BTreeMap;
use std::io::Cursor;

fn small_grid() -> Vec<LeapPoint> {
    let t2: Vec<f64> = (0..7).map(|i| -0.15 + 0.05 * i as f64).collect();
    grid(&Strategy::ALL, &t2, &[Some(28.0)])
}

/// Bitwise equality of two tables (NaN == NaN when the bits agree).
fn same_bits(a: &[SweepRow], b: &[SweepRow]) {
    assert_eq!(a.len(), b.len());
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert_eq!(
            (&x.status, &x.error, &x.word, x.n_events),
            (&y.status, &y.error, &y.word, y.n_events),
            "row {i}"
        );
        let all = |r: &SweepRow| -> Vec<f64> { [&r.columns[..], &r.apex_columns()].concat() };
        let (mine, theirs) = (all(x), all(y));
        assert_eq!(x.columns.len(), 1, "row {i}: the gear ratio");
        assert_eq!(mine.len(), theirs.len(), "row {i}");
        for (u, v) in mine.into_iter().zip(theirs) {
            assert_eq!(u.to_bits(), v.to_bits(), "row {i}");
        }
    }
}

#[test]
fn grid_order_is_strategy_gear_t2() {
    let pts = grid(
        &Strategy::ALL[..2],
        &[0.0, 0.1, 0.2],
        &[Some(20.0), Some(30.0)],
    );
    assert_eq!(pts.len(), 12);
    assert_eq!(pts[1].t2_s, 0.1);
    assert_eq!(pts[3].gear_ratio, Some(30.0));
    assert_eq!(pts[6].strategy, Strategy::ALL[1]);
}

#[test]
fn sweep_is_bit_identical_for_any_thread_count() {
    let (p, c) = (leap_params(), LeapConfig::default());
    let pts = small_grid();
    let one = sweep(&p, &c, &pts, 1).unwrap();
    let two = sweep(&p, &c, &pts, 2).unwrap();
    let three = sweep(&p, &c, &pts, 3).unwrap();
    same_bits(&one, &two);
    same_bits(&one, &three);
    // and each row equals the point run on its own, by a preset of its own
    for (pt, row) in pts.iter().zip(&one) {
        let alone = run_row(&LeapSweep::new(&p, &c), pt, &NEVER);
        same_bits(std::slice::from_ref(row), &[alone]);
    }
}

/// One column vocabulary (`selfmanip_sim::outcome::APEX_COLUMNS`): a leap row's `apex_z_m`
/// is the body centre's height above the ground, up — minus the NED `z` of the engine's own
/// apex event — as in the sweep of any robot (`selfmanip-sim/tests/preset_sweep.rs`), and
/// the vertical rate vanishes there.
#[test]
fn leap_rows_report_the_apex_height_up() {
    let (p, c) = (leap_params(), LeapConfig::default());
    let leap = rhex_model::leap::simulate_leap(&p, &c).unwrap();
    let e = leap.execution.events.last().unwrap();
    assert_eq!(e.kind, selfmanip_hybrid::EventKind::Apex);
    let iz = rhex_model::leap::leap_rhex(&p, &c).unwrap().model.ix_z();
    let pt = LeapPoint::new(c.strategy, c.t2_s, None);
    let row = sweep(&p, &c, &[pt], 1).unwrap().remove(0);
    let a = row.apex.unwrap();
    assert_eq!(a.z_m, -e.q[iz]);
    assert!(a.z_m > 0.0 && a.zdot_m_s.abs() < 1e-6, "{a:?}");
    assert_eq!(row.apex_columns()[2], a.z_m);
    assert_eq!(row.columns, vec![28.0]);
}

#[test]
fn a_bad_point_never_loses_the_others() {
    let (p, c) = (leap_params(), LeapConfig::default());
    let good = small_grid();
    let mut mixed = good.clone();
    let mut bad = good[3].clone();
    bad.overrides.insert("m_b".into(), json!(-1.0));
    mixed.insert(3, bad.clone());
    let mut bad_gear = good[0].clone();
    bad_gear.gear_ratio = Some(f64::NAN);
    mixed.push(bad_gear);
    let rows = sweep(&p, &c, &mixed, 2).unwrap();
    assert_eq!(rows.len(), good.len() + 2);
    assert_eq!(rows[3].status, "invalid_params");
    assert!(rows[3].error.contains("m_b"), "{}", rows[3].error);
    assert!(rows[3].apex.is_none() && rows[3].columns[0].is_nan());
    assert_eq!(rows.last().unwrap().status, "invalid_params");
    assert!(rows.last().unwrap().error.contains("gear_ratio"));
    let alone = sweep(&p, &c, &good, 2).unwrap();
    let mut rest = rows.clone();
    rest.remove(3);
    rest.pop();
    same_bits(&rest, &alone);
}

#[test]
fn overrides_reach_params_config_and_actuator_by_name() {
    let (p, c) = (leap_params(), LeapConfig::default());
    let mut pt = LeapPoint::new(Strategy::new(Push::Minus, Push::Plus), -0.05, Some(21.0));
    for (k, v) in [
        ("m_b", json!(8.5)),
        ("leg_shape", json!("stick")),
        ("mu_rear", json!(1.2)),
        ("delta_t_s", json!(0.0)),
        ("toe_stub_rad", json!(0.3)),
        ("current_limit_a", json!(12.5)),
    ] {
        pt.overrides.insert(k.into(), v);
    }
    let (pp, cc) = point_inputs(&p, &c, &pt).unwrap();
    assert_eq!(pp.m_b, 8.5);
    assert_eq!(pp.leg_shape, rhex_model::LegShape::Stick);
    assert_eq!(pp.mu_rear, Some(1.2));
    assert_eq!(cc.delta_t_s, 0.0);
    assert_eq!(cc.toe_stub_rad, Some(0.3));
    assert_eq!(cc.t2_s, -0.05);
    assert_eq!(cc.strategy, Strategy::new(Push::Minus, Push::Plus));
    match cc.actuator {
        LegActuator::GearedMotor(GearedMotor {
            gear_ratio,
            current_limit_a,
            motors_per_leg,
            ..
        }) => {
            assert_eq!((gear_ratio, current_limit_a), (21.0, 12.5));
            assert_eq!(
                X_RHEX_LEG.actuator(),
                LegActuator::GearedMotor(GearedMotor {
                    gear_ratio: 28.0,
                    current_limit_a: 20.0,
                    motors_per_leg,
                    gearbox_efficiency: None,
                    gearbox_loss: Default::default(),
                    battery_resistance_ohm: None,
                })
            );
        }
        other => panic!("{other:?}"),
    }
    // untouched fields keep the base
    assert_eq!(
        (pp.I_b, cc.swing_accel_rad_s2),
        (p.I_b, c.swing_accel_rad_s2)
    );
    // gear_ratio None keeps the saturated torque of the base
    let sat = LeapConfig {
        actuator: LegActuator::SaturatedTorque,
        ..LeapConfig::default()
    };
    let (_, cc) = point_inputs(&p, &sat, &LeapPoint::new(Strategy::ALL[0], 0.0, None)).unwrap();
    assert_eq!(cc.actuator, LegActuator::SaturatedTorque);
}

/// Each name is listed once: `pairs`, a field of both the parameters and the configuration,
/// is one override (the leap's pushing pairs). Second route: the names as a set.
#[test]
fn sweepable_names_are_listed_once() {
    let names = sweepable_names();
    let set: std::collections::BTreeSet<&String> = names.iter().collect();
    assert_eq!(set.len(), names.len(), "{names:?}");
    assert!(names.iter().any(|n| n == "pairs"));
}

/// Every field the parameters and the configuration read is an override by name — also
/// the optional ones that a default value leaves out of its serialization. Second route:
/// the keys of a serialization with every such option set.
#[test]
fn optional_fields_are_overrides_too() {
    let names = sweepable_names();
    let full = rhex_model::RhexParams {
        mu_body: Some(0.3),
        leg_armature_kg_m2: Some(0.01),
        ..leap_params()
    };
    let serde_json::Value::Object(keys) = serde_json::to_value(&full).unwrap() else {
        panic!("parameters serialize as an object")
    };
    for k in keys.keys() {
        assert!(names.contains(k), "{k} is not sweepable");
    }
    let mut pt = LeapPoint::new(Strategy::ALL[0], 0.0, Some(28.0));
    pt.overrides
        .insert("leg_armature_kg_m2".into(), json!(0.01));
    pt.overrides.insert("mu_body".into(), json!(0.3));
    let (pp, _) = point_inputs(&leap_params(), &LeapConfig::default(), &pt).unwrap();
    assert_eq!((pp.leg_armature_kg_m2, pp.mu_body), (Some(0.01), Some(0.3)));
}

#[test]
fn bad_overrides_name_their_field() {
    let (p, c) = (leap_params(), LeapConfig::default());
    let field_of = |k: &str, v: serde_json::Value| {
        let mut pt = LeapPoint::new(Strategy::ALL[0], 0.0, Some(28.0));
        pt.overrides.insert("m_b".into(), json!(9.0));
        pt.overrides.insert(k.into(), v);
        match point_inputs(&p, &c, &pt) {
            Err(e) => e.field().unwrap_or_else(|| panic!("{k}: {e}")).to_string(),
            other => panic!("{k}: {other:?}"),
        }
    };
    assert_eq!(field_of("no_such_thing", json!(1.0)), "no_such_thing");
    assert_eq!(field_of("leg_shape", json!("triangle")), "leg_shape");
    assert_eq!(field_of("delta_t_s", json!("soon")), "delta_t_s");
    assert_eq!(field_of("rho2", json!(0.0)), "rho2");
    assert_eq!(field_of("current_limit_a", json!(-3.0)), "current_limit_a");
    assert!(check_override_names(["m_b", "zeno_max_events", "motors_per_leg"]).is_ok());
    // own columns are not overrides
    assert!(check_override_names(["t2_s"]).is_err());
    assert!(sweep(&p, &c, &[], 0).is_err());
}

fn synthetic() -> (Trajectory, Vec<selfmanip_sim::EventRecord>) {
    let n = 50;
    let t_s: Vec<f64> = (0..n).map(|k| -0.1 + 0.004 * k as f64).collect();
    let q: Vec<Vec<f64>> = t_s
        .iter()
        .map(|t| vec![1.5 * t, 2.0 * t, 0.3 * t, -0.1 - t * t, 0.2 * t])
        .collect();
    let qd: Vec<Vec<f64>> = t_s
        .iter()
        .map(|t| vec![1.5, 2.0, 0.3, -2.0 * t, 0.2])
        .collect();
    let mode: Vec<String> = (0..n)
        .map(|k| {
            if k < 20 {
                "1010".into()
            } else if k < 35 {
                "0101".into()
            } else {
                "0000".into()
            }
        })
        .collect();
    let contacts = vec![
        "middle_leg".to_string(),
        "rear_leg".into(),
        "front_body".into(),
        "rear_body".into(),
    ];
    let contact_points_m = (0..n)
        .map(|k| {
            (0..4)
                .map(|c| {
                    if (k < 20) == (c >= 2) && k < 35 {
                        Some([0.1 * c as f64, 0.0])
                    } else {
                        None
                    }
                })
                .collect()
        })
        .collect::<Vec<Vec<_>>>();
    let contact_forces_n = contact_points_m
        .iter()
        .enumerate()
        .map(|(k, row)| {
            row.iter()
                .map(|p| p.map(|_| [3.0 + k as f64, -40.0]))
                .collect()
        })
        .collect();
    let tr = Trajectory {
        q_names: selfmanip_sim::trajectory::q_names(
            &rhex_model::Rhex::new(leap_params()).unwrap().model,
        ),
        tau: Vec::new(),
        contacts,
        t_s,
        q,
        qd,
        mode,
        contact_points_m,
        contact_forces_n,
    };
    let ev = vec![selfmanip_sim::EventRecord {
        t_s: -0.02,
        kind: "touchdown",
        mode_before: "1010".into(),
        mode_after: "1111".into(),
        contacts: vec!["middle_leg".into()],
        energy_loss_j: 0.25,
        impulse_n_s: vec![None, None, Some([0.1, -0.4]), None],
        force_n: vec![
            Some([0.0, -3.0]),
            None,
            Some([0.5, -6.0]),
            Some([0.0, -1.0]),
        ],
    }];
    (tr, ev)
}

#[test]
fn mcap_log_is_complete_and_atomic() {
    let (tr, ev) = synthetic();
    let params = leap_params();
    let mut md = BTreeMap::new();
    md.insert("strategy".to_string(), "++".to_string());
    let log = LeapLog {
        trajectory: &tr,
        events: &ev,
        params: &params,
        metadata: md,
    };
    let bytes = write_leap_mcap_to(Cursor::new(Vec::new()), &log)
        .unwrap()
        .into_inner();
    assert_eq!(&bytes[..8], b"\x89MCAP0\r\n");
    assert_eq!(&bytes[bytes.len() - 8..], b"\x89MCAP0\r\n");

    let dir = std::env::temp_dir().join(format!("selfmanip-mcap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("leap.mcap");
    write_leap_mcap(&path, &log).unwrap();
    assert_eq!(
        std::fs::read(&path).unwrap(),
        bytes,
        "file equals the in-memory stream"
    );
    // no temporary left behind
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
    // an invalid log leaves no file under the final name and no temporary
    let mut bad = tr.clone();
    bad.q.pop();
    let bad_path = dir.join("bad.mcap");
    let r = write_leap_mcap(
        &bad_path,
        &LeapLog {
            trajectory: &bad,
            events: &ev,
            params: &params,
            metadata: BTreeMap::new(),
        },
    );
    assert!(r.is_err());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn mcap_log_reads_back_with_the_mcap_reader() {
    let (tr, ev) = synthetic();
    let params = leap_params();
    let log = LeapLog {
        trajectory: &tr,
        events: &ev,
        params: &params,
        metadata: BTreeMap::new(),
    };
    let bytes = write_leap_mcap_to(Cursor::new(Vec::new()), &log)
        .unwrap()
        .into_inner();
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    let mut states = Vec::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        *counts.entry(m.channel.topic.clone()).or_default() += 1;
        let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        if m.channel.topic == "/state" {
            assert_eq!(m.channel.schema.as_ref().unwrap().name, "selfmanip.State");
            states.push(v);
        }
    }
    let n = tr.t_s.len();
    for topic in ["/tf", "/scene", "/state", "/contact_forces"] {
        assert_eq!(counts[topic], n, "{topic}");
    }
    assert_eq!(counts["/events"], ev.len());
    assert_eq!(counts["/mode"], 3, "three distinct modes in a row");
    for (k, s) in states.iter().enumerate() {
        let q: Vec<f64> = serde_json::from_value(s["q"].clone()).unwrap();
        assert_eq!(q, tr.q[k], "JSON floats round-trip exactly");
        assert_eq!(s["mode"], tr.mode[k]);
    }
}
