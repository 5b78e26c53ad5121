//! The **parameter tangent** of a compiled behaviour: the partial derivatives of every number
//! the interpreter uses with respect to the behaviour's named parameters (the `[parameters]`
//! table), for `selfmanip_hybrid::Controller::parameter_partials` and the time events' `dt/dp`.
//!
//! It lives beside the compiled plan, never in it: the forward path (`torque`,
//! `free_joint_qdd`) reads the plan's plain numbers, and only the sensitivities read this.
//! Every gradient has one entry per parameter, in the order of [`PlanTangent::names`]; the
//! gradient of a parameter `p` defined by a formula is `e_p` plus the formula's chain (to
//! differentiate with respect to `p` is to override `p` by a number, as a run with `p` set
//! does). Numbers are differentiated exactly: formulas forward-mode through their tree
//! ([`crate::expr::Expr::eval_grad`]), an actuator's data and torque law by closed forms
//! ([`ActuatorLaw`]).
use crate::expr::{Dual, Expr};
use std::collections::BTreeMap;
use std::sync::Arc;

/// A gradient over the behaviour's parameters.
pub(crate) type Grad = Arc<[f64]>;

/// `Σ wᵢ gᵢ` of gradients (`None`: zero), `None` when every term is.
pub(crate) fn sum(terms: &[(f64, Option<&Grad>)]) -> Option<Grad> {
    let n = terms.iter().find_map(|(_, g)| g.map(|g| g.len()))?;
    let mut out = vec![0.0; n];
    for (w, g) in terms {
        if let Some(g) = g {
            for (o, x) in out.iter_mut().zip(g.iter()) {
                *o += w * x;
            }
        }
    }
    Some(out.into())
}

/// `out += w g`.
pub(crate) fn axpy(out: &mut [f64], w: f64, g: &[f64]) {
    if w != 0.0 {
        for (o, x) in out.iter_mut().zip(g) {
            *o += w * x;
        }
    }
}

/// The tangent of a whole plan.
pub(crate) struct PlanTangent {
    /// The parameter names, in the order of every gradient.
    pub names: Vec<String>,
    /// The gradient of every named value expressions read (parameters and actuator
    /// quantities `<actuator>.<quantity>`).
    pub values: Arc<BTreeMap<String, Grad>>,
    /// Per program, per phase.
    pub phases: Vec<Vec<PhaseTangent>>,
    /// Per actuator, its torque law with the gradients of its data.
    pub actuators: Vec<ActuatorLaw>,
    pub kp_free: Grad,
    pub kd_free: Grad,
}

impl PlanTangent {
    /// The index of each name, or `None` if one is not a parameter of the behaviour.
    pub fn indices(&self, names: &[&str]) -> Option<Vec<usize>> {
        let mut out = Vec::with_capacity(names.len());
        self.indices_into(names, &mut out).then_some(out)
    }

    /// [`Self::indices`] into `out` (its old contents discarded); `false` if a name is not
    /// a parameter of the behaviour.
    pub fn indices_into(&self, names: &[&str], out: &mut Vec<usize>) -> bool {
        out.clear();
        for n in names {
            match self.names.iter().position(|m| m == n) {
                Some(i) => out.push(i),
                None => return false,
            }
        }
        true
    }
}

/// The gradients of one phase's numbers.
pub(crate) struct PhaseTangent {
    /// Of its start's times (`Start::times`, in order).
    pub times: Vec<Grad>,
    /// Of its start's delays after other phases (`Start::phases`, in order).
    pub delays: Vec<Grad>,
    pub torque: TorqueTangent,
    /// Of its motion's numbers, in the order `speed`, `accel`, `target` (a hold's angle is
    /// its target; a park has no speed).
    pub motion: [NumberTangent; 3],
}

/// The gradients of a torque law's numbers (the variants of `TorqueLaw`).
pub(crate) enum TorqueTangent {
    Zero,
    Constant(Grad),
    Schedule {
        times: Vec<Grad>,
        torques: Vec<Grad>,
    },
    Servo {
        target: Option<Grad>,
        kp: Grad,
        kd: Grad,
        /// Zero without a limit.
        limit: Grad,
    },
    Motor {
        command: Grad,
    },
}

/// The derivative of one number of a motion: a constant's gradient, or (a number of
/// `theta`, `omega`, the joint's angle and rate where the motion starts) its formula, with
/// the constants it reads.
#[derive(Clone)]
pub(crate) enum NumberTangent {
    Const(Grad),
    AtStart(Arc<Expr>, Arc<Vec<(String, f64)>>),
}

/// A number's partials: over the parameters, and over the start's `θ₀`, `ω₀`.
#[derive(Debug, Clone)]
pub(crate) struct NumberPartials {
    pub dp: Vec<f64>,
    pub dtheta: f64,
    pub domega: f64,
}

