//! The analyses of thesis section 4.3 that take any robot (`selfmanip_sim::analysis`) on one
//! that is not RHex: the quadruped of `tests/data/quadruped.toml` (reactive standing, the
//! tail effect, the liftoff-speed linear program, the takeoff bound), and the maximisers
//! against closed-form maxima.
use nalgebra::DMatrix;
use selfmanip_core::{ContactMode, FlatGround, Model, RobotDescription};
use selfmanip_sim::analysis::leg_tail::*;
use selfmanip_sim::analysis::liftoff::liftoff_speed;
use selfmanip_sim::analysis::maximise::{golden_max, grid_golden_max, pattern_search_max};
use selfmanip_sim::analysis::standing::*;
use selfmanip_sim::analysis::takeoff::{takeoff_bound, TorqueSpeedLine};
use selfmanip_sim::analysis::{contact_gaps, free_motion_basis, solve_contact_pose};

fn quadruped() -> Model {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/quadruped.toml"
    );
    RobotDescription::from_file(std::path::Path::new(path))
        .unwrap()
        .build()
        .unwrap()
}

/// The quadruped standing on both feet: the mode, and the pose from a fixed posture with
/// coordinates 5 and 6 (body height and pitch) solved onto the ground.
fn double_stance(m: &Model) -> (ContactMode, Vec<f64>) {
    let mode = ContactMode::parse_names(m, "fore_foot,hind_foot").unwrap();
    let feet: Vec<usize> = mode.active().collect();
    let q = solve_contact_pose(
        m,
        &FlatGround,
        &feet,
        &[5, 6],
        &[0.4, -0.8, -0.3, 0.7, 0.0, -0.3, 0.0],
    )
    .unwrap();
    (mode, q)
}

/// The standing controller on the non-RHex quadruped (both feet sticking, one internal force,
/// three free motions): the split comes from the free motions, `δ` decays monotonically and
/// `ε` decreases — the Lyapunov properties of (4.53)–(4.54) for a different robot.
#[test]
fn standing_controller_runs_on_the_quadruped() {
    let m = quadruped();
    let (mode, q0) = double_stance(&m);
    let split = TorqueSplit::from_free_motion(&m, &FlatGround, mode, &q0).unwrap();
    assert_eq!(split.n_mean, 3);
    // T orthogonal
    assert!((&split.t * split.t.transpose() - DMatrix::identity(4, 4)).norm() < 1e-10);
    let gains = StandingGains {
        kappa_m: 0.02,
        ..Default::default()
    };
    let tr = simulate_standing(
        &m,
        &FlatGround,
        mode,
        &q0,
        &[2.0],
        &split,
        &gains,
        0.01,
        800,
    )
    .unwrap();
    for w in tr.delta.windows(2) {
        assert!(w[1] <= w[0] * (1.0 + 1e-9) + 1e-15);
    }
    let (e0, e1) = (tr.epsilon[0], *tr.epsilon.last().unwrap());
    println!(
        "quadruped: ε {e0:.3e} → {e1:.3e}, δ {:.3e} → {:.3e}",
        tr.delta[0],
        tr.delta.last().unwrap()
    );
    assert!(*tr.delta.last().unwrap() < 1e-6 * tr.delta[0]);
    assert!(e1 < e0);
    assert!(tr.max_gap_m < 1e-6);
}

/// Tail effect, liftoff speed LP and takeoff bound on the quadruped: momentum vs flight
/// simulation; LP vs closed-form ratio and the dynamics at the optimum; takeoff root vs a
/// direct evaluation of the normal force.
#[test]
fn analyses_run_on_the_quadruped() {
    let m = quadruped();
    let q0 = vec![0.4, -0.8, -0.3, 0.7, 0.0, 0.0, 0.0];
    let hips = [0usize, 2];
    let mom = revolution_rotation_momentum(&m, &q0, &hips, 128).unwrap();
    let sim = revolution_rotation_dynamic(&m, &q0, &hips, 1.0, 2e-4).unwrap();
    println!(
        "quadruped tail: momentum {mom:.6} rad | simulation {:.6} rad",
        sim.delta_phi
    );
    assert!((mom - sim.delta_phi).abs() < 2e-3 * mom.abs());
    // liftoff LP in double stance, moving along the first free motion
    let (mode, q) = double_stance(&m);
    let y = selfmanip_sim::analysis::selector_rows(7, &[0, 2, 4]);
    let h = free_motion_basis(&m, &FlatGround, mode, &q, &y).unwrap();
    let dir: Vec<f64> = h.column(0).iter().cloned().collect();
    let ls = liftoff_speed(&m, &FlatGround, mode, &q, &dir, &[0.0; 4]).unwrap();
    if let Some(s) = ls.speed {
        let ratio = (0..ls.a.len())
            .filter(|&i| ls.b[i] < 0.0)
            .map(|i| (ls.a[i] / -ls.b[i]).sqrt())
            .fold(f64::INFINITY, f64::min);
        assert!((s - ratio).abs() < 1e-6 * ratio);
        println!("quadruped liftoff speed {s:.3} rad/s");
    } else {
        assert!(ls.b.iter().all(|&b| b >= 0.0));
    }
    // takeoff bound on the hind foot alone
    let hind = m.contact_index("hind_foot").unwrap();
    let single = ContactMode::with_defaults(&m, &[hind]).unwrap();
    let qs = solve_contact_pose(&m, &FlatGround, &[hind], &[5], &q).unwrap();
    let line = TorqueSpeedLine::new(40.0, 30.0).unwrap();
    let b = takeoff_bound(&m, &FlatGround, single, &qs, 2, 0.0, &line).unwrap();
    if let Some(b) = b {
        println!(
            "quadruped hind-foot takeoff: {:.3} rad/s, ẋ = {:.3} m/s",
            b.leg_rate, b.x_dot
        );
        assert!(b.leg_rate > 0.0 && b.leg_rate <= 30.0);
        assert!(contact_gaps(&m, &FlatGround, &[hind], &qs)[0].abs() < 1e-9);
    }
}

