//! `selfmanip.motor`'s native half: conversions only. Results are plain dicts (numpy
//! arrays for series); structured inputs (observer parameters, machine configuration)
//! arrive as dicts, deserialized with serde so that it names any missing or mistyped field.
use crate::convert::{column, to_map, to_py, AnyOut, DictOut};
use crate::errors::{self, choice, guard, invalid};
use motor::catalog::{synthetic_motors, CaseParameters, Catalog};
use motor::observer::{self, FaultFsmConfig, LegLog, ObserverParams};
use motor::tail::{self, SelectionConstraints, TailTask};
use motor::{Actuator, Drive, DriveLosses, GearboxLoss, HeatInput, ThermalModel, ThermalState};
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    add_functions! {
        m,
        motor_tail_optimum, motor_tail_constants, motor_rank_tail_motors, motor_thesis_catalog_toml,
        motor_drive_table, motor_torque_speed_curve, motor_operating_point,
        motor_thermal_simulation, motor_continuous_output_torque, motor_observe,
        motor_calibrate_observer, motor_identify_faults
    }
    m.add(
        "MOTOR_MAX_PROFILE_SAMPLES",
        motor::thermal::MAX_PROFILE_SAMPLES,
    )?;
    Ok(())
}

fn catalog(catalog_toml: Option<&str>) -> PyResult<Catalog> {
    match catalog_toml {
        Some(text) => Catalog::from_toml_str(text).map_err(errors::motor),
        None => Ok(Catalog::thesis()),
    }
}

fn case_parameters(case: &str) -> PyResult<CaseParameters> {
    let cases = [
        ("measured", CaseParameters::Measured),
        ("listed", CaseParameters::Listed),
    ];
    choice("case", case, &cases)
}

/// A drive of the catalog and its thermal model with `case`'s parameters.
fn thermal_drive(
    catalog_toml: Option<&str>,
    drive: &str,
    case: &str,
) -> PyResult<(Drive, ThermalModel)> {
    let cat = catalog(catalog_toml)?;
    let d = cat.drive(drive).map_err(errors::motor)?;
    let thermal = cat
        .drive_thermal(drive, case_parameters(case)?)
        .map_err(errors::motor)?;
    Ok((d, thermal))
}

/// Which drive, as `selfmanip.motor` passes it: the catalog's name for it, a controller
/// current limit in place of the catalog's (`None`: the catalog's), and the catalog in TOML
/// (`None`: the thesis's).
#[derive(FromPyObject)]
struct DriveChoice(String, Option<f64>, Option<String>);

impl DriveChoice {
    fn drive(&self) -> PyResult<Drive> {
        let DriveChoice(name, current_limit_a, catalog_toml) = self;
        drive_with_limit(&catalog(catalog_toml.as_deref())?, name, *current_limit_a)
    }
}

fn drive_with_limit(cat: &Catalog, drive: &str, current_limit_a: Option<f64>) -> PyResult<Drive> {
    let d = cat.drive(drive).map_err(errors::motor)?;
    match current_limit_a {
        Some(limit) => Drive::new(
            d.motor.with_current_limit(limit).map_err(errors::motor)?,
            d.gearbox,
        )
        .map_err(errors::motor),
        None => Ok(d),
    }
}

/// The tail's task as `selfmanip.motor` passes it: `(theta0_rad, body_inertia_kg_m2,
/// effectiveness)`.
#[derive(FromPyObject)]
struct TailTaskArgs(f64, f64, f64);

impl TailTaskArgs {
    fn task(&self) -> PyResult<TailTask> {
        let TailTaskArgs(theta0_rad, body_inertia_kg_m2, effectiveness) = *self;
        TailTask::new(theta0_rad, body_inertia_kg_m2, effectiveness).map_err(errors::motor)
    }
}

/// `motor_tail_optimum((theta0_rad, body_inertia_kg_m2, effectiveness), power_w)`.
#[pyfunction]
fn motor_tail_optimum(py: Python<'_>, task: TailTaskArgs, power_w: f64) -> DictOut<'_> {
    guard(|| {
        let opt = tail::tail_optimum(&task.task()?, power_w).map_err(errors::motor)?;
        let d = PyDict::new(py);
        d.set_item("no_load_speed_rad_s", opt.no_load_speed_rad_s)?;
        d.set_item("completion_time_s", opt.completion_time_s)?;
        Ok(d)
    })
}

#[pyfunction]
fn motor_tail_constants<'py>(py: Python<'py>) -> DictOut<'py> {
    let k = tail::tail_constants();
    let d = PyDict::new(py);
    d.set_item("s_star", k.s_star)?;
    d.set_item("k_omega", k.k_omega)?;
    d.set_item("k_t", k.k_t)?;
    Ok(d)
}

