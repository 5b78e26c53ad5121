//! A geared DC drive as numbers ([`GearedMotor`]): what a preset takes from its user for a
//! behaviour's DC-motor actuator ([`ActuatorSpec::DcMotor`]), binds to the behaviour's
//! parameters of the same names ([`GearedMotor::bind`], so that they are differentiable) and
//! checks against a catalog's motor and gearbox ([`GearedMotor::spec`]); and the choice of a
//! joint's actuator ([`JointActuator`]: a saturated torque or the geared motor) with the
//! catalog drive a preset offers ([`CatalogDrive`]: which motor and gearbox, its default).
use crate::behaviour::ActuatorSpec;
use crate::error::invalid;
use crate::expr::Scalar;
use crate::SimError;
use motor::geared::{GearedDrive, GearedDriveSpec};
use motor::GearboxLoss;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;

/// `motors_per_leg` catalog motors on a joint, each behind a gearbox of ratio `gear_ratio`,
/// with the controller current limit `current_limit_a` (thesis 2.1.2). The loss options
/// (`motor::DriveLosses`, `docs/calibration.md`) are off by default: `gearbox_efficiency`
/// (unset: the catalog gearbox's), `gearbox_loss` (`derating` `G η τ_m`, or `power_flow`) and
/// `battery_resistance_ohm` (unset: an ideal supply). A value set is a behaviour parameter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearedMotor {
    pub gear_ratio: f64,
    pub current_limit_a: f64,
    pub motors_per_leg: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gearbox_efficiency: Option<f64>,
    #[serde(default, skip_serializing_if = "crate::behaviour::spec::is_derating")]
    pub gearbox_loss: GearboxLoss,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery_resistance_ohm: Option<f64>,
}

impl GearedMotor {
    /// The behaviour parameters it binds: the gear ratio, current limit, motors per leg and
    /// the loss options set.
    pub fn values(&self) -> Vec<(&'static str, f64)> {
        let mut v = vec![
            ("gear_ratio", self.gear_ratio),
            ("current_limit_a", self.current_limit_a),
            ("motors_per_leg", f64::from(self.motors_per_leg)),
        ];
        v.extend(self.losses_set());
        v
    }

    /// The loss options set, as behaviour parameters (`gearbox_efficiency`,
    /// `battery_resistance_ohm`).
    pub fn losses_set(&self) -> Vec<(&'static str, f64)> {
        let set = [
            ("gearbox_efficiency", self.gearbox_efficiency),
            ("battery_resistance_ohm", self.battery_resistance_ohm),
        ];
        set.into_iter().filter_map(|(k, v)| Some((k, v?))).collect()
    }

    /// This drive with the loss options among `names` set where unset, to the drive's own
    /// values (the thesis catalog's efficiency of `gearbox`, an ideal supply), so that a run
    /// binds them as parameters; the run is the same bit for bit.
    pub fn with_loss_parameters(mut self, names: &[&str], gearbox: &str) -> Self {
        if names.contains(&"gearbox_efficiency") && self.gearbox_efficiency.is_none() {
            let catalog = motor::Catalog::thesis();
            self.gearbox_efficiency = catalog.gearbox(gearbox).ok().map(|g| g.efficiency);
        }
        if names.contains(&"battery_resistance_ohm") && self.battery_resistance_ohm.is_none() {
            self.battery_resistance_ohm = Some(0.0);
        }
        self
    }

    /// The drive of the catalog's `motor` and `gearbox` with these values.
    pub fn spec<'a>(&self, motor: &'a str, gearbox: &'a str) -> GearedDriveSpec<'a> {
        GearedDriveSpec {
            motor,
            gearbox,
            gear_ratio: Some(self.gear_ratio),
            current_limit_a: Some(self.current_limit_a),
            count: f64::from(self.motors_per_leg),
            gearbox_efficiency: self.gearbox_efficiency,
            losses: motor::DriveLosses {
                gearbox_loss: self.gearbox_loss,
                battery_resistance_ohm: self.battery_resistance_ohm.unwrap_or(0.0),
            },
        }
    }

    /// Checks the values (errors name the field, [`drive_error`]).
    pub fn validate(&self) -> Result<(), SimError> {
        self.spec("", "").validate().map_err(drive_error)
    }

    /// Makes the DC motor `spec` read this drive's values from the behaviour's parameters of
    /// the same names, and sets them in `parameters`.
    pub fn bind(&self, spec: &mut ActuatorSpec, parameters: &mut BTreeMap<String, Scalar>) {
        for (name, v) in self.values() {
            parameters.insert(name.into(), Scalar::Number(v));
        }
        if let ActuatorSpec::DcMotor {
            gear_ratio,
            current_limit_a,
            count,
            gearbox_efficiency,
            gearbox_loss,
            battery_resistance_ohm,
            ..
        } = spec
        {
            *gear_ratio = Some("gear_ratio".into());
            *current_limit_a = Some("current_limit_a".into());
            *count = "motors_per_leg".into();
            *gearbox_loss = self.gearbox_loss;
            for (name, _) in self.losses_set() {
                let slot = match name {
                    "gearbox_efficiency" => &mut *gearbox_efficiency,
                    _ => &mut *battery_resistance_ohm,
                };
                *slot = Some(name.into());
            }
        }
    }

