//! The damped slide of a massless chain: the contact problem of a foot at the end of a chain
//! of two or more massless joints under a law with damping, in the limit of vanishing link
//! inertia that defines the chain's motion in the air (`docs/singular-transitions.md` §10).
//!
//! A rigid slide of such a chain is never admissible (its normal row alone is a `1 × n`
//! block over `n ≥ 2` massless joints, §1), and where the chain's sticking force pulls the
//! rigid model has nothing left but to release the foot, which its own law puts straight
//! back. With link inertia `ε → 0` the chain's joints balance their torques at every
//! instant, `T(θ̇) = Bᵀλ` (`B` the contact's rows over the chain's joints, `λ` the ground's
//! force in the contact's rows, entering the dynamics as every contact force does, `−Aᵀλ`
//! in (5.3): the row convention of [`crate::contact`], `λ_n < 0` pushes), and a law whose
//! torque falls with the joints' rates, `T(θ̇) = T_c − K (θ̇ − θ̇_c)` with the damping
//! `K = −∂T/∂θ̇` positive definite, makes the chain's rates algebraic:
//!
//! ```text
//! θ̇ = θ̇_c + K⁻¹ (T_c − Bᵀλ),      u = A q̇ + B (θ̇ − θ̇_c) = w − G λ,
//! w = A q̇ + B K⁻¹ T_c,             G = B K⁻¹ Bᵀ,
//! ```
//!
//! `u` the foot's velocity in the contact's rows and `w` the velocity it has with no force
//! (the chain on its torque-free manifold). The **damped slide** is the contact's Coulomb
//! solution with the foot on the ground: `λ = λ_n (c e_t + e_n)`, `c = −μ_k s` with `s` the
//! side of the foot's sliding velocity `u_t` (`s = sign u_t`), and the normal force from
//! `u_n = 0`:
//!
//! ```text
//! λ_n = w_n / (G_nn + c G_nt).
//! ```
//!
//! The friction then dissipates: its power on the robot is `−λ_t u_t = μ_k s λ_n u_t =
//! μ_k λ_n |u_t| ≤ 0` with a pushing `λ_n < 0`.
//! It holds while the foot pushes (`U = −λ_n > 0`; its liftoff is `λ_n → 0`, where the
//! chain's rates meet the manifold's, `θ̇ = θ̇_c + K⁻¹ T_c`) and slides on its side
//! (`s u_t > 0`; its stick is `u_t → 0`). The force's power on the whole robot is
//! `−λ · u = −λ_t u_t` (`u_n = 0`): the friction's; on the massive part,
//! `−λ · (u − B θ̇) = −λ_t u_t + T(θ̇) · θ̇`, the friction's plus the chain law's (the
//! damping's among it), which an energy balance counts at the chain's joints.
//!
//! **The saturated piece.** A servo at its torque limit carries its torque whatever its
//! rate: the law's row of `K` for that joint `p` is zero ([`ChainLaw::saturated`]), `K` is
//! singular, and the chain's balance with `u_n = 0` is the bordered system
//!
//! ```text
//! [ K      Bᵀd ] [θ̇ − θ̇_c]   [ T_c            ]
//! [ b_nᵀ   0   ] [  λ_n   ] = [ −(A q̇)_n|_{θ̇_c} ],     d = (c, 1),
//! ```
//!
//! whose row `p` alone sets the normal force, `λ_n = T_p / (Bᵀd)_p`; the other joints'
//! balance sets their rates up to the saturated joint's free motion (the null vector `r` of
//! `K`, [`saturated_split`]), and `u_n = 0` sets that motion. It is the limit of the slide
//! with that joint damped by `ε → 0`, and its side's normal response is the limit
//! `ε (G_nn + c G_nt) = (b_nᵀ r) (Bᵀd)_p` (Painlevé's region where it is not positive).
//! Which piece of the law the slide lies on is the caller's to settle (the law at the
//! slide's own rates, `selfmanip_hybrid::damped_slide::prepare_on_pieces`).
//!
//! A stick that ends a damped slide without an impact (at a force event: a controller's
//! phase, another contact's guard) holds the foot at rest: the chain's rates are set so
//! that the foot's velocity is zero ([`stick_rates`]; the chain carries no momentum).
//!
//! This module is the contact problem at one state ([`solve`]) and the chain it applies to
//! ([`damped_chain`]); the law's `T_c` and `K` come from the caller, which knows the
//! controller.
use crate::constraint::Constraints;
use crate::contact::{ContactKind, ContactMode, RowDirection, Terrain};
use crate::data::Data;
use crate::error::{CoreError, Result};
use crate::friction::WEDGE_TOL;
use crate::kinematics::Kinematics;
use crate::model::Model;
use crate::sliding::SlideDirection;
pub use crate::sliding::{ChainLaw, DampedSlide};
use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
use std::ops::Range;

/// The massless joints of contact `k`'s chain — from the first joint whose whole distal
/// chain is massless to the contact's link — when they are two or more (a chain whose
/// rigid slide is singular); `None` for a body contact, a massive link, or a one-joint
/// chain (whose slide has a square `1 × 1` block and is the rigid engine's).
pub fn damped_chain(model: &Model, k: usize) -> Option<Range<usize>> {
    let j = model.contacts.get(k)?.link?;
    let first = model.chain(j).find(|&i| model.distal_massless(i))?;
    (j + 1 - first >= 2).then_some(first..j + 1)
}

