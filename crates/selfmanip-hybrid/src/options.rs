//! The options of an execution, checked once before it starts.
use crate::error::HybridError;
use crate::integrate::StepOptions;
use std::cmp::Ordering;

/// The default step budget of a run: a leap takes a few hundred accepted steps, a
/// thousand-step run of the robots in this repository is rare; this bounds a run that
/// crawls to a few tens of milliseconds and a few megabytes of dense output.
pub const DEFAULT_MAX_STEPS: usize = 20_000;

/// The default fold threshold `ε` of the pin ([`crate::fold`]): the flow stops within
/// `asin(ε) ≈ 0.6°` of the fold.
pub const DEFAULT_FOLD_THRESHOLD: f64 = 1e-2;

/// The default pin at which a leg whose torque falls with speed meets its fold guard and
/// passes the fold locked ([`crate::reset_workspace::ResetWorkspace::passage`]): `asin(0.1) ≈ 5.7°` either side.
pub const DEFAULT_PASSAGE_THRESHOLD: f64 = 0.1;

/// Options of an execution.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HybridOptions {
    pub step: StepOptions,
    /// Width of the bracket that locates a guard's zero (s).
    pub event_tol_s: f64,
    /// Pseudo-impulse duration δt of (5.39) (s). 0 takes its limit δt → 0⁺: the touching set
    /// lands in one impact and a contact left at rest is judged by force, at the resolution
    /// [`Self::rest_time_s`] ([`crate::complementarity`]).
    pub delta_t_s: f64,
    /// Zeno detection: more than `zeno_max_events` events within `zeno_window_s` is
    /// truncated, its mode held for a dwell of at least the window ([`crate::zeno`]); the
    /// run stops only where there is nothing to truncate.
    pub zeno_window_s: f64,
    pub zeno_max_events: usize,
    /// Total event budget: the run ends with [`crate::Termination::EventBudget`] at this
    /// many events.
    pub max_events: usize,
    /// Total budget of accepted integration steps: the run ends with
    /// [`crate::Termination::StepBudget`] at this many (see [`crate::budget`]).
    pub max_steps: usize,
    /// Stop at the first apex of a flight phase (otherwise every apex of a flight is recorded
    /// as an event, [`crate::EventKind::Apex`], and the run goes on).
    pub stop_at_apex: bool,
    /// A guard arms once it exceeds this margin (m for heights, N for forces).
    pub arm_margin: f64,
    /// The pin `ε` at which a contact's massless chain meets its fold guard, before the
    /// Lemma 5.1 singularity ([`crate::fold`]); in (0, 1).
    pub fold_threshold: f64,
    /// The pin at which a sliding leg whose torque falls with speed meets its fold guard and
    /// at which its passage through the fold ends ([`crate::fold`]); in
    /// [`Self::fold_threshold`], 1).
    pub passage_threshold: f64,
    /// Count free massless joints in the step-size control. Off by default: their smooth
    /// prescribed motions are followed with the steps the rest of the state needs (leaps are
    /// ~3× cheaper), at a tracking error of order 1e-5 rad in RHex's legs that moves with
    /// the step sequence. On, every coordinate is integrated to the tolerances — what
    /// finite differences of whole executions need to resolve 1e-5 of a derivative through
    /// a later touchdown of such a joint.
    #[serde(default)]
    pub control_free_joints: bool,
    /// Truncate at once a re-touch after a flight from rest shorter than
    /// [`Self::rest_time_s`] ([`crate::zeno::retouch_unresolved`]). Off here; on in a
    /// scenario's options (`selfmanip_sim::SimOptions`, what a user's run takes), off in
    /// the RHex leaps': on, it moves the compliant RHex leap's apex by centimetres in narrow
    /// bands of the leg's stiffness, and the calibration of
    /// `crates/rhex-model/tests/compliant_leap.rs` then falls into its second minimum
    /// (docs/decisions/2026-11-30-chatter-truncated.md).
    #[serde(default)]
    pub truncate_unresolved_flights: bool,
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
            max_steps: DEFAULT_MAX_STEPS,
            stop_at_apex: false,
            arm_margin: 1e-9,
            fold_threshold: DEFAULT_FOLD_THRESHOLD,
            passage_threshold: DEFAULT_PASSAGE_THRESHOLD,
            control_free_joints: false,
            truncate_unresolved_flights: false,
        }
    }
}

