//! Results A.1–A.3, B.1–B.3, C.2–C.5 of thesis section 4.3 computed by the general analysis
//! machinery (`rhex_model::analysis`) and checked against an independent route: a closed form
//! re-derived here, a conservation law, a second formulation, or finite differences. Each test
//! prints "thesis value | ours". (Result C.1 is `tests/rhex_results.rs::result_c1_…` at the
//! workspace root; C.2 below is its derivative.) Every analysis also runs on a second,
//! non-RHex robot: the sagittal quadruped of `tests/data/quadruped.toml`.
mod common;
use common::{flat_dynamics, flat_quasi_static, flat_reduced};
use nalgebra::{DMatrix, DVector};
use rhex_model::analysis::leg_tail::*;
use rhex_model::analysis::pitch_control::*;
use rhex_model::analysis::sensor_sweep::*;
use rhex_model::analysis::standing::*;
use rhex_model::quasistatic_map::{quasi_static_pose, Support};
use rhex_model::{LegShape, Rhex, RhexParams};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{Data, FlatGround};
use selfmanip_sim::analysis::leg_tail::*;
use selfmanip_sim::analysis::standing::*;
use selfmanip_sim::analysis::{free_motion_basis, solve_contact_pose};
use std::f64::consts::PI;

fn rhex(shape: LegShape) -> Rhex {
    Rhex::new(RhexParams {
        leg_shape: shape,
        ..Default::default()
    })
    .unwrap()
}

fn deg(x: f64) -> f64 {
    x.to_radians()
}

// ---------------------------------------------------------------------------------------
// 4.3.1 Reactive standing
// ---------------------------------------------------------------------------------------

/// Results A.1–A.3 (thesis: both costs decay to ~0 from any D.1 posture, round and stick legs,
/// with C.5 dropped). Random rough-terrain stances (each leg on its own plane sloped up to
/// ±15°), random initial leg fight `τ_d`. Checks, by independent routes:
/// - A.1: `δ` never increases (the Lyapunov argument of (4.53)) and ends ≤ 1e-10 of its start;
/// - A.2: `ε` ends ≤ 1e-10 N²m², and the final posture is a local maximum of the body height
///   along the free motion (probed directly with the kinematics, not with torques);
/// - A.3: the same for half-circle legs (rolling contact).
#[test]
fn results_a1_a2_a3_reactive_standing_on_rough_terrain() {
    let gains = StandingGains::default();
    for shape in [LegShape::Stick, LegShape::HalfCircle] {
        let r = rhex(shape);
        for seed in 0..6u64 {
            let (q0, terrain, mode) = random_rhex_stance(&r, seed, deg(15.0)).unwrap();
            let tau_d0 = [3.0 * ((seed as f64) * 1.7).sin()];
            let tr = simulate_standing(
                &r.model,
                &terrain,
                mode,
                &q0,
                &tau_d0,
                &TorqueSplit::mean_difference(),
                &gains,
                0.01,
                2000,
            )
            .unwrap();
            let (e0, d0) = (tr.epsilon[0], tr.delta[0]);
            let (e1, d1) = (*tr.epsilon.last().unwrap(), *tr.delta.last().unwrap());
            println!(
                "{shape:?} seed {seed}: ε {e0:.3e} → {e1:.3e}, δ {d0:.3e} → {d1:.3e} (thesis: both → ~0); drift {:.1e} m",
                tr.max_gap_m
            );
            for w in tr.delta.windows(2) {
                assert!(w[1] <= w[0] * (1.0 + 1e-9) + 1e-15, "A.1: δ increased");
            }
            assert!(d1 <= 1e-10 * d0.max(1e-6), "A.1: δ did not decay");
            assert!(e1 <= 1e-10, "A.2: ε = {e1}");
            assert!(tr.max_gap_m < 1e-6, "constraint drift {}", tr.max_gap_m);
            // local maximum of the body height along the free motion (ζ of (4.54))
            let qf = tr.q.last().unwrap().clone();
            let y = DMatrix::from_row_slice(1, 5, &[0.5, 0.5, 0.0, 0.0, 0.0]);
            let legs: Vec<usize> = mode.active().collect();
            let height = |dy: f64| {
                let h = free_motion_basis(&r.model, &terrain, mode, &qf, &y).unwrap();
                let mut q: Vec<f64> = qf
                    .iter()
                    .zip(h.column(0).iter())
                    .map(|(a, b)| a + dy * b)
                    .collect();
                // back onto the constraint manifold, joints held
                q = solve_contact_pose(&r.model, &terrain, &legs, &[2, 3], &{
                    q[2] = qf[2];
                    q.clone()
                })
                .unwrap();
                let mut kin = Kinematics::default();
                kin.compute(&r.model, &q, &[0.0; 5]);
                -kin.body_pos.y
            };
            let h0 = height(0.0);
            assert!(
                height(2e-3) < h0 && height(-2e-3) < h0,
                "A.2: not a height maximum"
            );
        }
    }
}

