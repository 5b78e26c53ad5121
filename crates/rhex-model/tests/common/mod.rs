//! Helpers shared by the leap tests: tight leaps for derivatives against differences of whole
//! leaps, and an execution's state at a time.
#![allow(dead_code)]
use rhex_model::leap::LeapConfig;
use selfmanip_hybrid::Execution;

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
