//! Batched leaps: strategy × `t2` × gear ratio × any parameter by name, as the generic sweep
//! ([`selfmanip_sim::sweep::preset_sweep`]: determinism, failure isolation, the rayon pool)
//! with the leap preset ([`LeapSweep`]). A row is the generic [`SweepRow`] with the leap's
//! apex (chapter 3's frame, z up) and the gear ratio used ([`LEAP_COLUMNS`]).
//!
//! **Overrides** name a field of [`RhexParams`], of [`LeapConfig`] (not `strategy`, `t2_s` or
//! `actuator`, which are columns) or of the geared motor (`current_limit_a`, …), as JSON values
//! read with the data files' serde rules (a wrong type names its field). **Gear ratio**
//! `Some(G)` runs the geared motor of ratio `G` (the base actuator's other values, else
//! chapter 5's); `None` keeps the base actuator (reported NaN for the saturated torque).
use crate::leap::{LeapConfig, Presets, Strategy, X_RHEX_LEG};
use crate::{RhexError, RhexParams};
use selfmanip_hybrid::budget::NEVER;
use selfmanip_sim::path::record_with;
pub use selfmanip_sim::sweep::{panic_message, run_row, SweepRow};
use selfmanip_sim::sweep::{preset_error_kind, preset_sweep, Preset, RecordFields};
use selfmanip_sim::SimError;
use serde_json::{Map, Value};
use std::sync::atomic::AtomicBool;

/// One leap of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct LeapPoint {
    pub strategy: Strategy,
    /// Rear leg's start relative to the front leg's (s).
    pub t2_s: f64,
    /// Geared motors of this ratio, or `None` for the base configuration's actuator.
    pub gear_ratio: Option<f64>,
    /// Parameter overrides by name (see the module documentation).
    pub overrides: Map<String, Value>,
}

impl LeapPoint {
    pub fn new(strategy: Strategy, t2_s: f64, gear_ratio: Option<f64>) -> Self {
        LeapPoint {
            strategy,
            t2_s,
            gear_ratio,
            overrides: Map::new(),
        }
    }
}

/// The leap preset's own columns of a [`SweepRow`]: the gear ratio used (NaN for the
/// saturated-torque actuator or a point that failed).
pub const LEAP_COLUMNS: [&str; 1] = ["gear_ratio"];

/// The leap as a preset of the generic sweep: each point's inputs ([`point_inputs`]) from
/// the base parameters and configuration, run on the preset kept for its strategy and
/// fixed inputs ([`Presets`]).
pub struct LeapSweep {
    pub params: RhexParams,
    pub cfg: LeapConfig,
    presets: Presets,
}

impl LeapSweep {
    pub fn new(params: &RhexParams, cfg: &LeapConfig) -> Self {
        LeapSweep {
            params: params.clone(),
            cfg: cfg.clone(),
            presets: Presets::default(),
        }
    }
}

impl Preset for LeapSweep {
    type Point = LeapPoint;
    type Error = RhexError;

    fn columns(&self) -> &'static [&'static str] {
        &LEAP_COLUMNS
    }

    fn run(&self, point: &LeapPoint, stop: &AtomicBool) -> Result<SweepRow, RhexError> {
        let (params, cfg) = point_inputs(&self.params, &self.cfg, point)?;
        // the column of a saturated torque's gear ratio is NaN (none)
        let g = cfg.actuator.gear_ratio().unwrap_or(f64::NAN);
        let r = self.presets.run(&params, &cfg, stop)?;
        Ok(SweepRow::of_run(
            &r.outcome,
            r.flew,
            r.apex,
            String::new(),
            vec![g],
        ))
    }

    fn error_kind(&self, e: &RhexError) -> &'static str {
        error_kind(e)
    }
}

