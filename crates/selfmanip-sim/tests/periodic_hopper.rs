//! A periodic hybrid orbit of a non-RHex robot — the one-legged hopper of
//! `examples/data/hopper.toml` (massless two-link leg, hip at the body's centre of mass)
//! hopping in place under `examples/data/hop_periodic.toml` — found by Newton shooting on the
//! apex section ([`selfmanip_hybrid::periodic`]), against independent routes:
//!
//! - the engine's section Jacobian and its multipliers against central finite differences of
//!   whole apex-to-apex runs, and the time-`T` monodromy against finite differences of
//!   fixed-time runs in every direction of the state (`docs/periodic-orbits.md`);
//! - the fixed point against one execution of several periods from it (the map is the same at
//!   every hop: the behaviour is autonomous);
//! - closed forms from conservation laws: with the hip limp on the ground and at the body's
//!   centre of mass, no force has a moment about the centre of mass and the massless leg
//!   carries no momentum, so `φ̇` is conserved through flight, touchdown and stance and
//!   `φ(τ) = φ₀ + φ̇₀ τ`: the rows of `φ, φ̇` in `DP` are `e_φ + τ e_φ̇` and `e_φ̇` exactly (two
//!   multipliers 1, a Jordan block), and a horizontal shift changes nothing (`∂·/∂x = e_x`);
//! - the trivial multipliers of the section (0, eigenvector `f(x*)`) and of the period map
//!   (1, eigenvector `f(x*)`);
//! - the behaviour's partial derivatives (`Controller::partials`) against finite differences
//!   of its torque and free-joint accelerations.
mod common;
use common::run_from_state;

use nalgebra::{Complex, DMatrix, DVector};
use selfmanip_core::{ContactMode, RobotDescription};
use selfmanip_hybrid::periodic::{
    find_periodic_orbit, floquet_multipliers, PeriodicOptions, PeriodicOrbit,
};
use selfmanip_hybrid::{ControlPoint, Controller, ControllerPartials, EventKind, Segment};
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::{Scenario, Simulation};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/data")
        .join(name)
}

/// The hopper at an apex: leg in its landing pose (hip a, knee −2a), body `h` above ground.
fn guess(h: f64) -> Vec<f64> {
    let a = 0.5;
    vec![a, -2.0 * a, 0.0, -h, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
}

fn simulation(q0: &[f64]) -> Simulation {
    let robot = RobotDescription::from_file(&data("hopper.toml")).unwrap();
    let mut s = Scenario::new(robot, q0.to_vec());
    s.behaviour = Behaviour::from_file(&data("hop_periodic.toml")).unwrap();
    s.options.t_final_s = 10.0;
    Simulation::new(&s).unwrap()
}

fn find() -> (Simulation, PeriodicOrbit) {
    let g = guess(0.45);
    let sim = simulation(&g[..5]);
    let orbit = common::orbit(&sim, &g);
    (sim, orbit)
}

fn opts() -> PeriodicOptions {
    PeriodicOptions::default()
}

/// `x1` of the return map from `x0`, with its event kinds.
fn map(sim: &Simulation, x0: &[f64]) -> (Vec<f64>, Vec<EventKind>) {
    let rm = common::apex_return_map(sim, x0, false);
    let kinds = rm.execution.events.iter().map(|e| e.kind).collect();
    (rm.x1, kinds)
}

/// `f(x*) = (q̇, q̈)` of the flight flow at the fixed point, under the behaviour.
fn flow_at(sim: &Simulation, x: &[f64]) -> DVector<f64> {
    let mut flow = selfmanip_hybrid::flow::Flow::new(
        &sim.model,
        &sim.terrain,
        std::sync::Arc::clone(&sim.controller),
    );
    let mut f = DVector::zeros(x.len());
    flow.rhs(0.0, ContactMode::FLIGHT, x, f.as_mut_slice())
        .unwrap();
    f
}

fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).amax() / b.amax().max(1.0)
}

