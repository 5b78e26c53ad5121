//! Derivatives of a run with respect to named parameters and start-state directions, for any
//! robot: a preset's parameter is a weighted sum of the engine's
//! ([`selfmanip_hybrid::sensitivity::Parameter`]: a body's mass, a joint's armature, a
//! behaviour parameter), carried through every event by
//! [`execution_sensitivity_columns`]; what is left to the preset is which engine parameters
//! stand behind its names and how its reported quantities read the end state.
//!
//! Times are reported on the caller's clock: execution times minus `offset_s` (a leap's
//! clock starts at its front motor's start, not at the execution's).
use nalgebra::DMatrix;
use selfmanip_core::{Model, Terrain};
use selfmanip_hybrid::sensitivity::{
    execution_sensitivity_columns, ColumnSensitivity, Parameter, SaltationStatus, SensitivityError,
};
use selfmanip_hybrid::{EventKind, Execution};

/// One event's saltation matrix over `(q, q̇)`.
#[derive(Debug, Clone, PartialEq)]
pub struct EventSaltation {
    /// Time on the caller's clock (s).
    pub t_s: f64,
    /// `Defined`, or why the saltation is not.
    pub status: SaltationStatus,
    /// `Ξ` (`2nq × 2nq`) when defined.
    pub saltation: Option<DMatrix<f64>>,
}

/// The engine's parameters behind named ones (`named[k]`: the engine parameters whose
/// weighted sum is the `k`-th name's derivative), each once, and the matrix that sums their
/// columns (after `nd` start-state directions, kept as they are) into the names'.
pub fn weighted_parameters(
    named: &[Vec<(Parameter, f64)>],
    nd: usize,
) -> (Vec<Parameter>, DMatrix<f64>) {
    let mut engine: Vec<Parameter> = Vec::new();
    let mut weights: Vec<(usize, usize, f64)> = Vec::new();
    for (k, terms) in named.iter().enumerate() {
        for (e, w) in terms {
            let i = engine.iter().position(|x| x == e).unwrap_or_else(|| {
                engine.push(e.clone());
                engine.len() - 1
            });
            weights.push((i, k, *w));
        }
    }
    let mut w = DMatrix::zeros(nd + engine.len(), nd + named.len());
    for j in 0..nd {
        w[(j, j)] = 1.0;
    }
    for &(i, k, wt) in &weights {
        w[(nd + i, nd + k)] += wt;
    }
    (engine, w)
}

/// The sensitivities of `exec` along the start-state `directions` (`2nq × nd`) and the named
/// parameters ([`weighted_parameters`]): the end state's columns and every event time's
/// gradient over `(directions, names)`.
pub fn named_sensitivity_columns(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
    directions: &DMatrix<f64>,
    named: &[Vec<(Parameter, f64)>],
) -> Result<ColumnSensitivity, SensitivityError> {
    let (engine, w) = weighted_parameters(named, directions.ncols());
    let mut s = execution_sensitivity_columns(model, terrain, exec, directions, &engine)?;
    s.columns = s.columns.map(|c| c * &w);
    for c in s.event_time_columns.iter_mut().flatten() {
        *c = &*c * &w;
    }
    Ok(s)
}

/// Why the end state's derivatives in `s` are not defined, if they are not: an event, a
/// controller's time event or a rolling/point switch without a saltation, or a terrain
/// feature change (times on the caller's clock).
pub fn undefined_reason(s: &ColumnSensitivity, offset_s: f64) -> Option<String> {
    if let Some(e) = s
        .events
        .iter()
        .find(|e| e.status != SaltationStatus::Defined)
    {
        Some(format!(
            "{:?} at t = {} s: {:?}",
            e.kind,
            e.t - offset_s,
            e.status
        ))
    } else if let Some(e) = s
        .time_events
        .iter()
        .find(|e| e.status != SaltationStatus::Defined)
    {
        Some(format!(
            "time event at t = {} s: {:?}",
            e.t - offset_s,
            e.status
        ))
    } else if let Some(sw) = s
        .touch_switches
        .iter()
        .find(|w| w.status != SaltationStatus::Defined)
    {
        Some(format!(
            "rolling/point switch at t = {} s: {:?}",
            sw.t - offset_s,
            sw.status
        ))
    } else if s.columns.is_none() {
        Some("the execution's sensitivities are not defined (a terrain feature change)".into())
    } else {
        None
    }
}

/// The saltation of every event of `s`, on the caller's clock.
pub fn event_saltations(s: &ColumnSensitivity, offset_s: f64) -> Vec<EventSaltation> {
    s.events
        .iter()
        .map(|e| EventSaltation {
            t_s: e.t - offset_s,
            status: e.status.clone(),
            saltation: e.saltation.clone(),
        })
        .collect()
}

/// The controllers' time events met (motor starts, knots of a schedule), on the caller's
/// clock: `(t_s, max |f⁺ − f⁻|)`, the jump of the flow there (0 where it is continuous).
pub fn time_event_jumps(s: &ColumnSensitivity, offset_s: f64) -> Vec<(f64, f64)> {
    s.time_events
        .iter()
        .map(|e| (e.t - offset_s, e.jump))
        .collect()
}

/// The gradient of the time of the event that ends `exec`, when that event is of `kind`
/// (`None` otherwise, or where its saltation is not defined).
pub fn end_event_time_gradient(
    s: &ColumnSensitivity,
    exec: &Execution,
    kind: EventKind,
) -> Option<Vec<f64>> {
    let t = s.event_time_columns.last().and_then(|t| t.clone())?;
    exec.events
        .last()
        .is_some_and(|e| e.kind == kind)
        .then(|| t.iter().copied().collect())
}
