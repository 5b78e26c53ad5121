//! Where one forward-dynamics evaluation spends its time: each pipeline stage of
//! `selfmanip_core::dynamics` timed alone for the chapter-4 RHex in mode 0101.
mod common;
use criterion::{criterion_group, criterion_main, Criterion};
use selfmanip::core::constraint::Constraints;
use selfmanip::core::inertia::mass_coriolis_gravity;
use selfmanip::core::kinematics::Kinematics;
use selfmanip::core::{Data, FlatGround};
use std::hint::black_box;
fn pipeline_stages(c: &mut Criterion) {
    let (rhex, q, qd) = common::chapter4_rhex_at_bench_state();
    let model = &rhex.model;
    let mut data = Data::new(model);
    let mode = rhex.mode("0101").unwrap();
    let mut kin = Kinematics::default();
    c.bench_function("kinematics", |b| {
        b.iter(|| kin.compute(model, black_box(&q), &qd))
    });
    kin.compute(model, &q, &qd);
    let mut m = data.m_bar.clone();
    let mut cq = data.c_qd.clone();
    let mut n = data.n_bar.clone();
    let mut scratch = Default::default();
    c.bench_function("mass_coriolis_gravity", |b| {
        b.iter(|| {
            mass_coriolis_gravity(
                model,
                &kin,
                black_box(&qd),
                &mut scratch,
                &mut m,
                &mut cq,
                &mut n,
            )
        })
    });
    let mut cons = Constraints::default();
    c.bench_function("constraints_assemble", |b| {
        b.iter(|| cons.assemble(model, &kin, &FlatGround, black_box(mode), &qd))
    });
    c.bench_function("prepare_all_stages", |b| {
        b.iter(|| data.prepare(model, &FlatGround, black_box(mode), &q, &qd))
    });
    data.prepare(model, &FlatGround, mode, &q, &qd).unwrap();
    let mr = m.clone();
    let a = cons.a.clone();
    let mut k = data.kkt.clone();
    c.bench_function("kkt_factor", |b| b.iter(|| k.factor(black_box(&mr), &a)));
}
criterion_group!(benches, pipeline_stages);
criterion_main!(benches);
