//! The slowest points of the issue-16 broad sweep: a (+,−) leap in which the robot sits on
//! its rear body end and the front leg's toe, sticking, reaches its friction cone's edge
//! every 2.2 ms. At the edge no mode continues the flow (a Painlevé-type conflict of the
//! massless leg, `docs/leap-physics.md`): the sticking force leaves the cone, sliding on
//! the edge of its side accelerates the toe against that edge, sliding on the other edge
//! pulls, and the toe is let go — and touches down again 10 µs later, the impact sticking
//! it. Before the chatter detection the cycle ran several hundred times until `t_final`
//! (`no_flight`, 51–61 ms of wall time); it now ends as a chatter (`zeno`).
//!
//! Checked by routes other than the detector: the cycle's slips are at the cone's edge
//! (the sticking force of the segment that ends there, solved again by the core's KKT:
//! `|λ_t| = μ |λ_n|`, the slip guard's root); each release lasts under 20 µs and ends with a
//! touchdown of the same toe; the configuration at the cycle's slips creeps by less than
//! the criterion's bound (recomputed from the events); the run makes a bounded number of
//! events (before: 580).
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LeapStatus, LegActuator};
use rhex_model::Rhex;
use selfmanip_core::{FlatGround, RowDirection};
use selfmanip_hybrid::flow::FlowWorkspace;
use selfmanip_hybrid::zeno::{CHATTER_CYCLES, CHATTER_Q_PER_CYCLE};
use selfmanip_hybrid::{EventKind, Termination};

#[test]
fn front_toe_at_its_cone_edge_chatters_and_ends_as_zeno() {
    let mut p = leap_params();
    p.m_b = 10.232834573074323;
    p.I_b = 0.07836595626904441;
    let LegActuator::GearedMotor {
        current_limit_a,
        motors_per_leg,
        ..
    } = LegActuator::default()
    else {
        unreachable!("the default actuator is geared")
    };
    let cfg = LeapConfig {
        strategy: "+-".parse().unwrap(),
        t2_s: -0.2303,
        actuator: LegActuator::GearedMotor {
            gear_ratio: 23.70,
            current_limit_a,
            motors_per_leg,
        },
        ..LeapConfig::default()
    };
    let r = simulate_leap(&p, &cfg).unwrap();
    assert_eq!(r.status, LeapStatus::Zeno, "{:?}", r.execution.termination);
    let Termination::Chatter { period, .. } = r.execution.termination else {
        panic!("{:?}", r.execution.termination)
    };
    assert_eq!(period, 3);
    let evs = &r.execution.events;
    assert!(evs.len() < 150, "{} events", evs.len());

    let mut pp = p.clone();
    pp.pairs = cfg.strategy.chapter3_pairs().to_vec();
    let rhex = Rhex::new(pp).unwrap();
    let model = &rhex.model;
    let nq = model.nq();
    let front = rhex.site(1);
    let mu = match model.contacts[front].friction {
        selfmanip_core::model::Friction::Sticking { mu } => mu,
        ref f => panic!("{f:?}"),
    };
    let cycle = &evs[evs.len() - 3 * CHATTER_CYCLES..];
    let mut ws = FlowWorkspace::new(model);
    let mut y = vec![0.0; 2 * nq];
    let mut slip_q: Vec<&[f64]> = Vec::new();
    for (i, e) in cycle.iter().enumerate() {
        assert_eq!(e.triggered, vec![front], "{:?} at {}", e.kind, e.t);
        match e.kind {
            EventKind::Slip => {
                assert_eq!(rhex.label(e.mode_before), "0110");
                slip_q.push(&e.q);
                // the sticking force at the end of the segment that meets the slip
                let seg = r
                    .execution
                    .segments
                    .iter()
                    .find(|s| s.t1 == e.t && s.mode == e.mode_before && s.t1 > s.t0)
                    .expect("the segment ending at the slip");
                seg.eval(seg.t1, &mut y);
                let (q, qd) = y.split_at(nq);
                ws.data
                    .prepare(model, &FlatGround, seg.mode, q, qd)
                    .unwrap();
                ws.solve_prepared(model, &*seg.controller, e.t, seg.mode, q, qd)
                    .unwrap();
                let row = |dir| {
                    seg.mode
                        .rows()
                        .position(|r| r.contact == front && r.direction == dir)
                        .unwrap()
                };
                let (lt, ln) = (
                    ws.data.lambda[row(RowDirection::Tangential)],
                    ws.data.lambda[row(RowDirection::Normal)],
                );
                assert!(ln < 0.0, "pushing: {ln}");
                let ratio = lt.abs() / (mu * -ln);
                assert!((ratio - 1.0).abs() < 1e-6, "|λ_t|/(μ|λ_n|) = {ratio}");
            }
            EventKind::Stick => {
                // the toe let go …
                assert_eq!(rhex.label(e.mode_after), "0010");
                // … and back on the ground within 20 µs
                let next = &cycle.get(i + 1).unwrap_or(&evs[evs.len() - 1]);
                if i + 1 < cycle.len() {
                    assert_eq!(next.kind, EventKind::Touchdown);
                    assert!(next.t - e.t < 2e-5, "{} s in the air", next.t - e.t);
                    assert_eq!(rhex.label(next.mode_after), "0110");
                }
            }
            EventKind::Touchdown => {}
            k => panic!("{k:?} in the cycle"),
        }
    }
    assert_eq!(slip_q.len(), CHATTER_CYCLES);
    let moved = slip_q[0]
        .iter()
        .zip(slip_q[CHATTER_CYCLES - 1])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        moved <= CHATTER_Q_PER_CYCLE * (CHATTER_CYCLES - 1) as f64,
        "moved {moved}"
    );
}
