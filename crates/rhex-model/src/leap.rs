//! RHex leaps from rest to apex (thesis chapter 3.2 and chapter 5's simulations): the four
//! open-loop strategies `(±, ±)` with coordination time `t2`, driven through the hybrid
//! engine of `selfmanip-hybrid`.
//!
//! **The leap.** The robot starts at rest sitting on its body (`I_1010`) on the ground, each
//! leg held [`LeapConfig::wait_clearance_rad`] above its touchdown angle (the angle at which
//! its lowest point reaches the ground, on the side its strategy pushes from). The front
//! leg's motor switches on at `t = 0` and the rear leg's at `t = t2` (negative: the rear leg
//! starts first); a leg swings down and touches the ground shortly after its start.
//! Execution time starts at `min(0, t2)`; every reported time is shifted so that the front
//! leg starts at 0. A leg's motor then applies its saturated torque `±τ_s` (or a current-limited geared DC
//! motor's torque at the leg speed) in the strategy's direction: `+` turns the leg with
//! increasing θ (the toe sweeps backward, pushing the body forward — RHex's walking direction,
//! rolling on the half circle), `−` the other way (pushing on the toe point: a flip).
//!
//! **Massless legs in the air** (thesis 5.1.1) have no dynamics: their motion is prescribed
//! with bounded acceleration (the thesis's assumption that keeps executions non-Zeno), as
//! smooth functions of time ([`selfmanip_sim::motion`]). A leg that has not touched down yet
//! swings towards the ground; a leg that has lifted off parks pointing up on the side of
//! straight down where it is, never sweeping through the ground (the thesis's "once a leg
//! has lifted off the ground it is slowly rotated upwards out of the way"), unless
//! [`LeapConfig::keep_pushing_after_liftoff`] keeps it turning in its push direction. The
//! park is planned once; a parked leg that the ground meets and lets go again returns to it
//! (`docs/decisions/2026-11-24-one-retraction-per-leg.md`).
//!
//! **Words.** The leap word is the sequence of ground-reaction-complex cells visited
//! (chapter 3.1), sliding toes counted as contact, zero-time cells suppressed.
use crate::params::{LegPair, RhexParams};
use crate::{Rhex, RhexError};
use motor::Actuator;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{ContactMode, Terrain};
use selfmanip_hybrid::EventMemoryPartials;
use selfmanip_hybrid::StepOptions;
use selfmanip_hybrid::{simulate_with, Controller, ControllerPartials, TimeEvent};
use selfmanip_hybrid::{Event, EventKind, Execution, HybridOptions, Termination};
use selfmanip_sim::motion::JointMotion as LegMotion;
use selfmanip_sim::motion::StartedLaw;
use selfmanip_sim::terrain::TerrainSpec;
use selfmanip_sim::Trajectory;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::str::FromStr;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// Direction a leg pushes in: `+` increases θ (forward lunge), `−` decreases it (flip).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Push {
    #[serde(rename = "+")]
    Plus,
    #[serde(rename = "-")]
    Minus,
}

impl Push {
    /// `+1` or `−1`.
    pub fn sign(self) -> f64 {
        match self {
            Push::Plus => 1.0,
            Push::Minus => -1.0,
        }
    }
    pub fn symbol(self) -> char {
        match self {
            Push::Plus => '+',
            Push::Minus => '-',
        }
    }
}

/// A leg strategy `S = (front, rear)` of section 3.2.1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Strategy {
    pub front: Push,
    pub rear: Push,
}

impl Strategy {
    pub const ALL: [Strategy; 4] = [
        Strategy::new(Push::Plus, Push::Plus),
        Strategy::new(Push::Plus, Push::Minus),
        Strategy::new(Push::Minus, Push::Plus),
        Strategy::new(Push::Minus, Push::Minus),
    ];
    pub const fn new(front: Push, rear: Push) -> Self {
        Strategy { front, rear }
    }
}

impl std::fmt::Display for Strategy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{}", self.front.symbol(), self.rear.symbol())
    }
}

impl FromStr for Strategy {
    type Err = RhexError;
    /// `"++"`, `"+-"`, `"-+"`, `"--"` (also `"(+,+)"`).
    fn from_str(s: &str) -> Result<Self, RhexError> {
        let signs: Vec<Push> = s
            .chars()
            .filter(|c| !matches!(c, '(' | ')' | ',' | ' '))
            .map(|c| match c {
                '+' => Ok(Push::Plus),
                '-' => Ok(Push::Minus),
                other => Err(other),
            })
            .collect::<Result<_, _>>()
            .map_err(|c| RhexError::Params {
                field: "strategy".into(),
                reason: format!("`{s}`: character `{c}` is not + or -"),
            })?;
        match signs[..] {
            [front, rear] => Ok(Strategy { front, rear }),
            _ => Err(RhexError::Params {
                field: "strategy".into(),
                reason: format!("`{s}`: expected two signs such as ++, +-, -+ or --"),
            }),
        }
    }
}

impl TryFrom<String> for Strategy {
    type Error = RhexError;
    fn try_from(s: String) -> Result<Self, RhexError> {
        s.parse()
    }
}

impl From<Strategy> for String {
    fn from(s: Strategy) -> String {
        s.to_string()
    }
}

/// What turns a planar leg (a contralateral pair of physical legs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LegActuator {
    /// The constant saturated torque `τ_s` of Table 4.2 (chapter 3's assumption).
    SaturatedTorque,
    /// `motors_per_leg` X-RHex motors (thesis Table 2.1, 37 V) behind a gearbox of ratio
    /// `gear_ratio` and the catalog gearbox efficiency, with the controller current limit
    /// `current_limit_a` (chapter 5's simulations: 20 A): the linear torque–speed line
    /// clipped by the current limit (section 2.1.2, Fig. 2.6).
    GearedMotor {
        gear_ratio: f64,
        current_limit_a: f64,
        motors_per_leg: u32,
    },
}

impl Default for LegActuator {
    fn default() -> Self {
        LegActuator::GearedMotor {
            gear_ratio: 28.0,
            current_limit_a: DEFAULT_CURRENT_LIMIT_A,
            motors_per_leg: DEFAULT_MOTORS_PER_LEG,
        }
    }
}

/// Chapter 5's controller current limit (A) and motors per planar leg (a contralateral pair).
const DEFAULT_CURRENT_LIMIT_A: f64 = 20.0;
const DEFAULT_MOTORS_PER_LEG: u32 = 2;

impl LegActuator {
    /// The geared motor with gear ratio `gear_ratio`, keeping this actuator's current limit
    /// and motor count (chapter 5's when this is the saturated torque).
    pub fn with_gear_ratio(&self, gear_ratio: f64) -> LegActuator {
        let (current_limit_a, motors_per_leg) = match *self {
            LegActuator::GearedMotor {
                current_limit_a,
                motors_per_leg,
                ..
            } => (current_limit_a, motors_per_leg),
            LegActuator::SaturatedTorque => (DEFAULT_CURRENT_LIMIT_A, DEFAULT_MOTORS_PER_LEG),
        };
        LegActuator::GearedMotor {
            gear_ratio,
            current_limit_a,
            motors_per_leg,
        }
    }
}

/// What the coordination time `t2` times (the two readings of the thesis; see
/// `docs/errata/ch3-leaping.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum T2Reference {
    /// The rear leg's motor starts `t2` after the front leg's (chapter 5, footnote 1: "the
    /// middle legs are started 0.01 s before the rear legs"): what a controller commands,
    /// and what the thesis's own simulation of chapter 3's leaps used. The default.
    #[default]
    MotorStart,
    /// The rear leg touches down `t2` after the front leg does (section 3.2.2: "choose as a
    /// reference time the touchdown of the front leg … the second leg will touch down at
    /// `t2`"). The rear motor's start is adjusted, leap by leap, by a secant search (at
    /// most [`TOUCHDOWN_SEARCH_RUNS`] runs of the leap); a leap whose legs do not both touch
    /// down keeps the motor-start offset `t2`.
    Touchdown,
}

/// Runs of a leap at most in a [`T2Reference::Touchdown`] search.
pub const TOUCHDOWN_SEARCH_RUNS: usize = 12;
/// Agreement of the touchdown offset with `t2` at which that search stops (s).
pub const TOUCHDOWN_SEARCH_TOL_S: f64 = 1e-7;

/// Everything a leap needs besides the robot's parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LeapConfig {
    pub strategy: Strategy,
    /// Start of the rear leg's motor relative to the front leg's (s); negative: rear first.
    pub t2_s: f64,
    pub actuator: LegActuator,
    /// The two leg pairs that push (front-most first). `None`: chapter 3's choice for the
    /// strategy, the leading leg disabled — middle and rear for `(+,+)`, front and rear for
    /// `(+,−)` and `(−,+)`, front and middle for `(−,−)` (section 3.3). A leap's robot has
    /// exactly these two pairs: the parameters' `pairs` are not read (an override named
    /// `pairs` in a sweep or from Python sets this field).
    pub pairs: Option<[LegPair; 2]>,
    /// Pseudo-impulse duration δt of (5.39) (s); 0 disables it. Thesis: 0.03 s.
    pub delta_t_s: f64,
    /// Bound on a massless leg's acceleration while it is in the air (rad/s²). `None`: set by
    /// the motor that turns it — its stall torque over its rotor's reflected inertia
    /// ([`leg_swing`]).
    pub swing_accel_rad_s2: Option<f64>,
    /// Speed a massless leg in the air is brought to (rad/s). `None`: its motor's no-load
    /// output speed ([`leg_swing`]).
    pub swing_speed_rad_s: Option<f64>,
    /// What `t2_s` times: the rear motor's start relative to the front one's (chapter 5,
    /// footnote 1; the default), or the rear leg's touchdown relative to the front leg's
    /// (section 3.2.2), found by adjusting the motor start.
    pub t2_reference: T2Reference,
    /// A leg waits for its motor raised this far (rad) above the angle at which it would
    /// touch the ground from the sitting posture, so that the body can pitch on the other
    /// leg without driving it into the ground; at its start it swings down (at
    /// `swing_accel_rad_s2`, `swing_speed_rad_s`) and touches down shortly after.
    pub wait_clearance_rad: f64,
    /// Toe stub (Result C.3, section 3.3.1): a pushing leg's torque reverses once its angle
    /// has turned this far past straight down (rad, measured in its push direction).
    pub toe_stub_rad: Option<f64>,
    pub terrain: TerrainSpec,
    /// Latest time of the execution (s after the front leg starts).
    pub t_final_s: f64,
    /// Stop at the first apex of flight (otherwise run to `t_final_s`: landings, ledges).
    pub stop_at_apex: bool,
    /// What a pushing leg does once it has lifted off: park out of the way (the thesis's
    /// "once a leg has lifted off the ground it is slowly rotated upwards out of the way"),
    /// or keep turning in its push direction at bounded acceleration until the robot is in
    /// flight (the motor stays on: the setting of Fig. 5.7's chatter).
    pub keep_pushing_after_liftoff: bool,
    /// Width of the bracket that locates each event (s).
    pub event_tol_s: f64,
    /// Relative error tolerance of the integrator per step (absolute: 1 % of it, in SI
    /// units of the state).
    pub rtol: f64,
    /// Zeno detection: more than `zeno_max_events` events within `zeno_window_s`.
    pub zeno_window_s: f64,
    pub zeno_max_events: usize,
    /// Budget of accepted integration steps: a leap that needs more ends `step_budget`.
    pub max_steps: usize,
    /// Budget of events: a leap that makes more ends `event_budget`.
    pub max_events: usize,
    /// Integrate the legs' prescribed motions in the air to the tolerances too
    /// ([`HybridOptions::control_free_joints`]; off by default: ~3× cheaper leaps).
    pub control_free_joints: bool,
}

