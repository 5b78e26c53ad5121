//! Re-touch cycles in the generalized Zeno detection (`selfmanip_hybrid::zeno`), on event
//! records built by hand: a touchdown whose impact kept its contact and whose force let it
//! go at once leaves the mode as it was but makes two transitions
//! (`Event::makes_transitions`), so one such event repeated `CHATTER_CYCLES` times with the
//! robot in place is a chatter of period 1 — and the same cycle of events that make no
//! transition (an impact that kept nothing new, an apex) is not. The dwell of a re-touch
//! cycle's truncation ends at a touchdown of another contact, not of its own.
use selfmanip_core::{ContactKind, ContactMode};
use selfmanip_hybrid::guard::Guard;
use selfmanip_hybrid::zeno::{ChatterDetector, ZenoWindow, CHATTER_CYCLES};
use selfmanip_hybrid::{Event, EventKind, Termination};

/// Contact 1 re-touching while contact 0 sticks: the impact goes into `{0, 1}`
/// (`impulse_mode`), the mode after is `{0}` again.
fn retouch(t: f64, kept: bool) -> Event {
    let standing = ContactMode::FLIGHT.with(0, ContactKind::Stick);
    let impact = standing.with(1, ContactKind::Stick);
    Event {
        t,
        kind: EventKind::Touchdown,
        mode_before: standing,
        mode_after: standing,
        triggered: vec![1],
        impulse: vec![0.0, 0.2, 0.0, 0.3],
        impulse_mode: if kept { impact } else { standing },
        pseudo_impulse: vec![],
        force: vec![0.0, -90.0],
        kinetic_before: 1.0,
        kinetic_after: 0.999,
        q: vec![0.5, -0.7, 1e-6 * t],
        qd_after: vec![0.0; 3],
    }
}

#[test]
fn a_retouch_makes_two_transitions_an_apex_none() {
    assert!(retouch(0.0, true).makes_transitions());
    assert!(!retouch(0.0, false).makes_transitions());
    let m = ContactMode::FLIGHT.with(0, ContactKind::Stick);
    let apex = Event::without_jump(0.0, EventKind::Apex, m, vec![], (&[0.0], &[0.0]));
    assert!(!apex.makes_transitions());
    // a touchdown that changes the mode makes one whatever its impact's mode
    let mut landing = retouch(0.0, false);
    landing.mode_before = ContactMode::FLIGHT;
    assert!(landing.makes_transitions());
}

#[test]
fn a_retouch_repeated_in_place_is_a_chatter_of_period_one() {
    // every 0.4 ms, the robot in place
    let events = |n: usize, kept: bool| -> Vec<Event> {
        (0..n).map(|i| retouch(4e-4 * i as f64, kept)).collect()
    };
    match ChatterDetector.check(&events(CHATTER_CYCLES, true)) {
        Some(Termination::Chatter {
            period, contacts, ..
        }) => {
            assert_eq!(period, 1);
            assert_eq!(contacts, vec![1]);
        }
        other => panic!("{other:?}"),
    }
    // one short: not yet
    assert_eq!(
        ChatterDetector.check(&events(CHATTER_CYCLES - 1, true)),
        None
    );
    // impacts that kept nothing new make no transition: no chatter however many
    assert_eq!(
        ChatterDetector.check(&events(4 * CHATTER_CYCLES, false)),
        None
    );
}

#[test]
fn a_retouch_dwell_ends_at_another_contacts_touchdown() {
    let held = [1];
    let mut z = ZenoWindow::new(0.01, 50);
    z.truncated(0.1, 0.01);
    z.hold_cycle_only();
    // its own contact touching again, or another guard: the dwell goes on
    assert!(!z.end_hold_at(&[Guard::Touchdown(1)], &held));
    assert!(!z.end_hold_at(&[Guard::Apex], &held));
    assert_eq!(z.holding_until(), Some(0.1 + 0.01));
    // another contact's touchdown ends it
    assert!(z.end_hold_at(&[Guard::Touchdown(0), Guard::Touchdown(1)], &held));
    assert_eq!(z.holding_until(), None);
    // a dwell of a Zeno window (not bounded to its cycle) holds through it
    let mut z = ZenoWindow::new(0.01, 50);
    z.truncated(0.1, 0.01);
    assert!(!z.end_hold_at(&[Guard::Touchdown(0)], &held));
    assert_eq!(z.holding_until(), Some(0.1 + 0.01));
}
