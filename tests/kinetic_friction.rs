//! Kinetic (Coulomb) friction of a sliding toe on a single-joint massless leg
//! (`selfmanip_core::friction`), against routes that do not use the engine's KKT:
//!
//! A body rests level on two frictionless skids and slides along the ground; a massless leg
//! at its centre presses its toe on the ground with a constant motor torque. The geometry
//! is fixed (the skids hold height and pitch, the toe's height fixes the leg angle), so the
//! toe slides with the body and only `x` moves. Then
//! - the toe's force lies on the cone edge against the sliding: `F_t = −μ_k |F_n| sign ẋ`;
//! - the leg's statics hold by virtual work, `τ + ∂p_toe/∂θ · F = 0`, with the Jacobian by
//!   central differences of the kinematics;
//! - Newton on the whole robot: `m ẍ = F_t` (the skids push only vertically);
//! - the body, decelerating at the constant `|F_t|/m`, stops at `t* = m v₀ / |F_t|`, having
//!   lost its kinetic energy to the friction work `|F_t| v₀ t*/2`; the engine's slip→stick
//!   event is that stop, and its reset sticks the toe where the cone holds it.
//!
//! And at zero sliding speed the site is sticking for the instant: the sliding mode's force
//! reproduces the sticking mode's when the cone holds it, and is the cone edge on the same
//! side when it does not — the force is continuous through a slip. An integrating caller's
//! law (`Data::slide_at_rest`) never holds a site in a sliding mode: where the cone holds it,
//! it takes no edge and reports that the cone holds it (the engine then sticks it).
use selfmanip::core::{ContactKind, Data, FlatGround, Model};
use selfmanip::hybrid::{ConstantTorque, EventKind};

mod sled;
#[path = "../crates/selfmanip-hybrid/tests/systems/mod.rs"]
mod systems;
use sled::{all_sliding, leg_angle, sled, state, G, HIP_HEIGHT, LEG, M, MU};
use systems::{assert_friction_took, sled_slide};

/// Toe position (world, z down) at leg angle `theta` with the body at the origin pose.
fn toe(model: &Model, theta: f64) -> [f64; 2] {
    let mut kin = selfmanip::core::kinematics::Kinematics::default();
    kin.compute(model, &[theta, 0.0, -HIP_HEIGHT, 0.0], &[0.0; 4]);
    let p = kin.point(
        selfmanip::core::kinematics::Part::Link(0),
        nalgebra::Vector2::new(0.0, LEG),
    );
    [p.x, p.y]
}

/// The torque that presses the toe into the ground (the sign that makes it push).
fn pressing_torque(model: &Model) -> f64 {
    // ∂p_z/∂θ > 0 means turning θ up drives the toe down: a positive torque presses it
    let h = 1e-6;
    let dz = toe(model, leg_angle() + h)[1] - toe(model, leg_angle() - h)[1];
    4.0 * dz.signum()
}

#[test]
fn sliding_toe_force_is_on_the_cone_edge_against_sliding_and_balances_the_leg() {
    let model = sled();
    let tau = pressing_torque(&model);
    for xdot in [0.7, -0.4] {
        let (q, _) = state(xdot);
        let data = sled::sliding_on_flat(&model, xdot, tau);
        // rows: toe normal, front skid, rear skid
        let lambda_n = data.lambda[0];
        assert!(lambda_n < 0.0, "the toe pushes: {lambda_n}");
        let site = &data.sliding[0];
        assert!(
            (site.force_t.abs() - MU * lambda_n.abs()).abs() < 1e-9 * lambda_n.abs(),
            "{} vs μ|λ_n| {}",
            site.force_t,
            MU * lambda_n.abs()
        );
        // on flat ground t̂ = +x: friction opposes the sliding velocity
        assert_eq!(site.force_t.signum(), -xdot.signum());
        // Newton: only the friction pushes the robot along x
        assert!((M * data.qdd[1] - site.force_t).abs() < 1e-9 * site.force_t.abs());
        // the massless leg's statics by virtual work, Jacobian by central differences
        let h = 1e-6;
        let (p1, p0) = (toe(&model, q[0] + h), toe(&model, q[0] - h));
        let jac = [(p1[0] - p0[0]) / (2.0 * h), (p1[1] - p0[1]) / (2.0 * h)];
        // ground force on the robot, world (x, z down): normal row points into the ground
        let force = [site.force_t, lambda_n];
        let virtual_work = tau + jac[0] * force[0] + jac[1] * force[1];
        assert!(
            virtual_work.abs() < 1e-6 * tau.abs(),
            "τ + Jᵀ F = {virtual_work}"
        );
    }
}

