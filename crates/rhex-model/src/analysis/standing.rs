//! Reactive standing (thesis 4.3.1) on RHex: random rough-terrain stances for the generic
//! reactive-standing simulation of [`selfmanip_sim::analysis::standing`] (Results A.1–A.3).
use super::solve_contact_pose;
use crate::{Rhex, RhexError};
use selfmanip_core::ContactMode;
use selfmanip_sim::analysis::seeded::SplitMix64;
use selfmanip_sim::analysis::standing::{sloped_plane, TwoPlaneTerrain};

/// A random rough-terrain stance for a two-pair RHex: legs in D.1 (`|θ| ≤ 30°`), each leg on
/// its own plane sloped by up to `max_slope_rad` and offset by up to 2 cm, body height and
/// pitch solved from the base constraints. Deterministic in `seed` (SplitMix64).
pub fn random_rhex_stance(
    rhex: &Rhex,
    seed: u64,
    max_slope_rad: f64,
) -> Result<(Vec<f64>, TwoPlaneTerrain, ContactMode), RhexError> {
    let model = &rhex.model;
    if model.n_joints() != 2 {
        return Err(super::bad("pairs", "random stances are for two-pair RHex"));
    }
    let mut rng = SplitMix64(seed);
    let mut uniform = |lo: f64, hi: f64| rng.uniform(lo, hi);
    let d30 = 30f64.to_radians();
    let t1 = uniform(-d30, d30);
    let t2 = uniform(-d30, d30);
    let terrain = TwoPlaneTerrain {
        split_x_m: 0.0,
        front: sloped_plane(
            0.2,
            uniform(-0.02, 0.02),
            uniform(-max_slope_rad, max_slope_rad),
        ),
        rear: sloped_plane(
            -0.2,
            uniform(-0.02, 0.02),
            uniform(-max_slope_rad, max_slope_rad),
        ),
    };
    let mode = rhex.mode("0101")?;
    let legs: Vec<usize> = mode.active().collect();
    let q = solve_contact_pose(
        model,
        &terrain,
        &legs,
        &[model.ix_z(), model.ix_phi()],
        &[t1, t2, 0.0, -0.17, 0.0],
    )?;
    Ok((q, terrain, mode))
}
