//! Finite inputs too large for double precision (issue 31): `qd0 = 1e308` reached a free leg
//! in the air and hung in nalgebra's eigenvalue routine (no iteration cap, inf/NaN Jacobian);
//! `q0 = 1e308` ran to `final_time` with an initial energy of −inf; a periodic-orbit guess of
//! 1e308 looped in `floquet_multipliers`. Each now ends in a typed error, from the cause.
use selfmanip_core::{CoreError, RobotDescription};
use selfmanip_hybrid::HybridError;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::periodic::{periodic_orbit, PeriodicSpec};
use selfmanip_sim::{Scenario, SimError, Simulation};
use std::path::Path;

fn hopper(q: Vec<f64>, qd: Option<Vec<f64>>) -> Scenario {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data");
    let robot = RobotDescription::from_file(&data.join("hopper.toml")).unwrap();
    let mut s = Scenario::new(robot, q);
    s.initial.qd = qd;
    s.behaviour = Behaviour::from_file(&data.join("hop.toml")).unwrap();
    s.options.t_final_s = 0.05;
    s
}

const Q0: [f64; 5] = [0.5, -1.0, 0.0, -0.451, 0.0];

#[test]
fn a_hopper_launched_at_1e308_ends_with_a_non_finite_error_instead_of_hanging() {
    let sim = Simulation::new(&hopper(Q0.to_vec(), Some(vec![1e308; 5])));
    // the kinetic energy ½ q̇ᵀ M̄ q̇ overflows first: refused at the input
    match sim.err().expect("refused") {
        SimError::InvalidValue { field, reason } => {
            assert_eq!(field, "initial.qd");
            assert!(reason.contains("too large"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    // the massless leg's hip at 1e308 rad/s: no kinetic energy (the leg has no inertia), but
    // the free-leg law overflows; the run ends with a typed error at the segment's start
    // (this looped in the eigenvalue routine)
    let s = hopper(Q0.to_vec(), Some(vec![1e308, 0.0, 0.0, 0.0, 0.0]));
    match Simulation::new(&s).unwrap().run() {
        Err(SimError::Hybrid(HybridError::Core(CoreError::NonFiniteResult { quantity }))) => {
            assert!(quantity.contains("free joints"), "{quantity}")
        }
        other => panic!("{other:?}"),
    }
    // a large but representable speed is a finite run: the hip spins, nothing overflows
    let s = hopper(Q0.to_vec(), Some(vec![1e150, 0.0, 0.0, 0.0, 0.0]));
    let run = Simulation::new(&s).unwrap().run().unwrap();
    assert!(run.execution.q.iter().all(|v| v.is_finite()));
}

#[test]
fn a_hopper_placed_at_1e308_is_refused_naming_initial_q() {
    match Simulation::new(&hopper(vec![1e308; 5], None))
        .err()
        .expect("refused")
    {
        SimError::InvalidValue { field, reason } => {
            assert_eq!(field, "initial.q");
            assert!(reason.contains("too large"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    // the same robot at a reachable height runs and reports finite energies
    let run = Simulation::new(&hopper(Q0.to_vec(), None))
        .unwrap()
        .run()
        .unwrap();
    let e = run.energy_report().unwrap();
    assert!(e.initial_j.is_finite() && e.final_j.is_finite(), "{e:?}");
}

#[test]
fn a_periodic_orbit_guessed_at_1e308_is_a_typed_error_instead_of_a_hang() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data");
    let mut s = hopper(Q0.to_vec(), Some(vec![1e150; 5]));
    s.behaviour = Behaviour::from_file(&data.join("hop_periodic.toml")).unwrap();
    assert!(periodic_orbit(&s, &PeriodicSpec::default()).is_err());
}
