//! Behaviours as data: a schema ([`spec`]) that a user writes in TOML or JSON, checked and
//! compiled against a robot ([`compile()`]) into an interpreter ([`BehaviourController`]) that
//! the hybrid engine runs as any other [`selfmanip_hybrid::Controller`].
//!
//! A behaviour gives each driven joint a *program*: phases in order, each with a torque law
//! (zero, constant, scheduled, a saturating servo, a motor of the `motor` crate) and a smooth
//! prescribed motion for when the joint is free and massless (thesis 5.1.1). Phases start at
//! a time, on an event (touchdown, liftoff, release, slip, stick, apex, flight of named
//! contacts), on a named event, on another joint's phase, or — as a level — while a joint is
//! past an angle. The file format is documented in `docs/behaviours.md`.
pub mod build;
pub mod compile;
pub mod interpreter;
pub mod spec;
pub(crate) mod tangent;

pub use compile::{compile, compile_bound, compile_shared, Parameters, ReusableParts};
pub use interpreter::BehaviourController;
pub use spec::{
    ActuatorSpec, Behaviour, FreeJointGains, Interpolation, JointProgram, Motion, NamedEvent, On,
    Phase, Torque, Trigger,
};
