//! A digest of user runs' results, bit for bit: per scenario file (the JSON of
//! `selfmanip.simulation.scenario(...).to_dict()`), the status, steps, events, the final
//! state and a hash of every event and the final state as printed (`{:?}` of an `f64` is
//! its shortest round-trip form, so the hash changes with any bit). A change meant to be a
//! pure speed-up leaves every line as it was.
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin user_run_bits -- [--stiff-switch] run178.json …
//! ```
//!
//! `--stiff-switch`: the runs with the stiff switch on (`SimOptions::stiff_switch`; a file's
//! own setting otherwise).
use selfmanip_sim::{Scenario, Simulation};
use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::path::Path;

fn main() {
    let flag = "--stiff-switch";
    let stiff = std::env::args().any(|a| a == flag);
    for path in std::env::args().skip(1).filter(|a| a != flag) {
        let mut s = Scenario::from_file(Path::new(&path)).unwrap_or_else(|e| panic!("{path}: {e}"));
        if stiff {
            s.options.stiff_switch = true;
        }
        let sim = Simulation::new(&s).unwrap_or_else(|e| panic!("{path}: {e}"));
        let run = sim.run().unwrap_or_else(|e| panic!("{path}: {e}"));
        let exec = &run.execution;
        let mut h = DefaultHasher::new();
        format!("{:?}", exec.events).hash(&mut h);
        format!("{:?} {:?} {:?}", exec.t, exec.q, exec.qd).hash(&mut h);
        println!(
            "{path}: {:?} steps {} events {} t {:?} digest {:016x}",
            run.outcome.status,
            exec.steps,
            exec.events.len(),
            exec.t,
            h.finish()
        );
    }
}
