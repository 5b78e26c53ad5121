//! What drives the joints: the [`Controller`] an execution asks for joint torques `Υ` along
//! every flow (5.48) and at every impact's pseudo-impulse (5.39), and for the prescribed
//! motion of free massless joints (thesis 5.1.1).
//!
//! A controller may remember the contact history (a leg that retracts once it has lifted
//! off): it is told of every event through [`Controller::on_event`]. Its memory is part of
//! the hybrid state, so the engine treats it as such: a run works on its own copy (the
//! controller given to [`crate::simulate()`] is left as it was, ready for the next run), and
//! every segment records the controller it ran with ([`crate::Segment::controller`]), so a
//! segment can be evaluated again later — trajectories, contact forces, energy — exactly as
//! it ran, without replaying the execution. For the sensitivities
//! ([`crate::sensitivity`]), a controller whose outputs depend on the time or state of an
//! event beyond the event itself says so ([`Controller::has_event_memory`]) and gives the
//! partials of its outputs with respect to them ([`Controller::memory_partials`],
//! [`Controller::memory_time_events`]).
use crate::event::Event;
use nalgebra::DMatrix;
use selfmanip_core::tangent::StatePartials;
use selfmanip_core::ContactMode;
use std::sync::Arc;

/// Where a [`Controller`] is asked for the partials of its outputs (for the sensitivities):
/// the time, the state `(q, q̇)`, the contact mode and the free massless joints whose
/// accelerations it prescribes (thesis 5.1.1). The outputs themselves —
/// [`Controller::torque`], asked at every evaluation of the flow, and
/// [`Controller::partials_piece`], at every sub-step of a tangent — take the parts as
/// arguments, which pass in registers (a point by reference stores and reloads every field
/// on that hot path); the free joints' law, [`Controller::free_joint_qdd`], depends on
/// neither the mode nor the torques' branch and takes `(t, q, q̇)` alone.
#[derive(Debug, Clone, Copy)]
pub struct ControlPoint<'a> {
    pub t: f64,
    pub q: &'a [f64],
    pub qd: &'a [f64],
    pub mode: ContactMode,
    /// The free joints, in the order of the rows of `q̈_free` and of its partials.
    pub free_joints: &'a [usize],
}

impl<'a> ControlPoint<'a> {
    /// The point `(t, q, q̇)` in `mode`, with no free joints.
    pub fn new(t: f64, q: &'a [f64], qd: &'a [f64], mode: ContactMode) -> Self {
        ControlPoint {
            t,
            q,
            qd,
            mode,
            free_joints: &[],
        }
    }

    /// The same point with the free joints `free_joints`.
    pub fn with_free_joints(self, free_joints: &'a [usize]) -> Self {
        ControlPoint {
            free_joints,
            ..self
        }
    }
}

