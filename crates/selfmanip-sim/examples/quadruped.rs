//! A planar quadruped pronking and bounding on flat ground: robot and behaviours are data
//! files (`data/quadruped.toml`, `data/pronk.toml`, `data/bound.toml`); the legs made
//! massless by setting their links' masses by name; each run logged to MCAP.
//!
//! ```sh
//! cargo run --release -p selfmanip-sim --example quadruped -- [out_dir]
//! SET="kp_push=90,t_compress=0.03" EVENTS=1 cargo run …   # parameters by name; every event
//! ```
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::{Run, Scenario, Simulation};
use std::collections::BTreeMap;
use std::path::PathBuf;

mod common;
use common::{data, dropped_quadruped, set_from_env};

/// The quadruped dropped from `drop_m` (feet above the ground) at pitch `phi`, legs at their
/// landing pose (hip a, knee −2a: each foot under its hip).
pub fn scenario(
    behaviour: &str,
    massless: bool,
    drop_m: f64,
    phi: f64,
) -> Result<Scenario, Box<dyn std::error::Error>> {
    let mut s = dropped_quadruped(drop_m, phi)?;
    s.behaviour = Behaviour::from_file(&data(behaviour))?;
    s.options.t_final_s = 1.5;
    if massless {
        // parameters by name: every link's mass and inertia
        for leg in ["fore", "hind"] {
            for k in 0..2 {
                s.set(&format!("legs.{leg}.links[{k}].mass_kg"), 0.0)?;
                s.set(&format!("legs.{leg}.links[{k}].inertia_kg_m2"), 0.0)?;
            }
        }
    }
    set_from_env(&mut s)?;
    Ok(s)
}

fn report(name: &str, run: &Run) {
    let o = &run.outcome;
    let flights = o.word.iter().filter(|c| c.as_str() == "00").count();
    println!(
        "{name}: {} after {:.2} s, {} events, {flights} flights, word {}",
        o.status.as_str(),
        o.t_end_s,
        o.n_events,
        o.word_string()
    );
    println!(
        "    end: x {:.3} m, height {:.3} m, pitch {:.1} deg; impact losses {:.2} J",
        o.q_end[4],
        -o.q_end[5],
        o.q_end[6].to_degrees(),
        o.impact_loss_j
    );
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    // massless legs; `MASSIVE=1` for the legs of the description (with these simple
    // servo behaviours the body then rocks between its feet until the run ends Zeno)
    let massless = std::env::var("MASSIVE").is_err();
    for (name, behaviour, phi) in [("pronk", "pronk.toml", 0.0), ("bound", "bound.toml", 0.15)] {
        let s = scenario(behaviour, massless, 0.05, phi)?;
        let run = Simulation::new(&s)?.run()?;
        report(name, &run);
        if std::env::var("EVENTS").is_ok() {
            for (e, raw) in run.events().iter().zip(&run.execution.events) {
                let q: Vec<String> = raw.q.iter().map(|x| format!("{x:.3}")).collect();
                println!(
                    "    t {:.4} s  {:<9} {} -> {}  {:?}  loss {:.3} J  q [{}]",
                    e.t_s,
                    e.kind,
                    e.mode_before,
                    e.mode_after,
                    e.contacts,
                    e.energy_loss_j,
                    q.join(", ")
                );
            }
        }
        let mut md = BTreeMap::new();
        md.insert("example".into(), name.into());
        run.write_mcap(&out.join(format!("{name}.mcap")), 0.005, md)?;
    }
    Ok(())
}
