//! Zeno detection: a run that makes more than `zeno_max_events` transitions — events, and
//! passages of a contact onto the next terrain feature — within any window of
//! `zeno_window_s` stops with [`Termination::Zeno`]. An execution of the thesis's hybrid
//! system is non-Zeno when its massless limbs move with bounded acceleration (section
//! 5.2); a rocking block without the pseudo-impulse is the classic Zeno execution, its
//! impacts accumulating at a finite time (section 5.1.4). Feature passages count as well:
//! a site rocking across the boundary between two features could otherwise split the flow
//! without end.
//!
//! **Truncation** ([`truncate`]). The window does not end the run when it can truncate it: a
//! Zeno execution is what the pseudo-impulse (5.39)–(5.40) exists to truncate (section
//! 5.1.4). Along the accumulating impacts the contacts' approach speeds go to zero, so the
//! plastic impulses `P_λ` of (5.28)–(5.29) shrink with them while the pseudo-impulse
//! `P_δ = A_J^† (Υ − C̄q̇ − N̄) δt` (5.39) does not depend on the speed: for any `δt > 0`
//! some impact has `U(P_λ + P_δ)` of the sign of `U(P_δ)` for every contact, and the block
//! of (5.44) comes to rest (below 6.3 cm/s in Fig. 5.5). That impact's limit `δt → 0⁺` is the
//! truncation: the plastic impact (5.52) into the set `J` of every contact of the Zeno
//! window that is on its surface, in the mode impulse complementarity gives it (every contact
//! sticking where that mode is singular), and then the **dwell**: the run goes on in that
//! mode with its contacts held — no liftoff or stick→slip guard armed ([`Flow::held`]), kept
//! by the complementarity of any reset in between; a general site held sliding whose force
//! comes to pull slides on without friction ([`Flow::pulled`]) — for
//! [`ZenoWindow::dwell_s`], after which force complementarity (5.19)–(5.20) judges them
//! ([`dwell_end`]). Holding `J` for `δt` and judging it by force is the pseudo-impulse of
//! (5.39), the impulse of mode `J`'s forces over `δt`, applied as that force. The run goes on
//! with an [`EventKind::ZenoTruncation`] naming the window's contacts; a window with nothing
//! to truncate (no contact of it on its surface, e.g. of feature passages only) ends the run
//! with [`Termination::Zeno`]. Derivation: docs/singular-transitions.md section 9.
//!
//! A **chatter** ([`ChatterDetector`]: one cycle of transitions repeated with the robot
//! staying where it is) is truncated the same way, over the contacts of its cycle: it is the
//! generalized Zeno execution of section 5.1.6, whose continuation is more of the same
//! cycle, and the truncated mode held for the dwell is that continuation's limit. Only a
//! chatter with nothing to truncate ends the run ([`Termination::Chatter`]).
use crate::error::HybridError;
use crate::event::{max_diff, Event, EventKind};
use crate::execution::Termination;
use crate::flow::{Flow, FlowWorkspace};
use crate::options::HybridOptions;
use crate::reset::{reset_workspace, Reset};
use crate::surface_tolerances::TERRAIN_STEP_M;
use selfmanip_core::{plastic_impact, ContactKind, ContactMode, CoreError};

/// The times of the transitions so far, latest last, with the contacts that triggered each.
#[derive(Debug, Clone)]
pub struct ZenoWindow {
    window_s: f64,
    max_in_window: usize,
    times: Vec<f64>,
    triggered: Vec<Vec<usize>>,
    /// The last truncation's dwell: its length (s) and when it ends ([`Self::truncated`]).
    dwell: Option<(f64, f64)>,
    /// Whether that dwell still holds its contacts ([`dwell_end`] has not been reached).
    holding: bool,
    /// Whether that dwell holds a re-touch cycle's contacts, and so ends at a touchdown of
    /// another contact ([`Self::hold_cycle_only`]).
    cycle_only: bool,
    /// The cycle of the last truncated chatter, while it may resume ([`Self::resumed`]).
    cycle: Option<TruncatedCycle>,
}

