//! Absurd options and inputs end in a typed error, a budget status or a located event —
//! never a hang, a panic or a NaN blamed on the caller's inputs — and a run can be stopped
//! from outside.
mod systems;

use selfmanip_core::description::{FrictionDescription, LinkDescription};
use selfmanip_core::{ContactMode, CoreError, FlatGround, Model};
use selfmanip_hybrid::{
    simulate, simulate_with, Controller, HybridError, HybridOptions, Termination, ZeroTorque,
};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use systems::{body, free_fall_touchdown, one_link_leg, uniform_link, Friction, G};

/// A point mass on one frictionless foot, dropped from `d` above the ground.
fn ball() -> Model {
    body(1.0, 0.01, G, &[("foot", 0.0, 0.0, Friction::Slide)])
}

fn drop_from(
    d: f64,
    opts: HybridOptions,
    t_final: f64,
) -> Result<selfmanip_hybrid::Execution, HybridError> {
    simulate(
        &ball(),
        &FlatGround,
        &ZeroTorque,
        ContactMode::FLIGHT,
        &[0.0, -d, 0.0],
        &[0.0; 3],
        t_final,
        opts,
    )
}

/// `event_tol_s = 1e-308` is below the resolution of time: the location stops where the
/// bracket's ends are adjacent floating-point numbers, at the closed-form touchdown time
/// `√(2d/g)`, instead of looping for ever.
#[test]
fn event_tolerance_of_1e_minus_308_locates_the_closed_form_touchdown() {
    let d = 0.3;
    let opts = HybridOptions {
        event_tol_s: 1e-308,
        ..HybridOptions::default()
    };
    let exec = drop_from(d, opts, 1.0).unwrap();
    free_fall_touchdown(&exec, d);
    assert_eq!(exec.termination, Termination::FinalTime);
}

/// A run that needs more steps than its budget ends with `StepBudget` at the budget, having
/// kept what it computed.
#[test]
fn step_budget_ends_a_long_run_with_a_typed_status() {
    let opts = HybridOptions {
        max_steps: 50,
        ..HybridOptions::default()
    };
    // resting on the ground for 1e6 s: ~1e8 steps of h_max
    let exec = drop_from(0.0, opts, 1e6).unwrap();
    match exec.termination {
        Termination::StepBudget { t, steps } => {
            assert_eq!(steps, 50);
            assert_eq!(exec.steps, 50);
            assert!(t > 0.0 && t < 1.0, "{t}");
            assert_eq!(exec.t, t);
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        drop_from(
            0.0,
            HybridOptions {
                max_steps: 0,
                ..HybridOptions::default()
            },
            1.0
        ),
        Err(HybridError::InvalidOption {
            field: "max_steps",
            ..
        })
    ));
}

/// A controller that raises a stop flag once the run's clock passes `at`: the run ends
/// within one step of it with `Interrupted`.
#[derive(Clone)]
struct RaiseAt {
    at: f64,
    flag: Arc<AtomicBool>,
}

impl Controller for RaiseAt {
    fn torque(&self, t: f64, _q: &[f64], _qd: &[f64], _mode: ContactMode, _tau: &mut [f64]) {
        if t >= self.at {
            self.flag.store(true, Ordering::Relaxed);
        }
    }
}

#[test]
fn a_raised_stop_flag_interrupts_the_run_within_a_step() {
    // a ball dropped from 10 m, run to 10 s under `ctrl` until `stop` is raised
    let run = |ctrl: &dyn Controller, stop: &AtomicBool| {
        let (q, qd) = ([0.0, -10.0, 0.0], [0.0; 3]);
        let (mode, opts) = (ContactMode::FLIGHT, HybridOptions::default());
        simulate_with(&ball(), &FlatGround, ctrl, mode, &q, &qd, 10.0, opts, stop).unwrap()
    };
    let flag = Arc::new(AtomicBool::new(false));
    let ctrl = RaiseAt {
        at: 0.2,
        flag: flag.clone(),
    };
    let exec = run(&ctrl, &flag);
    match exec.termination {
        // h_max = 0.01 s
        Termination::Interrupted { t } => assert!((0.2..=0.2 + 0.01 + 1e-12).contains(&t), "{t}"),
        other => panic!("{other:?}"),
    }
    // raised before the start: no more than one step
    let exec = run(&ZeroTorque, &AtomicBool::new(true));
    assert!(matches!(exec.termination, Termination::Interrupted { .. }));
    assert_eq!(exec.steps, 1);
}

/// A controller whose torque is finite but absurd (1e300 N m): the accelerations and then
/// the integrated state overflow, and the engine reports the non-finite quantity it made,
/// not the caller's (finite) state.
#[derive(Clone)]
struct Overflowing;

impl Controller for Overflowing {
    fn torque(&self, _t: f64, _q: &[f64], _qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        tau.fill(1e300);
    }
}

#[test]
fn an_engine_made_overflow_is_not_blamed_on_the_state() {
    // one massive link (1 kg body, 0.1 kg link), no contact
    let link = LinkDescription {
        inertia_kg_m2: 0.001,
        com_m: None,
        ..uniform_link(0.2, 0.1)
    };
    let mut d = one_link_leg(1.0, 0.1, G, link, FrictionDescription::Sliding);
    d.contacts.clear();
    let model = d.build().unwrap();
    let e = simulate(
        &model,
        &FlatGround,
        &Overflowing,
        ContactMode::FLIGHT,
        &[0.0, 0.0, -1.0, 0.0],
        &[0.0; 4],
        1.0,
        HybridOptions::default(),
    )
    .unwrap_err();
    match &e {
        HybridError::Core(CoreError::NonFiniteResult { .. }) => {}
        other => panic!("{other:?}"),
    }
    assert!(!e.to_string().contains("`qd`"), "{e}");
}
