//! RHex leaps (chapter 3.2 strategies through the chapter-5 hybrid system) checked against
//! laws that hold whatever the leap does: the energy balance `E₁ − E₀ = W_motor + W_fr − L`
//! with impact losses `L ≥ 0` (no reset adds energy) and the toes' kinetic friction work
//! `W_fr ≤ 0`, touchdowns located on the ground, post-impact
//! velocities on the new constraint manifold (5.52), slips exactly on the friction cone
//! (section 5.1.5), words that start at rest on the body (`1010`) and end in flight
//! (`0000`), determinism, and typed errors for bad input.
mod common;
use common::at_ledge;
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, Strategy};
use rhex_model::params::ToeSliding;
use rhex_model::{Rhex, RhexError, RhexParams};
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::model::Friction;
use selfmanip_core::Data;
use selfmanip_hybrid::EventKind;
use selfmanip_sim::terrain::TerrainSpec;
use selfmanip_sim::RunStatus;

fn cases() -> Vec<LeapConfig> {
    let mut v = Vec::new();
    for s in ["++", "--", "+-", "-+"] {
        for t2 in [-0.1, 0.0, 0.02, 0.1] {
            v.push(LeapConfig {
                strategy: s.parse().unwrap(),
                t2_s: t2,
                ..LeapConfig::default()
            });
        }
    }
    v
}

/// The robot a config leaps with (its pushing pairs).
fn robot(cfg: &LeapConfig) -> (RhexParams, Rhex) {
    let mut p = leap_params();
    p.pairs = cfg.pairs.unwrap_or(cfg.strategy.chapter3_pairs()).to_vec();
    (p.clone(), Rhex::new(p).unwrap())
}

#[test]
fn energy_balances_and_impacts_never_add_energy() {
    let p = leap_params();
    let mut checked = 0;
    let mut dissipated = 0.0;
    for cfg in cases() {
        let r = simulate_leap(&p, &cfg).unwrap();
        for e in &r.execution.events {
            if e.kind == EventKind::Touchdown {
                assert!(e.kinetic_after <= e.kinetic_before + 1e-9, "{e:?}");
            } else if e.kind != EventKind::Apex {
                // liftoff, slip and stick remove constraints or keep the velocity
                assert!((e.kinetic_after - e.kinetic_before).abs() < 1e-9, "{e:?}");
            }
        }
        let rep = r.energy_report().unwrap();
        // the sliding toes' kinetic friction only dissipates
        let w_fr = rep.friction_work_j;
        assert!(w_fr <= 1e-9, "friction work {w_fr}");
        dissipated -= w_fr;
        let scale = rep.joint_work_j.abs() + rep.final_j.abs() + 1.0;
        // the engine's balance counts it: E₁ − E₀ = W + W_fr − L
        let residual = rep.residual_j();
        assert!(
            residual.abs() < 1e-6 * scale,
            "{} t2={}: {rep:?} friction {w_fr} residual {residual}",
            cfg.strategy,
            cfg.t2_s,
        );
        if r.flew {
            // a leap gains energy only from its motors
            assert!(rep.final_j > rep.initial_j, "{rep:?}");
            assert!(rep.impact_loss_j >= -1e-9, "{rep:?}");
            checked += 1;
        }
    }
    assert!(checked >= 8, "only {checked} leaps reached flight");
    // the toes do slip and rub in these leaps: the friction term is not idle
    assert!(dissipated > 1.0, "friction dissipated only {dissipated} J");
}

#[test]
fn events_sit_on_their_guards() {
    let p = leap_params();
    for cfg in cases() {
        let (_, rhex) = robot(&cfg);
        let model = &rhex.model;
        let r = simulate_leap(&p, &cfg).unwrap();
        let exec = &r.execution;
        let mut data = Data::new(model);
        let mut y = vec![0.0; 10];
        for (i, e) in exec.events.iter().enumerate() {
            if e.kind == EventKind::Apex {
                continue;
            }
            // state just before the event: end of the segment that led to it (on flat ground
            // every segment ends at an event; on a ledge a contact passing onto the next
            // feature also ends one)
            let seg = &exec.segments[i];
            seg.eval(seg.t1, &mut y);
            let (q, qd) = y.split_at(5);
            data.kin.compute(model, q, qd);
            match e.kind {
                EventKind::Touchdown => {
                    for &k in &e.triggered {
                        let gap = contact_geometry(model, &data.kin, &cfg.terrain, k).gap_m;
                        assert!(gap.abs() < 1e-7, "touchdown gap {gap} ({e:?})");
                    }
                    // (5.52): the post-impact velocity satisfies the new constraints
                    let Some(next) = exec.segments.get(i + 1) else {
                        continue;
                    };
                    let mut y1 = vec![0.0; 10];
                    next.eval(next.t0, &mut y1);
                    data.prepare(model, &cfg.terrain, e.mode_after, &y1[..5], &y1[5..])
                        .unwrap();
                    let res = (&data.constraints.a
                        * nalgebra::DVector::from_column_slice(&y1[5..]))
                    .amax();
                    assert!(res < 1e-8, "A q̇⁺ = {res}");
                }
                // |λ_t| = μ U(λ_n) at the slipping contact, in the mode before — checked on a
                // sample 0.1 ms before the slip, so only when that sample lies in the
                // sticking segment that led to it
                EventKind::Slip if seg.t1 - seg.t0 > 2e-4 => {
                    check_on_cone(model, &e.triggered, &r, e.t);
                }
                _ => {}
            }
        }
    }
}

