//! Spatial robots (`d = 3` of thesis §4.1.1, Table 4.1): rigid-body algebra on nalgebra, a
//! kinematic tree from URDF, and the constrained dynamics of point contacts with the planar
//! core's KKT block inverse, exact for massless limbs. Part 1 of issue 32.
//!
//! Conventions, stated once here and followed by every function of the module (they are
//! Pinocchio's, so arrays and matrices pass between the two unchanged):
//! - Spatial vectors are **linear first**: a [`Motion`] `[v; ω]`, a [`Force`] `[f; n]`;
//!   Jacobians are 6 × nv with the linear rows first.
//! - `q` stacks each joint's coordinates in joint order (depth first over the URDF tree, a
//!   link's child joints in the order of their names, as Pinocchio through urdfdom); a
//!   free-flying base has `q = [x, y, z, qx, qy, qz, qw]` and `v = [v_lin, ω]`, its twist in
//!   the **base frame** (`nq = nv + 1`); see [`liegroup`].
//! - The world is URDF's: z up, gravity a vector of the model
//!   ([`SpatialModel::gravity`], `[0, 0, −9.81]` from a URDF).
//! - Contact rows and forces: see [`contact`] (`M q̈ + h = τ + Aᵀλ`, λ the ground's force on
//!   the robot, rows `[t₁, t₂, n]`, `n` out of the ground).
//!
//! Pipeline: URDF → [`SpatialModel`] (immutable) + [`SpatialData`] (workspace) →
//! [`kinematics::forward_kinematics`], [`kinematics::frame_jacobian`], [`rigid_body::crba`],
//! [`rigid_body::nonlinear_effects`], [`contact::forward_dynamics`], [`impact::impact`] (with
//! Coulomb friction: [`impact::coulomb_impacts`]),
//! [`quasistatic::quasi_static`]. [`rhex`] builds the six-legged RHex of Table 4.2 and maps
//! the planar RHex's states onto it.
pub mod contact;
pub mod coulomb;
pub mod error;
pub mod explog;
pub mod impact;
mod impulse_split;
pub mod inertia;
pub mod kinematics;
pub mod liegroup;
pub mod limb_kkt;
#[cfg(test)]
mod limb_paths_tests;
pub mod model;
pub mod motion;
pub mod quasistatic;
pub mod rhex;
pub mod rigid_body;
pub mod se3;
pub mod tree_kkt;
pub mod urdf;
mod urdf_xml;

pub use contact::{
    forward_dynamics, forward_dynamics_prescribed, free_rates, kkt_blocks, ContactShape,
    PointContact, SpatialKkt,
};
pub use error::{SpatialError, SpatialResult};
pub use impact::{
    coulomb_impacts, impact, impact_outcomes, impact_with, ImpactState, Separation, SpatialImpact,
    MAX_COMBINATIONS,
};
pub use inertia::Inertia;
pub use kinematics::{ReferenceFrame, SpatialData};
pub use liegroup::{difference, from_pinocchio, integrate, neutral, pinocchio_nq, to_pinocchio};
pub use model::{BaseKind, FrameKind, JointKind, SpatialModel};
pub use motion::{Force, Motion};
pub use quasistatic::{quasi_static, SpatialQuasiStatic};
pub use se3::SE3;
pub use tree_kkt::KktRoute;
