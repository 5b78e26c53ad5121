//! `selfmanip.leap` / `selfmanip.sweep`'s native half: one leap, a batched sweep on an
//! explicit rayon pool (GIL released), MCAP logs. Conversions only; the semantics live in
//! `rhex_model::{leap, sweep, mcap_log}`.
//!
//! Inputs by name: a JSON object of overrides (Table 4.2 symbols, `LeapConfig` fields, the
//! geared motor's `current_limit_a` / `motors_per_leg`) applied to `leap_params()` and
//! `LeapConfig::default()` with the saturated-torque actuator; a gear ratio selects the
//! geared motor.
use crate::{guard, to_py_err};
use numpy::ndarray::{Array2, Array3};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rhex_model::leap::{leap_params, LeapConfig, LeapEvent, LegActuator, Strategy, Trajectory};
use rhex_model::mcap_log::{q_names, write_leap_mcap, LeapLog};
use rhex_model::sweep::{check_override_names, point_inputs, sweep, sweepable_names, SweepPoint};
use rhex_model::RhexParams;
use serde_json::{Map, Value};
use std::collections::BTreeMap;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(leap_run, m)?)?;
    m.add_function(wrap_pyfunction!(leap_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(leap_write_mcap, m)?)?;
    m.add_function(wrap_pyfunction!(leap_sweepable_names, m)?)?;
    m.add_function(wrap_pyfunction!(leap_defaults_json, m)?)?;
    m.add_function(wrap_pyfunction!(leap_grammar_text, m)?)?;
    Ok(())
}

fn err(msg: String) -> PyErr {
    crate::SelfmanipError::new_err(msg)
}

/// The base of every leap: chapter 5's parameters, the default configuration with the
/// saturated torque (a gear ratio switches to the geared motor).
fn base() -> (RhexParams, LeapConfig) {
    (
        leap_params(),
        LeapConfig {
            actuator: LegActuator::SaturatedTorque,
            ..LeapConfig::default()
        },
    )
}

fn parse_overrides(json: &str) -> PyResult<Map<String, Value>> {
    match serde_json::from_str::<Value>(json).map_err(|e| err(format!("overrides: {e}")))? {
        Value::Object(m) => Ok(m),
        _ => Err(err("overrides must be a mapping of parameter names".into())),
    }
}

fn gear(g: f64) -> Option<f64> {
    (!g.is_nan()).then_some(g)
}

/// Resolves the inputs of one leap (errors name the field).
fn resolve(
    strategy: &str,
    t2_s: f64,
    gear_ratio: Option<f64>,
    overrides_json: &str,
) -> PyResult<(RhexParams, LeapConfig)> {
    let strategy: Strategy = strategy.parse().map_err(to_py_err)?;
    let mut pt = SweepPoint::new(strategy, t2_s, gear_ratio);
    pt.overrides = parse_overrides(overrides_json)?;
    let (p, c) = base();
    point_inputs(&p, &c, &pt).map_err(to_py_err)
}

/// Every parameter name a sweep or a leap accepts.
#[pyfunction]
fn leap_sweepable_names() -> Vec<String> {
    sweepable_names()
}

/// `{"params": leap_params(), "config": LeapConfig::default()}` as JSON.
#[pyfunction]
fn leap_defaults_json() -> PyResult<String> {
    let (p, c) = base();
    serde_json::to_string(&serde_json::json!({"params": p, "config": c})).map_err(to_py_err)
}

/// The leap grammar of chapter 3 as readable text.
#[pyfunction]
fn leap_grammar_text() -> String {
    rhex_model::grc::leap_grammar_text()
}

fn opt_pairs(rows: &[Vec<Option<[f64; 2]>>], nc: usize) -> Array3<f64> {
    Array3::from_shape_fn((rows.len(), nc, 2), |(k, c, i)| {
        rows[k][c].map_or(f64::NAN, |v| v[i])
    })
}

fn rows2(rows: &[Vec<f64>], ncols: usize) -> Array2<f64> {
    Array2::from_shape_fn((rows.len(), ncols), |(k, j)| rows[k][j])
}

