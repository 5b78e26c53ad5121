//! The two-node lumped thermal model of thesis Fig. 2.7 (section 2.1.3), its heat
//! coefficients, the winding-limited continuous torque, and the least-squares fit of the
//! case parameters to a heating/cooling log (Fig. 2.9).
//!
//! Node 1 is the winding ("core"), node 2 the housing ("case"); with `x = T − T_ambient`,
//!
//! ```text
//!   C₁ ẋ₁ = P − (x₁ − x₂)/R₁          P = I² R_c(T₁)  (Joule heat of the winding)
//!   C₂ ẋ₂ = (x₁ − x₂)/R₁ − x₂/R₂
//! ```
//!
//! with time constants `τ₁ = R₁C₁`, `τ₂ = R₂C₂` (maxon's "thermal time constants winding /
//! motor", thesis footnote 5). The steady state is `x₁ = P(R₁+R₂)`, `x₂ = P R₂`.
//! Between samples the heat input is held constant and the state is advanced exactly
//! (`x ← x* + e^{AΔt}(x − x*)`), so the step size only matters where the winding
//! resistance depends on temperature.
use crate::dc::Drive;
use crate::error::{
    at_most, finite, finite_samples, no_overflow, non_negative, positive, MotorError, Result,
};
use crate::nelder_mead::{minimize, NelderMeadOptions};
use serde::{Deserialize, Serialize};

/// Copper's temperature coefficient of resistance [1/K] (at 25 °C), for
/// [`ThermalModel::with_winding_alpha`]. The thesis's model uses a constant resistance.
pub const COPPER_ALPHA_PER_K: f64 = 0.00393;

/// Maximum winding temperature of the maxon motors in Table 2.1 [°C].
pub const MAX_WINDING_TEMPERATURE_C: f64 = 125.0;

/// Absolute zero [°C]: no ambient temperature lies below it.
pub const ABSOLUTE_ZERO_C: f64 = -273.15;

/// The most samples a thermal simulation runs ([`ThermalModel::simulate`]): 10⁷ samples are
/// four months at 1 s, and 240 MB of trace.
pub const MAX_PROFILE_SAMPLES: usize = 10_000_000;

/// The heat input of a thermal simulation ([`ThermalModel::simulate`]), one sample per
/// time step.
#[derive(Debug, Clone, Copy)]
pub enum HeatInput<'a> {
    /// Heat flow into the winding (W).
    Power(&'a [f64]),
    /// Winding current (A); its Joule heat uses the winding resistance at the core
    /// temperature at the start of each sample.
    Current(&'a [f64]),
    /// Output torque of `drive` (N m, Fig. 2.8), the winding current `I = τ_out / (k_M G η)`.
    OutputTorque {
        drive: &'a Drive,
        torque_n_m: &'a [f64],
    },
}

impl<'a> HeatInput<'a> {
    /// The profile's field name (for errors) and its samples.
    fn profile(&self) -> (&'static str, &'a [f64]) {
        match *self {
            HeatInput::Power(p) => ("power_w", p),
            HeatInput::Current(i) => ("current_a", i),
            HeatInput::OutputTorque { torque_n_m, .. } => ("torque_n_m", torque_n_m),
        }
    }
}

/// Core (winding) and case (housing) temperatures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThermalState {
    pub core_c: f64,
    pub case_c: f64,
}

impl ThermalState {
    /// Both nodes at the ambient temperature.
    pub fn ambient(ambient_c: f64) -> Self {
        Self {
            core_c: ambient_c,
            case_c: ambient_c,
        }
    }
}

/// A simulated temperature history: sample `k` at `k·dt`, the initial state first.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ThermalTrace {
    pub time_s: Vec<f64>,
    pub core_c: Vec<f64>,
    pub case_c: Vec<f64>,
}

