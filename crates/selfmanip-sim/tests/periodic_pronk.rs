//! A periodic orbit through simultaneous landings and liftoffs: the quadruped of
//! `examples/data/quadruped.toml` with massless legs, pronking under
//! `tests/data/pronk_periodic.toml` (the hind leg the fore leg's mirror image), found by
//! Newton shooting on the apex section although both feet land together and lift off
//! together, where the saltation meets several guards at once
//! (`selfmanip_hybrid::sensitivity`, `docs/periodic-orbits.md`, "Several guards at once").
//! Against independent routes:
//!
//! - the return map restricted to the mirror-symmetric perturbations (on which the order
//!   of the guards does not matter) and its multipliers against central differences of
//!   whole apex-to-apex runs in those directions;
//! - the one-sided derivatives of the liftoff (fore foot first, hind foot first) against
//!   the mirror symmetry: each is the other's mirror image, and both give the same
//!   multipliers;
//! - without the knee's damping, the closed form of the vertical map (the two springs'
//!   pre-load gained every hop, `∂z₁/∂z₀ = 1`).
mod common;

use nalgebra::DMatrix;
use selfmanip_core::description::FrictionDescription;
use selfmanip_core::RobotDescription;
use selfmanip_hybrid::periodic::{floquet_multipliers, PeriodicOrbit};
use selfmanip_hybrid::sensitivity::{execution_sensitivity, SaltationStatus};
use selfmanip_hybrid::EventKind;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::{Scenario, Simulation};
use std::path::Path;

/// The quadruped with massless legs and its friction declared (μ = μ_k = 1: no test here
/// depends on a default of the description).
fn robot() -> RobotDescription {
    let mut r = RobotDescription::from_file(&common::data("quadruped.toml")).unwrap();
    for leg in &mut r.legs {
        for l in &mut leg.links {
            l.mass_kg = 0.0;
            l.inertia_kg_m2 = 0.0;
        }
    }
    for c in &mut r.contacts {
        c.friction = FrictionDescription::Sticking {
            mu: Some(1.0),
            mu_kinetic: Some(1.0),
        };
    }
    r
}

/// `q = [fore[0], fore[1], hind[0], hind[1], x, z, φ]`: both legs in their landing pose at
/// rest, the body level `h` above the ground.
fn guess(h: f64) -> Vec<f64> {
    let a = 0.5;
    let mut x = vec![0.0; 14];
    x[..6].copy_from_slice(&[a, -2.0 * a, -a, 2.0 * a, 0.0, -h]);
    x
}

fn simulation(kd_knee: Option<f64>) -> Simulation {
    let mut s = Scenario::new(robot(), guess(0.45)[..7].to_vec());
    // every component to the same absolute tolerance: the symmetric differences of whole
    // return runs resolve the monodromy no better than each run's error
    s.options.velocity_tolerance = selfmanip_hybrid::VelocityTolerance::Uniform;
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/pronk_periodic.toml");
    s.behaviour = Behaviour::from_file(&p).unwrap();
    if let Some(kd) = kd_knee {
        s.behaviour
            .parameters
            .insert("kd_knee".into(), selfmanip_sim::expr::Scalar::Number(kd));
    }
    Simulation::new(&s).unwrap()
}

fn find(sim: &Simulation) -> PeriodicOrbit {
    common::orbit(sim, &guess(0.45))
}

/// `P(x)` and the run's event kinds with consecutive repeats merged (a liftoff of both
/// feet is one event or two at the same instant, as round-off decides).
fn map(sim: &Simulation, x: &[f64]) -> (Vec<f64>, Vec<EventKind>) {
    let rm = common::apex_return_map(sim, x, false);
    let mut kinds: Vec<EventKind> = rm.execution.events.iter().map(|e| e.kind).collect();
    kinds.dedup();
    (rm.x1, kinds)
}

/// The mirror `S`: fore ↔ hind with the angles negated, `x → −x`, `φ → −φ` (and rates).
fn mirror() -> DMatrix<f64> {
    let mut s = DMatrix::zeros(14, 14);
    for off in [0, 7] {
        for (i, j) in [(0, 2), (1, 3), (2, 0), (3, 1)] {
            s[(off + i, off + j)] = -1.0;
        }
        s[(off + 4, off + 4)] = -1.0;
        s[(off + 5, off + 5)] = 1.0;
        s[(off + 6, off + 6)] = -1.0;
    }
    s
}

