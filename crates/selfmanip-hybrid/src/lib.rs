//! # selfmanip-hybrid
//!
//! The hybrid system of thesis Definition 5.2 as an event-accurate simulator, one module per
//! stage, from the bottom up: a module imports only modules above it in this table
//! (`python3 scripts/import-cycles.py` finds no circle).
//!
//! | module | stage |
//! |---|---|
//! | [`integrate`] | Dormand–Prince 5(4) with dense output |
//! | [`bracketing`] | regula falsi and bisection: a root or a predicate's first instant, to a tolerance |
//! | [`limits`] | the contact count up to which complementarity is enumerated exactly |
//! | [`impact_qp`] | frictionless impact and liftoff complementarity as convex QPs |
//! | [`coulomb_impact`] | a plastic impact with Coulomb friction at every contact (a Painlevé end's impact) |
//! | [`error`] | the errors that stop a run from starting or going on |
//! | [`options`] | the options of a run, their defaults and checks |
//! | [`event`] | the events: which guard fired, the reset made, a Painlevé end's reason |
//! | [`controller`] | joint torques `Υ` and the motion of free massless joints |
//! | [`actuated`] | joint torques from actuator models |
//! | [`execution`] | the record: segments, events, termination |
//! | [`damped_slide`] | the damped slide's chain law (torques, damping) from a controller |
//! | [`flow`] | the flow (5.48) of a mode, `(t, q, q̇) ⇒ (q̈, λ)`, with its cache |
//! | [`energy`] | kinetic energy and the energy balance of an execution |
//! | [`reset_workspace`] | the resets' own workspace, apart from the flow's cache |
//! | [`fold`] | Lemma 5.1 singularities as transitions: the pin of a massless chain, its fold guard and its reset's rules |
//! | [`guard`] | touchdown, liftoff, stick↔slip, fold and apex guards (5.49)–(5.51): arming and sampling |
//! | [`free_joints`] | the step bound at which free massless joints' tracking law (out of the error norm) stays stable |
//! | [`locate`] | the first event of a step, located on the dense output to `event_tol_s` |
//! | [`surface_tolerances`] | how far off its surface a contact is on it, drifted, or gone |
//! | [`drift`] | constraint drift of the active contacts, projected away |
//! | [`features`] | the terrain feature under each active contact, and passing onto the next |
//! | [`contact_set`] | the mode a candidate contact set takes, the friction cone, the massless-link tie-break |
//! | [`impact`] | plastic impact (5.10)/(5.52) with the pseudo-impulse rule (5.39)–(5.40), or forces |
//! | [`complementarity`] | enumeration (5.28)–(5.29), (5.19)–(5.20), and the QP ([`impact_qp`]) beyond it |
//! | [`reset`] | the reset at an event: from fired guards to the next mode and `q̇⁺` |
//! | [`jam`] | a Painlevé end resolved as a jam (an impact without collision) |
//! | [`zeno`] | one windowed counter of events and feature passages |
//! | [`budget`] | bounded work per run: step and event budgets, the stop flag |
//! | [`segment`] | one segment: steps, terrain features, guards, until an event |
//! | [`simulate`](mod@simulate) | the loop: flow ⇒ guards ⇒ locate ⇒ reset ⇒ zeno |
//! | [`sensitivity`] | variational equations, saltation matrices, `dx(t_f)/dx(0)` of an execution |
//! | [`periodic`] | periodic orbits: apex return map, Newton shooting, monodromy, Floquet multipliers |
//!
//! Friction follows section 5.1.5 / Assumption 5.9: Coulomb sticking within `μ`,
//! frictionless sliding, stick→slip at the cone and slip→stick at zero sliding velocity.
//! Joint torques may come from actuator models (saturated torque, current-limited geared
//! DC motor) through [`actuated`].
pub mod actuated;
pub mod bracketing;
pub mod budget;
pub mod complementarity;
pub mod contact_set;
pub mod controller;
pub mod coulomb_impact;
pub mod damped_slide;
pub mod drift;
pub mod eigen;
pub mod energy;
pub mod error;
pub mod event;
pub mod execution;
pub mod features;
pub mod flow;
pub mod fold;
pub mod free_joints;
pub mod guard;
pub mod impact;
pub mod impact_qp;
pub mod integrate;
pub mod jam;
pub mod jam_hold;
pub mod limits;
pub mod locate;
pub mod ode_system;
pub mod options;
pub mod periodic;
pub mod reset;
pub mod reset_workspace;
pub mod rosenbrock;
pub mod segment;
pub mod sensitivity;
pub mod simulate;
pub mod surface_tolerances;
pub mod zeno;

pub use actuated::{Actuated, CommandPolicy};
pub use controller::{
    ConstantTorque, ControlPoint, Controller, ControllerPartials, EventMemoryPartials,
    MemoryTimeEvent, TimeEvent, ZeroTorque,
};
pub use energy::{energy_report, EnergyReport};
pub use error::HybridError;
pub use event::{Event, EventKind, PainleveReason};
pub use execution::{Execution, Segment, Termination};
pub use integrate::{StepOptions, VelocityTolerance};
pub use limits::ENUMERATION_LIMIT;
pub use options::HybridOptions;
pub use options::DEFAULT_MAX_STEPS;
pub use sensitivity::{
    execution_sensitivity, execution_sensitivity_columns, simulate_with_sensitivity,
    ColumnSensitivity, Parameter, Sensitivity,
};
pub use simulate::{simulate, simulate_with};