/// A chatter's cycle as its truncation left it ([`ZenoWindow::truncated_chatter`]).
#[derive(Debug, Clone)]
struct TruncatedCycle {
    /// Its last repetition before the truncation (`p` events).
    events: Vec<Event>,
    /// The contacts the truncation named.
    contacts: Vec<usize>,
    /// The truncation's time (s).
    t: f64,
    /// The index of the first event after the truncation's.
    after: usize,
}

impl ZenoWindow {
    pub fn new(window_s: f64, max_in_window: usize) -> Self {
        ZenoWindow {
            window_s,
            max_in_window,
            times: Vec::new(),
            triggered: Vec::new(),
            dwell: None,
            holding: false,
            cycle_only: false,
            cycle: None,
        }
    }

    /// The end of the dwell that holds its contacts now (s), if any.
    pub fn holding_until(&self) -> Option<f64> {
        self.dwell.filter(|_| self.holding).map(|(_, end)| end)
    }

    /// The dwell of a truncation (s), for which it holds its mode ([`truncate`]): `base_s`
    /// (the window, or the pseudo-impulse's `δt` where longer); twice the last dwell when no
    /// quiet window — a whole window without a transition — came between the last dwell's
    /// end and this truncation (the truncated mode's own continuation is the cycle: the
    /// hold spans more of it). A run of horizon `T` therefore makes at most
    /// `⌊log2(T / base_s + 1)⌋ + 1` truncations that follow one another, each after at most
    /// `zeno_max_events + 1` transitions.
    pub fn dwell_s(&self, base_s: f64) -> f64 {
        match self.dwell {
            Some((last, _)) => 2.0 * last,
            None => base_s,
        }
    }

    /// Records a truncation at `t` holding its mode for `dwell_s`: the window starts afresh.
    pub fn truncated(&mut self, t: f64, dwell_s: f64) {
        self.times.clear();
        self.triggered.clear();
        self.dwell = Some((dwell_s, t + dwell_s));
        self.holding = true;
        self.cycle_only = false;
        self.cycle = None;
    }

    /// Records that the truncation just made ([`Self::truncated`]) is of a chatter whose last
    /// repetition is `cycle`, truncated at `t` over `contacts`, `after` the index its
    /// truncation's event will have plus one: a cycle of re-touches bounds its dwell to
    /// itself ([`Self::hold_cycle_only`]), and the cycle is remembered while it may resume
    /// ([`Self::resumed`]).
    pub fn truncated_chatter(
        &mut self,
        cycle: &[Event],
        (t, contacts): (f64, &[usize]),
        after: usize,
    ) {
        if cycle.iter().all(|e| e.mode_before == e.mode_after) {
            self.hold_cycle_only();
        }
        self.cycle = Some(TruncatedCycle {
            events: cycle.to_vec(),
            contacts: contacts.to_vec(),
            t,
            after,
        });
    }

    /// A truncated chatter that **resumes**: its dwell over, before a quiet window (a whole
    /// window without a transition, which ends the doubling of [`Self::dwell_s`]: the cycle
    /// stopped), the latest events ([`Event`]s after the truncation's, latest last) repeat
    /// its cycle once ([`same_transition`]) with the robot where it was — no coordinate of
    /// `q` moved more than [`CHATTER_Q_PER_CYCLE`], the allowance of one cycle, since the
    /// cycle's last repetition. It is the same chatter, its truncation's continuation: the
    /// criterion's [`CHATTER_CYCLES`] repetitions identified its cycle already, and one
    /// repetition is the fewest that show it again. `Some(Chatter)` over the truncated
    /// contacts and those of the repetition (`cycles: 1`), truncated as before with the dwell
    /// doubled ([`Self::dwell_s`]).
    pub fn resumed(&self, events: &[Event]) -> Option<Termination> {
        let c = self.cycle.as_ref().filter(|_| !self.holding)?;
        let p = c.events.len();
        let since = events.get(c.after..)?;
        let tail = since.get(since.len().checked_sub(p)?..)?;
        if !tail
            .iter()
            .zip(&c.events)
            .all(|(a, b)| same_transition(a, b))
        {
            return None;
        }
        if max_diff(&c.events[0].q, &tail[0].q) > CHATTER_Q_PER_CYCLE {
            return None;
        }
        let t = tail[p - 1].t;
        let mut lists = vec![c.contacts.clone()];
        lists.extend(tail.iter().map(|e| e.triggered.clone()));
        Some(Termination::Chatter {
            t,
            period: p,
            cycles: 1,
            duration_s: t - c.t,
            contacts: union(&lists),
        })
    }

