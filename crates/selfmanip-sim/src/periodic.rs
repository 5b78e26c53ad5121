//! Periodic orbits of a scenario: [`selfmanip_hybrid::periodic`] run with the scenario's
//! robot, terrain and behaviour, its initial state the guess, and the search's options by
//! name ([`PeriodicSpec`], what `selfmanip.periodic_orbit` forwards); and the sensitivities
//! of a scenario's run ([`run_sensitivity`], what `simulate(..., sensitivity=True)` shows) and
//! its derivatives with respect to its behaviour's named parameters
//! ([`run_parameter_sensitivity`], in [`crate::sensitivity`]).
//!
//! ```text
//! Scenario (guess = initial q, q̇; behaviour compiled there) + PeriodicSpec
//!   => Simulation::new => find_periodic_orbit(model, terrain, behaviour, guess, options)
//! ```
use crate::error::{invalid, non_negative, positive, SimError};
use crate::scenario::{Scenario, Simulation};
use crate::trajectory::coordinate_indices;
use selfmanip_core::tangent::TangentError;
use selfmanip_core::Model;
use selfmanip_hybrid::periodic::{
    find_periodic_orbit, PeriodicError, PeriodicOptions, PeriodicOrbit,
};
use selfmanip_hybrid::sensitivity::{
    execution_sensitivity, EventSensitivity, SaltationStatus, Sensitivity, SensitivityError,
};
use selfmanip_hybrid::Termination;
use serde::{Deserialize, Serialize};

pub use crate::sensitivity::{run_parameter_sensitivity, ParameterSensitivity};

/// The options of a periodic-orbit search by name; every field absent keeps
/// [`PeriodicOptions::default`]'s value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct PeriodicSpec {
    /// `|P(x) − x|∞` at convergence.
    pub tol: Option<f64>,
    pub max_iterations: Option<usize>,
    pub max_halvings: Option<usize>,
    /// Return runs of the whole search.
    pub max_runs: Option<usize>,
    pub rank_rtol: Option<f64>,
    pub unit_circle_tol: Option<f64>,
    /// A return run longer than this fails (s).
    pub max_period_s: Option<f64>,
    /// Cyclic coordinates by name (`x`, `phi`, `leg[0]_theta`…; default `["x"]`).
    pub cyclic: Option<Vec<String>>,
    /// Integration and event tolerances of the return runs.
    pub rtol: Option<f64>,
    pub atol: Option<f64>,
    pub event_tol_s: Option<f64>,
    /// Pseudo-impulse duration δt of (5.39) (s).
    pub delta_t_s: Option<f64>,
}

impl PeriodicSpec {
    /// The engine's options for `model` (cyclic names resolved; errors name the field).
    pub fn options(&self, model: &Model) -> Result<PeriodicOptions, SimError> {
        let mut o = PeriodicOptions::default();
        macro_rules! set {
            ($($f:ident),*) => { $( if let Some(v) = self.$f { o.$f = v; } )* };
        }
        set!(
            tol,
            max_iterations,
            max_halvings,
            max_runs,
            rank_rtol,
            unit_circle_tol,
            max_period_s
        );
        if let Some(v) = self.rtol {
            o.hybrid.step.rtol = positive("rtol", v)?;
        }
        if let Some(v) = self.atol {
            o.hybrid.step.atol = positive("atol", v)?;
        }
        if let Some(v) = self.event_tol_s {
            o.hybrid.event_tol_s = positive("event_tol_s", v)?;
        }
        if let Some(v) = self.delta_t_s {
            o.hybrid.delta_t_s = non_negative("delta_t_s", v)?;
        }
        if let Some(names) = &self.cyclic {
            o.cyclic = Some(coordinate_indices(model, "cyclic", names)?);
        }
        Ok(o)
    }
}

/// Why a scenario's periodic orbit was not found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PeriodicRunError {
    /// The scenario or the options (the field is named).
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error(transparent)]
    Periodic(#[from] PeriodicError),
}

/// The periodic orbit through the apex section near the scenario's initial state (which must
/// be in flight: no initial contacts), with the simulation it was searched with.
pub fn periodic_orbit(
    scenario: &Scenario,
    spec: &PeriodicSpec,
) -> Result<(Simulation, PeriodicOrbit), PeriodicRunError> {
    if !scenario.initial.contacts.is_empty() {
        return Err(invalid(
            "initial.contacts",
            "the apex section is in flight: the guess has no active contacts",
        )
        .into());
    }
    let sim = Simulation::new(scenario)?;
    let opts = spec.options(&sim.model)?;
    let guess: Vec<f64> = sim.q0.iter().chain(&sim.qd0).copied().collect();
    let orbit = find_periodic_orbit(&sim.model, &sim.terrain, &*sim.controller, &guess, &opts)?;
    Ok((sim, orbit))
}

