//! The flow of a contact mode (thesis (5.48)): `(t, q, q̇) ⇒ (q̈, λ)` with the controller's
//! joint torques `Υ` and the prescribed motion of free massless joints, through the core's
//! constrained dynamics (5.3)–(5.4):
//!
//! $$ \ddot q = M^\dagger (\Upsilon - \bar C \dot q - \bar N) - A^{\dagger T} \dot A \dot q,
//! \qquad \lambda = A^\dagger (\Upsilon - \bar C \dot q - \bar N) - \Lambda \dot A \dot q. $$
//!
//! [`Flow`] owns the workspace its results live in and caches the last evaluation: the
//! integrator's stages and the guards ask for the flow at the same states (the last stage of
//! a step is its end point, where the guards are sampled; several force guards share one
//! sample). The cache is keyed by `(t, mode, q, q̇)` and by the *generation*, which advances
//! whenever the controller is replaced ([`Flow::set_controller`]) or told of an event
//! ([`Flow::notify`]), the joints locked for a fold passage change ([`Flow::set_lock`]), or
//! the sliding directions do ([`Flow::set_slide_directions`]) —
//! the only ways an answer at the same state can change.
//!
//! **Locked joints.** While a massless leg passes the fold of its sliding contact
//! ([`crate::fold`]) its joint turns at a constant speed (the speed at which its torque
//! vanishes): the flow prescribes `q̈ = 0` for it, and the core keeps its constraint column
//! ([`selfmanip_core::Data::locked`]).
//!
//! **Sliding directions.** A sliding contact with kinetic friction keeps the side of its
//! friction force through a segment ([`Flow::fix_slide_directions`]): the flow is smooth
//! where its sliding velocity passes zero, and the slip→stick guard makes that an event.
//! Nothing else writes the workspace: the resets work on one of their own
//! ([`crate::reset_workspace::ResetWorkspace`]), so no reset can leave the cache stale.
use crate::controller::Controller;
use crate::event::Event;
use crate::ode_system::OdeSystem;
use crate::sensitivity::EngineJacobian;
use selfmanip_core::contact::{contact_geometry, ContactGeometry, ContactKind};
use selfmanip_core::friction::{SlideDirection, SLIDING_SPEED_EPS_M_S};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{forward_dynamics_prepared, ContactMode, CoreError, Data, Model, Terrain};
use std::sync::Arc;

/// The flow of any mode of one robot on one terrain under one controller, with its cache.
pub struct Flow<'a> {
    model: &'a Model,
    terrain: &'a dyn Terrain,
    ctrl: Arc<dyn Controller>,
    ws: FlowWorkspace,
    /// Changes of the controller and of the lock so far.
    generation: u64,
    /// `(t, mode, generation)` of the flow that `data` holds, at the state `y`.
    key: Option<(f64, ContactMode, u64)>,
    y: Vec<f64>,
    /// Kinematics at `kin_y`, for states where no flow was evaluated.
    kin: Kinematics,
    kin_y: Option<Vec<f64>>,
    /// The kinematics of one contact's leg at a state the flow holds none for
    /// ([`Self::leg_geometry`]).
    leg_kin: Kinematics,
    /// Contacts held closed by a Zeno truncation's dwell ([`crate::zeno`]): their liftoff
    /// and stick→slip guards are not armed until the dwell ends.
    held: Vec<usize>,
    /// Contacts of `held` that slide, as general sites with kinetic friction, pushing at the
    /// segment's start ([`Self::fix_slide_directions`]): their liftoff guard stays armed, and
    /// where their normal force comes to pull they slide without friction ([`Self::pulled`]).
    held_slides: Vec<usize>,
    /// Contacts of `held` whose normal force came to pull in the dwell: they slide without
    /// friction until it ends ([`Self::pulled`]).
    frictionless: Vec<usize>,
    /// Contacts held sticking by a jam hold ([`crate::jam_hold`]): their liftoff and
    /// stick→slip guards give way to the hold's own guard.
    jammed: Vec<usize>,
    /// The exact flow Jacobian's workspace ([`Self::jacobian`]; made on the first call).
    engine_jacobian: Option<Box<EngineJacobian<'a>>>,
    /// The instants of the controller's time events ([`Controller::time_events`]) and the
    /// generation they were asked at: fixed for one controller, they are asked once.
    time_events: (Option<u64>, Vec<f64>),
    /// The buffers of the damped slides' chain accelerations.
    chain_scratch: crate::damped_slide::ChainScratch,
}