/// Recomputes the flow's forces at a slip event through the trajectory sampler (which
/// replays the controller) and checks the cone margin there.
fn check_on_cone(
    model: &selfmanip_core::Model,
    contacts: &[usize],
    r: &rhex_model::leap::LeapResult,
    t_event: f64,
) {
    // a sample just before the event, in the sticking mode
    let traj = r.trajectory(1e-4).unwrap();
    let i = traj
        .t_s
        .iter()
        .rposition(|&t| t + r.time_offset_s < t_event - 1e-9)
        .unwrap();
    for &k in contacts {
        let Friction::Sticking { mu } = model.contacts[k].friction else {
            panic!("only sticking contacts slip")
        };
        let f = traj.contact_forces_n[i][k].expect("active before the slip");
        // level ground: f = (tangential, normal)
        let margin = mu * (-f[1]) - f[0].abs();
        assert!(
            margin >= -1e-6 * (1.0 + f[1].abs()),
            "inside the cone before slipping: {margin}"
        );
        assert!(
            margin < 0.02 * mu * f[1].abs() + 1.0,
            "close to the cone 0.1 ms before: {margin} ({f:?})"
        );
    }
}

#[test]
fn words_start_sitting_and_end_in_flight() {
    let p = leap_params();
    for cfg in cases() {
        let r = simulate_leap(&p, &cfg).unwrap();
        assert_eq!(r.word.first().map(String::as_str), Some("1010"));
        if r.flew {
            assert_eq!(
                r.word.last().map(String::as_str),
                Some("0000"),
                "{}",
                r.word_string()
            );
            let apex = r.apex.unwrap();
            // apex above the start (body centre rho_b above the ground), moving level
            assert!(apex.z_m > p.rho_b, "{apex:?}");
            assert!(apex.zdot_m_s.abs() < 1e-6);
        }
        // no cell repeats twice in a row, every cell is a 4-character label
        for w in r.word.windows(2) {
            assert_ne!(w[0], w[1]);
        }
        assert!(r
            .word
            .iter()
            .all(|c| c.len() == 4 && c.chars().all(|ch| ch == '0' || ch == '1')));
    }
}

#[test]
fn same_inputs_give_bit_identical_leaps() {
    let p = leap_params();
    let cfg = LeapConfig {
        t2_s: 0.02,
        ..LeapConfig::default()
    };
    let a = simulate_leap(&p, &cfg).unwrap();
    let b = std::thread::spawn(move || simulate_leap(&leap_params(), &cfg).unwrap())
        .join()
        .unwrap();
    assert_eq!(a.execution.q, b.execution.q);
    assert_eq!(a.word, b.word);
    assert_eq!(format!("{:?}", a.apex), format!("{:?}", b.apex));
}

/// A ledge's vertical face is a contact surface: a 30 cm step 30 cm ahead is in the way of
/// the forward (+,+) leap, whose front body end meets the face. Checked against the face's
/// geometry alone: the touchdown is on the plane `x = d` below the top (the contact point's
/// height above it is zero, its normal horizontal), the impact removes energy, and no
/// contact ever penetrates the ground, the top or the face (every contact's distance to the
/// nearest of them stays non-negative along the whole execution).