/// The sensitivities of a run to its initial state
/// ([`selfmanip_hybrid::sensitivity::execution_sensitivity`]); an apex passed on the way is
/// no reset (its saltation the identity, its time's gradient given). A behaviour that remembers
/// events (motions started at them, phases a delay after them) has that memory
/// differentiated (`docs/sensitivity.md`, "A controller's memory of events"); one whose
/// memory is not differentiated is a typed error
/// ([`SensitivityError::EventMemoryWithoutPartials`]). A run cut by its step budget or
/// stopped from outside has none: it ends where its work ran out, not at a time of the model,
/// and carrying the tangent over its budget's steps would cost some ten times the run (every
/// event [`SaltationStatus::Unsupported`] with the reason, no state Jacobian). So has a run
/// along which the tangent meets a situation it does not cover yet (a contact on a terrain
/// corner, a sliding contact's friction at rest: [`TangentError`]); it was an error that
/// took the run with it.
pub fn run_sensitivity(run: &crate::Run) -> Result<Sensitivity, SensitivityError> {
    let exec = &run.execution;
    let cut = match exec.termination {
        Termination::StepBudget { t, steps } => Some(format!(
            "the run ended on its step budget ({steps} steps, at t = {t} s)"
        )),
        Termination::Interrupted { t } => Some(format!("the run was stopped at t = {t} s")),
        _ => None,
    };
    if let Some(reason) = cut {
        return Ok(not_formed(exec, &reason));
    }
    match execution_sensitivity(&run.model, &run.terrain, exec) {
        Ok(s) => Ok(s),
        // a situation the tangent does not cover yet, somewhere along the run: said on every
        // event, the run itself kept
        Err(SensitivityError::Tangent(
            e @ (TangentError::TurningFrame { .. } | TangentError::FrictionAtRest { .. }),
        )) => Ok(not_formed(exec, &e.to_string())),
        Err(e) => Err(e),
    }
}

/// The sensitivities of `exec` when none are formed: every event unsupported for `reason`.
fn not_formed(exec: &selfmanip_hybrid::Execution, reason: &str) -> Sensitivity {
    Sensitivity {
        segment_flows: Vec::new(),
        events: exec
            .events
            .iter()
            .map(|e| EventSensitivity {
                t: e.t,
                kind: e.kind,
                status: SaltationStatus::Unsupported {
                    reason: reason.to_string(),
                },
                saltation: None,
                guard_gradient: None,
                time_gradient: None,
                impact_mode: None,
                one_sided: Vec::new(),
            })
            .collect(),
        touch_switches: Vec::new(),
        feature_changes: Vec::new(),
        state_jacobian: None,
        one_sided_state_jacobian: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use selfmanip_core::RobotDescription;

    fn hopper() -> Model {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/hopper.toml");
        RobotDescription::from_file(&p).unwrap().build().unwrap()
    }

    /// Every field of the spec reaches the engine's options (each set to a value unlike its
    /// default), cyclic names resolve to their coordinates, and a bad one names its field.
    #[test]
    fn every_spec_field_reaches_the_options() {
        let m = hopper();
        let spec = PeriodicSpec {
            tol: Some(2e-8),
            max_iterations: Some(7),
            max_halvings: Some(3),
            max_runs: Some(11),
            rank_rtol: Some(1e-6),
            unit_circle_tol: Some(1e-3),
            max_period_s: Some(2.5),
            cyclic: Some(vec!["x".into(), "phi".into()]),
            rtol: Some(1e-9),
            atol: Some(1e-12),
            event_tol_s: Some(1e-12),
            delta_t_s: Some(0.01),
        };
        let o = spec.options(&m).unwrap();
        let d = PeriodicOptions::default();
        assert_eq!(
            (o.tol, o.max_iterations, o.max_halvings, o.max_runs),
            (2e-8, 7, 3, 11)
        );
        assert_eq!(
            (o.rank_rtol, o.unit_circle_tol, o.max_period_s),
            (1e-6, 1e-3, 2.5)
        );
        assert_eq!(o.cyclic, Some(vec![m.ix_x(), m.ix_phi()]));
        assert_eq!(
            (
                o.hybrid.step.rtol,
                o.hybrid.step.atol,
                o.hybrid.event_tol_s,
                o.hybrid.delta_t_s
            ),
            (1e-9, 1e-12, 1e-12, 0.01)
        );
        assert_ne!(o, d);
        assert_eq!(PeriodicSpec::default().options(&m).unwrap(), d);
        let bad = PeriodicSpec {
            cyclic: Some(vec!["x".into(), "y".into()]),
            ..PeriodicSpec::default()
        };
        match bad.options(&m) {
            Err(SimError::InvalidValue { field, .. }) => assert_eq!(field, "cyclic[1]"),
            other => panic!("{other:?}"),
        }
        let bad = PeriodicSpec {
            rtol: Some(-1.0),
            ..PeriodicSpec::default()
        };
        assert!(
            matches!(bad.options(&m), Err(SimError::InvalidValue { field, .. }) if field == "rtol")
        );
    }
}
