//! An execution of the hybrid system (thesis Definition 5.2), read as its stages in order:
//!
//! ```text
//! (q₀, q̇₀, mode₀)  => checked on its constraint manifold
//! loop:
//!   flow      the mode's flow (5.48), step by step           [flow, integrate, segment]
//!   guards    sampled on each step's dense output (5.49)–(5.51) [guard]
//!   locate    the first crossing, to event_tol_s              [locate, features]
//!   reset     impact or force complementarity ⇒ (mode, q̇⁺)   [reset, complementarity,
//!                                                              impact, contact_set]
//!   zeno      too many transitions in a window, or one cycle of transitions repeated
//!             with the robot staying where it is (a chatter, or a truncated one
//!             resuming) ⇒ truncated by the pseudo-impulse's limit (a reset) whose mode
//!             is held for a dwell, or the end when there is nothing to truncate  [zeno]
//!   budget    out of steps or events, or stopped from outside ⇒ end  [budget]
//! ```
use crate::budget::{Budget, NEVER};
use crate::controller::Controller;
use crate::error::HybridError;
use crate::event::{Event, EventKind, PainleveReason};
use crate::execution::{Execution, Termination};
use crate::flow::{Flow, FlowWorkspace};
use crate::guard::Firing;
use crate::jam::{coulomb_jam, jam};
use crate::options::HybridOptions;
use crate::reset::{reset, Reset};
use crate::segment::{SegmentEnd, SegmentIntegrator};
use crate::zeno::{ChatterDetector, ZenoWindow};
use selfmanip_core::contact::ContactKind;
use selfmanip_core::{ContactMode, CoreError, Model, Terrain};
use std::sync::atomic::AtomicBool;

/// Runs the hybrid system from `(q0, qd0)` in `mode0` until `t_final` or a terminal event.
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    model: &Model,
    terrain: &dyn Terrain,
    controller: &dyn Controller,
    mode0: ContactMode,
    q0: &[f64],
    qd0: &[f64],
    t_final: f64,
    opts: HybridOptions,
) -> Result<Execution, HybridError> {
    simulate_with(
        model, terrain, controller, mode0, q0, qd0, t_final, opts, &NEVER,
    )
}

