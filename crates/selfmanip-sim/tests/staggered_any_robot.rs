//! The generic machinery `rhex-model` runs its leaps and figures on, on a robot that is not
//! RHex (the biped of `tests/data/robots/biped_point_toes.toml`): a staggered scenario's runs
//! read in the first drive's frame (against fresh builds of each point and the touchdowns in
//! their event lists), its touchdown timing (against its target), the balanced pitch's range
//! (against a finer map), the liftoff-speed map (against its single poses), the splay
//! derivative (against differences of the two-contact stance built by hand), the takeoff
//! maps by gear ratio (against one map per ratio) and a determinate start on the body
//! (against the mode named by hand).
use selfmanip_core::{ContactMode, Model};
use selfmanip_hybrid::budget::NEVER;
use selfmanip_hybrid::EventKind;
use selfmanip_sim::analysis::balance_map::{
    balanced_pose, liftoff_speed_map, pitch_range, torus_map, BalancedPose,
};
use selfmanip_sim::analysis::double_stance::{
    double_stance, normal_force_difference, splay_derivative, splay_stance,
};
use selfmanip_sim::analysis::pose_rates::lead_liftoff_speed;
use selfmanip_sim::analysis::takeoff::TorqueSpeedLine;
use selfmanip_sim::analysis::takeoff_maps::{best_takeoffs, best_takeoffs_by_ratio, TakeoffSample};
use selfmanip_sim::behaviour::{Behaviour, JointProgram, Motion, Phase, Torque, Trigger};
use selfmanip_sim::staggered::{LagReference, StaggeredScenario, TOUCHDOWN_SEARCH_TOL_S};
use selfmanip_sim::terrain::TerrainSpec;
use selfmanip_sim::{InitialState, Scenario, SimError, SimOptions, Simulation};
mod common;
use common::test_robot;

/// The field an invalid-value error names.
fn field(e: SimError) -> String {
    match e {
        SimError::InvalidValue { field, .. } => field,
        other => panic!("not an invalid value: {other}"),
    }
}

/// The biped with legs of mass, sitting on its nose and tail with its legs raised forward
/// and back and held there; each leg's push (a constant torque towards the ground) starts at
/// its drive's time, the rear one `t2` after the front one.
fn sitting_biped(t2: f64, t_final_s: f64) -> Scenario {
    let mut robot = test_robot("biped_point_toes.toml");
    for leg in &mut robot.legs {
        leg.links[0].mass_kg = 0.2;
        leg.links[0].inertia_kg_m2 = 1e-3;
    }
    let push = |joint: &str, start: &str, tau: f64| {
        let phases = vec![
            Phase::new("wait", Torque::servo(5.0, 0.2, None, false)).moving(Motion::hold("q0")),
            Phase::new("push", Torque::constant(tau)).starting(Trigger::at(start)),
        ];
        JointProgram::new(joint, phases)
    };
    let behaviour = Behaviour::new("staggered", "two pushes a lag apart")
        .parameter("t2", t2)
        .parameter("t_front", "max(0, -t2)")
        .parameter("t_rear", "max(0, t2)")
        .program(push("front", "t_front", -0.03))
        .program(push("rear", "t_rear", 0.02));
    Scenario {
        robot,
        terrain: TerrainSpec::Flat,
        initial: InitialState {
            q: vec![1.4, -1.4, 0.0, -0.04, 0.0],
            qd: None,
            contacts: vec!["nose".into(), "tail".into()],
            solve: Vec::new(),
        },
        behaviour,
        options: SimOptions {
            t_final_s,
            ..SimOptions::default()
        },
    }
}

/// The biped's scenario built at lag 0.01 s as a staggered scenario timed by its toes.
fn staggered() -> StaggeredScenario {
    let sim = Simulation::new(&sitting_biped(0.01, 0.3)).unwrap();
    let toe = |name: &str| sim.model.contact_index(name).unwrap();
    let touchdowns = [toe("front_toe"), toe("rear_toe")];
    StaggeredScenario::new(sim, "t2", 0.01, 0.3, touchdowns)
}