    /// Bounds the dwell just begun ([`Self::truncated`]) to the cycle it truncates: a
    /// **re-touch cycle** (its events change no mode: a foot that its impact keeps and its
    /// force lets go at once, back on the ground a little later, [`Event::makes_transitions`])
    /// is the continuation of one contact's own law, and its truncated mode is that
    /// continuation's limit — not a constraint on the impacts of the others. A touchdown of
    /// another contact during the dwell ends it before its reset ([`Self::end_hold_at`]):
    /// that impact's complementarity judges every contact afresh, the held one with them.
    pub fn hold_cycle_only(&mut self) {
        self.cycle_only = true;
    }

    /// Whether a reset of the guards `fired` ends a dwell bounded to its cycle
    /// ([`Self::hold_cycle_only`]): one of them is a touchdown of a contact the dwell does
    /// not hold (`held`). The dwell then ends: the caller lets its contacts go
    /// ([`Flow::set_held`]) before the reset.
    pub fn end_hold_at(&mut self, fired: &[crate::guard::Guard], held: &[usize]) -> bool {
        if !(self.holding && self.cycle_only) {
            return false;
        }
        let other = fired
            .iter()
            .any(|g| g.touchdown().is_some_and(|k| !held.contains(&k)));
        if other {
            self.holding = false;
        }
        other
    }

    /// Records a transition at `t` (not before the last one) triggered by `contacts` (none
    /// for a feature passage); `Zeno` if the window ending at `t` now holds more than the
    /// allowed number, naming the contacts that triggered them.
    pub fn record(&mut self, t: f64, contacts: &[usize]) -> Option<Termination> {
        // a quiet window since the last transition (or since the dwell's end): the cycle
        // stopped, and the next truncation dwells from the base again
        let last = self.times.last().copied();
        if let Some((_, end)) = self.dwell {
            if t - last.unwrap_or(end).max(end) > self.window_s {
                self.dwell = None;
                self.cycle = None;
            }
        }
        self.times.push(t);
        self.triggered.push(contacts.to_vec());
        let since = t - self.window_s;
        let in_window = self.times.iter().rev().take_while(|&&s| s > since).count();
        (in_window > self.max_in_window).then(|| Termination::Zeno {
            t,
            events_in_window: in_window,
            contacts: union(&self.triggered[self.triggered.len() - in_window..]),
        })
    }
}

/// The longest cycle of events (in events) that [`ChatterDetector`] looks for.
pub const CHATTER_MAX_PERIOD: usize = 4;
/// How many repetitions of one cycle in a row make a chatter.
pub const CHATTER_CYCLES: usize = 30;
/// The largest change of any coordinate of `q` (rad or m) per cycle, on average over the
/// repetitions, that still counts as the robot staying where it is.
pub const CHATTER_Q_PER_CYCLE: f64 = 1e-2;

/// The shortest last cycle, as a fraction of the first, of a chatter: shorter, the cycles
/// accumulate (a Zeno execution, for [`ZenoWindow`]).
pub const CHATTER_MIN_DURATION_RATIO: f64 = 0.5;