/// [`simulate`] that another thread can stop: once `stop` is raised the run ends within one
/// integration step with [`Termination::Interrupted`], returning what it has computed.
///
/// ```no_run
/// # use selfmanip_hybrid::{simulate_with, HybridOptions, ZeroTorque};
/// # use selfmanip_core::{ContactMode, FlatGround, Model};
/// # fn run(model: &Model, q0: &[f64], qd0: &[f64]) {
/// use std::sync::atomic::{AtomicBool, Ordering};
/// let stop = AtomicBool::new(false);
/// std::thread::scope(|s| {
///     let run = s.spawn(|| {
///         simulate_with(model, &FlatGround, &ZeroTorque, ContactMode::FLIGHT, q0, qd0,
///                       1e3, HybridOptions::default(), &stop)
///     });
///     // … on Ctrl-C (or a deadline):
///     stop.store(true, Ordering::Relaxed);
///     let exec = run.join().unwrap();
/// });
/// # }
/// ```
#[allow(clippy::too_many_arguments)]
pub fn simulate_with(
    model: &Model,
    terrain: &dyn Terrain,
    controller: &dyn Controller,
    mode0: ContactMode,
    q0: &[f64],
    qd0: &[f64],
    t_final: f64,
    opts: HybridOptions,
    stop: &AtomicBool,
) -> Result<Execution, HybridError> {
    opts.validate(t_final)?;
    let mut budget = Budget::new(opts.max_steps, stop);
    // the run's own copy of the controller: it learns of the events, the caller's does not
    let mut flow = Flow::new(model, terrain, controller.clone_shared());
    // the resets' workspace
    let mut reset_ws = FlowWorkspace::new(model);
    check_initial_state(&mut reset_ws, &mut flow, mode0, q0, qd0)?;

    let (mut t, mut mode) = (0.0, mode0);
    let mut y: Vec<f64> = q0.iter().chain(qd0).copied().collect();
    let (mut segments, mut events) = (Vec::new(), Vec::new());
    let mut dwell_ends = Vec::new();
    let mut integrator = SegmentIntegrator::new(model, &opts);
    let mut zeno = ZenoWindow::new(opts.zeno_window_s, opts.zeno_max_events);
    let chatter = ChatterDetector;
    // sliding contacts whose sliding velocity is zero at the start of the next segment up
    // to drift (they stuck until the last reset, or their stick was just refused)
    let mut from_rest: Vec<usize> = Vec::new();
    // a Zeno window's truncation, taken as the next reset (crate::zeno::truncate)
    let mut truncation: Option<Reset> = None;
    let termination = 'run: loop {
        // flow ⇒ guards ⇒ locate ⇒ reset; a slide with no consistent continuation
        // (Painlevé) met on the way comes out as `Err((error, may_jam))`
        let t_start = t;
        let outcome: Result<Reset, (HybridError, bool)> = 'stages: {
            if let Some(r) = truncation.take() {
                break 'stages Ok(r);
            }
            // a truncation's dwell ends its segment (crate::zeno)
            let t_end = zeno.holding_until().map_or(t_final, |d| d.min(t_final));
            let run = integrator.run(
                &mut flow,
                mode,
                &mut t,
                &mut y,
                &from_rest,
                t_end,
                &opts,
                &mut budget,
            );
            let (segment, end) = match run {
                Ok(r) => r,
                // at the segment's start nothing was integrated: a jam may take it there;
                // later (inside a guard's evaluation) the run ends typed
                Err(e) => break 'stages Err((e, t == t_start)),
            };
            segments.push(segment);
            let fired = match end {
                // a site held sliding that comes to pull slides on without friction: the
                // segment ends there, and the next one starts with σ = 0 (Flow::pulled)
                SegmentEnd::Event { mut fired } => {
                    if !crate::guard::take_pulls(&mut flow, &mut fired) {
                        continue 'run;
                    }
                    fired
                }
                SegmentEnd::FeatureChange => match zeno.record(t, &[]) {
                    Some(z) => break 'run z,
                    None => continue 'run,
                },
                SegmentEnd::FinalTime if t >= t_final => break 'run Termination::FinalTime,
                // the dwell of a truncation ends: its contacts are judged by force again
                SegmentEnd::FinalTime => {
                    dwell_ends.push(t);
                    fresh_laws(&mut reset_ws, &flow, (t, mode), &y);
                    let held = (&mut reset_ws, &mut flow, &mut zeno);
                    match crate::zeno::dwell_end(held, &opts, mode, (t, &y)) {
                        Ok(Some(r)) => break 'stages Ok(r),
                        Ok(None) => continue 'run,
                        Err(e) => break 'stages Err((e, true)),
                    }
                }
                // mid-flow: the segment is recorded up to `t`, where the slide ended
                SegmentEnd::Painleve { contact } => {
                    let e = CoreError::PainleveInconsistent {
                        contact,
                        response: f64::NAN,
                    };
                    break 'stages Err((e.into(), true));
                }
                SegmentEnd::Ended(term) => break 'run term,
            };
            // a re-touch cycle's dwell ends at another contact's touchdown (crate::zeno)
            if zeno.end_hold_at(&fired, flow.held()) {
                flow.set_held(&[]);
            }
            fresh_laws(&mut reset_ws, &flow, (t, mode), &y);
            let at = Firing {
                guards: &fired,
                mode,
                t,
                y: &y,
            };
            match reset(&mut reset_ws, &mut flow, &opts, at, &[]) {
                Ok(r) => Ok(r),
                // an impact that chose an inconsistent slide: the same impact with that
                // contact sticking (its jam)
                Err(e) if fired.iter().any(|g| g.touchdown().is_some()) => {
                    Ok(jammed_impact(e, &mut reset_ws, &mut flow, &opts, at)?)
                }
                // at a force event (a slip onto an inconsistent slide)
                Err(e) => Err((e, true)),
            }
        };
        // ⇒ a jam, or the typed end (crate::jam)
        let reset = match outcome {
            Ok(r) => r,
            Err((e, may_jam)) => painleve(
                e,
                may_jam,
                &mut reset_ws,
                &mut flow,
                &opts,
                mode,
                (t, &y),
                events.last(),
            )?,
        };
        let (mut event, rest) = match reset {
            Reset::Continue {
                event,
                from_rest,
                lock,
            } => {
                flow.set_lock(&lock);
                (event, from_rest)
            }
            Reset::End { event, termination } => {
                events.extend(event);
                break termination;
            }
        };
        // an event that changes no mode and carries no impulse (a massless chain's foot
        // touching and let go at once) is no transition: neither told nor reported; an apex
        // recorded on the way changes nothing either, and the controller is not told of it
        let silent = event.changes_nothing();
        if event.kind != EventKind::Apex && !silent {
            flow.notify(&event);
        }
        y[model.nq()..].copy_from_slice(&event.qd_after);
        mode = event.mode_after;
        // a chain that slides damped starts on its slide's rates (crate::damped_slide)
        if reset_ws.damped != 0 {
            let (q, qd) = y.split_at_mut(model.nq());
            let ctrl = flow.controller().clone();
            crate::damped_slide::consistent_rates(
                model,
                terrain,
                &*ctrl,
                (t, mode),
                (q, qd),
                &mut reset_ws.data,
            )?;
            // the event records the velocity the run goes on from
            event.qd_after.copy_from_slice(qd);
        }
        from_rest = rest;
        // a silent event counts in the Zeno window too
        let zeno_window = zeno.record(t, &event.triggered);
        if !silent {
            events.push(event);
        }
        // ⇒ budget and Zeno
        if events.len() >= opts.max_events {
            break Termination::EventBudget;
        }
        if budget.stopped() {
            break Termination::Interrupted { t };
        }
        if let Some(z) = zeno_window {
            fresh_laws(&mut reset_ws, &flow, (t, mode), &y);
            let held = (&mut reset_ws, &mut flow, &mut zeno);
            truncation = crate::zeno::truncate_and_hold(held, &opts, mode, (t, &y), &z)?;
            if truncation.is_none() {
                break z;
            }
            continue;
        }
        // a chatter is truncated as a Zeno window is, and so are a truncated one resuming
        // and, when asked (HybridOptions::truncate_unresolved_flights), a re-touch after a
        // flight shorter than the run resolves (crate::zeno); only the first, with nothing
        // to truncate, ends the run
        let unresolved = |events: &[Event]| {
            let on = opts.truncate_unresolved_flights;
            on.then(|| crate::zeno::retouch_unresolved(events, opts.rest_time_s()))
                .flatten()
        };
        let found = chatter.check(&events).map(|c| (c, true)).or_else(|| {
            zeno.resumed(&events)
                .or_else(|| unresolved(&events))
                .map(|c| (c, false))
        });
        if let Some((c, ends)) = found {
            let held = (&mut reset_ws, &mut flow, &mut zeno);
            truncation = crate::zeno::truncate_and_hold(held, &opts, mode, (t, &y), &c)?;
            if truncation.is_none() && ends {
                break c;
            }
            if let (
                Some(_),
                Termination::Chatter {
                    period,
                    t,
                    contacts,
                    ..
                },
            ) = (&truncation, &c)
            {
                let cycle = &events[events.len() - period..];
                zeno.truncated_chatter(cycle, (*t, contacts), events.len() + 1);
            }
        }
        if let Some(p) = penetration(model, terrain, t, &y[..model.nq()]) {
            break p;
        }
    };
    let termination = match termination {
        Termination::FinalTime | Termination::Apex => {
            penetration(model, terrain, t, &y[..model.nq()]).unwrap_or(termination)
        }
        other => other,
    };
    let (q, qd) = y.split_at(model.nq());
    Ok(Execution {
        segments,
        events,
        termination,
        t,
        q: q.to_vec(),
        qd: qd.to_vec(),
        mode,
        steps: budget.steps(),
        dwell_ends,
    })
}