impl NumberTangent {
    /// The partials at the start `(θ₀, ω₀)`; `values` the plan's gradients of named values.
    pub fn at(
        &self,
        theta: f64,
        omega: f64,
        values: &BTreeMap<String, Grad>,
        n: usize,
    ) -> NumberPartials {
        match self {
            NumberTangent::Const(g) => NumberPartials {
                dp: g.to_vec(),
                dtheta: 0.0,
                domega: 0.0,
            },
            NumberTangent::AtStart(e, consts) => {
                // inputs: the parameters, then θ₀ and ω₀
                let unit = |i: usize| {
                    let mut d = vec![0.0; n + 2];
                    d[i] = 1.0;
                    d
                };
                let lookup = |name: &str| -> Option<Dual> {
                    match name {
                        "theta" => Some((theta, unit(n))),
                        "omega" => Some((omega, unit(n + 1))),
                        _ => {
                            let v = consts.iter().find(|(k, _)| k == name)?.1;
                            let mut d = vec![0.0; n + 2];
                            if let Some(g) = values.get(name) {
                                d[..n].copy_from_slice(g);
                            }
                            Some((v, d))
                        }
                    }
                };
                let (_, d) = e
                    .eval_grad(n + 2, &lookup)
                    .unwrap_or((f64::NAN, vec![f64::NAN; n + 2]));
                NumberPartials {
                    dp: d[..n].to_vec(),
                    dtheta: d[n],
                    domega: d[n + 1],
                }
            }
        }
    }
}

/// An actuator's torque law for its partial derivatives, with the gradients of the data it
/// depends on: the ideal torque source `τ = clamp(u) τ_max`, or `n` geared DC motors in
/// parallel, `τ = n G e clamp(s a₀, ±k_M I_max)`, `a₀ = τ_st (u − G ω/ω₀)` (thesis 2.1.2: the
/// motor's stall torque `τ_st` and no-load speed `ω₀` at the supply voltage `V` — both
/// proportional to it — the current-limited torque `k_M I_max`, the gearbox's ratio `G` and
/// efficiency `η`), with the drive's loss options ([`GearedLosses`], `motor::DriveLosses`):
/// the battery's sag `s = R/(R + u² R_b)` (1 on an ideal supply) and the gearbox factor
/// `e = η`, or `1/η` where the power-flow law is back-driven (`τ_m ω_m < 0`).
pub(crate) enum ActuatorLaw {
    Saturated { max_n_m: f64, dmax: Grad },
    Geared(GearedLaw),
}

/// `n` geared DC motors in parallel ([`ActuatorLaw::Geared`]): the data of the law and the
/// gradients of those the parameters move.
pub(crate) struct GearedLaw {
    pub n: f64,
    pub ratio: f64,
    pub efficiency: f64,
    pub stall_n_m: f64,
    pub no_load_rad_s: f64,
    pub torque_constant_n_m_per_a: f64,
    pub current_limit_a: f64,
    pub voltage_v: f64,
    pub losses: GearedLosses,
    pub dn: Grad,
    pub dratio: Grad,
    pub dcurrent: Grad,
    pub dvoltage: Grad,
    pub defficiency: Grad,
    pub dbattery: Grad,
}

/// The loss options of a geared law (`motor::DriveLosses`): the power-flow gearbox law, the
/// battery's internal resistance `R_b` (Ω) and the motor's terminal resistance `R` (Ω,
/// `k_M V/τ_st`, independent of `V`).
pub(crate) struct GearedLosses {
    pub power_flow: bool,
    pub battery_resistance_ohm: f64,
    pub terminal_resistance_ohm: f64,
}

impl GearedLosses {
    /// The battery's sag of the winding current at command `u`, `R/(R + u² R_b)` (exactly 1
    /// on an ideal supply).
    fn sag(&self, u: f64) -> f64 {
        if self.battery_resistance_ohm == 0.0 {
            1.0
        } else {
            let r = self.terminal_resistance_ohm;
            r / (r + u * u * self.battery_resistance_ohm)
        }
    }
}

/// A piece of a geared law: at the current limit (not on the torque–speed line), and
/// back-driven under the power-flow gearbox law.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct GearedPiece {
    pub on_limit: bool,
    pub back_driven: bool,
}

