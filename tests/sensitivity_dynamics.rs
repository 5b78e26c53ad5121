//! The exact Jacobian `∂(q̈, λ)/∂(q, q̇, Υ)` of the constrained dynamics (5.3)–(5.4)
//! ([`selfmanip::core::tangent::dynamics_jacobian`]: closed-form assembly derivatives, implicit
//! differentiation of the KKT system) against an independent route: central finite
//! differences of `forward_dynamics` itself,
//! `∂z/∂x_k ≈ (z(x + h e_k) − z(x − h e_k)) / 2h` with `h = 1e-6` (truncation `O(h²)` ≈ 1e-12,
//! rounding ≈ 1e-10 relative), required to agree to 1e-6 relative to the largest entry of each
//! block. Systems: the rocking block on one corner, a body with one massive leg, the same
//! with a massless leg in contact (singular `M̄`, regular KKT: Lemma 5.1), and RHex with
//! massless and massive half-circle legs and stick legs in every mode with a regular KKT
//! matrix, at seeded random states (the velocity need not satisfy the constraint: (5.3)–(5.4)
//! are defined for any `q̇`).
mod common;
#[path = "../crates/selfmanip-core/tests/common/dynamics_fd.rs"]
mod dynamics_fd;

use common::{feasible_labels, random_q, random_vec, rhex_massive, rhex_massless, rng, systems};
use dynamics_fd::{dynamics_jacobian_error, rel_err};
use nalgebra::DMatrix;
use selfmanip::core::contact::{ContactKind, TouchKind};
use selfmanip::core::tangent::{dynamics_jacobian, plastic_impact_jacobian};
use selfmanip::core::{forward_dynamics, plastic_impact, ContactMode, Data, FlatGround, Model};
use selfmanip::rhex::LegShape;

const H: f64 = 1e-6;
const TOL: f64 = 1e-6;

