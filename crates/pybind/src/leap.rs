//! `selfmanip.leap` / `selfmanip.sweep`'s native half: one leap, a sweep on an explicit rayon
//! pool, MCAP logs. Conversions only; the semantics live in `rhex_model::{leap, sweep,
//! mcap_log}`.
//!
//! **Inputs** arrive as Python objects: a `dict` of overrides by name (Table 4.2 symbols,
//! `LeapConfig` fields, the geared motor's `current_limit_a` / `motors_per_leg`), applied by
//! `rhex_model::sweep::point_inputs` to `leap_params()` and `LeapConfig::default()` — the
//! engine's defaults, whatever they are. The actuator of a point is `gear_ratio`: `None`
//! keeps the default actuator, a number selects the geared motor of that ratio, NaN the
//! saturated torque `τ_s` (chapter 3: the caller's explicit choice).
//!
//! **Work** runs on a worker thread with the GIL released and is interruptible by Ctrl-C
//! ([`crate::interrupt`]); a sweep checks the cancellation flag before every point.
use crate::convert::{column, to_map, to_py, to_value, DictOut};
use crate::errors::{self, invalid, Source};
use crate::interrupt::{self, Shared};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rhex_model::grc::{match_leap_word, Cell};
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LeapResult, LegActuator, Strategy};
use rhex_model::leap_sensitivity::{
    check_sensitivity_names, leap_with_sensitivity, LeapSensitivity, APEX_COLUMNS,
};
use rhex_model::mcap_log::{write_leap_mcap, LeapLog};
use rhex_model::sweep::{
    actuator_field_names, check_override_names, error_kind, panic_message, point_inputs,
    sweepable_names, LeapPoint, SweepRow,
};
use rhex_model::{RhexError, RhexParams};
use selfmanip_sim::sweep::run_parallel;
use selfmanip_sim::trajectory::q_names;
use selfmanip_sim::{EventRecord, SimError, Trajectory};
use serde_json::{Map, Value};
use std::collections::BTreeMap;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    add_functions! {
        m,
        leap_run, leap_sweep, leap_write_mcap, leap_sweepable_names, leap_actuator_fields,
        leap_defaults, leap_grammar_text, leap_word_equation
    }
    Ok(())
}

fn rhex_err(e: RhexError) -> PyErr {
    // a leap's vectors are the engine's own: the caller passes none
    errors::rhex(e, Source::Engine)
}

/// The base of a point: chapter 5's parameters and the engine's default configuration, with
/// the saturated torque when the caller chose it.
fn base(saturated: bool) -> (RhexParams, LeapConfig) {
    let mut cfg = LeapConfig::default();
    if saturated {
        cfg.actuator = LegActuator::SaturatedTorque;
    }
    (leap_params(), cfg)
}

/// `gear_ratio` as (`saturated`, the point's gear ratio).
fn actuator_choice(gear_ratio: Option<f64>) -> (bool, Option<f64>) {
    match gear_ratio {
        Some(g) if g.is_nan() => (true, None),
        g => (false, g),
    }
}

/// The inputs of one leap (errors name the field).
fn resolve(
    strategy: &str,
    t2_s: f64,
    gear_ratio: Option<f64>,
    overrides: Map<String, Value>,
) -> PyResult<(RhexParams, LeapConfig)> {
    let strategy: Strategy = strategy.parse().map_err(rhex_err)?;
    let (saturated, gear) = actuator_choice(gear_ratio);
    let mut pt = LeapPoint::new(strategy, t2_s, gear);
    pt.overrides = overrides;
    let (p, c) = base(saturated);
    point_inputs(&p, &c, &pt).map_err(rhex_err)
}

/// The names among [`leap_sweepable_names`] that set the geared motor.
#[pyfunction]
fn leap_actuator_fields() -> Vec<String> {
    actuator_field_names()
        .iter()
        .map(|s| s.to_string())
        .collect()
}

/// Every parameter name a sweep or a leap accepts, each once.
#[pyfunction]
fn leap_sweepable_names() -> Vec<String> {
    sweepable_names()
}

