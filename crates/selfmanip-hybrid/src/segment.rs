//! One segment of an execution: the flow of one mode integrated step by step until a guard
//! fires, a contact passes onto the next feature of the terrain, the final time, or the flow
//! itself ends the run.
//!
//! ```text
//! each accepted step  => terrain features   (a contact left its feature: locate, and either
//!                                            end the segment there or end the run)
//!                     => guards             (sample on the dense output; the first crossing
//!                                            located: the event)
//! ```
//!
//! The controller's **time events** ([`crate::Controller::time_events`]: a motor switched on,
//! the knots of a prescribed motion) are step stops, as an ODE solver's `tstop`s: a step that
//! would pass one is cut to end on it exactly, its stages at the instant take the flow's
//! left limit (the time one ulp before), and the next step starts afresh there (the stored
//! derivative is recomputed, at the right limit: one ulp after). No step straddles a jump of the flow or of its
//! time derivatives, so both the execution and its sensitivities keep their order there.
//!
//! Free massless joints follow the controller's prescribed motion (thesis 5.1.1): it feeds
//! back into nothing, so it is left out of the step-size control, and the steps are capped
//! where its tracking law stays stable instead ([`crate::free_joints`]).
use crate::budget::Budget;
use crate::drift;
use crate::error::HybridError;
use crate::execution::{Segment, Termination};
use crate::features::{FeatureChange, Surfaces};
use crate::flow::{Flow, FlowSystem, FlowWorkspace};
use crate::free_joints::FreeJointStability;
use crate::guard::{Guard, GuardSet, WatchedFlow};
use crate::integrate::{DenseOutput, DenseStep, Dopri5, StepError, VelocityTolerance};
use crate::locate::first_event;
use crate::options::HybridOptions;
use selfmanip_core::{free_massless_joints, ContactMode, CoreError, Model};

/// The factor a trial step shrinks by when one of its stages met a singular KKT matrix.
const SINGULAR_RETRY_FACTOR: f64 = 0.25;

/// The steps a segment's dense output has room for from its start (a leap's segments take
/// 13 steps on average; a longer one grows its buffers).
const STEPS_RESERVED: usize = 16;

/// How a segment ended.
#[derive(Debug, Clone, PartialEq)]
pub enum SegmentEnd {
    /// Guards fired at the segment's end: `fired` is every guard that has fired by then.
    Event { fired: Vec<Guard> },
    /// A contact passed continuously onto the next feature of the terrain.
    FeatureChange,
    /// The final time was reached.
    FinalTime,
    /// A slide lost its consistent continuation (Painlevé) at the segment's end, after the
    /// last accepted step: the run resolves it (a jam, [`crate::jam`]) or ends typed.
    Painleve { contact: String },
    /// The flow ended the run (a singular KKT matrix, a discontinuity of the terrain, the
    /// step budget, a stalled step size or the stop flag).
    Ended(Termination),
}

/// The integrator and the buffers of the segments of one run, reused from segment to
/// segment and from step to step (recording a step allocates nothing once the segment's
/// dense output has grown).
pub struct SegmentIntegrator {
    ode: Dopri5,
    dense: DenseStep,
    /// The state at sample and trial times.
    y_probe: Vec<f64>,
    weights: Vec<f64>,
    /// Each component's factor on the absolute tolerance ([`VelocityTolerance::scales`]).
    atol_scales: Vec<f64>,
    /// The step bound of the free joints' law (out of the error norm).
    free_stability: FreeJointStability,
    /// The step size the next segment starts with: the one the last segment reached (a
    /// reset changes the flow, not its time scale; a step too long is rejected and shrunk).
    h_carry: f64,
    guards: GuardSet,
    surfaces: Surfaces,
    /// The workspace of drift projections ([`crate::drift`]).
    drift_ws: FlowWorkspace,
    free_joints: Vec<usize>,
    dynamic_coords: Vec<usize>,
    /// The controller's time events ahead in the current segment, ascending: step stops.
    stops: Vec<f64>,
    /// One ulp after the last time event a step landed on (stages there take the flow's
    /// right limit).
    t_right: f64,
    /// Whether a chain may slide damped in the segment's mode
    /// ([`crate::damped_slide::sliding_damped`]).
    damped_mode: bool,
}