/// Joint torques (and the motion of free massless joints) as functions of time and state.
/// Implement it for a `Clone` type: [`ControllerClone`] comes with it. The partials are
/// asked at a [`ControlPoint`]; a law ignores the parts it does not depend on.
pub trait Controller: ControllerClone + Send + Sync {
    fn torque(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode, tau: &mut [f64]);
    /// The torques of `joints` at least (the entries of `tau` in that range; any other entry
    /// may be written too), the same numbers as [`Self::torque`]'s: what a damped slide asks
    /// for its chain several times per evaluation. By default [`Self::torque`]; a controller
    /// whose joints' laws are independent computes only those.
    fn torque_of(
        &self,
        t: f64,
        (q, qd): (&[f64], &[f64]),
        mode: ContactMode,
        joints: std::ops::Range<usize>,
        tau: &mut [f64],
    ) {
        let _ = joints;
        self.torque(t, q, qd, mode, tau);
    }
    /// Prescribed accelerations of free massless joints (thesis 5.1.1); default 0.
    fn free_joint_qdd(
        &self,
        _t: f64,
        _q: &[f64],
        _qd: &[f64],
        _free_joints: &[usize],
        out: &mut [f64],
    ) {
        out.fill(0.0);
    }
    /// Called after every reset with the event just applied (for controllers whose phase
    /// depends on the contact history); not for an apex recorded on the way (a run that does
    /// not stop there), which changes nothing.
    fn on_event(&mut self, _event: &Event) {}
    /// The partial derivatives of [`Self::torque`] and [`Self::free_joint_qdd`] at the point
    /// `at`, written into `out` (which arrives zeroed and sized), for the sensitivities
    /// of [`crate::sensitivity`]. Returns whether the controller provides them: the default
    /// does not, and a sensitivity run then stops with a typed error rather than guess.
    fn partials(&self, _at: &ControlPoint, _out: &mut ControllerPartials) -> bool {
        false
    }
    /// The partial derivatives of [`Self::torque`] and [`Self::free_joint_qdd`] with respect
    /// to the controller's named parameters `names` (e.g. a motor's start time or gear
    /// ratio), written into column `k` of `out.dtau_dp` / `out.dfree_dp` for `names[k]` (they
    /// arrive zeroed, sized `n × names.len()` and `n_free × names.len()`). Returns whether
    /// the controller knows every name: the default knows none (and accepts an empty list).
    fn parameter_partials(
        &self,
        _at: &ControlPoint,
        names: &[&str],
        _out: &mut ControllerPartials,
    ) -> bool {
        names.is_empty()
    }
    /// The controller's **time events**: instants at which its outputs may jump as a function
    /// of time alone (a motor that switches on at `t2`), each with `dt_b/dp` for every name of
    /// `names` (0 for a parameter the instant does not depend on). The sensitivities add
    /// `(f⁻ − f⁺) dt_b/dp` there; the default has none.
    fn time_events(&self, _names: &[&str]) -> Vec<TimeEvent> {
        Vec::new()
    }
    /// `∂Υ/∂t` at a fixed state — the explicit time dependence of [`Self::torque`] (a servo
    /// that tracks a motion, a torque schedule's ramp) — written into `dtau_dt` (zeroed, one
    /// entry per joint). Returns whether the controller provides it; the default does not,
    /// and the sensitivities then take it by a central difference of [`Self::torque`] in
    /// time at the fixed state. It enters where a guard depends on the
    /// torques: a force event's (liftoff, slip) rate along the flow is
    /// `ġ = D_xg f⁻ + ∂g/∂t`, with `∂g/∂t` from `∂λ/∂Υ ∂Υ/∂t`.
    fn time_partials(&self, _at: &ControlPoint, _dtau_dt: &mut [f64]) -> bool {
        false
    }
    /// Whether the controller's outputs depend on the time or the state of an event it was
    /// told of ([`Self::on_event`]) beyond the event itself — a motion started from the
    /// event's state, a phase that starts a delay after the event: **event memory**. Default
    /// `false` (outputs that depend on the state and on which events happened only). The
    /// sensitivities of [`crate::sensitivity`] then carry the remembered events' tangents
    /// and need [`Self::memory_partials`] and [`Self::memory_time_events`]; a controller that
    /// says it has event memory but gives no partials stops them with a typed error
    /// (`SensitivityError::EventMemoryWithoutPartials`) rather than hold the memory fixed.
    fn has_event_memory(&self) -> bool {
        false
    }
    /// The partial derivatives of [`Self::torque`] and [`Self::free_joint_qdd`] at the same
    /// arguments with respect to the events the controller remembers, one
    /// [`EventMemoryPartials`] per remembered event that they depend on, appended to `out`
    /// (which arrives empty). Events are numbered by the order the controller was told of
    /// them (0: the first [`Self::on_event`]); each event's memory is `(t_k, q_k, q̇_k⁺)`, the
    /// event's time and the state after its reset (the arguments of [`Self::on_event`]).
    /// Returns whether the controller provides them: the default does when it has no event
    /// memory ([`Self::has_event_memory`]).
    fn memory_partials(&self, _at: &ControlPoint, _out: &mut Vec<EventMemoryPartials>) -> bool {
        !self.has_event_memory()
    }
    /// Which smooth piece of its law the outputs lie on at `(t, q, q̇)` in `mode` — a
    /// servo's linear range or either side of its saturation, a motor's torque–speed line or
    /// its current limit — as a number that changes exactly where [`Self::partials`]
    /// switch branch. The outputs are continuous there (a **kink**), their partials are not.
    /// The sensitivities split the tangent's steps at every change
    /// ([`crate::sensitivity`]): a step that straddles a kink integrates the variational
    /// equation only to first order in the step (the kink's place in the step moves with the
    /// initial state), which left the derivatives of leaps whose servo leaves its saturation
    /// in stance 1e-5 … 1e-4 off. Default 0: one smooth piece (a controller whose partials
    /// switch without saying so is differentiated across the switch to that accuracy).
    fn partials_piece(&self, _t: f64, _q: &[f64], _qd: &[f64], _mode: ContactMode) -> u64 {
        0
    }
    /// The time events ([`Self::time_events`]) whose instants depend on remembered events
    /// (a phase that starts `δ` after the touchdown that started another: `t_b = t_k + δ`),
    /// each with `dt_b/d(t_k, q_k, q̇_k⁺)`; an instant that coincides with its event's own
    /// time is the event (its saltation accounts for it) and is not listed. Default none.
    fn memory_time_events(&self) -> Vec<MemoryTimeEvent> {
        Vec::new()
    }
}

