//! Sensitivities of an execution to its initial state and to named parameters: the
//! variational equations along each flow, the saltation matrix at each event, and their
//! chain rule
//! `dx(t_f)/dx(0) = Φ_k Ξ_k ⋯ Φ_1 Ξ_1 Φ_0` over the state `x = (q, q̇)` (dimension `2 nq`).
//!
//! **Variational equations.** Along a segment in mode `J`, `ẋ = f(t, x) = (q̇, q̈)` with
//! `q̈` from (5.3)–(5.4) at the controller's `Υ(t, q, q̇)`; its Jacobian
//! `F = [[0, I], [∂q̈/∂q, ∂q̈/∂q̇]]` comes from the exact derivatives of
//! [`selfmanip_core::tangent`] and the controller's own ([`Controller::partials`](crate::Controller::partials)), and
//! `Φ̇ = F Φ`. Free massless joints (thesis 5.1.1) are states like any other: their `q̈` is
//! the controller's prescription, so their rows of `F` are its partials (zero for the
//! default prescription `q̈ = 0`); locked joints (a fold passage) have `q̈ = 0`.
//!
//! `Φ` is integrated *on the execution's own DOPRI5 steps*: for every accepted step of the
//! record, from its start state, the same Butcher tableau gives the state's stages and, with
//! `F` at those stages, the stages of `Φ` (internal differentiation: `Φ` is the derivative of
//! the step map the engine applied, the step sizes held fixed). The last step of a segment,
//! which the engine cut at its event by dense output, is taken from its start to the event.
//! The sensitivity states are **excluded from step-size control**, for three reasons: the
//! execution is then bit-identical with or without sensitivities (it is computed first,
//! unchanged); `Φ` solves a linear equation whose coefficients are as smooth as the state's
//! flow, so the state's steps resolve it to the same order; and the derivative of the step
//! map with the step sequence frozen is the quantity a finite difference of whole executions
//! converges to when perturbations do not change the step sequence's smoothness.
//! A linearly implicit (RODAS4) step of the record, on a stiff stretch
//! ([`crate::integrate::StepOptions::stiff_switch`]), is one an explicit tangent step of its
//! size need not be stable on: there the tangent takes a RODAS4 step of its own along the
//! record's state, with `W = I/(hγ) − F` from the exact `F` (the variational equation is
//! linear in `Φ`; `implicit_tangent`), an order-4 integration of the exact flow's variational
//! equation rather than the derivative of the engine's step map.
//!
//! **Saltation.** At an event with guard `g` and reset `R`:
//! `Ξ = D_xR + (f⁺ − D_xR f⁻) D_xg / (D_xg f⁻)`, with `f⁻`, `f⁺` the flows before and after
//! (each with its segment's controller, locked joints and fixed sliding directions of its
//! Coulomb-sliding sites: the flow and its Jacobian include the kinetic friction force and
//! the passive springs, [`selfmanip_core::tangent`]). Touchdown: `g` the contact's height
//! (5.49), `R` the plastic impact (5.10)/(5.52) into the mode the event took — or into a
//! larger set whose extra contacts force complementarity (5.19)–(5.20) released at once (a
//! contact of the mode before, the contact that touched down, or a sliding toe that the
//! impact stuck), whichever reproduces the recorded `q̇⁺` (else the event is flagged) — with
//! its Jacobian from [`selfmanip_core::tangent::plastic_impact_jacobian`]; the pseudo-impulse
//! (5.39) only selects that mode, it does not change `q̇⁺`. Liftoff: `g = −λ_n` (5.50),
//! `R = I`. Slip: `g = μ(−λ_n) − |λ_t|`, `R = I`. Stick: `g` the sliding velocity, `R = I`.
//! Where a force event's reset projected the integrator's drift away (`crate::reset`: at a
//! slip, or a liftoff whose contact's slip guard fired with it as its cone shrank to a
//! point), `R` is that plastic impact into the mode before and `D_xR` its Jacobian
//! ([`DRIFT_JUMP_TOL`]); any other velocity jump at a force event is flagged. Apex: `g = −ż`;
//! at the apex that ends a run the end state is the state at the apex, `Ξ = I − f⁻ D_xg /
//! (D_xg f⁻)`; an apex passed on the way is no reset (`R = I`, the controller not told of it,
//! `f⁺ = f⁻`): `Ξ = I`, and only its time's gradient is new. A jam fired by a touchdown
//! (`crate::jam`): the touchdown's guard, `R` its stick jam's plastic impact or its Coulomb
//! impact, differentiated on its active set
//! ([`crate::coulomb_impact::coulomb_impact_jacobian`], with `∂R/∂μ` of each slipping contact).
//! Each event also gives its time's gradient `dt_e/dx(0) = −D_xg X⁻ / (D_xg f⁻)`. An
//! active arc whose rolling contact reaches the arc's end inside a segment (no event, but
//! `Ȧ`, hence `q̈`, changes form there) gets a saltation of its own ([`TouchSwitch`]).
//!
//! **Kinks of the controller's law** (a servo's saturation, a motor's current limit: the
//! outputs continuous, their partials not; [`Controller::partials_piece`](crate::Controller::partials_piece)) need no saltation
//! (`f⁺ = f⁻`), but a step that straddles one integrates `Ẋ = F X` only to first order in the
//! step (the quadrature weights the jump of `F` by the tableau's `b_i`, not by the kink's
//! place). The tangent's steps are split there as at a touch switch — the change bracketed
//! on the dense output to a few ulps — and a stage of the two sub-steps that the tableau put
//! past the kink takes the record's state at its time, so that every stage has its side's
//! partials (`docs/sensitivity.md`, "Kinks of a controller's law").
//!
//! **Several guards at once** (two feet landing or lifting off together): the derivative
//! for every order in which a perturbation may make them fire, the single-guard saltations
//! composed in that order (`simultaneous`, [`EventSensitivity::one_sided`]); the event is
//! `Defined` when the orders agree, else [`SaltationStatus::OneSided`] naming the guards,
//! and [`Sensitivity::one_sided_state_jacobian`] chains the first order of each such event
//! (the pieces of the Bouligand derivative agree on the perturbations that keep the guards
//! simultaneous).
//!
//! **Where Ξ is not defined** the event says so ([`SaltationStatus`]) instead of carrying a
//! number: grazing (`|D_xg f⁻|` below [`GRAZING_TOL`] relative to `|D_xg| |f⁻|`), a mode
//! held for zero time between two events at one instant, several guards whose orders are
//! not formed (more than [`MAX_SIMULTANEOUS_GUARDS`], an order whose single impact would
//! pull, event memory), and events not covered yet (folds, a fold passage's end, a segment
//! that ended on a terrain feature change, a Zeno truncation after several guards at once, a
//! jam met by the flow, a Coulomb impact on the boundary of its active set).
//! [`Sensitivity::state_jacobian`] is then `None`.
//!
//! **A Zeno truncation** ([`crate::zeno::truncate`]) is taken at once after the event that
//! filled the window or the chatter's criterion, at its instant: the pair is one event with
//! that event's guard and the reset `R₂ ∘ R₁`, `R₂` the plastic impact (5.52) into the held
//! mode, and `f⁺` the held mode's flow. The dwell's end ([`crate::Execution::dwell_ends`]) is
//! a time event that moves with the truncation's time: `X⁺ = X⁻ + (f⁻ − f⁺) dt_trunc/dx`, the
//! hold let go into the mode force complementarity gives (`truncation`,
//! `docs/sensitivity.md`, "A Zeno truncation").
//!
//! **Parameters and selected columns** ([`execution_sensitivity_columns`]): named parameters
//! `p` are constant states (`x̃ = (x, p)`, `ṗ = 0`), so the same variational equations and
//! saltation matrices carry `X_p = dx/dp`: along a flow `Ẋ_p = F X_p + ∂f/∂p`; at an event
//! `X_p⁺ = Ξ X_p + D_pR + (f⁺ − D_xR f⁻) D_pg / (D_xg f⁻)` and
//! `dt_e/dp = −(D_xg X_p + D_pg)/(D_xg f⁻)`. `∂f/∂p` comes from the controller
//! ([`Controller::parameter_partials`](crate::Controller::parameter_partials), through `∂q̈/∂Υ`) or, for an inertia
//! parameter of the body or a link, from `∂(M̄q̈ + C̄q̇ + N̄)/∂p` by implicit differentiation of the KKT system, for a
//! contact's kinetic friction coefficient from the Coulomb force on the cone's edge (a
//! generalized force direction of the same solve, [`Parameter::Friction`]); `D_pg` of
//! a force guard from `∂λ/∂p` (and `−λ_n` at a slip in its own static `μ`); `D_pR` of a
//! plastic impact from `∂M̄/∂p`. The pseudo-impulse's `δt` selects impacts' modes only: its
//! columns are zero ([`Parameter::PseudoImpulseDuration`]). A controller's
//! **time events** ([`Controller::time_events`](crate::Controller::time_events), e.g. a motor switched on at `t2`) add
//! `(f⁻ − f⁺) dt_b/dp` where the flow jumps; the tangent is split at them (and `∂f/∂p` may
//! jump there even when `f` does not). Only the columns asked for are propagated, by
//! Jacobian-times-matrix products ([`selfmanip_core::tangent::dynamics_jvp`]): never the
//! full `2nq × 2nq` matrices along the flows.
//!
//! **A controller's memory of events** ([`Controller::has_event_memory`](crate::Controller::has_event_memory): a motion started
//! from an event's state, a phase that starts a delay after an event) is part of the tangent:
//! the memory is the remembered events' `(t_k, x_k⁺)`, whose tangents
//! `M_k = (Dt_k, X⁺ + f⁺ Dt_k)` the columns carry; along a flow `Ẋ = F X + ∂f/∂m M`
//! ([`Controller::memory_partials`](crate::Controller::memory_partials)), at an event `Dt_e = −(D_xg X + D_mg M)/ġ` and
//! `X⁺ = Ξ X + (f⁺ − D_xR f⁻) D_mg M / ġ`, at a time event whose instant moves with the memory
//! `X += (f⁻ − f⁺) dt_b/dm M` ([`Controller::memory_time_events`](crate::Controller::memory_time_events)). A force guard's rate
//! `ġ = D_xg f⁻ + ∂g/∂t` includes the torques' explicit time dependence
//! ([`Controller::time_partials`](crate::Controller::time_partials), or a central difference of the torques in time when not
//! given). [`execution_sensitivity`] takes its
//! state Jacobian and event time gradients from the columns when a controller has memory;
//! a controller with memory and no memory partials is a typed error
//! ([`SensitivityError::EventMemoryWithoutPartials`]). `docs/sensitivity.md` derives it.
//!
//! **Not covered yet.** A run whose state sits on a guard that does not fire — a contact set
//! chosen at a complementarity boundary, e.g. a sliding contact started at zero sliding
//! velocity — gets the one-sided derivative of the sequence it realised, unflagged;
//! controllers without [`Controller::partials`](crate::Controller::partials) (the generic actuator models of
//! [`crate::Actuated`]) stop with a typed error; a controller with event memory that does not
//! say so ([`Controller::has_event_memory`](crate::Controller::has_event_memory) false, the default — the RHex leap controller
//! for a massless leg whose motion ends in the air, where it acts on nothing) is
//! differentiated with that memory held fixed.
mod chain;
mod columns;
mod coulomb_impact;
mod engine_jacobian;
mod evaluator;
mod event_saltation;
mod force_events;
mod implicit_tangent;
mod reset_jacobian;
mod saltation;
mod segment_tangent;
mod simultaneous;
mod state_jacobian;
mod tangent;
mod time_events;
mod touch_switch;
mod touchdown;
mod truncation;
mod types;

pub use columns::execution_sensitivity_columns;
pub(crate) use engine_jacobian::EngineJacobian;
pub use force_events::DRIFT_JUMP_TOL;
pub use saltation::{saltation, GRAZING_TOL};
pub use simultaneous::{MAX_SIMULTANEOUS_GUARDS, ORDER_AGREEMENT_TOL, SIMULTANEOUS_GUARD_S};
pub use state_jacobian::{execution_sensitivity, simulate_with_sensitivity};
pub use time_events::TIME_EVENT_TOL;
pub use types::{
    ColumnSensitivity, EventSensitivity, FrictionCoefficient, OneSidedSaltation, Parameter,
    SaltationStatus, Sensitivity, SensitivityError, TimeEventSensitivity, TouchSwitch,
};
