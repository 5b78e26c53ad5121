//! The options of an execution, checked once before it starts.
use crate::error::HybridError;
use crate::integrate::StepOptions;

/// Options of an execution.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HybridOptions {
    pub step: StepOptions,
    /// Width of the bracket that locates a guard's zero (s).
    pub event_tol_s: f64,
    /// Pseudo-impulse duration δt of (5.39) (s); 0 disables it.
    pub delta_t_s: f64,
    /// Zeno detection: more than `zeno_max_events` events within `zeno_window_s` stops the run.
    pub zeno_window_s: f64,
    pub zeno_max_events: usize,
    /// Total event budget.
    pub max_events: usize,
    /// Stop at the first apex of a flight phase.
    pub stop_at_apex: bool,
    /// A guard arms once it exceeds this margin (m for heights, N for forces).
    pub arm_margin: f64,
}

impl Default for HybridOptions {
    fn default() -> Self {
        HybridOptions {
            step: StepOptions::default(),
            event_tol_s: 1e-10,
            delta_t_s: 0.0,
            zeno_window_s: 0.01,
            zeno_max_events: 50,
            max_events: 10_000,
            stop_at_apex: false,
            arm_margin: 1e-9,
        }
    }
}

impl HybridOptions {
    /// Checks the options of a run that ends at `t_final` (errors name the field).
    pub fn validate(&self, t_final: f64) -> Result<(), HybridError> {
        if self.event_tol_s.is_nan() || self.event_tol_s <= 0.0 {
            return Err(HybridError::InvalidOption {
                field: "event_tol_s",
                reason: "must be positive".into(),
            });
        }
        if !self.delta_t_s.is_finite() || self.delta_t_s < 0.0 {
            return Err(HybridError::InvalidOption {
                field: "delta_t_s",
                reason: "must be finite and non-negative".into(),
            });
        }
        if !t_final.is_finite() {
            return Err(HybridError::InvalidOption {
                field: "t_final",
                reason: "must be finite".into(),
            });
        }
        Ok(())
    }
}
