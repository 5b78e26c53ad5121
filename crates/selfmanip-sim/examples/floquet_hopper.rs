//! Floquet multipliers of a hopping gait (the Rust twin of
//! `python/examples/floquet_hopper.py`): the one-legged hopper of `data/hopper.toml` under
//! `data/hop_periodic.toml`; Newton shooting on the apex section finds the periodic orbit
//! (`selfmanip_sim::periodic`, `docs/periodic-orbits.md`).
//!
//! ```sh
//! cargo run --release -p selfmanip-sim --example floquet_hopper
//! ```
use selfmanip_core::RobotDescription;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::periodic::{periodic_orbit, PeriodicSpec};
use selfmanip_sim::Scenario;

mod common;
use common::data;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let robot = RobotDescription::from_file(&data("hopper.toml"))?;
    // an apex guess: level, at rest, the leg in its landing pose (hip a, knee −2a)
    let a: f64 = 0.5;
    let mut scenario = Scenario::new(robot, vec![a, -2.0 * a, 0.0, -0.45, 0.0]);
    scenario.behaviour = Behaviour::from_file(&data("hop_periodic.toml"))?;
    let (_, o) = periodic_orbit(&scenario, &PeriodicSpec::default())?;
    println!(
        "periodic orbit: period {:.5} s, apex height {:.5} m, {} Newton iterations, residual {:.1e}",
        o.period_s, -o.x[3], o.iterations, o.residual
    );
    println!(
        "events per period: {:?}",
        o.events.iter().map(|e| e.0).collect::<Vec<_>>()
    );
    println!("section multipliers:");
    for l in &o.section_multipliers {
        println!("  {:+.6} {:+.2e}i   |λ| = {:.6}", l.re, l.im, l.norm());
    }
    println!("stability: {:?}", o.stability);
    Ok(())
}
