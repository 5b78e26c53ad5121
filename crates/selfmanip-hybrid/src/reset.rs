//! The reset at an event (thesis Definition 5.2): from the guards that fired, the mode and
//! velocity the execution continues with.
//!
//! ```text
//! fired guards      => touched, released, slipped, stuck contacts
//! touched           => a plastic impact: complementarity on impulses (5.28)–(5.29), (5.40)
//!                      (at δt = 0 over the whole touching set, and with the contacts it
//!                      leaves at rest: crate::complementarity)
//!                      => q̇⁺ (5.52) => the kept contacts must also hold in force (5.19)–(5.20)
//! folded            => the same impact problem, each folded contact barred from the kind
//!                      that is singular at its fold: a sliding one offered the stick (an
//!                      impulsive stick), else released ([`crate::fold`])
//! otherwise         => complementarity on forces (5.19)–(5.20), no velocity jump
//! ```
//!
//! Contacts that reached their friction cone slide, contacts whose sliding stopped try to
//! stick; a touchdown whose contact is already found below its ground met a step of the
//! terrain.
use crate::complementarity::Selected;
use crate::controller::Controller;
use crate::energy::kinetic_energy_at;
use crate::error::HybridError;
use crate::event::{Event, EventKind};
use crate::execution::Termination;
use crate::flow::{Flow, FlowWorkspace};
use crate::fold;
use crate::guard::{Firing, Guard};
use crate::options::HybridOptions;
use crate::reset_workspace::ResetWorkspace;
use crate::surface_tolerances::{MAX_DRIFT_M, TERRAIN_STEP_M};
use selfmanip_core::contact::ContactKind;
use selfmanip_core::{plastic_impact, ContactMode, Model};

/// What a reset leads to.
#[derive(Debug, Clone, PartialEq)]
pub enum Reset {
    /// The run goes on in `event.mode_after` from `event.qd_after`, with the joints `lock`
    /// locked for a fold passage ([`crate::fold`]); `from_rest` are the sliding contacts whose
    /// sliding velocity starts from zero (up to drift).
    Continue {
        event: Event,
        from_rest: Vec<usize>,
        lock: Vec<usize>,
    },
    /// The run ends here, with the event that ended it (the apex) if any.
    End {
        event: Option<Event>,
        termination: Termination,
    },
}

