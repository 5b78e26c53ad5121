//! A compliant leg ([`selfmanip_sim::compliant_leg`]) against routes of its own: the
//! vertical bounce of a body on one radial spring–damper leg against the damped
//! spring–mass's closed form, the energy balance with the spring's stored energy and the
//! damper's loss, and the exact derivatives in the leg's stiffness and damping against
//! Richardson-extrapolated central differences.
//!
//! **The bouncer.** A body of 7 kg (no gravity) with one leg under its centre of mass,
//! pointing straight down, Table 4.2's leg-pair mass (0.126 kg, 0.00092 kg m²) on its hip
//! link and no hip torque, its toe never slipping, falls onto the ground at `v₀`. The toe
//! force runs along the hip–toe line through the centre of mass: to first order in the
//! compression over the lever `e`, the body and hip link (`m = m_b + m_l`) bounce on a
//! linear spring `k_r` and damper `c_r`: `ω = √(k_r/m)`, `ζ = c_r / (2√(k_r m))`,
//! `ω_d = ω √(1 − ζ²)`. The toe leaves the ground when its force `k_r x + c_r ẋ` reaches zero
//! (not when `x` does): with `ζ = sin α`, at `ω_d t_c = π − 2α`, and there
//! `ẋ = −v₀ e^{−ζ ω t_c}`, so the contact lasts `t_c = (π − 2 asin ζ)/ω_d` and the rebound
//! ratio is `e^{−ζ (π − 2 asin ζ)/√(1 − ζ²)}` (the textbook `e^{−ζπ/√(1−ζ²)}` is the ratio
//! where `x` returns to 0, which a unilateral contact with a damper never waits for).
mod common;

use selfmanip_core::dynamics::energy;
use selfmanip_core::{Data, RobotDescription};
use selfmanip_hybrid::EventKind;
use selfmanip_sim::compliant_leg::{
    make_compliant, CompliantLeg, CompliantLegIndex, LEG_DAMPING, LEG_STIFFNESS,
};
use selfmanip_sim::sensitivity::run_parameter_sensitivity;
use selfmanip_sim::{simulate, Run, Scenario};

const M_B: f64 = 7.0;
const M_L: f64 = 0.126;
const RHO: f64 = 0.17;
/// The toe's height above the ground at the start (m).
const GAP: f64 = 1e-3;

fn robot() -> RobotDescription {
    RobotDescription::from_toml_str(&format!(
        "name = \"bouncer\"\ngravity_m_s2 = 0.0\n[body]\nmass_kg = {M_B}\ninertia_kg_m2 = 0.1\n\
         [[legs]]\nname = \"leg\"\nhip_m = [0.0, 0.0]\n\
         [[legs.links]]\nlength_m = {RHO}\nmass_kg = {M_L}\ninertia_kg_m2 = 0.00092\naxis = \"-y\"\n\
         [[contacts]]\nname = \"toe\"\nleg = \"leg\"\nshape = {{ kind = \"point\", position_m = [0.0, {RHO}] }}\n\
         friction = {{ kind = \"sticking\" }}\n"
    ))
    .unwrap()
}

/// The closed form: `(t_c, rebound ratio, ω, ζ)` of a radial `k_r`, `c_r` under `m_b + m_l`.
fn closed_form(k: f64, c: f64) -> (f64, f64, f64, f64) {
    let m = M_B + M_L;
    let w = (k / m).sqrt();
    let zeta = c / (2.0 * (k * m).sqrt());
    let wd = w * (1.0 - zeta * zeta).sqrt();
    let tc = (std::f64::consts::PI - 2.0 * zeta.asin()) / wd;
    (tc, (-zeta * w * tc).exp(), w, zeta)
}