/// The chain laws of the damped slides of `mode` at `(t, y)` on the resets' workspace
/// (crate::damped_slide), before a reset from `mode` prepares it; nothing for a robot
/// without a chain that can slide damped.
fn fresh_laws(ws: &mut FlowWorkspace, flow: &Flow, (t, mode): (f64, ContactMode), y: &[f64]) {
    if ws.damped == 0 {
        return;
    }
    let model = flow.model();
    let (q, qd) = y.split_at(model.nq());
    let ctrl = flow.controller().clone();
    let state = (t, q, qd);
    crate::damped_slide::set_laws(
        model,
        &mut ws.data,
        (ws.damped, false),
        &*ctrl,
        state,
        mode,
        &mut ws.laws,
    );
}

/// A collision outline inside the terrain at `(t, q)`, deeper than the drift the engine
/// corrects ([`crate::surface_tolerances::MAX_DRIFT_M`]): the end of the run, typed. Nothing
/// is computed for a model without collision outlines.
fn penetration(model: &Model, terrain: &dyn Terrain, t: f64, q: &[f64]) -> Option<Termination> {
    if model.outlines.is_empty() {
        return None;
    }
    let mut kin = selfmanip_core::kinematics::Kinematics::default();
    kin.compute(model, q, &vec![0.0; model.nq()]);
    let tol = crate::surface_tolerances::MAX_DRIFT_M;
    let p = selfmanip_core::contact::outline_penetration(model, &kin, terrain, tol)?;
    Some(Termination::Penetration {
        t,
        outline: model.outlines[p.outline].name.clone(),
        depth_m: p.depth_m,
    })
}

/// The initial state must satisfy its mode's constraints: `A q̇ = 0` and every active
/// contact on its surface.
fn check_initial_state(
    ws: &mut FlowWorkspace,
    flow: &mut Flow,
    mode: ContactMode,
    q: &[f64],
    qd: &[f64],
) -> Result<(), HybridError> {
    let data = &mut ws.data;
    data.prepare(flow.model(), flow.terrain(), mode, q, qd)?;
    let vres = (&data.constraints.a * nalgebra::DVector::from_column_slice(qd)).amax();
    if vres > 1e-8 {
        return Err(HybridError::OffManifold {
            field: "qd",
            residual: vres,
        });
    }
    let y: Vec<f64> = q.iter().chain(qd).copied().collect();
    for k in mode.active() {
        let gap = flow.geometry(k, &y).gap_m;
        if gap.abs() > 1e-8 {
            return Err(HybridError::OffManifold {
                field: "q",
                residual: gap.abs(),
            });
        }
    }
    Ok(())
}

