//! The results of the sensitivity pass and its errors: per event, per switch and time event
//! inside a segment, the state Jacobian ([`Sensitivity`]) and the selected columns
//! ([`ColumnSensitivity`]), and the parameters they are taken with ([`Parameter`]).
use crate::error::HybridError;
use crate::event::EventKind;
use nalgebra::{DMatrix, RowDVector};
use selfmanip_core::tangent::{BodyParameter, TangentError};
use selfmanip_core::ContactMode;

/// Why sensitivities could not be computed at all.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SensitivityError {
    #[error(transparent)]
    Hybrid(#[from] HybridError),
    #[error(transparent)]
    Tangent(#[from] TangentError),
    /// A segment's controller does not give its partial derivatives.
    #[error("the controller of the segment starting at t = {t} s gives no partial derivatives")]
    ControllerWithoutPartials { t: f64 },
    /// A parameter name that the segment's controller does not know.
    #[error(
        "parameter `{name}` is not a parameter of the controller (segment starting at t = {t} s)"
    )]
    UnknownParameter { name: String, t: f64 },
    /// A segment's controller remembers the time or state of an event
    /// ([`Controller::has_event_memory`](crate::Controller::has_event_memory)) but does not give the partial derivatives of its
    /// outputs with respect to them ([`Controller::memory_partials`](crate::Controller::memory_partials)), or refers to an event
    /// the execution did not record: holding that memory fixed would give a wrong derivative.
    #[error(
        "the controller at t = {t} s remembers events' times or states but gives no partial \
         derivatives with respect to them ({reason})"
    )]
    EventMemoryWithoutPartials { t: f64, reason: String },
    /// A [`Parameter::Friction`] the model does not have, or cannot be differentiated in
    /// along this run.
    #[error("{parameter:?}: {reason}")]
    NotAParameter {
        parameter: Parameter,
        reason: String,
    },
    /// The linearly implicit tangent step over a RODAS4 step of the record
    /// (`W = I / (h γ) − F`, [`crate::integrate::StepOptions::stiff_switch`]) met a singular
    /// `W`.
    #[error(
        "the linearly implicit tangent step at t = {t} s has a singular matrix W = I/(h γ) − F"
    )]
    SingularImplicitStep { t: f64 },
}

/// Whether an event's saltation matrix is defined.
#[derive(Debug, Clone, PartialEq)]
pub enum SaltationStatus {
    Defined,
    /// The flow meets the guard tangentially: `D_xg f⁻ ≈ 0` (relative value given).
    Grazing {
        transversality: f64,
    },
    /// The event's neighbouring mode lasted zero time (two events at one instant), or
    /// several guards fired at once where their orders could not be formed (see
    /// [`EventSensitivity::one_sided`]): the outcome may depend on the order.
    Simultaneous,
    /// Several guards fired at once (`guards`: their contacts) and the derivative depends on
    /// the order in which a perturbation makes them fire: the event's map is piecewise
    /// smooth there, its Bouligand derivative piecewise linear, one piece per order
    /// ([`EventSensitivity::one_sided`], each valid for the perturbations that keep its
    /// order; the pieces agree on the perturbations that keep the guards simultaneous).
    OneSided {
        guards: Vec<usize>,
    },
    /// An event kind or situation not differentiated yet.
    Unsupported {
        reason: String,
    },
}

impl SaltationStatus {
    /// The status's name (`defined`, `grazing`, `simultaneous`, `unsupported`).
    pub fn name(&self) -> &'static str {
        match self {
            SaltationStatus::Defined => "defined",
            SaltationStatus::Grazing { .. } => "grazing",
            SaltationStatus::Simultaneous => "simultaneous",
            SaltationStatus::OneSided { .. } => "one_sided",
            SaltationStatus::Unsupported { .. } => "unsupported",
        }
    }

    /// Why the saltation matrix is not defined, in words (`None` when it is).
    pub fn reason(&self) -> Option<String> {
        match self {
            SaltationStatus::Defined => None,
            SaltationStatus::Grazing { transversality } => Some(format!(
                "the flow meets the guard tangentially (|D_xg f| / (|D_xg| |f|) = \
                 {transversality:e})"
            )),
            SaltationStatus::Simultaneous => {
                Some("several guards at once, or a mode held for zero time".to_string())
            }
            SaltationStatus::OneSided { guards } => Some(format!(
                "the guards of contacts {guards:?} fired at once and the derivative depends on \
                 the order a perturbation makes them fire in (one-sided derivatives given)"
            )),
            SaltationStatus::Unsupported { reason } => Some(reason.clone()),
        }
    }
}

