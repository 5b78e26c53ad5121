//! What drives the joints: the [`Controller`] an execution asks for joint torques `Υ` along
//! every flow (5.48) and at every impact's pseudo-impulse (5.39), and for the prescribed
//! motion of free massless joints (thesis 5.1.1).
use crate::execution::Event;
use selfmanip_core::ContactMode;

/// Joint torques (and the motion of free massless joints) as functions of time and state.
pub trait Controller {
    fn torque(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode, tau: &mut [f64]);
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
    /// depends on the contact history, e.g. a leg that retracts once it has lifted off).
    fn on_event(&self, _event: &Event) {}
}

/// No actuation.
#[derive(Debug, Clone, Copy, Default)]
pub struct ZeroTorque;

impl Controller for ZeroTorque {
    fn torque(&self, _t: f64, _q: &[f64], _qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        tau.fill(0.0);
    }
}