/// The Cartesian product strategy × gear ratio × `t2` (`t2` varying fastest).
pub fn grid(strategies: &[Strategy], t2_s: &[f64], gear_ratios: &[Option<f64>]) -> Vec<LeapPoint> {
    let mut out = Vec::with_capacity(strategies.len() * t2_s.len() * gear_ratios.len());
    for &s in strategies {
        for &g in gear_ratios {
            for &t2 in t2_s {
                out.push(LeapPoint::new(s, t2, g));
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

/// The names that set the geared motor's fields: an override of one runs the geared motor.
pub fn actuator_field_names() -> &'static [&'static str] {
    &ACTUATOR_FIELDS
}

/// Every name an override may use, each once, grouped by what they set: every field serde
/// reads of [`RhexParams`] (but `pairs`, which names [`LeapConfig::pairs`]), of [`LeapConfig`]
/// (but its columns) and of the geared motor.
fn override_groups() -> RecordFields {
    RecordFields(vec![
        RecordFields::of::<RhexParams>(&[LEAP_PAIRS]),
        RecordFields::of::<LeapConfig>(&OWN_COLUMNS),
        ACTUATOR_FIELDS.to_vec(),
    ])
}

/// Every name an override may use, each once (`override_groups`).
pub fn sweepable_names() -> Vec<String> {
    override_groups().names()
}

/// Checks that every name is sweepable; the error names the first unknown one.
pub fn check_override_names<'a>(names: impl IntoIterator<Item = &'a str>) -> Result<(), RhexError> {
    match override_groups().unknown(names) {
        Some(n) => Err(RhexError::UnknownParameter {
            field: n.into(),
            known: sweepable_names().join(", "),
        }),
        None => Ok(()),
    }
}

/// The robot parameters and leap configuration of one point, validated.
pub fn point_inputs(
    base_params: &RhexParams,
    base_cfg: &LeapConfig,
    point: &LeapPoint,
) -> Result<(RhexParams, LeapConfig), RhexError> {
    let sorted = (override_groups().sort(&point.overrides))
        .map_err(|n| check_override_names([n]).expect_err("an unknown name"))?;
    let unreadable = |(field, reason)| RhexError::Unreadable { field, reason };
    let params = record_with(base_params, &sorted[0]).map_err(unreadable)?;
    let mut cfg = record_with(base_cfg, &sorted[1]).map_err(unreadable)?;
    if !sorted[2].is_empty() {
        cfg.actuator =
            record_with(&X_RHEX_LEG.geared(&cfg.actuator), &sorted[2]).map_err(unreadable)?;
    }
    cfg.strategy = point.strategy;
    cfg.t2_s = point.t2_s;
    if let Some(g) = point.gear_ratio {
        cfg.actuator = X_RHEX_LEG.with_gear_ratio(&cfg.actuator, g);
    }
    // the parameters reported with a leap describe its robot: the two pushing pairs
    let mut params = params;
    params.pairs = cfg.pairs.unwrap_or(cfg.strategy.chapter3_pairs()).to_vec();
    // the checks the leap makes, before the point runs (the parameters first)
    params.validate()?;
    cfg.validate()?;
    Ok((params, cfg))
}

/// The status string of an error (see [`SweepRow::status`]): `invalid_mode` for a bad mode
/// label, `invalid_params` for another error of the inputs, else the generic preset's
/// ([`preset_error_kind`]).
pub fn error_kind(e: &RhexError) -> &'static str {
    preset_error_kind(&match e {
        RhexError::ModeLabel { .. } => return "invalid_mode",
        RhexError::Core(c) => SimError::Core(c.clone()),
        RhexError::Hybrid(h) => SimError::Hybrid(h.clone()),
        RhexError::Sim(s) => s.clone(),
        _ => return "invalid_params",
    })
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
    points: &[LeapPoint],
    threads: usize,
) -> Result<Vec<SweepRow>, RhexError> {
    sweep_with(base_params, base_cfg, points, threads, &NEVER)
}

/// [`sweep`] that another thread can stop (on Ctrl-C: run it on a thread of its own and
/// raise `stop` from the calling one): running leaps end within one integration step, points
/// not yet started are not run, and all of them get the status `interrupted`; every point is
/// still a row, in input order.
pub fn sweep_with(
    base_params: &RhexParams,
    base_cfg: &LeapConfig,
    points: &[LeapPoint],
    threads: usize,
    stop: &AtomicBool,
) -> Result<Vec<SweepRow>, RhexError> {
    let preset = LeapSweep::new(base_params, base_cfg);
    Ok(preset_sweep(&preset, points, threads, stop)?)
}
