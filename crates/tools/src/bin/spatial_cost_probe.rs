//! A probe for instruction counts: `forward_dynamics` of the shipped quadruped standing on its
//! four feet with friction (the state of `benches/spatial.rs`), repeated `CALLS` times
//! (default 1000) inside `probe_calls`, with the URDF's legs or (`LEGS=massless_shins`) with
//! the shins (and the feet fixed to them) massless, free-flying or (`BASE=planar`) on a
//! planar base, its feet held in the plane; or (`ROBOT=rhex`) the six-legged RHex on
//! its six frictionless toes at the bench's state, with Table 4.2's legs or
//! (`LEGS=massless`) massless ones, or (`CONTACTS=tripod`) on a tripod of toes with friction
//! (front left, middle right, rear left; the other legs in the air). Under callgrind:
//!
//! ```sh
//! cargo build --release -p selfmanip-tools --bin spatial_cost_probe
//! valgrind --tool=callgrind --toggle-collect='*probe_calls*' target/release/spatial_cost_probe
//! ```
//!
//! and divide the collected instructions by the calls plus one (a first call runs before
//! the count is printed).
#[path = "../../../selfmanip-core/tests/spatial_support/bench_state.rs"]
mod bench_state;
use bench_state::{evaluate, rhex_standing, standing_state};
use nalgebra::DVector;
use selfmanip_core::spatial::inertia::Inertia;
use selfmanip_core::spatial::rhex::RhexSixLegs;
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

type Setup = (SpatialModel, Vec<PointContact>, [DVector<f64>; 3], String);

/// The quadruped on four feet with friction, with the URDF's legs or massless shins, on a
/// free-flying base or (`BASE=planar`) a planar one.
fn quadruped(legs: &str, base: &str) -> Result<Setup, Box<dyn std::error::Error>> {
    let massless = match legs {
        "urdf" => false,
        "massless_shins" => true,
        other => return Err(format!("LEGS: `{other}` (urdf, massless_shins)").into()),
    };
    let mut model = SpatialModel::from_urdf_file(QUADRUPED, BaseKind::from_name(base)?, None)?;
    if massless {
        for (joint, inertia) in model.joints.iter().zip(model.inertias.iter_mut()) {
            if joint.name.ends_with("_knee") {
                *inertia = Inertia::zero();
            }
        }
    }
    let contacts = FEET
        .iter()
        .map(|f| PointContact::new(&model, f, true))
        .collect::<Result<Vec<_>, _>>()?;
    let (q, v, tau) = standing_state(&model);
    let label = format!("quadruped ({legs}, {base} base), four feet with friction");
    Ok((model, contacts, [q, v, tau], label))
}

/// The six-legged RHex on its six frictionless toes at the state of `benches/spatial.rs`
/// (legs at 0.3 rad, moving slightly), with Table 4.2's legs or massless ones; or on a tripod
/// of toes with friction.
fn rhex(legs: &str, tripod: bool) -> Result<Setup, Box<dyn std::error::Error>> {
    let p = match legs {
        "table_4_2" => RhexSixLegs::table_4_2().with_table_4_2_legs(),
        "massless" => RhexSixLegs::table_4_2(),
        other => return Err(format!("LEGS: `{other}` (table_4_2, massless)").into()),
    };
    let model = p.model()?;
    let (mut toes, mut q, v, tau) = rhex_standing(&p, &model);
    let mut label = format!("six-legged RHex ({legs} legs), six frictionless toes");
    if tripod {
        toes = ["front_left", "middle_right", "rear_left"]
            .iter()
            .map(|leg| p.toe(&model, leg, true))
            .collect::<Result<_, _>>()?;
        label = format!("six-legged RHex ({legs} legs), a tripod of toes with friction");
        // legs at unequal angles: at equal ones a tripod's legs move as a parallelogram
        for (i, x) in q.iter_mut().skip(7).enumerate() {
            *x = 0.3 + 0.1 * i as f64;
        }
    }
    Ok((model, toes, [q, v, tau], label))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let calls: usize = std::env::var("CALLS").map_or(Ok(1000), |s| s.parse())?;
    let legs = std::env::var("LEGS").ok();
    let (model, contacts, [q, v, tau], label) = match std::env::var("ROBOT").as_deref() {
        Err(_) | Ok("quadruped") => quadruped(
            legs.as_deref().unwrap_or("urdf"),
            std::env::var("BASE").as_deref().unwrap_or("free_flyer"),
        )?,
        Ok("rhex") => rhex(
            legs.as_deref().unwrap_or("table_4_2"),
            std::env::var("CONTACTS").as_deref() == Ok("tripod"),
        )?,
        Ok(other) => return Err(format!("ROBOT: `{other}` (quadruped, rhex)").into()),
    };
    let mut data = SpatialData::new(&model);
    let state = (&q, &v, &tau);
    probe_calls(&model, &mut data, &contacts, state, 1);
    println!(
        "{label}: {calls} calls, route {:?}, |q̈| {:.6e}",
        data.kkt_route,
        data.qdd.norm()
    );
    probe_calls(&model, &mut data, &contacts, state, calls);
    Ok(())
}
