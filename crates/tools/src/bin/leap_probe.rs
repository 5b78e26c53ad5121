//! One leap per strategy and coordination time, printed with its word, apex and events.
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin leap_probe -- "++,-+" -0.1,0,0.1 0.03
//! ```
//! Arguments: strategies (comma-separated), t2 values in seconds, δt of the pseudo-impulse.
//! Set `EVENTS=1` to list every event (and `SEGS=1` every segment with its steps), `PAIRS=front,rear` to choose the pushing pairs,
//! `SATURATED=1` for chapter 3's saturated-torque legs instead of the geared motors, `GEAR` and
//! `CURRENT` (A) to change the geared motor's ratio and current limit, `M_B` (kg) and `I_B`
//! (kg m²) to change the body's mass and inertia, `LEDGE=height,distance` (m) for a ledge,
//! `QD=1` (with `EVENTS`) to print each event's q and q̇ after it, `LANDINGS=1` to run past the apex to `t_final`, `EVENT_TOL` (s) and `RTOL` the tolerances.
use rhex_model::leap::{
    leap_params, simulate_leap, GearedMotor, LeapConfig, LegActuator, X_RHEX_LEG,
};
use rhex_model::params::LegPair;
use selfmanip_tools::{body_from_env, print_leap_line, print_segment_line};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let strategies = args.get(1).map_or("++", String::as_str);
    let t2s = args.get(2).map_or("0", String::as_str);
    let delta_t_s: f64 = args.get(3).map_or(Ok(0.03), |s| s.parse())?;
    let pairs = match std::env::var("PAIRS").ok().as_deref() {
        None => None,
        Some(s) => {
            let p: Vec<LegPair> = s
                .split(',')
                .map(|n| match n {
                    "front" => Ok(LegPair::Front),
                    "middle" => Ok(LegPair::Middle),
                    "rear" => Ok(LegPair::Rear),
                    other => Err(format!("PAIRS: unknown pair `{other}`")),
                })
                .collect::<Result<_, _>>()?;
            Some([p[0], p[1]])
        }
    };
    for strategy in strategies.split(',') {
        for t2 in t2s.split(',') {
            let cfg = LeapConfig {
                strategy: strategy.parse()?,
                t2_s: t2.parse()?,
                delta_t_s,
                pairs,
                actuator: if std::env::var("SATURATED").is_ok() {
                    LegActuator::SaturatedTorque
                } else {
                    geared_from_env()?
                },
                terrain: match std::env::var("LEDGE").ok() {
                    None => selfmanip_sim::terrain::TerrainSpec::Flat,
                    Some(s) => {
                        let v: Vec<f64> = s.split(',').map(str::parse).collect::<Result<_, _>>()?;
                        selfmanip_sim::terrain::TerrainSpec::Ledge {
                            height_m: v[0],
                            distance_m: v[1],
                        }
                    }
                },
                stop_at_apex: std::env::var("LANDINGS").is_err(),
                event_tol_s: std::env::var("EVENT_TOL").map_or(Ok(1e-10), |v| v.parse())?,
                rtol: std::env::var("RTOL").map_or(Ok(1e-8), |v| v.parse())?,
                // CONTROL=1: every coordinate in the step-size control
                control_free_joints: std::env::var("CONTROL").is_ok(),
                ..LeapConfig::default()
            };
            let mut params = leap_params();
            body_from_env(&mut params)?;
            let r = simulate_leap(&params, &cfg)?;
            print_leap_line(
                strategy,
                cfg.t2_s,
                r.status.as_str(),
                &r.word_string(),
                r.apex.map(|a| [a.x_m, a.z_m, a.phi_rad]),
            );
            if std::env::var("EVENTS").is_ok() {
                println!(
                    "    termination {:?}, {} steps, {} segments",
                    r.execution.termination,
                    r.execution.steps,
                    r.execution.segments.len()
                );
                if std::env::var("SEGS").is_ok() {
                    for sg in &r.execution.segments {
                        print_segment_line("      ", sg);
                    }
                }
                if std::env::var("QD").is_ok() {
                    for e in &r.execution.events {
                        println!(
                            "    t {:.5} s  {:?}: q {:.4?}, q̇ after {:.4?}",
                            e.t, e.kind, e.q, e.qd_after
                        );
                    }
                }
                for e in &r.events {
                    println!(
                        "    t {:.5} s  {:<9} {} -> {}  {:?}  loss {:.3} J",
                        e.t_s, e.kind, e.mode_before, e.mode_after, e.contacts, e.energy_loss_j
                    );
                }
            }
        }
    }
    Ok(())
}

/// The default geared motor, with `GEAR` (gear ratio) and `CURRENT` (A) from the environment.
fn geared_from_env() -> Result<LegActuator, Box<dyn std::error::Error>> {
    let mut a = X_RHEX_LEG.actuator();
    let LegActuator::GearedMotor(GearedMotor {
        gear_ratio,
        current_limit_a,
        ..
    }) = &mut a
    else {
        unreachable!("the default actuator is geared")
    };
    if let Ok(g) = std::env::var("GEAR") {
        *gear_ratio = g.parse()?;
    }
    if let Ok(i) = std::env::var("CURRENT") {
        *current_limit_a = i.parse()?;
    }
    Ok(a)
}
