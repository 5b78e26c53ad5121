//! The reusable workspace of the dynamics pipeline ([`crate::dynamics`], Pinocchio's
//! `data`): every intermediate and output of one evaluation, with the solve of a prepared
//! KKT system that every stage above it shares.
use crate::constraint::Constraints;
use crate::contact::ContactMode;
use crate::inertia::InertiaScratch;
use crate::kinematics::Kinematics;
use crate::kkt::KktFactorization;
use crate::model::Model;
use crate::sliding::{ChainLaw, DampedSlide, SlideDirection, SlidingSite};
use nalgebra::{DMatrix, DVector};

/// Reusable workspace: every intermediate and output of one evaluation.
#[derive(Debug, Clone, Default)]
pub struct Data {
    pub kin: Kinematics,
    pub constraints: Constraints,
    /// `M̄` (q×q).
    pub m_bar: DMatrix<f64>,
    /// `C̄ q̇` (q).
    pub c_qd: DVector<f64>,
    /// `N̄` (q).
    pub n_bar: DVector<f64>,
    pub kkt: KktFactorization,
    /// Coordinates kept in the KKT system, ascending.
    pub dynamic_coords: Vec<usize>,
    /// Joints removed as free massless joints, ascending (with the [`Self::locked`] ones).
    pub free_joints: Vec<usize>,
    /// Massless joints in contact whose motion is prescribed, not solved for (set by the
    /// caller before [`Data::prepare`]; joints not in contact in the mode are free anyway).
    pub locked: Vec<usize>,
    /// Outputs: `q̈` (q) and `λ` (c), in the row order of `constraints.rows`.
    pub qdd: DVector<f64>,
    pub lambda: DVector<f64>,
    /// Sliding sites with kinetic friction in the prepared mode, and their generalized
    /// friction force `f^fr` (q) at the last solve ([`crate::friction`]).
    pub sliding: Vec<SlidingSite>,
    pub friction: DVector<f64>,
    /// Sliding directions fixed by the caller for a stretch of flow, by contact (set before
    /// [`Data::prepare`], kept by it); a sliding site not listed follows the instantaneous
    /// law, `σ = sign v_t` ([`crate::friction`]).
    pub slide_directions: Vec<(usize, SlideDirection)>,
    /// Whether a sliding site at rest without a fixed direction takes a cone edge even where
    /// the cone would hold it (as [`SlideDirection::FromRest`] does): what a
    /// caller that integrates the flow needs, where a site the cone holds must stick in a
    /// mode of its own; `false` (the instantaneous law): it is held for the instant.
    pub slide_at_rest: bool,
    /// The laws of massless chains whose contact may slide damped, by contact (set by the
    /// caller before [`Data::prepare`]; [`crate::damped_slide`]): a contact that slides in
    /// the prepared mode with a law here is a damped slide — its chain's joints are free,
    /// its force an applied one, its normal row's `λ` that force.
    pub damped_laws: Vec<(usize, ChainLaw)>,
    /// The damped slides of the prepared mode at the last solve.
    pub damped: Vec<DampedSlide>,
    /// The prepared mode and the mode of the KKT system without its damped slides, where
    /// they differ; the state's `q̇` they were prepared at.
    pub(crate) damped_modes: Option<(ContactMode, ContactMode)>,
    pub(crate) damped_qd: Vec<f64>,
    /// The rows of one damped slide's contact, assembled for its split (reused).
    pub(crate) damped_rows: Constraints,
    /// Whether a site of [`Self::sliding`] is general (folded into the solve), so that a
    /// solve without one does not look.
    pub(crate) has_general: bool,
    /// The fold of the general sliding sites' friction at the last solve, its buffers kept
    /// ([`crate::friction::fold::Fold`]).
    pub(crate) fold: crate::friction::fold::Fold,
    pub(crate) scratch: InertiaScratch,
    /// What [`Self::free_joints`] and [`Self::dynamic_coords`] were last found from: the
    /// key of the mode on the model and [`Self::locked`] then (`None` where not kept).
    pub(crate) free_key: Option<FreeJointsKey>,
    pub(crate) free_locked: Vec<usize>,
    /// The KKT right-hand side and solution on the dynamic coordinates.
    f_r: Vec<f64>,
    g_r: Vec<f64>,
    x_r: Vec<f64>,
}

