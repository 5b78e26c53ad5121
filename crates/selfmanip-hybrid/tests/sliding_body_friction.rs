//! The hybrid engine with Coulomb sliding friction at body sites (the general sliding sites
//! of `selfmanip_core::friction`, folded into the dynamics solve) against closed forms:
//! a puck or a block sliding on level ground stops at `t* = v₀/(μ g)` after
//! `v₀²/(2 μ g)`, where the engine's slip→stick event sticks it (thesis section 5.1.5 with a
//! kinetic coefficient instead of Assumption 5.9); on an incline it slides on with
//! `g (sin α − μ cos α)` when `μ < tan α` and stops and sticks when `μ > tan α`; the energy
//! balance closes with the friction's work equal to the kinetic energy lost (a conservation
//! law).
use selfmanip_core::{ContactKind, ContactMode, GroundPlane, Model};
use selfmanip_hybrid::{
    energy_report, simulate, EventKind, HybridOptions, Termination, ZeroTorque,
};

mod systems;
use systems::{
    coast, coast_sliding_on_level, painleve_mu_star, painleve_rod, sliding, Friction, G,
};

/// A rigid body with point contacts `(name, x, z)` in its frame, sticking with `mu` and
/// sliding with the same kinetic coefficient.
fn body(mass: f64, inertia: f64, points: &[(&str, f64, f64)], mu: f64) -> Model {
    let points: Vec<_> = points
        .iter()
        .map(|&(n, x, z)| (n, x, z, Friction::Coulomb(mu)))
        .collect();
    systems::body(mass, inertia, G, &points)
}

/// A puck (foot at its centre of mass) and a `w × h` block on its two bottom corners, each
/// launched along the level ground at `v₀`: one slip→stick event at `t* = v₀/(μ g)` (the
/// engine's guard on `v_t = 0`, located to the event tolerance), `x(t*) − x₀ = v₀²/(2μg)`,
/// a site sticking after it and the body at rest to the end; the friction's work is
/// `−½ m v₀²` and the engine's energy balance closes.
#[test]
fn body_sliding_on_level_ground_stops_at_v0_over_mu_g_and_sticks() {
    let (w, h) = (0.1, 0.05);
    let cases: [(Model, Vec<usize>, f64, f64); 2] = [
        (
            body(2.0, 0.01, &[("foot", 0.0, 0.0)], 0.4),
            vec![0],
            0.4,
            0.0,
        ),
        (
            body(
                2.0,
                2.0 * (w * w + h * h) / 12.0,
                &[("left", -w / 2.0, h / 2.0), ("right", w / 2.0, h / 2.0)],
                0.3,
            ),
            vec![0, 1],
            0.3,
            -h / 2.0,
        ),
    ];
    let plane = GroundPlane::level(0.0);
    for (model, contacts, mu, z0) in &cases {
        for v0 in [0.8, -1.1] {
            let q = [0.1, *z0, 0.0];
            let qd = [v0, 0.0, 0.0];
            let exec = coast(model, &plane, sliding(contacts), (&q, &qd), 1.0);
            let t_star = f64::abs(v0) / (mu * G);
            let stick = &exec.events[0];
            assert_eq!(stick.kind, EventKind::Stick, "{:?}", exec.events);
            assert!((stick.t - t_star).abs() < 1e-8, "{} vs {t_star}", stick.t);
            // a puck sticks; a block's two sticking corners would be redundant rows
            // (four on three coordinates), so one sticks and the other stays on in its
            // sliding mode, at rest (its cone holds: no edge)
            let stuck = contacts
                .iter()
                .filter(|&&k| stick.mode_after.kind(k) == Some(ContactKind::Stick))
                .count();
            assert_eq!(stuck, 1, "{:?}", stick.mode_after);
            assert!(contacts.iter().all(|&k| stick.mode_after.kind(k).is_some()));
            let d = v0 * f64::abs(v0) / (2.0 * mu * G);
            let x_stop = exec.q[0];
            assert!((x_stop - 0.1 - d).abs() < 1e-7, "{} vs {}", x_stop - 0.1, d);
            assert!(exec.events.iter().all(|e| e.kind == EventKind::Stick));
            assert_eq!(exec.termination, Termination::FinalTime);
            assert!(exec.qd.iter().all(|v| v.abs() < 1e-9), "{:?}", exec.qd);
            let e = energy_report(model, &plane, &exec).unwrap();
            let ke = 0.5 * 2.0 * v0 * v0;
            assert!((e.friction_work_j + ke).abs() < 1e-6 * ke, "{e:?}");
            assert!(e.residual_j().abs() < 1e-6 * ke, "{e:?}");
        }
    }
}