/// The bouncer falling at `v0` onto a leg of `spec`, run until 1.2 contact times after its
/// touchdown.
fn bouncer(spec: &CompliantLeg, v0: f64) -> (Scenario, CompliantLegIndex) {
    let mut s = Scenario::new(robot(), vec![0.0, 0.0, -(RHO + GAP), 0.0]);
    s.initial.qd = Some(vec![0.0, 0.0, v0, 0.0]);
    let (k_th, c_th) = spec.knee_gains();
    let e2 = spec.knee_offset_m * spec.knee_offset_m;
    let (tc, ..) = closed_form(k_th / e2, c_th / e2);
    s.options.t_final_s = GAP / v0 + 1.2 * tc;
    s.options.stop_at_apex = false;
    s.options.delta_t_s = 0.0;
    s.options.rtol = 1e-11;
    s.options.event_tol_s = 1e-14;
    let idx = make_compliant(&mut s, &["leg"], spec).unwrap();
    (s, idx[0])
}

fn kinds(run: &Run) -> Vec<EventKind> {
    run.execution.events.iter().map(|e| e.kind).collect()
}

/// `(contact time, rebound ratio)` of a run: liftoff less touchdown, and the body's speed
/// away from the ground just after the liftoff over `v0`.
fn bounce(run: &Run, v0: f64) -> (f64, f64) {
    assert_eq!(kinds(run), [EventKind::Touchdown, EventKind::Liftoff]);
    let e = &run.execution.events;
    let nq = run.model.nq();
    (e[1].t - e[0].t, -e[1].qd_after[nq - 2] / v0)
}

/// The bounce agrees with the closed form up to the compression `v₀/ω` over the
/// lever `e` — measured: to second order, halving `v₀` quarters the difference — and the
/// difference extrapolated to `v₀ → 0` (`(4 D(v₀/2) − D(v₀))/3`) is below 1e-5 of the
/// closed form's values (the textbook ratio of `x`'s return is 3–9 % off), for a radial
/// spring with and without damping and for the same spring given at the knee
/// (`k_θ = k_r e²`), which runs the same bounce (to 1e-9). The body neither pitches nor moves
/// across (the force runs through its centre of mass).
#[test]
fn bounce_matches_the_damped_spring_mass() {
    let e = 0.05;
    for (k, c) in [(4000.0, 0.0), (4000.0, 40.0), (20000.0, 150.0)] {
        let (tc, ratio, w, zeta) = closed_form(k, c);
        let textbook = (-zeta * std::f64::consts::PI / (1.0 - zeta * zeta).sqrt()).exp();
        let mut errs = Vec::new();
        for v0 in [0.04, 0.02] {
            let (s, _) = bouncer(&CompliantLeg::radial(k, c), v0);
            let run = simulate(&s).unwrap();
            let (t, r) = bounce(&run, v0);
            let nq = run.model.nq();
            let end = &run.execution;
            let (pitch, across) = (end.q[nq - 1], end.q[nq - 3]);
            assert!(
                pitch.abs() < 1e-8 && across.abs() < 1e-8,
                "{pitch} {across}"
            );
            // the same spring at the knee
            let angular = CompliantLeg::angular(k * e * e, c * e * e);
            let (sa, _) = bouncer(&angular, v0);
            let (ta, ra) = bounce(&simulate(&sa).unwrap(), v0);
            assert!(
                (ta - t).abs() < 1e-9 * t && (ra - r).abs() < 1e-9,
                "{ta} {t}, {ra} {r}"
            );
            println!(
                "k_r {k} c_r {c} v0 {v0}: t_c {t:.6} s (closed form {tc:.6}), rebound {r:.6} \
                 (closed form {ratio:.6}, x-return form {textbook:.6}), compression/e {:.3}",
                v0 / w / e
            );
            errs.push([(t - tc) / tc, r - ratio]);
        }
        for (j, (&big, &small)) in errs[0].iter().zip(&errs[1]).enumerate() {
            let limit = (4.0 * small - big) / 3.0;
            println!("  component {j}: errors {big:.3e}, {small:.3e}; extrapolated {limit:.3e}");
            assert!(
                small.abs() < 0.3 * big.abs() + 1e-9,
                "second order in v0: {big} {small}"
            );
            assert!(limit.abs() < 1e-5, "extrapolated to v0 → 0: {limit}");
        }
    }
}

