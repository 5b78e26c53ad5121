//! Derivatives of a run with respect to named parameters and start-state directions, for any
//! robot: a preset's parameter is a weighted sum of the engine's
//! ([`selfmanip_hybrid::sensitivity::Parameter`]: a body's mass, a joint's armature, a
//! behaviour parameter), carried through every event by
//! [`execution_sensitivity_columns`]; what is left to the preset is which engine parameters
//! stand behind its names and how its reported quantities read the end state.
//!
//! Times are reported on the caller's clock: execution times minus `offset_s` (a leap's
//! clock starts at its front motor's start, not at the execution's).
use crate::error::SimError;
use crate::scenario::Scenario;
use nalgebra::DMatrix;
use selfmanip_core::tangent::{BodyParameter, TangentError};
use selfmanip_core::{Model, Terrain};
use selfmanip_hybrid::sensitivity::{
    execution_sensitivity_columns, ColumnSensitivity, FrictionCoefficient, Parameter,
    SaltationStatus, SensitivityError,
};
use selfmanip_hybrid::{
    ControlPoint, ControllerPartials, EventKind, Execution, HybridOptions, Termination,
};

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
    let undefined = |status: &SaltationStatus| *status != SaltationStatus::Defined;
    let first = s
        .events
        .iter()
        .find(|e| undefined(&e.status))
        .map(|e| (format!("{:?}", e.kind), e.t, &e.status))
        .or_else(|| {
            s.time_events
                .iter()
                .find(|e| undefined(&e.status))
                .map(|e| ("time event".to_string(), e.t, &e.status))
        })
        .or_else(|| {
            s.touch_switches
                .iter()
                .find(|w| undefined(&w.status))
                .map(|w| ("rolling/point switch".to_string(), w.t, &w.status))
        });
    match first {
        Some((what, t, status)) => Some(format!("{what} at t = {} s: {status:?}", t - offset_s)),
        None if s.columns.is_none() => {
            Some("the execution's sensitivities are not defined (a terrain feature change)".into())
        }
        None => None,
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

/// A run's final state differentiated with respect to named parameters
/// ([`run_parameter_sensitivity`], [`scenario_parameter_sensitivity`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterSensitivity {
    /// `d(q, q̇)(T)/dp`, `2nq × k` (one column per name, in order); `None` when not formed
    /// (see [`Self::reason`]). The column of a name in [`Self::not_differentiated`] is NaN.
    pub state: Option<DMatrix<f64>>,
    /// Each event's `dt_e/dp` (`k` entries), `None` where its saltation is not defined.
    pub event_times: Vec<Option<Vec<f64>>>,
    /// Why [`Self::state`] is `None`.
    pub reason: Option<String>,
    /// Per name, why it has no exact derivative yet (`None`: it has one).
    pub not_differentiated: Vec<Option<String>>,
}

/// The derivatives of `run`'s final state with respect to the behaviour parameters `names`
/// (the `[parameters]` table: `kp_push`, `t2`, `gear_ratio`, …): the behaviour's exact
/// parameter partials carried through every event
/// ([`selfmanip_hybrid::sensitivity::execution_sensitivity_columns`]). Not formed (with the
/// reason) for a run cut by its budget or stopped, and where an event's saltation is not
/// defined. A name the behaviour does not have is [`SensitivityError::UnknownParameter`]
/// naming that name alone.
pub fn run_parameter_sensitivity(
    run: &crate::Run,
    names: &[&str],
) -> Result<ParameterSensitivity, SensitivityError> {
    let params: Vec<Parameter> = names
        .iter()
        .map(|n| Parameter::Controller((*n).to_string()))
        .collect();
    run_columns(run, &params).map_err(|e| match e {
        SensitivityError::UnknownParameter { name, t } => {
            let name = unknown_name(run, names).map_or(name, str::to_string);
            SensitivityError::UnknownParameter { name, t }
        }
        e => e,
    })
}