/// `∂Υ/∂m_k` and `∂q̈_free/∂m_k` of one remembered event `k`, `m_k = (t_k, q_k, q̇_k⁺)`
/// ([`Controller::memory_partials`]).
#[derive(Debug, Clone, PartialEq)]
pub struct EventMemoryPartials {
    /// The event's number among those the controller was told of (0: the first).
    pub event: usize,
    /// `∂Υ/∂m_k`, `n × (1 + 2nq)` (column 0 the event's time, then `q_k`, then `q̇_k⁺`).
    pub dtau: DMatrix<f64>,
    /// `∂q̈_free/∂m_k`, `n_free × (1 + 2nq)` (free joints in the order given).
    pub dfree: DMatrix<f64>,
}

/// A time event whose instant depends on a remembered event ([`Controller::memory_time_events`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MemoryTimeEvent {
    pub t: f64,
    /// The event's number among those the controller was told of.
    pub event: usize,
    /// `dt_b/d(t_k, q_k, q̇_k⁺)`, `1 + 2nq` entries.
    pub dt_dm: Vec<f64>,
}

/// An instant at which a controller's outputs may jump in time ([`Controller::time_events`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TimeEvent {
    pub t: f64,
    /// `dt_b/dp`, one entry per parameter name asked for.
    pub dt_dp: Vec<f64>,
}

/// Partial derivatives of a controller's outputs over the state ([`Controller::partials`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerPartials {
    /// `∂Υ/∂q`, `∂Υ/∂q̇` (`n × nq`).
    pub dtau: StatePartials,
    /// `∂q̈_free/∂q`, `∂q̈_free/∂q̇` (one row per free joint, in the order given).
    pub dfree: StatePartials,
    /// `∂Υ/∂p` (`n × k`) and `∂q̈_free/∂p` (`n_free × k`) over the named parameters of
    /// [`Controller::parameter_partials`]; no columns unless [`Self::with_parameters`].
    pub dtau_dp: DMatrix<f64>,
    pub dfree_dp: DMatrix<f64>,
}

impl ControllerPartials {
    /// Zero partials for `n` joints, `nq` coordinates and `n_free` free joints.
    pub fn zeros(n: usize, nq: usize, n_free: usize) -> Self {
        ControllerPartials {
            dtau: StatePartials::zeros(n, nq),
            dfree: StatePartials::zeros(n_free, nq),
            dtau_dp: DMatrix::zeros(n, 0),
            dfree_dp: DMatrix::zeros(n_free, 0),
        }
    }

    /// [`Self::zeros`] with `k` zero parameter columns.
    pub fn with_parameters(n: usize, nq: usize, n_free: usize, k: usize) -> Self {
        ControllerPartials {
            dtau_dp: DMatrix::zeros(n, k),
            dfree_dp: DMatrix::zeros(n_free, k),
            ..Self::zeros(n, nq, n_free)
        }
    }
}