/// The maximisers find the closed-form maxima: a parabola's vertex by golden section; the
/// higher of two bumps (the lower one at the grid's start) by grid then golden section; a
/// concave quadratic's maximiser in the plane by pattern search, and a maximum on the edge
/// of where the function is defined.
#[test]
fn maximisers_find_closed_form_maxima() {
    // near a maximum `f` is flat to round-off within √ε·|x|: the location is good to ~1e-8
    let (x, v) = golden_max(-1.0, 3.0, 1e-9, &mut |x| 2.0 - (x - 0.7) * (x - 0.7));
    assert!((x - 0.7).abs() < 1e-7 && (v - 2.0).abs() < 1e-15, "{x} {v}");
    // bumps at 1 (height 1) and 4 (height 2): the grid must pick the second
    let mut bumps =
        |x: f64| (-(x - 1.0) * (x - 1.0) * 8.0).exp() + 2.0 * (-(x - 4.0) * (x - 4.0) * 8.0).exp();
    let (x, v) = grid_golden_max(0.0, 5.0, 25, &mut bumps);
    assert!((x - 4.0).abs() < 1e-5 && (v - 2.0).abs() < 1e-9, "{x} {v}");
    let mut bowl = |p: [f64; 2]| Some(1.0 - (p[0] - 0.3).powi(2) - 2.0 * (p[1] + 0.2).powi(2));
    let (p, v) = pattern_search_max([0.0, 0.0], &mut bowl);
    assert!(
        (p[0] - 0.3).abs() < 1e-6 && (p[1] + 0.2).abs() < 1e-6,
        "{p:?}"
    );
    assert!((v - 1.0).abs() < 1e-12);
    // defined only for x ≤ 0.25: the maximum sits on that edge
    let mut edged = |p: [f64; 2]| (p[0] <= 0.25).then(|| p[0] - p[1] * p[1]);
    let (p, v) = pattern_search_max([0.0, 0.1], &mut edged);
    assert!(
        (p[0] - 0.25).abs() < 1e-8 && p[1].abs() < 1e-8 && (v - 0.25).abs() < 1e-8,
        "{p:?} {v}"
    );
}

/// The torque–speed line's constructors: from a catalog motor, `τ_s = n G η τ_stall` and
/// `ω₀ = ω_nl / G`; bad values and names are refused naming the field.
#[test]
fn torque_speed_line_from_the_catalog() {
    let cat = motor::Catalog::thesis();
    let m = cat.motor_spec("x-rhex").unwrap().motor().unwrap();
    let eta = cat.gearbox("x-rhex-28").unwrap().efficiency;
    let line = TorqueSpeedLine::from_catalog(&cat, "x-rhex", "x-rhex-28", 20.0, 3.0).unwrap();
    assert_eq!(
        line.stall_torque_n_m,
        3.0 * 20.0 * eta * m.achievable_stall_torque_n_m()
    );
    assert_eq!(line.no_load_speed_rad_s, m.no_load_speed_rad_s / 20.0);
    assert_eq!(line.torque(line.no_load_speed_rad_s), 0.0);
    assert!(
        (line.kappa_p() * line.kappa_g() - line.stall_torque_n_m).abs()
            < 1e-12 * line.stall_torque_n_m
    );
    let field = |e: selfmanip_sim::SimError| match e {
        selfmanip_sim::SimError::InvalidValue { field, .. } => field,
        other => panic!("unexpected {other:?}"),
    };
    assert_eq!(
        field(TorqueSpeedLine::new(-1.0, 10.0).unwrap_err()),
        "stall_torque_n_m"
    );
    assert_eq!(
        field(TorqueSpeedLine::new(1.0, f64::NAN).unwrap_err()),
        "no_load_speed_rad_s"
    );
    let no_motor = TorqueSpeedLine::from_catalog(&cat, "nope", "x-rhex-28", 20.0, 2.0);
    assert_eq!(field(no_motor.unwrap_err()), "motor");
    let no_box = TorqueSpeedLine::from_catalog(&cat, "x-rhex", "nope", 20.0, 2.0);
    assert_eq!(field(no_box.unwrap_err()), "gearbox");
    let bad_ratio = TorqueSpeedLine::from_catalog(&cat, "x-rhex", "x-rhex-28", 0.0, 2.0);
    assert_eq!(field(bad_ratio.unwrap_err()), "gear_ratio");
}
