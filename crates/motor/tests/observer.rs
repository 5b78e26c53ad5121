//! The leg observer and fault machine of thesis section 2.2, end to end on synthetic logs:
//! a simulated leg (the flight model with its own delay, encoder quantization and velocity
//! noise) with and without ground contact, hitting an obstacle in the air, and breaking
//! off; and the Nelder–Mead calibration recovering the parameters of a free-swing run.
use motor::numeric::rk4_step;
use motor::observer::*;
use motor::MotorError;
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

mod common;
use common::synthetic_leg;

const DT: f64 = 0.001;

/// What the world does to the simulated leg.
#[derive(Clone, Copy, Default)]
struct World {
    ground: bool,
    /// (start time, end time, arc low, arc high): a wall met only in that window.
    obstacle: Option<(f64, f64, f64, f64)>,
    /// From this time on the leg has no foot: no ground, 70 % of the gravity load.
    break_time: Option<f64>,
}

const CONTACT_HALF_ANGLE: f64 = 30.0 * PI / 180.0;

/// Simulates the physical leg: the same motor/PD/gravity structure driven by the reference
/// delayed by `T_del` (what reaches the hip over the bus), plus contact damping, sampled
/// with a 4096-count encoder and noisy velocity.
fn simulate(
    p: &ObserverParams,
    world: World,
    frequency_hz: impl Fn(f64) -> f64,
    duration_s: f64,
    seed: u64,
) -> LegLog {
    let n = (duration_s / DT) as usize;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    // reference from the Buehler clock, integrating the (possibly ramped) frequency
    let mut phase = 0.0;
    let mut refs = Vec::with_capacity(n);
    for k in 0..n {
        let f = frequency_hz(k as f64 * DT);
        let clock = BuehlerClock::new(1.0 / f, 0.5, PI / 3.0, 0.0).unwrap();
        refs.push(clock.reference_at_phase(phase));
        phase += f * DT;
    }
    let delay = (p.delay_s / DT).round() as usize;
    let (mut theta, mut omega) = refs[0];
    let mut log = LegLog {
        dt_s: DT,
        ..Default::default()
    };
    let substeps = 4;
    let h = DT / substeps as f64;
    for k in 0..n {
        let t = k as f64 * DT;
        let (theta_d, omega_d) = refs[k.saturating_sub(delay)];
        let broken = world.break_time.is_some_and(|tb| t >= tb);
        let k_g = if broken { 0.7 * p.k_g } else { p.k_g };
        let accel = |th: f64, w: f64| {
            let e = p.k_p * wrap_angle(theta_d - th)
                + p.k_d * (omega_d - w)
                + k_g * (th + p.theta_g_rad).sin();
            let mut a = -p.a_m * w + p.k_m * e;
            if world.ground && !broken && wrap_angle(th).abs() < CONTACT_HALF_ANGLE {
                a -= 60.0 * w; // the body's weight on the leg resists its rotation
            }
            if let Some((t0, t1, lo, hi)) = world.obstacle {
                let x = wrap_angle(th);
                if t >= t0 && t < t1 && x > lo && x < hi {
                    a -= 400.0 * w;
                }
            }
            a
        };
        for _ in 0..substeps {
            (theta, omega) = rk4_step(theta, omega, h, |th, w| (w, accel(th, w)));
        }
        let counts = (theta / (2.0 * PI) * 4096.0).round();
        log.theta_d_rad.push(refs[k].0);
        log.omega_d_rad_s.push(refs[k].1);
        log.theta_rad.push(wrap_angle(counts * 2.0 * PI / 4096.0));
        log.omega_rad_s
            .push(omega + 0.05 * (rng.gen::<f64>() - 0.5));
    }
    log
}

fn fsm(expect_ground: bool) -> FaultFsmConfig {
    let deg = PI / 180.0;
    FaultFsmConfig {
        phases: PhasePartition {
            landing_start_rad: -60.0 * deg,
            ground_start_rad: -20.0 * deg,
            takeoff_start_rad: 25.0 * deg,
            air_start_rad: 60.0 * deg,
        },
        low_residual_rad: 0.04,
        high_residual_rad: 0.12,
        min_dwell_s: 0.02,
        expect_ground,
    }
}

fn faults(changes: &[StateChange]) -> Vec<StateChange> {
    changes
        .iter()
        .copied()
        .filter(|c| c.to.is_fault())
        .collect()
}

/// The synthetic leg walking in `world` at one stride a second for 6 s (`seed` for the
/// sensor noise), identified with a fault detector that expects ground: its fault changes,
/// of which there is at least one, the first of them `first`.
fn faults_walking_in(world: World, seed: u64, first: LegState) -> Vec<StateChange> {
    let p = synthetic_leg();
    let log = simulate(&p, world, |_| 1.0, 6.0, seed);
    let changes = identify(&p, &fsm(true), &log).unwrap();
    let found = faults(&changes);
    assert!(!found.is_empty(), "{changes:?}");
    assert_eq!(found[0].to, first, "{changes:?}");
    found
}

#[test]
fn wrap_angle_maps_to_the_half_open_interval() {
    assert_eq!(wrap_angle(PI), PI);
    assert!((wrap_angle(-PI) - PI).abs() < 1e-15);
    assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-15);
    assert!((wrap_angle(-7.0) - (-7.0 + 2.0 * PI)).abs() < 1e-15);
}

