//! A probe for instruction counts (not a check): `forward_dynamics` of the quadruped standing
//! on its four feet with friction (the state of `benches/spatial.rs`), repeated
//! `SPATIAL_PROBE_CALLS` times (default 1000), with the URDF's legs and with massless shins.
//! `SPATIAL_PROBE_LEGS=massless_shins` selects the massless shins. Under callgrind:
//!
//! ```text
//! valgrind --tool=callgrind --toggle-collect='*probe_calls*' \
//!     target/release/deps/spatial_cost_probe-… --ignored --exact probe
//! ```
//!
//! and divide the collected instructions by the calls.
mod spatial_support;
use nalgebra::DVector;
use selfmanip_core::spatial::*;
use spatial_support::*;
use std::hint::black_box;

/// The bench's standing, moving state `(q, v, τ)`.
fn bench_state(model: &SpatialModel) -> (DVector<f64>, DVector<f64>, DVector<f64>) {
    let mut q = neutral(model);
    q[2] = 0.4;
    for leg in 0..4 {
        q[7 + 3 * leg + 1] = 0.5;
        q[7 + 3 * leg + 2] = -1.0;
    }
    let v = DVector::from_fn(model.nv, |i, _| 0.1 * ((i as f64) * 0.7).sin());
    let tau = DVector::from_fn(model.nv, |i, _| {
        if i < 6 {
            0.0
        } else {
            2.0 * ((i as f64) * 1.3).cos()
        }
    });
    (q, v, tau)
}

#[inline(never)]
fn probe_calls(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    state: (&DVector<f64>, &DVector<f64>, &DVector<f64>),
    calls: usize,
) {
    for _ in 0..calls {
        dynamics_at(model, data, contacts, state).unwrap();
        black_box(&data.qdd);
    }
}

#[test]
#[ignore = "a probe for callgrind, not a check"]
fn probe() {
    let calls: usize = std::env::var("SPATIAL_PROBE_CALLS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1000);
    let massless = std::env::var("SPATIAL_PROBE_LEGS").as_deref() == Ok("massless_shins");
    let model = if massless {
        quadruped_massless_shins()
    } else {
        quadruped()
    };
    let mut data = SpatialData::new(&model);
    let contacts = feet(&model, [true; 4]);
    let (q, v, tau) = bench_state(&model);
    let state = (&q, &v, &tau);
    dynamics_at(&model, &mut data, &contacts, state).unwrap();
    probe_calls(&model, &mut data, &contacts, state, calls);
}
