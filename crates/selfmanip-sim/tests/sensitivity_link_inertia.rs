//! A link's mass, inertia and centre of mass as exact sensitivity parameters
//! (`docs/sensitivity.md`, "Parameters by path"): runs with a flight, an apex passed on the
//! way, touchdowns (plastic impacts) and sliding, differentiated in their links' inertia
//! parameters by path, against Richardson central differences of whole runs with the field
//! set to `p ± h` (final state and every event time).
use selfmanip_hybrid::EventKind;
use selfmanip_sim::sensitivity::scenario_parameter_sensitivity;
use selfmanip_sim::{Scenario, Simulation};
mod common;

/// The joint programs of two two-link legs each servoed (gains `kp`, `kd`) to the landing
/// pose, hip 0.5 rad and knee −1 rad (the foot under the hip).
fn held_at_landing_pose(legs: [&str; 2], kp: f64, kd: f64) -> Vec<serde_json::Value> {
    let servo = |target: f64| {
        serde_json::json!({"kind": "servo", "target_rad": target, "kp_n_m_per_rad": kp,
        "kd_n_m_s_per_rad": kd})
    };
    legs.iter()
        .flat_map(|leg| [(0, 0.5), (1, -1.0)].map(|(k, t)| (format!("{leg}[{k}]"), t)))
        .map(|(joint, t)| {
            serde_json::json!({"joint": joint, "phases": [{"name": "h", "torque": servo(t)}]})
        })
        .collect()
}

/// The newcomer's bounder of issue 30 (a 2 kg body, two two-link legs of 0.1 kg links with
/// their centres given off the links' axes, point feet of friction 0.4) with servoed joints,
/// thrown up (`ż = −0.6` m/s, z down) moving forward at 1 m/s pitched 0.1 rad: it passes its
/// apex, falls, and its hind foot lands sliding, sticks, slips and slides on the cone's edge.
fn bounder(t_final: f64) -> Scenario {
    let link = |com: [f64; 2]| {
        serde_json::json!({"length_m": 0.15, "mass_kg": 0.1, "inertia_kg_m2": 1.875e-4,
        "com_m": com})
    };
    let friction = serde_json::json!({"kind": "sticking", "mu": 0.4});
    let foot = |g: &str| {
        serde_json::json!({"name": format!("{g}_foot"), "leg": g,
        "shape": {"kind": "point", "position_m": [0, 0.15]}, "friction": friction.clone()})
    };
    let leg = |name: &str, hip: f64| {
        serde_json::json!({"name": name, "hip_m": [hip, 0.0],
        "links": [link([0.01, 0.07]), link([-0.005, 0.08])]})
    };
    let robot = serde_json::json!({"name": "bounder", "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.0267},
        "contacts": [foot("front"), foot("hind")],
        "legs": [leg("front", 0.2), leg("hind", -0.2)]});
    let joints = held_at_landing_pose(["front", "hind"], 30.0, 0.5);
    let v = serde_json::json!({
        "robot": robot,
        "initial": {"q": [0.5, -1.0, 0.5, -1.0, 0.0, -0.30, 0.1],
                    "qd": [0.0, 0.0, 0.0, 0.0, 1.0, -0.6, 0.0]},
        "behaviour": {"joints": joints},
        "options": {"t_final_s": t_final, "rtol": 1e-12, "event_tol_s": 1e-14,
                    "stop_at_apex": false}
    });
    serde_json::from_value(v).unwrap()
}

#[test]
fn bounder_link_inertia_matches_central_differences() {
    let s = bounder(0.195);
    let cases = [
        ("legs.hind.links[0].mass_kg", 0.1),
        ("legs.hind.links[1].mass_kg", 0.1),
        ("legs.front.links[1].mass_kg", 0.1),
        ("legs.hind.links[1].inertia_kg_m2", 1.875e-4),
        ("legs.hind.links[0].com_m[0]", 0.01),
        ("legs.hind.links[1].com_m[1]", 0.08),
    ];
    use EventKind::{Apex, Slip, Stick, Touchdown};
    let kinds = [Apex, Touchdown, Slip, Touchdown, Stick, Stick, Slip];
    let w = common::worst_run_path_error(&s, &cases, &kinds);
    eprintln!("worst {w:.1e}");
}

