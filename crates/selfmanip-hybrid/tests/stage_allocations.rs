//! The inner loop allocates nothing per step: the integrator, the dense-step buffer, the
//! guard states and their sample buffers are reused, and a segment's dense output grows by
//! doubling. Counted with a per-thread counting allocator: doubling the number of steps of
//! a segment adds only the few allocations of the buffers' growth, not one per step.
mod counting;
mod systems;
use selfmanip_core::ContactMode;
use selfmanip_hybrid::Termination;
use systems::{block, released, short_steps, BLOCK, G};

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
    let (_, h, _) = BLOCK;
    // a fall from 100 m (touchdown guards sampled at every step), and a block standing on
    // its corners (liftoff and slip→stick guards: a flow evaluation per sample)
    for (mode, q) in [
        ("", [0.0, -100.0, 0.0]),
        ("left,right:slide", [0.0, -h / 2.0, 0.0]),
    ] {
        let (n1, a1) = steps_and_allocations(mode, q, 1.0);
        let (n2, a2) = steps_and_allocations(mode, q, 2.0);
        assert!(n2 >= n1 + 900, "mode `{mode}`: {n1} and {n2} steps");
        assert!(
            a2 <= a1 + 12,
            "mode `{mode}`: {a1} allocations for {n1} steps, {a2} for {n2}"
        );
    }
}
