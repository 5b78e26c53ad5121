//! Batched leaps (issue 5): many independent leaps — strategy × `t2` × gear ratio × any
//! parameter by name — run on an explicit rayon pool, results in input order.
//!
//! **Determinism.** Every point is a pure function of `(base params, base config, point)`:
//! no state is shared between points and the results are collected in input order, so a
//! sweep is bit-identical for any thread count.
//!
//! **Failure isolation.** A point whose inputs are invalid, whose leap engine returns an
//! error, or that panics becomes a row with a non-`ok` status and the error message; the
//! other points are unaffected. Only a malformed sweep (an unknown parameter name, zero
//! threads) is an error of the whole call.
//!
//! **Parameters by name.** An override names a field of [`RhexParams`] (`m_b`, `leg_shape`,
//! `mu_rear`, …), of [`LeapConfig`] (`delta_t_s`, `swing_accel_rad_s2`, `toe_stub_rad`, …;
//! not `strategy`, `t2_s` or `actuator`, which have their own columns) or of the geared
//! motor (`current_limit_a`, `motors_per_leg`). Values are JSON values, deserialized with
//! the same serde rules as the data files, so a wrong type names its field.
//!
//! **Gear ratio.** `Some(G)` runs the point with [`LegActuator::GearedMotor`] of ratio `G`
//! (current limit and motor count from the base actuator when it is a geared motor, else
//! the defaults: 20 A, two motors per planar leg); `None` keeps the base actuator. The
//! reported gear ratio is the one used, NaN for [`LegActuator::SaturatedTorque`].
use crate::leap::{simulate_leap, LeapConfig, LeapResult, LegActuator, Presets, Strategy};
use crate::{RhexError, RhexParams};
use selfmanip_hybrid::budget::NEVER;
use selfmanip_sim::path::{record_with, serde_field_names, sort_by_record};
pub use selfmanip_sim::sweep::panic_message;
use selfmanip_sim::sweep::{catch_panic, run_parallel};
use serde_json::{Map, Value};
use std::sync::atomic::{AtomicBool, Ordering};

/// One leap of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    pub strategy: Strategy,
    /// Rear leg's start relative to the front leg's (s).
    pub t2_s: f64,
    /// Geared motors of this ratio, or `None` for the base configuration's actuator.
    pub gear_ratio: Option<f64>,
    /// Parameter overrides by name (see the module documentation).
    pub overrides: Map<String, Value>,
}

impl SweepPoint {
    pub fn new(strategy: Strategy, t2_s: f64, gear_ratio: Option<f64>) -> Self {
        SweepPoint {
            strategy,
            t2_s,
            gear_ratio,
            overrides: Map::new(),
        }
    }
}

/// The outcome of one point, flattened for a table.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRow {
    /// The engine's [`selfmanip_sim::RunStatus`] (`apex`, `final_time`, `zeno`, …) or an error kind
    /// ([`error_kind`]: `invalid_params`, `singular_kkt`, `overflow`, `engine_error`,
    /// `panic`, …).
    pub status: String,
    /// The error message when the point failed with an error (empty otherwise).
    pub error: String,
    /// The leap flew ([`LeapResult::flew`]); `false` for a point that failed.
    pub flew: bool,
    /// Gear ratio used (NaN for the saturated-torque actuator or an invalid point).
    pub gear_ratio: f64,
    /// Apex (z up, x forward from the start); NaN when the leap has no apex.
    pub apex_t_s: f64,
    pub apex_x_m: f64,
    pub apex_z_m: f64,
    pub apex_phi_rad: f64,
    pub apex_xdot_m_s: f64,
    pub apex_zdot_m_s: f64,
    pub apex_phidot_rad_s: f64,
    /// Leap word, cells joined by `-` (empty when the point failed).
    pub word: String,
    /// Number of events of the execution.
    pub n_events: usize,
}

impl SweepRow {
    /// A row without an apex: `status`, the error message (empty for a leap that ran) and the
    /// gear ratio.
    pub fn failed(status: &str, error: String, gear_ratio: f64) -> Self {
        Self {
            status: status.into(),
            error,
            flew: false,
            gear_ratio,
            apex_t_s: f64::NAN,
            apex_x_m: f64::NAN,
            apex_z_m: f64::NAN,
            apex_phi_rad: f64::NAN,
            apex_xdot_m_s: f64::NAN,
            apex_zdot_m_s: f64::NAN,
            apex_phidot_rad_s: f64::NAN,
            word: String::new(),
            n_events: 0,
        }
    }

