//! Stage `guard` (and its location): guard values against closed forms, typed directions,
//! arming, a grazing touchdown, an event exactly on a step boundary, and two crossings in
//! one step.
mod systems;
use selfmanip_core::{ContactMode, FlatGround, GroundPlane};
use selfmanip_hybrid::flow::Flow;
use selfmanip_hybrid::guard::{Direction, Guard, GuardSet};
use selfmanip_hybrid::{simulate, EventKind, HybridOptions, StepOptions, Termination, ZeroTorque};
use std::sync::Arc;
use systems::{block, body, coast, puck, Friction, BLOCK, G};

#[test]
fn directions_orient_guard_values() {
    assert_eq!(Direction::PositiveThenNonPositive.orient(0.25), 0.25);
    assert_eq!(Direction::NegativeThenNonNegative.orient(0.25), -0.25);
    assert_eq!(Direction::Undetermined { reference: 0.1 }.orient(0.25), 0.0);
}

/// Touchdown guards are contact heights, liftoff guards pushing normal forces, the apex
/// guard the upward speed: closed forms for a tilted block in flight and a standing block.
#[test]
fn guard_values_are_heights_forces_and_speeds() {
    let model = block(G);
    let (w, h, m) = BLOCK;
    let mut flow = Flow::new(&model, &FlatGround, Arc::new(ZeroTorque));
    // flight, centre 0.3 m up, tilted by 0.2 rad, rising at 0.7 m/s
    let phi = 0.2_f64;
    let y = [0.0, -0.3, phi, 0.0, -0.7, 0.0];
    for (k, p) in [(0, [-w / 2.0, h / 2.0]), (1, [w / 2.0, h / 2.0])] {
        let z = -0.3 + systems::rotate(phi, p)[1];
        let gap = Guard::Touchdown(k)
            .value(&mut flow, 0.0, ContactMode::FLIGHT, &y)
            .unwrap();
        assert!((gap + z).abs() < 1e-14, "height of contact {k}");
    }
    let apex = Guard::Apex
        .value(&mut flow, 0.0, ContactMode::FLIGHT, &y)
        .unwrap();
    assert_eq!(apex, 0.7);
    // standing on both corners: each pushes with half the weight; the sliding corner (it
    // can stick) also has a slip→stick guard, its sliding velocity
    let mode = ContactMode::parse_names(&model, "left,right:slide").unwrap();
    let standing = [0.0, -h / 2.0, 0.0, 0.0, 0.0, 0.0];
    let mut guards = Vec::new();
    Guard::of_mode(&model, mode, &[], &HybridOptions::default(), &mut guards);
    assert_eq!(
        guards,
        vec![
            Guard::Liftoff { contact: 0, row: 1 },
            Guard::Liftoff { contact: 1, row: 2 },
            Guard::Stick(1)
        ]
    );
    for g in &guards[..2] {
        let push = g.value(&mut flow, 0.0, mode, &standing).unwrap();
        assert!((push - m * G / 2.0).abs() < 1e-9);
    }
    assert_eq!(
        guards[2].value(&mut flow, 0.0, mode, &standing).unwrap(),
        0.0
    );
}

/// A slip→stick guard fires against the sign of the sliding velocity it starts with, and
/// has no direction yet for a contact starting from rest.
#[test]
fn stick_guards_take_the_direction_of_the_sliding() {
    let model = puck(0.5);
    let mode = ContactMode::parse_names(&model, "foot:slide").unwrap();
    let mut flow = Flow::new(&model, &FlatGround, Arc::new(ZeroTorque));
    let opts = HybridOptions::default();
    let mut set = GuardSet::default();
    for (v, from_rest, expected) in [
        (0.4, false, Direction::PositiveThenNonPositive),
        (-0.4, false, Direction::NegativeThenNonNegative),
        (0.0, false, Direction::Undetermined { reference: 0.0 }),
        (0.4, true, Direction::Undetermined { reference: 0.4 }),
    ] {
        let y = [0.0, 0.0, 0.0, v, 0.0, 0.0];
        let rest: &[usize] = if from_rest { &[0] } else { &[] };
        set.arm(&mut flow, mode, 0.0, &y, rest, &opts).unwrap();
        let stick = set
            .states
            .iter()
            .find(|s| matches!(s.guard, Guard::Stick(0)))
            .unwrap();
        assert_eq!(stick.direction, expected, "v = {v}, from rest: {from_rest}");
    }
}

