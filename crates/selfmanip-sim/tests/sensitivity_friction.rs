//! Friction coefficients and the pseudo-impulse's δt as exact sensitivity parameters
//! (`docs/sensitivity.md`, "Parameters by path"): a hopper whose foot slips and slides
//! under Coulomb friction, differentiated in its foot's static `mu`, its kinetic
//! `mu_kinetic` and the two tied (`mu` with `mu_kinetic` left to default to it), against
//! Richardson central differences of whole runs (final state and every event time).
use selfmanip_hybrid::EventKind;
use selfmanip_sim::sensitivity::scenario_parameter_sensitivity;
use selfmanip_sim::{Scenario, Simulation};
mod common;
use common::fd;

/// The end state `(q, q̇)` followed by the event times, and the event kinds.
fn end(s: &Scenario) -> (Vec<f64>, Vec<EventKind>) {
    let run = Simulation::new(s).unwrap().run().unwrap();
    fd::end_state_and_events(&run.execution)
}

/// Richardson-extrapolated central differences in `path` at `p` (steps `h`, `h/2`).
fn central(s: &Scenario, path: &str, p: f64, h: f64, kinds: &[EventKind]) -> Vec<f64> {
    common::central_in_path(s, (path, p, h), kinds, end)
}

/// The bounder moving forward at 1 m/s, pitched 0.1 rad, feet of `mu = 0.4`: its hind
/// foot lands sliding at 0.061 s (the impact's sticking impulse outside the cone), sticks at
/// 0.063 s (the sliding velocity's zero), slips at 0.080 s (the slip guard
/// `|λ_t| = μ(−λ_n)`) and slides on the cone's edge under Coulomb friction to 0.09 s.
const MU: f64 = 0.4;
/// The static coefficient where the two are given apart.
const MU_STATIC: f64 = 0.45;
const T_FINAL: f64 = 0.09;

fn check(s: &Scenario, cases: &[(&str, f64)]) -> f64 {
    let sim = Simulation::new(s).unwrap();
    let run = sim.run().unwrap();
    let kinds: Vec<_> = run.execution.events.iter().map(|e| e.kind).collect();
    let kinds_expected = [EventKind::Touchdown, EventKind::Stick, EventKind::Slip];
    assert_eq!(kinds, kinds_expected);
    let names: Vec<&str> = cases.iter().map(|c| c.0).collect();
    let p = scenario_parameter_sensitivity(s, &sim.options, &run, &names).unwrap();
    assert_eq!(p.reason, None);
    common::worst_path_error(&p, cases, |path, value| {
        central(s, path, value, 1e-4 * value, &kinds)
    })
}

#[test]
fn friction_coefficients_match_central_differences() {
    // `mu` with `mu_kinetic` left to default to it: one number, both coefficients
    let tied = bounder(MU, None, 1.0, 0.1, T_FINAL);
    let w1 = check(&tied, &[("robot.contacts.hind_foot.friction.mu", MU)]);
    // given apart: the static coefficient (the slip's time) and the kinetic one (the slide)
    let apart = bounder(MU_STATIC, Some(MU), 1.0, 0.1, T_FINAL);
    let w2 = check(
        &apart,
        &[
            ("robot.contacts[1].friction.mu", MU_STATIC),
            ("robot.contacts.hind_foot.friction.mu_kinetic", MU),
        ],
    );
    eprintln!("worst {:.1e}", w1.max(w2));
}