/// The final state's and the events' derivatives of `run` with respect to the engine's
/// parameters `params` (see [`run_parameter_sensitivity`]).
fn run_columns(
    run: &crate::Run,
    params: &[Parameter],
) -> Result<ParameterSensitivity, SensitivityError> {
    let exec = &run.execution;
    let unformed = |reason: String| ParameterSensitivity {
        state: None,
        event_times: vec![None; exec.events.len()],
        reason: Some(reason),
        not_differentiated: vec![None; params.len()],
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
    let n2 = 2 * run.model.nq();
    let s = match execution_sensitivity_columns(
        &run.model,
        &run.terrain,
        exec,
        &DMatrix::zeros(n2, 0),
        params,
    ) {
        Ok(s) => s,
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
    let reason = s
        .events
        .iter()
        .find(|e| e.status != SaltationStatus::Defined)
        .map(|e| format!("{} at t = {} s: {}", e.kind.name(), e.t, e.status.name()));
    Ok(match (reason, s.columns) {
        (None, Some(x)) => ParameterSensitivity {
            state: Some(x),
            event_times,
            reason: None,
            not_differentiated: vec![None; params.len()],
        },
        (reason, _) => ParameterSensitivity {
            state: None,
            event_times,
            reason: Some(reason.unwrap_or_else(|| "not defined along the run".into())),
            not_differentiated: vec![None; params.len()],
        },
    })
}

/// The first of `names` that the run's first controller does not know (its
/// [`selfmanip_hybrid::Controller::parameter_partials`] refuses it alone).
fn unknown_name<'a>(run: &crate::Run, names: &[&'a str]) -> Option<&'a str> {
    let seg = run.execution.segments.first()?;
    let (n, nq) = (run.model.n_joints(), run.model.nq());
    let (q, qd) = seg.y0.split_at(nq);
    let at = ControlPoint::new(seg.t0, q, qd, seg.mode);
    names.iter().copied().find(|name| {
        let mut out = ControllerPartials::with_parameters(n, nq, 0, 1);
        !seg.controller.parameter_partials(&at, &[name], &mut out)
    })
}

/// What stands behind a parameter path of a scenario for the derivatives.
#[derive(Debug, Clone, PartialEq)]
enum PathParameter {
    /// A parameter the engine differentiates as it is (a behaviour parameter, an inertia
    /// parameter of the body or a link, a friction coefficient).
    Engine(Parameter),
    /// A number of the behaviour (a literal or a formula): made a behaviour parameter of its
    /// own (`FIELD_PARAMETER` + index) added to the field, 0 at the run.
    Field {
        path: String,
        value: serde_json::Value,
    },
    /// No exact derivative yet: why.
    NotDifferentiated(String),
}

/// The prefix of the behaviour parameters a field is differentiated through.
const FIELD_PARAMETER: &str = "__d_field_";

