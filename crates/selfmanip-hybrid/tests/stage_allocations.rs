//! The inner loop allocates nothing per step: the integrator, the dense-step buffer, the
//! guard states and their sample buffers are reused, and a segment's dense output grows by
//! doubling. Counted with a per-thread counting allocator: doubling the number of steps of
//! a segment adds only the few allocations of the buffers' growth, not one per step.
mod counting;
mod systems;
use selfmanip_core::ContactMode;
use selfmanip_hybrid::Termination;
use systems::{block, released, short_steps, G};

/// Steps of the first segment and allocations of a run to `t_final` from `(q, q̇)` in `mode`.
fn steps_and_allocations(mode: &str, q: [f64; 3], t_final: f64) -> (usize, usize) {
    let model = block(G);
    let mode = ContactMode::parse_names(&model, mode).unwrap();
    let before = counting::allocations();
    let exec = released(&model, mode, &q, t_final, short_steps());
    let allocations = counting::allocations() - before;
    assert_eq!(exec.termination, Termination::FinalTime);
    assert_eq!(exec.segments.len(), 1);
    (exec.segments[0].dense.len(), allocations)
}

#[test]
fn steps_allocate_nothing() {
    systems::assert_doubling_the_steps_adds_no_allocations(steps_and_allocations);
}
