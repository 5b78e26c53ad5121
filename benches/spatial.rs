//! Spatial (d = 3) constrained forward dynamics, thesis (5.3)–(5.4), of the shipped 12-joint
//! quadruped (`tests/data/urdf/quadruped12.urdf`) standing on its four feet, each a point
//! contact with friction (three rows): with the URDF's leg masses, and with massless shins
//! (singular `M`, the KKT block inverse of chapter 5). Also `M` (CRBA) and the bias forces
//! (RNEA) alone, and the dynamics in flight; the quadruped on a planar base, its feet held in the plane (two rows each);
//! and the six-legged RHex of Table 4.2 on its six toes. `scripts/bench-pinocchio.py` times Pinocchio's constrained forward dynamics
//! (and MuJoCo's dynamics in flight) on the same robot and state and prints the ratios. Target: ≤ 2 µs per KKT evaluation.
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::DVector;
use selfmanip::core::spatial::rhex::RhexSixLegs;
use selfmanip::core::spatial::rigid_body::{crba, nonlinear_effects};
use selfmanip::core::spatial::{BaseKind, PointContact, SpatialData, SpatialModel};
use std::hint::black_box;

#[path = "../crates/selfmanip-core/tests/spatial_support/bench_state.rs"]
mod bench_state;
use bench_state::{evaluate, rhex_standing, standing_state};

const QUADRUPED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/urdf/quadruped12.urdf"
);
const FEET: [&str; 4] = ["FL_foot", "FR_foot", "HL_foot", "HR_foot"];

/// The quadruped on `base`, with its shins' and feet's masses scaled by `shin_scale`.
fn quadruped(base: BaseKind, shin_scale: f64) -> SpatialModel {
    let mut robot = urdf_rs::read_file(QUADRUPED).expect("the shipped URDF parses");
    for link in &mut robot.links {
        if link.name.ends_with("_shin") || link.name.ends_with("_foot") {
            link.inertial.mass.value *= shin_scale;
            let i = &mut link.inertial.inertia;
            for x in [
                &mut i.ixx, &mut i.ixy, &mut i.ixz, &mut i.iyy, &mut i.iyz, &mut i.izz,
            ] {
                *x *= shin_scale;
            }
        }
    }
    SpatialModel::from_urdf_robot(&robot, base, None).expect("a tree")
}

type State<'a> = (&'a DVector<f64>, &'a DVector<f64>, &'a DVector<f64>);

/// One `forward_dynamics` benchmark at the state `(q, v, τ)`.
fn bench_dynamics(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    state: State<'_>,
) {
    group.bench_function(name, |b| b.iter(|| evaluate(model, data, contacts, state)));
}

fn spatial(c: &mut Criterion) {
    let mut group = c.benchmark_group("spatial_quadruped");
    for (label, base, scale) in [
        ("massive_legs", BaseKind::FreeFlyer, 1.0),
        ("massless_shins", BaseKind::FreeFlyer, 0.0),
        ("planar_base", BaseKind::Planar, 1.0),
    ] {
        let model = quadruped(base, scale);
        let feet: Vec<PointContact> = FEET
            .iter()
            .map(|f| PointContact::new(&model, f, true).expect("a foot frame"))
            .collect();
        let mut data = SpatialData::new(&model);
        let (q, v, tau) = standing_state(&model);
        let state = (&q, &v, &tau);
        bench_dynamics(
            &mut group,
            &format!("forward_dynamics_4_feet/{label}"),
            &model,
            &mut data,
            &feet,
            state,
        );
        if label == "massive_legs" {
            // in flight: M, the bias forces and M's factorization alone (no contact rows),
            // what MuJoCo's `mj_forward` with its constraints off computes
            bench_dynamics(
                &mut group,
                "forward_dynamics_flight",
                &model,
                &mut data,
                &[],
                state,
            );
            group.bench_function("crba", |b| {
                b.iter(|| {
                    crba(&model, &mut data, black_box(q.as_slice())).unwrap();
                    black_box(&data.M);
                })
            });
            group.bench_function("nonlinear_effects", |b| {
                b.iter(|| {
                    nonlinear_effects(
                        &model,
                        &mut data,
                        black_box(q.as_slice()),
                        black_box(v.as_slice()),
                    )
                    .unwrap();
                    black_box(&data.h);
                })
            });
        }
    }
    group.finish();
}

/// The six-legged RHex (Table 4.2) standing on its six toes, frictionless (six rows), legs
/// at 0.3 rad, moving slightly: massless legs (singular `M`) and Table 4.2's legs.
fn spatial_rhex(c: &mut Criterion) {
    let mut group = c.benchmark_group("spatial_rhex");
    for (label, p) in [
        ("massless_legs", RhexSixLegs::table_4_2()),
        (
            "table_4_2_legs",
            RhexSixLegs::table_4_2().with_table_4_2_legs(),
        ),
    ] {
        let model = p.model().expect("Table 4.2 is valid");
        let (toes, q, v, tau) = rhex_standing(&p, &model);
        let mut data = SpatialData::new(&model);
        let state = (&q, &v, &tau);
        bench_dynamics(
            &mut group,
            &format!("forward_dynamics_6_toes/{label}"),
            &model,
            &mut data,
            &toes,
            state,
        );
    }
    group.finish();
}

criterion_group!(benches, spatial, spatial_rhex);
criterion_main!(benches);