/// A slide inconsistent with Coulomb friction (Painlevé) met in the flow, at a segment's
/// start (its sliding directions from rest) or in the mode a reset chose: resolved as a jam
/// ([`crate::jam`]) when `may_jam` and it is not the jam just taken at this instant (a jam
/// that leads straight back into the same inconsistency resolves nothing); else the run
/// ends typed ([`Termination::Painleve`]). Any other error is the run's error.
#[allow(clippy::too_many_arguments)]
fn painleve(
    e: HybridError,
    may_jam: bool,
    ws: &mut FlowWorkspace,
    flow: &mut Flow,
    opts: &HybridOptions,
    mode: ContactMode,
    (t, y): (f64, &[f64]),
    last: Option<&Event>,
) -> Result<Reset, HybridError> {
    let HybridError::Core(CoreError::PainleveInconsistent { contact, .. }) = e else {
        return Err(e);
    };
    let again = last.is_some_and(|ev| {
        ev.kind == EventKind::Jam
            && ev.t == t
            && ev
                .triggered
                .iter()
                .any(|&k| flow.model().contacts[k].name == contact)
    });
    let reason = if !may_jam {
        PainleveReason::InsideStep
    } else if again {
        PainleveReason::Repeated
    } else {
        match jam(ws, flow, opts, mode, &contact, (t, y))? {
            Ok(r) => return Ok(r),
            // the stick refused: the impact with Coulomb friction at every contact
            Err(reason) => match flow
                .model()
                .contacts
                .iter()
                .position(|c| c.name == contact)
                .filter(|&k| mode.contains(k))
            {
                Some(k) => match coulomb_jam(ws, flow, opts, mode, (&[], k), (t, y), reason)? {
                    Ok(r) => return Ok(r),
                    Err(reason) => reason,
                },
                None => reason,
            },
        }
    };
    Ok(Reset::End {
        event: None,
        termination: Termination::Painleve {
            t,
            mode,
            contact,
            reason,
        },
    })
}

/// A touchdown's reset that failed with a Painlevé inconsistency (`e`) at a contact the
/// impact left sliding, taken again with that contact barred from sliding
/// ([`crate::reset::reset`] with it `jammed`): accepted as a [`EventKind::Jam`] when the
/// contact sticks after it (the impulse in its cone, pushing); else the run ends typed.
fn jammed_impact(
    e: HybridError,
    ws: &mut FlowWorkspace,
    flow: &mut Flow,
    opts: &HybridOptions,
    at: Firing<'_>,
) -> Result<Reset, HybridError> {
    let Firing {
        guards: fired,
        mode,
        t,
        y,
    } = at;
    let HybridError::Core(CoreError::PainleveInconsistent { contact, .. }) = e else {
        return Err(e);
    };
    let end = |reason| Reset::End {
        event: None,
        termination: Termination::Painleve {
            t,
            mode,
            contact: contact.clone(),
            reason,
        },
    };
    let Some(k) = flow.model().contacts.iter().position(|c| c.name == contact) else {
        return Ok(end(PainleveReason::Inactive));
    };
    // any failure of the retry leaves the end as it was without it: typed
    let rj = reset(ws, flow, opts, at, &[k]);
    let reason = match rj {
        Ok(Reset::Continue {
            mut event,
            from_rest,
            lock,
        }) => {
            let stuck = event.mode_after.kind(k) == Some(ContactKind::Stick);
            let in_cone =
                crate::jam::own_impulse_in_cone(flow.model(), event.mode_after, k, &event.impulse);
            if stuck && in_cone {
                event.kind = EventKind::Jam;
                if !event.triggered.contains(&k) {
                    event.triggered.push(k);
                }
                return Ok(Reset::Continue {
                    event,
                    from_rest,
                    lock,
                });
            }
            PainleveReason::JamOutsideCone
        }
        Ok(Reset::End { .. }) | Err(_) => PainleveReason::NoJamOutcome,
    };
    // the stick refused: the impact with Coulomb friction at every contact
    let touched: Vec<usize> = fired.iter().filter_map(|g| g.touchdown()).collect();
    Ok(
        match coulomb_jam(ws, flow, opts, mode, (&touched, k), (t, y), reason)? {
            Ok(r) => r,
            Err(reason) => end(reason),
        },
    )
}
