//! Prescribed motions of free massless joints (thesis 5.1.1: a massless limb out of contact
//! has no dynamics, so its motion is chosen, with bounded acceleration so that it cannot
//! teleport).
//!
//! Each motion is a smooth function of time, fixed when it starts (at a phase's start or at
//! the event that released the joint): its acceleration is continuous and piecewise
//! polynomial, so the integrator takes long steps through it — a feedback law that
//! saturates (`θ̈ = α sat(…)`) has kinks wherever it switches and costs many short steps.
//!
//! - [`JointMotion::swing`]: the velocity ramps smoothly (smoothstep) to a cruise speed,
//!   cruises, and ramps down to rest at a target angle (a smooth trapezoid);
//! - [`JointMotion::park`]: a quintic to rest at a target angle (used when the trapezoid
//!   does not fit, e.g. when the joint is already moving fast or the target is close);
//! - [`JointMotion::hold`]: rest at an angle.
//!
//! Both respect the acceleration bound `α` exactly: the smoothstep ramp from `ω₀` to `ω₁`
//! over `T` peaks at `1.5 |ω₁ − ω₀| / T`, and the quintic's duration is searched until its
//! peak acceleration (exact: the extrema of a cubic) is within `α`.
//!
//! A motion started from a state (an event's) has derivatives with respect to that start,
//! `∂(θ, θ̇, θ̈)/∂(t₀, θ₀, ω₀)`: [`StartedLaw::partials`], for a controller's event memory.

mod started;
pub use started::StartedLaw;

/// One joint's prescribed angle `θ(t)` (rad), its rate and its acceleration.
#[derive(Debug, Clone, PartialEq)]
pub struct JointMotion {
    t0: f64,
    kind: Kind,
}

#[derive(Debug, Clone, PartialEq)]
enum Kind {
    /// Rest at `end`.
    Hold { end: f64 },
    /// Smoothstep velocity ramps (up, cruise, down), one after the other, then rest at
    /// `end`.
    Ramps { pieces: [Ramp; 3], end: f64 },
    /// `θ₀ + ω₀τ + c₃τ³ + c₄τ⁴ + c₅τ⁵` for `τ ≤ T`, then rest at `end`.
    Quintic {
        theta0: f64,
        omega0: f64,
        c: [f64; 3],
        duration: f64,
        end: f64,
    },
}

/// Up to three knots of a motion ([`JointMotion::knot_slice`]): the first `.1` of `.0`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Knots([f64; 3], usize);

impl std::ops::Deref for Knots {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.0[..self.1]
    }
}

/// The velocity goes from `w0` to `w1` along the smoothstep `S(s) = 3s² − 2s³` over `duration`
/// (a cruise when `w0 = w1`), starting at angle `theta0`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Ramp {
    duration: f64,
    theta0: f64,
    w0: f64,
    w1: f64,
}

impl Ramp {
    fn eval(&self, tau: f64) -> (f64, f64, f64) {
        if self.duration <= 0.0 {
            return (self.theta0 + self.w0 * tau, self.w0, 0.0);
        }
        let s = tau / self.duration;
        let dw = self.w1 - self.w0;
        (
            self.theta0 + self.w0 * tau + dw * self.duration * (s * s * s - 0.5 * s * s * s * s),
            self.w0 + dw * s * s * (3.0 - 2.0 * s),
            dw / self.duration * 6.0 * s * (1.0 - s),
        )
    }

    fn end_angle(&self) -> f64 {
        self.eval(self.duration).0
    }
}

