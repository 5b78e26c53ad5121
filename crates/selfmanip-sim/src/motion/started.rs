//! The derivatives of a prescribed motion with respect to the state it started from, for
//! the sensitivities of a behaviour that starts motions at events (its **event memory**,
//! `selfmanip_hybrid::Controller::memory_partials`).
//!
//! A motion started at an event `k` from `(θ₀, ω₀) = (q_k[j], q̇_k⁺[j])` at `t₀ = t_k` is
//! `θ*(t) = Θ(t − t₀; θ₀, ω₀)`, so
//!
//! ```text
//! ∂(θ*, ω*, α*)/∂t_k = −(ω*, α*, d³θ*/dt³)          (JointMotion::jerk)
//! ∂(θ*, ω*, α*)/∂(θ₀, ω₀)                           (forward-mode derivative of the construction)
//! ```
//!
//! The second line differentiates [`JointMotion::swing`] / [`JointMotion::park`] as built
//! (the same branches: ramps or the quintic, the cruise speed `max(speed, |ω₀|)`, the
//! quintic's duration `T₀ 1.02ⁿ` with `n` the search's count held fixed) by dual numbers:
//! each quantity carries its value and its partials over `(θ₀, ω₀)`. The branches are those
//! of the motion at the values given; at a branch switch the derivative is one-sided.
use super::{JointMotion, Kind};

/// How many partials a [`D`] carries: over `(θ₀, ω₀, speed, accel, target)`.
const N: usize = 5;

/// A value with its partials over `(θ₀, ω₀)` and the motion's numbers `(speed, accel,
/// target)`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct D {
    v: f64,
    d: [f64; N],
}

impl D {
    fn c(v: f64) -> D {
        D { v, d: [0.0; N] }
    }
    fn var(v: f64, i: usize) -> D {
        let mut d = [0.0; N];
        d[i] = 1.0;
        D { v, d }
    }
    fn map(self, f: f64, df: f64) -> D {
        D {
            v: f,
            d: self.d.map(|x| df * x),
        }
    }
    fn abs(self) -> D {
        if self.v < 0.0 {
            -self
        } else {
            self
        }
    }
    fn sqrt(self) -> D {
        let s = self.v.sqrt();
        self.map(s, 0.5 / s)
    }
}

impl std::ops::Add for D {
    type Output = D;
    fn add(self, o: D) -> D {
        D {
            v: self.v + o.v,
            d: std::array::from_fn(|k| self.d[k] + o.d[k]),
        }
    }
}
impl std::ops::Sub for D {
    type Output = D;
    fn sub(self, o: D) -> D {
        self + (-o)
    }
}
impl std::ops::Neg for D {
    type Output = D;
    fn neg(self) -> D {
        D {
            v: -self.v,
            d: self.d.map(|x| -x),
        }
    }
}
impl std::ops::Mul for D {
    type Output = D;
    #[allow(clippy::suspicious_arithmetic_impl)] // the product rule
    fn mul(self, o: D) -> D {
        D {
            v: self.v * o.v,
            d: std::array::from_fn(|k| self.d[k] * o.v + self.v * o.d[k]),
        }
    }
}
impl std::ops::Div for D {
    type Output = D;
    #[allow(clippy::suspicious_arithmetic_impl)] // the quotient rule
    fn div(self, o: D) -> D {
        let v = self.v / o.v;
        D {
            v,
            d: std::array::from_fn(|k| (self.d[k] - v * o.d[k]) / o.v),
        }
    }
}
impl std::ops::Mul<D> for f64 {
    type Output = D;
    fn mul(self, o: D) -> D {
        D::c(self) * o
    }
}

/// The law of a motion started at an event, its numbers known (constants of the behaviour).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StartedLaw {
    Swing { target: f64, speed: f64, accel: f64 },
    Park { target: f64, accel: f64 },
}

impl StartedLaw {
    /// The motion itself (as `MotionLaw::start` builds it from constant numbers).
    #[cfg(test)]
    pub(crate) fn motion(&self, t0: f64, theta0: f64, omega0: f64) -> JointMotion {
        match *self {
            StartedLaw::Swing {
                target,
                speed,
                accel,
            } => JointMotion::swing(t0, theta0, omega0, target, speed, accel),
            StartedLaw::Park { target, accel } => {
                JointMotion::park(t0, theta0, omega0, target, accel)
            }
        }
    }

