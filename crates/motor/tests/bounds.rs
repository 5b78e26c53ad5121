//! Every size a caller can ask of the actuator models is bounded, and every result is finite
//! or a typed error naming the input: the reproducers of the adversarial audit (issue 31)
//! that reach the motor crate, each a regression test named after what it checks.
use motor::catalog::{synthetic_motors, CaseParameters, Catalog, MAX_SYNTHETIC_MOTORS};
use motor::dc::MAX_CURVE_POINTS;
use motor::observer::{observe, LegLog, LegObserver, ObserverParams, MAX_DELAY_SAMPLES};
use motor::tail::{rank_tail_motors, tail_optimum, SelectionConstraints, TailTask};
use motor::thermal::{HeatInput, ThermalState, MAX_PROFILE_SAMPLES};
use motor::MotorError;

mod common;

/// The synthetic leg with the delay `delay_s`.
fn params(delay_s: f64) -> ObserverParams {
    ObserverParams {
        delay_s,
        ..common::synthetic_leg()
    }
}

fn still_log(n: usize, dt_s: f64) -> LegLog {
    LegLog {
        dt_s,
        theta_d_rad: vec![0.0; n],
        omega_d_rad_s: vec![0.0; n],
        theta_rad: vec![0.0; n],
        omega_rad_s: vec![0.0; n],
    }
}

fn field_of(e: &MotorError) -> &'static str {
    match e {
        MotorError::InvalidParameter { field, .. }
        | MotorError::TooManySamples { field, .. }
        | MotorError::TooFewSamples { field, .. }
        | MotorError::Overflow { field, .. } => field,
        other => panic!("not a field error: {other:?}"),
    }
}

/// `observe(dict(P, delay_s=1e308), 1e-3, …)` panicked ("Out of bounds access": the delay's
/// sample count saturated to `usize::MAX` and `+ 2` wrapped).
#[test]
fn observer_delay_of_1e308_is_an_error_naming_delay_s_not_a_panic() {
    let log = still_log(100, 1e-3);
    let e = observe(&params(1e308), &log).unwrap_err();
    assert_eq!(field_of(&e), "delay_s");
    // the observer alone bounds its delay line before allocating it
    let e = LegObserver::new(params(1e308), 1e-3, 0.0, 0.0).unwrap_err();
    assert_eq!(field_of(&e), "delay_s");
    let just_over = (MAX_DELAY_SAMPLES as f64 + 1.0) * 1e-3;
    assert!(LegObserver::new(params(just_over), 1e-3, 0.0, 0.0).is_err());
}

/// A delay longer than the log compares the model with nothing of it: refused; a delay
/// inside the log runs.
#[test]
fn observer_delay_longer_than_the_log_is_refused() {
    let log = still_log(100, 1e-3);
    assert_eq!(
        field_of(&observe(&params(0.2), &log).unwrap_err()),
        "delay_s"
    );
    let samples = observe(&params(0.05), &log).unwrap();
    assert_eq!(samples.len(), 100);
    // a leg at rest at the reference with no gravity torque stays there: zero residuals
    assert!(samples.iter().all(|s| s.r_theta_rad.abs() < 1e-12));
}

/// Unknown observer keys were silently ignored.
#[test]
fn observer_params_reject_unknown_keys_naming_the_known_ones() {
    let json = r#"{"k_m": 50, "a_m": 20, "k_p": 10, "k_d": 0.5, "k_g": -1,
                   "theta_g_rad": 0, "delay_s": 0.01, "delay": 0.01}"#;
    let e = serde_json::from_str::<ObserverParams>(json)
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown field `delay`"), "{e}");
    assert!(e.contains("delay_s"), "{e}");
}

/// `torque_speed_curve(points=10**9)` asked for 24 GB.
#[test]
fn torque_speed_curve_points_are_bounded() {
    let drive = Catalog::thesis().drive("x-rhex-28").unwrap();
    let e = drive.torque_speed_curve(1_000_000_000).unwrap_err();
    assert_eq!(
        e,
        MotorError::TooManySamples {
            field: "points",
            limit: MAX_CURVE_POINTS,
            actual: 1_000_000_000
        }
    );
    // the curve's ends are the stall torque and the no-load speed (Fig. 2.6)
    let c = drive.torque_speed_curve(3).unwrap();
    assert_eq!(c[0].speed_rad_s, 0.0);
    assert_eq!(c[2].speed_rad_s, drive.output_no_load_speed_rad_s());
    assert!(c[2].torque_n_m.abs() < 1e-9 * c[0].torque_n_m);
}

