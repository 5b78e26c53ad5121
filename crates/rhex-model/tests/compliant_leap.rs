//! The RHex leap with compliant C-legs (`LeapConfig::compliant_leg`,
//! `selfmanip_sim::compliant_leg`): stick legs with Table 4.2's mass, a knee spring–damper of
//! radial stiffness `k_r` and damping `c_r`. Routes of their own: the rigid limit `k_r → ∞`
//! against the rigid leap of the same legs, the exact derivatives in `leg_stiffness` and
//! `leg_damping` against Richardson-extrapolated central differences, and the recovery of a
//! stated stiffness and damping from synthetic apex tables with motion-capture noise by
//! bounded Gauss–Newton on the exact Jacobians.
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, Strategy};
use rhex_model::leap_sensitivity::leap_with_sensitivity;
use rhex_model::params::LegShape;
use rhex_model::{RhexError, RhexParams};
use selfmanip_hybrid::EventKind;
use selfmanip_sim::compliant_leg::CompliantLeg;

/// Table 4.2's legs (mass on the hip link), stick-shaped: what a compliant leg is made of.
fn params() -> RhexParams {
    RhexParams {
        leg_shape: LegShape::Stick,
        ..leap_params().with_table_4_2_legs()
    }
}

/// [`params`] with toes that never slip (chapter 3's pinned toes, section 3.1.2).
fn pinned() -> RhexParams {
    RhexParams {
        mu_front: None,
        mu_middle: None,
        mu_rear: None,
        ..params()
    }
}

/// A leap of `strategy` at `t2` with a radial leg of `k_r`, `c_r` (rigid for `None`), its
/// free legs under step control (as with sensitivities).
fn cfg(strategy: &str, t2: f64, leg: Option<(f64, f64)>) -> LeapConfig {
    LeapConfig {
        strategy: strategy.parse::<Strategy>().unwrap(),
        t2_s: t2,
        control_free_joints: true,
        compliant_leg: leg.map(|(k, c)| CompliantLeg::radial(k, c)),
        ..LeapConfig::default()
    }
}

fn apex(p: &RhexParams, c: &LeapConfig) -> Vec<f64> {
    let r = simulate_leap(p, c).unwrap();
    let a = r
        .apex
        .unwrap_or_else(|| panic!("{}: {}", r.outcome.status.as_str(), r.reason()));
    a.to_array().to_vec()
}

/// Damping at ratio ζ for half the body's mass on one leg: `c_r = 2 ζ √(k_r m_b / 2)`.
fn damping(k: f64, zeta: f64) -> f64 {
    2.0 * zeta * (k * 0.5 * params().m_b).sqrt()
}

/// The rigid limit, pinned toes: as `k_r` grows (ζ = 0.3), the apex approaches the rigid
/// leap's of the same legs, the difference in height and pitch shrinking with each step
/// of `√10` in `k_r` (slowly: 4.3, 3.2, 1.7 cm and 30°, 14°, 7° at 10⁴, 3.16·10⁴, 10⁵ N/m; at
/// 3.16·10⁵ N/m the massless knee's hold in the air re-touches the middle toe in a
/// chatter that ends the leap without flight).
#[test]
fn stiff_legs_converge_to_the_rigid_leap() {
    let (strategy, t2) = ("++", 0.03);
    let rigid = apex(&pinned(), &cfg(strategy, t2, None));
    let mut last = [f64::INFINITY; 2];
    for k in [1e4, 3.16e4, 1e5] {
        let a = apex(&pinned(), &cfg(strategy, t2, Some((k, damping(k, 0.3)))));
        let d = [a[2] - rigid[2], (a[3] - rigid[3]).to_degrees()];
        println!(
            "{strategy} t2 {t2}: k_r {k:.2e}: apex z {:+.3e} m, φ {:+.3e}°, x {:+.3e} m from the \
             rigid leap's (z {:.4} m, φ {:.2}°)",
            d[0],
            d[1],
            a[1] - rigid[1],
            rigid[2],
            rigid[3].to_degrees()
        );
        for i in 0..2 {
            assert!(d[i].abs() < last[i], "{d:?} after {last:?}");
            last[i] = d[i].abs();
        }
    }
}

