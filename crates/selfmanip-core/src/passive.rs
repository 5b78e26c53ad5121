//! Passive joint springs and dampers, and the KKT system of a compliant **massless** leg.
//!
//! A joint may carry a torsional spring–damper ([`JointSpring`], described per link in
//! [`crate::description::SpringDescription`]). With `d = θ_j − θ_j⁰` it applies
//!
//! $$ \tau_j^{p}(\theta_j, \dot\theta_j) = -k\,d - k_3\,d^3 - c\,\dot\theta_j , $$
//!
//! the gradient of the spring energy $V_s = \tfrac12 k d^2 + \tfrac14 k_3 d^4$ plus viscous
//! damping ($k, k_3, c \ge 0$). It is a generalized force like gravity: [`add_passive_bias`]
//! subtracts it from $\bar N$ right where $\bar N$ is built (`Data::prepare`), so it enters the
//! flow (5.3)–(5.4), the pseudo-impulse (5.39) and the reduced dynamics through the same
//! $\Upsilon - \bar C\dot q - \bar N$, with no other change (the plastic impact (5.10) involves
//! no force). [`potential_energy`] and [`power`] complete the energy balance
//! $\dot E = \tau\cdot\dot\theta + \sum_j \tau^p_j\dot\theta_j + \dot V_s$, i.e.
//! $\tfrac{d}{dt}(T + V_g + V_s) = \tau\cdot\dot\theta - \sum_j c_j\dot\theta_j^2$ for
//! workless contacts.
//!
//! # A massless spring joint in contact
//!
//! Let a leg be a chain of **massless** links with joint coordinates $\theta_\ell$ (an actuated
//! hip, passive spring joints), touching the ground at one site with constraint rows
//! $A = [A_\ell \;\; A_b]$ (columns: the leg's joints, the rest of $q$). Because the leg's
//! rows of $\bar M$, $\bar C\dot q$ and gravity are zero, the leg's rows of the KKT system
//! $\bar M\ddot q + A^{\mathsf T}\lambda = \Upsilon - \bar C\dot q - \bar N$ (thesis (5.2)) read
//!
//! $$ A_\ell^{\mathsf T}\lambda = \tau_\ell + \tau_\ell^{p}(\theta_\ell, \dot\theta_\ell) , $$
//!
//! statics of the massless chain: the joint torques alone fix the ground force. With the toe
//! **sticking** (two rows) on a two-joint leg, $A_\ell = -J_\ell$ is the $2\times2$ toe
//! Jacobian, and
//!
//! $$ \lambda = -J_\ell^{-\mathsf T}\,(\tau_\ell + \tau^p_\ell), \qquad
//!    \dot\theta_\ell = -A_\ell^{-1} A_b\,\dot q_b , $$
//!
//! so the contact and the spring determine the massless coordinates (their rates follow the
//! body through the closed chain, their angles the body pose and the toe's place) and the
//! force (through the chain's statics). The rank condition of Lemma 5.1 is exactly
//! $\det J_\ell \neq 0$: hip, knee and toe not collinear (the leg neither straight nor folded
//! flat). Then every motion the contact allows moves the body, whose kinetic energy is
//! positive, so $\tilde M$ is positive definite and the KKT matrix is regular. For a leg
//! with one massless joint (a rigid leg) the same reading gives the thesis's
//! $\lambda_n = \tau / (A_n)_\theta$ of a sliding toe.
//!
//! A **sliding** toe has a single (normal) row. On a leg with two massless joints
//! $A_\ell$ is $1\times 2$: the chain has a motion along the ground that changes no
//! constraint and moves no mass — $\tilde M$ is singular and the KKT matrix is not invertible
//! (Lemma 5.1 fails). A compliant massless leg can therefore carry a sticking toe, not a
//! sliding one; and in the air (no contact) the joints of a massless chain are free massless
//! joints (thesis 5.1.1, footnote 3): the spring cannot load a chain with no inertia, so the
//! joint relaxes to its rest angle — instantly without damping, as $c\dot d = -k d - k_3 d^3$
//! with it. The engine prescribes free massless joints through the controller;
//! [`relaxation_qdd`] is a stiff, critically damped return to rest for that purpose.
use crate::model::{JointSpring, Model};
use nalgebra::DVector;

/// `τ = −k d − k₃ d³ − c q̇` with `d = q − rest`.
#[inline]
pub fn spring_torque(spring: &JointSpring, q: f64, qd: f64) -> f64 {
    let d = q - spring.rest_angle_rad;
    -spring.stiffness_n_m_per_rad * d
        - spring.cubic_stiffness_n_m_per_rad3 * d * d * d
        - spring.damping_n_m_s_per_rad * qd
}

/// The passive torques as part of the bias: `N̄_j −= τ_j^p` for every sprung joint, so that
/// `Υ − C̄q̇ − N̄` includes them.
#[inline]
pub fn add_passive_bias(model: &Model, q: &[f64], qd: &[f64], n_bar: &mut DVector<f64>) {
    for (j, joint) in model.joints.iter().enumerate() {
        if let Some(s) = &joint.spring {
            n_bar[j] -= spring_torque(s, q[j], qd[j]);
        }
    }
}

/// Passive torque of joint `j` at `(q, q̇)` (zero where there is no spring).
#[inline]
pub fn joint_torque(model: &Model, j: usize, q: &[f64], qd: &[f64]) -> f64 {
    model.joints[j]
        .spring
        .map_or(0.0, |s| spring_torque(&s, q[j], qd[j]))
}

/// Passive torque of every joint ([`joint_torque`]).
pub fn joint_torques(model: &Model, q: &[f64], qd: &[f64]) -> Vec<f64> {
    (0..model.joints.len())
        .map(|j| joint_torque(model, j, q, qd))
        .collect()
}

/// Spring energy `V_s = Σ ½ k d² + ¼ k₃ d⁴` (J).
pub fn potential_energy(model: &Model, q: &[f64]) -> f64 {
    model
        .joints
        .iter()
        .enumerate()
        .filter_map(|(j, joint)| joint.spring.map(|s| (s, q[j] - s.rest_angle_rad)))
        .map(|(s, d)| {
            0.5 * s.stiffness_n_m_per_rad * d * d
                + 0.25 * s.cubic_stiffness_n_m_per_rad3 * d * d * d * d
        })
        .sum()
}

/// Power of the dampers `−Σ c_j q̇_j²` (W, never positive): with [`potential_energy`], the
/// part of [`power`] that is not `−dV_s/dt`.
pub fn damping_power(model: &Model, qd: &[f64]) -> f64 {
    model
        .joints
        .iter()
        .zip(qd)
        .filter_map(|(joint, v)| joint.spring.map(|s| -s.damping_n_m_s_per_rad * v * v))
        .sum()
}

/// Power of the passive torques `Σ τ_j^p q̇_j` (W): `−dV_s/dt − Σ c q̇²`.
pub fn power(model: &Model, q: &[f64], qd: &[f64]) -> f64 {
    joint_torques(model, q, qd)
        .iter()
        .zip(qd)
        .map(|(t, v)| t * v)
        .sum()
}

/// A stiff, critically damped return of a free massless sprung joint to its rest angle,
/// `θ̈ = −ω² d − 2ω θ̇` (rate `ω` in rad/s): what a controller may prescribe for such a
/// joint in the air, where a massless spring has nothing to load and relaxes (module docs).
pub fn relaxation_qdd(spring: &JointSpring, q: f64, qd: f64, omega_rad_s: f64) -> f64 {
    -omega_rad_s * omega_rad_s * (q - spring.rest_angle_rad) - 2.0 * omega_rad_s * qd
}