/// `thermal_simulation(d, [1e308] * 10)` returned NaN temperatures (the Joule heat `I²R`
/// overflows); the CLI printed "core nan C" with exit status 0.
#[test]
fn thermal_simulation_of_an_overflowing_torque_is_an_error_naming_torque_n_m() {
    let cat = Catalog::thesis();
    let drive = cat.drive("x-rhex-28").unwrap();
    let thermal = cat
        .drive_thermal("x-rhex-28", CaseParameters::Measured)
        .unwrap();
    let run = |torque: &[f64], ambient_c: f64| {
        thermal.simulate(
            ThermalState::ambient(ambient_c),
            ambient_c,
            1.0,
            HeatInput::OutputTorque {
                drive: &drive,
                torque_n_m: torque,
            },
        )
    };
    let e = run(&[1e308; 10], 25.0).unwrap_err();
    assert!(
        matches!(
            e,
            MotorError::Overflow {
                field: "torque_n_m",
                ..
            }
        ),
        "{e:?}"
    );
    // an empty profile and an ambient below absolute zero were accepted
    assert_eq!(field_of(&run(&[], 25.0).unwrap_err()), "torque_n_m");
    assert_eq!(field_of(&run(&[1.0], -300.0).unwrap_err()), "ambient_c");
    // at absolute zero with no torque nothing heats: the trace stays there
    let t = run(&[0.0; 3], -273.15).unwrap();
    assert!(t.core_c.iter().all(|&c| c == -273.15));
    // a profile over the bound is refused before it runs
    let long = vec![0.0; MAX_PROFILE_SAMPLES + 1];
    assert_eq!(field_of(&run(&long, 25.0).unwrap_err()), "torque_n_m");
}

/// `tail_optimum(1e308, …)` returned inf: the product under the cube root overflowed where
/// the result does not. Eq. (2.1) scales as `Ω* ∝ θ₀^{1/3}`, `t* ∝ θ₀^{2/3}`: the optimum at
/// `θ₀ = 1e300` is the one at `θ₀ = 1` scaled by `1e100` and `1e200`.
#[test]
fn tail_optimum_at_a_huge_rotation_is_finite_and_follows_its_scaling_law() {
    let at = |theta0: f64| tail_optimum(&TailTask::new(theta0, 0.05, 1.29).unwrap(), 30.0).unwrap();
    let (one, huge) = (at(1.0), at(1e300));
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    assert!(rel(huge.no_load_speed_rad_s, one.no_load_speed_rad_s * 1e100) < 1e-13);
    assert!(rel(huge.completion_time_s, one.completion_time_s * 1e200) < 1e-13);
    let h = at(1e308);
    assert!(h.no_load_speed_rad_s.is_finite() && h.completion_time_s.is_finite());
}

/// `rank_tail_motors(max_length_m=nan)` returned an empty ranking (every comparison with NaN
/// is false); a synthetic catalog of any size was drawn.
#[test]
fn tail_ranking_constraints_and_catalog_size_are_checked() {
    let task = TailTask::new(std::f64::consts::FRAC_PI_2, 0.05, 1.29).unwrap();
    let motors = synthetic_motors(10, 7).unwrap();
    let with = |max_length_m: f64| SelectionConstraints {
        max_length_m,
        max_mass_kg: 0.2,
        max_completion_time_s: 0.5,
    };
    let e = rank_tail_motors(&motors, &task, &with(f64::NAN)).unwrap_err();
    assert_eq!(field_of(&e), "max_length_m");
    assert!(rank_tail_motors(&motors, &task, &with(0.03)).is_ok());
    let e = synthetic_motors(MAX_SYNTHETIC_MOTORS + 1, 7).unwrap_err();
    assert_eq!(field_of(&e), "synthetic_count");
}
