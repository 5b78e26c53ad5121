//! The integration's work counters (`integrate::work_counters`) against counts kept by a
//! second route: the right-hand side's own call count and the structure of Dormand–Prince
//! 5(4) (six new stages per trial step, one more for the stored derivative after a restart,
//! FSAL), and the execution's own count of accepted steps and its segments' dense outputs.
use selfmanip_core::ContactMode;
use selfmanip_hybrid::integrate::{
    reset_work_counters, work_counters, DenseStep, Dopri5, StepError,
};
use selfmanip_hybrid::{HybridOptions, StepOptions};

mod systems;
use systems::{released, BLOCK, G};

/// `ẏ = −50 y` from `y = 1` with a first trial step of 0.2 s: the first trials are rejected
/// (their error is far above the tolerance) until the step resolves the decay; then accepted
/// steps to `t = 0.5`. The counters' accepted and rejected trials satisfy DOPRI5's call count
/// `calls = 1 + 6 (accepted + rejected)` for the right-hand side's own count of its calls,
/// the accepted ones are the `Ok` steps the caller saw, and the end point is `e^{−25}`.
#[test]
fn dopri5_counts_match_its_stage_structure() {
    let mut calls = 0u64;
    let mut f = |_t: f64, y: &[f64], d: &mut [f64]| -> Result<(), ()> {
        calls += 1;
        d[0] = -50.0 * y[0];
        Ok(())
    };
    let mut ode = Dopri5::new(
        1,
        StepOptions {
            rtol: 1e-8,
            atol: 1e-12,
            h_initial_s: 0.2,
            ..Default::default()
        },
    );
    reset_work_counters();
    let (mut t, mut y) = (0.0, [1.0]);
    let mut step = DenseStep::default();
    let mut ok_steps = 0u64;
    while t < 0.5 {
        match ode.step(&mut f, t, &mut y, 0.5, &mut step) {
            Ok(()) => ok_steps += 1,
            Err(StepError::Rhs(())) | Err(StepError::StepTooSmall(_)) => panic!("step failed"),
        }
        t = step.t1();
    }
    let w = work_counters();
    // no flow evaluated: every count is in the default phase (0)
    let accepted = w.accepted[0];
    let rejected = w.rejected[0];
    assert_eq!(accepted, ok_steps);
    assert!(
        rejected >= 1,
        "the 0.2 s first trial (h λ = 10) is rejected"
    );
    assert_eq!(calls, 1 + 6 * (accepted + rejected));
    assert_eq!(w.accepted[1] + w.rejected[1], 0);
    assert!((y[0] - (-25.0f64).exp()).abs() < 1e-8 * (-25.0f64).exp() + 1e-12);
}

/// A block dropped from 0.2 m falls in the flight mode and lands on both corners at
/// `√(2d/g)` (a closed form tested in `executions.rs`): the counters split its work into
/// flight (before the touchdown) and stance (after), their accepted steps add up to the
/// execution's own count `Execution::steps` and to its segments' dense outputs, phase by
/// phase, and every right-hand side call made by a trial step is counted (`rhs ≥ 6 (accepted
/// + rejected)`, `rhs ≤ that + restarts + segments`).
#[test]
fn flow_counters_split_a_falling_block_into_flight_and_stance() {
    let model = systems::block(G);
    let d = 0.2;
    let q = [0.3, -BLOCK.1 / 2.0 - d, 0.0];
    reset_work_counters();
    let exec = released(
        &model,
        ContactMode::FLIGHT,
        &q,
        1.0,
        HybridOptions::default(),
    );
    let w = work_counters();
    systems::free_fall_touchdown(&exec, d);
    let mut by_phase = [0u64; 2];
    for sg in &exec.segments {
        by_phase[usize::from(sg.mode.active().next().is_none())] += sg.dense.len() as u64;
    }
    assert!(by_phase[0] > 0 && by_phase[1] > 0, "{by_phase:?}");
    assert_eq!(w.accepted, by_phase);
    assert_eq!(w.accepted[0] + w.accepted[1], exec.steps as u64);
    for p in 0..2 {
        let trials = 6 * (w.accepted[p] + w.rejected[p]);
        assert!(w.rhs_calls[p] >= trials, "phase {p}: {w:?}");
        assert!(
            w.rhs_calls[p] <= trials + w.restarts[p] + exec.segments.len() as u64,
            "phase {p}: {w:?}"
        );
        assert!(w.solves[p] > 0);
    }
}

/// The force guards are sampled mid-step only where the step's own stages do not show them
/// clear (`guard::GuardSet::watch_stage`): a block standing on both corners (the right one
/// sliding) pushes with `m g / 2` at each (a closed form, `stage_guard.rs`) at every stage,
/// so its 50 fixed steps solve the flow at most at their stages; the same block in zero
/// gravity pushes with nothing, within the arming margin, and takes the same steps with one
/// more solve each, at mid-step.
#[test]
fn force_guards_clear_over_a_step_take_no_mid_step_solve() {
    let h = 0.01;
    let opts = HybridOptions {
        step: StepOptions {
            h_initial_s: h,
            h_max_s: h,
            ..StepOptions::default()
        },
        ..HybridOptions::default()
    };
    let counts = [G, 0.0].map(|g| {
        let model = systems::block(g);
        let mode = ContactMode::parse_names(&model, "left,right:slide").unwrap();
        reset_work_counters();
        let exec = released(&model, mode, &[0.0, -BLOCK.1 / 2.0, 0.0], 0.5, opts);
        assert_eq!(exec.events.len(), 0, "g = {g}: it stands");
        work_counters()
    });
    let [clear, zero] = &counts;
    assert_eq!(clear.accepted[0], 50, "{clear:?}");
    assert_eq!(
        (zero.accepted, zero.rhs_calls),
        (clear.accepted, clear.rhs_calls)
    );
    assert!(clear.solves[0] <= clear.rhs_calls[0], "{clear:?}");
    assert_eq!(zero.solves[0], clear.solves[0] + 50, "{zero:?} {clear:?}");
}