    /// `∂(θ*, ω*, α*)/∂(t₀, θ₀, ω₀, speed, accel, target)` at `t` of `motion` (built by
    /// [`Self::motion`] from `(t₀, θ₀, ω₀)`): rows `θ*, ω*, α*`, columns the start, the
    /// swing's `speed` (0 for a park), the law's `accel` and its target.
    pub fn partials_full(
        &self,
        motion: &JointMotion,
        theta0: f64,
        omega0: f64,
        t: f64,
    ) -> [[f64; 6]; 3] {
        let t0 = motion.t0();
        let (_, w, a) = motion.eval(t);
        let jerk = motion.jerk(t);
        let r = self.reference_dual(motion, theta0, omega0, t);
        let mut out = [[0.0; 6]; 3];
        for (i, (dt, x)) in [(-w, r[0]), (-a, r[1]), (-jerk, r[2])]
            .into_iter()
            .enumerate()
        {
            // before the start the motion is its start (at its start speed): no t₀ term
            out[i] = [
                if t < t0 { 0.0 } else { dt },
                x.d[0],
                x.d[1],
                x.d[2],
                x.d[3],
                x.d[4],
            ];
        }
        out
    }

    /// The partials of each knot of `motion` ([`JointMotion::knots`], in order) over `(t₀,
    /// θ₀, ω₀, speed, accel, target)`: a knot is `t₀` plus the durations of the pieces
    /// before it, on the branches the motion took.
    pub fn knot_partials(&self, motion: &JointMotion, theta0: f64, omega0: f64) -> Vec<[f64; 6]> {
        let mut t = D::c(0.0);
        self.shape(motion, theta0, omega0)
            .durations()
            .iter()
            .map(|&dur| {
                t = t + dur;
                [1.0, t.d[0], t.d[1], t.d[2], t.d[3], t.d[4]]
            })
            .collect()
    }

    /// The law's own numbers `(speed, accel, target)` (a park's speed: 0).
    fn numbers(&self) -> (f64, f64, f64) {
        match *self {
            StartedLaw::Swing {
                target,
                speed,
                accel,
            } => (speed, accel, target),
            StartedLaw::Park { target, accel } => (0.0, accel, target),
        }
    }

    /// The law's numbers as dual numbers: `(θ₀, ω₀, speed, accel, target)`.
    fn inputs(&self, theta0: f64, omega0: f64) -> [D; 5] {
        let (speed, accel, target) = self.numbers();
        [
            D::var(theta0, 0),
            D::var(omega0, 1),
            D::var(speed, 2),
            D::var(accel, 3),
            D::var(target, 4),
        ]
    }

    /// The durations of `motion`'s pieces as dual numbers (the ramps' up, cruise, down; the
    /// quintic's one), on the branches the motion took, and for ramps the cruise speed `v`.
    /// Their values are the motion's own durations, their partials the formula's: formed
    /// here the values can round a few ulps otherwise, and [`Self::reference_dual`], which
    /// picks its piece by them, would take the previous piece one ulp past a knot, where
    /// the first stage of the tangent's next step sits (`docs/sensitivity.md`, "Time events").
    fn shape(&self, motion: &JointMotion, theta0: f64, omega0: f64) -> Shape {
        let [th0, w0, speed, accel, target] = self.inputs(theta0, omega0);
        let knots = motion.knot_slice();
        if matches!(self, StartedLaw::Swing { .. }) && knots.len() == 3 {
            // the ramps of JointMotion::swing
            let dir = (target.v - theta0).signum();
            let v = if speed.v.abs() >= dir * omega0 {
                dir * speed.abs()
            } else {
                w0
            };
            let up = (D::c(1.5) / accel) * (v - w0).abs();
            let down = (D::c(1.5) / accel) * v.abs();
            let ramps = 0.5 * ((w0 + v) * up) + 0.5 * (v * down);
            let cruise = (target - th0 - ramps) / v;
            let mut durations = [up, cruise, down];
            if let Kind::Ramps { pieces, .. } = &motion.kind {
                for (d, r) in durations.iter_mut().zip(pieces) {
                    d.v = r.duration;
                }
            }
            return Shape::Ramps(durations, v);
        }
        if knots.is_empty() {
            return Shape::Hold;
        }
        // the quintic of JointMotion::park: T = T₀ 1.02ⁿ
        let distance = (target - th0).abs();
        let mut dur = (5.77 * distance / accel).sqrt();
        let by_speed = w0.abs() / accel;
        if by_speed.v > dur.v {
            dur = by_speed;
        }
        if 1e-6 > dur.v {
            dur = D::c(1e-6);
        }
        let total = knots[0] - motion.t0();
        while dur.v * 1.02 <= total * (1.0 + 1e-9) && dur.v < total {
            dur = 1.02 * dur;
        }
        if let Kind::Quintic { duration, .. } = motion.kind {
            dur.v = duration;
        }
        Shape::Quintic([dur])
    }

