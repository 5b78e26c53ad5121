//! Batched leap sweeps (issue 5: "≥ 2,000 (+,+) leaps per second in a sweep, ≥ 1.8× from 1
//! to 2 threads" on the 2-core machine). One iteration is a sweep of 64 (+,+) leaps over
//! `t2 ∈ [−0.2, 0.2]` with the geared X-RHex motors (G = 28), on a pool of 1 or 2 threads;
//! leaps per second = 64 / time per iteration. Also one leap alone, and a mixed sweep over
//! all four strategies. `preset_plus_plus_64`: the same 64 points run on one [`LeapPreset`]
//! on one thread, each point's values bound to the simulation it built (`LeapPreset::run_at`),
//! the call a leap sweep makes per strategy.
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use selfmanip::hybrid::budget::NEVER;
use selfmanip::rhex::leap::{leap_params, simulate_leap, LeapConfig, LeapPreset, Strategy};
use selfmanip::rhex::sweep::{grid, sweep};
use std::hint::black_box;
use std::time::Duration;

const N: usize = 64;

fn t2_grid(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| -0.2 + 0.4 * i as f64 / (n - 1) as f64)
        .collect()
}

fn sweeps(c: &mut Criterion) {
    let params = leap_params();
    let cfg = LeapConfig::default();
    c.bench_function("leap_plus_plus_t2_0", |b| {
        b.iter(|| simulate_leap(black_box(&params), &cfg).unwrap())
    });

    let plus_plus = grid(&Strategy::ALL[..1], &t2_grid(N), &[Some(28.0)]);
    let mut g = c.benchmark_group("sweep_plus_plus_64");
    g.throughput(Throughput::Elements(N as u64));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(8));
    for threads in [1usize, 2] {
        g.bench_function(format!("threads_{threads}"), |b| {
            b.iter(|| sweep(&params, &cfg, black_box(&plus_plus), threads).unwrap())
        });
    }
    g.finish();

    let mut g = c.benchmark_group("preset_plus_plus_64");
    g.throughput(Throughput::Elements(N as u64));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(8));
    g.bench_function("threads_1", |b| {
        b.iter(|| {
            let preset = LeapPreset::new(&params, &cfg).unwrap();
            for &t2 in &t2_grid(N) {
                black_box(preset.run_at(t2, &cfg.actuator, &NEVER).unwrap());
            }
        })
    });
    g.finish();

    let all = grid(&Strategy::ALL, &t2_grid(N / 4), &[Some(28.0)]);
    let mut g = c.benchmark_group("sweep_all_strategies_64");
    g.throughput(Throughput::Elements(all.len() as u64));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(8));
    g.bench_function("threads_2", |b| {
        b.iter(|| sweep(&params, &cfg, black_box(&all), 2).unwrap())
    });
    g.finish();
}

criterion_group!(benches, sweeps);
criterion_main!(benches);
