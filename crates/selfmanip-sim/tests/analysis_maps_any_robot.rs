//! The analyses that `rhex-model` runs for its figures, on robots that are not RHex: the
//! takeoff maps (against single stances of `analysis::one_leg`), the per-pose quantities of
//! the sensor sweep (holding torques against the forward dynamics at rest, the lead joint's
//! free motion against the contact gaps, the liftoff speed against the normal forces there),
//! the balanced pose and the torus map (against the contact geometry), two contacts down,
//! and the seeded generator (against SplitMix64's published outputs).
use selfmanip_core::{forward_dynamics, ContactMode, Data, FlatGround, Model};
use selfmanip_sim::analysis::balance_map::{balanced_pose, torus_map, Support, MAX_MAP_N};
use selfmanip_sim::analysis::double_stance::double_stance;
use selfmanip_sim::analysis::one_leg::{best_takeoff_over_theta2, rear_takeoff_speed};
use selfmanip_sim::analysis::pose_rates::*;
use selfmanip_sim::analysis::seeded::SplitMix64;
use selfmanip_sim::analysis::takeoff::TorqueSpeedLine;
use selfmanip_sim::analysis::takeoff_maps::*;
use selfmanip_sim::analysis::{contact_gaps, normal_rows, solve_contact_pose};
mod common;
use common::test_robot;
use selfmanip_sim::SimError;

/// The field an invalid-value error names.
fn field(e: SimError) -> String {
    match e {
        SimError::InvalidValue { field, .. } => field,
        other => panic!("not an invalid value: {other}"),
    }
}

/// A biped of two massless one-link legs of different lengths on sticking point toes, a
/// body with a sliding nose and tail (front first).
fn biped() -> Model {
    test_robot("biped_point_toes.toml").build().unwrap()
}

/// `d gap / ds` of the contacts `toes` at `q` moving along `v` (central differences).
fn gap_rates(m: &Model, toes: &[usize], q: &[f64], v: &[f64]) -> Vec<f64> {
    let h = 1e-6;
    let at = |s: f64| {
        let qs: Vec<f64> = q.iter().zip(v).map(|(a, b)| a + s * b).collect();
        contact_gaps(m, &FlatGround, toes, &qs)
    };
    let (p, n) = (at(h), at(-h));
    p.iter().zip(&n).map(|(p, n)| (p - n) / (2.0 * h)).collect()
}

/// The biped on both toes, legs at `(0.2, −0.1)`, body height and pitch solved.
fn on_both_toes(m: &Model) -> (ContactMode, Vec<f64>) {
    let mode = ContactMode::parse_names(m, "front_toe,rear_toe").unwrap();
    let toes: Vec<usize> = mode.active().collect();
    let free = [m.ix_z(), m.ix_phi()];
    let q = solve_contact_pose(m, &FlatGround, &toes, &free, &[0.2, -0.1, 0.0, -0.1, 0.0]);
    (mode, q.unwrap())
}

#[test]
fn takeoff_maps_are_their_single_stances() {
    let m = test_robot("knee_and_wheel_feet.toml").build().unwrap();
    let line = TorqueSpeedLine::new(2.0, 30.0).unwrap();
    let map = takeoff_map(&m, &line, 7.0, 'x', [-0.4, 0.4], [-0.1, 0.1], 3).unwrap();
    assert_eq!(map.len(), 9);
    assert_eq!((map[0].theta2, map[8].theta2), (-0.4, 0.4));
    assert_eq!((map[0].phi, map[2].phi, map[1].phi), (-0.1, 0.1, 0.0));
    for s in &map {
        let single = rear_takeoff_speed(&m, s.theta2, s.phi, 0.0, &line).unwrap();
        assert_eq!(s.x_dot, single.map(|b| b.x_dot.abs()));
        assert_eq!((s.phi_dot, s.gear_ratio, s.leg), (0.0, 7.0, 'x'));
    }
    let best = best_takeoffs(&m, &line, 7.0, (), &[0.0, 0.5], &[0.0, 0.05], [-0.6, 0.6]);
    assert_eq!(best.len(), 4);
    for (i, s) in best.iter().enumerate() {
        let (phi_dot, phi) = ([0.0, 0.5][i / 2], [0.0, 0.05][i % 2]);
        let single = best_takeoff_over_theta2(&m, phi, phi_dot, &line, [-0.6, 0.6]);
        assert_eq!(
            (s.phi_dot, s.phi, s.theta2, s.x_dot),
            (phi_dot, phi, single.0, Some(single.1))
        );
    }
    for n in [0, 1, MAX_FIGURE_GRID + 1] {
        let e = takeoff_map(&m, &line, 7.0, (), [-0.4, 0.4], [-0.1, 0.1], n).unwrap_err();
        assert_eq!(field(e), "n");
    }
}

#[test]
fn rolling_legs_turn_arcs_into_their_circles() {
    let biped = test_robot("biped_point_toes.toml");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/robots/biped_point_toes.toml"
    ))
    .unwrap();
    let arc = text.replace(
        r#"shape = { kind = "point", position_m = [0.0, 0.14] }"#,
        r#"shape = { kind = "arc", center_m = [0.0, 0.07], radius_m = 0.07, normal_range_rad = [0.0, 3.0] }"#,
    );
    let mut d = selfmanip_core::RobotDescription::from_toml_str(&arc).unwrap();
    let before = d.clone();
    assert_eq!(
        biped,
        selfmanip_core::RobotDescription::from_toml_str(&text).unwrap()
    );
    rolling_legs(&mut d);
    let circle = text.replace(
        r#"shape = { kind = "point", position_m = [0.0, 0.14] }"#,
        r#"shape = { kind = "circle", center_m = [0.0, 0.07], radius_m = 0.07 }"#,
    );
    assert_eq!(
        d,
        selfmanip_core::RobotDescription::from_toml_str(&circle).unwrap()
    );
    assert_ne!(d, before);
}