/// The reset of the guards `at.guards` that fired at `(t, y = [q; q̇])` in `mode` of `flow`,
/// evaluated on the workspace `ws`, with the pseudo-impulse duration and the fold threshold
/// of `opts`.
/// The contacts `jammed` (usually none) may not slide: an impact that left one of them on a
/// slide inconsistent with Coulomb friction (Painlevé) is taken again with it offered the
/// stick — the impact's tangential part, an impact without collision ([`crate::jam`]).
pub fn reset(
    ws: &mut FlowWorkspace,
    flow: &mut Flow,
    opts: &HybridOptions,
    at: Firing<'_>,
    jammed: &[usize],
) -> Result<Reset, HybridError> {
    let Firing {
        guards: fired,
        mode,
        t,
        y,
    } = at;
    let model = flow.model();
    let (q, qd) = y.split_at(model.nq());
    if let Some(apex) = apex_reset(flow, opts, at) {
        return Ok(apex);
    }
    let fired: Vec<Guard> = fired
        .iter()
        .copied()
        .filter(|&g| g != Guard::Apex)
        .collect();
    let mut c = FiredContacts::of(&fired);
    // a jam hold lasts while its contact sticks, until its guard fires (crate::jam_hold)
    let jammed_before = still_held(flow, mode, &fired);
    // a chain that is ε past its fold is unlocked
    let mut lock = flow.lock().to_vec();
    lock.retain(|j| {
        !c.passed
            .iter()
            .any(|&k| fold::massless_chain(model, k).contains(j))
    });
    if c.passed.len() == fired.len() {
        return Ok(Reset::Continue {
            event: Event::without_jump(t, EventKind::FoldPassed, mode, c.passed, (q, qd)),
            from_rest: vec![],
            lock,
        });
    }
    let end = |termination| {
        Ok(Reset::End {
            event: None,
            termination,
        })
    };
    if let Some(step) = terrain_step(flow, opts, &c.touched, (t, y)) {
        return end(step);
    }
    let pins = fold_pins(flow, mode, &c.folded, (q, qd));
    let (mut prefer, barred) = bars(model, mode, &c, jammed);
    // … unless it passes the fold sliding, locked: then it may not stick
    let passing_bar: Vec<(usize, ContactKind)> =
        c.folded.iter().map(|&k| (k, ContactKind::Stick)).collect();
    let ctrl = flow.controller().clone();
    let cx = &mut reset_workspace(flow, &*ctrl, opts, ws, &barred, &lock);
    cx.ws.wedged.clear();
    // a landing at δt = 0 takes every contact touching with it (ResetWorkspace::touching)
    let more = cx.touching(mode, &c.touched, q, qd)?;
    c.touched.extend(more);
    let ke_before = kinetic_energy_at(model, cx.terrain, &mut cx.ws.data, q, qd)?;
    // sliding legs whose speed is slaved at their folds pass them locked (fold::passage)
    let mut qd_in = qd.to_vec();
    let mut passing = false;
    if !c.folded.is_empty() && c.folded.len() == fired.len() {
        if let Some((v, l)) = fold_passage(cx, (t, mode), &lock, (&c.folded, &pins), (q, qd))? {
            (qd_in, lock) = (v, l);
            passing = true;
            cx.barred = &passing_bar;
            prefer = mode;
        }
        cx.ws.data.locked.clone_from(&lock);
    }
    // a fold is resolved as an impact: the stick it offers must stop the sliding at once; a
    // passage has its velocity already (the lock's), and its contacts are judged by forces
    let impact = !c.touched.is_empty() || (!c.folded.is_empty() && !passing);
    let AfterReset {
        selected,
        mut qd_after,
        mut mode_after,
        mut force,
    } = match select_mode(
        cx,
        (t, mode),
        &c,
        prefer,
        (q, &mut qd_in),
        impact,
        opts.rest_time_s(),
    )? {
        Ok(s) => s,
        Err(term) => return end(term),
    };
    // a touched contact that the impact stuck and no force mode keeps, whose release would
    // put it straight back into the ground, is held sticking (crate::jam_hold)
    let mut jammed = Vec::new();
    if impact && !c.touched.is_empty() {
        let after = (selected.mode, mode_after);
        jammed = crate::jam_hold::entries(flow, t, &c.touched, after, q, &qd_after);
    }
    // a massless chain's foot whose damped slide is wedged on both sides, kept sticking,
    // is held as a jam (crate::damped_slide)
    if !cx.ws.wedged.is_empty() {
        let wedged = std::mem::take(&mut cx.ws.wedged);
        let held = wedged_holds(flow, t, &wedged, mode_after, q, &qd_after);
        for k in held {
            if !jammed.contains(&k) {
                jammed.push(k);
            }
        }
    }
    if !jammed.is_empty() {
        cx.held.extend_from_slice(&jammed);
        cx.jammed.extend_from_slice(&jammed);
        let mut kept: Vec<usize> = mode_after.active().chain(jammed.iter().copied()).collect();
        kept.sort_unstable();
        let prefer = jammed
            .iter()
            .fold(mode_after, |m, &k| m.with(k, ContactKind::Stick));
        match cx.select(t, &kept, &[], prefer, q, &qd_after, false)? {
            Ok(s) => (mode_after, force) = (s.mode, s.value),
            Err(term) => return end(term),
        }
    }
    // a chain released at its fold is left at rest relative to its parent (fold module
    // docs); one released on its passage turns on at its torque-free speed
    if !passing {
        for &k in c.folded.iter().filter(|&&k| !mode_after.contains(k)) {
            for j in fold::massless_chain(model, k) {
                qd_after[j] = 0.0;
            }
        }
    }
    let ke_after = kinetic_energy_at(model, cx.terrain, &mut cx.ws.data, q, &qd_after)?;
    fold::retain_held_locks(model, mode_after, &mut lock);
    if !jammed_before.is_empty() || !jammed.is_empty() {
        let mut held: Vec<usize> = jammed_before.into_iter().chain(jammed).collect();
        held.retain(|&k| mode_after.kind(k) == Some(ContactKind::Stick));
        held.sort_unstable();
        held.dedup();
        flow.set_jammed(&held);
    }
    // without a velocity jump, a contact that stuck until now starts sliding from rest;
    // so does one whose stick the cone refused (its velocity just crossed zero). After an
    // impact a sliding contact slides with the velocity the impact leaves it — even one
    // whose slip→stick guard fired with the touchdown: the flow takes it from rest only if
    // that velocity is within the rest band (Flow::fix_slide_directions), as the resets do
    let from_rest = mode_after
        .active()
        .filter(|&k| {
            !impact
                && mode_after.kind(k) == Some(ContactKind::Slide)
                && (c.stuck.contains(&k) || mode.kind(k) == Some(ContactKind::Stick))
        })
        .collect();
    let (kind, triggered) = c.event_kind();
    // an impact's value is its impulse, a force event's its forces (Selected)
    let (impulse, force) = if impact {
        (selected.value, force)
    } else {
        (Vec::new(), selected.value)
    };
    Ok(Reset::Continue {
        event: Event {
            t,
            kind,
            mode_before: mode,
            mode_after,
            triggered,
            impulse,
            impulse_mode: if impact {
                selected.mode
            } else {
                ContactMode::FLIGHT
            },
            pseudo_impulse: selected.pseudo_impulse,
            force,
            kinetic_before: ke_before,
            kinetic_after: ke_after,
            q: q.to_vec(),
            qd_after,
        },
        from_rest,
        lock,
    })
}

