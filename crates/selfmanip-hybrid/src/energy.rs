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
//! without one); at a joint locked for a fold passage, the torque that holds it; at a joint
//! of a chain that slides damped (`selfmanip_core::damped_slide`), its actuator's torque
//! (the foot's force, applied as `−Aᵀλ`, is in `f^fr`: its power is the friction's,
//! `−λ_t u_t = μ_k λ_n |u_t| ≤ 0`). A general site that a Zeno truncation's dwell holds
//! sliding while its normal force pulls slides without friction, from the instant its force
//! comes to pull to the dwell's end (`selfmanip_core::friction`, "A contact that pulls"), so
//! `W_fr` has no positive part there.
use crate::error::HybridError;
use crate::execution::Execution;
use crate::flow::Flow;
use selfmanip_core::dynamics::potential_energy;
use selfmanip_core::passive::{damping_power, joint_torque};
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
/// with, on each step's dense output, by adaptive 3-point Gauss–Legendre quadrature
/// ([`adaptive_gauss`]): exact to the interpolant's order where the powers are smooth, and
/// converged where they are not inside a step (a torque limit reached, a servo's target
/// switching, a sliding foot's friction), to [`QUADRATURE_TOL_J`] per step.
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
    let mut flow = Flow::new(model, terrain, exec.segments[0].controller.clone());
    let mut y = vec![0.0; 2 * nq];
    // joint, damping and friction work
    let mut work = [0.0; 3];
    for seg in &exec.segments {
        flow.set_controller(seg.controller.clone());
        flow.set_lock(&seg.locked);
        flow.set_slide_directions(&seg.slide_directions);
        for step in seg.dense.steps() {
            let (a, b) = (step.t0, step.t1().min(seg.t1));
            if b <= a {
                continue;
            }
            let mut powers = |t: f64| -> Result<[f64; 3], CoreError> {
                step.eval(t, &mut y);
                powers_at(model, &mut flow, seg.mode, t, &y)
            };
            let w = adaptive_gauss(&mut powers, a, b)?;
            for (acc, x) in work.iter_mut().zip(w) {
                *acc += x;
            }
        }
    }
    let [joint_work_j, damping_work_j, friction_work_j] = work;
    Ok(EnergyReport {
        initial_j,
        final_j,
        joint_work_j,
        damping_work_j,
        friction_work_j,
        impact_loss_j: exec.impact_losses().iter().sum(),
    })
}

/// The powers (W) at `(t, y = [q; q̇])` in `mode` of `flow`: of what drives the joints, of
/// the passive dampers and of the sliding sites' friction (module docs).
fn powers_at(
    model: &Model,
    flow: &mut Flow,
    mode: ContactMode,
    t: f64,
    y: &[f64],
) -> Result<[f64; 3], CoreError> {
    let (q, qd) = y.split_at(model.nq());
    flow.eval(t, mode, q, qd)?;
    let (data, tau) = flow.last();
    // the spring–damper's torque τ^p_j (0 without one)
    let passive = |j: usize| joint_torque(model, j, q, qd);
    let joint: f64 = (0..model.n_joints())
        .map(|j| {
            match (
                data.free_joints.contains(&j)
                    && !data.damped_laws.iter().any(|(_, l)| l.joints.contains(&j)),
                data.locked.contains(&j),
            ) {
                // locked for a fold passage: held by the torque that balances its contact
                // and spring, (Aᵀλ)_j − τ^p_j (its row of (5.3), M̄_j = 0)
                (true, true) => {
                    (data.constraints.a.column(j).dot(&data.lambda) - passive(j)) * qd[j]
                }
                // free: carries no load; its prescribed motion works against its own
                // spring–damper only
                (true, false) => -passive(j) * qd[j],
                _ => tau[j] * qd[j],
            }
        })
        .sum();
    let friction: f64 = data.friction.iter().zip(qd).map(|(f, v)| f * v).sum();
    Ok([joint, damping_power(model, qd), friction])
}

/// The tolerance of the work quadrature on one step (J): far below the balance's 1e-6 J over
/// a run of a thousand steps, and above the rounding of a step's few-joule powers.
pub const QUADRATURE_TOL_J: f64 = 1e-13;

/// Halvings of a step at most: a kink of the integrand is then bracketed to 2⁻²⁰ of the step.
const MAX_HALVINGS: u32 = 20;

/// Intervals halved per step at most, over all depths: bisecting one kink to
/// [`MAX_HALVINGS`] takes 20; an integrand whose rounding exceeds [`QUADRATURE_TOL_J`]
/// everywhere stops here instead of at 2²⁰ intervals, so a step's quadrature costs at most
/// `3 + 6 (1 + 2 MAX_SPLITS)` evaluations.
const MAX_SPLITS: u32 = 64;

