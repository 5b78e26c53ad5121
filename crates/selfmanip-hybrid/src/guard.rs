//! Guards (thesis (5.49)–(5.51)): the scalar functions of the state whose crossing of zero
//! ends the flow of a mode, how they are armed at a segment's start, and how they are
//! sampled on each accepted step's dense output to find the first interval in which one
//! crosses ([`crate::locate`] then brackets the crossing to the event tolerance).
//!
//! The guards of a mode:
//! - **touchdown** of an inactive contact `k`: its height $a_k(q)$ above the terrain
//!   (Definition 5.4), positive then non-positive;
//! - **liftoff** of an active contact: its pushing normal force $U(\lambda_n) = -\lambda_n$
//!   (5.51), positive then non-positive;
//! - **apex** (in flight; terminal with [`HybridOptions::stop_at_apex`], else recorded as an
//!   event that changes nothing): the upward body speed $-\dot z$;
//! - **stick→slip** of a sticking contact with finite Coulomb $\mu$ (section 5.1.5): the cone
//!   margin $\mu U(\lambda_n) - |\lambda_t|$;
//! - **fold** of an active contact that pins a massless chain with a square block of rows
//!   (Lemma 5.1; [`crate::fold`]): its pin $\pi_k(q) - \varepsilon$, positive then
//!   non-positive — the flow stops before the pose where the contact stops pinning the chain;
//! - **slip→stick** of a sliding contact that can stick: its tangential sliding velocity
//!   $v_t$, which must cross zero *against* its sign — positive then non-positive for a
//!   contact sliding forward, negative then non-negative for one sliding backward (Drake's
//!   `WitnessFunctionDirection`), and not yet known for one that starts from rest.
//!
//! **Arming.** A guard fires at zero only once it has been clearly on its starting side
//! (beyond `arm_margin`): a contact just made or broken sits at zero and must not
//! re-trigger at once. An unarmed guard fires only once it is clearly past zero,
//! `arm_margin` beyond its start value: no chatter at zero, and no tunnelling through the
//! ground when a swing is too small or too short to arm it. A slip→stick guard of a contact
//! sliding clearly is armed with the direction of its velocity; one that starts from rest —
//! its velocity within the margin, or the contact stuck until the reset, whose sliding
//! velocity is then only the drift of the sticking constraint, possibly beyond the margin —
//! has the direction fixed for its sliding force in the segment
//! ([`crate::flow::Flow::fix_slide_directions`]): armed once its velocity has moved
//! `arm_margin` along it, and firing unarmed if it moves `arm_margin` against it (the force
//! would then push it along). Without a fixed direction (no kinetic friction, or none
//! for the instant) it has none until its velocity has moved `arm_margin` away from its
//! start, and takes the direction of that motion.
//!
//! **Sampling.** Each step is sampled at a quarter, half, three quarters and its end. The
//! end point is the integrator's last stage, whose flow is cached, so the force guards
//! there cost nothing and are sampled first. Force guards (a flow evaluation per sample)
//! are sampled at the coarse samples (mid-step and end), and also at a fine sample where a
//! cheap (kinematic) guard crosses, so that none of them can cross unseen before the
//! earliest event; the kinematic guards at every sample. The mid-step sample of the force
//! guards is skipped where the step's own stages show them clear: DOPRI5 solves the flow
//! at `t₀ + c h`, `c = 0, 1/5, 3/10, 4/5, 8/9, 1`, at states within the step's local error
//! of the solution, and the force guards' values there are watched
//! ([`GuardSet::watch_stage`]); a step on which each of them stays above the arming
//! margin by more than its own spread over those instants (`2 min − max > margin`) is one
//! on which it neither crosses nor arms at mid-step (it is armed by the end sample, where
//! it is as clear), unless its force swings by more than that spread between two stages
//! that an accepted step resolves. Any other step — implicit, or with a force guard near
//! its margin, moving, or not read off the flow's solution (a jam hold's) — takes the
//! mid-step sample.
// the slip→stick guard's value is defined with the flow, which fixes a sliding contact's
// direction by it
use crate::flow::sliding_velocity;
use crate::flow::{Flow, FlowSystem};
use crate::fold;
use crate::integrate::DenseStep;
use crate::ode_system::OdeSystem;
use crate::options::HybridOptions;
use selfmanip_core::contact::contact_gap;
use selfmanip_core::contact::{ContactKind, RowDirection};
use selfmanip_core::friction::SlideDirection;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::model::Friction;
use selfmanip_core::{ContactMode, CoreError, Data, Model, Terrain};

