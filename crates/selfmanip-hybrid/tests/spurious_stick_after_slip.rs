//! Regression: right after a slip, the slip→stick guard armed on the drift of the sticking
//! contact's velocity and fired a "stick" within 1e-10 s that left the mode unchanged
//! (`000s -> 000s` in the RHex (+,+) leap at t2 = 0, t = 0.20431 s).
//!
//! A sticking contact holds its velocity at zero only through the acceleration-level
//! constraint, so its sliding velocity drifts (here: up to the 1e-8 tolerance of the start
//! state). A puck sticking on an incline steeper than `atan μ` slips at once and then slides
//! downhill from rest under `a = g (t · ẑ_down)`: its sliding velocity `v₀ + a t`, with `v₀`
//! at drift level, moves away from zero for good, so the only event is the slip — no stick
//! attempt, and no event that leaves the mode as it was.
use selfmanip_core::{ContactKind, ContactMode, GroundPlane, Model, RobotDescription};
use selfmanip_hybrid::{simulate, EventKind, HybridOptions};

const G: f64 = 9.81;

fn puck(mu: f64) -> Model {
    let text = format!(
        r#"
name = "puck"
gravity_m_s2 = {G}
legs = []
[body]
mass_kg = 2.0
inertia_kg_m2 = 0.01
[[contacts]]
name = "foot"
shape = {{ kind = "point", position_m = [0.0, 0.0] }}
friction = {{ kind = "sticking", mu = {mu} }}
"#
    );
    RobotDescription::from_toml_str(&text)
        .unwrap()
        .build()
        .unwrap()
}

#[test]
fn no_spurious_stick_right_after_a_slip() {
    let (beta, mu) = (0.5_f64, 0.3); // tan β = 0.546 > μ: slips at once
    let model = puck(mu);
    let plane = GroundPlane {
        point_m: [0.0, 0.0],
        normal_into_ground: [beta.sin(), beta.cos()],
    };
    let t = plane.tangent();
    let a = G * t.y;
    // drift of the sticking velocity: below the 1e-8 tolerance of the start state but above
    // the 1e-9 arming margin, against, along, and at zero relative to the slide
    for drift in [-5e-9 * a.signum(), 5e-9 * a.signum(), 0.0] {
        let q = [0.0, 0.0, beta];
        let qd = [drift * t.x, drift * t.y, 0.0];
        let t_final = 0.2;
        let exec = simulate(
            &model,
            &plane,
            &selfmanip_hybrid::ZeroTorque,
            ContactMode::FLIGHT.with(0, ContactKind::Stick),
            &q,
            &qd,
            t_final,
            HybridOptions::default(),
        )
        .unwrap();
        let unchanged: Vec<_> = exec
            .events
            .iter()
            .filter(|e| e.mode_before == e.mode_after)
            .collect();
        assert!(
            unchanged.is_empty(),
            "drift {drift:e}: events that leave the mode unchanged: {unchanged:?}"
        );
        let kinds: Vec<EventKind> = exec.events.iter().map(|e| e.kind).collect();
        assert_eq!(kinds, [EventKind::Slip], "drift {drift:e}");
        assert_eq!(exec.mode.kind(0), Some(ContactKind::Slide));
        // free sliding: v(T) = v₀ + a T along the tangent
        let v_t = exec.qd[0] * t.x + exec.qd[1] * t.y;
        assert!((v_t - (drift + a * t_final)).abs() < 1e-8, "{v_t}");
    }
}
