//! A link's length and a point contact's position as exact sensitivity parameters
//! (`docs/sensitivity.md`, "Parameters by path"): whole runs through touchdowns (plastic
//! impacts whose `A` moves, height guards that move with the foot), liftoffs and slips,
//! differentiated by path, against Richardson central differences of whole runs built with
//! the field set to `p ± h` (final state and every event time), to 1e-5.
use selfmanip_hybrid::EventKind;
use selfmanip_sim::Scenario;
mod common;

/// The newcomer's bounder of issue 30 (a 2 kg body, two two-link legs of 0.15 m links,
/// point feet of friction `mu` at the shins' ends, 5 mm ahead of their axes) with links of `masses` (thigh, shin; 0: a
/// massless link), the thighs' centres given off their axes (`appendix`: left to default to
/// the links' middles, as in the appendix, so that they move with the lengths); its
/// joints servoed (`kp`, 0.5) to hip 0.5 rad, knee −1 rad; started at `q0`, `qd0`.
struct Bounder {
    mu: f64,
    masses: [f64; 2],
    appendix: bool,
    kp: f64,
    q0: [f64; 7],
    qd0: [f64; 7],
}

fn bounder(b: &Bounder, t_final: f64) -> Scenario {
    let link = |m: f64, com: [f64; 2]| {
        let mut v = serde_json::json!({"length_m": 0.15, "mass_kg": m,
            "inertia_kg_m2": if m > 0.0 { 1.875e-4 } else { 0.0 }});
        if m > 0.0 && !b.appendix {
            v["com_m"] = serde_json::json!(com);
        }
        v
    };
    let foot = |g: &str| {
        serde_json::json!({"name": format!("{g}_foot"), "leg": g,
        "shape": {"kind": "point", "position_m": [0.005, 0.15]},
        "friction": {"kind": "sticking", "mu": b.mu}})
    };
    let leg = |name: &str, hip: f64| {
        serde_json::json!({"name": name, "hip_m": [hip, 0.0],
            "links": [link(b.masses[0], [0.01, 0.07]), link(b.masses[1], [0.0, 0.075])]})
    };
    let robot = serde_json::json!({"name": "bounder",
        "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.0267},
        "contacts": [foot("front"), foot("hind")],
        "legs": [leg("front", 0.2), leg("hind", -0.2)]});
    let servo = |t: f64| {
        serde_json::json!({"kind": "servo", "target_rad": t, "kp_n_m_per_rad": b.kp,
            "kd_n_m_s_per_rad": 0.5})
    };
    let joints: Vec<_> = ["front", "hind"]
        .iter()
        .flat_map(|g| [(0, 0.5), (1, -1.0)].map(|(k, t)| (format!("{g}[{k}]"), t)))
        .map(
            |(j, t)| serde_json::json!({"joint": j, "phases": [{"name": "h", "torque": servo(t)}]}),
        )
        .collect();
    let v = serde_json::json!({
        "robot": robot,
        "initial": {"q": b.q0, "qd": b.qd0},
        "behaviour": {"joints": joints},
        "options": {"t_final_s": t_final, "rtol": 1e-12, "event_tol_s": 1e-14,
                    "stop_at_apex": false}
    });
    serde_json::from_value(v).unwrap()
}

/// [`Bounder`] of friction 1.5 and servo gain 30, dropped from 0.36 m (z down) falling at
/// 0.6 m/s, pitched `pitch` and moving forward at `vx`.
fn pitched(masses: [f64; 2], appendix: bool, pitch: f64, vx: f64) -> Bounder {
    Bounder {
        mu: 1.5,
        masses,
        appendix,
        kp: 30.0,
        q0: [0.5, -1.0, 0.5, -1.0, 0.0, -0.36, pitch],
        qd0: [0.0, 0.0, 0.0, 0.0, vx, -0.6, 0.0],
    }
}

/// The hind leg's thigh length, the front leg's, and the hind foot's position (the shins'
/// lengths move nothing here: their feet are given in their frames, and their centres too
/// unless [`Bounder::appendix`]).
const GEOMETRY: [(&str, f64); 4] = [
    ("legs.hind.links[0].length_m", 0.15),
    ("legs.front.links[0].length_m", 0.15),
    ("contacts.hind_foot.shape.position_m[1]", 0.15),
    ("contacts.hind_foot.shape.position_m[0]", 0.005),
];

/// (a) The bounder with massive links, pitched nose-up and moving forward: its hind foot
/// lands (a plastic impact), then its front foot; the hind foot slips (Coulomb sliding,
/// whose friction moves with the geometry) and lifts off.
#[test]
fn a_bounder_through_touchdowns_a_slip_and_a_liftoff() {
    let b = pitched([0.1, 0.1], false, 0.1, 1.0);
    use EventKind::{Apex, Liftoff, Slip, Touchdown};
    let kinds = [Apex, Touchdown, Touchdown, Slip, Liftoff];
    let w = common::worst_run_path_error(&bounder(&b, 0.29), &GEOMETRY, &kinds);
    eprintln!("worst {w:.1e}");
}

/// (b) The bounder with massless thighs: a massless link's length moves the kinematics only
/// (the shin, its centre and its foot), through three touchdowns, a slip, a liftoff and a
/// stick.
#[test]
fn b_massless_thighs_through_touchdowns_and_a_liftoff() {
    let b = pitched([0.0, 0.1], true, 0.3, 0.0);
    use EventKind::{Apex, Liftoff, Slip, Stick, Touchdown};
    let kinds = [Apex, Touchdown, Touchdown, Slip, Liftoff, Touchdown, Stick];
    let w = common::worst_run_path_error(&bounder(&b, 0.35), &GEOMETRY, &kinds);
    eprintln!("worst {w:.1e}");
}

/// (c) The newcomer's bounder of the appendix as described there (every centre of
/// mass left to default to its link's middle, so a length moves its own link's centre too),
/// through two touchdowns, a slip and a liftoff.
#[test]
fn c_appendix_bounder_with_default_centres() {
    let b = pitched([0.1, 0.1], true, 0.1, 1.0);
    let mut cases = GEOMETRY.to_vec();
    cases.push(("legs.hind.links[1].length_m", 0.15));
    cases.push(("legs.front.links[1].length_m", 0.15));
    use EventKind::{Apex, Liftoff, Slip, Touchdown};
    let kinds = [Apex, Touchdown, Touchdown, Slip, Liftoff];
    let w = common::worst_run_path_error(&bounder(&b, 0.29), &cases, &kinds);
    eprintln!("worst {w:.1e}");
}

/// A geometric column leaves the others as they were: the body's mass differentiated alone
/// and beside a length and a contact's position gives the same column, bit for bit (each
/// column is its own solve with the same factorization).
#[test]
fn geometric_columns_leave_the_others_unchanged() {
    let s = bounder(&pitched([0.1, 0.1], false, 0.1, 1.0), 0.29);
    let sim = selfmanip_sim::Simulation::new(&s).unwrap();
    let run = sim.run().unwrap();
    let column = |names: &[&str]| {
        let p = selfmanip_sim::sensitivity::scenario_parameter_sensitivity(
            &s,
            &sim.options,
            &run,
            names,
        )
        .unwrap();
        p.state.unwrap().column(0).into_owned()
    };
    let alone = column(&["body.mass_kg"]);
    let beside = column(&["body.mass_kg", GEOMETRY[0].0, GEOMETRY[3].0]);
    assert_eq!(alone, beside);
}
