//! The leg observer of thesis section 2.2 (eqs. (2.2)–(2.5), Fig. 2.11), the
//! fault-identification state machine of Fig. 2.13, the "Buehler clock" reference of a
//! RHex gait, and the Nelder–Mead calibration of the observer on a free-swing log.
//!
//! The observer runs the flight model of one leg on the same reference as the real leg:
//!
//! ```text
//!   ω̂̇ = −A_m ω̂ + K_m ê,   θ̂̇ = ω̂                                   (2.2)
//!   ê = K_p ⟨θ_d − θ̂⟩ + K_d (ω_d − ω̂) + K_g sin(θ̂ + θ_g)               (2.3)–(2.4)
//! ```
//!
//! (`⟨·⟩` wraps to (−π, π]), advanced one sample at a time by RK4 with the reference held,
//! and its output is held in a buffer for the transport delay `T_del` (fractional delays
//! interpolate linearly). The residuals are `r_θ = ⟨θ̂ − θ⟩`, `r_ω = ω̂ − ω` (2.5).
use crate::error::{finite, finite_samples, non_negative, positive, MotorError, Result};
use crate::nelder_mead::{minimize, NelderMeadOptions};
use crate::numeric::rk4_step;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::f64::consts::{PI, TAU};

/// Wraps an angle to (−π, π] (thesis footnotes 8 and 11).
pub fn wrap_angle(angle_rad: f64) -> f64 {
    let r = angle_rad.rem_euclid(TAU);
    if r > PI {
        r - TAU
    } else {
        r
    }
}

/// Parameters of the observer (2.2)–(2.4) and its delay.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObserverParams {
    /// Motor gain `K_m` [1/s² per unit error].
    pub k_m: f64,
    /// Motor pole `A_m` [1/s].
    pub a_m: f64,
    /// Proportional gain `K_p` (taken from the leg controller, not calibrated).
    pub k_p: f64,
    /// Derivative gain `K_d` (s).
    pub k_d: f64,
    /// Gravity magnitude `K_g`.
    pub k_g: f64,
    /// Gravity angle offset `θ_g` (rad).
    pub theta_g_rad: f64,
    /// Transport delay `T_del` (s).
    pub delay_s: f64,
}

impl ObserverParams {
    pub fn validate(&self) -> Result<()> {
        positive("k_m", self.k_m)?;
        non_negative("a_m", self.a_m)?;
        non_negative("k_p", self.k_p)?;
        non_negative("k_d", self.k_d)?;
        finite("k_g", self.k_g)?;
        finite("theta_g_rad", self.theta_g_rad)?;
        non_negative("delay_s", self.delay_s)?;
        Ok(())
    }

    /// `(θ̇, ω̇)` of the flight model for a held reference.
    fn derivative(&self, theta: f64, omega: f64, theta_d: f64, omega_d: f64) -> (f64, f64) {
        let e = self.k_p * wrap_angle(theta_d - theta)
            + self.k_d * (omega_d - omega)
            + self.k_g * (theta + self.theta_g_rad).sin();
        (omega, -self.a_m * omega + self.k_m * e)
    }

    /// One RK4 step of length `dt` with the reference held.
    fn rk4(&self, theta: f64, omega: f64, theta_d: f64, omega_d: f64, dt: f64) -> (f64, f64) {
        rk4_step(theta, omega, dt, |th, w| {
            self.derivative(th, w, theta_d, omega_d)
        })
    }
}

/// Observer output: delayed estimates and residuals.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ObserverSample {
    pub theta_hat_rad: f64,
    pub omega_hat_rad_s: f64,
    pub r_theta_rad: f64,
    pub r_omega_rad_s: f64,
}

/// The running observer of one leg (allocation-free per sample).
#[derive(Debug, Clone)]
pub struct LegObserver {
    params: ObserverParams,
    dt_s: f64,
    theta: f64,
    omega: f64,
    delay_samples: f64,
    /// Past estimates `(θ̂, ω̂)`, newest last.
    history: VecDeque<(f64, f64)>,
}

