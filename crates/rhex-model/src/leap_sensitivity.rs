//! Sensitivities of RHex leaps to named parameters ([`SENSITIVITY_PARAMETERS`]) and to the
//! start state: the apex, differentiated through every event by the generic named
//! sensitivities ([`selfmanip_sim::sensitivity`]). What is RHex's is which engine parameters
//! stand behind a leap's names (`engine_terms`) and the apex in chapter 3's frame. The leap
//! runs with [`LeapConfig::control_free_joints`] on (bit for bit
//! [`crate::leap::simulate_leap`]'s with it); what each name moves, when a derivative is
//! undefined (then [`LeapSensitivity::ok`] is false, every derivative NaN, with the reason)
//! and why the free legs are step-controlled: `docs/sensitivity.md`, "The RHex leap".
use crate::leap::{LeapConfig, LeapPreset, LeapResult, LegActuator, T2Reference, X_RHEX_LEG};
use crate::params::{LegPair, ToeSliding};
use crate::{RhexError, RhexParams};
use nalgebra::DMatrix;
use selfmanip_core::tangent::BodyParameter;
use selfmanip_hybrid::sensitivity::Parameter;
use selfmanip_sim::named_terms::{armature_terms, contact_friction};
use selfmanip_sim::preset_run::ApexSensitivity;
pub use selfmanip_sim::sensitivity::EventSaltation;
use selfmanip_sim::sensitivity_preset::start_directions;
use selfmanip_sim::staggered::d_first_start_d_lag;

/// The apex columns a leap reports, in order (every sweep's column names).
pub use selfmanip_sim::outcome::APEX_COLUMNS;

/// The parameter names [`leap_with_sensitivity`] knows.
pub const SENSITIVITY_PARAMETERS: [&str; 14] = [
    "t2",
    "t2_s",
    "gear_ratio",
    "m_b",
    "I_b",
    "leg_armature_kg_m2",
    "gearbox_efficiency",
    "battery_resistance_ohm",
    "mu_front",
    "mu_middle",
    "mu_rear",
    "delta_t_s",
    "leg_stiffness",
    "leg_damping",
];

/// A leap with the derivatives of its apex (the generic [`ApexSensitivity`]: times from the
/// front leg's start, the events of [`crate::leap::PresetRun::events`]).
pub type LeapSensitivity = ApexSensitivity<LeapResult>;

/// Checks the parameter names of a sensitivity request against a leap configuration; the
/// error names the first unknown (or inapplicable) one.
pub fn check_sensitivity_names(cfg: &LeapConfig, names: &[&str]) -> Result<(), RhexError> {
    names
        .iter()
        .try_for_each(|n| engine_terms(n, cfg, None).map(|_| ()))
}

/// The engine's parameters behind the leap's parameter `name`, with the weights that make its
/// derivative the sum of theirs, on the leap's robot `leap = (params, model)`; with `None`,
/// only whether a leap of `cfg` has the parameter (errors name it). A behaviour parameter is
/// itself (`t2`, a loss option of the geared motor, the compliant leg's `leg_stiffness` and
/// `leg_damping`, [`selfmanip_sim::compliant_leg`]). The gear ratio moves the motors' torque
/// line and the servo (a behaviour parameter) and, on legs that carry their rotors
/// ([`crate::leap::armature_follows_gear`]), each leg joint's armature `a = n J G²`:
/// `d/dG = ∂/∂G + Σ_j (2 a_j / G) ∂/∂a_j` (the behaviour's `∂/∂G` has the servo's damping,
/// critical for the leg's inertia with `a`, move with it). The legs' armature is every leg
/// joint's at once, `Σ_j ∂/∂a_j` plus the behaviour's (the same damping), a parameter only
/// of legs that have one. A toe's friction is static, and kinetic with Coulomb toes.
fn engine_terms(
    name: &str,
    cfg: &LeapConfig,
    leap: Option<(&RhexParams, &selfmanip_core::Model)>,
) -> Result<Option<Vec<(Parameter, f64)>>, RhexError> {
    let geared = matches!(cfg.actuator, LegActuator::GearedMotor { .. });
    let unsupported = |reason: &str| {
        Err(RhexError::Unsupported {
            field: name.into(),
            reason: reason.into(),
        })
    };
    let one = |p: Parameter| Ok(leap.map(|_| vec![(p, 1.0)]));
    let toe = |pair: LegPair| {
        let Some((params, model)) = leap else {
            return Ok(None);
        };
        let coulomb = params.toe_sliding == ToeSliding::Coulomb;
        let toe = contact_friction(model, &format!("{}_leg", pair.name()), coulomb);
        let field = name.to_string();
        Ok(Some(vec![(
            toe.map_err(|reason| RhexError::Unsupported { field, reason })?,
            1.0,
        )]))
    };
    match name {
        "t2" | "t2_s" => one(Parameter::Controller("t2".into())),
        "gear_ratio" if geared => {
            let Some((params, model)) = leap else {
                return Ok(None);
            };
            let mut t = vec![(Parameter::Controller("gear_ratio".into()), 1.0)];
            if let (true, Some(g)) = (
                crate::leap::armature_follows_gear(params),
                cfg.actuator.gear_ratio(),
            ) {
                let a = crate::leap::leg_armature(params, cfg)?;
                t.extend(armature_terms(model, 2.0 * a / g));
            }
            Ok(Some(t))
        }
        "gearbox_efficiency" | "battery_resistance_ohm" if geared => {
            one(Parameter::Controller(name.into()))
        }
        "gear_ratio" => {
            unsupported("the saturated-torque actuator has no gear ratio to differentiate")
        }
        "gearbox_efficiency" | "battery_resistance_ohm" => {
            unsupported("the saturated-torque actuator has no drive losses")
        }
        "leg_stiffness" | "leg_damping" if cfg.compliant_leg.is_some() => {
            one(Parameter::Controller(name.into()))
        }
        "leg_stiffness" | "leg_damping" => {
            unsupported("the leap's legs are rigid (set `compliant_leg`)")
        }
        "m_b" => one(Parameter::Body(BodyParameter::Mass)),
        "I_b" => one(Parameter::Body(BodyParameter::Inertia)),
        "leg_armature_kg_m2" => {
            let Some((params, model)) = leap else {
                return Ok(None);
            };
            if crate::leap::leg_armature(params, cfg)? <= 0.0 {
                return unsupported(
                    "the legs have no armature (massless legs without their rotors): at zero \
                     a massless leg leaves the dynamics, so the armature is not a parameter \
                     of this leap",
                );
            }
            let mut t = armature_terms(model, 1.0);
            // the servo is critically damped for the leg's inertia with its armature
            t.push((Parameter::Controller("leg_armature_kg_m2".into()), 1.0));
            Ok(Some(t))
        }
        "mu_front" => toe(LegPair::Front),
        "mu_middle" => toe(LegPair::Middle),
        "mu_rear" => toe(LegPair::Rear),
        "delta_t_s" if cfg.delta_t_s > 0.0 => one(Parameter::PseudoImpulseDuration),
        "delta_t_s" => unsupported(
            "at δt = 0 the impact takes the limit δt → 0⁺, another rule: the derivative there \
             is one-sided (differentiated at a positive δt)",
        ),
        other => Err(RhexError::UnknownParameter {
            field: other.into(),
            known: SENSITIVITY_PARAMETERS.join(", "),
        }),
    }
}

