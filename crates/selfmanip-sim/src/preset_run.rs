//! What a preset reports of one run ([`PresetRun`]): the generic run's [`Outcome`] read in the
//! preset's frame ([`PresetFrame`]: its clock, its forward origin), its events in the robot's
//! labels, why it did not fly, its energy and its samples; and the run with the derivatives
//! of its apex ([`ApexSensitivity`], from [`EndStateSensitivity`]). A leap of `rhex-model` is
//! one (`rhex_model::leap::LeapResult`).
use crate::events::{event_records_labelled, EventRecord};
use crate::outcome::{BodyState, Outcome, PresetFrame, APEX_COLUMNS};
use crate::sensitivity::EventSaltation;
use crate::sensitivity_preset::{end_state_sensitivity, EndStateRequest, EndStateSensitivity};
use crate::terrain::TerrainSpec;
use crate::{SimError, Trajectory};
use nalgebra::DMatrix;
use selfmanip_core::{ContactKind, ContactMode, Model};
use selfmanip_hybrid::sensitivity::Parameter;
use selfmanip_hybrid::{EventKind, Execution, Termination};
use std::sync::Arc;

/// A run read in a preset's frame: the generic run's metrics (read through `Deref`), whether
/// it flew, its apex and events on the preset's clock, and the robot and terrain it ran on.
#[derive(Debug, Clone)]
pub struct PresetRun {
    pub model: Arc<Model>,
    pub terrain: TerrainSpec,
    /// Whether the preset stops at the apex of a flight ([`PresetFrame::stop_at_apex`]).
    pub stop_at_apex: bool,
    /// The generic run's metrics (times on the simulation clock, NED frame).
    pub outcome: Outcome,
    /// It reached the apex of a flight after its drive started (status `apex`), or, not
    /// stopping there, flew and ran on to `final_time`.
    pub flew: bool,
    /// The apex of its first flight, in the preset's frame (z up).
    pub apex: Option<BodyState>,
    /// The execution (times on the simulation clock).
    pub execution: Execution,
    /// Subtract from execution times to get times on the preset's clock.
    pub time_offset_s: f64,
    /// Start configuration `q`.
    pub q0: Vec<f64>,
    /// Events on the preset's clock in the robot's names and labels (empty where the preset
    /// keeps none).
    pub events: Vec<EventRecord>,
    /// Latest time of the execution (s on the preset's clock).
    pub t_final_s: f64,
}

impl std::ops::Deref for PresetRun {
    type Target = Outcome;
    #[inline]
    fn deref(&self) -> &Outcome {
        &self.outcome
    }
}

impl PresetRun {
    /// The run `(exec, outcome)` of `model` on `terrain` read in `frame`, its events labelled
    /// by `label` when `event_records`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn read(
        model: &Arc<Model>,
        terrain: &TerrainSpec,
        label: &dyn Fn(ContactMode) -> String,
        (exec, outcome): (Execution, Outcome),
        frame: PresetFrame,
        q0: Vec<f64>,
        t_final_s: f64,
        event_records: bool,
    ) -> Self {
        let events = match event_records {
            true => event_records_labelled(model, terrain, &exec, label, frame.t0_s),
            false => Vec::new(),
        };
        PresetRun {
            model: Arc::clone(model),
            terrain: *terrain,
            stop_at_apex: frame.stop_at_apex,
            flew: frame.flew(&exec, outcome.status),
            apex: frame.apex(model, &exec),
            outcome,
            execution: exec,
            time_offset_s: frame.t0_s,
            q0,
            events,
            t_final_s,
        }
    }

    /// Why the run did not fly, in words (empty when it flew): the engine's
    /// [`selfmanip_hybrid::Termination::describe`] on the preset's clock with the contacts'
    /// names and the flowing mode's label (the last event's, else `start_label`).
    #[inline]
    pub fn reason(&self, start_label: &str) -> String {
        let model = &self.model;
        let mode = self
            .events
            .last()
            .map_or_else(|| start_label.to_string(), |e| e.mode_after.clone());
        let name = |k: usize| {
            model
                .contacts
                .get(k)
                .map_or_else(|| format!("#{k}"), |c| c.name.clone())
        };
        let frame = PresetFrame {
            t0_s: self.time_offset_s,
            ..PresetFrame::world(self.stop_at_apex)
        };
        frame.reason(&self.execution, self.flew, self.t_final_s, &name, &mode)
    }

    /// Energy bookkeeping of the run (motor work, impact losses, start and end energy).
    #[inline]
    pub fn energy_report(&self) -> Result<selfmanip_hybrid::EnergyReport, SimError> {
        let (model, terrain) = (&self.model, &self.terrain);
        Ok(selfmanip_hybrid::energy_report(
            model,
            terrain,
            &self.execution,
        )?)
    }

    /// Samples the run every `dt_s` seconds (and at its end) with the generic sampler
    /// ([`crate::trajectory::sample_labelled`]), times on the preset's clock.
    #[inline]
    pub fn trajectory(
        &self,
        label: &dyn Fn(ContactMode) -> String,
        dt_s: f64,
    ) -> Result<Trajectory, SimError> {
        crate::trajectory::sample_labelled(
            &self.model,
            &self.terrain,
            &self.execution,
            label,
            dt_s,
            self.time_offset_s,
        )
    }
}

