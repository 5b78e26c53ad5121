//! A run whose feet slide damped (`selfmanip_core::damped_slide`, the decision
//! 2026-11-29-two-link-chain-retouch): a two-legged robot of the user-robot sweep (seed 30,
//! run 256, `data/damped_chain_push.json`) whose legs are both two massless links under
//! servos, pushing off flat ground.
//!
//! What is checked, each against a route of its own:
//! - the run reaches its final time with feet that slide damped;
//! - where a damped slide ends at its stick or liftoff guard, the event's time is the zero
//!   of the foot's sliding velocity `u_t` (the contact's rows times `q̇`) or of its push
//!   (the contact problem solved again at the segment's dense states under the chain law
//!   read off the segment's controller), found by an independent bisection of the dense
//!   output;
//! - the energy balance `E1 − E0 = W + W_fr − L` to 1e-6 J, with the friction's work
//!   non-zero;
//! - the run is deterministic: a second run's events are bit-identical;
//! - over runs of the user-robot sweep (seed 30) whose massless two-link legs slide and
//!   stick (`data/user_run_N.json`: run 211, a general site held sliding by a Zeno
//!   truncation's dwell while its normal force pulls; run 32, a damped slide ended by a
//!   stick at a controller's phase; run 402, a general site held sliding whose force comes
//!   to pull inside a segment of the dwell; runs 394 and 452, which showed the same faults;
//!   seed 44's run 405, `data/saturated_chain_stairs.json`, whose feet slide where a stop
//!   has saturated their chains' servos),
//!   the friction's and the dampers' works are never positive and the balance closes to 1e-6 J.
//! - the chain's torques the slide asks for (`Controller::torque_of`) are the whole
//!   torque's, bit for bit.
mod common;

use selfmanip_core::damped_slide::{contact_rows, solve};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{ContactMode, Model, Terrain};
use selfmanip_hybrid::damped_slide::{chain_law, damped_contacts, sliding_damped};
use selfmanip_hybrid::{EventKind, Segment};
use selfmanip_sim::{Run, RunStatus, Scenario, Simulation};
use std::path::Path;

fn scenario() -> Scenario {
    scenario_of("damped_chain_push.json")
}

fn scenario_of(file: &str) -> Scenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(file);
    Scenario::from_file(&path).unwrap()
}

fn run() -> Run {
    Simulation::new(&scenario()).unwrap().run().unwrap()
}

/// The contacts of `mode` that slide damped at the segment's start (the chain law holds).
fn damped_in(model: &Model, seg: &Segment) -> Vec<usize> {
    let sliding = sliding_damped(damped_contacts(model), seg.mode);
    let (q, qd) = seg.y0.split_at(model.nq());
    (0..model.n_contacts())
        .filter(|&k| sliding >> k & 1 == 1)
        .filter(|&k| {
            chain_law(model, &*seg.controller, (seg.t0, q, qd), seg.mode, k)
                .is_some_and(|l| l.holds)
        })
        .collect()
}

/// Whether contact `k`'s chain law at the segment's start is on a saturated piece (a servo
/// at its torque limit, `ChainLaw::saturated`).
fn saturated_at_start(model: &Model, seg: &Segment, k: usize) -> bool {
    let (q, qd) = seg.y0.split_at(model.nq());
    chain_law(model, &*seg.controller, (seg.t0, q, qd), seg.mode, k)
        .is_some_and(|l| l.holds && l.saturated.is_some())
}

/// The foot's sliding velocity `u_t` and push `−λ_n` of contact `k` at `t` on the
/// segment's dense output, the contact problem solved on `side` (`None`: where it is
/// consistent).
fn slide_at(
    model: &Model,
    terrain: &dyn Terrain,
    seg: &Segment,
    k: usize,
    t: f64,
    side: Option<f64>,
) -> (f64, f64) {
    let mut y = vec![0.0; 2 * model.nq()];
    seg.eval(t, &mut y);
    let (q, qd) = y.split_at(model.nq());
    let mut kin = Kinematics::default();
    kin.compute(model, q, qd);
    let a = contact_rows(model, &kin, terrain, k, qd);
    let u_t: f64 = (0..model.nq()).map(|j| a[(0, j)] * qd[j]).sum();
    let mode: ContactMode = seg.mode;
    let law = chain_law(model, &*seg.controller, (t, q, qd), mode, k).unwrap();
    let mu_k = model.contacts[k].kinetic_mu;
    let d = solve(model, &kin, terrain, k, qd, &law, mu_k, side)
        .unwrap()
        .unwrap();
    (u_t, d.push())
}

