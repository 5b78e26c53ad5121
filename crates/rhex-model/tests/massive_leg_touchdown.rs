//! Issue 16, a massive leg's touchdown that changes no mode — two mechanisms, one test each.
//!
//! First: with Table 4.2's leg mass
//! (0.126 kg, 0.00092 kg m² per pair) and Coulomb toes the (+,−) leap at t2 = −0.1 s ended
//! `zeno`: 13.8 ms after takeoff the front toe touched down, the reset released it (the
//! impact's pseudo-impulse and the force at q̇⁺ pulled: the leg's servo lifts the toe on the
//! ground) and 15 µs later it touched down again — 41 times in 0.3 ms. In the air the
//! leg got no torque at all (the leap controller of the time gave a leg off the ground zero torque,
//! right for a massless leg, whose motion is then prescribed as a free joint's, but a massive
//! leg is no free joint): limp, it fell back into the ground. The force complementarity of a
//! touchdown, (5.19)–(5.20) (Theorem 5.5), presumes one torque law `τ(t, q, q̇)` for both of
//! its branches; with a torque that depends on the contact, neither "push with zero gap
//! acceleration" nor "no force with a separating gap acceleration" holds, and the engine
//! cycles. The massive leg is now servoed along its air motion off the ground as on it.
//!
//! The test checks, on that leap, by a route outside the engine's resets: the controller's
//! torque on each leg is the same with and without the leg's contact (the premise of
//! (5.19)–(5.20)); and at every toe touchdown the outcome is consistent with the flow that
//! follows, written by hand at the acceleration level: a toe the reset releases has a
//! separating gap rate, or (at zero gap rate, a plastic impact's (5.52)) a gap acceleration
//! that does not close it, and a toe it keeps a gap acceleration that would close it if
//! released (the refused branch is inconsistent), both by central differences of the toe's
//! gap from the kinematics along `q + q̇ h + ½ q̈ h²`, with `q̈` from the forward dynamics
//! (5.2) of the branch without the toe under the controller's torque (the (+,−) leap's one
//! toe touchdown: the rear toe at 23 ms, kept, −2.7e3 m/s² free). No touchdown leaves the
//! mode unchanged.
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig};
use rhex_model::{Rhex, RhexParams};
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{forward_dynamics, Data, FlatGround};
use selfmanip_hybrid::{EventKind, Termination};

/// Table 4.2's leg-pair mass and inertia on the default leap's parameters (Coulomb toes).
fn massive() -> RhexParams {
    leap_params().with_table_4_2_legs()
}

#[test]
fn massive_leg_touchdown_that_changes_no_mode() {
    touchdowns_agree_with_the_flow(&massive(), "+-", -0.1);
}

/// The second cycle (issue 16): the (+,+) t2 = 0.16 leap flips the robot (138° pitch) onto
/// a body end; a parked toe meets the ground at 1.0 m/s. Stuck, the impact pulls (7.0 N s along
/// the ground, 2.0 N s up); the reset tried the slide only for a massless link, so it let
/// the toe go with its approach speed and the guard fired again at the same instant, 41
/// times. A touched toe left out must not approach the ground after the impact ((5.29)).
#[test]
fn massive_leg_toe_whose_sticking_impact_pulls_slides() {
    touchdowns_agree_with_the_flow(&massive(), "++", 0.16);
}