/// A guard of a mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Guard {
    /// Height of inactive contact `k` above the terrain.
    Touchdown(usize),
    /// Pushing normal force of active contact `contact` (its normal row `row` of the mode).
    Liftoff { contact: usize, row: usize },
    /// Upward body speed in flight.
    Apex,
    /// Cone margin `μ U(λ_n) − |λ_t|` of a sticking contact (rows of the mode).
    Slip {
        contact: usize,
        t_row: usize,
        n_row: usize,
        mu: f64,
    },
    /// Tangential sliding velocity of a sliding contact that can stick.
    Stick(usize),
    /// Pin `π_k − ε` of an active contact's massless chain ([`crate::fold`]).
    Fold { contact: usize, threshold: f64 },
    /// `ε − π_k` of a contact whose chain is passing its fold, locked
    /// ([`crate::fold`]): it fires once the chain is `ε` past the fold.
    FoldPassed { contact: usize, threshold: f64 },
    /// The end of a jam hold of a sticking contact ([`crate::jam_hold`]): positive while
    /// no mode keeps it and its release would re-enter the ground.
    Jammed {
        contact: usize,
        t_row: usize,
        n_row: usize,
        mu: f64,
    },
}

/// Guards that fired together, and where: in `mode`, at `(t, y = [q; q̇])` — what a reset
/// starts from ([`crate::reset::reset`]).
#[derive(Debug, Clone, Copy)]
pub struct Firing<'a> {
    pub guards: &'a [Guard],
    pub mode: ContactMode,
    pub t: f64,
    pub y: &'a [f64],
}

impl Guard {
    /// The contact whose liftoff or stick→slip guard this is — the guards that let a
    /// contact go, which a Zeno truncation's dwell holds back ([`crate::zeno`]).
    pub fn lets_go(self) -> Option<usize> {
        match self {
            Guard::Liftoff { contact, .. } | Guard::Slip { contact, .. } => Some(contact),
            _ => None,
        }
    }

    /// The contact whose touchdown guard this is.
    pub fn touchdown(self) -> Option<usize> {
        match self {
            Guard::Touchdown(contact) => Some(contact),
            _ => None,
        }
    }

    /// Whether the guard's value needs the flow (the contact forces), not just kinematics.
    pub fn needs_flow(self) -> bool {
        matches!(
            self,
            Guard::Liftoff { .. } | Guard::Slip { .. } | Guard::Jammed { .. }
        )
    }

    /// Whether this is a jam hold's guard ([`Guard::Jammed`]), whose value also evaluates
    /// the flow without its contact ([`crate::jam_hold::guard_value`]).
    pub fn is_jammed(self) -> bool {
        matches!(self, Guard::Jammed { .. })
    }

    /// The value of a liftoff or stick→slip guard from the flow's solution `data` in its
    /// mode; `None` for any other guard.
    fn force_value(self, data: &Data) -> Option<f64> {
        match self {
            Guard::Liftoff { contact, row } => {
                Some(crate::damped_slide::liftoff_value(data, contact, row))
            }
            Guard::Slip {
                t_row, n_row, mu, ..
            } => Some(mu * (-data.lambda[n_row]) - data.lambda[t_row].abs()),
            _ => None,
        }
    }