/// Why a parameter path has no derivative of a scenario's run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParameterPathError {
    /// `names[index]` names nothing settable of the scenario.
    #[error("parameters[{index}]: {source}")]
    Unknown { index: usize, source: SimError },
    #[error(transparent)]
    Sensitivity(#[from] SensitivityError),
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// The derivatives of `run` (a run of `scenario`, with its behaviour, under the engine's
/// `options`: the scenario's own, [`crate::scenario::SimOptions::hybrid`], unless the caller
/// changed them) with respect to
/// parameters named by path ([`crate::path`]: a behaviour parameter `kp_push` or
/// `parameters.kp_push`, a number of the behaviour `joints[1].phases[0].torque.kp_n_m_per_rad`,
/// a field of the robot `body.mass_kg`, `legs[0].links[1].mass_kg`), exact:
///
/// - a behaviour parameter: the behaviour's own partials;
/// - a number of the behaviour (a literal or a formula `e`): the field made `e + δ`, `δ` a
///   behaviour parameter at 0, and the run differentiated with respect to `δ` (the run of the
///   rewritten behaviour is compared with `run`: any difference in its events or end state
///   leaves the name not differentiated, with the reason);
/// - the body's mass and inertia, a link's mass, inertia (at a positive value) and centre
///   of mass `com_m[0]`, `com_m[1]`, a joint's armature: [`Parameter::Body`];
/// - a contact's `friction.mu` (the static coefficient, and the kinetic one with it where
///   `mu_kinetic` is left to default to it) and `friction.mu_kinetic`:
///   [`Parameter::Friction`]; `options.delta_t_s` at a positive value:
///   [`Parameter::PseudoImpulseDuration`] (zero columns);
/// - anything else (a link's length, the terrain, the initial state — whose
///   derivatives are the state Jacobian's): no exact derivative yet, its column NaN and the
///   reason in [`ParameterSensitivity::not_differentiated`], never a finite difference.
pub fn scenario_parameter_sensitivity(
    scenario: &Scenario,
    options: &HybridOptions,
    run: &crate::Run,
    names: &[&str],
) -> Result<ParameterSensitivity, ParameterPathError> {
    let tree = scenario.to_value()?;
    let mut routes = Vec::with_capacity(names.len());
    for (index, name) in names.iter().enumerate() {
        let full = crate::path::resolve(&tree, name)
            .map_err(|source| ParameterPathError::Unknown { index, source })?;
        routes.push(route(&run.model, &tree, &full, options));
    }
    let fields: Vec<(usize, String, serde_json::Value)> = routes
        .iter()
        .enumerate()
        .filter_map(|(i, r)| match r {
            PathParameter::Field { path, value } => Some((i, path.clone(), value.clone())),
            _ => None,
        })
        .collect();
    // each field alone first: one that is no number of the behaviour is flagged by itself
    let mut good = Vec::with_capacity(fields.len());
    for f in fields {
        match with_field_parameters(scenario, std::slice::from_ref(&f)) {
            Ok(_) => good.push(f),
            Err(reason) => routes[f.0] = PathParameter::NotDifferentiated(reason),
        }
    }
    let mut rewritten = None;
    if !good.is_empty() {
        match with_field_parameters(scenario, &good).and_then(|s| rerun(&s, options, run)) {
            Ok(r) => rewritten = Some(r),
            Err(reason) => {
                for (i, ..) in &good {
                    routes[*i] = PathParameter::NotDifferentiated(reason.clone());
                }
            }
        }
    }
    let params: Vec<Parameter> = routes
        .iter()
        .enumerate()
        .filter_map(|(i, r)| match r {
            PathParameter::Engine(p) => Some(p.clone()),
            PathParameter::Field { .. } => {
                Some(Parameter::Controller(format!("{FIELD_PARAMETER}{i}")))
            }
            PathParameter::NotDifferentiated(_) => None,
        })
        .collect();
    let s = match run_columns(rewritten.as_ref().unwrap_or(run), &params) {
        Err(SensitivityError::UnknownParameter { name, .. }) => {
            // a parameter of the table the controller gives no derivative for: named by path
            let index = routes
                .iter()
                .enumerate()
                .position(|(i, r)| match r {
                    PathParameter::Engine(Parameter::Controller(n)) => *n == name,
                    PathParameter::Field { .. } => name == format!("{FIELD_PARAMETER}{i}"),
                    _ => false,
                })
                .unwrap_or(0);
            return Err(ParameterPathError::Unknown {
                index,
                source: SimError::UnknownParameter {
                    path: names[index].to_string(),
                    reason: "the behaviour gives no derivative with respect to it".into(),
                },
            });
        }
        s => s?,
    };
    Ok(spread(s, &routes))
}

/// What stands behind the full path `full` of `tree` (a scenario run under `options`) for
/// the derivatives.
fn route(
    model: &Model,
    tree: &serde_json::Value,
    full: &str,
    options: &HybridOptions,
) -> PathParameter {
    if let Some(k) = full.strip_prefix("behaviour.parameters.") {
        return PathParameter::Engine(Parameter::Controller(k.to_string()));
    }
    if full == "options.delta_t_s" {
        return if options.delta_t_s > 0.0 {
            PathParameter::Engine(Parameter::PseudoImpulseDuration)
        } else {
            PathParameter::NotDifferentiated(
                "`options.delta_t_s` at 0 takes the limit δt → 0⁺, another impact rule: its \
                 derivative there is one-sided (differentiated at a positive δt)"
                    .into(),
            )
        };
    }
    if let Some(p) = friction_parameter(model, tree, full) {
        return p;
    }
    match full {
        "robot.body.mass_kg" => return PathParameter::Engine(Parameter::Body(BodyParameter::Mass)),
        "robot.body.inertia_kg_m2" => {
            return PathParameter::Engine(Parameter::Body(BodyParameter::Inertia))
        }
        _ => {}
    }
    if let Some((j, "length_m")) = link_field(model, tree, full) {
        return link_length(model, tree, full, j);
    }
    if let Some(p) = contact_position(model, tree, full) {
        return p;
    }
    if let Some(p) = link_field(model, tree, full).and_then(|(j, f)| link_parameter(j, f)) {
        return match p.check(model) {
            Ok(()) => PathParameter::Engine(Parameter::Body(p)),
            Err(e) => PathParameter::NotDifferentiated(e.to_string()),
        };
    }
    if full.starts_with("behaviour.") {
        let field = |value| PathParameter::Field {
            path: full.to_string(),
            value,
        };
        return match field_value(tree, full) {
            Some(v @ serde_json::Value::Number(_)) => field(v),
            Some(serde_json::Value::String(text)) if is_formula(tree, full, &text) => {
                field(serde_json::Value::String(text))
            }
            _ => PathParameter::NotDifferentiated(format!(
                "`{full}` holds no number of the behaviour"
            )),
        };
    }
    let what = if full.starts_with("initial.") {
        "the initial state's derivatives are the state Jacobian's (`sensitivity=True`)"
    } else {
        "no exact derivative yet: the engine differentiates the behaviour's numbers, the \
         body's and links' masses, inertias, centres of mass and lengths, the joints' \
         armatures, the point contacts' positions and friction coefficients and a positive \
         `options.delta_t_s`"
    };
    PathParameter::NotDifferentiated(format!("`{full}`: {what}"))
}

/// The contact a path names after `robot.contacts` (`[i]` or `.<name>`): its index among the
/// description's contacts and among `model`'s, if it names one.
fn contact_index(model: &Model, tree: &serde_json::Value, contact: &str) -> Option<(usize, usize)> {
    let contacts = tree.get("robot")?.get("contacts")?.as_array()?;
    let i = match contact.strip_prefix('[') {
        Some(i) => i.strip_suffix(']')?.parse().ok()?,
        None => {
            let name = contact.strip_prefix('.')?;
            contacts
                .iter()
                .position(|c| c.get("name").and_then(|n| n.as_str()) == Some(name))?
        }
    };
    let name = contacts.get(i)?.get("name").and_then(|n| n.as_str())?;
    let k = model.contacts.iter().position(|c| c.name == name)?;
    Some((i, k))
}

/// The friction coefficient the full path `full` names (`robot.contacts.<contact>.friction.
/// mu` or `.mu_kinetic`, the contact by name or index), if it names one: `mu` is the static
/// coefficient, and the kinetic one too where the description leaves `mu_kinetic` to
/// default to it ([`FrictionCoefficient::Both`]); `mu_kinetic` is the kinetic one alone.
fn friction_parameter(
    model: &Model,
    tree: &serde_json::Value,
    full: &str,
) -> Option<PathParameter> {
    let rest = full.strip_prefix("robot.contacts")?;
    let (contact, field) = rest.rsplit_once(".friction.")?;
    let (i, k) = contact_index(model, tree, contact)?;
    let friction = tree["robot"]["contacts"][i].get("friction")?;
    let kinetic_given = friction.get("mu_kinetic").is_some_and(|v| !v.is_null());
    let coefficient = match field {
        "mu" if kinetic_given => FrictionCoefficient::Static,
        "mu" => FrictionCoefficient::Both,
        "mu_kinetic" => FrictionCoefficient::Kinetic,
        _ => return None,
    };
    if field == "mu"
        && !friction
            .get("mu")
            .and_then(|v| v.as_f64())
            .is_some_and(f64::is_finite)
    {
        return Some(PathParameter::NotDifferentiated(format!(
            "`{full}`: an infinite friction coefficient is no number to differentiate in"
        )));
    }
    Some(PathParameter::Engine(Parameter::Friction {
        contact: k,
        coefficient,
    }))
}

/// Whether `text` (the field `full` of `tree`) is a formula of the behaviour's parameters
/// (not a name, a kind or a formula of the state).
fn is_formula(tree: &serde_json::Value, full: &str, text: &str) -> bool {
    let Ok(e) = crate::expr::Expr::parse(full, text) else {
        return false;
    };
    let mut vars = Vec::new();
    e.variables(&mut vars);
    let params = tree.get("behaviour").and_then(|b| b.get("parameters"));
    vars.iter()
        .all(|v| params.is_some_and(|p| p.get(v).is_some()))
}

/// The value at the full path `full` of `tree` (set to a marker, found where the trees
/// differ).
fn field_value(tree: &serde_json::Value, full: &str) -> Option<serde_json::Value> {
    let mut t = tree.clone();
    let marker = serde_json::Value::String("\u{0}marker".into());
    crate::path::set(&mut t, full, marker).ok()?;
    find_changed(tree, &t)
}

/// The value of `a` where `b` differs from it (the one leaf set to a marker).
fn find_changed(a: &serde_json::Value, b: &serde_json::Value) -> Option<serde_json::Value> {
    use serde_json::Value;
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => x
            .iter()
            .find_map(|(k, v)| y.get(k).and_then(|w| find_changed(v, w))),
        (Value::Array(x), Value::Array(y)) => x.iter().zip(y).find_map(|(v, w)| find_changed(v, w)),
        _ => (a != b).then(|| a.clone()),
    }
}

