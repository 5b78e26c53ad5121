//! Legs as inertial tails in flight (thesis 4.3.3, "Inertial Leg Effects", eqs. 4.67–4.68,
//! Result C.5).
//!
//! In flight no external wrench acts except uniform gravity, which does not change the
//! motion relative to the centre of mass, so the total momentum about the system COM is
//! conserved. Starting from rest, the body rates follow from the joint rates through the
//! zero-momentum condition on the body rows of `M̄` (4.67):
//! `M̄_bb v_b = −M̄_bθ θ̇`, hence the *effectiveness* `ε(q) = φ̇ / θ̇` for a set of joints
//! driven in phase. A full revolution turns the body by `Δφ = ∫₀^{2π} ε dθ`.
//!
//! Two routes are provided: [`revolution_rotation_momentum`] integrates `ε` over the
//! revolution, and [`revolution_rotation_dynamic`] integrates the full flight dynamics
//! (5.3) with PD-tracked joints under gravity; they must agree.
use super::{bad, check_finite};
use crate::error::SimError;
use nalgebra::{DMatrix, DVector};
use selfmanip_core::{forward_dynamics, ContactMode, Data, FlatGround, Model};
use serde::Serialize;

fn check_joints(model: &Model, joints: &[usize]) -> Result<(), SimError> {
    if joints.is_empty() {
        return Err(bad("joints", "at least one joint must turn"));
    }
    if let Some(&j) = joints.iter().find(|&&j| j >= model.n_joints()) {
        return Err(bad(
            "joints",
            format!("joint {j} does not exist ({} joints)", model.n_joints()),
        ));
    }
    Ok(())
}

/// Body pitch rate per unit rate of the in-phase `joints` at `q`, from zero total momentum
/// (4.67): `ε = φ̇/θ̇` with `M̄_bb v_b = −M̄_bθ s`, `s` the in-phase joint direction.
pub fn effectiveness_at(model: &Model, q: &[f64], joints: &[usize]) -> Result<f64, SimError> {
    check_joints(model, joints)?;
    let nq = model.nq();
    super::check_configuration(model, q)?;
    let n = model.n_joints();
    let mut data = Data::new(model);
    data.prepare_geometry(model, &FlatGround, ContactMode::FLIGHT, q, &vec![0.0; nq])?;
    let m = &data.m_bar;
    let mut s = DVector::zeros(n);
    for &j in joints {
        s[j] = 1.0;
    }
    let m_bb = m.view((n, n), (3, 3)).into_owned();
    let m_bt = m.view((n, 0), (3, n)).into_owned();
    let vb = m_bb
        .lu()
        .solve(&(-(m_bt * s)))
        .ok_or_else(|| bad("model", "singular body inertia"))?;
    Ok(vb[2])
}