/// The rates of contact `k`'s two-joint chain ([`damped_chain`]) that hold its foot at rest
/// at `(kin, q̇)`, the rest of `q̇` as it is: `θ̇ + B⁻¹ (−A q̇)`, `B` the contact's rows over
/// the chain (`2 × 2`). What a mode that sticks the foot starts from — the chain carries no
/// momentum, and a stick that finds its foot moving (a force event ends its slide, no impact
/// comes) holds the foot at that velocity otherwise, its sticking force then working on
/// the robot (`docs/singular-transitions.md` §10). `None` for a chain of other length or
/// where `B` is singular (the foot's rows do not fix the chain).
pub fn stick_rates(
    model: &Model,
    kin: &Kinematics,
    terrain: &dyn Terrain,
    k: usize,
    qd: &[f64],
) -> Option<DVector<f64>> {
    let joints = damped_chain(model, k).filter(|c| c.len() == 2)?;
    let a = contact_rows(model, kin, terrain, k, qd);
    let b = a.fixed_view::<2, 2>(0, joints.start).into_owned();
    let u = &a * DVector::from_column_slice(qd);
    let d = b.lu().solve(&Vector2::new(-u[0], -u[1]))?;
    d.iter()
        .all(|x| x.is_finite())
        .then(|| DVector::from_iterator(2, joints.zip(d.iter()).map(|(j, x)| qd[j] + x)))
}

/// The contact's two rows `A` (tangential, normal; `2 × nq`) at the kinematics `kin`.
pub fn contact_rows(
    model: &Model,
    kin: &Kinematics,
    terrain: &dyn Terrain,
    k: usize,
    qd: &[f64],
) -> DMatrix<f64> {
    let mut c = Constraints::default();
    let mode = ContactMode::FLIGHT.with(k, ContactKind::Stick);
    c.assemble(model, kin, terrain, mode, qd);
    debug_assert_eq!(c.rows[0].direction, RowDirection::Tangential);
    c.a
}

/// The contact's two rows `A` (tangential, normal; `2 × nq`), their rate `Ȧ` along `q̇` and
/// `Ȧ q̇`, at the kinematics `kin` (computed at `(q, q̇)`).
pub fn contact_rows_and_rates(
    model: &Model,
    kin: &Kinematics,
    terrain: &dyn Terrain,
    k: usize,
    qd: &[f64],
) -> (DMatrix<f64>, DMatrix<f64>, DVector<f64>) {
    let mut c = Constraints::default();
    let mode = ContactMode::FLIGHT.with(k, ContactKind::Stick);
    c.assemble(model, kin, terrain, mode, qd);
    (c.a, c.a_dot, c.a_dot_qd)
}

/// The foot's velocity `A q̇` (tangential, normal) in the contact's rows `a_s` (`2 × nq`,
/// column-major) with the chain's joints at the law's rates `θ̇_c`, the rest of `q̇` as it is.
fn velocity_at_law_rates(a_s: &[f64], qd: &[f64], law: &ChainLaw) -> [f64; 2] {
    let (j0, n) = (law.joints.start, law.joints.len());
    let rate = qd[..j0]
        .iter()
        .chain(law.rates.iter())
        .chain(&qd[j0 + n..])
        .copied();
    let mut u0 = [0.0; 2];
    exact::gemv_with(a_s, rate, &mut u0);
    u0
}

/// The foot's velocity with no force `w` and its mobility `G` (module docs) from the
/// contact's rows `a` at `q̇` under the chain's law `law`, with `K⁻¹` (`ki`, column-major
/// `n × n`).
///
/// ```text
/// w = A q̇|_{θ̇ = θ̇_c} + B (K⁻¹ T_c),   G = (B K⁻¹) Bᵀ
/// ```
fn mobility_of(
    a: &DMatrix<f64>,
    qd: &[f64],
    law: &ChainLaw,
    ki: &[f64],
) -> (Vector2<f64>, Matrix2<f64>) {
    let (j0, n) = (law.joints.start, law.joints.len());
    let a_s = a.as_slice();
    let b = &a_s[2 * j0..2 * (j0 + n)];
    let u0 = velocity_at_law_rates(a_s, qd, law);
    // B (K⁻¹ T_c)
    let mut kt = [0.0; MAX_EXACT];
    let mut bkt = [0.0; 2];
    let kt = if n <= MAX_EXACT {
        exact::gemv(ki, law.torque.as_slice(), &mut kt[..n]);
        &kt[..n]
    } else {
        return mobility_general(a, &u0, law, DMatrix::from_column_slice(n, n, ki));
    };
    exact::gemv(b, kt, &mut bkt);
    let w = Vector2::new(u0[0] + bkt[0], u0[1] + bkt[1]);
    // G = (B K⁻¹) Bᵀ, column by column
    let mut bk = [0.0; 2 * MAX_EXACT];
    for j in 0..n {
        exact::gemv(b, &ki[j * n..(j + 1) * n], &mut bk[2 * j..2 * j + 2]);
    }
    let mut g = [0.0; 4];
    for j in 0..2 {
        exact::gemv_with(
            &bk[..2 * n],
            (0..n).map(|p| b[2 * p + j]),
            &mut g[2 * j..2 * j + 2],
        );
    }
    (w, Matrix2::from_column_slice(&g))
}

/// [`mobility_of`] for a chain of more than [`MAX_EXACT`] joints, in nalgebra's own
/// products (the same order of operations), from `u0 = A q̇|_{θ̇ = θ̇_c}`.
#[cold]
fn mobility_general(
    a: &DMatrix<f64>,
    u0: &[f64; 2],
    law: &ChainLaw,
    k_inv: DMatrix<f64>,
) -> (Vector2<f64>, Matrix2<f64>) {
    let b = a.columns(law.joints.start, law.joints.len()).into_owned();
    let bkt = &b * (&k_inv * &law.torque);
    let g = &b * &k_inv * b.transpose();
    (
        Vector2::new(u0[0] + bkt[0], u0[1] + bkt[1]),
        Matrix2::new(g[(0, 0)], g[(0, 1)], g[(1, 0)], g[(1, 1)]),
    )
}

/// The longest chain whose small products run on the stack ([`exact`]).
const MAX_EXACT: usize = 8;

