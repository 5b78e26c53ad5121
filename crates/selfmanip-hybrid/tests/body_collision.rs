//! A body's collision shapes in the hybrid engine (issue 30, item 4): their sites are
//! ordinary contacts (guarded, impacting, rolling), checked against closed forms; an outline
//! the guards cannot keep out of the terrain ends the run as a typed penetration. Frames
//! (docs/conventions.md): NED, z down, `q = [x, z, φ]` for a body without legs, a body point
//! `p` at `X + R(φ) p` with `R(φ) = [[cos φ, sin φ], [−sin φ, cos φ]]`.
use nalgebra::Vector2;
use selfmanip_core::{
    forward_dynamics, ContactMode, Data, FlatGround, GroundPlane, Model, RobotDescription, Terrain,
};
use selfmanip_hybrid::{simulate, EventKind, Execution, HybridOptions, Termination, ZeroTorque};

#[path = "../../selfmanip-core/tests/common/spike.rs"]
mod spike;
use spike::Spike;

const G: f64 = 9.81;
const M: f64 = 2.0;
const I: f64 = 0.03;

/// A body of mass `M`, inertia `I`, with one collision shape (TOML inline table) and
/// `friction`, and no legs.
fn body(shape: &str, friction: &str) -> Model {
    let text = format!(
        "name = \"b\"\n[body]\nmass_kg = {M}\ninertia_kg_m2 = {I}\n\
         collision = [{{ shape = {shape}, friction = {friction} }}]\n"
    );
    RobotDescription::from_toml_str(&text)
        .unwrap()
        .build()
        .unwrap()
}

const STICK: &str = "{ kind = \"sticking\" }";

fn run(
    model: &Model,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q0: [f64; 3],
    qd0: [f64; 3],
    t: f64,
) -> Execution {
    simulate(
        model,
        terrain,
        &ZeroTorque,
        mode,
        &q0,
        &qd0,
        t,
        HybridOptions::default(),
    )
    .unwrap()
}

/// `model` dropped at rest, level, from `z0`.
fn dropped(model: &Model, terrain: &dyn Terrain, z0: f64, t: f64) -> Execution {
    run(
        model,
        terrain,
        ContactMode::FLIGHT,
        [0.0, z0, 0.0],
        [0.0; 3],
        t,
    )
}

fn names(model: &Model, contacts: &[usize]) -> Vec<String> {
    let mut v: Vec<String> = contacts
        .iter()
        .map(|&k| model.contacts[k].name.clone())
        .collect();
    v.sort();
    v
}

/// The names of the sites the run's first event lands on, after checking that it is a
/// touchdown at the free-fall time of a drop of `fall_m`, `sqrt(2 fall / g)`.
fn landing_after_free_fall(model: &Model, e: &Execution, fall_m: f64) -> Vec<String> {
    let first = &e.events[0];
    assert_eq!(first.kind, EventKind::Touchdown);
    let t = (2.0 * fall_m / G).sqrt();
    assert!((first.t - t).abs() < 1e-9, "{} against {t}", first.t);
    names(model, &first.triggered)
}