/// The first zero of `f` on `[a, b]` by sampling and bisection (`f(a)` on one side).
fn first_zero(f: impl Fn(f64) -> f64, a: f64, b: f64) -> Option<f64> {
    let n = 200;
    let f0 = f(a);
    let mut lo = a;
    for i in 1..=n {
        let t = a + (b - a) * i as f64 / n as f64;
        if f(t) * f0 <= 0.0 {
            let (mut l, mut h) = (lo, t);
            for _ in 0..80 {
                let m = 0.5 * (l + h);
                if f(m) * f0 > 0.0 {
                    l = m;
                } else {
                    h = m;
                }
            }
            return Some(0.5 * (l + h));
        }
        lo = t;
    }
    None
}

#[test]
fn the_run_finishes_with_feet_that_slide_damped() {
    let run = run();
    assert_eq!(
        run.outcome.status,
        RunStatus::FinalTime,
        "{:?}",
        run.execution.termination
    );
    let model = &run.model;
    let damped: usize = run
        .execution
        .segments
        .iter()
        .filter(|s| s.t1 > s.t0 && !damped_in(model, s).is_empty())
        .count();
    assert!(damped > 0, "no segment slides damped");
}

#[test]
fn a_damped_slide_ends_where_its_guard_function_is_zero() {
    let run = run();
    let (model, terrain) = (&*run.model, &run.terrain);
    let exec = &run.execution;
    let mut checked = 0;
    for (i, seg) in exec.segments.iter().enumerate() {
        // the event that ends the segment
        let Some(e) = exec
            .events
            .iter()
            .find(|e| e.t == seg.t1 && e.mode_before == seg.mode)
        else {
            continue;
        };
        if seg.t1 - seg.t0 < 1e-6 || i + 1 == exec.segments.len() {
            continue;
        }
        for k in damped_in(model, seg) {
            if !e.triggered.contains(&k) {
                continue;
            }
            // the side the segment started on, kept for it
            let side = {
                let (q, qd) = seg.y0.split_at(model.nq());
                let mut kin = Kinematics::default();
                kin.compute(model, q, qd);
                let law = chain_law(model, &*seg.controller, (seg.t0, q, qd), seg.mode, k);
                let mu_k = model.contacts[k].kinetic_mu;
                solve(model, &kin, terrain, k, qd, &law.unwrap(), mu_k, None)
                    .unwrap()
                    .unwrap()
                    .side
            };
            let f: Box<dyn Fn(f64) -> f64> = match e.kind {
                EventKind::Stick => Box::new(|t| slide_at(model, terrain, seg, k, t, Some(side)).0),
                EventKind::Liftoff => {
                    Box::new(|t| slide_at(model, terrain, seg, k, t, Some(side)).1)
                }
                _ => continue,
            };
            // start clear of the segment's first instant (a slide from rest)
            let a = seg.t0 + 1e-3 * (seg.t1 - seg.t0);
            // a truncation's dwell ends by time, its held contacts judged together: no zero
            let dwell = exec
                .events
                .iter()
                .any(|d| d.kind == EventKind::ZenoTruncation && d.t == seg.t0);
            let Some(zero) = first_zero(&f, a, seg.t1 + 1e-9) else {
                assert!(
                    dwell,
                    "{:?} of contact {k} at {} s: no zero from {} s",
                    e.kind, seg.t1, seg.t0
                );
                continue;
            };
            let tol = 1e-8_f64.max(1e-6 * (seg.t1 - seg.t0));
            assert!(
                (zero - seg.t1).abs() < tol,
                "{:?} of contact {k}: event at {} s, zero at {zero} s",
                e.kind,
                seg.t1
            );
            checked += 1;
        }
    }
    assert!(checked > 0, "no damped slide ended at its own guard");
}

#[test]
fn the_energy_balance_holds_with_friction_work() {
    let run = run();
    let er = run.energy_report().unwrap();
    assert!(
        er.residual_j().abs() < 1e-6,
        "residual {} J",
        er.residual_j()
    );
    assert!(
        er.friction_work_j < -1e-3,
        "friction work {} J",
        er.friction_work_j
    );
}

#[test]
fn the_run_is_deterministic() {
    common::assert_deterministic(run, |a, b| assert_eq!(a.steps, b.steps));
}

