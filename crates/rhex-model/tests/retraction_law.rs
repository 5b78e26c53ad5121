//! One retraction per leg (issue 16, the broad sweep's re-contact cycles;
//! `docs/decisions/2026-11-24-one-retraction-per-leg.md`).
//!
//! A leg that retracts (after its own liftoff, or once the robot has taken off) parks along
//! one motion, planned when it first retracts in the air (thesis 5.1.1: a free massless
//! limb's motion is prescribed). When the ground meets it on the way, its servo presses it
//! there (massless statics, the force its torque over its lever) and lets go where that
//! torque reaches zero; released, it returns to the same motion. Before, the park was planned
//! anew from each release, at rest in acceleration: not the acceleration the contact had
//! imposed, so the toe went back into the ground 10–20 µs later, pushed again and let go again
//! (15 of the broad sweep's 28 `zeno` points: 1,800 cycles/s at (−,+) t2 = 0.1385 s, G = 32.7).
//!
//! Checked by routes other than the controller:
//! - after a release the leg's angle is the closed form of its air law about the one motion:
//!   the error `e = q − θ_m` of the critically damped 20 rad/s loop (`q̈ = α_m + 400 (θ_m − q)
//!   + 40 (ω_m − q̇)`, the leap's free-joint law) is `e(τ) = (e₀ + (ė₀ + 20 e₀) τ) e^{−20 τ}`,
//!   with the motion rebuilt from the event that started the retraction
//!   ([`JointMotion::park`] to the stow angle, at the acceleration bound of
//!   [`leg_swing`]) — a re-planned park would not match;
//! - the released toe stays off the ground for at least a millisecond, by its gap from the
//!   kinematics on the dense output (not by the absence of a guard);
//! - over the 15 points of the broad sweep that ended in such a cycle, no leg's toe touches
//!   down within a millisecond of its own release, and none ends in a two-mode cycle.
mod common;

use common::state_at;
use rhex_model::leap::{leap_params, leg_swing, simulate_leap, LeapConfig, LeapResult, X_RHEX_LEG};
use rhex_model::{Rhex, RhexParams};
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_hybrid::{EventKind, Termination};
use selfmanip_sim::motion::JointMotion;

/// Where a parked leg points (rad): up, past vertical, on the side of straight down where it
/// is (`rhex_model::leap`).
const STOW_RAD: f64 = 2.6;
/// The free-joint loop about a prescribed motion: critically damped at 20 rad/s.
const LOOP_RAD_S: f64 = 20.0;

/// One of the broad sweep's points (strategy, t2, gear ratio, body inertia and mass).
fn point(s: &str, t2: f64, gear: f64, i_b: f64, m_b: f64) -> (RhexParams, LeapConfig) {
    let mut p = leap_params();
    p.I_b = i_b;
    p.m_b = m_b;
    let cfg = LeapConfig {
        strategy: s.parse().unwrap(),
        t2_s: t2,
        actuator: X_RHEX_LEG.at_gear_ratio(gear),
        ..LeapConfig::default()
    };
    (p, cfg)
}

/// The 15 points of the broad sweep (2,000 points, seed 16) that ended in a leg's
/// touchdown–liftoff cycle before (`SHOW=zeno broad_sweep`, kinds `0000<->0001`,
/// `0000<->0100`, `1000<->1001`).
const CYCLES: [(&str, f64, f64, f64, f64); 15] = [
    ("-+", 0.1385, 32.67, 0.2195465486914829, 9.171859692964638),
    ("-+", 0.1265, 35.82, 0.18713839651770628, 9.53946487676246),
    ("+-", 0.1937, 6.33, 0.10108951301799127, 7.949045910612237),
    ("-+", 0.1847, 28.65, 0.22032449926548855, 10.562532144852174),
    ("+-", 0.1509, 55.57, 0.13504714284515454, 10.279916588187778),
    ("-+", -0.1025, 49.78, 0.20550028877715001, 8.452201063252682),
    ("+-", 0.2181, 35.82, 0.12040766021770921, 10.588767220015562),
    ("-+", -0.0823, 33.01, 0.1363596368956577, 4.794418413011234),
    ("-+", -0.0780, 49.13, 0.1331657393155979, 5.478914284048185),
    ("+-", 0.2245, 52.79, 0.10756481453904408, 5.564785401071167),
    ("++", 0.0863, 36.50, 0.1755914335353955, 4.421982245505349),
    ("+-", 0.1910, 53.09, 0.1694842985524637, 10.132349880022728),
    ("-+", 0.1551, 29.85, 0.1286282348122526, 9.233212405343439),
    ("-+", 0.1811, 18.23, 0.2006677621533395, 6.446385961206612),
    ("+-", 0.2213, 37.45, 0.11705601206807327, 10.244668100328125),
];

/// The robot of a leap (its two pushing pairs) and the contact index of each leg's toe.
fn robot(p: &RhexParams, cfg: &LeapConfig) -> (Rhex, [usize; 2]) {
    let mut pp = p.clone();
    pp.pairs = cfg.strategy.chapter3_pairs().to_vec();
    let rhex = Rhex::new(pp).unwrap();
    let toes = [rhex.site(1), rhex.site(3)];
    (rhex, toes)
}

/// Each leg's releases: the events after which its toe is off the ground that had it on
/// before (execution time, index).
fn releases(r: &LeapResult, toe: usize) -> Vec<usize> {
    r.execution
        .events
        .iter()
        .enumerate()
        .filter(|(_, e)| e.mode_before.contains(toe) && !e.mode_after.contains(toe))
        .map(|(k, _)| k)
        .collect()
}