    /// `(θ*, ω*, α*)` at `t` with their partials over `(θ₀, ω₀, speed, accel, target)`, on
    /// the branches `motion` took.
    fn reference_dual(&self, motion: &JointMotion, theta0: f64, omega0: f64, t: f64) -> [D; 3] {
        let [th0, w0, _, _, target] = self.inputs(theta0, omega0);
        let tau = (t - motion.t0()).max(0.0);
        let shape = self.shape(motion, theta0, omega0);
        if let Shape::Ramps([up, cruise, down], v) = shape {
            let mut theta = th0;
            let mut tau = D::c(tau);
            for (dur, a, b) in [(up, w0, v), (cruise, v, v), (down, v, D::c(0.0))] {
                if tau.v <= dur.v {
                    return ramp(dur, theta, a, b, tau);
                }
                theta = ramp(dur, theta, a, b, dur)[0];
                tau = tau - dur;
            }
            return [target, D::c(0.0), D::c(0.0)];
        }
        let Some(&dur) = shape.durations().first() else {
            // a hold: at rest at its end from the start
            return [target, D::c(0.0), D::c(0.0)];
        };
        if tau > dur.v {
            return [target, D::c(0.0), D::c(0.0)];
        }
        let d = target - th0 - w0 * dur;
        let wt = w0 * dur;
        let t3 = dur * dur * dur;
        let c3 = (10.0 * d + 4.0 * wt) / t3;
        let c4 = (-15.0 * d - 7.0 * wt) / (t3 * dur);
        let c5 = (6.0 * d + 3.0 * wt) / (t3 * dur * dur);
        let tau = D::c(tau);
        let (s2, s3) = (tau * tau, tau * tau * tau);
        [
            th0 + w0 * tau + c3 * s3 + c4 * s3 * tau + c5 * s3 * s2,
            w0 + 3.0 * c3 * s2 + 4.0 * c4 * s3 + 5.0 * c5 * s2 * s2,
            6.0 * c3 * tau + 12.0 * c4 * s2 + 20.0 * c5 * s3,
        ]
    }
}

/// The pieces of a motion as dual numbers ([`StartedLaw::shape`]).
#[derive(Debug, Clone, Copy)]
enum Shape {
    /// At rest from the start.
    Hold,
    /// The ramps' durations (up, cruise, down) and the cruise speed.
    Ramps([D; 3], D),
    /// The quintic's duration.
    Quintic([D; 1]),
}

impl Shape {
    /// The pieces' durations, in order.
    fn durations(&self) -> &[D] {
        match self {
            Shape::Hold => &[],
            Shape::Ramps(d, _) => d,
            Shape::Quintic(d) => d,
        }
    }
}