/// The flow of one mode as the integrator's right-hand side ([`OdeSystem`]), with its exact
/// Jacobian ([`Flow::jacobian`]) for the linearly implicit steps. Its time is clamped to
/// `[t_right, t_left]`: the stages of a step that ends on a time event of the controller
/// take the flow's left limit there, those of the step after it the right limit.
pub struct FlowSystem<'s, 'a> {
    pub flow: &'s mut Flow<'a>,
    pub mode: ContactMode,
    pub t_right: f64,
    pub t_left: f64,
}

impl OdeSystem<CoreError> for FlowSystem<'_, '_> {
    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), CoreError> {
        let t = t.max(self.t_right).min(self.t_left);
        self.flow.rhs(t, self.mode, y, dy)
    }

    fn jacobian(&mut self, t: f64, y: &[f64], jac: &mut [f64]) -> bool {
        let t = t.max(self.t_right).min(self.t_left);
        self.flow.jacobian(t, self.mode, y, jac)
    }
}

impl<'a> Flow<'a> {
    pub fn new(model: &'a Model, terrain: &'a dyn Terrain, ctrl: Arc<dyn Controller>) -> Self {
        Flow {
            model,
            terrain,
            ctrl,
            ws: FlowWorkspace::new(model),
            generation: 0,
            key: None,
            y: Vec::with_capacity(2 * model.nq()),
            kin: Kinematics::default(),
            kin_y: None,
            leg_kin: Kinematics::default(),
            held: Vec::new(),
            held_slides: Vec::new(),
            frictionless: Vec::new(),
            jammed: Vec::new(),
            engine_jacobian: None,
            time_events: (None, Vec::new()),
            chain_scratch: Default::default(),
        }
    }

    /// The exact Jacobian `∂f/∂y` of [`Self::rhs`] for `mode` at `(t, y)`, column-major into
    /// `jac` (`2nq × 2nq`): the sensitivity engine's closed form
    /// ([`crate::sensitivity::EngineJacobian`]) under the flow's controller, locked joints and
    /// sliding directions. `false` (nothing written) where it has none: a controller without
    /// partials, a mode in which a massless chain may slide damped (its rates are solved
    /// for, [`crate::damped_slide`], which the closed form does not differentiate), or
    /// singular dynamics.
    pub fn jacobian(&mut self, t: f64, mode: ContactMode, y: &[f64], jac: &mut [f64]) -> bool {
        if crate::damped_slide::sliding_damped(self.ws.damped, mode) != 0 {
            return false;
        }
        let (model, terrain) = (self.model, self.terrain);
        let ej = self
            .engine_jacobian
            .get_or_insert_with(|| Box::new(EngineJacobian::new(model, terrain)));
        let data = &self.ws.data;
        ej.jacobian(
            (&*self.ctrl, &data.locked, &data.slide_directions),
            (t, mode),
            y,
            jac,
        )
    }

    /// The contacts a jam hold keeps sticking ([`crate::jam_hold`]).
    pub fn jammed(&self) -> &[usize] {
        &self.jammed
    }

    /// The contacts the dwell holds sliding that push at the segment's start, with their
    /// friction: their liftoff guard stays armed ([`Self::fix_slide_directions`]).
    pub fn held_slides(&self) -> &[usize] {
        &self.held_slides
    }