/// The contacts a jam hold keeps at a reset of the guards `fired` in `mode`
/// ([`crate::jam_hold`]): those of `flow`'s hold still sticking in `mode` whose guard did
/// not fire; `flow`'s hold is narrowed to them (the reset then adds those it holds).
fn still_held(flow: &mut Flow, mode: ContactMode, fired: &[Guard]) -> Vec<usize> {
    if flow.jammed().is_empty() {
        return Vec::new();
    }
    let ended = |k: usize| {
        fired
            .iter()
            .any(|g| matches!(*g, Guard::Jammed { contact, .. } if contact == k))
    };
    let held: Vec<usize> = flow
        .jammed()
        .iter()
        .copied()
        .filter(|&k| mode.kind(k) == Some(ContactKind::Stick) && !ended(k))
        .collect();
    flow.set_jammed(&held);
    held
}

/// The apex: the end of the run, or (not stopping there) an event that changes nothing —
/// unless other guards fired with it (`None`: the reset goes on without it).
fn apex_reset(flow: &Flow, opts: &HybridOptions, at: Firing<'_>) -> Option<Reset> {
    let Firing {
        guards: fired,
        mode,
        t,
        y,
    } = at;
    let (q, qd) = y.split_at(flow.model().nq());
    let apex_only = fired == [Guard::Apex];
    if !(fired.contains(&Guard::Apex) && (opts.stop_at_apex || apex_only)) {
        return None;
    }
    let event = Event::without_jump(t, EventKind::Apex, mode, vec![], (q, qd));
    if !opts.stop_at_apex {
        return Some(Reset::Continue {
            event,
            from_rest: vec![],
            lock: flow.lock().to_vec(),
        });
    }
    Some(Reset::End {
        event: Some(event),
        termination: Termination::Apex,
    })
}

/// The workspace of a reset of `flow` under `ctrl` (the flow's controller, cloned out so
/// that `flow` stays free), with the joints `lock` locked in `ws`, the kinds `barred` barred,
/// and the pseudo-impulse duration and fold threshold of `opts`.
pub(crate) fn reset_workspace<'a: 'b, 'b>(
    flow: &Flow<'a>,
    ctrl: &'b dyn Controller,
    opts: &HybridOptions,
    ws: &'b mut FlowWorkspace,
    barred: &'b [(usize, ContactKind)],
    lock: &[usize],
) -> ResetWorkspace<'b> {
    ws.data.locked.clear();
    ws.data.locked.extend_from_slice(lock);
    ResetWorkspace {
        model: flow.model(),
        terrain: flow.terrain(),
        ctrl,
        delta_t_s: opts.delta_t_s,
        ws,
        barred,
        fold_threshold: opts.fold_threshold,
        // a jam hold keeps its contacts as a dwell does (crate::jam_hold)
        held: if flow.jammed().is_empty() {
            flow.held().to_vec()
        } else {
            flow.held().iter().chain(flow.jammed()).copied().collect()
        },
        jammed: flow.jammed().to_vec(),
    }
}