/// `d apex / d leg_stiffness` and `d apex / d leg_damping` (exact, through every event) agree
/// with Richardson-extrapolated central differences of whole leaps to 1e-5 of the largest
/// entry (the apex `ż` left out: it is 0 at every apex).
#[test]
fn apex_derivatives_in_stiffness_and_damping() {
    let (k, c) = (2e4, damping(2e4, 0.3));
    let base = cfg("++", 0.03, Some((k, c)));
    let s = leap_with_sensitivity(&params(), &base, &["leg_stiffness", "leg_damping"]).unwrap();
    assert!(s.ok, "{:?}", s.reason);
    for (j, p) in [k, c].into_iter().enumerate() {
        let at = |x: f64| {
            let leg = if j == 0 { (x, c) } else { (k, x) };
            apex(&params(), &cfg("++", 0.03, Some(leg)))
        };
        let d = |h: f64| -> Vec<f64> {
            at(p + h)
                .iter()
                .zip(at(p - h))
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect()
        };
        let h = 1e-3 * p;
        let (d1, d2) = (d(h), d(h / 2.0));
        let fd: Vec<f64> = d1
            .iter()
            .zip(&d2)
            .map(|(a, b)| (4.0 * b - a) / 3.0)
            .collect();
        let exact: Vec<f64> = (0..7).map(|r| s.d_apex[r][j]).collect();
        let keep = |i: &usize| *i != 5;
        let size = (0..7).filter(keep).fold(0.0f64, |m, i| m.max(fd[i].abs()));
        let err = (0..7)
            .filter(keep)
            .fold(0.0f64, |m, i| m.max((exact[i] - fd[i]).abs()));
        println!(
            "d apex / d {}: exact {exact:.6?}\n  FD {fd:.6?}\n  worst {err:.3e} of {size:.3e}",
            s.parameters[j]
        );
        assert!(size > 0.0 && err < 1e-5 * size, "{err} of {size}");
    }
}

/// Bad input is a typed error naming the field: a negative stiffness, damping without its
/// stiffness, a compliant half-circle leg, and the derivative of a rigid leap's stiffness.
#[test]
fn bad_compliant_legs_name_the_field() {
    let field = |r: Result<(), RhexError>| match r {
        Err(e) => e.field().unwrap_or_default().to_string(),
        Ok(()) => "ok".into(),
    };
    let bad = |leg: CompliantLeg| {
        let c = LeapConfig {
            compliant_leg: Some(leg),
            ..LeapConfig::default()
        };
        field(simulate_leap(&params(), &c).map(|_| ()))
    };
    assert_eq!(
        bad(CompliantLeg::radial(-5.0, 1.0)),
        "compliant_leg.stiffness_n_per_m"
    );
    let damping_only = CompliantLeg {
        damping_n_m_s_per_rad: Some(0.1),
        ..CompliantLeg::default()
    };
    assert_eq!(bad(damping_only), "compliant_leg.damping_n_m_s_per_rad");
    let half_circle = LeapConfig {
        compliant_leg: Some(CompliantLeg::radial(1e4, 50.0)),
        ..LeapConfig::default()
    };
    let r = simulate_leap(&leap_params().with_table_4_2_legs(), &half_circle);
    assert!(field(r.map(|_| ())).ends_with(".shape"));
    let r = leap_with_sensitivity(&params(), &LeapConfig::default(), &["leg_damping"]);
    assert_eq!(field(r.map(|_| ())), "leg_damping");
}