impl ActuatorLaw {
    /// The gradient of the stall torque at the joint, `τ(1, 0)`: `τ_max`'s, or of
    /// `n G η min(s₁ τ_st, k_M I_max)` (`s₁ = R/(R + R_b)`; standstill drives the gearbox) the
    /// branch's (at a tie, where a current limit equals the stall torque, the torque–speed
    /// line's: the side a motor leaving standstill takes).
    pub fn stall_grad(&self) -> Grad {
        match self {
            ActuatorLaw::Saturated { dmax, .. } => dmax.clone(),
            ActuatorLaw::Geared(g) => {
                let limit = g.torque_constant_n_m_per_a * g.current_limit_a;
                let sag = g.losses.sag(1.0);
                let stall = g.stall_n_m * sag;
                let tau = g.n * g.ratio * g.efficiency * stall.min(limit);
                let on_line = stall <= limit;
                let terms: [(f64, Option<&Grad>); 6] = [
                    (tau / g.n, Some(&g.dn)),
                    (tau / g.ratio, Some(&g.dratio)),
                    (
                        if on_line {
                            0.0
                        } else {
                            tau / g.current_limit_a
                        },
                        Some(&g.dcurrent),
                    ),
                    (
                        if on_line { tau / g.voltage_v } else { 0.0 },
                        Some(&g.dvoltage),
                    ),
                    (tau / g.efficiency, Some(&g.defficiency)),
                    (
                        if on_line {
                            -tau * sag / g.losses.terminal_resistance_ohm
                        } else {
                            0.0
                        },
                        Some(&g.dbattery),
                    ),
                ];
                sum(&terms).expect("gradients given")
            }
        }
    }

    /// The gradient of the no-load output speed `ω₀ / G` (`ω₀ ∝ V`; the losses leave it).
    pub fn no_load_speed_grad(&self) -> Grad {
        match self {
            ActuatorLaw::Saturated { dmax, .. } => vec![0.0; dmax.len()].into(),
            ActuatorLaw::Geared(g) => {
                let w = g.no_load_rad_s / g.ratio;
                sum(&[
                    (-w / g.ratio, Some(&g.dratio)),
                    (w / g.voltage_v, Some(&g.dvoltage)),
                ])
                .expect("gradients given")
            }
        }
    }

    /// The gradient of the rotors' inertia reflected to the joint, `n J G²` (`J` the rotor's,
    /// from the catalog at its own voltage).
    pub fn reflected_inertia_grad(&self, rotor_kg_m2: f64) -> Grad {
        match self {
            ActuatorLaw::Saturated { dmax, .. } => vec![0.0; dmax.len()].into(),
            ActuatorLaw::Geared(g) => sum(&[
                (rotor_kg_m2 * g.ratio * g.ratio, Some(&g.dn)),
                (2.0 * g.n * rotor_kg_m2 * g.ratio, Some(&g.dratio)),
            ])
            .expect("gradients given"),
        }
    }

    /// `a₀ = τ_st (u − G ω/ω₀)`, the motor torque `s a₀` on the line (with the battery's sag
    /// `s`), and the current limit `k_M I_max`.
    fn line(&self, u: f64, speed: f64) -> (f64, f64, f64) {
        match self {
            ActuatorLaw::Saturated { .. } => (0.0, 0.0, f64::INFINITY),
            ActuatorLaw::Geared(g) => {
                let uc = u.clamp(-1.0, 1.0);
                let a0 = g.stall_n_m * (uc - speed * g.ratio / g.no_load_rad_s);
                (
                    a0,
                    a0 * g.losses.sag(uc),
                    g.torque_constant_n_m_per_a * g.current_limit_a,
                )
            }
        }
    }

    /// The joint speed at which the branch of the law is read: `speed`, or, where the state
    /// sits on the kink between the current limit and the torque–speed line (within
    /// round-off: `|a|` at most 1e-9 above the limit), nudged into the branch a joint its
    /// motor accelerates moves into. A drive whose current limit equals its stall torque
    /// has that kink at standstill: a joint that starts from rest runs on the line for
    /// every `t > t₀`, and the partials at its first instant must be the line's.
    fn branch_speed(&self, u: f64, speed: f64) -> f64 {
        if let ActuatorLaw::Geared(g) = self {
            let (_, a, limit) = self.line(u, speed);
            if a.abs() >= limit && a.abs() <= limit * (1.0 + 1e-9) && u != 0.0 {
                return speed + u.signum() * 2e-9 * g.no_load_rad_s / g.ratio;
            }
        }
        speed
    }

    /// The law's piece at command `u` and joint speed `ω`, on the side
    /// [`Self::branch_speed`] reads: at the current limit or on the torque–speed line, and
    /// (power-flow gearbox law only) back-driven, `τ_m ω < 0`. The ideal torque source has
    /// one piece.
    pub fn piece(&self, u: f64, speed: f64) -> GearedPiece {
        let (_, a, limit) = self.line(u, self.branch_speed(u, speed));
        let power_flow = matches!(self, ActuatorLaw::Geared(g) if g.losses.power_flow);
        GearedPiece {
            on_limit: a.abs() >= limit,
            back_driven: power_flow && a * speed < 0.0,
        }
    }