/// The contacts of the guards that fired, by guard.
#[derive(Default)]
struct FiredContacts {
    touched: Vec<usize>,
    released: Vec<usize>,
    slipped: Vec<usize>,
    stuck: Vec<usize>,
    folded: Vec<usize>,
    passed: Vec<usize>,
}

impl FiredContacts {
    fn of(fired: &[Guard]) -> Self {
        let mut c = FiredContacts::default();
        for guard in fired {
            match *guard {
                Guard::Touchdown(k) => c.touched.push(k),
                Guard::Liftoff { contact, .. } => c.released.push(contact),
                Guard::Slip { contact, .. } => c.slipped.push(contact),
                Guard::Stick(k) => c.stuck.push(k),
                Guard::Fold { contact, .. } => c.folded.push(contact),
                Guard::FoldPassed { contact, .. } => c.passed.push(contact),
                // the end of a jam hold: judged by force as at a liftoff
                Guard::Jammed { contact, .. } => c.released.push(contact),
                Guard::Apex => {}
            }
        }
        c
    }

    /// The event's kind and the contacts that triggered it, by precedence: a touchdown (with
    /// the folds that came with it), a fold, a liftoff, a slip, a stick, a fold passage's end.
    fn event_kind(self) -> (EventKind, Vec<usize>) {
        if !self.touched.is_empty() {
            (
                EventKind::Touchdown,
                self.touched.into_iter().chain(self.folded).collect(),
            )
        } else if !self.folded.is_empty() {
            (EventKind::Fold, self.folded)
        } else if !self.released.is_empty() {
            (EventKind::Liftoff, self.released)
        } else if !self.slipped.is_empty() {
            (EventKind::Slip, self.slipped)
        } else if !self.stuck.is_empty() {
            (EventKind::Stick, self.stuck)
        } else {
            (EventKind::FoldPassed, self.passed)
        }
    }
}

/// A contact whose height jumped through zero met a step of the terrain: located to
/// `event_tol_s`, a smooth crossing is at most `|ȧ_k| event_tol_s` below the ground.
fn terrain_step(
    flow: &mut Flow,
    opts: &HybridOptions,
    touched: &[usize],
    (t, y): (f64, &[f64]),
) -> Option<Termination> {
    let model = flow.model();
    for &k in touched {
        let geom = flow.geometry(k, y);
        let (q_, qd_) = y.split_at(model.nq());
        let approach = flow
            .kinematics(q_, qd_)
            .material_velocity(geom.part, geom.point)
            .dot(&geom.plane.normal())
            .abs();
        let gap = geom.gap_m;
        // (nor is a gap within the drift band: a contact released below the ground by a
        // coarsely located touchdown comes back from there, crate::drift)
        let allowed = (TERRAIN_STEP_M + 2.0 * approach * opts.event_tol_s).max(MAX_DRIFT_M);
        if gap < -allowed {
            return Some(Termination::TerrainDiscontinuity {
                t,
                contact: k,
                gap_m: gap,
            });
        }
    }
    None
}

/// Where each folded contact is judged: its pin.
fn fold_pins(
    flow: &mut Flow,
    mode: ContactMode,
    folded: &[usize],
    (q, qd): (&[f64], &[f64]),
) -> Vec<f64> {
    let model = flow.model();
    let terrain = flow.terrain();
    folded
        .iter()
        .map(|&k| {
            let own = fold::own_direction(flow.slide_directions(), k);
            fold::pin(
                model,
                flow.kinematics(q, qd),
                terrain,
                mode,
                k,
                own.as_slice(),
            )
            .unwrap_or(0.0)
        })
        .collect()
}