/// Parameters of the two-node circuit of Fig. 2.7 plus the winding's electrical resistance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThermalModel {
    /// `R_th1`, winding to housing [K/W].
    pub r_core_case_k_per_w: f64,
    /// `R_th2`, housing to ambient [K/W].
    pub r_case_ambient_k_per_w: f64,
    /// `C_th1` [J/K].
    pub c_core_j_per_k: f64,
    /// `C_th2` [J/K].
    pub c_case_j_per_k: f64,
    /// `R_c` at `reference_temperature_c` (Ω).
    pub winding_resistance_ohm: f64,
    /// Temperature coefficient of `R_c` [1/K]; 0 reproduces the thesis's model.
    pub winding_alpha_per_k: f64,
    pub reference_temperature_c: f64,
}

impl ThermalModel {
    /// From thermal resistances and masses; constant winding resistance.
    pub fn new(
        r_core_case_k_per_w: f64,
        r_case_ambient_k_per_w: f64,
        c_core_j_per_k: f64,
        c_case_j_per_k: f64,
        winding_resistance_ohm: f64,
    ) -> Result<Self> {
        Ok(Self {
            r_core_case_k_per_w: positive("r_core_case_k_per_w", r_core_case_k_per_w)?,
            r_case_ambient_k_per_w: positive("r_case_ambient_k_per_w", r_case_ambient_k_per_w)?,
            c_core_j_per_k: positive("c_core_j_per_k", c_core_j_per_k)?,
            c_case_j_per_k: positive("c_case_j_per_k", c_case_j_per_k)?,
            winding_resistance_ohm: positive("winding_resistance_ohm", winding_resistance_ohm)?,
            winding_alpha_per_k: 0.0,
            reference_temperature_c: 25.0,
        })
    }

    /// From the datasheet's thermal resistances and time constants (`C = τ/R`).
    pub fn from_time_constants(
        r_core_case_k_per_w: f64,
        r_case_ambient_k_per_w: f64,
        tau_core_s: f64,
        tau_case_s: f64,
        winding_resistance_ohm: f64,
    ) -> Result<Self> {
        let r1 = positive("r_core_case_k_per_w", r_core_case_k_per_w)?;
        let r2 = positive("r_case_ambient_k_per_w", r_case_ambient_k_per_w)?;
        Self::new(
            r1,
            r2,
            positive("tau_core_s", tau_core_s)? / r1,
            positive("tau_case_s", tau_case_s)? / r2,
            winding_resistance_ohm,
        )
    }

    /// From the heat coefficients of section 2.1.3 for a drive,
    /// `H = R_c R_th / (k_M² G²)` [K/(N m)²], and the two time constants (Table 2.3's form).
    pub fn from_heat_coefficients(
        drive: &Drive,
        h_core_k_per_n2m2: f64,
        h_case_k_per_n2m2: f64,
        tau_core_s: f64,
        tau_case_s: f64,
    ) -> Result<Self> {
        let r_c = drive.motor.terminal_resistance_ohm();
        let kg2 = (drive.motor.torque_constant_n_m_per_a * drive.gearbox.ratio).powi(2);
        Self::from_time_constants(
            positive("h_core_k_per_n2m2", h_core_k_per_n2m2)? * kg2 / r_c,
            positive("h_case_k_per_n2m2", h_case_k_per_n2m2)? * kg2 / r_c,
            tau_core_s,
            tau_case_s,
            r_c,
        )
    }

    /// The same model with a temperature-dependent winding resistance
    /// `R_c(T) = R_c (1 + α (T − T_ref))`.
    pub fn with_winding_alpha(
        mut self,
        alpha_per_k: f64,
        reference_temperature_c: f64,
    ) -> Result<Self> {
        self.winding_alpha_per_k = non_negative("winding_alpha_per_k", alpha_per_k)?;
        self.reference_temperature_c = finite("reference_temperature_c", reference_temperature_c)?;
        Ok(self)
    }

    /// `(τ₁, τ₂) = (R₁C₁, R₂C₂)`.
    pub fn time_constants_s(&self) -> (f64, f64) {
        (
            self.r_core_case_k_per_w * self.c_core_j_per_k,
            self.r_case_ambient_k_per_w * self.c_case_j_per_k,
        )
    }

