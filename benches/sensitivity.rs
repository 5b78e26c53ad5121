//! The cost of sensitivities: one execution with `simulate` against the same execution with
//! `simulate_with_sensitivity` (the execution, then `dx(t_f)/dx(0)` over the full state: the
//! variational equations on its own steps, `2 nq + n` KKT solves per stage, and a saltation
//! matrix per event), at the engine's default tolerances. Systems: the rocking block dropped
//! tilted (7 touchdowns, 6 states) and RHex with massless half-circle legs dropped onto them
//! under hip servos (2 touchdowns and a rolling/point switch, 10 states).
//!
//! And the default RHex leap (`LeapConfig::default()`, strategy `++`, `t2 = 0.05 s`: seven
//! events) plain against the same leap with its apex differentiated with respect to two
//! parameters (`t2`, `gear_ratio`: two columns propagated by Jacobian-times-matrix products,
//! issue 18's criterion: at most 5×), and the leap the sensitivity path runs — with its free
//! legs under step control — alone.
#[path = "../tests/common/mod.rs"]
mod common;

use common::{drop_state, rhex_massless, rocking_block, Servos};
use criterion::measurement::WallTime;
use criterion::{criterion_group, criterion_main, BenchmarkGroup, Criterion};
use selfmanip::core::{ContactMode, FlatGround, Model, Terrain};
use selfmanip::hybrid::sensitivity::simulate_with_sensitivity;
use selfmanip::hybrid::{simulate, Controller, HybridOptions, ZeroTorque};
use selfmanip::rhex::leap::{leap_params, simulate_leap, LeapConfig};
use selfmanip::rhex::leap_sensitivity::leap_with_sensitivity;
use selfmanip::rhex::LegShape;
use std::hint::black_box;

/// RHex with massless half-circle legs, 1 cm above flat ground, pitched 0.1 rad and moving,
/// under hip servos (the drop of `tests/sensitivity_rhex.rs`).
fn rhex_drop() -> (Model, Vec<f64>, Servos) {
    let model = rhex_massless(LegShape::HalfCircle).model;
    let y = drop_state(&model, &[0.3, -0.2], 0.1, 0.01, &[0.0, 0.0, 0.4, 0.3, 0.8]);
    let servo = Servos {
        k: 5.0,
        c: 0.05,
        target: vec![0.3, -0.2],
    };
    (model, y, servo)
}

/// A run from flight on flat ground: what `simulate` and `simulate_with_sensitivity` time.
struct FlightRun<'a> {
    model: &'a Model,
    controller: &'a dyn Controller,
    start: (&'a [f64], &'a [f64]),
    t_final: f64,
    opts: HybridOptions,
}

impl FlightRun<'_> {
    /// `run` (`simulate` or `simulate_with_sensitivity`) of this run, unwrapped.
    #[allow(clippy::type_complexity)]
    fn with<T, E: std::fmt::Debug>(
        &self,
        run: fn(
            &Model,
            &dyn Terrain,
            &dyn Controller,
            ContactMode,
            &[f64],
            &[f64],
            f64,
            HybridOptions,
        ) -> Result<T, E>,
    ) -> T {
        let (q0, qd0) = self.start;
        let (model, ctrl) = (self.model, self.controller);
        run(
            model,
            &FlatGround,
            ctrl,
            ContactMode::FLIGHT,
            q0,
            qd0,
            self.t_final,
            self.opts,
        )
        .unwrap()
    }

    /// `{name}/simulate` and `{name}/with_sensitivity` in `group`.
    fn bench(&self, group: &mut BenchmarkGroup<'_, WallTime>, name: &str) {
        group.bench_function(format!("{name}/simulate"), |b| {
            b.iter(|| black_box(self.with(simulate)))
        });
        group.bench_function(format!("{name}/with_sensitivity"), |b| {
            b.iter(|| black_box(self.with(simulate_with_sensitivity)))
        });
    }
}

fn sensitivity(c: &mut Criterion) {
    let opts = HybridOptions::default();
    let mut group = c.benchmark_group("sensitivity");
    // the rocking block: left corner 2 cm above ground, tilted 0.15 rad
    let (w, h) = (0.05_f64, 0.10_f64);
    let phi0 = 0.15_f64;
    let (s, co) = phi0.sin_cos();
    let left_z = -s * (-w / 2.0) + co * h / 2.0;
    let q0 = [0.0, -0.02 - left_z, phi0];
    let qd0 = [0.05, 0.1, -0.5];
    let rocking = FlightRun {
        model: &rocking_block(),
        controller: &ZeroTorque,
        start: (&q0, &qd0),
        t_final: 0.464,
        opts,
    };
    eprintln!(
        "rocking block: {} events",
        rocking.with(simulate).events.len()
    );
    rocking.bench(&mut group, "rocking_block");
    let (rhex, y0, servo) = rhex_drop();
    let (q0, qd0) = y0.split_at(rhex.nq());
    let rhex = FlightRun {
        model: &rhex,
        controller: &servo,
        start: (q0, qd0),
        t_final: 0.25,
        opts,
    };
    rhex.bench(&mut group, "rhex_drop");
    group.finish();
    let mut group = c.benchmark_group("leap_sensitivity");
    let params = leap_params();
    let cfg = LeapConfig {
        t2_s: 0.05,
        ..LeapConfig::default()
    };
    group.bench_function("leap", |b| {
        b.iter(|| black_box(simulate_leap(&params, &cfg).unwrap()))
    });
    // the execution the sensitivity path runs (its free legs under step control), alone
    let controlled = LeapConfig {
        control_free_joints: true,
        ..cfg.clone()
    };
    group.bench_function("leap_control_free_joints", |b| {
        b.iter(|| black_box(simulate_leap(&params, &controlled).unwrap()))
    });
    group.bench_function("leap_d_t2_gear_ratio", |b| {
        b.iter(|| black_box(leap_with_sensitivity(&params, &cfg, &["t2", "gear_ratio"]).unwrap()))
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(3));
    targets = sensitivity
}
criterion_main!(benches);