impl LegObserver {
    /// Starts at the leg's measured state (as if it had been there for the whole delay).
    pub fn new(
        params: ObserverParams,
        dt_s: f64,
        theta0_rad: f64,
        omega0_rad_s: f64,
    ) -> Result<Self> {
        params.validate()?;
        let dt_s = positive("dt_s", dt_s)?;
        finite("theta0_rad", theta0_rad)?;
        finite("omega0_rad_s", omega0_rad_s)?;
        let delay_samples = params.delay_s / dt_s;
        // the delay line holds `⌊D⌋ + 2` samples: bounded before it is allocated
        if delay_samples > MAX_DELAY_SAMPLES as f64 {
            return Err(MotorError::InvalidParameter {
                field: "delay_s",
                value: params.delay_s,
                reason: "the delay spans more samples of dt_s than the observer holds \
                         (MAX_DELAY_SAMPLES)",
            });
        }
        let len = delay_samples.floor() as usize + 2;
        Ok(Self {
            params,
            dt_s,
            theta: theta0_rad,
            omega: omega0_rad_s,
            delay_samples,
            history: std::iter::repeat_n((theta0_rad, omega0_rad_s), len).collect(),
        })
    }

    /// Advances the model by one sample on the reference `(θ_d, ω_d)` and compares its
    /// delayed output with the measured `(θ, ω)`.
    pub fn update(&mut self, theta_d: f64, omega_d: f64, theta: f64, omega: f64) -> ObserverSample {
        (self.theta, self.omega) = self
            .params
            .rk4(self.theta, self.omega, theta_d, omega_d, self.dt_s);
        self.history.pop_front();
        self.history.push_back((self.theta, self.omega));
        // delayed output: D samples back, linear between neighbours
        let n = self.history.len();
        let whole = self.delay_samples.floor();
        let frac = self.delay_samples - whole;
        let (t0, w0) = self.history[n - 1 - whole as usize];
        let (t1, w1) = self.history[n - 2 - whole as usize];
        let theta_hat = t0 + frac * (t1 - t0);
        let omega_hat = w0 + frac * (w1 - w0);
        ObserverSample {
            theta_hat_rad: wrap_angle(theta_hat),
            omega_hat_rad_s: omega_hat,
            r_theta_rad: wrap_angle(theta_hat - theta),
            r_omega_rad_s: omega_hat - omega,
        }
    }
}

/// A logged leg run: reference and encoder readings at a fixed sample time.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct LegLog {
    pub dt_s: f64,
    pub theta_d_rad: Vec<f64>,
    pub omega_d_rad_s: Vec<f64>,
    pub theta_rad: Vec<f64>,
    pub omega_rad_s: Vec<f64>,
}

impl LegLog {
    pub fn len(&self) -> usize {
        self.theta_rad.len()
    }
    pub fn is_empty(&self) -> bool {
        self.theta_rad.is_empty()
    }

    /// Equal lengths, at least two samples, no NaN.
    pub fn validate(&self) -> Result<()> {
        positive("dt_s", self.dt_s)?;
        let n = self.theta_rad.len();
        if n < 2 {
            return Err(MotorError::TooFewSamples {
                field: "theta_rad",
                required: 2,
                actual: n,
            });
        }
        for (field, v) in [
            ("theta_d_rad", &self.theta_d_rad),
            ("omega_d_rad_s", &self.omega_d_rad_s),
            ("omega_rad_s", &self.omega_rad_s),
        ] {
            if v.len() != n {
                return Err(MotorError::LengthMismatch {
                    field,
                    expected: n,
                    actual: v.len(),
                });
            }
        }
        finite_samples("theta_d_rad", &self.theta_d_rad)?;
        finite_samples("omega_d_rad_s", &self.omega_d_rad_s)?;
        finite_samples("theta_rad", &self.theta_rad)?;
        finite_samples("omega_rad_s", &self.omega_rad_s)?;
        Ok(())
    }
}

/// The most samples of `dt_s` a transport delay may span ([`LegObserver::new`]): a delay line
/// of 10⁷ samples (160 MB) is far beyond any logged leg, and it bounds the allocation.
pub const MAX_DELAY_SAMPLES: usize = 10_000_000;

/// Runs the observer over a log; sample 0 initializes it. A delay longer than the log leaves
/// no sample of the model to compare with it: an error naming `delay_s`.
pub fn observe(params: &ObserverParams, log: &LegLog) -> Result<Vec<ObserverSample>> {
    log.validate()?;
    params.validate()?;
    if params.delay_s > log.dt_s * log.len() as f64 {
        return Err(MotorError::InvalidParameter {
            field: "delay_s",
            value: params.delay_s,
            reason: "must not exceed the log's duration (dt_s × samples)",
        });
    }
    observe_unchecked(params, log)
}

fn observe_unchecked(params: &ObserverParams, log: &LegLog) -> Result<Vec<ObserverSample>> {
    let mut observer = LegObserver::new(*params, log.dt_s, log.theta_rad[0], log.omega_rad_s[0])?;
    Ok((0..log.len())
        .map(|k| {
            observer.update(
                log.theta_d_rad[k],
                log.omega_d_rad_s[k],
                log.theta_rad[k],
                log.omega_rad_s[k],
            )
        })
        .collect())
}