impl Default for LeapConfig {
    fn default() -> Self {
        LeapConfig {
            strategy: Strategy::new(Push::Plus, Push::Plus),
            t2_s: 0.0,
            actuator: LegActuator::default(),
            pairs: None,
            delta_t_s: 0.03,
            swing_accel_rad_s2: None,
            swing_speed_rad_s: None,
            t2_reference: T2Reference::MotorStart,
            wait_clearance_rad: 0.8,
            toe_stub_rad: None,
            terrain: TerrainSpec::Flat,
            t_final_s: 1.0,
            stop_at_apex: true,
            keep_pushing_after_liftoff: false,
            event_tol_s: 1e-10,
            rtol: 1e-8,
            zeno_window_s: 0.01,
            zeno_max_events: 40,
            max_steps: selfmanip_hybrid::DEFAULT_MAX_STEPS,
            max_events: DEFAULT_MAX_EVENTS,
            control_free_joints: false,
        }
    }
}

/// A leap's default event budget (a leap makes a few tens of events).
const DEFAULT_MAX_EVENTS: usize = 1_000;

/// The parameters of the leaps of chapters 3 and 5: Table 4.2 (massless half-circle legs)
/// with toe friction μ = 1.8 on the front and middle pairs and 2.5 on the rear (section
/// 5.1.5). Which pairs push is [`LeapConfig::pairs`].
pub fn leap_params() -> RhexParams {
    RhexParams {
        pairs: vec![LegPair::Middle, LegPair::Rear],
        mu_front: Some(1.8),
        mu_middle: Some(1.8),
        mu_rear: Some(2.5),
        ..RhexParams::default()
    }
}

impl Strategy {
    /// Chapter 3's pushing pairs for this strategy (the leading leg disabled, section 3.3).
    pub fn chapter3_pairs(self) -> [LegPair; 2] {
        match (self.front, self.rear) {
            (Push::Plus, Push::Plus) => [LegPair::Middle, LegPair::Rear],
            (Push::Minus, Push::Minus) => [LegPair::Front, LegPair::Middle],
            _ => [LegPair::Front, LegPair::Rear],
        }
    }
}

/// The body state at the apex of flight, in a z-**up** frame whose origin is the body centre
/// at the start (x forward): what chapter 3 reports.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Apex {
    pub t_s: f64,
    /// Forward displacement of the body centre from the start.
    pub x_m: f64,
    /// Height of the body centre above the ground under the start (positive up).
    pub z_m: f64,
    /// Pitch, nose-up positive.
    pub phi_rad: f64,
    pub xdot_m_s: f64,
    pub zdot_m_s: f64,
    pub phidot_rad_s: f64,
}

/// How a leap ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LeapStatus {
    /// Reached the apex of flight (or `t_final` after a flight when not stopping at apex).
    Ok,
    /// Never reached the apex of a flight (when stopping at apex), or never left the ground
    /// (otherwise), before `t_final`.
    NoFlight,
    /// A Zeno execution (too many events in the Zeno window), or a chatter: one cycle of
    /// events repeated with the robot staying where it is (`selfmanip_hybrid::zeno`).
    Zeno,
    EventBudget,
    NoContactSolution,
    SeveralContactSolutions,
    /// A contact met a place of a ledge that is not a contact feature for it: the edge where
    /// its face meets its top, met by a point of the robot (a leg's tip), or the concave
    /// corner where the face meets the ground (one contact site touching two surfaces at
    /// once). Body ends and leg arcs rest, roll and slide on the edge.
    TerrainEdge,
    /// The contact set met a pose where it no longer determines the motion of a massless
    /// leg (Lemma 5.1) and the fold guard could not resolve it (rare: such poses are
    /// normally resolved as transitions, see `selfmanip_hybrid::fold`).
    SingularContact,
    /// The run used up its budget of integration steps ([`LeapConfig::max_steps`]).
    StepBudget,
    /// The caller stopped the run ([`simulate_leap_with`]).
    Interrupted,
}

impl LeapStatus {
    pub fn as_str(self) -> &'static str {
        match self {
            LeapStatus::Ok => "ok",
            LeapStatus::NoFlight => "no_flight",
            LeapStatus::Zeno => "zeno",
            LeapStatus::EventBudget => "event_budget",
            LeapStatus::NoContactSolution => "no_contact_solution",
            LeapStatus::SeveralContactSolutions => "several_contact_solutions",
            LeapStatus::TerrainEdge => "terrain_edge",
            LeapStatus::SingularContact => "singular_contact",
            LeapStatus::StepBudget => "step_budget",
            LeapStatus::Interrupted => "interrupted",
        }
    }
}

/// The outcome of one leap.
#[derive(Debug, Clone)]
pub struct LeapResult {
    pub status: LeapStatus,
    /// The apex of the leap's first flight (when not stopping there, also after it: the run
    /// records it and goes on).
    pub apex: Option<Apex>,
    /// Ground-reaction-complex cells visited (labels `FB FL RB RL`), zero-time cells
    /// suppressed, starting with `1010`.
    pub word: Vec<String>,
    /// The execution (times on the simulation clock, which starts at `min(0, t2)`).
    pub execution: Execution,
    /// Subtract from execution times to get times relative to the front leg's start.
    pub time_offset_s: f64,
    /// Start configuration `q` (thesis coordinates, z down).
    pub q0: Vec<f64>,
    /// Events relative to the front leg's start, labelled.
    pub events: Vec<LeapEvent>,
    /// The rear motor's start relative to the front one's in this run (s): `t2` itself, or
    /// what the [`T2Reference::Touchdown`] search found.
    pub motor_t2_s: f64,
    /// The rear leg's first touchdown relative to the front leg's (s), each after its motor
    /// started (section 3.2.2's `t2`); `None` if one of them never touched down.
    pub touchdown_t2_s: Option<f64>,
}

impl LeapResult {
    /// The word joined by `-`, e.g. `1010-0110-0101-0001-0000`.
    pub fn word_string(&self) -> String {
        self.word.join("-")
    }
}

/// One event of a leap, labelled for users.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LeapEvent {
    /// Time relative to the front leg's start (s).
    pub t_s: f64,
    /// `touchdown`, `liftoff`, `slip`, `stick`, `fold` (a leg reached the pose where its
    /// contact stops pinning it: an impulsive stick, a release, or the start of its passage
    /// through that pose), `fold_passed` (the passage's end), `jam` (a Painlevé slide
    /// stopped by an impact without collision, `selfmanip_hybrid::jam`) or `apex`.
    pub kind: &'static str,
    pub mode_before: String,
    pub mode_after: String,
    /// Names of the contacts that fired the guard.
    pub contacts: Vec<String>,
    /// Kinetic energy lost in the event (J; zero for liftoff, slip, stick and apex; round-off,
    /// within [`ENERGY_ROUND_OFF`] `· (T⁻ + 1 J)`, reported as zero). Never negative for a
    /// touchdown; a `fold` that starts a passage may gain energy from the motor.
    pub energy_loss_j: f64,
}

impl LeapConfig {
    /// Checks every field (errors name it).
    pub fn validate(&self) -> Result<(), RhexError> {
        let bad = |field: &str, reason: String| {
            Err(RhexError::Params {
                field: field.into(),
                reason,
            })
        };
        let finite = [
            ("t2_s", self.t2_s),
            ("delta_t_s", self.delta_t_s),
            ("swing_accel_rad_s2", self.swing_accel_rad_s2.unwrap_or(1.0)),
            ("swing_speed_rad_s", self.swing_speed_rad_s.unwrap_or(1.0)),
            ("wait_clearance_rad", self.wait_clearance_rad),
            ("t_final_s", self.t_final_s),
            ("event_tol_s", self.event_tol_s),
            ("zeno_window_s", self.zeno_window_s),
            ("rtol", self.rtol),
        ];
        for (field, v) in finite {
            if !v.is_finite() {
                return bad(field, format!("must be finite, got {v}"));
            }
        }
        for (field, v) in [
            ("swing_accel_rad_s2", self.swing_accel_rad_s2.unwrap_or(1.0)),
            ("swing_speed_rad_s", self.swing_speed_rad_s.unwrap_or(1.0)),
            ("t_final_s", self.t_final_s),
            ("event_tol_s", self.event_tol_s),
            ("zeno_window_s", self.zeno_window_s),
            ("rtol", self.rtol),
        ] {
            if v <= 0.0 {
                return bad(field, format!("must be positive, got {v}"));
            }
        }
        for (field, n) in [
            ("max_steps", self.max_steps),
            ("max_events", self.max_events),
            ("zeno_max_events", self.zeno_max_events),
        ] {
            if n == 0 {
                return bad(field, "must be at least 1".into());
            }
        }
        if self.delta_t_s < 0.0 {
            return bad(
                "delta_t_s",
                format!("must be non-negative, got {}", self.delta_t_s),
            );
        }
        if !(0.0..=1.5).contains(&self.wait_clearance_rad) {
            return bad(
                "wait_clearance_rad",
                format!("must lie in [0, 1.5], got {}", self.wait_clearance_rad),
            );
        }
        if self.t2_s.abs() >= self.t_final_s {
            return bad(
                "t2_s",
                format!("|t2| must be below t_final_s = {}", self.t_final_s),
            );
        }
        if let Some(a) = self.toe_stub_rad {
            if !a.is_finite() || !(0.0..PI).contains(&a) {
                return bad("toe_stub_rad", format!("must lie in [0, π), got {a}"));
            }
        }
        if let LegActuator::GearedMotor {
            gear_ratio,
            current_limit_a,
            motors_per_leg,
        } = self.actuator
        {
            if !gear_ratio.is_finite() || gear_ratio <= 0.0 {
                return bad(
                    "gear_ratio",
                    format!("must be finite and positive, got {gear_ratio}"),
                );
            }
            if !current_limit_a.is_finite() || current_limit_a <= 0.0 {
                return bad(
                    "current_limit_a",
                    format!("must be finite and positive, got {current_limit_a}"),
                );
            }
            if motors_per_leg == 0 {
                return bad("motors_per_leg", "must be at least 1".into());
            }
        }
        Ok(self.terrain.validate()?)
    }
}

/// A planar leg's actuator: `n` identical drives in parallel (a contralateral pair).
struct LegDrive {
    drive: motor::Drive,
    n: f64,
}

impl Actuator for LegDrive {
    fn joint_torque_n_m(&self, command: f64, speed: f64) -> f64 {
        self.n * self.drive.joint_torque_n_m(command, speed)
    }
    fn electrical_power_w(&self, command: f64, speed: f64) -> f64 {
        self.n * self.drive.electrical_power_w(command, speed)
    }
}

/// What a leg motor's torque depends on, for its partial derivatives: the saturated torque
/// (`τ = u τ_s`, independent of speed and gear ratio) or `n` geared DC motors,
/// `τ = n G η clamp(τ_st (u − G ω/ω₀), ±k_M I_max)` (motor stall torque `τ_st`, no-load
/// speed `ω₀`, current-limited torque `k_M I_max`, gearbox ratio `G` and efficiency `η`).
#[derive(Debug, Clone, Copy, PartialEq)]
enum MotorLaw {
    Saturated,
    Geared {
        n: f64,
        ratio: f64,
        efficiency: f64,
        stall_n_m: f64,
        no_load_rad_s: f64,
        limit_n_m: f64,
    },
}

