//! The standard linear DC motor model (thesis section 2.1.2, its reference \[144\]; maxon's
//! "key information"), a gearbox, their combination ([`Drive`]), and the [`Actuator`]
//! trait through which the leap simulation asks an actuator for joint torque.
//!
//! At full command the motor's torque falls linearly with speed,
//! `τ(ω) = τ_stall (1 − ω/ω₀)`, and the motor controller clips the current to `I_max`, so
//! `|τ| ≤ k_M I_max` (the thesis's "achievable stall torque"). Both `ω₀ = V/k_e` and
//! `τ_stall = k_M V/R` scale with the supply voltage `V`; the continuous torque, a thermal
//! limit, does not. Behind a gearbox of ratio `G` and efficiency `η` the output sees
//! `ω_out = ω/G` and `τ_out = G η τ`.
//!
//! Two losses a real drive has are options of a [`Drive`] ([`DriveLosses`]), off by default:
//! the gearbox efficiency as a loss in the direction the power flows
//! ([`GearboxLoss::PowerFlow`]: `τ_out = G η τ` when the motor drives, `G τ/η` when the load
//! back-drives it) and the battery's internal resistance (`V = V_oc − R_b I_b`).
use crate::error::{at_most, non_negative, positive, MotorError, Result};
use serde::{Deserialize, Serialize};

/// rad/s per rpm (catalogs print rpm; everything here is SI).
pub const RAD_S_PER_RPM: f64 = std::f64::consts::PI / 30.0;

/// A DC motor's linear electromechanical model at one supply voltage, SI units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DcMotor {
    pub supply_voltage_v: f64,
    /// Speed with no load at the supply voltage.
    pub no_load_speed_rad_s: f64,
    /// Torque at zero speed and full voltage, before the controller's current limit.
    pub stall_torque_n_m: f64,
    /// `k_M`: torque per ampere.
    pub torque_constant_n_m_per_a: f64,
    /// The motor controller's peak current (`f64::INFINITY` for none).
    pub current_limit_a: f64,
    /// Thermally sustainable torque (datasheet, independent of voltage).
    pub continuous_torque_n_m: f64,
}

impl DcMotor {
    /// Validates every field.
    pub fn new(
        supply_voltage_v: f64,
        no_load_speed_rad_s: f64,
        stall_torque_n_m: f64,
        torque_constant_n_m_per_a: f64,
        current_limit_a: f64,
        continuous_torque_n_m: f64,
    ) -> Result<Self> {
        let current_limit_a = if current_limit_a == f64::INFINITY {
            current_limit_a
        } else {
            positive("current_limit_a", current_limit_a)?
        };
        Ok(Self {
            supply_voltage_v: positive("supply_voltage_v", supply_voltage_v)?,
            no_load_speed_rad_s: positive("no_load_speed_rad_s", no_load_speed_rad_s)?,
            stall_torque_n_m: positive("stall_torque_n_m", stall_torque_n_m)?,
            torque_constant_n_m_per_a: positive(
                "torque_constant_n_m_per_a",
                torque_constant_n_m_per_a,
            )?,
            current_limit_a,
            continuous_torque_n_m: non_negative("continuous_torque_n_m", continuous_torque_n_m)?,
        })
    }

    /// Terminal resistance implied by the model: `R = k_M V / τ_stall`.
    pub fn terminal_resistance_ohm(&self) -> f64 {
        self.torque_constant_n_m_per_a * self.supply_voltage_v / self.stall_torque_n_m
    }

    /// The motor recomputed at another supply voltage (thesis section 2.1.2: "given
    /// parameters for each motor were compensated based on our battery voltage"):
    /// `ω₀` and `τ_stall` scale with `V`, `k_M`, the current limit and the continuous
    /// torque do not.
    pub fn at_voltage(&self, supply_voltage_v: f64) -> Result<Self> {
        let scale = positive("supply_voltage_v", supply_voltage_v)? / self.supply_voltage_v;
        Ok(Self {
            supply_voltage_v,
            no_load_speed_rad_s: self.no_load_speed_rad_s * scale,
            stall_torque_n_m: self.stall_torque_n_m * scale,
            ..self.clone()
        })
    }

    /// The same motor behind a controller with another peak current.
    pub fn with_current_limit(&self, current_limit_a: f64) -> Result<Self> {
        Ok(Self {
            current_limit_a: positive("current_limit_a", current_limit_a)?,
            ..self.clone()
        })
    }

