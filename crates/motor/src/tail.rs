//! Inertial-tail reorientation (thesis section 2.1.1, eq. (2.1)): the gear ratio that
//! minimizes the time to turn the body by `θ₀`, in closed form, a numerical cross-check,
//! and motor selection over a catalog ranked by completion time.
//!
//! # Derivation (the thesis defers it to its reference \[93\])
//! Body (inertia `I_b`) and tail start at rest with zero angular momentum, so a joint torque
//! `τ` gives the relative joint acceleration `τ (1/I_b + 1/I_t)`, and the body turns by
//! `θ_rel / (1 + 1/ε)` where `ε = I_t/I_b` is the effectiveness (body rotation per absolute
//! tail rotation; the thesis's 155° relative sweep turning the body 89.7° gives
//! ε = 89.7/(155 − 89.7) ≈ 1.37, its "ε_n = 1.38"). The joint therefore sees
//! `I_eff = I_b/(1 + 1/ε)` and must turn `θ_rel = θ₀(1 + 1/ε)`.
//!
//! The motor runs at full voltage from rest with no braking (the "control profile"). Behind
//! the gearbox it is the line `τ = T(1 − ω/Ω)` with output no-load speed `Ω` and stall
//! torque `T = 4P/Ω`, where `P = τ_stall ω₀/4` is the motor's peak power (independent of
//! `G`). Then `ω(t) = Ω(1 − e^{−t/τ_m})`, `τ_m = I_eff Ω²/(4P)`, and
//! `θ(t) = Ω τ_m f(t/τ_m)` with `f(s) = s − 1 + e^{−s}`. Eliminating `Ω` at fixed `θ_rel`,
//! `t ∝ s / f(s)^{2/3}`, stationary where `f(s) = (2/3) s (1 − e^{−s})` (s* ≈ 2.149). Then
//!
//! ```text
//!   Ω* = (k_ω θ₀ P (1 + 1/ε)² / I_b)^{1/3},   t* = (k_t θ₀² I_b (1 + 1/ε) / P)^{1/3},
//!   k_ω = 4/f(s*) ≈ 3.161,   k_t = s*³/(4 f(s*)²) ≈ 1.549,
//! ```
//!
//! the form of eq. (2.1). The thesis prints k_ω ≈ 3.156, k_t ≈ 1.547 (0.15 % and 0.13 %
//! lower): see docs/errata/ch2-actuators.md.
use crate::catalog::MotorSpec;
use crate::error::{no_overflow, positive, MotorError, Result};
use crate::numeric::{bisect, rk4_step};
use serde::Serialize;
use std::sync::OnceLock;

/// A reorientation task: turn the body by `rotation_rad` with a tail of effectiveness
/// `effectiveness` (`ε`), body inertia `body_inertia_kg_m2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TailTask {
    pub rotation_rad: f64,
    pub body_inertia_kg_m2: f64,
    pub effectiveness: f64,
}

impl TailTask {
    pub fn new(rotation_rad: f64, body_inertia_kg_m2: f64, effectiveness: f64) -> Result<Self> {
        Ok(Self {
            rotation_rad: positive("theta0_rad", rotation_rad)?,
            body_inertia_kg_m2: positive("body_inertia_kg_m2", body_inertia_kg_m2)?,
            effectiveness: positive("effectiveness", effectiveness)?,
        })
    }

    /// `1 + 1/ε`.
    fn lever(&self) -> f64 {
        1.0 + 1.0 / self.effectiveness
    }
    /// Joint rotation needed, `θ₀(1 + 1/ε)`.
    pub fn joint_rotation_rad(&self) -> f64 {
        self.rotation_rad * self.lever()
    }
    /// Inertia seen at the joint, `I_b/(1 + 1/ε)`.
    pub fn joint_inertia_kg_m2(&self) -> f64 {
        self.body_inertia_kg_m2 / self.lever()
    }
}

/// The constants of eq. (2.1) from the derivation above.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TailConstants {
    /// Optimal `t/τ_m`.
    pub s_star: f64,
    pub k_omega: f64,
    pub k_t: f64,
}

fn f_rise(s: f64) -> f64 {
    s - 1.0 + (-s).exp()
}

