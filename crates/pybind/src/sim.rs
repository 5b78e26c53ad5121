//! `selfmanip.simulate` / `selfmanip.sweep`'s native half for any robot: a [`Scenario`] (the
//! Rust `selfmanip_sim::Scenario`) built from Python objects, its [`Run`], and sweeps over
//! named parameters. Conversions only; the semantics (defaults, checks, the word, the sweep's
//! determinism and per-point statuses) live in `selfmanip_sim`.
//!
//! **Inputs** arrive as Python objects: the robot as a `selfmanip._native.Robot`, a
//! description dict or a file path; the behaviour as a dict, a file path or `None` (no
//! actuation); the terrain as a dict (`{"kind": "ledge", …}`), a kind name or `None`;
//! options as a dict of `SimOptions` fields. Every absent field keeps the Rust default.
//!
//! **Work** runs on a worker thread with the GIL released and is interruptible by Ctrl-C
//! ([`crate::interrupt`]): the cancellation flag is the engine's stop flag, so a long run ends
//! within one integration step.
//!
//! **A Python controller** (`controller(t, q, qd, mode) -> tau`) is a Rust
//! [`selfmanip_hybrid::Controller`] that takes the GIL for every evaluation (the slow escape
//! hatch). An exception it raises, or a result of the wrong length or with a non-finite
//! entry, is stored, raises the stop flag (the run ends within one step) and is re-raised as a
//! typed error (`ControllerError` with the original as its cause, or `InvalidInputError` /
//! `InvalidTypeError` naming `controller`): never a panic across the FFI.
//!
//! **Sensitivities and periodic orbits** ([`PyRun::sensitivity`],
//! [`PyScenario::periodic_orbit`]) convert `selfmanip_hybrid::sensitivity` and
//! `selfmanip_sim::periodic` results: matrices as 2-D numpy arrays, multipliers as complex
//! arrays, a saltation matrix `None` with the reason where the engine flags it.
use crate::convert::{pairs_array, rows_array, to_map, to_py, to_value, AnyOut, DictOut};
use crate::errors::{self, guard, invalid, invalid_type, Source};
use crate::interrupt::{self, Shared};
use nalgebra::DMatrix;
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyList, PyString, PyTuple, PyType};
use selfmanip_core::{ContactMode, RobotDescription};
use selfmanip_hybrid::periodic::{PeriodicError, Stability};
use selfmanip_hybrid::sensitivity::SensitivityError;
use selfmanip_hybrid::Controller;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::labels::ContactLabels;
use selfmanip_sim::periodic::{periodic_orbit, run_sensitivity, PeriodicRunError, PeriodicSpec};
use selfmanip_sim::sensitivity::{scenario_parameter_sensitivity, ParameterPathError};
use selfmanip_sim::sweep::{grid, sweep_with, PointResult};
use selfmanip_sim::trajectory::{q_names, DEFAULT_DT_S};
use selfmanip_sim::{InitialState, Scenario, SimError, SimOptions, Simulation, TerrainSpec};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyScenario>()?;
    m.add_class::<PyRun>()?;
    add_functions! { m, sim_defaults }
    m.add(
        "SIM_MAX_SWEEP_POINTS",
        selfmanip_sim::sweep::MAX_SWEEP_POINTS,
    )?;
    Ok(())
}

fn caller_err(e: SimError) -> PyErr {
    errors::sim(e, Source::Caller)
}

fn engine_err(e: SimError) -> PyErr {
    errors::sim(e, Source::Engine)
}

/// A JSON value as `T`, or an error of `what` (`behaviour`, `terrain`, `robot`).
fn from_json<T: serde::de::DeserializeOwned>(v: Value, what: &str) -> PyResult<T> {
    serde_json::from_value(v).map_err(|e| {
        caller_err(SimError::Parse {
            what: what.into(),
            format: "python",
            message: e.to_string(),
        })
    })
}

/// `{"t_final_s": …, "sample_dt_s": …, "options": {…}}`: the Rust defaults.
#[pyfunction]
fn sim_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    let o = SimOptions::default();
    d.set_item("t_final_s", o.t_final_s)?;
    d.set_item("sample_dt_s", DEFAULT_DT_S)?;
    d.set_item("options", to_py(py, &o)?)?;
    Ok(d)
}

/// The names of the coordinates `indices` (into `names`).
fn named(names: &[String], indices: &[usize]) -> Vec<String> {
    indices.iter().map(|&i| names[i].clone()).collect()
}

