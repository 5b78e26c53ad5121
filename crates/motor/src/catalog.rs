//! Motor and gearbox catalogs (serde TOML): the thesis's Tables 2.1–2.3 shipped in
//! `data/thesis_actuators.toml`, user catalogs in the same format, and a seeded synthetic
//! catalog for selection benchmarks (the thesis searched 1,546 commercial motors).
use crate::dc::{DcMotor, Drive, Gearbox};
use crate::error::{at_most, non_negative, positive, MotorError, Result};
use crate::thermal::ThermalModel;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

/// Brushed or brushless (informational; the linear model is the same).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MotorKind {
    Brushed,
    Brushless,
}

/// A catalog motor: the linear model's parameters at `voltage_v`, plus size and mass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorSpec {
    pub name: String,
    #[serde(default)]
    pub part_number: String,
    pub kind: MotorKind,
    pub voltage_v: f64,
    pub no_load_speed_rad_s: f64,
    pub torque_constant_n_m_per_a: f64,
    /// Unlimited stall torque at `voltage_v`. When absent the model assumes the current
    /// limit binds exactly at stall (`τ_stall = k_M I_max`).
    #[serde(default)]
    pub stall_torque_n_m: Option<f64>,
    /// Controller peak current; absent = unlimited.
    #[serde(default)]
    pub current_limit_a: Option<f64>,
    pub continuous_torque_n_m: f64,
    #[serde(default)]
    pub mechanical_time_constant_s: Option<f64>,
    pub length_m: f64,
    pub width_m: f64,
    pub mass_kg: f64,
}

impl MotorSpec {
    /// One rotor's inertia (kg m²), `J = τ_m k_M² / R`, from the mechanical time constant
    /// `τ_m` (Table 2.1's 11.8 ms for X-RHex's motor: 7.2·10⁻⁶ kg m²) and the rated motor's
    /// torque constant and terminal resistance; `None` when the catalog gives no `τ_m`.
    /// Seen through a gearbox of ratio `G`, `n` such rotors are the joint's armature
    /// `n J G²`.
    pub fn rotor_inertia_kg_m2(&self) -> Result<Option<f64>> {
        let Some(tau_m) = self.mechanical_time_constant_s else {
            return Ok(None);
        };
        let m = self.motor()?;
        let k = m.torque_constant_n_m_per_a;
        Ok(Some(tau_m * k * k / m.terminal_resistance_ohm()))
    }

    /// The linear model at the catalog voltage.
    pub fn motor(&self) -> Result<DcMotor> {
        let current_limit = match self.current_limit_a {
            Some(limit) => positive("current_limit_a", limit)?,
            None => f64::INFINITY,
        };
        let stall = match self.stall_torque_n_m {
            Some(stall) => stall,
            None if current_limit.is_finite() => self.torque_constant_n_m_per_a * current_limit,
            None => {
                return Err(MotorError::InvalidParameter {
                    field: "stall_torque_n_m",
                    value: f64::NAN,
                    reason: "needed when there is no current_limit_a",
                })
            }
        };
        positive("length_m", self.length_m)?;
        positive("width_m", self.width_m)?;
        non_negative("mass_kg", self.mass_kg)?;
        DcMotor::new(
            self.voltage_v,
            self.no_load_speed_rad_s,
            stall,
            self.torque_constant_n_m_per_a,
            current_limit,
            self.continuous_torque_n_m,
        )
    }
}

/// Table 2.3's thermal description of a drive: time constants and heat coefficients
/// `H = R_c R_th/(k_M² G²)` in K/(N m)².
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeatSpec {
    pub tau_core_s: f64,
    pub tau_case_s: f64,
    pub h_core_k_per_n2m2: f64,
    pub h_case_k_per_n2m2: f64,
}

/// Which of Table 2.3's case parameters to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CaseParameters {
    /// maxon's bare-motor values.
    Listed,
    /// The thesis's bench fit with the gearbox attached (used for Fig. 2.8).
    Measured,
}

/// A motor/gearbox combination of the catalog.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveSpec {
    pub name: String,
    pub motor: String,
    pub gearbox: String,
    #[serde(default)]
    pub thermal_listed: Option<HeatSpec>,
    #[serde(default)]
    pub thermal_measured: Option<HeatSpec>,
}

/// A catalog of motors, gearboxes and drives.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Catalog {
    pub motor: Vec<MotorSpec>,
    pub gearbox: Vec<Gearbox>,
    pub drive: Vec<DriveSpec>,
}

/// The entry of `entries` called `name`, or `UnknownEntry { kind, name }`.
fn find_named<'a, T>(
    entries: &'a [T],
    kind: &'static str,
    name: &str,
    name_of: impl Fn(&T) -> &String,
) -> Result<&'a T> {
    entries
        .iter()
        .find(|e| name_of(e) == name)
        .ok_or_else(|| MotorError::UnknownEntry {
            kind,
            name: name.into(),
        })
}

