//! Batched executions on an explicit rayon pool.
//!
//! **Determinism.** Every point is a pure function of the base and the point: no state is
//! shared between points and results are collected in input order, so a sweep is
//! bit-identical for any thread count.
//!
//! **Failure isolation.** A point whose inputs are invalid, whose execution fails, or that
//! panics becomes a result with a failed status and the error; the other points are
//! unaffected. Only a malformed sweep (an unknown parameter name, zero threads) is an error
//! of the whole call.
//!
//! **Compiled once.** The base is built once per sweep; a point that sets only behaviour
//! parameters, to numbers, runs a copy of it with those values bound
//! ([`Simulation::rebind`]: the same simulation a fresh build gives, bit for bit, without
//! building the robot or round-tripping the scenario again); any other point is built afresh.
//!
//! **One task per point** (`with_max_len(1)`): rayon's default splitting hands each thread
//! runs of neighbouring points, whose costs are correlated (a range of long runs), and loses
//! ~20 % to the imbalance on 2 threads.
//!
//! **Presets.** A preset ([`Preset`]: RHex's leap, [`ScenarioPreset`] for any scenario) turns
//! its points into runs and reports each as a [`SweepRow`] in its own frame and on its own
//! clock (the column vocabulary of [`crate::outcome::APEX_COLUMNS`]: z up), with its own
//! columns and the status names of its errors; [`preset_sweep`] runs any of them.
use crate::error::SimError;
use crate::outcome::{BodyState, Outcome, PresetFrame, RunStatus};
use crate::scenario::{Scenario, Simulation};
use rayon::prelude::*;
use serde_json::Value;
use std::sync::atomic::{AtomicBool, Ordering};

/// The threads a pool for `items` points starts when `threads` are asked for: at most one per
/// core of the machine and one per point (more would only wait), so that no request
/// (`threads = 10⁹`) starts threads without bound. Results do not depend on it.
pub fn pool_threads(threads: usize, items: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    threads.min(cores).min(items.max(1))
}

/// Runs `f` on every item on a pool of `threads` threads ([`pool_threads`]: at most the
/// machine's cores); results in input order.
pub fn run_parallel<T: Sync, R: Send>(
    items: &[T],
    threads: usize,
    f: impl Fn(&T) -> R + Sync + Send,
) -> Result<Vec<R>, SimError> {
    if threads == 0 {
        return Err(SimError::InvalidValue {
            field: "threads".into(),
            reason: "must be at least 1".into(),
        });
    }
    let threads = pool_threads(threads, items.len());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| SimError::InvalidValue {
            field: "threads".into(),
            reason: format!("cannot start a pool of {threads} threads: {e}"),
        })?;
    Ok(pool.install(|| items.par_iter().with_max_len(1).map(f).collect()))
}

/// The text of a caught panic's payload (`"unknown panic"` when it is not a string).
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "unknown panic".into())
}

/// Runs `f`, turning a panic into `Err(message)`.
pub fn catch_panic<R>(f: impl FnOnce() -> R) -> Result<R, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|p| panic_message(p.as_ref()))
}

/// Values built at the first ask for their key and shared after that, for a caller that runs
/// many points on a few builds (a preset per set of fixed inputs): the caller owns it, keys
/// compare by value, and a build runs outside the lock (two threads may build the same key at
/// once; the first kept is kept). What a point gets is the value a fresh build gives, so
/// results do not depend on which points ran before or on which thread.
pub struct BuildCache<K, V>(std::sync::Mutex<Vec<(K, std::sync::Arc<V>)>>);

impl<K, V> Default for BuildCache<K, V> {
    fn default() -> Self {
        BuildCache(std::sync::Mutex::new(Vec::new()))
    }
}

