//! The resets' own workspace: what a reset evaluates candidate contact sets with, apart from
//! the flow's cache. The fold ([`crate::fold`]) and the contact sets ([`crate::contact_set`])
//! add their evaluations to it.
use crate::controller::Controller;
use crate::flow::FlowWorkspace;
use selfmanip_core::contact::ContactKind;
use selfmanip_core::{Model, Terrain};

/// What a reset evaluates candidate contact sets with: the robot, its terrain, the
/// controller at the event, the pseudo-impulse duration, and a workspace of the resets' own
/// (the flow's cache is never touched by a reset).
pub struct ResetWorkspace<'a> {
    pub model: &'a Model,
    pub terrain: &'a dyn Terrain,
    pub ctrl: &'a dyn Controller,
    /// δt of (5.39) (s); 0: no pseudo-impulse.
    pub delta_t_s: f64,
    pub ws: &'a mut FlowWorkspace,
    /// Contacts that may not take a kind at this reset: a contact at its fold may not keep
    /// the kind whose mode is singular there ([`crate::fold`]).
    pub barred: &'a [(usize, ContactKind)],
    /// The pin `ε` within which a mode counts as singular ([`crate::fold`]).
    pub fold_threshold: f64,
    /// Contacts a Zeno truncation's dwell holds ([`crate::zeno`]): complementarity keeps
    /// them, pushing or not, until the dwell ends.
    pub held: Vec<usize>,
    /// Contacts a jam hold keeps sticking ([`crate::jam_hold`]), also in `held`: their own
    /// force or impulse does not turn them to sliding.
    pub jammed: Vec<usize>,
}