    /// The guard's value at `(t, y = [q; q̇])` in the flow of `mode` (unoriented).
    pub fn value(
        self,
        flow: &mut Flow,
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<f64, CoreError> {
        let model = flow.model();
        let (q, qd) = y.split_at(model.nq());
        Ok(match self {
            Guard::Liftoff { .. } | Guard::Slip { .. } => {
                let data = flow.eval(t, mode, q, qd)?;
                self.force_value(data).expect("a force guard")
            }
            Guard::Apex => -qd[model.ix_z()],
            Guard::Jammed {
                contact,
                t_row,
                n_row,
                mu,
            } => crate::jam_hold::guard_value(flow, (t, mode, y), contact, (t_row, n_row), mu)?,
            _ => {
                let terrain = flow.terrain();
                let (kin, dirs) = flow.kinematics_and_directions(q, qd);
                self.kinematic_value(model, terrain, kin, dirs, mode, qd)
            }
        })
    }

    /// The value of a guard that needs no flow ([`Self::needs_flow`] false) from the
    /// kinematics at `(q, q̇)` and the segment's sliding directions: what [`Self::value`]
    /// returns for it, for callers that sample several such guards at one state.
    fn kinematic_value(
        self,
        model: &Model,
        terrain: &dyn Terrain,
        kin: &Kinematics,
        slide_directions: &[(usize, SlideDirection)],
        mode: ContactMode,
        qd: &[f64],
    ) -> f64 {
        match self {
            Guard::Touchdown(k) => contact_gap(model, kin, terrain, k),
            Guard::Apex => -qd[model.ix_z()],
            Guard::Stick(k) => sliding_velocity(model, kin, terrain, k),
            Guard::Fold { contact, threshold } => {
                // the segment's fixed σ of this contact (fold::pin)
                let own = fold::own_direction(slide_directions, contact);
                let dirs = own.as_slice();
                fold::pin(model, kin, terrain, mode, contact, dirs)
                    .expect("a fold guard's contact has a fold")
                    - threshold
            }
            Guard::FoldPassed { contact, threshold } => {
                let own = fold::own_direction(slide_directions, contact);
                let dirs = own.as_slice();
                threshold
                    - fold::pin(model, kin, terrain, mode, contact, dirs)
                        .expect("a fold guard's contact has a fold")
            }
            Guard::Liftoff { .. } | Guard::Slip { .. } | Guard::Jammed { .. } => {
                unreachable!("a force guard's value needs the flow")
            }
        }
    }

    /// The guards of `mode`, in a fixed order: touchdowns by contact, then per active
    /// contact its liftoff, its stick→slip or slip→stick guard and its fold (its passage's
    /// end when its chain is in `locked`), then the apex in flight.
    pub fn of_mode(
        model: &Model,
        mode: ContactMode,
        locked: &[usize],
        opts: &HybridOptions,
        out: &mut Vec<Guard>,
    ) {
        out.clear();
        out.extend(
            (0..model.n_contacts())
                .filter(|&k| !mode.contains(k))
                .map(Guard::Touchdown),
        );
        for (row, r) in mode.rows().enumerate() {
            if r.direction != RowDirection::Normal {
                continue;
            }
            let k = r.contact;
            out.push(Guard::Liftoff { contact: k, row });
            if let Friction::Sticking { mu } = model.contacts[k].friction {
                match mode.kind(k) {
                    Some(ContactKind::Stick) if mu.is_finite() => out.push(Guard::Slip {
                        contact: k,
                        t_row: row - 1,
                        n_row: row,
                        mu,
                    }),
                    Some(ContactKind::Slide) => out.push(Guard::Stick(k)),
                    _ => {}
                }
            }
            if fold::has_fold(model, mode, k) {
                // the passage threshold is set when the guard is armed (fold::guard_threshold)
                let contact = k;
                let passing = fold::massless_chain(model, k).any(|j| locked.contains(&j));
                out.push(if passing {
                    Guard::FoldPassed {
                        contact,
                        threshold: opts.passage_threshold,
                    }
                } else {
                    Guard::Fold {
                        contact,
                        threshold: opts.fold_threshold,
                    }
                });
            }
        }
        if mode.is_flight() {
            out.push(Guard::Apex);
        }
    }
}

/// Which way a guard's value must cross zero for it to fire on `t₀ < t* ≤ t₁` (Drake's
/// `WitnessFunctionDirection`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Direction {
    /// From positive to non-positive (every guard but slip→stick).
    PositiveThenNonPositive,
    /// From negative to non-negative (a contact sliding backward that comes to rest).
    NegativeThenNonNegative,
    /// Not known yet: a slip→stick guard starting from rest, whose direction is set by the
    /// first motion of its value `arm_margin` away from `reference`, its value at the start.
    Undetermined { reference: f64 },
}

impl Direction {
    /// The guard value turned so that the guard fires when it goes from positive to
    /// non-positive (zero while the direction is undetermined).
    pub fn orient(self, raw: f64) -> f64 {
        self.sign() * raw
    }

    fn sign(self) -> f64 {
        match self {
            Direction::PositiveThenNonPositive => 1.0,
            Direction::NegativeThenNonNegative => -1.0,
            Direction::Undetermined { .. } => 0.0,
        }
    }

    /// The direction of a guard whose value has sign `s` on its starting side: it fires on
    /// crossing zero against that sign.
    fn against(s: f64) -> Direction {
        if s > 0.0 {
            Direction::PositiveThenNonPositive
        } else {
            Direction::NegativeThenNonNegative
        }
    }
}