impl<K: PartialEq, V> BuildCache<K, V> {
    /// The value kept for `key`, or `build()`'s (kept for the next ask; an error is not kept).
    pub fn get_or_build<E>(
        &self,
        key: K,
        build: impl FnOnce() -> Result<V, E>,
    ) -> Result<std::sync::Arc<V>, E> {
        use std::sync::Arc;
        let found = |entries: &[(K, Arc<V>)]| {
            entries
                .iter()
                .find(|(k, _)| *k == key)
                .map(|(_, v)| Arc::clone(v))
        };
        if let Some(v) = self.0.lock().ok().and_then(|e| found(&e)) {
            return Ok(v);
        }
        let built = Arc::new(build()?);
        if let Ok(mut entries) = self.0.lock() {
            if found(&entries).is_none() {
                entries.push((key, Arc::clone(&built)));
            }
        }
        Ok(built)
    }
}

/// One point of a sweep: values by parameter name (paths of [`crate::path`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SweepPoint {
    pub values: Vec<(String, Value)>,
}

/// The most points a sweep's grid holds: 10⁷ runs are hours of work on any machine, and the
/// bound is checked before the product is formed (a range of 10¹² values asked for terabytes).
pub const MAX_SWEEP_POINTS: usize = 10_000_000;

/// The Cartesian product of `over` (the last parameter varying fastest); an error naming the
/// last axis when it would hold more than [`MAX_SWEEP_POINTS`] points.
pub fn grid(over: &[(String, Vec<Value>)]) -> Result<Vec<SweepPoint>, SimError> {
    let mut count: usize = 1;
    for (name, values) in over {
        count = count
            .checked_mul(values.len())
            .filter(|&n| n <= MAX_SWEEP_POINTS)
            .ok_or_else(|| SimError::InvalidValue {
                field: name.clone(),
                reason: format!("the sweep's grid would hold more than {MAX_SWEEP_POINTS} points"),
            })?;
    }
    let mut points = vec![SweepPoint::default()];
    for (name, values) in over {
        points = points
            .into_iter()
            .flat_map(|p| {
                values.iter().map(move |v| {
                    let mut q = p.clone();
                    q.values.push((name.clone(), v.clone()));
                    q
                })
            })
            .collect();
    }
    Ok(points)
}

/// Why a point has no outcome.
#[derive(Debug, Clone, PartialEq)]
pub enum PointFailure {
    Error(SimError),
    Panic(String),
}

/// The result of one point.
#[derive(Debug, Clone, PartialEq)]
pub struct PointResult {
    pub result: Result<Outcome, PointFailure>,
}

impl PointResult {
    /// `final_time`, `apex`, `zeno`, … for a run; the error's kind
    /// ([`SimError::kind`]) or `panic` for a failure.
    pub fn status(&self) -> &'static str {
        match &self.result {
            Ok(o) => o.status.as_str(),
            Err(PointFailure::Error(e)) => e.kind(),
            Err(PointFailure::Panic(_)) => "panic",
        }
    }

    /// The error message of a failed point.
    pub fn error(&self) -> Option<String> {
        match &self.result {
            Ok(_) => None,
            Err(PointFailure::Error(e)) => Some(e.to_string()),
            Err(PointFailure::Panic(m)) => Some(m.clone()),
        }
    }

    pub fn outcome(&self) -> Option<&Outcome> {
        self.result.as_ref().ok()
    }
}

/// The simulation of a point: `built` (the base's) with the point's values bound when they
/// are all numbers for behaviour parameters, else the base tree with the values set, built.
fn point_simulation(
    tree: &Value,
    built: Option<&Simulation>,
    point: &SweepPoint,
) -> Result<Simulation, SimError> {
    if let (Some(base), Some(values)) = (built, parameter_values(tree, point)) {
        let mut sim = base.clone();
        sim.rebind(&values, base.t_final_s)?;
        return Ok(sim);
    }
    Simulation::new(&Scenario::set_all(&mut tree.clone(), &point.values)?)
}

