//! The leap preset's own guarantees: a preset reused over points runs the leaps fresh ones
//! run (bit for bit) and checks its points as they do; the waiting legs' start pose.
use rhex_model::leap::{
    leap_params, leap_rhex, leap_start_pose, simulate_leap, GearedMotor, LeapConfig, LeapPreset,
    LeapResult, LegActuator, T2Reference, X_RHEX_LEG,
};
use rhex_model::Rhex;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_hybrid::budget::NEVER;
use selfmanip_sim::terrain::TerrainSpec;

/// What a leap's run is, to the bit: status, word, apex, motor start, the engine's
/// termination and step count, and every event's time, kind and state.
fn fingerprint(r: &LeapResult) -> String {
    format!(
        "{:?} {:?} {:?} {:?} {:?} {} {:?}",
        r.status,
        r.word,
        r.apex,
        r.motor_t2_s.to_bits(),
        r.execution.termination,
        r.execution.steps,
        r.execution.events
    )
}

/// A preset reused over points (t2 both ways of zero, gear ratios, current limits, the
/// touchdown-timed search) runs the leaps that fresh one-shot leaps of those points run,
/// bit for bit; on legs whose armature follows the gear ratio too (rebuilt there).
#[test]
fn a_reused_preset_runs_the_leaps_of_fresh_ones() {
    let geared = |g: f64, i: f64| {
        LegActuator::GearedMotor(GearedMotor {
            gear_ratio: g,
            current_limit_a: i,
            motors_per_leg: 2,
            gearbox_efficiency: None,
            gearbox_loss: Default::default(),
            battery_resistance_ohm: None,
        })
    };
    let mut rotors = leap_params();
    rotors.m_l = 0.126;
    rotors.I_l = 0.00092;
    let cases = [
        (leap_params(), T2Reference::MotorStart, "-+"),
        (leap_params(), T2Reference::Touchdown, "++"),
        (rotors, T2Reference::MotorStart, "+-"),
    ];
    for (params, t2_reference, strategy) in cases {
        let cfg = LeapConfig {
            strategy: strategy.parse().unwrap(),
            t2_reference,
            ..LeapConfig::default()
        };
        let preset = LeapPreset::new(&params, &cfg).unwrap();
        for (t2, actuator) in [
            (0.03, geared(28.0, 20.0)),
            (-0.05, geared(28.0, 20.0)),
            (0.02, geared(33.0, 20.0)),
            (-0.01, geared(24.0, 12.0)),
            (0.0, LegActuator::SaturatedTorque),
        ] {
            let point = LeapConfig {
                t2_s: t2,
                actuator: actuator.clone(),
                ..cfg.clone()
            };
            let fresh = simulate_leap(&params, &point).unwrap();
            let reused = preset.run_at(t2, &actuator, &NEVER).unwrap();
            assert_eq!(
                fingerprint(&reused),
                fingerprint(&fresh),
                "{strategy} t2 = {t2} {actuator:?}"
            );
        }
    }
}

/// A point's bad value is refused as a fresh leap refuses it, naming the field.
#[test]
fn a_reused_preset_checks_its_points() {
    let preset = LeapPreset::new(&leap_params(), &LeapConfig::default()).unwrap();
    let bad = X_RHEX_LEG.at_gear_ratio(-3.0);
    match preset.run_at(0.0, &bad, &NEVER) {
        Err(e) => assert_eq!(e.field(), Some("gear_ratio"), "{e}"),
        other => panic!("{other:?}"),
    }
    match preset.run_at(f64::NAN, &X_RHEX_LEG.actuator(), &NEVER) {
        Err(e) => assert_eq!(e.field(), Some("t2_s"), "{e}"),
        other => panic!("{other:?}"),
    }
}

/// The gap of leg `i`'s toe with that leg turned to `theta` from `q0` (m).
fn gap(rhex: &Rhex, terrain: &TerrainSpec, q0: &[f64], i: usize, theta: f64) -> f64 {
    let mut q = q0.to_vec();
    q[i] = theta;
    let mut kin = Kinematics::default();
    kin.compute(&rhex.model, &q, &vec![0.0; q.len()]);
    selfmanip_core::contact::contact_geometry(&rhex.model, &kin, terrain, rhex.site(2 * i + 1))
        .gap_m
}

/// The waiting legs are held the clearance above the angle where the toe touches the
/// ground (gap zero, checked on the kinematics directly), on flat ground and on an
/// incline; another clearance shifts them by the difference.
#[test]
fn legs_wait_the_clearance_above_their_touchdown_angles() {
    let params = leap_params();
    let cfg = LeapConfig {
        wait_clearance_rad: 0.731_234,
        ..LeapConfig::default()
    };
    let rhex = leap_rhex(&params, &cfg).unwrap();
    let q0 = leap_start_pose(&rhex, &cfg).unwrap();
    let sign = [cfg.strategy.front.sign(), cfg.strategy.rear.sign()];
    for i in 0..2 {
        let touchdown = q0[i] + sign[i] * cfg.wait_clearance_rad;
        assert!(
            gap(&rhex, &cfg.terrain, &q0, i, touchdown).abs() < 1e-12,
            "leg {i}"
        );
        assert!(
            gap(&rhex, &cfg.terrain, &q0, i, q0[i]) > 1e-3,
            "leg {i} waits clear"
        );
    }
    let other = LeapConfig {
        wait_clearance_rad: 0.5,
        ..cfg.clone()
    };
    let moved = leap_start_pose(&rhex, &other).unwrap();
    for i in 0..2 {
        let shift = moved[i] - q0[i];
        assert!(
            (shift - sign[i] * (0.731_234 - 0.5)).abs() < 1e-14,
            "leg {i}: {shift}"
        );
    }
    let incline = LeapConfig {
        terrain: TerrainSpec::Incline { slope_rad: 0.05 },
        ..cfg.clone()
    };
    let low = leap_start_pose(&rhex, &incline).unwrap();
    assert!(low.iter().zip(&q0).any(|(a, b)| a != b));
    for i in 0..2 {
        let touchdown = low[i] + sign[i] * cfg.wait_clearance_rad;
        let g = gap(&rhex, &incline.terrain, &low, i, touchdown);
        assert!(g.abs() < 1e-12, "leg {i} on the incline: {g}");
    }
}