/// `{"params": leap_params(), "config": LeapConfig::default()}`: the engine's defaults.
#[pyfunction]
fn leap_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("params", to_py(py, &leap_params())?)?;
    d.set_item("config", to_py(py, &LeapConfig::default())?)?;
    Ok(d)
}

/// The leap grammar of chapter 3 as readable text.
#[pyfunction]
fn leap_grammar_text() -> String {
    rhex_model::grc::leap_grammar_text()
}

/// The thesis equation, `"3.2"` … `"3.7"`, of the leap word made of `cells` (labels
/// `FB FL RB RL`, sliding toes as `1`), or `None` when it is none of them.
#[pyfunction]
fn leap_word_equation(cells: Vec<String>) -> PyResult<Option<&'static str>> {
    let cells = cells
        .iter()
        .map(|c| Cell::from_label(&c.replace('s', "1")))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| invalid("word", e.to_string()))?;
    Ok(match_leap_word(&cells))
}

/// One leap and, when `dt_s` is given, its trajectory: the work of [`leap_run`].
fn run_leap(
    params: &RhexParams,
    cfg: &LeapConfig,
    dt_s: Option<f64>,
    names: Option<&[String]>,
) -> Result<(LeapResult, Option<Trajectory>, Option<LeapSensitivity>), RhexError> {
    let (res, sens) = match names {
        None => (simulate_leap(params, cfg)?, None),
        Some(names) => {
            let refs: Vec<&str> = names.iter().map(String::as_str).collect();
            let s = leap_with_sensitivity(params, cfg, &refs)?;
            (s.result.clone(), Some(s))
        }
    };
    let traj = match dt_s {
        Some(dt) => Some(res.trajectory(dt)?),
        None => None,
    };
    Ok((res, traj, sens))
}

/// The sensitivities of a leap as a dict: `parameters`, `columns` (the apex columns),
/// `values` (`len(columns) × len(parameters)`, NaN unless `ok`), `ok`, `reason` and
/// `saltations` (one per event: an `(n, n)` array over `(q, q̇)`, or None where undefined).
fn sensitivity_dict<'py>(py: Python<'py>, s: &LeapSensitivity) -> DictOut<'py> {
    let d = PyDict::new(py);
    d.set_item("parameters", s.parameters.clone())?;
    d.set_item("columns", APEX_COLUMNS.to_vec())?;
    let k = s.parameters.len();
    d.set_item(
        "values",
        crate::convert::rows_array(&s.d_apex, k).into_pyarray(py),
    )?;
    d.set_item("ok", s.ok)?;
    d.set_item("reason", s.reason.clone().unwrap_or_default())?;
    let sal = PyList::empty(py);
    for e in &s.events {
        match &e.saltation {
            Some(x) => {
                let rows: Vec<Vec<f64>> =
                    x.row_iter().map(|r| r.iter().copied().collect()).collect();
                sal.append(crate::convert::rows_array(&rows, x.ncols()).into_pyarray(py))?
            }
            None => sal.append(py.None())?,
        }
    }
    d.set_item("saltations", sal)?;
    Ok(d)
}

fn events_list<'py>(py: Python<'py>, events: &[EventRecord]) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for e in events {
        let d = PyDict::new(py);
        d.set_item("t_s", e.t_s)?;
        d.set_item("kind", e.kind)?;
        d.set_item("mode_before", &e.mode_before)?;
        d.set_item("mode_after", &e.mode_after)?;
        d.set_item("contacts", &e.contacts)?;
        d.set_item("energy_loss_j", e.energy_loss_j)?;
        d.set_item("impulse_n_s", e.impulse_n_s.clone())?;
        d.set_item("force_n", e.force_n.clone())?;
        list.append(d)?;
    }
    Ok(list)
}