/// The apex channels a recovery fits (x, z, φ, ẋ, φ̇) and a motion-capture system's error on
/// each (2 mm, 2 mm, 0.5°, 20 mm/s, 5°/s): `calibrate`'s default channel scales.
const CHANNELS: [(usize, f64); 5] = [
    (1, 2e-3),
    (2, 2e-3),
    (3, 0.5 * std::f64::consts::PI / 180.0),
    (4, 0.02),
    (6, 5.0 * std::f64::consts::PI / 180.0),
];

/// The scaled apexes of the `(+,+)` series at `t2s` with a leg of `(k_r, c_r)`, and their
/// exact Jacobian in `(k_r, c_r)` (rows in `t2s` × [`CHANNELS`] order); `None` where a
/// leap's derivatives are not defined (its reason printed).
fn series(t2s: &[f64], leg: (f64, f64)) -> Option<(Vec<f64>, Vec<[f64; 2]>)> {
    let (mut y, mut j) = (Vec::new(), Vec::new());
    for &t2 in t2s {
        let s = leap_with_sensitivity(
            &pinned(),
            &cfg("++", t2, Some(leg)),
            &["leg_stiffness", "leg_damping"],
        )
        .unwrap();
        if !s.ok {
            println!(
                "  k_r {:.0}, c_r {:.1}, t2 {t2}: {:?}",
                leg.0, leg.1, s.reason
            );
            return None;
        }
        // a truncated leap's apex is set by the truncation's dwell (the engine's resolution
        // of a chatter), not by the leg alone: the fit does not step onto one
        let events = &s.result.execution.events;
        if events.iter().any(|e| e.kind == EventKind::ZenoTruncation) {
            println!("  k_r {:.0}, c_r {:.1}, t2 {t2}: truncated", leg.0, leg.1);
            return None;
        }
        let a = s.result.apex.unwrap();
        let v = a.to_array();
        for &(c, scale) in &CHANNELS {
            y.push(v[c] / scale);
            j.push([s.d_apex[c][0] / scale, s.d_apex[c][1] / scale]);
        }
    }
    Some((y, j))
}

