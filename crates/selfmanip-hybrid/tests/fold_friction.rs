//! Lemma 5.1 folds of a sliding massless leg whose toe carries kinetic (Coulomb) friction
//! (`selfmanip_core::friction`, `selfmanip_hybrid::fold`), against closed forms.
//!
//! The system of `tests/fold.rs`: a body (mass `m`, an inertia so large that it does not
//! turn) on one massless stick leg of length `L` hinged at its centre, under a constant joint
//! torque `τ` that turns the leg from `β₀ = −0.5` towards straight down; the toe now slides
//! with `μ_k = μ` and the body moves sideways at `ẋ`, so the toe slides one way throughout.
//!
//! **Where the flow is singular.** With the friction folded into the leg's statics the
//! force on the robot is `λ_n (n̂ + μσ t̂)` — along the cone edge `e` against the sliding —
//! and the massless joint's row of the KKT system reads `Ã_j λ_n = τ`,
//! `Ã_j = (A_n)_j + μσ (A_t)_j = −e·S(r)` (`r` from the hip to the toe). The system
//! `[M̄ Ãᵀ; A_n 0]` has, for one massless joint, the determinant `±Ã_j (A_n)_j det M̄_mm`
//! (expand along the joint's column, whose only entry is `(A_n)_j`): it is singular where
//! `(A_n)_j = 0` — the normal through the hip, `β = 0`, the leg's rate unbounded (the
//! frictionless fold) — **and** where `Ã_j = 0`, the cone edge through the hip,
//! `tan|β| = μ` on the side where the sliding turns the edge towards the hip: there
//! `|λ_n| = |τ| / (L |e| |sin∠(r, e)|)` grows without bound (the leg wedges). The fold
//! guard's pin is the smaller of `|sin ψ|` and `|sin ∠(r, e)|`; with `β` rising from `−0.5`
//! the wedge is met first, at `|β| = atan μ + asin ε`, when the toe slides the way that puts
//! the edge there (here `ẋ < 0`), and the frictionless fold `|β| = asin ε` otherwise.
mod systems;

use selfmanip_core::description::FrictionDescription;
use selfmanip_core::{forward_dynamics, Data, FlatGround, Model};
use selfmanip_hybrid::{ConstantTorque, EventKind, Termination};
use systems::{fold_options, massless_leg, sliding, toe_sliding_run};

const M: f64 = 1.0;
const L: f64 = 0.2;
const I_BODY: f64 = 1e6;
const MU: f64 = 0.3;

fn leg_robot(mu_kinetic: f64) -> Model {
    let friction = FrictionDescription::Sticking {
        mu: Some(MU),
        mu_kinetic: Some(mu_kinetic),
    };
    massless_leg(M, I_BODY, L, friction)
}

/// Runs the leg from `β₀ = −0.5` with the body moving sideways at `xdot`; returns the fold
/// event's angle `β` and the state just before it (`None` if the run meets no fold), and how
/// the run ended.
fn run(model: &Model, xdot: f64, eps: f64) -> (Option<(f64, Vec<f64>)>, Termination) {
    let beta0: f64 = -0.5;
    let q = [beta0, 0.0, -L * beta0.cos(), 0.0];
    let qd = [0.0, xdot, 0.0, 0.0];
    let opts = fold_options(eps);
    let press = ConstantTorque::first_joint(2.0);
    let exec = toe_sliding_run(model, &press, &q, &qd, 0.5, opts);
    let fold = exec
        .events
        .iter()
        .find(|e| e.kind == EventKind::Fold)
        .map(|fold| {
            let seg = exec
                .segments
                .iter()
                .find(|s| s.t1 == fold.t && s.t1 > s.t0)
                .expect("the segment that meets the fold");
            let mut y = vec![0.0; 2 * model.nq()];
            seg.eval(seg.t1, &mut y);
            (fold.q[0], y)
        });
    (fold, exec.termination)
}