#[test]
fn a_box_dropped_flat_lands_on_its_two_lower_corners_at_the_free_fall_time() {
    let (l, h) = (0.4, 0.1);
    let model = body(&format!("{{ kind = \"box\", size_m = [{l}, {h}] }}"), STICK);
    let z0 = -0.2;
    let e = dropped(&model, &FlatGround, z0, 0.5);
    assert_eq!(e.termination, Termination::FinalTime);
    // the lower corners (body z = +h/2) fall −z0 − h/2
    assert_eq!(
        landing_after_free_fall(&model, &e, -z0 - h / 2.0),
        ["body.collision[0].corner[0]", "body.collision[0].corner[1]"]
    );
    // it rests there: centre h/2 above the ground, level, still
    assert_eq!(e.events.len(), 1);
    assert!(
        (e.q[1] + h / 2.0).abs() < 1e-6 && e.q[2].abs() < 1e-9,
        "{:?}",
        e.q
    );
    assert!(e.qd.iter().all(|v| v.abs() < 1e-9), "{:?}", e.qd);
    // resting, each corner carries half the weight (a pushing normal force is negative):
    // one corner sticking, the other sliding, so that the rows are independent
    let rest = ContactMode::parse_names(
        &model,
        "body.collision[0].corner[0],body.collision[0].corner[1]:slide",
    )
    .unwrap();
    let mut data = Data::new(&model);
    forward_dynamics(
        &model,
        &mut data,
        &FlatGround,
        rest,
        &[0.0, -h / 2.0, 0.0],
        &[0.0; 3],
        &[],
        None,
    )
    .unwrap();
    // rows: corner[0] t, corner[0] n, corner[1] n
    let lam = data.lambda.as_slice();
    assert!(lam[0].abs() < 1e-12, "{lam:?}");
    assert!(
        (lam[1] + M * G / 2.0).abs() < 1e-9 && (lam[2] + M * G / 2.0).abs() < 1e-9,
        "{lam:?}"
    );
    assert!(data.qdd.iter().all(|a| a.abs() < 1e-9));
}

#[test]
fn a_tilted_stadium_lands_on_its_lower_end_circle_first() {
    let (len, r) = (0.4, 0.05);
    let model = body(
        &format!("{{ kind = \"stadium\", length_m = {len}, radius_m = {r} }}"),
        STICK,
    );
    // pitched nose-up by φ: the rear end circle's centre (−len/2, 0) is at z0 + sin φ len/2
    let (z0, phi) = (-0.3, 0.2_f64);
    let e = run(
        &model,
        &FlatGround,
        ContactMode::FLIGHT,
        [0.0, z0, phi],
        [0.0; 3],
        0.5,
    );
    let fall = -(z0 + phi.sin() * len / 2.0) - r;
    assert_eq!(
        landing_after_free_fall(&model, &e, fall),
        ["body.collision[0].end[0]"]
    );
    // then its front end comes down: it ends on both, level, its centre r above the ground
    let last = e
        .events
        .iter()
        .rev()
        .find(|ev| ev.kind == EventKind::Touchdown)
        .unwrap();
    assert!(last.mode_after.contains(0) && last.mode_after.contains(1));
    assert!(
        (e.q[1] + r).abs() < 1e-6 && e.q[2].abs() < 1e-6,
        "{:?}",
        e.q
    );
    assert!(!matches!(e.termination, Termination::Penetration { .. }));
}

#[test]
fn a_circle_rolls_down_an_incline_at_g_sin_alpha_over_one_plus_i_over_m_r2() {
    let r = 0.05;
    let model = body(&format!("{{ kind = \"circle\", radius_m = {r} }}"), STICK);
    // a plane through the origin descending towards +x at α: surface direction
    // (cos α, sin α), normal into the ground (−sin α, cos α)
    let alpha = 0.3_f64;
    let (sa, ca) = alpha.sin_cos();
    let plane = GroundPlane {
        point_m: [0.0, 0.0],
        normal_into_ground: [-sa, ca],
    };
    // centre r above the plane, at rest, rolling
    let q0 = [0.0, -r / ca, 0.0];
    let mode = ContactMode::with_defaults(&model, &[0]).unwrap();
    let t = 0.4;
    let e = run(&model, &plane, mode, q0, [0.0; 3], t);
    assert_eq!(e.termination, Termination::FinalTime);
    assert!(e.events.is_empty());
    let a = G * sa / (1.0 + I / (M * r * r));
    let s = 0.5 * a * t * t;
    let moved = Vector2::new(e.q[0] - q0[0], e.q[1] - q0[1]);
    assert!(
        (moved - s * Vector2::new(ca, sa)).norm() < 1e-9,
        "{moved} vs {s}"
    );
    // without slip: it turned by s / r (nose-down, −y, rolling towards +x)
    assert!((e.q[2] + s / r).abs() < 1e-8, "{}", e.q[2]);
}