#[test]
fn free_swing_residuals_are_small_where_the_tracking_error_is_not_and_nothing_is_flagged() {
    let p = synthetic_leg();
    let log = simulate(&p, World::default(), |_| 1.0, 6.0, 1);
    let samples = observe(&p, &log).unwrap();
    let skip = 200; // initial transient
    let max_r = samples[skip..]
        .iter()
        .map(|s| s.r_theta_rad.abs())
        .fold(0.0, f64::max);
    let max_tracking = (skip..log.len())
        .map(|k| wrap_angle(log.theta_d_rad[k] - log.theta_rad[k]).abs())
        .fold(0.0, f64::max);
    // Fig. 2.12 (left): the observer explains the tracking error of the free leg
    // (gravity sag, lag at the clock's speed changes); the residual stays at encoder
    // resolution while the raw tracking error would read as a "high" disturbance.
    assert!(max_r < 0.01, "max |r_θ| = {max_r}");
    assert!(max_tracking > 0.12, "max tracking error = {max_tracking}");
    let changes = identify(&p, &fsm(false), &log).unwrap();
    assert!(changes.is_empty(), "{changes:?}");
}

#[test]
fn walking_on_ground_cycles_stance_and_flight_without_faults() {
    let p = synthetic_leg();
    let log = simulate(
        &p,
        World {
            ground: true,
            ..Default::default()
        },
        |_| 1.0,
        6.0,
        2,
    );
    let changes = identify(&p, &fsm(true), &log).unwrap();
    assert!(faults(&changes).is_empty(), "{changes:?}");
    let stances = changes.iter().filter(|c| c.to == LegState::Stance).count();
    let flights = changes.iter().filter(|c| c.to == LegState::Flight).count();
    assert!(stances >= 5 && flights >= 5, "{changes:?}");
    // stance is declared while the leg is in the contact arc
    for c in changes.iter().filter(|c| c.to == LegState::Stance) {
        let k = (c.time_s / DT).round() as usize;
        assert!(
            wrap_angle(log.theta_rad[k]).abs() < CONTACT_HALF_ANGLE + 0.05,
            "{c:?}"
        );
    }
}

#[test]
fn an_obstacle_in_the_air_is_an_unexpected_disturbance() {
    let deg = PI / 180.0;
    let world = World {
        ground: true,
        obstacle: Some((3.5, 4.0, -100.0 * deg, -80.0 * deg)),
        ..Default::default()
    };
    let found = faults_walking_in(world, 3, LegState::UnexpectedDisturbance);
    assert!(found[0].time_s > 3.5 && found[0].time_s < 4.1, "{found:?}");
    assert!(
        found.iter().all(|c| c.to != LegState::MissingGround),
        "{found:?}"
    );
}

#[test]
fn a_leg_that_breaks_off_misses_the_ground_in_its_next_stance() {
    let world = World {
        ground: true,
        break_time: Some(3.7),
        ..Default::default()
    };
    let found = faults_walking_in(world, 4, LegState::MissingGround);
    // the first stance after the break starts at t = 4 s (clock phase 0)
    assert!(found[0].time_s > 4.0 && found[0].time_s < 4.5, "{found:?}");
    // and every later stance is missed too
    let missed = found
        .iter()
        .filter(|c| c.to == LegState::MissingGround)
        .count();
    assert!(missed >= 2, "{found:?}");
    assert!(
        found
            .iter()
            .all(|c| c.to != LegState::UnexpectedDisturbance),
        "{found:?}"
    );
}

#[test]
fn nelder_mead_calibration_recovers_the_free_swing_parameters() {
    // Thesis section 2.2.1: trained on free leg spinning with the gait speed ramped from
    // about 0.6 to 2.5 strides per second.
    let p = synthetic_leg();
    let log = simulate(
        &p,
        World::default(),
        |t| 0.6 + (2.5 - 0.6) * t / 8.0,
        8.0,
        5,
    );
    let initial = ObserverParams {
        k_m: 60.0,
        a_m: 15.0,
        k_d: 0.4,
        k_g: -1.3,
        theta_g_rad: 0.1,
        delay_s: 0.020,
        k_p: p.k_p,
    };
    let calibration = calibrate(&log, &initial).unwrap();
    let c = calibration.params;
    assert!((c.k_m / p.k_m - 1.0).abs() < 0.02, "{c:?}");
    assert!((c.a_m / p.a_m - 1.0).abs() < 0.03, "{c:?}");
    assert!((c.k_d / p.k_d - 1.0).abs() < 0.03, "{c:?}");
    assert!((c.k_g / p.k_g - 1.0).abs() < 0.03, "{c:?}");
    assert!(c.theta_g_rad.abs() < 0.02, "{c:?}");
    assert!((c.delay_s - p.delay_s).abs() < 0.001, "{c:?}");
    // residual at the encoder resolution (2π/4096 = 1.5e-3 rad)
    assert!(calibration.rms_r_theta_rad < 1.5e-3, "{calibration:?}");
}

#[test]
fn bad_observer_inputs_are_typed_errors() {
    let p = synthetic_leg();
    let mut log = simulate(&p, World::default(), |_| 1.0, 0.1, 6);
    log.theta_rad[7] = f64::NAN;
    assert!(matches!(
        observe(&p, &log),
        Err(MotorError::NonFiniteSample {
            field: "theta_rad",
            index: 7,
            ..
        })
    ));
    log.theta_rad.pop();
    assert!(matches!(
        observe(&p, &log),
        Err(MotorError::LengthMismatch { .. })
    ));
    let bad = ObserverParams { k_m: -1.0, ..p };
    assert!(matches!(
        LegObserver::new(bad, DT, 0.0, 0.0),
        Err(MotorError::InvalidParameter { field: "k_m", .. })
    ));
    let mut config = fsm(true);
    config.high_residual_rad = 0.01;
    assert!(matches!(
        FaultFsm::new(config, LegState::Flight),
        Err(MotorError::InvalidParameter { .. })
    ));
    let mut config = fsm(true);
    config.phases.air_start_rad = 0.0;
    assert!(FaultFsm::new(config, LegState::Flight).is_err());
}
