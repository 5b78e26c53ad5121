//! Behaviours written in Rust: constructors for the schema's values ([`super::spec`]) that
//! give exactly what the same behaviour read from a file gives, with nothing parsed (a
//! preset that builds its behaviour per run saves the parse). Every field a constructor does
//! not take is the file's default; the `with_…`/`starting`/`moving` methods set the others.
//!
//! ```
//! use selfmanip_sim::behaviour::{Behaviour, JointProgram, Motion, On, Phase, Torque, Trigger};
//! let b = Behaviour::new("kick", "push at t = 0.1 s until the leg lifts")
//!     .parameter("t_kick", 0.1)
//!     .program(JointProgram::new(
//!         "leg",
//!         vec![
//!             Phase::new("wait", Torque::Zero).moving(Motion::hold("q0")),
//!             Phase::new("push", Torque::constant(2.0)).starting(Trigger::at("t_kick")),
//!             Phase::new("rest", Torque::Zero).starting(Trigger::on(On::Liftoff)),
//!         ],
//!     ));
//! assert_eq!(b.joints[0].phases.len(), 3);
//! ```
use super::spec::Trigger;
use super::spec::{ActuatorSpec, Behaviour, JointProgram, Motion, NamedEvent, On, Phase, Torque};
use crate::expr::Scalar;

impl Behaviour {
    /// A behaviour with a name and description and nothing else (the file's defaults).
    pub fn new(name: impl Into<String>, description: impl Into<String>) -> Self {
        Behaviour {
            name: name.into(),
            description: description.into(),
            ..Behaviour::default()
        }
    }

    /// Sets the parameter `name` (a number or a formula of other parameters).
    pub fn parameter(mut self, name: &str, value: impl Into<Scalar>) -> Self {
        self.parameters.insert(name.into(), value.into());
        self
    }

    /// Sets the actuator `name`.
    pub fn actuator(mut self, name: &str, spec: ActuatorSpec) -> Self {
        self.actuators.insert(name.into(), spec);
        self
    }

    /// Sets the named event `name`.
    pub fn event(mut self, name: &str, event: NamedEvent) -> Self {
        self.events.insert(name.into(), event);
        self
    }

    /// Adds a joint's program (after those given before).
    pub fn program(mut self, program: JointProgram) -> Self {
        self.joints.push(program);
        self
    }
}

impl JointProgram {
    /// The program of `joint` (`"leg"` or `"leg[k]"`) that stays in its last phase.
    pub fn new(joint: impl Into<String>, phases: Vec<Phase>) -> Self {
        JointProgram {
            joint: joint.into(),
            phases,
            repeat_from: None,
        }
    }
}

impl Phase {
    /// A phase with torque law `torque`; its start, motion and restarts are the file's
    /// defaults (phase 0's start; the previous phase's motion and restarts).
    pub fn new(name: impl Into<String>, torque: Torque) -> Self {
        Phase {
            name: name.into(),
            start: None,
            torque,
            motion: None,
            restart_on: None,
        }
    }

    /// This phase, starting when `trigger` fires.
    pub fn starting(self, trigger: Trigger) -> Self {
        Phase {
            start: Some(trigger),
            ..self
        }
    }

    /// This phase, with the prescribed motion `motion`.
    pub fn moving(self, motion: Motion) -> Self {
        Phase {
            motion: Some(motion),
            ..self
        }
    }

    /// This phase, its motion starting again at the events `triggers` (none: planned once).
    pub fn restarting_on(self, triggers: Vec<Trigger>) -> Self {
        Phase {
            restart_on: Some(triggers),
            ..self
        }
    }
}

impl Torque {
    /// A constant torque (N m).
    pub fn constant(torque_n_m: impl Into<Scalar>) -> Self {
        Torque::Constant {
            torque_n_m: torque_n_m.into(),
        }
    }

    /// The command `command` to the actuator `actuator`, reversed past `reverse_beyond_rad`
    /// when given.
    pub fn motor(actuator: &str, command: impl Into<Scalar>, reverse: Option<Scalar>) -> Self {
        Torque::Motor {
            actuator: actuator.into(),
            command: command.into(),
            reverse_beyond_rad: reverse,
        }
    }

    /// A servo on the joint's motion with gains `kp`, `kd`, saturating at `limit` when given,
    /// silent while none of the joint's contacts is active when `only_in_contact`.
    pub fn servo(
        kp: impl Into<Scalar>,
        kd: impl Into<Scalar>,
        limit: Option<Scalar>,
        only_in_contact: bool,
    ) -> Self {
        Torque::Servo {
            target_rad: None,
            kp_n_m_per_rad: kp.into(),
            kd_n_m_s_per_rad: kd.into(),
            torque_limit_n_m: limit,
            only_in_contact,
        }
    }
}

impl Motion {
    /// Hold `angle_rad` at rest.
    pub fn hold(angle_rad: impl Into<Scalar>) -> Self {
        Motion::Hold {
            angle_rad: angle_rad.into(),
        }
    }

    /// Swing to `target_rad` at most at `speed_rad_s`, accelerating at most `accel_rad_s2`.
    pub fn swing(
        target_rad: impl Into<Scalar>,
        speed_rad_s: impl Into<Scalar>,
        accel_rad_s2: impl Into<Scalar>,
    ) -> Self {
        Motion::Swing {
            target_rad: target_rad.into(),
            speed_rad_s: speed_rad_s.into(),
            accel_rad_s2: accel_rad_s2.into(),
        }
    }

    /// Park at `target_rad` within the acceleration bound `accel_rad_s2`.
    pub fn park(target_rad: impl Into<Scalar>, accel_rad_s2: impl Into<Scalar>) -> Self {
        Motion::Park {
            target_rad: target_rad.into(),
            accel_rad_s2: accel_rad_s2.into(),
        }
    }
}

impl Trigger {
    /// The first of `triggers` to fire.
    pub fn any(triggers: Vec<Trigger>) -> Self {
        Trigger {
            any: Some(triggers),
            ..Trigger::default()
        }
    }
}

impl NamedEvent {
    /// The first event of kind `on` of any contact, at or after `not_before_s` when given.
    pub fn on(on: On, not_before_s: Option<Scalar>) -> Self {
        NamedEvent {
            on,
            contacts: None,
            not_before_s,
            after_event: None,
        }
    }
}

impl ActuatorSpec {
    /// `count` motors `motor` of the thesis catalog behind gearbox `gearbox`, at the gear
    /// ratio and current limit given (else the catalog's), with the file's defaults for the
    /// rest (the gearbox's own efficiency, derating, an ideal supply).
    pub fn dc_motor(
        motor: &str,
        gearbox: &str,
        gear_ratio: Option<Scalar>,
        current_limit_a: Option<Scalar>,
        count: impl Into<Scalar>,
    ) -> Self {
        ActuatorSpec::DcMotor {
            motor: motor.into(),
            gearbox: gearbox.into(),
            gear_ratio,
            current_limit_a,
            supply_voltage_v: None,
            count: count.into(),
            gearbox_efficiency: None,
            gearbox_loss: motor::GearboxLoss::Derating,
            battery_resistance_ohm: None,
            catalog: None,
        }
    }
}