/// A description (`what`: `robot`, `behaviour`) given as a dict, or else the path of its
/// file, opened by `from_file`; anything else is a type error naming `what` with `message`.
fn dict_or_file<T: serde::de::DeserializeOwned>(
    obj: &Bound<'_, PyAny>,
    what: &str,
    message: &str,
    from_file: impl FnOnce(&PathBuf) -> PyResult<T>,
) -> PyResult<T> {
    if obj.is_instance_of::<PyDict>() {
        return from_json(to_value(obj, what)?, what);
    }
    let path: PathBuf = obj.extract().map_err(|_| invalid_type(what, message))?;
    from_file(&path)
}

fn robot_description(robot: &Bound<'_, PyAny>) -> PyResult<RobotDescription> {
    if let Ok(r) = robot.cast::<crate::robot::Robot>() {
        return Ok(r.get().description().clone());
    }
    dict_or_file(
        robot,
        "robot",
        "`robot` must be a selfmanip.Robot, a description dict or a file path",
        |path| RobotDescription::from_file(path).map_err(|e| errors::core(e, Source::Caller)),
    )
}

fn behaviour_of(b: Option<&Bound<'_, PyAny>>) -> PyResult<Behaviour> {
    let Some(b) = b.filter(|b| !b.is_none()) else {
        return Ok(Behaviour::default());
    };
    dict_or_file(
        b,
        "behaviour",
        "`behaviour` must be a dict, a file path or None",
        |path| Behaviour::from_file(path).map_err(caller_err),
    )
}

fn terrain_of(t: Option<&Bound<'_, PyAny>>) -> PyResult<TerrainSpec> {
    let Some(t) = t.filter(|t| !t.is_none()) else {
        return Ok(TerrainSpec::default());
    };
    let v = if let Ok(s) = t.cast::<PyString>() {
        serde_json::json!({ "kind": s.to_str()? })
    } else {
        to_value(t, "terrain")?
    };
    from_json(v, "terrain")
}

/// The options: the fields given over the Rust defaults; an unknown or mistyped field names
/// itself (`options.<field>`).
fn options_of(o: Option<&Bound<'_, PyDict>>) -> PyResult<SimOptions> {
    match o {
        None => Ok(SimOptions::default()),
        Some(o) => fields_of(o, "options."),
    }
}

/// A struct of optional fields from a dict; an unknown or mistyped field names itself
/// (`<prefix><field>`).
fn fields_of<T: serde::de::DeserializeOwned>(o: &Bound<'_, PyDict>, prefix: &str) -> PyResult<T> {
    let map = to_map(o, "options")?;
    serde_json::from_value(Value::Object(map.clone())).map_err(|e| {
        let culprit = map.iter().find_map(|(k, v)| {
            let one = serde_json::json!({ k.as_str(): v });
            serde_json::from_value::<T>(one).err().map(|e| (k, e))
        });
        match culprit {
            Some((k, e1)) => invalid(&format!("{prefix}{k}"), format!("`{prefix}{k}`: {e1}")),
            None => invalid("options", format!("options: {e}")),
        }
    })
}

/// A scenario: robot description, terrain, initial state, behaviour and options
/// (`selfmanip_sim::Scenario`).
#[pyclass(module = "selfmanip._native", name = "Scenario")]
#[derive(Clone)]
pub struct PyScenario {
    inner: Scenario,
}

