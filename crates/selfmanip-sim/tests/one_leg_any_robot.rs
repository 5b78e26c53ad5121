//! The one-leg analyses (`selfmanip_sim::analysis::one_leg`) on a robot that is not RHex, the
//! two-legged body of `tests/data/robots/knee_and_wheel_feet.toml` (a two-link fore leg, a
//! hind leg on a circular foot): the stance puts its hind foot on the ground, the
//! searched maxima are at least every point of a brute-force grid, and the pitch
//! acceleration is affine in the leg's torque (the dynamics are linear in the torques).
use selfmanip_core::{FlatGround, Model};
use selfmanip_sim::analysis::contact_gaps;
use selfmanip_sim::analysis::one_leg::*;
use selfmanip_sim::analysis::takeoff::TorqueSpeedLine;
mod common;
use common::test_robot;

fn two_legs() -> Model {
    test_robot("knee_and_wheel_feet.toml").build().unwrap()
}

#[test]
fn hind_foot_stance_and_its_takeoff_on_two_legs() {
    let m = two_legs();
    let (j, k) = rear_leg(&m).unwrap();
    assert_eq!(m.contacts[k].name, "hind_foot");
    let (theta, phi) = (0.3, 0.05);
    let (q, mode) = rear_stance_q(&m, theta, phi).unwrap();
    assert_eq!((q[j], q[m.ix_phi()]), (theta, phi));
    assert!(contact_gaps(&m, &FlatGround, &[k], &q)[0].abs() < 1e-12);
    assert_eq!(mode.active().collect::<Vec<_>>(), vec![k]);
    // the leg's angle search is at least as good as a brute-force grid over the range
    // a motor the foot can hold against at rest (20 N m would lift it: no bound)
    let line = TorqueSpeedLine::new(2.0, 30.0).unwrap();
    let range = [-0.6, 0.6];
    let speed = |t: f64| {
        rear_takeoff_speed(&m, t, phi, 0.0, &line)
            .ok()
            .flatten()
            .map_or(0.0, |b| b.x_dot.abs())
    };
    let (t_best, v_best) = best_takeoff_over_theta2(&m, phi, 0.0, &line, range);
    assert!(v_best > 0.0 && (range[0]..=range[1]).contains(&t_best));
    assert_eq!(v_best, speed(t_best));
    for i in 0..=60 {
        let t = range[0] + (range[1] - range[0]) * f64::from(i) / 60.0;
        assert!(
            speed(t) <= v_best * (1.0 + 1e-9),
            "θ = {t}: {} > {v_best}",
            speed(t)
        );
    }
    // and the gear ratio's over its grid (the line's stall torque grows, its speed falls);
    // here the best is at the range's low end, which golden section approaches to ~1e-7
    let line_of = |g: f64| TorqueSpeedLine::new(0.1 * g, 600.0 / g);
    let (g_best, v_g) = optimal_gear_ratio(&m, phi, 0.0, range, [5.0, 80.0], &line_of).unwrap();
    assert!((5.0..=80.0).contains(&g_best));
    for g in [5.0, 10.0, 20.0, 40.0, 80.0] {
        let v = best_takeoff_over_theta2(&m, phi, 0.0, &line_of(g).unwrap(), range).1;
        assert!(v <= v_g * (1.0 + 1e-6), "G = {g}: {v} > {v_g}");
    }
}

#[test]
fn one_leg_pitch_acceleration_is_affine_in_the_torque() {
    let m = two_legs();
    let a = |tau: f64| single_leg_pitch_accel(&m, 0.3, 0.05, 1.0, -0.5, tau).unwrap();
    let (a0, a1, a3) = (a(0.0), a(1.0), a(3.0));
    let slope = a1 - a0;
    assert!(slope.abs() > 1e-6);
    assert!(
        (a3 - (a0 + 3.0 * slope)).abs() < 1e-9 * (1.0 + a3.abs()),
        "{a0} {a1} {a3}"
    );
    assert!(single_leg_pitch_accel(&m, f64::NAN, 0.0, 0.0, 0.0, 0.0).is_err());
}
