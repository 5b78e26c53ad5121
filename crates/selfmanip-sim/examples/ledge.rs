//! A one-legged hopper hopping forward up a ledge: the hopper and its behaviour
//! (`data/hopper.toml`, `data/hop_up.toml`: the leg tucks up in the air and lands ahead of
//! the hip), a forward start speed, and a step 4 cm up ahead (a terrain with a face, an
//! edge and a top); logged to MCAP.
//!
//! ```sh
//! cargo run --release -p selfmanip-sim --example ledge -- [ledge.mcap]
//! SET="lean=0.08,terrain.height_m=0.06" cargo run …   # parameters by name
//! ```
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::terrain::TerrainSpec;
use selfmanip_sim::{Scenario, Simulation};
use std::collections::BTreeMap;

mod common;
use common::{data, dropped_hopper, set_from_env};

/// The hopper dropped 5 cm at `speed` forward, towards a ledge `height_m` high whose face is
/// `distance_m` ahead.
pub fn scenario(
    speed: f64,
    height_m: f64,
    distance_m: f64,
) -> Result<Scenario, Box<dyn std::error::Error>> {
    let mut s = dropped_hopper(0.05)?;
    s.initial.qd = Some(vec![0.0, 0.0, speed, 0.0, 0.0]);
    s.behaviour = Behaviour::from_file(&data("hop_up.toml"))?;
    s.terrain = TerrainSpec::Ledge {
        height_m,
        distance_m,
    };
    s.options.t_final_s = 2.0;
    set_from_env(&mut s)?;
    Ok(s)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "ledge.mcap".into());
    let s = scenario(0.6, 0.04, 0.55)?;
    let run = Simulation::new(&s)?.run()?;
    let o = &run.outcome;
    println!(
        "status {} after {:.2} s, word {}",
        o.status.as_str(),
        o.t_end_s,
        o.word_string()
    );
    for (e, raw) in run.events().iter().zip(&run.execution.events) {
        println!(
            "  t {:.4} s  {:<9} {} -> {}  foot x {:.3} m",
            e.t_s,
            e.kind,
            e.mode_before,
            e.mode_after,
            raw.q[2]
                + 0.2 * (raw.q[0] + raw.q[4]).sin()
                + 0.2 * (raw.q[0] + raw.q[1] + raw.q[4]).sin()
        );
    }
    let x = o.q_end[2];
    let top = s.terrain.height_at(x);
    println!(
        "end: body x {x:.3} m over ground {top:.3} m high, body {:.3} m above it",
        -o.q_end[3] - top
    );
    let mut md = BTreeMap::new();
    md.insert("example".into(), "ledge".into());
    run.write_mcap(std::path::Path::new(&out), 0.005, md)?;
    println!("wrote {out}");
    Ok(())
}
