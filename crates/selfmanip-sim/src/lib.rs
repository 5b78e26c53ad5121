//! # selfmanip-sim
//!
//! Simulation of *any* planar robot through the hybrid engine of `selfmanip-hybrid`, and the
//! machinery around it that knows no particular robot (RHex lives in `rhex-model`, on top):
//!
//! | module | what |
//! |---|---|
//! | [`terrain`] | flat ground, an incline, a ledge, stairs: faces, edges and corners |
//! | [`motion`] | smooth prescribed motions of free massless joints |
//! | [`labels`] | contact-mode labels in the robot's own contact names, contact-cell words |
//! | [`events`] | the events of an execution in those names |
//! | [`trajectory`] | samples of an execution from its own dense output |
//! | [`mcap`] | MCAP logs that open in Foxglove: a frame per body and link, contacts, forces, modes, events |
//! | [`sweep`] | batched runs on an explicit pool: deterministic, per-point status |
//! | [`analysis`] | section 4.3's analyses for any `Model`: free motions, contact poses, standing, legs as tails |
//! | [`error`] | the crate's typed errors |
pub mod analysis;
pub mod error;
pub mod events;
pub mod labels;
pub mod mcap;
pub mod motion;
pub mod sweep;
pub mod terrain;
pub mod trajectory;

pub use error::SimError;
pub use labels::{contact_word, ContactLabels};
pub use motion::JointMotion;
pub use terrain::TerrainSpec;
pub use trajectory::Trajectory;
