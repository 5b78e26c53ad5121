//! Derivatives of RHex leaps with massive legs (Table 4.2's leg pair: 0.126 kg, 0.00092 kg m²)
//! and Coulomb toes, whose sliding toes are general sliding sites of
//! `selfmanip_core::friction` (folded into the dynamics solve; differentiated through the
//! folded system, `selfmanip_core::tangent`).
//!
//! What holds, each against central differences (the independent route):
//! - the flow's exact Jacobian `∂(q̈, λ)/∂(q, q̇, Υ)` at the states of every sliding segment
//!   of three massive-leg leaps, in the segment's own mode, sliding directions and locked
//!   joints (the rolling half-circle legs of the model, the leap's torques), against
//!   Richardson-extrapolated central differences of `forward_dynamics`;
//! - along a whole leap, `d t_e / d t2` of the events through a massive toe's sliding
//!   stretch, against central differences of whole leaps;
//! - the apex's derivatives, through the motions the legs start in the air from the state at
//!   the event that released them (their liftoff, the takeoff): the controller's memory of
//!   that event, whose partials it gives (`Controller::memory_partials`). Held fixed, as
//!   before, the (+,+) t2 = 0.03 leap's d pitch / d t2 came out 7 % off
//!   (`a_massive_legs_air_motion_from_its_liftoff`).
//!
//! And a waiting toe on the ground that slips at its motor's start (fired by the torque's
//! jump, not by a crossing) gets a state event's time gradient (0) where the motor start's
//! (1) is right: `leap_with_sensitivity` flags it (`LeapSensitivity::ok` false, with the
//! reason).
mod common;
#[path = "../../selfmanip-core/tests/common/dynamics_fd.rs"]
mod dynamics_fd;
use common::{apex_error, tight};
use dynamics_fd::dynamics_jacobian_error;
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, X_RHEX_LEG};
use rhex_model::leap_sensitivity::leap_with_sensitivity;
use rhex_model::{Rhex, RhexParams};
use selfmanip_core::friction::SlideDirection;
use selfmanip_core::tangent::dynamics_jacobian;
use selfmanip_core::{forward_dynamics, Data, FlatGround, Model};
use selfmanip_hybrid::execution::Segment;

/// Table 4.2's leg-pair mass and inertia on the default leap's parameters (Coulomb toes).
fn massive() -> RhexParams {
    leap_params().with_table_4_2_legs()
}

/// Whether a segment slides a site with kinetic friction on a fixed edge, for a while.
fn slides(seg: &Segment) -> bool {
    seg.t1 > seg.t0
        && seg
            .slide_directions
            .iter()
            .any(|(_, d)| matches!(d, SlideDirection::Fixed(s) if *s != 0.0))
}

