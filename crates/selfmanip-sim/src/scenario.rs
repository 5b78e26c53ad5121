//! A *scenario* — robot description, terrain, initial state, behaviour, options — and its
//! execution through the hybrid engine.
//!
//! ```text
//! Scenario (serde data)  => Simulation::new: Model, terrain, initial mode, compiled behaviour
//!                        => Simulation::run: selfmanip_hybrid::simulate => Run
//! Run                    => outcome (word, apex, landing), events, trajectory(dt),
//!                           energy_report(), write_mcap(path)
//! ```
use crate::behaviour::spec::{parse_text, read_file};
use crate::behaviour::{compile_bound, Behaviour, BehaviourController, Parameters, ReusableParts};
use crate::error::{invalid, non_negative, positive, SimError};
use crate::events::{event_records, EventRecord};
use crate::expr::{ParsedFormulas, Scalar};
use crate::labels::ContactLabels;
use crate::mcap::{self, McapLog};
use crate::outcome::{outcome, Outcome, WordOptions};
use crate::terrain::TerrainSpec;
use crate::trajectory::{coordinate_indices, q_names, sample, Trajectory};
use selfmanip_core::{ContactKind, ContactMode, Model, RobotDescription};
use selfmanip_hybrid::{
    energy_report, Controller, EnergyReport, Execution, HybridOptions, StepOptions,
    VelocityTolerance,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// Everything one execution needs. TOML or JSON; every field can be set by name
/// ([`crate::path`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub robot: RobotDescription,
    #[serde(default)]
    pub terrain: TerrainSpec,
    pub initial: InitialState,
    /// Default: no actuation (zero joint torques, free joints unaccelerated).
    #[serde(default)]
    pub behaviour: Behaviour,
    #[serde(default)]
    pub options: SimOptions,
}

/// The state an execution starts from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialState {
    /// `q = [θ…, x, z, φ]` (rad, m; NED: z down).
    pub q: Vec<f64>,
    /// `q̇` (default: at rest).
    #[serde(default)]
    pub qd: Option<Vec<f64>>,
    /// The contacts active at the start (`name`, or `name:slide` / `name:stick`); default
    /// none (flight).
    #[serde(default)]
    pub contacts: Vec<String>,
    /// Coordinates (by name: `z`, `phi`, `front_theta`, …) to solve so that the initial
    /// contacts touch the ground exactly, one per contact, starting from `q`.
    #[serde(default)]
    pub solve: Vec<String>,
}

/// Options of an execution.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimOptions {
    /// End of the execution (s).
    pub t_final_s: f64,
    /// Stop at the first apex of a flight.
    pub stop_at_apex: bool,
    /// Width of the bracket that locates each event (s).
    pub event_tol_s: f64,
    /// Pseudo-impulse duration δt of (5.39) (s); 0 disables it.
    pub delta_t_s: f64,
    /// Relative error tolerance per step.
    pub rtol: f64,
    /// Absolute error tolerance per step (default: `rtol / 100`), the heaviest coordinate's
    /// where the velocities' are scaled by their mass (`velocity_tolerance`).
    pub atol: Option<f64>,
    /// How the velocities share `atol`: `kinetic_energy` (the default: each by the mass it
    /// moves, [`VelocityTolerance::KineticEnergy`]) or `uniform`.
    pub velocity_tolerance: VelocityTolerance,
    /// Largest step (s).
    pub h_max_s: f64,
    /// More than `zeno_max_events` events within `zeno_window_s` end the run (Zeno).
    pub zeno_window_s: f64,
    pub zeno_max_events: usize,
    /// Total event budget.
    pub max_events: usize,
    /// Contacts shown in mode labels and words, in order (default: all, in the
    /// description's order).
    pub labels: Option<Vec<String>>,
    /// How the word is formed.
    pub word: WordOptions,
    /// Switch to a linearly implicit method on stiff stretches (a servo's damping on a light
    /// link): [`selfmanip_hybrid::StepOptions::stiff_switch`]. On by default; the
    /// derivatives of a run ([`crate::sensitivity`]) follow its implicit steps.
    pub stiff_switch: bool,
    /// Truncate at once a contact's re-touch after a flight from rest too short for an impact
    /// to resolve ([`HybridOptions::truncate_unresolved_flights`]) instead of after the
    /// chatter criterion's repetitions of it. On by default.
    pub truncate_unresolved_flights: bool,
}

