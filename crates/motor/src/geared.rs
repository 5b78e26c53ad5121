//! A geared drive as a specification — `count` identical motors of a catalog in parallel on
//! one joint, each behind a gearbox of the catalog — and its evaluation: the actuator (the
//! torque–speed line clipped by the current limit, thesis 2.1.2 and Fig. 2.6, with the
//! drive's loss options) and what a robot's model reads off it: the stall torque at the
//! joint, the no-load output speed `ω₀/G` and the rotors' inertia reflected to the joint,
//! `n J G²`.
use crate::error::{non_negative, positive};
use crate::{Actuator, Catalog, Drive, DriveLosses, MotorError, Result};

/// What a geared drive is: catalog names, and the values that replace the catalog's where set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GearedDriveSpec<'a> {
    /// Motor name in the catalog (`x-rhex`, …), at its rated voltage.
    pub motor: &'a str,
    /// Gearbox name in the catalog (`x-rhex-28`, …).
    pub gearbox: &'a str,
    pub gear_ratio: Option<f64>,
    pub current_limit_a: Option<f64>,
    /// Motors in parallel on the joint (a whole number ≥ 1).
    pub count: f64,
    /// The gearbox's torque efficiency `η ∈ (0, 1]`.
    pub gearbox_efficiency: Option<f64>,
    pub losses: DriveLosses,
}

impl GearedDriveSpec<'_> {
    /// Checks the values set (errors name them: `gear_ratio`, `current_limit_a`, `count`,
    /// `gearbox_efficiency`, `battery_resistance_ohm`).
    pub fn validate(&self) -> Result<()> {
        for (field, v) in [
            ("gear_ratio", self.gear_ratio),
            ("current_limit_a", self.current_limit_a),
        ] {
            v.map(|v| positive(field, v)).transpose()?;
        }
        if !(self.count >= 1.0 && self.count.fract() == 0.0) {
            return Err(MotorError::InvalidParameter {
                field: "count",
                value: self.count,
                reason: "must be a whole number >= 1",
            });
        }
        if let Some(e) = self.gearbox_efficiency.filter(|e| !(*e > 0.0 && *e <= 1.0)) {
            return Err(MotorError::InvalidParameter {
                field: "gearbox_efficiency",
                value: e,
                reason: "must be in (0, 1]",
            });
        }
        non_negative("battery_resistance_ohm", self.losses.battery_resistance_ohm)?;
        Ok(())
    }

    /// The drive of this specification in `catalog`.
    pub fn build(&self, catalog: &Catalog) -> Result<GearedDrive> {
        let spec = catalog.motor_spec(self.motor)?;
        let mut m = spec.motor()?;
        if let Some(i) = self.current_limit_a {
            m = m.with_current_limit(i)?;
        }
        let mut gearbox = catalog.gearbox(self.gearbox)?.clone();
        gearbox.ratio = self.gear_ratio.unwrap_or(gearbox.ratio);
        gearbox.efficiency = self.gearbox_efficiency.unwrap_or(gearbox.efficiency);
        Ok(GearedDrive {
            drive: Drive::new(m, gearbox)?.with_losses(self.losses)?,
            count: self.count,
            rotor_inertia_kg_m2: spec.rotor_inertia_kg_m2()?,
        })
    }
}

/// `count` identical drives in parallel on one joint, with the drive's loss options.
#[derive(Debug, Clone, PartialEq)]
pub struct GearedDrive {
    pub drive: Drive,
    pub count: f64,
    /// One rotor's inertia `J` (kg m², [`crate::MotorSpec::rotor_inertia_kg_m2`]); `None`
    /// when the catalog gives no mechanical time constant.
    pub rotor_inertia_kg_m2: Option<f64>,
}

impl GearedDrive {
    /// The torque at the joint at full command and rest (N m).
    pub fn stall_torque_n_m(&self) -> f64 {
        self.joint_torque_n_m(1.0, 0.0)
    }

    /// The no-load speed at the joint, `ω₀ / G` (rad/s).
    pub fn no_load_speed_rad_s(&self) -> f64 {
        self.drive.motor.no_load_speed_rad_s / self.drive.gearbox.ratio
    }

    /// The rotors' inertia seen at the joint, `n J G²` (kg m²): `n` rotors turning `G` times
    /// as fast as the joint.
    pub fn reflected_inertia_kg_m2(&self) -> Option<f64> {
        let ratio = self.drive.gearbox.ratio;
        Some(self.count * self.rotor_inertia_kg_m2? * ratio * ratio)
    }
}

impl Actuator for GearedDrive {
    fn joint_torque_n_m(&self, command: f64, speed: f64) -> f64 {
        self.count * self.drive.joint_torque_n_m(command, speed)
    }
    fn electrical_power_w(&self, command: f64, speed: f64) -> f64 {
        self.count * self.drive.electrical_power_w(command, speed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn x_rhex(gear_ratio: f64) -> GearedDriveSpec<'static> {
        GearedDriveSpec {
            motor: "x-rhex",
            gearbox: "x-rhex-28",
            gear_ratio: Some(gear_ratio),
            current_limit_a: None,
            count: 2.0,
            gearbox_efficiency: None,
            losses: DriveLosses::default(),
        }
    }

    #[test]
    fn reflected_inertia_and_speed_scale_with_the_ratio() {
        let c = Catalog::thesis();
        let (a, b) = (
            x_rhex(14.0).build(&c).unwrap(),
            x_rhex(28.0).build(&c).unwrap(),
        );
        let (ia, ib) = (
            a.reflected_inertia_kg_m2().unwrap(),
            b.reflected_inertia_kg_m2().unwrap(),
        );
        assert!((ib / ia - 4.0).abs() < 1e-12);
        assert!((a.no_load_speed_rad_s() / b.no_load_speed_rad_s() - 2.0).abs() < 1e-12);
        // the stall torque is the count times one drive's, G η min(τ_stall, k_M I_max): the
        // catalog's 20 A limit binds (0.67 N m of the motor, 30.8 N m for the pair at 28:1)
        let m = &b.drive.motor;
        let expected = 2.0 * 28.0 * 0.82 * m.torque_constant_n_m_per_a * 20.0;
        assert!((b.stall_torque_n_m() / expected - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_values_name_their_field() {
        let field = |s: GearedDriveSpec| match s.validate() {
            Err(MotorError::InvalidParameter { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        assert_eq!(field(x_rhex(0.0)), "gear_ratio");
        assert_eq!(
            field(GearedDriveSpec {
                count: 0.5,
                ..x_rhex(28.0)
            }),
            "count"
        );
        let eta = GearedDriveSpec {
            gearbox_efficiency: Some(1.5),
            ..x_rhex(28.0)
        };
        assert_eq!(field(eta), "gearbox_efficiency");
        assert!(x_rhex(28.0).validate().is_ok());
    }
}