    /// The row of a leap that ran (`why`: why it did not fly, or empty).
    pub fn of_leap(r: &LeapResult, why: String, gear_ratio: f64) -> Self {
        let mut row = Self::failed(r.status.as_str(), why, gear_ratio);
        row.flew = r.flew;
        row.word = r.word_string();
        row.n_events = r.events.len();
        if let Some(a) = r.apex {
            row.apex_t_s = a.t_s;
            row.apex_x_m = a.x_m;
            row.apex_z_m = a.z_m;
            row.apex_phi_rad = a.phi_rad;
            row.apex_xdot_m_s = a.xdot_m_s;
            row.apex_zdot_m_s = a.zdot_m_s;
            row.apex_phidot_rad_s = a.phidot_rad_s;
        }
        row
    }
}

/// The Cartesian product strategy × gear ratio × `t2` (`t2` varying fastest).
pub fn grid(strategies: &[Strategy], t2_s: &[f64], gear_ratios: &[Option<f64>]) -> Vec<SweepPoint> {
    let mut out = Vec::with_capacity(strategies.len() * t2_s.len() * gear_ratios.len());
    for &s in strategies {
        for &g in gear_ratios {
            for &t2 in t2_s {
                out.push(SweepPoint::new(s, t2, g));
            }
        }
    }
    out
}

const OWN_COLUMNS: [&str; 3] = ["strategy", "t2_s", "actuator"];
/// The override that names the leap's pushing pairs ([`LeapConfig::pairs`]), not the
/// parameters' `pairs`, which a leap does not read.
const LEAP_PAIRS: &str = "pairs";
const ACTUATOR_FIELDS: [&str; 5] = [
    "current_limit_a",
    "motors_per_leg",
    "gearbox_efficiency",
    "gearbox_loss",
    "battery_resistance_ohm",
];

/// The names that set the geared motor's fields ([`LegActuator::GearedMotor`]) rather than a
/// parameter or the configuration: an override of one of them runs the geared motor.
pub fn actuator_field_names() -> &'static [&'static str] {
    &ACTUATOR_FIELDS
}

/// Every name an override may use: the fields of [`RhexParams`], of [`LeapConfig`] (except
/// `strategy`, `t2_s`, `actuator`) and of the geared motor — every field serde reads,
/// including optional ones a default value leaves out of its serialization (`mu_body`,
/// `leg_armature_kg_m2`).
pub fn sweepable_names() -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    names.extend(
        serde_field_names::<RhexParams>()
            .iter()
            .map(|s| s.to_string()),
    );
    names.extend(
        serde_field_names::<LeapConfig>()
            .iter()
            .filter(|k| !OWN_COLUMNS.contains(k))
            .map(|s| s.to_string()),
    );
    names.extend(ACTUATOR_FIELDS.iter().map(|s| s.to_string()));
    names
}

/// Checks that every name is sweepable; the error names the first unknown one.
pub fn check_override_names<'a>(names: impl IntoIterator<Item = &'a str>) -> Result<(), RhexError> {
    let known = sweepable_names();
    match names.into_iter().find(|n| !known.iter().any(|k| k == n)) {
        Some(n) => Err(RhexError::UnknownParameter {
            field: n.into(),
            known: known.join(", "),
        }),
        None => Ok(()),
    }
}