/// Small dense products on slices, without allocating, in nalgebra's own order of
/// operations (so that they give its results bit for bit): `y = M x` as its `gemv` — column
/// by column, `y = x₀ M₀`, then `y = xⱼ Mⱼ + y` — and `uᵀv` as its `dot` — below 8 entries
/// a running sum from `+0`, else nalgebra's own.
pub mod exact {
    /// `y = M x`, `M` column-major with `y.len()` rows and `x.len()` columns.
    #[inline]
    pub fn gemv(m: &[f64], x: &[f64], y: &mut [f64]) {
        gemv_with(m, x.iter().copied(), y);
    }

    /// [`gemv`] with `x` given by its entries in order.
    #[inline]
    pub fn gemv_with(m: &[f64], x: impl Iterator<Item = f64>, y: &mut [f64]) {
        let r = y.len();
        let mut first = true;
        for (j, xj) in x.enumerate() {
            let col = &m[j * r..(j + 1) * r];
            if first {
                for (yi, mi) in y.iter_mut().zip(col) {
                    *yi = xj * mi;
                }
                first = false;
            } else {
                for (yi, mi) in y.iter_mut().zip(col) {
                    *yi += xj * mi;
                }
            }
        }
        if first {
            y.fill(0.0);
        }
    }

    /// `uᵀ v`.
    #[inline]
    pub fn dot(u: &[f64], v: &[f64]) -> f64 {
        debug_assert_eq!(u.len(), v.len());
        if u.len() >= 8 {
            let (u, v) = (
                nalgebra::DVectorView::from_slice(u, u.len()),
                nalgebra::DVectorView::from_slice(v, v.len()),
            );
            return u.dot(&v);
        }
        let mut s = 0.0;
        for (a, b) in u.iter().zip(v) {
            s += a * b;
        }
        s
    }
}

/// The damped slide of contact `k` (on the chain of `law`, [`damped_chain`]) at `(kin, q̇)`
/// with kinetic friction `mu_k`: on the side `side` (`±1`) when given (a segment keeps its
/// side; the stick guard ends it), else on the side where it is consistent — the foot
/// pushes and slides that way. Where both sides are or neither is, the side of the foot's
/// sticking force `λ_s = G⁻¹ w` where it pushes (the cone's edge it reaches), else that of
/// the frictionless slide's `u_t` (`w_t − G_tn w_n / G_nn`).
/// Where neither side is consistent (the foot leaves, or sticks), the frictionless slide's
/// side, flagged inconsistent ([`DampedSlide::consistent`]). `None` where `K` is singular.
/// A law that is not finite is [`CoreError::NonFiniteResult`].
#[allow(clippy::too_many_arguments)]
pub fn solve(
    model: &Model,
    kin: &Kinematics,
    terrain: &dyn Terrain,
    k: usize,
    qd: &[f64],
    law: &ChainLaw,
    mu_k: f64,
    side: Option<f64>,
) -> Result<Option<DampedSlide>> {
    solve_rows(
        k,
        contact_rows(model, kin, terrain, k, qd),
        qd,
        law,
        mu_k,
        side,
    )
}

/// [`solve`] with the contact's rows `a` ([`contact_rows`]).
pub fn solve_rows(
    k: usize,
    a: DMatrix<f64>,
    qd: &[f64],
    law: &ChainLaw,
    mu_k: f64,
    side: Option<f64>,
) -> Result<Option<DampedSlide>> {
    let mut slide = DampedSlide::unsolved(k, law.joints.len(), DMatrix::zeros(0, 0));
    Ok(solve_into(&a, qd, law, mu_k, side, &mut slide)?.then(|| {
        slide.rows = a;
        slide
    }))
}

impl DampedSlide {
    /// A slide of contact `k` on a chain of `n` joints with the rows `rows`, its numbers
    /// not yet solved: the buffers [`solve_into`] fills.
    fn unsolved(k: usize, n: usize, rows: DMatrix<f64>) -> Self {
        DampedSlide {
            contact: k,
            lambda: [0.0; 2],
            coef: 0.0,
            side: 0.0,
            w: Vector2::zeros(),
            g: Matrix2::zeros(),
            u_t: 0.0,
            rates: DVector::zeros(n),
            k_inv: Vec::new(),
            consistent: false,
            wedged: false,
            rows,
            rows_dot: None,
        }
    }
}

/// `dst = src`, in `dst`'s own buffer where the shapes agree.
pub fn assign(dst: &mut DMatrix<f64>, src: &DMatrix<f64>) {
    if dst.shape() == src.shape() {
        dst.as_mut_slice().copy_from_slice(src.as_slice());
    } else {
        *dst = src.clone();
    }
}

/// `dst = src` by swapping their buffers where the shapes agree (`src` then holds `dst`'s
/// old entries), else by a copy.
#[inline]
fn take_rows(dst: &mut DMatrix<f64>, src: &mut DMatrix<f64>) {
    if dst.shape() == src.shape() {
        std::mem::swap(dst, src);
    } else {
        *dst = src.clone();
    }
}