/// One leap. `gear_ratio`: `None` the engine's default actuator, a number the geared motor of
/// that ratio, NaN the saturated torque. Returns a dict: `status` (the engine's run status:
/// `apex`, `final_time`, `zeno`, `terrain_discontinuity`, …), `flew` (the leap reached its
/// apex, or flew and ran on to its final time: `rhex_model::leap::LeapResult::flew`),
/// `reason` (why it did not fly; empty when it did), `apex` (dict or None), `word` (list of cells), `events` (list of
/// dicts), `q0`, `q_names`, `time_offset_s`, `motor_t2_s` (the rear motor's start after the
/// front one's that the leap ran with: `t2` itself, or what a touchdown-timed leap's search
/// found), `touchdown_t2_s` (the rear leg's first touchdown after the front leg's, or None),
/// `params`, `config` (the full inputs used, as dicts) and, when `dt_s` is given,
/// `trajectory` (numpy arrays).
#[pyfunction]
#[pyo3(signature = (strategy, t2_s, gear_ratio, overrides, dt_s=None, sensitivities=None))]
fn leap_run<'py>(
    py: Python<'py>,
    strategy: &str,
    t2_s: f64,
    gear_ratio: Option<f64>,
    overrides: &Bound<'py, PyDict>,
    dt_s: Option<f64>,
    sensitivities: Option<Vec<String>>,
) -> DictOut<'py> {
    errors::guard(|| {
        let (params, cfg) = resolve(strategy, t2_s, gear_ratio, to_map(overrides, "")?)?;
        if let Some(dt) = dt_s {
            if !(dt.is_finite() && dt > 0.0) {
                return Err(invalid(
                    "dt",
                    format!("`dt` must be finite and positive, got {dt}"),
                ));
            }
        }
        if let Some(names) = &sensitivities {
            let refs: Vec<&str> = names.iter().map(String::as_str).collect();
            check_sensitivity_names(&cfg, &refs).map_err(rhex_err)?;
        }
        let (p, c) = (params.clone(), cfg.clone());
        let (res, traj, sens) = interrupt::run(py, None, move |_: &Shared| {
            run_leap(&p, &c, dt_s, sensitivities.as_deref())
        })?
        .map_err(rhex_err)?;
        let d = PyDict::new(py);
        d.set_item("status", res.status.as_str())?;
        d.set_item("flew", res.flew)?;
        d.set_item("reason", res.reason())?;
        match res.apex {
            Some(a) => d.set_item("apex", to_py(py, &a)?)?,
            None => d.set_item("apex", py.None())?,
        }
        d.set_item("word", res.word.clone())?;
        d.set_item("events", events_list(py, &res.events)?)?;
        d.set_item("q0", res.q0.clone().into_pyarray(py))?;
        d.set_item("q_names", q_names(&res.leap.rhex.model))?;
        d.set_item("time_offset_s", res.time_offset_s)?;
        d.set_item("motor_t2_s", res.motor_t2_s)?;
        d.set_item("touchdown_t2_s", res.touchdown_t2_s)?;
        d.set_item("params", to_py(py, &params)?)?;
        d.set_item("config", to_py(py, &cfg)?)?;
        if let Some(s) = &sens {
            d.set_item("sensitivity", sensitivity_dict(py, s)?)?;
        }
        if let Some(tr) = traj {
            let nq = tr.q.first().map_or(params.pairs.len() + 3, |r| r.len());
            let nc = tr.contacts.len();
            let td = PyDict::new(py);
            td.set_item("contacts", tr.contacts.clone())?;
            td.set_item("t_s", tr.t_s.clone().into_pyarray(py))?;
            td.set_item("q", crate::convert::rows_array(&tr.q, nq).into_pyarray(py))?;
            td.set_item(
                "qd",
                crate::convert::rows_array(&tr.qd, nq).into_pyarray(py),
            )?;
            td.set_item("mode", tr.mode.clone())?;
            td.set_item(
                "contact_points_m",
                crate::convert::pairs_array(&tr.contact_points_m, nc).into_pyarray(py),
            )?;
            td.set_item(
                "contact_forces_n",
                crate::convert::pairs_array(&tr.contact_forces_n, nc).into_pyarray(py),
            )?;
            d.set_item("trajectory", td)?;
        }
        Ok(d)
    })
}

/// The message of a point's error as the single leap would raise it (no GIL needed).
fn error_message(e: &RhexError) -> String {
    errors::map_rhex(e, Source::Engine).message
}

