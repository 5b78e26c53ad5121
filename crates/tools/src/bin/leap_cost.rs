//! What a leap's cost is made of: accepted and rejected steps, integrator restarts, flow
//! evaluations and dynamics solves, split into stance (a mode with a contact) and flight (no
//! contact), and the events, for the default massless legs or legs with mass.
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin leap_cost -- "++,--" 0,-0.02
//! M_L=0.126 cargo run --release -p selfmanip-tools --bin leap_cost -- "++" 0   # massive legs
//! SWEEP=1 M_L=0.126 cargo run --release -p selfmanip-tools --bin leap_cost     # 4 × 41 sweeps
//! ```
//! The sweep runs one [`LeapPreset`] per strategy, its points bound to the simulation the
//! preset built (`LeapPreset::run_at`) and without event records, as a leap sweep does.
//! `M_L` (kg) gives the legs that mass and Table 4.2's inertia scaled with it (their joints
//! carry their rotors' `n J G²`, as every massive leg does); `GEAR`, `M_B` (kg) and `I_B`
//! (kg m²) change the gear ratio and the body's mass and inertia; `SEGS=1` lists each leap's
//! segments with their accepted steps (`STEPS=1` every tenth step's size, `TORQUE=1` the
//! controller's torques along them); `RTOL` sets the leap's tolerance. With `SWEEP` the
//! counts are summed over the four 41-point sweeps `t2 = −0.2 … 0.2` s and the wall time of
//! the whole sweep is printed (the machine's load shows in it).
//!
//! What it showed (main 74e1521, the four 41-point sweeps, per leap): the massless default
//! takes 98 accepted steps (82 stance, 16 flight), legs with Table 4.2's mass and their
//! rotors 498 (314, 183), with few rejections (28 per leap, 5 %), one dynamics solve per
//! right-hand side call (and a few for the guards and segment starts: no factorization is
//! repeated), and as many events (6). The steps are accuracy-limited, not
//! stability-limited: their number scales as `rtol^(−1/5)` (rtol 1e-7: 324), the error
//! norm is led by the legs' velocities, and the flow's Jacobian has the legs' servo poles at
//! −205 … −232 /s (the critically damped 217 rad/s servo) wherever the servo is in its
//! linear range — steps of 0.4–0.6 ms there (h λ ≈ 0.1, far inside DOPRI5's stability
//! region), 2–4 ms where it saturates or the motor's own law drives the leg. Every event,
//! motor start and takeoff excites the servo's transient, which decays as `(1 + λt) e^{−λt}`
//! and is resolved to the tolerance for about 0.1 s: with the legs' own swings to their
//! park, that is where the flight's steps go.
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LeapPreset, Strategy, X_RHEX_LEG};
use selfmanip_hybrid::budget::NEVER;
use selfmanip_hybrid::integrate::{reset_work_counters, work_counters, WorkCounters};
use selfmanip_tools::{body_from_env, print_segment_line};
use std::collections::BTreeMap;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let mut params = leap_params();
    if let Ok(v) = std::env::var("M_L") {
        params.m_l = v.parse()?;
        params.I_l = 0.00092 * params.m_l / 0.126;
    }
    body_from_env(&mut params)?;
    let actuator = match std::env::var("GEAR") {
        Ok(g) => X_RHEX_LEG.at_gear_ratio(g.parse()?),
        Err(_) => X_RHEX_LEG.actuator(),
    };
    let cfg = LeapConfig {
        actuator,
        rtol: std::env::var("RTOL").map_or(Ok(LeapConfig::default().rtol), |v| v.parse())?,
        ..LeapConfig::default()
    };
    if std::env::var("SWEEP").is_ok() {
        let mut total = WorkCounters::default();
        let mut events = 0usize;
        // by mode (normal bits): segments, accepted steps, time spent
        let mut by_mode = BTreeMap::<u32, (usize, usize, f64)>::new();
        let mut statuses = BTreeMap::<String, usize>::new();
        let clock = std::time::Instant::now();
        // one preset per strategy, its 41 points bound to the simulation it built
        for strategy in Strategy::ALL {
            let preset = LeapPreset::new(
                &params,
                &LeapConfig {
                    strategy,
                    ..cfg.clone()
                },
            )?
            .without_event_records();
            for k in 0..41 {
                reset_work_counters();
                let r = preset.run_at(-0.2 + 0.01 * f64::from(k), &cfg.actuator, &NEVER)?;
                let w = work_counters();
                for p in 0..2 {
                    total.accepted[p] += w.accepted[p];
                    total.rejected[p] += w.rejected[p];
                    total.restarts[p] += w.restarts[p];
                    total.rhs_calls[p] += w.rhs_calls[p];
                    total.solves[p] += w.solves[p];
                }
                events += r.execution.events.len();
                for sg in &r.execution.segments {
                    let e = by_mode.entry(sg.mode.normal_bits()).or_insert((0, 0, 0.0));
                    e.0 += 1;
                    e.1 += sg.dense.len();
                    e.2 += sg.t1 - sg.t0;
                }
                *statuses.entry(r.status.as_str().to_string()).or_default() += 1;
            }
        }
        let ms = 1e3 * clock.elapsed().as_secs_f64();
        println!("164 leaps in {ms:.1} ms ({:.3} ms per leap)", ms / 164.0);
        println!("statuses {statuses:?}; events {events}");
        print_counters(&total, 164.0);
        println!("  by mode (normal bits): segments, accepted steps, simulated time, mean step");
        for (m, (n, steps, dt)) in &by_mode {
            println!(
                "    {m:>8b}: {n:>4} segments {steps:>7} steps {dt:>8.3} s  {:.2e} s",
                dt / (*steps).max(1) as f64
            );
        }
        return Ok(());
    }
    let strategies = args.get(1).map_or("++", String::as_str);
    let t2s = args.get(2).map_or("0", String::as_str);
    for strategy in strategies.split(',') {
        for t2 in t2s.split(',') {
            let c = LeapConfig {
                strategy: strategy.parse()?,
                t2_s: t2.parse()?,
                ..cfg.clone()
            };
            reset_work_counters();
            let clock = std::time::Instant::now();
            let r = simulate_leap(&params, &c)?;
            let ms = 1e3 * clock.elapsed().as_secs_f64();
            let w = work_counters();
            print!(
                "{strategy} t2={:+.3} s  {}  {ms:.3} ms  word {}",
                c.t2_s,
                r.status.as_str(),
                r.word_string()
            );
            if let Some(a) = r.apex {
                print!(
                    "  apex z {:.7} m, pitch {:.5} deg",
                    a.z_m,
                    a.phi_rad.to_degrees()
                );
            }
            println!();
            let mut kinds = BTreeMap::<String, usize>::new();
            for e in &r.execution.events {
                *kinds.entry(format!("{:?}", e.kind)).or_default() += 1;
            }
            println!("  events {} {kinds:?}", r.execution.events.len());
            print_counters(&w, 1.0);
            if std::env::var("SEGS").is_ok() {
                for sg in &r.execution.segments {
                    print_segment_line("    ", sg);
                    if std::env::var("TORQUE").is_ok() {
                        // the controller's torques and the legs' angles along the segment
                        let n = sg.y0.len() / 2;
                        let mut y = vec![0.0; 2 * n];
                        let mut tau = vec![0.0; 2];
                        for v in sg.dense.steps().step_by(5) {
                            v.eval(v.t0, &mut y);
                            sg.controller
                                .torque(v.t0, &y[..n], &y[n..], sg.mode, &mut tau);
                            println!(
                                "      t {:.5} h {:.1e} q_leg {:+.5} {:+.5} qd_leg {:+.3} {:+.3} tau {:+.4} {:+.4}",
                                v.t0, v.h, y[0], y[1], y[n], y[n + 1], tau[0], tau[1]
                            );
                        }
                    }
                    if std::env::var("STEPS").is_ok() {
                        // every tenth step's start and size
                        let hs: Vec<String> = sg
                            .dense
                            .steps()
                            .step_by(10)
                            .map(|v| format!("{:.4}:{:.1e}", v.t0, v.h))
                            .collect();
                        println!("      {}", hs.join(" "));
                    }
                }
            }
        }
    }
    Ok(())
}

/// The counters by phase, divided by `per` (leaps).
fn print_counters(w: &WorkCounters, per: f64) {
    for (p, name) in ["stance", "flight"].iter().enumerate() {
        println!(
            "  {name:<6}: accepted {:>8.1}  rejected {:>7.1}  restarts {:>6.1}  rhs {:>8.1}  solves {:>8.1}",
            w.accepted[p] as f64 / per,
            w.rejected[p] as f64 / per,
            w.restarts[p] as f64 / per,
            w.rhs_calls[p] as f64 / per,
            w.solves[p] as f64 / per,
        );
    }
}