impl JointMotion {
    /// From `(θ₀, ω₀)` at `t0`: ramp to the cruise speed `v` (its sign is the direction of
    /// `target − θ₀`), cruise, and come to rest at `target`, never accelerating faster than
    /// `accel`. When there is no room for that (the ramps alone would pass the target, or the
    /// leg moves away from it), a [`JointMotion::park`] instead.
    pub fn swing(t0: f64, theta0: f64, omega0: f64, target: f64, speed: f64, accel: f64) -> Self {
        let dir = (target - theta0).signum();
        let v = dir * speed.abs().max(dir * omega0);
        let up = 1.5 * (v - omega0).abs() / accel;
        let down = 1.5 * v.abs() / accel;
        // each smoothstep ramp covers the mean of its end speeds times its duration
        let ramps = 0.5 * (omega0 + v) * up + 0.5 * v * down;
        let cruise = (target - theta0 - ramps) / v;
        if dir * omega0 < 0.0 || !cruise.is_finite() || cruise < 0.0 {
            return Self::park(t0, theta0, omega0, target, accel);
        }
        let mut theta = theta0;
        let pieces = [(up, omega0, v), (cruise, v, v), (down, v, 0.0)].map(|(duration, w0, w1)| {
            let r = Ramp {
                duration,
                theta0: theta,
                w0,
                w1,
            };
            theta = r.end_angle();
            r
        });
        JointMotion {
            t0,
            kind: Kind::Ramps {
                pieces,
                end: target,
            },
        }
    }

    /// From `(θ₀, ω₀)` (zero acceleration) at `t0` to rest at `target` (zero velocity and
    /// acceleration) along a quintic, in the shortest duration (to 2 %) whose peak
    /// acceleration stays within `accel`.
    pub fn park(t0: f64, theta0: f64, omega0: f64, target: f64, accel: f64) -> Self {
        let distance = (target - theta0).abs();
        // rest to rest the quintic peaks at (10/√3) d/T²; a moving start needs at least |ω₀|/α
        let mut duration = (5.77 * distance / accel)
            .sqrt()
            .max(omega0.abs() / accel)
            .max(1e-6);
        let mut kind = Self::quintic(theta0, omega0, target, duration);
        for _ in 0..200 {
            if Self::peak_accel(&kind) <= accel {
                break;
            }
            duration *= 1.02;
            kind = Self::quintic(theta0, omega0, target, duration);
        }
        JointMotion { t0, kind }
    }

    fn quintic(theta0: f64, omega0: f64, target: f64, duration: f64) -> Kind {
        // with D = θ₁ − θ₀ − ω₀T and x = c₃T³, y = c₄T⁴, z = c₅T⁵ the end conditions
        // θ(T) = θ₁, θ̇(T) = 0, θ̈(T) = 0 read x + y + z = D, 3x + 4y + 5z = −ω₀T,
        // 6x + 12y + 20z = 0, solved by x = 10D + 4ω₀T, y = −15D − 7ω₀T, z = 6D + 3ω₀T
        let t = duration;
        let d = target - theta0 - omega0 * t;
        let wt = omega0 * t;
        Kind::Quintic {
            theta0,
            omega0,
            c: [
                (10.0 * d + 4.0 * wt) / t.powi(3),
                (-15.0 * d - 7.0 * wt) / t.powi(4),
                (6.0 * d + 3.0 * wt) / t.powi(5),
            ],
            duration,
            end: target,
        }
    }

    /// The exact peak of `|θ̈|` over the quintic: `θ̈ = 6c₃τ + 12c₄τ² + 20c₅τ³` is a cubic,
    /// extreme at the ends or where `6c₃ + 24c₄τ + 60c₅τ² = 0`.
    fn peak_accel(kind: &Kind) -> f64 {
        let Kind::Quintic { c, duration, .. } = kind else {
            return 0.0;
        };
        let acc = |tau: f64| {
            (6.0 * c[0] * tau + 12.0 * c[1] * tau * tau + 20.0 * c[2] * tau.powi(3)).abs()
        };
        let (a, b, cc) = (60.0 * c[2], 24.0 * c[1], 6.0 * c[0]);
        // the real roots (at most two) of the cubic's derivative, in `roots[..n]`
        let (roots, n) = if a.abs() > 0.0 {
            let disc = b * b - 4.0 * a * cc;
            if disc >= 0.0 {
                let r = [
                    (-b + disc.sqrt()) / (2.0 * a),
                    (-b - disc.sqrt()) / (2.0 * a),
                ];
                (r, 2)
            } else {
                ([0.0; 2], 0)
            }
        } else if b != 0.0 {
            ([-cc / b, 0.0], 1)
        } else {
            ([0.0; 2], 0)
        };
        roots[..n]
            .iter()
            .copied()
            .filter(|tau| (0.0..=*duration).contains(tau))
            .chain([0.0, *duration])
            .map(acc)
            .fold(0.0, f64::max)
    }