/// The event (index) at which leg `i` starts retracting in the air: its own first release
/// after its motor started, or the first flight once both motors have started (the open-loop
/// controller's rule, section 3.2), whichever comes first.
fn retract_start(r: &LeapResult, cfg: &LeapConfig, toes: [usize; 2], i: usize) -> Option<usize> {
    let offset = cfg.t2_s.min(0.0);
    let start = [-offset, cfg.t2_s - offset];
    let evs = &r.execution.events;
    let own = releases(r, toes[i])
        .into_iter()
        .find(|&k| evs[k].t >= start[i]);
    let takeoff = evs
        .iter()
        .position(|e| e.t >= start[0].max(start[1]) && e.mode_after.is_flight());
    match (own, takeoff) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// A released retracting leg returns to the one park planned when it started retracting:
/// its angle after each later release is the loop's closed form about that park, and its
/// toe stays off the ground (gap from the kinematics) for at least 1 ms.
#[test]
fn a_released_leg_returns_to_its_one_retraction_in_closed_form() {
    // the point of 1,800 cycles/s before: the rear leg, braking from its push, meets the
    // ground while the body rises at 0.6 m/s
    let (p, cfg) = point("-+", 0.1385, 32.67, 0.2195465486914829, 9.171859692964638);
    let r = simulate_leap(&p, &cfg).unwrap();
    let (rhex, toes) = robot(&p, &cfg);
    let model = &rhex.model;
    let nq = model.nq();
    let accel = leg_swing(&p, &cfg).unwrap().1;
    let sign = [cfg.strategy.front.sign(), cfg.strategy.rear.sign()];
    let evs = &r.execution.events;
    let mut kin = Kinematics::default();
    let mut y = vec![0.0; 2 * nq];
    let mut checked = 0;
    for i in 0..2 {
        let Some(k0) = retract_start(&r, &cfg, toes, i) else {
            continue;
        };
        let e0 = &evs[k0];
        let th0 = e0.q[i];
        let side = if sign[i] * th0 >= 0.0 {
            sign[i]
        } else {
            -sign[i]
        };
        let park = JointMotion::park(e0.t, th0, e0.qd_after[i], side * STOW_RAD, accel);
        for k in releases(&r, toes[i]).into_iter().filter(|&k| k > k0) {
            let e = &evs[k];
            let (th_m, w_m, _) = park.eval(e.t);
            let (err0, derr0) = (e.q[i] - th_m, e.qd_after[i] - w_m);
            // the flow after the release, up to the toe's next touchdown
            let until = evs[k + 1..]
                .iter()
                .find(|n| n.kind == EventKind::Touchdown && n.triggered.contains(&toes[i]))
                .map_or(r.execution.t, |n| n.t);
            assert!(
                until - e.t >= 1e-3,
                "leg {i} back on the ground after {} s",
                until - e.t
            );
            for s in 1..=20 {
                let t = e.t + (until - e.t).min(0.05) * f64::from(s) / 20.0;
                state_at(&r.execution, t, &mut y);
                let tau = t - e.t;
                let closed = park.eval(t).0
                    + (err0 + (derr0 + LOOP_RAD_S * err0) * tau) * (-LOOP_RAD_S * tau).exp();
                assert!(
                    (y[i] - closed).abs() < 1e-5,
                    "leg {i}, {tau} s after the release at {}: {} vs {closed}",
                    e.t,
                    y[i]
                );
                kin.compute(model, &y[..nq], &y[nq..]);
                let gap = contact_geometry(model, &kin, &cfg.terrain, toes[i]).gap_m;
                assert!(
                    gap > 0.0,
                    "leg {i} toe at {gap} m, {tau} s after its release"
                );
                checked += 1;
            }
        }
    }
    assert!(
        checked >= 20,
        "a release after the retraction started: {checked} samples"
    );
    assert!(
        !matches!(
            r.execution.termination,
            Termination::Chatter { .. } | Termination::Zeno { .. }
        ),
        "{:?}",
        r.execution.termination
    );
}

/// Over the broad sweep's 15 re-contact points: no leg's toe touches down within 1 ms of its
/// own release, and no run ends in a two-mode cycle (before: 10–20 µs, 500–1,800 cycles/s).
#[test]
fn no_leg_touches_down_within_a_millisecond_of_its_release() {
    for (s, t2, g, i_b, m_b) in CYCLES {
        let (p, cfg) = point(s, t2, g, i_b, m_b);
        let r = simulate_leap(&p, &cfg).unwrap();
        let (_, toes) = robot(&p, &cfg);
        let evs = &r.execution.events;
        for toe in toes {
            for k in releases(&r, toe) {
                if let Some(n) = evs[k + 1..]
                    .iter()
                    .find(|n| n.kind == EventKind::Touchdown && n.mode_after.contains(toe))
                {
                    assert!(
                        n.t - evs[k].t >= 1e-3,
                        "{s} t2={t2} G={g}: toe {toe} back after {} s",
                        n.t - evs[k].t
                    );
                }
            }
        }
        assert!(
            !matches!(r.execution.termination, Termination::Chatter { .. }),
            "{s} t2={t2} G={g}: {:?}",
            r.execution.termination
        );
        let word = r.word_string();
        let cells: Vec<&str> = word.split('-').collect();
        let tail = &cells[cells.len().saturating_sub(8)..];
        let mut distinct = tail.to_vec();
        distinct.sort_unstable();
        distinct.dedup();
        assert!(
            cells.len() < 8 || distinct.len() > 2,
            "{s} t2={t2} G={g}: ends in a cycle, {word}"
        );
    }
}
