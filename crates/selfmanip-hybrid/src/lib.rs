//! # selfmanip-hybrid
//!
//! The hybrid system of thesis Definition 5.2 as an event-accurate simulator: flows (5.48)
//! in each contact mode from `selfmanip-core`'s KKT dynamics, guards (5.49)–(5.51) located on
//! the dense output of a Dormand–Prince 5(4) integrator ([`dopri`]) to a time tolerance
//! (1e-10 s by default), plastic-impact resets (5.10)/(5.52) with impulse–velocity
//! complementarity and the pseudo-impulse (5.28)–(5.29), (5.39)–(5.40), force–acceleration
//! complementarity for liftoff (5.19)–(5.20), and Zeno detection ([`execution`]); joint
//! torques from actuator models (saturated torque, current-limited geared DC motor) through
//! [`actuated`].
//!
//! Friction follows section 5.1.5 / Assumption 5.9: Coulomb sticking within `μ`,
//! frictionless sliding, stick→slip at the cone and slip→stick at zero sliding velocity.
//! [`energy_report`] balances the energy of an execution (motor work, impact losses).
pub mod actuated;
pub mod dopri;
pub mod execution;
pub mod impact_qp;

pub use actuated::{Actuated, CommandPolicy};
pub use execution::{
    energy_report, simulate, Controller, EnergyReport, Event, EventKind, Execution, HybridError,
    HybridOptions, Segment, Termination, ZeroTorque,
};
