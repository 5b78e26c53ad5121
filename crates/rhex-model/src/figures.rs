//! The leaps of the thesis's chapter-5 figures, as configurations of this model (shared by
//! the examples `fig5_*` and the tests). Chapter 5 gives few parameters; where a choice was
//! made here it says how, and where the model cannot reproduce a figure it says why.
use crate::leap::{LeapConfig, Push, Strategy};
use crate::params::LegPair;
use crate::terrain::TerrainSpec;

/// Fig. 5.1's own settings (its footnote 1): (+,+) with the middle and rear pairs, 20 A,
/// δt = 0.03 s, the middle legs started 0.01 s before the rear ones, legs lifted off
/// rotated up out of the way — here onto the 20 cm ledge of [`fig5_1_ledge_20cm`]. In this
/// model the leap pitches nose-up past vertical before its apex (about 110°) and meets the
/// ledge's face: the thesis's keyframes are not reproduced with these settings.
pub fn fig5_1_settings() -> LeapConfig {
    LeapConfig {
        strategy: Strategy::new(Push::Plus, Push::Plus),
        pairs: Some([LegPair::Middle, LegPair::Rear]),
        t2_s: 0.01,
        ..fig5_1_ledge_20cm()
    }
}

/// A leap onto a 20 cm ledge (Fig. 5.1) that this model does make: strategy (−,+) with the
/// front and rear pairs, the rear motor started 0.2 s before the front one, the ledge's edge
/// 0.55 m ahead of the body's start, run to 1.2 s. The rear leg tips the robot forward onto
/// its nose; the front leg, pushing backward on its toe, throws it up onto the ledge, where
/// it lands on its body and slides on (the body ends are frictionless, Assumption C.3).
/// Found by a sweep over t2 and the edge's distance; it lands for edges 0.5–0.6 m ahead and
/// t2 from −0.22 to −0.19 s.
pub fn fig5_1_ledge_20cm() -> LeapConfig {
    LeapConfig {
        strategy: Strategy::new(Push::Minus, Push::Plus),
        pairs: Some([LegPair::Front, LegPair::Rear]),
        t2_s: -0.2,
        terrain: TerrainSpec::Ledge {
            height_m: 0.2,
            distance_m: 0.55,
        },
        stop_at_apex: false,
        t_final_s: 1.2,
        ..LeapConfig::default()
    }
}

/// Fig. 5.8's near-vertical leap with toe slip: (+,−) — the front leg pushes forward, the
/// rear leg backward, toes pushing against each other until they slip (μ = 1.8 front, 2.5
/// rear) — with the front and rear pairs (chapter 3's choice for (+,−)), 20 A, δt = 0.03 s,
/// and the rear motor started 0.04 s before the front one. The thesis gives no timing; this
/// is the most level apex of a sweep over t2. The body centre rises about 38 cm.
pub fn fig5_8_vertical_leap() -> LeapConfig {
    LeapConfig {
        strategy: Strategy::new(Push::Plus, Push::Minus),
        pairs: Some([LegPair::Front, LegPair::Rear]),
        t2_s: -0.04,
        ..LeapConfig::default()
    }
}