/// Runs one leap ([`crate::leap::simulate_leap`] with `control_free_joints = true`, the same
/// execution bit for bit: see the module docs) and differentiates its apex with respect to
/// the named parameters.
pub fn leap_with_sensitivity(
    params: &RhexParams,
    cfg: &LeapConfig,
    names: &[&str],
) -> Result<LeapSensitivity, RhexError> {
    leap_with_sensitivity_from(params, cfg, names, None, None)
}

/// [`leap_with_sensitivity`] from the leap's start state plus `start_offset` (`2nq` entries
/// over `(q, q̇)`; it must keep the start on its contacts: the leg angles, the forward
/// position and the legs' rates are free), also differentiating the apex along the
/// start-state `directions` (`2nq × d`).
pub fn leap_with_sensitivity_from(
    params: &RhexParams,
    cfg: &LeapConfig,
    names: &[&str],
    start_offset: Option<&[f64]>,
    directions: Option<&DMatrix<f64>>,
) -> Result<LeapSensitivity, RhexError> {
    check_sensitivity_names(cfg, names)?;
    // the free legs' touchdowns are resolved to the tolerances (see the module docs)
    // and the drive's loss options asked for are the behaviour's parameters (the same leap)
    let cfg = &LeapConfig {
        control_free_joints: true,
        actuator: X_RHEX_LEG.with_loss_parameters(&cfg.actuator, names),
        ..cfg.clone()
    };
    if cfg.toe_stub_rad.is_some() {
        return Err(RhexError::Unsupported {
            field: "toe_stub_rad".into(),
            reason: "the toe stub reverses the torque without an event: leaps with it have no \
                     sensitivities"
                .into(),
        });
    }
    if cfg.t2_reference != T2Reference::MotorStart {
        return Err(RhexError::Unsupported {
            field: "t2_reference".into(),
            reason: "sensitivities are taken at a fixed motor start: use t2_reference = \
                     motor_start (a touchdown-timed leap reports the start it found as \
                     motor_t2_s)"
                .into(),
        });
    }
    let preset = LeapPreset::new(params, cfg)?;
    let model = &preset.leap.rhex.model;
    let dirs = start_directions(model, directions)?;
    let result = preset.run_from(start_offset)?;
    let d_origin: Vec<f64> = names
        .iter()
        .map(|n| match *n {
            "t2" | "t2_s" => d_first_start_d_lag(cfg.t2_s),
            _ => 0.0,
        })
        .collect();
    let named = names
        .iter()
        .map(|n| Ok(engine_terms(n, cfg, Some((params, model)))?.unwrap_or_default()))
        .collect::<Result<Vec<_>, RhexError>>()?;
    let terrain = &cfg.terrain;
    let mut s = ApexSensitivity::at_apex(result, model, terrain, &dirs, &named, names, &d_origin);
    let motor = X_RHEX_LEG.motor(&cfg.actuator);
    s.reason = s.reason.map(|r| motor.undefined_derivative_reason(r));
    Ok(s)
}