impl MotorLaw {
    fn new(a: &LegActuator, drive: Option<&motor::Drive>) -> Self {
        match (a, drive) {
            (LegActuator::GearedMotor { motors_per_leg, .. }, Some(d)) => MotorLaw::Geared {
                n: f64::from(*motors_per_leg),
                ratio: d.gearbox.ratio,
                efficiency: d.gearbox.efficiency,
                stall_n_m: d.motor.stall_torque_n_m,
                no_load_rad_s: d.motor.no_load_speed_rad_s,
                limit_n_m: d.motor.current_limited_torque_n_m(),
            },
            _ => MotorLaw::Saturated,
        }
    }

    /// `(∂τ/∂ω, ∂τ/∂G)` at command `u` and joint speed `ω`: the derivative of the active
    /// branch (on the torque–speed line, or at the current limit). `None` for `∂τ/∂G` of
    /// the saturated torque (no gear ratio).
    fn partials(&self, u: f64, speed: f64) -> (f64, Option<f64>) {
        match *self {
            MotorLaw::Saturated => (0.0, None),
            MotorLaw::Geared {
                n,
                ratio,
                efficiency,
                stall_n_m,
                no_load_rad_s,
                limit_n_m,
            } => {
                let a = stall_n_m * (u.clamp(-1.0, 1.0) - speed * ratio / no_load_rad_s);
                if a.abs() < limit_n_m {
                    let c = n * ratio * efficiency;
                    (
                        -c * stall_n_m * ratio / no_load_rad_s,
                        Some(n * efficiency * a - c * stall_n_m * speed / no_load_rad_s),
                    )
                } else {
                    (0.0, Some(n * efficiency * a.clamp(-limit_n_m, limit_n_m)))
                }
            }
        }
    }
}

impl MotorLaw {
    /// [`Self::partials`] of the branch the leg moves into where the state sits on the kink
    /// between the current limit and the torque–speed line (within round-off: `|a|` at most
    /// 1e-9 above the limit). With the X-RHex drive the limit equals the stall torque, so the
    /// kink is at standstill: a leg that starts from rest in contact (after a touchdown into
    /// a sticking toe, its rate is 0 up to round-off of either sign) runs on the line for
    /// every `t > t₀`, and the partial at its first instant must be the line's. The side
    /// taken is the motor's push direction (a leg its motor accelerates from the kink);
    /// elsewhere the active branch, as [`Self::partials`].
    fn partials_one_sided(&self, u: f64, speed: f64) -> (f64, Option<f64>) {
        self.partials(u, self.branch_speed(u, speed))
    }

    /// The joint speed at which the branch of the law is read: `speed`, or, where the state
    /// sits on the kink between the current limit and the torque–speed line (within
    /// round-off), nudged into the branch the leg moves into.
    fn branch_speed(&self, u: f64, speed: f64) -> f64 {
        if let MotorLaw::Geared {
            ratio,
            stall_n_m,
            no_load_rad_s,
            limit_n_m,
            ..
        } = *self
        {
            let a = stall_n_m * (u.clamp(-1.0, 1.0) - speed * ratio / no_load_rad_s);
            if a.abs() >= limit_n_m && a.abs() <= limit_n_m * (1.0 + 1e-9) && u != 0.0 {
                return speed + u.signum() * 2e-9 * no_load_rad_s / ratio;
            }
        }
        speed
    }

    /// Whether [`Self::partials_one_sided`] takes the current limit's branch (not the
    /// torque–speed line's) at command `u` and joint speed `ω`: the motor's piece of its law
    /// ([`Controller::partials_piece`]).
    fn on_limit(&self, u: f64, speed: f64) -> bool {
        let MotorLaw::Geared {
            ratio,
            stall_n_m,
            no_load_rad_s,
            limit_n_m,
            ..
        } = *self
        else {
            return false;
        };
        let w = self.branch_speed(u, speed);
        (stall_n_m * (u.clamp(-1.0, 1.0) - w * ratio / no_load_rad_s)).abs() >= limit_n_m
    }
}

/// The actuator that turns one planar leg (a contralateral pair): chapter 3's saturated
/// torque `τ_s`, or the current-limited geared X-RHex motors (the leap's own drive, for
/// tools that build their own leap controller).
pub fn leg_actuator(params: &RhexParams, a: &LegActuator) -> Result<Arc<dyn Actuator>, RhexError> {
    Ok(leg_motor(params, a)?.0)
}

/// The leg actuator and the law of its torque.
fn leg_motor(
    params: &RhexParams,
    a: &LegActuator,
) -> Result<(Arc<dyn Actuator>, MotorLaw), RhexError> {
    let motor_err = |e: motor::MotorError| RhexError::Params {
        field: "actuator".into(),
        reason: e.to_string(),
    };
    Ok(match *a {
        LegActuator::SaturatedTorque => (
            Arc::new(motor::SaturatedTorque::new(params.tau_s).map_err(motor_err)?),
            MotorLaw::Saturated,
        ),
        LegActuator::GearedMotor {
            gear_ratio,
            current_limit_a,
            motors_per_leg,
        } => {
            let catalog = motor::catalog::Catalog::thesis();
            let m = catalog
                .motor_spec("x-rhex")
                .and_then(|m| m.motor())
                .and_then(|m| m.with_current_limit(current_limit_a))
                .map_err(motor_err)?;
            let mut gearbox = catalog.gearbox("x-rhex-28").map_err(motor_err)?.clone();
            gearbox.ratio = gear_ratio;
            let drive = motor::Drive::new(m, gearbox).map_err(motor_err)?;
            let law = MotorLaw::new(a, Some(&drive));
            (
                Arc::new(LegDrive {
                    drive,
                    n: f64::from(motors_per_leg),
                }),
                law,
            )
        }
    })
}

/// A leg's own inertia about its hip, `I_l + m_l (ρ₁/2)²` (kg m²; zero for Table 4.2's
/// massless legs): what the motor accelerates besides its rotors ([`leg_swing`]).
pub fn leg_inertia_about_hip(params: &RhexParams) -> f64 {
    params.I_l + params.m_l * (0.5 * params.rho1).powi(2)
}

/// The drive that turns a leg: its gear ratio `G`, motors per leg `n`, stall torque at the
/// joint (N m), the motor's no-load speed `ω₀` (rad/s) and one rotor's inertia `J` (kg m²).
/// The geared motor's own; the saturated-torque idealization keeps X-RHex's legs and motors
/// (Table 2.1's motor behind the 28:1 gearbox, two per planar leg) with `τ_s` as its stall
/// torque. The rotor inertia is not printed; it is `J = τ_m k_M² / R` from Table 2.1's
/// mechanical time constant `τ_m = 11.8 ms` and the motor model's `k_M` and `R`
/// ([`motor::catalog::MotorSpec::rotor_inertia_kg_m2`]: 7.2·10⁻⁶ kg m², within the range of
/// maxon's 45 mm flat motors).
struct LegMotorData {
    ratio: f64,
    n: f64,
    stall_n_m: f64,
    no_load_speed_rad_s: f64,
    rotor_kg_m2: f64,
}

fn leg_motor_data(params: &RhexParams, cfg: &LeapConfig) -> Result<LegMotorData, RhexError> {
    let motor_err = |e: motor::MotorError| RhexError::Params {
        field: "actuator".into(),
        reason: e.to_string(),
    };
    let catalog = motor::catalog::Catalog::thesis();
    let spec = catalog.motor_spec("x-rhex").map_err(motor_err)?;
    let (ratio, n, stall_n_m) = match cfg.actuator {
        LegActuator::GearedMotor {
            gear_ratio,
            motors_per_leg,
            ..
        } => {
            let drive = leg_actuator(params, &cfg.actuator)?;
            (
                gear_ratio,
                f64::from(motors_per_leg),
                drive.joint_torque_n_m(1.0, 0.0),
            )
        }
        LegActuator::SaturatedTorque => (
            catalog.gearbox("x-rhex-28").map_err(motor_err)?.ratio,
            f64::from(DEFAULT_MOTORS_PER_LEG),
            params.tau_s,
        ),
    };
    let m = spec.motor().map_err(motor_err)?;
    let rotor_kg_m2 = spec
        .rotor_inertia_kg_m2()
        .map_err(motor_err)?
        .ok_or_else(|| RhexError::Params {
            field: "actuator".into(),
            reason: "the motor's mechanical time constant is needed for the rotor inertia".into(),
        })?;
    Ok(LegMotorData {
        ratio,
        n,
        stall_n_m,
        no_load_speed_rad_s: m.no_load_speed_rad_s,
        rotor_kg_m2,
    })
}

impl LegMotorData {
    /// `n J G²`.
    fn reflected_inertia(&self) -> f64 {
        self.n * self.rotor_kg_m2 * self.ratio * self.ratio
    }
}

/// The inertia of a leg's motors' rotors seen at the leg's joint through the gearbox,
/// `n J G²` (kg m²; 0.0113 for X-RHex's two motors per planar leg at 28:1): `n` rotors of
/// inertia `J` turning `G` times as fast as the leg. One value for both uses: the swing
/// bound of a massless leg ([`leg_swing`]) and the armature of a massive leg's joint
/// ([`leg_armature`]).
pub fn rotor_reflected_inertia(params: &RhexParams, cfg: &LeapConfig) -> Result<f64, RhexError> {
    Ok(leg_motor_data(params, cfg)?.reflected_inertia())
}

/// The armature a leap gives each leg joint (kg m²): `params.leg_armature_kg_m2` when set;
/// otherwise its rotors' reflected inertia ([`rotor_reflected_inertia`]) on legs that carry
/// them ([`RhexParams::legs_carry_rotors`]: by default massive legs, whose physical motors
/// turn with them) and none on the others — by default massless legs, which stay massless
/// (Assumption C.6: their motion is prescribed, bounded by the same rotors in
/// [`leg_swing`]).
pub fn leg_armature(params: &RhexParams, cfg: &LeapConfig) -> Result<f64, RhexError> {
    Ok(leap_leg_armature(params, cfg)?.unwrap_or(0.0))
}

/// [`leg_armature`], `None` for legs without rotors or an explicit armature.
fn leap_leg_armature(params: &RhexParams, cfg: &LeapConfig) -> Result<Option<f64>, RhexError> {
    Ok(match params.leg_armature_kg_m2 {
        Some(a) => Some(a),
        None if params.legs_carry_rotors() => Some(rotor_reflected_inertia(params, cfg)?),
        None => None,
    })
}

/// Whether a leap's leg armature is the actuator's reflected rotor inertia, which moves with
/// the gear ratio (`∂a/∂G = 2 n J G`): legs that carry their rotors, without an explicit
/// armature.
pub(crate) fn armature_follows_gear(params: &RhexParams) -> bool {
    params.leg_armature_kg_m2.is_none() && params.legs_carry_rotors()
}

/// The robot of a leap: `params` (checked as the user gave them, [`RhexParams::validate`])
/// with the leap's two pushing pairs (`pairs`) and its legs' armature ([`leg_armature`]) set.
pub(crate) fn leap_robot_params(
    params: &RhexParams,
    cfg: &LeapConfig,
    pairs: [LegPair; 2],
) -> Result<RhexParams, RhexError> {
    params.validate()?;
    Ok(RhexParams {
        pairs: pairs.to_vec(),
        leg_armature_kg_m2: leap_leg_armature(params, cfg)?,
        leg_rotors: None,
        ..params.clone()
    })
}

