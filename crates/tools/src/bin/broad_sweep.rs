//! The sweeps of issue 16, reproducibly: the 41-point `t2` sweeps over [−0.2, 0.2] s in every
//! strategy with chapter 3's saturated-torque legs and with the default geared motor, and a
//! broad random sweep of 2,000 points (seeded: four strategies, `t2 ∈ [−0.3, 0.3]` s, gear
//! ratio `G ∈ [5, 60]`, body mass and inertia each scaled by a factor in [0.5, 1.5]).
//! Prints, per sweep, the status counts, the share that reached an apex, and the median and
//! slowest wall time of one leap (each leap timed on its own thread; the machine's load
//! shows in these times).
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin broad_sweep            # all sweeps
//! cargo run --release -p selfmanip-tools --bin broad_sweep -- 500     # a 500-point broad sweep
//! SHOW=zeno cargo run --release -p selfmanip-tools --bin broad_sweep  # and its zeno points
//! M_L=0.126 cargo run --release -p selfmanip-tools --bin broad_sweep   # with massive legs
//! ROTORS=1 cargo run --release -p selfmanip-tools --bin broad_sweep    # massless links that
//!                                                       # carry their motors' rotors, n J G²
//! ```
//! The `zeno` points are also counted by kind (`zeno by kind`: a two-mode cycle of one
//! contact, or events that change no mode; `docs/leap-model.md` says what they are).
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use rhex_model::leap::{leap_params, LeapConfig, LegActuator, Strategy, X_RHEX_LEG};
use rhex_model::sweep::{run_row, LeapPoint, LeapSweep, SweepRow};
use selfmanip_hybrid::budget::NEVER;
use serde_json::{json, Map};
use std::collections::BTreeMap;
use std::time::Instant;

/// The broad sweep's points (seed 16).
fn broad_points(n: usize) -> Vec<LeapPoint> {
    let base = leap_params();
    let mut rng = ChaCha8Rng::seed_from_u64(16);
    (0..n)
        .map(|_| {
            let strategy = Strategy::ALL[rng.gen_range(0..4)];
            let t2 = rng.gen_range(-0.3..0.3);
            let gear = rng.gen_range(5.0..60.0);
            let mut overrides = Map::new();
            overrides.insert("m_b".into(), json!(base.m_b * rng.gen_range(0.5..1.5)));
            overrides.insert("I_b".into(), json!(base.I_b * rng.gen_range(0.5..1.5)));
            if let Some(m_l) = std::env::var("M_L")
                .ok()
                .and_then(|v| v.parse::<f64>().ok())
            {
                // massive legs (Table 4.2's pair: 0.126 kg, 0.00092 kg m²), toes as given
                overrides.insert("m_l".into(), json!(m_l));
                overrides.insert("I_l".into(), json!(0.00092 * m_l / 0.126));
            }
            rotors(&mut overrides);
            LeapPoint {
                strategy,
                t2_s: t2,
                gear_ratio: Some(gear),
                overrides,
            }
        })
        .collect()
}

/// With `ROTORS` set, every leg carries its motors' rotors as joint armature
/// (`RhexParams::leg_rotors`: `n J G²` of each point's actuator) whatever its mass: the rotor
/// inertia the massless model's swing already uses, in the dynamics.
fn rotors(overrides: &mut Map<String, serde_json::Value>) {
    if std::env::var("ROTORS").is_ok() {
        overrides.insert("leg_rotors".into(), json!(true));
    }
}

/// Runs `points` on a pool of two threads, each leap timed; rows and times in input order.
fn run(cfg: &LeapConfig, points: &[LeapPoint]) -> Vec<(SweepRow, f64)> {
    let preset = LeapSweep::new(&leap_params(), cfg);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("a pool of two threads");
    pool.install(|| {
        points
            .par_iter()
            .with_max_len(1)
            .map(|p| {
                let t0 = Instant::now();
                let row = run_row(&preset, p, &NEVER);
                (row, t0.elapsed().as_secs_f64())
            })
            .collect()
    })
}

fn describe(p: &LeapPoint) -> String {
    let mut s = format!("{} t2={:+.4}", p.strategy, p.t2_s);
    if let Some(g) = p.gear_ratio {
        s += &format!(" G={g:.2}");
    }
    for (k, v) in &p.overrides {
        s += &format!(" {k}={v}");
    }
    s
}