#[pymethods]
impl PyScenario {
    /// Builds a scenario from its parts (see the module documentation); nothing is checked
    /// against the robot until it runs.
    #[new]
    #[pyo3(signature = (robot, behaviour, q0, qd0=None, terrain=None, contacts=None, solve=None, options=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        robot: &Bound<'_, PyAny>,
        behaviour: Option<&Bound<'_, PyAny>>,
        q0: Vec<f64>,
        qd0: Option<Vec<f64>>,
        terrain: Option<&Bound<'_, PyAny>>,
        contacts: Option<Vec<String>>,
        solve: Option<Vec<String>>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        guard(|| {
            Ok(PyScenario {
                inner: Scenario {
                    robot: robot_description(robot)?,
                    terrain: terrain_of(terrain)?,
                    initial: InitialState {
                        q: q0,
                        qd: qd0,
                        contacts: contacts.unwrap_or_default(),
                        solve: solve.unwrap_or_default(),
                    },
                    behaviour: behaviour_of(behaviour)?,
                    options: options_of(options)?,
                },
            })
        })
    }

    /// A scenario file (`.toml` or `.json`).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        guard(|| {
            Ok(PyScenario {
                inner: Scenario::from_file(&path).map_err(caller_err)?,
            })
        })
    }

    /// A scenario from its plain-data form (`to_dict`); numbers cross exactly.
    #[staticmethod]
    fn from_dict(data: &Bound<'_, PyDict>) -> PyResult<Self> {
        guard(|| {
            Ok(PyScenario {
                inner: from_json(Value::Object(to_map(data, "")?), "scenario")?,
            })
        })
    }

    /// `pickle` and `copy`: rebuilt from its plain-data form.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let py = slf.py();
        let data = to_py(py, &slf.borrow().inner)?;
        Ok((
            slf.get_type().getattr("from_dict")?,
            PyTuple::new(py, [data])?,
        ))
    }

    /// Sets one field by name (a behaviour parameter such as `kp_push`, or a path such as
    /// `legs.leg.links[1].length_m`, `terrain.height_m`, `options.rtol`).
    fn set(&mut self, name: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| {
            let v = to_value(value, name)?;
            self.inner.set(name, v).map_err(caller_err)
        })
    }

    /// Every name a parameter can be set by.
    fn settable_names(&self) -> PyResult<Vec<String>> {
        self.inner.settable_names().map_err(caller_err)
    }

    /// The scenario as plain Python data (the form parameter paths address).
    fn to_dict<'py>(&self, py: Python<'py>) -> AnyOut<'py> {
        to_py(py, &self.inner)
    }

    /// Names of the coordinates of `q` (`<joint>_theta`…, `x`, `z`, `phi`).
    fn q_names(&self) -> PyResult<Vec<String>> {
        let model = self
            .inner
            .robot
            .build()
            .map_err(|e| errors::core(e, Source::Caller))?;
        Ok(q_names(&model))
    }

    /// Runs the scenario: with its behaviour, or, when `controller` is given, with that Python
    /// callable `controller(t, q, qd, mode) -> tau` (the behaviour is then not read).
    #[pyo3(signature = (controller=None))]
    fn run(&self, py: Python<'_>, controller: Option<Bound<'_, PyAny>>) -> PyResult<PyRun> {
        guard(|| {
            let shared = Arc::new(Shared::default());
            let failure: Failure = Arc::new(Mutex::new(None));
            let replay = controller.as_ref().map(|f| f.clone().unbind());
            let sim = match controller {
                None => Simulation::new(&self.inner).map_err(caller_err)?,
                Some(f) => {
                    if !f.is_callable() {
                        return Err(invalid_type(
                            "controller",
                            "`controller` must be callable as controller(t, q, qd, mode) -> tau",
                        ));
                    }
                    let mut sim = Simulation::without_behaviour(&self.inner).map_err(caller_err)?;
                    sim.controller = Arc::new(PyController {
                        f: Arc::new(f.unbind()),
                        labels: sim.labels.clone(),
                        n_joints: sim.model.n_joints(),
                        failure: Arc::clone(&failure),
                        shared: Arc::clone(&shared),
                    });
                    sim
                }
            };
            let model = Arc::clone(&sim.model);
            let run = interrupt::run_shared(py, None, shared, move |sh: &Shared| {
                sim.run_with(&sh.cancel)
            })?;
            take_failure(&failure)?;
            let q0 = &self.inner.initial.q;
            Ok(PyRun {
                inner: run.map_err(|e| match e {
                    e @ SimError::Io { .. } => engine_err(e),
                    e => errors::map_sim(&e, Source::Engine)
                        .naming_massless_joints(&model, q0)
                        .into_pyerr(),
                })?,
                failure,
                scenario: self.inner.clone(),
                controller: replay,
            })
        })
    }

    /// The periodic orbit through the apex section near this scenario's initial state (the
    /// guess), found by Newton shooting (`selfmanip_sim::periodic`); `options`: fields of
    /// `PeriodicSpec` (`tol`, `max_iterations`, `cyclic`, `rtol`, …). Returns a dict (see
    /// `selfmanip.periodic_orbit`).
    #[pyo3(signature = (options=None))]
    fn periodic_orbit<'py>(
        &self,
        py: Python<'py>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> DictOut<'py> {
        guard(|| {
            let spec: PeriodicSpec = match options {
                None => PeriodicSpec::default(),
                Some(o) => fields_of(o, "")?,
            };
            let scenario = self.inner.clone();
            let found = py.detach(move || periodic_orbit(&scenario, &spec));
            let (sim, o) = found.map_err(periodic_err)?;
            let names = q_names(&sim.model);
            let state_names: Vec<String> = names
                .iter()
                .cloned()
                .chain(names.iter().map(|n| format!("{n}dot")))
                .collect();
            let nq = sim.model.nq();
            let d = PyDict::new(py);
            d.set_item("x", o.x.clone().into_pyarray(py))?;
            d.set_item("q", o.x[..nq].to_vec().into_pyarray(py))?;
            d.set_item("qd", o.x[nq..].to_vec().into_pyarray(py))?;
            d.set_item("state_names", state_names.clone())?;
            d.set_item("period_s", o.period_s)?;
            d.set_item("cyclic", named(&names, &o.cyclic))?;
            d.set_item("drift", o.drift.clone().into_pyarray(py))?;
            let events = PyList::empty(py);
            for (kind, mode) in &o.events {
                let e = PyDict::new(py);
                e.set_item("kind", kind.name())?;
                e.set_item("mode_after", sim.labels.label(*mode))?;
                events.append(e)?;
            }
            d.set_item("events", events)?;
            d.set_item("monodromy", matrix(&o.monodromy).into_pyarray(py))?;
            d.set_item(
                "period_monodromy",
                matrix(&o.period_monodromy).into_pyarray(py),
            )?;
            d.set_item("multipliers", o.multipliers.clone().into_pyarray(py))?;
            d.set_item(
                "section_coordinates",
                named(&state_names, &o.section_coordinates),
            )?;
            d.set_item(
                "section_jacobian",
                matrix(&o.section_jacobian).into_pyarray(py),
            )?;
            d.set_item(
                "section_multipliers",
                o.section_multipliers.clone().into_pyarray(py),
            )?;
            d.set_item(
                "stability",
                match o.stability {
                    Stability::Stable => "stable",
                    Stability::Neutral => "neutral",
                    Stability::Unstable => "unstable",
                },
            )?;
            d.set_item("iterations", o.iterations)?;
            d.set_item("residual", o.residual)?;
            d.set_item("rank_deficiency", o.rank_deficiency)?;
            let one_sided = PyList::empty(py);
            for e in &o.one_sided {
                let ed = PyDict::new(py);
                ed.set_item("t_s", e.t)?;
                ed.set_item("kind", e.kind.name())?;
                let contact = |c: &usize| sim.model.contacts[*c].name.clone();
                ed.set_item("guards", e.guards.iter().map(contact).collect::<Vec<_>>())?;
                ed.set_item(
                    "orders",
                    e.orders
                        .iter()
                        .map(|o| o.iter().map(contact).collect::<Vec<_>>())
                        .collect::<Vec<_>>(),
                )?;
                one_sided.append(ed)?;
            }
            d.set_item("one_sided", one_sided)?;
            Ok(d)
        })
    }

    /// A sweep: the grid of `over` (`[(name, [v0, v1, …]), …]`, the last name varying
    /// fastest) run on `threads` threads; `progress(done)` is called as points finish.
    /// Returns a dict of columns, one row per point (see `selfmanip.simulation.sweep`).
    #[pyo3(signature = (over, threads, progress=None))]
    fn sweep<'py>(
        &self,
        py: Python<'py>,
        over: Vec<(String, Bound<'py, PyAny>)>,
        threads: usize,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> DictOut<'py> {
        guard(|| {
            let mut axes: Vec<(String, Vec<Value>)> = Vec::new();
            for (name, values) in &over {
                let list: Vec<Bound<'py, PyAny>> = values.extract().map_err(|_| {
                    invalid_type(name, format!("`{name}`: the swept values must be a list"))
                })?;
                let vals = list
                    .iter()
                    .enumerate()
                    .map(|(i, x)| to_value(x, &format!("{name}[{i}]")))
                    .collect::<PyResult<Vec<_>>>()?;
                axes.push((name.clone(), vals));
            }
            let points = grid(&axes).map_err(caller_err)?;
            let base = self.inner.clone();
            let names: Vec<String> = axes.iter().map(|(n, _)| n.clone()).collect();
            let pts = points.clone();
            let rows = interrupt::run(py, progress, move |sh: &Shared| {
                sweep_with(&base, &pts, threads, &sh.cancel, &|| sh.tick())
            })?
            .map_err(caller_err)?;
            let rows: Vec<PointResult> = rows
                .into_iter()
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| errors::engine("the sweep was cancelled"))?;
            let coords = self.inner.robot.build().ok().map(|m| q_names(&m));
            let d = PyDict::new(py);
            for (j, name) in names.iter().enumerate() {
                let col = points
                    .iter()
                    .map(|p| crate::convert::from_value(py, &p.values[j].1))
                    .collect::<PyResult<Vec<_>>>()?;
                d.set_item(name, PyList::new(py, col)?)?;
            }
            sweep_columns(py, &d, &rows, coords.as_deref())?;
            Ok(d)
        })
    }
}