/// How a massless leg swings in the air while its motor is on: `(speed, acceleration
/// bound)`. The model's legs have no inertia, so the motion is prescribed (thesis 5.1.1);
/// its bounds are those of the physical leg, which its motor drives: it runs up to the
/// motor's no-load output speed `ω₀/G` (Table 2.1: 10314 rpm at 37 V; 38.6 rad/s at 28:1),
/// accelerating at most at the stall torque over the reflected rotor inertia
/// `n J G²` ([`rotor_reflected_inertia`]) plus the leg's own inertia about the hip. The
/// saturated-torque idealization keeps X-RHex's legs and motors: `τ_s` over the same
/// inertia, and the 28:1 drive's no-load speed. A massive leg's servo follows the same
/// motion. Explicit values in the configuration win.
pub fn leg_swing(params: &RhexParams, cfg: &LeapConfig) -> Result<(f64, f64), RhexError> {
    let d = leg_motor_data(params, cfg)?;
    let leg = leg_inertia_about_hip(params);
    let speed = cfg
        .swing_speed_rad_s
        .unwrap_or(d.no_load_speed_rad_s / d.ratio);
    let accel = cfg
        .swing_accel_rad_s2
        .unwrap_or(d.stall_n_m / (d.reflected_inertia() + leg));
    Ok((speed, accel))
}

/// `d(speed, accel)/dG` of [`leg_swing`] (zero for a value the configuration gives, and
/// for the saturated torque): `speed = ω₀/G` gives `−speed/G`; `accel = τ_st(G)/(nJG² + I)`
/// with `nJG² + I = τ_st/accel` gives `(dτ_st/dG − accel · 2nJG)/(nJG² + I)`, `dτ_st/dG`
/// from the motor law at stall.
fn swing_dgear(
    params: &RhexParams,
    cfg: &LeapConfig,
    law: &MotorLaw,
    speed: f64,
    accel: f64,
) -> [f64; 2] {
    let MotorLaw::Geared { ratio, .. } = *law else {
        return [0.0; 2];
    };
    let dspeed = if cfg.swing_speed_rad_s.is_some() {
        0.0
    } else {
        -speed / ratio
    };
    let daccel = match (cfg.swing_accel_rad_s2, law.partials(1.0, 0.0)) {
        (None, (_, Some(dstall))) => {
            // τ_st = n G η min(τ_stall, τ_limit) (the law at u = 1, ω = 0)
            let stall = match *law {
                MotorLaw::Geared {
                    n,
                    efficiency,
                    stall_n_m,
                    limit_n_m,
                    ..
                } => n * ratio * efficiency * stall_n_m.min(limit_n_m),
                MotorLaw::Saturated => 0.0,
            };
            let total = stall / accel; // nJG² + I
            let n_j_g2 = total - leg_inertia_about_hip(params);
            (dstall - accel * 2.0 * n_j_g2 / ratio) / total
        }
        _ => 0.0,
    };
    [dspeed, daccel]
}

/// What a leg is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Motor not yet on: the leg servo holds its start angle.
    Waiting,
    /// Motor on: saturated push; in the air, the leg swings on in its push direction.
    Pushing,
    /// After takeoff (or, unless it keeps pushing, after its own liftoff): parked pointing
    /// up in the air; on the ground its servo keeps following that motion.
    Retracting,
}

/// The open-loop leap controller of section 3.2 (it remembers the events of its run).
#[derive(Clone)]
pub(crate) struct LeapController {
    sign: [f64; 2],
    pub(crate) start: [f64; 2],
    hold: [f64; 2],
    pub(crate) leg_contact: [usize; 2],
    /// Whether each leg's joint moves only massless links: such a leg in the air is a free
    /// joint whose motion the controller prescribes ([`Controller::free_joint_qdd`]) and
    /// gets no torque; a massive leg in the air is a joint like any other, and its servo
    /// drives it along the same motion with the torque it uses on the ground.
    free_in_air: [bool; 2],
    actuators: [Arc<dyn Actuator>; 2],
    /// The law of the actuators' torque, for the partials.
    law: MotorLaw,
    hold_torque: f64,
    /// The servo's damping per N m of stall torque (s/rad): [`HOLD_KD_S`] on massless legs;
    /// on legs with inertia `I` about the hip (their own and their rotors' armature),
    /// `2 √(k_p I / H)`, which makes the servo `k_p = HOLD_KP_PER_RAD · H` critically damped
    /// on the leg ([`servo_damping`]).
    servo_kd_s: f64,
    /// Whether [`Self::servo_kd_s`] is the critical damping of a leg with inertia.
    servo_critical: bool,
    /// The inertia `I` that damping is critical for (kg m², [`leg_servo_inertia`]) and
    /// `dI/dG`: `2a/G` where the armature `a` is the rotors' `n J G²`
    /// ([`armature_follows_gear`]), else 0.
    servo_inertia: f64,
    dservo_inertia_dgear: f64,
    /// `d start / d t2` of each leg (the execution starts at `min(0, t2)`): `(0, 1)` for
    /// `t2 ≥ 0`, `(−1, 0)` below.
    pub(crate) dstart_dt2: [f64; 2],
    accel: f64,
    speed: f64,
    /// `d(speed, accel)/dG` of the swing ([`leg_swing`], [`swing_dgear`]).
    pub(crate) dswing_dgear: [f64; 2],
    stub: Option<f64>,
    keep_pushing: bool,
    /// Time of the first flight after both legs started (all legs retract from then on).
    takeoff: Option<f64>,
    /// Time each leg first lifted off after its motor started.
    lifted: [Option<f64>; 2],
    /// Each leg's motions in the air, by start time: the swing down from its motor's start,
    /// then a swing from every event that released it while pushing, and its one park.
    air: [Vec<LegMotion>; 2],
    /// For each motion of [`Self::air`], the event it started at, if any: the controller's
    /// memory of that event (the motion's law and the leg's angle and rate there), which
    /// the sensitivities differentiate ([`Controller::memory_partials`]).
    air_start: [Vec<Option<AirStart>>; 2],
    /// How many events the controller has been told of (the number of the next one).
    seen: usize,
    /// Whether each leg touched down again after a motion in the air that started at an
    /// event: from then on a massless leg's memory acts ([`Controller::has_event_memory`]).
    relanded: [bool; 2],
    /// Whether each leg's retraction has its motion in the air: planned once, at the event
    /// that made the leg retract in the air or first released it while retracting; a leg
    /// the ground releases later returns to it (the open-loop controller plans its motions
    /// from its own clock and events, not from contacts it does not sense).
    parked: [bool; 2],
}

/// A leg's motion in the air started at an event: the event's number among those the
/// controller was told of, the motion's law, and the leg's angle and rate after the event.
#[derive(Debug, Clone, Copy)]
struct AirStart {
    event: usize,
    law: StartedLaw,
    theta0: f64,
    omega0: f64,
}

/// Servo gains of a leg (per N m of stall torque).
const HOLD_KP_PER_RAD: f64 = 20.0;
const HOLD_KD_S: f64 = 0.5;
/// Gains (1/s², 1/s) that keep a free leg on its prescribed motion against round-off: a
/// critically damped 20 rad/s servo, idle while the leg is on its motion.
const AIR_KP: f64 = 400.0;
const AIR_KD: f64 = 40.0;

/// The leg servo's damping per N m of stall torque `H` (s/rad), and whether it is the
/// critical damping of a leg with inertia. A leg with inertia `I` about its hip
/// (`I_l + m_l (ρ/2)²` plus its joint's armature, the leg's `M̄_jj`) gets critical damping
/// for the servo's stiffness `k_p = HOLD_KP_PER_RAD · H`: `k_d = 2 √(k_p I)`, i.e.
/// `2 √(k_p I / H)` per N m, so that the servo tracks with one double pole at `√(k_p / I)`
/// (217 rad/s for Table 4.2's leg with its rotors at 28:1 and 20 A): the textbook design of a
/// position servo for the inertia it moves. [`HOLD_KD_S`] per N m was chosen for massless
/// legs, whose servo acts only through the contact's statics (no inertia to damp); on a leg
/// with inertia it is an overdamped servo (`ζ = 2.7` with the rotors, poles at 41 and
/// 1140 /s; `ζ = 7.2` on the bare leg, pole at 8400 /s) whose fast pole only makes the
/// flow stiff. The stiffness, which sets the angle error at which the servo saturates
/// (`1/HOLD_KP_PER_RAD` rad), is the same for every leg. Massless legs keep [`HOLD_KD_S`].
fn servo_damping(params: &RhexParams, hold_torque: f64) -> (f64, bool) {
    let inertia = leg_servo_inertia(params);
    if inertia > 0.0 && hold_torque > 0.0 {
        (2.0 * (HOLD_KP_PER_RAD * inertia / hold_torque).sqrt(), true)
    } else {
        (HOLD_KD_S, false)
    }
}

/// A leg's inertia about its hip with its joint's armature (the leg's `M̄_jj`), which the
/// servo is critically damped for ([`servo_damping`]).
fn leg_servo_inertia(params: &RhexParams) -> f64 {
    leg_inertia_about_hip(params) + params.leg_armature_kg_m2.unwrap_or(0.0)
}

impl LeapController {
    /// Whether leg `i`, when not pushing, is driven by its servo in `mode`: on the ground
    /// always, in the air when it is massive (a massless leg in the air is a free joint
    /// whose motion is prescribed instead).
    fn servoed(&self, i: usize, mode: ContactMode) -> bool {
        !self.free_in_air[i] || mode.contains(self.leg_contact[i])
    }

    fn phase(&self, i: usize, t: f64) -> Phase {
        if t < self.start[i] {
            Phase::Waiting
        } else if self.takeoff.is_some_and(|t0| t >= t0)
            || (!self.keep_pushing && self.lifted[i].is_some_and(|t0| t >= t0))
        {
            Phase::Retracting
        } else {
            Phase::Pushing
        }
    }

    /// Where a leg parks in the air: pointing up, a little past vertical, on the side of
    /// straight down that it is on (a leg never sweeps through the ground to park).
    fn stow(&self, i: usize, theta: f64) -> f64 {
        let side = if self.sign[i] * theta >= 0.0 {
            self.sign[i]
        } else {
            -self.sign[i]
        };
        side * STOW_RAD
    }

    /// The leg servo's torque toward angle `theta` and rate `omega`: a PD law saturating at
    /// the motor's stall torque (an ideal torque source, as for a waiting leg's hold). A
    /// waiting leg holds its start angle with it; a retracting leg that meets the ground
    /// keeps following its motion in the air with it, pushing back as a servoed leg does (a
    /// limp massless leg would be released at once and driven back into the ground by that
    /// motion, touching down again and again).
    fn servo(&self, q: f64, qd: f64, theta: f64, omega: f64) -> f64 {
        (-HOLD_KP_PER_RAD * self.hold_torque * (q - theta)
            - self.servo_kd_s * self.hold_torque * (qd - omega))
            .clamp(-self.hold_torque, self.hold_torque)
    }

    /// The motion of leg `i` in the air at `t`: the last one started by then.
    fn air_motion(&self, i: usize, t: f64) -> (f64, f64, f64) {
        self.air_motion_at(i, t).1.eval(t)
    }

    /// [`Self::air_motion`]'s motion and its index (0: the swing down that starts with the
    /// leg's motor).
    fn air_motion_at(&self, i: usize, t: f64) -> (usize, &LegMotion) {
        let motions = &self.air[i];
        motions
            .iter()
            .enumerate()
            .rev()
            .find(|(_, m)| m.t0() <= t)
            .or(motions.first().map(|m| (0, m)))
            .expect("every leg has its swing down")
    }

    /// `∂(θ, θ̇, θ̈)/∂t2` of leg `i`'s motion in the air at `t`: the swing down starts with
    /// the motor, `∂/∂t0 = −(θ̇, θ̈, d³θ/dt³)`; a motion started at an event depends on `t2`
    /// only through that event's time and state, the controller's memory
    /// ([`Controller::memory_partials`]): no partial here.
    fn air_motion_dt2(&self, i: usize, t: f64) -> (f64, f64, f64) {
        let (k, m) = self.air_motion_at(i, t);
        if k != 0 || self.dstart_dt2[i] == 0.0 || t < m.t0() {
            return (0.0, 0.0, 0.0);
        }
        let (_, w, a) = m.eval(t);
        let d = self.dstart_dt2[i];
        (-w * d, -a * d, -m.jerk(t) * d)
    }