impl SegmentIntegrator {
    pub fn new(model: &Model, opts: &HybridOptions) -> Self {
        let nq = model.nq();
        SegmentIntegrator {
            ode: Dopri5::new(2 * nq, opts.step),
            dense: DenseStep::default(),
            y_probe: vec![0.0; 2 * nq],
            free_stability: FreeJointStability::default(),
            weights: vec![1.0; 2 * nq],
            atol_scales: vec![1.0; 2 * nq],
            h_carry: opts.step.h_initial_s,
            guards: GuardSet::default(),
            surfaces: Surfaces::default(),
            drift_ws: FlowWorkspace::new(model),
            free_joints: Vec::new(),
            dynamic_coords: Vec::new(),
            stops: Vec::new(),
            t_right: f64::NEG_INFINITY,
            damped_mode: false,
        }
    }

    /// Prepares the segment of `mode` from `(t, y)`: the error weights (free and locked
    /// joints out of the norm), the velocities' absolute tolerances from the mass matrix
    /// there ([`VelocityTolerance`]), the free joints' step cap, the controller's time
    /// events ahead as step stops, each sliding toe's friction side, the guards armed, the
    /// terrain features under the active contacts, and the integrator. Returns the guards of the
    /// contacts that slip at the start.
    fn start(
        &mut self,
        flow: &mut Flow,
        mode: ContactMode,
        (t, y): (f64, &[f64]),
        from_rest: &[usize],
        t_final: f64,
        opts: &HybridOptions,
    ) -> Result<Vec<Guard>, HybridError> {
        let model = flow.model();
        let nq = model.nq();
        mode.validate(model)?;
        free_massless_joints(model, mode, &mut self.free_joints, &mut self.dynamic_coords);
        self.weights.fill(1.0);
        // locked joints turn at constant speed: prescribed, like free ones (unless these
        // are to be controlled: HybridOptions::control_free_joints)
        let free: &[usize] = if opts.control_free_joints {
            &[]
        } else {
            &self.free_joints
        };
        for &j in free.iter().chain(flow.lock()) {
            // joint j is coordinate j (q = [θ…, x, z, φ])
            self.weights[j] = 0.0;
            self.weights[nq + j] = 0.0;
        }
        let cap = self
            .free_stability
            .step_cap(flow.controller().as_ref(), t, y, nq, free)?;
        // the controller holds its memory over a segment: its time events are known here
        self.stops.clear();
        self.t_right = f64::NEG_INFINITY;
        self.stops.extend(
            flow.controller()
                .time_events(&[])
                .into_iter()
                .map(|e| e.t)
                .filter(|&s| s > t && s < t_final),
        );
        self.stops.sort_by(f64::total_cmp);
        self.stops.dedup();
        // the side of each sliding toe's friction force, for the whole segment
        let from_rest = flow.fix_slide_directions(t, mode, y, from_rest)?;
        self.guards.arm(flow, mode, t, y, &from_rest, opts)?;
        let slipping_now = self.guards.slipping_at_start(opts.arm_margin);
        self.surfaces.at_start(flow, mode, y);
        let rule = opts.step.velocity_tolerance;
        if rule != VelocityTolerance::Uniform {
            // the flow at the segment's start (its first step's first stage, then cached);
            // where it fails, the first step reports the failure
            match flow.eval(t, mode, &y[..nq], &y[nq..]) {
                Ok(data) => rule.scales((0..nq).map(|i| data.m_bar[(i, i)]), &mut self.atol_scales),
                Err(_) => self.atol_scales.fill(1.0),
            }
        }
        self.damped_mode = crate::damped_slide::sliding_damped(self.drift_ws.damped, mode) != 0;
        self.ode.reset(self.h_carry);
        self.ode.set_error_weights(&self.weights);
        self.ode.set_atol_scales(&self.atol_scales);
        self.ode.set_stability_cap(cap);
        Ok(slipping_now)
    }