/// A smoothstep velocity ramp from `w0` to `w1` over `dur` from `theta0`, at `tau`
/// (`JointMotion`'s ramps).
fn ramp(dur: D, theta0: D, w0: D, w1: D, tau: D) -> [D; 3] {
    if dur.v <= 0.0 {
        return [theta0 + w0 * tau, w0, D::c(0.0)];
    }
    let s = tau / dur;
    let dw = w1 - w0;
    let (s2, s3) = (s * s, s * s * s);
    [
        theta0 + w0 * tau + dw * dur * (s3 - 0.5 * (s3 * s)),
        w0 + dw * s2 * (D::c(3.0) - 2.0 * s),
        dw / dur * (6.0 * (s * (D::c(1.0) - s))),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The worst of `|exact[row] − fd| / (floor + |fd|)` over the rows (angle, rate,
    /// acceleration), `fd` the central difference `(ea − eb) / 2h` of a motion's values
    /// built at `±h`, each asserted below `tol` (`what`: the case, for the message).
    fn worst_error_against_fd(
        exact: [f64; 3],
        (ea, eb): ((f64, f64, f64), (f64, f64, f64)),
        h: f64,
        (floor, tol): (f64, f64),
        what: impl Fn() -> String,
    ) -> f64 {
        let fd = [ea.0 - eb.0, ea.1 - eb.1, ea.2 - eb.2].map(|d| d / (2.0 * h));
        let mut worst: f64 = 0.0;
        for row in 0..3 {
            let err = (exact[row] - fd[row]).abs() / (floor + fd[row].abs());
            worst = worst.max(err);
            assert!(
                err < tol,
                "{} row {row}: {} vs {}",
                what(),
                exact[row],
                fd[row]
            );
        }
        worst
    }

    /// Swings (ramps, a cruise at the start speed, one that falls back on a park) and a
    /// park, with their starts `(θ₀, ω₀)`.
    fn sample_laws() -> [(StartedLaw, f64, f64); 5] {
        [
            (
                StartedLaw::Swing {
                    target: 1.2,
                    speed: 15.0,
                    accel: 600.0,
                },
                0.3,
                -2.0,
            ),
            (
                StartedLaw::Swing {
                    target: -1.0,
                    speed: 15.0,
                    accel: 600.0,
                },
                0.4,
                -20.0,
            ),
            (
                StartedLaw::Swing {
                    target: 1.0,
                    speed: 12.0,
                    accel: 400.0,
                },
                0.9,
                3.0,
            ),
            (
                StartedLaw::Park {
                    target: -0.6,
                    accel: 400.0,
                },
                0.2,
                3.0,
            ),
            (
                StartedLaw::Swing {
                    target: 0.5,
                    speed: 15.0,
                    accel: 600.0,
                },
                0.45,
                -4.0,
            ),
        ]
    }

    /// The dual-number construction reproduces the motion (its values agree with
    /// `JointMotion::eval` to round-off), and its partials over `(t₀, θ₀, ω₀)` agree with
    /// central differences of whole motions built from perturbed starts (an independent
    /// route: the production constructor, not the dual one), for swings (ramps, a cruise at
    /// the start speed) and parks (a quintic after the duration search), at times inside
    /// every piece.
    #[test]
    fn motion_partials_match_central_differences() {
        let laws = sample_laws();
        let t0 = 0.1;
        let mut worst: f64 = 0.0;
        for (law, th, w) in laws {
            let m = law.motion(t0, th, w);
            let end = m.knots().last().copied().unwrap_or(t0) + 0.01;
            for i in 1..40 {
                let t = t0 + (end - t0) * i as f64 / 40.0;
                if m.knots().iter().any(|k| (k - t).abs() < 1e-4) {
                    continue;
                }
                let r = law.reference_dual(&m, th, w, t);
                let e = m.eval(t);
                for (x, y) in r.iter().zip([e.0, e.1, e.2]) {
                    assert!(
                        (x.v - y).abs() <= 1e-11 * (1.0 + y.abs()),
                        "{law:?} {t}: {} {y}",
                        x.v
                    );
                }
                let p = law.partials_full(&m, th, w, t);
                let h = 1e-6;
                for c in 0..3 {
                    let mut a = [t0, th, w];
                    let mut b = a;
                    a[c] += h;
                    b[c] -= h;
                    let (ea, eb) = (
                        law.motion(a[0], a[1], a[2]).eval(t),
                        law.motion(b[0], b[1], b[2]).eval(t),
                    );
                    let exact = [p[0][c], p[1][c], p[2][c]];
                    let what = || format!("{law:?} t {t} col {c}");
                    let err = worst_error_against_fd(exact, (ea, eb), h, (1.0, 1e-5), what);
                    worst = worst.max(err);
                }
            }
        }
        eprintln!("worst relative error of the motion partials: {worst:e}");
        // the bounds: speed and acceleration, against motions built with them perturbed
        let mut worst: f64 = 0.0;
        for (law, th, w) in laws {
            let m = law.motion(t0, th, w);
            let end = m.knots().last().copied().unwrap_or(t0) + 0.01;
            let with = |ds: f64, da: f64| match law {
                StartedLaw::Swing {
                    target,
                    speed,
                    accel,
                } => StartedLaw::Swing {
                    target,
                    speed: speed + ds,
                    accel: accel + da,
                },
                StartedLaw::Park { target, accel } => StartedLaw::Park {
                    target,
                    accel: accel + da,
                },
            };
            for i in 1..40 {
                let t = t0 + (end - t0) * i as f64 / 40.0;
                if m.knots().iter().any(|k| (k - t).abs() < 1e-4) {
                    continue;
                }
                let p = law.partials_full(&m, th, w, t);
                for (c, (ds, da)) in [(3, (1e-6, 0.0)), (4, (0.0, 1e-4))] {
                    let h = ds + da;
                    let ea = with(ds, da).motion(t0, th, w).eval(t);
                    let eb = with(-ds, -da).motion(t0, th, w).eval(t);
                    let exact = [p[0][c], p[1][c], p[2][c]];
                    let what = || format!("{law:?} t {t} col {c}");
                    let err = worst_error_against_fd(exact, (ea, eb), h, (1e-3, 1e-4), what);
                    worst = worst.max(err);
                }
            }
        }
        eprintln!("worst relative error of the bounds' partials: {worst:e}");
    }

    /// The partials over the target, and those of the knots over every number, against
    /// central differences of motions built with that number perturbed (the production
    /// constructor), for ramps and quintics.
    #[test]
    fn target_and_knot_partials_match_central_differences() {
        let laws = sample_laws();
        let t0 = 0.1;
        // (t0, θ0, ω0, speed, accel, target) perturbed by h in column c
        let build = |law: StartedLaw, x: [f64; 6]| {
            let l = match law {
                StartedLaw::Swing { .. } => StartedLaw::Swing {
                    target: x[5],
                    speed: x[3],
                    accel: x[4],
                },
                StartedLaw::Park { .. } => StartedLaw::Park {
                    target: x[5],
                    accel: x[4],
                },
            };
            l.motion(x[0], x[1], x[2])
        };
        let mut worst: f64 = 0.0;
        for (law, th, w) in laws {
            let (speed, accel, target) = law.numbers();
            let x0 = [t0, th, w, speed, accel, target];
            let m = law.motion(t0, th, w);
            let kp = law.knot_partials(&m, th, w);
            assert_eq!(kp.len(), m.knots().len());
            let end = m.knots().last().copied().unwrap_or(t0) + 0.01;
            for c in 0..6 {
                let h = 1e-6 * (1.0 + x0[c].abs());
                let (mut a, mut b) = (x0, x0);
                a[c] += h;
                b[c] -= h;
                let (ma, mb) = (build(law, a), build(law, b));
                for (k, (ka, kb)) in ma.knots().iter().zip(mb.knots()).enumerate() {
                    let fd = (ka - kb) / (2.0 * h);
                    let err = (kp[k][c] - fd).abs() / (1e-3 + fd.abs());
                    worst = worst.max(err);
                    assert!(err < 1e-5, "{law:?} knot {k} col {c}: {} vs {fd}", kp[k][c]);
                }
                if c != 5 {
                    continue;
                }
                for i in 1..40 {
                    let t = t0 + (end - t0) * i as f64 / 40.0;
                    if m.knots().iter().any(|k| (k - t).abs() < 1e-4) {
                        continue;
                    }
                    let p = law.partials_full(&m, th, w, t);
                    let (ea, eb) = (ma.eval(t), mb.eval(t));
                    let exact = [p[0][5], p[1][5], p[2][5]];
                    let what = || format!("{law:?} t {t}");
                    let err = worst_error_against_fd(exact, (ea, eb), h, (1e-3, 1e-4), what);
                    worst = worst.max(err);
                }
            }
        }
        eprintln!("worst relative error of the target and knot partials: {worst:e}");
    }
}