/// The sensitivity of one event.
#[derive(Debug, Clone, PartialEq)]
pub struct EventSensitivity {
    pub t: f64,
    pub kind: EventKind,
    pub status: SaltationStatus,
    /// `Ξ` (`2nq × 2nq`) when defined.
    pub saltation: Option<DMatrix<f64>>,
    /// `D_xg` of the guard that fired (when a single guard fired).
    pub guard_gradient: Option<RowDVector<f64>>,
    /// `dt_e / dx(0)` when defined.
    pub time_gradient: Option<RowDVector<f64>>,
    /// For a touchdown, the mode of the plastic impact the reset applied: the mode after,
    /// or a larger set whose extra contacts force complementarity released at once.
    pub impact_mode: Option<ContactMode>,
    /// Where several guards fired at once: the event's derivative for each order in which a
    /// perturbation may make them fire (the single-guard saltations composed in that
    /// order); empty for a single guard. When they all agree the event is
    /// [`SaltationStatus::Defined`] with `saltation` the common matrix, else
    /// [`SaltationStatus::OneSided`].
    pub one_sided: Vec<OneSidedSaltation>,
}

/// The derivative of an event at which several guards fired at once, for the perturbations
/// that make them fire in `order`: `Ξ_σ = Ξ_{σ_k} ⋯ Ξ_{σ_1}`, each single-guard saltation
/// `Ξ_{σ_i} = D_xR_i + (f_i − D_xR_i f_{i−1}) D_xg_i / (D_xg_i f_{i−1})` taken at the event's
/// state with the flow `f_{i−1}` of the mode (and controller) the earlier guards left, the
/// reset `R_i` of guard `σ_i` alone (a plastic impact into the mode with its contact added,
/// or the identity of a liftoff), `f_k = f⁺` the recorded flow after the event.
#[derive(Debug, Clone, PartialEq)]
pub struct OneSidedSaltation {
    /// The contacts whose guards fire, in firing order.
    pub order: Vec<usize>,
    /// `Ξ_σ` (`2nq × 2nq`).
    pub saltation: DMatrix<f64>,
    /// `−D_xg / ġ` of the guard that fires first (`1 × 2nq`): the event's time moves by this
    /// row times the state's perturbation just before it.
    pub time_row: RowDVector<f64>,
}

/// Sensitivities of an execution to its initial state `x(0) = (q0, q̇0)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivity {
    /// `Φ` of each segment (`2nq × 2nq`; the identity for a segment of zero duration), with
    /// the controller's event memory held fixed (when a controller has memory, the state
    /// Jacobian is not their product with the saltations: see the module docs).
    pub segment_flows: Vec<DMatrix<f64>>,
    /// One entry per event of the execution, in order.
    pub events: Vec<EventSensitivity>,
    /// Switches between an arc's rolling and its end's point touch inside segments, in
    /// order ([`TouchSwitch`]); their saltation matrices are part of `segment_flows`.
    pub touch_switches: Vec<TouchSwitch>,
    /// Segment ends without an event (terrain feature changes), by segment index: not
    /// differentiated yet.
    pub feature_changes: Vec<usize>,
    /// `dx(t_end)/dx(0)`, `None` unless every event's saltation is defined and the run ended
    /// at its final time or at the apex (a run cut by its event budget ends on an event
    /// with no flow after it, whose saltation is not formed).
    pub state_jacobian: Option<DMatrix<f64>>,
    /// Where `state_jacobian` is `None` only because some events are
    /// [`SaltationStatus::OneSided`]: the one-sided derivative of the run for the
    /// perturbations that make each such event's guards fire in its `one_sided[0].order`
    /// (a piece of the run's Bouligand derivative; on perturbations that keep those guards
    /// simultaneous, the derivative itself).
    pub one_sided_state_jacobian: Option<DMatrix<f64>>,
}

/// A switch inside a segment between an active arc's rolling and its end's point touch:
/// no event (the contact stays), but the flow's constraint rate `Ȧ` changes form there, so
/// `q̈` jumps and the crossing has a saltation `Ξ = I + (f⁺ − f⁻) D_xg / (D_xg f⁻)` (the reset
/// is the identity), `g` the angle between the ground's normal and the arc's end in the
/// part's frame (`D_qg = −∂β/∂q` of the part's angle). `f⁻`, `f⁺` are the flows at the two
/// ends of the bracket the crossing is located in by bisection on the dense output (a few
/// ulps apart).
#[derive(Debug, Clone, PartialEq)]
pub struct TouchSwitch {
    pub t: f64,
    pub contact: usize,
    pub status: SaltationStatus,
    pub saltation: Option<DMatrix<f64>>,
}

