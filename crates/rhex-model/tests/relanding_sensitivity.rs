//! Derivatives of default RHex leaps (massless legs) in which a leg meets the ground again
//! under the motion it started in the air at an event (its liftoff, the takeoff), against
//! central differences of whole leaps (the independent route), steps `h`, `10h`, `100h`
//! (`h = 1e-5` of each parameter's scale: t2 10 ms, G 28, m_b 7 kg).
//!
//! Two things make these leaps different from the others. The leg's motion starts from its
//! angle and rate at the event, so its touchdown time and its servo in stance depend on that
//! event's time and state: the controller's memory (`Controller::memory_partials`), carried
//! for a massless leg only in a run in which it lands again (`has_event_memory`). And in
//! stance that servo leaves its saturation (at `|Υ| = H`, the stall torque) within an
//! engine step: a kink of the flow — continuous, its Jacobian not — at a state that moves with
//! the parameters. A tangent step that straddles the kink is accurate to first order in the
//! step only (the kink's place in the step moves with the initial state); the sensitivities
//! split their steps there (`Controller::partials_piece`). With the memory carried and the
//! kink straddled, these derivatives were 1e-5 … 1e-4 off (`d apex_z / d t2` of (−,−)
//! t2 = −0.17: 7.06183 against 7.06189).
mod common;
use common::{apex_error, tight};
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LeapResult, X_RHEX_LEG};
use rhex_model::leap_sensitivity::leap_with_sensitivity;
use rhex_model::RhexParams;

/// The two default leaps of the 164-leap sweep (`t2 ∈ [−0.2, 0.2]` by 0.01 s) in which a
/// leg lands again under a motion started at an event.
const RELANDING: [(&str, f64); 2] = [("--", -0.17), ("++", -0.12)];

/// Whether a leg's toe touches down under a motion started at an event: after the takeoff
/// (the first flight once both motors started), or after its own liftoff.
fn lands_again(r: &LeapResult) -> bool {
    let start_both = r.motor_t2_s.max(0.0);
    let takeoff = r
        .events
        .iter()
        .position(|e| e.t_s >= start_both && e.mode_after.chars().all(|c| c == '0'));
    let leg_touchdown = |e: &selfmanip_sim::EventRecord| {
        e.kind == "touchdown" && e.contacts.iter().any(|c| c.ends_with("_leg"))
    };
    let after_takeoff = takeoff.is_some_and(|k| r.events[k..].iter().any(leg_touchdown));
    let after_liftoff = r.events.iter().enumerate().any(|(k, e)| {
        e.kind == "liftoff"
            && e.contacts.iter().any(|c| {
                c.ends_with("_leg")
                    && r.events[k..]
                        .iter()
                        .any(|d| leg_touchdown(d) && d.contacts.contains(c))
            })
    });
    after_takeoff || after_liftoff
}

/// The leap's servo leaves (or enters) its saturation inside a segment, away from the
/// segment's ends: the kink the tangent's steps are split at.
fn servo_kink_inside_a_segment(r: &LeapResult) -> bool {
    r.execution.segments.iter().any(|seg| {
        let nq = seg.y0.len() / 2;
        let piece = |t: f64| {
            let mut y = vec![0.0; 2 * nq];
            seg.eval(t, &mut y);
            seg.controller
                .partials_piece(t, &y[..nq], &y[nq..], seg.mode)
        };
        let (a, b) = (seg.t0 + 1e-6, seg.t1 - 1e-6);
        b > a && (0..=200).any(|k| piece(a + (b - a) * f64::from(k) / 200.0) != piece(a))
    })
}

/// The worst relative error of `d apex (z, φ, x) / d (t2, G, m_b)` over `leaps` of `p`
/// against central differences, each leap checked to land a leg again.
fn relanding_errors(p: &RhexParams, leaps: &[(&str, f64)]) -> [f64; 3] {
    let mut worst = [0.0_f64; 3];
    for &(s, t2) in leaps {
        let cfg = tight(s, t2);
        let r = leap_with_sensitivity(p, &cfg, &["t2", "gear_ratio", "m_b"]).unwrap();
        assert!(r.ok, "{s} {t2}: {:?}", r.reason);
        assert!(lands_again(&r.result), "{s} {t2}: no leg lands again");
        let col = |k: usize| [r.d_apex[2][k], r.d_apex[3][k], r.d_apex[1][k]];
        let leap = |c: &LeapConfig, pp: &RhexParams| simulate_leap(pp, c).unwrap().apex.unwrap();
        let e = [
            apex_error(col(0), &[1e-7, 1e-6, 1e-5], 1e-2, |d| {
                let mut c = cfg.clone();
                c.t2_s += d;
                leap(&c, p)
            }),
            apex_error(col(1), &[2.8e-4, 2.8e-3, 2.8e-2], 1e-4, |d| {
                let mut c = cfg.clone();
                c.actuator = X_RHEX_LEG.with_gear_ratio(&c.actuator, 28.0 + d);
                leap(&c, p)
            }),
            apex_error(col(2), &[7e-5, 7e-4, 7e-3], 1e-4, |d| {
                let mut pp = p.clone();
                pp.m_b += d;
                leap(&cfg, &pp)
            }),
        ];
        eprintln!(
            "{s} {t2}: d/dt2 {:.2e}, d/dG {:.2e}, d/dm_b {:.2e}",
            e[0], e[1], e[2]
        );
        for (w, v) in worst.iter_mut().zip(e) {
            *w = w.max(v);
        }
    }
    worst
}

/// `d apex (z, φ, x) / d (t2, G, m_b)` of both default leaps against central differences.
#[test]
fn a_massless_leg_landing_again_under_its_liftoff_motion_matches_central_differences() {
    let worst = relanding_errors(&leap_params(), &RELANDING);
    assert!(worst.iter().all(|&e| e < 1e-6), "{worst:?}");
}

/// The three leaps of the massive-leg sweep (Table 4.2's legs, the same 164 points) in
/// which a leg lands again under a motion started at an event: the memory of a leg with
/// inertia was carried before, but these leaps were flagged with the massless ones.
#[test]
fn a_massive_leg_landing_again_under_its_liftoff_motion_matches_central_differences() {
    let p = leap_params().with_table_4_2_legs();
    let worst = relanding_errors(&p, &[("-+", -0.11), ("++", -0.10), ("+-", 0.07)]);
    assert!(worst.iter().all(|&e| e < 1e-6), "{worst:?}");
}

/// The (−,−) t2 = −0.17 leap meets the kink the previous test depends on: its re-landed
/// front leg's servo leaves its saturation in stance, inside a segment.
#[test]
fn the_relanded_legs_servo_leaves_its_saturation_inside_a_segment() {
    let r = simulate_leap(&leap_params(), &tight("--", -0.17)).unwrap();
    assert!(lands_again(&r));
    assert!(servo_kink_inside_a_segment(&r));
}