    /// Rest at `angle` from `t0`.
    pub fn hold(t0: f64, angle: f64) -> Self {
        JointMotion {
            t0,
            kind: Kind::Hold { end: angle },
        }
    }

    /// When the motion started.
    #[inline]
    pub fn t0(&self) -> f64 {
        self.t0
    }

    /// The jerk `d³θ/dt³` at `t` (0 before `t0` and at rest after the end; on a boundary
    /// between pieces, the earlier piece's): with [`Self::eval`] it gives the motion's
    /// derivatives with respect to its start time, `∂(θ, θ̇, θ̈)/∂t0 = −(θ̇, θ̈, d³θ/dt³)`.
    pub fn jerk(&self, t: f64) -> f64 {
        if t < self.t0 {
            return 0.0;
        }
        let mut tau = t - self.t0;
        match &self.kind {
            Kind::Hold { .. } => 0.0,
            Kind::Ramps { pieces, .. } => {
                for r in pieces {
                    if tau <= r.duration {
                        if r.duration <= 0.0 {
                            return 0.0;
                        }
                        let s = tau / r.duration;
                        return (r.w1 - r.w0) / (r.duration * r.duration) * 6.0 * (1.0 - 2.0 * s);
                    }
                    tau -= r.duration;
                }
                0.0
            }
            Kind::Quintic { c, duration, .. } => {
                if tau > *duration {
                    return 0.0;
                }
                6.0 * c[0] + 24.0 * c[1] * tau + 60.0 * c[2] * tau * tau
            }
        }
    }

    /// The instants (absolute times, after `t0`) where the motion's pieces meet: its
    /// acceleration is continuous there, its jerk is not.
    pub fn knots(&self) -> Vec<f64> {
        self.knot_slice().to_vec()
    }

    /// [`Self::knots`] without allocating: the array and how many of its first entries are
    /// knots (0 for a hold, 3 for ramps, 1 for a quintic).
    pub(crate) fn knot_slice(&self) -> Knots {
        match &self.kind {
            Kind::Hold { .. } => Knots([0.0; 3], 0),
            Kind::Ramps { pieces, .. } => {
                let mut t = self.t0;
                Knots(
                    pieces.map(|r| {
                        t += r.duration;
                        t
                    }),
                    3,
                )
            }
            Kind::Quintic { duration, .. } => Knots([self.t0 + duration, 0.0, 0.0], 1),
        }
    }

