//! Stage `flow`: the flow (5.48) against statics and free fall, and its cache against a
//! controller that changes at an event.
mod systems;
use selfmanip_core::{forward_dynamics, ContactMode, Data, FlatGround};
use selfmanip_hybrid::flow::Flow;
use selfmanip_hybrid::{Controller, Event, EventKind, ZeroTorque};
use std::sync::Arc;
use systems::{block, one_leg, BLOCK, G};

/// A block standing on both bottom corners (one sticking, one sliding: two sticking
/// corners on a plane are redundant) is in equilibrium: `q̈ = 0`, each corner carries half
/// its weight (`λ_n = −m g / 2`, pushing negative), and the tangential force is zero.
#[test]
fn standing_block_flow_is_statics() {
    let model = block(G);
    let (_, h, m) = BLOCK;
    let mode = ContactMode::parse_names(&model, "left,right:slide").unwrap();
    let mut flow = Flow::new(&model, &FlatGround, Arc::new(ZeroTorque));
    let q = [0.0, -h / 2.0, 0.0];
    let data = flow.eval(0.0, mode, &q, &[0.0; 3]).unwrap();
    assert!(data.qdd.amax() < 1e-12);
    // rows: left t, left n, right n
    let lambda = data.lambda.as_slice();
    assert!(lambda[0].abs() < 1e-9);
    assert!((lambda[1] + m * G / 2.0).abs() < 1e-9);
    assert!((lambda[2] + m * G / 2.0).abs() < 1e-9);
}

/// In flight the flow is free fall: `ẍ = 0, z̈ = g, φ̈ = 0` (z down).
#[test]
fn flight_flow_is_free_fall() {
    let model = block(G);
    let mut flow = Flow::new(&model, &FlatGround, Arc::new(ZeroTorque));
    let mut dy = [0.0; 6];
    flow.rhs(
        0.0,
        ContactMode::FLIGHT,
        &[0.1, -1.0, 0.3, 0.5, 0.2, -2.0],
        &mut dy,
    )
    .unwrap();
    assert_eq!(dy[..3], [0.5, 0.2, -2.0]);
    assert!(dy[3].abs() < 1e-12 && (dy[4] - G).abs() < 1e-12 && dy[5].abs() < 1e-12);
}

/// A controller that doubles its hip torque at every event.
#[derive(Clone)]
struct Doubling {
    tau: f64,
}

impl Controller for Doubling {
    fn torque(&self, _t: f64, _q: &[f64], _qd: &[f64], _m: ContactMode, tau: &mut [f64]) {
        tau[0] = self.tau;
    }
    fn on_event(&mut self, _event: &Event) {
        self.tau *= 2.0;
    }
}

/// The flow's cache answers for `(t, mode, q, q̇)` under the controller it ran with: once
/// the controller learns of an event the flow at the same state is evaluated again (it
/// equals the core's forward dynamics with the new torque), and the controller that ran
/// before keeps its old answer (it is recorded with the segments before the event).
#[test]
fn cached_flow_follows_the_controller_through_an_event() {
    let model = one_leg(0.2, 0.4, G);
    let first: Arc<dyn Controller> = Arc::new(Doubling { tau: 1.5 });
    let mut flow = Flow::new(&model, &FlatGround, first.clone());
    let (q, qd) = ([0.3, 0.0, -1.0, 0.1], [1.0, 0.2, 0.0, -0.5]);
    let fresh = |tau: f64| {
        let mut data = Data::new(&model);
        forward_dynamics(
            &model,
            &mut data,
            &FlatGround,
            ContactMode::FLIGHT,
            &q,
            &qd,
            &[tau],
            None,
        )
        .unwrap();
        data.qdd.as_slice().to_vec()
    };
    let flow_qdd = |flow: &mut Flow| {
        let point = flow.eval(0.1, ContactMode::FLIGHT, &q, &qd).unwrap();
        point.qdd.clone()
    };
    let before = flow_qdd(&mut flow);
    assert_eq!(before.as_slice(), fresh(1.5));
    let event = Event::without_jump(
        0.1,
        EventKind::Liftoff,
        ContactMode::FLIGHT,
        vec![],
        (&q, &qd),
    );
    flow.notify(&event);
    let after = flow_qdd(&mut flow);
    assert_eq!(after.as_slice(), fresh(3.0));
    assert_ne!(before, after);
    let mut tau = [0.0];
    first.torque(0.1, &q, &qd, ContactMode::FLIGHT, &mut tau);
    assert_eq!(
        tau,
        [1.5],
        "the controller that ran before the event is unchanged"
    );
}

/// Kinematics at a state the flow has not evaluated equal those of a flow there.
#[test]
fn kinematics_without_a_flow_equal_the_flows() {
    let model = one_leg(0.2, 0.4, G);
    let (q, qd) = ([0.3, 0.0, -1.0, 0.1], [1.0, 0.2, 0.0, -0.5]);
    let mut flow = Flow::new(&model, &FlatGround, Arc::new(ZeroTorque));
    let y: Vec<f64> = q.iter().chain(&qd).copied().collect();
    let alone = flow.geometry(0, &y);
    flow.eval(0.0, ContactMode::FLIGHT, &q, &qd).unwrap();
    let with_flow = flow.geometry(0, &y);
    assert_eq!(alone.gap_m, with_flow.gap_m);
    assert_eq!(alone.point, with_flow.point);
}
