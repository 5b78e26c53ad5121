//! `selfmanip.analysis`'s native half: conversions only. RHex parameters arrive as the full
//! Table 4.2 JSON (`selfmanip.rhex.Model().params`), results leave as JSON text that the Python
//! layer turns into numpy arrays and dicts.
use crate::{guard, to_py_err};
use pyo3::prelude::*;
use rhex_model::analysis::{leg_tail, pitch_control as pc, sensor_sweep as ss, standing};
use selfmanip_sim::analysis::{leg_tail as tail, standing as stand};
use rhex_model::{LegShape, Rhex, RhexParams};
use selfmanip_core::RobotDescription;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(analysis_sensor_pitch_range, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_holding_torque, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_pitch_rate_gain, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_fig_4_8, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_fig_4_10, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_fig_4_11, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_fig_4_12, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_takeoff_speed, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_optimal_gear_ratio, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_splay_derivative, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_single_leg_pitch_accel, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_leg_effectiveness, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_tail_effect, m)?)?;
    m.add_function(wrap_pyfunction!(analysis_standing_rhex, m)?)?;
    Ok(())
}

fn params(params_json: Option<&str>) -> PyResult<RhexParams> {
    match params_json {
        None => Ok(RhexParams::default()),
        Some(s) => serde_json::from_str(s).map_err(to_py_err),
    }
}

fn rhex(params_json: Option<&str>) -> PyResult<Rhex> {
    Rhex::new(params(params_json)?).map_err(to_py_err)
}

macro_rules! json {
    ($v:expr) => {
        serde_json::to_string($v).map_err(to_py_err)
    };
}

fn leg(name: &str) -> PyResult<pc::TakeoffLeg> {
    match name {
        "stick" => Ok(pc::TakeoffLeg::Stick),
        "half_circle" => Ok(pc::TakeoffLeg::HalfCircle),
        "rolling" => Ok(pc::TakeoffLeg::Rolling),
        other => Err(crate::SelfmanipError::new_err(format!(
            "`leg` must be \"stick\", \"half_circle\" or \"rolling\", got {other:?}"
        ))),
    }
}

#[pyfunction]
#[pyo3(signature = (params_json, grid))]
fn analysis_sensor_pitch_range(params_json: Option<&str>, grid: usize) -> PyResult<String> {
    guard(|| json!(&ss::max_sensor_pitch(&rhex(params_json)?, grid).map_err(to_py_err)?))
}

#[pyfunction]
#[pyo3(signature = (params_json, theta1, theta2))]
fn analysis_holding_torque(
    params_json: Option<&str>,
    theta1: f64,
    theta2: f64,
) -> PyResult<String> {
    guard(|| json!(&ss::holding_torque(&rhex(params_json)?, theta1, theta2).map_err(to_py_err)?))
}

#[pyfunction]
#[pyo3(signature = (params_json, theta1, theta2))]
fn analysis_pitch_rate_gain(params_json: Option<&str>, theta1: f64, theta2: f64) -> PyResult<f64> {
    guard(|| ss::pitch_rate_gain(&rhex(params_json)?, theta1, theta2).map_err(to_py_err))
}

#[pyfunction]
#[pyo3(signature = (params_json, theta1_range, theta2_range, n))]
fn analysis_fig_4_8(
    py: Python<'_>,
    params_json: Option<&str>,
    theta1_range: [f64; 2],
    theta2_range: [f64; 2],
    n: usize,
) -> PyResult<String> {
    guard(|| {
        let r = rhex(params_json)?;
        let pts = py
            .detach(|| ss::fig_4_8(&r, theta1_range, theta2_range, n))
            .map_err(to_py_err)?;
        json!(&pts)
    })
}

#[pyfunction]
#[pyo3(signature = (params_json, theta2_range, phi_range, n, gear_ratio))]
fn analysis_fig_4_10(
    py: Python<'_>,
    params_json: Option<&str>,
    theta2_range: [f64; 2],
    phi_range: [f64; 2],
    n: usize,
    gear_ratio: f64,
) -> PyResult<String> {
    guard(|| {
        let p = params(params_json)?;
        let pts = py
            .detach(|| pc::fig_4_10(Some(p), theta2_range, phi_range, n, gear_ratio))
            .map_err(to_py_err)?;
        json!(&pts)
    })
}

#[pyfunction]
#[pyo3(signature = (params_json, ratios, phis, theta2_range))]
fn analysis_fig_4_11(
    py: Python<'_>,
    params_json: Option<&str>,
    ratios: Vec<f64>,
    phis: Vec<f64>,
    theta2_range: [f64; 2],
) -> PyResult<String> {
    guard(|| {
        let p = params(params_json)?;
        let pts = py
            .detach(|| pc::fig_4_11(Some(p), &ratios, &phis, theta2_range))
            .map_err(to_py_err)?;
        json!(&pts)
    })
}

#[pyfunction]
#[pyo3(signature = (params_json, phi_dots, phis, theta2_range, gear_ratio))]
fn analysis_fig_4_12(
    py: Python<'_>,
    params_json: Option<&str>,
    phi_dots: Vec<f64>,
    phis: Vec<f64>,
    theta2_range: [f64; 2],
    gear_ratio: f64,
) -> PyResult<String> {
    guard(|| {
        let p = params(params_json)?;
        let pts = py
            .detach(|| pc::fig_4_12(Some(p), &phi_dots, &phis, theta2_range, gear_ratio))
            .map_err(to_py_err)?;
        json!(&pts)
    })
}