/// The default relative step tolerance of a run: the energy balance
/// `E₁ − E₀ = W + W_d + W_fr − L` ([`selfmanip_hybrid::energy_report`]) closes to the
/// integration error of the state, which scales with `rtol`; over a run of a thousand steps
/// of a robot of a few joules it is about `100 J × rtol`. With the velocities' absolute
/// tolerances scaled by their mass ([`VelocityTolerance::KineticEnergy`]), 2e-9 balances the
/// newcomer's bounder of issue 30 to 6.6e-7 J over its 20-point bound sweep (7.8e-7 J over
/// 200 runs of it with the gains moved by parts in 10⁹), one part in 10⁷ of its energy, and
/// runs the user sweep (`scripts/user_robot_sweep.py`) in 11 % fewer steps than a uniform
/// tolerance at 5e-9, with smaller residuals
/// (docs/decisions/2026-11-30-kinetic-energy-velocity-tolerance.md).
pub const DEFAULT_RTOL: f64 = 2e-9;

impl Default for SimOptions {
    fn default() -> Self {
        let h = HybridOptions::default();
        SimOptions {
            t_final_s: 1.0,
            stop_at_apex: false,
            event_tol_s: h.event_tol_s,
            delta_t_s: 0.0,
            rtol: DEFAULT_RTOL,
            atol: None,
            velocity_tolerance: VelocityTolerance::KineticEnergy,
            h_max_s: h.step.h_max_s,
            zeno_window_s: h.zeno_window_s,
            zeno_max_events: h.zeno_max_events,
            max_events: h.max_events,
            labels: None,
            word: WordOptions::default(),
            stiff_switch: h.step.stiff_switch,
            truncate_unresolved_flights: true,
        }
    }
}

impl SimOptions {
    /// The engine's options (checked; errors name the field).
    pub fn hybrid(&self) -> Result<HybridOptions, SimError> {
        positive("options.t_final_s", self.t_final_s)?;
        positive("options.event_tol_s", self.event_tol_s)?;
        non_negative("options.delta_t_s", self.delta_t_s)?;
        positive("options.rtol", self.rtol)?;
        let atol = match self.atol {
            Some(a) => positive("options.atol", a)?,
            None => self.rtol * 1e-2,
        };
        positive("options.h_max_s", self.h_max_s)?;
        positive("options.zeno_window_s", self.zeno_window_s)?;
        non_negative("options.word.min_duration_s", self.word.min_duration_s)?;
        if self.zeno_max_events == 0 || self.max_events == 0 {
            return Err(invalid(
                "options.zeno_max_events",
                "event limits must be at least 1",
            ));
        }
        let d = HybridOptions::default();
        Ok(HybridOptions {
            step: StepOptions {
                rtol: self.rtol,
                atol,
                h_max_s: self.h_max_s,
                stiff_switch: self.stiff_switch,
                velocity_tolerance: self.velocity_tolerance,
                ..d.step
            },
            event_tol_s: self.event_tol_s,
            delta_t_s: self.delta_t_s,
            zeno_window_s: self.zeno_window_s,
            zeno_max_events: self.zeno_max_events,
            max_events: self.max_events,
            stop_at_apex: self.stop_at_apex,
            truncate_unresolved_flights: self.truncate_unresolved_flights,
            ..d
        })
    }
}

impl Scenario {
    pub fn from_toml_str(s: &str) -> Result<Self, SimError> {
        parse_text("scenario", "toml", s)
    }

    pub fn from_json_str(s: &str) -> Result<Self, SimError> {
        parse_text("scenario", "json", s)
    }

    /// Reads a `.toml` or `.json` scenario file (by extension).
    pub fn from_file(path: &Path) -> Result<Self, SimError> {
        read_file("scenario", path)
    }

    /// A scenario of `robot` at `q` at rest in flight on flat ground, with no actuation.
    pub fn new(robot: RobotDescription, q: Vec<f64>) -> Self {
        Scenario {
            robot,
            terrain: TerrainSpec::Flat,
            initial: InitialState {
                q,
                qd: None,
                contacts: Vec::new(),
                solve: Vec::new(),
            },
            behaviour: Behaviour::default(),
            options: SimOptions::default(),
        }
    }