/// The robot parameters and leap configuration of one point, validated.
pub fn point_inputs(
    base_params: &RhexParams,
    base_cfg: &LeapConfig,
    point: &SweepPoint,
) -> Result<(RhexParams, LeapConfig), RhexError> {
    // `pairs` is both the robot's leg pairs and the leap's pushing pairs; a leap's robot has
    // exactly its pushing pairs, so the name sets those
    let of_params: Vec<&str> = serde_field_names::<RhexParams>()
        .iter()
        .copied()
        .filter(|k| *k != LEAP_PAIRS)
        .collect();
    let of_cfg: Vec<&str> = serde_field_names::<LeapConfig>()
        .iter()
        .copied()
        .filter(|k| !OWN_COLUMNS.contains(k))
        .collect();
    let sorted = sort_by_record(&[&of_params, &of_cfg, &ACTUATOR_FIELDS], &point.overrides)
        .map_err(|n| check_override_names([n]).expect_err("an unknown name"))?;
    let unreadable = |(field, reason)| RhexError::Unreadable { field, reason };
    let params = record_with(base_params, &sorted[0]).map_err(unreadable)?;
    let mut cfg = record_with(base_cfg, &sorted[1]).map_err(unreadable)?;
    if !sorted[2].is_empty() {
        let base_act = match &cfg.actuator {
            a @ LegActuator::GearedMotor { .. } => a.clone(),
            LegActuator::SaturatedTorque => LegActuator::default(),
        };
        cfg.actuator = record_with(&base_act, &sorted[2]).map_err(unreadable)?;
    }
    cfg.strategy = point.strategy;
    cfg.t2_s = point.t2_s;
    if let Some(g) = point.gear_ratio {
        cfg.actuator = cfg.actuator.with_gear_ratio(g);
    }
    // the parameters reported with a leap describe its robot: the two pushing pairs
    let mut params = params;
    params.pairs = cfg.pairs.unwrap_or(cfg.strategy.chapter3_pairs()).to_vec();
    validate_inputs(&params, &cfg)?;
    Ok((params, cfg))
}

/// The checks a sweep makes before running a point (the leap makes its own too).
fn validate_inputs(params: &RhexParams, cfg: &LeapConfig) -> Result<(), RhexError> {
    params.validate()?;
    cfg.terrain.validate()?;
    if !cfg.t2_s.is_finite() {
        return Err(RhexError::InvalidValue {
            field: "t2_s".into(),
            reason: format!("must be finite, got {}", cfg.t2_s),
        });
    }
    cfg.actuator.validate()
}

/// The status string of an error (see [`SweepRow::status`]).
pub fn error_kind(e: &RhexError) -> &'static str {
    use selfmanip_hybrid::HybridError as H;
    match e {
        RhexError::InvalidValue { .. }
        | RhexError::UnknownParameter { .. }
        | RhexError::Unreadable { .. }
        | RhexError::Unsupported { .. }
        | RhexError::StartOverflow { .. } => "invalid_params",
        RhexError::ModeLabel { .. } => "invalid_mode",
        RhexError::Sim(s) if s.is_input_error() => "invalid_params",
        RhexError::Sim(s) => s.kind(),
        RhexError::Core(c) => core_kind(c),
        RhexError::Hybrid(h) => match h {
            H::Core(c) => core_kind(c),
            H::OffManifold { .. } => "off_manifold",
            H::InvalidOption { .. } => "invalid_params",
            H::StepTooSmall { .. } => "step_too_small",
            H::TooManyContacts { .. } => "too_many_contacts",
            H::ContactQp(_) => "contact_qp",
            #[allow(unreachable_patterns)]
            _ => "engine_error",
        },
    }
}

fn core_kind(c: &selfmanip_core::CoreError) -> &'static str {
    use selfmanip_core::CoreError as C;
    match c {
        C::SingularKkt { .. } => "singular_kkt",
        C::NonFinite { .. } => "non_finite",
        C::NonFiniteResult { .. } => "overflow",
        C::IllPosedQuasiStatic { .. } => "ill_posed",
        C::InvalidDescription { .. } | C::InvalidParameterization { .. } => "invalid_params",
        _ => "engine_error",
    }
}

/// The gear ratio a point ran with (NaN: the saturated torque).
pub fn gear_ratio_of(cfg: &LeapConfig) -> f64 {
    match cfg.actuator {
        LegActuator::GearedMotor { gear_ratio, .. } => gear_ratio,
        LegActuator::SaturatedTorque => f64::NAN,
    }
}

/// Runs one point: its inputs, then the leap.
pub fn run_point(
    base_params: &RhexParams,
    base_cfg: &LeapConfig,
    point: &SweepPoint,
) -> Result<LeapResult, RhexError> {
    let (params, cfg) = point_inputs(base_params, base_cfg, point)?;
    simulate_leap(&params, &cfg)
}