    /// `reason`, an undefined derivative's, saying where it is the power-flow gearbox law's
    /// jump: the law's torque jumps by `η²` without an event where a joint's speed changes
    /// sign under load, and a controller withholds its partials there.
    pub fn undefined_derivative_reason(&self, reason: String) -> String {
        if self.gearbox_loss == GearboxLoss::PowerFlow
            && reason.contains("gives no partial derivatives")
        {
            format!(
                "{reason}: a leg's speed changed sign under load, where the power-flow gearbox \
                 law's torque jumps by η² without an event (the derivative across it is \
                 one-sided and not formed)"
            )
        } else {
            reason
        }
    }
}

/// What turns a joint: a constant saturated torque (the robot's own value, such as RHex's
/// `τ_s`), or geared catalog motors ([`GearedMotor`]). Which catalog motor and gearbox, and
/// the geared motor a preset defaults to, are the preset's ([`CatalogDrive`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum JointActuator {
    SaturatedTorque,
    GearedMotor(GearedMotor),
}

impl JointActuator {
    /// The behaviour parameters the actuator binds (none for the saturated torque).
    pub fn values(&self) -> Vec<(&'static str, f64)> {
        match self {
            JointActuator::GearedMotor(m) => m.values(),
            JointActuator::SaturatedTorque => Vec::new(),
        }
    }

    /// The gear ratio of the geared motor; `None` for the saturated torque, which has none.
    pub fn gear_ratio(&self) -> Option<f64> {
        match self {
            JointActuator::GearedMotor(m) => Some(m.gear_ratio),
            JointActuator::SaturatedTorque => None,
        }
    }

    /// Checks the geared motor's fields (errors name them); the saturated torque has none.
    pub fn validate(&self) -> Result<(), SimError> {
        match self {
            JointActuator::SaturatedTorque => Ok(()),
            JointActuator::GearedMotor(m) => m.validate(),
        }
    }

    /// Whether a simulation built with this actuator runs `other` once `other`'s
    /// [`Self::values`] are bound (bit for bit what a fresh build of `other` runs): the same
    /// actuator, or geared motors with the same gearbox law and the same loss options set.
    pub fn binds_as(&self, other: &JointActuator) -> bool {
        let set = |m: &GearedMotor| {
            let names = m.losses_set().into_iter().map(|(k, _)| k);
            (names.collect::<Vec<_>>(), m.gearbox_loss)
        };
        match (self, other) {
            (JointActuator::GearedMotor(a), JointActuator::GearedMotor(b)) => set(a) == set(b),
            (a, b) => a == b,
        }
    }
}

/// A preset's catalog drive: the motor and gearbox of the thesis catalog behind its joints,
/// and the geared motor it defaults to, whose motors a saturated torque keeps (their speed
/// and rotors: what a joint swings at, what its armature is).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CatalogDrive {
    pub motor: &'static str,
    pub gearbox: &'static str,
    pub default: GearedMotor,
}

/// A joint's drive as built ([`CatalogDrive::joint_drive`]): the drive, its stall torque at
/// the joint (N m) and its reflected rotor inertia `n J G²` (kg m²).
pub struct JointDrive {
    pub drive: GearedDrive,
    pub stall_torque_n_m: f64,
    pub reflected_inertia_kg_m2: f64,
}

impl CatalogDrive {
    /// The default geared motor as an actuator.
    pub fn actuator(&self) -> JointActuator {
        JointActuator::GearedMotor(self.default)
    }

    /// The default geared motor at gear ratio `gear_ratio`.
    pub fn at_gear_ratio(&self, gear_ratio: f64) -> JointActuator {
        self.with_gear_ratio(&self.actuator(), gear_ratio)
    }

    /// The geared motor's values of `a`, the default's for the saturated torque.
    pub fn motor(&self, a: &JointActuator) -> GearedMotor {
        match a {
            JointActuator::GearedMotor(m) => *m,
            JointActuator::SaturatedTorque => self.default,
        }
    }

    /// The geared motor with gear ratio `gear_ratio`, keeping `a`'s other values (the
    /// default's when `a` is the saturated torque).
    pub fn with_gear_ratio(&self, a: &JointActuator, gear_ratio: f64) -> JointActuator {
        JointActuator::GearedMotor(GearedMotor {
            gear_ratio,
            ..self.motor(a)
        })
    }

    /// The actuator of `a`'s kind that a build keyed by kind starts from: the default geared
    /// motor, or the saturated torque.
    pub fn of_kind(&self, a: &JointActuator) -> JointActuator {
        match a {
            JointActuator::GearedMotor(_) => self.actuator(),
            JointActuator::SaturatedTorque => JointActuator::SaturatedTorque,
        }
    }

    /// `a` if it is the geared motor, else the default.
    pub fn geared(&self, a: &JointActuator) -> JointActuator {
        JointActuator::GearedMotor(self.motor(a))
    }

