//! Painlevé ends resolved as jams (`selfmanip_hybrid::jam`): an impact without collision
//! into the contact's stick, a plastic impact with both rows (thesis (5.10)/(5.52)).
//!
//! Painlevé's rod (uniform, mass `m`, half-length `l`, `I = m l²/3`, coordinates
//! `q = (x, z, φ)`, z down), its end at `p = (x − l cos φ, z + l sin φ)` on level ground at
//! angle `θ = φ`, derived here by hand: `A = ∂p/∂q = [[1, 0, l s], [0, 1, l c]]`
//! (`s, c = sin θ, cos θ`; rows tangential, normal), and with `M = diag(m, m, I)`
//!
//! ```text
//! m A M⁻¹ Aᵀ = [[1 + 3s², 3sc], [3sc, 1 + 3c²]],   det = 4
//! P = −(A M⁻¹ Aᵀ)⁻¹ A q̇⁻ = −(m v / 4) (1 + 3c², −3sc)    (A q̇⁻ = (v, 0): sliding at v)
//! ΔT = ½ (A q̇⁻)ᵀ (A M⁻¹ Aᵀ)⁻¹ A q̇⁻ = m v² (1 + 3c²) / 8
//! ```
//!
//! so `|P_t| / U(P_n) = (1 + 3c²)/(3sc) = μ*`, Painlevé's threshold: the jam's impulse is in
//! the cone exactly where the slide (end moving away from the centre, `v < 0`) is
//! inconsistent, `μ > μ*` — and outside it below, where the jam must be refused.
use selfmanip_core::{ContactKind, ContactMode, GroundPlane, Model};
use selfmanip_hybrid::flow::{Flow, FlowWorkspace};
use selfmanip_hybrid::jam::jam;
use selfmanip_hybrid::{EventKind, HybridOptions, PainleveReason, Termination, ZeroTorque};
use std::sync::Arc;

mod systems;
use systems::{coast, coast_sliding_on_level, painleve_mu_star, painleve_rod, sliding};

const M: f64 = 1.5;
const L: f64 = 0.4;
const THETA: f64 = 0.8;
const V: f64 = -0.3;

fn mu_star() -> f64 {
    painleve_mu_star(THETA)
}

fn rod(mu: f64) -> Model {
    painleve_rod(M, L, mu)
}

/// The rod's state: end on the ground, sliding at `V` (away from the centre), not turning.
fn state() -> ([f64; 3], [f64; 3]) {
    ([0.0, -L * THETA.sin(), THETA], [V, 0.0, 0.0])
}

/// The hand-derived `A` at `θ`, applied to `q̇`: the end's velocity (tangential, normal).
fn end_velocity(qd: &[f64]) -> (f64, f64) {
    let (s, c) = THETA.sin_cos();
    (qd[0] + L * s * qd[2], qd[1] + L * c * qd[2])
}

/// Beyond the threshold (`μ = 1.05 μ*`) the rod's run no longer ends at once: its first
/// event is a jam at `t = 0` into the end's stick, with the closed-form impulse
/// `P = −(m v/4)(1 + 3c², −3sc)` (in its cone, pushing), the end at rest after it by the
/// hand-derived `A` (an independent route to the constraint), and the kinetic energy
/// dropping by `m v² (1 + 3c²)/8`; the run goes on sticking.
#[test]
fn painleve_rod_jams_with_the_closed_form_plastic_impulse() {
    let (s, c) = THETA.sin_cos();
    let mu = 1.05 * mu_star();
    let model = rod(mu);
    let (q, qd) = state();
    let exec = coast_sliding_on_level(&model, (&q, &qd), 0.05);
    assert!(
        !matches!(exec.termination, Termination::Painleve { .. }),
        "{:?}",
        exec.termination
    );
    let e = &exec.events[0];
    assert_eq!(e.kind, EventKind::Jam, "{e:?}");
    assert_eq!(e.t, 0.0);
    assert_eq!(e.triggered, vec![0]);
    let stuck = ContactMode::FLIGHT.with(0, ContactKind::Stick);
    assert_eq!(e.mode_after, stuck);
    // rows of the stick: tangential, then normal
    let want = [
        -(M * V / 4.0) * (1.0 + 3.0 * c * c),
        (M * V / 4.0) * 3.0 * s * c,
    ];
    assert_eq!(e.impulse.len(), 2, "{:?}", e.impulse);
    for (got, want) in e.impulse.iter().zip(want) {
        assert!((got - want).abs() < 1e-12, "{:?} vs {want:?}", e.impulse);
    }
    // in the cone and pushing (docs/conventions.md: pushing normal impulses are negative)
    let (p_t, p_n) = (e.impulse[0], e.impulse[1]);
    assert!(p_n < 0.0 && p_t.abs() <= mu * -p_n, "{p_t} {p_n}");
    // |P_t| / U(P_n) is Painlevé's μ*
    assert!((p_t.abs() / -p_n - mu_star()).abs() < 1e-12);
    // the end sticks: its velocity after, by the hand-derived A, is zero
    let (vt, vn) = end_velocity(&e.qd_after);
    assert!(vt.abs() < 1e-12 && vn.abs() < 1e-12, "{vt} {vn}");
    // momentum balance M Δq̇ = Aᵀ P, by hand
    let dp_x = M * (e.qd_after[0] - V);
    let dp_z = M * e.qd_after[1];
    assert!((dp_x - p_t).abs() < 1e-12 && (dp_z - p_n).abs() < 1e-12);
    // the energy lost is the closed form's, and positive
    let lost = e.kinetic_before - e.kinetic_after;
    let want_lost = M * V * V * (1.0 + 3.0 * c * c) / 8.0;
    assert!((lost - want_lost).abs() < 1e-12, "{lost} vs {want_lost}");
    assert!((e.kinetic_before - 0.5 * M * V * V).abs() < 1e-12);
    assert_eq!(exec.impact_losses()[0], lost);
    // the run goes on from the stick (the inconsistent slide had no segment)
    assert_eq!(exec.segments[0].mode, stuck);
    assert_eq!(exec.segments[0].t0, 0.0);
    assert!(exec.t > 0.0);
}

