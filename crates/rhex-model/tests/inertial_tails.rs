//! Result C.5: the legs act as inertial tails. In flight the robot's angular momentum about
//! its centre of mass is conserved, so legs with mass that turn relative to the body turn the
//! body the other way — what takes the default leap's (+,+) apex pitch from 68° to 52.5° with
//! Table 4.2's leg mass (`docs/decisions/2026-11-24-massive-legs-servoed-in-the-air.md`), and what
//! the thesis measured on the robot (ε_m = 14°/360°, Fig. 4.13).
//!
//! Independent route: the angular momentum written from first principles in the world's
//! `(x, z)` plane — each rigid piece's `I ω + m (r − C) × (v − Ċ)`, the pieces' centres from
//! the hips (`X + R(φ) h`, `docs/conventions.md`) and the toes (`contact_points`), the
//! velocities by central differences along `q̇`, each piece's `ω` from a vector fixed in it —
//! is zero along the engine's flight from rest; and, with the two legs locked in parallel,
//! the body's rate per relative leg rate is the closed form of (4.68) as derived in
//! [`selfmanip_sim::analysis::leg_tail::effectiveness_closed_form`] (the body turns against
//! the legs: `ε < 0` in this sign convention).
//!
//! The converted thesis prints the denominator as `I_b + 2I_l + 2m_lℓ₁ + m_r2 ρ₁/2` — two terms
//! of the wrong unit (kg m); with Table 4.2's values that reads ε = −0.0161 instead of −0.0219
//! (`docs/errata/ch4-analysis.md`).
mod common;
use common::flight;
use rhex_model::leap::leap_params;
use rhex_model::modes::Rhex;
use rhex_model::params::{LegPair, LegShape};
use selfmanip_core::{contact_points, ContactMode, FlatGround, Model};
use selfmanip_hybrid::Controller;
use selfmanip_sim::analysis::leg_tail::effectiveness_closed_form;

/// Equal drive on both legs, and an internal spring–damper between them that locks them in
/// parallel (its torques cancel: no external moment).
#[derive(Clone)]
struct Locked {
    tau: f64,
    k: f64,
    c: f64,
}

impl Controller for Locked {
    fn torque(&self, _t: f64, q: &[f64], qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        let d = self.k * (q[1] - q[0]) + self.c * (qd[1] - qd[0]);
        tau[0] = self.tau + d;
        tau[1] = self.tau - d;
    }
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// World positions of the pieces' centres and of a vector fixed in each: body, front leg,
/// rear leg (`q = [θ_front, θ_rear, x, z, φ]`, hips at `±ℓ`, leg centres halfway to the toes).
fn pieces(model: &Model, l: f64, q: &[f64]) -> [([f64; 2], [f64; 2]); 3] {
    let (x, z, phi) = (q[2], q[3], q[4]);
    let hip = |h: f64| [x + h * phi.cos(), z - h * phi.sin()];
    let points = contact_points(model, &FlatGround, q, &vec![0.0; q.len()]).unwrap();
    let toe = |name: &str| {
        let k = model.contacts.iter().position(|c| c.name == name).unwrap();
        points[k].position_m
    };
    let (hf, hr) = (hip(l), hip(-l));
    let leg = |h: [f64; 2], t: [f64; 2]| {
        (
            [0.5 * (h[0] + t[0]), 0.5 * (h[1] + t[1])],
            [t[0] - h[0], t[1] - h[1]],
        )
    };
    [
        ([x, z], [hf[0] - hr[0], hf[1] - hr[1]]),
        leg(hf, toe("front_leg")),
        leg(hr, toe("rear_leg")),
    ]
}

#[test]
fn legs_turning_in_flight_turn_the_body_back_by_result_c5() {
    let mut params = leap_params().with_table_4_2_legs();
    params.pairs = vec![LegPair::Front, LegPair::Rear]; // hips at ±ℓ, as (4.68) takes them
    params.leg_shape = LegShape::Stick; // the leg's centre on its line, as (4.67)–(4.68) take it
    let rhex = Rhex::new(params.clone()).unwrap();
    let model = &rhex.model;
    assert_eq!(model.nq(), 5);
    let (mb, ib, ml, il, l, a) = (
        params.m_b,
        params.I_b,
        params.m_l,
        params.I_l,
        params.l1,
        0.5 * params.rho1,
    );
    let mass = [mb, ml, ml];
    let inertia = [ib, il, il];
    let ctrl = Locked {
        tau: 0.4,
        k: 50.0,
        c: 1.0,
    };
    let q0 = [1.0, 1.0, 0.0, -2.0, 0.1];
    let exec = flight(model, &ctrl, &q0, 0.12);
    let seg = exec.segments.last().unwrap();

    let eps = -effectiveness_closed_form(mb, ib, ml, il, a, &[l, -l]).unwrap();
    let r_mr = mb * 2.0 * ml / (mb + 2.0 * ml);
    let eps_printed = -(2.0 * il + r_mr * a * a) / (ib + 2.0 * il + 2.0 * ml * l + r_mr * a);
    let mut turned = 0.0;
    for t in [0.03, 0.06, 0.09, 0.12] {
        let mut y = vec![0.0; 10];
        seg.eval(t, &mut y);
        let (q, qd) = y.split_at(5);
        let h = 1e-6;
        let at = |s: f64| {
            let qs: Vec<f64> = q.iter().zip(qd).map(|(a, b)| a + s * h * b).collect();
            pieces(model, l, &qs)
        };
        let (p, plus, minus) = (pieces(model, l, q), at(1.0), at(-1.0));
        let rate = |i: usize, k: usize| (plus[i].0[k] - minus[i].0[k]) / (2.0 * h);
        let omega = |i: usize| {
            let u = p[i].1;
            let du = [
                (plus[i].1[0] - minus[i].1[0]) / (2.0 * h),
                (plus[i].1[1] - minus[i].1[1]) / (2.0 * h),
            ];
            cross(u, du) / (u[0] * u[0] + u[1] * u[1])
        };
        let total: f64 = mass.iter().sum();
        let c = [0, 1].map(|k| (0..3).map(|i| mass[i] * p[i].0[k]).sum::<f64>() / total);
        let cd = [0, 1].map(|k| (0..3).map(|i| mass[i] * rate(i, k)).sum::<f64>() / total);
        let momentum: Vec<f64> = (0..3)
            .map(|i| {
                inertia[i] * omega(i)
                    + mass[i]
                        * cross(
                            [p[i].0[0] - c[0], p[i].0[1] - c[1]],
                            [rate(i, 0) - cd[0], rate(i, 1) - cd[1]],
                        )
            })
            .collect();
        let scale: f64 = momentum.iter().map(|m| m.abs()).sum();
        let total_h: f64 = momentum.iter().sum();
        assert!(scale > 1e-3, "the legs turn: {momentum:?}");
        assert!(
            total_h.abs() < 1e-7 * scale,
            "angular momentum about the centre of mass at t = {t}: {total_h:e} of {scale:e}"
        );
        // locked in parallel: the body's rate per relative leg rate is (4.68)
        let (wb, wl) = (omega(0), 0.5 * (omega(1) + omega(2)));
        assert!((q[0] - q[1]).abs() < 1e-3, "locked: {:?}", &q[..2]);
        let measured = wb / (wl - wb);
        assert!(
            (measured - eps).abs() < 2e-3 * eps.abs(),
            "ε = {measured} against (4.68) {eps}"
        );
        assert!((eps_printed - measured).abs() > 0.2 * eps.abs());
        turned = q[0] - q0[0];
    }
    assert!(turned > 0.5, "the legs turned {turned} rad");
}