    /// Where the liftoff guard of `contact`, one of [`Self::held_slides`], fires (its normal
    /// force comes to pull), the dwell holds it on, sliding without friction until the dwell
    /// ends (from the next segment on, [`Self::fix_slide_directions`];
    /// `selfmanip_core::friction`, "A contact that pulls"). Returns whether it was one.
    pub fn pulled(&mut self, contact: usize) -> bool {
        let held_slide = self.held_slides.contains(&contact);
        if held_slide {
            self.frictionless.push(contact);
        }
        held_slide
    }

    /// Replaces the contacts a jam hold keeps sticking (none: no hold).
    pub fn set_jammed(&mut self, contacts: &[usize]) {
        self.jammed.clear();
        self.jammed.extend_from_slice(contacts);
    }

    /// Holds the contacts `contacts` closed (none: the hold ends): see [`Self::held`].
    pub fn set_held(&mut self, contacts: &[usize]) {
        self.held.clear();
        self.held.extend_from_slice(contacts);
        self.frictionless.clear();
    }

    /// The contacts a Zeno truncation holds closed for its dwell ([`crate::zeno`]): the
    /// segments arm neither their liftoff nor their stick→slip guards.
    pub fn held(&self) -> &[usize] {
        &self.held
    }

    /// The contacts of the model that can slide damped, as a bit set
    /// ([`crate::damped_slide::damped_contacts`], fixed for the model).
    pub fn damped_contacts(&self) -> u32 {
        self.ws.damped
    }

