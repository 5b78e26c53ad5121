//! A disk passing over the convex edge of a step, against closed forms. On the edge the
//! contact is the corner point, the contact normal turns with the disk's centre (its rate
//! enters `Ȧ`), and the centre moves on a circle of radius `r` about the edge:
//!
//! - frictionless, sliding over from the top at speed `v₀`, it is a point mass on a circle
//!   (the normal force passes through the centre): it leaves the edge where
//!   `g cos θ = v²/r` with `v² = v₀² + 2 g r (1 − cos θ)`, i.e. `cos θ* = (v₀²/(g r) + 2)/3`
//!   (the particle leaving a sphere), at the time `x₀/v₀ + ∫₀^θ* r dθ / v(θ)`;
//! - rolling over it with friction, it pivots on the edge with `I_p = I + m r²`:
//!   `I_p ω² = I_p ω₀² + 2 m g r (1 − cos θ)`, normal force `m (g cos θ − r ω²)`, tangential
//!   force `m g sin θ · I/I_p`, so it slips where `(I/I_p) sin θ = μ (cos θ − r ω²/g)`.
//!
//! Passing from the top onto the edge is no terrain discontinuity: the gap and the normal are
//! continuous there.
use nalgebra::Vector2;
use selfmanip_core::{GroundPlane, Model, RobotDescription, Terrain};
use selfmanip_hybrid::{EventKind, Termination};
mod systems;
use systems::{coast, sliding, sticking};

const G: f64 = 9.81;
const R: f64 = 0.05;
const M: f64 = 2.0;
/// A uniform disk.
const I: f64 = 0.5 * M * R * R;

/// A level top at world `z = 0` for `x ≤ 0`, a sheer face at `x = 0` down to a ground 10 m
/// below: the edge is the convex corner at the origin.
struct Step;

impl Terrain for Step {
    fn plane_under(&self, x_m: f64) -> GroundPlane {
        GroundPlane::level(if x_m <= 0.0 { 0.0 } else { 10.0 })
    }
    fn face_near(&self, p: Vector2<f64>) -> Option<GroundPlane> {
        (p.y > 0.0 && p.x > 0.0).then_some(GroundPlane {
            point_m: [0.0, 0.0],
            normal_into_ground: [-1.0, 0.0],
        })
    }
    fn corner_near(&self, c: Vector2<f64>) -> Option<Vector2<f64>> {
        (c.y <= 0.0 && c.x > 0.0).then(Vector2::zeros)
    }
}

fn disk(friction: &str) -> Model {
    let text = format!(
        r#"
name = "disk"
gravity_m_s2 = {G}
legs = []
[body]
mass_kg = {M}
inertia_kg_m2 = {I}
[[contacts]]
name = "rim"
shape = {{ kind = "circle", center_m = [0.0, 0.0], radius_m = {R} }}
friction = {friction}
"#
    );
    RobotDescription::from_toml_str(&text)
        .unwrap()
        .build()
        .unwrap()
}

/// Angle of the centre from straight above the edge (z down).
fn theta(q: &[f64]) -> f64 {
    q[0].atan2(-q[1])
}

/// `∫₀^θ f` by Simpson's rule on `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, theta: f64, n: usize) -> f64 {
    let h = theta / n as f64;
    let inner: f64 = (1..n)
        .map(|i| f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
        .sum();
    h / 3.0 * (f(0.0) + inner + f(theta))
}

#[test]
fn frictionless_disk_leaves_the_edge_where_a_particle_leaves_a_sphere() {
    let model = disk(r#"{ kind = "sliding" }"#);
    let (x0, v0) = (0.1, 0.3);
    let exec = coast(
        &model,
        &Step,
        sliding(&[0]),
        (&[-x0, -R, 0.0], &[v0, 0.0, 0.0]),
        0.6,
    );
    assert!(
        !matches!(exec.termination, Termination::TerrainDiscontinuity { .. }),
        "{:?}",
        exec.termination
    );
    let e = &exec.events[0];
    assert_eq!(e.kind, EventKind::Liftoff, "{:?}", exec.events);
    let cos_star = (v0 * v0 / (G * R) + 2.0) / 3.0;
    let th = theta(&e.q);
    assert!(
        (th.cos() - cos_star).abs() < 1e-6,
        "{} vs {cos_star}",
        th.cos()
    );
    // on the edge the centre stays at r from it (the corner's gap is zero)
    assert!((e.q[0].hypot(e.q[1]) - R).abs() < 1e-9);
    // energy: the frictionless edge does no work
    let v2 = e.qd_after[0].powi(2) + e.qd_after[1].powi(2);
    assert!((v2 - (v0 * v0 + 2.0 * G * R * (1.0 - th.cos()))).abs() < 1e-8);
    // the time: the slide along the top, then the arc round the edge
    let speed = |t: f64| (v0 * v0 + 2.0 * G * R * (1.0 - t.cos())).sqrt();
    let t_star = x0 / v0 + simpson(|t| R / speed(t), cos_star.acos(), 2000);
    assert!((e.t - t_star).abs() < 1e-7, "{} vs {t_star}", e.t);
}

#[test]
fn rolling_disk_pivots_on_the_edge_and_slips_where_its_cone_runs_out() {
    let mu = 3.0;
    let model = disk(&format!(r#"{{ kind = "sticking", mu = {mu} }}"#));
    let (x0, v0) = (0.05, 0.2);
    // rolling: the rim point at the ground, R below the centre, is at rest
    let omega0 = -v0 / R;
    let exec = coast(
        &model,
        &Step,
        sticking(&[0]),
        (&[-x0, -R, 0.0], &[v0, 0.0, omega0]),
        0.6,
    );
    let e = &exec.events[0];
    assert_eq!(e.kind, EventKind::Slip, "{:?}", exec.events);
    let ip = I + M * R * R;
    let omega2 = |t: f64| omega0 * omega0 + 2.0 * M * G * R * (1.0 - t.cos()) / ip;
    // the slip angle: (I/I_p) sin θ = μ (cos θ − r ω²/g), by bisection
    let cone = |t: f64| I / ip * t.sin() - mu * (t.cos() - R * omega2(t) / G);
    let (mut lo, mut hi) = (0.0, 1.5);
    assert!(cone(lo) < 0.0 && cone(hi) > 0.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if cone(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let th = theta(&e.q);
    assert!((th - lo).abs() < 1e-6, "{th} vs {lo}");
    // pivoting: the centre moves on the circle at r ω, and energy is conserved
    let w = e.qd_after[2];
    assert!((e.qd_after[0].hypot(e.qd_after[1]) - R * w.abs()).abs() < 1e-8);
    assert!((w * w - omega2(th)).abs() < 1e-6 * omega2(th), "{w}");
}