/// The columns of a sweep's rows (NaN / empty where a point has no value).
fn sweep_columns(
    py: Python<'_>,
    d: &Bound<'_, PyDict>,
    rows: &[PointResult],
    coords: Option<&[String]>,
) -> PyResult<()> {
    let nan = f64::NAN;
    let num = |f: &dyn Fn(&selfmanip_sim::Outcome) -> f64| -> Vec<f64> {
        rows.iter().map(|r| r.outcome().map_or(nan, f)).collect()
    };
    let text = |f: &dyn Fn(&PointResult) -> String| -> Vec<String> { rows.iter().map(f).collect() };
    d.set_item("status", text(&|r| r.status().to_string()))?;
    d.set_item("error", text(&|r| r.error().unwrap_or_default()))?;
    d.set_item(
        "word",
        text(&|r| r.outcome().map_or(String::new(), |o| o.word_string())),
    )?;
    d.set_item(
        "mode_end",
        text(&|r| r.outcome().map_or(String::new(), |o| o.mode_end.clone())),
    )?;
    d.set_item(
        "n_events",
        rows.iter()
            .map(|r| r.outcome().map_or(0, |o| o.n_events as i64))
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item("t_end_s", num(&|o| o.t_end_s).into_pyarray(py))?;
    d.set_item("flight_time_s", num(&|o| o.flight_time_s).into_pyarray(py))?;
    d.set_item("impact_loss_j", num(&|o| o.impact_loss_j).into_pyarray(py))?;
    type Get = fn(&selfmanip_sim::outcome::BodyState) -> f64;
    let body: [(&str, Get); 7] = [
        ("t_s", |b| b.t_s),
        ("x_m", |b| b.x_m),
        ("z_m", |b| b.z_m),
        ("phi_rad", |b| b.phi_rad),
        ("xdot_m_s", |b| b.xdot_m_s),
        ("zdot_m_s", |b| b.zdot_m_s),
        ("phidot_rad_s", |b| b.phidot_rad_s),
    ];
    for (k, g) in body {
        d.set_item(
            format!("apex_{k}"),
            num(&|o| o.apex.map_or(nan, |a| g(&a.upward()))).into_pyarray(py),
        )?;
    }
    for (k, g) in body {
        d.set_item(
            format!("landing_{k}"),
            num(&|o| o.landing.as_ref().map_or(nan, |l| g(&l.before.upward()))).into_pyarray(py),
        )?;
    }
    d.set_item(
        "landing_energy_loss_j",
        num(&|o| o.landing.as_ref().map_or(nan, |l| l.energy_loss_j)).into_pyarray(py),
    )?;
    if let Some(names) = coords {
        for (i, n) in names.iter().enumerate() {
            d.set_item(
                format!("end_{n}"),
                num(&|o| o.q_end.get(i).copied().unwrap_or(nan)).into_pyarray(py),
            )?;
        }
    }
    Ok(())
}

/// The first error of a Python controller, shared by every copy of it.
type Failure = Arc<Mutex<Option<PyErr>>>;

/// Re-raises the stored failure of a Python controller, if any.
fn take_failure(failure: &Failure) -> PyResult<()> {
    match failure.lock().unwrap_or_else(|e| e.into_inner()).take() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// `selfmanip.errors.ControllerError`.
fn controller_error(py: Python<'_>, message: String, cause: PyErr) -> PyErr {
    static CELL: PyOnceLock<Py<PyType>> = PyOnceLock::new();
    let made = CELL
        .import(py, "selfmanip.errors", "ControllerError")
        .and_then(|cls| cls.call1((message, "controller")));
    match made {
        Ok(exc) => {
            let err = PyErr::from_value(exc);
            err.set_cause(py, Some(cause));
            err
        }
        Err(e) => e,
    }
}

/// A Python callable as a controller (see the module documentation).
#[derive(Clone)]
struct PyController {
    f: Arc<Py<PyAny>>,
    labels: ContactLabels,
    n_joints: usize,
    failure: Failure,
    shared: Arc<Shared>,
}

impl PyController {
    fn fail(&self, e: PyErr) {
        let mut slot = self.failure.lock().unwrap_or_else(|e| e.into_inner());
        if slot.is_none() {
            *slot = Some(e);
        }
        self.shared.cancel.store(true, Ordering::Relaxed);
    }

    fn failed(&self) -> bool {
        self.failure
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .is_some()
    }

    fn call(
        &self,
        py: Python<'_>,
        t: f64,
        q: &[f64],
        qd: &[f64],
        mode: ContactMode,
    ) -> PyResult<Vec<f64>> {
        let out = self
            .f
            .bind(py)
            .call1((
                t,
                PyArray1::from_slice(py, q),
                PyArray1::from_slice(py, qd),
                self.labels.label(mode),
            ))
            .map_err(|e| {
                controller_error(
                    py,
                    format!("the controller raised {} at t = {t} s", describe(py, &e)),
                    e,
                )
            })?;
        let tau: Vec<f64> = out.extract().map_err(|_| {
            invalid_type(
                "controller",
                format!(
                    "`controller` must return {} joint torques (a sequence of numbers), got {}",
                    self.n_joints,
                    out.get_type().name().map_or("?".into(), |n| n.to_string())
                ),
            )
        })?;
        if tau.len() != self.n_joints {
            return Err(invalid(
                "controller",
                format!(
                    "`controller` returned {} torques at t = {t} s, the robot has {} joints",
                    tau.len(),
                    self.n_joints
                ),
            ));
        }
        if let Some(i) = tau.iter().position(|x| !x.is_finite()) {
            return Err(invalid(
                "controller",
                format!(
                    "`controller` returned a non-finite torque ({}) for joint {i} at t = {t} s",
                    tau[i]
                ),
            ));
        }
        Ok(tau)
    }
}

fn describe(py: Python<'_>, e: &PyErr) -> String {
    let name = e
        .get_type(py)
        .name()
        .map_or_else(|_| "an exception".to_string(), |n| n.to_string());
    format!("{name}: {}", e.value(py))
}

impl Controller for PyController {
    fn torque(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode, tau: &mut [f64]) {
        tau.fill(0.0);
        if self.failed() {
            return;
        }
        match Python::attach(|py| self.call(py, t, q, qd, mode)) {
            Ok(v) => tau.copy_from_slice(&v),
            Err(e) => self.fail(e),
        }
    }
}

/// One execution (`selfmanip_sim::Run`).
#[pyclass(module = "selfmanip._native", name = "Run", frozen)]
pub struct PyRun {
    inner: selfmanip_sim::Run,
    /// The Python controller's failure slot (sampling evaluates it again).
    failure: Failure,
    /// The scenario it ran and the Python controller, if any: `pickle` replays the run from
    /// them (the engine is deterministic, so the copy is the same run bit for bit).
    scenario: Scenario,
    controller: Option<Py<PyAny>>,
}

#[pymethods]
impl PyRun {
    /// `pickle` and `copy`: `Scenario.run(scenario, controller)`, the run replayed.
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let scenario = Bound::new(
            py,
            PyScenario {
                inner: self.scenario.clone(),
            },
        )?;
        let controller = match &self.controller {
            Some(f) => f.bind(py).clone(),
            None => py.None().into_bound(py),
        };
        let args = PyTuple::new(py, [scenario.into_any(), controller])?;
        Ok((py.get_type::<PyScenario>().getattr("run")?, args))
    }

    /// How the run ended (`final_time`, `apex`, `zeno`, …).
    #[getter]
    fn status(&self) -> &'static str {
        self.inner.outcome.status.as_str()
    }

    /// Why the run ended short of its final time or apex, in words (empty if it did not).
    #[getter]
    fn reason(&self) -> String {
        self.inner.outcome.reason.clone()
    }

    /// Accepted integration steps of the run (its cost; bounded by `max_steps`).
    #[getter]
    fn steps(&self) -> usize {
        self.inner.execution.steps
    }

    /// The contact cells visited, in the robot's own contact order.
    #[getter]
    fn word(&self) -> Vec<String> {
        self.inner.outcome.word.clone()
    }

    /// The outcome as a dict (status, word, apex, landing, end state, …).
    fn outcome<'py>(&self, py: Python<'py>) -> AnyOut<'py> {
        to_py(py, &self.inner.outcome)
    }

    /// The events as dicts: `t_s`, `kind`, `mode_before`, `mode_after`, `contacts`,
    /// `energy_loss_j`, `impulse_n_s`, `force_n` (`selfmanip_sim::EventRecord`).
    fn events<'py>(&self, py: Python<'py>) -> AnyOut<'py> {
        to_py(py, &self.inner.events())
    }

    /// The segments as dicts: `t0_s`, `t1_s`, `mode`.
    fn segments<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for s in &self.inner.execution.segments {
            let d = PyDict::new(py);
            d.set_item("t0_s", s.t0)?;
            d.set_item("t1_s", s.t1)?;
            d.set_item("mode", self.inner.labels.label(s.mode))?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// Coordinate names of `q`.
    #[getter]
    fn q_names(&self) -> Vec<String> {
        q_names(&self.inner.model)
    }

    /// The contacts shown in mode labels and words, in order.
    #[getter]
    fn labels(&self) -> Vec<String> {
        self.inner.labels.names().to_vec()
    }

    /// Samples every `dt_s` (default: the crate's sample interval) as numpy arrays.
    #[pyo3(signature = (dt_s=None))]
    fn trajectory<'py>(&self, py: Python<'py>, dt_s: Option<f64>) -> DictOut<'py> {
        guard(|| {
            let tr = self
                .inner
                .trajectory(dt_s.unwrap_or(DEFAULT_DT_S))
                .map_err(|e| match e {
                    SimError::InvalidValue { .. } => caller_err(e),
                    e => engine_err(e),
                })?;
            take_failure(&self.failure)?;
            let nq = self.inner.model.nq();
            let nj = self.inner.model.n_joints();
            let nc = tr.contacts.len();
            let d = PyDict::new(py);
            d.set_item("q_names", tr.q_names.clone())?;
            d.set_item("contacts", tr.contacts.clone())?;
            d.set_item("t_s", tr.t_s.clone().into_pyarray(py))?;
            d.set_item("q", rows_array(&tr.q, nq).into_pyarray(py))?;
            d.set_item("qd", rows_array(&tr.qd, nq).into_pyarray(py))?;
            d.set_item("tau", rows_array(&tr.tau, nj).into_pyarray(py))?;
            d.set_item("mode", tr.mode.clone())?;
            d.set_item(
                "contact_points_m",
                pairs_array(&tr.contact_points_m, nc).into_pyarray(py),
            )?;
            d.set_item(
                "contact_forces_n",
                pairs_array(&tr.contact_forces_n, nc).into_pyarray(py),
            )?;
            Ok(d)
        })
    }

    /// The execution's sensitivities to its initial state
    /// (`selfmanip_sim::periodic::run_sensitivity`): `state_jacobian` (`2nq × 2nq`
    /// numpy array, `None` where some event's saltation is not defined) and `events`, one dict
    /// per event of the run in order: `t_s`, `kind`, `status` (`defined`, `grazing`,
    /// `simultaneous`, `one_sided`, `unsupported`), `reason` (`None` when defined),
    /// `saltation` (`2nq × 2nq` or `None`), `time_gradient` (`dt_e/dx(0)`, or `None`),
    /// `one_sided` (where several guards fired at once: `order`, contact names in firing
    /// order, and `saltation` for each order); `one_sided_state_jacobian` where
    /// `state_jacobian` is `None` only for `one_sided` events (the piece of each one's first
    /// order).
    fn sensitivity<'py>(&self, py: Python<'py>) -> DictOut<'py> {
        guard(|| {
            let run = &self.inner;
            let s = py
                .detach(|| run_sensitivity(run))
                .map_err(sensitivity_err)?;
            take_failure(&self.failure)?;
            let d = PyDict::new(py);
            for (key, j) in [
                ("state_jacobian", &s.state_jacobian),
                ("one_sided_state_jacobian", &s.one_sided_state_jacobian),
            ] {
                match j {
                    Some(j) => d.set_item(key, matrix(j).into_pyarray(py))?,
                    None => d.set_item(key, py.None())?,
                }
            }
            let events = PyList::empty(py);
            for e in &s.events {
                let ed = PyDict::new(py);
                ed.set_item("t_s", e.t)?;
                ed.set_item("kind", e.kind.name())?;
                ed.set_item("status", e.status.name())?;
                ed.set_item("reason", e.status.reason())?;
                match &e.saltation {
                    Some(x) => ed.set_item("saltation", matrix(x).into_pyarray(py))?,
                    None => ed.set_item("saltation", py.None())?,
                }
                match &e.time_gradient {
                    Some(g) => ed.set_item(
                        "time_gradient",
                        g.iter().copied().collect::<Vec<f64>>().into_pyarray(py),
                    )?,
                    None => ed.set_item("time_gradient", py.None())?,
                }
                let pieces = PyList::empty(py);
                for p in &e.one_sided {
                    let pd = PyDict::new(py);
                    let names: Vec<String> = p
                        .order
                        .iter()
                        .map(|&c| run.model.contacts[c].name.clone())
                        .collect();
                    pd.set_item("order", names)?;
                    pd.set_item("saltation", matrix(&p.saltation).into_pyarray(py))?;
                    pieces.append(pd)?;
                }
                ed.set_item("one_sided", pieces)?;
                events.append(ed)?;
            }
            d.set_item("events", events)?;
            Ok(d)
        })
    }

    /// The final state's derivatives with respect to parameters named by path
    /// (`selfmanip_sim::sensitivity::scenario_parameter_sensitivity`: behaviour parameters,
    /// behaviour numbers, the body's mass and inertia, joints' armatures):
    /// `parameter_jacobian` (`2nq × len(names)`, `None` when not formed; NaN columns for
    /// names without an exact derivative yet), `reason` (why not formed, else `None`),
    /// `not_differentiated` (per name, why it has no exact derivative, else `None`) and
    /// `event_time_gradients` (per event `dt_e/dp`, or `None`). A name that names nothing is
    /// an `InvalidInputError` naming `parameters[i]`.
    fn parameter_sensitivity<'py>(&self, py: Python<'py>, names: Vec<String>) -> DictOut<'py> {
        guard(|| {
            let (run, scenario) = (&self.inner, &self.scenario);
            let refs: Vec<&str> = names.iter().map(String::as_str).collect();
            let options = scenario.options.hybrid().map_err(caller_err)?;
            let s = py
                .detach(|| scenario_parameter_sensitivity(scenario, &options, run, &refs))
                .map_err(|e| match e {
                    ParameterPathError::Unknown { index, source } => {
                        invalid(&format!("parameters[{index}]"), source.to_string())
                    }
                    ParameterPathError::Sensitivity(e) => sensitivity_err(e),
                    ParameterPathError::Sim(e) => caller_err(e),
                })?;
            take_failure(&self.failure)?;
            let d = PyDict::new(py);
            match &s.state {
                Some(j) => d.set_item("parameter_jacobian", matrix(j).into_pyarray(py))?,
                None => d.set_item("parameter_jacobian", py.None())?,
            }
            d.set_item("reason", s.reason.clone())?;
            d.set_item("not_differentiated", s.not_differentiated.clone())?;
            let times = PyList::empty(py);
            for t in &s.event_times {
                match t {
                    Some(g) => times.append(g.clone().into_pyarray(py))?,
                    None => times.append(py.None())?,
                }
            }
            d.set_item("event_time_gradients", times)?;
            Ok(d)
        })
    }

    /// `E₁ − E₀ = W + W_d + W_fr − L`: `initial_j`, `final_j`, `joint_work_j`, `damping_work_j`,
    /// `friction_work_j`, `impact_loss_j`, `residual_j`.
    fn energy_report<'py>(&self, py: Python<'py>) -> DictOut<'py> {
        guard(|| {
            let r = self.inner.energy_report().map_err(engine_err)?;
            take_failure(&self.failure)?;
            let d = PyDict::new(py);
            d.set_item("initial_j", r.initial_j)?;
            d.set_item("final_j", r.final_j)?;
            d.set_item("joint_work_j", r.joint_work_j)?;
            d.set_item("damping_work_j", r.damping_work_j)?;
            d.set_item("friction_work_j", r.friction_work_j)?;
            d.set_item("impact_loss_j", r.impact_loss_j)?;
            d.set_item("residual_j", r.residual_j())?;
            Ok(d)
        })
    }

    /// Writes an MCAP log sampled every `dt_s` (default: the crate's sample interval),
    /// atomically; `metadata` goes into its `selfmanip` metadata record.
    #[pyo3(signature = (path, dt_s=None, metadata=None))]
    fn write_mcap(
        &self,
        py: Python<'_>,
        path: PathBuf,
        dt_s: Option<f64>,
        metadata: Option<BTreeMap<String, String>>,
    ) -> PyResult<()> {
        guard(|| {
            let dt = dt_s.unwrap_or(DEFAULT_DT_S);
            let md = metadata.unwrap_or_default();
            // the sampling may call a Python controller: keep the GIL reachable; Ctrl-C stops
            // the write before its next record and leaves no file behind
            let run = &self.inner;
            let r = interrupt::run_borrowed(py, |cancel| {
                run.write_mcap_until(&path, dt, md, &|| cancel.load(Ordering::Relaxed))
            })?;
            take_failure(&self.failure)?;
            r.map_err(|e| match e {
                SimError::InvalidValue { .. } => caller_err(e),
                e => engine_err(e),
            })
        })
    }
}