/// Runs one point and flattens the outcome; never panics and never fails.
pub fn run_row(base_params: &RhexParams, base_cfg: &LeapConfig, point: &SweepPoint) -> SweepRow {
    run_row_with(base_params, base_cfg, point, &NEVER, &Presets::default())
}

/// [`run_row`] that another thread can stop ([`simulate_leap_with`]): a point not started
/// before `stop` was raised is not run, its status `interrupted`. The leap runs on its preset
/// in `presets` (the sweep's own: each strategy's built once).
pub fn run_row_with(
    base_params: &RhexParams,
    base_cfg: &LeapConfig,
    point: &SweepPoint,
    stop: &AtomicBool,
    presets: &Presets,
) -> SweepRow {
    if stop.load(Ordering::Relaxed) {
        return SweepRow::failed(
            selfmanip_sim::RunStatus::Interrupted.as_str(),
            String::new(),
            f64::NAN,
        );
    }
    let outcome = catch_panic(|| {
        let (params, cfg) = point_inputs(base_params, base_cfg, point)?;
        let g = gear_ratio_of(&cfg);
        presets.run(&params, &cfg, stop).map(|r| (r, g))
    });
    match outcome {
        Err(m) => SweepRow::failed("panic", m, f64::NAN),
        Ok(Err(e)) => SweepRow::failed(error_kind(&e), e.to_string(), f64::NAN),
        Ok(Ok((r, g))) => SweepRow::of_leap(&r, String::new(), g),
    }
}

/// Runs every point on a rayon pool of exactly `threads` threads; rows in input order.
///
/// Errors only for `threads == 0` or a pool that cannot start; every per-point failure is a
/// row (see [`SweepRow::status`]).
///
/// ```no_run
/// use rhex_model::leap::{leap_params, LeapConfig, Strategy};
/// use rhex_model::sweep::{grid, sweep};
/// let t2: Vec<f64> = (0..41).map(|i| -0.2 + 0.01 * i as f64).collect();
/// let points = grid(&Strategy::ALL, &t2, &[Some(28.0)]);
/// let rows = sweep(&leap_params(), &LeapConfig::default(), &points, 2)?;
/// assert_eq!(rows.len(), 4 * 41);
/// # Ok::<(), rhex_model::RhexError>(())
/// ```
pub fn sweep(
    base_params: &RhexParams,
    base_cfg: &LeapConfig,
    points: &[SweepPoint],
    threads: usize,
) -> Result<Vec<SweepRow>, RhexError> {
    sweep_with(base_params, base_cfg, points, threads, &NEVER)
}

/// [`sweep`] that another thread can stop: once `stop` is raised, running leaps end within
/// one integration step and the points not yet started are not run; all of them get the
/// status `interrupted` (the rows of finished points are kept). Every point is still a row,
/// in input order.
///
/// How a caller stops it on Ctrl-C: run the sweep on a thread of its own and, on the
/// calling thread, poll for the signal and raise the flag.
///
/// ```no_run
/// use rhex_model::leap::{leap_params, LeapConfig, Strategy};
/// use rhex_model::sweep::{grid, sweep_with};
/// use std::sync::atomic::{AtomicBool, Ordering};
/// let points = grid(&Strategy::ALL, &[0.0, 0.1], &[None]);
/// let stop = AtomicBool::new(false);
/// let rows = std::thread::scope(|s| {
///     let job = s.spawn(|| sweep_with(&leap_params(), &LeapConfig::default(), &points, 2, &stop));
///     while !job.is_finished() {
///         std::thread::sleep(std::time::Duration::from_millis(50));
///         let interrupted = false; // e.g. pyo3's `py.check_signals().is_err()`
///         if interrupted {
///             stop.store(true, Ordering::Relaxed);
///         }
///     }
///     job.join().expect("the sweep thread does not panic")
/// })?;
/// # Ok::<(), rhex_model::RhexError>(())
/// ```
pub fn sweep_with(
    base_params: &RhexParams,
    base_cfg: &LeapConfig,
    points: &[SweepPoint],
    threads: usize,
    stop: &AtomicBool,
) -> Result<Vec<SweepRow>, RhexError> {
    let presets = Presets::default();
    Ok(run_parallel(points, threads, |p| {
        run_row_with(base_params, base_cfg, p, stop, &presets)
    })?)
}