/// A puck launched downhill on a plane tilted by `α`: with `μ < tan α` no event, and the
/// distance down the slope after `T` is `v₀T + ½ g (sin α − μ cos α) T²`; with `μ > tan α`
/// it decelerates at `g (μ cos α − sin α)`, sticks at `t* = v₀ / (g (μ cos α − sin α))` and
/// stays (the cone holds `tan α ≤ μ`). Energy: `ΔE = W_fr`.
#[test]
fn puck_on_incline_slides_on_below_the_cone_and_sticks_above_it() {
    let (alpha, v0, t_end) = (0.4_f64, 0.6, 0.5);
    let plane = GroundPlane {
        point_m: [0.0, 0.0],
        normal_into_ground: [alpha.sin(), alpha.cos()],
    };
    let t = plane.tangent();
    let down = if t.y > 0.0 { t } else { -t };
    for mu in [0.25, 0.6] {
        let model = body(2.0, 0.01, &[("foot", 0.0, 0.0)], mu);
        let q = [0.0, 0.0, alpha];
        let qd = [v0 * down.x, v0 * down.y, 0.0];
        let exec = coast(&model, &plane, sliding(&[0]), (&q, &qd), t_end);
        let a = G * (alpha.sin() - mu * alpha.cos());
        let s = exec.q[0] * down.x + exec.q[1] * down.y;
        if mu < alpha.tan() {
            assert!(exec.events.is_empty(), "{:?}", exec.events);
            let want = v0 * t_end + 0.5 * a * t_end * t_end;
            assert!((s - want).abs() < 1e-7, "{s} vs {want}");
        } else {
            let t_star = v0 / -a;
            assert_eq!(exec.events.len(), 1, "{:?}", exec.events);
            assert_eq!(exec.events[0].kind, EventKind::Stick);
            assert!((exec.events[0].t - t_star).abs() < 1e-8);
            let want = v0 * t_star + 0.5 * a * t_star * t_star;
            assert!((s - want).abs() < 1e-7, "{s} vs {want}");
            assert!(exec.qd.iter().all(|v| v.abs() < 1e-9));
        }
        let e = energy_report(&model, &plane, &exec).unwrap();
        assert!(e.friction_work_j < 0.0);
        assert!(e.residual_j().abs() < 1e-6, "{e:?}");
    }
}