/// `(q̈, λ)` of the segment's mode at `(q, q̇)` with torques `tau`, or `None`.
fn eval(
    model: &Model,
    seg: &Segment,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Option<(Vec<f64>, Vec<f64>)> {
    let mut data = Data::new(model);
    data.locked = seg.locked.clone();
    data.set_slide_directions(&seg.slide_directions);
    forward_dynamics(model, &mut data, &FlatGround, seg.mode, q, qd, tau, None).ok()?;
    Some((
        data.qdd.as_slice().to_vec(),
        data.lambda.as_slice().to_vec(),
    ))
}

/// The worst relative error (to the largest entry of each block, or 1) of the exact flow
/// Jacobian at `(q, q̇)` of `seg` against central differences extrapolated from `h` and
/// `h/2` (truncation `O(h⁴)`), and the number of general sites folded there.
fn flow_jacobian_error(model: &Model, seg: &Segment, t: f64, y: &[f64]) -> (f64, usize) {
    let nq = model.nq();
    let (q, qd) = (&y[..nq], &y[nq..]);
    let mut tau = vec![0.0; model.n_joints()];
    seg.controller.torque(t, q, qd, seg.mode, &mut tau);
    let mut data = Data::new(model);
    data.locked = seg.locked.clone();
    data.set_slide_directions(&seg.slide_directions);
    let jac = dynamics_jacobian(model, &mut data, &FlatGround, seg.mode, q, qd, &tau, None)
        .unwrap_or_else(|e| panic!("segment at {}: {e}", seg.t0));
    let general = data
        .sliding
        .iter()
        .filter(|s| s.general && s.coef != 0.0 && s.held.is_none())
        .count();
    let h = 1e-5;
    let worst = dynamics_jacobian_error(
        &jac,
        (q, qd, &tau),
        &[(h, -1.0 / 3.0), (h / 2.0, 4.0 / 3.0)],
        |q, qd, tau| eval(model, seg, q, qd, tau),
    )
    .expect("the dynamics are defined beside the segment's state");
    (worst, general)
}

/// The flow Jacobian through the massive legs' sliding toes at the start and the middle of
/// every sliding segment of three massive-leg leaps (the rear toe, the front toe, both).
#[test]
fn flow_jacobian_through_massive_legs_sliding_toes_equals_finite_differences() {
    let p = massive();
    let (mut checked, mut worst, mut folded) = (0, 0.0_f64, 0);
    for (strategy, t2) in [("--", -0.1), ("++", 0.05), ("+-", 0.05)] {
        let cfg = LeapConfig {
            strategy: strategy.parse().unwrap(),
            t2_s: t2,
            ..LeapConfig::default()
        };
        let r = simulate_leap(&p, &cfg).unwrap();
        let mut pp = p.clone();
        pp.pairs = cfg.strategy.chapter3_pairs().to_vec();
        let rhex = Rhex::new(pp).unwrap();
        let model = &rhex.model;
        assert!(
            (0..2).all(|j| !model.distal_massless(j)),
            "the legs have mass"
        );
        let segs: Vec<&Segment> = r.execution.segments.iter().filter(|s| slides(s)).collect();
        assert!(!segs.is_empty(), "{strategy} {t2}: no sliding segment");
        let mut y = vec![0.0; 2 * model.nq()];
        for seg in segs {
            for t in [seg.t0, 0.5 * (seg.t0 + seg.t1)] {
                seg.eval(t, &mut y);
                let (e, g) = flow_jacobian_error(model, seg, t, &y);
                assert!(e < 1e-6, "{strategy} {t2}, segment at {t}: {e:e}");
                checked += 1;
                worst = worst.max(e);
                folded = folded.max(g);
            }
        }
    }
    eprintln!("{checked} states, worst {worst:e}, up to {folded} general sites folded");
    assert!(folded >= 1, "a massive toe's friction folded");
}

/// Along the (−,−) t2 = −0.1 leap (legs with Table 4.2's mass and their rotors' armature;
/// events: a touchdown, the rear toe's slip, its sliding stretch, the rear leg's liftoff,
/// …) `d t_e / d t2` of every event up to and including that liftoff — the first event
/// after which a massive leg's motion in the air, started from that event's state, acts —
/// equals central differences of whole leaps (steps 1e-7, 1e-6, 1e-5 s; the best-converged
/// of the three), and so do the apex's derivatives, through that motion (the controller's
/// memory of the liftoff). The default massless leap's are defined too.
#[test]
fn event_times_through_a_massive_toes_slide_equal_central_differences() {
    let p = massive();
    let cfg = tight("--", -0.1);
    let s = leap_with_sensitivity(&p, &cfg, &["t2"]).unwrap();
    assert!(s.ok, "{:?}", s.reason);
    let exact = [s.d_apex[2][0], s.d_apex[3][0], s.d_apex[1][0]];
    let err = apex_error(exact, &[1e-7, 1e-6, 1e-5], 1e-2, |d| {
        let mut c = cfg.clone();
        c.t2_s += d;
        simulate_leap(&p, &c).unwrap().apex.unwrap()
    });
    assert!(err < 1e-5, "apex: {err:e}");
    let events = &s.result.events;
    let kinds: Vec<&str> = events.iter().map(|e| e.kind).collect();
    assert_eq!(kinds[..3], ["touchdown", "slip", "liftoff"], "{kinds:?}");
    // the rear toe slides between the slip and the liftoff, on a fixed edge
    let off = s.result.time_offset_s;
    let exec = &s.result.execution;
    assert!(exec.segments.iter().any(|g| slides(g)
        && g.t0 - off >= events[1].t_s - 1e-9
        && g.t1 - off <= events[2].t_s + 1e-9));
    let times = |d: f64| {
        let mut c = cfg.clone();
        c.t2_s += d;
        simulate_leap(&p, &c).unwrap().run.events
    };
    let mut worst = 0.0_f64;
    for k in 0..3 {
        let exact = s.event_times[k].as_ref().expect("defined")[0];
        let err = [1e-7, 1e-6, 1e-5]
            .iter()
            .map(|&h| {
                let (a, b) = (times(h), times(-h));
                assert_eq!(a[k].kind, events[k].kind);
                assert_eq!(b[k].kind, events[k].kind);
                let fd = (a[k].t_s - b[k].t_s) / (2.0 * h);
                (exact - fd).abs() / fd.abs().max(1e-2)
            })
            .fold(f64::INFINITY, f64::min);
        eprintln!(
            "event {k} {}: d t/d t2 = {exact:.9}, error {err:.1e}",
            events[k].kind
        );
        worst = worst.max(err);
    }
    assert!(worst < 1e-5, "{worst:e}");
    // the massless default leap is not flagged
    let s = leap_with_sensitivity(&leap_params(), &tight("++", 0.05), &["t2"]).unwrap();
    assert!(s.ok, "{:?}", s.reason);
}

/// A toe that slips the instant its motor starts (massive legs, (−,+) with the rear motor
/// 0.14 s after the front one): the slip is fired by the torque's jump, not by a crossing,
/// so its time follows the motor start — `d t_slip / d t2 = 1` by central differences of
/// whole leaps — where the state event's formula `−D_xg X / D_xg f⁻` would not give it. The
/// hybrid sensitivities flag it (an event at a controller's time event) and the leap reports
/// no derivatives, with that reason.
#[test]
fn a_slip_fired_by_a_motor_start_is_flagged_not_differentiated() {
    let p = massive();
    let cfg = LeapConfig {
        strategy: "-+".parse().unwrap(),
        t2_s: 0.14,
        ..LeapConfig::default()
    };
    let s = leap_with_sensitivity(&p, &cfg, &["t2"]).unwrap();
    assert!(!s.ok);
    let reason = s.reason.as_deref().unwrap_or_default();
    assert!(reason.contains("time event"), "{reason}");
    let slip_at = |t2: f64| {
        let r = simulate_leap(
            &p,
            &LeapConfig {
                t2_s: t2,
                ..cfg.clone()
            },
        )
        .unwrap();
        r.events
            .iter()
            .find(|e| e.kind == "slip")
            .map(|e| e.t_s)
            .expect("a slip")
    };
    assert!((slip_at(0.14) - 0.14).abs() < 1e-12, "{}", slip_at(0.14));
    let h = 1e-6;
    let d = (slip_at(0.14 + h) - slip_at(0.14 - h)) / (2.0 * h);
    assert!((d - 1.0).abs() < 1e-6, "d t_slip / d t2 = {d}");
}

/// The (+,+) t2 = 0.03 leap with Table 4.2's legs and their rotors: the legs leave the
/// ground and are servoed along motions started from their state at liftoff, turning the
/// body in flight (Result C.5). The apex's `d/dt2` and `d/dG` (the motions' speed and
/// acceleration bounds, the servo, the rotors' armature all move with `G`) against central
/// differences of whole leaps — 7 % off in pitch when the memory of the liftoff was held
/// fixed.
#[test]
fn a_massive_legs_air_motion_from_its_liftoff() {
    let p = massive();
    let cfg = tight("++", 0.03);
    let s = leap_with_sensitivity(&p, &cfg, &["t2", "gear_ratio"]).unwrap();
    assert!(s.ok, "{:?}", s.reason);
    let col = |k: usize| [s.d_apex[2][k], s.d_apex[3][k], s.d_apex[1][k]];
    let e_t2 = apex_error(col(0), &[1e-6, 1e-5], 1e-2, |d| {
        let mut c = cfg.clone();
        c.t2_s += d;
        simulate_leap(&p, &c).unwrap().apex.unwrap()
    });
    let e_g = apex_error(col(1), &[1e-5, 1e-4], 1e-4, |d| {
        let mut c = cfg.clone();
        c.actuator = X_RHEX_LEG.with_gear_ratio(&c.actuator, 28.0 + d);
        simulate_leap(&p, &c).unwrap().apex.unwrap()
    });
    assert!(e_t2 < 1e-5 && e_g < 1e-4, "d/dt2 {e_t2:e}, d/dG {e_g:e}");
}