    /// `a` with the loss options among `names` bound as parameters
    /// ([`GearedMotor::with_loss_parameters`]); the run is the same bit for bit.
    pub fn with_loss_parameters(&self, a: &JointActuator, names: &[&str]) -> JointActuator {
        match a {
            JointActuator::GearedMotor(m) => {
                JointActuator::GearedMotor(m.with_loss_parameters(names, self.gearbox))
            }
            a => a.clone(),
        }
    }

    /// The drive of `a` ([`motor::geared`]): the geared motor's, or for the saturated torque
    /// the default's, whose motors it keeps.
    pub fn spec(&self, a: &JointActuator) -> GearedDriveSpec<'static> {
        self.motor(a).spec(self.motor, self.gearbox)
    }

    /// The drive of `a` ([`Self::spec`]) built from the thesis catalog.
    pub fn drive(&self, a: &JointActuator) -> Result<GearedDrive, SimError> {
        self.spec(a)
            .build(&motor::Catalog::thesis())
            .map_err(drive_error)
    }

    /// The drive of `a`, its stall torque at the joint (`saturated_n_m` for the saturated
    /// torque, which keeps the default's motors) and its reflected rotor inertia `n J G²`
    /// (`J` from the catalog's mechanical time constant,
    /// [`motor::catalog::MotorSpec::rotor_inertia_kg_m2`]). Errors name `gear_ratio` when
    /// the torque or the inertia (growing as `G` and `G²`) overflows.
    pub fn joint_drive(
        &self,
        a: &JointActuator,
        saturated_n_m: f64,
    ) -> Result<JointDrive, SimError> {
        let drive = self.drive(a)?;
        let stall_n_m = match a {
            JointActuator::GearedMotor(_) => drive.stall_torque_n_m(),
            JointActuator::SaturatedTorque => saturated_n_m,
        };
        let reflected = drive.reflected_inertia_kg_m2().ok_or_else(|| {
            invalid(
                "actuator",
                "the motor's mechanical time constant is needed for the rotor inertia",
            )
        })?;
        // torque and inertia grow as G and G²: a ratio they overflow at is the ratio's fault
        if !(stall_n_m.is_finite() && reflected.is_finite()) {
            let reason = format!(
                "the drive's stall torque ({stall_n_m:e} N m) or reflected rotor inertia n J G² \
                 ({reflected:e} kg m²) is not finite at G = {:e}",
                drive.drive.gearbox.ratio
            );
            return Err(invalid("gear_ratio", reason));
        }
        Ok(JointDrive {
            drive,
            stall_torque_n_m: stall_n_m,
            reflected_inertia_kg_m2: reflected,
        })
    }

    /// The actuator that turns a joint: the saturated torque `saturated_n_m`, or the
    /// current-limited geared motors of `a`.
    pub fn runtime(
        &self,
        a: &JointActuator,
        saturated_n_m: f64,
    ) -> Result<Arc<dyn motor::Actuator>, SimError> {
        Ok(match a {
            JointActuator::SaturatedTorque => {
                Arc::new(motor::SaturatedTorque::new(saturated_n_m).map_err(drive_error)?)
            }
            _ => Arc::new(self.drive(a)?),
        })
    }
}

/// A drive's error as an invalid value naming the field of [`GearedMotor`] (`count` is
/// `motors_per_leg`), else `actuator`.
pub fn drive_error(e: motor::MotorError) -> SimError {
    let field = match e {
        motor::MotorError::InvalidParameter { field: "count", .. } => "motors_per_leg",
        motor::MotorError::InvalidParameter { field, .. }
            if [
                "gear_ratio",
                "current_limit_a",
                "gearbox_efficiency",
                "battery_resistance_ohm",
            ]
            .contains(&field) =>
        {
            field
        }
        _ => "actuator",
    };
    SimError::InvalidValue {
        field: field.into(),
        reason: e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drive() -> GearedMotor {
        GearedMotor {
            gear_ratio: 28.0,
            current_limit_a: 20.0,
            motors_per_leg: 2,
            gearbox_efficiency: None,
            gearbox_loss: GearboxLoss::Derating,
            battery_resistance_ohm: None,
        }
    }

    #[test]
    fn bad_values_name_the_drive_field() {
        let field = |m: GearedMotor| match m.validate() {
            Err(SimError::InvalidValue { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        let m = drive();
        assert_eq!(
            field(GearedMotor {
                motors_per_leg: 0,
                ..m
            }),
            "motors_per_leg"
        );
        assert_eq!(
            field(GearedMotor {
                gear_ratio: -1.0,
                ..m
            }),
            "gear_ratio"
        );
        let e = Some(1.5);
        assert_eq!(
            field(GearedMotor {
                gearbox_efficiency: e,
                ..m
            }),
            "gearbox_efficiency"
        );
    }

    #[test]
    fn serde_form_omits_the_unset_options() {
        let json = serde_json::to_value(drive()).unwrap();
        let mut keys: Vec<&str> = json
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        keys.sort_unstable();
        assert_eq!(keys, ["current_limit_a", "gear_ratio", "motors_per_leg"]);
        let back: GearedMotor = serde_json::from_value(json).unwrap();
        assert_eq!(back, drive());
    }
}
