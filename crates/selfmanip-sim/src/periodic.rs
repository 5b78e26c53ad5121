//! Periodic orbits of a scenario: [`selfmanip_hybrid::periodic`] run with the scenario's
//! robot, terrain and behaviour, its initial state the guess, and the search's options by
//! name ([`PeriodicSpec`], what `selfmanip.periodic_orbit` forwards); and the sensitivities
//! of a scenario's run ([`run_sensitivity`], what `simulate(..., sensitivity=True)` shows) and
//! its derivatives with respect to its behaviour's named parameters
//! ([`run_parameter_sensitivity`]).
//!
//! ```text
//! Scenario (guess = initial q, q̇; behaviour compiled there) + PeriodicSpec
//!   => Simulation::new => find_periodic_orbit(model, terrain, behaviour, guess, options)
//! ```
use crate::error::{invalid, non_negative, positive, SimError};
use crate::scenario::{Scenario, Simulation};
use crate::trajectory::q_names;
use nalgebra::DMatrix;
use selfmanip_core::tangent::TangentError;
use selfmanip_core::Model;
use selfmanip_hybrid::periodic::{
    find_periodic_orbit, PeriodicError, PeriodicOptions, PeriodicOrbit,
};
use selfmanip_hybrid::sensitivity::{
    execution_sensitivity, execution_sensitivity_columns, EventSensitivity, Parameter,
    SaltationStatus, Sensitivity, SensitivityError,
};
use selfmanip_hybrid::ControllerPartials;
use selfmanip_hybrid::{EventKind, Termination};
use serde::{Deserialize, Serialize};

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
            let all = q_names(model);
            let mut idx = Vec::new();
            for (i, n) in names.iter().enumerate() {
                let k = all.iter().position(|a| a == n).ok_or_else(|| {
                    invalid(
                        format!("cyclic[{i}]"),
                        format!("no coordinate `{n}` (coordinates: {})", all.join(", ")),
                    )
                })?;
                idx.push(k);
            }
            o.cyclic = Some(idx);
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
/// ([`selfmanip_hybrid::sensitivity::execution_sensitivity`]), with an apex recorded on the
/// way (a run that does not stop there) flagged [`SaltationStatus::Unsupported`] and the
/// state Jacobian withheld: the engine salts every apex as a terminal one (`I − f D_xg /
/// (D_xg f)`, which zeroes `ż`'s row), while the flow goes on unchanged through it (its
/// saltation is the identity) — a wrong number, not returned. A behaviour that remembers
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
    let mut s = match execution_sensitivity(&run.model, &run.terrain, exec) {
        Ok(s) => s,
        // a situation the tangent does not cover yet, somewhere along the run: said on every
        // event, the run itself kept
        Err(SensitivityError::Tangent(
            e @ (TangentError::TurningFrame { .. } | TangentError::FrictionAtRest { .. }),
        )) => return Ok(not_formed(exec, &e.to_string())),
        Err(e) => return Err(e),
    };
    let terminal = exec.termination == Termination::Apex;
    let n = s.events.len();
    for (i, e) in s.events.iter_mut().enumerate() {
        if e.kind == EventKind::Apex && !(terminal && i + 1 == n) {
            e.status = SaltationStatus::Unsupported {
                reason: "an apex recorded on the way is salted as a terminal one by the engine \
                         (docs/periodic-orbits.md, known limits)"
                    .into(),
            };
            e.saltation = None;
            e.time_gradient = None;
            s.state_jacobian = None;
        }
    }
    Ok(s)
}

/// A run's final state differentiated with respect to named parameters of its behaviour
/// ([`run_parameter_sensitivity`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterSensitivity {
    /// `d(q, q̇)(T)/dp`, `2nq × k` (one column per name, in order); `None` when not formed
    /// (see [`Self::reason`]).
    pub state: Option<DMatrix<f64>>,
    /// Each event's `dt_e/dp` (`k` entries), `None` where its saltation is not defined.
    pub event_times: Vec<Option<Vec<f64>>>,
    /// Why [`Self::state`] is `None`.
    pub reason: Option<String>,
}