    /// Integrates the flow of `mode` from `(t, y)` until a guard fires, a contact passes onto
    /// the next terrain feature, `t_final`, or the flow ends the run; advances `(t, y)` to
    /// the segment's end and returns the segment and how it ended. `from_rest`: sliding
    /// contacts whose slip→stick guard starts from rest. Every accepted step is counted
    /// against `budget`, which may end the run there.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &mut self,
        flow: &mut Flow,
        mode: ContactMode,
        t: &mut f64,
        y: &mut [f64],
        from_rest: &[usize],
        t_final: f64,
        opts: &HybridOptions,
        budget: &mut Budget,
    ) -> Result<(Segment, SegmentEnd), HybridError> {
        let slipping_now = self.start(flow, mode, (*t, y), from_rest, t_final, opts)?;
        // the time a contact passes continuously onto the next terrain feature in this
        // segment's last step, once located
        let mut feature_change: Option<f64> = None;
        let mut seg = Segment {
            mode,
            t0: *t,
            t1: *t,
            y0: y.to_vec(),
            controller: flow.controller().clone(),
            locked: flow.lock().to_vec(),
            slide_directions: flow.slide_directions().to_vec(),
            dense: DenseOutput::with_capacity(STEPS_RESERVED, y.len()),
        };
        let end = loop {
            if !slipping_now.is_empty() {
                break SegmentEnd::Event {
                    fired: slipping_now,
                };
            }
            if *t >= t_final {
                break SegmentEnd::FinalTime;
            }
            // (t, y) => one accepted step of the flow, its dense output in `dense`, not past
            // the next time event (whose stages take the flow's left limit there)
            let t_end = feature_change.unwrap_or(t_final);
            let stop = self.stops.iter().copied().find(|&s| s > *t && s < t_end);
            let t_end = stop.unwrap_or(t_end);
            let t_left = stop.map_or(f64::INFINITY, f64::next_down);
            let t_right = self.t_right;
            let (t_start, h_proposed) = (*t, self.ode.next_step_size());
            self.guards.watch_step();
            let step = self.ode.step(
                &mut WatchedFlow {
                    system: FlowSystem {
                        flow,
                        mode,
                        t_right,
                        t_left,
                    },
                    guards: &mut self.guards,
                },
                *t,
                y,
                t_end,
                &mut self.dense,
            );
            // whether the step landed on the time event
            let landed = stop.filter(|&s| step.is_ok() && self.dense.h == s - t_start);
            let dense = &self.dense;
            match step {
                Ok(()) if feature_change.is_none() => {
                    // an active contact stays on its feature (the flow holds a_k = 0) up to
                    // drift, which is projected away; one that left it met an edge or a
                    // corner of the terrain: locate where
                    let off = self.surfaces.left_by(flow, y).is_some();
                    if off && self.surfaces.only_drifted(flow, y) {
                        if self.drift_ws.damped != 0 {
                            // the damped slides of `mode` keep out of the projection
                            let (q, qd) = y.split_at(flow.model().nq());
                            // the flow's laws at this state (set_laws), in which one that
                            // stopped holding inside the step keeps the damping it held with
                            let laws = &flow.eval(*t, mode, q, qd)?.damped_laws;
                            self.drift_ws.data.damped_laws.clone_from(laws);
                        }
                        drift::project(flow, &mut self.drift_ws, mode, y)?;
                        self.ode.reset(self.ode.next_step_size());
                    } else if off {
                        match self.surfaces.locate_change(
                            flow,
                            dense,
                            &mut self.y_probe,
                            opts.event_tol_s,
                        ) {
                            // the next feature continues the surface: the flow changes
                            // there, so the step is taken again up to that instant and the
                            // segment ends with it
                            FeatureChange::Continuous { t: off } => {
                                dense.eval(dense.t0, y);
                                feature_change = Some(off);
                                self.ode.reset(off - dense.t0);
                                continue;
                            }
                            FeatureChange::Discontinuity {
                                t: off,
                                contact,
                                gap_m,
                            } => {
                                dense.eval(off, y);
                                seg.dense.push(dense);
                                budget.count();
                                seg.t1 = off;
                                *t = off;
                                break SegmentEnd::Ended(Termination::TerrainDiscontinuity {
                                    t: off,
                                    contact,
                                    gap_m,
                                });
                            }
                        }
                    }
                }
                Ok(()) => {}
                Err(e) => match step_failed(&mut self.ode, e, *t, mode)? {
                    None => continue,
                    Some(end) => break end,
                },
            }
            // => the guards sampled on the step; the first crossing located: the event
            let crossed = self.guards.sample_step(
                flow,
                mode,
                dense,
                y,
                &mut self.y_probe,
                opts.arm_margin,
            )?;
            if let Some(hi) = crossed {
                let (te, fired) = first_event(
                    &self.guards,
                    flow,
                    mode,
                    (dense, hi),
                    &mut self.y_probe,
                    opts.event_tol_s,
                )?;
                seg.dense.push(dense);
                budget.count();
                seg.t1 = te;
                *t = te;
                y.copy_from_slice(&self.y_probe);
                break SegmentEnd::Event { fired };
            }
            seg.dense.push(dense);
            *t = dense.t1();
            if let Some(s) = landed {
                // exactly on the instant; the flow's derivative there is taken afresh, and
                // the next step tries what this one would have without the stop (a step cut
                // short, down to an ulp, says nothing about the flow's time scale)
                *t = s;
                self.t_right = s.next_up();
                self.ode.reset(self.ode.next_step_size().max(h_proposed));
                // a chain that slides damped has no momentum: its rates are the slide's
                // under the law that starts here (crate::damped_slide)
                let damped = self.drift_ws.damped;
                if crate::damped_slide::sliding_damped(damped, mode) != 0 {
                    let model = flow.model();
                    let ctrl = flow.controller().clone();
                    let ws = &mut self.drift_ws;
                    ws.data.slide_directions.clear();
                    ws.data
                        .slide_directions
                        .extend_from_slice(flow.slide_directions());
                    let (q, qd) = y.split_at_mut(model.nq());
                    let state = (self.t_right, mode);
                    crate::damped_slide::consistent_rates(
                        model,
                        flow.terrain(),
                        &*ctrl,
                        state,
                        (q, qd),
                        &mut ws.data,
                    )?;
                }
            } else if self.damped_mode {
                // the chain rates of a damped slide are algebraic, carried by their
                // derivative, which the error norm does not watch (the chain has no mass)
                // and which jumps where a servo meets or leaves its torque limit (the law's
                // differences straddle the kink there): where they drifted from the slide's
                // beyond the integrator's tolerance, they are set to the slide's, and the
                // next step starts afresh
                let model = flow.model();
                let (q, qd) = y.split_at_mut(model.nq());
                let data = flow.eval(*t, mode, q, qd)?;
                let atol = opts.step.atol * crate::integrate::MAX_VELOCITY_ATOL_SCALE;
                let tol = (atol, opts.step.rtol);
                if crate::damped_slide::project_drifted_rates(model, data, qd, tol) {
                    self.ode.reset(self.ode.next_step_size());
                }
            }
            seg.t1 = *t;
            if feature_change.is_some_and(|tc| *t >= tc) {
                break SegmentEnd::FeatureChange;
            }
            if let Some(term) = budget.step(*t) {
                break SegmentEnd::Ended(term);
            }
        };
        self.h_carry = self.ode.next_step_size().max(opts.step.h_initial_s);
        Ok((seg, end))
    }
}