/// `∫ₐᵇ f` of the vector integrand `f` by 3-point Gauss–Legendre on `[a, b]`, compared with
/// the sum over its halves; halved again where the two differ by more than
/// [`QUADRATURE_TOL_J`] (the integrand is not a polynomial of degree ≤ 5 there: a kink),
/// down to [`MAX_HALVINGS`] halvings and [`MAX_SPLITS`] halved intervals in all.
pub fn adaptive_gauss<E>(
    f: &mut impl FnMut(f64) -> Result<[f64; 3], E>,
    a: f64,
    b: f64,
) -> Result<[f64; 3], E> {
    let whole = gauss3(f, a, b)?;
    let mut splits = MAX_SPLITS;
    refine(f, a, b, whole, MAX_HALVINGS, &mut splits)
}

fn refine<E>(
    f: &mut impl FnMut(f64) -> Result<[f64; 3], E>,
    a: f64,
    b: f64,
    whole: [f64; 3],
    halvings: u32,
    splits: &mut u32,
) -> Result<[f64; 3], E> {
    let m = 0.5 * (a + b);
    let (left, right) = (gauss3(f, a, m)?, gauss3(f, m, b)?);
    let split: [f64; 3] = std::array::from_fn(|i| left[i] + right[i]);
    let converged = (0..3).all(|i| (split[i] - whole[i]).abs() <= QUADRATURE_TOL_J);
    if converged || halvings == 0 || *splits == 0 {
        return Ok(split);
    }
    *splits -= 1;
    let (l, r) = (
        refine(f, a, m, left, halvings - 1, splits)?,
        refine(f, m, b, right, halvings - 1, splits)?,
    );
    Ok(std::array::from_fn(|i| l[i] + r[i]))
}

/// 3-point Gauss–Legendre quadrature of `f` on `[a, b]` (exact for degree ≤ 5).
fn gauss3<E>(
    f: &mut impl FnMut(f64) -> Result<[f64; 3], E>,
    a: f64,
    b: f64,
) -> Result<[f64; 3], E> {
    let r = 0.5 * (0.6f64).sqrt();
    let nodes = [
        (0.5 - r, 5.0 / 18.0),
        (0.5, 8.0 / 18.0),
        (0.5 + r, 5.0 / 18.0),
    ];
    let mut sum = [0.0; 3];
    for (x, w) in nodes {
        let v = f(a + x * (b - a))?;
        for i in 0..3 {
            sum[i] += w * (b - a) * v[i];
        }
    }
    Ok(sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A kinked integrand (`|t − c|`, whose integral is known in closed form) is integrated
    /// to the tolerance, which plain 3-point Gauss–Legendre on the interval misses by far;
    /// a quintic needs no halving beyond the first comparison (exact either way).
    #[test]
    fn adaptive_gauss_converges_on_a_kink() {
        let c = 0.3;
        let exact = (c * c + (1.0 - c) * (1.0 - c)) / 2.0;
        let mut f = |t: f64| -> Result<[f64; 3], ()> { Ok([(t - c).abs(), 0.0, 0.0]) };
        let plain = gauss3(&mut f, 0.0, 1.0).unwrap()[0];
        assert!((plain - exact).abs() > 1e-3, "{plain} {exact}");
        let got = adaptive_gauss(&mut f, 0.0, 1.0).unwrap()[0];
        assert!((got - exact).abs() < 1e-12, "{got} {exact}");
        let mut calls = 0;
        let mut quintic = |t: f64| -> Result<[f64; 3], ()> {
            calls += 1;
            Ok([t.powi(5), 0.0, 0.0])
        };
        let got = adaptive_gauss(&mut quintic, 0.0, 2.0).unwrap()[0];
        assert!((got - 64.0 / 6.0).abs() < 1e-12);
        assert_eq!(calls, 9);
    }

    /// An integrand that never converges (noise far above the tolerance at every point)
    /// costs a bounded number of evaluations: the whole step, then `1 + 2 MAX_SPLITS` pairs of
    /// halves (3 points each).
    #[test]
    fn adaptive_gauss_cost_is_bounded_on_noise() {
        let mut calls = 0u32;
        let mut noisy = |t: f64| -> Result<[f64; 3], ()> {
            calls += 1;
            Ok([
                t + if calls.is_multiple_of(2) { 1e-6 } else { -1e-6 },
                0.0,
                0.0,
            ])
        };
        let got = adaptive_gauss(&mut noisy, 0.0, 1.0).unwrap()[0];
        assert!((got - 0.5).abs() < 1e-5, "{got}");
        assert_eq!(calls, 3 + 6 * (1 + 2 * MAX_SPLITS));
    }
}
