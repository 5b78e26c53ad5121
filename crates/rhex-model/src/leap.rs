//! RHex leaps from rest to apex (thesis chapter 3.2 and chapter 5's simulations): the four
//! open-loop strategies `(±, ±)` with coordination time `t2`, as a preset of the generic
//! simulator. [`LeapPreset`] turns `(params, cfg)` into the robot, its start pose and a
//! `selfmanip_sim::Scenario` that runs the strategy's behaviour (`data/behaviours/leap_*.toml`,
//! [`LEAP_BEHAVIOURS`]) through the interpreter; [`LeapResult`] is read off the execution.
//! The model (start pose, motor law, legs in the air, the word, the apex's frame) is
//! `docs/leap-model.md`.
use crate::params::{LegPair, RhexParams};
use crate::{Rhex, RhexError};
use motor::Actuator;
use selfmanip_core::ContactMode;
use selfmanip_hybrid::VelocityTolerance;
use selfmanip_sim::analysis::{angle_to_ground, body_reach_m};
use selfmanip_sim::behaviour::{
    ActuatorSpec, Behaviour, JointProgram, Motion, NamedEvent, On, Phase, Torque, Trigger,
};
pub use selfmanip_sim::drive::{CatalogDrive, GearedMotor, JointActuator, JointDrive};
use selfmanip_sim::expr::Scalar;
use selfmanip_sim::outcome::{BodyState, WordOptions};
pub use selfmanip_sim::preset_run::PresetRun;
use selfmanip_sim::preset_run::{determinate_body_start, farthest_above};
use selfmanip_sim::staggered::{LagReference, StaggeredRun, StaggeredScenario};
use selfmanip_sim::sweep::BuildCache;
use selfmanip_sim::terrain::TerrainSpec;
use selfmanip_sim::{InitialState, Scenario, SimOptions};
use selfmanip_sim::{Simulation, Trajectory};
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

    /// Chapter 3's pushing pairs for this strategy (the leading leg disabled, section 3.3).
    pub fn chapter3_pairs(self) -> [LegPair; 2] {
        match (self.front, self.rear) {
            (Push::Plus, Push::Plus) => [LegPair::Middle, LegPair::Rear],
            (Push::Minus, Push::Minus) => [LegPair::Front, LegPair::Middle],
            _ => [LegPair::Front, LegPair::Rear],
        }
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
        let unreadable = |reason: String| RhexError::Unreadable {
            field: "strategy".into(),
            reason: format!("`{s}`: {reason}"),
        };
        let signs: Vec<Push> = s
            .chars()
            .filter(|c| !matches!(c, '(' | ')' | ',' | ' '))
            .map(|c| match c {
                '+' => Ok(Push::Plus),
                '-' => Ok(Push::Minus),
                other => Err(unreadable(format!("character `{other}` is not + or -"))),
            })
            .collect::<Result<_, _>>()?;
        match signs[..] {
            [front, rear] => Ok(Strategy { front, rear }),
            _ => Err(unreadable(
                "expected two signs such as ++, +-, -+ or --".into(),
            )),
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

/// What turns a planar leg (a contralateral pair of physical legs): chapter 3's constant
/// saturated torque `τ_s` of Table 4.2, or `motors_per_leg` X-RHex motors (Table 2.1, 37 V)
/// behind their gearbox (section 2.1.2): the generic [`JointActuator`] with RHex's catalog
/// drive [`X_RHEX_LEG`].
pub type LegActuator = JointActuator;

/// Chapter 5's leg drive: the thesis catalog's X-RHex motor and gearbox, two motors per
/// planar leg at 28:1, the controller's 20 A limit, no loss options.
pub const X_RHEX_LEG: CatalogDrive = CatalogDrive {
    motor: "x-rhex",
    gearbox: "x-rhex-28",
    default: GearedMotor {
        gear_ratio: 28.0,
        current_limit_a: 20.0,
        motors_per_leg: 2,
        gearbox_efficiency: None,
        gearbox_loss: motor::GearboxLoss::Derating,
        battery_resistance_ohm: None,
    },
};

/// What the coordination time `t2` times (`docs/errata/ch3-leaping.md`): the rear motor's
/// start `t2` after the front one's (the default: chapter 5, footnote 1; what the thesis's
/// own simulations used), or the rear leg's touchdown `t2` after the front one's (section
/// 3.2.2), the generic [`LagReference`].
pub type T2Reference = LagReference;

/// Everything a leap needs besides the robot's parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LeapConfig {
    pub strategy: Strategy,
    /// Start of the rear leg's motor relative to the front leg's (s); negative: rear first.
    pub t2_s: f64,
    pub actuator: LegActuator,
    /// The two pushing leg pairs (front-most first). `None`: chapter 3's for the strategy
    /// ([`Strategy::chapter3_pairs`]). A leap's robot has exactly these two pairs (the
    /// parameters' `pairs` are not read; an override named `pairs` sets this field).
    pub pairs: Option<[LegPair; 2]>,
    /// Pseudo-impulse duration δt of (5.39) (s); 0 disables it. Thesis: 0.03 s.
    pub delta_t_s: f64,
    /// Bound on a massless leg's acceleration in the air (rad/s²). `None`: its motor's
    /// ([`leg_swing`]).
    pub swing_accel_rad_s2: Option<f64>,
    /// Speed a massless leg in the air is brought to (rad/s). `None`: its motor's no-load
    /// output speed ([`leg_swing`]).
    pub swing_speed_rad_s: Option<f64>,
    /// What `t2_s` times: the rear motor's start (the default) or the rear leg's touchdown.
    pub t2_reference: T2Reference,
    /// A leg waits raised this far (rad) above its touchdown angle from the sitting posture.
    pub wait_clearance_rad: f64,
    /// Toe stub (Result C.3, section 3.3.1): a pushing leg's torque reverses once its angle
    /// has turned this far past straight down (rad, in its push direction).
    pub toe_stub_rad: Option<f64>,
    pub terrain: TerrainSpec,
    /// Latest time of the execution (s after the front leg starts).
    pub t_final_s: f64,
    /// Stop at the first apex of flight (otherwise run to `t_final_s`: landings, ledges).
    pub stop_at_apex: bool,
    /// A pushing leg that has lifted off keeps turning in its push direction until the robot
    /// flies (the setting of Fig. 5.7's chatter) instead of parking out of the way.
    pub keep_pushing_after_liftoff: bool,
    /// Width of the bracket that locates each event (s).
    pub event_tol_s: f64,
    /// Relative error tolerance of the integrator per step (absolute: 1 % of it).
    pub rtol: f64,
    /// Zeno detection: more than `zeno_max_events` events within `zeno_window_s`.
    pub zeno_window_s: f64,
    pub zeno_max_events: usize,
    /// Budgets of accepted integration steps and of events (`step_budget`, `event_budget`).
    pub max_steps: usize,
    pub max_events: usize,
    /// Integrate the legs' prescribed motions in the air to the tolerances too
    /// ([`selfmanip_hybrid::HybridOptions::control_free_joints`]; off: ~3× cheaper leaps).
    pub control_free_joints: bool,
    /// Compliant C-legs ([`selfmanip_sim::compliant_leg`]: stick legs with mass, a knee
    /// spring–damper; `docs/leap-model.md`); `None` (default): rigid legs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub compliant_leg: Option<selfmanip_sim::compliant_leg::CompliantLeg>,
}

impl Default for LeapConfig {
    fn default() -> Self {
        LeapConfig {
            strategy: Strategy::new(Push::Plus, Push::Plus),
            t2_s: 0.0,
            actuator: X_RHEX_LEG.actuator(),
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
            // a leap makes a few tens of events
            max_events: 1_000,
            control_free_joints: false,
            compliant_leg: None,
        }
    }
}

/// The parameters of the leaps of chapters 3 and 5: Table 4.2 (massless half-circle legs)
/// with toe friction μ = 1.8 on the front and middle pairs and 2.5 on the rear (5.1.5).
pub fn leap_params() -> RhexParams {
    RhexParams {
        pairs: vec![LegPair::Middle, LegPair::Rear],
        mu_front: Some(1.8),
        mu_middle: Some(1.8),
        mu_rear: Some(2.5),
        ..RhexParams::default()
    }
}

/// The body state at the apex of flight in chapter 3's frame (z up, origin at the body
/// centre at the start, times from the front motor's start; `phi_rad` nose-up positive).
pub type Apex = BodyState;

/// The outcome of one leap: the generic preset run ([`PresetRun`]: status, word in the labels
/// `FB FL RB RL`, apex, events, … read through `Deref`) on the leap's clock (t = 0 at the
/// front motor's start) and in chapter 3's frame, with the leap's timing.
#[derive(Debug, Clone)]
pub struct LeapResult {
    pub run: PresetRun,
    /// The rear motor's start relative to the front one's in this run (s).
    pub motor_t2_s: f64,
    /// The rear leg's first touchdown relative to the front leg's (s), each after its motor
    /// started (section 3.2.2's `t2`); `None` if one never touched down.
    pub touchdown_t2_s: Option<f64>,
    /// The leap it ran: its robot (the two pushing pairs), terrain and run options.
    pub leap: Arc<LeapScenario>,
}

impl std::ops::Deref for LeapResult {
    type Target = PresetRun;
    fn deref(&self) -> &PresetRun {
        &self.run
    }
}

impl LeapConfig {
    /// Checks every field (errors name it); the run's options as the generic simulator
    /// checks them ([`SimOptions::hybrid`]).
    pub fn validate(&self) -> Result<(), RhexError> {
        let bad = |field: &str, reason: String| Err(RhexError::invalid(field, reason));
        if !self.t2_s.is_finite() {
            return bad("t2_s", format!("must be finite, got {}", self.t2_s));
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
        self.sim_options(0.0).hybrid().map_err(|e| match e {
            selfmanip_sim::SimError::InvalidValue { field, reason } => {
                RhexError::invalid(field.trim_start_matches("options."), reason)
            }
            e => e.into(),
        })?;
        // the free legs' tracking law differences two values of the swing's size
        for (field, v) in [
            ("swing_accel_rad_s2", self.swing_accel_rad_s2),
            ("swing_speed_rad_s", self.swing_speed_rad_s),
        ] {
            match v {
                Some(v) if !(v.is_finite() && v > 0.0) => {
                    return bad(field, format!("must be finite and positive, got {v}"))
                }
                Some(v) if !(2.0 * v).is_finite() => {
                    return bad(
                        field,
                        format!("must be at most f64::MAX / 2 (the free legs' tracking law is differenced), got {v}"),
                    )
                }
                _ => {}
            }
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
        self.actuator.validate()?;
        self.compliant_leg
            .as_ref()
            .map_or(Ok(()), |c| c.validate())?;
        Ok(self.terrain.validate()?)
    }

    /// The generic simulator's options of this leap, on a clock that starts `offset_s`
    /// (`min(0, t2)`) before the front motor; contact labels aside.
    fn sim_options(&self, offset_s: f64) -> SimOptions {
        SimOptions {
            t_final_s: self.t_final_s - offset_s,
            stop_at_apex: self.stop_at_apex,
            event_tol_s: self.event_tol_s,
            delta_t_s: self.delta_t_s,
            rtol: self.rtol,
            atol: None,
            zeno_window_s: self.zeno_window_s,
            zeno_max_events: self.zeno_max_events,
            labels: None,
            word: WordOptions {
                // zero-time cells: no longer than the events' location resolves, ≤ 0.1 ms
                min_duration_s: (1e3 * self.event_tol_s).min(1e-4),
                sliding_as_contact: true,
            },
            // DOPRI5 throughout: the leaps' figures and corpus are DOPRI5's (the stiffness
            // test finds a few post-landing stretches of the half-circle legs near its bound)
            stiff_switch: false,
            // one absolute tolerance for every component: the figures and corpus are
            // those of the leaps' own `rtol` with `atol = rtol / 100` throughout
            velocity_tolerance: VelocityTolerance::Uniform,
            // the compliant leg's toes re-touch after short flights that its calibration
            // resolves event by event (docs/decisions/2026-11-30-chatter-truncated.md)
            truncate_unresolved_flights: false,
            ..SimOptions::default()
        }
    }
}

/// The actuator that turns one planar leg: chapter 3's saturated torque `τ_s`, or the
/// current-limited geared X-RHex motors ([`CatalogDrive::runtime`]).
pub fn leg_actuator(params: &RhexParams, a: &LegActuator) -> Result<Arc<dyn Actuator>, RhexError> {
    Ok(X_RHEX_LEG.runtime(a, params.tau_s)?)
}

/// A leg's own inertia about its hip, `I_l + m_l (ρ₁/2)²` (kg m²; zero for massless legs).
pub fn leg_inertia_about_hip(params: &RhexParams) -> f64 {
    params.I_l + params.m_l * (0.5 * params.rho1).powi(2)
}

/// The drive that turns a leg ([`CatalogDrive::joint_drive`]; `τ_s` for the saturated torque,
/// which keeps X-RHex's motors).
fn leg_motor(params: &RhexParams, cfg: &LeapConfig) -> Result<JointDrive, RhexError> {
    Ok(X_RHEX_LEG.joint_drive(&cfg.actuator, params.tau_s)?)
}

/// The rotors' inertia seen at a leg's joint, `n J G²` (kg m²; 0.0113 for X-RHex's two motors
/// at 28:1): the swing bound of a massless leg ([`leg_swing`]) and a massive leg's armature.
pub fn rotor_reflected_inertia(params: &RhexParams, cfg: &LeapConfig) -> Result<f64, RhexError> {
    Ok(leg_motor(params, cfg)?.reflected_inertia_kg_m2)
}

/// The armature a leap gives each leg joint (kg m²): `params.leg_armature_kg_m2` when set,
/// else [`rotor_reflected_inertia`] on legs that carry their rotors
/// ([`RhexParams::legs_carry_rotors`]), else none (massless legs stay massless, C.6).
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

/// Whether a leap's leg armature is the reflected rotor inertia, which moves with the gear
/// ratio (`∂a/∂G = 2 n J G`).
pub(crate) fn armature_follows_gear(params: &RhexParams) -> bool {
    params.leg_armature_kg_m2.is_none() && params.legs_carry_rotors()
}

/// The mass or inertia parameter that makes a start state overflow: the one farthest above
/// its Table 4.2 value ([`farthest_above`]: a massless leg's `m_l = 0` compares).
fn overflowing_parameter(params: &RhexParams) -> &'static str {
    let table = RhexParams::default();
    farthest_above(&[
        ("m_b", params.m_b, table.m_b),
        ("I_b", params.I_b, table.I_b),
        ("m_l", params.m_l, table.m_l),
        ("I_l", params.I_l, table.I_l),
    ])
}

/// How a leg swings in the air while its motor is on, `(speed, acceleration bound)`: the
/// motor's no-load output speed `ω₀/G` (38.6 rad/s at 28:1) and its stall torque over the
/// reflected rotor inertia plus the leg's own about the hip (thesis 5.1.1; the saturated
/// torque keeps X-RHex's drive with `τ_s`). Explicit values in the configuration win.
pub fn leg_swing(params: &RhexParams, cfg: &LeapConfig) -> Result<(f64, f64), RhexError> {
    let m = leg_motor(params, cfg)?;
    let leg = leg_inertia_about_hip(params);
    let speed = (cfg.swing_speed_rad_s).unwrap_or(m.drive.no_load_speed_rad_s());
    let accel =
        (cfg.swing_accel_rad_s2).unwrap_or(m.stall_torque_n_m / (m.reflected_inertia_kg_m2 + leg));
    Ok((speed, accel))
}

/// The robot of a leap: `params` (checked as given) with the leap's two pushing pairs
/// ([`LeapConfig::pairs`] or chapter 3's) and its legs' armature ([`leg_armature`]).
pub fn leap_rhex(params: &RhexParams, cfg: &LeapConfig) -> Result<Rhex, RhexError> {
    let pairs = cfg.pairs.unwrap_or(cfg.strategy.chapter3_pairs());
    if pairs[0] == pairs[1] {
        let reason = "a leap strategy drives two different leg pairs";
        return Err(RhexError::invalid("pairs", reason));
    }
    params.validate()?;
    Rhex::new(RhexParams {
        pairs: pairs.to_vec(),
        leg_armature_kg_m2: leap_leg_armature(params, cfg)?,
        leg_rotors: None,
        ..params.clone()
    })
}

/// A leap's start pose `q0`: sitting level on both body ends, each pushing leg held
/// [`LeapConfig::wait_clearance_rad`] above the angle at which its lowest point reaches the
/// ground on the side its strategy pushes from (by bisection on the engine's contact
/// geometry, [`selfmanip_sim::analysis::angle_to_ground`]). It does not depend on `t2` or the
/// actuator ([`LeapPreset`] computes it once).
pub fn leap_start_pose(rhex: &Rhex, cfg: &LeapConfig) -> Result<Vec<f64>, RhexError> {
    let params = &rhex.params;
    let terrain = cfg.terrain;
    if let TerrainSpec::Ledge { distance_m, .. } = terrain {
        // the face must be clear of a body end, or a leg turned straight towards it
        let side = distance_m.signum();
        let reach = body_reach_m(&rhex.model, side);
        if distance_m.abs() <= reach {
            let reason = format!(
                "the ledge's face must be beyond the robot's reach at the start \
                 ({reach:.3} m {} the body centre), got {distance_m}",
                if side > 0.0 { "ahead of" } else { "behind" }
            );
            return Err(RhexError::invalid("terrain.distance_m", reason));
        }
    }
    let sign = [cfg.strategy.front.sign(), cfg.strategy.rear.sign()];
    let mut q0 = vec![0.0, 0.0, 0.0, -params.rho_b, 0.0];
    for i in 0..2 {
        let contact = rhex.site(2 * i + 1);
        // from pointing up (clear) to pointing down (through the ground)
        let up = -sign[i] * (PI - 1e-9);
        let touchdown = angle_to_ground(&rhex.model, &terrain, &q0, i, contact, up, 0.0)
            .ok_or_else(|| {
                let reason = "a leg pointing straight down must reach the ground from the \
                              sitting posture";
                RhexError::invalid("rho_b", reason)
            })?;
        q0[i] = touchdown - sign[i] * cfg.wait_clearance_rad;
    }
    Ok(q0)
}

/// The mode a leap starts in: `1010`; with Coulomb body ends (`RhexParams::mu_body`) the
/// rear one starts sliding ([`determinate_body_start`]: both sticking is statically
/// indeterminate).
fn start_mode(rhex: &Rhex) -> Result<ContactMode, RhexError> {
    Ok(determinate_body_start(&rhex.model, rhex.mode("1010")?))
}

/// The presets a caller keeps for the leaps it runs (a sweep builds one per strategy and set
/// of fixed inputs and runs each point on it, [`LeapPreset::run_at`]), keyed by value by what
/// a build depends on: the parameters and the configuration with `t2_s` set to 0 and the
/// actuator to its kind's default. A point gives what a fresh leap gives, bit for bit.
#[derive(Default)]
pub struct Presets(BuildCache<(RhexParams, LeapConfig), LeapPreset>);

impl Presets {
    /// The leap `(params, cfg)` on the preset kept for it (built at the first ask): what
    /// [`simulate_leap_with`] gives, bit for bit, without its event records.
    pub fn run(
        &self,
        params: &RhexParams,
        cfg: &LeapConfig,
        stop: &AtomicBool,
    ) -> Result<LeapResult, RhexError> {
        let key = LeapConfig {
            t2_s: 0.0,
            actuator: X_RHEX_LEG.of_kind(&cfg.actuator),
            ..cfg.clone()
        };
        let build = || LeapPreset::new(params, cfg).map(LeapPreset::without_event_records);
        let preset = (self.0).get_or_build((params.clone(), key), build)?;
        preset.run_at(cfg.t2_s, &cfg.actuator, stop)
    }
}

/// A leap as a preset of the generic simulator: the robot, its start pose and the scenario of
/// its strategy's behaviour ([`leap_scenario`]), built once; [`Self::run`] runs it at any
/// motor start `t2` and [`Self::run_at`] at any point `(t2, actuator)` by binding the
/// behaviour's parameters ([`Simulation::rebind`]: bit for bit a fresh preset's leap).
///
/// ```no_run
/// # use rhex_model::leap::{leap_params, LeapConfig, LeapPreset, Strategy, X_RHEX_LEG};
/// # let stop = std::sync::atomic::AtomicBool::new(false);
/// let params = leap_params();
/// for strategy in Strategy::ALL {
///     let preset = LeapPreset::new(&params, &LeapConfig { strategy, ..LeapConfig::default() })?;
///     for k in 0..41 {
///         let t2_s = -0.2 + 0.01 * f64::from(k);
///         let leap = preset.run_at(t2_s, &X_RHEX_LEG.at_gear_ratio(28.0), &stop)?;
///     }
/// }
/// # Ok::<(), rhex_model::RhexError>(())
/// ```
#[derive(Clone, Debug)]
pub struct LeapPreset {
    pub cfg: LeapConfig,
    pub q0: Vec<f64>,
    /// The scenario of `cfg`'s own point (its motor start `cfg.t2_s`, its actuator).
    pub leap: Arc<LeapScenario>,
    /// The parameters as given (a point whose actuator changes the robot is built afresh).
    params: RhexParams,
    /// The simulation of `cfg`'s point ([`StaggeredScenario`]: the rear motor `t2` later).
    sim: StaggeredScenario,
}

impl LeapPreset {
    /// The preset of `(params, cfg)` (checked: errors name the field).
    pub fn new(params: &RhexParams, cfg: &LeapConfig) -> Result<Self, RhexError> {
        cfg.validate()?;
        let rhex = leap_rhex(params, cfg)?;
        let q0 = leap_start_pose(&rhex, cfg)?;
        let mode0 = start_mode(&rhex)?;
        let motor = LeapConfig {
            t2_reference: T2Reference::MotorStart,
            ..cfg.clone()
        };
        let leap = scenario_of(rhex, params, &motor, &q0)?;
        let q0 = leap.scenario.initial.q.clone();
        // a start the simulator refuses (its energy overflows) is the parameters' fault
        let mut sim = Simulation::new(&leap.scenario).map_err(|e| match e {
            selfmanip_sim::SimError::InvalidValue { field, reason }
                if field.starts_with("initial.") =>
            {
                RhexError::StartOverflow {
                    field: overflowing_parameter(&leap.rhex.params).into(),
                    reason,
                }
            }
            e => e.into(),
        })?;
        sim.mode0 = mode0;
        sim.options.max_steps = cfg.max_steps;
        sim.options.max_events = cfg.max_events;
        sim.options.control_free_joints = cfg.control_free_joints;
        let toes = [leap.rhex.site(1), leap.rhex.site(3)];
        let sim = StaggeredScenario::new(sim, "t2", cfg.t2_s, cfg.t_final_s, toes);
        Ok(LeapPreset {
            cfg: cfg.clone(),
            q0,
            leap: Arc::new(leap),
            params: params.clone(),
            sim,
        })
    }

    /// This preset with results that carry no event records ([`PresetRun::events`] empty,
    /// [`LeapResult::reason`] names the start's mode), everything else bit for bit.
    pub fn without_event_records(mut self) -> Self {
        self.sim.event_records = false;
        self
    }

    /// The simulation of the leap with the rear motor starting `motor_t2_s` after the front
    /// one, and the front motor's start on its clock (`−min(0, t2)`).
    pub fn simulation(&self, motor_t2_s: f64) -> Result<(Simulation, f64), RhexError> {
        Ok(self.sim.simulation(&[], motor_t2_s)?)
    }

    /// Runs the leap at its motor start `cfg.t2_s` from its start state plus `start_offset`
    /// ([`StaggeredScenario::run_from`]: the waiting legs hold the unperturbed pose).
    pub(crate) fn run_from(&self, start_offset: Option<&[f64]>) -> Result<LeapResult, RhexError> {
        let t2 = self.cfg.t2_s;
        let rhex = &self.leap.rhex;
        let run = self.sim.run_from(t2, start_offset)?;
        Ok(self.result(self.sim.read(run, t2, &|m| rhex.label(m))))
    }

    /// Runs the leap with the rear motor starting `motor_t2_s` after the front one.
    pub fn run(&self, motor_t2_s: f64, stop: &AtomicBool) -> Result<LeapResult, RhexError> {
        let reference = T2Reference::MotorStart;
        self.run_point(&[], motor_t2_s, reference, stop)
    }

    /// Runs the leap as `cfg.t2_reference` says: the motor start `t2`, or the touchdown
    /// offset `t2` by a search over motor starts.
    pub fn run_leap(&self, stop: &AtomicBool) -> Result<LeapResult, RhexError> {
        self.run_point(&[], self.cfg.t2_s, self.cfg.t2_reference, stop)
    }

    /// The leap of the point `(t2_s, actuator)`: what [`simulate_leap_with`] gives with
    /// `cfg`'s `t2_s` and `actuator` replaced, bit for bit. Where the robot does not depend
    /// on the actuator (no rotors that follow the gear ratio), both are geared motors with the
    /// same loss options set, or the actuator is the preset's, the point's values are bound to
    /// the simulation built once; otherwise the point is built afresh.
    pub fn run_at(
        &self,
        t2_s: f64,
        actuator: &LegActuator,
        stop: &AtomicBool,
    ) -> Result<LeapResult, RhexError> {
        let point = LeapConfig {
            t2_s,
            actuator: actuator.clone(),
            ..self.cfg.clone()
        };
        point.validate()?;
        let same = *actuator == self.cfg.actuator;
        if !same {
            // what a fresh preset asks of the actuator (its drive builds)
            leg_swing(&self.params, &point)?;
        }
        let same_robot = same
            || (self.cfg.actuator.binds_as(actuator)
                && leap_leg_armature(&self.params, &point)?
                    == leap_leg_armature(&self.params, &self.cfg)?);
        if !same_robot {
            let mut fresh = LeapPreset::new(&self.params, &point)?;
            fresh.sim.event_records = self.sim.event_records;
            return fresh.run_leap(stop);
        }
        let values = if same { Vec::new() } else { actuator.values() };
        self.run_point(&values, t2_s, self.cfg.t2_reference, stop)
    }

    /// The leap with the behaviour parameters `values` bound, at `t2` timed as `reference`
    /// says ([`StaggeredScenario::run_timed`]).
    fn run_point(
        &self,
        values: &[(&str, f64)],
        t2_s: f64,
        reference: T2Reference,
        stop: &AtomicBool,
    ) -> Result<LeapResult, RhexError> {
        let rhex = &self.leap.rhex;
        let label = |m: ContactMode| rhex.label(m);
        let run = self.sim.run_timed(values, t2_s, reference, stop, &label)?;
        Ok(self.result(run))
    }

    /// The leap's result of its staggered run (the rear motor `t2` after the front one).
    fn result(&self, r: StaggeredRun) -> LeapResult {
        LeapResult {
            run: r.run,
            motor_t2_s: r.lag_s,
            touchdown_t2_s: r.touchdown_lag_s,
            leap: Arc::clone(&self.leap),
        }
    }
}

/// Runs one leap (see the module documentation). Errors are bad parameters (typed, naming
/// the field) and engine failures that prevent any answer; a leap that does not fly is an
/// `Ok` result with the engine's [`RunStatus`](selfmanip_sim::RunStatus).
pub fn simulate_leap(params: &RhexParams, cfg: &LeapConfig) -> Result<LeapResult, RhexError> {
    simulate_leap_with(params, cfg, &selfmanip_hybrid::budget::NEVER)
}

/// [`simulate_leap`] that another thread can stop: once `stop` is raised the leap ends
/// within one integration step with status `interrupted`.
pub fn simulate_leap_with(
    params: &RhexParams,
    cfg: &LeapConfig,
    stop: &AtomicBool,
) -> Result<LeapResult, RhexError> {
    LeapPreset::new(params, cfg)?.run_leap(stop)
}

impl LeapResult {
    /// Why the leap did not fly, in words (empty when it [flew](PresetRun::flew)):
    /// [`PresetRun::reason`] with the leap's contacts, from `1010`.
    pub fn reason(&self) -> String {
        self.run.reason("1010")
    }

    /// Energy bookkeeping of the leap (motor work, impact losses, start and end energy).
    pub fn energy_report(&self) -> Result<selfmanip_hybrid::EnergyReport, RhexError> {
        Ok(self.run.energy_report()?)
    }

    /// Samples the leap every `dt_s` seconds (and at its end), times from the front leg's
    /// start ([`PresetRun::trajectory`]).
    pub fn trajectory(&self, dt_s: f64) -> Result<Trajectory, RhexError> {
        let rhex = &self.leap.rhex;
        Ok(self.run.trajectory(&|m| rhex.label(m), dt_s)?)
    }
}

/// The shipped behaviour files (the schema of `docs/behaviours.md`), by strategy.
pub const LEAP_BEHAVIOURS: [(&str, &str); 4] = [
    ("++", include_str!("../data/behaviours/leap_pp.toml")),
    ("+-", include_str!("../data/behaviours/leap_pm.toml")),
    ("-+", include_str!("../data/behaviours/leap_mp.toml")),
    ("--", include_str!("../data/behaviours/leap_mm.toml")),
];

/// The shipped behaviour of a strategy: the data of its file ([`LEAP_BEHAVIOURS`]) built in
/// Rust, nothing parsed (`tests/leap_behaviours.rs` checks that each file parses to exactly
/// this value; parsing costs ~9 % of a one-shot leap's instructions, JSON ~2.4 %).
pub fn leap_behaviour(strategy: Strategy) -> Behaviour {
    let joints = strategy.chapter3_pairs().map(LegPair::name);
    behaviour(
        strategy,
        &Settings {
            joints,
            ..Settings::default()
        },
    )
}

/// What a leap sets in its strategy's file ([`scenario_of`]): the two programs' joints; the
/// swing's speed and acceleration as numbers where set (else the files' formulas of the
/// motor); `toe_stub_rad` as each push's `reverse_beyond_rad`; `keep_pushing_after_liftoff`
/// (retract at `takeoff` only); legs with inertia, servoed in the air too with the damping of
/// [`servo_damping`].
#[derive(Default)]
struct Settings<'a> {
    joints: [&'a str; 2],
    swing_speed_rad_s: Option<f64>,
    swing_accel_rad_s2: Option<f64>,
    toe_stub_rad: Option<f64>,
    keep_pushing_after_liftoff: bool,
    massive: [bool; 2],
    kd_n_m_s_per_rad: Option<String>,
}

/// The behaviour of `strategy` with the settings `k`.
fn behaviour(strategy: Strategy, k: &Settings<'_>) -> Behaviour {
    let motor = "leg.stall_torque_n_m";
    let accel = || match k.swing_accel_rad_s2 {
        Some(a) => num(a),
        None => "leg.stall_torque_n_m / (leg.reflected_inertia_kg_m2 + leg_inertia_kg_m2)".into(),
    };
    let kd = match &k.kd_n_m_s_per_rad {
        Some(kd) => Scalar::Expr(kd.clone()),
        None => format!("kd_hold * {motor}").as_str().into(),
    };
    let kp = format!("kp_hold * {motor}");
    let servo =
        |i: usize| Torque::servo(kp.as_str(), kd.clone(), Some(motor.into()), !k.massive[i]);
    let retract = match k.keep_pushing_after_liftoff {
        true => Trigger::event("takeoff"),
        false => Trigger::any(vec![Trigger::on(On::Release), Trigger::event("takeoff")]),
    };
    let program = |i: usize, start: &str, sign: &str| {
        let speed = k
            .swing_speed_rad_s
            .map_or_else(|| "leg.no_load_speed_rad_s".into(), num);
        let stowed = format!("if({sign} * theta >= 0, {sign}, -{sign}) * stow");
        let phases = vec![
            Phase::new("wait", servo(i)).moving(Motion::hold("q0")),
            Phase::new("push", Torque::motor("leg", sign, k.toe_stub_rad.map(num)))
                .starting(Trigger::at(start))
                .moving(Motion::swing(
                    format!("{sign} * stow").as_str(),
                    speed,
                    accel(),
                ))
                .restarting_on(vec![Trigger::on(On::Release)]),
            Phase::new("retract", servo(i))
                .starting(retract.clone())
                .moving(Motion::park(stowed.as_str(), accel()))
                .restarting_on(Vec::new()),
        ];
        JointProgram::new(k.joints[i], phases)
    };
    let symbols = format!("({},{})", strategy.front.symbol(), strategy.rear.symbol());
    let description =
        format!("RHex leap {symbols}: open-loop motor pushes with coordination time t2");
    let d = &X_RHEX_LEG.default;
    let takeoff = NamedEvent::on(On::Flight, Some("max(t_front, t_rear)".into()));
    let (ratio, limit) = (Some("gear_ratio".into()), Some("current_limit_a".into()));
    let leg = ActuatorSpec::dc_motor(
        X_RHEX_LEG.motor,
        X_RHEX_LEG.gearbox,
        ratio,
        limit,
        "motors_per_leg",
    );
    Behaviour::new(format!("rhex-leap-{strategy}"), description)
        .parameter("t2", 0.0)
        .parameter("t_front", "max(0, -t2)")
        .parameter("t_rear", "max(0, t2)")
        .parameter("s_front", strategy.front.sign())
        .parameter("s_rear", strategy.rear.sign())
        .parameter("gear_ratio", d.gear_ratio)
        .parameter("current_limit_a", d.current_limit_a)
        .parameter("motors_per_leg", f64::from(d.motors_per_leg))
        .parameter("leg_inertia_kg_m2", 0.0)
        .parameter("stow", 2.6)
        .parameter("kp_hold", 20.0)
        .parameter("kd_hold", 0.5)
        .actuator("leg", leg)
        .event("takeoff", takeoff)
        .program(program(0, "t_front", "s_front"))
        .program(program(1, "t_rear", "s_rear"))
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

/// The leap of `(params, cfg)` from the start configuration `q0` ([`PresetRun::q0`]) as a
/// scenario; its legs are timed by motor start.
pub fn leap_scenario(
    params: &RhexParams,
    cfg: &LeapConfig,
    q0: &[f64],
) -> Result<LeapScenario, RhexError> {
    cfg.validate()?;
    if cfg.t2_reference != T2Reference::MotorStart {
        return Err(RhexError::Unsupported {
            field: "t2_reference".into(),
            reason: "a leap scenario times its legs by motor start: pass the motor start of \
                     the touchdown-timed leap (`LeapResult::motor_t2_s`) as `t2_s`"
                .into(),
        });
    }
    let rhex = leap_rhex(params, cfg)?;
    scenario_of(rhex, params, cfg, q0)
}

/// [`leap_scenario`] on the leap's robot `rhex` ([`leap_rhex`]), `cfg` checked. The toes'
/// friction is the robot's; `t2_s` is the motor-start offset.
pub(crate) fn scenario_of(
    mut rhex: Rhex,
    params: &RhexParams,
    cfg: &LeapConfig,
    q0: &[f64],
) -> Result<LeapScenario, RhexError> {
    // the swing is the motor's formula (so that its partials follow the gear ratio) unless
    // set, or the actuator (a saturated torque) has no motor data: then a number
    let geared = matches!(cfg.actuator, LegActuator::GearedMotor { .. });
    let (speed, accel) = leg_swing(params, cfg)?;
    let damping = servo_damping(params, &rhex.params, geared);
    let pairs = rhex.params.ordered_pairs();
    let settings = Settings {
        // the front-most pushing pair drives joint 0, the rear-most joint 1
        joints: [pairs[0].name(), pairs[1].name()],
        swing_speed_rad_s: (!geared || cfg.swing_speed_rad_s.is_some()).then_some(speed),
        swing_accel_rad_s2: (!geared || cfg.swing_accel_rad_s2.is_some()).then_some(accel),
        toe_stub_rad: cfg.toe_stub_rad,
        keep_pushing_after_liftoff: cfg.keep_pushing_after_liftoff,
        massive: [0, 1].map(|i| !rhex.model.distal_massless(i)),
        kd_n_m_s_per_rad: damping.as_ref().map(|(kd, _)| kd.clone()),
    };
    let mut b = behaviour(cfg.strategy, &settings)
        .parameter("t2", cfg.t2_s)
        .parameter("leg_inertia_kg_m2", leg_inertia_about_hip(&rhex.params));
    if let Some((_, armature)) = damping {
        b = b.parameter("leg_armature_kg_m2", armature);
    }
    let leg = b.actuators.get_mut("leg").expect("the files' actuator");
    match &cfg.actuator {
        LegActuator::SaturatedTorque => {
            *leg = ActuatorSpec::Saturated {
                max_torque_n_m: num(rhex.params.tau_s),
            };
        }
        LegActuator::GearedMotor(m) => m.bind(leg, &mut b.parameters),
    }
    let model = &rhex.model;
    let offset = cfg.t2_s.min(0.0);
    let labels = (0..rhex.label_len())
        .map(|i| model.contacts[rhex.site(i)].name.clone())
        .collect();
    let mut scenario = Scenario {
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
            labels: Some(labels),
            ..cfg.sim_options(offset)
        },
    };
    if let Some(c) = &cfg.compliant_leg {
        selfmanip_sim::compliant_leg::make_compliant(&mut scenario, &settings.joints, c)?;
        rhex.model = scenario.robot.build()?;
    }
    Ok(LeapScenario {
        scenario,
        rhex,
        time_offset_s: -offset,
    })
}

/// The servo damping of legs with inertia as a formula of the behaviour's parameters (its
/// partials follow the gear ratio and the armature), and the value of the parameter
/// `leg_armature_kg_m2` it reads; `None` for massless legs without armature (the files'
/// `kd_hold`, chosen for massless legs). A leg of inertia `I` about its hip (with its
/// joint's armature) gets critical damping for the stiffness `k_p = kp_hold · H` (`H` the
/// stall torque): `k_d = 2 √(kp_hold I / H) · H` (a double pole at 217 rad/s for Table 4.2's
/// leg with its rotors at 28:1). The armature is `n J G²` where it follows the gear ratio
/// (`user`: the parameters as given; `robot`: the leap's, its armature set; `geared`: the
/// saturated torque has no rotors to reflect), else the parameter as set.
fn servo_damping(user: &RhexParams, robot: &RhexParams, geared: bool) -> Option<(String, f64)> {
    let armature = robot.leg_armature_kg_m2.unwrap_or(0.0);
    if leg_inertia_about_hip(robot) + armature <= 0.0 {
        return None;
    }
    let (armature, value) = if geared && armature_follows_gear(user) {
        ("(leg.reflected_inertia_kg_m2 + leg_armature_kg_m2)", 0.0)
    } else {
        ("leg_armature_kg_m2", armature)
    };
    let kd = format!(
        "2 * sqrt(kp_hold * (leg_inertia_kg_m2 + {armature}) / leg.stall_torque_n_m) \
         * leg.stall_torque_n_m"
    );
    Some((kd, value))
}