/// Painlevé's rod in the engine: a uniform rod (half-length `l`, `I = m l²/3`) whose end
/// slides away from its centre at angle `θ` has the normal response
/// `1 + 3cos²θ − 3μ sinθ cosθ` (derived by hand in the core's `tests/sliding_friction.rs`);
/// above `μ* = (1 + 3cos²θ)/(3 sinθ cosθ)` the slide has no consistent continuation and the
/// run jams at once (an impact without collision into the end's stick, `tests/painleve_jam.rs`
/// checks its impulse), never a number from the inconsistent slide; below it it slides.
#[test]
fn painleve_rod_run_jams_beyond_the_threshold_and_slides_below_it() {
    let (l, theta) = (0.4, 0.8_f64);
    let s = theta.sin();
    let mu_star = painleve_mu_star(theta);
    for (factor, painleve) in [(1.05, true), (0.95, false)] {
        let mu = mu_star * factor;
        let model = painleve_rod(1.5, l, mu);
        // the end on the ground, sliding at −0.3 m/s (away from the centre), not turning
        let q = [0.0, -l * s, theta];
        let qd = [-0.3, 0.0, 0.0];
        let exec = coast_sliding_on_level(&model, (&q, &qd), 0.05);
        assert!(exec.t > 0.0, "{:?}", exec.termination);
        let jammed = exec
            .events
            .first()
            .is_some_and(|e| e.kind == EventKind::Jam);
        assert_eq!(jammed, painleve, "μ {mu}, μ* {mu_star}: {:?}", exec.events);
        if jammed {
            assert_eq!(exec.events[0].t, 0.0);
            assert_eq!(exec.events[0].triggered, vec![0]);
        }
    }
}

/// Sensitivities through general sliding sites (the friction folded into the solve,
/// differentiated through the folded system: `selfmanip_core::tangent`), against the closed
/// forms and against central differences of whole simulations (`h = 1e-5` on the initial
/// velocity and position; `x(T)` is quadratic in both, so only round-off remains):
/// - a block sliding on its two corners for `T` short of its stop, `σ` fixed:
///   `x(T) = x₀ + v₀T − ½ μ g σ T²`, `ẋ(T) = v₀ − μ g σ T`, so `∂x(T)/∂v₀ = T`,
///   `∂ẋ(T)/∂v₀ = 1`, `∂x(T)/∂x₀ = 1`, and the rest of those columns against the
///   differences;
/// - a puck sliding to its stop and past it: `x_final = x₀ + v₀|v₀|/(2μg)`, so
///   `∂x_final/∂v₀ = |v₀|/(μ g)` — through the slip→stick event's saltation (the stop time
///   `t* = |v₀|/(μg)` moves with `v₀`, `∂t*/∂v₀ = σ/(μ g)`).
#[test]
fn sensitivity_through_general_sliding_sites_equals_closed_forms_and_differences() {
    use nalgebra::DMatrix;
    let (w, h) = (0.1, 0.05);
    let mu = 0.3;
    let block = body(
        2.0,
        2.0 * (w * w + h * h) / 12.0,
        &[("left", -w / 2.0, h / 2.0), ("right", w / 2.0, h / 2.0)],
        mu,
    );
    let puck = body(2.0, 0.01, &[("foot", 0.0, 0.0)], mu);
    let plane = GroundPlane::level(0.0);
    // the stop located to 1e-13 s: its location's round-off, `μ g δt / 2h` in a difference,
    // stays below 1e-8
    let opts = HybridOptions {
        event_tol_s: 1e-13,
        ..HybridOptions::default()
    };
    let run = |model: &Model, contacts: &[usize], q: &[f64], qd: &[f64], t: f64| {
        simulate(
            model,
            &plane,
            &ZeroTorque,
            sliding(contacts),
            q,
            qd,
            t,
            opts,
        )
        .unwrap()
    };
    let fd = 1e-5;
    for (model, contacts, z0, past_stop) in [
        (&block, vec![0, 1], -h / 2.0, false),
        (&puck, vec![0], 0.0, true),
    ] {
        for v0 in [0.8, -1.1] {
            let t_star = f64::abs(v0) / (mu * G);
            let t_end = if past_stop {
                1.5 * t_star
            } else {
                0.6 * t_star
            };
            let q = [0.1, z0, 0.0];
            let qd = [v0, 0.0, 0.0];
            let (exec, sens) = selfmanip_hybrid::simulate_with_sensitivity(
                model,
                &plane,
                &ZeroTorque,
                sliding(&contacts),
                &q,
                &qd,
                t_end,
                opts,
            )
            .unwrap();
            let kinds: Vec<_> = exec.events.iter().map(|e| e.kind).collect();
            assert_eq!(
                kinds,
                if past_stop {
                    vec![EventKind::Stick]
                } else {
                    vec![]
                }
            );
            let jac = sens.state_jacobian.expect("every saltation defined");
            // x = (q, q̇) = (x, z, φ, ẋ, ż, φ̇): columns ẋ₀ (3) and x₀ (0)
            let sigma = v0.signum();
            let (dx_dv0, dxd_dv0) = if past_stop {
                (f64::abs(v0) / (mu * G), 0.0)
            } else {
                (t_end, 1.0)
            };
            assert!(
                (jac[(0, 3)] - dx_dv0).abs() < 1e-7 * dx_dv0,
                "∂x/∂v₀ {} vs {dx_dv0} (σ {sigma})",
                jac[(0, 3)]
            );
            assert!(
                (jac[(3, 3)] - dxd_dv0).abs() < 1e-7,
                "∂ẋ/∂v₀ {}",
                jac[(3, 3)]
            );
            assert!((jac[(0, 0)] - 1.0).abs() < 1e-9, "∂x/∂x₀ {}", jac[(0, 0)]);
            if past_stop {
                let st = sens.events[0].time_gradient.as_ref().expect("stop time");
                let want = sigma / (mu * G);
                assert!(
                    (st[3] - want).abs() < 1e-7 * want.abs(),
                    "∂t*/∂v₀ {}",
                    st[3]
                );
            }
            // the x₀ and ẋ₀ columns of the whole state's Jacobian against differences
            let mut diff = DMatrix::zeros(6, 2);
            for (c, k) in [0, 3].into_iter().enumerate() {
                let (mut xp, mut xm) = ([q, qd].concat(), [q, qd].concat());
                xp[k] += fd;
                xm[k] -= fd;
                let (ep, em) = (
                    run(model, &contacts, &xp[..3], &xp[3..], t_end),
                    run(model, &contacts, &xm[..3], &xm[3..], t_end),
                );
                assert_eq!(ep.events.len(), exec.events.len());
                assert_eq!(em.events.len(), exec.events.len());
                for i in 0..3 {
                    diff[(i, c)] = (ep.q[i] - em.q[i]) / (2.0 * fd);
                    diff[(3 + i, c)] = (ep.qd[i] - em.qd[i]) / (2.0 * fd);
                }
            }
            let exact = DMatrix::from_fn(6, 2, |i, c| jac[(i, [0, 3][c])]);
            let err = (&exact - &diff).amax() / diff.amax().max(1.0);
            assert!(err < 1e-6, "{}: {err:e}\n{exact}\n{diff}", model.name);
        }
    }
}