    /// Heat coefficients `(H_core, H_case)` of this motor behind `drive`'s gearbox, thesis
    /// section 2.1.3: `H = R_c R_th / (k_M² G²)`. They give the steady rise per squared
    /// *ideal* output torque `k_M G I`; with gearbox efficiency `η` the rise per squared
    /// actual output torque is `H/η²`.
    pub fn heat_coefficients(&self, drive: &Drive) -> (f64, f64) {
        let kg2 = (drive.motor.torque_constant_n_m_per_a * drive.gearbox.ratio).powi(2);
        (
            self.winding_resistance_ohm * self.r_core_case_k_per_w / kg2,
            self.winding_resistance_ohm * self.r_case_ambient_k_per_w / kg2,
        )
    }

    fn winding_resistance_at(&self, core_c: f64) -> f64 {
        self.winding_resistance_ohm
            * (1.0 + self.winding_alpha_per_k * (core_c - self.reference_temperature_c))
    }

    /// Steady state for a constant heat input.
    pub fn steady_state(&self, power_w: f64, ambient_c: f64) -> ThermalState {
        let case = power_w * self.r_case_ambient_k_per_w;
        ThermalState {
            core_c: ambient_c + case + power_w * self.r_core_case_k_per_w,
            case_c: ambient_c + case,
        }
    }

    /// Steady state for a constant winding current, with the temperature-dependent
    /// resistance: `x₁ = I² R_c (1 + α(T_a + x₁ − T_ref)) (R₁+R₂)`, linear in `x₁`.
    /// Errors when `I² R_c α (R₁+R₂) ≥ 1` (thermal runaway: no steady state).
    pub fn steady_state_for_current(&self, current_a: f64, ambient_c: f64) -> Result<ThermalState> {
        let g = current_a * current_a * self.winding_resistance_ohm;
        let r_sum = self.r_core_case_k_per_w + self.r_case_ambient_k_per_w;
        let denominator = 1.0 - g * self.winding_alpha_per_k * r_sum;
        if denominator <= 0.0 {
            return Err(MotorError::InvalidParameter {
                field: "current_a",
                value: current_a,
                reason:
                    "thermal runaway: the winding resistance grows faster than the heat can leave",
            });
        }
        let rise = g
            * r_sum
            * (1.0 + self.winding_alpha_per_k * (ambient_c - self.reference_temperature_c))
            / denominator;
        let power = rise / r_sum;
        Ok(self.steady_state(power, ambient_c))
    }

    /// Largest constant current whose steady winding temperature stays at or below
    /// `max_winding_c`: `I² = ΔT / (R_c(T_max) (R₁+R₂))`.
    pub fn continuous_current_a(&self, max_winding_c: f64, ambient_c: f64) -> Result<f64> {
        let rise = finite("max_winding_c", max_winding_c)? - finite("ambient_c", ambient_c)?;
        positive("max_winding_c - ambient_c", rise)?;
        let r_hot = self.winding_resistance_at(max_winding_c);
        Ok((rise / (r_hot * (self.r_core_case_k_per_w + self.r_case_ambient_k_per_w))).sqrt())
    }

    /// The continuous current seen as output torque behind `drive`, `k_M G η I`.
    pub fn continuous_output_torque_n_m(
        &self,
        drive: &Drive,
        max_winding_c: f64,
        ambient_c: f64,
    ) -> Result<f64> {
        let current = self.continuous_current_a(max_winding_c, ambient_c)?;
        Ok(current
            * drive.motor.torque_constant_n_m_per_a
            * drive.gearbox.ratio
            * drive.gearbox.efficiency)
    }

