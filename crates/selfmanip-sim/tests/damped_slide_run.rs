//! A run through the damped slide of a massless two-link chain
//! (`selfmanip_hybrid::damped_slide`, docs/singular-transitions.md section 10), on the path a
//! user runs by default.
//!
//! The robot (`data/two_link_massless_legs.json`, drawn by the user-robot sweep): four legs,
//! `mid_hind` with both links massless under a servo, three others with massless shins,
//! pushing off on level ground. Before the damped slide, `mid_hind_foot`'s sticking force
//! pulled, its rigid slide was singular and its release fell straight back: thousands of
//! silent re-touches, and a run at the step budget.
//!
//! What is checked, each by a route of its own:
//! - the run reaches its final time and a damped slide carries at least one segment (the
//!   flow, evaluated at the segment's start, reports it);
//! - every reported event changes the mode (the re-touch cycle kept it);
//! - the energy balance `E1 − E0 = W + W_fr − L` to 1e-6 J, with the damped slide's friction
//!   and the chain's actuator work in it;
//! - a second run, on another thread, bit-identical.
use selfmanip_hybrid::flow::Flow;
use selfmanip_sim::{Run, RunStatus, Scenario, Simulation};
use std::path::Path;

fn simulate() -> Run {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/two_link_massless_legs.json");
    let s = Scenario::from_file(&path).unwrap();
    Simulation::new(&s).unwrap().run().unwrap()
}

#[test]
fn two_link_massless_chain_slides_damped_to_the_final_time() {
    let run = simulate();
    let exec = &run.execution;
    assert_eq!(
        run.outcome.status,
        RunStatus::FinalTime,
        "{:?}",
        exec.termination
    );

    let model = &*run.model;
    let nq = model.nq();
    let mut damped_segments = 0;
    for seg in &exec.segments {
        let mut flow = Flow::new(model, &run.terrain, seg.controller.clone());
        flow.set_lock(&seg.locked);
        flow.set_slide_directions(&seg.slide_directions);
        flow.eval(seg.t0, seg.mode, &seg.y0[..nq], &seg.y0[nq..])
            .unwrap();
        if !flow.last().0.damped.is_empty() {
            damped_segments += 1;
        }
    }
    assert!(damped_segments > 0, "no segment slides damped");

    for e in &exec.events {
        assert_ne!(e.mode_before, e.mode_after, "{:?} at {}", e.kind, e.t);
    }

    let report = run.energy_report().unwrap();
    assert!(report.residual_j().abs() < 1e-6, "{report:?}");

    let again = std::thread::spawn(simulate).join().unwrap();
    assert_eq!(again.execution.events.len(), exec.events.len());
    for (a, b) in again.execution.events.iter().zip(&exec.events) {
        assert_eq!(a.t.to_bits(), b.t.to_bits());
        assert_eq!(a.q, b.q);
        assert_eq!(a.qd_after, b.qd_after);
    }
}