/// Result of [`calibrate`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Calibration {
    pub params: ObserverParams,
    pub rms_r_theta_rad: f64,
    pub rms_r_omega_rad_s: f64,
    pub evaluations: usize,
}

/// Weight of the velocity residual in the calibration cost `mean r_θ² + w mean r_ω²` (s²).
pub const CALIBRATION_OMEGA_WEIGHT_S2: f64 = 1e-3;

/// Calibrates `(K_m, A_m, K_g, θ_g, K_d, T_del)` on a free-swing log by Nelder–Mead from
/// `initial` (thesis section 2.2.1: "using a hand-tuned starting simplex"); `K_p` is kept
/// from `initial`. The cost is `mean r_θ² + w mean r_ω²` with
/// `w =` [`CALIBRATION_OMEGA_WEIGHT_S2`]; the simplex is restarted from its best vertex
/// until a restart no longer improves the cost.
pub fn calibrate(log: &LegLog, initial: &ObserverParams) -> Result<Calibration> {
    log.validate()?;
    initial.validate()?;
    let max_delay = 0.25 * log.dt_s * log.len() as f64;
    let unpack = |x: &[f64]| ObserverParams {
        k_m: x[0],
        a_m: x[1],
        k_g: x[2],
        theta_g_rad: x[3],
        k_d: x[4],
        delay_s: x[5],
        k_p: initial.k_p,
    };
    let cost = |p: &ObserverParams| -> f64 {
        if p.validate().is_err() || p.delay_s > max_delay {
            return f64::INFINITY;
        }
        match observe_unchecked(p, log) {
            Ok(samples) => {
                let n = samples.len() as f64;
                let (mut st, mut sw) = (0.0, 0.0);
                for s in &samples {
                    st += s.r_theta_rad * s.r_theta_rad;
                    sw += s.r_omega_rad_s * s.r_omega_rad_s;
                }
                (st + CALIBRATION_OMEGA_WEIGHT_S2 * sw) / n
            }
            Err(_) => f64::INFINITY,
        }
    };
    let mut x = vec![
        initial.k_m,
        initial.a_m,
        initial.k_g,
        initial.theta_g_rad,
        initial.k_d,
        initial.delay_s,
    ];
    let mut best = cost(&unpack(&x));
    let mut evaluations = 1;
    for _restart in 0..8 {
        let step: Vec<f64> = vec![
            0.2 * x[0].abs().max(1e-3),
            0.2 * x[1].abs().max(1e-3),
            0.2 * x[2].abs().max(1e-3),
            0.2,
            0.2 * x[4].abs().max(1e-3),
            (0.2 * x[5]).max(2.0 * log.dt_s),
        ];
        let result = minimize(
            |v| cost(&unpack(v)),
            &x,
            &step,
            NelderMeadOptions {
                f_tolerance: 1e-16,
                x_tolerance: 1e-9,
                max_evaluations: 6000,
            },
        );
        evaluations += result.evaluations;
        let improved = result.f < best * (1.0 - 1e-6);
        if result.f <= best {
            best = result.f;
            x = result.x;
        }
        if !improved {
            break;
        }
    }
    if !best.is_finite() {
        return Err(MotorError::NoConvergence {
            what: "observer calibration",
            reason: "no parameter vector gave a finite cost".into(),
        });
    }
    let params = unpack(&x);
    let samples = observe_unchecked(&params, log)?;
    let n = samples.len() as f64;
    Ok(Calibration {
        params,
        rms_r_theta_rad: (samples.iter().map(|s| s.r_theta_rad.powi(2)).sum::<f64>() / n).sqrt(),
        rms_r_omega_rad_s: (samples.iter().map(|s| s.r_omega_rad_s.powi(2)).sum::<f64>() / n)
            .sqrt(),
        evaluations,
    })
}

/// The "Buehler clock" of a RHex gait: each leg sweeps `sweep_rad` around `center_rad`
/// slowly during the stance fraction `duty_factor` of the period, and the remaining
/// `2π − sweep` quickly in flight. Angles increase in the direction of leg recirculation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BuehlerClock {
    pub period_s: f64,
    pub duty_factor: f64,
    pub sweep_rad: f64,
    pub center_rad: f64,
}