/// What a failed step does: a trial stage beyond a fold (a step too long for the guards to
/// see the pin fall) or past a Painlevé threshold is retried shorter (`None`), so that the
/// fold guard fires first; at the state itself the segment ends. Other errors stop the run.
fn step_failed(
    ode: &mut Dopri5,
    err: StepError<CoreError>,
    t: f64,
    mode: ContactMode,
) -> Result<Option<SegmentEnd>, HybridError> {
    match err {
        StepError::Rhs(CoreError::SingularKkt {
            kind,
            condition_estimate,
        }) => {
            if ode.retry_smaller(SINGULAR_RETRY_FACTOR) {
                return Ok(None);
            }
            // Lemma 5.1 fails at the state itself: the flow ends here
            Ok(Some(SegmentEnd::Ended(Termination::SingularFlow {
                t,
                mode,
                kind,
                condition_estimate,
            })))
        }
        StepError::Rhs(CoreError::PainleveInconsistent { contact, .. }) => {
            // a trial stage past the threshold: a shorter step first, as above
            if ode.retry_smaller(SINGULAR_RETRY_FACTOR) {
                return Ok(None);
            }
            Ok(Some(SegmentEnd::Painleve { contact }))
        }
        StepError::Rhs(e) => Err(e.into()),
        // the flow stalls: the run ends typed where it stalled
        StepError::StepTooSmall(h) => Ok(Some(SegmentEnd::Ended(Termination::StepTooSmall {
            t,
            h_s: h,
        }))),
    }
}