    /// `∂(θ, θ̇, θ̈)/∂G` of leg `i`'s motion in the air at `t`: every motion's speed and
    /// acceleration bounds depend on the gear ratio ([`leg_swing`]), differentiated by the
    /// motion's law ([`StartedLaw::partials_with_bounds`], the same branches: ramps or a
    /// quintic park) — the swing down's from rest at the hold angle, a motion started at an
    /// event's from the leg's state there (whose dependence on that state is the
    /// controller's memory, [`Controller::memory_partials`]).
    fn air_motion_dgear(&self, i: usize, t: f64) -> (f64, f64, f64) {
        let (k, m) = self.air_motion_at(i, t);
        if t < m.t0() || self.dswing_dgear == [0.0; 2] {
            return (0.0, 0.0, 0.0);
        }
        let (law, theta0, omega0) = match self.air_start[i][k] {
            Some(start) => (start.law, start.theta0, start.omega0),
            None => (
                StartedLaw::Swing {
                    target: self.sign[i] * STOW_RAD,
                    speed: self.speed,
                    accel: self.accel,
                },
                self.hold[i],
                0.0,
            ),
        };
        let p = law.partials_with_bounds(m, theta0, omega0, t);
        let [ds, da] = self.dswing_dgear;
        let along = |row: [f64; 5]| row[3] * ds + row[4] * da;
        (along(p[0]), along(p[1]), along(p[2]))
    }

    /// The servo's command per N m of its saturation torque `H` ([`Self::servo`] is `H` times
    /// it, clamped to `±H`).
    fn servo_raw(&self, q: f64, qd: f64, theta: f64, omega: f64) -> f64 {
        -HOLD_KP_PER_RAD * (q - theta) - self.servo_kd_s * (qd - omega)
    }

    /// Whether the servo is in its linear range at command `raw` ([`Self::servo_raw`]): the
    /// branch of its partials and its piece (a value exactly at the limit counts as
    /// saturated).
    fn servo_linear(&self, raw: f64) -> bool {
        (raw * self.hold_torque).abs() < self.hold_torque
    }

    /// The servo's partials `(∂/∂q, ∂/∂q̇, ∂/∂θ, ∂/∂ω, ∂/∂H, ∂/∂I)` at its arguments, `I`
    /// the inertia its damping is critical for: the active branch of the clamp (zero inside
    /// the saturation but for `±∂/∂H`).
    fn servo_partials(&self, q: f64, qd: f64, theta: f64, omega: f64) -> [f64; 6] {
        let h = self.hold_torque;
        let raw = self.servo_raw(q, qd, theta, omega);
        if self.servo_linear(raw) {
            let (kp, kd) = (HOLD_KP_PER_RAD * h, self.servo_kd_s * h);
            // d(kd H)/dH: kd H = 2 √(k_p H I) on a leg with inertia (half of kd), kd H = 0.5 H
            // on a massless one
            let dkd_dh = if self.servo_critical {
                0.5 * self.servo_kd_s
            } else {
                self.servo_kd_s
            };
            // d(kd H)/dI = kd H / (2 I) on a leg with inertia; a massless leg's kd is fixed
            let dkd_di = if self.servo_critical {
                0.5 * kd / self.servo_inertia
            } else {
                0.0
            };
            [
                -kp,
                -kd,
                kp,
                kd,
                -HOLD_KP_PER_RAD * (q - theta) - dkd_dh * (qd - omega),
                -dkd_di * (qd - omega),
            ]
        } else {
            [0.0, 0.0, 0.0, 0.0, raw.signum(), 0.0]
        }
    }

    /// `dH/dG` of the hold torque `H = n G η min(τ_st, k_M I_max)` (0 for the saturated
    /// torque).
    fn dhold_dgear(&self) -> f64 {
        match self.law {
            MotorLaw::Geared { ratio, .. } => self.hold_torque / ratio,
            MotorLaw::Saturated => 0.0,
        }
    }

    /// The servo target of leg `i` at `t` in `phase` (waiting: its hold angle).
    fn servo_target(&self, i: usize, t: f64, phase: Phase) -> (f64, f64) {
        match phase {
            Phase::Waiting => (self.hold[i], 0.0),
            _ => {
                let (theta, omega, _) = self.air_motion(i, t);
                (theta, omega)
            }
        }
    }
}

impl Controller for LeapController {
    fn torque(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode, tau: &mut [f64]) {
        for i in 0..2 {
            let s = self.sign[i];
            tau[i] = match self.phase(i, t) {
                Phase::Pushing => {
                    let stubbed = self.stub.is_some_and(|a| s * q[i] > a);
                    let u = if stubbed { -s } else { s };
                    self.actuators[i].joint_torque_n_m(u, qd[i])
                }
                // a massless leg in the air follows its prescribed motion: no torque
                _ if !self.servoed(i, mode) => 0.0,
                Phase::Waiting => self.servo(q[i], qd[i], self.hold[i], 0.0),
                Phase::Retracting => {
                    let (theta, omega, _) = self.air_motion(i, t);
                    self.servo(q[i], qd[i], theta, omega)
                }
            };
        }
    }

    fn free_joint_qdd(&self, t: f64, q: &[f64], qd: &[f64], free: &[usize], out: &mut [f64]) {
        for (slot, &j) in out.iter_mut().zip(free) {
            *slot = if j < 2 {
                let (theta, omega, alpha) = match self.phase(j, t) {
                    Phase::Waiting => (self.hold[j], 0.0, 0.0),
                    Phase::Pushing | Phase::Retracting => self.air_motion(j, t),
                };
                alpha + AIR_KP * (theta - q[j]) + AIR_KD * (omega - qd[j])
            } else {
                0.0
            };
        }
    }

    fn partials(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        mode: ContactMode,
        free: &[usize],
        out: &mut ControllerPartials,
    ) -> bool {
        if self.stub.is_some() {
            // the toe stub reverses the torque at an angle without an event: not covered
            return false;
        }
        for i in 0..2 {
            let phase = self.phase(i, t);
            match phase {
                Phase::Pushing => {
                    let u = self.sign[i];
                    out.dtau_dqd[(i, i)] = self.law.partials_one_sided(u, qd[i]).0;
                }
                _ if !self.servoed(i, mode) => {}
                _ => {
                    let (theta, omega) = self.servo_target(i, t, phase);
                    let d = self.servo_partials(q[i], qd[i], theta, omega);
                    out.dtau_dq[(i, i)] = d[0];
                    out.dtau_dqd[(i, i)] = d[1];
                }
            }
        }
        for (r, &j) in free.iter().enumerate() {
            if j < 2 {
                out.dfree_dq[(r, j)] = -AIR_KP;
                out.dfree_dqd[(r, j)] = -AIR_KD;
            }
        }
        true
    }

    fn parameter_partials(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        mode: ContactMode,
        free: &[usize],
        names: &[&str],
        out: &mut ControllerPartials,
    ) -> bool {
        for (col, name) in names.iter().enumerate() {
            match *name {
                "t2_s" => {
                    for i in 0..2 {
                        let phase = self.phase(i, t);
                        if phase == Phase::Waiting {
                            continue;
                        }
                        let (dth, dw, da) = self.air_motion_dt2(i, t);
                        if phase == Phase::Retracting && self.servoed(i, mode) {
                            let (theta, omega) = self.servo_target(i, t, phase);
                            let d = self.servo_partials(q[i], qd[i], theta, omega);
                            out.dtau_dp[(i, col)] = d[2] * dth + d[3] * dw;
                        }
                        if let Some(r) = free.iter().position(|&j| j == i) {
                            out.dfree_dp[(r, col)] = da + AIR_KP * dth + AIR_KD * dw;
                        }
                    }
                }
                "gear_ratio" => {
                    if self.law == MotorLaw::Saturated {
                        return false;
                    }
                    let dh = self.dhold_dgear();
                    for i in 0..2 {
                        let phase = self.phase(i, t);
                        // the swing down's dependence on G (its speed and acceleration)
                        let (dth, dw, da) = self.air_motion_dgear(i, t);
                        out.dtau_dp[(i, col)] = match phase {
                            Phase::Pushing => {
                                let u = self.sign[i];
                                self.law.partials_one_sided(u, qd[i]).1.unwrap_or(0.0)
                            }
                            _ if !self.servoed(i, mode) => 0.0,
                            _ => {
                                let (theta, omega) = self.servo_target(i, t, phase);
                                let d = self.servo_partials(q[i], qd[i], theta, omega);
                                let moving = phase == Phase::Retracting;
                                d[4] * dh
                                    + d[5] * self.dservo_inertia_dgear
                                    + if moving { d[2] * dth + d[3] * dw } else { 0.0 }
                            }
                        };
                        if phase != Phase::Waiting {
                            if let Some(r) = free.iter().position(|&j| j == i) {
                                out.dfree_dp[(r, col)] = da + AIR_KP * dth + AIR_KD * dw;
                            }
                        }
                    }
                }
                // the legs' armature, through the servo's damping (critical for the leg's
                // inertia with it); the swing's bounds are the rotors' (`leg_swing`), whatever
                // armature is set by hand
                "leg_armature_kg_m2" => {
                    for i in 0..2 {
                        let phase = self.phase(i, t);
                        if phase != Phase::Pushing && self.servoed(i, mode) {
                            let (theta, omega) = self.servo_target(i, t, phase);
                            let d = self.servo_partials(q[i], qd[i], theta, omega);
                            out.dtau_dp[(i, col)] = d[5];
                        }
                    }
                }
                _ => return false,
            }
        }
        true
    }

    /// Each motor's start, and the knots of the swing down that starts with it (its jerk
    /// jumps there, and so does `∂q̈/∂t2`): all move with the start. Then the starts and knots
    /// of the motions started at events (fixed: the controller's memory is not
    /// differentiated). The engine's steps land on all of them.
    fn time_events(&self, names: &[&str]) -> Vec<TimeEvent> {
        let mut out = Vec::new();
        for i in 0..2 {
            let dt_dp: Vec<f64> = names
                .iter()
                .map(|n| {
                    if *n == "t2_s" {
                        self.dstart_dt2[i]
                    } else {
                        0.0
                    }
                })
                .collect();
            let knots = self.air[i]
                .first()
                .map(LegMotion::knots)
                .unwrap_or_default();
            for t in std::iter::once(self.start[i]).chain(knots) {
                out.push(TimeEvent {
                    t,
                    dt_dp: dt_dp.clone(),
                });
            }
            // the motions started at events (they move with the event, the controller's
            // memory, not with a parameter: `dt_b/dp = 0`; their knots do not jump the flow)
            for m in self.air[i].iter().skip(1) {
                for t in std::iter::once(m.t0()).chain(m.knots()) {
                    out.push(TimeEvent {
                        t,
                        dt_dp: vec![0.0; names.len()],
                    });
                }
            }
        }
        out
    }

