//! Leaps and sweeps with absurd inputs (issue 16): each ends in a typed error, a budget status
//! or a fix — never a hang, a silent inf or a lost sweep — and a leap or a sweep can be
//! stopped from outside.
use rhex_model::leap::{leap_params, simulate_leap, simulate_leap_with, LeapConfig, Strategy};
use rhex_model::params::ToeSliding;
use rhex_model::sweep::{grid, sweep, sweep_with, LeapPoint};
use rhex_model::{RhexError, RhexParams};
use selfmanip_core::CoreError;
use selfmanip_hybrid::{HybridError, Termination};
use selfmanip_sim::RunStatus;
use serde_json::json;
use std::sync::atomic::AtomicBool;

fn leap(cfg: &LeapConfig) -> rhex_model::leap::LeapResult {
    simulate_leap(&leap_params(), cfg).unwrap()
}

/// `event_tol_s = 1e-308` (below the resolution of time): the leap locates its events to
/// adjacent floating-point times and reaches the apex of the default leap (1e-10 s).
#[test]
fn event_tol_of_1e_minus_308_leaps_like_the_default() {
    let fine = leap(&LeapConfig::default());
    let r = leap(&LeapConfig {
        event_tol_s: 1e-308,
        ..LeapConfig::default()
    });
    assert!(r.flew);
    let (a, b) = (r.apex.unwrap(), fine.apex.unwrap());
    assert!((a.z_m - b.z_m).abs() < 1e-6 && (a.phi_rad - b.phi_rad).abs() < 1e-6);
    assert_eq!(r.word, fine.word);
}