/// A controller's time event met by an execution ([`Controller::time_events`](crate::Controller::time_events)).
#[derive(Debug, Clone, PartialEq)]
pub struct TimeEventSensitivity {
    pub t: f64,
    /// `max |f⁺ − f⁻|` there.
    pub jump: f64,
    /// Always `Defined` today (kept for time events that cannot be differentiated).
    pub status: SaltationStatus,
}

/// A named parameter of an execution's sensitivities ([`execution_sensitivity_columns`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Parameter {
    /// A parameter of the bodies: the body's mass or inertia, a joint's armature, a link's
    /// mass, inertia or centre of mass (`M̄`, `C̄q̇`, `N̄` and the impacts depend on it), or
    /// a link's length or a point contact's position (also `A`, `Ȧq̇` and the touchdown and
    /// stick guards).
    Body(BodyParameter),
    /// A parameter the segments' controllers know by this name
    /// ([`Controller::parameter_partials`](crate::Controller::parameter_partials), [`Controller::time_events`](crate::Controller::time_events)).
    Controller(String),
    /// A friction coefficient of contact `contact`: its static `μ` (the cone
    /// `|λ_t| ≤ μ(−λ_n)` of a sticking contact, the slip guard), its kinetic `μ_k` (the
    /// Coulomb sliding force on the cone's edge), or both where they are one number (a
    /// description that leaves `mu_kinetic` to default to `mu`).
    Friction {
        contact: usize,
        coefficient: FrictionCoefficient,
    },
    /// The pseudo-impulse's duration `δt` (5.39)–(5.40). The pseudo-impulse is never applied
    /// to the state (thesis §5.1.4: it is "used only in determining which contacts to
    /// break", an extra guard condition of the impact), so `δt` only selects the impact's
    /// mode: the state and the event times are locally constant in it, and its columns are
    /// zero wherever the selection is strict (a `δt` at which (5.40)'s test changes its
    /// answer changes the mode sequence: no derivative there). Differentiated at a
    /// positive `δt` only: at `δt = 0` the impact's rule is another one (the limit
    /// `δt → 0⁺`, `crate::complementarity`), so the derivative there is one-sided.
    PseudoImpulseDuration,
}

/// Which of a contact's friction coefficients a [`Parameter::Friction`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrictionCoefficient {
    /// The static `μ` alone.
    Static,
    /// The kinetic `μ_k` alone.
    Kinetic,
    /// `μ = μ_k`, one number.
    Both,
}

impl FrictionCoefficient {
    /// Whether the static `μ` moves with it.
    pub fn moves_static(self) -> bool {
        matches!(
            self,
            FrictionCoefficient::Static | FrictionCoefficient::Both
        )
    }

    /// Whether the kinetic `μ_k` moves with it.
    pub fn moves_kinetic(self) -> bool {
        matches!(
            self,
            FrictionCoefficient::Kinetic | FrictionCoefficient::Both
        )
    }
}

/// Sensitivities of an execution along selected columns: directions of the initial state
/// and named parameters ([`execution_sensitivity_columns`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnSensitivity {
    /// How many leading columns are initial-state directions (the rest are parameters).
    pub n_directions: usize,
    pub parameters: Vec<Parameter>,
    /// One entry per event of the execution, in order, as in [`Sensitivity::events`]
    /// (`time_gradient` is left `None`: see [`Self::event_time_columns`]).
    pub events: Vec<EventSensitivity>,
    /// `dt_e/d(columns)` of each event (`1 × m`), `None` where its saltation is undefined.
    pub event_time_columns: Vec<Option<RowDVector<f64>>>,
    pub touch_switches: Vec<TouchSwitch>,
    /// The controllers' time events met (see [`Controller::time_events`](crate::Controller::time_events)).
    pub time_events: Vec<TimeEventSensitivity>,
    pub feature_changes: Vec<usize>,
    /// `dx(t_end)/d(columns)` (`2nq × m`), `None` under the conditions of
    /// [`Sensitivity::state_jacobian`] or when a time event was flagged.
    pub columns: Option<DMatrix<f64>>,
}