    /// The scenario as a JSON tree (the form parameter paths address).
    pub fn to_value(&self) -> Result<serde_json::Value, SimError> {
        serde_json::to_value(self).map_err(|e| SimError::Parse {
            what: "scenario".into(),
            format: "json",
            message: e.to_string(),
        })
    }

    /// The scenario with the fields named in `values` set (paths as in [`crate::path`]);
    /// a value of the wrong type names its path.
    pub fn with_values(&self, values: &[(String, serde_json::Value)]) -> Result<Self, SimError> {
        let mut tree = self.to_value()?;
        crate::path::distinct_paths(&tree, values)?;
        Self::set_all(&mut tree, values)
    }

    pub(crate) fn set_all(
        tree: &mut serde_json::Value,
        values: &[(String, serde_json::Value)],
    ) -> Result<Self, SimError> {
        for (name, v) in values {
            crate::path::set(tree, name, v.clone())?;
        }
        serde_json::from_value(tree.clone()).map_err(|e| {
            // name the value at fault: the first whose own change fails
            let culprit = values.iter().map(|(n, _)| n.clone()).next_back();
            SimError::InvalidValue {
                field: culprit.unwrap_or_else(|| "scenario".into()),
                reason: e.to_string(),
            }
        })
    }

    /// Sets one field by name.
    pub fn set(&mut self, name: &str, value: impl Into<serde_json::Value>) -> Result<(), SimError> {
        *self = self.with_values(&[(name.to_string(), value.into())])?;
        Ok(())
    }

    /// Every name a parameter can be set by: the behaviour's parameters, then the full paths
    /// of every settable field.
    pub fn settable_names(&self) -> Result<Vec<String>, SimError> {
        let mut names: Vec<String> = self.behaviour.parameters.keys().cloned().collect();
        names.extend(crate::path::leaves(&self.to_value()?));
        Ok(names)
    }
}

/// A scenario ready to run: the model, the initial state and mode, the controller.
#[derive(Clone)]
pub struct Simulation {
    pub model: Arc<Model>,
    pub terrain: TerrainSpec,
    pub controller: Arc<dyn Controller>,
    pub q0: Vec<f64>,
    pub qd0: Vec<f64>,
    pub mode0: ContactMode,
    pub t_final_s: f64,
    pub options: HybridOptions,
    pub labels: ContactLabels,
    pub word: WordOptions,
    /// The behaviour the controller was compiled from, its parameters apart (in
    /// `parameters`): what [`Self::rebind`] evaluates again.
    behaviour: Arc<Behaviour>,
    parameters: Arc<Parameters>,
    /// The behaviour's formulas, parsed at the first compilation for every rebind.
    formulas: Arc<ParsedFormulas>,
    /// The behaviour's compiled parts, kept by the first rebind: a later one compiles again
    /// only those that read a parameter whose value changed.
    parts: Arc<ReusableParts>,
}

impl Simulation {
    /// Checks and builds everything (errors name the field).
    pub fn new(s: &Scenario) -> Result<Self, SimError> {
        let mut sim = Self::without_behaviour(s)?;
        let mut b = s.behaviour.clone();
        sim.parameters = Arc::new(std::mem::take(&mut b.parameters));
        sim.behaviour = Arc::new(b);
        sim.controller = Arc::new(sim.compiled(&sim.parameters, sim.t_final_s, false)?);
        Ok(sim)
    }

    /// The behaviour compiled with the parameters `p` for a run to `t_final_s`; by a rebind
    /// (`reuse`), with the parts kept by the first rebind ([`ReusableParts`]: a simulation
    /// run once does not pay for keeping them).
    fn compiled(
        &self,
        p: &Arc<Parameters>,
        t_final_s: f64,
        reuse: bool,
    ) -> Result<BehaviourController, SimError> {
        compile_bound(
            &self.behaviour,
            p,
            (&self.formulas, reuse.then_some(&*self.parts)),
            &self.model,
            &self.q0,
            &self.qd0,
            t_final_s,
        )
    }

