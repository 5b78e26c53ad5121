//! What the dynamics benchmarks (`kkt.rs`, `pipeline.rs`) share: the robot and the state
//! they evaluate it at, so that their per-stage and whole-evaluation times add up.
use selfmanip::rhex::Rhex;

/// The chapter-4 RHex (massless half-circle legs) and the state `(q, q̇)` of the dynamics
/// benchmarks (legs at −0.4 and 0.5 rad, the body 0.16 m up and pitched 0.05 rad, every
/// coordinate moving).
pub fn chapter4_rhex_at_bench_state() -> (Rhex, [f64; 5], [f64; 5]) {
    let q = [-0.4, 0.5, 0.0, -0.16, 0.05];
    let qd = [2.0, 1.5, 0.3, -0.1, 0.2];
    (Rhex::chapter4(), q, qd)
}