/// The thesis's Tables 2.1–2.3 as a TOML catalog.
pub const THESIS_CATALOG_TOML: &str = include_str!("../data/thesis_actuators.toml");

/// A Table 2.1 motor of [`Catalog::thesis`]: `[name, part number]`, its kind, `[voltage V,
/// no-load speed rad/s, torque constant N m/A, current limit A, continuous torque N m]` and
/// `[mechanical time constant s, length m, width m, mass kg]` (no unlimited stall torque).
fn thesis_motor(
    [name, part_number]: [&str; 2],
    kind: MotorKind,
    [voltage_v, no_load_speed_rad_s, torque_constant_n_m_per_a, current_limit_a, continuous_torque_n_m]: [f64; 5],
    [tau_m_s, length_m, width_m, mass_kg]: [f64; 4],
) -> MotorSpec {
    MotorSpec {
        name: name.into(),
        part_number: part_number.into(),
        kind,
        voltage_v,
        no_load_speed_rad_s,
        torque_constant_n_m_per_a,
        stall_torque_n_m: None,
        current_limit_a: Some(current_limit_a),
        continuous_torque_n_m,
        mechanical_time_constant_s: Some(tau_m_s),
        length_m,
        width_m,
        mass_kg,
    }
}

/// A Table 2.2 gearbox of [`Catalog::thesis`]: `[name, part number]`, ratio, efficiency and
/// `[peak output torque N m, continuous output torque N m, mass kg]`.
fn thesis_gearbox(
    [name, part_number]: [&str; 2],
    ratio: f64,
    efficiency: f64,
    [peak_torque_n_m, continuous_torque_n_m, mass_kg]: [f64; 3],
) -> Gearbox {
    Gearbox {
        name: name.into(),
        part_number: part_number.into(),
        ratio,
        efficiency,
        peak_torque_n_m,
        continuous_torque_n_m,
        mass_kg,
    }
}

/// A Table 2.3 drive of [`Catalog::thesis`]: `[name, motor, gearbox]` and its listed and
/// measured `[τ_core s, τ_case s, H_core, H_case K/(N m)²]`.
fn thesis_drive(
    [name, motor, gearbox]: [&str; 3],
    listed: [f64; 4],
    measured: [f64; 4],
) -> DriveSpec {
    let heat =
        |[tau_core_s, tau_case_s, h_core_k_per_n2m2, h_case_k_per_n2m2]: [f64; 4]| HeatSpec {
            tau_core_s,
            tau_case_s,
            h_core_k_per_n2m2,
            h_case_k_per_n2m2,
        };
    DriveSpec {
        name: name.into(),
        motor: motor.into(),
        gearbox: gearbox.into(),
        thermal_listed: Some(heat(listed)),
        thermal_measured: Some(heat(measured)),
    }
}

