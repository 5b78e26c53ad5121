//! The four leap strategies of thesis section 3.2.1 as behaviour files
//! (`data/behaviours/leap_{pp,pm,mp,mm}.toml`, the schema of `docs/behaviours.md`), and a
//! leap as a scenario of `selfmanip-sim`: the same robot, terrain, start, options and
//! behaviour as [`crate::leap::simulate_leap`]'s controller, run by the behaviour
//! interpreter. `tests/leap_behaviours.rs` checks that both give the same executions.
//!
//! The [`LeapConfig`] fields map onto the behaviour by name: `t2_s` → `t2`, the geared
//! motor → `gear_ratio`, `current_limit_a`, `motors_per_leg` (the saturated torque replaces
//! the actuator `leg`), the legs' inertia about their hips → `leg_inertia_kg_m2`,
//! `toe_stub_rad` → each push's `reverse_beyond_rad`, `keep_pushing_after_liftoff` → the
//! retract phase waits for `takeoff` only; the pushing pairs name the two programs' joints.
//! The files swing a leg in the air as its motor does ([`crate::leap::leg_swing`]: the
//! no-load output speed `leg.no_load_speed_rad_s`, the stall torque over the rotors'
//! reflected inertia `leg.reflected_inertia_kg_m2` plus the leg's own); with the saturated
//! torque, or explicit `swing_speed_rad_s` / `swing_accel_rad_s2`, the swing motions get
//! [`crate::leap::leg_swing`]'s numbers. The toes' friction (Coulomb sliding or not,
//! `RhexParams::toe_sliding`) is the robot's, in its description. `t2_s` is the motor-start
//! offset ([`crate::leap::T2Reference::MotorStart`]); for a touchdown-timed leap pass the
//! motor start its search found (`LeapResult::motor_t2_s`) with `MotorStart`.
use crate::leap::{LeapConfig, LegActuator, Push, Strategy};
use crate::params::RhexParams;
use crate::{Rhex, RhexError};
use selfmanip_sim::behaviour::{ActuatorSpec, Behaviour, Motion, Torque, Trigger};
use selfmanip_sim::expr::Scalar;
use selfmanip_sim::outcome::WordOptions;
use selfmanip_sim::{InitialState, Scenario, SimOptions};

/// The shipped behaviour files, by strategy `(+,+)`, `(+,−)`, `(−,+)`, `(−,−)`.
pub const LEAP_BEHAVIOURS: [(&str, &str); 4] = [
    ("++", include_str!("../data/behaviours/leap_pp.toml")),
    ("+-", include_str!("../data/behaviours/leap_pm.toml")),
    ("-+", include_str!("../data/behaviours/leap_mp.toml")),
    ("--", include_str!("../data/behaviours/leap_mm.toml")),
];

/// The shipped behaviour of a strategy (each file parsed once per process).
pub fn leap_behaviour(strategy: Strategy) -> Behaviour {
    static PARSED: [std::sync::OnceLock<Behaviour>; 4] = [const { std::sync::OnceLock::new() }; 4];
    let key = strategy.to_string();
    let i = LEAP_BEHAVIOURS
        .iter()
        .position(|(k, _)| *k == key)
        .expect("four strategies, four files");
    PARSED[i]
        .get_or_init(|| {
            Behaviour::from_toml_str(LEAP_BEHAVIOURS[i].1).expect("the shipped behaviours parse")
        })
        .clone()
}

/// A leap as a scenario.
#[derive(Debug, Clone)]
pub struct LeapScenario {
    pub scenario: Scenario,
    /// The robot with the leap's two pushing pairs.
    pub rhex: Rhex,
    /// Subtract from execution times to get times relative to the front leg's start.
    pub time_offset_s: f64,
}

fn num(x: f64) -> Scalar {
    Scalar::Number(x)
}