/// Each lag's run is what a fresh build of that lag runs, on the first drive's clock
/// (`−min(0, lag)` earlier), with the touchdown lag its event list gives.
#[test]
fn staggered_runs_are_fresh_builds_read_in_the_first_drives_frame() {
    let s = staggered();
    let label = |m: ContactMode| s.sim.labels.label(m);
    for lag in [-0.04, 0.01, 0.03] {
        let r = s
            .run_timed(&[], lag, LagReference::MotorStart, &NEVER, &label)
            .unwrap();
        let offset = -f64::min(0.0, lag);
        // on a clock that starts with the earlier drive: to t_final + offset
        let fresh = Simulation::new(&sitting_biped(lag, 0.3 + offset)).unwrap();
        let exec = fresh.run().unwrap().execution;
        assert_eq!(r.lag_s, lag);
        assert_eq!(r.run.time_offset_s, offset);
        assert_eq!(r.run.execution.events.len(), exec.events.len(), "{lag}");
        for (a, b) in r.run.execution.events.iter().zip(&exec.events) {
            assert_eq!((a.kind, a.t.to_bits()), (b.kind, b.t.to_bits()), "{lag}");
        }
        assert_eq!(r.run.events.len(), exec.events.len());
        let first = |k: usize, after: f64| {
            exec.events
                .iter()
                .find(|e| {
                    e.kind == EventKind::Touchdown && e.t >= after && e.triggered.contains(&k)
                })
                .map(|e| e.t)
        };
        let [f, b] = s.touchdowns;
        let expected = first(f, offset)
            .zip(first(b, offset + lag))
            .map(|(a, b)| b - a);
        assert!(expected.is_some(), "both toes land at {lag}");
        assert_eq!(r.touchdown_lag_s, expected, "{lag}");
        assert_eq!(r.run.q0, s.sim.q0);
    }
}

/// Timed by touchdown, the run found lands its toes the target apart.
#[test]
fn touchdown_timing_finds_its_target() {
    let s = staggered();
    let label = |m: ContactMode| s.sim.labels.label(m);
    let motor = s
        .run_timed(&[], 0.02, LagReference::MotorStart, &NEVER, &label)
        .unwrap();
    let target = motor.touchdown_lag_s.unwrap() + 0.01;
    let r = s
        .run_timed(&[], target, LagReference::Touchdown, &NEVER, &label)
        .unwrap();
    let lag = r.touchdown_lag_s.unwrap();
    assert!(
        (lag - target).abs() <= TOUCHDOWN_SEARCH_TOL_S,
        "{lag} vs {target}"
    );
    assert_ne!(r.lag_s, target);
}

/// The biped (massless legs) and its two sides: nose and front toe, tail and rear toe.
fn biped() -> (Model, impl Fn(f64, f64) -> Option<BalancedPose>) {
    let m = test_robot("biped_point_toes.toml").build().unwrap();
    let model = m.clone();
    let pose =
        move |t1: f64, t2: f64| balanced_pose(&model, &[t1, t2, 0.0, 0.0, 0.0], &[1, 0], &[3, 2]);
    (m, pose)
}

/// The pitch's range: no pose of a map four times finer pitches beyond it, and the
/// extremes are the poses at their angles.
#[test]
fn pitch_range_bounds_a_finer_map() {
    let (_, pose) = biped();
    let r = pitch_range(24, &pose).unwrap();
    let fine = torus_map(96, |t1, t2| pose(t1, t2).map(|p| p.phi)).unwrap();
    let (hi, lo) = fine
        .iter()
        .fold((f64::MIN, f64::MAX), |(h, l), &p| (h.max(p), l.min(p)));
    assert!(
        r.max_phi >= hi - 1e-9 && r.min_phi <= lo + 1e-9,
        "{r:?} {hi} {lo}"
    );
    assert!(r.max_phi > r.min_phi);
    assert_eq!(pose(r.argmax[0], r.argmax[1]).unwrap().phi, r.max_phi);
    assert_eq!(pose(r.argmin[0], r.argmin[1]).unwrap().phi, r.min_phi);
    assert_eq!(field(pitch_range(7, &pose).unwrap_err()), "grid");
    assert_eq!(field(pitch_range(8, |_, _| None).unwrap_err()), "model");
}

/// The liftoff map is its single poses: where the front leg carries the robot, the liftoff
/// speed at the pose built from the angles.
#[test]
fn liftoff_speed_map_is_its_single_poses() {
    let (m, pose) = biped();
    let ranges = [[-0.8, 0.8], [-0.8, 0.8]];
    let map = liftoff_speed_map(&m, ranges, 9, 0, &pose).unwrap();
    let mut expected = Vec::new();
    for i in 0..9 {
        for j in 0..9 {
            let (t1, t2) = (-0.8 + 0.2 * i as f64, -0.8 + 0.2 * j as f64);
            let Some(p) = pose(t1, t2) else { continue };
            if !p.mode.active().any(|k| k == 1) {
                continue;
            }
            let q = [t1, t2, 0.0, -p.height_m, p.phi];
            if let Ok(speed) = lead_liftoff_speed(&m, p.mode, &q, 0) {
                expected.push(([t1, t2], speed));
            }
        }
    }
    assert!(map.iter().any(|s| s.speed.is_some()));
    assert_eq!(map.len(), expected.len());
    for (s, (theta, speed)) in map.iter().zip(&expected) {
        assert!((s.theta[0] - theta[0]).abs() < 1e-12 && (s.theta[1] - theta[1]).abs() < 1e-12);
        let close = match (s.speed, speed) {
            (Some(a), Some(b)) => (a - b).abs() <= 1e-9 * b.abs().max(1.0),
            (a, b) => a == *b,
        };
        assert!(close, "{s:?} vs {speed:?}");
    }
    assert_eq!(
        field(liftoff_speed_map(&m, ranges, 1, 0, &pose).unwrap_err()),
        "n"
    );
    assert_eq!(
        field(liftoff_speed_map(&m, ranges, 9, 2, &pose).unwrap_err()),
        "lead"
    );
}