/// The newcomer's bounder of issue 30 (a 2 kg body, two two-link legs of 0.1 kg links,
/// point feet of friction `mu`) with servoed joints, dropped pitched nose-down moving
/// forward at `vx` m/s, so that its hind foot lands alone and slides.
fn bounder(mu: f64, mu_k: Option<f64>, vx: f64, phi: f64, t_final: f64) -> Scenario {
    let link = serde_json::json!({"length_m": 0.15, "mass_kg": 0.1, "inertia_kg_m2": 1.875e-4});
    let mut friction = serde_json::json!({"kind": "sticking", "mu": mu});
    if let Some(k) = mu_k {
        friction["mu_kinetic"] = k.into();
    }
    let foot = |g: &str| {
        serde_json::json!({"name": format!("{g}_foot"), "leg": g,
        "shape": {"kind": "point", "position_m": [0, 0.15]}, "friction": friction.clone()})
    };
    let robot = serde_json::json!({"name": "bounder", "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.0267},
        "contacts": [foot("front"), foot("hind")],
        "legs": [{"name": "front", "hip_m": [0.2, 0.0], "links": [link, link]},
                 {"name": "hind", "hip_m": [-0.2, 0.0], "links": [link, link]}]});
    let servo = |t: f64| {
        serde_json::json!({"kind": "servo", "target_rad": t, "kp_n_m_per_rad": 30.0,
        "kd_n_m_s_per_rad": 0.5})
    };
    let joints: Vec<_> = [
        ("front[0]", 0.5),
        ("front[1]", -1.0),
        ("hind[0]", 0.5),
        ("hind[1]", -1.0),
    ]
    .iter()
    .map(|(j, t)| serde_json::json!({"joint": j, "phases": [{"name": "h", "torque": servo(*t)}]}))
    .collect();
    let v = serde_json::json!({
        "robot": robot,
        "initial": {"q": [0.5, -1.0, 0.5, -1.0, 0.0, -0.30, phi], "qd": [0.0, 0.0, 0.0, 0.0, vx, 0.0, 0.0]},
        "behaviour": {"joints": joints},
        "options": {"t_final_s": t_final, "rtol": 1e-12, "event_tol_s": 1e-14}
    });
    serde_json::from_value(v).unwrap()
}

/// The pseudo-impulse is never applied to the state (thesis §5.1.4): a landing of the
/// hopper's massless leg that uses it (δt = 0.01 s, its pseudo-impulse recorded on the
/// touchdown) has zero columns in `options.delta_t_s`, and the runs at `δt ± h` are the run
/// itself, bit for bit (the central differences are exactly zero); at δt = 0 the name is
/// flagged (another impact rule: a one-sided derivative).
#[test]
fn pseudo_impulse_duration_has_zero_derivative_where_it_selects() {
    let text = std::fs::read_to_string(common::data("hop.toml")).unwrap();
    let b = selfmanip_sim::behaviour::Behaviour::from_toml_str(&text).unwrap();
    let mut s = common::hopper(b, 0.45);
    s.options.delta_t_s = 0.01;
    let sim = Simulation::new(&s).unwrap();
    let run = sim.run().unwrap();
    let e = &run.execution;
    let kinds: Vec<_> = e.events.iter().map(|e| e.kind).collect();
    assert_eq!(
        kinds,
        [
            EventKind::Touchdown,
            EventKind::Liftoff,
            EventKind::Apex,
            EventKind::Touchdown
        ]
    );
    assert!(
        !e.events[0].pseudo_impulse.is_empty(),
        "the landing uses the pseudo-impulse"
    );
    assert!(!e.events[3].pseudo_impulse.is_empty());
    let names = ["options.delta_t_s", "parameters.kp_push"];
    let p = scenario_parameter_sensitivity(&s, &sim.options, &run, &names).unwrap();
    assert_eq!(p.reason, None);
    assert_eq!(p.not_differentiated, [None, None]);
    let x = p.state.as_ref().unwrap();
    assert!(x.column(0).iter().all(|v| *v == 0.0), "{}", x.column(0));
    // the other column is not zero: the run has derivatives, δt's are zero
    assert!(x.column(1).amax() > 1e-3);
    let fd = central(&s, "options.delta_t_s", 0.01, 1e-4, &kinds);
    assert!(fd.iter().all(|v| *v == 0.0), "{fd:?}");
    let mut at_zero = s.clone();
    at_zero.options.delta_t_s = 0.0;
    let sim0 = Simulation::new(&at_zero).unwrap();
    let run0 = sim0.run().unwrap();
    let p0 = scenario_parameter_sensitivity(&at_zero, &sim0.options, &run0, &names[..1]).unwrap();
    assert!(p0.not_differentiated[0]
        .as_deref()
        .is_some_and(|r| r.contains("one-sided")));
}