    fn on_event(&mut self, event: &Event) {
        let both_started = event.t >= self.start[0].max(self.start[1]);
        let took_off = self.takeoff.is_none() && both_started && event.mode_after.is_flight();
        if took_off {
            self.takeoff = Some(event.t);
        }
        for i in 0..2 {
            let c = self.leg_contact[i];
            if event.mode_after.contains(c)
                && !event.mode_before.contains(c)
                && self.air_start[i].iter().any(Option::is_some)
            {
                self.relanded[i] = true;
            }
            let left = event.mode_before.contains(c) && !event.mode_after.contains(c);
            if left && event.t >= self.start[i] && self.lifted[i].is_none() {
                self.lifted[i] = Some(event.t);
            }
            // a leg released here, or made to retract here, starts a new motion in the air
            if event.mode_after.contains(c) || !(left || took_off) || event.t < self.start[i] {
                continue;
            }
            let (theta, omega) = (event.q[i], event.qd_after[i]);
            let law = match self.phase(i, event.t) {
                // a leg that has its retraction keeps it: released by the ground (or at
                // takeoff), it returns to that motion; planned anew from the release, the
                // park would start at rest in acceleration, not at the acceleration the
                // ground imposed, and carry the toe back into the ground (docs/leap-model.md)
                Phase::Retracting if self.parked[i] => continue,
                Phase::Retracting => {
                    self.parked[i] = true;
                    StartedLaw::Park {
                        target: self.stow(i, theta),
                        accel: self.accel,
                    }
                }
                _ => StartedLaw::Swing {
                    target: self.sign[i] * STOW_RAD,
                    speed: self.speed,
                    accel: self.accel,
                },
            };
            let motion = match law {
                StartedLaw::Park { target, accel } => {
                    LegMotion::park(event.t, theta, omega, target, accel)
                }
                StartedLaw::Swing {
                    target,
                    speed,
                    accel,
                } => LegMotion::swing(event.t, theta, omega, target, speed, accel),
            };
            self.air[i].push(motion);
            self.air_start[i].push(Some(AirStart {
                event: self.seen,
                law,
                theta0: theta,
                omega0: omega,
            }));
        }
        self.seen += 1;
    }

    /// A motion in the air started at an event makes the outputs depend on that event's
    /// time and state — on a body that feels them through a leg with inertia, which its servo
    /// drives along the motion, or through a massless leg once it meets the ground again
    /// under the motion (its touchdown's time and its servo in stance follow the motion). A
    /// massless leg's motion that ends in the air acts on nothing, so its memory is carried
    /// only in a run in which such a leg lands again (the sensitivities of the other massless
    /// leaps do not pay for it). The memory is then carried over the whole run (the
    /// sensitivities ask every segment's controller, and the last one knows the landing).
    fn has_event_memory(&self) -> bool {
        (0..2).any(|i| {
            (!self.free_in_air[i] || self.relanded[i])
                && self.air_start[i].iter().any(Option::is_some)
        })
    }

    /// `∂Υ/∂m_k`, `∂q̈_free/∂m_k` of the events whose motions the legs follow at `t`: a free
    /// leg's `q̈ = α* + k_p (θ* − q) + k_d (ω* − q̇)` and a servoed retracting leg's servo
    /// toward `(θ*, ω*)`, with `∂(θ*, ω*, α*)/∂(t_k, θ_k, ω_k)` of the motion's law
    /// ([`StartedLaw::partials`]; `θ_k`, `ω_k` the leg's own entries of `q_k`, `q̇_k⁺`).
    fn memory_partials(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        mode: ContactMode,
        free: &[usize],
        out: &mut Vec<EventMemoryPartials>,
    ) -> bool {
        if self.stub.is_some() {
            return false;
        }
        let nq = q.len();
        for i in 0..2 {
            let phase = self.phase(i, t);
            if phase == Phase::Waiting {
                continue;
            }
            let (k, m) = self.air_motion_at(i, t);
            let Some(start) = self.air_start[i][k] else {
                continue;
            };
            let d = start.law.partials(m, start.theta0, start.omega0, t);
            // the columns of m_k: t_k, then q_k, then q̇_k⁺
            let cols = [0, 1 + i, 1 + nq + i];
            let free_row = free.iter().position(|&j| j == i);
            let servo = phase == Phase::Retracting && self.servoed(i, mode);
            if free_row.is_none() && !servo {
                continue;
            }
            // one entry per event (both legs' motions may start at the same one)
            let e = match out.iter().position(|e| e.event == start.event) {
                Some(e) => e,
                None => {
                    out.push(EventMemoryPartials {
                        event: start.event,
                        dtau: nalgebra::DMatrix::zeros(2, 1 + 2 * nq),
                        dfree: nalgebra::DMatrix::zeros(free.len(), 1 + 2 * nq),
                    });
                    out.len() - 1
                }
            };
            let entry = &mut out[e];
            if let Some(r) = free_row {
                for (c, &col) in cols.iter().enumerate() {
                    entry.dfree[(r, col)] += d[2][c] + AIR_KP * d[0][c] + AIR_KD * d[1][c];
                }
            } else {
                let (theta, omega) = self.servo_target(i, t, phase);
                let s = self.servo_partials(q[i], qd[i], theta, omega);
                for (c, &col) in cols.iter().enumerate() {
                    entry.dtau[(i, col)] += s[2] * d[0][c] + s[3] * d[1][c];
                }
            }
        }
        true
    }

    /// Per leg, two bits: a pushing leg's motor on its torque–speed line (0) or at its
    /// current limit (1); a servoed leg's PD law in its linear range (0) or saturated at
    /// `+H` (1) or `−H` (2); a massless leg in the air (no torque) 0. Its partials switch
    /// exactly there ([`Self::partials`]).
    fn partials_piece(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode) -> u64 {
        let mut out = 0;
        for i in 0..2 {
            let phase = self.phase(i, t);
            let code = match phase {
                Phase::Pushing => u64::from(self.law.on_limit(self.sign[i], qd[i])),
                _ if !self.servoed(i, mode) => 0,
                _ => {
                    let (theta, omega) = self.servo_target(i, t, phase);
                    let raw = self.servo_raw(q[i], qd[i], theta, omega);
                    if self.servo_linear(raw) {
                        0
                    } else if raw > 0.0 {
                        1
                    } else {
                        2
                    }
                }
            };
            out |= code << (2 * i);
        }
        out
    }
}

/// The angle at which leg `i`'s lowest point just reaches the ground with the body at `q`,
/// on the side that `sign` pushes from (`+`: the leg ahead of its hip; `−`: behind), by
/// bisection on the engine's own contact geometry (any leg shape).
fn touchdown_angle(
    rhex: &Rhex,
    terrain: &dyn Terrain,
    q: &[f64],
    i: usize,
    contact: usize,
    sign: f64,
) -> Result<f64, RhexError> {
    let mut kin = Kinematics::default();
    let zero = vec![0.0; q.len()];
    let mut qq = q.to_vec();
    let mut gap = |theta: f64| {
        qq[i] = theta;
        kin.compute(&rhex.model, &qq, &zero);
        selfmanip_core::contact::contact_geometry(&rhex.model, &kin, terrain, contact).gap_m
    };
    // pointing up (clear) .. pointing down (through the ground)
    let (mut clear, mut through) = (-sign * (PI - 1e-9), 0.0);
    if !(gap(clear) > 0.0 && gap(through) < 0.0) {
        return Err(RhexError::Params {
            field: "rho_b".into(),
            reason: "a leg pointing straight down must reach the ground from the sitting posture"
                .into(),
        });
    }
    for _ in 0..200 {
        let mid = 0.5 * (clear + through);
        if gap(mid) > 0.0 {
            clear = mid;
        } else {
            through = mid;
        }
        if (clear - through).abs() < 1e-15 {
            break;
        }
    }
    Ok(clear)
}

/// The ground-reaction-complex cells visited (sliding toes count as contact), with cells
/// held for no longer than `min_duration_s` suppressed and repeats merged.
fn leap_word(rhex: &Rhex, exec: &Execution, min_duration_s: f64) -> Vec<String> {
    let mut word: Vec<String> = Vec::new();
    for (n, seg) in exec.segments.iter().enumerate() {
        let last = n + 1 == exec.segments.len();
        if seg.t1 - seg.t0 <= min_duration_s && n > 0 && !last {
            continue;
        }
        let cell = rhex.label(seg.mode).replace('s', "1");
        if word.last() != Some(&cell) {
            word.push(cell);
        }
    }
    word
}

/// Everything a leap is built from: the robot with its two pushing pairs, the terrain, the
/// start state and the controller (fresh, without history).
pub(crate) struct LeapSetup {
    pub(crate) rhex: Rhex,
    pub(crate) terrain: TerrainSpec,
    pub(crate) q0: Vec<f64>,
    pub(crate) ctrl: LeapController,
    /// The rear motor's start after the front one's (s).
    pub(crate) motor_t2_s: f64,
}

impl LeapSetup {
    /// The leap of `cfg` with the rear motor starting `motor_t2_s` after the front one.
    pub(crate) fn new(
        params: &RhexParams,
        cfg: &LeapConfig,
        motor_t2_s: f64,
    ) -> Result<Self, RhexError> {
        cfg.validate()?;
        let pairs = cfg.pairs.unwrap_or(cfg.strategy.chapter3_pairs());
        if pairs[0] == pairs[1] {
            return Err(RhexError::Params {
                field: "pairs".into(),
                reason: "a leap strategy drives two different leg pairs".into(),
            });
        }
        // dI/dG of the legs' inertia: their armature's where it is their rotors' n J G²
        let dservo_inertia_dgear = match cfg.actuator {
            LegActuator::GearedMotor { gear_ratio, .. } if armature_follows_gear(params) => {
                2.0 * leg_armature(params, cfg)? / gear_ratio
            }
            _ => 0.0,
        };
        // the leap's two pairs, and the rotors of massive legs as their joints' armature
        let params = leap_robot_params(params, cfg, pairs)?;
        let terrain = cfg.terrain;
        let sign = [cfg.strategy.front.sign(), cfg.strategy.rear.sign()];
        // the robot and its start posture depend only on these (a sweep over t2 builds the
        // same ones for every leap): built once, then cloned (`StartCache`)
        let key = format!(
            "{params:?}|{terrain:?}|{sign:?}|{:?}",
            cfg.wait_clearance_rad
        );
        let cached = START_CACHE.get(&key);
        let rhex = match &cached {
            Some(start) => start.0.clone(),
            None => Rhex::new(params.clone())?,
        };
        if let TerrainSpec::Ledge { distance_m, .. } = terrain {
            // the face must be clear of everything the robot can reach at the start: a
            // body end, or a leg turned straight towards it
            let side = distance_m.signum();
            let reach = params
                .ordered_pairs()
                .iter()
                .map(|&p| side * params.hip_x(p) + params.rho(p))
                .fold(
                    if side > 0.0 { params.l1 } else { params.l2 } + params.rho_b,
                    f64::max,
                );
            if distance_m.abs() <= reach {
                return Err(RhexError::Params {
                    field: "terrain.distance_m".into(),
                    reason: format!(
                        "the ledge's face must be beyond the robot's reach at the start \
                         ({reach:.3} m {} the body centre), got {distance_m}",
                        if side > 0.0 { "ahead of" } else { "behind" }
                    ),
                });
            }
        }
        let leg_contact = [rhex.site(1), rhex.site(3)];
        let q0 = match cached {
            Some(start) => start.1.clone(),
            None => {
                // sitting level on both body ends, each leg at its touchdown angle
                let mut q0 = vec![0.0, 0.0, 0.0, -params.rho_b, 0.0];
                for i in 0..2 {
                    // waiting legs are held raised above their touchdown angle, clear of the
                    // ground while the body moves on the other leg; each swings down when its
                    // motor starts
                    q0[i] = touchdown_angle(&rhex, &terrain, &q0, i, leg_contact[i], sign[i])?
                        - sign[i] * cfg.wait_clearance_rad;
                }
                START_CACHE.insert(key, Arc::new((rhex.clone(), q0.clone())));
                q0
            }
        };
        // execution time starts at min(0, t2)
        let offset = motor_t2_s.min(0.0);
        let (front, law) = leg_motor(&params, &cfg.actuator)?;
        let actuators = [front, leg_actuator(&params, &cfg.actuator)?];
        let hold_torque = actuators[0].joint_torque_n_m(1.0, 0.0);
        let start = [-offset, motor_t2_s - offset];
        let (speed, accel) = leg_swing(&params, cfg)?;
        let (servo_kd_s, servo_critical) = servo_damping(&params, hold_torque);
        let ctrl = LeapController {
            sign,
            start,
            hold: [q0[0], q0[1]],
            leg_contact,
            free_in_air: [0, 1].map(|i| rhex.model.distal_massless(i)),
            actuators,
            law,
            hold_torque,
            servo_kd_s,
            servo_critical,
            servo_inertia: leg_servo_inertia(&params),
            dservo_inertia_dgear,
            dstart_dt2: if motor_t2_s >= 0.0 {
                [0.0, 1.0]
            } else {
                [-1.0, 0.0]
            },
            accel,
            speed,
            dswing_dgear: swing_dgear(&params, cfg, &law, speed, accel),
            stub: cfg.toe_stub_rad,
            keep_pushing: cfg.keep_pushing_after_liftoff,
            takeoff: None,
            lifted: [None, None],
            parked: [false, false],
            // each leg swings down from rest at its hold angle when its motor starts, towards
            // pointing up in its push direction: it touches the ground on the way
            air: std::array::from_fn(|i| {
                vec![LegMotion::swing(
                    start[i],
                    q0[i],
                    0.0,
                    sign[i] * STOW_RAD,
                    speed,
                    accel,
                )]
            }),
            // the swing down starts with the motor, not at an event
            air_start: [vec![None], vec![None]],
            seen: 0,
            relanded: [false; 2],
        };
        Ok(LeapSetup {
            rhex,
            terrain,
            q0,
            ctrl,
            motor_t2_s,
        })
    }
}

