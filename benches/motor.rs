//! Actuator tools (issue: "analytic ranking of 1,546 catalog motors in well under 10 ms";
//! the thesis: 171 s numerically → 0.175 s analytically). Also one hour of thermal
//! simulation at 1 s and one observer sample.
use criterion::{criterion_group, criterion_main, Criterion};
use selfmanip::motor::catalog::synthetic_motors;
use selfmanip::motor::observer::LegObserver;
use selfmanip::motor::tail::{rank_tail_motors, SelectionConstraints, TailTask};
use selfmanip::motor::{CaseParameters, Catalog, HeatInput, ThermalState};
use std::hint::black_box;

#[path = "../crates/motor/tests/common/mod.rs"]
mod motor_fixtures;

fn motor_tools(c: &mut Criterion) {
    let motors = synthetic_motors(1546, 7).expect("1,546 motors are within the bound");
    let task = TailTask::new(std::f64::consts::FRAC_PI_2, 0.05, 1.29).unwrap();
    let constraints = SelectionConstraints {
        max_length_m: 0.030,
        max_mass_kg: 0.200,
        max_completion_time_s: 0.5,
    };
    c.bench_function("tail_rank_1546_motors", |b| {
        b.iter(|| rank_tail_motors(black_box(&motors), &task, &constraints).unwrap())
    });

    let catalog = Catalog::thesis();
    let drive = catalog.drive("x-rhex-28").unwrap();
    let thermal = catalog
        .drive_thermal("x-rhex-28", CaseParameters::Measured)
        .unwrap();
    let torque: Vec<f64> = (0..3600)
        .map(|k| if k % 60 < 30 { 2.0 } else { 0.5 })
        .collect();
    c.bench_function("thermal_one_hour_at_1s", |b| {
        b.iter(|| {
            thermal
                .simulate(
                    ThermalState::ambient(25.0),
                    25.0,
                    1.0,
                    HeatInput::OutputTorque {
                        drive: &drive,
                        torque_n_m: black_box(&torque),
                    },
                )
                .unwrap()
        })
    });

    let params = motor_fixtures::synthetic_leg();
    let mut observer = LegObserver::new(params, 0.001, 0.0, 0.0).unwrap();
    c.bench_function("observer_sample", |b| {
        b.iter(|| observer.update(black_box(0.3), 2.0, 0.29, 2.1))
    });
}

criterion_group!(benches, motor_tools);
criterion_main!(benches);