    pub fn model(&self) -> &'a Model {
        self.model
    }

    pub fn terrain(&self) -> &'a dyn Terrain {
        self.terrain
    }

    /// The controller the flow is evaluated with.
    pub fn controller(&self) -> &Arc<dyn Controller> {
        &self.ctrl
    }

    /// Evaluates the flow with `ctrl` from here on.
    pub fn set_controller(&mut self, ctrl: Arc<dyn Controller>) {
        self.ctrl = ctrl;
        self.generation += 1;
    }

    /// Evaluates the flow with the massless joints `joints` locked at their speed (a fold
    /// passage; empty: none) from here on.
    pub fn set_lock(&mut self, joints: &[usize]) {
        if self.ws.data.locked != joints {
            self.ws.data.locked.clear();
            self.ws.data.locked.extend_from_slice(joints);
            self.generation += 1;
        }
    }

    /// The joints locked at their speed ([`Self::set_lock`]).
    pub fn lock(&self) -> &[usize] {
        &self.ws.data.locked
    }

    /// Evaluates the flow with the sliding directions `dirs` of the sites with kinetic
    /// friction fixed (by contact; empty: the instantaneous law) from here on
    /// ([`selfmanip_core::Data::slide_directions`]).
    pub fn set_slide_directions(&mut self, dirs: &[(usize, SlideDirection)]) {
        if self.ws.data.set_slide_directions(dirs) {
            self.generation += 1;
        }
    }

    /// The sliding directions the flow is evaluated with ([`Self::set_slide_directions`]).
    pub fn slide_directions(&self) -> &[(usize, SlideDirection)] {
        &self.ws.data.slide_directions
    }

    /// Fixes the sliding direction `σ` of every sliding contact of `mode` with kinetic
    /// friction for a segment that starts at `(t, y)`: `sign v_t` for one that slides, and
    /// for one that starts from rest (`from_rest`, or within
    /// [`selfmanip_core::friction::SLIDING_SPEED_EPS_M_S`], as the resets judge it) the cone
    /// edge that the friction law takes at rest, on the side of its sticking force (one flow
    /// evaluation; [`selfmanip_core::friction`]). Within the segment the force keeps that
    /// side; the slip→stick guard ends the segment where `v_t` crosses zero. Returns the
    /// contacts that start from rest.
    pub fn fix_slide_directions(
        &mut self,
        t: f64,
        mode: ContactMode,
        y: &[f64],
        from_rest: &[usize],
    ) -> Result<Vec<usize>, CoreError> {
        let (model, terrain) = (self.model, self.terrain);
        let mut dirs: Vec<(usize, SlideDirection)> = Vec::new();
        for k in mode.active() {
            if mode.kind(k) != Some(ContactKind::Slide) || model.contacts[k].kinetic_mu == 0.0 {
                continue;
            }
            let v_t = sliding_velocity(model, self.kinematics_at(y), terrain, k);
            dirs.push((
                k,
                if from_rest.contains(&k) || v_t.abs() <= SLIDING_SPEED_EPS_M_S {
                    SlideDirection::FromRest
                } else {
                    SlideDirection::Fixed(v_t.signum())
                },
            ));
        }
        let rest: Vec<usize> = dirs
            .iter()
            .filter(|d| d.1 == SlideDirection::FromRest)
            .map(|d| d.0)
            .collect();
        if !rest.is_empty() {
            self.set_slide_directions(&dirs);
            let (q, qd) = y.split_at(model.nq());
            let data = self.eval(t, mode, q, qd)?;
            for d in &mut dirs {
                if d.1 == SlideDirection::FromRest {
                    // a damped slide's side is that of u_t = −v_t
                    let sigma = data
                        .sliding
                        .iter()
                        .find(|s| s.contact == d.0)
                        .map(|s| s.sigma)
                        .or_else(|| {
                            data.damped
                                .iter()
                                .find(|s| s.contact == d.0)
                                .map(|s| -s.side)
                        })
                        .unwrap_or(0.0);
                    d.1 = SlideDirection::Fixed(sigma);
                }
            }
        }
        // a general site that a Zeno truncation's dwell holds sliding while its normal force
        // pulls slides without friction for the segment, and so does one whose force came to
        // pull in the dwell; one that pushes keeps its liftoff guard, which marks where it
        // comes to pull (selfmanip_core::friction, "A contact that pulls"; Self::pulled)
        self.held_slides.clear();
        if !self.held.is_empty() && dirs.iter().any(|d| self.held.contains(&d.0)) {
            self.set_slide_directions(&dirs);
            let (q, qd) = y.split_at(model.nq());
            let held = self.held.clone();
            let data = self.eval(t, mode, q, qd)?;
            let (pulls, pushes): (Vec<_>, Vec<_>) = data
                .sliding
                .iter()
                .filter(|s| s.general && held.contains(&s.contact))
                .map(|s| (s.contact, data.lambda[s.row] > 0.0))
                .partition(|&(_, pull)| pull);
            for d in &mut dirs {
                if pulls.iter().any(|&(c, _)| c == d.0) || self.frictionless.contains(&d.0) {
                    d.1 = SlideDirection::Fixed(0.0);
                } else if pushes.iter().any(|&(c, _)| c == d.0) {
                    self.held_slides.push(d.0);
                }
            }
        }
        self.set_slide_directions(&dirs);
        Ok(rest)
    }

    fn kinematics_at(&mut self, y: &[f64]) -> &Kinematics {
        let (q, qd) = y.split_at(self.model.nq());
        self.kinematics(q, qd)
    }

    /// The workspace and the joint torques `Υ` of the last evaluation.
    pub fn last(&self) -> (&Data, &[f64]) {
        (&self.ws.data, &self.ws.tau)
    }

    /// Tells the controller of an event (its torques may change from here on): a copy of
    /// it learns of the event and replaces it, so the one that ran before stays as it was.
    pub fn notify(&mut self, event: &Event) {
        let mut next = self.ctrl.clone_shared();
        Arc::get_mut(&mut next)
            .expect("a controller just copied has no other owner")
            .on_event(event);
        self.set_controller(next);
    }

    /// Whether `data` holds a flow (and so the kinematics) at `(q, q̇)`.
    fn holds_state(&self, q: &[f64], qd: &[f64]) -> bool {
        self.key.is_some() && self.y[..q.len()] == *q && self.y[q.len()..] == *qd
    }

    /// The flow of `mode` at `(t, q, q̇)`: the core's workspace with `q̈` in `qdd` and `λ` in
    /// `lambda` (rows of `mode`), evaluated unless the cache holds it.
    pub fn eval(
        &mut self,
        t: f64,
        mode: ContactMode,
        q: &[f64],
        qd: &[f64],
    ) -> Result<&Data, CoreError> {
        let same_state = self.holds_state(q, qd);
        if same_state && self.key == Some((t, mode, self.generation)) {
            return Ok(&self.ws.data);
        }
        self.key = None;
        crate::integrate::count_solve(mode.is_flight());
        // the run's initial state was checked: a non-finite state here is the integrator's
        if !q.iter().chain(qd).all(|v| v.is_finite()) {
            return Err(CoreError::NonFiniteResult {
                quantity: "state (q, q̇) of the integration",
            });
        }
        let (model, terrain) = (self.model, self.terrain);
        if same_state {
            // another mode, time or controller at the state of the last evaluation (a jam
            // hold's guard asks for the flow without its contact): its state stages stand
            self.ws.set_laws(model, &*self.ctrl, (t, mode), q, qd);
            self.ws.data.prepare_at_state(model, terrain, mode, qd)?;
        } else {
            self.ws
                .prepare(model, terrain, &*self.ctrl, (t, mode), q, qd)?;
        }
        self.ws.solve_prepared(model, &*self.ctrl, t, mode, q, qd)?;
        if !self.ws.data.damped.is_empty() {
            let (asked, events) = &mut self.time_events;
            if *asked != Some(self.generation) {
                crate::damped_slide::event_instants(&*self.ctrl, events);
                *asked = Some(self.generation);
            }
            crate::damped_slide::chain_accelerations_clear_of(
                model,
                terrain,
                &*self.ctrl,
                (t, mode),
                (q, qd),
                (events, &mut self.chain_scratch),
                &mut self.ws.data,
            )?;
        }
        self.y.clear();
        self.y.extend_from_slice(q);
        self.y.extend_from_slice(qd);
        self.key = Some((t, mode, self.generation));
        Ok(&self.ws.data)
    }

    /// The solution of the flow's last evaluation ([`Self::eval`]).
    pub fn solution(&self) -> &Data {
        &self.ws.data
    }

    /// The integrator's right-hand side `ẏ = [q̇; q̈]` of the flow of `mode` at `y = [q; q̇]`.
    pub fn rhs(
        &mut self,
        t: f64,
        mode: ContactMode,
        y: &[f64],
        dy: &mut [f64],
    ) -> Result<(), CoreError> {
        let nq = self.model.nq();
        let (q, qd) = y.split_at(nq);
        crate::integrate::count_rhs(mode.is_flight());
        let data = self.eval(t, mode, q, qd)?;
        dy[..nq].copy_from_slice(qd);
        dy[nq..].copy_from_slice(data.qdd.as_slice());
        Ok(())
    }

    /// Poses and velocities at `(q, q̇)`: those of the flow if the cache holds that state,
    /// else computed once per state.
    pub fn kinematics(&mut self, q: &[f64], qd: &[f64]) -> &Kinematics {
        if self.refresh_kinematics(q, qd) {
            &self.ws.data.kin
        } else {
            &self.kin
        }
    }

    /// [`Self::kinematics`] at `(q, q̇)` together with the sliding directions the flow is
    /// evaluated with ([`Self::slide_directions`]): what a kinematic guard needs.
    pub fn kinematics_and_directions(
        &mut self,
        q: &[f64],
        qd: &[f64],
    ) -> (&Kinematics, &[(usize, SlideDirection)]) {
        let kin = if self.refresh_kinematics(q, qd) {
            &self.ws.data.kin
        } else {
            &self.kin
        };
        (kin, &self.ws.data.slide_directions)
    }

    /// [`Self::kinematics_and_directions`] for guards that read only the legs `legs` and the
    /// body: the flow's kinematics where it holds them at `(q, q̇)`, else those legs' alone,
    /// computed into `scratch` ([`Kinematics::compute_legs`]; the flow's cache is left as
    /// it was).
    pub fn kinematics_of_legs<'s>(
        &'s mut self,
        q: &[f64],
        qd: &[f64],
        legs: u64,
        scratch: &'s mut Kinematics,
    ) -> (&'s Kinematics, &'s [(usize, SlideDirection)]) {
        let kin = if self.holds_state(q, qd) {
            &self.ws.data.kin
        } else if self.kin_holds(q, qd) {
            &self.kin
        } else {
            scratch.compute_legs(self.model, q, qd, legs);
            &*scratch
        };
        (kin, &self.ws.data.slide_directions)
    }

    /// Whether `self.kin` holds the kinematics at `(q, q̇)`.
    fn kin_holds(&self, q: &[f64], qd: &[f64]) -> bool {
        let nq = q.len();
        self.kin_y
            .as_ref()
            .is_some_and(|y| y[..nq] == *q && y[nq..] == *qd)
    }

    /// Whether the flow's workspace holds the kinematics at `(q, q̇)`; if not, they are made
    /// current in `self.kin` (computed unless they are already).
    fn refresh_kinematics(&mut self, q: &[f64], qd: &[f64]) -> bool {
        if self.holds_state(q, qd) {
            return true;
        }
        if !self.kin_holds(q, qd) {
            self.kin.compute(self.model, q, qd);
            let y = self.kin_y.get_or_insert_with(Vec::new);
            y.clear();
            y.extend_from_slice(q);
            y.extend_from_slice(qd);
        }
        false
    }

    /// [`Self::geometry`] from the kinematics of the body and contact `k`'s leg alone where
    /// the flow holds none at `y` ([`Kinematics::compute_legs`], bit for bit those of
    /// [`Kinematics::compute`]; the flow's kinematics are left as they were): for states
    /// visited once, such as the points of a difference.
    pub fn leg_geometry(&mut self, k: usize, y: &[f64]) -> ContactGeometry {
        let (model, terrain) = (self.model, self.terrain);
        let (q, qd) = y.split_at(model.nq());
        let legs = model
            .contact_leg(k)
            .filter(|&leg| leg < 64)
            .map_or(0, |leg| 1u64 << leg);
        let mut scratch = std::mem::take(&mut self.leg_kin);
        let (kin, _) = self.kinematics_of_legs(q, qd, legs, &mut scratch);
        let geometry = contact_geometry(model, kin, terrain, k);
        self.leg_kin = scratch;
        geometry
    }

    /// The geometry of contact `k` at `y = [q; q̇]`.
    pub fn geometry(&mut self, k: usize, y: &[f64]) -> ContactGeometry {
        let (q, qd) = y.split_at(self.model.nq());
        let (model, terrain) = (self.model, self.terrain);
        contact_geometry(model, self.kinematics(q, qd), terrain, k)
    }
}

