//! The engine's behaviour corpus: 2,016 leap setups, each run twice — stopped at the apex
//! (its apex state) and continued past it to its landings until 1 s — (four strategies × 21 values of t2 in [−0.2, 0.2] s × flat ground and ledges ahead and
//! behind × saturated torque and the geared motor × four robot variants), one JSON line
//! each with the status, word, every event (time, kind, modes, contacts) and the end state,
//! floats as exact bit patterns. A refactoring of the engine must leave this output
//! unchanged; `scripts/engine-corpus.sh` runs it and compares two outputs.
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin engine_corpus > corpus.jsonl
//! ```
use rayon::prelude::*;
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LegActuator, Strategy, X_RHEX_LEG};
use rhex_model::params::{LegShape, RhexParams};
use selfmanip_sim::terrain::TerrainSpec;
use serde_json::json;
use std::time::Instant;

/// One robot variant: a name and its parameters.
fn variants() -> Vec<(&'static str, RhexParams)> {
    let base = leap_params();
    vec![
        ("half_circle", base.clone()),
        (
            "stick",
            RhexParams {
                leg_shape: LegShape::Stick,
                ..base.clone()
            },
        ),
        (
            "massive_legs",
            // a massive leg's toe slides without friction (the variant as it was when Coulomb
            // sliding needed massless legs, kept so that corpora stay comparable; massive
            // legs with Coulomb toes: docs/leap-model.md)
            RhexParams {
                toe_sliding: rhex_model::params::ToeSliding::Frictionless,
                ..base.clone().with_table_4_2_legs()
            },
        ),
        (
            "heavy_body",
            RhexParams {
                m_b: base.m_b * 1.3,
                I_b: base.I_b * 1.3,
                ..base
            },
        ),
    ]
}

fn bits(x: f64) -> String {
    format!("{:016x}", x.to_bits())
}

fn main() {
    let t2s: Vec<f64> = (0..21).map(|i| -0.2 + 0.02 * i as f64).collect();
    let terrains = [
        ("flat", TerrainSpec::Flat),
        (
            "ledge_ahead",
            TerrainSpec::Ledge {
                height_m: 0.2,
                distance_m: 0.45,
            },
        ),
        (
            "ledge_behind",
            TerrainSpec::Ledge {
                height_m: 0.2,
                distance_m: -0.45,
            },
        ),
    ];
    let actuators = [
        ("saturated", LegActuator::SaturatedTorque),
        ("geared", X_RHEX_LEG.actuator()),
    ];
    let variants = variants();
    let mut cases = Vec::new();
    for (vname, params) in &variants {
        for (aname, actuator) in &actuators {
            for (tname, terrain) in &terrains {
                for strategy in Strategy::ALL {
                    for &t2 in &t2s {
                        for stop_at_apex in [true, false] {
                            cases.push((
                                *vname,
                                params,
                                *aname,
                                actuator,
                                *tname,
                                terrain,
                                strategy,
                                t2,
                                stop_at_apex,
                            ));
                        }
                    }
                }
            }
        }
    }
    let lines: Vec<(String, f64)> = cases
        .par_iter()
        .with_max_len(1)
        .map(
            |&(vname, params, aname, actuator, tname, terrain, strategy, t2, stop_at_apex)| {
                let cfg = LeapConfig {
                    strategy,
                    t2_s: t2,
                    actuator: actuator.clone(),
                    terrain: *terrain,
                    stop_at_apex,
                    t_final_s: 1.0,
                    ..LeapConfig::default()
                };
                let start = Instant::now();
                let r = simulate_leap(params, &cfg);
                let secs = start.elapsed().as_secs_f64();
                let mut line = json!({
                    "variant": vname,
                    "actuator": aname,
                    "terrain": tname,
                    "strategy": strategy.to_string(),
                    "t2": format!("{t2:.3}"),
                    "stop_at_apex": stop_at_apex,
                });
                let fields = match r {
                    Err(e) => json!({ "error": e.to_string() }),
                    Ok(r) => {
                        let ex = &r.execution;
                        let events: Vec<_> = r
                            .events
                            .iter()
                            .zip(&ex.events)
                            .map(|(e, raw)| {
                                json!([
                                    bits(raw.t),
                                    e.kind,
                                    e.mode_before,
                                    e.mode_after,
                                    e.contacts,
                                    bits(raw.kinetic_before),
                                    bits(raw.kinetic_after)
                                ])
                            })
                            .collect();
                        let apex = r.apex.map(|a| a.to_array().map(bits));
                        json!({
                            "status": r.status.as_str(),
                            "word": r.word_string(),
                            "termination": format!("{:?}", ex.termination),
                            "t_end": bits(ex.t),
                            "q": ex.q.iter().map(|&x| bits(x)).collect::<Vec<_>>(),
                            "qd": ex.qd.iter().map(|&x| bits(x)).collect::<Vec<_>>(),
                            "events": events,
                            "apex": apex,
                            "segments": ex.segments.len(),
                        })
                    }
                };
                line.as_object_mut()
                    .expect("an object")
                    .extend(fields.as_object().expect("an object").clone());
                let s = line.to_string();
                (s, secs)
            },
        )
        .collect();
    let mut slowest = (0.0, String::new());
    let mut total = 0.0;
    for (line, secs) in &lines {
        println!("{line}");
        total += secs;
        if *secs > slowest.0 {
            slowest = (*secs, line.chars().take(120).collect());
        }
    }
    eprintln!(
        "{} runs, {:.1} s of run time, slowest {:.3} s: {}",
        lines.len(),
        total,
        slowest.0,
        slowest.1
    );
}
