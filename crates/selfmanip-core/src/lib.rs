//! # selfmanip-core
//!
//! Exact constrained dynamics of planar legged robots in any contact mode, after the
//! self-manipulation framework of the RHex thesis (chapters 4–5): the robot is the object
//! it manipulates, contacts are fingers, and the legs may be massless.
//!
//! Conventions (documented once, in [`frames`] and [`contact`]): SI units; world and body
//! frames North-East-Down (x forward, **z down**, pitch φ nose-up positive);
//! `q = [θ₁…θₙ, x, z, φ]`; `λ` is the ground's force on the robot in each contact frame
//! (normal axis into the ground, so pushing normal forces are negative); rows ordered by
//! contact, tangential before normal.
//!
//! Pipeline: [`RobotDescription`] → [`Model`] (immutable) + [`Data`] (workspace) →
//! [`forward_dynamics`] / [`plastic_impact`] / [`reduced::ReducedDynamics`] /
//! [`quasistatic::QuasiStatic`].
mod arc_range;
pub mod constraint;
pub mod contact;
pub mod damped_slide;
mod data;
pub mod description;
pub mod dynamics;
pub mod error;
pub mod frames;
pub mod friction;
mod geometry_partials;
pub mod grasp;
pub mod inertia;
pub mod inertia_partials;
pub mod kinematics;
pub mod kkt;
pub mod model;
pub mod passive;
pub mod poses;
pub mod quasistatic;
pub mod reduced;
mod sliding;
pub mod spatial;
pub mod tangent;

pub use contact::{
    ConstraintRow, ContactKind, ContactMode, FlatGround, GroundPlane, RowDirection, Terrain,
};
pub use description::RobotDescription;
pub use dynamics::{
    energy, forward_dynamics, forward_dynamics_prepared, free_massless_joints, kinetic_energy,
    plastic_impact, plastic_impact_prepared, pseudo_impulse, pseudo_impulse_prepared, Data, Impact,
};
pub use error::{CoreError, Result, SingularityKind};
pub use kkt::{KktBlocks, KktFactorization, KktInfo};
pub use model::Model;
pub use poses::{
    contact_points, forward_kinematics, point_jacobian, ContactPoint, PartState, Poses,
};
