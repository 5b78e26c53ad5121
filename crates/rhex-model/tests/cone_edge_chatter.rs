//! The slowest points of the issue-16 broad sweep: a (+,−) leap in which the robot sits on
//! its rear body end and the front leg's toe, sticking, reached its friction cone's edge
//! every 2.2 ms. At the edge no mode continued the flow (a Painlevé-type conflict of the
//! massless leg, `docs/decisions/2026-11-24-chatter-ends-as-zeno.md`): the sticking force left the cone, and the toe was
//! let go — and touched down again 10 µs later, the impact sticking it. Before the chatter
//! detection the cycle ran several hundred times until `t_final` (`no_flight`, 51–61 ms of
//! wall time); then it ended as a chatter (`zeno`, period 3, under 150 events).
//!
//! The 10 µs return was the leg law's, not the cone's: the front leg was retracting, and each
//! release planned its park anew, at rest in acceleration, which carried the toe straight
//! back into the ground. A retracting leg now keeps its one retraction
//! (`tests/retraction_law.rs`; `docs/decisions/2026-11-24-one-retraction-per-leg.md`): released,
//! it returns to that motion, and the cycle is gone. This test keeps the point: the front
//! toe touches down while the robot sits on its rear body end, slides, and lets go once;
//! after that its gap from the kinematics (not the guard) stays positive to the end of the
//! run, which ends with the robot back on both body ends (`no_flight`, as the (+,−)
//! rear-first leaps around it) in a bounded number of events.
mod common;

use common::state_at;
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, X_RHEX_LEG};
use rhex_model::Rhex;
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_hybrid::{EventKind, Termination};
use selfmanip_sim::RunStatus;

#[test]
fn front_toe_of_the_old_cone_edge_chatter_lets_go_once() {
    let mut p = leap_params();
    p.m_b = 10.232834573074323;
    p.I_b = 0.07836595626904441;
    let cfg = LeapConfig {
        strategy: "+-".parse().unwrap(),
        t2_s: -0.2303,
        actuator: X_RHEX_LEG.at_gear_ratio(23.70),
        ..LeapConfig::default()
    };
    let r = simulate_leap(&p, &cfg).unwrap();
    assert!(
        !matches!(r.execution.termination, Termination::Chatter { .. }),
        "{:?}",
        r.execution.termination
    );
    assert_eq!(r.status, RunStatus::FinalTime, "{}", r.word_string());
    let evs = &r.execution.events;
    assert!(evs.len() < 30, "{} events", evs.len());

    let mut pp = p.clone();
    pp.pairs = cfg.strategy.chapter3_pairs().to_vec();
    let rhex = Rhex::new(pp).unwrap();
    let model = &rhex.model;
    let nq = model.nq();
    let front = rhex.site(1);
    // the front toe's touchdown while the robot sits on its rear body end, and its release
    let on_rear_end = |e: &selfmanip_hybrid::Event| rhex.label(e.mode_before) == "0010";
    let touch = evs
        .iter()
        .position(|e| {
            e.kind == EventKind::Touchdown && e.triggered == vec![front] && on_rear_end(e)
        })
        .expect("the front toe meets the ground with the robot on its rear body end");
    let release = evs[touch..]
        .iter()
        .position(|e| e.mode_before.contains(front) && !e.mode_after.contains(front))
        .map(|k| touch + k)
        .expect("the front toe lets go");
    // once: never on the ground again
    assert!(
        evs[release + 1..]
            .iter()
            .all(|e| !e.mode_after.contains(front)),
        "the front toe back on the ground: {}",
        r.word_string()
    );
    let (t0, t1) = (evs[release].t, r.execution.t);
    let mut kin = Kinematics::default();
    let mut y = vec![0.0; 2 * nq];
    for s in 1..=200 {
        let t = t0 + (t1 - t0) * f64::from(s) / 200.0;
        state_at(&r.execution, t, &mut y);
        kin.compute(model, &y[..nq], &y[nq..]);
        let gap = contact_geometry(model, &kin, &cfg.terrain, front).gap_m;
        assert!(
            gap > 0.0,
            "front toe at {gap} m, {} s after it let go",
            t - t0
        );
    }
}