/// Generalized Zeno detection: a chattering execution (thesis Fig. 5.7 and section 5.1.6,
/// "not quite a Zeno execution, as the finite acceleration of the leg in the air results in
/// only finitely many transitions in a finite time").
///
/// **Criterion.** A Zeno execution's transition times converge, and with them its state;
/// [`ZenoWindow`] sees the first by the density of events. A chatter has the same
/// signature on the hybrid state without the density: the discrete state runs through one
/// cycle of transitions again and again — the same `p` events (kind, contacts, mode before
/// and after), `p ≤` [`CHATTER_MAX_PERIOD`] — while the continuous configuration stays
/// where it is and the cycles do not shrink: over [`CHATTER_CYCLES`] repetitions no coordinate of `q` at the cycle's
/// events moves more than [`CHATTER_Q_PER_CYCLE`] per cycle on average. Such a run makes
/// events in proportion to its horizon and nothing else: its continuation is more of the
/// same cycle, its limit the truncated mode ([`truncate`]) — or, with nothing to truncate,
/// the end ([`Termination::Chatter`]). A gait that repeats a cycle of
/// modes moves the robot (its legs turn by a revolution per cycle, its body advances) and
/// is not caught. Nor is an execution whose cycles shrink — the last lasting less than
/// [`CHATTER_MIN_DURATION_RATIO`] of the first —: its transition times accumulate, a Zeno
/// execution proper (a rocking block without the pseudo-impulse), which the window catches.
/// The run truncates a chatter as it truncates a Zeno window ([`truncate_and_hold`], module
/// docs) and ends with it only when there is nothing to truncate.
///
/// **Re-touch cycles.** The cycle must make transitions ([`Event::makes_transitions`]): an
/// apex recorded again and again makes none. A touchdown that leaves the mode as it was but
/// whose impact kept its contact, which force complementarity then let go at once, makes two
/// — into the impact's mode and out of it — in one event: Fig. 5.7's chatter (the leg lifted
/// by its own law after the impact, put back by it a little later) with one event per
/// cycle, a cycle of period 1. Its truncation holds the contact for the dwell or until
/// another contact touches down ([`ZenoWindow::hold_cycle_only`]).
///
/// Cost: `O(CHATTER_MAX_PERIOD · CHATTER_CYCLES)` comparisons per event, on the last
/// `CHATTER_MAX_PERIOD · CHATTER_CYCLES` events only.
#[derive(Debug, Clone, Default)]
pub struct ChatterDetector;

impl ChatterDetector {
    /// `Some(Chatter)` if `events` (latest last) end with a chatter.
    pub fn check(&self, events: &[Event]) -> Option<Termination> {
        for p in 1..=CHATTER_MAX_PERIOD {
            let span = p * CHATTER_CYCLES;
            if events.len() < span {
                break;
            }
            let tail = &events[events.len() - span..];
            // every event equals the one a period later
            if !(0..span - p).all(|i| same_transition(&tail[i], &tail[i + p])) {
                continue;
            }
            // the cycle makes a transition (a cycle of events that make none — apexes — is
            // no chatter); a re-touch makes two ([`Event::makes_transitions`])
            if !tail[..p].iter().any(Event::makes_transitions) {
                continue;
            }
            // not accumulating: the last cycle lasts at least half as long as the first (a
            // Zeno execution's cycles shrink towards its accumulation time: the window's)
            let first_cycle = tail[p].t - tail[0].t;
            let last_cycle = tail[span - p].t - tail[span - 2 * p].t;
            if last_cycle < CHATTER_MIN_DURATION_RATIO * first_cycle {
                continue;
            }
            let moved = max_diff(&tail[0].q, &tail[span - p].q);
            if moved <= CHATTER_Q_PER_CYCLE * (CHATTER_CYCLES - 1) as f64 {
                let t = events.last().map_or(0.0, |e| e.t);
                let cycle: Vec<Vec<usize>> =
                    tail[..p].iter().map(|e| e.triggered.clone()).collect();
                return Some(Termination::Chatter {
                    t,
                    period: p,
                    cycles: CHATTER_CYCLES,
                    duration_s: t - tail[0].t,
                    contacts: union(&cycle),
                });
            }
        }
        None
    }
}