impl Data {
    pub fn new(model: &Model) -> Self {
        let nq = model.nq();
        Data {
            m_bar: DMatrix::zeros(nq, nq),
            c_qd: DVector::zeros(nq),
            n_bar: DVector::zeros(nq),
            qdd: DVector::zeros(nq),
            friction: DVector::zeros(nq),
            ..Default::default()
        }
    }

    /// Solves the prepared KKT system for the generalized force `f(self, a)` at each dynamic
    /// coordinate `a` and the constraint right-hand side `g(self, r)` at each row `r`,
    /// writing full-length `x` (prescribed entries = `x_free`) and `y`.
    ///
    /// A free joint's column of `M̄` and of `A` is zero by construction (nothing massive and
    /// no active contact lies distal to it), so its prescribed acceleration moves nothing
    /// else and the kept system is just `f`, `g` on the dynamic coordinates. A locked joint's
    /// column of `M̄` is zero too (it is massless), but its column of `A` is not: its
    /// prescribed `x` enters `g`.
    // inlined into each caller, as when it shared a module with them (its callers' closures
    // then fold into the loops)
    #[inline(always)]
    pub(crate) fn solve_prepared(
        &mut self,
        f: impl Fn(&Self, usize) -> f64,
        g: impl Fn(&Self, usize) -> f64,
        x_free: Option<&[f64]>,
        x: &mut DVector<f64>,
        y: &mut DVector<f64>,
    ) {
        let nq = self.m_bar.nrows();
        let m = self.dynamic_coords.len();
        let c = self.constraints.n_rows();
        debug_assert!(self.free_joints.iter().all(|&j| {
            self.m_bar.column(j).iter().all(|&v| v == 0.0)
                && (self.locked.contains(&j)
                    || self.constraints.a.column(j).iter().all(|&v| v == 0.0))
        }));
        self.x_r.resize(m, 0.0);
        if x.len() != nq {
            set_zeros(x, nq);
        }
        if y.len() != c {
            set_zeros(y, c);
        }
        let (mut f_r, mut g_r) = (std::mem::take(&mut self.f_r), std::mem::take(&mut self.g_r));
        f_r.clear();
        f_r.extend(self.dynamic_coords.iter().map(|&a| f(self, a)));
        g_r.clear();
        g_r.extend((0..c).map(|r| g(self, r)));
        (self.f_r, self.g_r) = (f_r, g_r);
        if let (false, Some(xf)) = (self.locked.is_empty(), x_free) {
            let a = &self.constraints.a;
            for (i, &j) in self.free_joints.iter().enumerate() {
                if self.locked.contains(&j) {
                    for r in 0..c {
                        self.g_r[r] -= a[(r, j)] * xf[i];
                    }
                }
            }
        }
        self.kkt
            .solve(&self.f_r, &self.g_r, &mut self.x_r, y.as_mut_slice());
        let x = x.as_mut_slice();
        for (&a, &xr) in self.dynamic_coords.iter().zip(&self.x_r) {
            x[a] = xr;
        }
        for (i, &j) in self.free_joints.iter().enumerate() {
            x[j] = x_free.map_or(0.0, |xf| xf[i]);
        }
    }

    /// Sets [`Self::slide_directions`] to `dirs` (before [`Self::prepare`]); whether they
    /// changed.
    pub fn set_slide_directions(&mut self, dirs: &[(usize, SlideDirection)]) -> bool {
        if self.slide_directions == dirs {
            return false;
        }
        self.slide_directions.clear();
        self.slide_directions.extend_from_slice(dirs);
        true
    }