    /// Largest torque the current limit allows, `k_M I_max`.
    pub fn current_limited_torque_n_m(&self) -> f64 {
        self.torque_constant_n_m_per_a * self.current_limit_a
    }

    /// The thesis's "achievable stall torque": `min(τ_stall, k_M I_max)`.
    pub fn achievable_stall_torque_n_m(&self) -> f64 {
        self.stall_torque_n_m.min(self.current_limited_torque_n_m())
    }

    /// Torque at shaft speed `speed_rad_s` for a voltage command `command ∈ [−1, 1]`
    /// (fraction of the supply voltage): `τ = τ_stall (u − ω/ω₀)`, clipped to `±k_M I_max`.
    #[inline]
    pub fn torque_n_m(&self, command: f64, speed_rad_s: f64) -> f64 {
        self.torque_on_battery_n_m(command, speed_rad_s, 0.0)
    }

    /// [`DcMotor::torque_n_m`] when the supply voltage is a battery's open-circuit voltage
    /// `V_oc` behind its internal resistance `R_b` (`battery_resistance_ohm`), through a
    /// lossless PWM stage of duty `u`: the battery current is `I_b = u I`, its terminal
    /// voltage `V = V_oc − R_b I_b`, and `u V = R I + k_e ω` gives the winding current
    /// `I = (u V_oc − k_e ω)/(R + u² R_b)`, so
    /// `τ = τ_stall (u − ω/ω₀) · R/(R + u² R_b)`, clipped to `±k_M I_max`. The no-load speed
    /// is unchanged; the stall torque at full command falls to `k_M V_oc/(R + R_b)`.
    /// `R_b = 0` is [`DcMotor::torque_n_m`] bit for bit.
    #[inline]
    pub fn torque_on_battery_n_m(
        &self,
        command: f64,
        speed_rad_s: f64,
        battery_resistance_ohm: f64,
    ) -> f64 {
        let u = command.clamp(-1.0, 1.0);
        let limit = self.current_limited_torque_n_m();
        let line = self.stall_torque_n_m * (u - speed_rad_s / self.no_load_speed_rad_s);
        if battery_resistance_ohm == 0.0 {
            return line.clamp(-limit, limit);
        }
        let r = self.terminal_resistance_ohm();
        (line * (r / (r + u * u * battery_resistance_ohm))).clamp(-limit, limit)
    }

    /// Torque at full command, the torque–speed curve of Fig. 2.6.
    pub fn max_torque_at_speed_n_m(&self, speed_rad_s: f64) -> f64 {
        self.torque_n_m(1.0, speed_rad_s)
    }

    /// Winding current for a motor torque, `I = τ/k_M`.
    pub fn current_for_torque_a(&self, torque_n_m: f64) -> f64 {
        torque_n_m / self.torque_constant_n_m_per_a
    }

    /// Peak mechanical power at full command. Without a binding current limit it is
    /// `τ_stall ω₀ / 4` at `ω₀/2`; when `k_M I_max < τ_stall/2` the peak sits at the corner
    /// of the clipped curve, `k_M I_max · ω₀ (1 − k_M I_max/τ_stall)`.
    pub fn peak_power_w(&self) -> f64 {
        let t_lim = self.current_limited_torque_n_m();
        if t_lim >= 0.5 * self.stall_torque_n_m {
            0.25 * self.stall_torque_n_m * self.no_load_speed_rad_s
        } else {
            t_lim * self.no_load_speed_rad_s * (1.0 - t_lim / self.stall_torque_n_m)
        }
    }
}

/// A gearbox: ratio, efficiency and the permissible output torques of its datasheet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gearbox {
    pub name: String,
    #[serde(default)]
    pub part_number: String,
    /// Reduction `G` (motor turns per output turn).
    pub ratio: f64,
    /// Torque efficiency `η ∈ (0, 1]` (output torque = `G η` motor torque).
    pub efficiency: f64,
    /// Peak permissible output torque.
    pub peak_torque_n_m: f64,
    /// Continuously permissible output torque.
    pub continuous_torque_n_m: f64,
    pub mass_kg: f64,
}

