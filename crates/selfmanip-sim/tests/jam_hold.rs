//! The jam hold of a wedged massless shin (`selfmanip_hybrid::jam_hold`,
//! docs/singular-transitions.md section 10).
//!
//! The robot (`data/wedged_shin.json`): a 3.5 kg body on two legs with limp servos, the front
//! leg a massive thigh (0.13 kg) and a massless shin, the hind leg massive, μ = 0.45, dropped
//! onto stairs. Its front foot slides into its wedge (`|b_n| < μ |b_t|`), where every
//! touchdown sticks while no force mode keeps it and its release falls straight back: before
//! the hold, 10,000 events (the budget) of `touchdown → release → touchdown` within
//! microseconds. Held, the foot sticks until its guard fires.
//!
//! What is checked, each against a route of its own:
//! - the held stick's force satisfies the massless knee's statics `τ_knee = (Aᵀλ)_knee`
//!   (the knee carries no inertia: its row of the dynamics is the torque balance alone) and
//!   equals the flow's force in the held mode at the state after the touchdown;
//! - the hold ends where its guard `−max(min(U, μU − |λ_t|), ä)` crosses zero, found by a
//!   plain bisection on the segment's dense output to 1e-12 s;
//! - the count of events: every event changes the mode, and each touchdown of the front
//!   foot is preceded by a reported event that let it go (a touchdown needs the foot in the
//!   air), so no touchdown keeps the mode — the cycle that ran into the budget;
//! - the energy balance `E1 − E0 = W + W_fr − L` to 1e-6 J, and a second run bit-identical.
#[path = "../../selfmanip-core/tests/common/bisect.rs"]
mod bisect;
mod common;

use bisect::bisect;
use selfmanip_core::contact::{ContactKind, RowDirection};
use selfmanip_core::{ContactMode, Data};
use selfmanip_hybrid::flow::Flow;
use selfmanip_hybrid::jam_hold::gap_acceleration;
use selfmanip_hybrid::{EventKind, Segment};
use selfmanip_sim::{Run, RunStatus, Scenario, Simulation};
use std::path::Path;

const FRONT: usize = 0;
const KNEE: usize = 1;
const MU: f64 = 0.45;

fn run() -> Run {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/wedged_shin.json");
    let s = Scenario::from_file(&path).unwrap();
    Simulation::new(&s).unwrap().run().unwrap()
}

/// The tangential and normal rows of `k` in `mode`.
fn rows_of(mode: ContactMode, k: usize) -> (usize, usize) {
    let rows: Vec<_> = mode.rows().collect();
    let n = rows
        .iter()
        .position(|r| r.contact == k && r.direction == RowDirection::Normal)
        .unwrap();
    let t = rows
        .iter()
        .position(|r| r.contact == k && r.direction == RowDirection::Tangential)
        .unwrap();
    (t, n)
}

/// The hold's guard at `(t, y)` in the held `mode` (positive while held): the cone margin of
/// the front foot's force and its gap's second derivative released.
fn hold_guard(flow: &mut Flow, t: f64, mode: ContactMode, y: &[f64]) -> f64 {
    let nq = y.len() / 2;
    let (tr, nr) = rows_of(mode, FRONT);
    let lambda = flow
        .eval(t, mode, &y[..nq], &y[nq..])
        .unwrap()
        .lambda
        .clone();
    let push = -lambda[nr];
    let cone = (MU * push - lambda[tr].abs()).min(push);
    let acc = gap_acceleration(flow, mode.without(FRONT), FRONT, t, y).unwrap();
    -cone.max(acc)
}

