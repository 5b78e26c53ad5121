//! What a user's run costs, and where: runs scenario files (the JSON of
//! `selfmanip.simulation.scenario(...).to_dict()`, e.g. slow runs of
//! `scripts/user_robot_sweep.py`) and prints, per run, its status, events, segments (one per
//! reset, reported or not), accepted/rejected steps and restarts split by stance and flight
//! (`selfmanip_hybrid::integrate::work_counters`, with the linearly implicit steps on stiff
//! stretches and the switches to them), the CPU time of the run, and the segments
//! that took the most steps with their mode, duration and smallest and median step, and the
//! run's energy residual (`selfmanip_hybrid::energy_report`).
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin user_run_cost -- [--[no-]stiff-switch] \
//!     [--[no-]unresolved-flights] run471.json …
//! ```
//!
//! Each flag overrides the file's setting (`SimOptions::stiff_switch`,
//! `SimOptions::truncate_unresolved_flights`; both on by default).
use selfmanip_hybrid::integrate::{reset_work_counters, work_counters};
use selfmanip_sim::{Scenario, Simulation};
use std::path::Path;
use std::time::Instant;

fn main() {
    // `--stiff-switch` / `--no-stiff-switch` (and the same for `unresolved-flights`): the
    // runs with the option on / off; a file's own setting otherwise
    let flags = [
        ("--stiff-switch", "--no-stiff-switch"),
        ("--unresolved-flights", "--no-unresolved-flights"),
    ];
    let flag = |(on, off): (&str, &str)| {
        std::env::args().find_map(|a| {
            (a == on)
                .then_some(true)
                .or_else(|| (a == off).then_some(false))
        })
    };
    let (switch, unresolved) = (flag(flags[0]), flag(flags[1]));
    for path in std::env::args()
        .skip(1)
        .filter(|a| !flags.iter().any(|&(on, off)| a == on || a == off))
    {
        let mut s = Scenario::from_file(Path::new(&path)).unwrap_or_else(|e| panic!("{path}: {e}"));
        if let Some(b) = switch {
            s.options.stiff_switch = b;
        }
        if let Some(b) = unresolved {
            s.options.truncate_unresolved_flights = b;
        }
        let sim = Simulation::new(&s).unwrap_or_else(|e| panic!("{path}: {e}"));
        reset_work_counters();
        let t0 = Instant::now();
        let run = sim.run().unwrap_or_else(|e| panic!("{path}: {e}"));
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let w = work_counters();
        let exec = &run.execution;
        println!(
            "{path}: {:?} {ms:.1} ms; events {} segments {} steps {} accepted {:?} rejected {:?} \
             restarts {:?} rhs {:?} solves {:?} implicit {:?} switches {:?}",
            run.outcome.status,
            exec.events.len(),
            exec.segments.len(),
            exec.steps,
            w.accepted,
            w.rejected,
            w.restarts,
            w.rhs_calls,
            w.solves,
            w.implicit,
            w.switches
        );
        let mut kinds: std::collections::BTreeMap<String, usize> = Default::default();
        for e in &exec.events {
            *kinds.entry(format!("{:?}", e.kind)).or_default() += 1;
        }
        println!("  event kinds {kinds:?}");
        let mut segs: Vec<_> = exec.segments.iter().collect();
        segs.sort_by_key(|s| std::cmp::Reverse(s.dense.len()));
        // USER_RUN_COST_SEGMENTS=N: the N longest segments (6)
        let shown = std::env::var("USER_RUN_COST_SEGMENTS")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(6);
        for seg in segs.iter().take(shown) {
            let implicit = seg.dense.steps().filter(|st| st.implicit).count();
            let mut h: Vec<f64> = seg.dense.steps().map(|st| st.h).collect();
            h.sort_by(f64::total_cmp);
            if h.is_empty() {
                continue;
            }
            println!(
                "  segment t {:.6}..{:.6} mode {:?} steps {} (implicit {implicit}) h min {:.2e} \
                 median {:.2e} max {:.2e}",
                seg.t0,
                seg.t1,
                seg.mode,
                h.len(),
                h[0],
                h[h.len() / 2],
                h[h.len() - 1]
            );
        }
        if let Ok(er) = run.energy_report() {
            println!(
                "  energy residual {:.3e} J (friction work {:.3e} J)",
                er.residual_j(),
                er.friction_work_j
            );
        }
        // USER_RUN_COST_STEPS_AT=t: the step sizes of the segment that holds t
        if let Some(at) = std::env::var("USER_RUN_COST_STEPS_AT")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
        {
            for seg in exec.segments.iter().filter(|s| s.t0 <= at && at < s.t1) {
                let h: Vec<String> = seg
                    .dense
                    .steps()
                    .map(|st| format!("{:.2e}{}", st.h, if st.implicit { "i" } else { "" }))
                    .collect();
                println!("  steps of the segment at {at}: {}", h.join(" "));
            }
        }
        // USER_RUN_COST_EVENTS=1: every event (time, kind, modes, contacts, energy lost) and
        // the termination
        if std::env::var("USER_RUN_COST_EVENTS").is_ok() {
            for e in &exec.events {
                println!(
                    "  {:.7} {:?} {:?} -> {:?} {:?} lost {:.3e} J",
                    e.t,
                    e.kind,
                    e.mode_before,
                    e.mode_after,
                    e.triggered,
                    e.kinetic_before - e.kinetic_after
                );
            }
            println!("  termination {:?}", exec.termination);
        }
        let short = exec.segments.iter().filter(|s| s.dense.len() <= 1).count();
        println!("  segments of at most one step: {short}");
    }
}