/// `motor_rank_tail_motors((theta0_rad, body_inertia_kg_m2, effectiveness), max_length_m,
/// max_mass_kg, max_completion_time_s, catalog_toml=None, synthetic_count=1546, seed=7)`.
#[pyfunction]
#[pyo3(signature = (task, max_length_m, max_mass_kg, max_completion_time_s, catalog_toml=None, synthetic_count=1546, seed=7))]
#[allow(clippy::too_many_arguments)]
fn motor_rank_tail_motors<'py>(
    py: Python<'py>,
    task: TailTaskArgs,
    max_length_m: f64,
    max_mass_kg: f64,
    max_completion_time_s: f64,
    catalog_toml: Option<&str>,
    synthetic_count: usize,
    seed: u64,
) -> DictOut<'py> {
    guard(|| {
        let task = task.task()?;
        let motors = match catalog_toml {
            Some(text) => Catalog::from_toml_str(text).map_err(errors::motor)?.motor,
            None => synthetic_motors(synthetic_count, seed).map_err(errors::motor)?,
        };
        let constraints = SelectionConstraints {
            max_length_m,
            max_mass_kg,
            max_completion_time_s,
        };
        let selection = py
            .detach(|| tail::rank_tail_motors(&motors, &task, &constraints))
            .map_err(errors::motor)?;
        let d = PyDict::new(py);
        let r = &selection.ranked;
        d.set_item("name", PyList::new(py, r.iter().map(|m| m.name.clone()))?)?;
        d.set_item("index", column(py, r, |m| m.index as i64))?;
        d.set_item("peak_power_w", column(py, r, |m| m.peak_power_w))?;
        d.set_item("gear_ratio", column(py, r, |m| m.gear_ratio))?;
        d.set_item("completion_time_s", column(py, r, |m| m.completion_time_s))?;
        d.set_item(
            "invalid",
            PyList::new(
                py,
                selection.invalid.iter().map(|(i, e)| (*i, e.to_string())),
            )?,
        )?;
        Ok(d)
    })
}

#[pyfunction]
fn motor_thesis_catalog_toml() -> &'static str {
    motor::catalog::THESIS_CATALOG_TOML
}

#[pyfunction]
#[pyo3(signature = (catalog_toml=None, current_limit_a=None))]
fn motor_drive_table<'py>(
    py: Python<'py>,
    catalog_toml: Option<&str>,
    current_limit_a: Option<f64>,
) -> PyResult<Bound<'py, PyList>> {
    guard(|| {
        let cat = catalog(catalog_toml)?;
        let rows = PyList::empty(py);
        for spec in &cat.drive {
            let drive = drive_with_limit(&cat, &spec.name, current_limit_a)?;
            let motor_spec = cat.motor_spec(&spec.motor).map_err(errors::motor)?;
            let d = PyDict::new(py);
            d.set_item("name", &spec.name)?;
            d.set_item("motor", &spec.motor)?;
            d.set_item("gearbox", &spec.gearbox)?;
            d.set_item("supply_voltage_v", drive.motor.supply_voltage_v)?;
            d.set_item("current_limit_a", drive.motor.current_limit_a)?;
            d.set_item("gear_ratio", drive.gearbox.ratio)?;
            d.set_item("efficiency", drive.gearbox.efficiency)?;
            d.set_item(
                "output_no_load_speed_rad_s",
                drive.output_no_load_speed_rad_s(),
            )?;
            d.set_item(
                "achievable_output_stall_torque_n_m",
                drive.achievable_output_stall_torque_n_m(),
            )?;
            d.set_item(
                "continuous_output_torque_n_m",
                drive.continuous_output_torque_n_m(),
            )?;
            d.set_item("peak_output_power_w", drive.peak_output_power_w())?;
            d.set_item("gearbox_peak_torque_n_m", drive.gearbox.peak_torque_n_m)?;
            d.set_item(
                "gearbox_continuous_torque_n_m",
                drive.gearbox.continuous_torque_n_m,
            )?;
            d.set_item("mass_kg", drive.combination_mass_kg(motor_spec.mass_kg))?;
            if let Some(h) = spec.thermal_measured {
                d.set_item("h_core_k_per_n2m2", h.h_core_k_per_n2m2)?;
                d.set_item("h_case_k_per_n2m2", h.h_case_k_per_n2m2)?;
                d.set_item("tau_core_s", h.tau_core_s)?;
                d.set_item("tau_case_s", h.tau_case_s)?;
            }
            rows.append(d)?;
        }
        Ok(rows)
    })
}

