//! The generic pieces a preset (such as RHex's leap) builds on, on robots and functions that
//! are not RHex: the contact-bisection angle on the quadruped of `tests/data/quadruped.toml`
//! against its Newton-solved stance, the secant search against a closed-form root, and the
//! build cache's one build per key, the quasi-static pitch of a block on two feet of unequal
//! length against its closed form, and a preset's end-state derivatives
//! (`sensitivity_preset`) on the hopper against central differences of whole runs.
use selfmanip_core::{ContactMode, FlatGround, Model};
use selfmanip_hybrid::sensitivity::Parameter;
use selfmanip_hybrid::{EventKind, Termination};
use selfmanip_sim::analysis::roots::secant_search;
use selfmanip_sim::analysis::{angle_to_ground, balance_pitch, contact_gaps, solve_contact_pose};
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::expr::Scalar;
use selfmanip_sim::outcome::BodyState;
use selfmanip_sim::sensitivity_preset::{end_state_sensitivity, EndStateRequest};
use selfmanip_sim::sweep::BuildCache;
use selfmanip_sim::{Run, Scenario, Simulation};
mod common;
use common::{data, hopper, test_robot};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The quadruped of `tests/data/quadruped.toml`.
fn quadruped() -> Model {
    test_robot("../quadruped.toml").build().unwrap()
}

/// The quadruped standing on both feet (body height and pitch solved by Newton's method):
/// bisecting the fore hip's angle on the fore foot's gap, from the side where the foot is
/// clear, finds the hip angle of the stance (the second route); no sign change, no angle.
#[test]
fn angle_to_ground_finds_the_solved_stance() {
    let m = quadruped();
    let mode = ContactMode::parse_names(&m, "fore_foot,hind_foot").unwrap();
    let feet: Vec<usize> = mode.active().collect();
    let hip = 0.4;
    let q = solve_contact_pose(
        &m,
        &FlatGround,
        &feet,
        &[5, 6],
        &[hip, -0.8, -0.3, 0.7, 0.0, -0.3, 0.0],
    )
    .unwrap();
    let fore = feet[0];
    let gap_at = |h: f64| {
        let mut qq = q.clone();
        qq[0] = h;
        contact_gaps(&m, &FlatGround, &[fore], &qq)[0]
    };
    let (clear, through) = if gap_at(hip + 0.1) > 0.0 {
        (hip + 0.1, hip - 0.1)
    } else {
        (hip - 0.1, hip + 0.1)
    };
    assert!(gap_at(clear) > 0.0 && gap_at(through) < 0.0);
    let found = angle_to_ground(&m, &FlatGround, &q, 0, fore, clear, through).unwrap();
    assert!((found - hip).abs() < 1e-9, "{found} vs {hip}");
    assert!(gap_at(found) >= 0.0 && gap_at(found).abs() < 1e-12);
    assert_eq!(
        angle_to_ground(&m, &FlatGround, &q, 0, fore, through, clear),
        None
    );
}

/// The secant search finds the root of `d(s) = 3(s − 0.2) + (s − 0.2)²` to its tolerance,
/// keeps the first run when a run has no reading, and stops at its run budget and limit.
#[test]
fn secant_search_finds_a_closed_form_root() {
    let d = |s: f64| 3.0 * (s - 0.2) + (s - 0.2).powi(2);
    let runs = AtomicUsize::new(0);
    let run = |s: f64| {
        runs.fetch_add(1, Ordering::Relaxed);
        Ok::<_, ()>((s, Some(d(s))))
    };
    let s = secant_search(0.0, 12, 1e-12, 1.0, run).unwrap();
    assert!(d(s).abs() <= 1e-12 && (s - 0.2).abs() < 1e-12, "{s}");
    assert!(runs.load(Ordering::Relaxed) <= 12);
    // no reading at the start: the first run is the answer
    let first = secant_search(0.5, 12, 1e-12, 1.0, |s| Ok::<_, ()>((s, None))).unwrap();
    assert_eq!(first, 0.5);
    // one run allowed: the start
    let one = secant_search(0.0, 1, 1e-12, 1.0, |s| Ok::<_, ()>((s, Some(d(s))))).unwrap();
    assert_eq!(one, 0.0);
    // the next input `0 − d(0) = 0.56` lies beyond the limit 0.5: the start is kept
    let limited = secant_search(0.0, 12, 1e-12, 0.5, |s| Ok::<_, ()>((s, Some(d(s))))).unwrap();
    assert_eq!(limited, 0.0);
    // an error of a run is the search's
    assert_eq!(
        secant_search::<f64, _>(0.0, 12, 1e-12, 1.0, |_| Err("bad")),
        Err("bad")
    );
}

