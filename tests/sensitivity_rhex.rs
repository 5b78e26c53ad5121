//! Whole-execution sensitivities of RHex (chapter 4's planar model: two leg pairs, the body's
//! two end points) against central differences of whole executions: the robot dropped
//! pitched onto flat ground with its hips held by servos, landing on its legs, which roll on
//! their half-circle arcs (or touch with their tips), and on its body. The legs are massless
//! (singular `M̄`; free joints in flight, Lemma 5.1 in stance) or carry Table 4.2's masses.
//! The servo `Υ_i = −k (θ_i − θ_i*) − c θ̇_i` gives its partials, chained through `∂q̈/∂Υ`.
//! In this run the rear leg's rolling contact reaches its arc's end mid-segment (no event;
//! the flow's `Ȧ` changes form there): without that crossing's saltation the whole-run
//! Jacobian is off by 26 % (measured); with it, the agreement is limited to ~5e-6 by the
//! engine itself, whose steps straddle that unlocated switch (the two-event run up to
//! 0.12 s, before the switch, agrees to 1e-8).
//! The chapter-3 leap controller (a DC motor's torque–speed line and its phases) does not give
//! partials yet, so the leap itself is not covered here.
mod common;

use common::systems::flight_run;
use common::{rhex_massive, rhex_massless, seq, tight, tumbling_drop, Servos};
use nalgebra::DMatrix;
use selfmanip::core::{ContactMode, FlatGround, Model};
use selfmanip::hybrid::sensitivity::{simulate_with_sensitivity, SaltationStatus};
use selfmanip::rhex::LegShape;

/// Runs the drop, checks every saltation is defined and the whole-run Jacobian against
/// central differences in every direction of the initial state; returns the worst relative
/// error and the number of events.
fn check_drop(model: &Model, y0: &[f64], tf: f64) -> (f64, usize) {
    let nq = model.nq();
    let n = model.n_joints();
    let ctrl = Servos {
        k: 5.0,
        c: 0.05,
        target: y0[..n].to_vec(),
    };
    let opts = tight();
    let (exec, sens) = simulate_with_sensitivity(
        model,
        &FlatGround,
        &ctrl,
        ContactMode::FLIGHT,
        &y0[..nq],
        &y0[nq..],
        tf,
        opts,
    )
    .unwrap();
    eprintln!(
        "{}: {:?} at {:?}, {:?}",
        model.name,
        exec.events
            .iter()
            .map(|e| (
                e.kind,
                e.mode_after.normal_bits(),
                e.mode_after.tangential_bits()
            ))
            .collect::<Vec<_>>(),
        exec.events.iter().map(|e| e.t).collect::<Vec<_>>(),
        exec.termination
    );
    // the rear leg's rolling contact reaches its arc's end inside a segment: a switch
    // without an event, with its own saltation
    eprintln!(
        "touch switches: {:?}",
        sens.touch_switches
            .iter()
            .map(|s| (s.t, s.contact, &s.status))
            .collect::<Vec<_>>()
    );
    assert!(!sens.touch_switches.is_empty());
    for es in &sens.events {
        assert_eq!(es.status, SaltationStatus::Defined, "{es:?}");
    }
    let jac = sens.state_jacobian.as_ref().expect("defined");
    const H: f64 = 1e-6;
    let run = |y: &[f64]| flight_run(model, &ctrl, y, tf, opts);
    let mut fd = DMatrix::zeros(2 * nq, 2 * nq);
    for k in 0..2 * nq {
        let (mut yp, mut ym) = (y0.to_vec(), y0.to_vec());
        yp[k] += H;
        ym[k] -= H;
        let (ep, em) = (run(&yp), run(&ym));
        assert_eq!(seq(&ep), seq(&exec), "direction {k}");
        assert_eq!(seq(&em), seq(&exec), "direction {k}");
        for i in 0..2 * nq {
            let xp = if i < nq { ep.q[i] } else { ep.qd[i - nq] };
            let xm = if i < nq { em.q[i] } else { em.qd[i - nq] };
            fd[(i, k)] = (xp - xm) / (2.0 * H);
        }
    }
    let err = (jac - &fd).amax() / fd.amax().max(1.0);
    (err, exec.events.len())
}

#[test]
fn rhex_drop_whole_execution_jacobian() {
    for (rhex, shape) in [
        (rhex_massless(LegShape::HalfCircle), "massless half-circle"),
        (rhex_massive(LegShape::HalfCircle), "massive half-circle"),
    ] {
        let model = &rhex.model;
        let y0 = tumbling_drop(model);
        let (err, events) = check_drop(model, &y0, 0.25);
        eprintln!("RHex {shape}: {events} events, worst relative error {err:e}");
        assert!(err < 1e-5, "{shape}: {err:e}");
    }
}
