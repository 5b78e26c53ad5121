//! The re-touch chatters truncated without `CHATTER_CYCLES` repetitions
//! (`selfmanip_hybrid::zeno`), on event records built by hand:
//! - a re-touch after a flight shorter than the run's time resolution `rest_time_s`
//!   (`retouch_unresolved`): the flight is the time since the contact's own event took it
//!   out of the mode it stuck in, compared strictly with the resolution;
//! - a truncated chatter that resumes after its dwell (`ZenoWindow::resumed`): one
//!   repetition of its cycle, the robot where it was, before a quiet window.
use selfmanip_core::{ContactKind, ContactMode};
use selfmanip_hybrid::guard::Guard;
use selfmanip_hybrid::zeno::{retouch_unresolved, ZenoWindow, CHATTER_Q_PER_CYCLE};
use selfmanip_hybrid::{Event, EventKind, Termination};

fn standing() -> ContactMode {
    ContactMode::FLIGHT.with(0, ContactKind::Stick)
}

/// Contact 1 re-touching while contact 0 sticks: the impact into `{0, 1}`, the mode after
/// `{0}` again, at configuration offset `dq`.
fn retouch(t: f64, dq: f64) -> Event {
    Event {
        t,
        kind: EventKind::Touchdown,
        mode_before: standing(),
        mode_after: standing(),
        triggered: vec![1],
        impulse: vec![0.0, 0.2, 0.0, 0.3],
        impulse_mode: standing().with(1, ContactKind::Stick),
        pseudo_impulse: vec![],
        force: vec![0.0, -90.0],
        kinetic_before: 1.0,
        kinetic_after: 0.999,
        q: vec![0.5 + dq, -0.7, 0.0],
        qd_after: vec![0.0; 3],
    }
}

/// Contact 1 released by force at `t` (`{0, 1}` → `{0}`).
fn release(t: f64) -> Event {
    let both = standing().with(1, ContactKind::Stick);
    Event::without_jump(
        t,
        EventKind::Liftoff,
        both,
        vec![1],
        (&[0.5, -0.7, 0.0], &[0.0; 3]),
    )
    .with_mode_after(standing())
}

trait ModeAfter {
    fn with_mode_after(self, m: ContactMode) -> Self;
}
impl ModeAfter for Event {
    fn with_mode_after(mut self, m: ContactMode) -> Self {
        self.mode_after = m;
        self
    }
}

#[test]
fn a_retouch_after_an_unresolved_flight_is_a_chatter() {
    let tau = 2e-4;
    // released at 0.1, back 0.1 ms later: shorter than the resolution
    let events = vec![release(0.1), retouch(0.1 + 1e-4, 0.0)];
    match retouch_unresolved(&events, tau) {
        Some(Termination::Chatter {
            period,
            cycles,
            contacts,
            duration_s,
            ..
        }) => {
            assert_eq!((period, cycles, contacts), (1, 1, vec![1]));
            assert!((duration_s - 1e-4).abs() < 1e-15, "{duration_s}");
        }
        other => panic!("{other:?}"),
    }
    // back after 0.3 ms: a flight the run resolves
    let events = vec![release(0.1), retouch(0.1 + 3e-4, 0.0)];
    assert_eq!(retouch_unresolved(&events, tau), None);
    // the flight counts from the latest event that involved the contact: after a previous
    // re-touch (whose mode before does not hold it) it is no flight from rest
    let events = vec![
        release(0.1),
        retouch(0.1 + 3e-4, 0.0),
        retouch(0.1 + 4e-4, 0.0),
    ];
    assert_eq!(retouch_unresolved(&events, tau), None);
    // a contact that slid before it left is not at rest
    let mut slid = release(0.1);
    slid.mode_before = standing().with(1, ContactKind::Slide);
    assert_eq!(
        retouch_unresolved(&[slid, retouch(0.1 + 1e-4, 0.0)], tau),
        None
    );
    // a contact another contact's event let go (a see-saw) is left to the criterion
    let mut other = release(0.1);
    other.triggered = vec![2];
    assert_eq!(
        retouch_unresolved(&[other, retouch(0.1 + 1e-4, 0.0)], tau),
        None
    );
    // a touchdown that keeps its contact is no re-touch; nor one with nothing released
    // before it (its contact's flight unknown)
    let mut kept = retouch(0.1 + 1e-4, 0.0);
    kept.mode_after = kept.impulse_mode;
    assert_eq!(retouch_unresolved(&[release(0.1), kept], tau), None);
    assert_eq!(retouch_unresolved(&[retouch(0.1, 0.0)], tau), None);
}

/// A window whose last truncation (at 0.1, dwell 0.01 s) was of the re-touch cycle
/// `retouch(0.1, 0)`, still holding; the truncation's event is index 1 of the events.
fn holding_window() -> ZenoWindow {
    let mut z = ZenoWindow::new(0.01, 50);
    z.truncated(0.1, 0.01);
    z.truncated_chatter(&[retouch(0.1, 0.0)], (0.1, &[1]), 2);
    z
}

/// [`holding_window`] with its hold (of contacts 0 and 1) ended by contact 2's touchdown.
fn truncated_window() -> ZenoWindow {
    let mut z = holding_window();
    // a re-touch cycle: the dwell is bounded to it
    assert!(z.end_hold_at(&[Guard::Touchdown(2)], &[0, 1]));
    z
}

#[test]
fn a_truncated_chatter_resuming_is_truncated_at_its_first_repetition() {
    let z = truncated_window();
    let before = vec![retouch(0.1, 0.0), retouch(0.1, 0.0)];
    let with = |e: Event| -> Vec<Event> { before.iter().cloned().chain([e]).collect() };
    match z.resumed(&with(retouch(0.105, 0.5 * CHATTER_Q_PER_CYCLE))) {
        Some(Termination::Chatter {
            period,
            cycles,
            contacts,
            ..
        }) => assert_eq!((period, cycles, contacts), (1, 1, vec![1])),
        other => panic!("{other:?}"),
    }
    // another contact's touchdown between (the one that ended the hold, contact 2 landing
    // in the mode) does not break the cycle: the latest event repeats it, counted for
    // contact 1 alone
    let mut landing = retouch(0.104, 0.0);
    landing.triggered = vec![2];
    landing.mode_after = standing().with(2, ContactKind::Stick);
    let through: Vec<Event> = before
        .iter()
        .cloned()
        .chain([landing, retouch(0.105, 0.0)])
        .collect();
    match z.resumed(&through) {
        Some(Termination::Chatter {
            cycles, contacts, ..
        }) => assert_eq!((cycles, contacts), (1, vec![1])),
        other => panic!("{other:?}"),
    }
    // the robot moved more than one cycle's allowance: another motion
    assert_eq!(
        z.resumed(&with(retouch(0.105, 2.0 * CHATTER_Q_PER_CYCLE))),
        None
    );
    // another event: not the cycle
    assert_eq!(z.resumed(&with(release(0.105))), None);
    // no event after the truncation's yet
    assert_eq!(z.resumed(&before), None);
    // after a quiet window (a whole window without a transition since the dwell's end) the
    // cycle stopped: not resumed
    let mut quiet = truncated_window();
    assert_eq!(quiet.record(0.1 + 0.01 + 0.011, &[1]), None);
    assert_eq!(quiet.resumed(&with(retouch(0.121, 0.0))), None);
    // while the dwell holds, nothing resumes
    let z = holding_window();
    assert_eq!(z.resumed(&with(retouch(0.105, 0.0))), None);
}
