//! The two-node thermal model of Fig. 2.7: exact discretization against RK4, the closed-form
//! steady state, the energy balance, Table 2.3's heat coefficients and the 60 % claim, the
//! 125 °C continuous current, and the least-squares case fit of Fig. 2.9.
use motor::catalog::CaseParameters;
use motor::numeric::rk4_step;
use motor::thermal::{
    HeatInput, ThermalModel, ThermalState, ThermalTrace, COPPER_ALPHA_PER_K,
    MAX_WINDING_TEMPERATURE_C,
};
use motor::{Catalog, MotorError};
use rand::{Rng, SeedableRng};

fn model() -> ThermalModel {
    // maxon-like values: R1 2 K/W, R2 6 K/W, τ1 17 s, τ2 300 s, R_c 1.2 Ω
    ThermalModel::from_time_constants(2.0, 6.0, 17.0, 300.0, 1.2).unwrap()
}

/// Classical RK4 on the circuit ODE with the heat input held per sample: an independent
/// route to the exact exponential step ([`ThermalModel`] does not integrate numerically).
/// `m`'s temperatures from rest at the ambient temperature `ambient_c` under `input`, one
/// sample every `dt_s`.
fn from_ambient(
    m: &ThermalModel,
    ambient_c: f64,
    dt_s: f64,
    input: HeatInput<'_>,
) -> motor::Result<ThermalTrace> {
    m.simulate(ThermalState::ambient(ambient_c), ambient_c, dt_s, input)
}

fn rk4_reference(
    m: &ThermalModel,
    ambient: f64,
    dt: f64,
    power: &[f64],
    substeps: usize,
) -> Vec<(f64, f64)> {
    let f = |x1: f64, x2: f64, p: f64| {
        let q12 = (x1 - x2) / m.r_core_case_k_per_w;
        (
            (p - q12) / m.c_core_j_per_k,
            (q12 - x2 / m.r_case_ambient_k_per_w) / m.c_case_j_per_k,
        )
    };
    let h = dt / substeps as f64;
    let (mut x1, mut x2) = (0.0, 0.0);
    let mut out = vec![(ambient, ambient)];
    for &p in power {
        for _ in 0..substeps {
            (x1, x2) = rk4_step(x1, x2, h, |x1, x2| f(x1, x2, p));
        }
        out.push((x1 + ambient, x2 + ambient));
    }
    out
}

#[test]
fn exact_step_matches_rk4_and_converges_to_the_closed_form_steady_state() {
    let m = model();
    let power: Vec<f64> = (0..600)
        .map(|k| {
            if k < 300 {
                10.0
            } else {
                2.0 + (k as f64 * 0.1).sin()
            }
        })
        .collect();
    let trace = from_ambient(&m, 25.0, 1.0, HeatInput::Power(&power)).unwrap();
    let reference = rk4_reference(&m, 25.0, 1.0, &power, 50);
    for (k, (c1, c2)) in reference.iter().enumerate() {
        assert!(
            (trace.core_c[k] - c1).abs() < 1e-9 && (trace.case_c[k] - c2).abs() < 1e-9,
            "sample {k}"
        );
    }
    // steady state x1 = P (R1 + R2), x2 = P R2
    let long = from_ambient(&m, 20.0, 5.0, HeatInput::Power(&vec![7.0; 2000])).unwrap();
    let steady = m.steady_state(7.0, 20.0);
    assert!((long.core_c.last().unwrap() - (20.0 + 7.0 * 8.0)).abs() < 1e-9);
    assert!((long.case_c.last().unwrap() - (20.0 + 7.0 * 6.0)).abs() < 1e-9);
    assert!((steady.core_c - (20.0 + 56.0)).abs() < 1e-12);
}