/// One point of a sweep as a row: never fails, never panics. Unlike a single leap, a point
/// that does not reach `ok` carries the reason in `error`.
/// With `names`, the leap's apex sensitivities too: `(ok, d APEX_COLUMNS[c] / d names[k]`
/// at `c * names.len() + k`, NaN where undefined or when the point failed).
fn sweep_row(
    base: &(RhexParams, LeapConfig),
    point: &LeapPoint,
    names: Option<&[String]>,
) -> (SweepRow, Option<(bool, Vec<f64>)>) {
    let k = names.map_or(0, <[String]>::len);
    let failed_sens = names.map(|_| (false, vec![f64::NAN; APEX_COLUMNS.len() * k]));
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let (params, cfg) = point_inputs(&base.0, &base.1, point)?;
        let (r, sens) = match names {
            None => (simulate_leap(&params, &cfg)?, None),
            Some(names) => {
                let refs: Vec<&str> = names.iter().map(String::as_str).collect();
                let s = leap_with_sensitivity(&params, &cfg, &refs)?;
                let values = s.d_apex.iter().flatten().copied().collect();
                (s.result, Some((s.ok, values)))
            }
        };
        let why = r.reason();
        let gear_ratio = cfg.actuator.gear_ratio().unwrap_or(f64::NAN); // NaN: none
        Ok::<_, RhexError>((r, why, gear_ratio, sens))
    }));
    let (row, sens) = sweep_row_of(outcome);
    (row, sens.or(failed_sens))
}

type PointOutcome =
    std::thread::Result<Result<(LeapResult, String, f64, Option<(bool, Vec<f64>)>), RhexError>>;

fn sweep_row_of(outcome: PointOutcome) -> (SweepRow, Option<(bool, Vec<f64>)>) {
    match outcome {
        Err(p) => (
            SweepRow::failed(
                "panic",
                format!(
                    "internal error in selfmanip (a bug, please report it): {}",
                    panic_message(p.as_ref())
                ),
                1,
            ),
            None,
        ),
        Ok(Err(e)) => (SweepRow::failed(error_kind(&e), error_message(&e), 1), None),
        Ok(Ok((r, why, g, sens))) => (
            SweepRow::of_run(&r.outcome, r.flew, r.apex, why, vec![g]),
            sens,
        ),
    }
}

/// A point's apex sensitivities when asked for: whether they are valid, and the values
/// (apex column by column, one per parameter).
type RowSensitivities = Option<(bool, Vec<f64>)>;
/// A point's row and its sensitivities.
type Row = (SweepRow, RowSensitivities);

/// Runs the points on a pool of exactly `threads` threads, one task per point, rows in input
/// order (bit-identical for any thread count). A point skipped because the sweep was
/// interrupted is `None`. `bases[saturated]` is each point's base.
fn sweep_rows(
    bases: &[(RhexParams, LeapConfig); 2],
    points: &[(bool, LeapPoint)],
    threads: usize,
    names: Option<&[String]>,
    shared: &Shared,
) -> Result<Vec<Option<Row>>, String> {
    // one task per leap on a pool of its own (neighbouring points have correlated costs:
    // `rhex_model::sweep::sweep`)
    run_parallel(points, threads, |(saturated, p)| {
        if shared.cancelled() {
            return None;
        }
        let row = sweep_row(&bases[usize::from(*saturated)], p, names);
        shared.tick();
        Some(row)
    })
    .map_err(|e| match e {
        SimError::InvalidValue { reason, .. } => reason,
        e => e.to_string(),
    })
}