    /// Whether the state sits at the power-flow law's jump: back-driven, within round-off
    /// of rest (`0 < |ω| ≤ 1e-9 ω₀/G`), with `η < 1` — the torque jumps there by `η²` when
    /// the speed changes sign under load, without an event, so a derivative carried across
    /// it is not defined. The sensitivities split their steps where [`Self::piece`] changes,
    /// so a crossing either way puts a stage at the kink on its back-driven side: this says
    /// so there. (A motor that starts from rest back-driven says so too: conservative.) Off
    /// for the derating law.
    pub fn at_power_flow_jump(&self, u: f64, speed: f64) -> bool {
        match self {
            ActuatorLaw::Geared(g) if g.losses.power_flow && g.efficiency < 1.0 => {
                let (_, a, _) = self.line(u, speed);
                a * speed < 0.0 && speed.abs() <= 1e-9 * g.no_load_rad_s / g.ratio
            }
            _ => false,
        }
    }

    /// `∂τ/∂ω` and `∂τ/∂p` (over the parameters, `du` the command's gradient) at command `u`
    /// and joint speed `ω`, on the piece [`Self::piece`] says:
    ///
    /// - saturated: `∂τ/∂ω = 0`, `∂τ/∂p = u ∂τ_max/∂p + τ_max ∂u/∂p` (inside `|u| < 1`);
    /// - on the line `τ = c s a₀`, `c = n G e`: `∂τ/∂ω = −c s G τ_st/ω₀`,
    ///   `∂τ/∂G = n e s (a₀ − G τ_st ω/ω₀)`, `∂τ/∂n = G e s a₀`, `∂τ/∂V = c s u τ_st/V`
    ///   (`τ_st/ω₀` and `R` do not depend on `V`), `∂τ/∂η = ±τ/η` (`+` driving, `−`
    ///   back-driven), `∂τ/∂R_b = −c a₀ u² s²/R`, `∂τ/∂u = c (s τ_st − 2 u R_b s² a₀/R)`;
    /// - at the limit `τ = ±n G e k_M I_max`: `∂τ/∂G = τ/G`, `∂τ/∂n = τ/n`,
    ///   `∂τ/∂I_max = τ/I_max`, `∂τ/∂η = ±τ/η`.
    ///
    /// `∂τ/∂p` is written into `d` (its old contents and length discarded).
    pub fn partials(&self, u: f64, du: &[f64], speed: f64, d: &mut Vec<f64>) -> f64 {
        let inside = u.abs() < 1.0;
        d.clear();
        match self {
            ActuatorLaw::Saturated { max_n_m, dmax } => {
                let uc = u.clamp(-1.0, 1.0);
                d.extend(dmax.iter().map(|x| uc * x));
                if inside {
                    axpy(d, *max_n_m, du);
                }
                0.0
            }
            ActuatorLaw::Geared(g) => {
                let w = self.branch_speed(u, speed);
                let (a0, a, limit) = self.line(u, w);
                let piece = self.piece(u, speed);
                // the gearbox factor `e` and `∂e/∂η / e`
                let (e, de) = if piece.back_driven {
                    (1.0 / g.efficiency, -1.0 / g.efficiency)
                } else {
                    (g.efficiency, 1.0 / g.efficiency)
                };
                let (ratio, stall_n_m, no_load_rad_s) = (g.ratio, g.stall_n_m, g.no_load_rad_s);
                let c = g.n * ratio * e;
                d.resize(du.len(), 0.0);
                if !piece.on_limit {
                    let uc = u.clamp(-1.0, 1.0);
                    let sag = g.losses.sag(uc);
                    axpy(d, e * ratio * a, &g.dn);
                    axpy(
                        d,
                        g.n * e * sag * (a0 - ratio * stall_n_m * w / no_load_rad_s),
                        &g.dratio,
                    );
                    axpy(d, c * sag * uc * stall_n_m / g.voltage_v, &g.dvoltage);
                    axpy(d, c * a * de, &g.defficiency);
                    let r = g.losses.terminal_resistance_ohm;
                    axpy(d, -c * a0 * uc * uc * sag * sag / r, &g.dbattery);
                    if inside {
                        let r_b = g.losses.battery_resistance_ohm;
                        let da_du = sag * stall_n_m - 2.0 * uc * r_b * sag * sag * a0 / r;
                        axpy(d, c * da_du, du);
                    }
                    -c * sag * stall_n_m * ratio / no_load_rad_s
                } else {
                    let tau = c * a.signum() * limit;
                    axpy(d, tau / g.n, &g.dn);
                    axpy(d, tau / ratio, &g.dratio);
                    axpy(d, tau / g.current_limit_a, &g.dcurrent);
                    axpy(d, tau * de, &g.defficiency);
                    0.0
                }
            }
        }
    }
}
