//! # selfmanip-sim
//!
//! Simulation of *any* planar robot through the hybrid engine of `selfmanip-hybrid`, and the
//! machinery around it that knows no particular robot (RHex lives in `rhex-model`, on top):
//!
//! | module | what |
//! |---|---|
//! | [`scenario`] | robot + terrain + initial state + behaviour + options ⇒ a run: outcome, events, trajectory, energy, MCAP |
//! | [`behaviour`] | behaviours as data: phases, triggers, torques, motions, actuators; the interpreter |
//! | [`drive`] | a geared DC drive as numbers, bound to a behaviour's parameters |
//! | [`compliant_leg`] | a rigid leg made a two-link leg with a knee spring–damper (its law a behaviour law) |
//! | [`path`] | parameters by name: any field of a scenario, by path |
//! | [`outcome`] | what a run amounts to: status, word, apex, landing, end state |
//! | [`expr`] | formulas in number fields |
//! | [`terrain`] | flat ground, an incline, a ledge, stairs: faces, edges and corners |
//! | [`motion`] | smooth prescribed motions of free massless joints |
//! | [`labels`] | contact-mode labels in the robot's own contact names, contact-cell words |
//! | [`events`] | the events of an execution in those names |
//! | [`trajectory`] | samples of an execution from its own dense output |
//! | [`mcap`] | MCAP logs that open in Foxglove: a frame per body and link, contacts, forces, modes, events |
//! | [`preset_run`] | what a preset reports of a run in its frame, and of its apex's derivatives |
//! | [`periodic`] | periodic orbits of a scenario: Newton shooting on the apex section, Floquet multipliers |
//! | [`named_terms`] | engine parameters behind named ones on any robot: joint armatures, a contact's friction |
//! | [`sensitivity`] | derivatives of a run by named parameters (weighted sums of the engine's) and start directions |
//! | [`sensitivity_preset`] | what a preset reports of them: the end body state's derivatives on its clock and in its frame |
//! | [`sweep`] | batched runs on an explicit pool: deterministic, per-point status |
//! | [`analysis`] | section 4.3's analyses for any `Model`: free motions, contact poses, standing, legs as tails, takeoff and liftoff speeds |
//! | [`error`] | the crate's typed errors |
pub mod analysis;
pub mod behaviour;
pub mod compliant_leg;
pub mod drive;
pub mod error;
pub mod events;
pub mod expr;
pub mod labels;
pub mod mcap;
pub mod motion;
pub mod named_terms;
pub mod outcome;
pub mod path;
pub mod periodic;
pub mod preset_run;
pub mod scenario;
pub mod sensitivity;
pub mod sensitivity_preset;
pub mod staggered;
pub mod sweep;
pub mod terrain;
pub mod trajectory;

pub use behaviour::{Behaviour, BehaviourController};
pub use error::SimError;
pub use events::EventRecord;
pub use labels::{contact_word, ContactLabels};
pub use motion::JointMotion;
pub use outcome::{Outcome, RunStatus};
pub use scenario::{simulate, InitialState, Run, Scenario, SimOptions, Simulation};
pub use terrain::TerrainSpec;
pub use trajectory::Trajectory;