/// The joint whose link's field the full path `full` names (`robot.legs.<leg>.links[k].
/// <field>`, the leg by name or index), and the field (`mass_kg`, `com_m[0]`, …), if it
/// names one.
fn link_field<'a>(
    model: &Model,
    tree: &serde_json::Value,
    full: &'a str,
) -> Option<(usize, &'a str)> {
    let rest = full.strip_prefix("robot.legs")?;
    let (leg, link) = rest.rsplit_once(".links[")?;
    let (k, field) = link.split_once("].")?;
    let k: usize = k.parse().ok()?;
    let legs = tree.get("robot")?.get("legs")?.as_array()?;
    let li = match leg.strip_prefix('[') {
        Some(i) => i.strip_suffix(']')?.parse().ok()?,
        None => {
            let name = leg.strip_prefix('.')?;
            legs.iter()
                .position(|l| l.get("name").and_then(|n| n.as_str()) == Some(name))?
        }
    };
    let j = model
        .joints
        .iter()
        .position(|j| j.leg == li && j.index_in_leg == k)?;
    Some((j, field))
}

/// The length of joint `j`'s link (the field `full` of `tree`): its centre of mass follows
/// when the description leaves it to default to the link's middle; refused when a collision
/// shape of the link is centred by default (its centre moves too, another parameter).
fn link_length(model: &Model, tree: &serde_json::Value, full: &str, j: usize) -> PathParameter {
    let link = full
        .rsplit_once('.')
        .and_then(|(l, _)| field_value_at(tree, l));
    let given = |f: &str| {
        link.as_ref()
            .and_then(|l| l.get(f))
            .is_some_and(|v| !v.is_null())
    };
    let default_centred = link
        .as_ref()
        .and_then(|l| l.get("collision"))
        .and_then(|c| c.as_array())
        .is_some_and(|c| {
            c.iter()
                .any(|c| c.get("center_m").is_none_or(|v| v.is_null()))
        });
    if default_centred {
        return PathParameter::NotDifferentiated(format!(
            "`{full}`: a collision shape of the link is centred at its middle by default and \
             moves with its length: not differentiated (give its `center_m`)"
        ));
    }
    let p = BodyParameter::LinkLength {
        joint: j,
        com_follows: !given("com_m"),
    };
    match p.check(model) {
        Ok(()) => PathParameter::Engine(Parameter::Body(p)),
        Err(e) => PathParameter::NotDifferentiated(e.to_string()),
    }
}