#[test]
fn a_ledge_face_is_a_contact_surface() {
    let (h, d) = (0.3, 0.3);
    let cfg = at_ledge(h, d);
    let r = simulate_leap(&leap_params(), &cfg).unwrap();
    let (_, rhex) = robot(&cfg);
    let model = &rhex.model;
    let mut kin = selfmanip_core::kinematics::Kinematics::default();
    let nq = r.q0.len();
    let on_face = r
        .execution
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Touchdown)
        .find_map(|e| {
            kin.compute(model, &e.q, &vec![0.0; nq]);
            e.triggered.iter().find_map(|&k| {
                let g = contact_geometry(model, &kin, &cfg.terrain, k);
                (g.plane.normal_into_ground == [1.0, 0.0]).then_some((e, g))
            })
        })
        .expect("a contact touches the face");
    let (e, g) = on_face;
    assert!(
        (g.point.x - d).abs() < 1e-9,
        "on the plane x = d: {}",
        g.point.x
    );
    assert!(
        -g.point.y < h && -g.point.y > 0.0,
        "below the top: z = {}",
        -g.point.y
    );
    assert!(e.kinetic_after <= e.kinetic_before + 1e-12);
    let mut y = vec![0.0; 2 * nq];
    for seg in &r.execution.segments {
        for i in 0..=20 {
            seg.eval(seg.t0 + (seg.t1 - seg.t0) * i as f64 / 20.0, &mut y);
            kin.compute(model, &y[..nq], &y[nq..]);
            for k in 0..model.n_contacts() {
                let gap = contact_geometry(model, &kin, &cfg.terrain, k).gap_m;
                assert!(
                    gap > -1e-6,
                    "contact {k} penetrates by {gap} at t = {}",
                    seg.t0
                );
            }
        }
    }
}

/// A ledge's top edge is a contact feature for a body end (a circle): landing on it, the
/// body end's centre stays one body radius from the edge (the corner's gap is zero, the
/// contact normal turning with it), and it slides over onto the top where its centre passes
/// over the edge — a change of feature, not an event, with the normal continuous there. The
/// leap: (+,+) with the front and rear pairs, the rear motor 0.057 s first, at a 20 cm
/// ledge 45 cm ahead (the landing is sensitive to the leap before it: since the fold guard
/// resolves the rear leg's fold 0.19 s in, the rear body end lands on the edge for t2 in
/// [−0.0585, −0.0565] s; at −0.06 s it now bounces off the edge onto the ledge's corner); it flies nose-up over the edge, its rear body end lands on the edge and
/// slides onto the top, the front one lands after it, and the robot sits level on the top
/// (`z = h + ρ_b`, `φ = 0`). A test of the terrain's features, run on the leap where it was
/// found: frictionless sliding toes (Assumption 5.9) and the swing bounds of then (12 rad/s,
/// 400 rad/s²); no default (+,+) leap at front/rear faces 40–60 cm slides a body end over the
/// edge without an event between.
#[test]
fn a_body_end_landing_on_a_ledge_edge_slides_over_it_onto_the_top() {
    let (h, d) = (0.2, 0.45);
    let cfg = LeapConfig {
        t2_s: -0.057,
        pairs: Some([rhex_model::LegPair::Front, rhex_model::LegPair::Rear]),
        swing_speed_rad_s: Some(12.0),
        swing_accel_rad_s2: Some(400.0),
        ..at_ledge(h, d)
    };
    let params = RhexParams {
        toe_sliding: ToeSliding::Frictionless,
        ..leap_params()
    };
    let r = simulate_leap(&params, &cfg).unwrap();
    assert!(r.flew, "{}", r.word_string());
    let (p, rhex) = robot(&cfg);
    let model = &rhex.model;
    let rear = model
        .contacts
        .iter()
        .position(|c| c.name == "rear_body")
        .unwrap();
    let nq = model.nq();
    let mut kin = selfmanip_core::kinematics::Kinematics::default();
    let mut y = vec![0.0; 2 * nq];
    let mut geometry_at = |seg: &selfmanip_hybrid::Segment, t: f64| {
        seg.eval(t, &mut y);
        kin.compute(model, &y[..nq], &y[nq..]);
        (contact_geometry(model, &kin, &cfg.terrain, rear), y.clone())
    };
    let segs = &r.execution.segments;
    let on_edge: Vec<usize> = (0..segs.len())
        .filter(|&i| {
            segs[i].mode.contains(rear)
                && geometry_at(&segs[i], 0.5 * (segs[i].t0 + segs[i].t1))
                    .0
                    .on_corner
        })
        .collect();
    assert_eq!(on_edge.len(), 1, "one stretch on the edge");
    let (i, seg) = (on_edge[0], &segs[on_edge[0]]);
    for k in 0..=20 {
        let t = seg.t0 + (seg.t1 - seg.t0) * k as f64 / 20.0;
        let (g, y) = geometry_at(seg, t);
        let (x, z, phi) = (y[nq - 3], y[nq - 2], y[nq - 1]);
        // the rear body centre (world, z down) at −ℓ₂ along the body axis
        let c = nalgebra::Vector2::new(x - p.l2 * phi.cos(), z + p.l2 * phi.sin());
        let from_edge = (c - nalgebra::Vector2::new(d, -h)).norm();
        assert!((from_edge - p.rho_b).abs() < 1e-8, "{from_edge} at {t}");
        assert!(g.gap_m.abs() < 1e-8);
    }
    // the next stretch is on the top, in the same mode, with no event between
    let next = &segs[i + 1];
    assert_eq!(next.mode, seg.mode);
    assert!(r.execution.events.iter().all(|e| e.t != seg.t1));
    let (after, y) = geometry_at(next, next.t0);
    let (before, _) = geometry_at(seg, seg.t1);
    assert!(!after.on_corner && after.plane.normal_into_ground == [0.0, 1.0]);
    assert!((after.plane.normal() - before.plane.normal()).norm() < 1e-6);
    let phi = y[nq - 1];
    assert!(
        (y[nq - 3] - p.l2 * phi.cos() - d).abs() < 1e-6,
        "centre over the edge"
    );
    // sitting level on the top
    let q = &r.execution.q;
    assert_eq!(r.events.last().unwrap().mode_after, "1010");
    assert!((-q[nq - 2] - (h + p.rho_b)).abs() < 1e-8 && q[nq - 1].abs() < 1e-8);
}

