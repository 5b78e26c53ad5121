//! The newcomer's bounder of issue 30 with light shins (2 g, 2·10⁻⁶ kg m²) and stiff servo
//! damping (`k_d / I = 2·10⁵ /s`), dropped from 5 cm with its joints away from their targets:
//! the stiff user robot of `stiff_run.rs` and `stiff_sensitivity.rs`.
use selfmanip_sim::Scenario;

/// The bounder with the front shin's servo damping `kd_front_shin` (N m s; the other servos'
/// 0.4) and the scenario's `options` (the JSON object's fields, e.g. `"t_final_s": 0.3`).
pub fn stiff_bounder(kd_front_shin: f64, options: &str) -> Scenario {
    let link = r#"{"length_m": 0.15, "mass_kg": 0.1, "inertia_kg_m2": 1.875e-4}"#;
    let shin = r#"{"length_m": 0.15, "mass_kg": 0.002, "inertia_kg_m2": 2e-6}"#;
    let foot = |g: &str| {
        format!(
            r#"{{"name": "{g}_foot", "leg": "{g}", "shape": {{"kind": "point",
            "position_m": [0, 0.15]}}, "friction": {{"kind": "sticking", "mu": 0.8}}}}"#
        )
    };
    let leg = |n: &str, x: f64| {
        format!(r#"{{"name": "{n}", "hip_m": [{x}, 0.0], "links": [{link}, {shin}]}}"#)
    };
    let servo = |j: &str, target: f64, kd: f64| {
        format!(
            r#"{{"joint": "{j}", "phases": [{{"name": "h", "torque": {{"kind": "servo",
            "target_rad": {target}, "kp_n_m_per_rad": 20.0, "kd_n_m_s_per_rad": {kd}}}}}]}}"#
        )
    };
    let json = format!(
        r#"{{"robot": {{"name": "bounder", "body": {{"mass_kg": 2.0, "inertia_kg_m2": 0.0267}},
        "contacts": [{}, {}], "legs": [{}, {}]}},
        "initial": {{"q": [0.5, -1.0, 0.5, -1.0, 0.0, -0.33, 0.0]}},
        "behaviour": {{"joints": [{}, {}, {}, {}]}},
        "options": {{{options}}}}}"#,
        foot("front"),
        foot("hind"),
        leg("front", 0.2),
        leg("hind", -0.2),
        servo("front[0]", 0.6, 0.4),
        servo("front[1]", -0.8, kd_front_shin),
        servo("hind[0]", 0.6, 0.4),
        servo("hind[1]", -0.8, 0.4),
    );
    Scenario::from_json_str(&json).unwrap()
}