/// The kinds each contact is offered and barred from: a contact at its fold may not keep its
/// kind (a sliding one is offered the stick), a contact whose cone margin has just reached
/// zero may not stick again at once, a jammed one may not slide (it is offered the stick).
fn bars(
    model: &Model,
    mode: ContactMode,
    c: &FiredContacts,
    jammed: &[usize],
) -> (ContactMode, Vec<(usize, ContactKind)>) {
    let mut prefer = mode;
    let mut barred = Vec::with_capacity(c.folded.len());
    for &k in &c.folded {
        let (bar, offered) = fold::fold_options(model, mode, k);
        barred.push((k, bar));
        if let Some(kind) = offered {
            prefer = prefer.with(k, kind);
        }
    }
    // a contact whose cone margin has just reached zero may not stick again at once: its
    // slip guard has decided (the cone test at rest of a force event, ResetWorkspace::
    // held_at_rest, would otherwise keep it on the cone's edge by round-off of the drift
    // projection below, and the guard would fire again: an event that changes nothing)
    barred.extend(c.slipped.iter().map(|&k| (k, ContactKind::Stick)));
    barred.extend(jammed.iter().map(|&k| (k, ContactKind::Slide)));
    for &k in jammed {
        prefer = prefer.with(k, ContactKind::Stick);
    }
    (prefer, barred)
}

/// Whether every folded contact (with its pin) passes its fold sliding, its joint locked:
/// the velocity after the entries and the lock with their joints, or `None`.
fn fold_passage(
    cx: &mut ResetWorkspace,
    (t, mode): (f64, ContactMode),
    lock: &[usize],
    (folded, pins): (&[usize], &[f64]),
    (q, qd): (&[f64], &[f64]),
) -> Result<Option<fold::Passage>, HybridError> {
    let (mut v, mut l) = (qd.to_vec(), lock.to_vec());
    for (&k, &pin) in folded.iter().zip(pins) {
        match cx.passage(t, mode, &l, (k, pin), (q, &v))? {
            Some((v1, l1)) => (v, l) = (v1, l1),
            None => return Ok(None),
        }
    }
    Ok(Some((v, l)))
}

