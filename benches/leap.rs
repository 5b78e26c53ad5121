//! One RHex (+,+) leap from rest to apex (thesis chapter 3.2 through the chapter-5 hybrid
//! system): touchdowns, slips and liftoffs located to 1e-10 s on the DOPRI5 dense output,
//! plastic-impact and force complementarity at every event. Target: ≤ 1 ms on one core.
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use selfmanip::rhex::leap::{leap_params, simulate_leap, LeapConfig};
use std::hint::black_box;

fn leap(c: &mut Criterion) {
    let params = leap_params();
    let mut group = c.benchmark_group("leap_to_apex");
    for t2 in [0.0, 0.02, 0.1] {
        let cfg = LeapConfig {
            t2_s: t2,
            event_tol_s: 1e-10,
            ..LeapConfig::default()
        };
        group.bench_with_input(BenchmarkId::new("++", t2), &cfg, |b, cfg| {
            b.iter(|| simulate_leap(black_box(&params), cfg).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, leap);
criterion_main!(benches);