/// The concave corner at the foot of a ledge's face is where one site would touch two
/// surfaces: a body end sliding along the ground into it ends the leap as `TerrainEdge`,
/// there — its centre one body radius above the ground and one from the face. The leap:
/// (+,+) on RHex, the rear motor 0.16 s first, at a 20 cm ledge 40 cm ahead; the rear push
/// lifts the front end, the robot hops and lands on its front body end, which slides into
/// the foot of the face.
#[test]
fn a_body_end_sliding_into_the_foot_of_a_ledge_is_reported_not_carried_on() {
    let (h, d) = (0.2, 0.4);
    let cfg = LeapConfig {
        t2_s: -0.16,
        ..at_ledge(h, d)
    };
    let r = simulate_leap(&leap_params(), &cfg).unwrap();
    assert_eq!(
        r.status,
        RunStatus::TerrainDiscontinuity,
        "{}",
        r.word_string()
    );
    let selfmanip_hybrid::Termination::TerrainDiscontinuity { contact, .. } =
        r.execution.termination
    else {
        panic!("{:?}", r.execution.termination)
    };
    let (p, rhex) = robot(&cfg);
    assert_eq!(rhex.model.contacts[contact].name, "front_body");
    // the front body centre: x + ℓ₁ cos φ, height z + ℓ₁ sin φ (z, φ up / nose-up)
    let q = &r.execution.q;
    let (x, z, phi) = (q[2], -q[3], q[4]);
    let (cx, cz) = (x + p.l1 * phi.cos(), z + p.l1 * phi.sin());
    assert!(
        (cx + p.rho_b - d).abs() < 1e-6,
        "touching the face: {}",
        cx + p.rho_b
    );
    assert!((cz - p.rho_b).abs() < 1e-6, "on the ground: {cz}");
}

#[test]
fn bad_input_is_a_typed_error_naming_the_field() {
    let p = leap_params();
    let field = |r: Result<_, RhexError>| match r {
        Err(e) => e
            .field()
            .unwrap_or_else(|| panic!("untyped: {e}"))
            .to_string(),
        Ok(_) => panic!("accepted"),
    };
    let base = LeapConfig::default();
    let with = |f: &dyn Fn(&mut LeapConfig)| {
        let mut c = base.clone();
        f(&mut c);
        field(simulate_leap(&p, &c).map(|_| ()))
    };
    assert_eq!(with(&|c| c.t2_s = f64::NAN), "t2_s");
    assert_eq!(with(&|c| c.delta_t_s = -0.1), "delta_t_s");
    assert_eq!(with(&|c| c.t2_s = 5.0), "t2_s");
    assert_eq!(
        with(&|c| c.actuator = rhex_model::leap::X_RHEX_LEG.at_gear_ratio(-3.0)),
        "gear_ratio"
    );
    assert_eq!(
        with(&|c| c.terrain = TerrainSpec::Ledge {
            height_m: f64::INFINITY,
            distance_m: 0.5
        }),
        "terrain.height_m"
    );
    // the face within reach of the start: the front body end reaches ℓ₁ + ρ_b = 0.255 m,
    // the rear legs (hip at −ℓ₂) ℓ₂ + ρ₂ = 0.375 m behind
    for d in [0.25, -0.37] {
        assert_eq!(
            with(&|c| c.terrain = TerrainSpec::Ledge {
                height_m: 0.2,
                distance_m: d
            }),
            "terrain.distance_m"
        );
    }
    assert_eq!(
        with(&|c| c.pairs = Some([rhex_model::LegPair::Rear, rhex_model::LegPair::Rear])),
        "pairs"
    );
    let mut bad = leap_params();
    bad.m_b = f64::NAN;
    assert_eq!(field(simulate_leap(&bad, &base).map(|_| ())), "m_b");
    assert!(matches!(
        "+x".parse::<Strategy>(),
        Err(RhexError::Unreadable { ref field, .. }) if field == "strategy"
    ));
    assert!("+-+".parse::<Strategy>().is_err());
}