#[test]
fn sled_on_a_pressed_toe_stops_at_the_closed_form_time() {
    let model = sled();
    let tau = pressing_torque(&model);
    let v0 = 0.6;
    let (q, qd) = state(v0);
    // the friction force, constant along the slide (fixed geometry, constant torque)
    let data = sled::sliding_on_flat(&model, v0, tau);
    let f_t = data.sliding[0].force_t.abs();
    let t_star = M * v0 / f_t;
    let press = ConstantTorque::first_joint(tau);
    let exec = sled_slide(&model, &press, (&q, &qd), 2.0 * t_star);
    // it stops at t*: the first segment ends with the slip→stick event where the sliding
    // velocity crosses zero (no rest band: the friction force keeps its side through the
    // segment, so the crossing is a transversal zero of a smooth flow, located to event_tol),
    // having travelled v0 t*/2 — the kinetic energy gone into friction work
    let stop = &exec.events[0];
    assert_eq!(stop.kind, EventKind::Stick, "{:?}", exec.events);
    assert!((stop.t - t_star).abs() < 1e-7, "{} vs {t_star}", stop.t);
    let seg = &exec.segments[0];
    assert_eq!(seg.t1, stop.t);
    let mut y = vec![0.0; 8];
    seg.eval(stop.t, &mut y);
    assert!(y[5].abs() < 1e-7 * v0, "speed at the event {}", y[5]);
    let travelled = y[1] - q[1];
    assert!((travelled - 0.5 * v0 * t_star).abs() < 1e-8, "{travelled}");
    assert!((0.5 * M * v0 * v0 - f_t * travelled).abs() < 1e-8 * f_t);
    // the engine's energy balance counts that work (E₁ − E₀ = W + W_fr − L): the friction
    // took all of the sled's kinetic energy (the toe sticks after the stop, the skids slide
    // without friction), and the balance closes over the whole run
    assert_friction_took(&model, &exec, 0.5 * M * v0 * v0);
    // at rest the reset decides by the cone (second route: the sticking mode's force at the
    // stop, by the core's KKT at zero speed): held, the toe sticks in a mode with its
    // tangential row, and the sled stays where it stopped to the end of the run
    let stick_mode = all_sliding().with(0, ContactKind::Stick);
    let mut stick = Data::new(&model);
    let (qs, qds) = ([y[0], y[1], y[2], y[3]], [0.0; 4]);
    sled::solve(
        &model,
        &mut stick,
        &FlatGround,
        stick_mode,
        (&qs, &qds),
        tau,
    )
    .unwrap();
    let (lt, ln) = (stick.lambda[0], stick.lambda[1]);
    assert!(
        lt.abs() <= MU * -ln,
        "this sled's toe is held at rest: {lt} vs {ln}"
    );
    assert_eq!(
        stop.mode_after.kind(0),
        Some(ContactKind::Stick),
        "{:?}",
        stop.mode_after
    );
    // (the skids are judged by complementarity as ever: one that the stuck toe's torque
    // unloads lifts off) — and the toe stays where it stopped through the next segment
    let next = &exec.segments[1];
    assert_eq!(next.mode.kind(0), Some(ContactKind::Stick));
    let toe_at = |y: &[f64]| {
        let mut kin = selfmanip::core::kinematics::Kinematics::default();
        kin.compute(&model, &y[..4], &y[4..]);
        kin.point(
            selfmanip::core::kinematics::Part::Link(0),
            nalgebra::Vector2::new(0.0, LEG),
        )
    };
    let p_stop = toe_at(&y);
    let mut y1 = vec![0.0; 8];
    next.eval(next.t1, &mut y1);
    assert!(
        (toe_at(&y1) - p_stop).norm() < 1e-9,
        "the toe moved: {:?}",
        toe_at(&y1) - p_stop
    );
    // the sliding segment takes the steps of a smooth flow, not those of a velocity band
    // (the rest band of the earlier law kept the sled hovering at its edge)
    assert!(
        seg.dense.len() < 50,
        "{} steps to the stop",
        seg.dense.len()
    );
}