/// The point's values as `(behaviour parameter, number)`, `None` when one sets anything else
/// (a field of the robot, options, terrain or start; a formula): the names resolve as
/// [`crate::path::resolve`] resolves them, a bare name to the behaviour parameter of that
/// name, `behaviour.parameters.<name>` to itself.
fn parameter_values<'p>(tree: &Value, point: &'p SweepPoint) -> Option<Vec<(&'p str, f64)>> {
    let parameters = tree.get("behaviour")?.get("parameters")?;
    point
        .values
        .iter()
        .map(|(name, v)| {
            let key = name.strip_prefix("behaviour.parameters.").unwrap_or(name);
            let plain = key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            let root = crate::path::ROOTS.contains(&key);
            (plain && !root && parameters.get(key).is_some())
                .then(|| v.as_f64())
                .flatten()
                .map(|x| (key, x))
        })
        .collect()
}

/// Runs one point: the base with the point's values set, checked, run.
pub fn run_point(base: &Scenario, point: &SweepPoint) -> Result<Outcome, SimError> {
    let s = base.with_values(&point.values)?;
    Ok(Simulation::new(&s)?.run()?.outcome)
}

/// Runs every point on a pool of `threads` threads; results in input order. Errors only
/// for a name that names no parameter of `base`, zero threads, or a pool that cannot start.
pub fn sweep(
    base: &Scenario,
    points: &[SweepPoint],
    threads: usize,
) -> Result<Vec<PointResult>, SimError> {
    // never stopped: every point has its result
    let rows = sweep_with(
        base,
        points,
        threads,
        &selfmanip_hybrid::budget::NEVER,
        &|| {},
    )?;
    Ok(rows.into_iter().flatten().collect())
}

/// [`sweep`] that another thread can stop, and that reports each finished point: once
/// `stop` is raised, points not yet started are skipped (`None`) and a point running ends
/// within one integration step with the status `interrupted`; `done` is called after each
/// point (from the worker threads; for a progress count).
pub fn sweep_with(
    base: &Scenario,
    points: &[SweepPoint],
    threads: usize,
    stop: &AtomicBool,
    done: &(dyn Fn() + Sync),
) -> Result<Vec<Option<PointResult>>, SimError> {
    // a base that does not build leaves every point to its own build (and its own error)
    let preset = ScenarioPreset::new(base)?;
    preset.check(points)?;
    run_parallel(points, threads, |p| {
        if stop.load(Ordering::Relaxed) {
            return None;
        }
        let result = match catch_panic(|| Ok::<_, SimError>(preset.outcome(p, stop)?.0.outcome)) {
            Ok(Ok(o)) => Ok(o),
            Ok(Err(e)) => Err(PointFailure::Error(e)),
            Err(m) => Err(PointFailure::Panic(m)),
        };
        done();
        Some(PointResult { result })
    })
}

/// A preset of the simulator as a sweep runs it ([`preset_sweep`]): how one of its points
/// becomes a run (a scenario built, or bound to one built before), the row it reports (the
/// apex in the preset's frame and on its clock, [`PresetFrame`]; its own columns) and the
/// status names of its errors.
pub trait Preset: Sync {
    /// One point of the preset's sweep.
    type Point: Sync;
    /// What a point fails with.
    type Error: std::fmt::Display;
    /// The names of the preset's own columns ([`SweepRow::columns`], in this order).
    fn columns(&self) -> &'static [&'static str];
    /// Runs one point; a raised `stop` ends its run within one integration step.
    fn run(&self, point: &Self::Point, stop: &AtomicBool) -> Result<SweepRow, Self::Error>;
    /// The status of a point that failed with `e` (`invalid_params`, `singular_kkt`, …).
    fn error_kind(&self, e: &Self::Error) -> &'static str;
}