/// A rod (half-length `l`, `I = m l²/3`) sliding on one end, turning and falling as it goes:
/// the friction's derivative through the changing geometry (`dBᵀλ`, the folded system's
/// `K'`) carried by the variational equations. The state Jacobian times directions that keep
/// the end on the ground and its normal velocity zero — `ẋ₀`; `(ż₀, φ̇₀) ∝ (−l cos θ, 1)`;
/// `x₀`; `(z₀, φ₀, ż₀) ∝ (−l cos θ, 1, φ̇ l sin θ)` — equals central differences of whole runs (`h = 1e-6`), with the end sliding toward and
/// away from the centre (`σ = ±1`).
#[test]
fn sliding_rod_sensitivity_equals_differences_of_whole_runs() {
    use nalgebra::DVector;
    let (l, theta, mu) = (0.4, 0.8_f64, 0.5);
    let model = painleve_rod(1.5, l, mu);
    let plane = GroundPlane::level(0.0);
    let (s, c) = theta.sin_cos();
    let t_end = 0.05;
    let run = |x: &[f64]| coast(&model, &plane, sliding(&[0]), (&x[..3], &x[3..]), t_end);
    for v_end in [0.8, -0.8] {
        // the end on the ground, sliding at v_end, the rod
        // turning at φ̇ (ż_P = ż + φ̇ l cos θ = 0)
        let phidot = 0.5;
        let x0 = [
            0.0,
            -l * s,
            theta,
            v_end - phidot * l * s,
            -phidot * l * c,
            phidot,
        ];
        let (exec, sens) = selfmanip_hybrid::simulate_with_sensitivity(
            &model,
            &plane,
            &ZeroTorque,
            sliding(&[0]),
            &x0[..3],
            &x0[3..],
            t_end,
            HybridOptions::default(),
        )
        .unwrap();
        assert!(exec.events.is_empty(), "{:?}", exec.events);
        assert_eq!(exec.termination, Termination::FinalTime);
        let jac = sens.state_jacobian.expect("no event");
        let dirs: [[f64; 6]; 4] = [
            [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0, -l * c, 1.0],
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, -l * c, 1.0, 0.0, phidot * l * s, 0.0],
        ];
        let h = 1e-6;
        for d in dirs {
            let d = DVector::from_row_slice(&d);
            let x = DVector::from_row_slice(&x0);
            let (ep, em) = (run((&x + h * &d).as_slice()), run((&x - h * &d).as_slice()));
            let end = |e: &selfmanip_hybrid::Execution| {
                DVector::from_iterator(6, e.q.iter().chain(e.qd.iter()).copied())
            };
            let diff = (end(&ep) - end(&em)) / (2.0 * h);
            let exact = &jac * &d;
            let err = (&exact - &diff).amax() / diff.amax().max(1.0);
            assert!(err < 1e-6, "v_end {v_end}, d {d}: {err:e}\n{exact}\n{diff}");
        }
    }
}