/// The value of the object at the path `path` of `tree` (`robot.legs[0].links[1]`, legs by
/// name or index).
fn field_value_at(tree: &serde_json::Value, path: &str) -> Option<serde_json::Value> {
    let mut node = tree;
    for part in path.split('.') {
        let (name, index) = match part.split_once('[') {
            Some((n, i)) => (n, Some(i.strip_suffix(']')?)),
            None => (part, None),
        };
        node = match node.get(name) {
            Some(n) => n,
            // a leg or contact named `name` of the array `node`
            None => node
                .as_array()?
                .iter()
                .find(|e| e.get("name").and_then(|n| n.as_str()) == Some(name))?,
        };
        if let Some(i) = index {
            node = node.as_array()?.get(i.parse::<usize>().ok()?)?;
        }
    }
    Some(node.clone())
}

/// The position of a point contact the full path `full` names (`robot.contacts.<contact>.
/// shape.position_m[axis]`, the contact by name or index), if it names one; an arc's centre
/// and radius are refused with the reason.
fn contact_position(model: &Model, tree: &serde_json::Value, full: &str) -> Option<PathParameter> {
    let rest = full.strip_prefix("robot.contacts")?;
    let (contact, field) = rest.split_once(".shape.")?;
    let (_, k) = contact_index(model, tree, contact)?;
    let axis = match field {
        "position_m[0]" => 0,
        "position_m[1]" => 1,
        _ => {
            return Some(PathParameter::NotDifferentiated(format!(
                "`{full}`: an arc's centre and radius are not differentiated yet (a point \
                 contact's `position_m` is)"
            )))
        }
    };
    let p = BodyParameter::ContactPosition(k, axis);
    Some(match p.check(model) {
        Ok(()) => PathParameter::Engine(Parameter::Body(p)),
        Err(e) => PathParameter::NotDifferentiated(e.to_string()),
    })
}

