//! The sampler and the engine agree at a run's end (issue 31): a run that ends at its final
//! time right at an event ends in a segment of zero duration, in the mode and the state after
//! the reset. The sampler skipped that segment and took its last sample from the one before
//! (the flight before a touchdown here; in the issue, a slide that had just become
//! inconsistent, so every `trajectory(dt)` failed with a Painlevé error).
mod common;

use common::data;
use selfmanip_core::RobotDescription;
use selfmanip_hybrid::EventKind;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::Scenario;

fn hopper(t_final_s: f64) -> Scenario {
    let robot = RobotDescription::from_file(&data("hopper.toml")).unwrap();
    let mut s = Scenario::new(robot, vec![0.5, -1.0, 0.0, -0.451, 0.0]);
    s.behaviour = Behaviour::from_file(&data("hop.toml")).unwrap();
    s.options.t_final_s = t_final_s;
    s
}

#[test]
fn a_run_ending_at_a_touchdown_is_sampled_last_after_the_impact() {
    let first = selfmanip_sim::simulate(&hopper(0.6)).unwrap();
    let touchdown = first
        .execution
        .events
        .iter()
        .find(|e| e.kind == EventKind::Touchdown)
        .unwrap()
        .t;
    let run = selfmanip_sim::simulate(&hopper(touchdown)).unwrap();
    let exec = &run.execution;
    let last_event = exec.events.last().unwrap();
    assert_eq!(last_event.kind, EventKind::Touchdown);
    let last = exec.segments.last().unwrap();
    assert!(
        last.t0 == last.t1 && last.t1 == exec.t,
        "a mode of zero duration at the end"
    );
    let tr = run.trajectory(0.01).unwrap();
    let n = tr.t_s.len() - 1;
    assert_eq!(tr.t_s[n], exec.t);
    // the impact's own record (the velocity its reset computed), a second route to the state
    assert_eq!(tr.qd[n], last_event.qd_after);
    assert_eq!(tr.q[n], last_event.q);
    assert_eq!(tr.mode[n], run.labels.label(last_event.mode_after));
    assert_ne!(tr.mode[n], tr.mode[n - 1]);
    // the impact changed the velocity: the flight's end, sampled before, was not the run's end
    let jump = tr.qd[n]
        .iter()
        .zip(&tr.qd[n - 1])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(jump > 1.0, "{jump}");
}