#[pyfunction]
#[pyo3(signature = (params_json, leg_kind, theta2, phi, phi_dot, gear_ratio))]
fn analysis_takeoff_speed(
    params_json: Option<&str>,
    leg_kind: &str,
    theta2: f64,
    phi: f64,
    phi_dot: f64,
    gear_ratio: f64,
) -> PyResult<String> {
    guard(|| {
        let model =
            pc::takeoff_model(Some(params(params_json)?), leg(leg_kind)?).map_err(to_py_err)?;
        let line = pc::TorqueSpeedLine::xrhex(gear_ratio).map_err(to_py_err)?;
        json!(&pc::rear_takeoff_speed(&model, theta2, phi, phi_dot, &line).map_err(to_py_err)?)
    })
}

#[pyfunction]
#[pyo3(signature = (params_json, phi, phi_dot, theta2_range, ratio_range))]
fn analysis_optimal_gear_ratio(
    params_json: Option<&str>,
    phi: f64,
    phi_dot: f64,
    theta2_range: [f64; 2],
    ratio_range: [f64; 2],
) -> PyResult<(f64, f64)> {
    guard(|| {
        let model = pc::takeoff_model(Some(params(params_json)?), pc::TakeoffLeg::Rolling)
            .map_err(to_py_err)?;
        pc::optimal_gear_ratio(
            &model,
            phi,
            phi_dot,
            theta2_range,
            ratio_range,
            &pc::TorqueSpeedLine::xrhex,
        )
        .map_err(to_py_err)
    })
}

#[pyfunction]
#[pyo3(signature = (params_json, theta_m, theta_m_dot, tau))]
fn analysis_splay_derivative(
    params_json: Option<&str>,
    theta_m: f64,
    theta_m_dot: f64,
    tau: f64,
) -> PyResult<f64> {
    guard(|| {
        pc::splay_derivative(&rhex(params_json)?, theta_m, theta_m_dot, tau).map_err(to_py_err)
    })
}

#[pyfunction]
#[pyo3(signature = (params_json, leg_kind, theta2, phi, theta2_dot, phi_dot, tau2))]
fn analysis_single_leg_pitch_accel(
    params_json: Option<&str>,
    leg_kind: &str,
    theta2: f64,
    phi: f64,
    theta2_dot: f64,
    phi_dot: f64,
    tau2: f64,
) -> PyResult<f64> {
    guard(|| {
        let model =
            pc::takeoff_model(Some(params(params_json)?), leg(leg_kind)?).map_err(to_py_err)?;
        pc::single_leg_pitch_accel(&model, theta2, phi, theta2_dot, phi_dot, tau2)
            .map_err(to_py_err)
    })
}

#[pyfunction]
#[pyo3(signature = (params_json, pairs))]
fn analysis_leg_effectiveness(params_json: Option<&str>, pairs: usize) -> PyResult<f64> {
    guard(|| {
        let base = match params_json {
            None => None,
            Some(s) => Some(params(Some(s))?),
        };
        let r = leg_tail::tail_rhex(base, pairs).map_err(to_py_err)?;
        leg_tail::leg_effectiveness(&r).map_err(to_py_err)
    })
}

#[pyfunction]
#[pyo3(signature = (description, format, q0, joints, period_s, dt_s))]
fn analysis_tail_effect(
    py: Python<'_>,
    description: &str,
    format: &str,
    q0: Vec<f64>,
    joints: Vec<usize>,
    period_s: f64,
    dt_s: f64,
) -> PyResult<String> {
    guard(|| {
        let d = match format {
            "toml" => RobotDescription::from_toml_str(description),
            "json" => RobotDescription::from_json_str(description),
            other => {
                return Err(crate::SelfmanipError::new_err(format!(
                    "format `{other}`: expected \"toml\" or \"json\""
                )))
            }
        }
        .map_err(to_py_err)?;
        let model = d.build().map_err(to_py_err)?;
        let (mom, sim) = py
            .detach(|| {
                let mom = tail::revolution_rotation_momentum(&model, &q0, &joints, 128)?;
                let sim = tail::revolution_rotation_dynamic(&model, &q0, &joints, period_s, dt_s)?;
                Ok::<_, selfmanip_sim::SimError>((mom, sim))
            })
            .map_err(to_py_err)?;
        Ok(serde_json::json!({"momentum_delta_phi": mom, "simulated": sim}).to_string())
    })
}

#[pyfunction]
#[pyo3(signature = (params_json, leg_shape, seed, max_slope_rad, tau_d0, dt_s, steps))]
#[allow(clippy::too_many_arguments)]
fn analysis_standing_rhex(
    py: Python<'_>,
    params_json: Option<&str>,
    leg_shape: &str,
    seed: u64,
    max_slope_rad: f64,
    tau_d0: f64,
    dt_s: f64,
    steps: usize,
) -> PyResult<String> {
    guard(|| {
        let mut p = params(params_json)?;
        p.leg_shape = match leg_shape {
            "stick" => LegShape::Stick,
            "half_circle" => LegShape::HalfCircle,
            other => {
                return Err(crate::SelfmanipError::new_err(format!(
                    "`leg_shape` must be \"stick\" or \"half_circle\", got {other:?}"
                )))
            }
        };
        let r = Rhex::new(p).map_err(to_py_err)?;
        let trace = py
            .detach(|| {
                let (q0, terrain, mode) = standing::random_rhex_stance(&r, seed, max_slope_rad)?;
                Ok::<_, rhex_model::RhexError>(stand::simulate_standing(
                    &r.model,
                    &terrain,
                    mode,
                    &q0,
                    &[tau_d0],
                    &stand::TorqueSplit::mean_difference(),
                    &stand::StandingGains::default(),
                    dt_s,
                    steps,
                )?)
            })
            .map_err(to_py_err)?;
        json!(&trace)
    })
}