impl Gearbox {
    /// Checks every field (zero or negative ratio, efficiency outside (0, 1], …).
    pub fn validate(&self) -> Result<()> {
        positive("ratio", self.ratio)?;
        positive("efficiency", self.efficiency)?;
        if self.efficiency > 1.0 {
            return Err(MotorError::InvalidParameter {
                field: "efficiency",
                value: self.efficiency,
                reason: "must be at most 1",
            });
        }
        positive("peak_torque_n_m", self.peak_torque_n_m)?;
        positive("continuous_torque_n_m", self.continuous_torque_n_m)?;
        non_negative("mass_kg", self.mass_kg)?;
        Ok(())
    }
}

/// The most points [`Drive::torque_speed_curve`] samples: a figure needs hundreds; the bound
/// keeps a request's memory bounded (10⁶ points are 24 MB).
pub const MAX_CURVE_POINTS: usize = 1_000_000;

/// One point of a torque–speed / power–speed curve at the gearbox output.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CurvePoint {
    pub speed_rad_s: f64,
    pub torque_n_m: f64,
    pub power_w: f64,
}

/// How the gearbox efficiency `η` enters the output torque.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GearboxLoss {
    /// `τ_out = G η τ_m` whatever the direction of the power: the datasheet derating with
    /// which Table 2.2's output torques are computed (the default).
    #[default]
    Derating,
    /// A loss in the direction the power flows: `τ_out = G η τ_m` while the motor drives
    /// (`τ_m ω_m ≥ 0`, standstill included) and `τ_out = G τ_m / η` while the load
    /// back-drives it (`τ_m ω_m < 0`), so the gearbox's friction takes `(1 − η)` of the
    /// power that passes through it either way (the derating returns power when
    /// back-driven). The torque jumps at `ω_m = 0` where `τ_m ≠ 0`, by the factor `η²`.
    PowerFlow,
}

/// The losses of a [`Drive`] beyond the motor's own: both off by default
/// ([`GearboxLoss::Derating`], an ideal supply), which keeps every output of the model
/// before these options bit for bit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DriveLosses {
    pub gearbox_loss: GearboxLoss,
    /// The internal resistance `R_b` (Ω) of the battery whose open-circuit voltage is the
    /// motor's supply voltage, as this drive sees it (`n` identical drives drawing equal
    /// currents from one battery each see `n R_b`). 0: an ideal source.
    pub battery_resistance_ohm: f64,
}

impl Default for DriveLosses {
    fn default() -> Self {
        Self {
            gearbox_loss: GearboxLoss::Derating,
            battery_resistance_ohm: 0.0,
        }
    }
}

/// A motor behind a gearbox: the derived rows of Table 2.2 and the output curves of
/// Fig. 2.6.
#[derive(Debug, Clone, PartialEq)]
pub struct Drive {
    pub motor: DcMotor,
    pub gearbox: Gearbox,
    pub losses: DriveLosses,
}

impl Drive {
    pub fn new(motor: DcMotor, gearbox: Gearbox) -> Result<Self> {
        gearbox.validate()?;
        Ok(Self {
            motor,
            gearbox,
            losses: DriveLosses::default(),
        })
    }

    /// The same drive with the losses `losses` (errors name `battery_resistance_ohm`
    /// when it is negative or not finite).
    pub fn with_losses(&self, losses: DriveLosses) -> Result<Self> {
        non_negative("battery_resistance_ohm", losses.battery_resistance_ohm)?;
        Ok(Self {
            losses,
            ..self.clone()
        })
    }

    fn g_eta(&self) -> f64 {
        self.gearbox.ratio * self.gearbox.efficiency
    }

    /// Output torque for motor torque `tau_m` at motor speed `speed_m`, by the gearbox law
    /// of [`DriveLosses::gearbox_loss`].
    #[inline]
    fn output_from_motor_torque(&self, tau_m: f64, speed_m: f64) -> f64 {
        match self.losses.gearbox_loss {
            GearboxLoss::Derating => self.g_eta() * tau_m,
            GearboxLoss::PowerFlow if tau_m * speed_m >= 0.0 => self.g_eta() * tau_m,
            GearboxLoss::PowerFlow => self.gearbox.ratio * tau_m / self.gearbox.efficiency,
        }
    }

    /// Motor torque for a command at motor speed `speed_m`, on this drive's battery.
    #[inline]
    fn motor_torque_n_m(&self, command: f64, speed_m: f64) -> f64 {
        self.motor
            .torque_on_battery_n_m(command, speed_m, self.losses.battery_resistance_ohm)
    }

