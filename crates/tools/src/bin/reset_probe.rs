//! The cost of the resets on robots with many contacts: runs scenario files (the JSON of
//! `selfmanip.simulation.scenario(...).to_dict()`, e.g. slow runs of
//! `scripts/user_robot_sweep.py`) one after the other and prints, per run, its status,
//! word, event and step counts and a digest of every event's time, modes, velocity after,
//! impulse and forces and of the end state (exact bits), so that two builds can be compared
//! run by run. Run it under `valgrind --tool=callgrind` for instruction counts.
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin reset_probe -- [--t-final S] run471.json …
//! ```
use selfmanip_sim::{Scenario, Simulation};
use std::hash::{Hash, Hasher};
use std::path::Path;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut t_final_s = None;
    if let Some(i) = args.iter().position(|a| a == "--t-final") {
        let v = args.get(i + 1).expect("--t-final needs seconds");
        t_final_s = Some(v.parse::<f64>().expect("--t-final: seconds"));
        args.drain(i..i + 2);
    }
    for path in &args {
        let mut s = Scenario::from_file(Path::new(path)).unwrap_or_else(|e| panic!("{path}: {e}"));
        if let Some(t) = t_final_s {
            s.options.t_final_s = t;
        }
        let run = Simulation::new(&s)
            .and_then(|sim| sim.run())
            .unwrap_or_else(|e| panic!("{path}: {e}"));
        let exec = &run.execution;
        let mut h = std::collections::hash_map::DefaultHasher::new();
        for e in &exec.events {
            e.t.to_bits().hash(&mut h);
            format!("{:?}{:?}", e.mode_before, e.mode_after).hash(&mut h);
            for v in e.qd_after.iter().chain(&e.impulse).chain(&e.force) {
                v.to_bits().hash(&mut h);
            }
        }
        for v in exec.q.iter().chain(&exec.qd) {
            v.to_bits().hash(&mut h);
        }
        println!(
            "{path}: {:?} word {} events {} steps {} t_end {:016x} digest {:016x}",
            run.outcome.status,
            run.outcome.word_string(),
            exec.events.len(),
            exec.steps,
            exec.t.to_bits(),
            h.finish()
        );
    }
}