/// A **re-touch after a flight the run does not resolve**: the latest event (`events`,
/// latest last) is a touchdown that re-touches ([`Event::is_retouch`]) a contact which left
/// its surface less than `rest_time_s` ([`crate::HybridOptions::rest_time_s`], the run's
/// time resolution) before, **from rest and by its own event**: the latest event that
/// involved it took it out of the mode, was triggered by it (its own liftoff, slip or fold
/// — not another contact's impact, whose complementarity judges it afresh), and the mode
/// before that event held it sticking (a re-touch's mode before does not hold it: a
/// series of re-touches is the criterion's and [`ZenoWindow::resumed`]'s). A flight
/// that short from rest is no flight at that resolution — the rule by which an impact
/// leaves a contact at rest ([`crate::complementarity`], (5.40) with `δt = τ/2` for it):
/// the contact stayed, and the impact that kept it and the force that let it go at once
/// are the start of the chatter of thesis Fig. 5.7 below the resolution, whose
/// continuation is more of the same cycle. A contact that slid, or that another contact's
/// impact let go (a see-saw of two feet), is no contact at rest: it is left to the
/// 30-repetition criterion. `Some(Chatter)` of period 1 and one cycle over the contacts so
/// back (`duration_s` the shortest such flight), truncated as a chatter is. The run applies
/// it only when asked ([`crate::HybridOptions::truncate_unresolved_flights`]: on in a
/// scenario's defaults, off in the engine's and the RHex leaps';
/// docs/decisions/2026-11-30-chatter-truncated.md).
pub fn retouch_unresolved(events: &[Event], rest_time_s: f64) -> Option<Termination> {
    let (e, before) = events.split_last()?;
    if e.kind != EventKind::Touchdown || !e.is_retouch() {
        return None;
    }
    let flight = |k: usize| {
        // the latest event that involved `k`; it left there unless it stays after it
        let last = before.iter().rev().find(|ev| {
            ev.mode_before.contains(k) || ev.impulse_mode.contains(k) || ev.mode_after.contains(k)
        })?;
        let from_rest =
            last.mode_before.kind(k) == Some(ContactKind::Stick) && last.triggered.contains(&k);
        (from_rest && !last.mode_after.contains(k)).then_some(e.t - last.t)
    };
    let flights: Vec<(usize, f64)> = e
        .triggered
        .iter()
        .filter_map(|&k| flight(k).map(|f| (k, f)))
        .filter(|&(_, f)| f < rest_time_s)
        .collect();
    let shortest = flights.iter().map(|&(_, f)| f).reduce(f64::min)?;
    Some(Termination::Chatter {
        t: e.t,
        period: 1,
        cycles: 1,
        duration_s: shortest,
        contacts: flights.iter().map(|&(k, _)| k).collect(),
    })
}

/// Whether `b` repeats the transition `a` in a chatter's cycle: the same kind, mode before
/// and after, and contacts.
fn same_transition(a: &Event, b: &Event) -> bool {
    a.kind == b.kind
        && a.mode_before == b.mode_before
        && a.mode_after == b.mode_after
        && a.triggered == b.triggered
}

/// The contacts of `lists`, sorted, each once.
fn union(lists: &[Vec<usize>]) -> Vec<usize> {
    let mut all: Vec<usize> = lists.iter().flatten().copied().collect();
    all.sort_unstable();
    all.dedup();
    all
}

/// The truncation of a Zeno execution (module docs) at `(t, y = [q; q̇])` in `mode` of
/// `flow`, whose window holds the transitions of `contacts`: the plastic impact (5.52) into
/// `J` = the active contacts and those of `contacts` within [`TERRAIN_STEP_M`] of their
/// surface, into the mode that impulse complementarity (5.28)–(5.29) gives `J` (a sticking
/// contact whose impulse leaves its cone slides) — or, where that mode is singular (a
/// massless two-link chain cannot slide, section 1 of docs/singular-transitions.md), with
/// every contact of `J` sticking. The run goes on in that mode, which the caller holds for
/// the dwell ([`ZenoWindow::dwell_s`], [`Flow::set_held`]). `None` when there is nothing to
/// truncate (no contact of the window in `J`, `J` singular either way — within the fold
/// threshold of a contact's fold too —, or a slide without consistent forces): the
/// window's end stands.
pub fn truncate(
    ws: &mut FlowWorkspace,
    flow: &mut Flow,
    opts: &HybridOptions,
    mode: ContactMode,
    (t, y): (f64, &[f64]),
    contacts: &[usize],
) -> Result<Option<Reset>, HybridError> {
    let model = flow.model();
    let (q, qd) = y.split_at(model.nq());
    let added: Vec<usize> = contacts
        .iter()
        .copied()
        .filter(|&k| !mode.contains(k) && flow.geometry(k, y).gap_m.abs() <= TERRAIN_STEP_M)
        .collect();
    if added.is_empty() && !contacts.iter().any(|&k| mode.contains(k)) {
        return Ok(None);
    }
    let mut set: Vec<usize> = mode.active().chain(added).collect();
    set.sort_unstable();
    let lock = flow.lock().to_vec();
    let ctrl = flow.controller().clone();
    let cx = &mut reset_workspace(flow, &*ctrl, opts, ws, &[], &lock);
    let inconsistent = |e: &CoreError| matches!(e, CoreError::PainleveInconsistent { .. });
    let held = match cx.outcome(t, &set, mode, q, qd, true) {
        Ok(Some(o)) => o.mode,
        // no set is consistent: the set held in its own kinds — unless a contact of it is
        // within the fold threshold of its fold, where the impact's KKT matrix is as good
        // as singular (as `mode_for` takes it): there is nothing to truncate into
        Ok(None) => {
            let m = ContactMode::with_defaults(model, &set)?;
            if cx.within_fold(m) {
                return Ok(None);
            }
            m
        }
        Err(e) if inconsistent(&e) => return Ok(None),
        Err(e) => return Err(e.into()),
    };
    let ke_before = crate::energy::kinetic_energy_at(model, cx.terrain, &mut cx.ws.data, q, qd)?;
    let imp = match plastic_impact(model, &mut cx.ws.data, cx.terrain, held, q, qd) {
        Ok(imp) => imp,
        Err(CoreError::SingularKkt { .. }) => return Ok(None),
        Err(e) => return Err(e.into()),
    };
    let qd_after: Vec<f64> = imp.qd_plus.iter().copied().collect();
    let ke_after =
        crate::energy::kinetic_energy_at(model, cx.terrain, &mut cx.ws.data, q, &qd_after)?;
    Ok(Some(Reset::Continue {
        event: Event {
            t,
            kind: EventKind::ZenoTruncation,
            mode_before: mode,
            mode_after: held,
            triggered: contacts.to_vec(),
            impulse: imp.impulse.iter().copied().collect(),
            impulse_mode: held,
            pseudo_impulse: vec![],
            force: vec![],
            kinetic_before: ke_before,
            kinetic_after: ke_after,
            q: q.to_vec(),
            qd_after,
        },
        from_rest: vec![],
        lock,
    }))
}