/// `motor_torque_speed_curve((drive, current_limit_a, catalog_toml), points=50)`.
#[pyfunction]
#[pyo3(signature = (drive, points=50))]
fn motor_torque_speed_curve(py: Python<'_>, drive: DriveChoice, points: usize) -> DictOut<'_> {
    guard(|| {
        let curve = drive
            .drive()?
            .torque_speed_curve(points)
            .map_err(errors::motor)?;
        let out = PyDict::new(py);
        out.set_item("speed_rad_s", column(py, &curve, |p| p.speed_rad_s))?;
        out.set_item("torque_n_m", column(py, &curve, |p| p.torque_n_m))?;
        out.set_item("power_w", column(py, &curve, |p| p.power_w))?;
        Ok(out)
    })
}

fn parse_gearbox_loss(name: &str) -> PyResult<GearboxLoss> {
    let losses = [
        ("derating", GearboxLoss::Derating),
        ("power_flow", GearboxLoss::PowerFlow),
    ];
    choice("gearbox_loss", name, &losses)
}

/// One operating point of a drive with its optional losses: output torque, electrical
/// power, the motor's torque and current, and the battery's current and terminal voltage:
/// `motor_operating_point((drive, current_limit_a, catalog_toml), command, speed_rad_s,
/// gearbox_loss="derating", battery_resistance_ohm=0.0)`.
#[pyfunction]
#[pyo3(signature = (drive, command, speed_rad_s, gearbox_loss="derating", battery_resistance_ohm=0.0))]
fn motor_operating_point<'py>(
    py: Python<'py>,
    drive: DriveChoice,
    command: f64,
    speed_rad_s: f64,
    gearbox_loss: &str,
    battery_resistance_ohm: f64,
) -> DictOut<'py> {
    guard(|| {
        let losses = DriveLosses {
            gearbox_loss: parse_gearbox_loss(gearbox_loss)?,
            battery_resistance_ohm,
        };
        let d = drive.drive()?.with_losses(losses).map_err(errors::motor)?;
        let speed_m = speed_rad_s * d.gearbox.ratio;
        let tau_m = d
            .motor
            .torque_on_battery_n_m(command, speed_m, battery_resistance_ohm);
        let current = d.motor.current_for_torque_a(tau_m);
        let k_e = d.motor.supply_voltage_v / d.motor.no_load_speed_rad_s;
        let motor_power_w = (d.motor.terminal_resistance_ohm() * current + k_e * speed_m) * current;
        let battery_current_a = d.battery_current_a(motor_power_w);
        let out = PyDict::new(py);
        out.set_item(
            "output_torque_n_m",
            d.joint_torque_n_m(command, speed_rad_s),
        )?;
        out.set_item(
            "electrical_power_w",
            d.electrical_power_w(command, speed_rad_s),
        )?;
        out.set_item("motor_torque_n_m", tau_m)?;
        out.set_item("current_a", current)?;
        out.set_item("battery_current_a", battery_current_a)?;
        out.set_item(
            "battery_voltage_v",
            d.motor.supply_voltage_v - battery_resistance_ohm * battery_current_a,
        )?;
        Ok(out)
    })
}

#[pyfunction]
#[pyo3(signature = (drive, torque_n_m, dt_s, ambient_c=25.0, case="measured", catalog_toml=None))]
fn motor_thermal_simulation<'py>(
    py: Python<'py>,
    drive: &str,
    torque_n_m: PyReadonlyArray1<'py, f64>,
    dt_s: f64,
    ambient_c: f64,
    case: &str,
    catalog_toml: Option<&str>,
) -> DictOut<'py> {
    guard(|| {
        let (d, thermal) = thermal_drive(catalog_toml, drive, case)?;
        let torque = torque_n_m.as_slice()?.to_vec();
        let trace = py
            .detach(|| {
                thermal.simulate(
                    ThermalState::ambient(ambient_c),
                    ambient_c,
                    dt_s,
                    HeatInput::OutputTorque {
                        drive: &d,
                        torque_n_m: &torque,
                    },
                )
            })
            .map_err(errors::motor)?;
        let mean_torque_sq = torque.iter().map(|t| t * t).sum::<f64>() / torque.len().max(1) as f64;
        let steady = thermal.steady_state_for_current(
            d.current_for_output_torque_a(mean_torque_sq.sqrt()),
            ambient_c,
        );
        let out = PyDict::new(py);
        out.set_item("time_s", trace.time_s.into_pyarray(py))?;
        out.set_item("core_c", trace.core_c.into_pyarray(py))?;
        out.set_item("case_c", trace.case_c.into_pyarray(py))?;
        if let Ok(s) = steady {
            out.set_item("steady_core_c", s.core_c)?;
            out.set_item("steady_case_c", s.case_c)?;
        }
        Ok(out)
    })
}