/// A workspace the flow is evaluated on: the core's, with the controller's joint torques
/// `Υ` and the prescribed accelerations of the free massless joints.
#[derive(Debug, Clone)]
pub struct FlowWorkspace {
    pub data: Data,
    pub tau: Vec<f64>,
    pub free: Vec<f64>,
    /// The contacts that can slide damped ([`crate::damped_slide::damped_contacts`]).
    pub damped: u32,
    /// The contacts a reset kept sticking because their damped slide is wedged on both
    /// sides (`reset::wedged_holds`).
    pub wedged: Vec<usize>,
    /// The buffers of the chain laws ([`crate::damped_slide::set_laws`]).
    pub(crate) laws: crate::damped_slide::LawScratch,
}

impl FlowWorkspace {
    pub fn new(model: &Model) -> Self {
        // a sliding toe at rest takes a cone edge: one that the cone holds sticks, in a mode
        // of its own (the resets' complementarity), never held inside a sliding mode
        let mut data = Data::new(model);
        data.slide_at_rest = true;
        FlowWorkspace {
            data,
            tau: vec![0.0; model.n_joints()],
            free: Vec::new(),
            damped: crate::damped_slide::damped_contacts(model),
            wedged: Vec::new(),
            laws: Default::default(),
        }
    }

    /// Prepares `data` for the flow of `mode` at `(t, q, q̇)` under `ctrl`: the chain laws of
    /// its damped slides ([`crate::damped_slide::set_laws`]), then every stage of the core's
    /// [`Data::prepare`].
    #[inline]
    pub fn prepare(
        &mut self,
        model: &Model,
        terrain: &dyn Terrain,
        ctrl: &dyn Controller,
        (t, mode): (f64, ContactMode),
        q: &[f64],
        qd: &[f64],
    ) -> Result<(), CoreError> {
        self.set_laws(model, ctrl, (t, mode), q, qd);
        self.data.prepare(model, terrain, mode, q, qd)
    }