/// The torque split (4.45)–(4.49) on rough terrain, by independent routes: (4.48) — the
/// particular solution with `τ_d = 0` carries all the work against gravity,
/// `τ_m,p = ½ ∂V/∂θ_m` along the free motion (virtual work; `V` from the kinematics, central
/// differences along `H`); (4.49) with (4.46) — the internal-force torques `J_hᵀ f_N ∝ [γ₂, −γ₁]`
/// are orthogonal to `H_h ∝ [γ₁, γ₂]` (internal forces do no work), and on level ground with
/// `φ = 0` their ratio is `−γ₂/γ₁` of (4.47).
#[test]
fn torque_split_4_48_4_49() {
    use selfmanip_core::inertia::potential_energy;
    use selfmanip_core::quasistatic::quasi_static;
    let t_d = DMatrix::from_column_slice(2, 1, &[0.5, -0.5]);
    let y = DMatrix::from_row_slice(1, 5, &[0.5, 0.5, 0.0, 0.0, 0.0]);
    for shape in [LegShape::Stick, LegShape::HalfCircle] {
        let r = rhex(shape);
        for seed in 10..16u64 {
            let (q, terrain, mode) = random_rhex_stance(&r, seed, deg(15.0)).unwrap();
            let mut data = Data::new(&r.model);
            let qs = quasi_static(&r.model, &mut data, &terrain, mode, &q, &t_d).unwrap();
            let h = free_motion_basis(&r.model, &terrain, mode, &q, &y).unwrap();
            let tau = &qs.balance.tau_particular;
            assert!((tau[0] - tau[1]).abs() < 1e-10, "τ_d,p = 0");
            let v = |e: f64| {
                let qq: Vec<f64> = q
                    .iter()
                    .zip(h.column(0).iter())
                    .map(|(a, b)| a + e * b)
                    .collect();
                let mut kin = Kinematics::default();
                kin.compute(&r.model, &qq, &[0.0; 5]);
                potential_energy(&r.model, &kin)
            };
            let e = 1e-6;
            let dv = (v(e) - v(-e)) / (2.0 * e);
            assert!(
                (0.5 * (tau[0] + tau[1]) - 0.5 * dv).abs() < 1e-6 * (1.0 + dv.abs()),
                "(4.48) by virtual work"
            );
            let tn = qs.balance.internal_torques.column(0);
            let work = tn[0] * h[(0, 0)] + tn[1] * h[(1, 0)];
            assert!(
                work.abs() < 1e-9 * tn.norm(),
                "(4.49): internal forces do no work"
            );
        }
    }
    // level ground, φ = 0 (θ₁ = θ₂), stick legs: ratio −γ₂/γ₁ with γ of (4.47)
    let r = rhex(LegShape::Stick);
    let (l, rho) = (r.params.l1, r.params.rho1);
    for th in [deg(-20.0), deg(5.0), deg(25.0)] {
        let q = [th, th, 0.0, -rho * th.cos(), 0.0];
        let mut data = Data::new(&r.model);
        let qs = flat_quasi_static(&r.model, &mut data, r.mode("0101").unwrap(), &q, &t_d);
        let tn = qs.balance.internal_torques.column(0);
        let g = 2.0 * l * rho * th.cos();
        assert!((tn[0] / tn[1] + g / g).abs() < 1e-10, "(4.49) ratio");
        // (4.48) as printed, at φ = 0, θ₁ = θ₂ (= −m_b g ρ sin θ / 2)
        let tm = 0.5 * (qs.balance.tau_particular[0] + qs.balance.tau_particular[1]);
        let printed =
            -r.params.m_b * r.params.g * rho * rho * (2.0 * l * th.cos() * th.sin()) / (2.0 * g);
        println!(
            "(4.48) θ = {:.0}°: printed {printed:.5} | ours {tm:.5}",
            th.to_degrees()
        );
        assert!((tm - printed).abs() < 1e-9, "(4.48): {tm} vs {printed}");
    }
}

// ---------------------------------------------------------------------------------------
// 4.3.2 Pitching sensor sweep
// ---------------------------------------------------------------------------------------