/// A sweep. Per point: `strategies[i]`, `t2_s[i]`, `gear_ratio[i]` (as for [`leap_run`]) and
/// the values of `columns` (`{"name": [v0, v1, …]}`); `base_overrides` applies to every point
/// and is checked up front. `progress(done)` is called as points finish. Returns a dict of
/// columns (numpy arrays for numbers, lists for strings); a point that is not `ok` has the
/// reason in `error`.
#[pyfunction]
#[pyo3(signature = (strategies, t2_s, gear_ratio, base_overrides, columns, threads, progress=None, sensitivities=None))]
#[allow(clippy::too_many_arguments)]
fn leap_sweep<'py>(
    py: Python<'py>,
    strategies: Vec<String>,
    t2_s: Vec<f64>,
    gear_ratio: Vec<Option<f64>>,
    base_overrides: &Bound<'py, PyDict>,
    columns: &Bound<'py, PyDict>,
    threads: usize,
    progress: Option<&Bound<'py, PyAny>>,
    sensitivities: Option<Vec<String>>,
) -> DictOut<'py> {
    errors::guard(|| {
        let n = strategies.len();
        if t2_s.len() != n || gear_ratio.len() != n {
            return Err(invalid(
                "t2",
                format!(
                    "strategy, t2 and gear_ratio must have one entry per point: {n}, {}, {}",
                    t2_s.len(),
                    gear_ratio.len()
                ),
            ));
        }
        if threads == 0 {
            return Err(invalid("threads", "`threads` must be at least 1"));
        }
        // the base, checked once (a bad base is an error of the call, not of every point)
        let first = strategies.first().map_or("++", |s| s.as_str());
        let (bp, bc) = resolve(first, 0.0, None, to_map(base_overrides, "")?)?;
        let saturated_cfg = LeapConfig {
            actuator: LegActuator::SaturatedTorque,
            ..bc.clone()
        };
        if let Some(names) = &sensitivities {
            let refs: Vec<&str> = names.iter().map(String::as_str).collect();
            check_sensitivity_names(&bc, &refs).map_err(rhex_err)?;
        }
        let bases = [(bp.clone(), bc), (bp, saturated_cfg)];
        let mut cols: Vec<(String, Vec<Value>)> = Vec::new();
        for (k, v) in columns.iter() {
            let name: String = k.extract()?;
            let values: Vec<Bound<'py, PyAny>> = v.extract().map_err(|_| {
                errors::invalid_type(&name, format!("`{name}`: the swept column must be a list"))
            })?;
            if values.len() != n {
                return Err(invalid(
                    &name,
                    format!("`{name}`: the swept column must have one value per point ({n})"),
                ));
            }
            let values = values
                .iter()
                .enumerate()
                .map(|(i, x)| to_value(x, &format!("{name}[{i}]")))
                .collect::<PyResult<Vec<_>>>()?;
            cols.push((name, values));
        }
        check_override_names(cols.iter().map(|(k, _)| k.as_str())).map_err(rhex_err)?;
        let mut parsed: Vec<(String, Strategy)> = Vec::new();
        let mut points = Vec::with_capacity(n);
        for i in 0..n {
            let s = match parsed.iter().find(|(k, _)| *k == strategies[i]) {
                Some((_, s)) => *s,
                None => {
                    let s: Strategy = strategies[i].parse().map_err(rhex_err)?;
                    parsed.push((strategies[i].clone(), s));
                    s
                }
            };
            let (saturated, gear) = actuator_choice(gear_ratio[i]);
            let mut pt = LeapPoint::new(s, t2_s[i], gear);
            for (k, a) in &cols {
                pt.overrides.insert(k.clone(), a[i].clone());
            }
            points.push((saturated, pt));
        }
        let names = sensitivities.clone();
        let rows = interrupt::run(py, progress, move |shared: &Shared| {
            sweep_rows(&bases, &points, threads, names.as_deref(), shared)
        })?
        .map_err(|e| invalid("threads", e))?;
        let rows: Vec<Row> = rows
            .into_iter()
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| errors::engine("the sweep was cancelled"))?;
        let (rows, sens): (Vec<SweepRow>, Vec<RowSensitivities>) = rows.into_iter().unzip();
        let d = PyDict::new(py);
        if let Some(names) = &sensitivities {
            let k = names.len();
            for (c, col) in APEX_COLUMNS.iter().enumerate() {
                for (j, name) in names.iter().enumerate() {
                    let v: Vec<f64> = sens
                        .iter()
                        .map(|s| s.as_ref().map_or(f64::NAN, |(_, v)| v[c * k + j]))
                        .collect();
                    d.set_item(format!("d_{col}/d_{name}"), v.into_pyarray(py))?;
                }
            }
            let ok: Vec<bool> = sens
                .iter()
                .map(|s| s.as_ref().is_some_and(|x| x.0))
                .collect();
            d.set_item("sensitivity_ok", ok.into_pyarray(py))?;
        }
        d.set_item("gear_ratio", column(py, &rows, |r| r.columns[0]))?;
        for (c, name) in APEX_COLUMNS.iter().enumerate() {
            d.set_item(*name, column(py, &rows, |r| r.apex_columns()[c]))?;
        }
        d.set_item("n_events", column(py, &rows, |r| r.n_events as i64))?;
        let text = |name: &str, field: fn(&SweepRow) -> &str| {
            d.set_item(name, PyList::new(py, rows.iter().map(field))?)
        };
        text("word", |r| &r.word)?;
        text("status", |r| &r.status)?;
        d.set_item("flew", column(py, &rows, |r| r.flew))?;
        text("error", |r| &r.error)?;
        Ok(d)
    })
}