/// A puck put down sticking at rest on an incline steeper than its cone (`tan α > μ`) slips
/// at once (the cone cannot hold `m g sin α` with `μ m g cos α`), and from rest its friction
/// takes the cone edge against the coming slide (`SlideDirection::FromRest`): it slides down
/// with `g (sin α − μ cos α)`, `s(T) = ½ g (sin α − μ cos α) T²`, the force continuous
/// through the slip (the edge is where the sticking force left the cone).
#[test]
fn sticking_puck_on_a_steep_incline_slips_at_once_and_slides_with_coulomb_deceleration() {
    let (alpha, mu, t_end) = (0.5_f64, 0.3, 0.4);
    assert!(alpha.tan() > mu);
    let plane = GroundPlane {
        point_m: [0.0, 0.0],
        normal_into_ground: [alpha.sin(), alpha.cos()],
    };
    let t = plane.tangent();
    let down = if t.y > 0.0 { t } else { -t };
    let model = body(2.0, 0.01, &[("foot", 0.0, 0.0)], mu);
    let exec = coast(
        &model,
        &plane,
        ContactMode::FLIGHT.with(0, ContactKind::Stick),
        (&[0.0, 0.0, alpha], &[0.0; 3]),
        t_end,
    );
    assert_eq!(exec.events.len(), 1, "{:?}", exec.events);
    assert_eq!(exec.events[0].kind, EventKind::Slip);
    assert!(exec.events[0].t.abs() < 1e-12);
    let a = G * (alpha.sin() - mu * alpha.cos());
    let s = exec.q[0] * down.x + exec.q[1] * down.y;
    let want = 0.5 * a * t_end * t_end;
    assert!((s - want).abs() < 1e-7, "{s} vs {want}");
    let e = energy_report(&model, &plane, &exec).unwrap();
    // the friction's work is μ m g cos α along the distance
    let w = -mu * 2.0 * G * alpha.cos() * want;
    assert!(
        (e.friction_work_j - w).abs() < 1e-6 * w.abs(),
        "{e:?} vs {w}"
    );
    assert!(e.residual_j().abs() < 1e-6, "{e:?}");
}
