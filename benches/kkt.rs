//! Forward dynamics (thesis 5.3–5.4) of the chapter-4 RHex (massless half-circle legs):
//! mode 0101 and every other contact mode except the over-constrained 1111.
//! Target: ≤ 1 µs per evaluation.
mod common;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use selfmanip::core::{forward_dynamics, Data, FlatGround};
use std::hint::black_box;

fn dynamics(c: &mut Criterion) {
    let (rhex, q, qd) = common::chapter4_rhex_at_bench_state();
    let model = &rhex.model;
    let mut data = Data::new(model);
    let tau = [20.0, 15.0];
    let mut group = c.benchmark_group("forward_dynamics");
    for label in rhex.all_labels().into_iter().filter(|l| l != "1111") {
        let mode = rhex.mode(&label).unwrap();
        group.bench_with_input(BenchmarkId::from_parameter(&label), &mode, |b, &mode| {
            b.iter(|| {
                // some modes are kinematically singular at this pose: the typed error path
                // is part of what is timed
                let _ = forward_dynamics(
                    model,
                    &mut data,
                    &FlatGround,
                    mode,
                    black_box(&q),
                    black_box(&qd),
                    &tau,
                    None,
                );
                black_box(&data.qdd);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, dynamics);
criterion_main!(benches);