    /// `e^{AΔt}` of the circuit (closed form for a 2×2 matrix with distinct real eigenvalues,
    /// which this circuit always has: the discriminant is `(a−d)² + 4bc` with `b, c > 0`).
    fn transition(&self, dt_s: f64) -> [[f64; 2]; 2] {
        let (r1, r2, c1, c2) = (
            self.r_core_case_k_per_w,
            self.r_case_ambient_k_per_w,
            self.c_core_j_per_k,
            self.c_case_j_per_k,
        );
        let (a, b, c, d) = (
            -1.0 / (r1 * c1),
            1.0 / (r1 * c1),
            1.0 / (r1 * c2),
            -1.0 / (r1 * c2) - 1.0 / (r2 * c2),
        );
        let half_trace = 0.5 * (a + d);
        let root = (0.25 * (a - d) * (a - d) + b * c).sqrt();
        let (l1, l2) = (half_trace + root, half_trace - root);
        let (e1, e2) = ((l1 * dt_s).exp(), (l2 * dt_s).exp());
        // e^{AΔ} = (e1 (A − l2 I) − e2 (A − l1 I)) / (l1 − l2)
        let s = 1.0 / (l1 - l2);
        [
            [s * (e1 * (a - l2) - e2 * (a - l1)), s * (e1 - e2) * b],
            [s * (e1 - e2) * c, s * (e1 * (d - l2) - e2 * (d - l1))],
        ]
    }

    fn check_profile(
        field: &'static str,
        samples: &[f64],
        dt_s: f64,
        ambient_c: f64,
    ) -> Result<()> {
        positive("dt_s", dt_s)?;
        // finite: no NaN reaches the comparison
        if finite("ambient_c", ambient_c)? < ABSOLUTE_ZERO_C {
            return Err(MotorError::InvalidParameter {
                field: "ambient_c",
                value: ambient_c,
                reason: "must be at least absolute zero (-273.15 °C)",
            });
        }
        if samples.is_empty() {
            return Err(MotorError::TooFewSamples {
                field,
                required: 1,
                actual: 0,
            });
        }
        at_most(field, samples.len(), MAX_PROFILE_SAMPLES)?;
        finite_samples(field, samples)
    }

    /// A trace whose every temperature is finite, or [`MotorError::Overflow`] naming the
    /// profile `field` whose heat input overflowed it.
    fn finite_trace(field: &'static str, trace: ThermalTrace) -> Result<ThermalTrace> {
        // the first non-finite temperature of each node, if any
        let first_bad = |v: &[f64]| v.iter().copied().find(|x| !x.is_finite()).unwrap_or(0.0);
        no_overflow(field, "the winding temperature", first_bad(&trace.core_c))?;
        no_overflow(field, "the case temperature", first_bad(&trace.case_c))?;
        Ok(trace)
    }

    fn run(
        &self,
        initial: ThermalState,
        ambient_c: f64,
        dt_s: f64,
        samples: usize,
        mut power_at: impl FnMut(usize, f64) -> f64,
    ) -> ThermalTrace {
        let phi = self.transition(dt_s);
        let mut trace = ThermalTrace {
            time_s: Vec::with_capacity(samples + 1),
            core_c: Vec::with_capacity(samples + 1),
            case_c: Vec::with_capacity(samples + 1),
        };
        let (mut x1, mut x2) = (initial.core_c - ambient_c, initial.case_c - ambient_c);
        trace.time_s.push(0.0);
        trace.core_c.push(initial.core_c);
        trace.case_c.push(initial.case_c);
        for k in 0..samples {
            let p = power_at(k, x1 + ambient_c);
            // steady state for this sample's heat input, then exact decay towards it
            let (s1, s2) = (
                p * (self.r_core_case_k_per_w + self.r_case_ambient_k_per_w),
                p * self.r_case_ambient_k_per_w,
            );
            let (d1, d2) = (x1 - s1, x2 - s2);
            x1 = s1 + phi[0][0] * d1 + phi[0][1] * d2;
            x2 = s2 + phi[1][0] * d1 + phi[1][1] * d2;
            trace.time_s.push((k + 1) as f64 * dt_s);
            trace.core_c.push(x1 + ambient_c);
            trace.case_c.push(x2 + ambient_c);
        }
        trace
    }

    /// The Joule heat `I² R_c(T₁)` of the winding current `current_a` at the core
    /// temperature `core_c`.
    fn joule_heat_w(&self, current_a: f64, core_c: f64) -> f64 {
        current_a * current_a * self.winding_resistance_at(core_c)
    }