/// [`solve_rows`] into `slide`'s numbers and rates (its contact, rows and `Ȧ` left to the
/// caller), in its own buffers: whether there is a slide.
fn solve_into(
    a: &DMatrix<f64>,
    qd: &[f64],
    law: &ChainLaw,
    mu_k: f64,
    side: Option<f64>,
    slide: &mut DampedSlide,
) -> Result<bool> {
    if !law
        .torque
        .as_slice()
        .iter()
        .chain(law.damping.as_slice())
        .all(|v| v.is_finite())
    {
        return Err(CoreError::NonFiniteResult {
            quantity: "a damped chain's torques or damping",
        });
    }
    if let Some(p) = law.saturated {
        return solve_saturated_into(a, qd, law, p, mu_k, side, slide);
    }
    // K⁻¹ in place, in the slide's own buffer
    let (j0, n) = (law.joints.start, law.joints.len());
    slide.k_inv.clear();
    slide.k_inv.extend_from_slice(law.damping.as_slice());
    if !nalgebra::DMatrixViewMut::from_slice(&mut slide.k_inv, n, n).try_inverse_mut() {
        return Ok(false);
    }
    let ki = &slide.k_inv[..];
    let (w, g) = mobility_of(a, qd, law, ki);
    // Painlevé's region: on a side whose normal response `G_nn + c G_nt` is within the
    // wedge tolerance of zero or below it, a pushing force draws the foot into the ground
    let wedge = WEDGE_TOL * (g[(1, 1)] + mu_k * g[(1, 0)].abs());
    // u = w − G λ with λ = λ_n (c e_t + e_n), c = −μ_k s: u_n = 0 sets λ_n (the response
    // held at the wedge's edge inside Painlevé's region, so that a slide kept on its side
    // stays finite up to its liftoff guard, which fires there: `DampedSlide::wedged`)
    let on_side = |s: f64| {
        let c = -mu_k * s;
        let den = (g[(1, 1)] + c * g[(1, 0)]).max(wedge);
        let lambda_n = w[1] / den;
        let u_t = w[0] - (g[(0, 1)] + c * g[(0, 0)]) * lambda_n;
        (c, lambda_n, u_t)
    };
    let consistent = |s: f64| {
        let (c, lambda_n, u_t) = on_side(s);
        // a foot at rest on its side (`|u_t|` within the rest band) is coming to rest or
        // starting from it: sticking, not sliding, is its continuation
        lambda_n.is_finite()
            && g[(1, 1)] + c * g[(1, 0)] > wedge
            && lambda_n < 0.0
            && (mu_k == 0.0 || s * u_t > crate::friction::SLIDING_SPEED_EPS_M_S)
    };
    // the side of the sticking force `λ_s = G⁻¹ w` (`u = 0`), else the frictionless
    // slide's `u_t`
    let rest = || {
        g.try_inverse()
            .map(|gi| gi * w)
            .filter(|l| l[1] < 0.0)
            .map_or(0.0, |l| l[0].signum())
    };
    let free = || (w[0] - g[(0, 1)] * w[1] / g[(1, 1)]).signum();
    let s = chosen_side(side, rest, free, consistent);
    let (c, lambda_n, u_t) = on_side(s);
    if !lambda_n.is_finite() {
        return Ok(false);
    }
    let lambda = Vector2::new(c * lambda_n, lambda_n);
    // θ̇ = θ̇_c + K⁻¹ (T_c − Bᵀ λ)
    let b = &a.as_slice()[2 * j0..2 * (j0 + n)];
    let rest = (0..n).map(|p| {
        let bt_lambda = lambda[1] * b[2 * p + 1] + lambda[0] * b[2 * p];
        law.torque[p] - bt_lambda
    });
    if slide.rates.len() != n {
        slide.rates = DVector::zeros(n);
    }
    exact::gemv_with(ki, rest, slide.rates.as_mut_slice());
    for (r, c) in slide.rates.iter_mut().zip(law.rates.iter()) {
        *r += c;
    }
    slide.lambda = [lambda[0], lambda[1]];
    slide.coef = c;
    slide.side = s;
    slide.w = w;
    slide.g = g;
    slide.u_t = u_t;
    slide.consistent = consistent(s);
    slide.wedged = g[(1, 1)] + c * g[(1, 0)] <= wedge;
    Ok(true)
}

/// The side a slide takes: `side` where given (a segment keeps its side), else the side of
/// the foot's sticking force `rest` where it pushes — a foot leaving the cone at rest slides
/// on the edge its sticking force reached (continuity, `c = λ_t/λ_n = −μ_k s` there) —, else
/// that of the frictionless slide's `u_t` (`free`); the other side where only it is
/// `consistent`.
fn chosen_side(
    side: Option<f64>,
    rest: impl FnOnce() -> f64,
    free: impl FnOnce() -> f64,
    consistent: impl Fn(f64) -> bool,
) -> f64 {
    if let Some(s) = side.filter(|&s| s != 0.0) {
        return s.signum();
    }
    let rest = rest();
    let first = if rest != 0.0 { rest } else { free() };
    let first = if first == 0.0 || first.is_nan() {
        1.0
    } else {
        first
    };
    if !consistent(first) && consistent(-first) {
        -first
    } else {
        first
    }
}

/// The split of a saturated piece's damping `K` (`n × n`, its row `p` zero:
/// [`ChainLaw::saturated`]): the solution `x₀` of `K x = y` with `x₀_p = 0` —
/// `K_FF x₀_F = y_F` over the other joints `F`; row `p` of `y` is the caller's to balance —
/// and the null vector `r` of `K` with `r_p = 1` (`K_FF r_F = −K_Fp`), so that every
/// solution is `x₀ + σ r`. `None` where `K_FF` is singular.
pub fn saturated_split(
    k: &DMatrix<f64>,
    p: usize,
    y: &[f64],
) -> Option<(DVector<f64>, DVector<f64>)> {
    let n = k.nrows();
    let free: Vec<usize> = (0..n).filter(|&i| i != p).collect();
    let lu = DMatrix::from_fn(n - 1, n - 1, |r, c| k[(free[r], free[c])]).lu();
    let x = lu.solve(&DVector::from_iterator(n - 1, free.iter().map(|&i| y[i])))?;
    let r = lu.solve(&DVector::from_iterator(
        n - 1,
        free.iter().map(|&i| -k[(i, p)]),
    ))?;
    let (mut x0, mut r0) = (DVector::zeros(n), DVector::zeros(n));
    for (c, &i) in free.iter().enumerate() {
        x0[i] = x[c];
        r0[i] = r[c];
    }
    r0[p] = 1.0;
    (x0.iter().chain(r0.iter()).all(|v| v.is_finite())).then_some((x0, r0))
}