/// The mirror-symmetric section directions (without `ż`, fixed by the section, and `x`,
/// cyclic): the legs' angles and rates as mirror pairs, and `z`.
fn symmetric_basis() -> DMatrix<f64> {
    let mut v = DMatrix::zeros(14, 5);
    for (col, (i, j)) in [(0, 2), (1, 3), (7, 9), (8, 10)].into_iter().enumerate() {
        v[(i, col)] = 1.0;
        v[(j, col)] = -1.0;
    }
    v[(5, 4)] = 1.0;
    v
}

/// The matrix `C` with `J V = V C` (least squares), and the part of `J V` outside `V`.
fn restricted(j: &DMatrix<f64>, v: &DMatrix<f64>) -> (DMatrix<f64>, f64) {
    let vt = v.transpose();
    let c = (&vt * v).try_inverse().unwrap() * &vt * j * v;
    let off = (j * v - v * &c).amax();
    (c, off)
}

/// The pronk's orbit: found from a level guess at rest, 3 events a period (both feet land
/// in one touchdown, lift off together, apex); the touchdown is differentiable (plastic
/// impacts into nested modes commute to first order: both orders agree) and the liftoff is
/// one-sided (fore-first and hind-first differ). On the mirror-symmetric directions the
/// return map's Jacobian maps into them, and its multipliers agree with central differences
/// (Richardson, h = 1e-5) of whole apex-to-apex runs to 1e-5 (its rows of angles and height
/// to 1e-5, of the legs' rates to 1e-4); those multipliers are among the orbit's section
/// multipliers.
#[test]
fn pronk_orbit_through_simultaneous_guards_matches_symmetric_differences() {
    let sim = simulation(None);
    let o = find(&sim);
    eprintln!(
        "x* {:?}\nT {} s, {} iterations, residual {:e}, one-sided {:?}",
        o.x, o.period_s, o.iterations, o.residual, o.one_sided
    );
    common::hop_events(&o);
    assert_eq!(o.one_sided.len(), 1, "{:?}", o.one_sided);
    assert_eq!(o.one_sided[0].kind, EventKind::Liftoff);
    assert_eq!(o.one_sided[0].guards, [0, 1]);
    let v = symmetric_basis();
    let (c, off) = restricted(&o.monodromy, &v);
    assert!(
        off < 1e-8 * o.monodromy.amax(),
        "DP leaves the symmetric subspace: {off:e}"
    );
    // central differences in the symmetric directions, Richardson-extrapolated
    let kinds_of_orbit = map(&sim, &o.x).1;
    let d = |h: f64| {
        let mut fd = DMatrix::zeros(14, 5);
        for col in 0..5 {
            let (mut xp, mut xm) = (o.x.clone(), o.x.clone());
            for i in 0..14 {
                xp[i] += h * v[(i, col)];
                xm[i] -= h * v[(i, col)];
            }
            let ((yp, kp), (ym, km)) = (map(&sim, &xp), map(&sim, &xm));
            assert_eq!(kp, kinds_of_orbit);
            assert_eq!(km, kinds_of_orbit);
            for i in 0..14 {
                fd[(i, col)] = (yp[i] - ym[i]) / (2.0 * h);
            }
        }
        fd
    };
    let h = 1e-5;
    let jv_fd = (4.0 * d(h / 2.0) - d(h)) / 3.0;
    let vt = v.transpose();
    let c_fd = (&vt * &v).try_inverse().unwrap() * &vt * &jv_fd;
    // the angles' and the height's rows (0, 1, 4 of C); the legs' rates (2, 3) end still
    // converging to their hold, where the tangent is known to lag finite differences of
    // whole runs by ~1e-5 relative (docs/periodic-orbits.md, "Known limits": the states at
    // the events and the end are read from the dense output)
    let scale = c.amax().max(1.0);
    let row_err = |rows: &[usize]| {
        rows.iter()
            .map(|&r| (c.row(r) - c_fd.row(r)).amax() / scale)
            .fold(0.0, f64::max)
    };
    let (err_q, err_rates) = (row_err(&[0, 1, 4]), row_err(&[2, 3]));
    let (mc, mfd) = (
        floquet_multipliers(&c).unwrap(),
        floquet_multipliers(&c_fd).unwrap(),
    );
    let me = common::multiplier_error(&mc, &mfd);
    eprintln!(
        "symmetric multipliers {mc:?}\n  finite differences {mfd:?}\n  {me:e}; rows of \
         angles and height {err_q:e}, of the legs' rates {err_rates:e}"
    );
    assert!(err_q < 1e-5, "{err_q:e}\n{c}\n{c_fd}");
    assert!(err_rates < 1e-4, "{err_rates:e}\n{c}\n{c_fd}");
    assert!(me < 1e-5, "{me:e}");
    assert!(common::multiplier_error(&mc, &o.section_multipliers) < 1e-8);
}