/// The multipliers of `a` off the unit circle's neighbourhood (`|λ − 1| > 1e-3`), each
/// matched to the nearest of `b`'s: the worst distance. (Multipliers at 1 here come in
/// Jordan blocks — the conserved `φ̇` — whose eigenvalues are ill-conditioned, `O(ε^{1/k})`:
/// those are checked through their rows, against the closed form.)
fn multiplier_error(a: &[Complex<f64>], b: &[Complex<f64>]) -> f64 {
    let off_one = a
        .iter()
        .filter(|l| (*l - Complex::new(1.0, 0.0)).norm() > 1e-3);
    common::multiplier_error(off_one, b)
}

/// The hopper's orbit: found from a guess 10 cm off in apex height and with the leg at
/// rest; three events a period (touchdown, liftoff, apex); the engine's section Jacobian and
/// its multipliers against central differences (h = 1e-6) of whole apex-to-apex runs in every
/// section coordinate, each with the orbit's event sequence, to 1e-5.
#[test]
fn hopper_section_multipliers_match_finite_differences() {
    let (sim, o) = find();
    eprintln!(
        "x* {:?}\nT {} s, {:?}, {} iterations, residual {:e}, rank deficiency {}",
        o.x, o.period_s, o.events, o.iterations, o.residual, o.rank_deficiency
    );
    eprintln!("DP multipliers {:?}", o.multipliers);
    let kinds = common::hop_events(&o);
    let idx = &o.section_coordinates;
    let fd = common::section_jacobian_fd(|x| map(&sim, x), &o.x, idx, &kinds, 1e-6);
    let e = rel(&o.section_jacobian, &fd);
    let fd_mult = floquet_multipliers(&fd).unwrap();
    let em = multiplier_error(&o.section_multipliers, &fd_mult)
        .max(multiplier_error(&fd_mult, &o.section_multipliers));
    eprintln!("section Jacobian vs central differences {e:e}; multipliers {em:e}");
    eprintln!("FD multipliers {fd_mult:?}");
    assert!(e < 1e-5, "{e:e}");
    assert!(em < 1e-5, "{em:e}");
    // the hop's own multipliers: one unstable (the horizontal speed: a vertical leg at
    // touchdown tips the body further each stance), the height's and the leg's stable
    let moduli: Vec<f64> = o.section_multipliers.iter().map(|l| l.norm()).collect();
    assert!(moduli[0] > 1.1, "{moduli:?}");
    assert_eq!(o.stability, selfmanip_hybrid::periodic::Stability::Unstable);
}

/// `M_T = DP − f ∇τ` against central differences of fixed-time runs (`T` from `x*`, no stop
/// at the apex) in all ten state directions, including `ż` (off the section); and the
/// trivial multipliers: `DP f = 0` (`P` is constant along the flow) and `M_T f = f`.
#[test]
fn hopper_period_monodromy_matches_fixed_time_differences() {
    let (sim, o) = find();
    let nq = sim.model.nq();
    let run = |x: &[f64]| {
        let e = run_from_state(&sim, ContactMode::FLIGHT, x, o.period_s, opts().hybrid);
        e.q.iter().chain(&e.qd).copied().collect::<Vec<f64>>()
    };
    let h = 1e-6;
    let n2 = 2 * nq;
    let mut fd = DMatrix::zeros(n2, n2);
    for c in 0..n2 {
        let (mut xp, mut xm) = (o.x.clone(), o.x.clone());
        xp[c] += h;
        xm[c] -= h;
        let (yp, ym) = (run(&xp), run(&xm));
        for i in 0..n2 {
            fd[(i, c)] = (yp[i] - ym[i]) / (2.0 * h);
        }
    }
    let e = rel(&o.period_monodromy, &fd);
    eprintln!("period monodromy vs fixed-time central differences {e:e}");
    assert!(e < 1e-5, "{e:e}\n{}\n{fd}", o.period_monodromy);
    let f = flow_at(&sim, &o.x);
    let dpf = (&o.monodromy * &f).amax() / f.amax();
    let mtf = (&o.period_monodromy * &f - &f).amax() / f.amax();
    eprintln!("|DP f|/|f| {dpf:e}, |M_T f − f|/|f| {mtf:e}");
    assert!(dpf < 1e-6 && mtf < 1e-6, "{dpf:e} {mtf:e}");
}

