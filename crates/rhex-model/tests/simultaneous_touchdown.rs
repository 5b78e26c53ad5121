//! Regression (issue 16): the default (+,−) leap at t2 = 0, whose two legs touch down at the
//! same instant.
//!
//! **The defect.** Both toes touch down at 0.03155 s and both are at rest after the impact.
//! Force complementarity then judged the set {front, rear} with both toes sliding from rest,
//! each on the cone edge its own sticking force picks — but the friction law checked each
//! edge with the toes after it still free of friction. Together, the front toe's edge was one
//! on which its leg's statics *pull* (λ_n = +2,453 N, against a push of 184 N alone), so the
//! set was rejected and the front leg let go — a massless leg whose motor drives it into the
//! ground: its touchdown fired again 3 µs later, and on — with the rest band of the earlier
//! law, 8 null touchdowns `100s → 100s` and `no_flight` or `zeno` by tolerance; with rest
//! decided by events but edges still chosen one toe at a time, a 0.4 ms touchdown–liftoff
//! chatter of the front leg to `zeno` at rtol 1e-8 (and, before a contact's velocity after
//! an impact was its own, a liftoff repeated at one instant at 1e-6).
//! **The fix** (`selfmanip_core::friction::resolve`): toes leaving rest together take their
//! edges jointly — each must start sliding against its force under the others' forces, and
//! an edge on which the leg's statics push is preferred (on one that pulls, the contact is
//! let go by complementarity; where both edges are consistent the law does not choose, the
//! contact does), searching the 2ⁿ edge combinations when the sticking forces' sides fail.
//!
//! The independent routes: the dense output of the segment after the touchdown (each toe
//! slides in the direction its fixed friction edge opposes, `σ v_t > 0`, found on the
//! integrated states by the kinematics, not by the friction law), the core's KKT at its start
//! (both legs push), and the same events at every integration tolerance.
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LeapResult};
use rhex_model::Rhex;
use selfmanip_core::friction::SlideDirection;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{forward_dynamics, Data, FlatGround, RowDirection};

fn leap(rtol: f64) -> LeapResult {
    simulate_leap(
        &leap_params(),
        &LeapConfig {
            strategy: "+-".parse().unwrap(),
            t2_s: 0.0,
            rtol,
            ..LeapConfig::default()
        },
    )
    .unwrap()
}

#[test]
fn simultaneous_touchdown_keeps_both_toes_leaving_rest_together() {
    let r = leap(1e-8);
    assert!(r.flew, "{}", r.word_string());
    // the first event is both legs' touchdown, and it keeps both (label FB FL RB RL)
    let first = &r.events[0];
    assert_eq!(first.kind, "touchdown");
    assert!(
        first.contacts.iter().any(|c| c == "front_leg"),
        "{:?}",
        first.contacts
    );
    assert!(
        first.contacts.iter().any(|c| c == "rear_leg"),
        "{:?}",
        first.contacts
    );
    let after: Vec<char> = first.mode_after.chars().collect();
    assert!(
        after[1] != '0' && after[3] != '0',
        "both legs held: {}",
        first.mode_after
    );
    // no event that changes nothing (the apex is recorded as such by design)
    for e in r.events.iter().filter(|e| e.kind != "apex") {
        assert_ne!(
            e.mode_before, e.mode_after,
            "a null {} at {}",
            e.kind, e.t_s
        );
    }
    // the segment after the touchdown: each sliding toe has a fixed friction edge σ ≠ 0,
    // and on the integrated states it slides that way, σ v_t > 0, from just after the start
    let mut p = leap_params();
    p.pairs = "+-"
        .parse::<rhex_model::leap::Strategy>()
        .unwrap()
        .chapter3_pairs()
        .to_vec();
    let rhex = Rhex::new(p).unwrap();
    let model = &rhex.model;
    let seg = &r.execution.segments[1];
    assert_eq!(seg.mode, r.execution.events[0].mode_after);
    let sliding: Vec<(usize, f64)> = seg
        .slide_directions
        .iter()
        .map(|&(k, d)| match d {
            SlideDirection::Fixed(s) => (k, s),
            SlideDirection::FromRest => panic!("a direction left open"),
        })
        .collect();
    assert_eq!(
        sliding.len(),
        2,
        "both toes slide: {:?}",
        seg.slide_directions
    );
    let nq = model.nq();
    let mut y = vec![0.0; 2 * nq];
    let mut kin = Kinematics::default();
    for frac in [1e-3, 1e-2, 0.1] {
        let t = seg.t0 + frac * (seg.t1 - seg.t0);
        seg.eval(t, &mut y);
        kin.compute(model, &y[..nq], &y[nq..]);
        for &(k, sigma) in &sliding {
            assert!(sigma != 0.0, "toe {k} without friction");
            let v_t = selfmanip_hybrid::flow::sliding_velocity(model, &kin, &FlatGround, k);
            assert!(
                sigma * v_t > 0.0,
                "toe {k} at {t}: σ = {sigma}, v_t = {v_t}"
            );
        }
    }
    // … and both legs push at the segment's start (the core's KKT with those edges)
    let (q, qd) = seg.y0.split_at(nq);
    let mut tau = vec![0.0; model.n_joints()];
    seg.controller.torque(seg.t0, q, qd, seg.mode, &mut tau);
    let mut data = Data::new(model);
    data.slide_directions.clone_from(&seg.slide_directions);
    forward_dynamics(model, &mut data, &FlatGround, seg.mode, q, qd, &tau, None).unwrap();
    for (row, rw) in data.constraints.rows.iter().enumerate() {
        if rw.direction == RowDirection::Normal {
            assert!(
                data.lambda[row] < 0.0,
                "contact {} pulls: {}",
                rw.contact,
                data.lambda[row]
            );
        }
    }
    // one outcome at every tolerance: the same events (kind, modes)
    let transitions = |r: &LeapResult| -> Vec<String> {
        r.events
            .iter()
            .map(|e| format!("{} {}->{}", e.kind, e.mode_before, e.mode_after))
            .collect()
    };
    for rtol in [1e-6, 1e-4, 1e-3] {
        let c = leap(rtol);
        assert_eq!(transitions(&c), transitions(&r), "rtol {rtol}");
    }
}
