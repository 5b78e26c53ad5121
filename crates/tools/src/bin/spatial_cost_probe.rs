//! A probe for instruction counts: `forward_dynamics` of the shipped quadruped standing on its
//! four feet with friction (the state of `benches/spatial.rs`), repeated `CALLS` times
//! (default 1000) inside `probe_calls`, with the URDF's legs or (`LEGS=massless_shins`) with
//! the shins (and the feet fixed to them) massless. Under callgrind:
//!
//! ```sh
//! cargo build --release -p selfmanip-tools --bin spatial_cost_probe
//! valgrind --tool=callgrind --toggle-collect='*probe_calls*' target/release/spatial_cost_probe
//! ```
//!
//! and divide the collected instructions by the calls (printed).
#[path = "../../../selfmanip-core/tests/spatial_support/bench_state.rs"]
mod bench_state;
use bench_state::{evaluate, standing_state};
use nalgebra::DVector;
use selfmanip_core::spatial::inertia::Inertia;
use selfmanip_core::spatial::{BaseKind, PointContact, SpatialData, SpatialModel};

const QUADRUPED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/urdf/quadruped12.urdf"
);
const FEET: [&str; 4] = ["FL_foot", "FR_foot", "HL_foot", "HR_foot"];

#[inline(never)]
fn probe_calls(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    state: (&DVector<f64>, &DVector<f64>, &DVector<f64>),
    calls: usize,
) {
    for _ in 0..calls {
        evaluate(model, data, contacts, state);
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let calls: usize = std::env::var("CALLS").map_or(Ok(1000), |s| s.parse())?;
    let massless = match std::env::var("LEGS").as_deref() {
        Err(_) | Ok("urdf") => false,
        Ok("massless_shins") => true,
        Ok(other) => return Err(format!("LEGS: `{other}` (urdf, massless_shins)").into()),
    };
    let mut model = SpatialModel::from_urdf_file(QUADRUPED, BaseKind::FreeFlyer, None)?;
    if massless {
        for (joint, inertia) in model.joints.iter().zip(model.inertias.iter_mut()) {
            if joint.name.ends_with("_knee") {
                *inertia = Inertia::zero();
            }
        }
    }
    let mut data = SpatialData::new(&model);
    let contacts = FEET
        .iter()
        .map(|f| PointContact::new(&model, f, true))
        .collect::<Result<Vec<_>, _>>()?;
    let (q, v, tau) = standing_state(&model);
    let state = (&q, &v, &tau);
    probe_calls(&model, &mut data, &contacts, state, 1);
    println!(
        "quadruped ({}), four feet with friction: {calls} calls, route {:?}, |q̈| {:.6e}",
        if massless {
            "massless shins"
        } else {
            "URDF legs"
        },
        data.kkt_route,
        data.qdd.norm()
    );
    probe_calls(&model, &mut data, &contacts, state, calls);
    Ok(())
}
