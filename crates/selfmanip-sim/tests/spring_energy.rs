//! The energy balance `E₁ − E₀ = W + W_d + W_fr − L` with passive joint springs and dampers
//! (issue 31: the report left out the springs' potential energy and the dampers' work, so a
//! limp one-link leg with a 20 N m/rad spring, in flight from θ = 0.8, reported a residual of
//! ½k(0.8² − θ_end²) = 2.29 J). `E` holds `V_s = ½kd² + ¼k₃d⁴`; `W_d = −∫Σcθ̇² dt`. The
//! balance is a conservation law checked against states integrated by the engine: the two
//! sides come from different routes (energies at the end states, quadrature of powers).
mod common;

use common::test_robot;
use selfmanip_core::description::SpringDescription;
use selfmanip_core::RobotDescription;
use selfmanip_sim::{Scenario, Simulation};

/// `tests/data/robots/sprung_leg.toml` with `spring` at its leg's joint, with its foot or
/// (`contact = false`) without any contact.
fn leg(spring: SpringDescription, contact: bool) -> RobotDescription {
    let mut robot = test_robot("sprung_leg.toml");
    robot.legs[0].links[0].spring = Some(spring);
    if !contact {
        robot.contacts.clear();
    }
    robot
}

/// A spring of stiffness `k` (N·m/rad), cubic term `k3` (N·m/rad³), damping `c`
/// (N·m·s/rad), relaxed at `rest` (rad).
fn spring(k: f64, k3: f64, c: f64, rest: f64) -> SpringDescription {
    SpringDescription {
        stiffness_n_m_per_rad: k,
        cubic_stiffness_n_m_per_rad3: k3,
        damping_n_m_s_per_rad: c,
        rest_angle_rad: rest,
    }
}

/// A limp run (no behaviour: zero torques) of `robot` from `q` for `t_final` s.
fn run(robot: RobotDescription, q: Vec<f64>, qd: Option<Vec<f64>>, t_final: f64) -> Simulation {
    let mut s = Scenario::new(robot, q);
    s.initial.qd = qd;
    s.options.t_final_s = t_final;
    s.options.rtol = 1e-10;
    Simulation::new(&s).unwrap()
}

/// The case: the old residual was exactly the spring energy released,
/// ½k(0.8² − θ_end²); now the total energy is conserved (no torque, damper or contact).
#[test]
fn a_limp_sprung_leg_in_flight_conserves_energy_with_its_spring() {
    let k = 20.0;
    let sim = run(
        leg(spring(k, 0.0, 0.0, 0.0), false),
        vec![0.8, 0.0, -2.0, 0.0],
        None,
        0.3,
    );
    let r = sim.run().unwrap();
    let e = r.energy_report().unwrap();
    let theta_end = r.execution.q[0];
    let released = 0.5 * k * (0.8f64.powi(2) - theta_end.powi(2));
    assert!(released.abs() > 0.5, "the spring moves energy: {released}");
    assert_eq!((e.joint_work_j, e.damping_work_j), (0.0, 0.0));
    assert!(e.residual_j().abs() < 1e-6, "{e:?}");
    assert!((e.final_j - e.initial_j).abs() < 1e-6, "{e:?}");
}

/// With a damper and a cubic term: the energy lost is the dampers' work, to 1e-6 J.
#[test]
fn a_damped_sprung_leg_loses_the_dampers_work() {
    let sim = run(
        leg(spring(20.0, 5.0, 0.4, 0.1), false),
        vec![0.8, 0.0, -2.0, 0.0],
        Some(vec![-3.0, 0.5, 0.0, 1.0]),
        0.3,
    );
    let e = sim.run().unwrap().energy_report().unwrap();
    assert!(e.damping_work_j < -0.1, "{e:?}");
    assert!(e.residual_j().abs() < 1e-6, "{e:?}");
    assert!(
        (e.final_j - e.initial_j - e.damping_work_j).abs() < 1e-6,
        "{e:?}"
    );
}

/// Landing on the sprung leg's foot: touchdown losses, stance with the spring loaded, and
/// the damper, all in one balance.
#[test]
fn a_sprung_leg_that_lands_balances_impacts_spring_and_damper() {
    let sim = run(
        leg(spring(30.0, 0.0, 0.2, 0.0), true),
        vec![0.3, 0.0, -0.35, 0.0],
        Some(vec![0.0, 0.3, 0.0, 0.0]),
        0.4,
    );
    let r = sim.run().unwrap();
    assert!(!r.execution.events.is_empty(), "the foot lands");
    let e = r.energy_report().unwrap();
    assert!(e.impact_loss_j > 0.0 && e.damping_work_j < 0.0, "{e:?}");
    assert!(e.residual_j().abs() < 1e-6, "{e:?}");
}