/// Closed forms of the conservation laws (module docs): `φ̇` conserved, `φ(τ) = φ₀ + φ̇₀ τ`,
/// nothing depends on `x`: the rows of `φ` and `φ̇` and the column of `x` in `DP`.
#[test]
fn hopper_conserved_pitch_rate_gives_exact_unit_multipliers() {
    let (sim, o) = find();
    let m = &sim.model;
    let nq = m.nq();
    let (phi, phid, x) = (m.ix_phi(), nq + m.ix_phi(), m.ix_x());
    let n2 = 2 * nq;
    let e = |k: usize| DVector::from_fn(n2, |i, _| if i == k { 1.0 } else { 0.0 });
    let row_phi = e(phi) + o.period_s * e(phid);
    let err_phi = (o.monodromy.row(phi).transpose() - row_phi).amax();
    let err_phid = (o.monodromy.row(phid).transpose() - e(phid)).amax();
    let err_x = (o.monodromy.column(x) - e(x)).amax();
    eprintln!("rows φ {err_phi:e}, φ̇ {err_phid:e}, column x {err_x:e}");
    assert!(err_phi < 1e-9 && err_phid < 1e-9 && err_x < 1e-9);
    // the Newton step is the minimum-norm one: the conserved φ̇ leaves one direction free
    assert_eq!(o.rank_deficiency, 1);
    assert_eq!(o.drift.len(), 1);
    // one orbit of a family (the body's tilt φ sets the leg's touchdown angle and so a
    // horizontal speed): the minimum-norm steps from a level guess end within a few mrad of
    // level, hopping nearly in place
    eprintln!("φ* {}, ẋ* {}, drift {:?}", o.x[phi], o.x[nq + x], o.drift);
    assert!(
        o.x[phi].abs() < 1e-2 && o.drift[0].abs() < 1e-3,
        "{:?}",
        o.drift
    );
}

/// The fixed point against one execution of five periods from it: every apex of the run
/// (recorded on the way) is `x*` again, `T` apart — the return map of a fresh run is the
/// hop of a long run, the behaviour being autonomous. The largest multiplier 1.25 grows the
/// residual 1e-9 to ~3e-9 in five periods.
#[test]
fn hopper_fixed_point_returns_over_five_periods() {
    let (sim, o) = find();
    let nq = sim.model.nq();
    let e = run_from_state(
        &sim,
        ContactMode::FLIGHT,
        &o.x,
        5.0 * o.period_s + 0.05,
        opts().hybrid,
    );
    let apexes: Vec<_> = e
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Apex)
        .collect();
    assert_eq!(
        apexes.len(),
        5,
        "{:?}",
        e.events.iter().map(|e| e.kind).collect::<Vec<_>>()
    );
    let mut worst: f64 = 0.0;
    for (k, a) in apexes.iter().enumerate() {
        let dt = a.t - (k as f64 + 1.0) * o.period_s;
        // x* again, its x advanced by k + 1 strides
        let mut expected = o.x.clone();
        expected[o.cyclic[0]] += (k as f64 + 1.0) * o.drift[0];
        let dx =
            a.q.iter()
                .chain(&a.qd_after)
                .zip(&expected)
                .enumerate()
                .filter(|(i, _)| *i != nq + sim.model.ix_z())
                .map(|(_, (u, v))| (u - v).abs())
                .fold(0.0, f64::max);
        worst = worst.max(dx).max(dt.abs());
    }
    eprintln!("five periods: worst apex-state / period error {worst:e}");
    assert!(worst < 1e-7, "{worst:e}");
}

/// Two searches give bit-identical orbits.
#[test]
fn hopper_orbit_is_deterministic() {
    let (_, a) = find();
    let (_, b) = find();
    assert_eq!(a.x, b.x);
    assert_eq!(a.period_s, b.period_s);
    assert_eq!(a.monodromy, b.monodromy);
    assert_eq!(a.multipliers, b.multipliers);
}

