//! `selfmanip.analysis`'s native half: conversions only. RHex parameters arrive as a dict of
//! Table 4.2 values (`selfmanip.rhex.Model().params`; `None`: the shipped table), results
//! leave as plain Python dicts and lists that the Python layer turns into numpy arrays.
use crate::convert::{to_map, to_py, AnyOut};
use crate::errors::{self, choice, guard, invalid, Source};
use crate::robot::Robot;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rhex_model::analysis::{leg_tail, pitch_control as pc, sensor_sweep as ss, standing};
use rhex_model::{LegShape, Rhex, RhexError, RhexParams};
use selfmanip_sim::analysis::{leg_tail as tail, standing as stand};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    add_functions! {
        m,
        analysis_sensor_pitch_range, analysis_holding_torque, analysis_pitch_rate_gain,
        analysis_fig_4_8, analysis_fig_4_10, analysis_fig_4_11, analysis_fig_4_12,
        analysis_takeoff_speed, analysis_optimal_gear_ratio, analysis_splay_derivative,
        analysis_single_leg_pitch_accel, analysis_leg_effectiveness, analysis_tail_effect,
        analysis_standing_rhex
    }
    Ok(())
}

/// An analysis error: its vectors are the analysis's own.
fn err(e: RhexError) -> PyErr {
    errors::rhex(e, Source::Engine)
}

fn params(params: Option<&Bound<'_, PyDict>>) -> PyResult<RhexParams> {
    match params {
        None => Ok(RhexParams::default()),
        Some(d) => serde_json::from_value(serde_json::Value::Object(to_map(d, "params")?))
            .map_err(|e| invalid("params", format!("RHex parameters: {e}"))),
    }
}

fn rhex(p: Option<&Bound<'_, PyDict>>) -> PyResult<Rhex> {
    Rhex::new(params(p)?).map_err(err)
}

fn leg(name: &str) -> PyResult<pc::TakeoffLeg> {
    use pc::TakeoffLeg::{HalfCircle, Rolling, Stick};
    let legs = [
        ("stick", Stick),
        ("half_circle", HalfCircle),
        ("rolling", Rolling),
    ];
    choice("leg", name, &legs)
}

type Params<'a, 'py> = Option<&'a Bound<'py, PyDict>>;

/// `analysis` run with the GIL released (a figure's grid, a standing run), its result
/// converted for Python.
fn detached<'py, T: serde::Serialize + Send>(
    py: Python<'py>,
    analysis: impl FnOnce() -> Result<T, RhexError> + Send,
) -> AnyOut<'py> {
    let out = py.detach(analysis).map_err(err)?;
    to_py(py, &out)
}

/// The take-off model of section 4.3 with the parameters `params` and the leg `leg`.
fn takeoff_model(params: Params<'_, '_>, leg: pc::TakeoffLeg) -> PyResult<selfmanip_core::Model> {
    pc::takeoff_model(Some(self::params(params)?), leg).map_err(err)
}

#[pyfunction]
#[pyo3(signature = (params, grid))]
fn analysis_sensor_pitch_range<'py>(
    py: Python<'py>,
    params: Params<'_, 'py>,
    grid: usize,
) -> AnyOut<'py> {
    guard(|| {
        to_py(
            py,
            &ss::max_sensor_pitch(&rhex(params)?, grid).map_err(err)?,
        )
    })
}

#[pyfunction]
#[pyo3(signature = (params, theta1, theta2))]
fn analysis_holding_torque<'py>(
    py: Python<'py>,
    params: Params<'_, 'py>,
    theta1: f64,
    theta2: f64,
) -> AnyOut<'py> {
    guard(|| {
        to_py(
            py,
            &ss::holding_torque(&rhex(params)?, theta1, theta2).map_err(err)?,
        )
    })
}

#[pyfunction]
#[pyo3(signature = (params, theta1, theta2))]
fn analysis_pitch_rate_gain(params: Params<'_, '_>, theta1: f64, theta2: f64) -> PyResult<f64> {
    guard(|| ss::pitch_rate_gain(&rhex(params)?, theta1, theta2).map_err(err))
}

#[pyfunction]
#[pyo3(signature = (params, theta1_range, theta2_range, n))]
fn analysis_fig_4_8<'py>(
    py: Python<'py>,
    params: Params<'_, 'py>,
    theta1_range: [f64; 2],
    theta2_range: [f64; 2],
    n: usize,
) -> AnyOut<'py> {
    guard(|| {
        let r = rhex(params)?;
        detached(py, || ss::fig_4_8(&r, theta1_range, theta2_range, n))
    })
}

#[pyfunction]
#[pyo3(signature = (params, theta2_range, phi_range, n, gear_ratio))]
fn analysis_fig_4_10<'py>(
    py: Python<'py>,
    params: Params<'_, 'py>,
    theta2_range: [f64; 2],
    phi_range: [f64; 2],
    n: usize,
    gear_ratio: f64,
) -> AnyOut<'py> {
    guard(|| {
        let p = self::params(params)?;
        detached(py, || {
            pc::fig_4_10(Some(p), theta2_range, phi_range, n, gear_ratio)
        })
    })
}

#[pyfunction]
#[pyo3(signature = (params, ratios, phis, theta2_range))]
fn analysis_fig_4_11<'py>(
    py: Python<'py>,
    params: Params<'_, 'py>,
    ratios: Vec<f64>,
    phis: Vec<f64>,
    theta2_range: [f64; 2],
) -> AnyOut<'py> {
    guard(|| {
        let p = self::params(params)?;
        detached(py, || pc::fig_4_11(Some(p), &ratios, &phis, theta2_range))
    })
}