#[test]
fn heat_in_equals_heat_stored_plus_heat_lost() {
    // ∫P dt = C1 x1 + C2 x2 + ∫ x2/R2 dt (the circuit's energy balance), with the loss
    // integral by the trapezoid rule on a fine grid.
    let m = model();
    let dt = 0.01;
    let power: Vec<f64> = (0..60_000)
        .map(|k| if k < 30_000 { 12.0 } else { 0.0 })
        .collect();
    let trace = from_ambient(&m, 0.0, dt, HeatInput::Power(&power)).unwrap();
    let heat_in: f64 = power.iter().sum::<f64>() * dt;
    let lost: f64 = trace
        .case_c
        .windows(2)
        .map(|w| 0.5 * (w[0] + w[1]) * dt / m.r_case_ambient_k_per_w)
        .sum();
    let stored = m.c_core_j_per_k * trace.core_c.last().unwrap()
        + m.c_case_j_per_k * trace.case_c.last().unwrap();
    assert!(
        ((stored + lost) / heat_in - 1.0).abs() < 1e-6,
        "{} vs {heat_in}",
        stored + lost
    );
}

#[test]
fn table_2_3_heat_coefficients_scale_as_one_over_g_squared_and_give_the_60_percent_reduction() {
    let catalog = Catalog::thesis();
    let x18 = catalog.drive("x-rhex-18").unwrap();
    let x28 = catalog.drive("x-rhex-28").unwrap();
    let t18 = catalog
        .drive_thermal("x-rhex-18", CaseParameters::Measured)
        .unwrap();
    // the round trip H → (R_th) → H
    let (hc, hk) = t18.heat_coefficients(&x18);
    assert!((hc - 9.4).abs() < 1e-12 && (hk - 10.2).abs() < 1e-12);
    // The same motor behind 28:1: H scales by (18/28)² -- Table 2.3 prints 3.9, 3.7, 4.2 for
    // the 28:1 column, each within rounding of the 18:1 value times (18/28)².
    let s = (18.0_f64 / 28.0).powi(2);
    let (hc28, hk28) = t18.heat_coefficients(&x28);
    assert!((hc28 - 9.4 * s).abs() < 1e-12 && (hk28 - 10.2 * s).abs() < 1e-12);
    for (h18, printed28) in [(9.4, 3.9), (8.9, 3.7), (10.2, 4.2)] {
        assert!(
            (h18 * s - printed28).abs() <= 0.05 + 1e-12,
            "{h18} → {printed28}"
        );
    }
    // Simulate one output-torque profile through both gearboxes (same motor, same thermal
    // circuit): the rise over ambient is linear in I² ∝ 1/G², so at every instant the 28:1
    // rise is (18/28)² of the 18:1 rise, a 58.7 % reduction -- the thesis's "60 %".
    let profile: Vec<f64> = (0..3600)
        .map(|k| if k % 600 < 400 { 1.5 } else { 0.3 })
        .collect();
    let torque = |drive| HeatInput::OutputTorque {
        drive,
        torque_n_m: &profile,
    };
    let a = from_ambient(&t18, 25.0, 1.0, torque(&x18)).unwrap();
    let b = from_ambient(&t18, 25.0, 1.0, torque(&x28)).unwrap();
    for k in 1..a.core_c.len() {
        let ratio = (b.core_c[k] - 25.0) / (a.core_c[k] - 25.0);
        assert!((ratio - s).abs() < 1e-9, "sample {k}: {ratio}");
    }
    assert!((1.0 - s - 0.587).abs() < 1e-3);
    // and from the printed coefficients (core + measured case) directly
    let printed_ratio: f64 = (3.9 + 4.2) / (9.4 + 10.2);
    assert!((printed_ratio - s).abs() < 0.01);
}