/// The quadruped of `examples/data/quadruped.toml` (massive thighs and shanks, designed for
/// the pronk and bound examples, not for this test) thrown up at 0.5 m/s moving forward at
/// 0.8 m/s pitched nose-up 0.15 rad, its joints servoed to the landing pose: it passes its
/// apex and lands hind foot first, then fore foot (plastic impacts of massive legs).
fn quadruped(t_final: f64) -> Scenario {
    let mut s = common::examples::dropped_quadruped(0.1, 0.15).unwrap();
    let joints = held_at_landing_pose(["fore", "hind"], 150.0, 2.0);
    s.behaviour = serde_json::from_value(serde_json::json!({ "joints": joints })).unwrap();
    s.initial.qd = Some(vec![0.0, 0.0, 0.0, 0.0, 0.8, -0.5, 0.0]);
    s.options.t_final_s = t_final;
    s.options.rtol = 1e-12;
    s.options.event_tol_s = 1e-14;
    s.options.stop_at_apex = false;
    s
}

#[test]
fn quadruped_link_inertia_matches_central_differences() {
    let s = quadruped(0.3);
    let cases = [
        ("legs.fore.links[0].mass_kg", 0.4),
        ("legs.hind.links[1].mass_kg", 0.2),
        ("legs.fore.links[1].inertia_kg_m2", 0.0008),
        ("legs.hind.links[0].inertia_kg_m2", 0.0015),
        ("body.mass_kg", 10.0),
    ];
    use EventKind::{Apex, Liftoff, Slip, Touchdown};
    let kinds = [Apex, Touchdown, Touchdown, Slip, Liftoff];
    let w = common::worst_run_path_error(&s, &cases, &kinds);
    eprintln!("worst {w:.1e}");
}

/// A link's mass or inertia of 0 is refused with the reason, its column NaN, beside an exact
/// one: 0 is the edge of its domain (here the shank keeps its inertia, the thigh its mass),
/// and a link without mass, inertia or armature is another model (Lemma 5.1's massless limb).
#[test]
fn massless_link_parameters_are_flagged() {
    let mut s = bounder(0.16);
    s.set("legs.front.links[1].mass_kg", 0.0).unwrap();
    s.set("legs.hind.links[0].inertia_kg_m2", 0.0).unwrap();
    let sim = Simulation::new(&s).unwrap();
    let run = sim.run().unwrap();
    let names = [
        "legs.front.links[1].mass_kg",
        "legs.hind.links[0].inertia_kg_m2",
        "legs.hind.hip_m[0]",
        "legs.hind.links[0].mass_kg",
    ];
    let p = scenario_parameter_sensitivity(&s, &sim.options, &run, &names).unwrap();
    assert_eq!(p.reason, None);
    let x = p.state.as_ref().unwrap();
    for (k, name) in names[..3].iter().enumerate() {
        let why = p.not_differentiated[k].as_deref().expect(name);
        eprintln!("{name}: {why}");
        assert!(x.column(k).iter().all(|v| v.is_nan()), "{name}");
    }
    assert!(p.not_differentiated[0]
        .as_deref()
        .unwrap()
        .contains("no mass"));
    assert!(p.not_differentiated[1]
        .as_deref()
        .unwrap()
        .contains("no inertia"));
    assert!(p.not_differentiated[2]
        .as_deref()
        .unwrap()
        .contains("no exact derivative"));
    // the massive thigh's mass is exact on the same run (the hind thigh keeps its mass)
    assert_eq!(p.not_differentiated[3], None);
    let fd = common::central_in_path(&s, (names[3], 0.1, 1e-5), &kinds_of(&s), common::run_end);
    let (err, scale) = common::path_column_error(&p, 3, &fd);
    eprintln!("legs.hind.links[0].mass_kg: {err:.1e} (|FD| = {scale:.2e})");
    assert!(err < 1e-5, "{err:e}");
}

fn kinds_of(s: &Scenario) -> Vec<EventKind> {
    common::run_end(s).1
}
