//! The takeoff-speed bound of a leg with a linear torque–speed motor (thesis (4.64)–(4.66),
//! generalised to any planar robot): with one contact down, `(Uλ)_n` is affine in the joint
//! torque and quadratic in the velocity, and the motor line `τ ≤ κ_P κ_G (1 − κ_G θ̇)` is
//! affine in the leg rate, so along `ẏ = (θ̇, φ̇)` with `φ̇` fixed the liftoff condition
//! `(Uλ)_n(θ̇) ≥ 0` is a scalar quadratic in `θ̇`: its first positive root is the bound
//! (closed form, exact). RHex's instances (Result C.4, Figs. 4.10–4.12) are in `rhex-model`.
use super::{bad, check_finite, free_motion_basis, normal_rows, selector_rows};
use crate::error::SimError;
use selfmanip_core::{forward_dynamics, ContactMode, Data, Model, Terrain};
use serde::Serialize;

/// The linear torque–speed limit of a leg, `τ ≤ τ_s (1 − θ̇/ω₀) = κ_P κ_G (1 − κ_G θ̇)` with
/// `κ_G = 1/ω₀` (∝ gear ratio) and `κ_P = τ_s ω₀` (∝ peak power) (ref. \[129\], after (4.64)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TorqueSpeedLine {
    pub stall_torque_n_m: f64,
    pub no_load_speed_rad_s: f64,
}

impl TorqueSpeedLine {
    pub fn new(stall_torque_n_m: f64, no_load_speed_rad_s: f64) -> Result<Self, SimError> {
        if !(stall_torque_n_m > 0.0 && stall_torque_n_m.is_finite()) {
            return Err(bad("stall_torque_n_m", "must be positive and finite"));
        }
        if !(no_load_speed_rad_s > 0.0 && no_load_speed_rad_s.is_finite()) {
            return Err(bad("no_load_speed_rad_s", "must be positive and finite"));
        }
        Ok(Self {
            stall_torque_n_m,
            no_load_speed_rad_s,
        })
    }

    /// A planar leg driven by `motors` identical motors (a contralateral pair: 2) through a
    /// gearbox of `ratio` and `efficiency`: `τ_s = n G η τ_stall`, `ω₀ = ω_nl / G` (the
    /// current-limited stall torque of chapter 2 is used as `τ_stall`).
    pub fn from_motor(
        motor: &motor::DcMotor,
        ratio: f64,
        efficiency: f64,
        motors: f64,
    ) -> Result<Self, SimError> {
        if !(ratio > 0.0 && ratio.is_finite()) {
            return Err(bad("gear_ratio", "must be positive and finite"));
        }
        if !(efficiency > 0.0 && efficiency <= 1.0) {
            return Err(bad("efficiency", "must be in (0, 1]"));
        }
        if !(motors > 0.0 && motors.is_finite()) {
            return Err(bad("motors", "must be positive"));
        }
        Self::new(
            motors * ratio * efficiency * motor.achievable_stall_torque_n_m(),
            motor.no_load_speed_rad_s / ratio,
        )
    }

    /// A catalog's motor `motor` (its current-limited stall torque) behind its gearbox
    /// `gearbox`'s efficiency at gear ratio `ratio`, `motors` motors per planar leg (errors
    /// name `motor` or `gearbox` for a name the catalog does not have).
    pub fn from_catalog(
        catalog: &motor::Catalog,
        motor: &str,
        gearbox: &str,
        ratio: f64,
        motors: f64,
    ) -> Result<Self, SimError> {
        let m = catalog
            .motor_spec(motor)
            .and_then(|s| s.motor())
            .map_err(|e| bad("motor", e.to_string()))?;
        let eta = catalog
            .gearbox(gearbox)
            .map_err(|e| bad("gearbox", e.to_string()))?
            .efficiency;
        Self::from_motor(&m, ratio, eta, motors)
    }

    pub fn kappa_g(&self) -> f64 {
        1.0 / self.no_load_speed_rad_s
    }
    pub fn kappa_p(&self) -> f64 {
        self.stall_torque_n_m * self.no_load_speed_rad_s
    }
    pub fn torque(&self, speed_rad_s: f64) -> f64 {
        self.stall_torque_n_m * (1.0 - speed_rad_s / self.no_load_speed_rad_s)
    }
}

