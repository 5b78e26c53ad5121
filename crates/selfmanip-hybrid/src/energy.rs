//! Energy bookkeeping of an execution: the total energy $E = T + V_g + V_s$ (thesis (4.24),
//! with the passive joint springs' energy, `selfmanip_core::dynamics::potential_energy`) at
//! its start and end, the work of the joint torques along the flow, the work of the passive
//! dampers (never positive), the work of the kinetic friction of sliding sites
//! (`selfmanip_core::friction`, never positive), and the kinetic energy lost in its impacts.
//! A correct execution balances,
//! $$ E_1 - E_0 = W + W_d + W_{fr} - L, \qquad W = \int \tau \cdot \dot\theta \ dt, \qquad
//!    W_d = -\int \textstyle\sum_j c_j \dot\theta_j^2 \ dt \le 0, \qquad
//!    W_{fr} = \int f^{fr} \cdot \dot q \ dt \le 0, \qquad L = \sum (T^- - T^+) \ge 0 . $$
//! The spring torques `−∂V_s/∂θ` are inside `V_s`, so `W` is the work of what drives the
//! joints: the actuators' torques; at a free massless joint, whose motion is prescribed
//! (thesis 5.1.1), the torque `−τ^p_j` that moves it against its own spring–damper (zero
//! without one); at a joint locked for a fold passage, the torque that holds it.
use crate::error::HybridError;
use crate::execution::Execution;
use crate::flow::Flow;
use selfmanip_core::dynamics::potential_energy;
use selfmanip_core::passive::{damping_power, spring_torque};
use selfmanip_core::{kinetic_energy, ContactMode, CoreError, Data, Model, Terrain};

/// The energy balance of an execution (J).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct EnergyReport {
    pub initial_j: f64,
    pub final_j: f64,
    /// `∫ τ·θ̇ dt` over the joints in the dynamics (free massless joints carry no load; a
    /// joint locked for a fold passage does the work of the torque that holds it).
    pub joint_work_j: f64,
    /// `−∫ Σ c_j θ̇_j² dt`, the work of the joints' passive dampers (never positive).
    pub damping_work_j: f64,
    /// `∫ f^fr·q̇ dt`, the work of the sliding sites' kinetic friction (never positive).
    pub friction_work_j: f64,
    /// `Σ (T⁻ − T⁺)` over the impulsive events (touchdowns and folds).
    pub impact_loss_j: f64,
}

impl EnergyReport {
    /// `E₁ − E₀ − W − W_d − W_fr + L`.
    pub fn residual_j(&self) -> f64 {
        self.final_j
            - self.initial_j
            - self.joint_work_j
            - self.damping_work_j
            - self.friction_work_j
            + self.impact_loss_j
    }
}

/// `T = ½ q̇ᵀ M̄ q̇` at `(q, q̇)`. `M̄` does not depend on the contacts, so the flight mode is
/// prepared; its KKT may be singular (free massless legs), which does not matter here.
pub fn kinetic_energy_at(
    model: &Model,
    terrain: &dyn Terrain,
    data: &mut Data,
    q: &[f64],
    qd: &[f64],
) -> Result<f64, CoreError> {
    data.prepare_geometry(model, terrain, ContactMode::FLIGHT, q, qd)?;
    Ok(kinetic_energy(data, qd))
}

/// The [`EnergyReport`] of `exec`, a run of `model` on `terrain`: each segment's torques and
/// friction forces re-evaluated with the controller, locks and sliding directions it ran
/// with, on each step's dense output, by 3-point Gauss–Legendre quadrature (exact to the
/// interpolant's order).
pub fn energy_report(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
) -> Result<EnergyReport, HybridError> {
    let nq = model.nq();
    let (q0, qd0) = exec.segments[0].y0.split_at(nq);
    let mut data = Data::new(model);
    let total = |data: &mut Data, q: &[f64], qd: &[f64]| -> Result<f64, CoreError> {
        let t = kinetic_energy_at(model, terrain, data, q, qd)?;
        Ok(t + potential_energy(model, &data.kin, q))
    };
    let initial_j = total(&mut data, q0, qd0)?;
    let final_j = total(&mut data, &exec.q, &exec.qd)?;
    let nodes = [
        (0.5 - 0.5 * (0.6f64).sqrt(), 5.0 / 18.0),
        (0.5, 8.0 / 18.0),
        (0.5 + 0.5 * (0.6f64).sqrt(), 5.0 / 18.0),
    ];
    let mut flow = Flow::new(model, terrain, exec.segments[0].controller.clone());
    let mut y = vec![0.0; 2 * nq];
    let mut joint_work_j = 0.0;
    let mut damping_work_j = 0.0;
    let mut friction_work_j = 0.0;
    for seg in &exec.segments {
        flow.set_controller(seg.controller.clone());
        flow.set_lock(&seg.locked);
        flow.set_slide_directions(&seg.slide_directions);
        for step in seg.dense.steps() {
            let (a, b) = (step.t0, step.t1().min(seg.t1));
            if b <= a {
                continue;
            }
            for &(x, w) in &nodes {
                let t = a + x * (b - a);
                step.eval(t, &mut y);
                let (q, qd) = y.split_at(nq);
                flow.eval(t, seg.mode, q, qd)?;
                let (data, tau) = flow.last();
                // the spring–damper's torque τ^p_j (0 without one)
                let passive = |j: usize| {
                    model.joints[j]
                        .spring
                        .map_or(0.0, |s| spring_torque(&s, q[j], qd[j]))
                };
                let power: f64 = (0..model.n_joints())
                    .map(
                        |j| match (data.free_joints.contains(&j), data.locked.contains(&j)) {
                            // locked (a fold passage, a damped slide): held by the torque
                            // that balances its contact, friction and spring,
                            // (Aᵀλ)_j − f^fr_j − τ^p_j (its row of (5.3), M̄_j = 0)
                            (true, true) => {
                                (data.constraints.a.column(j).dot(&data.lambda)
                                    - data.friction[j]
                                    - passive(j))
                                    * qd[j]
                            }
                            // free: carries no load; its prescribed motion works against its
                            // own spring–damper only
                            (true, false) => -passive(j) * qd[j],
                            _ => tau[j] * qd[j],
                        },
                    )
                    .sum();
                joint_work_j += w * (b - a) * power;
                damping_work_j += w * (b - a) * damping_power(model, qd);
                let friction: f64 = data.friction.iter().zip(qd).map(|(f, v)| f * v).sum();
                friction_work_j += w * (b - a) * friction;
            }
        }
    }
    Ok(EnergyReport {
        initial_j,
        final_j,
        joint_work_j,
        damping_work_j,
        friction_work_j,
        impact_loss_j: exec.impact_losses().iter().sum(),
    })
}