/// [`solve_into`] on a saturated piece (module docs): joint `p` of the chain carries its
/// law's torque `T_p` whatever its rate, so its balance alone sets the normal force on a
/// side, `λ_n = T_p / (Bᵀd)_p`, the other joints' balance sets their rates up to the
/// saturated joint's free motion `r` (the null vector of `K`, [`saturated_split`]), and
/// `u_n = 0` sets that motion. The side's normal response is the limit `ε D = (b_nᵀ r)
/// (Bᵀd)_p` of `ε (G_nn + c G_nt)` as the saturated joint's damping `ε → 0`: Painlevé's
/// region where it is within the wedge tolerance of zero or below.
#[allow(clippy::too_many_arguments)]
fn solve_saturated_into(
    a: &DMatrix<f64>,
    qd: &[f64],
    law: &ChainLaw,
    p: usize,
    mu_k: f64,
    side: Option<f64>,
    slide: &mut DampedSlide,
) -> Result<bool> {
    let (j0, n) = (law.joints.start, law.joints.len());
    if p >= n || n < 2 {
        return Ok(false);
    }
    let a_s = a.as_slice();
    let b = &a_s[2 * j0..2 * (j0 + n)];
    let (b_t, b_n) = (|i: usize| b[2 * i], |i: usize| b[2 * i + 1]);
    let u0 = velocity_at_law_rates(a_s, qd, law);
    let k = &law.damping;
    let bn_norm = (0..n).map(|i| b_n(i) * b_n(i)).sum::<f64>().sqrt();
    // on the cone's edge `d = (c, 1)`: λ_n, the rates' step from θ̇_c, u_t and the normal
    // response with its wedge tolerance
    let on_edge = |c: f64| {
        let bd_p = b_n(p) + c * b_t(p);
        let lambda_n = law.torque[p] / bd_p;
        let y: Vec<f64> = (0..n)
            .map(|i| law.torque[i] - (b_n(i) + c * b_t(i)) * lambda_n)
            .collect();
        let (x0, r) = saturated_split(k, p, &y)?;
        let bn_r: f64 = (0..n).map(|i| b_n(i) * r[i]).sum();
        let bn_x0: f64 = (0..n).map(|i| b_n(i) * x0[i]).sum();
        let step = x0 + r.clone() * (-(u0[1] + bn_x0) / bn_r);
        let u_t = u0[0] + (0..n).map(|i| b_t(i) * step[i]).sum::<f64>();
        // the normal response `(b_nᵀ r)(Bᵀd)_p` against its scale `|b_n| |r| (|b_np| + μ
        // |b_tp|)`: it wedges where the saturated joint's free motion stops moving the foot
        // normally (`b_nᵀ r → 0`, the rates' step growing as its inverse) as where `(Bᵀd)_p`
        // vanishes
        let response = bn_r * bd_p;
        let wedge = WEDGE_TOL * bn_norm * r.norm() * (b_n(p).abs() + mu_k * b_t(p).abs());
        let finite = lambda_n.is_finite() && u_t.is_finite() && step.iter().all(|v| v.is_finite());
        finite.then_some((lambda_n, step, u_t, response, wedge, r))
    };
    let consistent = |s: f64| {
        on_edge(-mu_k * s).is_some_and(|(lambda_n, _, u_t, response, wedge, _)| {
            response > wedge
                && lambda_n < 0.0
                && (mu_k == 0.0 || s * u_t > crate::friction::SLIDING_SPEED_EPS_M_S)
        })
    };
    // the sticking force: [K Bᵀ; B 0] [θ̇ − θ̇_c; λ] = [T_c; −u0]
    let rest = || {
        let h = DMatrix::from_fn(n + 2, n + 2, |r, c| match (r < n, c < n) {
            (true, true) => k[(r, c)],
            (true, false) => b[2 * r + (c - n)],
            (false, true) => b[2 * c + (r - n)],
            (false, false) => 0.0,
        });
        let rhs = DVector::from_iterator(n + 2, law.torque.iter().copied().chain([-u0[0], -u0[1]]));
        h.lu()
            .solve(&rhs)
            .filter(|x| x[n + 1] < 0.0)
            .map_or(0.0, |x| x[n].signum())
    };
    let free = || on_edge(0.0).map_or(0.0, |e| e.2.signum());
    let s = chosen_side(side, rest, free, consistent);
    let c = -mu_k * s;
    let Some((lambda_n, step, u_t, response, wedge, r)) = on_edge(c) else {
        return Ok(false);
    };
    if slide.rates.len() != n {
        slide.rates = DVector::zeros(n);
    }
    for (i, x) in slide.rates.iter_mut().enumerate() {
        *x = law.rates[i] + step[i];
    }
    let br_t: f64 = (0..n).map(|i| b_t(i) * r[i]).sum();
    let br_n: f64 = (0..n).map(|i| b_n(i) * r[i]).sum();
    slide.lambda = [c * lambda_n, lambda_n];
    slide.coef = c;
    slide.side = s;
    slide.w = Vector2::new(u0[0], u0[1]);
    // ε G → (B r) b_pᵀ
    slide.g = Matrix2::new(br_t * b_t(p), br_t * b_n(p), br_n * b_t(p), br_n * b_n(p));
    slide.u_t = u_t;
    slide.k_inv.clear();
    slide.consistent = consistent(s);
    slide.wedged = response <= wedge;
    Ok(true)
}