#[test]
fn holding_torque_holds_the_biped_at_rest() {
    let m = biped();
    let (mode, q) = on_both_toes(&m);
    let tau = holding_torque(&m, mode, &q).unwrap();
    // the internal force is fixed by t_dᵀτ = 0: equal torques
    assert!((tau[0] - tau[1]).abs() < 1e-12 * tau[0].abs().max(1.0));
    let mut data = Data::new(&m);
    let zero = vec![0.0; m.nq()];
    forward_dynamics(&m, &mut data, &FlatGround, mode, &q, &zero, &tau, None).unwrap();
    assert!(data.qdd.amax() < 1e-9, "{}", data.qdd);
    // one toe down is not determinate for two joints with this split
    let one = ContactMode::parse_names(&m, "front_toe").unwrap();
    assert_eq!(field(holding_torque(&m, one, &q).unwrap_err()), "mode");
}

#[test]
fn the_lead_joints_motion_keeps_both_toes_down_and_lifts_one_at_its_speed() {
    let m = biped();
    let (mode, q) = on_both_toes(&m);
    let v = lead_motion(&m, mode, &q, 0).unwrap();
    assert!((v[0] - 1.0).abs() < 1e-12);
    let toes: Vec<usize> = mode.active().collect();
    for r in gap_rates(&m, &toes, &q, &v) {
        assert!(r.abs() < 1e-8, "gap rate {r}");
    }
    let gain = pitch_rate_gain(&m, mode, &q, 0).unwrap();
    assert_eq!(gain, 1.0 / v[m.ix_phi()]);
    // at the liftoff speed one toe's normal force vanishes; below it both push
    let speed = lead_liftoff_speed(&m, mode, &q, 0)
        .unwrap()
        .expect("a toe lifts");
    let normals = |s: f64| {
        let qd: Vec<f64> = v.iter().map(|x| s * x).collect();
        let mut data = Data::new(&m);
        forward_dynamics(&m, &mut data, &FlatGround, mode, &q, &qd, &[0.0; 2], None).unwrap();
        normal_rows(&data)
            .iter()
            .map(|&r| data.lambda[r])
            .collect::<Vec<f64>>()
    };
    let rest = normals(0.0);
    let scale = rest.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let lifted = normals(speed);
    assert!(lifted.iter().any(|l| l.abs() < 1e-7 * scale), "{lifted:?}");
    let below = normals(0.9 * speed);
    assert!(
        below.iter().zip(&rest).all(|(b, r)| b * r > 0.0),
        "{below:?}"
    );
}

#[test]
fn balanced_poses_rest_on_their_two_supports() {
    let m = biped();
    let (nose, tail) = (0, 2);
    let (front, rear) = ([1, nose], [3, tail]);
    let poses = torus_map(16, |t1, t2| {
        let q = [t1, t2, 0.0, 0.0, 0.0];
        balanced_pose(&m, &q, &front, &rear).map(|p| (t1, t2, p))
    })
    .unwrap();
    assert!(!poses.is_empty() && poses.len() <= 256);
    let mut kinds = Vec::new();
    for (t1, t2, p) in &poses {
        let q = [*t1, *t2, 0.0, -p.height_m, p.phi];
        let down: Vec<usize> = p.mode.active().collect();
        for g in contact_gaps(&m, &FlatGround, &down, &q) {
            assert!(g.abs() < 1e-9, "{g}");
        }
        for g in contact_gaps(&m, &FlatGround, &[0, 1, 2, 3], &q) {
            assert!(g > -1e-9, "{g}");
        }
        let body = |s: Support, k: usize| (s == Support::Body) == down.contains(&k);
        assert!(body(p.front, nose) && body(p.rear, tail));
        kinds.push(p.front.letter());
    }
    assert!(kinds.contains(&'B') && kinds.contains(&'T'));
    for n in [0, MAX_MAP_N + 1] {
        assert_eq!(field(torus_map(n, |_, _| Some(())).unwrap_err()), "n");
    }
}

#[test]
fn double_stance_is_on_both_toes_along_its_motion() {
    let m = biped();
    let mode = ContactMode::parse_names(&m, "front_toe,rear_toe").unwrap();
    let y = [0.5, 0.5, 0.0, 0.0, 0.0];
    let (q, qd) = double_stance(&m, mode, &[0.2, -0.1, 0.0, -0.1, 0.0], &y, 2.0).unwrap();
    let (_, q_ref) = on_both_toes(&m);
    assert_eq!(q, q_ref);
    assert!((0.5 * qd[0] + 0.5 * qd[1] - 2.0).abs() < 1e-12);
    let toes: Vec<usize> = mode.active().collect();
    for r in gap_rates(&m, &toes, &q, &qd) {
        assert!(r.abs() < 1e-7, "gap rate {r}");
    }
}
#[test]
fn splitmix64_gives_its_published_outputs() {
    // the reference outputs of SplitMix64 from seed 0
    let mut r = SplitMix64(0);
    assert_eq!(r.next_u64(), 0xE220A8397B1DCDAF);
    assert_eq!(r.next_u64(), 0x6E789E6AA1B965F4);
    assert_eq!(r.next_u64(), 0x06C45D188009454F);
    let mut r = SplitMix64(7);
    for _ in 0..100 {
        let u = r.uniform(-2.0, 3.0);
        assert!((-2.0..3.0).contains(&u));
    }
}