    /// The chain laws of `mode`'s damped slides at `(t, q, q̇)`
    /// ([`crate::damped_slide::set_laws`]).
    #[inline]
    fn set_laws(
        &mut self,
        model: &Model,
        ctrl: &dyn Controller,
        (t, mode): (f64, ContactMode),
        q: &[f64],
        qd: &[f64],
    ) {
        if self.damped != 0 {
            crate::damped_slide::set_laws(
                model,
                &mut self.data,
                (self.damped, false),
                ctrl,
                (t, q, qd),
                mode,
                &mut self.laws,
            );
        }
    }

    /// The flow (5.48) of `mode` at `(t, q, q̇)`, `data` prepared there: the controller's
    /// torques `Υ` into `tau` and its free-joint accelerations into `free`, then (5.3)–(5.4)
    /// into `data.qdd`, `data.lambda`. Shared by [`Flow`] and by the resets, which need the
    /// forces of candidate modes (5.19)–(5.20) on a workspace of their own. Joints locked in
    /// `data` ([`selfmanip_core::Data::locked`]) get `q̈ = 0`.
    pub fn solve_prepared(
        &mut self,
        model: &Model,
        ctrl: &dyn Controller,
        t: f64,
        mode: ContactMode,
        q: &[f64],
        qd: &[f64],
    ) -> Result<(), CoreError> {
        // (t, q, q̇) => Υ, and the free joints' prescribed q̈ (which joints are free is known
        // after `prepare`)
        self.tau.resize(model.n_joints(), 0.0);
        ctrl.torque(t, q, qd, mode, &mut self.tau);
        self.free.resize(self.data.free_joints.len(), 0.0);
        if !self.free.is_empty() {
            ctrl.free_joint_qdd(t, q, qd, &self.data.free_joints, &mut self.free);
        }
        // locked joints turn at constant speed
        if !self.data.locked.is_empty() {
            for (x, j) in self.free.iter_mut().zip(&self.data.free_joints) {
                if self.data.locked.contains(j) {
                    *x = 0.0;
                }
            }
        }
        // (Υ − C̄q̇ − N̄, −Ȧq̇) => (q̈, λ)
        forward_dynamics_prepared(model, &mut self.data, &self.tau, Some(&self.free))
    }
}

/// Tangential velocity `t · v` of the material point of contact `k` at its contact point
/// (the sliding velocity; zero while it sticks or rolls).
pub fn sliding_velocity(model: &Model, kin: &Kinematics, terrain: &dyn Terrain, k: usize) -> f64 {
    let geom = contact_geometry(model, kin, terrain, k);
    kin.material_velocity(geom.part, geom.point)
        .dot(&geom.plane.tangent())
}