/// The smallest relative step tolerance [`HybridOptions`] accepts: half a unit in the last
/// place of a double is 1.1e-16, so a tighter one asks the steps for what rounding undoes.
pub const MIN_RTOL: f64 = 1e-16;

/// The widest event bracket [`HybridOptions::event_tol_s`] may ask for (s): wider, a
/// touchdown would be placed a visible part of a stride away from where it happens.
pub const MAX_EVENT_TOL_S: f64 = 1e-3;

impl HybridOptions {
    /// The shortest time between transitions that the run resolves (s): the Zeno window
    /// allows `zeno_max_events` in `zeno_window_s`, so transitions closer than this on
    /// average are a Zeno execution to it. At `delta_t_s = 0`, a contact that an impact would
    /// release for a flight shorter than this is at rest (`crate::complementarity`).
    pub fn rest_time_s(&self) -> f64 {
        self.zeno_window_s / self.zeno_max_events as f64
    }

    /// Checks the options of a run that ends at `t_final` (errors name the field).
    pub fn validate(&self, t_final: f64) -> Result<(), HybridError> {
        if self.event_tol_s.is_nan() || self.event_tol_s <= 0.0 {
            return Err(HybridError::InvalidOption {
                field: "event_tol_s",
                reason: "must be positive".into(),
            });
        }
        if self.event_tol_s > MAX_EVENT_TOL_S {
            return Err(HybridError::InvalidOption {
                field: "event_tol_s",
                reason: format!(
                    "must be at most {MAX_EVENT_TOL_S} s (an event located to a second is \
                     not located), got {}",
                    self.event_tol_s
                ),
            });
        }
        if !self.delta_t_s.is_finite() || self.delta_t_s < 0.0 {
            return Err(HybridError::InvalidOption {
                field: "delta_t_s",
                reason: "must be finite and non-negative".into(),
            });
        }
        for (field, n) in [
            ("max_steps", self.max_steps),
            ("max_events", self.max_events),
        ] {
            if n == 0 {
                return Err(HybridError::InvalidOption {
                    field,
                    reason: "must be at least 1".into(),
                });
            }
        }
        if !(self.fold_threshold > 0.0 && self.fold_threshold < 1.0) {
            return Err(HybridError::InvalidOption {
                field: "fold_threshold",
                reason: format!("must lie in (0, 1), got {}", self.fold_threshold),
            });
        }
        if !(self.passage_threshold >= self.fold_threshold && self.passage_threshold < 1.0) {
            return Err(HybridError::InvalidOption {
                field: "passage_threshold",
                reason: format!(
                    "must lie in [fold_threshold, 1), got {}",
                    self.passage_threshold
                ),
            });
        }
        // a relative tolerance of 1 lets a step's error be as large as the state itself; one
        // below MIN_RTOL no step of double precision arithmetic meets (the step collapses)
        if !(self.step.rtol >= MIN_RTOL && self.step.rtol < 1.0) {
            return Err(HybridError::InvalidOption {
                field: "rtol",
                reason: format!("must lie in [{MIN_RTOL:e}, 1), got {:e}", self.step.rtol),
            });
        }
        // a largest step below the smallest one ends the run at its first step
        if matches!(
            self.step.h_max_s.partial_cmp(&self.step.h_min_s),
            None | Some(Ordering::Less)
        ) {
            return Err(HybridError::InvalidOption {
                field: "h_max_s",
                reason: format!(
                    "must be at least the smallest step h_min_s = {:e} s, got {:e}",
                    self.step.h_min_s, self.step.h_max_s
                ),
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