#[test]
fn a_circle_landing_with_speed_rolls_on_at_the_speed_its_angular_momentum_allows() {
    let r = 0.05;
    let model = body(&format!("{{ kind = \"circle\", radius_m = {r} }}"), STICK);
    let (z0, v0, t) = (-0.2, 0.3, 0.5);
    let e = run(
        &model,
        &FlatGround,
        ContactMode::FLIGHT,
        [0.0, z0, 0.0],
        [v0, 0.0, 0.0],
        t,
    );
    assert_eq!(e.events.len(), 1);
    let t1 = (2.0 * (-z0 - r) / G).sqrt();
    assert!((e.events[0].t - t1).abs() < 1e-9);
    // the plastic impact keeps the angular momentum about the contact point:
    // M v0 r = (M r² + I) ω, so it rolls at v = M v0 / (M + I / r²)
    let v = M * v0 / (M + I / (r * r));
    assert!((e.qd[0] - v).abs() < 1e-9, "{} vs {v}", e.qd[0]);
    assert!(
        (e.q[0] - (v0 * t1 + v * (t - t1))).abs() < 1e-8,
        "{}",
        e.q[0]
    );
    assert!((e.q[2] + v * (t - t1) / r).abs() < 1e-7, "{}", e.q[2]);
}

#[test]
fn a_terrain_corner_inside_the_outline_ends_the_run_as_a_penetration() {
    let (l, h) = (0.4, 0.1);
    let model = body(&format!("{{ kind = \"box\", size_m = [{l}, {h}] }}"), STICK);
    // a spike 7 cm high at x = 0.05: its tip passes between the box's corners
    let spike = Spike {
        tip: Vector2::new(0.05, -0.07),
    };
    let z0 = -0.2;
    // it lands on its corners with the tip inside, h/2 − 0.02 deep: the landing is the end
    let e = dropped(&model, &spike, z0, 0.5);
    let t1 = (2.0 * (-z0 - h / 2.0) / G).sqrt();
    let Termination::Penetration {
        t,
        ref outline,
        depth_m,
    } = e.termination
    else {
        panic!("{}", e.termination)
    };
    assert_eq!(outline, "body.collision[0]");
    assert!(
        (t - t1).abs() < 1e-9 && (depth_m - (h / 2.0 - 0.02)).abs() < 1e-8,
        "{t} {depth_m}"
    );
    assert_eq!(e.events.len(), 1);
    // ending in flight with the tip 2 cm inside its bottom edge: found at the final time
    // (bottom edge at z0 + h/2 + g t²/2 = −0.05)
    let t_end = (2.0 * 0.1 / G).sqrt();
    let e = dropped(&model, &spike, z0, t_end);
    assert!(e.events.is_empty());
    let Termination::Penetration { t, depth_m, .. } = e.termination else {
        panic!("{}", e.termination)
    };
    assert!(
        (t - t_end).abs() < 1e-12 && (depth_m - 0.02).abs() < 1e-9,
        "{t} {depth_m}"
    );
    // the same corners declared as plain contacts: no outline, nothing checked — the run
    // reaches its final time with the spike inside (what issue 30 reported, unsaid)
    let corners: String = [(-1.0, 1.0), (1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)]
        .iter()
        .enumerate()
        .map(|(j, (a, b))| {
            format!(
                "[[contacts]]\nname = \"c{j}\"\nshape = {{ kind = \"point\", position_m = [{}, {}] }}\n\
                 friction = {STICK}\n",
                a * l / 2.0,
                b * h / 2.0
            )
        })
        .collect();
    let plain = RobotDescription::from_toml_str(&format!(
        "name = \"b\"\n[body]\nmass_kg = {M}\ninertia_kg_m2 = {I}\n{corners}"
    ))
    .unwrap()
    .build()
    .unwrap();
    let e = dropped(&plain, &spike, z0, t_end);
    assert_eq!(e.termination, Termination::FinalTime);
}