#[pyfunction]
#[pyo3(signature = (params, phi_dots, phis, theta2_range, gear_ratio))]
fn analysis_fig_4_12<'py>(
    py: Python<'py>,
    params: Params<'_, 'py>,
    phi_dots: Vec<f64>,
    phis: Vec<f64>,
    theta2_range: [f64; 2],
    gear_ratio: f64,
) -> AnyOut<'py> {
    guard(|| {
        let p = self::params(params)?;
        detached(py, || {
            pc::fig_4_12(Some(p), &phi_dots, &phis, theta2_range, gear_ratio)
        })
    })
}

#[pyfunction]
#[pyo3(signature = (params, leg_kind, theta2, phi, phi_dot, gear_ratio))]
fn analysis_takeoff_speed<'py>(
    py: Python<'py>,
    params: Params<'_, 'py>,
    leg_kind: &str,
    theta2: f64,
    phi: f64,
    phi_dot: f64,
    gear_ratio: f64,
) -> AnyOut<'py> {
    guard(|| {
        let model = takeoff_model(params, leg(leg_kind)?)?;
        let line = pc::xrhex_line(gear_ratio).map_err(err)?;
        to_py(
            py,
            &pc::rear_takeoff_speed(&model, theta2, phi, phi_dot, &line)
                .map_err(|e| err(e.into()))?,
        )
    })
}

#[pyfunction]
#[pyo3(signature = (params, phi, phi_dot, theta2_range, ratio_range))]
fn analysis_optimal_gear_ratio(
    params: Params<'_, '_>,
    phi: f64,
    phi_dot: f64,
    theta2_range: [f64; 2],
    ratio_range: [f64; 2],
) -> PyResult<(f64, f64)> {
    guard(|| {
        let model = takeoff_model(params, pc::TakeoffLeg::Rolling)?;
        pc::optimal_gear_ratio(
            &model,
            phi,
            phi_dot,
            theta2_range,
            ratio_range,
            &pc::xrhex_line,
        )
        .map_err(err)
    })
}

#[pyfunction]
#[pyo3(signature = (params, theta_m, theta_m_dot, tau))]
fn analysis_splay_derivative(
    params: Params<'_, '_>,
    theta_m: f64,
    theta_m_dot: f64,
    tau: f64,
) -> PyResult<f64> {
    guard(|| pc::splay_derivative(&rhex(params)?, theta_m, theta_m_dot, tau).map_err(err))
}

#[pyfunction]
#[pyo3(signature = (params, leg_kind, theta2, phi, theta2_dot, phi_dot, tau2))]
fn analysis_single_leg_pitch_accel(
    params: Params<'_, '_>,
    leg_kind: &str,
    theta2: f64,
    phi: f64,
    theta2_dot: f64,
    phi_dot: f64,
    tau2: f64,
) -> PyResult<f64> {
    guard(|| {
        let model = takeoff_model(params, leg(leg_kind)?)?;
        pc::single_leg_pitch_accel(&model, theta2, phi, theta2_dot, phi_dot, tau2)
            .map_err(|e| err(e.into()))
    })
}

#[pyfunction]
#[pyo3(signature = (params, pairs))]
fn analysis_leg_effectiveness(params: Params<'_, '_>, pairs: usize) -> PyResult<f64> {
    guard(|| {
        let base = match params {
            None => None,
            Some(d) => Some(self::params(Some(d))?),
        };
        let r = leg_tail::tail_rhex(base, pairs).map_err(err)?;
        leg_tail::leg_effectiveness(&r).map_err(err)
    })
}

/// Any robot: body rotation for one revolution of `joints` in flight, by the zero-momentum
/// integral and by simulation. `q0` is the caller's: its errors name it.
#[pyfunction]
#[pyo3(signature = (robot, q0, joints, period_s, dt_s))]
fn analysis_tail_effect<'py>(
    py: Python<'py>,
    robot: PyRef<'py, Robot>,
    q0: Vec<f64>,
    joints: Vec<usize>,
    period_s: f64,
    dt_s: f64,
) -> AnyOut<'py> {
    guard(|| {
        let model = robot.model().clone();
        let (mom, sim) = py
            .detach(|| {
                let mom = tail::revolution_rotation_momentum(&model, &q0, &joints, 128)?;
                let sim = tail::revolution_rotation_dynamic(&model, &q0, &joints, period_s, dt_s)?;
                Ok::<_, RhexError>((mom, sim))
            })
            .map_err(|e| errors::rhex(e, Source::Caller))?;
        let d = PyDict::new(py);
        d.set_item("momentum_delta_phi", mom)?;
        d.set_item("simulated", to_py(py, &sim)?)?;
        Ok(d.into_any())
    })
}

#[pyfunction]
#[pyo3(signature = (params, leg_shape, seed, max_slope_rad, tau_d0, dt_s, steps))]
#[allow(clippy::too_many_arguments)]
fn analysis_standing_rhex<'py>(
    py: Python<'py>,
    params: Params<'_, 'py>,
    leg_shape: &str,
    seed: u64,
    max_slope_rad: f64,
    tau_d0: f64,
    dt_s: f64,
    steps: usize,
) -> AnyOut<'py> {
    guard(|| {
        let mut p = self::params(params)?;
        let shapes = [
            ("stick", LegShape::Stick),
            ("half_circle", LegShape::HalfCircle),
        ];
        p.leg_shape = choice("leg_shape", leg_shape, &shapes)?;
        let r = Rhex::new(p).map_err(err)?;
        detached(py, || {
            let (q0, terrain, mode) = standing::random_rhex_stance(&r, seed, max_slope_rad)?;
            Ok(stand::simulate_standing(
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
    })
}