impl BuehlerClock {
    pub fn new(period_s: f64, duty_factor: f64, sweep_rad: f64, center_rad: f64) -> Result<Self> {
        positive("period_s", period_s)?;
        positive("duty_factor", duty_factor)?;
        positive("sweep_rad", sweep_rad)?;
        if duty_factor >= 1.0 || sweep_rad >= TAU {
            return Err(MotorError::InvalidParameter {
                field: if duty_factor >= 1.0 {
                    "duty_factor"
                } else {
                    "sweep_rad"
                },
                value: if duty_factor >= 1.0 {
                    duty_factor
                } else {
                    sweep_rad
                },
                reason: "duty factor must be < 1 and sweep < 2π",
            });
        }
        Ok(Self {
            period_s,
            duty_factor,
            sweep_rad,
            center_rad: finite("center_rad", center_rad)?,
        })
    }

    /// Reference `(θ_d, ω_d)` at gait phase `phase ∈ [0, 1)` (stance starts at phase 0),
    /// `θ_d` wrapped to (−π, π].
    pub fn reference_at_phase(&self, phase: f64) -> (f64, f64) {
        let p = phase.rem_euclid(1.0);
        let start = self.center_rad - 0.5 * self.sweep_rad;
        if p < self.duty_factor {
            (
                wrap_angle(start + self.sweep_rad * p / self.duty_factor),
                self.sweep_rad / (self.duty_factor * self.period_s),
            )
        } else {
            let flight = TAU - self.sweep_rad;
            (
                wrap_angle(
                    start
                        + self.sweep_rad
                        + flight * (p - self.duty_factor) / (1.0 - self.duty_factor),
                ),
                flight / ((1.0 - self.duty_factor) * self.period_s),
            )
        }
    }
}

/// Where in its cycle a leg is (thesis: G, T, A, L).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum LegPhase {
    Landing,
    Ground,
    Takeoff,
    Air,
}

/// Partition of the leg circle into four consecutive arcs in the direction of rotation:
/// landing `[landing_start, ground_start)`, ground `[ground_start, takeoff_start)`,
/// takeoff `[takeoff_start, air_start)`, air `[air_start, landing_start)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PhasePartition {
    pub landing_start_rad: f64,
    pub ground_start_rad: f64,
    pub takeoff_start_rad: f64,
    pub air_start_rad: f64,
}

impl PhasePartition {
    fn offsets(&self) -> (f64, f64, f64) {
        let o = |a: f64| (a - self.landing_start_rad).rem_euclid(TAU);
        (
            o(self.ground_start_rad),
            o(self.takeoff_start_rad),
            o(self.air_start_rad),
        )
    }

    pub fn validate(&self) -> Result<()> {
        for (field, v) in [
            ("landing_start_rad", self.landing_start_rad),
            ("ground_start_rad", self.ground_start_rad),
            ("takeoff_start_rad", self.takeoff_start_rad),
            ("air_start_rad", self.air_start_rad),
        ] {
            finite(field, v)?;
        }
        let (g, t, a) = self.offsets();
        if !(0.0 < g && g < t && t < a) {
            return Err(MotorError::InvalidParameter {
                field: "phase_partition",
                value: a,
                reason: "arcs must follow landing → ground → takeoff → air around the circle",
            });
        }
        Ok(())
    }

    pub fn classify(&self, theta_rad: f64) -> LegPhase {
        let (g, t, a) = self.offsets();
        let x = (theta_rad - self.landing_start_rad).rem_euclid(TAU);
        if x < g {
            LegPhase::Landing
        } else if x < t {
            LegPhase::Ground
        } else if x < a {
            LegPhase::Takeoff
        } else {
            LegPhase::Air
        }
    }
}

/// Residual level: `|r_θ| < low` is L, `|r_θ| ≥ high` is H, between is M (the pair of
/// disconnected "medium" intervals of the thesis).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum ResidualLevel {
    Low,
    Medium,
    High,
}

/// The states of Fig. 2.13.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum LegState {
    Stance,
    PossibleTakeoff,
    Flight,
    PossibleLanding,
    UnexpectedDisturbance,
    MissingGround,
}

impl LegState {
    /// The two error states.
    pub fn is_fault(self) -> bool {
        matches!(self, Self::UnexpectedDisturbance | Self::MissingGround)
    }
}

/// Configuration of the fault-identification machine.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FaultFsmConfig {
    pub phases: PhasePartition,
    pub low_residual_rad: f64,
    pub high_residual_rad: f64,
    /// Minimum lingering time in every state before it may be left (s).
    pub min_dwell_s: f64,
    /// False for a leg that is not expected to meet the ground (a free-spin calibration
    /// run): "missing ground" is then never declared.
    pub expect_ground: bool,
}