impl Catalog {
    /// Parses and validates a TOML catalog (every motor and gearbox, every drive's
    /// references).
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let catalog: Self = toml::from_str(text).map_err(|e| MotorError::Parse {
            message: e.to_string(),
        })?;
        if catalog.motor.is_empty() {
            return Err(MotorError::EmptyCatalog { field: "motor" });
        }
        for m in &catalog.motor {
            m.motor()?;
        }
        for g in &catalog.gearbox {
            g.validate()?;
        }
        for d in &catalog.drive {
            catalog.drive(&d.name)?;
        }
        Ok(catalog)
    }

    /// Tables 2.1–2.3: [`THESIS_CATALOG_TOML`] as a value built in Rust, nothing parsed (the
    /// test `the_thesis_catalog_is_its_file` checks that the file parses and validates to
    /// exactly this value).
    pub fn thesis() -> Self {
        Catalog {
            motor: vec![
                thesis_motor(
                    ["research-rhex", "maxon 118752"],
                    MotorKind::Brushed,
                    // the torque constant is 245 mNm / 15 A, as in the catalog file
                    [24.0, 1424.1886696273727, 0.245 / 15.0, 15.0, 0.0231],
                    [0.00428, 0.0545, 0.025, 0.130],
                ),
                thesis_motor(
                    ["x-rhex", "maxon 251601"],
                    MotorKind::Brushless,
                    [37.0, 1080.0795543041709, 0.0335, 20.0, 0.0831],
                    [0.0118, 0.0209, 0.045, 0.110],
                ),
            ],
            gearbox: vec![
                thesis_gearbox(
                    ["research-rhex-33", "maxon 166163"],
                    33.0,
                    1.0,
                    [3.4, 2.25, 0.162],
                ),
                thesis_gearbox(["x-rhex-18", "maxon 326659"], 18.0, 0.82, [6.0, 4.0, 0.178]),
                thesis_gearbox(["x-rhex-28", "maxon 326662"], 28.0, 0.82, [6.0, 4.0, 0.178]),
            ],
            drive: vec![
                thesis_drive(
                    ["research-rhex", "research-rhex", "research-rhex-33"],
                    [12.4, 910.0, 9.9, 44.8],
                    [12.4, 551.0, 9.9, 17.2],
                ),
                thesis_drive(
                    ["x-rhex-18", "x-rhex", "x-rhex-18"],
                    [16.7, 212.0, 9.4, 8.9],
                    [16.7, 710.0, 9.4, 10.2],
                ),
                thesis_drive(
                    ["x-rhex-28", "x-rhex", "x-rhex-28"],
                    [16.7, 212.0, 3.9, 3.7],
                    [16.7, 710.0, 3.9, 4.2],
                ),
            ],
        }
    }

    pub fn motor_spec(&self, name: &str) -> Result<&MotorSpec> {
        find_named(&self.motor, "motor", name, |m| &m.name)
    }

    pub fn gearbox(&self, name: &str) -> Result<&Gearbox> {
        find_named(&self.gearbox, "gearbox", name, |g| &g.name)
    }

    pub fn drive_spec(&self, name: &str) -> Result<&DriveSpec> {
        find_named(&self.drive, "drive", name, |d| &d.name)
    }

    /// The motor/gearbox combination `name`.
    pub fn drive(&self, name: &str) -> Result<Drive> {
        let spec = self.drive_spec(name)?;
        Drive::new(
            self.motor_spec(&spec.motor)?.motor()?,
            self.gearbox(&spec.gearbox)?.clone(),
        )
    }

    /// The thermal model of drive `name` from its Table 2.3 row.
    pub fn drive_thermal(&self, name: &str, which: CaseParameters) -> Result<ThermalModel> {
        let spec = self.drive_spec(name)?;
        let heat = match which {
            CaseParameters::Listed => spec.thermal_listed,
            CaseParameters::Measured => spec.thermal_measured,
        }
        .ok_or_else(|| MotorError::UnknownEntry {
            kind: "thermal data of drive",
            name: name.into(),
        })?;
        ThermalModel::from_heat_coefficients(
            &self.drive(name)?,
            heat.h_core_k_per_n2m2,
            heat.h_case_k_per_n2m2,
            heat.tau_core_s,
            heat.tau_case_s,
        )
    }
}

/// The most motors [`synthetic_motors`] draws (a catalog of 10⁶ is ~100 MB).
pub const MAX_SYNTHETIC_MOTORS: usize = 1_000_000;

/// `count` (at most [`MAX_SYNTHETIC_MOTORS`]) synthetic catalog motors, seeded and deterministic: log-uniform power
/// 1–500 W, no-load speeds 3,000–20,000 rpm, supply 6–48 V, lengths 10–120 mm and masses
/// growing with power (a stand-in for the 1,546-motor catalog of section 2.1.1, which is
/// not public).
pub fn synthetic_motors(count: usize, seed: u64) -> Result<Vec<MotorSpec>> {
    at_most("synthetic_count", count, MAX_SYNTHETIC_MOTORS)?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut log_uniform = |lo: f64, hi: f64| (lo.ln() + rng.gen::<f64>() * (hi / lo).ln()).exp();
    Ok((0..count)
        .map(|i| {
            let power_w = log_uniform(1.0, 500.0);
            let no_load_speed_rad_s = log_uniform(3000.0, 20000.0) * crate::dc::RAD_S_PER_RPM;
            let voltage_v = log_uniform(6.0, 48.0);
            let stall_torque_n_m = 4.0 * power_w / no_load_speed_rad_s;
            let length_m = log_uniform(0.010, 0.120);
            let mass_kg = 0.02 * power_w.powf(0.6) * log_uniform(0.7, 1.4);
            MotorSpec {
                name: format!("synthetic-{i:05}"),
                part_number: String::new(),
                kind: if i % 2 == 0 {
                    MotorKind::Brushed
                } else {
                    MotorKind::Brushless
                },
                voltage_v,
                no_load_speed_rad_s,
                torque_constant_n_m_per_a: voltage_v / no_load_speed_rad_s,
                stall_torque_n_m: Some(stall_torque_n_m),
                current_limit_a: None,
                continuous_torque_n_m: 0.15 * stall_torque_n_m,
                mechanical_time_constant_s: None,
                length_m,
                width_m: log_uniform(0.010, 0.090),
                mass_kg,
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_thesis_catalog_is_its_file() {
        // the file is the documented data: it parses and validates to the value built in Rust
        let parsed = Catalog::from_toml_str(THESIS_CATALOG_TOML).unwrap();
        let built = Catalog::thesis();
        assert_eq!(parsed, built);
        // bit for bit (PartialEq on f64 would let −0.0 pass for 0.0)
        assert_eq!(format!("{parsed:?}"), format!("{built:?}"));
    }
}