/// A guard's state through one segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuardState {
    pub guard: Guard,
    pub direction: Direction,
    /// Clearly on its starting side once: fires at zero (unarmed: at `−unarmed_shift`).
    pub armed: bool,
    /// How far past zero an unarmed guard must go to fire.
    pub unarmed_shift: f64,
    /// Oriented value at the end of the last accepted step (at the segment's start before
    /// the first step).
    last: f64,
    /// Oriented value and time at its latest sample within the step being sampled.
    value: f64,
    t: f64,
}

impl GuardState {
    /// The shift that the guard's oriented value takes to fire at zero.
    pub fn shift(&self) -> f64 {
        if self.armed {
            0.0
        } else {
            self.unarmed_shift
        }
    }

    /// Its state at a segment's start, where its value is `raw`; `from_rest`: the contact of
    /// a slip→stick guard starts sliding from rest (see the module docs).
    /// `sigma`: the sliding direction fixed for the segment, if any (non-zero).
    fn arm(guard: Guard, raw: f64, from_rest: bool, sigma: Option<f64>, margin: f64) -> Self {
        let (direction, armed, unarmed_shift) = match guard {
            Guard::Stick(_) if raw.abs() > margin && !from_rest => {
                (Direction::against(raw.signum()), true, 0.0)
            }
            // from rest with a fixed sliding direction: it fires when the velocity, having
            // moved along σ, comes back to zero, or at once if it moves clearly against σ
            // (the friction force would then push it along: Coulomb's law is violated)
            Guard::Stick(_) if sigma.is_some() => (
                Direction::against(sigma.unwrap_or(1.0)),
                false,
                margin + (-sigma.unwrap_or(1.0) * raw).max(0.0),
            ),
            Guard::Stick(_) => (
                Direction::Undetermined { reference: raw },
                false,
                f64::INFINITY,
            ),
            // an apex needs a rise first: a flight that starts falling (or at an apex just
            // recorded) has none until it rises again
            Guard::Apex => (
                Direction::PositiveThenNonPositive,
                raw > margin,
                f64::INFINITY,
            ),
            _ => (
                Direction::PositiveThenNonPositive,
                raw > margin,
                margin + (-raw).max(0.0),
            ),
        };
        let last = direction.orient(raw);
        GuardState {
            guard,
            direction,
            armed,
            unarmed_shift,
            last,
            value: last,
            t: 0.0,
        }
    }

    /// Records the raw value at sample time `ts`; the crossing `(guard, shift, its previous
    /// sample time, shifted values there and at ts)` if it crossed since its last sample.
    fn sample(&mut self, index: usize, ts: f64, raw: f64, margin: f64) -> Option<Crossing> {
        let (prev_t, prev_v) = (self.t, self.value);
        self.t = ts;
        if let Direction::Undetermined { reference } = self.direction {
            // a slip→stick guard arms once the sliding velocity has moved clear of its start
            let moved = raw - reference;
            if moved.abs() > margin {
                self.direction = Direction::against(moved.signum());
                self.armed = true;
            }
            self.value = self.direction.orient(raw);
            return None;
        }
        let v = self.direction.orient(raw);
        let sh = self.shift();
        let crossing = (prev_v + sh > 0.0 && v + sh <= 0.0).then_some(Crossing {
            guard: index,
            shift: sh,
            lo: prev_t,
            f_lo: prev_v + sh,
            f_hi: v + sh,
        });
        if v > margin {
            self.armed = true;
        }
        self.value = v;
        crossing
    }

    /// Whether it has fired by `(t, y)` (used for the guards that fire together with the
    /// earliest one).
    fn fired_at(
        &self,
        flow: &mut Flow,
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<bool, CoreError> {
        if matches!(self.direction, Direction::Undetermined { .. }) {
            return Ok(false);
        }
        Ok(self.direction.orient(self.guard.value(flow, t, mode, y)?) + self.shift() <= 0.0)
    }
}

/// Takes out of `fired` the liftoff guards that mark where a site the dwell holds sliding
/// comes to pull ([`Flow::pulled`]: it slides on without friction). Returns whether any
/// guard fired besides them.
pub fn take_pulls(flow: &mut Flow, fired: &mut Vec<Guard>) -> bool {
    fired.retain(|g| !matches!(*g, Guard::Liftoff { contact, .. } if flow.pulled(contact)));
    !fired.is_empty()
}

/// A guard that crossed between two samples: its shifted oriented value is positive at `lo`
/// and non-positive at the sample that found it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// Index of the guard in the [`GuardSet`].
    pub guard: usize,
    pub shift: f64,
    pub lo: f64,
    pub f_lo: f64,
    pub f_hi: f64,
}

