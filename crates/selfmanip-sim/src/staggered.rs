//! A scenario with two drives started a lag apart, compiled once and run at many points: its
//! simulation is rebound per point (behaviour parameter values and the lag) on a clock that
//! starts with the earlier drive, its runs are read in the first drive's frame
//! ([`StaggeredRun`]: the preset's run with its lag and touchdown lag), and a search finds the
//! lag at which the two drives' legs touch down a given time apart ([`LagReference`]: what a
//! lag times). What a preset of two staggered drives keeps per set of fixed inputs
//! ([`crate::sweep::BuildCache`]).
use crate::analysis::roots::secant_search;
use crate::outcome::{first_touchdown_s, PresetFrame};
use crate::preset_run::PresetRun;
use crate::{Run, SimError, Simulation};
use selfmanip_core::ContactMode;
use selfmanip_hybrid::Execution;
use serde::{Deserialize, Serialize};
use std::sync::atomic::AtomicBool;

/// Runs at most in a touchdown-timed search ([`search_touchdown_lag`]).
pub const TOUCHDOWN_SEARCH_RUNS: usize = 12;
/// Agreement of the touchdown lag with its target at which that search stops (s).
pub const TOUCHDOWN_SEARCH_TOL_S: f64 = 1e-7;

/// What a staggered run's lag times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum LagReference {
    /// The second drive's motor starts `lag` after the first's. The default.
    #[default]
    MotorStart,
    /// The second drive's leg touches down `lag` after the first's: the motor lag is found
    /// run by run ([`search_touchdown_lag`]); a run whose legs do not both touch down keeps
    /// the motor lag `lag`.
    Touchdown,
}

impl LagReference {
    /// The run at the lag `lag_s` timed as this says, of `run(s) = (result, touchdown lag)`
    /// at the motor lag `s`: the run at `s = lag_s`, or the one [`search_touchdown_lag`]
    /// finds (`|s| < limit_s`).
    pub fn run<R, E>(
        self,
        lag_s: f64,
        limit_s: f64,
        mut run: impl FnMut(f64) -> Result<(R, Option<f64>), E>,
    ) -> Result<R, E> {
        match self {
            LagReference::MotorStart => Ok(run(lag_s)?.0),
            LagReference::Touchdown => search_touchdown_lag(lag_s, limit_s, run),
        }
    }
}

/// A compiled scenario whose second drive starts `lag` seconds after the first (the behaviour
/// parameter `lag_parameter`; negative: the second starts first): its simulation as built at
/// the lag `built_lag_s`, on a clock that starts `min(0, lag)` before the first drive.
#[derive(Clone)]
pub struct StaggeredScenario {
    pub sim: Simulation,
    pub lag_parameter: &'static str,
    pub built_lag_s: f64,
    /// Final time on the first drive's clock (s).
    pub t_final_s: f64,
    /// The contacts whose touchdowns a run's touchdown lag compares ([`touchdown_lag_s`]):
    /// the first drive's leg's, then the second's.
    pub touchdowns: [usize; 2],
    /// Its runs carry their event records ([`PresetRun::events`]; a sweep that reads only
    /// rows does without).
    pub event_records: bool,
}

/// A run of a [`StaggeredScenario`] read in the first drive's frame.
#[derive(Debug, Clone)]
pub struct StaggeredRun {
    /// The run on the first drive's clock, `x` from the start's.
    pub run: PresetRun,
    /// The second drive's start after the first's in this run (s).
    pub lag_s: f64,
    /// The second leg's first touchdown after the first leg's, each after its drive started
    /// ([`touchdown_lag_s`]); `None` if one never touched down.
    pub touchdown_lag_s: Option<f64>,
}

impl std::fmt::Debug for StaggeredScenario {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StaggeredScenario")
            .field("lag_parameter", &self.lag_parameter)
            .field("built_lag_s", &self.built_lag_s)
            .field("t_final_s", &self.t_final_s)
            .field("touchdowns", &self.touchdowns)
            .field("event_records", &self.event_records)
            .finish_non_exhaustive()
    }
}