/// A copy of a controller in its current state, boxed or shared (implemented for every
/// `Clone` controller).
pub trait ControllerClone {
    fn clone_box(&self) -> Box<dyn Controller>;
    /// The copy in an `Arc` of its own (no other owner): what an execution records in its
    /// segments, made in place rather than moved out of a box.
    fn clone_shared(&self) -> Arc<dyn Controller>;
}

impl<T: Controller + Clone + 'static> ControllerClone for T {
    fn clone_box(&self) -> Box<dyn Controller> {
        Box::new(self.clone())
    }
    fn clone_shared(&self) -> Arc<dyn Controller> {
        Arc::new(self.clone())
    }
}

impl std::fmt::Debug for dyn Controller {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("dyn Controller")
    }
}

/// No actuation: [`ConstantTorque`] with no torques (`Υ = 0`, partials zero, no named
/// parameters).
#[allow(non_upper_case_globals)]
pub const ZeroTorque: ConstantTorque = ConstantTorque {
    torques_n_m: Vec::new(),
};

/// Constant joint torques: `Υ_j = torques_n_m[j]`, 0 at the joints past the list's end. Its
/// partials over the state vanish, and each torque of the list is a named parameter,
/// `"tau[j]"` for joint `j` (`∂Υ_j/∂tau[j] = 1`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ConstantTorque {
    pub torques_n_m: Vec<f64>,
}

impl ConstantTorque {
    /// `tau_n_m` at joint 0, none at the others.
    pub fn first_joint(tau_n_m: f64) -> Self {
        ConstantTorque {
            torques_n_m: vec![tau_n_m],
        }
    }

    /// The joint whose torque `name` is (`"tau[j]"`), if it is one of this controller's.
    fn joint_of(&self, name: &str) -> Option<usize> {
        let j = name.strip_prefix("tau[")?.strip_suffix(']')?.parse().ok()?;
        (j < self.torques_n_m.len()).then_some(j)
    }
}

impl Controller for ConstantTorque {
    fn torque(&self, _t: f64, _q: &[f64], _qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        let k = self.torques_n_m.len().min(tau.len());
        tau[..k].copy_from_slice(&self.torques_n_m[..k]);
        tau[k..].fill(0.0);
    }
    fn partials(&self, _at: &ControlPoint, _out: &mut ControllerPartials) -> bool {
        true
    }
    fn parameter_partials(
        &self,
        _at: &ControlPoint,
        names: &[&str],
        out: &mut ControllerPartials,
    ) -> bool {
        for (k, name) in names.iter().enumerate() {
            match self.joint_of(name) {
                Some(j) if j < out.dtau_dp.nrows() => out.dtau_dp[(j, k)] = 1.0,
                _ => return false,
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The torques land on their joints and zero the rest; each `"tau[j]"` moves only its
    /// own joint's torque, one for one; a name that is not one of its torques is refused.
    #[test]
    fn constant_torque_parameters_are_its_torques() {
        let c = ConstantTorque {
            torques_n_m: vec![1.5, -2.0],
        };
        let at = ControlPoint::new(0.0, &[], &[], ContactMode::FLIGHT);
        let mut tau = [9.0; 3];
        c.torque(0.0, &[], &[], ContactMode::FLIGHT, &mut tau);
        assert_eq!(tau, [1.5, -2.0, 0.0]);
        let mut out = ControllerPartials::with_parameters(3, 4, 0, 2);
        assert!(c.partials(&at, &mut out));
        assert!(c.parameter_partials(&at, &["tau[1]", "tau[0]"], &mut out));
        let expected = DMatrix::from_row_slice(3, 2, &[0.0, 1.0, 1.0, 0.0, 0.0, 0.0]);
        assert_eq!(out.dtau_dp, expected);
        for name in ["tau[2]", "tau", "tau[x]", "k"] {
            let mut out = ControllerPartials::with_parameters(3, 4, 0, 1);
            let known = c.parameter_partials(&at, &[name], &mut out);
            assert!(!known, "{name}");
        }
    }
}
