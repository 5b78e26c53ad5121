//! Runs one leap `n` times and prints the time per leap and the steps per segment: a quick
//! probe for profiling (`perf`, `valgrind --tool=callgrind`); the benchmark is `benches/leap.rs`.
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin leap_loop -- 300 0.02
//! ```
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig};
fn main() {
    let n: usize = std::env::args().nth(1).map_or(200, |s| s.parse().unwrap());
    let t2: f64 = std::env::args().nth(2).map_or(0.0, |s| s.parse().unwrap());
    let params = leap_params();
    let cfg = LeapConfig {
        t2_s: t2,
        ..LeapConfig::default()
    };
    let t = std::time::Instant::now();
    let mut steps = 0;
    let mut segs = Vec::new();
    for _ in 0..n {
        let r = simulate_leap(&params, &cfg).unwrap();
        steps = r
            .execution
            .segments
            .iter()
            .map(|s| s.dense.len())
            .sum::<usize>();
        segs = r
            .execution
            .segments
            .iter()
            .map(|s| (s.dense.len(), s.t1 - s.t0))
            .collect();
    }
    println!(
        "{:.3} ms/leap, {steps} steps {:?}",
        t.elapsed().as_secs_f64() * 1e3 / n as f64,
        segs
    );
}