/// [`truncate`] for the Zeno window's end or the chatter `z` (over the contacts it names)
/// at `(t, y)` in `mode`, its mode held for the dwell ([`ZenoWindow::dwell_s`]: the window, or `δt` where longer, doubled while the cycle
/// resumes): `None` when there is nothing to truncate (the run ends with `z`).
pub fn truncate_and_hold(
    (ws, flow, zeno): (&mut FlowWorkspace, &mut Flow, &mut ZenoWindow),
    opts: &HybridOptions,
    mode: ContactMode,
    (t, y): (f64, &[f64]),
    z: &Termination,
) -> Result<Option<Reset>, HybridError> {
    let (Termination::Zeno { contacts, .. } | Termination::Chatter { contacts, .. }) = z else {
        return Ok(None);
    };
    let truncation = truncate(ws, flow, opts, mode, (t, y), contacts)?;
    if let Some(Reset::Continue { event, .. }) = &truncation {
        let dwell = zeno.dwell_s(opts.zeno_window_s.max(opts.delta_t_s));
        let held: Vec<usize> = event.mode_after.active().collect();
        flow.set_held(&held);
        zeno.truncated(t, dwell);
    }
    Ok(truncation)
}

/// The reset at the end of a truncation's dwell at `(t, y)` in `mode`: the liftoff and
/// stick→slip guards of the contacts held fire together, and force complementarity
/// (5.19)–(5.20) decides which of them go on holding — an event that changes nothing when
/// all of them do; `None` when none of them is still in `mode`.
pub fn dwell_end(
    (ws, flow, zeno): (&mut FlowWorkspace, &mut Flow, &mut ZenoWindow),
    opts: &HybridOptions,
    mode: ContactMode,
    (t, y): (f64, &[f64]),
) -> Result<Option<Reset>, HybridError> {
    zeno.holding = false;
    let held = flow.held().to_vec();
    flow.set_held(&[]);
    let mut guards = Vec::new();
    crate::guard::Guard::of_mode(flow.model(), mode, flow.lock(), opts, &mut guards);
    guards.retain(|g| g.lets_go().is_some_and(|k| held.contains(&k)));
    if guards.is_empty() {
        return Ok(None);
    }
    let at = crate::guard::Firing {
        guards: &guards,
        mode,
        t,
        y,
    };
    crate::reset::reset(ws, flow, opts, at, &[]).map(Some)
}