    /// `(θ, θ̇, θ̈)` at `t ≥ t0` (before `t0`: the start, at its start speed).
    #[inline]
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        let mut tau = (t - self.t0).max(0.0);
        match &self.kind {
            Kind::Hold { end } => (*end, 0.0, 0.0),
            Kind::Ramps { pieces, end } => {
                for r in pieces {
                    if tau <= r.duration {
                        return r.eval(tau);
                    }
                    tau -= r.duration;
                }
                (*end, 0.0, 0.0)
            }
            Kind::Quintic {
                theta0,
                omega0,
                c,
                duration,
                end,
            } => {
                if tau > *duration {
                    return (*end, 0.0, 0.0);
                }
                let (t2, t3) = (tau * tau, tau * tau * tau);
                (
                    theta0 + omega0 * tau + c[0] * t3 + c[1] * t3 * tau + c[2] * t3 * t2,
                    omega0 + 3.0 * c[0] * t2 + 4.0 * c[1] * t3 + 5.0 * c[2] * t2 * t2,
                    6.0 * c[0] * tau + 12.0 * c[1] * t2 + 20.0 * c[2] * t3,
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The jerk against central differences of the acceleration (away from piece
    /// boundaries, where the jerk jumps), for a swing and a park.
    #[test]
    fn jerk_is_the_rate_of_acceleration() {
        for m in [
            JointMotion::swing(0.1, 0.2, 0.0, 2.6, 12.0, 400.0),
            JointMotion::park(0.1, 0.2, 3.0, -2.6, 400.0),
        ] {
            let h = 1e-7;
            for k in 1..200 {
                let t = 0.1 + 0.5 * f64::from(k) / 200.0;
                let fd = (m.eval(t + h).2 - m.eval(t - h).2) / (2.0 * h);
                let j = m.jerk(t);
                // a boundary within h: the jerk jumps there (skip it)
                if (m.jerk(t + h) - m.jerk(t - h)).abs() > 1e-3 * (1.0 + j.abs()) {
                    continue;
                }
                assert!(
                    (fd - j).abs() <= 1e-5 * (1.0 + j.abs()),
                    "t {t}: {fd} vs {j}"
                );
            }
        }
    }

    /// Rate and acceleration against central differences of the angle and rate, continuity
    /// at every piece boundary, the bound on acceleration, and the end at rest on target.
    fn check(m: &JointMotion, target: f64, accel: f64, t_end: f64) {
        let h = 1e-6;
        let n = 4000;
        let mut prev = m.eval(m.t0());
        for k in 1..=n {
            let t = m.t0() + t_end * f64::from(k) / f64::from(n);
            let (th, w, a) = m.eval(t);
            let (thp, wp, _) = m.eval(t + h);
            let (thm, wm, _) = m.eval(t - h);
            assert!((w - (thp - thm) / (2.0 * h)).abs() < 1e-5, "rate at {t}");
            assert!(
                (a - (wp - wm) / (2.0 * h)).abs() < 1e-3 * accel,
                "accel at {t}"
            );
            assert!(
                a.abs() <= accel * (1.0 + 1e-9),
                "accel {a} over {accel} at {t}"
            );
            // continuous: no jump between neighbouring samples beyond what the bounds allow
            let dt = t_end / f64::from(n);
            assert!((th - prev.0).abs() <= prev.1.abs() * dt + accel * dt * dt + 1e-12);
            assert!((w - prev.1).abs() <= accel * dt * (1.0 + 1e-9));
            prev = (th, w, a);
        }
        let (th, w, a) = m.eval(m.t0() + 1e3);
        assert!((th - target).abs() < 1e-12 && w == 0.0 && a == 0.0);
    }

    #[test]
    fn swing_from_rest_is_a_smooth_trapezoid() {
        let m = JointMotion::swing(0.2, -0.8, 0.0, 2.6, 12.0, 400.0);
        assert!(matches!(m.kind, Kind::Ramps { .. }));
        // cruise speed reached after the ramp 1.5 v/α = 0.045 s
        let (_, w, _) = m.eval(0.2 + 0.05);
        assert!((w - 12.0).abs() < 1e-12);
        check(&m, 2.6, 400.0, 0.6);
    }

    #[test]
    fn swing_keeps_a_faster_start_speed() {
        let m = JointMotion::swing(0.0, 0.3, 20.0, 2.6, 12.0, 400.0);
        // 20 rad/s over 2.3 rad with 0.075 s to brake: the trapezoid fits, cruising at 20
        let (_, w, _) = m.eval(0.03);
        assert!((w - 20.0).abs() < 1e-12);
        check(&m, 2.6, 400.0, 0.4);
    }

    #[test]
    fn park_falls_back_on_a_quintic_and_turns_round() {
        // moving away from the target: a quintic that brakes, turns and arrives at rest
        let m = JointMotion::swing(1.0, 0.5, -15.0, 2.6, 12.0, 400.0);
        assert!(matches!(m.kind, Kind::Quintic { .. }));
        check(&m, 2.6, 400.0, 1.0);
        let p = JointMotion::park(0.0, -0.2, 3.0, -2.6, 400.0);
        check(&p, -2.6, 400.0, 1.0);
    }
}
