//! A chatter is truncated as a Zeno execution is, not ended (`selfmanip_hybrid::zeno`, the
//! decision 2026-11-30-chatter-truncated).
//!
//! The robot (`data/held_shin_chatter.json`): a four-legged robot from the user-robot sweep
//! (seed 30, run 8) pushing on stairs; its fore leg is a massive thigh with a massless shin.
//! Its fore foot is held by the jam hold at each touchdown and let go where its released
//! foot separates, back on the ground a fraction of a millisecond later: a cycle of two
//! events (touchdown, liftoff) with the robot in place, which used to end the run.
//!
//! What is checked, each against a route of its own:
//! - the run reaches its final time, and where a truncation follows a chatter, the
//!   chatter is that of the detector's own criterion on the events before it
//!   (`ChatterDetector::check`, applied independently here);
//! - the truncation is a plastic impact (no kinetic energy gained: Kelvin's theorem) and its
//!   contacts are held for the dwell: no liftoff or slip of them within `zeno_window_s`
//!   (the dwell's shortest length);
//! - the energy balance `E1 − E0 = W + W_fr − L` to 1e-6 J across the truncations.
//!
//! A truncation into a mode whose KKT matrix is as good as singular truncates nothing
//! (`data/fold_truncation.json`: a two-legged robot of the user-robot sweep, seed 41, run
//! 113, both legs two massless links, on stairs, with re-touch series at its hind chain's
//! fold). Held sticking there, the chain's stop takes rates of 10⁴ rad/s, and the run ended
//! in an error (`Ȧq̇` not finite). It now ends typed, with the Zeno window's status, at a
//! state that is finite and where a chain of the window's contacts is within the fold
//! threshold of its fold, by the closed form of a two-link chain's pin.
use selfmanip_hybrid::zeno::ChatterDetector;
use selfmanip_hybrid::{EventKind, HybridOptions, Termination};
use selfmanip_sim::{Run, RunStatus, Scenario, Simulation};
use std::path::Path;

fn scenario() -> Scenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/held_shin_chatter.json");
    Scenario::from_file(&path).unwrap()
}

fn run() -> Run {
    Simulation::new(&scenario()).unwrap().run().unwrap()
}

#[test]
fn a_chatter_is_truncated_and_the_run_goes_on() {
    let run = run();
    let (exec, status) = (&run.execution, run.outcome.status);
    assert_eq!(status, RunStatus::FinalTime, "{:?}", exec.termination);
    assert!(!matches!(exec.termination, Termination::Chatter { .. }));
    let t_final = scenario().options.t_final_s;
    assert!((exec.t - t_final).abs() < 1e-12);
    // the truncations that follow a chatter: the detector's criterion holds on the events
    // before each of them
    let after_chatter: Vec<usize> = (0..exec.events.len())
        .filter(|&i| {
            exec.events[i].kind == EventKind::ZenoTruncation
                && ChatterDetector.check(&exec.events[..i]).is_some()
        })
        .collect();
    assert!(!after_chatter.is_empty(), "no chatter was truncated");
    // and no chatter of the detector's remains at the end of the run
    assert!(ChatterDetector.check(&exec.events).is_none());
}

#[test]
fn a_truncation_is_plastic_and_holds_its_contacts() {
    let run = run();
    let window = scenario().options.zeno_window_s;
    let events = &run.execution.events;
    let mut truncations = 0;
    for (i, e) in events.iter().enumerate() {
        if e.kind != EventKind::ZenoTruncation {
            continue;
        }
        truncations += 1;
        assert!(
            e.kinetic_after <= e.kinetic_before + 1e-12,
            "truncation at {} gains {:.3e} J",
            e.t,
            e.kinetic_after - e.kinetic_before
        );
        let held: Vec<usize> = e.mode_after.active().collect();
        for later in events[i + 1..].iter().take_while(|l| l.t < e.t + window) {
            let lets_go = matches!(later.kind, EventKind::Liftoff | EventKind::Slip);
            assert!(
                !(lets_go && later.triggered.iter().any(|k| held.contains(k))),
                "held contacts {held:?} let go at {} within the dwell from {}",
                later.t,
                e.t
            );
        }
    }
    assert!(truncations > 0);
}

#[test]
fn the_energy_balance_closes_across_the_truncations() {
    let run = run();
    let report = run.energy_report().unwrap();
    assert!(report.residual_j().abs() < 1e-6, "{report:?}");
}

/// The pin of a two-link chain's sticking foot (`docs/singular-transitions.md` §3) in closed
/// form: `√|r₁ × r₂| / max |r_j|` with `r₁` the hip-to-foot and `r₂` the knee-to-foot vectors,
/// so `|r₁ × r₂| = ℓ₁ ℓ₂ |sin θ_knee|` and `|r₁|² = ℓ₁² + ℓ₂² + 2 ℓ₁ ℓ₂ cos θ_knee`.
fn two_link_pin(l1: f64, l2: f64, knee: f64) -> f64 {
    let reach = (l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * knee.cos()).sqrt();
    (l1 * l2 * knee.sin().abs()).sqrt() / reach.max(l2)
}

#[test]
fn a_truncation_at_a_fold_truncates_nothing() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fold_truncation.json");
    let scenario = Scenario::from_file(&path).unwrap();
    let run = Simulation::new(&scenario)
        .unwrap()
        .run()
        .expect("the run ends typed, not with an error");
    let (model, exec) = (&run.model, &run.execution);
    assert!(
        exec.q.iter().chain(&exec.qd).all(|v| v.is_finite()),
        "{:?} {:?}",
        exec.q,
        exec.qd
    );
    // it ends with the Zeno window's status, one of whose contacts sits at the foot of a
    // two-link massless chain within the fold threshold of its fold at the run's last state
    let Termination::Zeno { contacts, .. } = &exec.termination else {
        panic!("{:?}", exec.termination)
    };
    let folded = contacts.iter().any(|&k| {
        let Some(link) = model.contacts[k].link else {
            return false;
        };
        let leg = &model.legs[model.joints[link].leg];
        let (thigh, shin) = (
            &model.joints[leg.first_joint],
            &model.joints[leg.first_joint + 1],
        );
        assert!(leg.n_links == 2 && thigh.mass_kg == 0.0 && shin.mass_kg == 0.0);
        two_link_pin(thigh.length_m, shin.length_m, exec.q[leg.first_joint + 1])
            <= HybridOptions::default().fold_threshold
    });
    assert!(folded, "no chain of {contacts:?} at its fold: {:?}", exec.q);
}
