//! A re-touch chatter is truncated (`selfmanip_hybrid::zeno`, the decision
//! 2026-11-30-chatter-truncated, "Re-touch cycles").
//!
//! The robot, built here: a 9.5 kg body on two legs of two massive links each (a 0.35 kg
//! thigh, a 0.17 kg shin of `I = 1.17·10⁻⁴` kg m²) under stiff servos (`k_d = 16.3` N m s/rad,
//! `k_d / I ≈ 10⁵` /s on the shin), holding their pose, dropped 1 cm pitched nose-down by
//! 0.05 rad. The front foot lands and sticks; the hind foot then comes down on the ground
//! again and again: its impact keeps it (`P > 0`), its force lets it go at once (the servo's
//! damping, excited by the impact, lifts it), and its servo puts it back a fraction of a
//! millisecond later — a touchdown that leaves the mode as it was, 73 times in a row before
//! the detector counted such a cycle (the chatter of thesis Fig. 5.7, one event per cycle).
//!
//! What is checked, each against a route of its own:
//! - the run reaches its final time, and a truncation follows the re-touches, on the
//!   detector's own criterion applied independently to the events before it
//!   (`ChatterDetector::check`); no more than `CHATTER_CYCLES` re-touches of one contact
//!   follow one another;
//! - every re-touch is a plastic impact (no kinetic energy gained: Kelvin's theorem) that
//!   carries an impulse and leaves the mode as it was;
//! - the energy balance `E1 − E0 = W + W_fr − L` to 1e-6 J across the truncation, with the
//!   friction and damping work not positive;
//! - a second run bit-identical (the truncation's bookkeeping is deterministic).
use selfmanip_hybrid::zeno::{ChatterDetector, CHATTER_CYCLES};
use selfmanip_hybrid::{Event, EventKind};
use selfmanip_sim::{Run, RunStatus, Scenario, Simulation};
mod common;

fn scenario() -> Scenario {
    let mut s = common::retouch_robot(serde_json::json!(385.65));
    // the lowest foot 1 cm above the ground (NED: z down)
    s["initial"] = serde_json::json!({"q": [0.46, -0.7254, 0.46, -0.7254, 0.0, -0.3205, -0.05]});
    s["options"] = serde_json::json!({"t_final_s": 0.2});
    Scenario::from_json_str(&s.to_string()).unwrap()
}

fn run() -> Run {
    Simulation::new(&scenario()).unwrap().run().unwrap()
}

/// A touchdown that leaves the mode as it was.
fn retouch(e: &Event) -> bool {
    e.kind == EventKind::Touchdown && e.mode_before == e.mode_after
}

#[test]
fn a_retouch_cycle_is_truncated_and_the_energy_balances() {
    let run = run();
    let exec = &run.execution;
    let ended = (run.outcome.status, &exec.termination);
    assert!(ended.0 == RunStatus::FinalTime, "{ended:?}");
    let retouches: Vec<&Event> = exec.events.iter().filter(|e| retouch(e)).collect();
    assert!(retouches.len() >= CHATTER_CYCLES, "{}", retouches.len());
    for e in &retouches {
        // an impact that kept the touched contact, which force let go at once
        assert!(e.makes_transitions(), "{e:?}");
        assert!(e.impulse.iter().any(|p| p.abs() > 1e-9), "{e:?}");
        assert!(e.kinetic_after <= e.kinetic_before + 1e-12, "{e:?}");
    }
    // a truncation after the re-touches, on the detector's criterion
    let truncated: Vec<usize> = (0..exec.events.len())
        .filter(|&i| {
            exec.events[i].kind == EventKind::ZenoTruncation
                && ChatterDetector.check(&exec.events[..i]).is_some()
        })
        .collect();
    assert!(
        !truncated.is_empty(),
        "the re-touch cycle was not truncated"
    );
    let mut in_a_row = 0;
    let mut longest = 0;
    for w in exec.events.windows(2) {
        let same = retouch(&w[1]) && retouch(&w[0]) && w[1].triggered == w[0].triggered;
        in_a_row = if same { in_a_row + 1 } else { 1 };
        longest = longest.max(in_a_row);
    }
    assert!(longest <= CHATTER_CYCLES, "{longest} re-touches in a row");
    // E1 − E0 = W + W_fr − L across the re-touches and the truncation
    let er = run.energy_report().unwrap();
    assert!(er.residual_j().abs() < 1e-6, "{er:?}");
    assert!(
        er.friction_work_j <= 0.0 && er.damping_work_j <= 0.0,
        "{er:?}"
    );
    // deterministic
    let again = self::run();
    assert_eq!(again.execution.events, exec.events);
    assert_eq!(again.execution.q, exec.q);
}
