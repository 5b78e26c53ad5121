//! Helpers shared by the RHex tests (these and the workspace's `tests/leap_sensitivity.rs`
//! and `tests/rhex_results.rs`): tight leaps for derivatives against differences of whole
//! leaps, an execution's state at a time, the core's solves on flat ground, the default leap
//! beside a variant's, an execution's events of one kind and a flight from rest.
#![allow(dead_code)]
use nalgebra::DMatrix;
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LeapResult};
use rhex_model::RhexParams;
use selfmanip_core::quasistatic::{quasi_static, QuasiStatic};
use selfmanip_core::reduced::{reduced_dynamics, ReducedDynamics};
use selfmanip_core::{forward_dynamics, ContactMode, Data, FlatGround, Model};
use selfmanip_hybrid::{simulate, Controller, Event, EventKind, Execution, HybridOptions};
use selfmanip_sim::terrain::TerrainSpec;

/// A leap with tight tolerances, so that central differences of whole leaps resolve 1e-6
/// (as `tests/leap_sensitivity.rs` of the workspace), under the sensitivities' step control
/// of the free legs.
pub fn tight(strategy: &str, t2: f64) -> LeapConfig {
    LeapConfig {
        strategy: strategy.parse().unwrap(),
        t2_s: t2,
        rtol: 1e-12,
        event_tol_s: 1e-14,
        control_free_joints: true,
        ..LeapConfig::default()
    }
}

/// A leap run past its apex to 1.5 s at a ledge `h` high whose face is at `x = d`.
pub fn at_ledge(h: f64, d: f64) -> LeapConfig {
    LeapConfig {
        terrain: TerrainSpec::Ledge {
            height_m: h,
            distance_m: d,
        },
        stop_at_apex: false,
        t_final_s: 1.5,
        ..LeapConfig::default()
    }
}

/// The worst relative disagreement of `exact` (`d apex_z`, `d apex_φ`, `d apex_x` over one
/// parameter) with central differences of whole leaps `leap(±h)`, taking for each column the
/// best of `steps` (relative to `max(|fd|, floor)`).
pub fn apex_error(
    exact: [f64; 3],
    steps: &[f64],
    floor: f64,
    leap: impl Fn(f64) -> rhex_model::leap::Apex,
) -> f64 {
    let at = |h: f64| {
        let (a, b) = (leap(h), leap(-h));
        [
            (a.z_m - b.z_m) / (2.0 * h),
            (a.phi_rad - b.phi_rad) / (2.0 * h),
            (a.x_m - b.x_m) / (2.0 * h),
        ]
    };
    let fds: Vec<[f64; 3]> = steps.iter().map(|&h| at(h)).collect();
    (0..3)
        .map(|c| {
            fds.iter()
                .map(|fd| {
                    eprintln!("  exact {:.9e}, fd {:.9e}", exact[c], fd[c]);
                    (exact[c] - fd[c]).abs() / fd[c].abs().max(floor)
                })
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

/// The state `(q, q̇)` of `exec` at `t` into `y`, from the last segment with steps that spans
/// `t` (after an event at `t`, the state after it).
pub fn state_at(exec: &Execution, t: f64, y: &mut [f64]) {
    exec.segments
        .iter()
        .rev()
        .find(|g| g.t0 <= t && t <= g.t1 && !g.dense.is_empty())
        .expect("a segment")
        .eval(t, y);
}

/// [`forward_dynamics`] on flat ground, no free-joint motion prescribed: `q̈` and `λ` land in
/// `data.qdd` and `data.lambda`.
pub fn flat_dynamics(
    model: &Model,
    data: &mut Data,
    mode: ContactMode,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) {
    forward_dynamics(model, data, &FlatGround, mode, q, qd, tau, None).unwrap();
}

/// [`reduced_dynamics`] on flat ground with the coordinate map `y`.
pub fn flat_reduced(
    model: &Model,
    data: &mut Data,
    mode: ContactMode,
    (q, qd): (&[f64], &[f64]),
    tau: &[f64],
    y: &DMatrix<f64>,
) -> ReducedDynamics {
    reduced_dynamics(model, data, &FlatGround, mode, q, qd, tau, y).unwrap()
}

/// [`quasi_static`] on flat ground with the torque constraints `t`.
pub fn flat_quasi_static(
    model: &Model,
    data: &mut Data,
    mode: ContactMode,
    q: &[f64],
    t: &DMatrix<f64>,
) -> QuasiStatic {
    quasi_static(model, data, &FlatGround, mode, q, t).unwrap()
}

/// The default leap of chapters 3 and 5 and the same leap of [`leap_params`] changed by
/// `change` (a variant that should leap alike).
pub fn default_leap_and(change: impl FnOnce(&mut RhexParams)) -> (LeapResult, LeapResult) {
    let cfg = LeapConfig::default();
    let mut params = leap_params();
    change(&mut params);
    let run = |p: &RhexParams| simulate_leap(p, &cfg).unwrap();
    (run(&leap_params()), run(&params))
}

/// The events of `exec` of kind `kind`, in order.
pub fn events_of(exec: &Execution, kind: EventKind) -> Vec<&Event> {
    exec.events.iter().filter(|e| e.kind == kind).collect()
}

/// The execution of `model` under `ctrl` from rest at `q0` in flight over flat ground to
/// `t_final` (default options), checked to meet no event.
pub fn flight(model: &Model, ctrl: &dyn Controller, q0: &[f64], t_final: f64) -> Execution {
    let (mode, qd0) = (ContactMode::FLIGHT, vec![0.0; q0.len()]);
    let options = HybridOptions::default();
    let exec = simulate(model, &FlatGround, ctrl, mode, q0, &qd0, t_final, options).unwrap();
    assert!(exec.events.is_empty(), "a flight: {:?}", exec.events);
    exec
}

/// The step `(t, Δz, Δφ)` of `steps` (neighbouring points of a sweep) whose `Δz` rises most,
/// the first of equals (`(0, −∞, 0)` for none).
pub fn largest_rise(steps: &[(f64, f64, f64)]) -> (f64, f64, f64) {
    let start = (0.0, f64::NEG_INFINITY, 0.0);
    (steps.iter().copied()).fold(start, |a, s| if s.1 > a.1 { s } else { a })
}