/// `Δφ` for one full in-phase revolution (`+2π`) of `joints` starting at `q0`, integrating
/// `dφ/dθ = ε(q(θ))` with RK4 in `steps` steps.
pub fn revolution_rotation_momentum(
    model: &Model,
    q0: &[f64],
    joints: &[usize],
    steps: usize,
) -> Result<f64, SimError> {
    let steps = steps.max(8);
    let h = std::f64::consts::TAU / steps as f64;
    let n = model.n_joints();
    let phi_ix = n + 2;
    let at = |th: f64, phi: f64| -> Result<f64, SimError> {
        let mut q = q0.to_vec();
        for &j in joints {
            q[j] += th;
        }
        q[phi_ix] = phi;
        effectiveness_at(model, &q, joints)
    };
    let mut phi = q0[phi_ix];
    for i in 0..steps {
        let th = i as f64 * h;
        let k1 = at(th, phi)?;
        let k2 = at(th + 0.5 * h, phi + 0.5 * h * k1)?;
        let k3 = at(th + 0.5 * h, phi + 0.5 * h * k2)?;
        let k4 = at(th + h, phi + h * k3)?;
        phi += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    Ok(phi - q0[phi_ix])
}

/// Result of a simulated in-flight leg revolution.
#[derive(Debug, Clone, Serialize)]
pub struct FlightRevolution {
    /// Body rotation `Δφ` (rad) between rest before and rest after the revolution.
    pub delta_phi: f64,
    /// Largest joint tracking error during the manoeuvre (rad).
    pub max_tracking_error: f64,
    /// Final joint angles minus initial (should be 2π for the driven joints).
    pub joint_travel: Vec<f64>,
}

/// Integrates the flight dynamics (5.3) (mode = flight, gravity on) while PD torques make
/// `joints` follow one smooth revolution `θ_ref = θ₀ + 2π (s − sin(2πs)/2π)`, `s = t/T`, from
/// rest to rest; the other joints are held at their initial angles. RK4 with `dt`.
pub fn revolution_rotation_dynamic(
    model: &Model,
    q0: &[f64],
    joints: &[usize],
    period_s: f64,
    dt_s: f64,
) -> Result<FlightRevolution, SimError> {
    check_joints(model, joints)?;
    if !(period_s > 0.0 && dt_s > 0.0 && dt_s < period_s) {
        return Err(bad("period_s", "need 0 < dt_s < period_s"));
    }
    if model.has_massless_links() {
        return Err(bad(
            "model",
            "legs must have mass for the tail effect (drop C.6)",
        ));
    }
    let nq = model.nq();
    let n = model.n_joints();
    let mut data = Data::new(model);
    let tau_ref = std::f64::consts::TAU;
    let reference = |t: f64| -> (f64, f64) {
        let s = (t / period_s).clamp(0.0, 1.0);
        let w = tau_ref / period_s;
        if t >= period_s {
            return (tau_ref, 0.0);
        }
        (
            tau_ref * (s - (tau_ref * s).sin() / tau_ref),
            w * (1.0 - (tau_ref * s).cos()),
        )
    };
    // stiff PD: natural frequency well above the manoeuvre's
    let (kp, kd) = (4.0e4, 2.0 * 200.0);
    let mut f = |t: f64, x: &[f64]| -> Result<Vec<f64>, SimError> {
        let (r, rd) = reference(t);
        let mut tau = vec![0.0; n];
        // joint-space inertia scale so that the gains are dimensionless in time
        for j in 0..n {
            let (target, target_rate) = if joints.contains(&j) {
                (q0[j] + r, rd)
            } else {
                (q0[j], 0.0)
            };
            tau[j] = kp * (target - x[j]) + kd * (target_rate - x[nq + j]);
        }
        // scale by the diagonal of M̄ so the loop bandwidth is the same for every joint
        data.prepare(model, &FlatGround, ContactMode::FLIGHT, &x[..nq], &x[nq..])?;
        for (j, t) in tau.iter_mut().enumerate() {
            *t *= data.m_bar[(j, j)];
        }
        forward_dynamics(
            model,
            &mut data,
            &FlatGround,
            ContactMode::FLIGHT,
            &x[..nq],
            &x[nq..],
            &tau,
            None,
        )?;
        Ok(x[nq..]
            .iter()
            .cloned()
            .chain(data.qdd.iter().cloned())
            .collect())
    };
    let mut x: Vec<f64> = q0
        .iter()
        .cloned()
        .chain(std::iter::repeat_n(0.0, nq))
        .collect();
    let t_end = period_s * 1.5;
    let steps = (t_end / dt_s).ceil() as usize;
    let h = t_end / steps as f64;
    let mut max_err = 0.0f64;
    for i in 0..steps {
        let t = i as f64 * h;
        let k1 = f(t, &x)?;
        let x2: Vec<f64> = x.iter().zip(&k1).map(|(a, b)| a + 0.5 * h * b).collect();
        let k2 = f(t + 0.5 * h, &x2)?;
        let x3: Vec<f64> = x.iter().zip(&k2).map(|(a, b)| a + 0.5 * h * b).collect();
        let k3 = f(t + 0.5 * h, &x3)?;
        let x4: Vec<f64> = x.iter().zip(&k3).map(|(a, b)| a + h * b).collect();
        let k4 = f(t + h, &x4)?;
        for k in 0..2 * nq {
            x[k] += h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k]);
        }
        let (r, _) = reference(t + h);
        for &j in joints {
            max_err = max_err.max((x[j] - q0[j] - r).abs());
        }
        check_finite("state", &x)?;
    }
    Ok(FlightRevolution {
        delta_phi: x[n + 2] - q0[n + 2],
        max_tracking_error: max_err,
        joint_travel: (0..n).map(|j| x[j] - q0[j]).collect(),
    })
}

/// Closed form for `N` identical legs with hips on the body axis, COM at distance `c` from the
/// hip along the leg, turning in phase (our re-derivation of (4.68), see errata):
///
/// `ε = (N I_l + m_r c²) / (I_b + N I_l + m_l Σ_k (ℓ_k − ℓ̄)² + m_r c²)`,
/// `m_r = m_b N m_l / (m_b + N m_l)`, exact (configuration independent) when the mean hip
/// position `ℓ̄` is at the body COM. Returns `None` otherwise.
#[allow(non_snake_case)]
pub fn effectiveness_closed_form(
    m_b: f64,
    I_b: f64,
    m_l: f64,
    I_l: f64,
    com_from_hip_m: f64,
    hips_x_m: &[f64],
) -> Option<f64> {
    let nl = hips_x_m.len() as f64;
    let mean = hips_x_m.iter().sum::<f64>() / nl;
    if mean.abs() > 1e-12 {
        return None;
    }
    let m_r = m_b * nl * m_l / (m_b + nl * m_l);
    let spread: f64 = hips_x_m.iter().map(|l| (l - mean).powi(2)).sum();
    let c2 = com_from_hip_m * com_from_hip_m;
    Some((nl * I_l + m_r * c2) / (I_b + nl * I_l + m_l * spread + m_r * c2))
}

/// `M̄`'s body block must be invertible for the momentum route; exposed for tests.
pub fn body_inertia_block(model: &Model, q: &[f64]) -> Result<DMatrix<f64>, SimError> {
    let mut data = Data::new(model);
    data.prepare_geometry(
        model,
        &FlatGround,
        ContactMode::FLIGHT,
        q,
        &vec![0.0; q.len()],
    )?;
    let n = model.n_joints();
    Ok(data.m_bar.view((n, n), (3, 3)).into_owned())
}