    /// `ω₀ / G`.
    pub fn output_no_load_speed_rad_s(&self) -> f64 {
        self.motor.no_load_speed_rad_s / self.gearbox.ratio
    }

    /// `G η · min(τ_stall, k_M I_max)`.
    pub fn achievable_output_stall_torque_n_m(&self) -> f64 {
        self.g_eta() * self.motor.achievable_stall_torque_n_m()
    }

    /// `G η τ_continuous` (the motor's thermal limit seen at the output; compare with the
    /// gearbox's own `continuous_torque_n_m`).
    pub fn continuous_output_torque_n_m(&self) -> f64 {
        self.g_eta() * self.motor.continuous_torque_n_m
    }

    /// Output torque at full command and output speed `speed_rad_s`.
    pub fn max_output_torque_at_speed_n_m(&self, speed_rad_s: f64) -> f64 {
        self.output_torque_n_m(1.0, speed_rad_s)
    }

    /// Output torque for a voltage command at output speed `speed_rad_s` (with the
    /// drive's [`DriveLosses`]).
    #[inline]
    pub fn output_torque_n_m(&self, command: f64, speed_rad_s: f64) -> f64 {
        let speed_m = speed_rad_s * self.gearbox.ratio;
        self.output_from_motor_torque(self.motor_torque_n_m(command, speed_m), speed_m)
    }

    /// The output torque of the thesis's law, `G η τ_m` on an ideal supply, without reading
    /// [`Self::losses`]: [`Self::output_torque_n_m`] of a drive with the default
    /// [`DriveLosses`] bit for bit. For callers that choose the law once (a compiled
    /// behaviour), so that the default pays no option check per call.
    #[inline]
    pub fn derated_output_torque_n_m(&self, command: f64, speed_rad_s: f64) -> f64 {
        let speed_m = speed_rad_s * self.gearbox.ratio;
        self.g_eta() * self.motor.torque_n_m(command, speed_m)
    }

    /// Winding current that produces `torque_n_m` at the output, `τ_out / (G η k_M)`.
    pub fn current_for_output_torque_a(&self, torque_n_m: f64) -> f64 {
        torque_n_m / (self.g_eta() * self.motor.torque_constant_n_m_per_a)
    }

    /// Peak output power, `η` times the motor's.
    pub fn peak_output_power_w(&self) -> f64 {
        self.gearbox.efficiency * self.motor.peak_power_w()
    }

    /// Motor plus gearbox mass (motor mass from the catalog entry; the model itself is
    /// massless).
    pub fn combination_mass_kg(&self, motor_mass_kg: f64) -> f64 {
        motor_mass_kg + self.gearbox.mass_kg
    }

    /// `points` samples (2 to [`MAX_CURVE_POINTS`]) of the output torque–speed and
    /// power–speed curves at full command, from standstill to the no-load speed (Fig. 2.6).
    pub fn torque_speed_curve(&self, points: usize) -> Result<Vec<CurvePoint>> {
        at_most("points", points, MAX_CURVE_POINTS)?;
        if points < 2 {
            return Err(MotorError::TooFewSamples {
                field: "points",
                required: 2,
                actual: points,
            });
        }
        let top = self.output_no_load_speed_rad_s();
        Ok((0..points)
            .map(|i| {
                let speed_rad_s = top * i as f64 / (points - 1) as f64;
                let torque_n_m = self.max_output_torque_at_speed_n_m(speed_rad_s);
                CurvePoint {
                    speed_rad_s,
                    torque_n_m,
                    power_w: torque_n_m * speed_rad_s,
                }
            })
            .collect())
    }
}

/// What the leap simulation needs from an actuator: the joint torque for a normalized
/// command at the current joint speed, and the electrical power drawn (for the energy
/// bookkeeping of an execution).
pub trait Actuator: Send + Sync {
    /// Joint torque [N m] for a command `u ∈ [−1, 1]` at joint speed `ω` [rad/s].
    fn joint_torque_n_m(&self, command: f64, joint_speed_rad_s: f64) -> f64;
    /// Power drawn from the supply (W) at that command and speed.
    fn electrical_power_w(&self, command: f64, joint_speed_rad_s: f64) -> f64;
}