/// The liftoff's two one-sided derivatives are each other's mirror image: with `S` the
/// mirror, the fore-first saltation is `S Ξ_hind-first S` (the mirror maps one order onto
/// the other). Round-off breaks the orbit's symmetry at ~1e-15, far below.
#[test]
fn one_sided_liftoff_derivatives_are_mirror_images() {
    let sim = simulation(None);
    let o = find(&sim);
    let rm = common::apex_return_map(&sim, &o.x, false);
    let s = execution_sensitivity(&sim.model, &sim.terrain, &rm.execution).unwrap();
    let lift = s
        .events
        .iter()
        .find(|e| e.kind == EventKind::Liftoff)
        .unwrap();
    assert_eq!(
        lift.status,
        SaltationStatus::OneSided { guards: vec![0, 1] }
    );
    assert!(lift.saltation.is_none());
    assert_eq!(lift.one_sided.len(), 2);
    let (a, b) = (&lift.one_sided[0], &lift.one_sided[1]);
    assert_eq!((a.order.clone(), b.order.clone()), (vec![0, 1], vec![1, 0]));
    let m = mirror();
    let diff = (&a.saltation - &m * &b.saltation * &m).amax() / a.saltation.amax();
    let apart = (&a.saltation - &b.saltation).amax() / a.saltation.amax();
    eprintln!("one-sided liftoff: mirror images to {diff:e}, apart {apart:e}");
    assert!(apart > 1e-3, "the orders differ: {apart:e}");
    assert!(diff < 1e-9, "{diff:e}");
    // the touchdown of both feet: its orders agree, the event is differentiable
    let td = &s.events[0];
    assert_eq!(
        (td.kind, &td.status),
        (EventKind::Touchdown, &SaltationStatus::Defined)
    );
    assert_eq!(td.one_sided.len(), 2);
    assert!(s.state_jacobian.is_none());
    assert!(s.one_sided_state_jacobian.is_some());
}

/// Without the knee's damping the stance is conservative (weight, the two knee springs
/// `½ kp (k − k*)²`; the massless legs carry no energy, their touchdown takes no impulse
/// from the body, their liftoff comes where the springs' force vanishes): from an apex at
/// rest, level, legs resting in their landing pose `k_land`, each hop gains both springs'
/// pre-load, `m g (h₁ − h₀) = 2 · ½ kp (k_land − k*)²` = 100 · 0.3² / (10 · 9.81) m, whatever
/// `h₀`: `∂z₁/∂z₀ = 1`. Through the simultaneous touchdown and the one-sided liftoff (`z` is
/// a symmetric direction, where every order's derivative is the derivative).
#[test]
fn undamped_pronk_gains_both_springs_preload_in_closed_form() {
    let sim = simulation(Some(0.0));
    let g = guess(0.45);
    let rm = common::apex_return_map(&sim, &g, true);
    let ev = &rm.execution.events;
    assert_eq!(ev[0].kind, EventKind::Touchdown);
    assert_eq!(ev[0].triggered, [0, 1]);
    let (m, grav, kp, k_land, k_star) = (10.0, 9.81, 100.0, -1.0, -0.7);
    let k_lo = ev[1].q[1];
    assert!((ev[0].q[1] - k_land).abs() < 1e-12);
    assert!(
        (k_lo - k_star).abs() < 1e-9,
        "liftoff at the spring's rest: {k_lo}"
    );
    let gain = 2.0 * 0.5 * kp * (k_land - k_star).powi(2) / (m * grav);
    let rise = -(rm.x1[5] - rm.x0[5]);
    let j = rm.jacobian.as_ref().unwrap();
    eprintln!(
        "undamped pronk: rise {rise} m vs {gain} m; ∂z₁/∂z₀ = {}; one-sided {:?}",
        j[(5, 5)],
        rm.one_sided
    );
    assert!((rise - gain).abs() < 1e-8, "{rise} vs {gain}");
    assert!((j[(5, 5)] - 1.0).abs() < 1e-8, "{}", j[(5, 5)]);
}
