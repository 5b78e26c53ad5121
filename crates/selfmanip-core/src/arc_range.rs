//! The range of normal angles of a contact arc, in the form the contact test uses: a
//! constant of the model, kept by [`crate::kinematics::Kinematics`] and read by
//! [`crate::contact`].
use nalgebra::Vector2;

/// An arc's range of normal angles `[α₀, α₁]` in the form
/// [`crate::contact::contact_geometry`] tests against: the unit normals `(sin α, cos α)` at
/// its ends and the pseudo-angle of its width `α₁ − α₀`. A constant of the model, which
/// [`crate::kinematics::Kinematics`] keeps for each arc (recomputing it only when the range
/// changes) so that the test in every evaluation needs no `atan2`, `sin` or `cos`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ArcRange {
    pub range: [f64; 2],
    pub ends: [Vector2<f64>; 2],
    width: f64,
}

impl ArcRange {
    pub(crate) fn new(range: [f64; 2]) -> Self {
        let unit = |a: f64| {
            let (s, c) = a.sin_cos();
            Vector2::new(s, c)
        };
        let w = range[1] - range[0];
        ArcRange {
            range,
            ends: [unit(range[0]), unit(range[1])],
            width: if w >= std::f64::consts::TAU {
                f64::INFINITY
            } else {
                pseudo_angle(w.cos(), w.sin())
            },
        }
    }

    /// Whether the unit direction `d = (sin α, cos α)` lies on the arc, i.e. the
    /// counter-clockwise distance `(α − α₀) mod 2π` is at most `α₁ − α₀`.
    pub(crate) fn contains(&self, d: Vector2<f64>) -> bool {
        let u0 = self.ends[0];
        // (cos, sin) of α − α₀
        pseudo_angle(d.dot(&u0), d.x * u0.y - d.y * u0.x) <= self.width
    }
}

/// A stand-in for the angle `θ ∈ [0, 2π)` of `(cos θ, sin θ)` that is monotone in `θ` and
/// needs no `atan2`: `1 − cos θ ∈ [0, 2]` on the upper half turn, `3 + cos θ ∈ (2, 4)` on the
/// lower.
fn pseudo_angle(c: f64, s: f64) -> f64 {
    if s >= 0.0 {
        1.0 - c
    } else {
        3.0 + c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The definition [`ArcRange::contains`] replaces: `(α − α₀) mod 2π ≤ α₁ − α₀` with
    /// `α = atan2(d_x, d_z)`.
    fn in_range_by_angle(d: Vector2<f64>, range: [f64; 2]) -> bool {
        let from_start = (d.x.atan2(d.y) - range[0]).rem_euclid(std::f64::consts::TAU);
        from_start <= range[1] - range[0]
    }

    #[test]
    fn arc_range_agrees_with_the_angle_test() {
        let mut r = ChaCha8Rng::seed_from_u64(3);
        let pi = std::f64::consts::PI;
        let mut ranges = vec![[-pi, 0.0], [0.0, pi], [-0.3, 0.4], [1.0, 1.0 + 2.0 * pi]];
        ranges.extend((0..200).map(|_| {
            let a0 = r.gen_range(-4.0..4.0);
            [a0, a0 + r.gen_range(0.01..2.0 * pi)]
        }));
        for range in ranges {
            let arc = ArcRange::new(range);
            for _ in 0..200 {
                let a: f64 = r.gen_range(-pi..pi);
                // away from the ends, where rounding may decide either way
                let near_end = range.iter().any(|&e| {
                    let g = (a - e).rem_euclid(2.0 * pi);
                    g < 1e-9 || g > 2.0 * pi - 1e-9
                });
                if near_end {
                    continue;
                }
                let d = Vector2::new(a.sin(), a.cos());
                assert_eq!(
                    arc.contains(d),
                    in_range_by_angle(d, range),
                    "{a} in {range:?}"
                );
            }
        }
    }
}