/// The status of a preset's point that failed with `e` (see [`SweepRow::status`]):
/// `invalid_params` for an error of the inputs, `overflow` for a result that overflows,
/// `off_manifold` for a start off its contacts, else the engine's kind ([`SimError::kind`]).
pub fn preset_error_kind(e: &SimError) -> &'static str {
    use selfmanip_core::CoreError as C;
    use selfmanip_hybrid::HybridError as H;
    match e {
        SimError::Core(C::NonFiniteResult { .. })
        | SimError::Hybrid(H::Core(C::NonFiniteResult { .. })) => "overflow",
        SimError::Hybrid(H::OffManifold { .. }) => "off_manifold",
        e if e.is_input_error() => "invalid_params",
        e => e.kind(),
    }
}

/// The names a preset's point may set, by the serde record each sets (a robot's parameters,
/// a run's configuration, an actuator's values): a name is a field of the first record that
/// lists it ([`crate::path::sort_by_record`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordFields(pub Vec<Vec<&'static str>>);

impl RecordFields {
    /// The fields serde reads of `T` ([`crate::path::serde_field_names`]) but `skip`.
    pub fn of<T: serde::de::DeserializeOwned>(skip: &[&str]) -> Vec<&'static str> {
        let names = crate::path::serde_field_names::<T>();
        names
            .iter()
            .copied()
            .filter(|k| !skip.contains(k))
            .collect()
    }

    /// Every name, each once, record by record.
    pub fn names(&self) -> Vec<String> {
        self.0.concat().into_iter().map(String::from).collect()
    }

    /// The first of `names` that no record lists.
    pub fn unknown<'a>(&self, names: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
        names
            .into_iter()
            .find(|n| !self.0.iter().any(|r| r.contains(n)))
    }

    /// `overrides` sorted into the records they set, in their order; `Err(name)`: the first
    /// name no record lists.
    pub fn sort<'a>(
        &self,
        overrides: &'a serde_json::Map<String, Value>,
    ) -> Result<Vec<Vec<(&'a String, &'a Value)>>, &'a str> {
        let records: Vec<&[&str]> = self.0.iter().map(Vec::as_slice).collect();
        crate::path::sort_by_record(&records, overrides)
    }
}

/// The outcome of one point of a preset's sweep, flattened for a table.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRow {
    /// The run's [`RunStatus`] (`apex`, `final_time`, `zeno`, …), the preset's error kind
    /// ([`Preset::error_kind`]), `panic`, or `interrupted` for a point not started.
    pub status: String,
    /// The error message of a failed point, or (where the preset gives it) why a run did not
    /// fly; empty otherwise.
    pub error: String,
    /// The run flew ([`PresetFrame::flew`]); `false` for a point that failed.
    pub flew: bool,
    /// The apex in the preset's frame, `z` up ([`crate::outcome::APEX_COLUMNS`]).
    pub apex: Option<BodyState>,
    /// The contact word, cells joined by `-` (empty when the point failed).
    pub word: String,
    /// Events of the execution.
    pub n_events: usize,
    /// The preset's own columns ([`Preset::columns`]); NaN for a point that failed.
    pub columns: Vec<f64>,
}

impl SweepRow {
    /// A row without a run: `status`, the error message and `n_columns` NaN columns.
    pub fn failed(status: &str, error: String, n_columns: usize) -> Self {
        SweepRow {
            status: status.into(),
            error,
            flew: false,
            apex: None,
            word: String::new(),
            n_events: 0,
            columns: vec![f64::NAN; n_columns],
        }
    }

    /// The row of a run of `outcome` that `flew` or not, its `apex` in the preset's frame.
    pub fn of_run(
        outcome: &Outcome,
        flew: bool,
        apex: Option<BodyState>,
        error: String,
        columns: Vec<f64>,
    ) -> Self {
        SweepRow {
            status: outcome.status.as_str().into(),
            error,
            flew,
            apex,
            word: outcome.word_string(),
            n_events: outcome.n_events,
            columns,
        }
    }

