//! The hot path allocates nothing: once a `SpatialData` has met a contact set, repeated
//! `forward_dynamics` and `crba` + `nonlinear_effects` calls make no heap allocation (counted
//! by a global allocator wrapper).
mod spatial_support;
use selfmanip_core::spatial::rigid_body::{crba, nonlinear_effects};
use spatial_support::*;

/// The hybrid crate's per-thread counting allocator (std only), shared as source.
#[path = "../../selfmanip-hybrid/tests/counting/mod.rs"]
mod counting;

#[test]
fn forward_dynamics_does_not_allocate() {
    let (model, mut data, mut rng) = setup(quadruped_massless_shins(), 13);
    let contacts = feet(&model, [true; 4]);
    let states: Vec<_> = (0..10).map(|_| random_state(&model, &mut rng)).collect();
    // warm up: sizes the contact buffers and the KKT factorization
    dynamics_at(
        &model,
        &mut data,
        &contacts,
        (&states[0].0, &states[0].1, &states[0].2),
    )
    .unwrap();
    let before = counting::allocations();
    assert!(before > 0, "the counter counts (set-up allocates)");
    for (q, v, tau) in &states {
        dynamics_at(&model, &mut data, &contacts, (q, v, tau)).unwrap();
        crba(&model, &mut data, q.as_slice()).unwrap();
        nonlinear_effects(&model, &mut data, q.as_slice(), v.as_slice()).unwrap();
    }
    let made = counting::allocations() - before;
    assert_eq!(made, 0, "{made} allocations in 10 evaluations");
}
