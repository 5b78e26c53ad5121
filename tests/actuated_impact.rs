//! The pseudo-impulse (5.38)–(5.39) of an actuated robot: `P_δ = A†(Υ − C̄q̇⁻ − N̄) δt`.
//! The thesis leaves the velocity at which the actuators' torque `Υ` is taken open (its
//! chapter-5 torques do not depend on velocity). Here it is taken at the velocity the impact
//! leaves, q̇⁺: the actuators act through the impact's δt at that speed, and it matters for
//! a motor's torque–speed line and for a servo's damping, which resists the velocity jump
//! (for a RHex leg servo that meets the ground, it is what keeps the leg on the ground).
//!
//! Checked on the sagittal quadruped landing with spinning legs under joint dampers
//! `τ = −b q̇`: the event's pseudo-impulse equals the core's (5.39) with `Υ(q̇⁺)` (a second
//! route: the core function called directly on the event's state), and differs clearly from
//! the one with `Υ(q̇⁻)`, so the test sees which velocity was used.
mod common;

use selfmanip::core::{pseudo_impulse, ContactMode, Data, FlatGround};
use selfmanip::hybrid::{simulate, Controller, EventKind, HybridOptions};

/// Joint dampers `τ = −b q̇`.
#[derive(Clone)]
struct Dampers {
    b: f64,
}

impl Controller for Dampers {
    fn torque(&self, _t: f64, _q: &[f64], qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        for (t, w) in tau.iter_mut().zip(qd) {
            *t = -self.b * w;
        }
    }
}

#[test]
fn pseudo_impulse_takes_the_actuators_at_the_post_impact_velocity() {
    let model = common::quadruped();
    let nj = model.n_joints();
    let ctrl = Dampers { b: 3.0 };
    // legs straight down (knees slightly bent), body 1 cm above touching, falling, and
    // the hips spinning so that the impact changes the joint velocities
    let mut q0 = vec![0.0; model.nq()];
    let mut qd0 = vec![0.0; model.nq()];
    for (j, qj) in q0.iter_mut().take(nj).enumerate() {
        *qj = if j % 2 == 0 { 0.2 } else { -0.4 };
    }
    let mut data = Data::new(&model);
    let lowest = (0..model.contacts.len())
        .map(|k| {
            data.prepare(&model, &FlatGround, ContactMode::FLIGHT, &q0, &qd0)
                .unwrap();
            selfmanip::core::contact::contact_geometry(&model, &data.kin, &FlatGround, k).gap_m
        })
        .fold(f64::INFINITY, f64::min);
    q0[nj + 1] += lowest - 0.01; // z down: lower the robot until 1 cm is left
    qd0[nj + 1] = 0.8;
    for (j, w) in qd0.iter_mut().take(nj).enumerate() {
        *w = if j % 2 == 0 { 4.0 } else { -3.0 };
    }
    let opts = HybridOptions {
        delta_t_s: 0.03,
        ..HybridOptions::default()
    };
    let exec = simulate(
        &model,
        &FlatGround,
        &ctrl,
        ContactMode::FLIGHT,
        &q0,
        &qd0,
        0.2,
        opts,
    )
    .unwrap();
    let e = exec
        .events
        .iter()
        .find(|e| e.kind == EventKind::Touchdown && !e.mode_after.is_flight())
        .unwrap_or_else(|| panic!("{:?}\n{:#?}", exec.termination, exec.events));
    assert!(!e.pseudo_impulse.is_empty());
    // the velocity just before the event, from the dense output of the flight before it
    let seg = exec
        .segments
        .iter()
        .rev()
        .find(|s| s.t1 <= e.t + 1e-12)
        .expect("a segment before the event");
    let mut y = vec![0.0; 2 * model.nq()];
    seg.eval(e.t, &mut y);
    let qd_minus = &y[model.nq()..];
    let jump: f64 = (0..nj)
        .map(|j| (e.qd_after[j] - qd_minus[j]).abs())
        .fold(0.0, f64::max);
    assert!(
        jump > 0.5,
        "the impact changes the joint velocities: {jump}"
    );

    let torque_at = |qd: &[f64]| -> Vec<f64> { qd[..nj].iter().map(|w| -ctrl.b * w).collect() };
    let p_delta = |tau: &[f64]| -> Vec<f64> {
        let mut data = Data::new(&model);
        pseudo_impulse(
            &model,
            &mut data,
            &FlatGround,
            e.mode_after,
            &e.q,
            qd_minus,
            tau,
            opts.delta_t_s,
        )
        .unwrap()
        .iter()
        .copied()
        .collect()
    };
    let with_plus = p_delta(&torque_at(&e.qd_after));
    let with_minus = p_delta(&torque_at(qd_minus));
    let diff = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    };
    assert!(
        diff(&e.pseudo_impulse, &with_plus) < 1e-9,
        "{:?} vs {with_plus:?}",
        e.pseudo_impulse
    );
    assert!(
        diff(&with_plus, &with_minus) > 1e-3,
        "the two velocities must give different pseudo-impulses here: {with_plus:?} {with_minus:?}"
    );
}
