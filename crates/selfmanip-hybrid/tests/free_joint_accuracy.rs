//! The prescribed motion of a free massless joint is integrated to the run's tolerance when
//! its controller declares the instants where that motion changes shape as time events
//! (`selfmanip_hybrid::Controller::time_events`; the engine's steps land on them): a leg
//! swung down touches down when the closed form of its swing says.
//!
//! A free massless joint feeds back into no other coordinate (thesis 5.1.1) and is left out
//! of the step-size control, but its angle decides when its contact touches down (the guard
//! (5.49) is its toe's height). Integrated with whatever steps the rest of the state allows
//! — up to `h_max` = 10 ms while the body rests — a kink of its prescribed acceleration (a
//! swing reaching its speed) inside a step moves the touchdown by an amount that no
//! tolerance reduces: this swing without its time event touched down 0.37 ms late at rtol
//! 1e-6 (and the default RHex leaps' first touchdown came 0.26 ms late at every rtol from
//! 1e-8 to 1e-12 before the leap controller declared its knots: 0.03155 s against 0.03129 s
//! with the leg in the step-size control).
//! Putting the free joints in the step-size control instead costs 1.8 times the steps of a
//! default leap; with a weight 10³–10⁶ times looser the embedded error estimate does not see
//! the kink (errors of 0.03–0.9 ms at rtol 1e-6).
#[path = "../../selfmanip-core/tests/common/bisect.rs"]
mod bisect;
mod systems;

use bisect::bisect;
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{ContactMode, FlatGround, Model};
use selfmanip_hybrid::{simulate, Controller, EventKind, HybridOptions, StepOptions, TimeEvent};
use systems::G;

const LEG_M: f64 = 0.2;
/// The belly's depth below the hip: the body rests on it, the hip 5 cm above the ground.
const BELLY_M: f64 = 0.05;
const THETA0: f64 = std::f64::consts::PI;
const ALPHA: f64 = 3000.0;
const T_ACCEL: f64 = 0.012;

/// The swing: from rest at `THETA0`, `ALPHA` until `T_ACCEL`, then constant speed (the
/// shape of a motor-set leg swing: a kink in `θ̈`).
fn swing(t: f64) -> (f64, f64, f64) {
    if t < T_ACCEL {
        (THETA0 + 0.5 * ALPHA * t * t, ALPHA * t, ALPHA)
    } else {
        let w = ALPHA * T_ACCEL;
        (
            THETA0 + 0.5 * ALPHA * T_ACCEL * T_ACCEL + w * (t - T_ACCEL),
            w,
            0.0,
        )
    }
}

/// No torque; the free leg on its swing (a critically damped servo against round-off, as
/// the RHex leap's controller has).
#[derive(Clone)]
struct Swing;

impl Controller for Swing {
    fn time_events(&self, names: &[&str]) -> Vec<TimeEvent> {
        vec![TimeEvent {
            t: T_ACCEL,
            dt_dp: vec![0.0; names.len()],
        }]
    }
    fn torque(&self, _t: f64, _q: &[f64], _qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        tau.fill(0.0);
    }
    fn free_joint_qdd(&self, t: f64, q: &[f64], qd: &[f64], free: &[usize], out: &mut [f64]) {
        for (o, &j) in out.iter_mut().zip(free) {
            let (th, w, a) = swing(t);
            *o = a + 400.0 * (th - q[j]) + 40.0 * (w - qd[j]);
        }
    }
}

fn model() -> Model {
    systems::one_leg(LEG_M, 0.0, G)
}

/// The toe's height above the ground with the body resting, the leg at `theta`.
fn toe_gap(model: &Model, theta: f64) -> f64 {
    let mut kin = Kinematics::default();
    let q = [theta, 0.0, -BELLY_M, 0.0];
    kin.compute(model, &q, &[0.0; 4]);
    contact_geometry(
        model,
        &kin,
        &FlatGround,
        model.contact_index("toe").unwrap(),
    )
    .gap_m
}

/// The touchdown time of the closed-form swing: the first sign change of the toe's height
/// on a 10 µs grid, bisected to 1e-13 s.
fn closed_form_touchdown(model: &Model) -> f64 {
    let gap = |t: f64| toe_gap(model, swing(t).0);
    let mut t = 0.0;
    while gap(t + 1e-5) > 0.0 {
        t += 1e-5;
        assert!(t < 0.2, "the swing never reaches the ground");
    }
    bisect(t, t + 1e-5, 1e-13, gap).1
}

fn touchdown(model: &Model, rtol: f64) -> f64 {
    let belly = ContactMode::parse_names(model, "belly:slide").unwrap();
    let opts = HybridOptions {
        step: StepOptions {
            rtol,
            ..StepOptions::default()
        },
        ..HybridOptions::default()
    };
    let q0 = [THETA0, 0.0, -BELLY_M, 0.0];
    let exec = simulate(model, &FlatGround, &Swing, belly, &q0, &[0.0; 4], 0.1, opts).unwrap();
    exec.events
        .iter()
        .find(|e| e.kind == EventKind::Touchdown)
        .expect("the toe touches down")
        .t
}

/// The closed form of the swing and the toe's geometry (no integrator) against the engine's
/// touchdown event, at rtol 1e-6, 1e-8 and 1e-10: within a hundred times the angle
/// tolerance over the leg's speed, `100 · rtol · |θ| / ω`, plus ten event tolerances.
/// Without the time event it was 0.37 ms late at rtol 1e-6.
#[test]
fn a_free_legs_touchdown_is_where_its_swing_puts_it_at_every_tolerance() {
    let model = model();
    // the hip is 5 cm above the ground: pointing up, the toe is L + 5 cm above it
    assert!(toe_gap(&model, THETA0) > 0.2, "the leg starts pointing up");
    let t_exact = closed_form_touchdown(&model);
    assert!(
        t_exact > T_ACCEL,
        "the kink of the swing lies before the touchdown"
    );
    let (theta, omega, _) = swing(t_exact);
    for rtol in [1e-6, 1e-8, 1e-10] {
        let t = touchdown(&model, rtol);
        let bound =
            100.0 * rtol * theta.abs() / omega + 10.0 * HybridOptions::default().event_tol_s;
        assert!(
            (t - t_exact).abs() <= bound,
            "rtol {rtol}: touchdown at {t} s, the swing's closed form {t_exact} s (off by {:e} s, bound {bound:e} s)",
            t - t_exact
        );
    }
}
