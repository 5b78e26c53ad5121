//! The state of the quadruped's cost measurements (`benches/spatial.rs`, `spatial_cost_probe.rs`,
//! `scripts/bench-pinocchio.py`), shared as source.
use nalgebra::DVector;
use selfmanip_core::spatial::rhex::{RhexSixLegs, PAIRS, SIDES};
use selfmanip_core::spatial::{
    forward_dynamics, neutral, JointKind, PointContact, SpatialData, SpatialModel,
};
use std::hint::black_box;

/// Standing at 0.4 m on legs bent by 0.5 rad (knees −1 rad), moving: `(q, v, τ)`, on a
/// free-flying base (`q[2]` the height) or a planar one (`q[1]`).
pub fn standing_state(model: &SpatialModel) -> (DVector<f64>, DVector<f64>, DVector<f64>) {
    let (height, legs) = match model.floating_base() {
        Some(JointKind::Planar) => (1, 3),
        _ => (2, 7),
    };
    let base_rates = model.nv - 12;
    let mut q = neutral(model);
    q[height] = 0.4;
    for leg in 0..4 {
        q[legs + 3 * leg + 1] = 0.5;
        q[legs + 3 * leg + 2] = -1.0;
    }
    let v = DVector::from_fn(model.nv, |i, _| 0.1 * ((i as f64) * 0.7).sin());
    let tau = DVector::from_fn(model.nv, |i, _| {
        if i < base_rates {
            0.0
        } else {
            2.0 * ((i as f64) * 1.3).cos()
        }
    });
    (q, v, tau)
}

/// The six-legged RHex `p` (its `model`) on its six frictionless toes, legs at 0.3 rad so
/// that each toe's normal row pins its leg (massless or not), moving slightly: the toes and
/// `(q, v, τ)`.
pub fn rhex_standing(
    p: &RhexSixLegs,
    model: &SpatialModel,
) -> (Vec<PointContact>, DVector<f64>, DVector<f64>, DVector<f64>) {
    let toes = PAIRS
        .iter()
        .flat_map(|pair| SIDES.iter().map(move |side| format!("{pair}_{side}")))
        .map(|leg| p.toe(model, &leg, false).expect("a toe frame"))
        .collect();
    let mut q = neutral(model);
    q[2] = p.leg_length_m * 0.3f64.cos();
    for x in q.iter_mut().skip(7) {
        *x = 0.3;
    }
    let v = DVector::from_fn(model.nv, |i, _| 0.1 * ((i as f64) * 0.7).sin());
    let tau = DVector::from_fn(model.nv, |i, _| if i < 6 { 0.0 } else { 1.0 });
    (toes, q, v, tau)
}

/// One `forward_dynamics` at `(q, v, τ)` with its inputs hidden from the optimizer: the unit
/// the bench times and the probe counts.
pub fn evaluate(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    (q, v, tau): (&DVector<f64>, &DVector<f64>, &DVector<f64>),
) {
    forward_dynamics(
        model,
        data,
        contacts,
        black_box(q.as_slice()),
        black_box(v.as_slice()),
        tau.as_slice(),
    )
    .expect("standing is regular");
    black_box(&data.qdd);
}