#[pyfunction]
#[pyo3(signature = (drive, max_winding_c=125.0, ambient_c=25.0, case="measured", catalog_toml=None))]
fn motor_continuous_output_torque(
    drive: &str,
    max_winding_c: f64,
    ambient_c: f64,
    case: &str,
    catalog_toml: Option<&str>,
) -> PyResult<f64> {
    guard(|| {
        let (d, thermal) = thermal_drive(catalog_toml, drive, case)?;
        thermal
            .continuous_output_torque_n_m(&d, max_winding_c, ambient_c)
            .map_err(errors::motor)
    })
}

/// A dict deserialized into `T`; serde's message names the missing or mistyped key.
fn from_dict<T: serde::de::DeserializeOwned>(d: &Bound<'_, PyDict>, field: &str) -> PyResult<T> {
    serde_json::from_value(serde_json::Value::Object(to_map(d, field)?))
        .map_err(|e| invalid(field, format!("{field}: {e}")))
}

fn observer_params(params: &Bound<'_, PyDict>) -> PyResult<ObserverParams> {
    let p: ObserverParams = from_dict(params, "params")?;
    p.validate().map_err(errors::motor)?;
    Ok(p)
}

/// What the observer functions take after their own dicts: the observer's parameters and a
/// leg's log, `(params, dt_s, theta_d, omega_d, theta, omega)` (rad, rad/s), passed
/// positionally.
#[derive(FromPyObject)]
struct ObserverCall<'py>(
    Bound<'py, PyDict>,
    f64,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
);

impl ObserverCall<'_> {
    fn to_log(&self) -> PyResult<LegLog> {
        let ObserverCall(_, dt_s, theta_d, omega_d, theta, omega) = self;
        Ok(LegLog {
            dt_s: *dt_s,
            theta_d_rad: theta_d.as_slice()?.to_vec(),
            omega_d_rad_s: omega_d.as_slice()?.to_vec(),
            theta_rad: theta.as_slice()?.to_vec(),
            omega_rad_s: omega.as_slice()?.to_vec(),
        })
    }

    /// `run` on the checked parameters and the log, with the interpreter released.
    fn run<T: Send>(
        &self,
        py: Python<'_>,
        run: impl FnOnce(&ObserverParams, &LegLog) -> motor::Result<T> + Send,
    ) -> PyResult<T> {
        let params = observer_params(&self.0)?;
        let log = self.to_log()?;
        py.detach(|| run(&params, &log)).map_err(errors::motor)
    }
}

/// `motor_observe(params, dt_s, theta_d, omega_d, theta, omega)`.
#[pyfunction]
#[pyo3(signature = (*call))]
fn motor_observe<'py>(py: Python<'py>, call: ObserverCall<'py>) -> DictOut<'py> {
    guard(|| {
        let samples = call.run(py, observer::observe)?;
        let out = PyDict::new(py);
        out.set_item("theta_hat_rad", column(py, &samples, |s| s.theta_hat_rad))?;
        out.set_item(
            "omega_hat_rad_s",
            column(py, &samples, |s| s.omega_hat_rad_s),
        )?;
        out.set_item("r_theta_rad", column(py, &samples, |s| s.r_theta_rad))?;
        out.set_item("r_omega_rad_s", column(py, &samples, |s| s.r_omega_rad_s))?;
        Ok(out)
    })
}

/// `motor_calibrate_observer(initial_params, dt_s, theta_d, omega_d, theta, omega)`.
#[pyfunction]
#[pyo3(signature = (*call))]
fn motor_calibrate_observer<'py>(py: Python<'py>, call: ObserverCall<'py>) -> AnyOut<'py> {
    guard(|| {
        let calibration = call.run(py, |initial, log| observer::calibrate(log, initial))?;
        to_py(py, &calibration)
    })
}

/// `motor_identify_faults(config, params, dt_s, theta_d, omega_d, theta, omega)`.
#[pyfunction]
#[pyo3(signature = (config, *call))]
fn motor_identify_faults<'py>(
    py: Python<'py>,
    config: &Bound<'py, PyDict>,
    call: ObserverCall<'py>,
) -> AnyOut<'py> {
    guard(|| {
        let config: FaultFsmConfig = from_dict(config, "config")?;
        let changes = call.run(py, |params, log| observer::identify(params, &config, log))?;
        to_py(py, &changes)
    })
}