/// The flow as the integrator's system ([`FlowSystem`]), with `guards` watching the force
/// guards at every stage it evaluates ([`GuardSet::watch_stage`]).
pub struct WatchedFlow<'s, 'a> {
    pub system: FlowSystem<'s, 'a>,
    pub guards: &'s mut GuardSet,
}

impl OdeSystem<CoreError> for WatchedFlow<'_, '_> {
    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), CoreError> {
        self.system.rhs(t, y, dy)?;
        self.guards.watch_stage(self.system.flow.solution());
        Ok(())
    }

    fn jacobian(&mut self, t: f64, y: &[f64], jac: &mut [f64]) -> bool {
        self.system.jacobian(t, y, jac)
    }
}

/// The legs whose poses and velocities the kinematic guards of `guards` read, as a bit set
/// ([`Kinematics::compute_legs`]): those of their contacts' links (a fold's chain ends at
/// its contact's link; a contact on the body and the apex read the body alone).
fn kinematic_legs(model: &Model, guards: &[Guard]) -> u64 {
    guards
        .iter()
        .filter_map(|g| match *g {
            Guard::Touchdown(k)
            | Guard::Stick(k)
            | Guard::Fold { contact: k, .. }
            | Guard::FoldPassed { contact: k, .. } => model.contact_leg(k),
            _ => None,
        })
        .filter(|&leg| leg < 64)
        .fold(0, |legs, leg| legs | 1 << leg)
}

/// Where the guards are sampled in each step (fractions of it; the last is its end point).
pub const SAMPLES: [f64; 4] = [0.25, 0.5, 0.75, 1.0];

/// The guards of the segment being integrated, with their state and the buffers their
/// sampling reuses from step to step.
#[derive(Debug, Default)]
pub struct GuardSet {
    guards: Vec<Guard>,
    pub states: Vec<GuardState>,
    /// Raw values at each sample, `SAMPLES.len()` rows of one entry per guard.
    raw: Vec<f64>,
    crossings: Vec<Crossing>,
    /// Scratch torques for the fold thresholds.
    scratch_tau: Vec<f64>,
    /// The force guards (their indices; the jam holds' last, [`Self::arm`]), and their
    /// oriented values over the stages of the step being taken ([`Self::watch_step`]): the
    /// least and the greatest, one entry each.
    force: Vec<usize>,
    stage_lo: Vec<f64>,
    stage_hi: Vec<f64>,
    /// Whether every stage of the step being sampled was watched.
    watched: bool,
    /// The legs the kinematic guards read (bit `l` for leg `l`: [`kinematic_legs`]), and
    /// the kinematics of those legs at a sample the flow holds no kinematics for.
    legs: u64,
    sample_kin: Kinematics,
}