/// The fold guard with Coulomb friction locates the wedge (the zero of the statics'
/// denominator, `|β| = atan μ`) for one sliding direction and the frictionless fold
/// (`β = 0`) for the other, each `asin ε` before it; there the normal force is the closed
/// form `|τ| / (L √(1+μ²) ε)` of the leg's statics; the run goes on past the fold (a typed
/// transition, never a singular flow). Without kinetic friction both directions meet the
/// fold at `β = 0`.
#[test]
fn sliding_leg_with_friction_meets_its_fold_where_the_statics_denominator_vanishes() {
    let eps = 1e-2;
    let phi = MU.atan();
    let model = leg_robot(MU);
    let mut kinds = Vec::new();
    for xdot in [10.0, -10.0] {
        let (fold, end) = run(&model, xdot, eps);
        let (beta, y) = fold.unwrap_or_else(|| panic!("ẋ = {xdot}: no fold, {end:?}"));
        assert!(
            !matches!(end, Termination::SingularFlow { .. }),
            "ẋ = {xdot}: {end:?}"
        );
        let (q, qd) = y.split_at(model.nq());
        let wedge = (beta.abs() - (phi + eps.asin())).abs() < 1e-7;
        let kinematic = (beta.abs() - eps.asin()).abs() < 1e-7;
        assert!(
            wedge != kinematic,
            "ẋ = {xdot}: fold at β = {beta}, wedge at {}, fold at {}",
            phi + eps.asin(),
            eps.asin()
        );
        if wedge {
            // the statics: |λ_n| L √(1+μ²) |sin∠(r, e)| = |τ|, with |sin∠(r, e)| = ε there
            let mut data = Data::new(&model);
            forward_dynamics(
                &model,
                &mut data,
                &FlatGround,
                sliding(&[0]),
                q,
                qd,
                &[2.0],
                None,
            )
            .unwrap();
            let lambda_n = data.lambda[0];
            let closed = 2.0 / (L * (1.0 + MU * MU).sqrt() * eps);
            assert!(lambda_n < 0.0, "pushing: {lambda_n}");
            assert!(
                (lambda_n.abs() - closed).abs() < 1e-5 * closed,
                "λ_n = {lambda_n} vs {closed}"
            );
        }
        kinds.push(wedge);
    }
    assert_eq!(kinds.iter().filter(|&&w| w).count(), 1, "{kinds:?}");
    // without kinetic friction the same runs meet no wedge, only the fold at β = 0: one
    // sliding all the way, the other after its toe came to rest — where sticking would pull
    // the toe (the leg's torque turns it towards the fold), so it slides on, frictionless,
    // pushing (`ResetWorkspace::outside_cone`: a pull is outside the cone), rather than
    // being let go
    let frictionless = leg_robot(0.0);
    for xdot in [10.0, -10.0] {
        let (fold, end) = run(&frictionless, xdot, eps);
        let (beta, _) = fold.unwrap_or_else(|| panic!("ẋ = {xdot}: no fold, {end:?}"));
        assert!(
            (beta.abs() - eps.asin()).abs() < 1e-7,
            "ẋ = {xdot}: β = {beta}"
        );
    }
}

/// The fold guard's pin takes the sliding direction `σ` of the segment
/// (`Data::slide_directions`, fixed when the segment starts), not `sign v_t` with the rest
/// band: the flow integrates the force `λ_n (n̂ + μσ t̂)` with that `σ` whatever `v_t` does,
/// so its singular configuration (the wedge) is where that edge passes through the hip.
///
/// Closed forms at `β = −0.5`, `|r| = L`: the normal's pin is `|sin β|`; the edge at
/// `atan μ` from the normal makes the angle `|β| ∓ atan μ` with `r`, so the two directions'
/// pins are `min(|sin β|, |sin(|β| − atan μ)|)` and `min(|sin β|, |sin(|β| + atan μ)|)
/// = |sin β|`. Checked: (1) at rest (`v_t = 0`) with `σ = ±1` fixed the pin is one of the two
/// closed forms each, and they differ; without a fixed direction (a candidate mode at a
/// reset) and with `σ = 0` it is the normal's; (2) with the toe sliding fast one way
/// (`|v_t| = 10 m/s`) and the opposite `σ` fixed, the pin is the fixed `σ`'s, not the
/// velocity's.
#[test]
fn fold_pin_takes_the_segments_fixed_sliding_direction() {
    use selfmanip_core::friction::SlideDirection;
    use selfmanip_hybrid::fold::pin;
    let model = leg_robot(MU);
    let beta: f64 = -0.5;
    let q = [beta, 0.0, -L * beta.cos(), 0.0];
    let pin_at = |xdot: f64, dirs: &[(usize, SlideDirection)]| {
        let mut data = Data::new(&model);
        data.prepare(
            &model,
            &FlatGround,
            sliding(&[0]),
            &q,
            &[0.0, xdot, 0.0, 0.0],
        )
        .unwrap();
        pin(&model, &data.kin, &FlatGround, sliding(&[0]), 0, dirs).unwrap()
    };
    let normal = beta.sin().abs();
    let wedge_side = (beta.abs() - MU.atan()).sin().abs();
    let fixed = |s: f64| [(0usize, SlideDirection::Fixed(s))];
    let (plus, minus) = (pin_at(0.0, &fixed(1.0)), pin_at(0.0, &fixed(-1.0)));
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    assert!(
        (close(plus, wedge_side) && close(minus, normal))
            || (close(plus, normal) && close(minus, wedge_side)),
        "σ = +1: {plus}, σ = −1: {minus}; closed forms {wedge_side}, {normal}"
    );
    assert!(close(pin_at(0.0, &[]), normal), "{}", pin_at(0.0, &[]));
    assert!(close(pin_at(0.0, &fixed(0.0)), normal));
    // sliding fast either way, the fixed σ decides
    for xdot in [10.0, -10.0] {
        for s in [1.0, -1.0] {
            let p = pin_at(xdot, &fixed(s));
            let at_rest = pin_at(0.0, &fixed(s));
            assert!(close(p, at_rest), "ẋ = {xdot}, σ = {s}: {p} vs {at_rest}");
        }
    }
    // and without a fixed direction the velocity's sign is the edge: the two velocities
    // give the two closed forms
    let (a, b) = (pin_at(10.0, &[]), pin_at(-10.0, &[]));
    assert!(
        (close(a, wedge_side) && close(b, normal)) || (close(a, normal) && close(b, wedge_side)),
        "{a}, {b}"
    );
}