fn event_kind(k: &str, field: &str) -> PyResult<&'static str> {
    Ok(match k {
        "touchdown" => "touchdown",
        "liftoff" => "liftoff",
        "slip" => "slip",
        "stick" => "stick",
        "apex" => "apex",
        "end" => "end",
        other => {
            return Err(invalid(
                field,
                format!(
                    "`{field}`: event kind `{other}` is not one of touchdown, liftoff, slip, \
                     stick, apex"
                ),
            ))
        }
    })
}

fn pairs_from(
    a: &numpy::PyReadonlyArray3<'_, f64>,
    field: &str,
    n: usize,
    nc: usize,
) -> PyResult<Vec<Vec<Option<[f64; 2]>>>> {
    let v = a.as_array();
    if v.shape() != [n, nc, 2] {
        return Err(invalid(
            field,
            format!(
                "`{field}` has shape {:?}, expected ({n}, {nc}, 2)",
                v.shape()
            ),
        ));
    }
    Ok((0..n)
        .map(|k| {
            (0..nc)
                .map(|c| {
                    let (x, z) = (v[[k, c, 0]], v[[k, c, 1]]);
                    (!(x.is_nan() || z.is_nan())).then_some([x, z])
                })
                .collect()
        })
        .collect())
}

fn rows_from(
    a: &numpy::PyReadonlyArray2<'_, f64>,
    field: &str,
    n: usize,
) -> PyResult<Vec<Vec<f64>>> {
    let v = a.as_array();
    if v.nrows() != n {
        return Err(invalid(
            field,
            format!("`{field}` has {} rows, expected {n}", v.nrows()),
        ));
    }
    Ok(v.rows().into_iter().map(|r| r.to_vec()).collect())
}