impl GuardSet {
    /// Arms the guards of `mode` at the segment's start `(t, y)`; `from_rest`: sliding
    /// contacts whose slip→stick guard starts from rest.
    pub fn arm(
        &mut self,
        flow: &mut Flow,
        mode: ContactMode,
        t: f64,
        y: &[f64],
        from_rest: &[usize],
        opts: &HybridOptions,
    ) -> Result<(), CoreError> {
        Guard::of_mode(flow.model(), mode, flow.lock(), opts, &mut self.guards);
        // a Zeno truncation's dwell holds its contacts closed (crate::zeno), all but the
        // end of a damped slide (its liftoff guard: the foot leaves, its law stops holding
        // or it wedges; crate::damped_slide), which no other mode continues, and the pull
        // of a general site held sliding with its friction (its liftoff guard, Flow::pulled)
        let (held, slides) = (flow.held(), flow.held_slides());
        let damped = crate::damped_slide::sliding_damped(flow.damped_contacts(), mode);
        self.guards.retain(|g| {
            g.lets_go().is_none_or(|k| !held.contains(&k))
                || matches!(*g, Guard::Liftoff { contact, .. }
                    if damped >> contact & 1 == 1 || slides.contains(&contact))
        });
        // a jam hold's contacts end it by its own guard (crate::jam_hold): their liftoff
        // guards give way, their stick→slip guards turn into it
        let jammed =
            |k: usize| flow.jammed().contains(&k) && mode.kind(k) == Some(ContactKind::Stick);
        self.guards
            .retain(|g| !matches!(*g, Guard::Liftoff { contact, .. } if jammed(contact)));
        for g in &mut self.guards {
            if let Guard::Slip {
                contact,
                t_row,
                n_row,
                mu,
            } = *g
            {
                if jammed(contact) {
                    *g = Guard::Jammed {
                        contact,
                        t_row,
                        n_row,
                        mu,
                    };
                }
            }
        }
        // a leg whose torque falls with speed meets its fold at the passage threshold
        let (q, qd) = y.split_at(flow.model().nq());
        self.scratch_tau.resize(flow.model().n_joints(), 0.0);
        for g in &mut self.guards {
            if let Guard::Fold { contact, threshold } = g {
                *threshold = fold::guard_threshold(
                    flow.model(),
                    &**flow.controller(),
                    (t, q, qd),
                    mode,
                    *contact,
                    opts,
                    &mut self.scratch_tau,
                );
            }
        }
        self.states.clear();
        for &g in &self.guards {
            let raw = g.value(flow, t, mode, y)?;
            let rest = matches!(g, Guard::Stick(k) if from_rest.contains(&k));
            let sigma = match g {
                Guard::Stick(k) => flow.slide_directions().iter().find_map(|&(c, d)| match d {
                    SlideDirection::Fixed(s) if c == k && s != 0.0 => Some(s),
                    _ => None,
                }),
                _ => None,
            };
            self.states
                .push(GuardState::arm(g, raw, rest, sigma, opts.arm_margin));
        }
        self.raw.resize(SAMPLES.len() * self.states.len(), 0.0);
        // the force guards, those that read the flow of `mode` before the jam holds', whose
        // flow without their contact replaces the flow's evaluation of `mode` at a sample
        self.force.clear();
        for jammed in [false, true] {
            self.force.extend((0..self.states.len()).filter(|&gi| {
                let g = self.states[gi].guard;
                g.needs_flow() && g.is_jammed() == jammed
            }));
        }
        self.legs = kinematic_legs(flow.model(), &self.guards);
        Ok(())
    }

    pub fn len(&self) -> usize {
        self.states.len()
    }

    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// Starts watching the force guards over the stages of the next step
    /// ([`Self::watch_stage`]), from their values at its start.
    pub fn watch_step(&mut self) {
        self.stage_lo.clear();
        self.stage_lo
            .extend(self.force.iter().map(|&gi| self.states[gi].last));
        self.stage_hi.clone_from(&self.stage_lo);
        self.watched = true;
    }

    /// Records the force guards' values in the flow's solution `data` at one stage of the
    /// step being taken (a value that is not finite, or a guard whose value is not read off
    /// the solution, counts as crossed).
    pub fn watch_stage(&mut self, data: &Data) {
        let watched = self.stage_lo.iter_mut().zip(&mut self.stage_hi);
        for (&gi, (lo, hi)) in self.force.iter().zip(watched) {
            let st = &self.states[gi];
            let v = match st.guard.force_value(data) {
                Some(raw) if raw.is_finite() => st.direction.orient(raw),
                _ => f64::NEG_INFINITY,
            };
            *lo = lo.min(v);
            *hi = hi.max(v);
        }
    }

    /// Whether the force guards need their mid-step sample on the step `dense`: unless the
    /// step is explicit and every stage was watched ([`Self::watch_step`]), with each force
    /// guard's values over the stages clear of its arming margin by more than their own
    /// spread (`2 lo − hi > margin`).
    fn mid_step_needed(&self, dense: &DenseStep, margin: f64) -> bool {
        if dense.implicit || !self.watched {
            return true;
        }
        // (a NaN compares false: not clear)
        let clear = |(&lo, &hi): (&f64, &f64)| 2.0 * lo - hi > margin;
        !self.stage_lo.iter().zip(&self.stage_hi).all(clear)
    }

    /// Sticking contacts whose force already lies outside their cone at the segment's start
    /// (an inconsistent start, or a cone that a reset left violated): they slip at once.
    pub fn slipping_at_start(&self, margin: f64) -> Vec<Guard> {
        self.states
            .iter()
            .filter(|s| matches!(s.guard, Guard::Slip { .. }) && s.last < -margin)
            .map(|s| s.guard)
            .collect()
    }