/// The derivatives of `run`'s final state with respect to the behaviour parameters `names`
/// (the `[parameters]` table: `kp_push`, `t2`, `gear_ratio`, …): the behaviour's exact
/// parameter partials carried through every event
/// ([`selfmanip_hybrid::sensitivity::execution_sensitivity_columns`]). Not formed (with the
/// reason) for a run cut by its budget or stopped, where an event's saltation is not defined,
/// and past an apex recorded on the way (see [`run_sensitivity`]). A name the behaviour does
/// not have is [`SensitivityError::UnknownParameter`] naming that name alone.
pub fn run_parameter_sensitivity(
    run: &crate::Run,
    names: &[&str],
) -> Result<ParameterSensitivity, SensitivityError> {
    let exec = &run.execution;
    let unformed = |reason: String| ParameterSensitivity {
        state: None,
        event_times: vec![None; exec.events.len()],
        reason: Some(reason),
    };
    match exec.termination {
        Termination::StepBudget { t, steps } => {
            return Ok(unformed(format!(
                "the run ended on its step budget ({steps} steps, at t = {t} s)"
            )))
        }
        Termination::Interrupted { t } => {
            return Ok(unformed(format!("the run was stopped at t = {t} s")))
        }
        _ => {}
    }
    let params: Vec<Parameter> = names
        .iter()
        .map(|n| Parameter::Controller((*n).to_string()))
        .collect();
    let n2 = 2 * run.model.nq();
    let s = match execution_sensitivity_columns(
        &run.model,
        &run.terrain,
        exec,
        &DMatrix::zeros(n2, 0),
        &params,
    ) {
        Ok(s) => s,
        Err(SensitivityError::UnknownParameter { name, t }) => {
            let name = unknown_name(run, names).map_or(name, str::to_string);
            return Err(SensitivityError::UnknownParameter { name, t });
        }
        Err(SensitivityError::Tangent(
            e @ (TangentError::TurningFrame { .. } | TangentError::FrictionAtRest { .. }),
        )) => return Ok(unformed(e.to_string())),
        Err(e) => return Err(e),
    };
    let event_times = s
        .event_time_columns
        .iter()
        .map(|c| c.as_ref().map(|c| c.iter().copied().collect()))
        .collect();
    let last = exec.events.len().saturating_sub(1);
    let reason = if let Some(e) = s
        .events
        .iter()
        .find(|e| e.status != SaltationStatus::Defined)
    {
        Some(format!(
            "{} at t = {} s: {}",
            e.kind.name(),
            e.t,
            e.status.name()
        ))
    } else if let Some(i) = exec.events.iter().position(|e| e.kind == EventKind::Apex) {
        (i != last || exec.termination != Termination::Apex).then(|| {
            "an apex recorded on the way is salted as a terminal one by the engine".to_string()
        })
    } else {
        None
    };
    Ok(match (reason, s.columns) {
        (None, Some(x)) => ParameterSensitivity {
            state: Some(x),
            event_times,
            reason: None,
        },
        (reason, _) => ParameterSensitivity {
            state: None,
            event_times,
            reason: Some(reason.unwrap_or_else(|| "not defined along the run".into())),
        },
    })
}

/// The first of `names` that the run's first controller does not know (its
/// [`selfmanip_hybrid::Controller::parameter_partials`] refuses it alone).
fn unknown_name<'a>(run: &crate::Run, names: &[&'a str]) -> Option<&'a str> {
    let seg = run.execution.segments.first()?;
    let (n, nq) = (run.model.n_joints(), run.model.nq());
    let (q, qd) = seg.y0.split_at(nq);
    names.iter().copied().find(|name| {
        let mut out = ControllerPartials::with_parameters(n, nq, 0, 1);
        !seg.controller
            .parameter_partials(seg.t0, q, qd, seg.mode, &[], &[name], &mut out)
    })
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
            })
            .collect(),
        touch_switches: Vec::new(),
        feature_changes: Vec::new(),
        state_jacobian: None,
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
