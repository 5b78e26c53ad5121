//! Helpers shared by the leap tests that compare derivatives with differences of whole leaps.
use rhex_model::leap::LeapConfig;

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