#[test]
fn at_zero_sliding_speed_the_toe_sticks_for_the_instant() {
    // the sled at rest on an incline tilted by β: gravity along the plane must be held by
    // the toe alone (the skids are frictionless), λ_t = ∓ m g sin β — inside the cone on a
    // gentle slope, outside on a steep one
    let model = sled();
    let tau = pressing_torque(&model);
    let mut seen = [false; 2];
    for beta in [0.1_f64, 0.3, 0.6, 0.9] {
        let plane = selfmanip::core::GroundPlane {
            point_m: [0.0, 0.0],
            normal_into_ground: [beta.sin(), beta.cos()],
        };
        // the flat-ground pose turned by β about the origin (body z along the normal)
        let n = plane.normal();
        let q = [leg_angle(), -HIP_HEIGHT * n.x, -HIP_HEIGHT * n.y, beta];
        let qd = [0.0; 4];
        let stick_mode = all_sliding().with(0, ContactKind::Stick);
        let mut stick = Data::new(&model);
        sled::solve(&model, &mut stick, &plane, stick_mode, (&q, &qd), tau).unwrap();
        // the sticking mode holds everything: nothing moves
        assert!(stick.qdd.iter().all(|a| a.abs() < 1e-9), "{:?}", stick.qdd);
        let (lt, ln) = (stick.lambda[0], stick.lambda[1]);
        assert!(ln < 0.0 && (lt.abs() - M * G * beta.sin()).abs() < 1e-9 * M * G);
        let mut slide = Data::new(&model);
        sled::solve(&model, &mut slide, &plane, all_sliding(), (&q, &qd), tau).unwrap();
        let site = &slide.sliding[0];
        assert!(site.at_rest);
        // the integrating caller's law at rest: never held
        let mut integ = Data::new(&model);
        integ.slide_at_rest = true;
        sled::solve(&model, &mut integ, &plane, all_sliding(), (&q, &qd), tau).unwrap();
        let isite = &integ.sliding[0];
        assert_eq!(isite.cone_holds, lt.abs() <= MU * ln.abs());
        if lt.abs() <= MU * ln.abs() {
            seen[0] = true;
            // neither edge starts it sliding against its force: no friction, and the
            // caller is told the cone holds it
            assert_eq!(isite.sigma, 0.0);
            assert_eq!(isite.force_t, 0.0);
            // the cone holds it: the sliding mode's flow is the sticking one
            assert!((site.force_t - lt).abs() < 1e-9 * lt.abs());
            assert!((slide.lambda[0] - ln).abs() < 1e-9 * ln.abs());
            assert!(slide.qdd.iter().all(|a| a.abs() < 1e-9), "{:?}", slide.qdd);
        } else {
            seen[1] = true;
            // the same edge for the integrating caller, σ against the sticking force
            assert_eq!(isite.sigma, -lt.signum());
            assert!((isite.force_t - site.force_t).abs() < 1e-9 * lt.abs());
            // it slips: the cone edge on the side of the sticking force, and the sled
            // accelerates down the slope
            assert_eq!(site.force_t.signum(), lt.signum());
            assert!((site.force_t.abs() - MU * slide.lambda[0].abs()).abs() < 1e-9 * lt.abs());
            let t = plane.tangent();
            let a_along = slide.qdd[1] * t.x + slide.qdd[2] * t.y;
            let down_slope = t.y.signum(); // gravity's component along t̂ (z down)
            assert!(a_along * down_slope > 0.0, "{a_along}");
        }
    }
    assert!(seen[0] && seen[1], "both regimes exercised: {seen:?}");
}