/// The mode of the KKT system for `mode`: without the contacts that slide damped — those
/// with a law in [`Data::damped_laws`] that slide in `mode` and whose law's damping is
/// invertible —, whose slides at `(data.kin, q̇)` go into [`Data::damped`] (on the side the
/// caller fixed in [`Data::slide_directions`], `σ = sign v_t = −sign u_t`, else the
/// consistent one). `mode` itself where there are none.
#[inline(never)]
pub(crate) fn split(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    mode: ContactMode,
    qd: &[f64],
) -> Result<ContactMode> {
    data.damped_modes = None;
    if data.damped_laws.is_empty() {
        if !data.damped.is_empty() {
            data.damped.clear();
        }
        return Ok(mode);
    }
    // the slides are solved into the buffers of the last split's (`used` of them so far)
    let mut used = 0;
    let mut inner = mode;
    for (k, law) in &data.damped_laws {
        let k = *k;
        if mode.kind(k) != Some(ContactKind::Slide) {
            continue;
        }
        let side = data
            .slide_directions
            .iter()
            .find(|d| d.0 == k)
            .and_then(|d| match d.1 {
                SlideDirection::Fixed(s) if s != 0.0 => Some(-s),
                _ => None,
            });
        // the contact's rows A and their rate Ȧ (contact_rows_and_rates), in the
        // workspace's own buffers
        let rows = &mut data.damped_rows;
        let mode_k = ContactMode::FLIGHT.with(k, ContactKind::Stick);
        rows.assemble(model, &data.kin, terrain, mode_k, qd);
        let mu_k = model.contacts[k].kinetic_mu;
        if used == data.damped.len() {
            let slide = DampedSlide::unsolved(k, law.joints.len(), rows.a.clone());
            data.damped.push(slide);
        }
        let slide = &mut data.damped[used];
        match solve_into(&rows.a, qd, law, mu_k, side, slide) {
            // no slide is kept from a split that fails (Data::prepare_mode skips the split
            // where there are no laws and no split before)
            Err(e) => {
                data.damped.clear();
                return Err(e);
            }
            Ok(false) => continue,
            Ok(true) => {}
        }
        slide.contact = k;
        // the rows go to the slide, its old buffers back to the workspace (the next
        // assembly rewrites them)
        take_rows(&mut slide.rows, &mut rows.a);
        match &mut slide.rows_dot {
            Some(a_dot) => take_rows(a_dot, &mut rows.a_dot),
            None => slide.rows_dot = Some(rows.a_dot.clone()),
        }
        // on a fixed side, the slide wedges where `G_nn + c G_nt` reaches zero (its
        // normal force would grow without bound): flagged (DampedSlide::wedged), its
        // liftoff guard ends it there and the reset judges the contact again
        used += 1;
        inner = inner.without(k);
    }
    data.damped.truncate(used);
    if inner != mode {
        data.damped_modes = Some((mode, inner));
        data.damped_qd.clear();
        data.damped_qd.extend_from_slice(qd);
    }
    Ok(inner)
}

/// A row vector of the KKT system's mode (`v`) in the rows of the prepared mode, in `v`'s
/// own buffer: a damped slide's normal row takes `normal(slide)`.
pub(crate) fn splice(data: &Data, v: &mut DVector<f64>, normal: impl Fn(&DampedSlide) -> f64) {
    let Some((mode, _)) = data.damped_modes else {
        return;
    };
    // the active contacts, as bits
    let mut active = mode.active().fold(0u32, |m, k| m | 1 << k);
    let slides = data.damped.iter().fold(0u32, |m, d| m | 1 << d.contact);
    // from the last contact back (`ContactMode::rows`: each contact's rows together, the
    // contacts ascending), each row of the KKT system's mode to its own row of the prepared
    // mode — as late as it was or later: the slides' rows come in between
    let mut inner = v.len();
    let mut buf = crate::data::take_entries(v);
    buf.resize(mode.n_rows(), 0.0);
    let mut r = buf.len();
    while active != 0 {
        let k = 31 - active.leading_zeros() as usize;
        active &= !(1 << k);
        let rows = mode.n_rows_of(k);
        if slides >> k & 1 == 1 {
            let d = data.damped.iter().find(|d| d.contact == k);
            let value = normal(d.expect("a damped slide"));
            for _ in 0..rows {
                r -= 1;
                buf[r] = value;
            }
        } else {
            for _ in 0..rows {
                r -= 1;
                inner -= 1;
                buf[r] = buf[inner];
            }
        }
    }
    debug_assert_eq!((r, inner), (0, 0), "the rows of the KKT system's mode");
    *v = crate::data::vector_on(buf);
}