/// Result B.1 (thesis: ±arcsin((ρ₁−ρ_b)/(ℓ₁+ℓ₂)) ≈ ±17.0°, reached with the front leg vertical
/// and the rear body sliding), by search over every quasi-static mode — for Table 4.2 and an
/// asymmetric variant. Independent route: the closed form (4.56) maximised by hand
/// (`cos y = 1`).
#[test]
fn result_b1_sensor_pitch_range_by_search() {
    let asym = RhexParams {
        l1: 0.25,
        l2: 0.18,
        rho1: 0.19,
        rho2: 0.15,
        rho_b: 0.04,
        ..Default::default()
    };
    for p in [RhexParams::default(), asym] {
        let r = Rhex::new(p.clone()).unwrap();
        let range = max_sensor_pitch(&r, 72).unwrap();
        let up = ((p.rho1 - p.rho_b) / (p.l1 + p.l2)).asin();
        let down = -((p.rho2 - p.rho_b) / (p.l1 + p.l2)).asin();
        println!(
            "B.1: max {:.4}° (closed form {:.4}°, thesis ≈ 17°), min {:.4}° ({:.4}°), rolling-only grid max {:.3}° (thesis ≈ 10°), at {}",
            range.max_phi.to_degrees(),
            up.to_degrees(),
            range.min_phi.to_degrees(),
            down.to_degrees(),
            range.rolling_max_phi.to_degrees(),
            range.argmax_label
        );
        assert!((range.max_phi - up).abs() < 1e-7);
        assert!((range.min_phi - down).abs() < 1e-7);
        assert_eq!(range.argmax_label, "0110", "front leg + rear body");
        assert!(range.rolling_max_phi < up);
    }
}