/// The ideal saturated-torque actuator of the thesis's chapter 4/5 simulations
/// (`τ_s` of Table 4.2): `τ = u τ_max`, lossless (electrical power = mechanical power).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SaturatedTorque {
    pub max_torque_n_m: f64,
}

impl SaturatedTorque {
    pub fn new(max_torque_n_m: f64) -> Result<Self> {
        Ok(Self {
            max_torque_n_m: positive("max_torque_n_m", max_torque_n_m)?,
        })
    }
}

impl Actuator for SaturatedTorque {
    fn joint_torque_n_m(&self, command: f64, _joint_speed_rad_s: f64) -> f64 {
        command.clamp(-1.0, 1.0) * self.max_torque_n_m
    }
    fn electrical_power_w(&self, command: f64, joint_speed_rad_s: f64) -> f64 {
        self.joint_torque_n_m(command, joint_speed_rad_s) * joint_speed_rad_s
    }
}

/// A geared DC motor as a joint actuator: the command is the voltage fraction and the torque
/// follows the linear model with the current limit. The supply delivers `V_eff I` with
/// `I = τ_motor/k_M` and `V_eff = R I + k_e ω_motor` (`k_e = V/ω₀`), which equals `u V` where
/// the current limit does not bind (a lossless PWM stage).
///
/// With a battery resistance `R_b` the power is the one drawn from the battery's
/// open-circuit voltage: the motor's `P_m = V_eff I` plus the battery's own loss `R_b I_b²`,
/// with the battery current `I_b` the root of `P_m = (V_oc − R_b I_b) I_b` nearer zero.
impl Actuator for Drive {
    fn joint_torque_n_m(&self, command: f64, joint_speed_rad_s: f64) -> f64 {
        self.output_torque_n_m(command, joint_speed_rad_s)
    }
    fn electrical_power_w(&self, command: f64, joint_speed_rad_s: f64) -> f64 {
        let r_b = self.losses.battery_resistance_ohm;
        let motor_power_w = self.motor_power_w(command, joint_speed_rad_s, r_b);
        if r_b == 0.0 {
            return motor_power_w;
        }
        let battery_current_a = self.battery_current_a(motor_power_w);
        motor_power_w + r_b * battery_current_a * battery_current_a
    }
}

impl Drive {
    /// The motor's electrical power `V_eff I` (`I = τ_m/k_M`, `V_eff = R I + k_e ω_m`) at a
    /// command and output speed, on a battery of internal resistance
    /// `battery_resistance_ohm` (which sets `τ_m`, not the formula).
    #[inline]
    fn motor_power_w(
        &self,
        command: f64,
        joint_speed_rad_s: f64,
        battery_resistance_ohm: f64,
    ) -> f64 {
        let m = &self.motor;
        let motor_speed = joint_speed_rad_s * self.gearbox.ratio;
        let tau_m = m.torque_on_battery_n_m(command, motor_speed, battery_resistance_ohm);
        let current = m.current_for_torque_a(tau_m);
        let back_emf_v = m.supply_voltage_v * motor_speed / m.no_load_speed_rad_s;
        (m.terminal_resistance_ohm() * current + back_emf_v) * current
    }

    /// The electrical power of the thesis's law on an ideal supply, without reading
    /// [`Self::losses`]: [`Actuator::electrical_power_w`] of a drive with the default
    /// [`DriveLosses`] bit for bit (see [`Self::derated_output_torque_n_m`]).
    #[inline]
    pub fn ideal_supply_power_w(&self, command: f64, joint_speed_rad_s: f64) -> f64 {
        self.motor_power_w(command, joint_speed_rad_s, 0.0)
    }

    /// The battery current `I_b` that delivers the motor power `motor_power_w` at the
    /// battery's terminal voltage `V_oc − R_b I_b`: the root of
    /// `R_b I_b² − V_oc I_b + P = 0` nearer zero, `2P / (V_oc + √(V_oc² − 4 R_b P))`
    /// (the discriminant clipped at 0: beyond the battery's maximum power).
    pub fn battery_current_a(&self, motor_power_w: f64) -> f64 {
        let v_oc = self.motor.supply_voltage_v;
        let disc = v_oc * v_oc - 4.0 * self.losses.battery_resistance_ohm * motor_power_w;
        2.0 * motor_power_w / (v_oc + disc.max(0.0).sqrt())
    }
}