/// The selected contact set and the velocity after the reset from `q̇_in` (an `impact` or
/// forces): the impulses' (or forces') complementarity among the active and touched
/// contacts, the impact's `q̇⁺` (5.52), and the mode whose contacts also hold in force
/// (5.19)–(5.20); or the termination complementarity ended the run with.
fn select_mode(
    cx: &mut ResetWorkspace,
    (t, mode): (f64, ContactMode),
    c: &FiredContacts,
    mut prefer: ContactMode,
    (q, qd_in): (&[f64], &mut Vec<f64>),
    impact: bool,
    rest_time_s: f64,
) -> Result<Result<AfterReset, Termination>, HybridError> {
    let model = cx.model;
    // at a force event the velocity is continuous and satisfies the constraints of the mode
    // before, `A q̇ = 0`, up to the integrator's drift: project that drift away (a plastic
    // impact into the mode before, (5.52), as crate::drift does), so that a contact that
    // stuck until now starts sliding from zero sliding speed exactly. Its sliding direction
    // is then chosen by the forces at rest (selfmanip_core::friction), not by the sign of a
    // drift whose size scales with the tolerance (at rtol = 1e-6 a middle leg stuck until its
    // slip had |v_t| = 1.3 µm/s of the wrong sign, outside the rest band: the wrong cone edge,
    // a pulling normal force, a liftoff instead of a slip — a different leap)
    // Only at a slip: elsewhere the projection would move a leaving contact's force root
    // (a massless leg's rate, slaved to its contact, sets its motor torque) and its liftoff
    // guard would fire again at once, an event that changes nothing.
    if !impact && c.folded.is_empty() && !c.slipped.is_empty() {
        let imp = plastic_impact(model, &mut cx.ws.data, cx.terrain, mode, q, qd_in)?;
        qd_in.copy_from_slice(imp.qd_plus.as_slice());
    }
    // contacts that reached the cone slide; contacts whose sliding stopped try to stick
    for &k in &c.slipped {
        prefer = prefer.with(k, ContactKind::Slide);
    }
    for &k in &c.stuck {
        prefer = prefer.with(k, ContactKind::Stick);
    }
    let mut candidates: Vec<usize> = mode.active().chain(c.touched.iter().copied()).collect();
    candidates.sort_unstable();
    candidates.dedup();
    let selected = match cx.select(t, &candidates, &c.released, prefer, q, qd_in, impact)? {
        Ok(s) => s,
        Err(term) => return Ok(Err(term)),
    };
    // q̇⁺ of the impact into the selected mode (5.52)
    let mut qd_after = qd_in.clone();
    if impact {
        let imp = plastic_impact(model, &mut cx.ws.data, cx.terrain, selected.mode, q, qd_in)?;
        qd_after.copy_from_slice(imp.qd_plus.as_slice());
    }
    // at δt = 0 the impact also takes the contacts it leaves at rest (crate::complementarity)
    let mut selected = selected;
    if impact && cx.delta_t_s == 0.0 {
        let released: Vec<usize> = candidates
            .iter()
            .copied()
            .filter(|&k| !selected.mode.contains(k))
            .collect();
        let resting = cx.resting(t, &released, (selected.mode, prefer), q, qd_in, rest_time_s)?;
        if !resting.is_empty() {
            let mut set: Vec<usize> = selected.mode.active().chain(resting).collect();
            set.sort_unstable();
            if let Some(o) = cx.outcome(t, &set, prefer, q, qd_in, true)? {
                let imp = plastic_impact(model, &mut cx.ws.data, cx.terrain, o.mode, q, qd_in)?;
                qd_after.copy_from_slice(imp.qd_plus.as_slice());
                selected = Selected {
                    mode: o.mode,
                    value: o.value,
                    pseudo_impulse: o.pseudo_impulse,
                };
            }
        }
    }
    // contacts kept by the impact must also hold in force (5.19)–(5.20)
    let mut mode_after = selected.mode;
    let mut force = Vec::new();
    if impact && !mode_after.is_flight() {
        let kept: Vec<usize> = mode_after.active().collect();
        match cx.select(t, &kept, &[], mode_after, q, &qd_after, false)? {
            Ok(s) => (mode_after, force) = (s.mode, s.value),
            Err(term) => return Ok(Err(term)),
        }
    }
    Ok(Ok(AfterReset {
        selected,
        qd_after,
        mode_after,
        force,
    }))
}

/// What complementarity made of a reset: the contact set selected (with its impulses or
/// forces and pseudo-impulses), the velocity after the reset, and the mode after it, whose
/// contacts also hold in force: after an impact, `force` (rows of `mode_after`).
struct AfterReset {
    selected: Selected,
    qd_after: Vec<f64>,
    mode_after: ContactMode,
    force: Vec<f64>,
}

/// The contacts of `wedged` (kept sticking by a reset because their damped slide is wedged
/// on both sides: in Painlevé's region or inconsistent) that stick in `mode_after` and,
/// released, would not separate (their gap's second derivative in the flow without them
/// below the jam's tolerance, as at a jam hold's entry): held sticking by the jam hold
/// ([`crate::jam_hold`]) until its guard — the cone holds their force again, or released
/// they separate.
fn wedged_holds(
    flow: &mut Flow,
    t: f64,
    wedged: &[usize],
    mode_after: ContactMode,
    q: &[f64],
    qd: &[f64],
) -> Vec<usize> {
    let y: Vec<f64> = q.iter().chain(qd).copied().collect();
    wedged
        .iter()
        .copied()
        .filter(|&k| mode_after.kind(k) == Some(selfmanip_core::ContactKind::Stick))
        .filter(|&k| {
            crate::jam_hold::gap_acceleration(flow, mode_after.without(k), k, t, &y)
                .unwrap_or(f64::NEG_INFINITY)
                < -crate::jam_hold::SEPARATION_TOL_M_S2
        })
        .collect()
}
