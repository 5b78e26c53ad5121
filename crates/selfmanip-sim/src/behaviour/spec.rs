//! The behaviour file (TOML or JSON): what drives each joint, phase by phase. The schema is
//! documented for users in `docs/behaviours.md`; every type here is plain serde data that
//! [`super::compile()`] checks against a robot and turns into a [`super::BehaviourController`].
use crate::error::SimError;
use crate::expr::Scalar;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A behaviour: named parameters, actuators, named events and one program per driven joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct Behaviour {
    pub name: String,
    pub description: String,
    /// Named numbers (or formulas of other parameters) that any number field may use.
    pub parameters: BTreeMap<String, Scalar>,
    /// Actuators by name; a `motor` command drives one.
    pub actuators: BTreeMap<String, ActuatorSpec>,
    /// Events by name: the first event of the execution that matches a trigger.
    pub events: BTreeMap<String, NamedEvent>,
    /// Gains that keep a free massless joint on its prescribed motion against round-off.
    pub free_joints: FreeJointGains,
    /// One program per driven joint (joints without one: zero torque, and when free, zero
    /// prescribed acceleration).
    pub joints: Vec<JointProgram>,
}

/// `q̈ = α_ref + kp (θ_ref − q) + kd (ω_ref − q̇)` for a free massless joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FreeJointGains {
    pub kp_per_s2: Scalar,
    pub kd_per_s: Scalar,
}

impl Default for FreeJointGains {
    /// A critically damped 20 rad/s loop.
    fn default() -> Self {
        FreeJointGains {
            kp_per_s2: Scalar::Number(400.0),
            kd_per_s: Scalar::Number(40.0),
        }
    }
}

/// An actuator model from the `motor` crate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ActuatorSpec {
    /// An ideal torque source `τ = u τ_max`, `u ∈ [−1, 1]`.
    Saturated { max_torque_n_m: Scalar },
    /// `count` identical DC motors of the catalog in parallel, each behind a gearbox of the
    /// catalog (ratio and current limit overridable): the torque–speed line clipped by the
    /// current limit (thesis 2.1.2, `motor::Drive`).
    DcMotor {
        /// Motor name in the catalog (`x-rhex`, `research-rhex`, …).
        motor: String,
        /// Gearbox name in the catalog (`x-rhex-28`, …).
        gearbox: String,
        #[serde(default)]
        gear_ratio: Option<Scalar>,
        #[serde(default)]
        current_limit_a: Option<Scalar>,
        #[serde(default)]
        supply_voltage_v: Option<Scalar>,
        #[serde(default = "one")]
        count: Scalar,
        /// The gearbox's torque efficiency `η ∈ (0, 1]` (default: the catalog gearbox's).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        gearbox_efficiency: Option<Scalar>,
        /// How `η` enters the torque (`motor::GearboxLoss`): `"derating"` (default, `G η τ_m`
        /// both ways, the thesis's law) or `"power_flow"` (`G τ_m/η` when back-driven).
        #[serde(default, skip_serializing_if = "is_derating")]
        gearbox_loss: motor::GearboxLoss,
        /// The internal resistance (Ω) of the battery behind each motor's PWM stage
        /// (`motor::DriveLosses::battery_resistance_ohm`; default 0: an ideal supply).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        battery_resistance_ohm: Option<Scalar>,
        /// A catalog TOML file of the `motor` crate's format; default: the thesis's Tables
        /// 2.1–2.3.
        #[serde(default)]
        catalog: Option<String>,
    },
}

fn one() -> Scalar {
    Scalar::Number(1.0)
}

pub(crate) fn is_derating(loss: &motor::GearboxLoss) -> bool {
    *loss == motor::GearboxLoss::Derating
}

/// The first event of an execution that matches (after `after_event`, if given). A named
/// event is a moment of the execution every joint program can refer to, e.g. `takeoff`: the
/// first flight once both legs have started.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NamedEvent {
    /// The kind of event (not `joint_angle` or `phase`).
    pub on: On,
    /// The contacts the event concerns (default: every contact).
    #[serde(default)]
    pub contacts: Option<Vec<String>>,
    /// Only events at or after this time (s).
    #[serde(default)]
    pub not_before_s: Option<Scalar>,
    /// Only once this other named event has happened (at this event or before).
    #[serde(default)]
    pub after_event: Option<String>,
}