/// The leap of `(params, cfg)` from the start configuration `q0` (sitting on both body
/// ends, legs raised — [`crate::leap::LeapResult::q0`]) as a scenario.
pub fn leap_scenario(
    params: &RhexParams,
    cfg: &LeapConfig,
    q0: &[f64],
) -> Result<LeapScenario, RhexError> {
    cfg.validate()?;
    if cfg.t2_reference != crate::leap::T2Reference::MotorStart {
        return Err(RhexError::Params {
            field: "t2_reference".into(),
            reason: "a leap scenario times its legs by motor start: pass the motor start of \
                     the touchdown-timed leap (`LeapResult::motor_t2_s`) as `t2_s`"
                .into(),
        });
    }
    let pairs = cfg.pairs.unwrap_or(cfg.strategy.chapter3_pairs());
    if pairs[0] == pairs[1] {
        return Err(RhexError::Params {
            field: "pairs".into(),
            reason: "a leap strategy drives two different leg pairs".into(),
        });
    }
    let rhex = Rhex::new(crate::leap::leap_robot_params(params, cfg, pairs)?)?;
    let mut b = leap_behaviour(cfg.strategy);
    // the front-most pushing pair drives joint 0, the rear-most joint 1
    for (prog, pair) in b.joints.iter_mut().zip(rhex.params.ordered_pairs()) {
        prog.joint = pair.name().into();
    }
    let p = &mut b.parameters;
    p.insert("t2".into(), num(cfg.t2_s));
    p.insert(
        "leg_inertia_kg_m2".into(),
        num(crate::leap::leg_inertia_about_hip(&rhex.params)),
    );
    let sign = |s: Push| num(s.sign());
    p.insert("s_front".into(), sign(cfg.strategy.front));
    p.insert("s_rear".into(), sign(cfg.strategy.rear));
    match cfg.actuator {
        LegActuator::SaturatedTorque => {
            b.actuators.insert(
                "leg".into(),
                ActuatorSpec::Saturated {
                    max_torque_n_m: num(rhex.params.tau_s),
                },
            );
        }
        LegActuator::GearedMotor {
            gear_ratio,
            current_limit_a,
            motors_per_leg,
        } => {
            p.insert("gear_ratio".into(), num(gear_ratio));
            p.insert("current_limit_a".into(), num(current_limit_a));
            p.insert("motors_per_leg".into(), num(f64::from(motors_per_leg)));
        }
    }
    // the files swing the legs as their motors do (`leg.no_load_speed_rad_s`, the stall
    // torque over the reflected rotor inertia); a saturated torque has no motor data, and
    // explicit values win: then the swing is set as numbers, those of `leg_swing`
    let motor_set = matches!(cfg.actuator, LegActuator::GearedMotor { .. })
        && cfg.swing_speed_rad_s.is_none()
        && cfg.swing_accel_rad_s2.is_none();
    let swing = if motor_set {
        None
    } else {
        Some(crate::leap::leg_swing(params, cfg)?)
    };
    for prog in &mut b.joints {
        for phase in &mut prog.phases {
            match (phase.motion.as_mut(), swing) {
                (
                    Some(Motion::Swing {
                        speed_rad_s,
                        accel_rad_s2,
                        ..
                    }),
                    Some((speed, accel)),
                ) => {
                    *speed_rad_s = num(speed);
                    *accel_rad_s2 = num(accel);
                }
                (Some(Motion::Park { accel_rad_s2, .. }), Some((_, accel))) => {
                    *accel_rad_s2 = num(accel);
                }
                _ => {}
            }
            match (phase.name.as_str(), &mut phase.torque) {
                (
                    "push",
                    Torque::Motor {
                        reverse_beyond_rad, ..
                    },
                ) => *reverse_beyond_rad = cfg.toe_stub_rad.map(num),
                ("retract", _) if cfg.keep_pushing_after_liftoff => {
                    phase.start = Some(Trigger::event("takeoff"));
                }
                _ => {}
            }
        }
    }
    let model = &rhex.model;
    let offset = cfg.t2_s.min(0.0);
    let labels = (0..rhex.label_len())
        .map(|i| model.contacts[rhex.site(i)].name.clone())
        .collect();
    let scenario = Scenario {
        robot: rhex.params.description(),
        terrain: cfg.terrain,
        initial: InitialState {
            q: q0.to_vec(),
            qd: None,
            contacts: vec!["front_body".into(), "rear_body".into()],
            solve: Vec::new(),
        },
        behaviour: b,
        options: SimOptions {
            t_final_s: cfg.t_final_s - offset,
            stop_at_apex: cfg.stop_at_apex,
            event_tol_s: cfg.event_tol_s,
            delta_t_s: cfg.delta_t_s,
            rtol: cfg.rtol,
            atol: None,
            zeno_window_s: cfg.zeno_window_s,
            zeno_max_events: cfg.zeno_max_events,
            labels: Some(labels),
            word: WordOptions {
                min_duration_s: 1e3 * cfg.event_tol_s,
                sliding_as_contact: true,
            },
            ..SimOptions::default()
        },
    };
    Ok(LeapScenario {
        scenario,
        rhex,
        time_offset_s: -offset,
    })
}