/// Budgets and bad input end with typed errors: one iteration from a guess 10 cm off is not
/// enough, nor two return runs; a state of the wrong length names its field.
#[test]
fn hopper_search_errors_are_typed() {
    use selfmanip_hybrid::periodic::PeriodicError;
    let g = guess(0.45);
    let sim = simulation(&g[..5]);
    let one = PeriodicOptions {
        max_iterations: 1,
        ..opts()
    };
    match find_periodic_orbit(&sim.model, &sim.terrain, &*sim.controller, &g, &one) {
        Err(PeriodicError::NotConverged {
            iterations: 1,
            residual,
            best,
        }) => assert!(residual > 1e-9 && best.len() == 10),
        other => panic!("{other:?}"),
    }
    // the run budget: the first run and one trial, then the second iteration stops
    let two = PeriodicOptions {
        max_runs: 2,
        ..opts()
    };
    match find_periodic_orbit(&sim.model, &sim.terrain, &*sim.controller, &g, &two) {
        Err(PeriodicError::RunBudget { runs: 2, .. }) => {}
        other => panic!("{other:?}"),
    }
    match find_periodic_orbit(&sim.model, &sim.terrain, &*sim.controller, &g[..9], &opts()) {
        Err(PeriodicError::InvalidInput { field: "guess", .. }) => {}
        other => panic!("{other:?}"),
    }
    let bad = PeriodicOptions {
        max_period_s: f64::NAN,
        ..opts()
    };
    match find_periodic_orbit(&sim.model, &sim.terrain, &*sim.controller, &g, &bad) {
        Err(PeriodicError::InvalidInput {
            field: "max_period_s",
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // too short a budget to come back: NoReturn with the run's termination
    let short = PeriodicOptions {
        max_period_s: 0.1,
        ..opts()
    };
    match find_periodic_orbit(&sim.model, &sim.terrain, &*sim.controller, &g, &short) {
        Err(PeriodicError::NoReturn { t, .. }) => assert!((t - 0.1).abs() < 1e-12),
        other => panic!("{other:?}"),
    }
}

/// Central differences of a controller's torque and free-joint accelerations in every state
/// direction, against its `partials`.
fn check_partials(
    ctrl: &dyn Controller,
    t: f64,
    y: &[f64],
    mode: ContactMode,
    free: &[usize],
) -> f64 {
    let nq = y.len() / 2;
    let n = nq - 3;
    let mut p = ControllerPartials::zeros(n, nq, free.len());
    assert!(ctrl.partials(
        &ControlPoint::new(t, &y[..nq], &y[nq..], mode).with_free_joints(free),
        &mut p
    ));
    let eval = |y: &[f64]| {
        let mut tau = vec![0.0; n];
        let mut fr = vec![0.0; free.len()];
        ctrl.torque(t, &y[..nq], &y[nq..], mode, &mut tau);
        ctrl.free_joint_qdd(t, &y[..nq], &y[nq..], free, &mut fr);
        (tau, fr)
    };
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    for c in 0..2 * nq {
        let (mut yp, mut ym) = (y.to_vec(), y.to_vec());
        yp[c] += h;
        ym[c] -= h;
        let ((tp, fp), (tm, fm)) = (eval(&yp), eval(&ym));
        let (dt, df) = if c < nq {
            (&p.dtau.dq, &p.dfree.dq)
        } else {
            (&p.dtau.dqd, &p.dfree.dqd)
        };
        let cc = c % nq;
        for i in 0..n {
            worst = worst.max(((tp[i] - tm[i]) / (2.0 * h) - dt[(i, cc)]).abs());
        }
        for i in 0..free.len() {
            worst = worst.max(((fp[i] - fm[i]) / (2.0 * h) - df[(i, cc)]).abs());
        }
    }
    worst
}

/// `BehaviourController::partials` against central differences of `torque` and
/// `free_joint_qdd`: the knee servo in stance (the controller of the orbit's stance segment),
/// the free joints' tracking laws in flight; then a servo on its saturated branch and inside
/// it, a schedule and a constant torque (zero partials).
#[test]
fn behaviour_partials_match_finite_differences() {
    let (sim, o) = find();
    let nq = sim.model.nq();
    let rm = common::apex_return_map(&sim, &o.x, false);
    let stance = &rm.execution.segments[1];
    assert!(!stance.mode.is_flight());
    // the partials at the middle of a segment, of the controller it ran with
    let at_middle = |seg: &Segment, free: &[usize]| {
        let t = 0.5 * (seg.t0 + seg.t1);
        let mut y = vec![0.0; 2 * nq];
        seg.eval(t, &mut y);
        check_partials(&*seg.controller, t, &y, seg.mode, free)
    };
    let e1 = at_middle(stance, &[]);
    let flight = &rm.execution.segments[2];
    let e2 = at_middle(flight, &[0, 1]);
    eprintln!("partials vs central differences: stance {e1:e}, flight {e2:e}");
    assert!(e1 < 1e-6 && e2 < 1e-6, "{e1:e} {e2:e}");
    // a saturating servo, a schedule, a constant
    let text = r#"
        [[joints]]
        joint = "leg[0]"
        [[joints.phases]]
        name = "servo"
        torque = { kind = "servo", target_rad = 0.2, kp_n_m_per_rad = 10.0, kd_n_m_s_per_rad = 0.5, torque_limit_n_m = 1.0 }
        motion = { kind = "hold", angle_rad = 0.0 }
        [[joints]]
        joint = "leg[1]"
        [[joints.phases]]
        name = "sched"
        torque = { kind = "schedule", times_s = [0.0, 1.0], torques_n_m = [0.0, 2.0] }
        [[joints.phases]]
        name = "const"
        start = { at_s = 0.5 }
        torque = { kind = "constant", torque_n_m = 0.7 }
    "#;
    let b = Behaviour::from_toml_str(text).unwrap();
    let q0 = guess(0.5);
    let ctrl = selfmanip_sim::behaviour::compile(&b, &sim.model, &q0[..5], &[0.0; 5], 1.0).unwrap();
    let stance_mode = ContactMode::FLIGHT.with(0, selfmanip_core::ContactKind::Stick);
    for (t, hip, saturated) in [(0.2, 0.25, false), (0.7, 0.5, true), (0.2, -0.3, true)] {
        let mut y = q0.clone();
        y[0] = hip;
        y[5] = 0.1;
        let mut p = ControllerPartials::zeros(2, nq, 0);
        assert!(ctrl.partials(
            &ControlPoint::new(t, &y[..nq], &y[nq..], stance_mode),
            &mut p
        ));
        assert_eq!(p.dtau.dq[(0, 0)] == 0.0, saturated, "hip {hip}");
        let e = check_partials(&ctrl, t, &y, stance_mode, &[]);
        assert!(e < 1e-6, "t {t}, hip {hip}: {e:e}");
    }
}

/// `run_sensitivity` carries the state Jacobian of a run through an apex recorded on the
/// way (no reset: its saltation the identity; checked against central differences in
/// `tests/sensitivity_paths.rs`) and, for a run that stops at the apex, it equals the return
/// map's Jacobian.
#[test]
fn run_sensitivity_passes_an_apex_on_the_way() {
    use selfmanip_hybrid::sensitivity::SaltationStatus;
    let (_, o) = find();
    let mut s = Scenario::new(
        RobotDescription::from_file(&data("hopper.toml")).unwrap(),
        o.x[..5].to_vec(),
    );
    s.initial.qd = Some(o.x[5..].to_vec());
    s.behaviour = Behaviour::from_file(&data("hop_periodic.toml")).unwrap();
    let h = opts().hybrid;
    (s.options.rtol, s.options.atol, s.options.event_tol_s) =
        (h.step.rtol, Some(h.step.atol), h.event_tol_s);
    s.options.velocity_tolerance = h.step.velocity_tolerance;
    s.options.truncate_unresolved_flights = h.truncate_unresolved_flights;
    s.options.t_final_s = o.period_s + 0.1;
    let run = Simulation::new(&s).unwrap().run().unwrap();
    let sens = selfmanip_sim::periodic::run_sensitivity(&run).unwrap();
    let last = sens.events.last().unwrap();
    assert_eq!(last.kind, EventKind::Apex);
    assert_eq!(last.status, SaltationStatus::Defined);
    let xi = last.saltation.as_ref().unwrap();
    assert!((xi - nalgebra::DMatrix::identity(10, 10)).amax() < 1e-12);
    assert!(sens.state_jacobian.is_some());
    s.options.stop_at_apex = true;
    let run = Simulation::new(&s).unwrap().run().unwrap();
    let sens = selfmanip_sim::periodic::run_sensitivity(&run).unwrap();
    let j = sens
        .state_jacobian
        .expect("a terminal apex is differentiated");
    let e = (&j - &o.monodromy).amax();
    eprintln!("stopped at the apex: state Jacobian vs the orbit's DP {e:e}");
    assert!(e < 1e-9, "{e:e}");
}

/// A closed form of the vertical return map. Without the knee's damping (`kd = 0`) the stance
/// is conservative — body weight and the knee spring `½ kp (k − k*)²`, the massless leg
/// carrying no energy — the touchdown of a massless leg takes no impulse (no loss), and the
/// liftoff comes where the spring's force, hence `λ_n`, vanishes: `k = k*` exactly. The hop
/// from an apex at rest, level, with the leg at rest in its landing pose (`k_land`, held in
/// the air: it does not move) therefore gains the spring's pre-load,
/// `m g (h₁ − h₀) = ½ kp (k_land − k*)²`: `h₁ − h₀ = 60 · 0.5² / (2 · 4 · 9.81) = 0.19113 m`,
/// whatever `h₀`, so `∂z₁/∂z₀ = 1` exactly (a multiplier 1: every height hops, higher each
/// time). Against the engine's value and Jacobian of the return map.
#[test]
fn undamped_hop_gains_the_spring_preload_in_closed_form() {
    // a point foot: the round foot rolls as the shank turns in stance, which moves the
    // contact off the line under the hip and lends the hop a little horizontal speed
    // (measured: the rise 1.8e-7 m short, ∂z₁/∂z₀ = 0.99998)
    let text = std::fs::read_to_string(data("hopper.toml")).unwrap();
    let round = r#"shape = { kind = "circle", center_m = [0.0, 0.2], radius_m = 0.02 }"#;
    assert!(text.contains(round));
    let text = text.replace(
        round,
        r#"shape = { kind = "point", position_m = [0.0, 0.2] }"#,
    );
    let robot = RobotDescription::from_toml_str(&text).unwrap();
    let g = guess(0.45);
    let mut s = Scenario::new(robot, g[..5].to_vec());
    s.behaviour = Behaviour::from_file(&data("hop_periodic.toml")).unwrap();
    s.behaviour
        .parameters
        .insert("kd_knee".into(), selfmanip_sim::expr::Scalar::Number(0.0));
    let sim = Simulation::new(&s).unwrap();
    let rm = common::apex_return_map(&sim, &g, true);
    let kinds: Vec<_> = rm.execution.events.iter().map(|e| e.kind).collect();
    assert_eq!(
        kinds,
        [EventKind::Touchdown, EventKind::Liftoff, EventKind::Apex]
    );
    let (m, grav, kp, k_land, k_star) = (4.0, 9.81, 60.0, -1.0, -0.5);
    let k_td = rm.execution.events[0].q[1];
    let k_lo = rm.execution.events[1].q[1];
    assert!((k_td - k_land).abs() < 1e-12, "{k_td}");
    assert!(
        (k_lo - k_star).abs() < 1e-9,
        "liftoff at the spring's rest angle: {k_lo}"
    );
    let gain = kp * (k_td - k_star).powi(2) / (2.0 * m * grav);
    let rise = -(rm.x1[3] - rm.x0[3]);
    let j = rm.jacobian.as_ref().unwrap();
    eprintln!(
        "undamped hop: rise {rise} m vs closed form {gain} m; ∂z₁/∂z₀ = {}",
        j[(3, 3)]
    );
    assert!((rise - gain).abs() < 1e-8, "{rise} vs {gain}");
    assert!((j[(3, 3)] - 1.0).abs() < 1e-8, "{}", j[(3, 3)]);
}
