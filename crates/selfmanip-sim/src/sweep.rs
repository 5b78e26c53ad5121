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
use crate::error::SimError;
use crate::outcome::Outcome;
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
    let tree = base.to_value()?;
    for p in points {
        crate::path::distinct_paths(&tree, &p.values)?;
    }
    // the base as each point's fresh build reads it (through the JSON tree); a base that does
    // not build leaves every point to its own build (and its own error)
    let built = catch_panic(|| Simulation::new(&Scenario::set_all(&mut tree.clone(), &[])?))
        .ok()
        .and_then(Result::ok);
    run_parallel(points, threads, |p| {
        if stop.load(Ordering::Relaxed) {
            return None;
        }
        let result = match catch_panic(|| {
            Ok::<_, SimError>(
                point_simulation(&tree, built.as_ref(), p)?
                    .run_with(stop)?
                    .outcome,
            )
        }) {
            Ok(Ok(o)) => Ok(o),
            Ok(Err(e)) => Err(PointFailure::Error(e)),
            Err(m) => Err(PointFailure::Panic(m)),
        };
        done();
        Some(PointResult { result })
    })
}
