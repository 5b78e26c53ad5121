//! Free massless joints are left out of the step-size control (their prescribed motion feeds
//! back into nothing), so the steps must stay where their tracking law
//! `q̈ = α* + kp (θ* − q) + kd (ω* − q̇)` is integrated stably. With gains stiffer than the
//! steps — `kp` = 10⁶ /s² at the default 10 ms, or the shipped 4,000 /s² with a user's
//! `h_max_s` of 65 ms — the joints once grew to 10⁵³ rad in a few steps, unseen by the error
//! norm, and a hopper's foot landed at 10²⁵ m/s with 10²⁰ J gained in one impact.
//!
//! Route: the hopper of `examples/hopper.rs` dropped from 1 m (no contact for 0.3 s), both
//! massless joints holding angles they start `e₀` = 0.1 rad away from. The deviation obeys
//! `ë + kd ė + kp e = 0`; critically damped (`kd = 2√kp = 2ω`) it is
//! `e(t) = e₀ (1 + ωt) e^{−ωt}`, never larger than `|e₀|` and gone after some 40/ω.
use selfmanip_core::RobotDescription;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::{Scenario, Simulation};
use std::path::Path;

const E0: f64 = 0.1;
const HOLD: [f64; 2] = [0.5, -1.0];

/// The largest joint deviation from the held angles over the flight, and the largest after
/// `settle_s`, with free-joint gains `kp`, `kd` and the step bound `h_max_s`.
fn deviations(kp: f64, kd: f64, h_max_s: Option<f64>, settle_s: f64) -> (f64, f64) {
    let robot = RobotDescription::from_file(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/hopper.toml"),
    )
    .unwrap();
    let q0 = vec![HOLD[0] + E0, HOLD[1] - E0, 0.0, -1.0, 0.0];
    let mut s = Scenario::new(robot, q0);
    s.behaviour = Behaviour::from_toml_str(&format!(
        r#"
        name = "hold"
        [free_joints]
        kp_per_s2 = {kp}
        kd_per_s = {kd}
        [[joints]]
        joint = "leg[0]"
        [[joints.phases]]
        name = "hold"
        motion = {{ kind = "hold", angle_rad = {} }}
        [[joints]]
        joint = "leg[1]"
        [[joints.phases]]
        name = "hold"
        motion = {{ kind = "hold", angle_rad = {} }}
        "#,
        HOLD[0], HOLD[1]
    ))
    .unwrap();
    s.options.t_final_s = 0.3;
    if let Some(h) = h_max_s {
        s.options.h_max_s = h;
    }
    let run = Simulation::new(&s).unwrap().run().unwrap();
    assert!(run.execution.events.is_empty(), "the drop touches nothing");
    let tr = run.trajectory(1e-3).unwrap();
    let (mut all, mut late) = (0.0_f64, 0.0_f64);
    for (t, q) in tr.t_s.iter().zip(&tr.q) {
        let e = (q[0] - HOLD[0]).abs().max((q[1] - HOLD[1]).abs());
        all = all.max(e);
        if *t >= settle_s {
            late = late.max(e);
        }
    }
    (all, late)
}

#[test]
fn stiff_free_joint_gains_at_the_default_steps_follow_the_closed_form_bound() {
    // ω = 1000 rad/s: 20 h|λ| at the default 10 ms steps
    let w = 1000.0_f64;
    let (all, late) = deviations(w * w, 2.0 * w, None, 40.0 / w);
    assert!(all <= E0 * (1.0 + 1e-9), "max deviation {all}");
    assert!(late < 1e-9 * E0, "after 40/ω: {late}");
}

#[test]
fn a_long_step_bound_with_the_shipped_gains_follows_the_closed_form_bound() {
    // ω = 63 rad/s (hop_up.toml's 4,000 /s², critically damped), steps up to 65 ms: 4 h|λ|
    let w = 4000.0_f64.sqrt();
    let (all, late) = deviations(w * w, 2.0 * w, Some(0.065), 40.0 / w);
    assert!(all <= E0 * (1.0 + 1e-9), "max deviation {all}");
    assert!(late < 1e-9 * E0, "after 40/ω: {late}");
}
