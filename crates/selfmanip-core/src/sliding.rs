//! The sliding sites with kinetic friction of a prepared mode, as the workspace
//! ([`crate::Data::sliding`]) keeps them and the friction solve ([`crate::friction`]) sets
//! them, and the damped slides of massless chains ([`crate::damped_slide`]): their types
//! only, below both.
use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
use std::ops::Range;

/// How the sliding direction `σ` of a site with kinetic friction is set while a caller
/// integrates a stretch of flow ([`crate::Data::slide_directions`], [`crate::friction`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SlideDirection {
    /// `σ ∈ {−1, 0, 1}` whatever `v_t` is (0: no friction).
    Fixed(f64),
    /// The site starts from rest: the cone edge on the side of its sticking force (never
    /// held); the edge taken is left in [`SlidingSite::sigma`].
    FromRest,
}

/// One sliding site with kinetic friction at the prepared state.
#[derive(Debug, Clone, Default)]
pub struct SlidingSite {
    /// Its normal row in `data.constraints.rows`.
    pub row: usize,
    /// Its contact.
    pub contact: usize,
    /// The joint of the massless leg that carries it ([`usize::MAX`] for a general site).
    pub joint: usize,
    /// Whether its friction is folded into the dynamics solve (a site not resolved by the
    /// statics of a single-joint massless leg: a body site, a massive or multi-joint leg,
    /// or a leg with another active contact; [`crate::friction`], "The general sliding site").
    pub general: bool,
    pub mu_k: f64,
    /// `(coordinate, A_t entry)` over the coordinates the site's point depends on.
    pub a_t: Vec<(usize, f64)>,
    /// `Ȧ_t q̇`.
    pub a_t_dot_qd: f64,
    /// Sliding velocity `v_t = −A_t q̇` (m/s).
    pub v_t: f64,
    /// The ratio `λ_t/λ_n` of the site's force, `μ_k σ` while it slides (0 at rest until
    /// [`crate::friction`] resolves it at rest).
    pub coef: f64,
    /// The sliding direction `σ` of its force: fixed, `sign v_t`, or at rest the edge
    /// the friction solve took (`−sign λ^s_t`; 0: none, or held).
    pub sigma: f64,
    /// At rest, whether the cone holds its sticking force (then it takes no edge unless
    /// the instantaneous law holds it: the caller must let it stick).
    pub cone_holds: bool,
    /// Its [`crate::Data::slide_directions`] entry, if any.
    pub preset: Option<SlideDirection>,
    /// At zero sliding speed with its sticking force inside the cone: that tangential force
    /// (N, along `t̂`), which holds the site at rest.
    pub held: Option<f64>,
    /// Whether its force comes from sticking (resolved by [`crate::friction`]): [`SlideDirection::FromRest`],
    /// or without a fixed direction `|v_t| ≤`
    /// [`crate::friction::SLIDING_SPEED_EPS_M_S`], or it slides into
    /// a wedge.
    pub at_rest: bool,
    /// Whether it slides into a wedge (the cone edge against its sliding through the hip).
    pub wedged: bool,
    /// The friction force on the robot along the site's tangent `t̂` (the row direction of a
    /// tangential row), `μ_k σ λ_n` (N), at the last assembly.
    pub force_t: f64,
}

/// The chain's law at a state, affine in the chain's rates: the torques `T_c` it applies at
/// the rates `θ̇_c` (N m, joint order) and its damping `K = −∂T/∂θ̇` (N m s/rad), so that
/// `T(θ̇) = T_c − K (θ̇ − θ̇_c)`.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainLaw {
    pub joints: Range<usize>,
    /// `θ̇_c` (rad/s).
    pub rates: DVector<f64>,
    pub torque: DVector<f64>,
    pub damping: DMatrix<f64>,
    /// Whether the damped slide holds on the law's piece at the state: its damping is
    /// positive definite, or it is on a saturated piece ([`Self::saturated`]) with damping
    /// at every other joint. Where it does not (both servos of a two-joint chain saturated,
    /// a phase without damping), `damping` and `saturated` are the last ones that held,
    /// carried over so that the flow stays defined up to the slide's liftoff guard, which
    /// fires there (`selfmanip_hybrid::damped_slide`).
    pub holds: bool,
    /// The chain's joint (its index in the chain) whose torque does not move with the
    /// chain's rates on the law's piece — a servo at its torque limit: its row of `K` is
    /// zero — with the symmetric part of `K` over the other joints positive definite; `None`
    /// on a piece with damping at every joint (`crate::damped_slide`, the saturated piece).
    pub saturated: Option<usize>,
}

/// The damped slide of one contact at one state ([`solve`]).
#[derive(Debug, Clone, PartialEq)]
pub struct DampedSlide {
    pub contact: usize,
    /// `(λ_t, λ_n)` in the contact's rows (N; `λ_n < 0` pushes).
    pub lambda: [f64; 2],
    /// `c = λ_t / λ_n = −μ_k s`.
    pub coef: f64,
    /// The side `s = ±1` of the sliding velocity `u_t` the friction opposes (`s = sign u_t`).
    pub side: f64,
    /// The foot's velocity with no force `w` and its mobility `G`, in the rows `(t, n)`. On
    /// a saturated piece, where the saturated joint moves the foot freely (`G` unbounded),
    /// `w` is the foot's velocity at the law's rates `θ̇_c` and `g` the limit `ε G` as that
    /// joint's damping `ε → 0`.
    pub w: Vector2<f64>,
    pub g: Matrix2<f64>,
    /// The foot's sliding velocity `u_t` in the tangential row (m/s).
    pub u_t: f64,
    /// The chain's rates `θ̇` (rad/s, joint order).
    pub rates: DVector<f64>,
    /// `K⁻¹`, the inverse of its law's damping (`n × n`, column-major), which the slide was
    /// solved with (and the chain's accelerations read); empty on a saturated piece, whose
    /// `K` is singular ([`ChainLaw::saturated`]).
    pub k_inv: Vec<f64>,
    /// Whether the slide is consistent: the foot pushes and, with friction, slides on the
    /// side its friction opposes, faster than the rest band
    /// ([`crate::friction::SLIDING_SPEED_EPS_M_S`]).
    pub consistent: bool,
    /// Whether its side is in Painlevé's region (`G_nn + c G_nt` within the wedge tolerance
    /// of zero or below it; [`crate::friction::WEDGE_TOL`]): its normal force is then held
    /// at the region's edge, and a flow keeps it only up to its liftoff guard.
    pub wedged: bool,
    /// The contact's rows `A` (tangential, normal; `2 × nq`).
    pub rows: DMatrix<f64>,
    /// Their rate `Ȧ` along `q̇` (`2 × nq`) where the slide was solved from the rows'
    /// assembly ([`crate::Data::prepare`]; `None` from rows a caller gave): what the chain's
    /// accelerations read (`selfmanip_hybrid::damped_slide::chain_accelerations`).
    pub rows_dot: Option<DMatrix<f64>>,
}

impl DampedSlide {
    /// The push `U = −λ_n` (N): the liftoff guard's function.
    pub fn push(&self) -> f64 {
        -self.lambda[1]
    }
}