/// The robots and start postures [`LeapSetup::new`] built last, keyed by the `Debug` text of
/// everything they depend on (the parameters with the pushing pairs, the terrain, the push
/// signs and the wait clearance; `Debug` writes every `f64` so that it reads back to the
/// same bits, `-0.0` included, so equal keys mean bit-equal inputs). A cached value is what
/// a fresh build would give, so results do not depend on what other leaps, on any thread,
/// ran before; builds that fail are not cached.
struct StartCache(std::sync::Mutex<Vec<(String, Start)>>);

/// A [`StartCache`] entry: the robot and its start posture `q0`.
type Start = Arc<(Rhex, Vec<f64>)>;

/// The entries [`StartCache`] keeps (the oldest is dropped first).
const START_CACHE_ENTRIES: usize = 16;

/// The process-wide [`StartCache`] (shared by every thread of a sweep).
static START_CACHE: StartCache = StartCache(std::sync::Mutex::new(Vec::new()));

impl StartCache {
    fn get(&self, key: &str) -> Option<Start> {
        let entries = self.0.lock().ok()?;
        entries
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| Arc::clone(v))
    }

    fn insert(&self, key: String, value: Start) {
        let Ok(mut entries) = self.0.lock() else {
            return;
        };
        if entries.iter().any(|(k, _)| *k == key) {
            return;
        }
        if entries.len() >= START_CACHE_ENTRIES {
            entries.remove(0);
        }
        entries.push((key, value));
    }
}

/// Where a parked leg points: up, a little past vertical in its push direction (rad).
const STOW_RAD: f64 = 2.6;

/// Round-off of a kinetic energy evaluated twice (`½ q̇ᵀ M̄ q̇` at the two velocities of one
/// projection), relative to the energy, and its floor (J): an event's loss within
/// `ENERGY_ROUND_OFF · (T⁻ + 1 J)` is reported as zero.
pub const ENERGY_ROUND_OFF: f64 = 1e-12;

/// The kinetic energy an event lost, `T⁻ − T⁺`, with round-off ([`ENERGY_ROUND_OFF`])
/// reported as zero: a zero-speed touchdown loses nothing, and its computed loss is a few
/// 1e-13 J of either sign.
fn energy_loss(before: f64, after: f64) -> f64 {
    let loss = before - after;
    if loss.abs() <= ENERGY_ROUND_OFF * (before.abs() + 1.0) {
        0.0
    } else {
        loss
    }
}

/// Runs one leap (see the module documentation) and reports its apex and word.
///
/// Errors are bad parameters (typed, naming the field) and failures of the engine that
/// prevent any answer; a leap that runs but does not reach flight, or ends Zeno, is an `Ok`
/// result with the corresponding [`LeapStatus`].
pub fn simulate_leap(params: &RhexParams, cfg: &LeapConfig) -> Result<LeapResult, RhexError> {
    simulate_leap_with(params, cfg, &selfmanip_hybrid::budget::NEVER)
}

/// [`simulate_leap`] that another thread can stop: once `stop` is raised the leap ends
/// within one integration step with status [`LeapStatus::Interrupted`].
pub fn simulate_leap_with(
    params: &RhexParams,
    cfg: &LeapConfig,
    stop: &AtomicBool,
) -> Result<LeapResult, RhexError> {
    match cfg.t2_reference {
        T2Reference::MotorStart => run_leap(params, cfg, cfg.t2_s, stop),
        T2Reference::Touchdown => touchdown_timed_leap(params, cfg, stop),
    }
}

/// [`T2Reference::Touchdown`]: a secant search on the rear motor's start `s` for the
/// touchdown offset `T(s) = t2` (`T(s) = s` while the body is at rest between the two
/// touchdowns, so the search starts there and usually ends after one or two more runs).
fn touchdown_timed_leap(
    params: &RhexParams,
    cfg: &LeapConfig,
    stop: &AtomicBool,
) -> Result<LeapResult, RhexError> {
    let target = cfg.t2_s;
    let mut s0 = target;
    let mut r0 = run_leap(params, cfg, s0, stop)?;
    let Some(mut d0) = r0.touchdown_t2_s.map(|t| t - target) else {
        return Ok(r0);
    };
    let mut s1 = s0 - d0;
    for _ in 1..TOUCHDOWN_SEARCH_RUNS {
        if d0.abs() <= TOUCHDOWN_SEARCH_TOL_S || s1.abs() >= cfg.t_final_s {
            break;
        }
        let r1 = run_leap(params, cfg, s1, stop)?;
        let Some(d1) = r1.touchdown_t2_s.map(|t| t - target) else {
            break;
        };
        let better = d1.abs() < d0.abs();
        let slope = (d1 - d0) / (s1 - s0);
        let next = if slope.is_finite() && slope.abs() > 1e-6 {
            s1 - d1 / slope
        } else {
            s1 - d1
        };
        (s0, d0) = (s1, d1);
        if better {
            r0 = r1;
        }
        s1 = next;
    }
    Ok(r0)
}

/// One leap with the rear motor starting `motor_t2_s` after the front one.
fn run_leap(
    params: &RhexParams,
    cfg: &LeapConfig,
    motor_t2_s: f64,
    stop: &AtomicBool,
) -> Result<LeapResult, RhexError> {
    let setup = LeapSetup::new(params, cfg, motor_t2_s)?;
    run_leap_setup(&setup, cfg, stop, None)
}

/// Runs the leap `setup` describes, from its start state or (`start_offset`, `2nq` entries)
/// from that state plus an offset (which must keep the start on its contact constraints).
pub(crate) fn run_leap_setup(
    setup: &LeapSetup,
    cfg: &LeapConfig,
    stop: &AtomicBool,
    start_offset: Option<&[f64]>,
) -> Result<LeapResult, RhexError> {
    let (rhex, terrain, ctrl, q0, start) = (
        &setup.rhex,
        setup.terrain,
        &setup.ctrl,
        &setup.q0,
        setup.ctrl.start,
    );
    let model = &rhex.model;
    let offset = -setup.ctrl.start[0];
    let mut qd0 = vec![0.0; q0.len()];
    let mut q_start = q0.clone();
    if let Some(dx) = start_offset {
        let nq = q0.len();
        if dx.len() != 2 * nq {
            return Err(RhexError::Params {
                field: "start_offset".into(),
                reason: format!("expected {} entries, got {}", 2 * nq, dx.len()),
            });
        }
        for i in 0..nq {
            q_start[i] += dx[i];
            qd0[i] += dx[nq + i];
        }
    }
    let opts = HybridOptions {
        event_tol_s: cfg.event_tol_s,
        delta_t_s: cfg.delta_t_s,
        zeno_window_s: cfg.zeno_window_s,
        zeno_max_events: cfg.zeno_max_events,
        max_steps: cfg.max_steps,
        max_events: cfg.max_events,
        stop_at_apex: cfg.stop_at_apex,
        control_free_joints: cfg.control_free_joints,
        step: StepOptions {
            rtol: cfg.rtol,
            atol: cfg.rtol * 1e-2,
            ..StepOptions::default()
        },
        ..HybridOptions::default()
    };
    let mut mode0 = rhex.mode("1010")?;
    let body_friction = model
        .contacts
        .iter()
        .any(|c| c.link.is_none() && c.kinetic_mu > 0.0);
    if let (true, Ok(rear)) = (body_friction, model.contact_index("rear_body")) {
        if mode0.kind(rear) == Some(selfmanip_core::ContactKind::Stick) {
            // Coulomb body ends (`RhexParams::mu_body`): the rear one starts sliding (both
            // sticking is statically indeterminate)
            mode0 = mode0.with(rear, selfmanip_core::ContactKind::Slide);
        }
    }
    let exec = simulate_with(
        model,
        &terrain,
        ctrl,
        mode0,
        &q_start,
        &qd0,
        cfg.t_final_s - offset,
        opts,
        stop,
    )?;
    let flew = exec
        .segments
        .iter()
        .any(|s| s.mode.is_flight() && s.t0 >= start[0].min(start[1]));
    let status = match exec.termination {
        Termination::Apex => LeapStatus::Ok,
        Termination::FinalTime if flew && !cfg.stop_at_apex => LeapStatus::Ok,
        Termination::FinalTime => LeapStatus::NoFlight,
        Termination::Zeno { .. } | Termination::Chatter { .. } => LeapStatus::Zeno,
        Termination::EventBudget => LeapStatus::EventBudget,
        Termination::NoContactSolution { .. } => LeapStatus::NoContactSolution,
        Termination::SeveralContactSolutions { .. } => LeapStatus::SeveralContactSolutions,
        Termination::TerrainDiscontinuity { .. } => LeapStatus::TerrainEdge,
        Termination::SingularFlow { .. } | Termination::Painleve { .. } => {
            LeapStatus::SingularContact
        }
        Termination::StepBudget { .. } => LeapStatus::StepBudget,
        Termination::Interrupted { .. } => LeapStatus::Interrupted,
    };
    // the apex that ended the run, or (run on past it) that of its first flight after a
    // motor started
    let apex_event = match exec.termination {
        Termination::Apex => exec.events.last(),
        _ if !cfg.stop_at_apex => exec
            .events
            .iter()
            .find(|e| e.kind == EventKind::Apex && e.t >= start[0].min(start[1])),
        _ => None,
    };
    let apex = apex_event.map(|e| Apex {
        t_s: e.t - start[0],
        x_m: e.q[2] - q0[2],
        z_m: -e.q[3],
        phi_rad: e.q[4],
        xdot_m_s: e.qd_after[2],
        zdot_m_s: -e.qd_after[3],
        phidot_rad_s: e.qd_after[4],
    });
    // cells that last no longer than the events' location can resolve are zero-time cells;
    // never more than 0.1 ms (a coarse event tolerance does not hide real cells)
    let word = leap_word(rhex, &exec, (1e3 * cfg.event_tol_s).min(1e-4));
    let names = |ks: &[usize]| ks.iter().map(|&k| model.contacts[k].name.clone()).collect();
    let events = exec
        .events
        .iter()
        .map(|e| LeapEvent {
            t_s: e.t - start[0],
            kind: e.kind.name(),
            mode_before: rhex.label(e.mode_before),
            mode_after: rhex.label(e.mode_after),
            contacts: names(&e.triggered),
            energy_loss_j: if matches!(
                e.kind,
                EventKind::Touchdown | EventKind::Fold | EventKind::Jam
            ) {
                energy_loss(e.kinetic_before, e.kinetic_after)
            } else {
                0.0
            },
        })
        .collect();
    // the touchdown offset: each pushing leg's first touchdown after its motor started
    let first_touchdown = |i: usize| {
        exec.events
            .iter()
            .find(|e| {
                e.kind == EventKind::Touchdown
                    && e.t >= start[i]
                    && e.triggered.contains(&ctrl.leg_contact[i])
            })
            .map(|e| e.t)
    };
    let touchdown_t2_s = first_touchdown(0)
        .zip(first_touchdown(1))
        .map(|(front, rear)| rear - front);
    Ok(LeapResult {
        status,
        apex,
        word,
        execution: exec,
        time_offset_s: start[0],
        q0: q0.clone(),
        events,
        motor_t2_s: setup.motor_t2_s,
        touchdown_t2_s,
    })
}