/// The checks of the module docs on the leap `strategy`, `t2_s` with parameters `p`.
fn touchdowns_agree_with_the_flow(p: &RhexParams, strategy: &str, t2_s: f64) {
    let cfg = LeapConfig {
        strategy: strategy.parse().unwrap(),
        t2_s,
        ..LeapConfig::default()
    };
    let r = simulate_leap(p, &cfg).unwrap();
    let word = r.word_string();
    let evs = &r.execution.events;
    let mut pp = p.clone();
    pp.pairs = cfg.strategy.chapter3_pairs().to_vec();
    let rhex = Rhex::new(pp).unwrap();
    let model = &rhex.model;
    let (nq, nj) = (model.nq(), model.n_joints());
    assert!(
        (0..2).all(|j| !model.distal_massless(j)),
        "the legs have mass"
    );
    let toes = [rhex.site(1), rhex.site(3)];
    let terrain = FlatGround;
    let mut kin = Kinematics::default();
    let gap = |kin: &mut Kinematics, q: &[f64], c: usize| {
        kin.compute(model, q, &vec![0.0; nq]);
        contact_geometry(model, kin, &terrain, c).gap_m
    };
    let mut checked = 0;
    for e in evs.iter().filter(|e| e.kind == EventKind::Touchdown) {
        let seg = r
            .execution
            .segments
            .iter()
            .find(|g| g.t0 == e.t)
            .expect("the flow after the touchdown");
        let ctrl = &seg.controller;
        let (q, qd) = (&e.q[..], &e.qd_after[..]);
        let mut tau = vec![0.0; nj];
        ctrl.torque(e.t, q, qd, e.mode_after, &mut tau);
        // a released toe: separating rate, or a gap acceleration that does not close it
        for &c in e.triggered.iter().filter(|&&c| toes.contains(&c)) {
            // the branch without the toe: the one the reset took, or the one it refused
            let kept = e.mode_after.contains(c);
            let mut data = Data::new(model);
            let free = e.mode_after.without(c);
            forward_dynamics(model, &mut data, &terrain, free, q, qd, &tau, None).unwrap();
            let qdd: Vec<f64> = data.qdd.iter().copied().collect();
            let h = 1e-4;
            let at = |s: f64| -> Vec<f64> {
                (0..nq)
                    .map(|i| q[i] + qd[i] * s + 0.5 * qdd[i] * s * s)
                    .collect()
            };
            let (gm, g0, gp) = (
                gap(&mut kin, &at(-h), c),
                gap(&mut kin, &at(0.0), c),
                gap(&mut kin, &at(h), c),
            );
            // the rate on a finer step (its truncation error, h² d³g/6, would pass 1 µm/s
            // on the acceleration's step)
            let hr = 1e-6;
            let rate = (gap(&mut kin, &at(hr), c) - gap(&mut kin, &at(-hr), c)) / (2.0 * hr);
            let accel = (gp - 2.0 * g0 + gm) / (h * h);
            // gap positive above the ground; rates of round-off size are "zero"
            if kept {
                // refused release: at the zero rate of a plastic impact the free branch
                // would close the gap (the toe would enter the ground)
                assert!(
                    rate.abs() < 1e-6 && accel < 0.0,
                    "toe {c} kept at {} though free it leaves: rate {rate}, accel {accel}",
                    e.t
                );
                checked += 1;
                continue;
            }
            assert!(
                rate > 1e-6 || accel >= -1e-3,
                "toe {c} released at {} closing: gap rate {rate} m/s, acceleration {accel} m/s²",
                e.t
            );
            checked += 1;
        }
        // one torque law for both branches of every toe
        for &c in &toes {
            let mut other = vec![0.0; nj];
            let toggled = if e.mode_after.contains(c) {
                e.mode_after.without(c)
            } else {
                e.mode_after
                    .with(c, selfmanip_core::contact::ContactKind::Slide)
            };
            ctrl.torque(e.t, q, qd, toggled, &mut other);
            assert_eq!(tau, other, "torque depends on toe {c}'s contact at {}", e.t);
        }
    }
    assert!(checked > 0, "no toe touchdown to check: {word}");
    assert!(
        !matches!(r.execution.termination, Termination::Zeno { .. }),
        "{:?} {word}",
        r.execution.termination
    );
    assert!(evs.len() < 40, "{} events: {word}", evs.len());
    assert!(
        evs.iter()
            .all(|e| e.kind != EventKind::Touchdown || e.mode_before != e.mode_after),
        "a touchdown that changes no mode: {word}"
    );
}