/// A puck sliding *backward* up an incline (a negative sliding velocity) stops at
/// `t* = |v₀| / (g sin β)`: its slip→stick guard fires negative-then-non-negative.
#[test]
fn puck_sliding_backward_stops_at_the_closed_form_time() {
    let (beta, v0, mu) = (-0.3_f64, -1.2, 0.8);
    let model = puck(mu);
    let plane = GroundPlane {
        point_m: [0.0, 0.0],
        normal_into_ground: [beta.sin(), beta.cos()],
    };
    let t = plane.tangent();
    let mode = ContactMode::parse_names(&model, "foot:slide").unwrap();
    let exec = coast(
        &model,
        &plane,
        mode,
        (&[0.0, 0.0, beta], &[v0 * t.x, v0 * t.y, 0.0]),
        2.0,
    );
    let stop = &exec.events[0];
    assert_eq!(stop.kind, EventKind::Stick);
    let expected = v0.abs() / (G * beta.abs().sin());
    assert!((stop.t - expected).abs() < 1e-9, "{} vs {expected}", stop.t);
}

/// A bar spinning at `ω` in zero gravity, its centre `z_c` above the ground: its left end
/// is at height `z_c − L sin ωt`. Grazing from above (`z_c = L + δ`) never fires; reaching
/// the ground (`z_c = L − δ`) fires at `t* = asin(z_c / L) / ω`.
#[test]
fn grazing_touchdown_fires_only_when_the_end_reaches_the_ground() {
    let (l, omega, delta) = (0.5_f64, 2.0, 1e-6);
    let model = body(
        1.0,
        0.02,
        0.0,
        &[
            ("left", -l, 0.0, Friction::Slide),
            ("right", l, 0.0, Friction::Slide),
        ],
    );
    let run = |zc: f64| {
        coast(
            &model,
            &FlatGround,
            ContactMode::FLIGHT,
            (&[0.0, -zc, 0.0], &[0.0, 0.0, omega]),
            1.5,
        )
    };
    let above = run(l + delta);
    assert!(above.events.is_empty(), "a miss by 1 µm must not fire");
    assert_eq!(above.termination, Termination::FinalTime);
    let touching = run(l - delta);
    let first = &touching.events[0];
    let expected = ((l - delta) / l).asin() / omega;
    assert_eq!(first.triggered, vec![0]);
    assert!(
        (first.t - expected).abs() < 1e-8,
        "{} vs {expected}",
        first.t
    );
}

/// Options with fixed steps of `h` s (the motions below are linear: DOPRI5 is exact and
/// never shrinks a step).
fn fixed_steps(h: f64) -> HybridOptions {
    HybridOptions {
        step: StepOptions {
            h_initial_s: h,
            h_max_s: h,
            ..StepOptions::default()
        },
        ..HybridOptions::default()
    }
}

/// A block falling at 1 m/s in zero gravity from 0.5 m lands at exactly `t = 0.5`, the end
/// of its fourth 0.125 s step: the event is found there, once, inside the step that holds it.
#[test]
fn an_event_exactly_on_a_step_boundary_fires_once_at_it() {
    let model = block(0.0);
    let (_, h, _) = BLOCK;
    let opts = fixed_steps(0.125);
    let exec = simulate(
        &model,
        &FlatGround,
        &ZeroTorque,
        ContactMode::FLIGHT,
        &[0.0, -0.5 - h / 2.0, 0.0],
        &[0.0, 1.0, 0.0],
        1.0,
        opts,
    )
    .unwrap();
    let landing = &exec.events[0];
    assert_eq!(landing.kind, EventKind::Touchdown);
    assert_eq!(landing.triggered, vec![0, 1]);
    assert!((landing.t - 0.5).abs() <= opts.event_tol_s);
    let seg = &exec.segments[0];
    let last = seg.dense.step(seg.dense.len() - 1);
    assert!(last.t0 <= landing.t && landing.t <= last.t1());
    assert_eq!(exec.events.len(), 1, "landed, and stays");
}

/// Two contacts 0.30 m and 0.31 m above the ground, falling at 1 m/s in zero gravity with a
/// single 1 s step: both cross inside the step; the earlier fires alone, at 0.30 s.
#[test]
fn two_crossings_in_one_step_the_earlier_fires() {
    let model = body(
        1.0,
        0.02,
        0.0,
        &[
            ("low", -0.1, 0.0, Friction::Slide),
            ("high", 0.1, -0.01, Friction::Slide),
        ],
    );
    let exec = simulate(
        &model,
        &FlatGround,
        &ZeroTorque,
        ContactMode::FLIGHT,
        &[0.0, -0.30, 0.0],
        &[0.0, 1.0, 0.0],
        1.0,
        fixed_steps(1.0),
    )
    .unwrap();
    let first = &exec.events[0];
    assert_eq!(first.triggered, vec![0], "only the lower contact");
    assert!((first.t - 0.30).abs() < 1e-9, "{}", first.t);
}