    /// Binds numbers to behaviour parameters by name and sets the final time: the
    /// simulation [`Self::new`] builds for the scenario with each
    /// `behaviour.parameters.<name>` set to its value and `options.t_final_s` to
    /// `t_final_s`, bit for bit. The robot, start state, labels and options already built
    /// and checked are kept (a sweep's points and a preset's leaps share them); the behaviour
    /// is evaluated again with the new values (errors name the field, as [`Self::new`]'s
    /// do). A name that is not one of the behaviour's parameters is an error.
    pub fn rebind(&mut self, values: &[(&str, f64)], t_final_s: f64) -> Result<(), SimError> {
        positive("options.t_final_s", t_final_s)?;
        let mut p = (*self.parameters).clone();
        for (name, v) in values {
            let slot = p.get_mut(*name).ok_or_else(|| SimError::UnknownParameter {
                path: format!("behaviour.parameters.{name}"),
                reason: "not a parameter of the behaviour".into(),
            })?;
            *slot = Scalar::Number(*v);
        }
        let p = Arc::new(p);
        self.controller = Arc::new(self.compiled(&p, t_final_s, true)?);
        self.parameters = p;
        self.t_final_s = t_final_s;
        Ok(())
    }

    /// Like [`Self::new`] with no actuation; set [`Self::controller`] to drive it with any
    /// [`Controller`] (the behaviour of the scenario is not read).
    pub fn without_behaviour(s: &Scenario) -> Result<Self, SimError> {
        let model = s.robot.build()?;
        s.terrain.validate()?;
        let nq = model.nq();
        let mut q0 = s.initial.q.clone();
        let qd0 = s.initial.qd.clone().unwrap_or_else(|| vec![0.0; nq]);
        for (field, v) in [("initial.q", &q0), ("initial.qd", &qd0)] {
            if v.len() != nq {
                return Err(invalid(
                    field,
                    format!(
                        "expected {nq} coordinates ({}), got {}",
                        q_names(&model).join(", "),
                        v.len()
                    ),
                ));
            }
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(invalid(format!("{field}[{i}]"), "must be finite"));
            }
        }
        let mut mode0 = ContactMode::FLIGHT;
        let mut active = Vec::new();
        for (i, item) in s.initial.contacts.iter().enumerate() {
            let field = format!("initial.contacts[{i}]");
            let (name, kind) = match item.split_once(':') {
                Some((n, "slide")) => (n, Some(ContactKind::Slide)),
                Some((n, "stick")) => (n, Some(ContactKind::Stick)),
                Some((_, other)) => {
                    return Err(invalid(
                        field,
                        format!("unknown contact kind `{other}` (slide or stick)"),
                    ))
                }
                None => (item.as_str(), None),
            };
            let k = crate::labels::contact_by_name(&model, name, &field)?;
            if active.contains(&k) {
                return Err(invalid(field, format!("contact `{name}` is listed twice")));
            }
            mode0 = match kind {
                Some(kind) => mode0.with(k, kind),
                None => mode0.union(ContactMode::with_defaults(&model, &[k])?),
            };
            active.push(k);
        }
        mode0.validate(&model)?;
        let terrain = s.terrain;
        if !s.initial.solve.is_empty() {
            let free = coordinate_indices(&model, "initial.solve", &s.initial.solve)?;
            q0 = crate::analysis::solve_contact_pose(&model, &terrain, &active, &free, &q0)?;
        }
        // finite coordinates too large for double precision (1e308) give an infinite energy
        let mut data = selfmanip_core::Data::new(&model);
        if let Err(selfmanip_core::CoreError::NonFiniteResult { quantity }) =
            selfmanip_core::energy(&model, &mut data, &q0, &qd0)
        {
            let field = if quantity == "T" {
                "initial.qd"
            } else {
                "initial.q"
            };
            return Err(invalid(
                field,
                format!("too large: `{quantity}` overflows at it"),
            ));
        }
        // no inactive contact may start below the ground (the first step would meet it as a
        // discontinuity of the terrain, not as a touchdown)
        let inactive: Vec<usize> = (0..model.n_contacts())
            .filter(|k| !active.contains(k))
            .collect();
        let gaps = crate::analysis::contact_gaps(&model, &terrain, &inactive, &q0);
        if let Some((k, gap)) = inactive.iter().zip(&gaps).find(|(_, g)| **g < -1e-9) {
            return Err(invalid(
                "initial.q",
                format!(
                    "contact `{}` starts {:.3e} m below the ground (list it in `initial.contacts` \
                     to start on it)",
                    model.contacts[*k].name, -gap
                ),
            ));
        }
        let labels = match &s.options.labels {
            Some(names) => ContactLabels::from_names(&model, names, "options.labels")?,
            None => ContactLabels::all(&model),
        };
        Ok(Simulation {
            options: s.options.hybrid()?,
            t_final_s: s.options.t_final_s,
            word: s.options.word,
            labels,
            model: Arc::new(model),
            terrain,
            controller: Arc::new(selfmanip_hybrid::ZeroTorque),
            q0,
            qd0,
            mode0,
            behaviour: Arc::default(),
            parameters: Arc::default(),
            formulas: Arc::default(),
            parts: Arc::default(),
        })
    }

    /// Runs the execution.
    pub fn run(&self) -> Result<Run, SimError> {
        self.run_with(&selfmanip_hybrid::budget::NEVER)
    }

    /// [`Self::run`] that another thread can stop: once `stop` is raised the run ends within
    /// one integration step with [`crate::RunStatus::Interrupted`]
    /// ([`selfmanip_hybrid::simulate_with`]).
    pub fn run_with(&self, stop: &AtomicBool) -> Result<Run, SimError> {
        let exec = selfmanip_hybrid::simulate_with(
            &self.model,
            &self.terrain,
            &*self.controller,
            self.mode0,
            &self.q0,
            &self.qd0,
            self.t_final_s,
            self.options,
            stop,
        )?;
        let outcome = outcome(&self.model, &exec, &self.labels, self.word);
        Ok(Run {
            model: Arc::clone(&self.model),
            terrain: self.terrain,
            labels: self.labels.clone(),
            execution: exec,
            outcome,
        })
    }
}