impl StaggeredScenario {
    /// `sim`, built at the lag `built_lag_s` of its behaviour parameter `lag_parameter`, run to
    /// `t_final_s` on the first drive's clock; its runs carry their event records and time
    /// their legs' touchdowns at the contacts `touchdowns`.
    pub fn new(
        sim: Simulation,
        lag_parameter: &'static str,
        built_lag_s: f64,
        t_final_s: f64,
        touchdowns: [usize; 2],
    ) -> Self {
        StaggeredScenario {
            sim,
            lag_parameter,
            built_lag_s,
            t_final_s,
            touchdowns,
            event_records: true,
        }
    }

    /// The simulation at lag `lag_s` with the behaviour parameters `values` bound too
    /// ([`Simulation::rebind`]: what a fresh build of that point runs, bit for bit), and the
    /// first drive's start on its clock (`−min(0, lag)`).
    pub fn simulation(
        &self,
        values: &[(&str, f64)],
        lag_s: f64,
    ) -> Result<(Simulation, f64), SimError> {
        let offset = lag_s.min(0.0);
        let mut sim = self.sim.clone();
        // the build's own point is its simulation as built
        if !values.is_empty() || lag_s.to_bits() != self.built_lag_s.to_bits() {
            let mut bound = values.to_vec();
            bound.push((self.lag_parameter, lag_s));
            sim.rebind(&bound, self.t_final_s - offset)?;
        }
        Ok((sim, -offset))
    }

    /// Runs [`Self::simulation`] at lag `lag_s` from its start state plus `start_offset`
    /// (`2nq` entries over `(q, q̇)`, [`crate::named_terms::offset_start`]; the behaviour is
    /// compiled at the unperturbed start): the run, and the first drive's start on its clock.
    pub fn run_from(
        &self,
        lag_s: f64,
        start_offset: Option<&[f64]>,
    ) -> Result<(Run, f64), SimError> {
        let (mut sim, first_start) = self.simulation(&[], lag_s)?;
        if let Some(dx) = start_offset {
            crate::named_terms::offset_start(&mut sim, dx)?;
        }
        Ok((sim.run_with(&selfmanip_hybrid::budget::NEVER)?, first_start))
    }

    /// Runs [`Self::simulation`]: the run, and the first drive's start on its clock.
    pub fn run(
        &self,
        values: &[(&str, f64)],
        lag_s: f64,
        stop: &AtomicBool,
    ) -> Result<(Run, f64), SimError> {
        let (sim, first_start) = self.simulation(values, lag_s)?;
        Ok((sim.run_with(stop)?, first_start))
    }

    /// The run `(run, first drive's start on its clock)` at lag `lag_s` read in the first
    /// drive's frame ([`staggered_frame`]), its modes labelled by `label`.
    pub fn read(
        &self,
        (run, first_start): (Run, f64),
        lag_s: f64,
        label: &dyn Fn(ContactMode) -> String,
    ) -> StaggeredRun {
        let (exec, outcome) = (run.execution, run.outcome);
        let (model, q0) = (&self.sim.model, self.sim.q0.clone());
        let stop_at_apex = self.sim.options.stop_at_apex;
        let frame = staggered_frame(first_start, lag_s, q0[model.ix_x()], stop_at_apex);
        let touchdown_lag_s = touchdown_lag_s(&exec, self.touchdowns, first_start, lag_s);
        let run = PresetRun::read(
            model,
            &self.sim.terrain,
            label,
            (exec, outcome),
            frame,
            q0,
            self.t_final_s,
            self.event_records,
        );
        StaggeredRun {
            run,
            lag_s,
            touchdown_lag_s,
        }
    }

    /// The run at lag `lag_s` timed as `reference` says ([`LagReference::run`]: a touchdown
    /// lag searched over drive lags) with the behaviour parameters `values` bound, read
    /// ([`Self::read`]).
    pub fn run_timed(
        &self,
        values: &[(&str, f64)],
        lag_s: f64,
        reference: LagReference,
        stop: &AtomicBool,
        label: &dyn Fn(ContactMode) -> String,
    ) -> Result<StaggeredRun, SimError> {
        reference.run(lag_s, self.t_final_s, |s| {
            let r = self.read(self.run(values, s, stop)?, s, label);
            let lag = r.touchdown_lag_s;
            Ok((r, lag))
        })
    }
}

