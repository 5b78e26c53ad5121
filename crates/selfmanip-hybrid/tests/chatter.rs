//! The generalized Zeno detection (`selfmanip_hybrid::zeno::ChatterDetector`) on event
//! records built by hand: the criterion (a cycle of the same events repeated
//! `CHATTER_CYCLES` times with the configuration staying within `CHATTER_Q_PER_CYCLE` per
//! cycle) against its edges — one repetition short, a cycle that carries the robot along
//! (a gait), a cycle broken by one different event, a cycle of unchanged modes.
use selfmanip_core::{ContactKind, ContactMode};
use selfmanip_hybrid::zeno::{
    ChatterDetector, CHATTER_CYCLES, CHATTER_MAX_PERIOD, CHATTER_MIN_DURATION_RATIO,
    CHATTER_Q_PER_CYCLE,
};
use selfmanip_hybrid::{Event, EventKind, Termination};

fn event(t: f64, kind: EventKind, before: ContactMode, after: ContactMode, q0: f64) -> Event {
    Event {
        t,
        kind,
        mode_before: before,
        mode_after: after,
        triggered: vec![1],
        impulse: vec![],
        impulse_mode: ContactMode::FLIGHT,
        pseudo_impulse: vec![],
        force: vec![],
        kinetic_before: 0.0,
        kinetic_after: 0.0,
        q: vec![q0, 0.1],
        qd_after: vec![0.0, 0.0],
    }
}

/// The (+,−) cycle of the broad sweep: stick → slip → release → touchdown, `cycles` times,
/// the leg angle creeping by `step` per cycle, one cycle every 2.2 ms.
fn cycle_events(cycles: usize, step: f64) -> Vec<Event> {
    cycle_events_shrinking(cycles, step, 1.0)
}

/// [`cycle_events`] with each cycle `ratio` times as long as the one before (the first
/// 2.2 ms).
fn cycle_events_shrinking(cycles: usize, step: f64, ratio: f64) -> Vec<Event> {
    let body = ContactMode::FLIGHT.with(3, ContactKind::Slide);
    let stick = body.with(1, ContactKind::Stick);
    let slide = body.with(1, ContactKind::Slide);
    let mut ev = Vec::new();
    let (mut t, mut period) = (0.0, 2.2e-3);
    for c in 0..cycles {
        let q0 = c as f64 * step;
        ev.push(event(t, EventKind::Slip, stick, slide, q0));
        ev.push(event(t + 1e-7, EventKind::Stick, slide, body, q0));
        ev.push(event(
            t + 1e-5 * period / 2.2e-3,
            EventKind::Touchdown,
            body,
            stick,
            q0,
        ));
        t += period;
        period *= ratio;
    }
    ev
}

#[test]
fn a_cycle_repeated_with_the_robot_in_place_is_a_chatter() {
    let d = ChatterDetector;
    let creep = 0.15e-2; // the sweep's front leg: 1.5 mrad per cycle
    let ev = cycle_events(CHATTER_CYCLES, creep);
    match d.check(&ev) {
        Some(Termination::Chatter {
            period,
            cycles,
            t,
            duration_s,
            contacts,
        }) => {
            assert_eq!(period, 3);
            // every event of the cycle was triggered by contact 1
            assert_eq!(contacts, vec![1]);
            assert_eq!(cycles, CHATTER_CYCLES);
            assert_eq!(t, ev.last().unwrap().t);
            // the 3·CHATTER_CYCLES events from the first slip to the last touchdown
            let expected = (CHATTER_CYCLES - 1) as f64 * 2.2e-3 + 1e-5;
            assert!((duration_s - expected).abs() < 1e-12, "{duration_s}");
        }
        other => panic!("{other:?}"),
    }
    // one repetition short: not yet
    assert_eq!(d.check(&cycle_events(CHATTER_CYCLES - 1, creep)), None);
    // … nor in the events before the last one (the tail ends mid-cycle, but is still
    // periodic: a cycle read from its second event is the same cycle)
    let ev = cycle_events(CHATTER_CYCLES + 1, creep);
    assert!(d.check(&ev[..ev.len() - 1]).is_some());
}

#[test]
fn a_cycle_that_moves_the_robot_is_no_chatter() {
    let d = ChatterDetector;
    // just above the bound per cycle, on average: a gait
    let ev = cycle_events(CHATTER_CYCLES, 1.01 * CHATTER_Q_PER_CYCLE);
    assert_eq!(d.check(&ev), None);
    // just below it: a chatter
    let ev = cycle_events(CHATTER_CYCLES, 0.99 * CHATTER_Q_PER_CYCLE);
    assert!(d.check(&ev).is_some());
    // a leg turning a revolution per cycle
    let ev = cycle_events(2 * CHATTER_CYCLES, std::f64::consts::TAU);
    assert_eq!(d.check(&ev), None);
}

/// Cycles that shrink accumulate (a Zeno execution proper, the window's): the last of 30
/// cycles shrinking by `r` each lasts `r²⁹` of the first.
#[test]
fn shrinking_cycles_are_zeno_not_chatter() {
    let d = ChatterDetector;
    let n = (CHATTER_CYCLES - 2) as f64;
    // the last cycle measured is cycle CHATTER_CYCLES − 2 (the span ends at the last one's
    // start): ratio r^n against the bound
    let r_at = |x: f64| x.powf(1.0 / n);
    let ev = cycle_events_shrinking(CHATTER_CYCLES, 0.0, r_at(0.9 * CHATTER_MIN_DURATION_RATIO));
    assert_eq!(d.check(&ev), None);
    let ev = cycle_events_shrinking(CHATTER_CYCLES, 0.0, r_at(1.1 * CHATTER_MIN_DURATION_RATIO));
    assert!(d.check(&ev).is_some());
}

#[test]
fn a_broken_cycle_or_unchanged_modes_are_no_chatter() {
    let d = ChatterDetector;
    // one event of another kind in the middle of the cycles
    let mut ev = cycle_events(CHATTER_CYCLES, 0.0);
    let mid = ev.len() / 2;
    ev[mid].kind = EventKind::Liftoff;
    assert_eq!(d.check(&ev), None);
    // … or on another contact
    let mut ev = cycle_events(CHATTER_CYCLES, 0.0);
    ev[mid].triggered = vec![2];
    assert_eq!(d.check(&ev), None);
    // a cycle whose events change no mode (apexes recorded on the way)
    let m = ContactMode::FLIGHT;
    let ev: Vec<Event> = (0..CHATTER_MAX_PERIOD * CHATTER_CYCLES)
        .map(|i| event(i as f64, EventKind::Apex, m, m, 0.0))
        .collect();
    assert_eq!(d.check(&ev), None);
}