#[test]
fn config_round_trips_through_json() {
    let cfg = LeapConfig {
        strategy: "-+".parse().unwrap(),
        t2_s: -0.05,
        terrain: TerrainSpec::Ledge {
            height_m: 0.2,
            distance_m: 0.6,
        },
        ..LeapConfig::default()
    };
    let text = serde_json::to_string(&cfg).unwrap();
    assert!(text.contains("\"-+\""));
    let back: LeapConfig = serde_json::from_str(&text).unwrap();
    assert_eq!(back, cfg);
    assert!(serde_json::from_str::<LeapConfig>(r#"{"t2": 0.1}"#).is_err());
}

/// Fig. 5.7 (section 5.1.4): in the chapter-5 leap (middle and rear legs, 20 A, t2 = 0.01 s)
/// without a pseudo-impulse, the rear leg's touchdown impulsively breaks the front (middle)
/// leg's contact (0110 → 0001); the front leg, its motor still on, comes back to the ground —
/// the start of the thesis's "cyclic oscillation". Its touchdown pulls on the rear leg by
/// less than the rear leg's force holds over the run's resolution
/// (`HybridOptions::rest_time_s`), so the rear leg is at rest and stays (0001 → 0101,
/// `selfmanip_hybrid::complementarity`), where the thesis's rigid rule released it again. With δt = 0.03 s the front leg stays down through the
/// rear touchdown (0110 → 0101) and touches down once. As in the thesis the motors stay on
/// until flight (open loop): a leg lifted off keeps turning in its push direction.
#[test]
fn pseudo_impulse_removes_the_front_leg_chatter_of_fig_5_7() {
    let p = leap_params();
    let run = |delta_t_s: f64| {
        simulate_leap(
            &p,
            &LeapConfig {
                t2_s: 0.01,
                delta_t_s,
                keep_pushing_after_liftoff: true,
                ..LeapConfig::default()
            },
        )
        .unwrap()
    };
    let touchdowns = |r: &rhex_model::leap::LeapResult| -> Vec<(String, String, String)> {
        r.events
            .iter()
            .filter(|e| e.kind == "touchdown")
            .map(|e| {
                (
                    e.contacts.join(","),
                    e.mode_before.replace('s', "1"),
                    e.mode_after.replace('s', "1"),
                )
            })
            .collect()
    };
    let without = run(0.0);
    assert!(without.flew, "{}", without.word_string());
    let td = touchdowns(&without);
    let td: Vec<(&str, &str, &str)> = td
        .iter()
        .map(|(c, a, b)| (c.as_str(), a.as_str(), b.as_str()))
        .collect();
    // the rear leg's touchdown breaks the front leg's contact; the front leg's comes back
    assert_eq!(
        td[..3],
        [
            ("middle_leg", "1010", "0110"),
            ("rear_leg", "0110", "0001"),
            ("middle_leg", "0001", "0101"),
        ],
        "{td:?}"
    );
    let with = run(0.03);
    assert!(with.flew);
    let td = touchdowns(&with);
    assert_eq!(
        td.iter().filter(|t| t.0 == "middle_leg").count(),
        1,
        "{td:?}"
    );
    let rear = td.iter().find(|t| t.0 == "rear_leg").unwrap();
    assert_eq!((rear.1.as_str(), rear.2.as_str()), ("0110", "0101"));
}

/// Landings after the apex: the parked legs meet the ground again. A retracting leg's servo
/// keeps following its motion in the air while the leg is on the ground, so a leg that the
/// falling body drives into the ground pushes back and stays down; and the pseudo-impulse
/// sees the servo at the velocity the impact leaves (its damping resists the jump, see
/// `tests/actuated_impact.rs`). With the leg limp on the ground, or the servo taken at
/// q̇⁻, the leg was released at once, driven back into the ground by its motion in the air,
/// and touched down again at the same instant: each of these landings ended `zeno`. Now
/// they run to the final time, some landing touchdown of a leg keeps the leg down, and no
/// contact touches down twice within a microsecond.
///
/// This regression runs where it was found: frictionless sliding toes (Assumption 5.9) and
/// the swing bounds the leaps had then (12 rad/s, 400 rad/s²). With the default Coulomb toes
/// and motor-set swing some of these landings end `zeno` again (a parked leg re-touching as
/// the body lands on its front end); see `docs/leap-model.md`.
#[test]
fn parked_legs_that_meet_the_ground_stay_on_it() {
    let p = RhexParams {
        toe_sliding: ToeSliding::Frictionless,
        ..leap_params()
    };
    let mut kept = 0;
    for t2 in [0.08, 0.10, 0.12, 0.14] {
        let cfg = LeapConfig {
            t2_s: t2,
            stop_at_apex: false,
            t_final_s: 1.2,
            swing_speed_rad_s: Some(12.0),
            swing_accel_rad_s2: Some(400.0),
            ..LeapConfig::default()
        };
        let r = simulate_leap(&p, &cfg).unwrap();
        assert!(r.flew, "t2 {t2}: {}", r.word_string());
        let takeoff = r
            .events
            .iter()
            .position(|e| e.mode_after == "0000")
            .expect("a flight");
        let touchdowns: Vec<_> = r.events[takeoff..]
            .iter()
            .filter(|e| e.kind == "touchdown")
            .collect();
        for pair in touchdowns.windows(2) {
            assert!(
                pair[1].t_s - pair[0].t_s > 1e-6 || pair[0].contacts != pair[1].contacts,
                "t2 {t2}: {:?} touched down twice at once",
                pair[0].contacts
            );
        }
        // cells read (front body, middle leg, rear body, rear leg)
        kept += touchdowns
            .iter()
            .filter(|e| {
                e.contacts.iter().any(|c| {
                    let slot = match c.as_str() {
                        "middle_leg" => 1,
                        "rear_leg" => 3,
                        _ => return false,
                    };
                    e.mode_after.as_bytes()[slot] != b'0'
                })
            })
            .count();
    }
    assert!(kept > 0, "no landing touchdown kept a leg down");
}

/// Fig. 5.1 with the figure's own settings (`rhex_model::figures::fig5_1_ledge_20cm`): the
/// leap ends sitting level on the 20 cm ledge — both body ends on its top, so the body
/// centre is at `h + ρ_b` with zero pitch (the closed form of resting on a level plane), the
/// whole body past the edge — then slides on the frictionless top (Assumption C.3) with its
/// kinetic energy conserved.
#[test]
fn fig5_1_leap_lands_on_the_20_cm_ledge() {
    let p = leap_params();
    let cfg = rhex_model::figures::fig5_1_ledge_20cm();
    let TerrainSpec::Ledge {
        height_m,
        distance_m,
    } = cfg.terrain
    else {
        panic!("a ledge")
    };
    let r = simulate_leap(&p, &cfg).unwrap();
    assert!(r.flew, "{}", r.word_string());
    let last = r.events.last().unwrap();
    assert_eq!(last.mode_after, "1010");
    let (q, qd) = (&r.execution.q, &r.execution.qd);
    assert!((-q[3] - (height_m + p.rho_b)).abs() < 1e-9, "z = {}", -q[3]);
    assert!(q[4].abs() < 1e-9, "pitch {}", q[4]);
    assert!(
        q[2] - p.l2 - p.rho_b > distance_m,
        "rear end over the edge: x = {}",
        q[2]
    );
    // sliding on, level, with the legs parked in the air: T = ½ m_b ẋ² is what the last impact left
    let e = r.execution.events.last().unwrap();
    let t_end = 0.5 * p.m_b * qd[2] * qd[2];
    assert!(qd[3].abs() < 1e-9 && qd[4].abs() < 1e-9);
    assert!(
        (t_end - e.kinetic_after).abs() < 1e-6 * e.kinetic_after,
        "{t_end} vs {}",
        e.kinetic_after
    );
}

/// The (+,−) leap of a near-vertical, near-level kind — it rises more than it travels
/// (section 3.3: "more or less vertically") with its pitch under 10° (section 3.4.1:
/// "near-level") — in which the toes slide with their force on the friction cone's edge
/// while the legs push against each other, and whose rise the motors paid for:
/// `m g Δz ≤ W + W_fr − L` (the rest is kinetic energy at apex). `sliding`: whether a toe
/// sliding at speed must carry `|F_t| = μ_k |F_n|`, with `μ_k` of `p.toe_sliding`.
fn assert_vertical_leap_on_sliding_toes(p: &RhexParams, cfg: &LeapConfig) -> f64 {
    let r = simulate_leap(p, cfg).unwrap();
    assert!(r.flew, "{}", r.word_string());
    let apex = r.apex.unwrap();
    let rise = apex.z_m - p.rho_b;
    assert!(
        rise > 0.0 && apex.x_m.abs() < rise,
        "x {} for rise {rise}",
        apex.x_m
    );
    assert!(
        apex.phi_rad.abs() < 10f64.to_radians(),
        "pitch {}",
        apex.phi_rad
    );
    let traj = r.trajectory(1e-3).unwrap();
    let mut sliding = 0;
    for (k, mode) in traj.mode.iter().enumerate() {
        for (c, ch) in mode.chars().enumerate() {
            let contact = match c {
                1 => "front_leg",
                3 => "rear_leg",
                _ => continue,
            };
            if ch != 's' {
                continue;
            }
            let i = traj.contacts.iter().position(|n| n == contact).unwrap();
            let f = traj.contact_forces_n[k][i].unwrap();
            let mu_k = match p.toe_sliding {
                ToeSliding::Coulomb => if contact == "front_leg" {
                    p.mu_front
                } else {
                    p.mu_rear
                }
                .unwrap(),
                ToeSliding::Frictionless => 0.0,
            };
            if (f[0].abs() - mu_k * f[1].abs()).abs() <= 1e-6 * f[1].abs() {
                sliding += 1;
            }
        }
    }
    assert!(sliding > 10, "{}", r.word_string());
    let rep = r.energy_report().unwrap();
    let w_fr = rep.friction_work_j;
    match p.toe_sliding {
        ToeSliding::Coulomb => assert!(w_fr < 0.0),
        ToeSliding::Frictionless => assert_eq!(w_fr, 0.0),
    }
    assert!(p.m_b * p.g * rise <= rep.joint_work_j + w_fr - rep.impact_loss_j + 1e-6);
    apex.z_m
}

/// Fig. 5.8 with the figure's own toe law (`rhex_model::figures::fig5_8_vertical_leap`:
/// a slipping toe slides without friction, section 5.1.5): a near-vertical, near-level leap
/// whose toes slide carrying no tangential force, rising to about the figure's 37 cm (the
/// text's "about": within 25 %), higher than the same leap with the default's Coulomb toes,
/// which rub (`docs/fidelity.md`).
#[test]
fn fig5_8_vertical_leap_slides_its_toes_freely_to_about_37_cm() {
    let (p, cfg) = rhex_model::figures::fig5_8_vertical_leap();
    let z = assert_vertical_leap_on_sliding_toes(&p, &cfg);
    assert!((z - 0.37).abs() < 0.25 * 0.37, "apex {z} m");
    // the same leap with Coulomb toes dissipates as they rub and rises less
    let coulomb = simulate_leap(&leap_params(), &cfg).unwrap();
    assert!(coulomb.apex.unwrap().z_m < z);
}

/// The vertical leap on the default path (Coulomb toes, `μ_k = μ`): the rear motor started
/// 0.02 s before the front one, among the highest near-level apexes of the default (+,−)
/// sweep (`docs/fidelity.md`). It rises less than Fig. 5.8's frictionless slide, near the
/// 23 cm the robot reached (section 3.4.1).
#[test]
fn vertical_leap_with_coulomb_toes_slides_on_the_cone_edge() {
    let cfg = LeapConfig {
        t2_s: -0.02,
        ..rhex_model::figures::fig5_8_vertical_leap().1
    };
    assert_vertical_leap_on_sliding_toes(&leap_params(), &cfg);
}

/// Mirror symmetry, a second route to every leap: reflecting the planar robot front-to-back
/// (`x → −x`, `φ → −φ`, front ↔ rear) maps the strategy `(+,+)` with the rear leg starting
/// `τ` after the front one onto `(−,−)` with it starting `τ` *before* (`t2 = −τ`), on a robot
/// that is its own mirror image: stick legs (the half circle is not), equal hip distances,
/// leg lengths and toe friction. The two leaps are then one execution seen in a mirror: the
/// same clock, apex height and word with `FB FL ↔ RB RL` swapped, the opposite displacement
/// and pitch. Nothing in the engine knows about the mirror (contact order, row order, the
/// enumeration over contact subsets all differ), so agreement tests the whole hybrid
/// pipeline and the leap controller's sign handling at once.
///
/// With frictionless sliding toes (Assumption 5.9) every event is compared. With Coulomb
/// toes (the default) a toe that comes to rest under kinetic friction arrives with its
/// sticking force on the cone's edge, so whether the engine's slip→stick event keeps it
/// stuck or lets it slip again at the same instant is decided by round-off — the flow after
/// is the same (the force is the edge force either way); the outcome is compared there.
#[test]
fn mirrored_strategies_give_mirrored_leaps() {
    let base = {
        let mut p = leap_params();
        p.leg_shape = rhex_model::LegShape::Stick;
        p.l2 = p.l1;
        p.rho2 = p.rho1;
        p.mu_rear = p.mu_front;
        p
    };
    let pairs = Some([rhex_model::LegPair::Front, rhex_model::LegPair::Rear]);
    let mirror_cell = |c: &str| {
        let b: Vec<char> = c.chars().collect();
        [b[2], b[3], b[0], b[1]].iter().collect::<String>()
    };
    for sliding in [ToeSliding::Frictionless, ToeSliding::Coulomb] {
        let p = RhexParams {
            toe_sliding: sliding,
            ..base.clone()
        };
        let mut compared = 0;
        for tau in [-0.1, -0.03, 0.0, 0.02, 0.1] {
            let leap = |s: &str, t2: f64| {
                let cfg = LeapConfig {
                    strategy: s.parse().unwrap(),
                    t2_s: t2,
                    pairs,
                    ..LeapConfig::default()
                };
                simulate_leap(&p, &cfg).unwrap()
            };
            let (a, b) = (leap("++", tau), leap("--", -tau));
            assert_eq!(a.status, b.status, "{sliding:?} τ = {tau}");
            let mirrored: Vec<String> = a.word.iter().map(|c| mirror_cell(c)).collect();
            assert_eq!(mirrored, b.word, "{sliding:?} τ = {tau}");
            let (ea, eb) = (&a.execution, &b.execution);
            if sliding == ToeSliding::Frictionless {
                assert_eq!(ea.events.len(), eb.events.len(), "τ = {tau}");
                for (x, y) in ea.events.iter().zip(&eb.events) {
                    assert!((x.t - y.t).abs() < 1e-8, "τ = {tau}: {} vs {}", x.t, y.t);
                }
            }
            assert!((ea.t - eb.t).abs() < 1e-8, "{sliding:?} τ = {tau}");
            let (qa, qb) = (&ea.q, &eb.q);
            // q = [θ_front, θ_rear, x, z, φ]
            let expect = [-qa[1], -qa[0], -qa[2], qa[3], -qa[4]];
            for (i, (e, g)) in expect.iter().zip(qb).enumerate() {
                assert!(
                    (e - g).abs() < 1e-6,
                    "{sliding:?} τ = {tau}, q[{i}]: {e} vs {g}"
                );
            }
            if let (Some(x), Some(y)) = (a.apex, b.apex) {
                assert!((x.z_m - y.z_m).abs() < 1e-6 && (x.x_m + y.x_m).abs() < 1e-6);
                assert!((x.phi_rad + y.phi_rad).abs() < 1e-6);
                compared += 1;
            }
        }
        assert!(
            compared >= 3,
            "{sliding:?}: only {compared} leaps reached an apex"
        );
    }
}

/// No event fires on round-off: every liftoff and slip changes the contact mode, and a stick
/// that does not (the cone refuses to hold the contact whose sliding velocity reversed) comes
/// long after the previous event, not right after a reset. A liftoff whose force root was
/// located so exactly that the contact could stay with zero force, or a stick right after a
/// slip whose sliding velocity is round-off, would leave the mode as it was and fire again
/// moments later. A touchdown may keep the mode (the impact can decide that the touching
/// contact separates), but not fire again for the same contact at the same instant (a
/// released massless leg whose motion keeps it in the ground). Checked over chapter 3's
/// sweep (all four strategies, t2 from −0.2 to 0.2 s).
#[test]
fn no_event_fires_on_round_off() {
    let p = leap_params();
    let mut idle = Vec::new();
    for s in ["++", "--", "+-", "-+"] {
        for k in 0..41 {
            let cfg = LeapConfig {
                strategy: s.parse().unwrap(),
                t2_s: -0.2 + 0.01 * k as f64,
                ..LeapConfig::default()
            };
            let r = simulate_leap(&p, &cfg).unwrap();
            let (_, rhex) = robot(&cfg);
            for (i, e) in r.execution.events.iter().enumerate() {
                let since = i
                    .checked_sub(1)
                    .map_or(f64::INFINITY, |j| e.t - r.execution.events[j].t);
                // a toe held at rest by the core's friction (|v_t| within its rest band): the
                // engine's slip→stick guard sees only the drift of its sliding velocity
                let held = |e: &selfmanip_hybrid::Event| {
                    let mut kin = selfmanip_core::kinematics::Kinematics::default();
                    kin.compute(&rhex.model, &e.q, &e.qd_after);
                    e.triggered.iter().all(|&k| {
                        selfmanip_hybrid::flow::sliding_velocity(&rhex.model, &kin, &cfg.terrain, k)
                            .abs()
                            <= selfmanip_core::friction::SLIDING_SPEED_EPS_M_S
                    })
                };
                let round_off = match e.kind {
                    EventKind::Liftoff | EventKind::Slip => true,
                    EventKind::Stick => since < 1e-6 && !held(e),
                    // a released massless leg re-touching at the same instant
                    EventKind::Touchdown => {
                        since < 1e-9 && r.execution.events[i - 1].triggered == e.triggered
                    }
                    _ => false,
                };
                if round_off && e.mode_before == e.mode_after {
                    idle.push(format!("{s} t2={:.2} t={:.6} {:?}", cfg.t2_s, e.t, e.kind));
                }
            }
        }
    }
    assert!(
        idle.is_empty(),
        "{} events keep the mode: {idle:#?}",
        idle.len()
    );
}