/// What a trigger waits for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum On {
    /// A touchdown event (an impact) fired by one of `contacts`.
    Touchdown,
    /// A liftoff event fired by one of `contacts`.
    Liftoff,
    /// A stick→slip event of one of `contacts`.
    Slip,
    /// A slip→stick event of one of `contacts`.
    Stick,
    /// The apex of a flight (only with `stop_at_apex`, where it ends the run).
    Apex,
    /// Any event after which one of `contacts` is inactive that was active before it (a
    /// liftoff, or a contact released at an impact).
    Release,
    /// Any event after which one of `contacts` is active that was not before it.
    Touch,
    /// Any event after which no contact is active.
    Flight,
    /// Any event at all.
    Any,
    /// A level, not an event: the joint is past `angle_rad` in `direction` (see the docs).
    JointAngle,
    /// Another joint's (or this joint's) phase has started (`phase = "joint.phase"`).
    Phase,
}

/// When a phase starts (or a motion restarts, or a named event fires). Exactly one of
/// `at_s`, `on`, `event`, `any` is given.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct Trigger {
    /// At this time of the execution clock (s).
    pub at_s: Option<Scalar>,
    /// On an event of this kind.
    pub on: Option<On>,
    /// The contacts the event concerns (default: in a joint program, the contacts carried by
    /// the joint's links; in a named event, every contact).
    pub contacts: Option<Vec<String>>,
    /// Only events at or after this time (s).
    pub not_before_s: Option<Scalar>,
    /// `on = "joint_angle"`: the joint (default: the program's own).
    pub joint: Option<String>,
    /// `on = "joint_angle"`: the angle (rad).
    pub angle_rad: Option<Scalar>,
    /// `on = "joint_angle"`: `+1` past the angle increasing, `−1` decreasing (default `+1`).
    pub direction: Option<Scalar>,
    /// `on = "phase"`: `"joint.phase"`.
    pub phase: Option<String>,
    /// `on = "phase"`: delay after that phase's start (s, default 0).
    pub delay_s: Option<Scalar>,
    /// A named event (of `[events]`).
    pub event: Option<String>,
    /// The first of several triggers.
    pub any: Option<Vec<Trigger>>,
}

impl Trigger {
    pub fn at(t: impl Into<Scalar>) -> Self {
        Trigger {
            at_s: Some(t.into()),
            ..Default::default()
        }
    }
    pub fn on(on: On) -> Self {
        Trigger {
            on: Some(on),
            ..Default::default()
        }
    }
    pub fn event(name: &str) -> Self {
        Trigger {
            event: Some(name.into()),
            ..Default::default()
        }
    }
}

/// The phases of one joint, in order: phase 0 holds from the start; each later phase starts
/// when its trigger fires once the phase before it has started, and holds until the next
/// one starts. After the last phase, a program with `repeat_from` goes on with that phase
/// (a gait cycle); one without stays in its last phase.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointProgram {
    /// `"leg"` for the joint of a one-link leg, `"leg[k]"` for link `k` of a leg.
    pub joint: String,
    pub phases: Vec<Phase>,
    /// The phase (by name) that follows the last one.
    #[serde(default)]
    pub repeat_from: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Phase {
    pub name: String,
    /// When the phase starts (not for phase 0, which holds from the start).
    #[serde(default)]
    pub start: Option<Trigger>,
    /// The joint torque while the phase holds (default: zero).
    #[serde(default)]
    pub torque: Torque,
    /// The prescribed motion of the joint while it is free and massless (and the target of
    /// a servo without one). Default: the previous phase's; phase 0: hold the angle.
    #[serde(default)]
    pub motion: Option<Motion>,
    /// Events at which the motion starts again from the joint's state (when the joint's
    /// contacts are all inactive after the event). Default: the previous phase's.
    #[serde(default)]
    pub restart_on: Option<Vec<Trigger>>,
}

