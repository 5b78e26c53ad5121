//! The same leaps through the leap controller and through the shipped behaviour files (the
//! interpreter of `selfmanip-sim`), for instruction counts that load on the machine does
//! not disturb:
//!
//! ```sh
//! cargo build --release -p selfmanip-tools --bin leap_paths
//! valgrind --tool=callgrind target/release/leap_paths controller
//! valgrind --tool=callgrind target/release/leap_paths behaviour
//! valgrind --tool=callgrind target/release/leap_paths start
//! ```
//!
//! The behaviour path needs each leap's start pose, which the controller path computes
//! inside `simulate_leap`; here it comes from the same leap stopped at once, and `start`
//! counts that alone, to subtract.
//!
//! Each runs the four strategies at t2 ∈ {−0.1, −0.02, 0, 0.02, 0.1} s from rest to apex
//! (`behaviour` builds each scenario and its `Simulation` per leap, as the controller path
//! builds its robot and start pose per leap) and prints one line per leap (status, word,
//! apex height) so that the two paths can be compared.
use rhex_model::leap::leap_scenario;
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, Strategy};
use rhex_model::params::RhexParams;
use selfmanip_sim::Simulation;

/// The start pose of a leap: that of the same leap stopped before any leg moves.
fn start_pose(params: &RhexParams, cfg: &LeapConfig) -> Result<Vec<f64>, rhex_model::RhexError> {
    let short = LeapConfig {
        t_final_s: cfg.t2_s.abs() + 1e-9,
        ..cfg.clone()
    };
    Ok(simulate_leap(params, &short)?.q0)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "controller".into());
    let params = leap_params();
    for s in ["++", "+-", "-+", "--"] {
        for t2 in [-0.1, -0.02, 0.0, 0.02, 0.1] {
            let cfg = LeapConfig {
                strategy: s.parse::<Strategy>()?,
                t2_s: t2,
                ..LeapConfig::default()
            };
            match path.as_str() {
                "controller" => {
                    let r = simulate_leap(&params, &cfg)?;
                    println!(
                        "{s} {t2:+.2} {} {:?}",
                        r.word_string(),
                        r.apex.map(|a| a.z_m)
                    );
                }
                "start" => {
                    let q0 = start_pose(&params, &cfg)?;
                    println!("{s} {t2:+.2} {q0:?}");
                }
                "behaviour" => {
                    let q0 = start_pose(&params, &cfg)?;
                    let ls = leap_scenario(&params, &cfg, &q0)?;
                    let run = Simulation::new(&ls.scenario)?.run()?;
                    println!(
                        "{s} {t2:+.2} {} {:?}",
                        run.outcome.word_string(),
                        // the leap reports heights z-up, the scenario NED z (down)
                        run.outcome.apex.map(|a| -a.z_m)
                    );
                }
                other => return Err(format!("unknown path {other:?}").into()),
            }
        }
    }
    Ok(())
}