/// The inertia parameter of a link's field (`mass_kg`, `inertia_kg_m2`, `armature_kg_m2`,
/// `com_m[0]`, `com_m[1]`), if it is one.
fn link_parameter(j: usize, field: &str) -> Option<selfmanip_core::tangent::BodyParameter> {
    Some(match field {
        "mass_kg" => BodyParameter::LinkMass(j),
        "inertia_kg_m2" => BodyParameter::LinkInertia(j),
        "armature_kg_m2" => BodyParameter::Armature(j),
        "com_m[0]" => BodyParameter::LinkCom(j, 0),
        "com_m[1]" => BodyParameter::LinkCom(j, 1),
        _ => return None,
    })
}

/// `scenario` with each behaviour number of `fields` (`(name index, full path, value)`) made
/// `value + δ_i` (`δ_i` a behaviour parameter at 0), checked to compile; else why not.
fn with_field_parameters(
    scenario: &Scenario,
    fields: &[(usize, String, serde_json::Value)],
) -> Result<Scenario, String> {
    let mut s = scenario.clone();
    let mut values = Vec::with_capacity(fields.len());
    for (i, path, value) in fields {
        let p = format!("{FIELD_PARAMETER}{i}");
        let sum = match value {
            serde_json::Value::String(e) => format!("({e}) + {p}"),
            v => format!("{v} + {p}"),
        };
        values.push((path.clone(), serde_json::Value::String(sum)));
        s.behaviour
            .parameters
            .insert(p, crate::expr::Scalar::Number(0.0));
    }
    let s = s
        .with_values(&values)
        .and_then(|s| crate::scenario::Simulation::new(&s).map(|_| s))
        .map_err(|e| format!("not a number the behaviour differentiates ({e})"))?;
    Ok(s)
}

/// The run of `s` (a scenario [`with_field_parameters`]) under `options`, checked to be
/// `run` (events and end state bit for bit); else why not.
fn rerun(s: &Scenario, options: &HybridOptions, run: &crate::Run) -> Result<crate::Run, String> {
    let again = crate::scenario::Simulation::new(s)
        .and_then(|mut sim| {
            sim.options = *options;
            sim.run()
        })
        .map_err(|e| format!("the behaviour with the field as a parameter does not run ({e})"))?;
    let (a, b) = (&run.execution, &again.execution);
    let same = a.events.len() == b.events.len()
        && a.events
            .iter()
            .zip(&b.events)
            .all(|(x, y)| x.t == y.t && x.kind == y.kind)
        && a.q == b.q
        && a.qd == b.qd;
    if same {
        Ok(again)
    } else {
        Err("the run with the field as a parameter differs from the run itself".into())
    }
}

/// The engine's columns of `s` spread over every name of `routes`, NaN (and the reason) for
/// those not differentiated.
fn spread(mut s: ParameterSensitivity, routes: &[PathParameter]) -> ParameterSensitivity {
    let k = routes.len();
    let cols: Vec<Option<usize>> = routes
        .iter()
        .scan(0, |next, r| {
            Some(match r {
                PathParameter::NotDifferentiated(_) => None,
                _ => {
                    *next += 1;
                    Some(*next - 1)
                }
            })
        })
        .collect();
    let pick =
        |v: &[f64]| -> Vec<f64> { cols.iter().map(|c| c.map_or(f64::NAN, |c| v[c])).collect() };
    s.state = s
        .state
        .map(|x| DMatrix::from_fn(x.nrows(), k, |r, j| cols[j].map_or(f64::NAN, |c| x[(r, c)])));
    for t in s.event_times.iter_mut().flatten() {
        *t = pick(t);
    }
    s.not_differentiated = routes
        .iter()
        .map(|r| match r {
            PathParameter::NotDifferentiated(why) => Some(why.clone()),
            _ => None,
        })
        .collect();
    s
}
