//! A one-legged hopper dropped from a height, hopping in place: the robot and the behaviour
//! are data files (`data/hopper.toml`, `data/hop.toml`); the run is logged to MCAP.
//!
//! ```sh
//! cargo run --release -p selfmanip-sim --example hopper -- [hopper.mcap]
//! ```
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::Simulation;
use std::collections::BTreeMap;

mod common;
use common::{data, dropped_hopper};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "hopper.mcap".into());
    // dropped level, foot 10 cm above the ground, the leg at its landing pose
    let mut scenario = dropped_hopper(0.1)?;
    scenario.behaviour = Behaviour::from_file(&data("hop.toml"))?;
    scenario.options.t_final_s = 1.0;
    let run = Simulation::new(&scenario)?.run()?;
    let o = &run.outcome;
    println!("status {}  word {}", o.status.as_str(), o.word_string());
    for e in run.events() {
        println!(
            "  t {:.4} s  {:<9} {} -> {}  {:?}  loss {:.3} J",
            e.t_s, e.kind, e.mode_before, e.mode_after, e.contacts, e.energy_loss_j
        );
    }
    if let Some(ap) = o.apex {
        println!("first apex: t {:.3} s, height {:.3} m", ap.t_s, -ap.z_m);
    }
    let energy = run.energy_report()?;
    println!(
        "energy: E0 {:.3} J, E1 {:.3} J, joint work {:.3} J, impact loss {:.3} J, residual {:.2e} J",
        energy.initial_j,
        energy.final_j,
        energy.joint_work_j,
        energy.impact_loss_j,
        energy.residual_j()
    );
    let mut md = BTreeMap::new();
    md.insert("example".into(), "hopper".into());
    run.write_mcap(std::path::Path::new(&out), 0.005, md)?;
    println!("wrote {out}");
    Ok(())
}