impl FaultFsmConfig {
    pub fn validate(&self) -> Result<()> {
        self.phases.validate()?;
        positive("low_residual_rad", self.low_residual_rad)?;
        positive("high_residual_rad", self.high_residual_rad)?;
        if self.high_residual_rad <= self.low_residual_rad {
            return Err(MotorError::InvalidParameter {
                field: "high_residual_rad",
                value: self.high_residual_rad,
                reason: "must exceed low_residual_rad",
            });
        }
        non_negative("min_dwell_s", self.min_dwell_s)?;
        Ok(())
    }

    pub fn level(&self, r_theta_rad: f64) -> ResidualLevel {
        let r = r_theta_rad.abs();
        if r < self.low_residual_rad {
            ResidualLevel::Low
        } else if r < self.high_residual_rad {
            ResidualLevel::Medium
        } else {
            ResidualLevel::High
        }
    }
}

/// The transition rule of Fig. 2.13 (the figure itself is not in the text; this table
/// implements the prose of section 2.2.1): a residual rise is expected in landing/ground
/// (→ possible landing → stance) and unexpected in takeoff/air (→ unexpected disturbance);
/// a low residual through the ground arc is missing ground; a falling residual in
/// takeoff/air leaves stance through possible takeoff.
pub fn next_state(
    state: LegState,
    phase: LegPhase,
    level: ResidualLevel,
    expect_ground: bool,
) -> LegState {
    use LegPhase::*;
    use LegState::*;
    use ResidualLevel::*;
    match state {
        Flight => match (level, phase) {
            (High, Landing | Ground) => Stance,
            (High, Takeoff | Air) => UnexpectedDisturbance,
            (Medium, Landing | Ground) => PossibleLanding,
            (Low, Ground) if expect_ground => MissingGround,
            _ => Flight,
        },
        PossibleLanding => match (level, phase) {
            (High, _) => Stance,
            (Low, Ground) if expect_ground => MissingGround,
            (Low, _) => Flight,
            _ => PossibleLanding,
        },
        Stance => match (level, phase) {
            (Medium | Low, Takeoff | Air) => PossibleTakeoff,
            _ => Stance,
        },
        PossibleTakeoff => match (level, phase) {
            (Low, _) => Flight,
            (High, Air) => UnexpectedDisturbance,
            (High, _) => Stance,
            _ => PossibleTakeoff,
        },
        UnexpectedDisturbance => match (level, phase) {
            (Low, _) => Flight,
            (High, Landing | Ground) => Stance,
            _ => UnexpectedDisturbance,
        },
        MissingGround => match (level, phase) {
            (High, Landing | Ground) => Stance,
            (Medium, Landing | Ground) => PossibleLanding,
            (_, Takeoff | Air) => Flight,
            _ => MissingGround,
        },
    }
}

/// The running state machine.
#[derive(Debug, Clone)]
pub struct FaultFsm {
    config: FaultFsmConfig,
    state: LegState,
    time_in_state_s: f64,
}

/// A state change of the machine.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StateChange {
    pub time_s: f64,
    pub from: LegState,
    pub to: LegState,
}

impl FaultFsm {
    pub fn new(config: FaultFsmConfig, initial: LegState) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            state: initial,
            time_in_state_s: 0.0,
        })
    }

    pub fn state(&self) -> LegState {
        self.state
    }

    /// Feeds one sample (leg angle, residual) after `dt_s`; returns the new state.
    pub fn step(&mut self, dt_s: f64, theta_rad: f64, r_theta_rad: f64) -> LegState {
        self.time_in_state_s += dt_s;
        if self.time_in_state_s + 1e-12 >= self.config.min_dwell_s {
            let next = next_state(
                self.state,
                self.config.phases.classify(theta_rad),
                self.config.level(r_theta_rad),
                self.config.expect_ground,
            );
            if next != self.state {
                self.state = next;
                self.time_in_state_s = 0.0;
            }
        }
        self.state
    }
}

/// Runs the observer and the state machine over a log (starting in flight) and returns the
/// state changes.
pub fn identify(
    params: &ObserverParams,
    config: &FaultFsmConfig,
    log: &LegLog,
) -> Result<Vec<StateChange>> {
    let samples = observe(params, log)?;
    let mut fsm = FaultFsm::new(*config, LegState::Flight)?;
    let mut changes = Vec::new();
    for (k, s) in samples.iter().enumerate() {
        let before = fsm.state();
        let after = fsm.step(log.dt_s, log.theta_rad[k], s.r_theta_rad);
        if after != before {
            changes.push(StateChange {
                time_s: k as f64 * log.dt_s,
                from: before,
                to: after,
            });
        }
    }
    Ok(changes)
}