/// The energy balance `E1 − E0 = W + W_d + W_fr − L` of user runs whose feet slide, stick
/// and are held by a Zeno truncation: the kinetic friction `−μ_k |λ_n| |v_t|` and the
/// dampers `−c θ̇²` only take energy (never positive, to round-off), and the balance — with
/// the friction's work non-zero — closes to 1e-6 J. Before a pulling contact lost its
/// friction, the friction of runs 211 and 452 did +3.2 J and +1.4 J, and before a site that
/// comes to pull inside a segment lost it there, that of run 402 did +1.4 J (its foot driven
/// to 29 m/s); before a stick set its chain's rates, the balance of run 32 missed by 66 J
/// (its stuck foot kept sliding at 3.2 m/s) and that of run 394 by 1.1 kJ. Seed 44's run
/// 405 (`saturated_chain_stairs.json`: two legs of two massless links under servos with a
/// torque limit, on stairs) slides where a stop has taken its servos to their limit (the
/// chain's law linearized on its torque-free manifold); before, its feet re-touched
/// 59,658 times without an event and the run ended at its step budget. Seed 38's run 47
/// (`saturated_knee_slide.json`: four legs of two massless links whose knee servos push to
/// their torque limit) slides with a knee at its limit (the slide on the law's saturated
/// piece); before, its feet re-touched 13,083 times and the run ended as
/// `several_contact_solutions` after 411 events.
#[test]
fn user_runs_dissipate_and_balance() {
    for file in [
        "damped_chain_push.json",
        "user_run_211.json",
        "user_run_32.json",
        "user_run_394.json",
        "user_run_402.json",
        "user_run_452.json",
        "saturated_chain_stairs.json",
        "saturated_knee_slide.json",
    ] {
        let run = Simulation::new(&scenario_of(file)).unwrap().run().unwrap();
        assert_eq!(run.outcome.status, RunStatus::FinalTime, "{file}");
        if file == "saturated_knee_slide.json" {
            let model = &run.model;
            let saturated = run.execution.segments.iter().any(|s| {
                s.t1 > s.t0
                    && damped_in(model, s)
                        .iter()
                        .any(|&k| saturated_at_start(model, s, k))
            });
            assert!(
                saturated,
                "{file}: no segment slides with a servo at its limit"
            );
        }
        if file == "saturated_chain_stairs.json" {
            let model = &run.model;
            let segments = &run.execution.segments;
            assert!(
                segments
                    .iter()
                    .any(|s| s.t1 > s.t0 && !damped_in(model, s).is_empty()),
                "{file}: no segment slides damped"
            );
        }
        let er = run.energy_report().unwrap();
        assert!(er.friction_work_j < -1e-4, "{file}: friction {er:?}");
        assert!(er.damping_work_j <= 1e-12, "{file}: damping {er:?}");
        assert!(er.residual_j().abs() < 1e-6, "{file}: residual {er:?}");
    }
}

/// A damped slide asks the behaviour for its chain's torques alone
/// (`Controller::torque_of`), several times per evaluation: they are the whole torque's
/// numbers, bit for bit, for every range of joints, in every contact mode of the robot's
/// feet, at random times and states — for the behaviours of the sweep's runs (servos, held
/// and tracking, with torque limits, in and out of contact, before and after their pushes).
#[test]
fn a_chain_s_torques_are_the_whole_torque_s() {
    use selfmanip_sim::analysis::seeded::SplitMix64;
    let mut rng = SplitMix64(17);
    for file in [
        "damped_chain_push.json",
        "user_run_32.json",
        "user_run_211.json",
        "user_run_394.json",
        "user_run_402.json",
        "user_run_452.json",
    ] {
        let sim = Simulation::new(&scenario_of(file)).unwrap();
        let (model, ctrl) = (&sim.model, &*sim.controller);
        let (nq, nj, nc) = (model.nq(), model.n_joints(), model.n_contacts());
        let mut whole = vec![0.0; nj];
        let mut part = vec![0.0; nj];
        for _ in 0..40 {
            let t = rng.uniform(0.0, 0.5);
            let q: Vec<f64> = (0..nq).map(|_| rng.uniform(-1.5, 1.5)).collect();
            let qd: Vec<f64> = (0..nq).map(|_| rng.uniform(-20.0, 20.0)).collect();
            for normal in 0..1u32 << nc {
                let mode = ContactMode::from_bits(normal, normal).unwrap();
                ctrl.torque(t, &q, &qd, mode, &mut whole);
                for lo in 0..nj {
                    for hi in lo + 1..=nj {
                        part.fill(f64::NAN);
                        ctrl.torque_of(t, (&q, &qd), mode, lo..hi, &mut part);
                        for j in lo..hi {
                            assert_eq!(
                                part[j].to_bits(),
                                whole[j].to_bits(),
                                "{file}: joint {j} of {lo}..{hi} at t = {t} in {mode:?}"
                            );
                        }
                    }
                }
            }
        }
    }
}