/// `(q̈, λ)` at a state, or `None` if the KKT matrix is singular there.
fn eval(
    model: &Model,
    mode: ContactMode,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Option<(Vec<f64>, Vec<f64>)> {
    let mut data = Data::new(model);
    forward_dynamics(model, &mut data, &FlatGround, mode, q, qd, tau, None).ok()?;
    Some((
        data.qdd.iter().copied().collect(),
        data.lambda.iter().copied().collect(),
    ))
}

/// How each contact of the last prepared mode touches (a point or a rolling arc).
fn touch_kinds(data: &Data) -> Vec<TouchKind> {
    data.constraints
        .geometry
        .iter()
        .map(|(_, g)| g.touch)
        .collect()
}

/// Checks one state; returns the worst relative error, or `None` when a perturbed state's
/// KKT matrix is singular (or the geometry switches between rolling and a point touch).
fn check_state(
    model: &Model,
    mode: ContactMode,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Option<f64> {
    let mut data = Data::new(model);
    let jac = dynamics_jacobian(model, &mut data, &FlatGround, mode, q, qd, tau, None).ok()?;
    let touches = touch_kinds(&data);
    dynamics_jacobian_error(&jac, (q, qd, tau), &[(H, 1.0)], |q, qd, tau| {
        let z = eval(model, mode, q, qd, tau)?;
        // the same touch kinds as at the state (no switch at an arc's end)
        let mut d = Data::new(model);
        d.prepare(model, &FlatGround, mode, q, qd).ok()?;
        (touch_kinds(&d) == touches).then_some(z)
    })
}

/// Checks `count` random states in each mode; returns (states checked, worst error).
fn check_modes(model: &Model, modes: &[ContactMode], count: usize, seed: u64) -> (usize, f64) {
    let mut r = rng(seed);
    let (mut checked, mut worst) = (0, 0.0_f64);
    for &mode in modes {
        for _ in 0..count {
            let q = random_q(model, &mut r);
            let qd = random_vec(model.nq(), 2.0, &mut r);
            let tau = random_vec(model.n_joints(), 5.0, &mut r);
            if let Some(e) = check_state(model, mode, &q, &qd, &tau) {
                assert!(e < TOL, "{} in {mode:?}: relative error {e:e}", model.name);
                checked += 1;
                worst = worst.max(e);
            }
        }
    }
    (checked, worst)
}

#[test]
fn dynamics_jacobian_equals_finite_differences_small_systems() {
    let block = systems::block(systems::G);
    let left = ContactMode::FLIGHT.with(0, ContactKind::Stick);
    let (n, e) = check_modes(&block, &[ContactMode::FLIGHT, left], 5, 1);
    assert_eq!(n, 10);
    eprintln!("block: worst {e:e}");
    for link_mass in [0.2, 0.0] {
        let leg = systems::one_leg(0.2, link_mass, systems::G);
        let toe = ContactMode::FLIGHT.with(0, ContactKind::Stick);
        let toe_slide = ContactMode::FLIGHT.with(0, ContactKind::Slide);
        let both = toe_slide.with(1, ContactKind::Slide);
        let (n, e) = check_modes(&leg, &[ContactMode::FLIGHT, toe, toe_slide, both], 5, 2);
        assert!(n >= 15, "{n} states checked");
        eprintln!("one leg (link {link_mass} kg): worst {e:e}");
    }
}

#[test]
fn dynamics_jacobian_equals_finite_differences_rhex_every_mode() {
    for shape in [LegShape::HalfCircle, LegShape::Stick] {
        for rhex in [rhex_massless(shape), rhex_massive(shape)] {
            let modes: Vec<_> = feasible_labels(&rhex)
                .iter()
                .map(|l| rhex.mode(l).unwrap())
                .collect();
            let (n, e) = check_modes(&rhex.model, &modes, 2, 3);
            // most random states have a regular KKT matrix
            assert!(
                n >= modes.len(),
                "{shape:?}: only {n} of {} states",
                2 * modes.len()
            );
            eprintln!(
                "RHex {shape:?} {}: {n} states, worst {e:e}",
                rhex.model.name
            );
        }
    }
}

/// The plastic impact map `q̇⁺(q, q̇⁻)` (5.52) against central differences of
/// `plastic_impact`, RHex (massless legs: free joints keep their velocity) and the block.
#[test]
fn impact_jacobian_equals_finite_differences() {
    let mut r = rng(7);
    let mut checked = 0;
    for rhex in [
        rhex_massless(LegShape::HalfCircle),
        rhex_massive(LegShape::Stick),
    ] {
        let model = &rhex.model;
        for label in feasible_labels(&rhex) {
            let mode = rhex.mode(&label).unwrap();
            let q = random_q(model, &mut r);
            let qd = random_vec(model.nq(), 2.0, &mut r);
            let mut data = Data::new(model);
            let Ok(jac) = plastic_impact_jacobian(model, &mut data, &FlatGround, mode, &q, &qd)
            else {
                continue;
            };
            let nq = model.nq();
            let imp = |q: &[f64], qd: &[f64]| {
                let mut d = Data::new(model);
                plastic_impact(model, &mut d, &FlatGround, mode, q, qd)
                    .ok()
                    .map(|i| i.qd_plus)
            };
            let (mut fq, mut fv) = (DMatrix::zeros(nq, nq), DMatrix::zeros(nq, nq));
            let mut ok = true;
            for k in 0..nq {
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[k] += H;
                qm[k] -= H;
                let (mut vp, mut vm) = (qd.clone(), qd.clone());
                vp[k] += H;
                vm[k] -= H;
                match (imp(&qp, &qd), imp(&qm, &qd), imp(&q, &vp), imp(&q, &vm)) {
                    (Some(a), Some(b), Some(c), Some(d)) => {
                        fq.set_column(k, &((a - b) / (2.0 * H)));
                        fv.set_column(k, &((c - d) / (2.0 * H)));
                    }
                    _ => ok = false,
                }
            }
            if !ok {
                continue;
            }
            let e = rel_err(&jac.dqd_plus.dq, &fq).max(rel_err(&jac.dqd_plus.dqd, &fv));
            assert!(e < TOL, "{label}: {e:e}");
            checked += 1;
        }
    }
    assert!(checked > 10, "{checked}");
}