    /// The apex columns ([`crate::outcome::APEX_COLUMNS`]); NaN without an apex.
    pub fn apex_columns(&self) -> [f64; 7] {
        self.apex.map_or([f64::NAN; 7], |a| a.to_array())
    }
}

/// Runs one point of `preset`; never panics and never fails: a point not started before
/// `stop` was raised is `interrupted`, a failure is a row of its error kind, a panic a row
/// `panic` with its message.
pub fn run_row<P: Preset>(preset: &P, point: &P::Point, stop: &AtomicBool) -> SweepRow {
    let n = preset.columns().len();
    if stop.load(Ordering::Relaxed) {
        return SweepRow::failed(RunStatus::Interrupted.as_str(), String::new(), n);
    }
    match catch_panic(|| preset.run(point, stop)) {
        Err(m) => SweepRow::failed("panic", m, n),
        Ok(Err(e)) => SweepRow::failed(preset.error_kind(&e), e.to_string(), n),
        Ok(Ok(row)) => row,
    }
}

/// Runs every point of `preset` on a pool of `threads` threads ([`run_parallel`]); rows in
/// input order, every point a row ([`run_row`]). Errors only for zero threads or a pool that
/// cannot start.
pub fn preset_sweep<P: Preset>(
    preset: &P,
    points: &[P::Point],
    threads: usize,
    stop: &AtomicBool,
) -> Result<Vec<SweepRow>, SimError> {
    run_parallel(points, threads, |p| run_row(preset, p, stop))
}

/// The sweep of a scenario as a preset: a point sets values by name ([`SweepPoint`],
/// [`crate::path`]); its row reports the apex in the world frame, `z` up, on the
/// execution's clock ([`PresetFrame::world`]), and no columns of its own.
pub struct ScenarioPreset {
    /// The base as each point's fresh build reads it (through the JSON tree).
    tree: Value,
    /// The base built once, `None` when it does not build (each point builds its own).
    built: Option<Simulation>,
}

impl ScenarioPreset {
    /// The preset of `base` (errors only when `base` does not serialize).
    pub fn new(base: &Scenario) -> Result<Self, SimError> {
        let tree = base.to_value()?;
        let built = catch_panic(|| Simulation::new(&Scenario::set_all(&mut tree.clone(), &[])?))
            .ok()
            .and_then(Result::ok);
        Ok(ScenarioPreset { tree, built })
    }

    /// Checks that every point's names are parameters of the base, each set once.
    pub fn check(&self, points: &[SweepPoint]) -> Result<(), SimError> {
        for p in points {
            crate::path::distinct_paths(&self.tree, &p.values)?;
        }
        Ok(())
    }

    /// The run of one point, stopped by `stop`, and whether it stops at its apex.
    fn outcome(
        &self,
        point: &SweepPoint,
        stop: &AtomicBool,
    ) -> Result<(crate::Run, bool), SimError> {
        let sim = point_simulation(&self.tree, self.built.as_ref(), point)?;
        let stop_at_apex = sim.options.stop_at_apex;
        Ok((sim.run_with(stop)?, stop_at_apex))
    }
}

impl Preset for ScenarioPreset {
    type Point = SweepPoint;
    type Error = SimError;

    fn columns(&self) -> &'static [&'static str] {
        &[]
    }

    fn run(&self, point: &SweepPoint, stop: &AtomicBool) -> Result<SweepRow, SimError> {
        let (run, stop_at_apex) = self.outcome(point, stop)?;
        let frame = PresetFrame::world(stop_at_apex);
        let (exec, o) = (&run.execution, &run.outcome);
        let flew = frame.flew(exec, o.status);
        let apex = frame.apex(&run.model, exec);
        Ok(SweepRow::of_run(
            o,
            flew,
            apex,
            o.reason.clone(),
            Vec::new(),
        ))
    }

    fn error_kind(&self, e: &SimError) -> &'static str {
        e.kind()
    }
}
