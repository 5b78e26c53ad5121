//! The four leap strategies of thesis section 3.2.1 as behaviour files
//! (`data/behaviours/leap_{pp,pm,mp,mm}.toml`, the schema of `docs/behaviours.md`), and a
//! leap as a scenario of `selfmanip-sim` run by the behaviour interpreter: what
//! [`crate::leap::simulate_leap`] runs ([`crate::leap::LeapPreset`]).
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
    let rhex = crate::leap::leap_rhex(params, cfg)?;
    scenario_of(rhex, params, cfg, q0)
}

/// [`leap_scenario`] on the leap's robot `rhex` ([`crate::leap::leap_rhex`]), `cfg` checked.
pub(crate) fn scenario_of(
    rhex: Rhex,
    params: &RhexParams,
    cfg: &LeapConfig,
    q0: &[f64],
) -> Result<LeapScenario, RhexError> {
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
    // a massive leg is a joint like any other in the air too: its servo drives it there (a
    // massless one is a free joint whose motion is prescribed), critically damped for the
    // leg's inertia about its hip with its armature (`servo_damping`)
    let geared = matches!(cfg.actuator, LegActuator::GearedMotor { .. });
    let critical = servo_damping_expr(params, &rhex.params, geared, &mut b);
    for (i, prog) in b.joints.iter_mut().enumerate() {
        let massive = !rhex.model.distal_massless(i);
        for phase in &mut prog.phases {
            if let Torque::Servo {
                only_in_contact,
                kd_n_m_s_per_rad,
                ..
            } = &mut phase.torque
            {
                *only_in_contact = !massive;
                if let Some(kd) = &critical {
                    *kd_n_m_s_per_rad = Scalar::Expr(kd.clone());
                }
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

/// The servo damping of legs with inertia, as a formula of the behaviour's parameters (so
/// that its partials follow the gear ratio and the armature). A leg with inertia `I` about
/// its hip (`I_l + m_l (ρ/2)²` plus its joint's armature, the leg's `M̄_jj`) gets critical
/// damping for the servo's stiffness `k_p = kp_hold · H` (`H` the stall torque):
/// `k_d = 2 √(k_p I) = 2 √(kp_hold I / H) · H`, one double pole at `√(k_p / I)` (217 rad/s
/// for Table 4.2's leg with its rotors at 28:1 and 20 A), the textbook design of a position
/// servo for the inertia it moves. The files' `kd_hold` per N m was chosen for massless
/// legs, whose servo acts only through the contact's statics; on a leg with inertia it is
/// an overdamped servo (`ζ = 2.7` with the rotors) whose fast pole only makes the flow
/// stiff. The armature is the rotors' reflected inertia `n J G²` where it follows the gear
/// ratio (plus the parameter `leg_armature_kg_m2`, 0 there), else the parameter
/// `leg_armature_kg_m2` as set. `None` for massless legs without armature (the file's
/// damping).
/// `user` are the parameters as given, `robot` the leap's (its armature set); `geared`: the
/// actuator is the geared motor (the saturated torque has no rotors to reflect: its
/// armature is a number).
fn servo_damping_expr(
    user: &RhexParams,
    robot: &RhexParams,
    geared: bool,
    b: &mut Behaviour,
) -> Option<String> {
    let armature = robot.leg_armature_kg_m2.unwrap_or(0.0);
    if crate::leap::leg_inertia_about_hip(robot) + armature <= 0.0 {
        return None;
    }
    let armature = if geared && crate::leap::armature_follows_gear(user) {
        b.parameters.insert("leg_armature_kg_m2".into(), num(0.0));
        "(leg.reflected_inertia_kg_m2 + leg_armature_kg_m2)"
    } else {
        b.parameters
            .insert("leg_armature_kg_m2".into(), num(armature));
        "leg_armature_kg_m2"
    };
    Some(format!(
        "2 * sqrt(kp_hold * (leg_inertia_kg_m2 + {armature}) / leg.stall_torque_n_m) \
         * leg.stall_torque_n_m"
    ))
}