/// The takeoff bound at one state.
#[derive(Debug, Clone, Serialize)]
pub struct TakeoffBound {
    /// Largest leg rate (rad/s) before `(Uλ)_n` reaches zero at full motor torque.
    pub leg_rate: f64,
    /// Body COM forward speed there (m/s); output name `xdot` (`docs/conventions.md`).
    #[serde(rename = "xdot")]
    pub x_dot: f64,
    /// Torque at that rate (N m).
    pub tau: f64,
    /// True if the contact holds all the way to the motor's no-load speed.
    pub holds_to_no_load: bool,
}

/// (4.64)–(4.66) generalised: in a single-contact `mode` at `q`, with `y = [θ_all, φ]`,
/// the leg joint `leg_joint` turning at `θ̇` under full motor torque `line.torque(θ̇)`, the other
/// joints at rest and unactuated, and pitch rate `phi_dot`, returns the first `θ̇ > 0` at which
/// the contact's normal force `Uλ` vanishes. `None` if the contact cannot hold even at rest.
pub fn takeoff_bound(
    model: &Model,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    leg_joint: usize,
    phi_dot: f64,
    line: &TorqueSpeedLine,
) -> Result<Option<TakeoffBound>, SimError> {
    check_finite("phi_dot", &[phi_dot])?;
    let n = model.n_joints();
    if leg_joint >= n {
        return Err(bad(
            "leg_joint",
            format!("joint {leg_joint} does not exist"),
        ));
    }
    let nq = model.nq();
    let mut idx: Vec<usize> = (0..n).collect();
    idx.push(model.ix_phi());
    let h = free_motion_basis(model, terrain, mode, q, &selector_rows(nq, &idx))?;
    let mut data = Data::new(model);
    data.prepare_geometry(model, terrain, mode, q, &vec![0.0; nq])?;
    let rows = normal_rows(&data);
    let qd_of = |w: f64| -> Vec<f64> {
        let mut yd = nalgebra::DVector::zeros(n + 1);
        yd[leg_joint] = w;
        yd[n] = phi_dot;
        (&h * yd).iter().cloned().collect()
    };
    let mut g = |w: f64| -> Result<Vec<f64>, SimError> {
        let mut tau = vec![0.0; n];
        tau[leg_joint] = line.torque(w);
        forward_dynamics(model, &mut data, terrain, mode, q, &qd_of(w), &tau, None)?;
        Ok(rows.iter().map(|&i| -data.lambda[i]).collect())
    };
    let w1 = line.no_load_speed_rad_s;
    let (g0, gh, g1) = (g(0.0)?, g(0.5 * w1)?, g(w1)?);
    if g0.iter().any(|&v| v < 0.0) {
        return Ok(None);
    }
    // exact quadratic through the three samples, per row; first positive root in (0, w1]
    let mut w_star = w1;
    for r in 0..rows.len() {
        let c0 = g0[r];
        // g(w) = c0 + c1 w + c2 w²
        let c2 = 2.0 * (g1[r] - 2.0 * gh[r] + c0) / (w1 * w1);
        let c1 = (g1[r] - c0) / w1 - c2 * w1;
        let roots = real_roots(c2, c1, c0);
        for rt in roots {
            if rt > 0.0 && rt < w_star {
                w_star = rt;
            }
        }
    }
    let qd = qd_of(w_star);
    Ok(Some(TakeoffBound {
        leg_rate: w_star,
        x_dot: qd[model.ix_x()],
        tau: line.torque(w_star),
        holds_to_no_load: w_star >= w1,
    }))
}

fn real_roots(a: f64, b: f64, c: f64) -> Vec<f64> {
    let scale = a.abs().max(b.abs()).max(c.abs());
    if a.abs() <= 1e-14 * scale {
        return if b != 0.0 { vec![-c / b] } else { vec![] };
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return vec![];
    }
    // numerically stable pair
    let s = disc.sqrt();
    let qq = -0.5 * (b + b.signum() * s);
    let mut r = vec![qq / a];
    if qq != 0.0 {
        r.push(c / qq);
    }
    r
}