/// Below the threshold (`μ = 0.95 μ*`) the slide is consistent, and the jam's impulse
/// (`|P_t|/U(P_n) = μ*`) leaves the cone: asked to jam there, `jam` refuses with the typed
/// reason ([`PainleveReason::JamOutsideCone`]) — the approach to Painlevé's singular point,
/// which the rigid-body theory leaves ambiguous; the run itself slides on.
#[test]
fn jam_whose_impulse_leaves_the_cone_is_refused_typed() {
    let ground = GroundPlane::level(0.0);
    let (q, qd) = state();
    // the jam of the rod's end, asked for directly
    let jam_at = |mu: f64| {
        let model = rod(mu);
        let y: Vec<f64> = q.iter().chain(&qd).copied().collect();
        let mut flow = Flow::new(&model, &ground, Arc::new(ZeroTorque));
        let mut ws = FlowWorkspace::new(&model);
        let opts = HybridOptions::default();
        jam(&mut ws, &mut flow, &opts, sliding(&[0]), "end", (0.0, &y))
            .unwrap()
            .map(|_| ())
    };
    assert_eq!(
        jam_at(0.95 * mu_star()),
        Err(PainleveReason::JamOutsideCone)
    );
    // … and at 1.05 μ* the same call jams
    let r = jam_at(1.05 * mu_star());
    assert!(r.is_ok(), "{r:?}");
    let exec = coast(
        &rod(0.95 * mu_star()),
        &ground,
        sliding(&[0]),
        (&q, &qd),
        0.05,
    );
    assert!(exec.events.iter().all(|e| e.kind != EventKind::Jam));
    assert!(exec.t > 0.0);
}

/// A jam never adds energy: over a fan of rod angles and friction coefficients beyond each
/// angle's threshold, every jam's kinetic energy drops by the closed form
/// `m v² (1 + 3cos²θ)/8` (a second route: the energy of the velocity after, computed by hand
/// from `q̇⁺`, `½ m (ẋ² + ż²) + ½ I φ̇²`).
#[test]
fn jams_never_add_energy_and_lose_the_closed_form() {
    for theta in [0.3_f64, 0.6, 0.9, 1.2] {
        let (s, c) = theta.sin_cos();
        let mu_star = (1.0 + 3.0 * c * c) / (3.0 * s * c);
        for factor in [1.01, 1.5, 3.0] {
            let model = rod(mu_star * factor);
            let q = [0.0, -L * s, theta];
            let qd = [V, 0.0, 0.0];
            let exec = coast_sliding_on_level(&model, (&q, &qd), 0.02);
            let e = &exec.events[0];
            assert_eq!(e.kind, EventKind::Jam, "θ {theta} ×{factor}: {e:?}");
            let v = &e.qd_after;
            let by_hand =
                0.5 * M * (v[0] * v[0] + v[1] * v[1]) + 0.5 * (M * L * L / 3.0) * v[2] * v[2];
            assert!((e.kinetic_after - by_hand).abs() < 1e-12);
            let lost = e.kinetic_before - e.kinetic_after;
            let want = M * V * V * (1.0 + 3.0 * c * c) / 8.0;
            assert!(
                lost > 0.0 && (lost - want).abs() < 1e-12,
                "{lost} vs {want}"
            );
        }
    }
}

/// Derivatives do not pass through a jam the flow meets (a slide's Painlevé inconsistency,
/// no touchdown: no crossing guard, its saltation is not formed): the rod's run,
/// which jams at its start before any segment, gets no state Jacobian — no number that
/// would be wrong — while the same rod below the threshold, sliding on without a jam, gets
/// one.
#[test]
fn sensitivities_do_not_pass_through_a_jam() {
    let (q, qd) = state();
    let run = |mu: f64| {
        selfmanip_hybrid::sensitivity::simulate_with_sensitivity(
            &rod(mu),
            &GroundPlane::level(0.0),
            &ZeroTorque,
            sliding(&[0]),
            &q,
            &qd,
            0.05,
            HybridOptions::default(),
        )
        .unwrap()
    };
    let (exec, sens) = run(1.05 * mu_star());
    assert_eq!(exec.events[0].kind, EventKind::Jam);
    assert!(sens.state_jacobian.is_none());
    let (exec, sens) = run(0.95 * mu_star());
    assert!(exec.events.iter().all(|e| e.kind != EventKind::Jam));
    assert!(sens.state_jacobian.is_some(), "{:?}", exec.termination);
}
