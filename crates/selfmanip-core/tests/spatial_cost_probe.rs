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
#[path = "spatial_support/bench_state.rs"]
mod bench_state;
mod spatial_support;
use bench_state::standing_state;
use nalgebra::DVector;
use selfmanip_core::spatial::*;
use spatial_support::*;
use std::hint::black_box;

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
    let (q, v, tau) = standing_state(&model);
    let state = (&q, &v, &tau);
    dynamics_at(&model, &mut data, &contacts, state).unwrap();
    probe_calls(&model, &mut data, &contacts, state, calls);
}