/// Solves `f(s) = (2/3) s (1 − e^{−s})` by bisection to machine precision.
pub fn tail_constants() -> TailConstants {
    static CONSTANTS: OnceLock<TailConstants> = OnceLock::new();
    *CONSTANTS.get_or_init(|| {
        let h = |s: f64| f_rise(s) - 2.0 / 3.0 * s * (1.0 - (-s).exp());
        let s = bisect(|s| h(s) < 0.0, 1.0, 4.0, 200); // h(1) < 0 < h(4)
        let f = f_rise(s);
        TailConstants {
            s_star: s,
            k_omega: 4.0 / f,
            k_t: s.powi(3) / (4.0 * f * f),
        }
    })
}

/// Optimal output no-load speed and completion time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TailOptimum {
    /// `Ω*`, the gearbox-output no-load speed (gear ratio = motor no-load speed / Ω*).
    pub no_load_speed_rad_s: f64,
    pub completion_time_s: f64,
}

/// Eq. (2.1): the minimum-time output no-load speed and completion time for peak motor
/// power `power_w`.
pub fn tail_optimum(task: &TailTask, power_w: f64) -> Result<TailOptimum> {
    let p = positive("power_w", power_w)?;
    let k = tail_constants();
    let lever = task.lever();
    // Ω* = ∛(k_Ω θ₀ P ℓ² / I_b), t* = ∛(k_t θ₀² I_b ℓ / P), ℓ = 1 + 1/ε: the cube root of each
    // factor, so that no intermediate product overflows where the result does not
    let (theta, inertia) = (task.rotation_rad.cbrt(), task.body_inertia_kg_m2.cbrt());
    let fields = "theta0_rad, power_w, body_inertia_kg_m2, effectiveness";
    Ok(TailOptimum {
        no_load_speed_rad_s: no_overflow(
            fields,
            "the optimal no-load speed",
            (k.k_omega * lever * lever).cbrt() * theta * (p.cbrt() / inertia),
        )?,
        completion_time_s: no_overflow(
            fields,
            "the completion time",
            (k.k_t * lever).cbrt() * theta * theta * (inertia / p.cbrt()),
        )?,
    })
}

/// Completion time at any output no-load speed `Ω` (any gear ratio): solves
/// `Ω τ_m f(t/τ_m) = θ_rel` for `t` by Newton's method (monotone from the right: `f` is
/// increasing and convex).
pub fn completion_time_s(task: &TailTask, power_w: f64, no_load_speed_rad_s: f64) -> Result<f64> {
    let p = positive("power_w", power_w)?;
    let omega = positive("no_load_speed_rad_s", no_load_speed_rad_s)?;
    let tau_m = task.joint_inertia_kg_m2() * omega * omega / (4.0 * p);
    let c = task.joint_rotation_rad() / (omega * tau_m);
    let mut s = c + 1.0; // f(c + 1) > c: start right of the root
    for _ in 0..100 {
        let step = (f_rise(s) - c) / (1.0 - (-s).exp());
        s -= step;
        if step.abs() <= 1e-15 * s.max(1.0) {
            return Ok(s * tau_m);
        }
    }
    Err(MotorError::NoConvergence {
        what: "tail completion time",
        reason: format!("Newton iteration stalled at s = {s}"),
    })
}

/// The same completion time by integrating the joint dynamics
/// `I_eff ω̇ = (4P/Ω)(1 − ω/Ω)` with classical RK4 at step `dt_s` and locating the crossing
/// `θ = θ_rel` on the cubic Hermite interpolant (an independent route to
/// [`completion_time_s`]).
pub fn simulated_completion_time_s(
    task: &TailTask,
    power_w: f64,
    no_load_speed_rad_s: f64,
    dt_s: f64,
) -> Result<f64> {
    let p = positive("power_w", power_w)?;
    let omega_max = positive("no_load_speed_rad_s", no_load_speed_rad_s)?;
    let h = positive("dt_s", dt_s)?;
    let stall = 4.0 * p / omega_max;
    let inertia = task.joint_inertia_kg_m2();
    let target = task.joint_rotation_rad();
    let accel = |w: f64| stall * (1.0 - w / omega_max) / inertia;
    let (mut t, mut theta, mut w) = (0.0_f64, 0.0_f64, 0.0_f64);
    for _ in 0..100_000_000u64 {
        let (theta1, w1) = rk4_step(theta, w, h, |_, w| (w, accel(w)));
        if theta1 >= target {
            // cubic Hermite on [t, t+h] with slopes w, w1; bisection on the interpolant
            let hermite = |x: f64| {
                let (x2, x3) = (x * x, x * x * x);
                (2.0 * x3 - 3.0 * x2 + 1.0) * theta
                    + (x3 - 2.0 * x2 + x) * h * w
                    + (-2.0 * x3 + 3.0 * x2) * theta1
                    + (x3 - x2) * h * w1
            };
            return Ok(t + bisect(|x| hermite(x) < target, 0.0, 1.0, 60) * h);
        }
        t += h;
        theta = theta1;
        w = w1;
    }
    Err(MotorError::NoConvergence {
        what: "tail simulation",
        reason: "target rotation not reached".into(),
    })
}