/// The kind of a `zeno` point, from its word (the modes it ran through): `cycle A↔B` when
/// its last eight modes alternate between two (a touchdown–liftoff or stick–slip cycle of one
/// contact), else `null events` (the run ended on events that changed no mode: a contact
/// touching down again and again at one instant).
fn zeno_kind(word: &str) -> String {
    let modes: Vec<&str> = word.split('-').collect();
    let tail = &modes[modes.len().saturating_sub(8)..];
    let mut distinct: Vec<&str> = tail.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    if modes.len() >= 8 && distinct.len() == 2 {
        format!("cycle {}<->{}", distinct[0], distinct[1])
    } else {
        "null events".to_string()
    }
}

fn report(name: &str, points: &[LeapPoint], out: &[(SweepRow, f64)]) {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for (r, _) in out {
        *counts.entry(r.status.as_str()).or_default() += 1;
    }
    let n = out.len();
    let apex = out.iter().filter(|(r, _)| r.apex.is_some()).count();
    let mut times: Vec<f64> = out.iter().map(|o| o.1).collect();
    times.sort_by(f64::total_cmp);
    let (slow_i, slow) = out
        .iter()
        .enumerate()
        .max_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
        .map(|(i, o)| (i, o.1))
        .unwrap_or((0, 0.0));
    let counts: Vec<String> = counts.iter().map(|(k, v)| format!("{k} {v}")).collect();
    println!(
        "{name}: {n} leaps, apex {apex} ({:.1} %); {}",
        100.0 * apex as f64 / n.max(1) as f64,
        counts.join(", ")
    );
    if n > 0 {
        println!(
            "    leap time median {:.2} ms, slowest {:.2} ms ({}, {}), total {:.2} s",
            1e3 * times[n / 2],
            1e3 * slow,
            describe(&points[slow_i]),
            out[slow_i].0.status,
            times.iter().sum::<f64>()
        );
    }
}

fn main() {
    let n_broad: usize = std::env::args().nth(1).map_or(2000, |s| {
        s.parse().expect("the number of broad-sweep points")
    });
    let t2: Vec<f64> = (0..41).map(|i| -0.2 + 0.01 * i as f64).collect();
    for (aname, actuator) in [
        ("saturated torque", LegActuator::SaturatedTorque),
        ("geared motor (default)", X_RHEX_LEG.actuator()),
    ] {
        let cfg = LeapConfig {
            actuator,
            ..LeapConfig::default()
        };
        for s in Strategy::ALL {
            let points: Vec<LeapPoint> = t2
                .iter()
                .map(|&t| {
                    let mut p = LeapPoint::new(s, t, None);
                    rotors(&mut p.overrides);
                    p
                })
                .collect();
            let out = run(&cfg, &points);
            report(&format!("t2 sweep {s}, {aname}"), &points, &out);
        }
    }
    if n_broad > 0 {
        let points = broad_points(n_broad);
        let t0 = Instant::now();
        let out = run(&LeapConfig::default(), &points);
        let wall = t0.elapsed().as_secs_f64();
        report("broad sweep", &points, &out);
        println!("    wall time {wall:.2} s on 2 threads");
        let mut by_strategy: BTreeMap<String, BTreeMap<&str, usize>> = BTreeMap::new();
        for (p, (r, _)) in points.iter().zip(&out) {
            *by_strategy
                .entry(p.strategy.to_string())
                .or_default()
                .entry(r.status.as_str())
                .or_default() += 1;
        }
        for (s, c) in by_strategy {
            let c: Vec<String> = c.iter().map(|(k, v)| format!("{k} {v}")).collect();
            println!("    {s}: {}", c.join(", "));
        }
        let mut kinds: BTreeMap<String, usize> = BTreeMap::new();
        for (p, (r, _)) in points.iter().zip(&out) {
            if r.status == "zeno" {
                *kinds
                    .entry(format!("{} {}", p.strategy, zeno_kind(&r.word)))
                    .or_default() += 1;
            }
        }
        let kinds: Vec<String> = kinds.iter().map(|(k, v)| format!("{k} {v}")).collect();
        println!("    zeno by kind: {}", kinds.join(", "));
        // SHOW=zeno (a status) lists the points that ended so, SHOW=slow those over 50 ms
        if let Ok(show) = std::env::var("SHOW") {
            for (p, (r, dt)) in points.iter().zip(&out) {
                if r.status == show || (show == "slow" && *dt > 0.05) {
                    let kind = if r.status == "zeno" {
                        format!(" [{}]", zeno_kind(&r.word))
                    } else {
                        String::new()
                    };
                    println!(
                        "    {} {:.1} ms: {}{kind} ({})",
                        r.status,
                        1e3 * dt,
                        describe(p),
                        r.word
                    );
                }
            }
        }
    }
}