    /// `Υ − C̄q̇ − N̄` for joint torques `tau` (`N̄` includes the passive joint torques; plus
    /// the kinetic friction of sliding sites as last assembled by a solve at this state).
    pub fn generalized_force(&self, model: &Model, tau: &[f64]) -> DVector<f64> {
        DVector::from_fn(model.nq(), |a, _| self.generalized_force_at(model, tau, a))
    }

    /// Entry `a` of [`Self::generalized_force`].
    pub(crate) fn generalized_force_at(&self, model: &Model, tau: &[f64], a: usize) -> f64 {
        let f = -self.c_qd.as_slice()[a] - self.n_bar.as_slice()[a] + self.friction.as_slice()[a];
        match tau.get(a) {
            Some(t) if a < model.n_joints() => f + t,
            _ => f,
        }
    }
}

/// All that [`crate::dynamics::free_massless_joints`] reads of a model of at most 64 joints
/// and a mode, as bit sets over the joints: the links an active contact touches, the joints
/// that are not massless, the last joint of each leg (a joint's distal chain runs to its
/// leg's end); and the numbers of joints and coordinates. The free joints are a function of
/// it alone ([`Self::split`]), so that a workspace keeps them while it is the same
/// ([`Data::free_key`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct FreeJointsKey {
    touched: u64,
    massive: u64,
    ends: u64,
    n: usize,
    nq: usize,
}

impl FreeJointsKey {
    /// The key of `mode` on `model`; `None` for a model of more than 64 joints.
    pub(crate) fn of(model: &Model, mode: ContactMode) -> Option<Self> {
        let n = model.n_joints();
        if n > 64 {
            return None;
        }
        let (mut touched, mut massive, mut ends) = (0u64, 0u64, 0u64);
        for c in mode.active() {
            if let Some(l) = model.contacts[c].link {
                touched |= 1 << l;
            }
        }
        for (j, joint) in model.joints.iter().enumerate() {
            massive |= u64::from(!joint.is_massless()) << j;
        }
        for leg in &model.legs {
            if leg.n_links > 0 {
                // (a leg past the joints has no key: the general route reads the model)
                let last = leg.first_joint + leg.n_links - 1;
                if last >= n {
                    return None;
                }
                ends |= 1 << last;
            }
        }
        Some(FreeJointsKey {
            touched,
            massive,
            ends,
            n,
            nq: model.nq(),
        })
    }

    /// The free joints into `free` and the kept coordinates into `dynamic`
    /// ([`crate::dynamics::free_massless_joints`]): joint `j` is free iff neither an active
    /// contact nor a joint that is not massless lies on its distal chain.
    pub(crate) fn split(&self, free: &mut Vec<usize>, dynamic: &mut Vec<usize>) {
        free.clear();
        dynamic.clear();
        let blocked = self.touched | self.massive;
        for j in 0..self.n {
            // bits j..=e, e the first leg's end at or after j
            let above = self.ends & (u64::MAX << j);
            let chain = ((above & above.wrapping_neg()) << 1).wrapping_sub(1) & (u64::MAX << j);
            if blocked & chain == 0 {
                free.push(j);
            } else {
                dynamic.push(j);
            }
        }
        dynamic.extend(self.n..self.nq);
    }
}

/// `v = 0ₙ` in `v`'s own buffer: a workspace vector whose length moves between modes
/// allocates only to grow.
#[inline]
pub(crate) fn set_zeros(v: &mut DVector<f64>, n: usize) {
    let mut buf = take_entries(v);
    buf.clear();
    buf.resize(n, 0.0);
    *v = vector_on(buf);
}

/// The entries of `v`, its buffer taken (`v` left empty; neither allocates).
#[inline]
pub(crate) fn take_entries(v: &mut DVector<f64>) -> Vec<f64> {
    std::mem::take(v).data.into()
}

/// The vector of the entries `buf`, on its buffer (nalgebra's `from_vec` collects them anew).
#[inline]
pub(crate) fn vector_on(buf: Vec<f64>) -> DVector<f64> {
    let n = buf.len();
    DVector::from_data(nalgebra::VecStorage::new(
        nalgebra::Dyn(n),
        nalgebra::U1,
        buf,
    ))
}
