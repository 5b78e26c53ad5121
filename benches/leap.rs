//! One RHex (+,+) leap from rest to apex (thesis chapter 3.2 through the chapter-5 hybrid
//! system): touchdowns, slips and liftoffs located to 1e-10 s on the DOPRI5 dense output,
//! plastic-impact and force complementarity at every event. Target: ≤ 1 ms on one core.
//!
//! The same leaps through the behaviour interpreter of `selfmanip-sim` (the shipped file
//! `leap_pp.toml`, bit-identical executions): `behaviour_run` compiles nothing per
//! iteration (a `Simulation` built once), `behaviour_build_and_run` also checks and compiles
//! the scenario each time, as the controller path builds its robot and start pose each time.
//! `++ preset_at` runs the leap on a [`LeapPreset`] built once for the strategy, its point
//! bound to the simulation the preset built (`LeapPreset::run_at`: what a leap sweep does per
//! point), beside the one-shot `simulate_leap` (`++`), which builds the preset each time.
//! `++ massive_legs`: the same leap with legs of Table 4.2's mass carrying their rotors (no
//! target yet; the massless default is the one the 1 ms bound is for).
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use selfmanip::hybrid::budget::NEVER;
use selfmanip::rhex::leap::leap_scenario;
use selfmanip::rhex::leap::{leap_params, simulate_leap, LeapConfig, LeapPreset};
use selfmanip::sim::Simulation;
use std::hint::black_box;

/// The default leap at the motor start `t2_s`, its events located to 1e-10 s.
fn leap_at(t2_s: f64) -> LeapConfig {
    LeapConfig {
        t2_s,
        event_tol_s: 1e-10,
        ..LeapConfig::default()
    }
}

fn leap(c: &mut Criterion) {
    let params = leap_params();
    let mut group = c.benchmark_group("leap_to_apex");
    let preset = LeapPreset::new(&params, &LeapConfig::default()).unwrap();
    for t2 in [0.0, 0.02, 0.1] {
        let cfg = leap_at(t2);
        group.bench_with_input(BenchmarkId::new("++", t2), &cfg, |b, cfg| {
            b.iter(|| simulate_leap(black_box(&params), cfg).unwrap())
        });
        group.bench_with_input(BenchmarkId::new("++ preset_at", t2), &cfg, |b, cfg| {
            b.iter(|| {
                preset
                    .run_at(black_box(cfg.t2_s), &cfg.actuator, &NEVER)
                    .unwrap()
            })
        });
        let q0 = simulate_leap(&params, &cfg).unwrap().run.q0;
        let scenario = leap_scenario(&params, &cfg, &q0).unwrap().scenario;
        let sim = Simulation::new(&scenario).unwrap();
        group.bench_with_input(BenchmarkId::new("++ behaviour_run", t2), &sim, |b, sim| {
            b.iter(|| black_box(sim).run().unwrap())
        });
        group.bench_with_input(
            BenchmarkId::new("++ behaviour_build_and_run", t2),
            &scenario,
            |b, s| b.iter(|| Simulation::new(black_box(s)).unwrap().run().unwrap()),
        );
    }
    // legs with Table 4.2's pair mass and inertia (m_l = 0.126 kg, I_l = 0.00092 kg m²),
    // carrying their rotors' n J G² as joint armature, Coulomb toes: the model that issue 16
    // measures against the massless default (its cost: the legs' servo modes, docs)
    let massive = selfmanip::rhex::params::RhexParams {
        m_l: 0.126,
        I_l: 0.00092,
        ..leap_params()
    };
    for t2 in [0.0, -0.02] {
        let cfg = leap_at(t2);
        group.bench_with_input(BenchmarkId::new("++ massive_legs", t2), &cfg, |b, cfg| {
            b.iter(|| simulate_leap(black_box(&massive), cfg).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, leap);
criterion_main!(benches);