/// After a plastic impact into a mode with damped slides (which take no impulse): each
/// chain's rates jump to its slide's at the impact's `q̇⁺` (on the consistent side).
pub(crate) fn impact_rates(model: &Model, data: &Data, qd_plus: &mut DVector<f64>) -> Result<()> {
    for d in &data.damped {
        let Some((_, law)) = data.damped_laws.iter().find(|(k, _)| *k == d.contact) else {
            continue;
        };
        let mu_k = model.contacts[d.contact].kinetic_mu;
        if let Some(after) = solve_rows(
            d.contact,
            d.rows.clone(),
            qd_plus.as_slice(),
            law,
            mu_k,
            None,
        )? {
            for (j, r) in law.joints.clone().zip(after.rates.iter()) {
                qd_plus[j] = *r;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// The slice products give nalgebra's own products bit for bit (what they replace):
    /// `M x` for every shape up to 12 × 12 (with a zero-column one), and `uᵀv` for every
    /// length up to 12, across the 8 entries where nalgebra's dot unrolls.
    #[test]
    fn exact_products_are_nalgebras_bit_for_bit() {
        let mut r = ChaCha8Rng::seed_from_u64(30);
        for rows in 1..=12 {
            for cols in 0..=12 {
                let m = DMatrix::from_fn(rows, cols, |_, _| r.gen_range(-1.0..1.0));
                let x = DVector::from_fn(cols, |_, _| r.gen_range(-1.0..1.0));
                let mut y = vec![f64::NAN; rows];
                exact::gemv(m.as_slice(), x.as_slice(), &mut y);
                assert_eq!(bits(&y), bits((&m * &x).as_slice()), "{rows}×{cols}");
            }
            let u = DVector::from_fn(rows, |_, _| r.gen_range(-1.0..1.0));
            let v = DVector::from_fn(rows, |_, _| r.gen_range(-1.0..1.0));
            let d = exact::dot(u.as_slice(), v.as_slice());
            assert_eq!(d.to_bits(), u.dot(&v).to_bits(), "dot of {rows}");
        }
    }

    /// Random rows `A` (`2 × nq`), rates `q̇` and a law with positive definite damping
    /// over the chain of `n` joints from `j0`.
    fn random_slide(
        r: &mut ChaCha8Rng,
        n: usize,
        nq: usize,
        j0: usize,
    ) -> (DMatrix<f64>, Vec<f64>, ChainLaw) {
        let a = DMatrix::from_fn(2, nq, |_, _| r.gen_range(-1.0..1.0));
        let qd: Vec<f64> = (0..nq).map(|_| r.gen_range(-2.0..2.0)).collect();
        let c = DMatrix::from_fn(n, n, |_, _| r.gen_range(-0.3..0.3));
        let law = ChainLaw {
            joints: j0..j0 + n,
            rates: DVector::from_fn(n, |_, _| r.gen_range(-2.0..2.0)),
            torque: DVector::from_fn(n, |_, _| r.gen_range(-1.0..1.0)),
            damping: &c * c.transpose() + DMatrix::identity(n, n),
            holds: true,
            saturated: None,
        };
        (a, qd, law)
    }

    /// The damped slide on slices ([`solve_rows`]) against its products written in
    /// nalgebra (the route it replaced), bit for bit, for chains of 2 to 10 joints (beyond
    /// [`MAX_EXACT`] too) at random rows, rates and laws; and the slide's own physics: the
    /// foot stays on the ground (`u_n = (A q̇)_n = 0` at the slide's rates) and the chain's
    /// torques balance the ground's force (`T(θ̇) = Bᵀλ`).
    #[test]
    fn damped_slide_on_slices_is_the_nalgebra_route() {
        let mut r = ChaCha8Rng::seed_from_u64(31);
        let mut checked = 0;
        for n in 2..=10 {
            for _ in 0..20 {
                let j0 = 1;
                let (a, qd, law) = random_slide(&mut r, n, n + 4, j0);
                let Some(slide) = solve_rows(0, a.clone(), &qd, &law, 0.6, None).unwrap() else {
                    continue;
                };
                // the nalgebra route
                let b = a.columns(j0, n).into_owned();
                let k_inv = law.damping.clone().try_inverse().unwrap();
                let mut v = DVector::from_column_slice(&qd);
                v.rows_mut(j0, n).copy_from(&law.rates);
                let w = &a * v + &b * (&k_inv * &law.torque);
                let g = &b * &k_inv * b.transpose();
                let lambda = DVector::from_column_slice(&slide.lambda);
                let rates = &law.rates + &k_inv * (&law.torque - b.transpose() * &lambda);
                assert_eq!(bits(slide.w.as_slice()), bits(w.as_slice()), "w, n={n}");
                assert_eq!(bits(slide.g.as_slice()), bits(g.as_slice()), "G, n={n}");
                assert_eq!(
                    bits(slide.rates.as_slice()),
                    bits(rates.as_slice()),
                    "θ̇, n={n}"
                );
                // u_n = 0 and T(θ̇) = T_c − K (θ̇ − θ̇_c) = Bᵀλ, where the normal response
                // is outside Painlevé's region (the normal force is then not held)
                if !slide.wedged {
                    let mut qd_s = DVector::from_column_slice(&qd);
                    qd_s.rows_mut(j0, n).copy_from(&slide.rates);
                    let u = &a * qd_s;
                    let scale = 1.0 + w.norm() + g.norm() * lambda.norm();
                    assert!(u[1].abs() < 1e-12 * scale, "u_n = {}, n={n}", u[1]);
                    let t = &law.torque - &law.damping * (&slide.rates - &law.rates);
                    let bt = b.transpose() * &lambda;
                    assert!((t - bt).norm() < 1e-11 * scale, "torque balance, n={n}");
                }
                checked += 1;
            }
        }
        assert!(checked > 150, "{checked}");
    }

    /// The slide on a saturated piece (a joint `p` whose row of `K` is zero, its torque
    /// fixed: [`solve_saturated_into`]) is the limit of the slide with that joint damped by
    /// `ε → 0` (`K + ε e_p e_pᵀ`, the full piece's route): on a fixed side, the force and
    /// the rates of chains of 2 to 5 joints — whose other joints couple to the saturated
    /// one, `K_Fp ≠ 0` — at random rows, rates and laws, their difference falling with
    /// `ε`; and its own equations hold: `u_n = 0` and `T_c − K (θ̇ − θ̇_c) = Bᵀλ`, the
    /// saturated row included.
    #[test]
    fn the_saturated_piece_is_the_limit_of_vanishing_damping() {
        let mut r = ChaCha8Rng::seed_from_u64(33);
        let mut checked = 0;
        for n in 2..=5 {
            for case in 0..40 {
                let j0 = 1;
                let (a, qd, mut law) = random_slide(&mut r, n, n + 4, j0);
                let p = case % n;
                for c in 0..n {
                    law.damping[(p, c)] = 0.0;
                }
                law.saturated = Some(p);
                let side = Some(if case % 2 == 0 { 1.0 } else { -1.0 });
                let Some(sat) = solve_rows(0, a.clone(), &qd, &law, 0.6, side).unwrap() else {
                    continue;
                };
                if sat.wedged {
                    continue;
                }
                // its equations
                let b = a.columns(j0, n).into_owned();
                let lambda = DVector::from_column_slice(&sat.lambda);
                let mut qd_s = DVector::from_column_slice(&qd);
                qd_s.rows_mut(j0, n).copy_from(&sat.rates);
                let scale = 1.0 + lambda.norm() + sat.rates.norm();
                assert!((&a * qd_s)[1].abs() < 1e-10 * scale, "u_n, n={n}");
                let t = &law.torque - &law.damping * (&sat.rates - &law.rates);
                assert!(
                    (t - b.transpose() * &lambda).amax() < 1e-10 * scale,
                    "balance"
                );
                // the limit
                let gap = |eps: f64| {
                    let mut damped = law.clone();
                    damped.damping[(p, p)] = eps;
                    damped.saturated = None;
                    let d = solve_rows(0, a.clone(), &qd, &damped, 0.6, side)
                        .unwrap()
                        .expect("the slide of the damped joint");
                    let dl = (DVector::from_column_slice(&d.lambda) - &lambda).amax();
                    (dl + (&d.rates - &sat.rates).amax()) / scale
                };
                // O(ε), down to the round-off of K⁻¹'s entries of order 1/ε
                let (coarse, fine) = (gap(1e-4), gap(1e-6));
                assert!(
                    fine < 0.03 * coarse + 1e-9,
                    "n={n}, p={p}: {coarse:e} → {fine:e}"
                );
                checked += 1;
            }
        }
        assert!(checked > 60, "{checked}");
    }

    /// A saturated slide wedges where the saturated joint's free motion `r` (the null vector
    /// of `K`) stops moving the foot normally: with the chain's normal row `b_n` turned so
    /// that `b_nᵀ r = δ |b_n| |r|`, the rates' step grows as `1/δ` (the bordered system's
    /// `σ = −(u0_n + b_nᵀ x₀)/(b_nᵀ r)`), and the slide is flagged wedged — its liftoff
    /// guard ends it — once `|δ|` is below the wedge tolerance, on either side of the right
    /// angle, and not while `|δ|` is well above it.
    #[test]
    fn a_saturated_slide_wedges_where_its_free_motion_leaves_the_normal() {
        let mut rng = ChaCha8Rng::seed_from_u64(34);
        let mut checked = 0;
        for case in 0..60 {
            let n = 2 + case % 3;
            let j0 = 1;
            let (mut a, qd, mut law) = random_slide(&mut rng, n, n + 4, j0);
            let p = case % n;
            for c in 0..n {
                law.damping[(p, c)] = 0.0;
            }
            law.saturated = Some(p);
            let (_, r) = saturated_split(&law.damping, p, &vec![0.0; n]).unwrap();
            // the chain's normal row without its component along `r`
            let r_hat = r.normalize();
            let b_n = DVector::from_fn(n, |i, _| a[(1, j0 + i)]);
            let b_perp = &b_n - &r_hat * b_n.dot(&r_hat);
            let mut wedged_at = Vec::new();
            let mut steps = Vec::new();
            for delta in [0.3, 0.1, 1e-5, -1e-5, 1e-8] {
                // b_nᵀ r = δ |b_⊥| |r|
                let row = &b_perp + &r_hat * (delta * b_perp.norm());
                for i in 0..n {
                    a[(1, j0 + i)] = row[i];
                }
                // the edge's lever at the saturated joint, `(Bᵀd)_p` on side `s = 1`, clear
                // of zero (else the slide wedges there whatever `δ`)
                if row[p] - 0.6 * a[(0, j0 + p)] < 0.1 {
                    break;
                }
                let Some(d) = solve_rows(0, a.clone(), &qd, &law, 0.6, Some(1.0)).unwrap() else {
                    break;
                };
                wedged_at.push((delta, d.wedged));
                steps.push((row.dot(&r), (&d.rates - &law.rates).amax()));
            }
            if wedged_at.len() < 5 {
                continue;
            }
            for &(delta, wedged) in &wedged_at {
                assert_eq!(
                    wedged,
                    delta.abs() < WEDGE_TOL,
                    "n={n}, p={p}, δ={delta}: {wedged_at:?}"
                );
            }
            // the step grows as 1/(b_nᵀ r) towards the right angle
            let (near, far) = (steps[4], steps[1]);
            let ratio = near.1 / far.1;
            let want = (far.0 / near.0).abs();
            assert!(
                ratio > 0.01 * want && ratio < 100.0 * want,
                "n={n}, p={p}: {steps:?}"
            );
            checked += 1;
        }
        assert!(checked > 15, "{checked}");
    }

    /// A slide solved into the buffers of another ([`solve_into`], as the split reuses the
    /// last one's) is the fresh one of [`solve_rows`] bit for bit, across chains of 2 to 10
    /// joints whose lengths change from one solve to the next.
    #[test]
    fn a_slide_solved_in_place_is_the_fresh_one() {
        let mut r = ChaCha8Rng::seed_from_u64(32);
        let mut slide = DampedSlide::unsolved(0, 0, DMatrix::zeros(0, 0));
        let mut solved = 0;
        for i in 0..60 {
            let n = 2 + (i * 7) % 9;
            let (a, qd, law) = random_slide(&mut r, n, n + 3, i % 3);
            let side = [None, Some(1.0), Some(-1.0)][i % 3];
            let fresh = solve_rows(0, a.clone(), &qd, &law, 0.6, side).unwrap();
            let kept = solve_into(&a, &qd, &law, 0.6, side, &mut slide).unwrap();
            assert_eq!(kept, fresh.is_some());
            let Some(fresh) = fresh else {
                continue;
            };
            slide.rows = a;
            assert_eq!(bits(&fresh.lambda), bits(&slide.lambda), "λ, n={n}");
            assert_eq!(
                bits(fresh.w.as_slice()),
                bits(slide.w.as_slice()),
                "w, n={n}"
            );
            assert_eq!(
                bits(fresh.g.as_slice()),
                bits(slide.g.as_slice()),
                "G, n={n}"
            );
            assert_eq!(bits(fresh.rates.as_slice()), bits(slide.rates.as_slice()));
            assert_eq!(
                bits(&[fresh.coef, fresh.side, fresh.u_t]),
                bits(&[slide.coef, slide.side, slide.u_t])
            );
            assert_eq!(
                (fresh.consistent, fresh.wedged),
                (slide.consistent, slide.wedged)
            );
            assert_eq!(fresh, slide);
            solved += 1;
        }
        assert!(solved > 40, "{solved}");
    }
}