/// The splay stance is the double stance at `θ_m ± θ_d` moving with the mean angle, and the
/// splay derivative its normal-force difference differenced at another step.
#[test]
fn splay_derivative_differences_the_splayed_stance() {
    let (m, _) = biped();
    let mode = ContactMode::parse_names(&m, "front_toe,rear_toe").unwrap();
    let (tm, rate, tau) = (0.1, 1.5, 0.3);
    let stance = |td: f64| {
        let q = [tm + td, tm - td, 0.0, -0.1, 0.0];
        double_stance(&m, mode, &q, &[0.5, 0.5, 0.0, 0.0, 0.0], rate).unwrap()
    };
    assert_eq!(
        splay_stance(&m, mode, [tm, 0.02], rate, -0.1).unwrap(),
        stance(0.02)
    );
    let h = 1e-4;
    let diff = |td: f64| {
        let (q, qd) = stance(td);
        normal_force_difference(&m, mode, &q, &qd, &[tau, tau]).unwrap()
    };
    let fd = (diff(h) - diff(-h)) / (2.0 * h);
    let d = splay_derivative(&m, mode, tm, rate, tau, -0.1).unwrap();
    assert!((d - fd).abs() <= 1e-5 * fd.abs().max(1.0), "{d} vs {fd}");
    assert!(fd.abs() > 1e-3, "{fd}");
}

/// By gear ratio, the takeoff maps are one map at pitch rate 0 per ratio, its own motor line
/// each (a knee-and-wheel robot); a line that cannot be made is the call's error.
#[test]
fn takeoffs_by_ratio_are_one_map_per_ratio() {
    let m = test_robot("knee_and_wheel_feet.toml").build().unwrap();
    let line = |g: f64| TorqueSpeedLine::new(0.1 * g, 600.0 / g);
    let by_ratio = best_takeoffs_by_ratio(&m, &[5.0, 9.0], line, 'w', &[0.0, 0.05], [-0.6, 0.6]);
    let mut one_by_one = Vec::new();
    for g in [5.0, 9.0] {
        let l = line(g).unwrap();
        one_by_one.extend(best_takeoffs(
            &m,
            &l,
            g,
            'w',
            &[0.0],
            &[0.0, 0.05],
            [-0.6, 0.6],
        ));
    }
    let key = |s: &TakeoffSample<char>| (s.theta2, s.phi, s.phi_dot, s.gear_ratio, s.x_dot);
    let by_ratio: Vec<_> = by_ratio.unwrap().iter().map(key).collect();
    assert_eq!(by_ratio, one_by_one.iter().map(key).collect::<Vec<_>>());
    assert_ne!(one_by_one[0].x_dot, one_by_one[2].x_dot);
    let bad = best_takeoffs_by_ratio(&m, &[5.0, -1.0], line, 'w', &[0.0], [-0.6, 0.6]);
    assert!(bad.is_err());
}

/// Resting on a sticking nose and tail, the tail starts sliding; sliding body contacts, a
/// single sticking one and the toes are left as they are.
#[test]
fn a_start_on_two_sticking_body_contacts_slides_the_second() {
    use selfmanip_core::description::FrictionDescription;
    use selfmanip_sim::preset_run::determinate_body_start;
    let mut d = test_robot("biped_point_toes.toml");
    let sliding = d.clone().build().unwrap();
    for c in d.contacts.iter_mut().filter(|c| c.leg.is_none()) {
        c.friction = FrictionDescription::Sticking {
            mu: Some(0.5),
            mu_kinetic: Some(0.5),
        };
    }
    let m = d.build().unwrap();
    let mode = |m: &Model, s: &str| ContactMode::parse_names(m, s).unwrap();
    let start = determinate_body_start(&m, mode(&m, "nose,tail"));
    assert_eq!(start, mode(&m, "nose,tail:slide"));
    for s in ["nose", "tail,front_toe,rear_toe", "front_toe,rear_toe"] {
        assert_eq!(determinate_body_start(&m, mode(&m, s)), mode(&m, s), "{s}");
    }
    let both = mode(&sliding, "nose,tail");
    assert_eq!(determinate_body_start(&sliding, both), both);
}