/// A matrix as a 2-D array.
fn matrix(m: &DMatrix<f64>) -> numpy::ndarray::Array2<f64> {
    numpy::ndarray::Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)])
}

/// A sensitivity error: a controller without partial derivatives is the caller's behaviour
/// (`InvalidInputError` naming `behaviour`); the engine's own failures are `EngineError`.
fn sensitivity_err(e: SensitivityError) -> PyErr {
    match e {
        SensitivityError::Hybrid(h) => errors::map_hybrid(&h, Source::Engine).into_pyerr(),
        SensitivityError::ControllerWithoutPartials { .. } => invalid(
            "behaviour",
            format!("{e} (motor torques and joint-angle levels have none yet)"),
        ),
        // a behaviour whose memory of an event (a motion whose numbers use the state) is not
        // differentiated: the caller's behaviour, as above
        SensitivityError::EventMemoryWithoutPartials { .. } => invalid("behaviour", e.to_string()),
        e => errors::engine(e.to_string()),
    }
}

/// A periodic-orbit error: bad input names its field; a search that does not converge, a
/// run that does not return, a map without a Jacobian are `EngineError`s with the reason.
fn periodic_err(e: PeriodicRunError) -> PyErr {
    match e {
        PeriodicRunError::Sim(s) => caller_err(s),
        PeriodicRunError::Periodic(p) => match p {
            PeriodicError::InvalidInput { field, reason } => {
                invalid(field, format!("`{field}`: {reason}"))
            }
            PeriodicError::Hybrid(h) => errors::map_hybrid(&h, Source::Caller).into_pyerr(),
            PeriodicError::Sensitivity(s) => sensitivity_err(s),
            other => errors::engine(other.to_string()),
        },
    }
}