impl LeapResult {
    /// Why the leap ended short of `ok`, in words (empty for `ok`): the engine's
    /// [`Termination::describe`] on the leap's clock (t = 0 at the first motor's start) with
    /// the leap's contact names and the flowing mode's label (`s` for a sliding toe); a run
    /// that ended at its final time says it found no flight (or no apex).
    pub fn reason(&self, params: &RhexParams, cfg: &LeapConfig) -> String {
        if self.status == LeapStatus::Ok {
            return String::new();
        }
        if self.execution.termination == Termination::FinalTime {
            return format!(
                "no flight reached{} before t_final_s = {} s",
                if cfg.stop_at_apex { " its apex" } else { "" },
                cfg.t_final_s
            );
        }
        // the mode that was flowing: the last event's, or the start's
        let mode = self
            .events
            .last()
            .map_or_else(|| "1010".to_string(), |e| e.mode_after.clone());
        // a contact's name builds the robot: only a termination that names one asks for it
        let name = |k: usize| {
            Rhex::new(params.clone())
                .ok()
                .and_then(|r| r.model.contacts.get(k).map(|c| c.name.clone()))
                .unwrap_or_else(|| format!("#{k}"))
        };
        self.execution.termination.describe(
            &|t| format!("t = {:.6} s", t - self.time_offset_s),
            &name,
            Some(&mode),
        )
    }

    /// Energy bookkeeping of the leap (motor work, impact losses, start and end energy),
    /// each segment re-evaluated with the controller it ran with.
    pub fn energy_report(
        &self,
        params: &RhexParams,
        cfg: &LeapConfig,
    ) -> Result<selfmanip_hybrid::EnergyReport, RhexError> {
        let setup = LeapSetup::new(params, cfg, self.motor_t2_s)?;
        Ok(selfmanip_hybrid::energy_report(
            &setup.rhex.model,
            &setup.terrain,
            &self.execution,
        )?)
    }

    /// Work of the toes' kinetic friction along the leap (J, never positive): the engine's
    /// [`EnergyReport::friction_work_j`](selfmanip_hybrid::EnergyReport), `∫ f^frᵀ q̇ dt`
    /// with `f^fr` the generalized friction force of the sliding toes
    /// (`selfmanip_core::friction`), each segment re-evaluated as it ran. The energy
    /// balances: `E₁ − E₀ = W + W_fr − L` ([`Self::energy_report`]).
    pub fn friction_work_j(&self, params: &RhexParams, cfg: &LeapConfig) -> Result<f64, RhexError> {
        Ok(self.energy_report(params, cfg)?.friction_work_j)
    }

    /// Samples the leap every `dt_s` seconds (and at its end) with the generic sampler
    /// ([`selfmanip_sim::trajectory::sample_labelled`]): states, torques, modes in RHex's
    /// labels, contact points and contact forces, each from its segment's flow as it ran;
    /// times from the front leg's start.
    pub fn trajectory(
        &self,
        params: &RhexParams,
        cfg: &LeapConfig,
        dt_s: f64,
    ) -> Result<Trajectory, RhexError> {
        let setup = LeapSetup::new(params, cfg, self.motor_t2_s)?;
        Ok(selfmanip_sim::trajectory::sample_labelled(
            &setup.rhex.model,
            &setup.terrain,
            &self.execution,
            &|m| setup.rhex.label(m),
            dt_s,
            self.time_offset_s,
        )?)
    }
}

#[cfg(test)]
mod start_cache_tests {
    use super::*;

    /// The gap of leg `i`'s toe with that leg turned to `theta` from `q0` (m).
    fn gap(setup: &LeapSetup, i: usize, theta: f64) -> f64 {
        let mut q = setup.q0.clone();
        q[i] = theta;
        let mut kin = Kinematics::default();
        kin.compute(&setup.rhex.model, &q, &vec![0.0; q.len()]);
        let contact = setup.ctrl.leg_contact[i];
        selfmanip_core::contact::contact_geometry(&setup.rhex.model, &kin, &setup.terrain, contact)
            .gap_m
    }

    /// A setup built from the cache is bit-identical to the first build, its waiting legs
    /// are held the clearance above the angle where the toe touches the ground (gap zero,
    /// checked on the kinematics directly), and a different clearance or terrain is not
    /// served the cached posture.
    #[test]
    fn cached_start_is_the_fresh_one_and_keys_tell_inputs_apart() {
        let params = leap_params();
        // a clearance no other test uses: the first build is a miss
        let cfg = LeapConfig {
            wait_clearance_rad: 0.731_234,
            ..LeapConfig::default()
        };
        let first = LeapSetup::new(&params, &cfg, 0.0).unwrap();
        let second = LeapSetup::new(&params, &cfg, 0.0).unwrap();
        let bits = |q: &[f64]| q.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&first.q0), bits(&second.q0));
        assert_eq!(first.rhex.params, second.rhex.params);
        assert_eq!(first.rhex.model, second.rhex.model);
        for (i, sign) in first.ctrl.sign.iter().enumerate() {
            let touchdown = first.q0[i] + sign * cfg.wait_clearance_rad;
            assert!(gap(&first, i, touchdown).abs() < 1e-12, "leg {i}");
            assert!(gap(&first, i, first.q0[i]) > 1e-3, "leg {i} waits clear");
        }
        // another clearance: the same touchdown angles, held differently
        let other = LeapConfig {
            wait_clearance_rad: 0.5,
            ..cfg.clone()
        };
        let moved = LeapSetup::new(&params, &other, 0.0).unwrap();
        for (i, sign) in first.ctrl.sign.iter().enumerate() {
            let shift = moved.q0[i] - first.q0[i];
            assert!(
                (shift - sign * (0.731_234 - 0.5)).abs() < 1e-14,
                "leg {i}: {shift}"
            );
        }
        // another terrain: a 0.05 rad incline under the robot changes the touchdown angles
        let lower = LeapConfig {
            terrain: TerrainSpec::Incline { slope_rad: 0.05 },
            ..cfg.clone()
        };
        let low = LeapSetup::new(&params, &lower, 0.0).unwrap();
        assert!(low.q0.iter().zip(&first.q0).any(|(a, b)| a != b));
        for (i, sign) in low.ctrl.sign.iter().enumerate() {
            let touchdown = low.q0[i] + sign * cfg.wait_clearance_rad;
            assert!(
                gap(&low, i, touchdown).abs() < 1e-12,
                "leg {i} on the incline"
            );
        }
    }
}

#[cfg(test)]
mod servo_tests {
    use super::*;

    fn massive() -> RhexParams {
        RhexParams {
            m_l: 0.126,
            I_l: 0.00092,
            ..leap_params()
        }
    }

    /// A massive leg's servo is critically damped on the leg's inertia about its hip as the
    /// core's `M̄` has it (the joint's diagonal entry: the leg's own inertia about the hip
    /// plus its rotors' armature, `n J G²`), at the same stiffness per N m as a massless
    /// leg's, which keeps [`HOLD_KD_S`].
    #[test]
    fn a_massive_legs_servo_is_critically_damped_on_its_mass_matrix_entry() {
        let cfg = LeapConfig::default();
        let setup = LeapSetup::new(&massive(), &cfg, 0.0).unwrap();
        let model = &setup.rhex.model;
        let mut data = selfmanip_core::Data::new(model);
        let zeros = vec![0.0; model.nq()];
        selfmanip_core::energy(model, &mut data, &setup.q0, &zeros).unwrap();
        let a = rotor_reflected_inertia(&massive(), &cfg).unwrap();
        for i in 0..2 {
            assert_eq!(model.joints[i].armature_kg_m2, a);
            let inertia = data.m_bar[(i, i)];
            let h = setup.ctrl.hold_torque;
            let (kp, kd) = (HOLD_KP_PER_RAD * h, setup.ctrl.servo_kd_s * h);
            let zeta = kd / (2.0 * (kp * inertia).sqrt());
            assert!((zeta - 1.0).abs() < 1e-12, "leg {i}: ζ = {zeta}");
        }
        assert!(setup.ctrl.servo_critical);
        let massless = LeapSetup::new(&leap_params(), &cfg, 0.0).unwrap();
        assert!(!massless.ctrl.servo_critical);
        assert_eq!(massless.ctrl.servo_kd_s, HOLD_KD_S);
    }

    /// The servo's partials against central differences of its torque, `∂/∂H` through both
    /// gains (the critical damping `2 √(k_p I)` moves with `H` as `√H`) and `∂/∂I` through the
    /// damping (as `√I`; none on a massless leg, whose damping is fixed), inside the clamp.
    #[test]
    fn servo_partials_match_central_differences() {
        for params in [leap_params(), massive()] {
            let setup = LeapSetup::new(&params, &LeapConfig::default(), 0.0).unwrap();
            let ctrl = &setup.ctrl;
            let (q, qd, theta, omega) = (0.31, -0.4, 0.3, 0.2);
            let d = ctrl.servo_partials(q, qd, theta, omega);
            let raw = ctrl.servo(q, qd, theta, omega);
            assert!(raw.abs() < ctrl.hold_torque, "inside the clamp: {raw}");
            let e = 1e-6;
            let fd = |f: &dyn Fn(f64) -> f64| (f(e) - f(-e)) / (2.0 * e);
            let num = [
                fd(&|s| ctrl.servo(q + s, qd, theta, omega)),
                fd(&|s| ctrl.servo(q, qd + s, theta, omega)),
                fd(&|s| ctrl.servo(q, qd, theta + s, omega)),
                fd(&|s| ctrl.servo(q, qd, theta, omega + s)),
                fd(&|s| {
                    let mut c = ctrl.clone();
                    c.hold_torque += s;
                    c.servo_kd_s = servo_damping(&setup.rhex.params, c.hold_torque).0;
                    c.servo(q, qd, theta, omega)
                }),
                if ctrl.servo_critical {
                    fd(&|s| {
                        let mut p = setup.rhex.params.clone();
                        p.leg_armature_kg_m2 = Some(p.leg_armature_kg_m2.unwrap_or(0.0) + s);
                        let mut c = ctrl.clone();
                        c.servo_kd_s = servo_damping(&p, c.hold_torque).0;
                        c.servo(q, qd, theta, omega)
                    })
                } else {
                    0.0
                },
            ];
            for (k, (a, b)) in d.iter().zip(num).enumerate() {
                assert!(
                    (a - b).abs() < 1e-6 * b.abs().max(1.0),
                    "partial {k}: {a} against {b}"
                );
            }
        }
    }
}