/// Recovery: apex tables of the `(+,+)` series with pinned toes (8 coordination times) generated with a stated
/// leg, `k_r = 2·10⁴` N/m and `c_r` at ζ = 0.3, plus Gaussian motion-capture noise of the
/// channels' scales, are fitted by Gauss–Newton with step halving on the exact Jacobians
/// from `(k_r, c_r) = (10⁴, 100)` and `(3·10⁴, 150)`, the lower cost kept (a trial point
/// whose leaps have no derivatives or were truncated counts as a rise of the cost) (log-parameters,
/// bounded to a decade either side; the cost has a second minimum near `(4·10³, 220)`); each fit's 95 % intervals
/// `±1.96 σ` from `(JᵀJ)⁻¹` (the noise's scales known) contain the stated values in every
/// draw of 4 (`COMPLIANT_DRAWS=20`: at least 19 of 20), and both are identified (the smaller singular value of the scaled Jacobian
/// is reported with the intervals).
#[test]
fn calibration_recovers_a_stated_stiffness_and_damping() {
    use rand::{Rng, SeedableRng};
    let t2s = [-0.06, -0.04, -0.02, 0.02, 0.04, 0.06, 0.08, 0.1];
    let truth = (2e4, damping(2e4, 0.3));
    let (clean, _) = series(&t2s, truth).expect("the stated leg's leaps are differentiable");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(33);
    let mut normal = move || {
        let (u, v): (f64, f64) = (rng.gen::<f64>().max(1e-300), rng.gen());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    };
    let (mut inside, mut runs) = (0, 0);
    // each draw costs ~100 s of leaps with derivatives: 4 by default, the 20 with
    // COMPLIANT_DRAWS=20
    let draws: usize = std::env::var("COMPLIANT_DRAWS").map_or(4, |v| v.parse().unwrap());
    for draw in 0..draws {
        let measured: Vec<f64> = clean.iter().map(|y| y + normal()).collect();
        // Gauss–Newton in (ln k, ln c)
        // two starts (the cost has a second minimum near (4·10³, 220) with 15× the noise's
        // cost): the fit of the lower cost
        let mut best: Option<([f64; 2], f64, nalgebra::Matrix2<f64>)> = None;
        for start in [(1e4f64, 100f64), (3e4, 150.0)] {
            let mut x = [start.0.ln(), start.1.ln()];
            let (lo, hi) = (
                [truth.0.ln() - 2.3, truth.1.ln() - 2.3],
                [truth.0.ln() + 2.3, truth.1.ln() + 2.3],
            );
            // the scaled residuals, the cost and the Jacobian in (ln k, ln c) at x
            let eval = |x: &[f64; 2]| {
                let p = (x[0].exp(), x[1].exp());
                let Some((y, j)) = series(&t2s, p) else {
                    return (f64::INFINITY, Vec::new(), Vec::new());
                };
                let r: Vec<f64> = y.iter().zip(&measured).map(|(y, m)| y - m).collect();
                let rows: Vec<nalgebra::Vector2<f64>> = j
                    .iter()
                    .map(|j| nalgebra::Vector2::new(j[0] * p.0, j[1] * p.1))
                    .collect();
                (r.iter().map(|r| r * r).sum::<f64>(), r, rows)
            };
            let (mut cost, mut r, mut rows) = eval(&x);
            if !cost.is_finite() {
                continue;
            }
            runs += t2s.len();
            for _ in 0..15 {
                let jtj: nalgebra::Matrix2<f64> = rows.iter().map(|v| v * v.transpose()).sum();
                let g: nalgebra::Vector2<f64> = rows.iter().zip(&r).map(|(v, r)| v * *r).sum();
                let mut step = jtj.lu().solve(&(-g)).unwrap();
                // step halving: a Gauss–Newton step is taken only where it lowers the cost
                let mut accepted = false;
                for _ in 0..6 {
                    let t = [0, 1].map(|i| (x[i] + step[i]).clamp(lo[i], hi[i]));
                    let (c, rr, vv) = eval(&t);
                    runs += t2s.len();
                    if c < cost {
                        (x, cost, r, rows, accepted) = (t, c, rr, vv, true);
                        break;
                    }
                    step *= 0.5;
                }
                if !accepted || step.norm() < 1e-7 {
                    break;
                }
            }
            let jtj = rows.iter().map(|v| v * v.transpose()).sum();
            if best.as_ref().is_none_or(|b| cost < b.1) {
                best = Some((x, cost, jtj));
            }
        }
        let (x, cost, jtj) = best.unwrap();
        let cov = jtj.try_inverse().unwrap();
        let sv = jtj.symmetric_eigenvalues().map(f64::sqrt);
        let ok = [truth.0, truth.1]
            .iter()
            .enumerate()
            .all(|(i, t)| (t.ln() - x[i]).abs() <= 1.96 * cov[(i, i)].sqrt());
        inside += usize::from(ok);
        println!(
            "draw {draw:2}: k_r {:.0} N/m ± {:.1} %, c_r {:.2} N s/m ± {:.1} % (95 %); stated {:.0}, {:.2}; \
             singular values {:.3e}, {:.3e}; cost {cost:.1} of {} residuals; {}",
            x[0].exp(),
            196.0 * cov[(0, 0)].sqrt(),
            x[1].exp(),
            196.0 * cov[(1, 1)].sqrt(),
            truth.0,
            truth.1,
            sv.max(),
            sv.min(),
            clean.len(),
            if ok { "inside" } else { "OUTSIDE" }
        );
        assert!(
            sv.min() > 1.0,
            "a combination of k_r and c_r is not identified: {sv}"
        );
    }
    println!(
        "{inside} of {draws} draws inside their 95 % intervals; {runs} leaps with derivatives"
    );
    // at least 19 of 20 (all of fewer than 20)
    assert!(inside + draws / 20 >= draws, "{inside} of {draws}");
}