/// `d (first drive's start on the execution clock) / d lag` at lag `lag_s`: the clock starts
/// with the earlier drive, at `min(0, lag)` on the first drive's, so a negative lag moves the
/// first drive's start (`−min(0, lag)`) by `−1` per second of lag.
pub fn d_first_start_d_lag(lag_s: f64) -> f64 {
    if lag_s >= 0.0 {
        0.0
    } else {
        -1.0
    }
}

/// The frame of a run whose first drive starts at `first_start_s` on the execution clock and
/// second `lag_s` later: its clock from the first drive's start, flights counted from the
/// earlier start, `x` from `x0_m`.
pub fn staggered_frame(
    first_start_s: f64,
    lag_s: f64,
    x0_m: f64,
    stop_at_apex: bool,
) -> PresetFrame {
    PresetFrame {
        t0_s: first_start_s,
        drive_start_s: first_start_s.min(first_start_s + lag_s),
        x0_m,
        stop_at_apex,
    }
}

/// The touchdown lag of such a run: the first touchdown of `contacts[1]` after the second
/// drive's start minus that of `contacts[0]` after the first's (`None` if either never touches
/// down).
pub fn touchdown_lag_s(
    exec: &Execution,
    contacts: [usize; 2],
    first_start_s: f64,
    lag_s: f64,
) -> Option<f64> {
    let first = first_touchdown_s(exec, contacts[0], first_start_s);
    let second = first_touchdown_s(exec, contacts[1], first_start_s + lag_s);
    first.zip(second).map(|(a, b)| b - a)
}

/// The run at the drive lag `s` whose touchdown lag `T(s)` is `target_s`: a secant search
/// (at most [`TOUCHDOWN_SEARCH_RUNS`] runs, to [`TOUCHDOWN_SEARCH_TOL_S`], `|s| < limit_s`) on
/// `run(s) = (result, T(s))`, started at `target_s` (`T(s) = s` while the body rests between
/// the two touchdowns, so it usually ends after one or two more runs); the run it returns is
/// the one [`secant_search`] keeps.
pub fn search_touchdown_lag<R, E>(
    target_s: f64,
    limit_s: f64,
    mut run: impl FnMut(f64) -> Result<(R, Option<f64>), E>,
) -> Result<R, E> {
    let (runs, tol) = (TOUCHDOWN_SEARCH_RUNS, TOUCHDOWN_SEARCH_TOL_S);
    secant_search(target_s, runs, tol, limit_s, |s| {
        let (r, lag) = run(s)?;
        Ok((r, lag.map(|t| t - target_s)))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The search ends at the lag whose touchdown lag is the target. Second route: the root
    /// of `T(s) = s + 2 s²` in closed form, `s = (√(1 + 8 t) − 1) / 4`.
    #[test]
    fn search_finds_the_lag_of_a_touchdown_lag() {
        let target = 0.05;
        let found =
            search_touchdown_lag(target, 1.0, |s| Ok::<_, ()>((s, Some(s + 2.0 * s * s)))).unwrap();
        let exact = ((1.0 + 8.0 * target).sqrt() - 1.0) / 4.0;
        assert!(
            (found - exact).abs() < TOUCHDOWN_SEARCH_TOL_S,
            "{found} vs {exact}"
        );
    }

    /// The frame's clock starts with the first drive and its flights with the earlier one.
    #[test]
    fn frame_counts_flights_from_the_earlier_drive() {
        let f = staggered_frame(0.1, -0.1, 0.5, true);
        assert_eq!((f.t0_s, f.drive_start_s, f.x0_m), (0.1, 0.0, 0.5));
        let f = staggered_frame(0.0, 0.1, 0.5, false);
        assert_eq!((f.t0_s, f.drive_start_s), (0.0, 0.0));
    }
}
