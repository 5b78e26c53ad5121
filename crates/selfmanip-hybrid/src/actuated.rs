//! Joint torques from actuator models: a [`CommandPolicy`] decides a normalized command
//! `u ∈ [−1, 1]` per joint (open-loop strategies, PD trackers, …) and each joint's
//! [`motor::Actuator`] turns it into torque at the joint's current speed — a saturated
//! torque source (`τ_s` of Table 4.2) or a current-limited geared DC motor (thesis section
//! 2.1.2, `motor::Drive`). Joint `k` is generalized coordinate `q[k]` (joints come first).
use crate::controller::Controller;
use motor::Actuator;
use selfmanip_core::ContactMode;
use std::sync::Arc;

/// Decides the normalized joint commands.
pub trait CommandPolicy {
    /// Fills `u` (one entry per joint, in `[−1, 1]`; values outside are clipped by the
    /// actuators).
    fn command(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode, u: &mut [f64]);
}

/// A controller whose torques come from per-joint actuator models.
#[derive(Clone)]
pub struct Actuated<P> {
    pub policy: P,
    /// One actuator per joint, in joint order.
    pub actuators: Vec<Arc<dyn Actuator>>,
}

impl<P: CommandPolicy> Actuated<P> {
    pub fn new(policy: P, actuators: Vec<Arc<dyn Actuator>>) -> Self {
        Self { policy, actuators }
    }

    /// Power drawn from the supplies at this state (for the energy bookkeeping of an
    /// execution: motor work is the integral of the mechanical part `τ·q̇_joint`).
    pub fn electrical_power_w(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode) -> f64 {
        let mut u = vec![0.0; self.actuators.len()];
        self.policy.command(t, q, qd, mode, &mut u);
        self.actuators
            .iter()
            .zip(&u)
            .enumerate()
            .map(|(k, (a, &uk))| a.electrical_power_w(uk, qd[k]))
            .sum()
    }
}

impl<P: CommandPolicy + Clone + Send + Sync + 'static> Controller for Actuated<P> {
    fn torque(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode, tau: &mut [f64]) {
        debug_assert_eq!(tau.len(), self.actuators.len());
        // the commands are written into `tau` first, then replaced by the torques
        self.policy.command(t, q, qd, mode, tau);
        for (k, (a, slot)) in self.actuators.iter().zip(tau.iter_mut()).enumerate() {
            *slot = a.joint_torque_n_m(*slot, qd[k]);
        }
    }
}