/// `m_l = 1e308`: finite, but the leg's weight overflows — a typed error naming what
/// overflowed (not a non-finite `qd`, which the caller never gave), at the first evaluation.
#[test]
fn leg_mass_of_1e308_is_a_typed_overflow_error() {
    // a massive leg, its toes sliding without friction (the folded Coulomb friction of a
    // massive leg's toe would meet the same overflow)
    let params = RhexParams {
        m_l: 1e308,
        toe_sliding: ToeSliding::Frictionless,
        ..leap_params()
    };
    // the simulator refuses the start whose mass matrix overflows before the first step (or
    // the first evaluation meets the overflow): typed, naming what overflowed
    match simulate_leap(&params, &LeapConfig::default()) {
        Err(e @ RhexError::StartOverflow { .. }) => {
            // the parameter that overflows, not `params`
            assert_eq!(e.field(), Some("m_l"));
            assert!(e.to_string().contains("overflows"), "{e}");
        }
        Err(e @ RhexError::Hybrid(HybridError::Core(CoreError::NonFiniteResult { .. }))) => {
            assert!(!e.to_string().contains("`qd`"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    // in a sweep: a row of its own, the others untouched
    let mut bad = LeapPoint::new(Strategy::ALL[0], 0.0, None);
    bad.overrides.insert("m_l".into(), json!(1e308));
    bad.overrides
        .insert("toe_sliding".into(), json!("frictionless"));
    let good = LeapPoint::new(Strategy::ALL[0], 0.0, None);
    let rows = sweep(
        &leap_params(),
        &LeapConfig::default(),
        &[good.clone(), bad, good],
        2,
    )
    .unwrap();
    assert_eq!(rows[1].status, "invalid_params");
    assert_eq!(rows[0].status, "apex");
    assert!(rows[0].flew);
    assert_eq!(rows[0], rows[2]);
}

/// `t_final_s = 1e6` without stopping at the apex: the robot lands and rests, and the run
/// ends at its step budget (`step_budget`) instead of integrating 1e6 s; the apex of its
/// flight is reported all the same.
#[test]
fn t_final_of_1e6_without_stopping_at_apex_ends_at_its_step_budget() {
    let cfg = LeapConfig {
        t_final_s: 1e6,
        stop_at_apex: false,
        ..LeapConfig::default()
    };
    let r = leap(&cfg);
    assert_eq!(r.status, RunStatus::StepBudget);
    assert!(matches!(
        r.execution.termination,
        Termination::StepBudget { .. }
    ));
    assert_eq!(r.execution.steps, cfg.max_steps);
    assert!(r.apex.is_some());
    // the budget is a parameter: a smaller one ends sooner
    let r = leap(&LeapConfig {
        max_steps: 100,
        ..cfg.clone()
    });
    assert_eq!((r.status, r.execution.steps), (RunStatus::StepBudget, 100));
    // and says so in words, with the budget and the instant on the leap's clock (it read
    // `StepBudget { t: …, steps: 100 }`, the enum's debug form)
    let Termination::StepBudget { t, .. } = r.execution.termination else {
        unreachable!()
    };
    let why = r.reason();
    assert!(
        why.contains("step budget (max_steps: 100 accepted steps)"),
        "{why}"
    );
    assert!(
        why.contains(&format!("t = {:.6} s", t - r.time_offset_s)),
        "{why}"
    );
    assert!(!why.contains('{'), "{why}");
    assert!(matches!(
        simulate_leap(&leap_params(), &LeapConfig { max_steps: 0, ..cfg }),
        Err(RhexError::InvalidValue { field, .. }) if field == "max_steps"
    ));
}

/// The default leap of `strategy` at t2 = −0.02 s (Fig. 5.8's timing; every strategy flies).
fn at_fig_5_8_timing(strategy: Strategy) -> LeapConfig {
    LeapConfig {
        strategy,
        t2_s: -0.02,
        ..LeapConfig::default()
    }
}

/// Not stopping at the apex, a leap records the apex of its first flight as an event and
/// reports it: the same apex as the leap that stops there (the flows agree up to it). At
/// t2 = −0.02 s (Fig. 5.8's timing) every strategy's default leap flies.
#[test]
fn stop_at_apex_false_reports_the_apex_of_the_first_flight() {
    for s in Strategy::ALL {
        let cfg = at_fig_5_8_timing(s);
        let stopped = leap(&cfg);
        let on = leap(&LeapConfig {
            stop_at_apex: false,
            ..cfg
        });
        assert!(stopped.flew, "{s}");
        assert!(on.flew, "{s}");
        assert_eq!(on.apex, stopped.apex, "{s}");
        assert!(on.events.iter().any(|e| e.kind == "apex"));
    }
}

/// `event_tol_s = 1e-3` or `rtol = 1e-3` on flat ground: a touchdown located coarsely is up
/// to `|ȧ| event_tol_s` below the ground and an active contact drifts off it by the
/// integration error — neither is a step of the terrain (nor is a contact released a little
/// below the ground by such a touchdown, which comes back from there). The leaps reach the
/// apex of the default leap to a few millimetres (2 cm at the coarse rtol) and degrees, at
/// t2 = −0.02 s (every
/// strategy flies there) — except (+,+) at `rtol = 1e-3`: with Coulomb toes its leap has
/// two outcomes, 34 cm and 24 cm, and which one a tolerance gives is not monotone in it
/// (1e-8, 1e-7, 1e-4: 34 cm; 1e-6, 1e-5, 1e-3: 24 cm; `docs/leap-model.md`, "Tolerances"), so only its
/// status is checked there. And (−,−) at `event_tol_s = 1e-3`: its leap reaches 52.6 cm at
/// −153° for every rtol from 1e-9 to 1e-3 and every t2 from −0.0205 to −0.018 s at the
/// default event tolerance, and for event tolerances up to 1e-4 s; from 1.5e-4 s on, the
/// front toe's stick at 0.0534 s is located up to 0.2 ms late, the state that follows
/// differs (0.3 rad/s in the rear leg's rate at its liftoff), and the toe's later slip
/// (0.173 s) lets it go instead of sliding: it touches down again 3 ms later and leaves
/// again (word `…-0100-0000-0100-0000`, 55 cm at −194°). That outcome belongs to the event
/// location, not to the model (issue 16; `docs/decisions/2026-11-24-one-retraction-per-leg.md`),
/// so there its word is checked to be the fine one with that one extra touch.
#[test]
fn coarse_event_tolerance_and_rtol_still_leap_on_flat_ground() {
    for s in Strategy::ALL {
        let base = at_fig_5_8_timing(s);
        let fine = leap(&base).apex.unwrap();
        for cfg in [
            LeapConfig {
                event_tol_s: 1e-3,
                ..base.clone()
            },
            LeapConfig {
                rtol: 1e-3,
                ..base.clone()
            },
        ] {
            let r = leap(&cfg);
            assert!(r.flew, "{s} {r:?}", r = r.word_string());
            let a = r.apex.unwrap();
            if s == Strategy::ALL[0] && cfg.rtol == 1e-3 {
                continue; // the two-outcome leap (doc comment)
            }
            let fine_word = leap(&base).word_string();
            if s == Strategy::ALL[3] && cfg.event_tol_s == 1e-3 && r.word_string() != fine_word {
                // the (−,−) leap's second outcome at a coarse event tolerance (doc comment):
                // the same modes up to the flight, then the front toe once more on the ground
                assert_eq!(r.word_string(), format!("{fine_word}-0100-0000"), "{s}");
                continue;
            }
            // an apex within a few millimetres at the coarse event tolerance, within 2 cm at
            // the coarse rtol (its relative error over a leap of half a metre and more)
            let tol = if cfg.rtol == 1e-3 { 2e-2 } else { 5e-3 };
            assert!(
                (a.z_m - fine.z_m).abs() < tol,
                "{s}: {} vs {}",
                a.z_m,
                fine.z_m
            );
            assert!((a.phi_rad - fine.phi_rad).abs() < 0.05, "{s}");
        }
    }
}

/// Round-off of a kinetic energy evaluated twice is reported as no loss: over a `t2` sweep of
/// every strategy no touchdown reports a negative loss, and the zero-speed touchdown of a leg
/// placed on the ground from rest reports exactly zero.
#[test]
fn touchdown_energy_loss_is_never_negative_round_off() {
    for s in Strategy::ALL {
        for k in 0..9 {
            let r = leap(&LeapConfig {
                strategy: s,
                t2_s: -0.2 + 0.05 * k as f64,
                ..LeapConfig::default()
            });
            for e in r.events.iter().filter(|e| e.kind == "touchdown") {
                assert!(e.energy_loss_j >= 0.0, "{s} {:?}", e);
            }
        }
    }
}

/// A raised stop flag ends a leap within one step (`interrupted`), and a sweep whose flag is
/// raised returns every point, each `interrupted` (none lost, none run).
#[test]
fn stop_flag_interrupts_leaps_and_sweeps() {
    let raised = AtomicBool::new(true);
    let r = simulate_leap_with(&leap_params(), &LeapConfig::default(), &raised).unwrap();
    assert_eq!(r.status, RunStatus::Interrupted);
    assert!(r.execution.steps <= 1);
    // timings at which every strategy flies: rows without an apex hold NaN, never equal
    let points = grid(&Strategy::ALL, &[-0.02, 0.1], &[None]);
    let rows = sweep_with(&leap_params(), &LeapConfig::default(), &points, 2, &raised).unwrap();
    assert_eq!(rows.len(), points.len());
    assert!(rows.iter().all(|r| r.status == "interrupted"), "{rows:?}");
    let lowered = AtomicBool::new(false);
    let rows = sweep_with(&leap_params(), &LeapConfig::default(), &points, 2, &lowered).unwrap();
    assert_eq!(
        rows,
        sweep(&leap_params(), &LeapConfig::default(), &points, 2).unwrap()
    );
}

/// A point whose step budget runs out is a `step_budget` row of its own; the sweep keeps
/// every other point as it is alone.
#[test]
fn a_sweep_reports_step_budget_per_point_and_keeps_the_good_points() {
    let mut starved = LeapPoint::new(Strategy::ALL[1], 0.05, Some(40.0));
    starved.overrides.insert("max_steps".into(), json!(30));
    let good = grid(&Strategy::ALL, &[-0.02], &[Some(28.0)]);
    let mut points = good.clone();
    points.insert(2, starved);
    let rows = sweep(&leap_params(), &LeapConfig::default(), &points, 2).unwrap();
    assert_eq!(rows[2].status, "step_budget");
    let alone = sweep(&leap_params(), &LeapConfig::default(), &good, 1).unwrap();
    assert_eq!([&rows[..2], &rows[3..]].concat(), alone);
}

/// `gear_ratio = 1e308` (issue 31: `leap --gear-ratio=1e308`): finite, but the drive's
/// reflected rotor inertia `n J G²` overflows — a typed error naming `gear_ratio`, not the
/// servo gain the behaviour derives from it; the largest ratio whose drive stays finite
/// (`G²` finite) still builds.
#[test]
fn gear_ratio_of_1e308_names_the_gear_ratio() {
    let geared = |g: f64| LeapConfig {
        actuator: rhex_model::leap::X_RHEX_LEG.at_gear_ratio(g),
        ..LeapConfig::default()
    };
    match simulate_leap(&leap_params(), &geared(1e308)) {
        Err(e) => {
            assert_eq!(e.field(), Some("gear_ratio"), "{e}");
            assert!(e.to_string().contains("not finite"), "{e}");
        }
        Ok(r) => panic!("a leap at G = 1e308 ran: {:?}", r.status),
    }
    // 1e150: G² = 1e300 is finite, so the drive builds; whatever the leap does then, it
    // does not blame the gear ratio's drive
    if let Err(e) = simulate_leap(&leap_params(), &geared(1e150)) {
        assert!(!e.to_string().contains("reflected rotor inertia"), "{e}");
    }
}
