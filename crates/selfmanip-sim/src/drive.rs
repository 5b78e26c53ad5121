//! A geared DC drive as numbers ([`GearedMotor`]): what a preset takes from its user for a
//! behaviour's DC-motor actuator ([`ActuatorSpec::DcMotor`]), binds to the behaviour's
//! parameters of the same names ([`GearedMotor::bind`], so that they are differentiable) and
//! checks against a catalog's motor and gearbox ([`GearedMotor::spec`]).
use crate::behaviour::ActuatorSpec;
use crate::expr::Scalar;
use crate::SimError;
use motor::geared::GearedDriveSpec;
use motor::GearboxLoss;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

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