/// `mode` with every sticking contact on the body but the first (by index) sliding: two
/// sticking points on one rigid body leave the tangential force between them statically
/// indeterminate, so a preset that starts resting on its body lets all but one slide.
pub fn determinate_body_start(model: &Model, mode: ContactMode) -> ContactMode {
    let on_body = |k: &usize| model.contacts[*k].link.is_none();
    let stick = |k: &usize| mode.kind(*k) == Some(ContactKind::Stick);
    let mut sticking = mode.active().filter(on_body).filter(stick);
    sticking.next();
    sticking.fold(mode, |m, k| m.with(k, ContactKind::Slide))
}

/// Of a preset's named parameters `(name, value, reference)`, the one farthest above its
/// reference relative to the reference's size (at least 1, so that a zero reference
/// compares; the first on a tie): the parameter to name when the start state the preset
/// builds from them overflows.
pub fn farthest_above<'a>(values: &[(&'a str, f64, f64)]) -> &'a str {
    let first = values.first().map_or("", |v| v.0);
    values
        .iter()
        .map(|&(name, v, r)| (name, v.abs() / r.abs().max(1.0)))
        .fold((first, f64::NEG_INFINITY), |best, c| {
            if c.1 > best.1 {
                c
            } else {
                best
            }
        })
        .0
}

/// A preset's run `result` with the derivatives of its apex ([`APEX_COLUMNS`], z up, on the
/// preset's clock) with respect to named parameters and start-state directions.
#[derive(Debug, Clone)]
pub struct ApexSensitivity<R> {
    pub result: R,
    /// The parameter names, as given.
    pub parameters: Vec<String>,
    /// `d_apex[c][k] = d APEX_COLUMNS[c] / d parameters[k]`; NaN unless [`Self::ok`].
    pub d_apex: Vec<Vec<f64>>,
    /// `d APEX_COLUMNS[c] / d (start-state direction j)`; NaN unless [`Self::ok`].
    pub d_apex_d_start: Vec<Vec<f64>>,
    /// Whether every derivative is defined.
    pub ok: bool,
    /// Why not, when not ok.
    pub reason: Option<String>,
    /// One entry per event of the execution.
    pub events: Vec<EventSaltation>,
    /// The behaviour's time events met (motor starts, knots of a swing): `(t_s, max |f⁺ −
    /// f⁻|)`, the jump of the flow there (0 where it is continuous).
    pub time_events: Vec<(f64, f64)>,
    /// `d t_e / d (directions, parameters)` of each event (its time on the preset's clock),
    /// in the order of [`Self::events`]; `None` where its saltation is not defined. Defined
    /// along the execution whether or not the apex's derivatives are.
    pub event_times: Vec<Option<Vec<f64>>>,
}

impl<R> ApexSensitivity<R> {
    /// The run `result` with the end-state derivatives `d` taken at its apex by `names`.
    pub fn new(result: R, names: &[&str], d: EndStateSensitivity) -> Self {
        ApexSensitivity {
            result,
            parameters: names.iter().map(|s| s.to_string()).collect(),
            d_apex: d.d_state,
            d_apex_d_start: d.d_state_d_start,
            ok: d.ok,
            reason: d.reason,
            events: d.events,
            time_events: d.time_events,
            event_times: d.event_times,
        }
    }

    /// The derivatives of the apex that ends a preset's run `result` (of `model` on
    /// `terrain`, z up, on the preset's clock) along the start-state `directions` and the
    /// named parameters `names` (each the weighted sum of engine parameters `named[k]`,
    /// moving the preset's clock origin by `d_origin[k]`): never an error; not ok, with the
    /// reason, where the run did not end at an apex or a derivative is undefined
    /// ([`end_state_sensitivity`]).
    #[allow(clippy::too_many_arguments)]
    pub fn at_apex(
        result: R,
        model: &Model,
        terrain: &TerrainSpec,
        directions: &DMatrix<f64>,
        named: &[Vec<(Parameter, f64)>],
        names: &[&str],
        d_origin: &[f64],
    ) -> Self
    where
        R: std::ops::Deref<Target = PresetRun>,
    {
        let exec = &result.execution;
        let not_ended =
            (exec.termination != Termination::Apex || result.apex.is_none()).then(|| {
                "the run did not end at an apex (sensitivities are taken at the apex that \
                 ends a run)"
                    .to_string()
            });
        let d = end_state_sensitivity(&EndStateRequest {
            model,
            terrain,
            exec,
            directions,
            named,
            names,
            offset_s: result.time_offset_s,
            d_origin,
            end: (EventKind::Apex, "apex"),
            not_ended,
            z_up: true,
        });
        ApexSensitivity::new(result, names, d)
    }

    /// `d column / d parameter` by names (`None` for a name not asked for).
    pub fn get(&self, column: &str, parameter: &str) -> Option<f64> {
        let c = APEX_COLUMNS.iter().position(|n| *n == column)?;
        let k = self.parameters.iter().position(|n| n == parameter)?;
        Some(self.d_apex[c][k])
    }
}
