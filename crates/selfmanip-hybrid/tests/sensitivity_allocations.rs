//! The tangent's stages allocate nothing: the column tangent of
//! [`execution_sensitivity_columns`] keeps its stage, column and Jacobian-product buffers in
//! its evaluator, so doubling the number of steps of a segment adds no allocations beyond a
//! fixed few (the per-segment and per-event work), not one (or dozens) per stage. Counted with
//! a per-thread counting allocator, as in `stage_allocations.rs`.
mod counting;
mod systems;
use nalgebra::DMatrix;
use selfmanip_core::tangent::BodyParameter;
use selfmanip_core::{ContactMode, FlatGround};
use selfmanip_hybrid::sensitivity::{execution_sensitivity_columns, Parameter};
use selfmanip_hybrid::Termination;
use systems::{block, released, short_steps, G};

/// Steps of the single segment of a run to `t_final` and the allocations of its column
/// tangent (two state directions and the body mass).
fn steps_and_tangent_allocations(mode: &str, q: [f64; 3], t_final: f64) -> (usize, usize) {
    let model = block(G);
    let mode = ContactMode::parse_names(&model, mode).unwrap();
    let exec = released(&model, mode, &q, t_final, short_steps());
    assert_eq!(exec.termination, Termination::FinalTime);
    assert_eq!(exec.segments.len(), 1);
    let n2 = 2 * model.nq();
    let mut dirs = DMatrix::zeros(n2, 2);
    dirs[(1, 0)] = 1.0;
    dirs[(n2 - 1, 1)] = 1.0;
    let params = [Parameter::Body(BodyParameter::Mass)];
    let before = counting::allocations();
    let s = execution_sensitivity_columns(&model, &FlatGround, &exec, &dirs, &params).unwrap();
    let allocations = counting::allocations() - before;
    drop(s);
    (exec.segments[0].dense.len(), allocations)
}

#[test]
fn tangent_stages_allocate_nothing() {
    systems::assert_doubling_the_steps_adds_no_allocations(steps_and_tangent_allocations);
}