/// One build per key (compared by value), shared after; a failed build is not kept.
#[test]
fn build_cache_builds_once_per_key() {
    let cache: BuildCache<(u32, String), u64> = BuildCache::default();
    let builds = AtomicUsize::new(0);
    let build = |v: u64| {
        builds.fetch_add(1, Ordering::Relaxed);
        Ok::<_, String>(v)
    };
    let a = cache.get_or_build((1, "a".into()), || build(10)).unwrap();
    let again = cache.get_or_build((1, "a".into()), || build(99)).unwrap();
    assert_eq!((*a, *again), (10, 10));
    assert!(std::sync::Arc::ptr_eq(&a, &again));
    let b = cache.get_or_build((1, "b".into()), || build(20)).unwrap();
    assert_eq!(*b, 20);
    assert_eq!(builds.load(Ordering::Relaxed), 2);
    let failed = cache.get_or_build((2, "c".into()), || Err::<u64, _>("no".to_string()));
    assert_eq!(failed.unwrap_err(), "no");
    assert_eq!(
        *cache.get_or_build((2, "c".into()), || build(30)).unwrap(),
        30
    );
}

/// The hopper of `hop.toml` from its drop to the apex after its hop.
fn hop_to_apex(b: &Behaviour) -> Run {
    let mut s: Scenario = hopper(b.clone(), 0.8);
    s.options.stop_at_apex = true;
    let mut sim = Simulation::new(&s).unwrap();
    sim.options.control_free_joints = true;
    sim.run().unwrap()
}

/// The apex body state of the hop with parameter `name` set to `v`.
fn apex_with(b: &Behaviour, name: &str, v: f64) -> [f64; 7] {
    let mut b = b.clone();
    b.parameters.insert(name.into(), Scalar::Number(v));
    let run = hop_to_apex(&b);
    assert_eq!(run.execution.termination, Termination::Apex);
    run.outcome.apex.map(|a: BodyState| a.to_array()).unwrap()
}

/// The apex state's derivatives by named behaviour parameters on the hopper (not RHex)
/// against central differences of whole runs (Richardson from `h` and `h/2`); `z_up` flips
/// exactly the two vertical rows, a moving clock origin shifts exactly the time row, and a
/// run that does not end at the event gives every derivative NaN with the caller's reason.
#[test]
fn end_state_derivatives_match_whole_runs_on_the_hopper() {
    let b = Behaviour::from_file(&data("hop.toml")).unwrap();
    let run = hop_to_apex(&b);
    assert_eq!(run.execution.termination, Termination::Apex);
    let names = ["lean", "kp_push"];
    let named: Vec<Vec<(Parameter, f64)>> = names
        .iter()
        .map(|n| vec![(Parameter::Controller((*n).into()), 1.0)])
        .collect();
    let dirs = nalgebra::DMatrix::zeros(2 * run.model.nq(), 0);
    let request = |z_up: bool, d_origin: &'static [f64], not_ended: Option<String>| {
        end_state_sensitivity(&EndStateRequest {
            model: &run.model,
            terrain: &run.terrain,
            exec: &run.execution,
            directions: &dirs,
            named: &named,
            names: &names,
            offset_s: 0.0,
            d_origin,
            end: (EventKind::Apex, "apex"),
            not_ended,
            z_up,
        })
    };
    let d = request(false, &[0.0, 0.0], None);
    assert!(d.ok, "{:?}", d.reason);
    for (k, name) in names.iter().enumerate() {
        let p = match &b.parameters[*name] {
            Scalar::Number(x) => *x,
            other => panic!("{other:?}"),
        };
        let h = 1e-3 * p.abs().max(0.1);
        let cd = |h: f64| {
            let (a, m) = (apex_with(&b, name, p + h), apex_with(&b, name, p - h));
            (0..7)
                .map(|c| (a[c] - m[c]) / (2.0 * h))
                .collect::<Vec<_>>()
        };
        let (d1, d2) = (cd(h), cd(0.5 * h));
        for c in 0..7 {
            let fd = (4.0 * d2[c] - d1[c]) / 3.0;
            let scale = fd.abs() + 1e-3;
            assert!(
                (d.d_state[c][k] - fd).abs() / scale < 1e-5,
                "d apex[{c}] / d {name}: {} vs {fd}",
                d.d_state[c][k]
            );
        }
    }
    let up = request(true, &[1.0, 0.0], None);
    for c in 0..7 {
        for k in 0..2 {
            let expected = match (c, k) {
                (0, 0) => d.d_state[0][0] - 1.0,
                (2 | 5, _) => -d.d_state[c][k],
                _ => d.d_state[c][k],
            };
            assert_eq!(up.d_state[c][k].to_bits(), expected.to_bits(), "{c} {k}");
        }
    }
    let not = request(false, &[0.0, 0.0], Some("no apex here".into()));
    assert!(!not.ok && not.reason.as_deref() == Some("no apex here"));
    assert!(not.d_state.iter().flatten().all(|v| v.is_nan()));
    assert_eq!(not.events.len(), run.execution.events.len());
}

