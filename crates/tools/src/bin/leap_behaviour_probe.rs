//! `leap_probe`'s leaps through the behaviour interpreter: the shipped behaviour files
//! (`data/behaviours/leap_*.toml`) run as scenarios of `selfmanip-sim`.
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin leap_behaviour_probe -- "++,-+" -0.1,0,0.1
//! ```
//! Arguments: strategies (comma-separated), t2 values in seconds. The start pose is the leap
//! controller's (a leap stopped at once); the robot and options are `LeapConfig::default()`'s.
use rhex_model::leap::leap_scenario;
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig};
use selfmanip_sim::Simulation;
use selfmanip_tools::print_leap_line;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let strategies = args.get(1).map_or("++", String::as_str);
    let t2s = args.get(2).map_or("0", String::as_str);
    let params = leap_params();
    for strategy in strategies.split(',') {
        // the start pose depends on the strategy, not on t2
        let start = LeapConfig {
            strategy: strategy.parse()?,
            t_final_s: 1e-4,
            ..LeapConfig::default()
        };
        let q0 = simulate_leap(&params, &start)?.run.q0;
        for t2 in t2s.split(',') {
            let cfg = LeapConfig {
                t2_s: t2.parse()?,
                ..start.clone()
            };
            let cfg = LeapConfig {
                t_final_s: LeapConfig::default().t_final_s,
                ..cfg
            };
            let ls = leap_scenario(&params, &cfg, &q0)?;
            let run = Simulation::new(&ls.scenario)?.run()?;
            let o = &run.outcome;
            print_leap_line(
                strategy,
                cfg.t2_s,
                o.status.as_str(),
                &o.word_string(),
                o.apex.map(|a| [a.x_m - q0[2], -a.z_m, a.phi_rad]),
            );
        }
    }
    Ok(())
}