/// Runs a scenario: [`Simulation::new`] then [`Simulation::run`].
pub fn simulate(s: &Scenario) -> Result<Run, SimError> {
    Simulation::new(s)?.run()
}

/// One execution with what is needed to evaluate it again.
#[derive(Debug, Clone)]
pub struct Run {
    pub model: Arc<Model>,
    pub terrain: TerrainSpec,
    pub labels: ContactLabels,
    pub execution: Execution,
    pub outcome: Outcome,
}

impl Run {
    /// The events, named.
    pub fn events(&self) -> Vec<EventRecord> {
        event_records(
            &self.model,
            &self.terrain,
            &self.execution,
            &self.labels,
            0.0,
        )
    }

    /// Samples every `dt_s` (see [`crate::trajectory`]).
    pub fn trajectory(&self, dt_s: f64) -> Result<Trajectory, SimError> {
        sample(
            &self.model,
            &self.terrain,
            &self.execution,
            &self.labels,
            dt_s,
            0.0,
        )
    }

    /// `E₁ − E₀ = W + W_fr − L` bookkeeping ([`selfmanip_hybrid::energy_report`]).
    pub fn energy_report(&self) -> Result<EnergyReport, SimError> {
        Ok(energy_report(&self.model, &self.terrain, &self.execution)?)
    }

    /// Writes an MCAP log sampled every `dt_s`, atomically (see [`crate::mcap`]).
    pub fn write_mcap(
        &self,
        path: &Path,
        dt_s: f64,
        metadata: BTreeMap<String, String>,
    ) -> Result<(), SimError> {
        self.write_mcap_until(path, dt_s, metadata, &|| false)
    }

    /// [`Self::write_mcap`], stopped by `cancelled` (Ctrl-C) with no file left behind
    /// ([`mcap::write_mcap_until`]).
    pub fn write_mcap_until(
        &self,
        path: &Path,
        dt_s: f64,
        metadata: BTreeMap<String, String>,
        cancelled: &dyn Fn() -> bool,
    ) -> Result<(), SimError> {
        let trajectory = self.trajectory(dt_s)?;
        let events = self.events();
        let mut metadata = metadata;
        metadata
            .entry("word".into())
            .or_insert_with(|| self.outcome.word_string());
        metadata
            .entry("status".into())
            .or_insert_with(|| self.outcome.status.as_str().into());
        mcap::write_mcap_until(
            path,
            &McapLog {
                model: &self.model,
                trajectory: &trajectory,
                events: &events,
                metadata,
                layout: mcap::Layout::of(&self.model),
            },
            cancelled,
        )
    }
}