/// One leap. Returns a dict: `status`, `apex` (dict or None), `word` (list of cells),
/// `events`, `q0`, `q_names`, `params_json`, `config_json`, and, when `dt_s` is given,
/// `trajectory` (numpy arrays).
#[pyfunction]
#[pyo3(signature = (strategy, t2_s, gear_ratio, overrides_json, dt_s=None))]
fn leap_run<'py>(
    py: Python<'py>,
    strategy: &str,
    t2_s: f64,
    gear_ratio: Option<f64>,
    overrides_json: &str,
    dt_s: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let (params, cfg) = resolve(strategy, t2_s, gear_ratio, overrides_json)?;
        if let Some(dt) = dt_s {
            if !(dt.is_finite() && dt > 0.0) {
                return Err(err(format!("`dt` must be finite and positive, got {dt}")));
            }
        }
        let (res, traj) = py
            .detach(|| {
                let res = rhex_model::leap::simulate_leap(&params, &cfg)?;
                let traj = match dt_s {
                    Some(dt) => Some(res.trajectory(&params, &cfg, dt)?),
                    None => None,
                };
                Ok::<_, rhex_model::RhexError>((res, traj))
            })
            .map_err(to_py_err)?;
        let d = PyDict::new(py);
        d.set_item("status", res.status.as_str())?;
        match res.apex {
            Some(a) => {
                let ad = PyDict::new(py);
                ad.set_item("t_s", a.t_s)?;
                ad.set_item("x_m", a.x_m)?;
                ad.set_item("z_m", a.z_m)?;
                ad.set_item("phi_rad", a.phi_rad)?;
                ad.set_item("xdot_m_s", a.xdot_m_s)?;
                ad.set_item("zdot_m_s", a.zdot_m_s)?;
                ad.set_item("phidot_rad_s", a.phidot_rad_s)?;
                d.set_item("apex", ad)?;
            }
            None => d.set_item("apex", py.None())?,
        }
        d.set_item("word", res.word.clone())?;
        d.set_item(
            "events_json",
            serde_json::to_string(&res.events).map_err(to_py_err)?,
        )?;
        d.set_item("q0", res.q0.clone())?;
        d.set_item("q_names", q_names(&params))?;
        d.set_item("time_offset_s", res.time_offset_s)?;
        d.set_item(
            "params_json",
            serde_json::to_string(&params).map_err(to_py_err)?,
        )?;
        d.set_item(
            "config_json",
            serde_json::to_string(&cfg).map_err(to_py_err)?,
        )?;
        if let Some(tr) = traj {
            let nq = tr.q.first().map_or(params.pairs.len() + 3, |r| r.len());
            let nc = tr.contacts.len();
            let td = PyDict::new(py);
            td.set_item("contacts", tr.contacts.clone())?;
            td.set_item("t_s", tr.t_s.clone().into_pyarray(py))?;
            td.set_item("q", rows2(&tr.q, nq).into_pyarray(py))?;
            td.set_item("qd", rows2(&tr.qd, nq).into_pyarray(py))?;
            td.set_item("mode", tr.mode.clone())?;
            td.set_item(
                "contact_points_m",
                opt_pairs(&tr.contact_points_m, nc).into_pyarray(py),
            )?;
            td.set_item(
                "contact_forces_n",
                opt_pairs(&tr.contact_forces_n, nc).into_pyarray(py),
            )?;
            d.set_item("trajectory", td)?;
        }
        Ok(d)
    })
}

/// A sweep. Per point: `strategies[i]`, `t2_s[i]`, `gear_ratio[i]` (NaN: saturated torque),
/// and the columns of `point_overrides_json` (`{"name": [v0, v1, …]}`); `base_overrides_json`
/// applies to every point and is checked up front. Returns a dict of columns (numpy arrays
/// for numbers, lists for strings).
#[pyfunction]
#[pyo3(signature = (strategies, t2_s, gear_ratio, base_overrides_json, point_overrides_json, threads))]
fn leap_sweep<'py>(
    py: Python<'py>,
    strategies: Vec<String>,
    t2_s: Vec<f64>,
    gear_ratio: Vec<f64>,
    base_overrides_json: &str,
    point_overrides_json: &str,
    threads: usize,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let n = strategies.len();
        if t2_s.len() != n || gear_ratio.len() != n {
            return Err(err(format!(
                "strategy, t2 and gear_ratio must have one entry per point: {n}, {}, {}",
                t2_s.len(),
                gear_ratio.len()
            )));
        }
        // the base, checked once (a bad base is an error of the call, not of every point)
        let first = strategies.first().map_or("++", |s| s.as_str());
        let (bp, bc) = resolve(first, 0.0, None, base_overrides_json)?;
        let columns = parse_overrides(point_overrides_json)?;
        check_override_names(columns.keys().map(|k| k.as_str())).map_err(to_py_err)?;
        let mut cols: Vec<(&String, &Vec<Value>)> = Vec::new();
        for (k, v) in &columns {
            match v {
                Value::Array(a) if a.len() == n => cols.push((k, a)),
                _ => {
                    return Err(err(format!(
                        "RHex parameter `{k}`: the swept column must have one value per point ({n})"
                    )))
                }
            }
        }
        let mut parsed: Vec<(String, Strategy)> = Vec::new();
        let mut points = Vec::with_capacity(n);
        for i in 0..n {
            let s = match parsed.iter().find(|(k, _)| *k == strategies[i]) {
                Some((_, s)) => *s,
                None => {
                    let s: Strategy = strategies[i].parse().map_err(to_py_err)?;
                    parsed.push((strategies[i].clone(), s));
                    s
                }
            };
            let mut pt = SweepPoint::new(s, t2_s[i], gear(gear_ratio[i]));
            for (k, a) in &cols {
                pt.overrides.insert((*k).clone(), a[i].clone());
            }
            points.push(pt);
        }
        let rows = py
            .detach(|| sweep(&bp, &bc, &points, threads))
            .map_err(to_py_err)?;
        let d = PyDict::new(py);
        let f = |g: fn(&rhex_model::sweep::SweepRow) -> f64| -> Vec<f64> {
            rows.iter().map(g).collect()
        };
        d.set_item("gear_ratio", f(|r| r.gear_ratio).into_pyarray(py))?;
        d.set_item("apex_t_s", f(|r| r.apex_t_s).into_pyarray(py))?;
        d.set_item("apex_x_m", f(|r| r.apex_x_m).into_pyarray(py))?;
        d.set_item("apex_z_m", f(|r| r.apex_z_m).into_pyarray(py))?;
        d.set_item("apex_phi_rad", f(|r| r.apex_phi_rad).into_pyarray(py))?;
        d.set_item("apex_xdot_m_s", f(|r| r.apex_xdot_m_s).into_pyarray(py))?;
        d.set_item("apex_zdot_m_s", f(|r| r.apex_zdot_m_s).into_pyarray(py))?;
        d.set_item(
            "apex_phidot_rad_s",
            f(|r| r.apex_phidot_rad_s).into_pyarray(py),
        )?;
        d.set_item(
            "n_events",
            rows.iter()
                .map(|r| r.n_events as i64)
                .collect::<Vec<_>>()
                .into_pyarray(py),
        )?;
        d.set_item(
            "word",
            PyList::new(py, rows.iter().map(|r| r.word.as_str()))?,
        )?;
        d.set_item(
            "status",
            PyList::new(py, rows.iter().map(|r| r.status.as_str()))?,
        )?;
        d.set_item(
            "error",
            PyList::new(py, rows.iter().map(|r| r.error.as_str()))?,
        )?;
        Ok(d)
    })
}