#[test]
fn continuous_current_reaches_exactly_the_winding_limit_with_hot_resistance() {
    let m = model()
        .with_winding_alpha(COPPER_ALPHA_PER_K, 25.0)
        .unwrap();
    let current = m
        .continuous_current_a(MAX_WINDING_TEMPERATURE_C, 25.0)
        .unwrap();
    // closed form: I² R_c (1 + α (125 − 25)) (R1 + R2) = 100 K
    let expected = (100.0 / (1.2 * (1.0 + COPPER_ALPHA_PER_K * 100.0) * 8.0)).sqrt();
    assert!((current - expected).abs() < 1e-12);
    // simulation with the temperature-dependent resistance settles at 125 °C
    let trace = from_ambient(&m, 25.0, 0.5, HeatInput::Current(&vec![current; 20_000])).unwrap();
    assert!(
        (trace.core_c.last().unwrap() - 125.0).abs() < 1e-6,
        "{}",
        trace.core_c.last().unwrap()
    );
    let steady = m.steady_state_for_current(current, 25.0).unwrap();
    assert!((steady.core_c - 125.0).abs() < 1e-9);
    // thermal runaway is reported, not integrated into nonsense
    assert!(matches!(
        m.steady_state_for_current(100.0, 25.0),
        Err(MotorError::InvalidParameter {
            field: "current_a",
            ..
        })
    ));
}

#[test]
fn case_fit_recovers_the_parameters_of_a_heating_and_cooling_log() {
    // Fig. 2.9: three fixed current demands, then cooling from 3300 s. The "measured" log is
    // the model with the Table 2.3 measured X-RHex case (H_case 10.2, τ 710 s) plus 0.3 K
    // Gaussian sensor noise; the fit starts from the listed values (8.9, 212 s).
    let catalog = Catalog::thesis();
    let truth = catalog
        .drive_thermal("x-rhex-18", CaseParameters::Measured)
        .unwrap();
    let start = catalog
        .drive_thermal("x-rhex-18", CaseParameters::Listed)
        .unwrap();
    let current: Vec<f64> = (0..4400)
        .map(|k| match k {
            0..1100 => 2.0,
            1100..2200 => 3.0,
            2200..3300 => 4.0,
            _ => 0.0,
        })
        .collect();
    let clean = from_ambient(&truth, 22.0, 1.0, HeatInput::Current(&current)).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
    let noisy: Vec<f64> = clean
        .case_c
        .iter()
        .map(|t| {
            // Box–Muller
            let (u1, u2): (f64, f64) = (rng.gen::<f64>().max(1e-300), rng.gen());
            t + 0.3 * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        })
        .collect();
    let fit = start.fit_case(22.0, 1.0, &current, &noisy).unwrap();
    let (_, tau2) = fit.model.time_constants_s();
    assert!((fit.model.r_case_ambient_k_per_w / truth.r_case_ambient_k_per_w - 1.0).abs() < 0.01);
    assert!((tau2 / 710.0 - 1.0).abs() < 0.02, "τ2 = {tau2}");
    // the RMS error is the noise level (the thesis reports ≈ 1 °C on real data)
    assert!(
        (fit.rms_error_c - 0.3).abs() < 0.03,
        "rms {}",
        fit.rms_error_c
    );
}

#[test]
fn bad_thermal_inputs_are_typed_errors() {
    assert!(matches!(
        ThermalModel::new(-1.0, 6.0, 10.0, 100.0, 1.0),
        Err(MotorError::InvalidParameter {
            field: "r_core_case_k_per_w",
            ..
        })
    ));
    assert!(matches!(
        ThermalModel::from_time_constants(2.0, 6.0, 17.0, 300.0, -1.2),
        Err(MotorError::InvalidParameter {
            field: "winding_resistance_ohm",
            ..
        })
    ));
    let m = model();
    assert!(matches!(
        from_ambient(&m, 25.0, 1.0, HeatInput::Power(&[1.0, f64::NAN])),
        Err(MotorError::NonFiniteSample {
            field: "power_w",
            index: 1,
            ..
        })
    ));
    assert!(matches!(
        m.fit_case(25.0, 1.0, &[1.0, 1.0, 1.0], &[25.0, 25.0]),
        Err(MotorError::LengthMismatch { .. })
    ));
    assert!(matches!(
        m.fit_case(25.0, 1.0, &[1.0, 1.0], &[25.0, f64::NAN, 25.0]),
        Err(MotorError::NonFiniteSample {
            field: "measured_case_c",
            ..
        })
    ));
}