/// What a preset reads off a run, on the hopper's hop to its apex: the apex that ended it is
/// the outcome's, seen from the start (clock, forward position, z up); the foot's first
/// touchdown is the landing of its drop; a flight starts after the drop's touchdown and none
/// after the run's end.
#[test]
fn readings_of_a_run_on_the_hopper() {
    use selfmanip_sim::outcome::{first_touchdown_s, flies_after, reported_apex};
    let b = Behaviour::from_file(&data("hop.toml")).unwrap();
    let run = hop_to_apex(&b);
    let exec = &run.execution;
    let e = reported_apex(exec, true, 0.0).expect("the run ends at its apex");
    assert_eq!(e.kind, EventKind::Apex);
    let apex = BodyState::from_state(&run.model, e.t, &e.q, &e.qd_after);
    assert_eq!(Some(apex), run.outcome.apex);
    let (t0, x0) = (0.25, exec.events[0].q[run.model.ix_x()]);
    let seen = apex.seen_from_start(t0, x0);
    assert_eq!(
        seen.to_array(),
        [
            apex.t_s - t0,
            apex.x_m - x0,
            -apex.z_m,
            apex.phi_rad,
            apex.xdot_m_s,
            -apex.zdot_m_s,
            apex.phidot_rad_s
        ]
    );
    let touchdown = exec
        .events
        .iter()
        .find(|e| e.kind == EventKind::Touchdown)
        .unwrap();
    let foot = touchdown.triggered[0];
    assert_eq!(first_touchdown_s(exec, foot, 0.0), Some(touchdown.t));
    assert_eq!(first_touchdown_s(exec, foot, exec.t + 1.0), None);
    assert!(flies_after(exec, touchdown.t));
    assert!(!flies_after(exec, exec.t + 1.0));
    // the apex that ended the run is reported whatever the caller's start
    assert!(reported_apex(exec, false, exec.t + 1.0).is_some());
}

/// A block with point feet at `(±0.2, d)` below its centre (front `d = 0.05`, rear `0.08`)
/// rests where both are equally deep: `−0.2 sin φ + 0.05 cos φ = 0.2 sin φ + 0.08 cos φ`
/// with `x` forward and nose-up `φ` raising the front, so `tan φ = −0.03 / 0.4` (nose down,
/// the longer rear foot lifting the tail); equal feet rest level.
#[test]
fn balance_pitch_of_a_block_on_unequal_feet() {
    use selfmanip_core::description::ShapeDescription;
    let mut d = test_robot("block_on_two_feet.toml");
    let level = d.clone().build().unwrap();
    let (phi, f, r) = balance_pitch(&level, &[0.0, 0.0, 0.0], &[0], &[1]).unwrap();
    assert!(phi.abs() < 1e-13, "{phi}");
    assert!((f.depth_m - 0.05).abs() < 1e-12 && (r.depth_m - 0.05).abs() < 1e-12);
    d.contacts[1].shape = ShapeDescription::Point {
        position_m: [-0.2, 0.08],
    };
    let m = d.build().unwrap();
    let (phi, f, r) = balance_pitch(&m, &[0.0, 0.0, 0.0], &[0], &[1]).unwrap();
    assert!((phi.tan() + 0.03 / 0.4).abs() < 1e-12, "{phi}");
    let depth = 0.05 * phi.cos() - 0.2 * phi.sin();
    assert!((f.depth_m - depth).abs() < 1e-12 && (r.depth_m - depth).abs() < 1e-12);
    assert_eq!((f.contact, r.contact), (0, 1));
    // a side without contacts has no pitch
    assert_eq!(balance_pitch(&m, &[0.0, 0.0, 0.0], &[], &[1]), None);
}