/// Numerical minimum-time optimum: golden-section search over `ln Ω` in
/// `[Ω_lo, Ω_hi]` of the *simulated* completion time (the thesis's numerical route of
/// \[124\], 1,000× slower than eq. (2.1)).
pub fn numerical_optimum(
    task: &TailTask,
    power_w: f64,
    bracket_rad_s: (f64, f64),
    dt_s: f64,
) -> Result<TailOptimum> {
    let (mut a, mut b) = (
        positive("bracket_low", bracket_rad_s.0)?.ln(),
        positive("bracket_high", bracket_rad_s.1)?.ln(),
    );
    let time = |x: f64| simulated_completion_time_s(task, power_w, x.exp(), dt_s);
    let phi = 0.5 * (5.0_f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - phi * (b - a), a + phi * (b - a));
    let (mut fc, mut fd) = (time(c)?, time(d)?);
    while b - a > 1e-7 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - phi * (b - a);
            fc = time(c)?;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + phi * (b - a);
            fd = time(d)?;
        }
    }
    let x = 0.5 * (a + b);
    Ok(TailOptimum {
        no_load_speed_rad_s: x.exp(),
        completion_time_s: time(x)?,
    })
}

/// Selection constraints of section 2.1.1 (length < 30 mm, mass < 200 g, time < 0.5 s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelectionConstraints {
    pub max_length_m: f64,
    pub max_mass_kg: f64,
    pub max_completion_time_s: f64,
}

/// One motor that meets the constraints, at its analytic optimum gear ratio.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RankedMotor {
    /// Index in the input catalog.
    pub index: usize,
    pub name: String,
    pub peak_power_w: f64,
    pub gear_ratio: f64,
    pub completion_time_s: f64,
}

/// Result of [`rank_tail_motors`]: the feasible motors fastest first, and the catalog
/// entries that could not be evaluated (bad data), each with its error, so one bad entry
/// never hides the others.
#[derive(Debug, Clone, PartialEq)]
pub struct TailSelection {
    pub ranked: Vec<RankedMotor>,
    pub invalid: Vec<(usize, MotorError)>,
}

/// Ranks `motors` on `task` by the analytic completion time (eq. (2.1) at each motor's peak
/// power), keeping those that meet `constraints`; ties are broken by catalog index so the
/// order is deterministic.
pub fn rank_tail_motors(
    motors: &[MotorSpec],
    task: &TailTask,
    constraints: &SelectionConstraints,
) -> Result<TailSelection> {
    if motors.is_empty() {
        return Err(MotorError::EmptyCatalog { field: "motors" });
    }
    positive("max_length_m", constraints.max_length_m)?;
    positive("max_mass_kg", constraints.max_mass_kg)?;
    positive("max_completion_time_s", constraints.max_completion_time_s)?;
    let mut ranked = Vec::new();
    let mut invalid = Vec::new();
    for (index, spec) in motors.iter().enumerate() {
        let evaluated = spec.motor().and_then(|motor| {
            let power = motor.peak_power_w();
            tail_optimum(task, power).map(|opt| (motor, power, opt))
        });
        match evaluated {
            Ok((motor, peak_power_w, opt)) => {
                if spec.length_m < constraints.max_length_m
                    && spec.mass_kg < constraints.max_mass_kg
                    && opt.completion_time_s < constraints.max_completion_time_s
                {
                    ranked.push(RankedMotor {
                        index,
                        name: spec.name.clone(),
                        peak_power_w,
                        gear_ratio: motor.no_load_speed_rad_s / opt.no_load_speed_rad_s,
                        completion_time_s: opt.completion_time_s,
                    });
                }
            }
            Err(e) => invalid.push((index, e)),
        }
    }
    ranked.sort_by(|a, b| {
        a.completion_time_s
            .total_cmp(&b.completion_time_s)
            .then(a.index.cmp(&b.index))
    });
    Ok(TailSelection { ranked, invalid })
}