    /// Temperatures from `initial` for a heat-input profile (sample `k` held over
    /// `[k dt, (k+1) dt)`): a heat flow, a winding current or an output torque, see
    /// [`HeatInput`]. The profile must be non-empty, finite and at most
    /// [`MAX_PROFILE_SAMPLES`] long; a heat input that overflows the temperatures is
    /// [`MotorError::Overflow`] naming the profile.
    pub fn simulate(
        &self,
        initial: ThermalState,
        ambient_c: f64,
        dt_s: f64,
        input: HeatInput<'_>,
    ) -> Result<ThermalTrace> {
        let (field, samples) = input.profile();
        Self::check_profile(field, samples, dt_s, ambient_c)?;
        let n = samples.len();
        let trace = match input {
            HeatInput::Power(power_w) => self.run(initial, ambient_c, dt_s, n, |k, _| power_w[k]),
            HeatInput::Current(current_a) => self.run(initial, ambient_c, dt_s, n, |k, core_c| {
                self.joule_heat_w(current_a[k], core_c)
            }),
            HeatInput::OutputTorque { drive, torque_n_m } => {
                self.run(initial, ambient_c, dt_s, n, |k, core_c| {
                    self.joule_heat_w(drive.current_for_output_torque_a(torque_n_m[k]), core_c)
                })
            }
        };
        Self::finite_trace(field, trace)
    }

    /// Fits the case parameters `(R₂, τ₂)` to a logged case temperature by least squares
    /// (Nelder–Mead on their logarithms), keeping the core parameters and the winding of
    /// `self` (the datasheet's), as the thesis does for Table 2.3's "measured" rows. `self`'s
    /// case parameters are the starting guess. `measured_case_c[k]` is the case temperature
    /// at `k dt` (so one more sample than `current_a`); the log starts at ambient.
    pub fn fit_case(
        &self,
        ambient_c: f64,
        dt_s: f64,
        current_a: &[f64],
        measured_case_c: &[f64],
    ) -> Result<CaseFit> {
        Self::check_profile("current_a", current_a, dt_s, ambient_c)?;
        finite_samples("measured_case_c", measured_case_c)?;
        if current_a.len() < 2 {
            return Err(MotorError::TooFewSamples {
                field: "current_a",
                required: 2,
                actual: current_a.len(),
            });
        }
        if measured_case_c.len() != current_a.len() + 1 {
            return Err(MotorError::LengthMismatch {
                field: "measured_case_c",
                expected: current_a.len() + 1,
                actual: measured_case_c.len(),
            });
        }
        let (_, tau2) = self.time_constants_s();
        let with_case = |x: &[f64]| -> Self {
            let (r2, t2) = (x[0].exp(), x[1].exp());
            Self {
                r_case_ambient_k_per_w: r2,
                c_case_j_per_k: t2 / r2,
                ..*self
            }
        };
        let initial = ThermalState {
            core_c: measured_case_c[0],
            case_c: measured_case_c[0],
        };
        let rms = |model: &Self| -> f64 {
            let trace = model.run(initial, ambient_c, dt_s, current_a.len(), |k, core_c| {
                model.joule_heat_w(current_a[k], core_c)
            });
            let sum: f64 = trace
                .case_c
                .iter()
                .zip(measured_case_c)
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            (sum / measured_case_c.len() as f64).sqrt()
        };
        let x0 = [self.r_case_ambient_k_per_w.ln(), tau2.ln()];
        let result = minimize(
            |x| rms(&with_case(x)),
            &x0,
            &[0.5, 0.5],
            NelderMeadOptions {
                f_tolerance: 1e-12,
                x_tolerance: 1e-9,
                max_evaluations: 4000,
            },
        );
        if !result.f.is_finite() {
            return Err(MotorError::NoConvergence {
                what: "case thermal fit",
                reason: "objective not finite".into(),
            });
        }
        let model = with_case(&result.x);
        Ok(CaseFit {
            model,
            rms_error_c: result.f,
            evaluations: result.evaluations,
        })
    }
}

/// Result of [`ThermalModel::fit_case`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaseFit {
    pub model: ThermalModel,
    /// RMS case-temperature error of the fit over the log (K).
    pub rms_error_c: f64,
    pub evaluations: usize,
}