/// A joint torque law.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Torque {
    #[default]
    Zero,
    Constant {
        torque_n_m: Scalar,
    },
    /// Piecewise-linear (or held) torque over the execution clock; constant beyond the ends.
    Schedule {
        times_s: Vec<Scalar>,
        torques_n_m: Vec<Scalar>,
        #[serde(default)]
        interpolation: Interpolation,
    },
    /// `τ = sat(−kp (q − θ*) − kd (q̇ − ω*), ±torque_limit)`; the target is `target_rad` (at
    /// rest) or, when omitted, the joint's motion `(θ_ref, ω_ref)`.
    Servo {
        #[serde(default)]
        target_rad: Option<Scalar>,
        kp_n_m_per_rad: Scalar,
        kd_n_m_s_per_rad: Scalar,
        #[serde(default)]
        torque_limit_n_m: Option<Scalar>,
        /// Zero torque while none of the joint's contacts is active.
        #[serde(default)]
        only_in_contact: bool,
    },
    /// The normalized command `command ∈ [−1, 1]` to an actuator, at the joint's speed;
    /// reversed once the joint has turned past `reverse_beyond_rad` in the command's
    /// direction (a toe stub, thesis Result C.3).
    Motor {
        actuator: String,
        command: Scalar,
        #[serde(default)]
        reverse_beyond_rad: Option<Scalar>,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    #[default]
    Linear,
    Hold,
}

/// A smooth prescribed motion (thesis 5.1.1: a free massless joint has no dynamics; its
/// motion is chosen with bounded acceleration). Targets may use `theta` and `omega`, the
/// joint's angle and rate where the motion starts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Motion {
    /// Hold an angle at rest.
    Hold { angle_rad: Scalar },
    /// Ramp to a cruise speed, cruise, and come to rest at the target (a smooth trapezoid).
    Swing {
        target_rad: Scalar,
        speed_rad_s: Scalar,
        accel_rad_s2: Scalar,
    },
    /// A quintic to rest at the target within the acceleration bound.
    Park {
        target_rad: Scalar,
        accel_rad_s2: Scalar,
    },
}

impl Behaviour {
    pub fn from_toml_str(s: &str) -> Result<Self, SimError> {
        parse_text("behaviour", "toml", s)
    }

    pub fn from_json_str(s: &str) -> Result<Self, SimError> {
        parse_text("behaviour", "json", s)
    }

    /// Reads a `.toml` or `.json` file (by extension).
    pub fn from_file(path: &std::path::Path) -> Result<Self, SimError> {
        read_file("behaviour", path)
    }
}

/// Parses `text` in `format` (`"toml"` or `"json"`) as a `what` (`"behaviour"`,
/// `"scenario"`); the error names both.
pub(crate) fn parse_text<T: DeserializeOwned>(
    what: &str,
    format: &'static str,
    text: &str,
) -> Result<T, SimError> {
    let parsed = if format == "json" {
        serde_json::from_str(text).map_err(|e| e.to_string())
    } else {
        toml::from_str(text).map_err(|e| e.to_string())
    };
    parsed.map_err(|message| SimError::Parse {
        what: what.into(),
        format,
        message,
    })
}

/// Reads a `.toml` or `.json` file (by extension) as a `what` ([`parse_text`]).
pub(crate) fn read_file<T: DeserializeOwned>(
    what: &str,
    path: &std::path::Path,
) -> Result<T, SimError> {
    let text = read_text(path)?;
    let format = match path.extension().and_then(|e| e.to_str()) {
        Some("json") => "json",
        _ => "toml",
    };
    parse_text(what, format, &text)
}

/// The text of a file (an empty file is an error naming the file, not a parse error).
pub(crate) fn read_text(path: &std::path::Path) -> Result<String, SimError> {
    let text = std::fs::read_to_string(path).map_err(|e| SimError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
        kind: e.kind(),
    })?;
    if text.trim().is_empty() {
        return Err(SimError::Io {
            path: path.display().to_string(),
            message: "the file is empty".into(),
            kind: std::io::ErrorKind::InvalidData,
        });
    }
    Ok(text)
}