/// One event from a dict `{t_s, kind, mode_before, mode_after, contacts, energy_loss_j,
/// impulse_n_s, force_n}`.
fn event_from(e: &Bound<'_, PyAny>, i: usize) -> PyResult<EventRecord> {
    let field = |k: &str| format!("events[{i}].{k}");
    let get = |k: &str| -> PyResult<Option<Bound<'_, PyAny>>> {
        match e.get_item(k) {
            Ok(v) => Ok(Some(v)),
            Err(err) if err.is_instance_of::<pyo3::exceptions::PyKeyError>(e.py()) => Ok(None),
            Err(_) => Err(errors::invalid_type(
                &format!("events[{i}]"),
                format!("`events[{i}]` must be a dict"),
            )),
        }
    };
    let typed = |k: &str, v: Bound<'_, PyAny>| -> PyResult<Value> { to_value(&v, &field(k)) };
    let text = |k: &str| -> PyResult<String> {
        match get(k)? {
            None => Ok(String::new()),
            Some(v) => v.extract().map_err(|_| {
                errors::invalid_type(&field(k), format!("`{}` must be a string", field(k)))
            }),
        }
    };
    let t_s = match get("t_s")? {
        Some(v) => typed("t_s", v)?.as_f64().ok_or_else(|| {
            errors::invalid_type(
                &field("t_s"),
                format!("`{}` must be a number", field("t_s")),
            )
        })?,
        None => {
            return Err(invalid(
                &field("t_s"),
                format!("`{}` is missing", field("t_s")),
            ))
        }
    };
    let contacts = match get("contacts")? {
        None => Vec::new(),
        Some(v) => v.extract().map_err(|_| {
            errors::invalid_type(
                &field("contacts"),
                format!("`{}` must be a list of names", field("contacts")),
            )
        })?,
    };
    let energy_loss_j = match get("energy_loss_j")? {
        None => 0.0,
        Some(v) => typed("energy_loss_j", v)?.as_f64().unwrap_or(0.0),
    };
    // per contact: None or [x, z] (the keys of `LeapResult.events`; absent: none)
    let sites = |k: &str| -> PyResult<Vec<Option<[f64; 2]>>> {
        match get(k)? {
            None => Ok(Vec::new()),
            Some(v) => v.extract().map_err(|_| {
                errors::invalid_type(
                    &field(k),
                    format!(
                        "`{}` must be a list of None or [x, z] per contact",
                        field(k)
                    ),
                )
            }),
        }
    };
    Ok(EventRecord {
        t_s,
        kind: event_kind(&text("kind")?, &field("kind"))?,
        mode_before: text("mode_before")?,
        mode_after: text("mode_after")?,
        contacts,
        energy_loss_j,
        impulse_n_s: sites("impulse_n_s")?,
        force_n: sites("force_n")?,
    })
}

/// Writes a leap's MCAP log atomically (see `rhex_model::mcap_log` for the topics).
/// `params` is a dict of Table 4.2 values; `events` a list of dicts with the keys of
/// `LeapResult.events`.
#[pyfunction]
#[pyo3(signature = (path, params, contacts, t_s, q, qd, mode, contact_points_m, contact_forces_n, events, metadata))]
#[allow(clippy::too_many_arguments)]
fn leap_write_mcap(
    py: Python<'_>,
    path: std::path::PathBuf,
    params: &Bound<'_, PyDict>,
    contacts: Vec<String>,
    t_s: Vec<f64>,
    q: numpy::PyReadonlyArray2<'_, f64>,
    qd: numpy::PyReadonlyArray2<'_, f64>,
    mode: Vec<String>,
    contact_points_m: numpy::PyReadonlyArray3<'_, f64>,
    contact_forces_n: numpy::PyReadonlyArray3<'_, f64>,
    events: &Bound<'_, PyList>,
    metadata: BTreeMap<String, String>,
) -> PyResult<()> {
    errors::guard(|| {
        let params: RhexParams = serde_json::from_value(Value::Object(to_map(params, "params")?))
            .map_err(|e| invalid("params", format!("params: {e}")))?;
        let rhex =
            rhex_model::Rhex::new(params.clone()).map_err(|e| errors::rhex(e, Source::Caller))?;
        let n = t_s.len();
        let nc = contacts.len();
        let tr = Trajectory {
            q_names: q_names(&rhex.model),
            tau: Vec::new(),
            q: rows_from(&q, "q", n)?,
            qd: rows_from(&qd, "qd", n)?,
            contact_points_m: pairs_from(&contact_points_m, "contact_points_m", n, nc)?,
            contact_forces_n: pairs_from(&contact_forces_n, "contact_forces_n", n, nc)?,
            contacts,
            t_s,
            mode,
        };
        let events = events
            .iter()
            .enumerate()
            .map(|(i, e)| event_from(&e, i))
            .collect::<PyResult<Vec<_>>>()?;
        py.detach(|| {
            write_leap_mcap(
                &path,
                &LeapLog {
                    trajectory: &tr,
                    events: &events,
                    params: &params,
                    metadata,
                },
            )
        })
        .map_err(|e| match e {
            // the OSError subclass of the kind (FileNotFoundError, PermissionError, …)
            RhexError::Sim(SimError::Io { message, kind, .. }) => PyErr::from(std::io::Error::new(
                kind,
                format!("MCAP log I/O: {message} (writing {})", path.display()),
            )),
            e => errors::rhex(e, errors::Source::Caller),
        })
    })
}