#[test]
fn wedged_shin_is_held_by_force_and_let_go_at_its_guard() {
    let run = run();
    let exec = &run.execution;
    assert_eq!(
        run.outcome.status,
        RunStatus::FinalTime,
        "{:?}",
        exec.termination
    );
    let model = &*run.model;
    assert_eq!(
        selfmanip_hybrid::jam_hold::held_joint(model, FRONT),
        Some(KNEE)
    );

    // every touchdown changes the mode, and every reported event does
    assert!(!exec.events.is_empty());
    for e in &exec.events {
        assert_ne!(e.mode_before, e.mode_after, "{:?} at {}", e.kind, e.t);
    }
    // the holds: a touchdown of the front foot into a stick its cone does not hold
    let holds: Vec<_> = exec
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Touchdown && e.triggered == [FRONT])
        .filter(|e| e.mode_after.kind(FRONT) == Some(ContactKind::Stick))
        .filter(|e| {
            let (tr, nr) = rows_of(e.mode_after, FRONT);
            let push = -e.force[nr];
            e.force[tr].abs() > MU * push * (1.0 - 1e-9)
        })
        .collect();
    assert!(!holds.is_empty(), "the wedged touchdown is held");

    for e in &holds {
        let seg = exec.segments.iter().find(|s| s.t0 == e.t).unwrap();
        let ctrl = seg.controller.clone();
        let nq = model.nq();
        // statics of the massless knee: τ_knee = (Aᵀλ)_knee (the core's M̄q̈ + … = Υ − Aᵀλ)
        let mut tau = vec![0.0; model.n_joints()];
        ctrl.torque(e.t, &e.q, &e.qd_after, e.mode_after, &mut tau);
        let mut data = Data::new(model);
        data.prepare(model, &run.terrain, e.mode_after, &e.q, &e.qd_after)
            .unwrap();
        let a = &data.constraints.a;
        let moment: f64 = (0..a.nrows()).map(|r| a[(r, KNEE)] * e.force[r]).sum();
        let scale = tau[KNEE].abs().max(1e-3);
        assert!(
            (tau[KNEE] - moment).abs() < 1e-9 * scale.max(moment.abs()),
            "knee statics: τ {} (Aᵀλ) {moment}",
            tau[KNEE]
        );
        // the flow's force in the held mode at the same state
        let mut flow = Flow::new(model, &run.terrain, ctrl);
        let lambda = flow
            .eval(e.t, e.mode_after, &e.q, &e.qd_after)
            .unwrap()
            .lambda
            .clone();
        for (x, y) in lambda.iter().zip(&e.force) {
            assert!(
                (x - y).abs() < 1e-9 * (1.0 + y.abs()),
                "{lambda:?} vs {:?}",
                e.force
            );
        }
        assert_eq!(nq, e.q.len());
    }

    // where a hold ends silently (its cone holds the force again, or its release separates):
    // a segment that starts at no reported event, after one that held the front foot
    let ends: Vec<(&Segment, &Segment)> = exec
        .segments
        .windows(2)
        .map(|w| (&w[0], &w[1]))
        .filter(|(prev, next)| {
            next.t0 > holds[0].t
                && !exec.events.iter().any(|e| e.t == next.t0)
                && prev.mode.kind(FRONT) == Some(ContactKind::Stick)
        })
        .collect();
    assert!(!ends.is_empty(), "a hold ends at its guard");
    for (prev, _) in ends {
        let mut flow = Flow::new(model, &run.terrain, prev.controller.clone());
        let mut y = vec![0.0; 2 * model.nq()];
        let mut g = |t: f64| {
            prev.eval(t, &mut y);
            hold_guard(&mut flow, t, prev.mode, &y)
        };
        // bisection from the last step's start (held) to the segment's end (let go)
        let last = prev.dense.step(prev.dense.len() - 1);
        let (lo, hi) = (last.t0, prev.t1);
        assert!(g(lo) > 0.0, "held at the step's start: {}", g(lo));
        assert!(g(hi) <= 1e-9, "let go at the end: {}", g(hi));
        let (_, hi) = bisect(lo, hi, 1e-12, &mut g);
        assert!(
            (hi - prev.t1).abs() < 1e-9,
            "the guard's time {} vs bisection {hi}",
            prev.t1
        );
    }

    let report = run.energy_report().unwrap();
    assert!(report.residual_j().abs() < 1e-6, "{report:?}");
}

#[test]
fn wedged_shin_run_is_deterministic() {
    common::assert_deterministic(run, |a, b| assert_eq!(a.q, b.q));
}

/// A run through a jam hold has no derivative formed past the hold's entry: the events from
/// it on are refused by name (the entry is by force, the end by the hold's own guard, neither
/// differentiated), never given a liftoff's or a touchdown's saltation; the events before it
/// are not refused for it.
#[test]
fn derivatives_refuse_the_jam_hold_by_name() {
    use selfmanip_hybrid::sensitivity::SaltationStatus;
    let run = run();
    let model = &*run.model;
    let exec = &run.execution;
    let entry = exec
        .events
        .iter()
        .position(|e| selfmanip_hybrid::jam_hold::entered(model, e).is_some())
        .expect("the wedged run enters a jam hold");
    let s = selfmanip_sim::periodic::run_sensitivity(&run).unwrap();
    assert!(s.state_jacobian.is_none());
    let refused = |es: &selfmanip_hybrid::sensitivity::EventSensitivity| matches!(&es.status, SaltationStatus::Unsupported { reason } if reason.contains("jam hold"));
    for (i, es) in s.events.iter().enumerate() {
        assert_eq!(
            refused(es),
            i >= entry,
            "event {i} at {}: {:?}",
            es.t,
            es.status
        );
    }
}