/// Result B.2 (thesis: the round leg (4.57) needs less torque than the stick leg (4.58)).
/// Independent route: virtual work — quasi-statically `τ₁ = m_b g ∂h/∂θ₁` along the constrained
/// motion, `h(θ₁)` the body height of the quasi-static pose (finite differences), against the
/// torque from (4.21)–(4.23). Then the comparison at equal pitch: for the same `φ`, the round
/// leg's holding torque is smaller.
#[test]
fn result_b2_holding_torque_by_virtual_work() {
    let theta2 = -2.5; // rear leg folded: rear body slides
    for shape in [LegShape::Stick, LegShape::HalfCircle] {
        let r = rhex(shape);
        let (m, g) = (r.params.m_b, r.params.g);
        for i in 1..12 {
            let t1 = deg(-75.0 + 6.0 * i as f64);
            let ht = holding_torque(&r, t1, theta2).unwrap();
            assert_eq!(ht.label, "0110", "front leg and rear body");
            let hgt = |t: f64| quasi_static_pose(&r, t, theta2).unwrap().height_m;
            let e = 1e-6;
            let vw = m * g * (hgt(t1 + e) - hgt(t1 - e)) / (2.0 * e);
            assert!(
                (ht.tau[0] - vw).abs() < 1e-6 * (1.0 + vw.abs()),
                "{shape:?} θ₁={t1}: quasi-static {} vs virtual work {vw}",
                ht.tau[0]
            );
            assert!(
                ht.tau[1].abs() < 1e-12,
                "the folded rear leg carries nothing"
            );
        }
    }
    // same pitch, both shapes: invert φ(θ₁) on the rolling side (θ₁ − φ < 0)
    let (round, stick) = (rhex(LegShape::HalfCircle), rhex(LegShape::Stick));
    for k in 1..8 {
        let phi = deg(2.0 * k as f64);
        let solve = |r: &Rhex| {
            let (mut lo, mut hi) = (deg(-90.0), 0.0);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if quasi_static_pose(r, mid, theta2).unwrap().phi < phi {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            holding_torque(r, 0.5 * (lo + hi), theta2).unwrap().tau[0]
        };
        let (tr, ts) = (solve(&round), solve(&stick));
        println!(
            "B.2 at φ = {:.0}°: round {tr:.3} N m < stick {ts:.3} N m",
            phi.to_degrees()
        );
        assert!(tr.abs() < ts.abs());
    }
}

/// Result B.3 / (4.59) (thesis: `θ̇₁ = (H_φ)⁻¹ φ̇` with
/// `(H_φ)⁻¹ = (ρ₁ sin(θ₁−φ) − 2(ℓ₁+ℓ₂) cos φ)/(ρ₁ sin(θ₁−φ))`, front rolling, rear body).
/// Routes: the printed closed form; finite differences of the implicit pitch `φ(θ₁)` (4.44);
/// and tracking: integrating `θ̇₁ = φ̇_d/H_φ` makes `φ(θ₁(t))` exactly linear in time.
#[test]
fn result_b3_exact_pitch_rate_controller() {
    let r = rhex(LegShape::HalfCircle);
    let p = &r.params;
    let theta2 = -2.5;
    for i in 1..10 {
        let t1 = deg(-80.0 + 8.0 * i as f64);
        let pose = quasi_static_pose(&r, t1, theta2).unwrap();
        assert_eq!((pose.front, pose.rear), (Support::Rolling, Support::Body));
        let gain = pitch_rate_gain(&r, t1, theta2).unwrap();
        let u = t1 - pose.phi;
        let printed =
            (p.rho1 * u.sin() - 2.0 * (p.l1 + p.l2) * pose.phi.cos()) / (p.rho1 * u.sin());
        let e = 1e-6;
        let fd = 2.0 * e
            / (quasi_static_pose(&r, t1 + e, theta2).unwrap().phi
                - quasi_static_pose(&r, t1 - e, theta2).unwrap().phi);
        println!(
            "B.3 θ₁={:.0}°: (4.59) {printed:.6} | H route {gain:.6} | FD {fd:.6}",
            t1.to_degrees()
        );
        assert!((gain - printed).abs() < 1e-9 * printed.abs());
        assert!((gain - fd).abs() < 1e-5 * fd.abs());
    }
    // tracking φ̇_d = 5°/s for 1 s from θ₁ = −70° (stays below the 17° maximum)
    let phid = deg(5.0);
    let mut t1 = deg(-70.0);
    let phi0 = quasi_static_pose(&r, t1, theta2).unwrap().phi;
    let h = 1e-3;
    for _ in 0..1000 {
        let f = |t: f64| phid * pitch_rate_gain(&r, t, theta2).unwrap();
        let k1 = f(t1);
        let k2 = f(t1 + 0.5 * h * k1);
        let k3 = f(t1 + 0.5 * h * k2);
        let k4 = f(t1 + h * k3);
        t1 += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    let phi1 = quasi_static_pose(&r, t1, theta2).unwrap().phi;
    println!(
        "B.3 tracking: φ from {:.3}° to {:.3}° at θ₁ = {:.2}°",
        phi0.to_degrees(),
        phi1.to_degrees(),
        t1.to_degrees()
    );
    assert!(
        (phi1 - phi0 - phid).abs() < 1e-9,
        "tracked {}",
        (phi1 - phi0).to_degrees()
    );
}

/// Fig. 4.8's optimisation (thesis: ≈ 300°/s over the rolling range, about twice that with the
/// rear body sliding). The LP (Clarabel) is checked against (i) the closed-form ratio
/// `min a_i/(−b_i)`, (ii) the dynamics (5.4) evaluated at the optimum (the binding normal force
/// is zero there), (iii) λ from the reduced dynamics (4.39), a second formulation, and
/// (iv) the exact quadratic dependence of λ on the speed.
#[test]
fn fig_4_8_liftoff_speed_linear_program() {
    let r = rhex(LegShape::HalfCircle);
    let model = &r.model;
    let mut speeds = vec![];
    for (t1, t2) in [
        (deg(-40.0), deg(-40.0)),
        (deg(-20.0), deg(-60.0)),
        (deg(-40.0), deg(-150.0)),
    ] {
        let pose = quasi_static_pose(&r, t1, t2).unwrap();
        let q = [t1, t2, 0.0, -pose.height_m, pose.phi];
        let nfree = 5 - pose.mode.n_rows();
        let mut y = DMatrix::zeros(nfree, 5);
        y[(0, 0)] = 1.0;
        if nfree == 2 {
            y[(1, 1)] = 1.0;
        }
        let h = free_motion_basis(model, &FlatGround, pose.mode, &q, &y).unwrap();
        let dir: Vec<f64> = h.column(0).iter().cloned().collect();
        let ls = liftoff_speed(model, &FlatGround, pose.mode, &q, &dir, &[0.0, 0.0]).unwrap();
        let s = ls.speed.expect("some contact lifts");
        let ratio = (0..ls.a.len())
            .filter(|&i| ls.b[i] < 0.0)
            .map(|i| (ls.a[i] / -ls.b[i]).sqrt())
            .fold(f64::INFINITY, f64::min);
        assert!(
            (s - ratio).abs() < 1e-6 * ratio,
            "LP {s} vs closed form {ratio}"
        );
        let mut data = Data::new(model);
        let qd: Vec<f64> = dir.iter().map(|v| v * s).collect();
        flat_dynamics(model, &mut data, pose.mode, &q, &qd, &[0.0, 0.0]);
        let bind = ls.binding_row.unwrap();
        let scale = ls.a.iter().cloned().fold(0.0, f64::max);
        assert!(
            data.lambda[bind].abs() < 1e-6 * scale,
            "binding normal force {}",
            data.lambda[bind]
        );
        for (k, &i) in ls.normal_rows.iter().enumerate() {
            assert!(-data.lambda[i] >= -1e-6 * scale, "row {i} pulls");
            // λ(2s) = a + 4 b s² exactly
            let qd2: Vec<f64> = dir.iter().map(|v| v * 2.0 * s).collect();
            let mut d2 = Data::new(model);
            flat_dynamics(model, &mut d2, pose.mode, &q, &qd2, &[0.0, 0.0]);
            let pred = ls.a[k] + 4.0 * ls.b[k] * s * s;
            assert!((-d2.lambda[i] - pred).abs() < 1e-8 * (1.0 + pred.abs()));
        }
        if nfree == 1 {
            let red = flat_reduced(model, &mut data, pose.mode, (&q, &qd), &[0.0, 0.0], &y);
            assert!((red.lambda[bind]).abs() < 1e-6 * scale, "(4.39) agrees");
        }
        println!(
            "Fig 4.8 at ({:.0}°, {:.0}°) mode {}: {:.0}°/s",
            t1.to_degrees(),
            t2.to_degrees(),
            pose.label,
            s.to_degrees()
        );
        speeds.push((pose.label.clone(), s));
    }
    // the rear-body mode allows a faster sweep than the rolling double stance
    let rr = speeds
        .iter()
        .filter(|(l, _)| l == "0101")
        .map(|x| x.1)
        .fold(f64::INFINITY, f64::min);
    let rb = speeds
        .iter()
        .filter(|(l, _)| l == "0110")
        .map(|x| x.1)
        .fold(0.0, f64::max);
    assert!(rb > rr);
}

// ---------------------------------------------------------------------------------------
// 4.3.3 Pitch control in leaping
// ---------------------------------------------------------------------------------------

/// Result C.2 / (4.61) (thesis, under D.2 and D.3 (`I_b = 0`):
/// `∂((Uλ)_2n − (Uλ)_1n)/∂θ_d = −2ρτ sin²θ_m/(ℓ² cos θ_m) < 0`). Ours: central differences of
/// the general dynamics (5.4) in double stance; compared with the printed closed form at
/// `I_b = 0`, and its sign checked with Table 4.2's `I_b` and at speed.
#[test]
fn result_c2_splay_reduces_imbalance() {
    let p = RhexParams {
        leg_shape: LegShape::Stick,
        I_b: 0.0,
        ..Default::default()
    };
    let point_mass = Rhex::new(p.clone()).unwrap();
    let (rho, l) = (p.rho1, p.l1);
    for tm in [5.0, 15.0, 25.0] {
        for tau in [5.0, 20.0] {
            let tm = deg(tm);
            let ours = splay_derivative(&point_mass, tm, 0.0, tau).unwrap();
            let printed = -2.0 * rho * tau * tm.sin().powi(2) / (l * l * tm.cos());
            println!(
                "C.2 θ_m={:.0}° τ={tau}: (4.61) {printed:.5} | ours {ours:.5}",
                tm.to_degrees()
            );
            assert!((ours - printed).abs() < 1e-5 * (1.0 + printed.abs()));
        }
    }
    // Table 4.2's I_b = 0.15: the thesis says C.2 holds "numerically" too. A second
    // formulation of λ — the reduced dynamics (4.39) with y = θ_m — gives the same derivative,
    // and its sign is reported (see errata: the inertial pitching term dominates).
    let table = rhex(LegShape::Stick);
    let y = DMatrix::from_row_slice(1, 5, &[0.5, 0.5, 0.0, 0.0, 0.0]);
    for tm in [5.0, 15.0, 25.0] {
        for thd in [0.0, 5.0] {
            for tau in [0.0, 2.0, 15.0] {
                let d = splay_derivative(&table, deg(tm), thd, tau).unwrap();
                let imb = |td: f64| {
                    let (q, qd, mode) = double_stance_state(&table, deg(tm), td, thd).unwrap();
                    let mut data = Data::new(&table.model);
                    let red =
                        flat_reduced(&table.model, &mut data, mode, (&q, &qd), &[tau, tau], &y);
                    -red.lambda[3] + red.lambda[1]
                };
                let e = 1e-5;
                let d2 = (imb(e) - imb(-e)) / (2.0 * e);
                let d0 = -2.0 * table.params.rho1 * tau * deg(tm).sin().powi(2)
                    / (table.params.l1.powi(2) * deg(tm).cos());
                println!("C.2 Table I_b θ_m={tm}° θ̇_m={thd} τ={tau}: (4.61) {d0:.3} | KKT {d:.3} | (4.39) {d2:.3}");
                assert!((d - d2).abs() < 1e-4 * (1.0 + d.abs()));
            }
        }
    }
}

/// Independent Lagrangian of the rear-stick-leg stance (massless legs, toe pinned at the
/// origin): `y = (θ₂, φ)`, COM `p(y) = (ℓ₂ cos φ + ρ sin(θ₂−φ), −ℓ₂ sin φ − ρ cos(θ₂−φ))`,
/// `T = ½ m|ṗ|² + ½ I φ̇²`, `V = −m g p_z`, generalized force `(τ₂, 0)`; Coriolis terms by
/// finite differences of `M(y)`. Returns `φ̈`.
fn lagrangian_phi_dd(p: &RhexParams, th: f64, phi: f64, thd: f64, phid: f64, tau: f64) -> f64 {
    let (m, i, l, rho, g) = (p.m_b, p.I_b, p.l2, p.rho2, p.g);
    let jac = |th: f64, phi: f64| {
        let u = th - phi;
        DMatrix::from_row_slice(
            2,
            2,
            &[
                rho * u.cos(),
                -l * phi.sin() - rho * u.cos(),
                rho * u.sin(),
                -l * phi.cos() - rho * u.sin(),
            ],
        )
    };
    let mass = |th: f64, phi: f64| {
        let j = jac(th, phi);
        let mut mm = j.transpose() * j * m;
        mm[(1, 1)] += i;
        mm
    };
    let yd = DVector::from_vec(vec![thd, phid]);
    let e = 1e-6;
    let mdot =
        (mass(th + e * thd, phi + e * phid) - mass(th - e * thd, phi - e * phid)) / (2.0 * e);
    let kin = |th: f64, phi: f64| 0.5 * (yd.transpose() * mass(th, phi) * &yd)[(0, 0)];
    let dtdy = DVector::from_vec(vec![
        (kin(th + e, phi) - kin(th - e, phi)) / (2.0 * e),
        (kin(th, phi + e) - kin(th, phi - e)) / (2.0 * e),
    ]);
    let pz = |th: f64, phi: f64| -l * phi.sin() - rho * (th - phi).cos();
    let dvdy = DVector::from_vec(vec![
        -m * g * (pz(th + e, phi) - pz(th - e, phi)) / (2.0 * e),
        -m * g * (pz(th, phi + e) - pz(th, phi - e)) / (2.0 * e),
    ]);
    let rhs = DVector::from_vec(vec![tau, 0.0]) - mdot * &yd + dtdy - dvdy;
    mass(th, phi).lu().solve(&rhs).unwrap()[1]
}

/// Result C.3 / (4.63) (thesis: `φ̈` grows with `τ₂` and with the rear leg speed).
/// Ours: `φ̈` from the KKT dynamics (5.3) vs an independent Lagrangian, and vs the printed
/// (4.63) at mid-stance (`θ₂ = φ = 0`) where we re-derived it by hand
/// (`φ̈ = (ℓ₂ m ρ θ̇₂² + τ₂ − ℓ₂ m g)/(I_b + ℓ₂² m)`). Monotonicity over D.1.
#[test]
fn result_c3_single_leg_pitch_dynamics() {
    let model = takeoff_model(None, TakeoffLeg::Stick).unwrap();
    let p = RhexParams::default();
    let (m, i, l, rho, g) = (p.m_b, p.I_b, p.l2, p.rho2, p.g);
    let mut max_dev_printed = 0.0f64;
    for (th, phi, thd, phid, tau) in [
        (0.0, 0.0, 5.0, 0.0, 10.0),
        (deg(20.0), deg(5.0), 8.0, 1.0, 20.0),
        (deg(-25.0), deg(-8.0), 3.0, -2.0, 5.0),
        (deg(10.0), deg(-3.0), 12.0, 0.5, 25.0),
    ] {
        let ours = single_leg_pitch_accel(&model, th, phi, thd, phid, tau).unwrap();
        let lag = lagrangian_phi_dd(&p, th, phi, thd, phid, tau);
        let c = th.cos();
        let printed = (l * m * c * (rho * (thd - phid).powi(2) + l * th.sin() * phid * phid)
            + tau * (1.0 + l / rho * th.sin())
            - l * m * g * c * (th - phi).cos())
            / (i + l * l * m * c * c);
        max_dev_printed = max_dev_printed.max((printed - ours).abs());
        println!(
            "C.3 θ₂={:.0}° φ={:.0}°: (4.63) {printed:.4} | Lagrange {lag:.4} | ours {ours:.4}",
            th.to_degrees(),
            phi.to_degrees()
        );
        assert!(
            (ours - lag).abs() < 1e-5 * (1.0 + lag.abs()),
            "KKT vs Lagrangian"
        );
        if th == 0.0 && phi == 0.0 && phid == 0.0 {
            let hand = (l * m * rho * thd * thd + tau - l * m * g) / (i + l * l * m);
            assert!((ours - hand).abs() < 1e-9 * (1.0 + hand.abs()));
            assert!((printed - hand).abs() < 1e-9 * (1.0 + hand.abs()));
        }
    }
    println!(
        "largest |(4.63) − ours| away from mid-stance: {max_dev_printed:.3} rad/s² (see errata)"
    );
    for th in [-25.0, -10.0, 0.0, 10.0, 25.0] {
        for phi in [-8.0, 0.0, 8.0] {
            let (th, phi) = (deg(th), deg(phi));
            let a = |thd: f64, tau: f64| {
                single_leg_pitch_accel(&model, th, phi, thd, 0.5, tau).unwrap()
            };
            assert!(a(6.0, 12.0) > a(6.0, 10.0), "C.3: harder push pitches up");
            assert!(a(7.0, 10.0) > a(6.0, 10.0), "C.3: faster leg pitches up");
        }
    }
}

/// Result C.4 (thesis: rounded legs' takeoff bound (4.66) exceeds the stick legs' (4.65), by at
/// least 0.6 m/s over Fig. 4.10's range). Ours: the general bound (first root of the liftoff
/// quadratic, X-RHex motor, G = 23, two motors per planar leg) vs the re-derived closed forms at
/// mid-stance; at the bound the dynamics give a zero normal force; then the margin over D.1.
#[test]
fn result_c4_takeoff_speed_bound() {
    let p = RhexParams::default();
    let line = xrhex_line(23.0).unwrap();
    let stick = takeoff_model(None, TakeoffLeg::Stick).unwrap();
    let round = takeoff_model(None, TakeoffLeg::Rolling).unwrap();
    let bs = rear_takeoff_speed(&stick, 0.0, 0.0, 0.0, &line)
        .unwrap()
        .unwrap();
    let br = rear_takeoff_speed(&round, 0.0, 0.0, 0.0, &line)
        .unwrap()
        .unwrap();
    let (cs, cr) = (
        midstance_closed_form(&p, &line, 0.0, 1.0),
        midstance_closed_form(&p, &line, 0.0, 0.5),
    );
    println!("C.4 mid-stance: stick (4.65) {cs:.4} | ours {:.4} m/s; round (4.66) {cr:.4} | ours {:.4} m/s", bs.x_dot.abs(), br.x_dot.abs());
    assert!((bs.x_dot.abs() - cs).abs() < 1e-8 * cs);
    assert!((br.x_dot.abs() - cr).abs() < 1e-8 * cr);
    // with a pitch rate too
    let pd = 0.8;
    let bsp = rear_takeoff_speed(&stick, 0.0, 0.0, pd, &line)
        .unwrap()
        .unwrap();
    let x_hand = midstance_closed_form(&p, &line, pd, 1.0);
    println!(
        "   φ̇ = {pd}: (4.65) {x_hand:.4} | ours {:.4} m/s",
        bsp.x_dot.abs()
    );
    assert!((bsp.x_dot.abs() - x_hand).abs() < 1e-8 * x_hand);
    // at the bound the contact force vanishes (independent evaluation of (5.4))
    for (model, b) in [(&stick, &bs), (&round, &br)] {
        let (q, mode) = rear_stance_q(model, 0.0, 0.0).unwrap();
        let j = 1;
        let mut y = DMatrix::zeros(3, 5);
        y[(0, 0)] = 1.0;
        y[(1, 1)] = 1.0;
        y[(2, 4)] = 1.0;
        let h = free_motion_basis(model, &FlatGround, mode, &q, &y).unwrap();
        let qd: Vec<f64> = (h.column(j) * b.leg_rate).iter().cloned().collect();
        let mut data = Data::new(model);
        flat_dynamics(model, &mut data, mode, &q, &qd, &[0.0, b.tau]);
        assert!(
            data.lambda[1].abs() < 1e-8 * p.m_b * p.g,
            "normal force at the bound {}",
            data.lambda[1]
        );
    }
    // over D.1 (θ₂ ∈ [−30°, 30°], φ ∈ [−10°, 10°])
    let mut min_gap = f64::INFINITY;
    for i in 0..=12 {
        for k in 0..=4 {
            let (t2, phi) = (deg(-30.0 + 5.0 * i as f64), deg(-10.0 + 5.0 * k as f64));
            let s = rear_takeoff_speed(&stick, t2, phi, 0.0, &line)
                .unwrap()
                .unwrap()
                .x_dot
                .abs();
            let r = rear_takeoff_speed(&round, t2, phi, 0.0, &line)
                .unwrap()
                .unwrap()
                .x_dot
                .abs();
            min_gap = min_gap.min(r - s);
        }
    }
    println!("C.4: round − stick over D.1 ≥ {min_gap:.3} m/s (thesis: ≥ 0.6 m/s)");
    assert!(min_gap >= 0.6, "C.4's 0.6 m/s margin");
}

/// Fig. 4.11 (thesis: optimum gear ratio ≈ 25–30, XRL uses 23). Ours: at mid-stance the general
/// machinery's optimum equals the optimum of the closed form (4.66) over `G` (a second route,
/// maximised independently); with `θ₂` free, the optimum is a verified local maximum.
#[test]
fn fig_4_11_optimal_gear_ratio() {
    let p = RhexParams::default();
    let round = takeoff_model(None, TakeoffLeg::Rolling).unwrap();
    let mut cf = |g: f64| midstance_closed_form(&p, &xrhex_line(g).unwrap(), 0.0, 0.5);
    let (g_cf, v_cf) = golden_max(5.0, 100.0, 1e-7, &mut cf);
    let mut gen = |g: f64| {
        rear_takeoff_speed(&round, 0.0, 0.0, 0.0, &xrhex_line(g).unwrap())
            .unwrap()
            .unwrap()
            .x_dot
            .abs()
    };
    let (g_gen, v_gen) = golden_max(5.0, 100.0, 1e-7, &mut gen);
    println!("mid-stance optimum: closed form G = {g_cf:.3} ({v_cf:.3} m/s) | ours G = {g_gen:.3} ({v_gen:.3} m/s)");
    assert!((g_cf - g_gen).abs() < 1e-3 * g_cf);
    let range = [deg(-45.0), deg(45.0)];
    for phi in [deg(-5.0), 0.0, deg(5.0)] {
        let (g_opt, v_opt) =
            optimal_gear_ratio(&round, phi, 0.0, range, [5.0, 80.0], &|g| xrhex_line(g)).unwrap();
        let at =
            |g: f64| best_takeoff_over_theta2(&round, phi, 0.0, &xrhex_line(g).unwrap(), range).1;
        println!("Fig 4.11 φ = {:.0}°: optimal G = {g_opt:.2} ({v_opt:.3} m/s) vs G = 23: {:.3} m/s (thesis: 25–30 vs 23)", phi.to_degrees(), at(23.0));
        assert!(v_opt >= at(g_opt - 2.0) - 1e-9 && v_opt >= at(g_opt + 2.0) - 1e-9);
        assert!((25.0..=30.0).contains(&g_opt), "the thesis's 25–30 window");
        assert!(v_opt > at(23.0), "X-RHex's 23 is below the optimum");
    }
}

/// Result C.5 (thesis: ε_n = 0.035 predicted with six legs, 14°/360° = 0.039 measured).
/// Three routes: our closed form (4.68, re-derived), the zero-momentum integral over a
/// revolution, and a full simulation of the flight dynamics with PD-tracked legs under gravity.
#[test]
fn result_c5_legs_as_tails() {
    for pairs in [2usize, 3] {
        let r = tail_rhex(None, pairs).unwrap();
        let p = &r.params;
        let hips: Vec<f64> = r
            .params
            .ordered_pairs()
            .iter()
            .map(|&pp| p.hip_x(pp))
            .collect();
        let cf =
            effectiveness_closed_form(p.m_b, p.I_b, p.m_l, p.I_l, 0.5 * p.rho1, &hips).unwrap();
        let eps = leg_effectiveness(&r).unwrap();
        let joints: Vec<usize> = (0..pairs).collect();
        // configuration independence (4.68)
        for th in [0.0, 1.0, 2.5, -2.0] {
            let mut q = vec![0.0; r.model.nq()];
            for &j in &joints {
                q[j] = th;
            }
            assert!((effectiveness_at(&r.model, &q, &joints).unwrap() - cf).abs() < 1e-12);
        }
        let sim =
            revolution_rotation_dynamic(&r.model, &vec![0.0; r.model.nq()], &joints, 0.3, 2e-4)
                .unwrap();
        let eps_sim = sim.delta_phi.abs() / (2.0 * PI);
        println!(
            "C.5 {pairs} pairs: closed form {cf:.5} | momentum {eps:.5} | flight sim {eps_sim:.5} ({:.2}° per revolution; tracking err {:.1e}) — thesis 0.035 (model), 0.039 (measured, 14°)",
            sim.delta_phi.abs().to_degrees(),
            sim.max_tracking_error
        );
        assert!((eps - cf).abs() < 1e-10);
        assert!((eps_sim - cf).abs() < 1e-3 * cf);
        assert!(
            sim.delta_phi > 0.0,
            "the body turns against the legs (φ about +y, θ about −y)"
        );
    }
}

/// Bad input gives typed errors naming the field.
#[test]
fn bad_input_is_rejected() {
    use rhex_model::RhexError;
    let field = |e: RhexError| match e {
        RhexError::InvalidValue { field, .. } => field,
        other => panic!("unexpected {other:?}"),
    };
    assert_eq!(
        field(TorqueSpeedLine::new(-1.0, 10.0).unwrap_err().into()),
        "stall_torque_n_m"
    );
    assert_eq!(field(xrhex_line(f64::NAN).unwrap_err()), "gear_ratio");
    assert_eq!(field(tail_rhex(None, 4).unwrap_err()), "pairs");
    let r = rhex(LegShape::HalfCircle);
    assert_eq!(field(max_sensor_pitch(&r, 2).unwrap_err()), "grid");
    assert_eq!(
        field(holding_torque(&r, f64::INFINITY, 0.0).unwrap_err()),
        "theta"
    );
    let m = &r.model;
    assert_eq!(
        field(
            revolution_rotation_dynamic(m, &[0.0; 5], &[0, 1], 0.3, 1e-3)
                .unwrap_err()
                .into()
        ),
        "model",
        "massless legs have no tail effect"
    );
    assert_eq!(
        field(effectiveness_at(m, &[0.0; 5], &[7]).unwrap_err().into()),
        "joints"
    );
}