    /// Samples every guard on the accepted step `dense`, whose end state is `y_end` (the
    /// state the integrator advanced to: its flow is cached), with `y` as scratch. Returns
    /// the time of the first sample by which any guard crossed, with the crossings (in
    /// [`Self::crossings`]), or `None` when none did (the values at the step's end are then
    /// kept for the next step).
    pub fn sample_step(
        &mut self,
        flow: &mut Flow,
        mode: ContactMode,
        dense: &DenseStep,
        y_end: &[f64],
        y: &mut [f64],
        margin: f64,
    ) -> Result<Option<f64>, CoreError> {
        let (t0, h) = (dense.t0, dense.h);
        let ng = self.states.len();
        // the samples at which the force guards are sampled before any kinematic guard
        // crossed: the end point, and mid-step unless the step's stages showed them clear
        let mid = self.mid_step_needed(dense, margin);
        self.watched = false;
        let coarse = |si: usize| si == SAMPLES.len() - 1 || (si == 1 && mid);
        // the raw values at every sample, the end point first (its flow is cached)
        let mut sample_t = [0.0; SAMPLES.len()];
        for si in [3, 1, 0, 2] {
            let s = SAMPLES[si];
            let ts = if s == 1.0 {
                y.copy_from_slice(y_end);
                t0 + h
            } else {
                let ts = t0 + s * h;
                dense.eval(ts, y);
                ts
            };
            sample_t[si] = ts;
            // at a coarse sample the force guards first: their flow evaluation computes the
            // kinematics there, which the kinematic guards then reuse (the other order
            // computed them twice); every value is a function of the state alone
            if coarse(si) {
                for fi in 0..self.force.len() {
                    let gi = self.force[fi];
                    self.raw[si * ng + gi] = self.states[gi].guard.value(flow, ts, mode, y)?;
                }
            }
            // the kinematic guards from one look-up of the kinematics at this sample (of
            // the legs they read)
            let (model, terrain) = (flow.model(), flow.terrain());
            let (q, qd) = y.split_at(model.nq());
            let (kin, dirs) = flow.kinematics_of_legs(q, qd, self.legs, &mut self.sample_kin);
            for (gi, st) in self.states.iter().enumerate() {
                if !st.guard.needs_flow() {
                    self.raw[si * ng + gi] = st
                        .guard
                        .kinematic_value(model, terrain, kin, dirs, mode, qd);
                }
            }
        }
        // in time order, stop at the first sample by which a guard crossed
        for st in &mut self.states {
            st.value = st.last;
            st.t = t0;
        }
        self.crossings.clear();
        for (si, &ts) in sample_t.iter().enumerate() {
            // pass 0: the guards sampled here; pass 1 (a fine sample where a kinematic guard
            // crossed): the force guards too
            for pass in 0..2 {
                if pass == 1 {
                    if self.crossings.is_empty() || coarse(si) {
                        break;
                    }
                    dense.eval(ts, y);
                }
                for gi in 0..ng {
                    let sampled = coarse(si) || !self.states[gi].guard.needs_flow();
                    if sampled != (pass == 0) {
                        continue;
                    }
                    let raw = if pass == 0 {
                        self.raw[si * ng + gi]
                    } else {
                        self.states[gi].guard.value(flow, ts, mode, y)?
                    };
                    if let Some(c) = self.states[gi].sample(gi, ts, raw, margin) {
                        self.crossings.push(c);
                    }
                }
            }
            if !self.crossings.is_empty() {
                return Ok(Some(ts));
            }
        }
        for st in &mut self.states {
            st.last = st.value;
        }
        Ok(None)
    }

    /// The crossings found by the last [`Self::sample_step`].
    pub fn crossings(&self) -> &[Crossing] {
        &self.crossings
    }

    /// The guards that have fired by `(t, y)`: `first`, which fired there, and every other
    /// one that has also crossed by then.
    pub fn fired_with(
        &self,
        first: usize,
        flow: &mut Flow,
        t: f64,
        mode: ContactMode,
        y: &[f64],
    ) -> Result<Vec<Guard>, CoreError> {
        let mut fired = Vec::new();
        for (gi, st) in self.states.iter().enumerate() {
            if gi == first || st.fired_at(flow, t, mode, y)? {
                fired.push(st.guard);
            }
        }
        Ok(fired)
    }
}