fn event_kind(k: &str) -> PyResult<&'static str> {
    Ok(match k {
        "touchdown" => "touchdown",
        "liftoff" => "liftoff",
        "slip" => "slip",
        "stick" => "stick",
        "apex" => "apex",
        "end" => "end",
        other => {
            return Err(err(format!(
                "event kind `{other}` is not one of touchdown, liftoff, slip, stick, apex"
            )))
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
        return Err(err(format!(
            "`{field}` has shape {:?}, expected ({n}, {nc}, 2)",
            v.shape()
        )));
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
        return Err(err(format!(
            "`{field}` has {} rows, expected {n}",
            v.nrows()
        )));
    }
    Ok(v.rows().into_iter().map(|r| r.to_vec()).collect())
}

/// Writes a leap's MCAP log atomically (see `rhex_model::mcap_log` for the topics).
/// `events_json` is a list of `{t_s, kind, mode_before, mode_after, contacts, energy_loss_j}`.
#[pyfunction]
#[pyo3(signature = (path, params_json, contacts, t_s, q, qd, mode, contact_points_m, contact_forces_n, events_json, metadata))]
#[allow(clippy::too_many_arguments)]
fn leap_write_mcap(
    py: Python<'_>,
    path: std::path::PathBuf,
    params_json: &str,
    contacts: Vec<String>,
    t_s: Vec<f64>,
    q: numpy::PyReadonlyArray2<'_, f64>,
    qd: numpy::PyReadonlyArray2<'_, f64>,
    mode: Vec<String>,
    contact_points_m: numpy::PyReadonlyArray3<'_, f64>,
    contact_forces_n: numpy::PyReadonlyArray3<'_, f64>,
    events_json: &str,
    metadata: BTreeMap<String, String>,
) -> PyResult<()> {
    guard(|| {
        let params: RhexParams =
            serde_json::from_str(params_json).map_err(|e| err(format!("params: {e}")))?;
        params.validate().map_err(to_py_err)?;
        let n = t_s.len();
        let nc = contacts.len();
        let tr = Trajectory {
            q: rows_from(&q, "q", n)?,
            qd: rows_from(&qd, "qd", n)?,
            contact_points_m: pairs_from(&contact_points_m, "contact_points_m", n, nc)?,
            contact_forces_n: pairs_from(&contact_forces_n, "contact_forces_n", n, nc)?,
            contacts,
            t_s,
            mode,
        };
        let raw: Vec<Value> =
            serde_json::from_str(events_json).map_err(|e| err(format!("events: {e}")))?;
        let mut events = Vec::with_capacity(raw.len());
        for e in &raw {
            let s = |k: &str| e.get(k).and_then(|v| v.as_str()).unwrap_or("").to_string();
            events.push(LeapEvent {
                t_s: e
                    .get("t_s")
                    .and_then(|v| v.as_f64())
                    .ok_or_else(|| err("events: `t_s` missing".into()))?,
                kind: event_kind(&s("kind"))?,
                mode_before: s("mode_before"),
                mode_after: s("mode_after"),
                contacts: e
                    .get("contacts")
                    .and_then(|v| v.as_array())
                    .map(|a| {
                        a.iter()
                            .filter_map(|c| c.as_str().map(String::from))
                            .collect()
                    })
                    .unwrap_or_default(),
                energy_loss_j: e
                    .get("energy_loss_j")
                    .and_then(|v| v.as_f64())
                    .unwrap_or(0.0),
            });
        }
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
        .map_err(to_py_err)
    })
}
