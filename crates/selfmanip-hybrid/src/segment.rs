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
//! Free massless joints follow the controller's prescribed motion (thesis 5.1.1): it feeds
//! back into nothing, so it is left out of the step-size control.
use crate::budget::Budget;
use crate::drift;
use crate::error::HybridError;
use crate::execution::{Segment, Termination};
use crate::features::{FeatureChange, Surfaces};
use crate::flow::{Flow, FlowWorkspace};
use crate::guard::{Guard, GuardSet};
use crate::integrate::{DenseOutput, DenseStep, Dopri5, StepError};
use crate::locate::first_event;
use crate::options::HybridOptions;
use selfmanip_core::{free_massless_joints, ContactMode, CoreError, Model};

/// The factor a trial step shrinks by when one of its stages met a singular KKT matrix.
const SINGULAR_RETRY_FACTOR: f64 = 0.25;

/// How a segment ended.
#[derive(Debug, Clone, PartialEq)]
pub enum SegmentEnd {
    /// Guards fired at the segment's end: `fired` is every guard that has fired by then.
    Event { fired: Vec<Guard> },
    /// A contact passed continuously onto the next feature of the terrain.
    FeatureChange,
    /// The final time was reached.
    FinalTime,
    /// The flow ended the run (a singular KKT matrix, a discontinuity of the terrain, the
    /// step budget or the stop flag).
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
    /// The step size the next segment starts with: the one the last segment reached (a
    /// reset changes the flow, not its time scale; a step too long is rejected and shrunk).
    h_carry: f64,
    guards: GuardSet,
    surfaces: Surfaces,
    /// The workspace of drift projections ([`crate::drift`]).
    drift_ws: FlowWorkspace,
    free_joints: Vec<usize>,
    dynamic_coords: Vec<usize>,
}

impl SegmentIntegrator {
    pub fn new(model: &Model, opts: &HybridOptions) -> Self {
        let nq = model.nq();
        SegmentIntegrator {
            ode: Dopri5::new(2 * nq, opts.step),
            dense: DenseStep::default(),
            y_probe: vec![0.0; 2 * nq],
            weights: vec![1.0; 2 * nq],
            h_carry: opts.step.h_initial_s,
            guards: GuardSet::default(),
            surfaces: Surfaces::default(),
            drift_ws: FlowWorkspace::new(model),
            free_joints: Vec::new(),
            dynamic_coords: Vec::new(),
        }
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
        let model = flow.model();
        let nq = model.nq();
        mode.validate(model)?;
        free_massless_joints(model, mode, &mut self.free_joints, &mut self.dynamic_coords);
        self.weights.fill(1.0);
        // locked joints turn at constant speed: prescribed, like free ones
        for &j in self.free_joints.iter().chain(flow.lock()) {
            // joint j is coordinate j (q = [θ…, x, z, φ])
            self.weights[j] = 0.0;
            self.weights[nq + j] = 0.0;
        }
        // the side of each sliding toe's friction force, for the whole segment
        let from_rest = flow.fix_slide_directions(*t, mode, y, from_rest)?;
        self.guards.arm(flow, mode, *t, y, &from_rest, opts)?;
        let slipping_now = self.guards.slipping_at_start(opts.arm_margin);
        self.surfaces.at_start(flow, mode, y);
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
            dense: DenseOutput::default(),
        };
        self.ode.reset(self.h_carry);
        self.ode.set_error_weights(&self.weights);
        let end = loop {
            if !slipping_now.is_empty() {
                break SegmentEnd::Event {
                    fired: slipping_now,
                };
            }
            if *t >= t_final {
                break SegmentEnd::FinalTime;
            }
            // (t, y) => one accepted step of the flow, its dense output in `dense`
            let step = self.ode.step(
                &mut |tt, yy, dy| flow.rhs(tt, mode, yy, dy),
                *t,
                y,
                feature_change.unwrap_or(t_final),
                &mut self.dense,
            );
            let dense = &self.dense;
            match step {
                Ok(()) if feature_change.is_none() => {
                    // an active contact stays on its feature (the flow holds a_k = 0) up to
                    // drift, which is projected away; one that left it met an edge or a
                    // corner of the terrain: locate where
                    let off = self.surfaces.left_by(flow, y).is_some();
                    if off && self.surfaces.only_drifted(flow, y) {
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
                Err(StepError::Rhs(CoreError::SingularKkt {
                    kind,
                    condition_estimate,
                })) => {
                    // a trial stage beyond a fold (a step too long for the guards to see
                    // the pin fall): try a shorter step, so that the fold guard fires first
                    if self.ode.retry_smaller(SINGULAR_RETRY_FACTOR) {
                        continue;
                    }
                    // Lemma 5.1 fails at the state itself: the flow ends here
                    break SegmentEnd::Ended(Termination::SingularFlow {
                        t: *t,
                        mode,
                        kind,
                        condition_estimate,
                    });
                }
                Err(StepError::Rhs(e)) => return Err(e.into()),
                Err(StepError::StepTooSmall(h)) => {
                    return Err(HybridError::StepTooSmall { t_s: *t, h_s: h })
                }
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