/// Along the bounce (with gravity: the body falls 2 cm), the kinetic and potential energy
/// of the rigid bodies plus the spring's stored energy `½ k_θ (δ − δ₀)²` plus the damper's
/// loss so far `∫ c_θ δ̇² dt` (trapezoids on 20 000 samples of the trajectory) stay the start's,
/// to 1e-6 of the kinetic energy at touchdown; the engine's own report agrees.
#[test]
fn energy_balance_with_spring_and_damper() {
    let spec = CompliantLeg::radial(20000.0, 150.0);
    let (mut s, idx) = bouncer(&spec, 1.0);
    s.robot.gravity_m_s2 = 9.81;
    let run = simulate(&s).unwrap();
    assert_eq!(
        kinds(&run),
        [EventKind::Touchdown, EventKind::Liftoff],
        "{:?}",
        run.execution.termination
    );
    let (k_th, c_th) = spec.knee_gains();
    let knee = idx.hip + 1;
    let d0 = idx.geometry.rest_bend_rad;
    let (t_td, t_lo) = (run.execution.events[0].t, run.execution.events[1].t);
    let tr = run.trajectory((t_lo - t_td) / 20_000.0).unwrap();
    let mut data = Data::new(&run.model);
    let (mut loss, mut start, mut worst, mut scale) = (0.0, None, 0.0f64, 0.0f64);
    let mut prev: Option<(f64, f64)> = None;
    for i in 0..tr.t_s.len() {
        let t = tr.t_s[i];
        // strictly inside the stance: the impact's jump and the liftoff's instant left out
        if t <= t_td || t >= t_lo {
            continue;
        }
        let (q, qd) = (&tr.q[i], &tr.qd[i]);
        let (kin, pot) = energy(&run.model, &mut data, q, qd).unwrap();
        let p = c_th * qd[knee] * qd[knee];
        if let Some((t0, p0)) = prev {
            loss += 0.5 * (p + p0) * (t - t0);
        }
        prev = Some((t, p));
        let total = kin + pot + 0.5 * k_th * (q[knee] - d0).powi(2) + loss;
        let e0 = *start.get_or_insert(total);
        scale = scale.max(kin);
        worst = worst.max((total - e0).abs());
    }
    println!("energy drift {worst:.3e} J of {scale:.3e} J; damper loss {loss:.4e} J");
    assert!(loss > 1e-3 * scale, "the damper dissipates: {loss}");
    assert!(worst < 1e-6 * scale, "{worst} of {scale}");
    let report = run.energy_report().unwrap();
    assert!(report.residual_j().abs() < 1e-6 * scale, "{report:?}");
}

/// The end state's and the events' exact derivatives in `leg_stiffness` and `leg_damping`
/// (the knee servo's gains' partials, [`run_parameter_sensitivity`]) agree with
/// Richardson-extrapolated central differences of whole runs to 1e-5 (relative to the
/// largest entry), radial and angular.
#[test]
fn stiffness_and_damping_derivatives_match_central_differences() {
    for spec in [
        CompliantLeg::radial(4000.0, 40.0),
        CompliantLeg::angular(10.0, 0.1),
    ] {
        let (s, _) = bouncer(&spec, 0.05);
        let run = simulate(&s).unwrap();
        let seq = kinds(&run);
        let sens = run_parameter_sensitivity(&run, &[LEG_STIFFNESS, LEG_DAMPING]).unwrap();
        let x = sens.state.as_ref().expect("formed");
        let (k, c) = spec.values();
        for (j, (name, p)) in [(LEG_STIFFNESS, k), (LEG_DAMPING, c)]
            .into_iter()
            .enumerate()
        {
            let fd = common::central_in_path(&s, (name, p, 1e-3 * p), &seq, |t| {
                let r = simulate(t).unwrap();
                let (mut y, kinds) = common::fd::end_state_and_events(&r.execution);
                y.extend(r.execution.events.iter().map(|e| e.t));
                (y, kinds)
            });
            let mut exact: Vec<f64> = x.column(j).iter().copied().collect();
            exact.extend(sens.event_times.iter().map(|t| t.as_ref().unwrap()[j]));
            let size = fd.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let err = exact
                .iter()
                .zip(&fd)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            println!("{name} at {p}: worst |exact − FD| {err:.3e} of {size:.3e}");
            assert!(
                size > 0.0 && err < 1e-5 * size,
                "{name}: {exact:?} vs {fd:?}"
            );
        }
    }
}
