//! The KKT block inverse of thesis (5.2), stable when `M̄` is singular.
//!
//! ```text
//! [ M̄  Aᵀ ]⁻¹   [ M†   A†ᵀ ]
//! [ A   0  ]   = [ A†   Λ   ]
//! ```
//!
//! Null-space method, never forming `M̄⁻¹`: a Householder QR `Aᵀ = [Q₁ Q₂] [R; 0]` splits
//! velocity space into the constrained directions `Q₁` and the free motions `Q₂ = H` (4.20).
//! Lemma 5.1 says the KKT matrix is invertible iff `A` has full row rank and the reduced
//! mass matrix `M̃ = Q₂ᵀ M̄ Q₂` is positive definite; both are tested (QR diagonal, Cholesky
//! pivots) and a failure is a typed [`CoreError::SingularKkt`] carrying a condition estimate.
//!
//! For `[M̄ Aᵀ; A 0][x; y] = [f; g]`:
//! `x₁ = R⁻ᵀ g`, `x₂ = M̃⁻¹ Q₂ᵀ (f − M̄ Q₁ x₁)`, `x = Q₁x₁ + Q₂x₂`, `y = R⁻¹ Q₁ᵀ (f − M̄ x)`,
//! hence `M† = Q₂ M̃⁻¹ Q₂ᵀ`, `A†ᵀ = (I − M†M̄) Q₁ R⁻ᵀ`, `Λ = −R⁻¹ Q₁ᵀ M̄ A†ᵀ`.
//!
//! Range-space method, where `M̄` is clearly positive definite and the system has more than
//! [`SMALL_M`] coordinates (a legged robot with four or more joints): the Cholesky factor
//! `M̄ = L Lᵀ`, `Z = L⁻¹ Aᵀ` and the Cholesky factor of the Schur complement
//! `S = A M̄⁻¹ Aᵀ = Zᵀ Z`; then `S y = Zᵀ L⁻¹ f − g` and `x = L⁻ᵀ (L⁻¹ f − Z y)`
//! (`Λ = −S⁻¹`). It declines, and the null-space method runs, where a pivot of `M̄` or `S`
//! is not clearly positive (see [`RANGE_PIVOT_FRACTION`]); the null-space factors
//! ([`KktFactorization::null_space_basis`], [`KktFactorization::info`]) are then formed on
//! demand only.
//!
//! Massless range-space method, where some coordinates move no mass (their row and column
//! of `M̄` exactly zero: a joint whose links outward are all massless) and the others are
//! clearly positive definite: the range-space method on the massive coordinates, the
//! massless ones then solved through the rows that hold them, `T x_Z = f_Z − Vᵀ u` with
//! `V = C⁻¹ A_Z` and `T = Vᵀ V` ([`massless_range_factor`]). It declines where a massless
//! coordinate is held by no row (or fewer rows than massless coordinates), and the
//! null-space method runs.
#![allow(non_snake_case)]
use crate::error::{CoreError, Result, SingularityKind};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use std::cmp::Ordering;

/// The largest `m` for which the kernels do not look for `Q`'s unit columns.
const SMALL_M: usize = 6;

/// Relative tolerance on the QR diagonal of `Aᵀ` below which rows are dependent.
pub const RANK_TOLERANCE: f64 = 1e-10;
/// Relative tolerance on the Cholesky pivots of `M̃` (relative to the largest diagonal entry
/// of `M̃` or `M̄`) below which Lemma 5.1 fails.
pub const PIVOT_TOLERANCE: f64 = 1e-11;
/// The range-space route's pivot test: a Cholesky pivot of `M̄` (of `S`) below this fraction
/// of its diagonal entry, the inertia a coordinate (the reach a row) keeps once the
/// coordinates (rows) before it are eliminated, declines the route. Set by measured
/// accuracy (`docs/decisions/2026-11-30-range-space-kkt-for-planar-trees.md`).
pub const RANGE_PIVOT_FRACTION: f64 = 1e-4;
/// A diagonal entry of `M̄` below this fraction of the largest marks a coordinate moving no
/// mass: the range-space route declines, and the massless one takes it as massless where
/// its row and column are exactly zero (else declines too).
pub const RANGE_MASSLESS_DIAGONAL: f64 = 1e-6;

/// Which factors [`KktFactorization::solve`] uses.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
enum Route {
    #[default]
    NullSpace,
    RangeSpace,
    /// The range-space route on the coordinates that move mass, the massless ones
    /// (`M̄`'s row and column exactly zero) eliminated through the rows that hold them
    /// ([`massless_range_factor`]).
    MasslessRange,
}

/// Non-fatal diagnostics of a successful factorization.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct KktInfo {
    /// `max|R_ii| / min|R_ii|`: conditioning of the active constraints.
    pub constraint_condition: f64,
    /// `max d / min d` over the Cholesky pivots of `M̃`: conditioning of the free motion.
    pub reduced_mass_condition: f64,
}

/// The three blocks of the inverse.
#[derive(Debug, Clone, PartialEq)]
pub struct KktBlocks {
    /// `M†` (q×q), symmetric positive semi-definite.
    pub m_dagger: DMatrix<f64>,
    /// `A†` (c×q), the mass-weighted left inverse: `A† Aᵀ = I`.
    pub a_dagger: DMatrix<f64>,
    /// `Λ` (c×c), symmetric negative semi-definite: negative definite, `−(A M̄⁻¹ Aᵀ)⁻¹`,
    /// when `M̄` is invertible; zero on the rows' combinations massless coordinates take up.
    pub lambda: DMatrix<f64>,
}

impl KktBlocks {
    /// The blocks of a system factored on the coordinates `coords` of `n` (a massless limb's
    /// prescribed coordinates left out) in all `n`: `M†` n × n and `A†` c × n, zero on the
    /// rows and columns of the coordinates left out; `Λ` as it is.
    pub fn embedded(self, coords: &[usize], n: usize) -> KktBlocks {
        let c = self.a_dagger.nrows();
        let mut m_dagger = DMatrix::zeros(n, n);
        let mut a_dagger = DMatrix::zeros(c, n);
        for (j, &kj) in coords.iter().enumerate() {
            for (i, &ki) in coords.iter().enumerate() {
                m_dagger[(ki, kj)] = self.m_dagger[(i, j)];
            }
            a_dagger.column_mut(kj).copy_from(&self.a_dagger.column(j));
        }
        KktBlocks {
            m_dagger,
            a_dagger,
            lambda: self.lambda,
        }
    }
}

/// A reusable factorization (allocates only when sizes grow).
///
/// Storage is flat and column-major, sized for the current `m` and `c`. At the sizes of a
/// planar robot (`m ≲ 12`, `c ≲ 8`) loop overhead, not arithmetic, is what costs, so:
/// every length-`m` operation runs over the whole column (the reflectors carry explicit
/// zeros above their pivot), the kernels are compiled for each small `m` (a `Dim` below) so
/// that those loops unroll, and the factor keeps `Q` explicitly and the reciprocals of the
/// pivots so that [`Self::solve`] is a few matrix–vector products with no divisions. The
/// coordinates no constraint row involves (the joints of the legs off the ground; all of
/// them in flight) are where `Q` is the identity: beyond `m = 6`, factor and solve take its
/// unit columns as such instead of multiplying by them, with the same results bit for bit
/// (see [`factor_kernel`]).
#[derive(Debug, Clone, Default)]
pub struct KktFactorization {
    m: usize,
    c: usize,
    /// `M̄` (m×m), for the residual `f − M̄x` of the multiplier solve.
    mbar: Vec<f64>,
    /// `Aᵀ` (m×c), reduced in place by the QR: `R`'s strict upper triangle (its diagonal is
    /// `r_diag`).
    r: Vec<f64>,
    /// Householder reflectors `H_k = I − β_k v_k v_kᵀ` (`v_k`: m×c, zero above row `k`;
    /// `β_k = 0`: `H_k = I`).
    v: Vec<f64>,
    beta: Vec<f64>,
    /// `R_kk` and `1/R_kk`.
    r_diag: Vec<f64>,
    r_inv: Vec<f64>,
    /// `Q = H₁ ⋯ H_c = [Q₁ Q₂]` (m×m).
    q: Vec<f64>,
    /// The rows `T` some reflector touches (and the first `c`): outside them `Q` is the
    /// identity, exactly (see [`factor_kernel`]).
    touched: Vec<bool>,
    /// Every row in `T` (no structure to use).
    all_touched: bool,
    /// `Q₁ᵀ M̄ Q₂` (c×e).
    g12: Vec<f64>,
    /// `M̃ = Q₂ᵀ M̄ Q₂` (e×e), overwritten by its Cholesky factor `L` (lower), and `1/L_jj`.
    l: Vec<f64>,
    l_inv: Vec<f64>,
    /// `m` scratch entries.
    t: Vec<f64>,
    info: KktInfo,
    route: Route,
    /// The range-space route: `L` of `M̄ = L Lᵀ` (m×m, column-major, strictly lower: its
    /// diagonal and above are `+0`) and `1/L_jj`; `Z = L⁻¹ Aᵀ` (m×c); the Cholesky factor of
    /// `S = Zᵀ Z` (c×c, stored as `L`) and the reciprocals of its diagonal.
    ml: Vec<f64>,
    ml_inv: Vec<f64>,
    z: Vec<f64>,
    sl: Vec<f64>,
    sl_inv: Vec<f64>,
    /// The massless range-space route: the coordinates that move mass, then the massless
    /// ones (`perm`, the first `n_massive` massive), `M̄` on the massive ones (`mp`, whose
    /// Cholesky factor is `ml`; `Z` and `S`'s factor as above, over the massive coordinates),
    /// `V = C⁻¹ B` (c×z, `B` the rows' columns of the massless coordinates) and the Cholesky
    /// factor of `T = Vᵀ V` (z×z) with the reciprocals of its diagonal; `m + c` scratch entries.
    perm: Vec<usize>,
    n_massive: usize,
    mp: Vec<f64>,
    vz: Vec<f64>,
    tm: Vec<f64>,
    tl: Vec<f64>,
    tl_inv: Vec<f64>,
    scratch: Vec<f64>,
    /// On the range-space routes, the null-space factors of the same system once asked for
    /// (`null_ready`: of the current system).
    null: Option<Box<KktFactorization>>,
    null_ready: bool,
}

/// A dimension known at compile time ([`Fixed`]) or only at run time (`usize`). The KKT
/// kernels are written once, generic over the number of coordinates `m`, and instantiated
/// for the small `m` of planar robots, where every length-`m` loop then unrolls.
trait Dim: Copy {
    fn get(self) -> usize;
}

impl Dim for usize {
    #[inline(always)]
    fn get(self) -> usize {
        self
    }
}

#[derive(Clone, Copy)]
struct Fixed<const N: usize>;

impl<const N: usize> Dim for Fixed<N> {
    #[inline(always)]
    fn get(self) -> usize {
        N
    }
}

/// Calls `$kernel(dim, …)` with `dim` a [`Fixed`] size for `m` in 3..=12, else `m` itself.
macro_rules! with_dim {
    ($m:expr, $kernel:ident($($arg:expr),*)) => {
        match $m {
            3 => $kernel(Fixed::<3>, $($arg),*),
            4 => $kernel(Fixed::<4>, $($arg),*),
            5 => $kernel(Fixed::<5>, $($arg),*),
            6 => $kernel(Fixed::<6>, $($arg),*),
            7 => $kernel(Fixed::<7>, $($arg),*),
            8 => $kernel(Fixed::<8>, $($arg),*),
            9 => $kernel(Fixed::<9>, $($arg),*),
            10 => $kernel(Fixed::<10>, $($arg),*),
            11 => $kernel(Fixed::<11>, $($arg),*),
            12 => $kernel(Fixed::<12>, $($arg),*),
            m => $kernel(m, $($arg),*),
        }
    };
}

/// Runs `$body` with `$md`, `$cd` bound to the sizes `m` and `c`: both [`Fixed`] for the
/// systems of planar robots (`m` in 3..=6, any `c ≤ m`; `m` in 7..=11 with the even `c ≤ 8`
/// of feet that add two rows each, as a four-legged robot of two-link legs has, `m ≤ 11`),
/// where the factorization's and solve's loops over the rows and the free motions then
/// unroll as well (the Cholesky factor's above all); `m` alone fixed for the other `c` and
/// `m` up to 12; else both at run time. The same operations in the same order for every
/// binding: the results are bit-identical.
macro_rules! with_dims {
    ($m:expr, $c:expr, |$md:ident, $cd:ident| $body:expr) => {
        with_dims!(@go ($m, $c), $md, $cd, $body;
            3 0, 3 1, 3 2, 3 3,
            4 0, 4 1, 4 2, 4 3, 4 4,
            5 0, 5 1, 5 2, 5 3, 5 4, 5 5,
            6 0, 6 1, 6 2, 6 3, 6 4, 6 5, 6 6,
            7 0, 7 2, 7 4,
            8 0, 8 2, 8 4, 8 6, 8 8,
            9 0, 9 2, 9 4, 9 6, 9 8,
            10 0, 10 2, 10 4, 10 6, 10 8,
            11 0, 11 2, 11 4, 11 6, 11 8;
            7, 8, 9, 10, 11, 12)
    };
    (@go $mc:expr, $md:ident, $cd:ident, $body:expr;
        $($mm:literal $cc:literal),*; $($m_only:literal),*) => {
        match $mc {
            $(($mm, $cc) => {
                let ($md, $cd) = (Fixed::<$mm>, Fixed::<$cc>);
                $body
            })*
            (m, c) => match m {
                $($m_only => {
                    let ($md, $cd) = (Fixed::<$m_only>, c);
                    $body
                })*
                _ => {
                    let ($md, $cd) = (m, c);
                    $body
                }
            },
        }
    };
}

impl KktFactorization {
    pub fn n_coords(&self) -> usize {
        self.m
    }
    pub fn n_rows(&self) -> usize {
        self.c
    }

    /// Factors `[M̄ Aᵀ; A 0]` (`M̄`: m×m symmetric PSD, `A`: c×m).
    pub fn factor(&mut self, mbar: &DMatrix<f64>, a: &DMatrix<f64>) -> Result<()> {
        debug_assert_eq!(a.ncols(), mbar.nrows());
        self.load(mbar, a, None);
        // a non-finite M̄ takes the plain route, whose NaNs the structured one would skip
        let dense = !self.mbar.iter().all(|x| x.is_finite());
        self.factor_loaded(dense)
            .map_err(|kind| singular(mbar.clone(), a.clone(), kind))
    }

    /// [`Self::factor`] on the coordinates `coords` of a larger system: `M̄[coords, coords]`
    /// and `A[:, coords]`, gathered straight into the factorization (no reduced copies).
    /// `M̄` is finite (the flow checks it where it computes it), which [`Self::factor`]
    /// tests instead.
    pub(crate) fn factor_on(
        &mut self,
        mbar: &DMatrix<f64>,
        a: &DMatrix<f64>,
        coords: &[usize],
    ) -> Result<()> {
        self.try_factor_on(mbar, a, coords).map_err(|kind| {
            singular(
                mbar.select_rows(coords).select_columns(coords),
                a.select_columns(coords),
                kind,
            )
        })
    }

    /// [`Self::factor_on`] whose Lemma 5.1 failure is only its kind: no condition number (an
    /// SVD of the KKT matrix), for callers that discard the error (a candidate mode found
    /// singular is simply not a candidate).
    pub(crate) fn try_factor_on(
        &mut self,
        mbar: &DMatrix<f64>,
        a: &DMatrix<f64>,
        coords: &[usize],
    ) -> std::result::Result<(), SingularityKind> {
        self.load(mbar, a, Some(coords));
        debug_assert!(self.mbar.iter().all(|x| x.is_finite()), "M̄ not finite");
        self.factor_loaded(false)
    }

    /// Factors the loaded system: by the range-space route beyond [`SMALL_M`] coordinates
    /// where it applies, else by the null-space route (`dense`: its plain kernel).
    fn factor_loaded(&mut self, dense: bool) -> std::result::Result<(), SingularityKind> {
        self.null_ready = false;
        let (floor, pivot) = (RANGE_MASSLESS_DIAGONAL, RANGE_PIVOT_FRACTION);
        if self.m > SMALL_M
            && range_space_allowed()
            && with_dims!(self.m, self.c, |md, cd| range_factor_kernel(
                md, cd, self, floor, pivot
            ))
        {
            self.route = Route::RangeSpace;
            return Ok(());
        }
        if self.m > SMALL_M && range_space_allowed() && massless_range_factor(self, floor, pivot) {
            self.route = Route::MasslessRange;
            return Ok(());
        }
        self.route = Route::NullSpace;
        with_dims!(self.m, self.c, |md, cd| factor_kernel(md, cd, self, dense))
    }

    /// The null-space factors of the current system: this factorization's own, or on the
    /// range-space route a copy of the system factored by the null-space route (once).
    fn null_factors(&mut self) -> &KktFactorization {
        if self.route == Route::NullSpace {
            return self;
        }
        if !self.null_ready {
            let (m, c) = (self.m, self.c);
            let mut k = self.null.take().unwrap_or_default();
            k.size(m, c);
            k.mbar.copy_from_slice(&self.mbar);
            k.r.copy_from_slice(&self.r);
            // the system is regular here (Lemma 5.1): the null-space route succeeds
            let ok = with_dims!(m, c, |md, cd| factor_kernel(md, cd, &mut k, false));
            debug_assert!(
                ok.is_ok(),
                "null-space route failed where the range route held"
            );
            self.null = Some(k);
            self.null_ready = true;
        }
        self.null.as_deref().expect("formed above")
    }

    /// The diagnostics of the factorization (of the null-space route's factors, formed on
    /// demand on the range-space route).
    pub fn info(&mut self) -> KktInfo {
        self.null_factors().info
    }

    /// Whether [`Self::solve`] uses range-space factors (of `M̄`, or of `M̄` on the
    /// coordinates that move mass).
    pub fn is_range_space(&self) -> bool {
        self.route != Route::NullSpace
    }

    /// Sizes the storage and copies `M̄[coords, coords]` and `A[:, coords]ᵀ` in (all
    /// coordinates when `coords` is `None`).
    fn load(&mut self, mbar: &DMatrix<f64>, a: &DMatrix<f64>, coords: Option<&[usize]>) {
        // every coordinate, in order (a mode without free joints): the plain copies
        let all =
            |c: &[usize]| c.len() == mbar.nrows() && c.iter().enumerate().all(|(i, &k)| i == k);
        let coords = coords.filter(|c| !all(c));
        let m = coords.map_or(mbar.nrows(), <[usize]>::len);
        self.size(m, a.nrows());
        let c = self.c;
        match coords {
            None => {
                self.mbar.copy_from_slice(mbar.as_slice());
                with_dims!(m, c, |md, cd| load_at(md, cd, self, a, |i| i));
            }
            Some(coords) => {
                with_dim!(m, load_mbar(self, mbar, coords));
                with_dims!(m, c, |md, cd| load_at(md, cd, self, a, |i| coords[i]));
            }
        }
    }

    /// Sizes the storage for `m` coordinates and `c` rows.
    #[inline(always)]
    fn size(&mut self, m: usize, c: usize) {
        if (m, c) != (self.m, self.c) || self.q.len() != m * m {
            self.resize(m, c);
        }
    }

    /// [`Self::size`] when a size changed; the range-space route's storage only beyond
    /// [`SMALL_M`] coordinates, where the route may be taken.
    fn resize(&mut self, m: usize, c: usize) {
        let e = m.saturating_sub(c);
        self.m = m;
        self.c = c;
        self.mbar.resize(m * m, 0.0);
        self.r.resize(m * c, 0.0);
        self.v.resize(m * c, 0.0);
        self.beta.resize(c, 0.0);
        self.r_diag.resize(c, 0.0);
        self.r_inv.resize(c, 0.0);
        self.q.resize(m * m, 0.0);
        self.touched.resize(m, true);
        self.g12.resize(c * e, 0.0);
        self.l.resize(e * e, 0.0);
        self.l_inv.resize(e, 0.0);
        self.t.resize(m, 0.0);
        if m > SMALL_M {
            self.ml.resize(m * m, 0.0);
            self.ml_inv.resize(m, 0.0);
            self.z.resize(m * c, 0.0);
            self.sl.resize(c * c, 0.0);
            self.sl_inv.resize(c, 0.0);
            self.perm.resize(m, 0);
            self.mp.resize(m * m, 0.0);
            self.vz.resize(m * c, 0.0);
            self.tm.resize(c * c, 0.0);
            self.tl.resize(c * c, 0.0);
            self.tl_inv.resize(c, 0.0);
            self.scratch.resize(m + c, 0.0);
        }
    }

    /// Solves `[M̄ Aᵀ; A 0][x; y] = [f; g]` with the current factorization.
    ///
    /// With `x = Q x̃` and `A = [Rᵀ 0] Qᵀ`: `x̃₁ = R⁻ᵀ g`, `M̃ x̃₂ = Q₂ᵀ f − (Q₁ᵀM̄Q₂)ᵀ x̃₁`,
    /// and `y = R⁻¹ Q₁ᵀ (f − M̄ x)`.
    pub fn solve(&mut self, f: &[f64], g: &[f64], x: &mut [f64], y: &mut [f64]) {
        let (m, c) = (self.m, self.c);
        assert!(f.len() == m && g.len() == c && x.len() == m && y.len() == c);
        match self.route {
            Route::NullSpace => {
                with_dims!(m, c, |md, cd| solve_kernel(md, cd, self, f, g, x, y, false))
            }
            Route::RangeSpace => {
                with_dims!(m, c, |md, cd| range_solve_kernel(md, cd, self, f, g, x, y))
            }
            Route::MasslessRange => massless_range_solve(self, f, g, x, y),
        }
    }

    /// The blocks `M†`, `A†`, `Λ` of the inverse (column by column).
    pub fn blocks(&mut self) -> KktBlocks {
        let (m, c) = (self.m, self.c);
        let mut m_dagger = DMatrix::zeros(m, m);
        let mut a_dagger = DMatrix::zeros(c, m);
        let mut lambda = DMatrix::zeros(c, c);
        let mut f = vec![0.0; m];
        let mut g = vec![0.0; c];
        let mut x = vec![0.0; m];
        let mut y = vec![0.0; c];
        for j in 0..m {
            f.iter_mut().for_each(|v| *v = 0.0);
            f[j] = 1.0;
            self.solve(&f, &g, &mut x, &mut y);
            for i in 0..m {
                m_dagger[(i, j)] = x[i];
            }
            for i in 0..c {
                a_dagger[(i, j)] = y[i];
            }
        }
        f.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..c {
            g.iter_mut().for_each(|v| *v = 0.0);
            g[j] = 1.0;
            self.solve(&f, &g, &mut x, &mut y);
            for i in 0..c {
                lambda[(i, j)] = y[i];
            }
        }
        KktBlocks {
            m_dagger,
            a_dagger,
            lambda,
        }
    }

    /// Basis of the free motions `Q₂` (columns span `ker A`).
    pub fn null_space_basis(&mut self) -> DMatrix<f64> {
        let k = self.null_factors();
        let (m, c) = (k.m, k.c);
        DMatrix::from_column_slice(m, m - c, &k.q[c * m..m * m])
    }
}

/// `M̄[coords, coords]` into the factorization, for `m = dim`.
fn load_mbar<D: Dim>(dim: D, kkt: &mut KktFactorization, mbar: &DMatrix<f64>, coords: &[usize]) {
    let (m, nq, mb) = (dim.get(), mbar.nrows(), mbar.as_slice());
    let coords = &coords[..m];
    for j in 0..m {
        let (src, dst) = (
            &mb[coords[j] * nq..(coords[j] + 1) * nq],
            &mut kkt.mbar[j * m..],
        );
        for i in 0..m {
            dst[i] = src[coords[i]];
        }
    }
}

/// `A[:, coord]ᵀ` into the factorization, for `m = dim` and `c = cdim`.
fn load_at<D: Dim, C: Dim>(
    dim: D,
    cdim: C,
    kkt: &mut KktFactorization,
    a: &DMatrix<f64>,
    coord: impl Fn(usize) -> usize,
) {
    let (m, c, at) = (dim.get(), cdim.get(), a.as_slice());
    let r = &mut kkt.r[..m * c];
    // A is c×nq column-major: column coord(i) of A is row i of Aᵀ
    for i in 0..m {
        let src = &at[coord(i) * c..(coord(i) + 1) * c];
        for (row, &x) in src.iter().enumerate() {
            r[row * m + i] = x;
        }
    }
}

/// The factorization proper, on the loaded `M̄` and `Aᵀ`, for `m = dim` and `c = cdim`; a
/// Lemma 5.1 failure is returned as its kind (the caller, which still holds the inputs, adds
/// the condition).
///
/// A contact row of a legged robot involves the body's coordinates and its own leg's joints,
/// so the reflectors are zero on the rows `T` of the other legs' joints (and all of `Q` is
/// the identity in flight, `c = 0`): outside `T`, `Q e_j = e_j`, `M̄ e_j` is a column of `M̄`
/// and `e_iᵀ M̄ Q e_j` an entry. The kernel takes them as such and runs the plain products
/// (`Q e_j` by its reflectors, `M̄ q_j` by columns of `M̄`, dot products over all `m` rows)
/// only on the columns in `T`, skipping exactly the terms that are exact zeros there: every
/// sum it forms keeps its other terms, their order and their partial sums, so that the
/// factor is bit for bit that of the plain route (`dense`; the terms skipped are `±0` when
/// `M̄` and the reflectors are finite, and `+0` added to a sum started at `+0` changes
/// nothing; where the plain route turns a `−0` of `M̄` into `+0`, so does this one). A
/// non-finite reflector takes the plain route, and so do the systems of up to
/// [`SMALL_M`] coordinates.
fn factor_kernel<D: Dim, C: Dim>(
    dim: D,
    cdim: C,
    kkt: &mut KktFactorization,
    dense: bool,
) -> std::result::Result<(), SingularityKind> {
    let (m, c) = (dim.get(), cdim.get());
    debug_assert_eq!(c, kkt.c);
    if c > m {
        return Err(SingularityKind::RedundantConstraints);
    }
    let e = m - c;
    let (mbar, r, v, q) = (
        &kkt.mbar[..m * m],
        &mut kkt.r[..m * c],
        &mut kkt.v[..m * c],
        &mut kkt.q[..m * m],
    );
    let col = |j: usize| j * m..(j + 1) * m;

    // Householder QR of Aᵀ: H_k reflects rows kkt.. of column k onto α e_k, with
    // v_k = x − α e_k and β_k = 2/‖v_k‖² = 1/(‖x‖² − α x_k); then H_k acts on the columns
    // to the right (v_k is zero above row k, so their first k rows, R's, stay).
    for i in 0..c {
        let (done, rest) = r.split_at_mut((i + 1) * m);
        let x = &done[col(i)];
        let vi = &mut v[col(i)];
        for p in 0..m {
            vi[p] = if p >= i { x[p] } else { 0.0 };
        }
        let norm2 = dot(dim, vi, vi);
        let norm = norm2.sqrt();
        let alpha = if x[i] >= 0.0 { -norm } else { norm };
        kkt.r_diag[i] = alpha;
        if norm2 == 0.0 {
            kkt.beta[i] = 0.0;
            continue;
        }
        let beta = 1.0 / (norm2 - alpha * x[i]);
        kkt.beta[i] = beta;
        vi[i] -= alpha;
        for j in i + 1..c {
            reflect(dim, vi, beta, &mut rest[col(j - i - 1)]);
        }
    }
    let (mut rmin, mut rmax) = (f64::INFINITY, 0.0f64);
    for &d in &kkt.r_diag[..c] {
        rmin = rmin.min(d.abs());
        rmax = rmax.max(d.abs());
    }
    if c > 0 && (rmax == 0.0 || rmin <= RANK_TOLERANCE * rmax || !rmin.is_finite()) {
        return Err(SingularityKind::RedundantConstraints);
    }
    for (ri, &d) in kkt.r_inv[..c].iter_mut().zip(&kkt.r_diag[..c]) {
        *ri = 1.0 / d;
    }

    // T: the first c rows and those where a reflector is nonzero. After the rank test the
    // β_k are finite unless the reflectors are not (a NaN pivot passes it); then every row
    // counts, as a NaN β turns Q e_j into NaNs for every j. Up to m = 6 (RHex) finding T
    // costs more than it saves.
    let mut dense = dense || m <= SMALL_M || !kkt.beta[..c].iter().all(|b| b.is_finite());
    let touched = &mut kkt.touched[..m];
    if !dense {
        for (p, tp) in touched.iter_mut().enumerate() {
            *tp = p < c || (0..c).any(|k| v[k * m + p] != 0.0);
        }
        dense = touched.iter().all(|&t| t);
    }
    kkt.all_touched = dense;

    // Q e_j = H₁ ⋯ H_c e_j, where H_i e_j = e_j for i > j (v_i is zero above row i), and for
    // j ∉ T (each reflection adds β(vᵢᵀe_j)vᵢ = ±0 to every entry)
    for j in 0..m {
        let qj = &mut q[col(j)];
        qj.fill(0.0);
        qj[j] = 1.0;
        if !dense && !touched[j] {
            continue;
        }
        for i in (0..c.min(j + 1)).rev() {
            if kkt.beta[i] != 0.0 {
                reflect(dim, &v[col(i)], kkt.beta[i], qj);
            }
        }
    }

    // t = M̄ q_{c+j};  Q₁ᵀ M̄ Q₂ and the lower triangle of M̃ = Q₂ᵀ M̄ Q₂. A column q_s of Q
    // is +0 outside T (and e_s for s ∉ T): M̄ q_s sums the columns of M̄ in T only (the others
    // add +0·M̄ = ±0); M̄ e_s is M̄'s column with −0 turned into +0 (the +0 terms before it);
    // e_sᵀ t is t_s (the sum of one term).
    let t = &mut kkt.t[..m];
    for j in 0..e {
        let qj = &q[col(c + j)];
        if dense || touched[c + j] {
            t.fill(0.0);
            for s in (0..m).filter(|&s| dense || touched[s]) {
                axpy(dim, qj[s], &mbar[col(s)], t);
            }
        } else {
            for (tp, &x) in t.iter_mut().zip(&mbar[col(c + j)]) {
                *tp = x + 0.0;
            }
        }
        for i in 0..c {
            kkt.g12[j * c + i] = dot(dim, &q[col(i)], t);
        }
        for i in j..e {
            kkt.l[j * e + i] = if dense || touched[c + i] {
                dot(dim, &q[col(c + i)], t)
            } else {
                t[c + i]
            };
        }
    }

    // M̃ = L Lᵀ, pivots tested against Lemma 5.1. The pivot scale includes M̄'s own diagonal:
    // relative to M̃ alone, a 1×1 M̃ that is rounding noise (a massless joint that no contact
    // pins down) would always pass.
    let l = &mut kkt.l[..e * e];
    let scale = (0..e)
        .map(|i| l[i * e + i].abs())
        .chain((0..m).map(|i| mbar[i * m + i].abs()))
        .fold(0.0, f64::max);
    let (mut dmin, mut dmax) = (f64::INFINITY, 0.0f64);
    for j in 0..e {
        // column j of L: rows j.. of column j of M̃ minus the earlier columns
        for i in 0..j {
            let lji = l[i * e + j];
            let (left, right) = l.split_at_mut(j * e);
            for (lpj, lpi) in right[j..e].iter_mut().zip(&left[i * e + j..(i + 1) * e]) {
                *lpj -= lpi * lji;
            }
        }
        let d = l[j * e + j];
        // (NaN fails too)
        let positive = d.partial_cmp(&(PIVOT_TOLERANCE * scale)) == Some(Ordering::Greater);
        if !positive || scale == 0.0 {
            return Err(SingularityKind::UnconstrainedMasslessMotion);
        }
        dmin = dmin.min(d);
        dmax = dmax.max(d);
        let inv = 1.0 / d.sqrt();
        kkt.l_inv[j] = inv;
        l[j * e + j..(j + 1) * e].iter_mut().for_each(|x| *x *= inv);
    }
    kkt.info = KktInfo {
        constraint_condition: if c > 0 { rmax / rmin } else { 1.0 },
        reduced_mass_condition: if e > 0 { dmax / dmin } else { 1.0 },
    };
    Ok(())
}

/// [`KktFactorization::solve`] for `m = dim` and `c = cdim`: `Q`'s unit columns outside `T`
/// taken as such, as in [`factor_kernel`], bit for bit the plain route (`dense`) when `f`
/// and `x̃` are finite (which it tests: it takes the plain route otherwise).
#[allow(clippy::too_many_arguments)]
fn solve_kernel<D: Dim, C: Dim>(
    dim: D,
    cdim: C,
    kkt: &mut KktFactorization,
    f: &[f64],
    g: &[f64],
    x: &mut [f64],
    y: &mut [f64],
    dense: bool,
) {
    let (m, c) = (dim.get(), cdim.get());
    debug_assert_eq!(c, kkt.c);
    let e = m - c;
    let (mbar, r, q, f, x) = (
        &kkt.mbar[..m * m],
        &kkt.r[..m * c],
        &kkt.q[..m * m],
        &f[..m],
        &mut x[..m],
    );
    let col = |j: usize| j * m..(j + 1) * m;
    let xt = &mut kkt.t[..m];
    // x̃₁ = R⁻ᵀ g  (Rᵀ lower triangular; row i of Rᵀ is R[..i, i], above the diagonal)
    for i in 0..c {
        let ri = &r[i * m..i * m + i];
        let s = g[i] - ri.iter().zip(&xt[..i]).map(|(a, b)| a * b).sum::<f64>();
        xt[i] = s * kkt.r_inv[i];
    }
    // x̃₂ = L⁻ᵀ L⁻¹ (Q₂ᵀ f − (Q₁ᵀ M̄ Q₂)ᵀ x̃₁), where e_sᵀ f = f_s + 0 for s ∉ T
    let touched = &kkt.touched[..m];
    let dense = dense || m <= SMALL_M || kkt.all_touched || !all_finite(dim, f);
    for j in 0..e {
        let g12j = &kkt.g12[j * c..(j + 1) * c];
        let qf = if dense || touched[c + j] {
            dot(dim, &q[col(c + j)], f)
        } else {
            f[c + j] + 0.0
        };
        xt[c + j] = qf - g12j.iter().zip(&xt[..c]).map(|(a, b)| a * b).sum::<f64>();
    }
    let (l, z) = (&kkt.l[..e * e], &mut xt[c..]);
    for i in 0..e {
        let mut s = z[i];
        for p in 0..i {
            s -= l[p * e + i] * z[p];
        }
        z[i] = s * kkt.l_inv[i];
    }
    for i in (0..e).rev() {
        let mut s = z[i];
        for p in i + 1..e {
            s -= l[i * e + p] * z[p];
        }
        z[i] = s * kkt.l_inv[i];
    }
    // x = Q x̃, where x̃_s e_s adds x̃_s to x_s (and ±0 elsewhere) for s ∉ T
    let dense = dense || !all_finite(dim, xt);
    x.fill(0.0);
    for j in 0..m {
        if dense || touched[j] {
            axpy(dim, xt[j], &q[col(j)], x);
        } else {
            x[j] += xt[j];
        }
    }
    // t = f − M̄ x   (M̄ symmetric: row p = column p);  y = R⁻¹ Q₁ᵀ t
    if c == 0 {
        return;
    }
    let t = xt;
    for p in 0..m {
        t[p] = f[p] - dot(dim, &mbar[col(p)], x);
    }
    for i in (0..c).rev() {
        let mut s = dot(dim, &q[col(i)], t);
        for p in i + 1..c {
            s -= r[p * m + i] * y[p];
        }
        y[i] = s * kkt.r_inv[i];
    }
}

#[cfg(test)]
thread_local! {
    /// Tests that compare a whole computation on both routes turn the range-space one off.
    static NULL_SPACE_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Whether the range-space route may be taken (always, outside tests).
fn range_space_allowed() -> bool {
    #[cfg(test)]
    return !NULL_SPACE_ONLY.with(std::cell::Cell::get);
    #[cfg(not(test))]
    true
}

/// The range-space factorization of the loaded system for `m = dim` and `c = cdim`:
/// `M̄ = L Lᵀ`, `Z = L⁻¹ Aᵀ`, `S = Zᵀ Z = C Cᵀ`; `false` (the route does not apply) where a
/// diagonal entry of `M̄` is below `massless` ([`RANGE_MASSLESS_DIAGONAL`]) of the largest or
/// a pivot of `M̄` or `S` below `pivot` ([`RANGE_PIVOT_FRACTION`]) of its diagonal entry (a
/// massless or nearly massless coordinate; rows dependent or nearly so; anything not
/// finite).
fn range_factor_kernel<D: Dim, C: Dim>(
    dim: D,
    cdim: C,
    kkt: &mut KktFactorization,
    massless: f64,
    pivot: f64,
) -> bool {
    let (m, c) = (dim.get(), cdim.get());
    if c > m {
        return false;
    }
    let mbar = &kkt.mbar[..m * m];
    let largest = (0..m).map(|i| mbar[i * m + i]).fold(0.0, f64::max);
    let floor = massless * largest;
    // a massless coordinate declines the route before any elimination (a NaN fails too)
    if !(0..m).all(|i| mbar[i * m + i] > floor) {
        return false;
    }
    let accept = |ajj: f64, d: f64| d > pivot * ajj;
    if !cholesky(dim, mbar, &mut kkt.ml, &mut kkt.ml_inv, accept) {
        return false;
    }
    let (l, l_inv, z) = (&kkt.ml[..m * m], &kkt.ml_inv[..m], &mut kkt.z[..m * c]);
    z.copy_from_slice(&kkt.r[..m * c]);
    for zk in z.chunks_exact_mut(m) {
        forward(dim, l, l_inv, zk);
    }
    // S in Q's storage, which the range-space route does not use
    gram_lower(dim, z, c, &mut kkt.q[..c * c]);
    let accept = |sjj: f64, d: f64| d > pivot * sjj;
    cholesky(cdim, &kkt.q[..c * c], &mut kkt.sl, &mut kkt.sl_inv, accept)
}

/// [`KktFactorization::solve`] on the range-space factors, for `m = dim` and `c = cdim`:
/// `w = L⁻¹ f`, `y = S⁻¹ (Zᵀ w − g)`, `x = L⁻ᵀ (w − Z y)`.
fn range_solve_kernel<D: Dim, C: Dim>(
    dim: D,
    cdim: C,
    kkt: &KktFactorization,
    f: &[f64],
    g: &[f64],
    x: &mut [f64],
    y: &mut [f64],
) {
    let (m, c) = (dim.get(), cdim.get());
    let (l, l_inv, z) = (&kkt.ml[..m * m], &kkt.ml_inv[..m], &kkt.z[..m * c]);
    let (x, y) = (&mut x[..m], &mut y[..c]);
    x.copy_from_slice(&f[..m]);
    forward(dim, l, l_inv, x);
    if c > 0 {
        for (k, yk) in y.iter_mut().enumerate() {
            *yk = dot(dim, &z[k * m..(k + 1) * m], x) - g[k];
        }
        let (sl, sl_inv) = (&kkt.sl[..c * c], &kkt.sl_inv[..c]);
        forward(cdim, sl, sl_inv, y);
        backward(cdim, sl, sl_inv, y);
        for (k, &yk) in y.iter().enumerate() {
            axpy(dim, -yk, &z[k * m..(k + 1) * m], x);
        }
    }
    backward(dim, l, l_inv, x);
}

/// The range-space factorization of the loaded system where some coordinates move no mass
/// (`M̄`'s row and column exactly zero, `P` the others, `Z` these; `m = p + z`):
///
/// ```text
/// [ M̄_PP  0   A_Pᵀ ] [x_P]   [f_P]
/// [ 0     0   Bᵀ   ] [x_Z] = [f_Z],   B = A_Z,
/// [ A_P   B   0    ] [ y ]   [ g ]
/// ```
///
/// `M̄_PP = L Lᵀ`, `Z = L⁻¹ A_Pᵀ`, `S = Zᵀ Z = C Cᵀ`, `V = C⁻¹ B`, `T = Vᵀ V = D Dᵀ`. With
/// `w = L⁻¹ f_P` and `u = C⁻¹ (Zᵀ w − g)`, eliminating `x_P = L⁻ᵀ (w − Z y)` leaves
/// `S y − B x_Z = Zᵀ w − g` and `Bᵀ y = f_Z`: so `T x_Z = f_Z − Vᵀ u`,
/// `y = C⁻ᵀ (u + V x_Z)` ([`massless_range_solve`]). The massless coordinates' rates are set
/// by the rows that hold them (a massless leg's foot on the ground), the massive ones by
/// their inertia and the rows' forces. `false` (the route does not apply) where no
/// coordinate is massless, a massive one's diagonal entry is below `massless` of the
/// largest (nearly massless: not exactly zero), there are more massless coordinates than
/// rows or more rows than massive coordinates, or a pivot of `M̄_PP`, `S` or `T` is below `pivot` of its diagonal entry (a
/// massless coordinate no row holds, rows dependent or nearly so); the null-space route
/// then runs.
fn massless_range_factor(kkt: &mut KktFactorization, massless: f64, pivot: f64) -> bool {
    let (m, c) = (kkt.m, kkt.c);
    let mbar = &kkt.mbar[..m * m];
    let largest = (0..m).map(|i| mbar[i * m + i]).fold(0.0, f64::max);
    let floor = massless * largest;
    // the massive coordinates in order, then the massless ones
    let perm = &mut kkt.perm[..m];
    let mut p = 0;
    for i in 0..m {
        if mbar[i * m + i] > floor {
            perm[p] = i;
            p += 1;
        }
    }
    let nz = m - p;
    // (`S`, c×c, has rank at most p: more rows than massive coordinates leave it singular)
    if nz == 0 || nz > c || c > p || largest.is_nan() {
        return false;
    }
    let mut z_at = p;
    for i in 0..m {
        let massive = mbar[i * m + i] > floor;
        if massive {
            continue;
        }
        // exactly massless: its whole column zero (a NaN is not)
        if !mbar[i * m..(i + 1) * m].iter().all(|&v| v == 0.0) {
            return false;
        }
        perm[z_at] = i;
        z_at += 1;
    }
    let perm = &kkt.perm[..m];
    let mp = &mut kkt.mp[..p * p];
    for (b, &j) in perm[..p].iter().enumerate() {
        for (a, &i) in perm[..p].iter().enumerate() {
            mp[b * p + a] = mbar[j * m + i];
        }
    }
    kkt.n_massive = p;
    with_dims!(p, c, |pd, cd| massless_range_kernel(pd, cd, kkt, pivot))
}

/// The factors of [`massless_range_factor`] once `M̄_PP` is gathered, for `p = pdim`
/// massive coordinates and `c = cdim` rows.
fn massless_range_kernel<D: Dim, C: Dim>(
    pdim: D,
    cdim: C,
    kkt: &mut KktFactorization,
    pivot: f64,
) -> bool {
    let (m, p, c) = (kkt.m, pdim.get(), cdim.get());
    let nz = m - p;
    let perm = &kkt.perm[..m];
    let accept = |ajj: f64, d: f64| d > pivot * ajj;
    if !cholesky(pdim, &kkt.mp[..p * p], &mut kkt.ml, &mut kkt.ml_inv, accept) {
        return false;
    }
    let (l, l_inv) = (&kkt.ml[..p * p], &kkt.ml_inv[..p]);
    // Z = L⁻¹ A_Pᵀ (p×c) and V's columns B = A_Z (c×z) from Aᵀ's storage
    let r = &kkt.r[..m * c];
    let z = &mut kkt.z[..p * c];
    for k in 0..c {
        let zk = &mut z[k * p..(k + 1) * p];
        for (a, &i) in perm[..p].iter().enumerate() {
            zk[a] = r[k * m + i];
        }
        forward(pdim, l, l_inv, zk);
    }
    gram_lower(pdim, z, c, &mut kkt.q[..c * c]);
    if !cholesky(cdim, &kkt.q[..c * c], &mut kkt.sl, &mut kkt.sl_inv, accept) {
        return false;
    }
    let (sl, sl_inv) = (&kkt.sl[..c * c], &kkt.sl_inv[..c]);
    let v = &mut kkt.vz[..c * nz];
    for (b, &i) in perm[p..].iter().enumerate() {
        let vb = &mut v[b * c..(b + 1) * c];
        for (k, x) in vb.iter_mut().enumerate() {
            *x = r[k * m + i];
        }
        forward(cdim, sl, sl_inv, vb);
    }
    gram_lower(cdim, v, nz, &mut kkt.tm[..nz * nz]);
    cholesky(nz, &kkt.tm[..nz * nz], &mut kkt.tl, &mut kkt.tl_inv, accept)
}

/// [`KktFactorization::solve`] on the factors of [`massless_range_factor`].
fn massless_range_solve(
    kkt: &mut KktFactorization,
    f: &[f64],
    g: &[f64],
    x: &mut [f64],
    y: &mut [f64],
) {
    let (p, c) = (kkt.n_massive, kkt.c);
    with_dims!(p, c, |pd, cd| massless_solve_kernel(
        pd, cd, kkt, f, g, x, y
    ))
}

/// [`massless_range_solve`] for `p = pdim` massive coordinates and `c = cdim` rows.
fn massless_solve_kernel<D: Dim, C: Dim>(
    pdim: D,
    cdim: C,
    kkt: &mut KktFactorization,
    f: &[f64],
    g: &[f64],
    x: &mut [f64],
    y: &mut [f64],
) {
    let (m, p, c) = (kkt.m, pdim.get(), cdim.get());
    let nz = m - p;
    let (perm, z, v) = (&kkt.perm[..m], &kkt.z[..p * c], &kkt.vz[..c * nz]);
    let (l, l_inv) = (&kkt.ml[..p * p], &kkt.ml_inv[..p]);
    let (sl, sl_inv) = (&kkt.sl[..c * c], &kkt.sl_inv[..c]);
    let (tl, tl_inv) = (&kkt.tl[..nz * nz], &kkt.tl_inv[..nz]);
    let (w, u) = kkt.scratch[..m + c].split_at_mut(m);
    let (w, xz) = w.split_at_mut(p);
    // w = L⁻¹ f_P, u = C⁻¹ (Zᵀ w − g)
    for (a, &i) in perm[..p].iter().enumerate() {
        w[a] = f[i];
    }
    forward(pdim, l, l_inv, w);
    for (k, uk) in u.iter_mut().enumerate() {
        *uk = dot(pdim, &z[k * p..(k + 1) * p], w) - g[k];
    }
    forward(cdim, sl, sl_inv, u);
    // T x_Z = f_Z − Vᵀ u
    for (b, &i) in perm[p..].iter().enumerate() {
        xz[b] = f[i] - dot(cdim, &v[b * c..(b + 1) * c], u);
    }
    forward(nz, tl, tl_inv, xz);
    backward(nz, tl, tl_inv, xz);
    // y = C⁻ᵀ (u + V x_Z), x_P = L⁻ᵀ (w − Z y)
    for (b, &xb) in xz.iter().enumerate() {
        axpy(cdim, xb, &v[b * c..(b + 1) * c], u);
    }
    backward(cdim, sl, sl_inv, u);
    y[..c].copy_from_slice(u);
    for (k, &yk) in u.iter().enumerate() {
        axpy(pdim, -yk, &z[k * p..(k + 1) * p], w);
    }
    backward(pdim, l, l_inv, w);
    for (a, &i) in perm[..p].iter().enumerate() {
        x[i] = w[a];
    }
    for (b, &i) in perm[p..].iter().enumerate() {
        x[i] = xz[b];
    }
}

/// The Cholesky factor `A = L Lᵀ` of the symmetric `a` (n×n for `n = dim`, column-major,
/// lower triangle read) by columns into `l` (strictly lower; `+0` on and above the diagonal)
/// and `l_inv` (`1/L_jj`); `false` at the first pivot `d` that `accept(a_jj, d)` rejects (a
/// NaN is rejected by any comparison `d > …`).
fn cholesky<D: Dim>(
    dim: D,
    a: &[f64],
    l: &mut [f64],
    l_inv: &mut [f64],
    accept: impl Fn(f64, f64) -> bool,
) -> bool {
    let n = dim.get();
    let l = &mut l[..n * n];
    for j in 0..n {
        let (left, right) = l.split_at_mut(j * n);
        let lj = &mut right[..n];
        lj.copy_from_slice(&a[j * n..(j + 1) * n]);
        // column i of L is +0 on rows ≤ i: the rows above j take garbage, cleared below;
        // an exact zero L_ji (coordinates on different branches of a tree) adds nothing
        for i in 0..j {
            let li = &left[i * n..(i + 1) * n];
            if li[j] != 0.0 {
                axpy(dim, -li[j], li, lj);
            }
        }
        let d = lj[j];
        if !accept(a[j * n + j], d) {
            return false;
        }
        let inv = 1.0 / d.sqrt();
        l_inv[j] = inv;
        for (p, x) in lj.iter_mut().enumerate() {
            *x = if p > j { *x * inv } else { 0.0 };
        }
    }
    true
}

/// `w ← L⁻¹ w` for a factor of [`cholesky`] (n = dim).
#[inline(always)]
fn forward<D: Dim>(dim: D, l: &[f64], l_inv: &[f64], w: &mut [f64]) {
    let n = dim.get();
    for i in 0..n {
        let wi = w[i] * l_inv[i];
        w[i] = wi;
        // (a row's entries off its branch of the tree stay exact zeros)
        if wi != 0.0 {
            axpy(dim, -wi, &l[i * n..(i + 1) * n], w);
        }
    }
}

/// `w ← L⁻ᵀ w` for a factor of [`cholesky`] (n = dim): column `i` of `L` is `+0` on rows
/// `≤ i`, so its product with `w` takes the entries already solved only.
#[inline(always)]
fn backward<D: Dim>(dim: D, l: &[f64], l_inv: &[f64], w: &mut [f64]) {
    let n = dim.get();
    for i in (0..n).rev() {
        w[i] = (w[i] - dot(dim, &l[i * n..(i + 1) * n], w)) * l_inv[i];
    }
}

/// The lower triangle of the Gram matrix `Xᵀ X` (k×k, column-major into `g`) of the `k`
/// columns of `x`, each of `dim` entries.
#[inline(always)]
fn gram_lower<D: Dim>(dim: D, x: &[f64], k: usize, g: &mut [f64]) {
    let n = dim.get();
    for j in 0..k {
        for i in j..k {
            g[j * k + i] = dot(dim, &x[i * n..(i + 1) * n], &x[j * n..(j + 1) * n]);
        }
    }
}

/// `aᵀ b` over the first `dim` entries, in two interleaved partial sums: half the
/// dependency chain of a running sum (these short dot products are latency-bound).
#[inline(always)]
fn dot<D: Dim>(dim: D, a: &[f64], b: &[f64]) -> f64 {
    let n = dim.get();
    let (a, b) = (&a[..n], &b[..n]);
    let (mut s0, mut s1) = (0.0, 0.0);
    for i in 0..n / 2 {
        s0 += a[2 * i] * b[2 * i];
        s1 += a[2 * i + 1] * b[2 * i + 1];
    }
    if n % 2 == 1 {
        s0 += a[n - 1] * b[n - 1];
    }
    s0 + s1
}

/// Whether the first `dim` entries are finite (`v·0` is `±0` then, else NaN: no branch per
/// entry).
#[inline(always)]
fn all_finite<D: Dim>(dim: D, v: &[f64]) -> bool {
    v[..dim.get()].iter().fold(0.0, |s, &x| s + x * 0.0) == 0.0
}

/// `y ← y + α x` over the first `dim` entries.
#[inline(always)]
fn axpy<D: Dim>(dim: D, alpha: f64, x: &[f64], y: &mut [f64]) {
    let (x, y) = (&x[..dim.get()], &mut y[..dim.get()]);
    for i in 0..dim.get() {
        y[i] += alpha * x[i];
    }
}

/// `x ← H x = x − β v (vᵀ x)` for one Householder reflector.
#[inline(always)]
fn reflect<D: Dim>(dim: D, v: &[f64], beta: f64, x: &mut [f64]) {
    let s = beta * dot(dim, v, x);
    axpy(dim, -s, v, x);
}

/// The typed Lemma 5.1 failure, with the 2-norm condition of the KKT matrix (an SVD: error
/// path only).
fn singular(mbar: DMatrix<f64>, a: DMatrix<f64>, kind: SingularityKind) -> CoreError {
    CoreError::SingularKkt {
        kind,
        condition_estimate: kkt_condition_number(&mbar, &a),
    }
}

/// The 2-norm condition number of `[M̄ Aᵀ; A 0]` (an SVD; used on error paths and in tests),
/// NaN when the matrix is not finite (the SVD would not converge).
pub fn kkt_condition_number(mbar: &DMatrix<f64>, a: &DMatrix<f64>) -> f64 {
    let k = kkt_matrix(mbar, a);
    if !k.iter().all(|x| x.is_finite()) {
        return f64::NAN;
    }
    let sv = k.svd(false, false).singular_values;
    let max = sv.max();
    let min = sv.min();
    if min == 0.0 {
        f64::INFINITY
    } else {
        max / min
    }
}

/// Assembles `[M̄ Aᵀ; A 0]`.
pub fn kkt_matrix(mbar: &DMatrix<f64>, a: &DMatrix<f64>) -> DMatrix<f64> {
    let m = mbar.nrows();
    let c = a.nrows();
    let mut k = DMatrix::zeros(m + c, m + c);
    k.view_mut((0, 0), (m, m)).copy_from(mbar);
    k.view_mut((m, 0), (c, m)).copy_from(a);
    k.view_mut((0, m), (m, c)).copy_from(&a.transpose());
    k
}

/// Solves the same KKT system densely via `M̄_ε`-free LU, for cross-checks.
pub fn kkt_solve_dense(
    mbar: &DMatrix<f64>,
    a: &DMatrix<f64>,
    f: &DVector<f64>,
    g: &DVector<f64>,
) -> Option<(DVector<f64>, DVector<f64>)> {
    let m = mbar.nrows();
    let c = a.nrows();
    let k = kkt_matrix(mbar, a);
    let mut rhs = DVector::zeros(m + c);
    rhs.rows_mut(0, m).copy_from(f);
    rhs.rows_mut(m, c).copy_from(g);
    let sol = k.lu().solve(&rhs)?;
    Some((sol.rows(0, m).into_owned(), sol.rows(m, c).into_owned()))
}

#[cfg(test)]
#[path = "kkt_range_tests.rs"]
mod range_tests;

/// Asserts that each named pair of vectors is equal bit for bit (signed zeros and NaNs
/// included), naming the pair and `case` otherwise.
#[cfg(test)]
fn assert_same_bits(pairs: &[(&str, &Vec<f64>, &Vec<f64>)], case: &str) {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (name, u, w) in pairs {
        assert_eq!(bits(u), bits(w), "{name}, {case}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random `c×m` constraint matrix and a PSD `M̄` whose first `massless` coordinates carry
    /// no mass (as a massless leg's joint does).
    fn random_system(
        m: usize,
        c: usize,
        massless: usize,
        r: &mut ChaCha8Rng,
    ) -> (DMatrix<f64>, DMatrix<f64>) {
        let b = DMatrix::from_fn(m, m, |i, _| {
            if i < massless {
                0.0
            } else {
                r.gen_range(-1.0..1.0)
            }
        });
        let mbar = b.transpose() * &b
            + DMatrix::from_fn(m, m, |i, j| if i == j && i >= massless { 0.5 } else { 0.0 });
        let a = DMatrix::from_fn(c, m, |_, _| r.gen_range(-1.0..1.0));
        (mbar, a)
    }

    /// The kernels compiled for fixed `(m, c)` give the run-time-size kernels' factor and
    /// solution bit for bit (the same operations in the same order): every pair `with_dims!`
    /// fixes, and its neighbours beyond.
    #[test]
    fn fixed_size_kernels_are_bit_identical_to_run_time_ones() {
        let mut r = ChaCha8Rng::seed_from_u64(7);
        let (mut fixed, mut dynamic) = (KktFactorization::default(), KktFactorization::default());
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for m in 1..=13 {
            for c in 0..=m {
                for massless in [0, 1.min(c), 2.min(c)] {
                    let (mbar, a) = random_system(m, c, massless, &mut r);
                    fixed.load(&mbar, &a, None);
                    with_dims!(m, c, |md, cd| factor_kernel(md, cd, &mut fixed, false)).unwrap();
                    dynamic.load(&mbar, &a, None);
                    factor_kernel(m, c, &mut dynamic, false).unwrap();
                    assert_eq!(bits(&fixed.q), bits(&dynamic.q), "Q, m={m} c={c}");
                    assert_eq!(bits(&fixed.l), bits(&dynamic.l), "L, m={m} c={c}");
                    assert_eq!(bits(&fixed.r_diag), bits(&dynamic.r_diag), "R, m={m} c={c}");
                    let f: Vec<f64> = (0..m).map(|_| r.gen_range(-1.0..1.0)).collect();
                    let g: Vec<f64> = (0..c).map(|_| r.gen_range(-1.0..1.0)).collect();
                    let (mut x1, mut y1) = (vec![0.0; m], vec![0.0; c]);
                    let (mut x2, mut y2) = (vec![0.0; m], vec![0.0; c]);
                    fixed.solve(&f, &g, &mut x1, &mut y1);
                    solve_kernel(m, c, &mut dynamic, &f, &g, &mut x2, &mut y2, false);
                    assert_eq!(bits(&x1), bits(&x2), "x, m={m} c={c}");
                    assert_eq!(bits(&y1), bits(&y2), "y, m={m} c={c}");
                }
            }
        }
    }

    /// [`KktFactorization::factor_on`] gathers the system of its coordinates: on every
    /// coordinate in order (loaded by plain copies) and on a subset (gathered by index) it
    /// gives the factorization of the selected matrices bit for bit.
    #[test]
    fn factor_on_coordinates_is_the_factor_of_the_selection() {
        let mut r = ChaCha8Rng::seed_from_u64(33);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let (mut on, mut plain) = (KktFactorization::default(), KktFactorization::default());
        for m in 3..=13 {
            let (mbar, a) = random_system(m, 2, 1, &mut r);
            let all: Vec<usize> = (0..m).collect();
            let subset: Vec<usize> = (0..m).filter(|i| i % 3 != 1).collect();
            for coords in [&all, &subset] {
                let (mb, ac) = (
                    mbar.select_rows(coords.iter())
                        .select_columns(coords.iter()),
                    a.select_columns(coords.iter()),
                );
                let on_ok = on.factor_on(&mbar, &a, coords).is_ok();
                assert_eq!(on_ok, plain.factor(&mb, &ac).is_ok(), "m={m}");
                if !on_ok {
                    continue;
                }
                assert_eq!(bits(&on.q), bits(&plain.q), "Q, m={m}");
                assert_eq!(bits(&on.l), bits(&plain.l), "L, m={m}");
                assert_eq!(bits(&on.mbar), bits(&plain.mbar), "M̄, m={m}");
            }
        }
    }

    /// Every size the kernels are compiled for and the run-time fallback beyond them: the
    /// solution satisfies both block rows, agrees with a dense LU of the KKT matrix, and the
    /// constraint condition is that of the QR of `Aᵀ` (`|R_ii|` are unique).
    #[test]
    fn solve_matches_dense_lu_for_every_size() {
        let mut r = ChaCha8Rng::seed_from_u64(51);
        let mut k = KktFactorization::default();
        for m in 1..=13 {
            for c in 0..=m {
                for massless in [0, 1.min(c), 2.min(c)] {
                    let (mbar, a) = random_system(m, c, massless, &mut r);
                    k.factor(&mbar, &a).unwrap();
                    let f = DVector::from_fn(m, |_, _| r.gen_range(-1.0..1.0));
                    let g = DVector::from_fn(c, |_, _| r.gen_range(-1.0..1.0));
                    let (mut x, mut y) = (vec![0.0; m], vec![0.0; c]);
                    k.solve(f.as_slice(), g.as_slice(), &mut x, &mut y);
                    let (x, y) = (DVector::from_vec(x), DVector::from_vec(y));
                    let (xd, yd) = kkt_solve_dense(&mbar, &a, &f, &g).unwrap();
                    // both solutions are backward stable: compare to rounding × condition
                    let scale = 1.0 + xd.norm() + yd.norm();
                    let tol = 1e-13 * scale * kkt_condition_number(&mbar, &a);
                    assert!((&x - &xd).norm() < tol, "x, m={m} c={c}");
                    assert!((&y - &yd).norm() < tol, "y, m={m} c={c}");
                    assert!((&mbar * &x + a.transpose() * &y - &f).norm() < 1e-10 * scale);
                    assert!((&a * &x - &g).norm() < 1e-10 * scale);
                    if c > 0 {
                        let rd = a.transpose().qr().r().diagonal().map(f64::abs);
                        let expect = rd.max() / rd.min();
                        let got = k.info().constraint_condition;
                        assert!((got - expect).abs() < 1e-9 * expect, "{got} vs {expect}");
                    }
                    let q2 = k.null_space_basis();
                    assert!((&a * &q2).norm() < 1e-12 * (1.0 + a.norm()));
                    let gram = q2.transpose() * &q2;
                    assert!((gram - DMatrix::identity(m - c, m - c)).norm() < 1e-13);
                }
            }
        }
    }

    /// Regression: a massless joint that no constraint row involves is free massless motion
    /// (Lemma 5.1) although rounding in `Q₂` leaves its reduced mass `M̃` a tiny nonzero
    /// number: the pivot test was relative to `M̃` alone, and a 1×1 `M̃` always passed it
    /// (the flow then returned accelerations of 1e30).
    #[test]
    fn massless_joint_untouched_by_constraints_is_singular() {
        // q = [θ, x, z, φ], θ massless; three rows on the body only, mixed so that the
        // reflectors touch θ's row
        let mbar = DMatrix::from_diagonal(&DVector::from_vec(vec![0.0, 7.15, 7.15, 0.15]));
        let a = DMatrix::from_row_slice(
            3,
            4,
            &[0.0, 1.0, 0.3, 0.2, 0.0, -0.4, 1.0, 0.5, 0.0, 0.1, 0.2, 1.0],
        );
        let mut k = KktFactorization::default();
        match k.factor(&mbar, &a) {
            Err(CoreError::SingularKkt {
                kind: SingularityKind::UnconstrainedMasslessMotion,
                condition_estimate,
            }) => assert!(condition_estimate > 1e12, "{condition_estimate}"),
            other => panic!("expected a Lemma 5.1 failure, got {other:?}"),
        }
        // pinning θ with a fourth row makes it regular
        let a4 = a.insert_row(3, 0.0);
        let mut a4 = a4;
        a4[(3, 0)] = 1.0;
        a4[(3, 1)] = 0.2;
        k.factor(&mbar, &a4).unwrap();
    }

    /// A system shaped like a legged robot's (a body of three coordinates, the rest legs of
    /// two joints): each constraint row involves the body and one leg, or is a joint limit
    /// of one joint; `M̄ = BᵀB` with each row of `B` on the body and one leg (exact zeros
    /// between legs), some coordinates massless; exact zeros are `±0` at random.
    fn legged_system(
        m: usize,
        c: usize,
        massless: usize,
        r: &mut ChaCha8Rng,
    ) -> (DMatrix<f64>, DMatrix<f64>) {
        let body = r.gen_range(0..m.saturating_sub(2).max(1));
        let is_body = |p: usize| (body..body + 3).contains(&p);
        let legs: Vec<usize> = (0..m).filter(|&p| !is_body(p)).collect();
        let leg_of = |p: usize| legs.iter().position(|&l| l == p).map(|i| i / 2);
        let rows = |r: &mut ChaCha8Rng, n: usize, limit: bool| {
            let mut out = DMatrix::zeros(n, m);
            for i in 0..n {
                let leg = r.gen_range(0..legs.len().div_ceil(2).max(1));
                let joint = legs.get(r.gen_range(0..legs.len().max(1))).copied();
                for p in 0..m {
                    let on = if limit && r.gen_bool(0.3) {
                        Some(p) == joint
                    } else {
                        is_body(p) || leg_of(p) == Some(leg)
                    };
                    out[(i, p)] = if on {
                        r.gen_range(-1.0..1.0)
                    } else if r.gen_bool(0.5) {
                        -0.0
                    } else {
                        0.0
                    };
                }
            }
            out
        };
        let b = rows(r, m + 2, false);
        let mut mbar = b.transpose() * &b;
        for p in 0..m {
            if p < massless {
                mbar.row_mut(p).fill(0.0);
                mbar.column_mut(p).fill(0.0);
            } else {
                mbar[(p, p)] += 0.5;
            }
        }
        mbar.iter_mut()
            .filter(|x| **x == 0.0 && r.gen_bool(0.5))
            .for_each(|x| *x = -0.0);
        (mbar, rows(r, c, true))
    }

    /// Factors `(M̄, A)` and solves for `(f, g)` by the structured route and by the plain
    /// dense one (every row touched): the same outcome, and on success the same factor,
    /// diagnostics and solution, bit for bit (signed zeros included).
    fn assert_routes_agree(mbar: &DMatrix<f64>, a: &DMatrix<f64>, f: &[f64], g: &[f64]) {
        let (m, c) = (mbar.nrows(), a.nrows());
        let mut k = [KktFactorization::default(), KktFactorization::default()];
        let mut out = vec![];
        for (kkt, dense) in k.iter_mut().zip([false, true]) {
            kkt.load(mbar, a, None);
            let res = with_dims!(m, c, |md, cd| factor_kernel(md, cd, kkt, dense));
            let (mut x, mut y) = (vec![0.0; m], vec![0.0; c]);
            if res.is_ok() {
                with_dims!(m, c, |md, cd| solve_kernel(
                    md, cd, kkt, f, g, &mut x, &mut y, dense
                ));
            }
            out.push((res, x, y));
        }
        let ([s, d], [(rs, xs, ys), (rd, xd, yd)]) = (&k, &out[..]) else {
            unreachable!()
        };
        assert_eq!(rs, rd, "outcome, m={m} c={c}");
        if rs.is_err() {
            return;
        }
        assert_same_bits(
            &[
                ("Q", &s.q, &d.q),
                ("R", &s.r, &d.r),
                ("R_kk", &s.r_diag, &d.r_diag),
                ("β", &s.beta, &d.beta),
                ("Q₁ᵀM̄Q₂", &s.g12, &d.g12),
                ("L", &s.l, &d.l),
                ("1/L_jj", &s.l_inv, &d.l_inv),
                ("x", xs, xd),
                ("y", ys, yd),
            ],
            &format!("m={m} c={c}"),
        );
        assert_eq!(s.info, d.info);
    }

    /// The structured route (unit columns of `Q` outside the reflectors' rows) gives the
    /// plain dense route's results bit for bit: legged systems of every size the kernels
    /// are compiled for and beyond, flight (`c = 0`) to fully constrained (`c = m`),
    /// massless coordinates, signed zeros in `M̄`, `A`, `f`, `g`; rank-deficient `A`, nearly
    /// dependent rows, a nearly singular `M̃`; and non-finite right-hand sides.
    #[test]
    fn structured_route_is_bit_identical_to_the_dense_one() {
        let mut r = ChaCha8Rng::seed_from_u64(30);
        let signed = |r: &mut ChaCha8Rng, n: usize| -> Vec<f64> {
            (0..n)
                .map(|_| match r.gen_range(0..6) {
                    0 => 0.0,
                    1 => -0.0,
                    _ => r.gen_range(-1.0..1.0),
                })
                .collect()
        };
        let (mut touched, mut cases) = (0, 0);
        for m in 3..=13 {
            for c in 0..=m {
                for massless in [0, 1, 2] {
                    let (mbar, a) = legged_system(m, c, massless, &mut r);
                    let (f, g) = (signed(&mut r, m), signed(&mut r, c));
                    assert_routes_agree(&mbar, &a, &f, &g);
                    // a repeated row; a row nearly a copy of another
                    if c >= 2 {
                        let mut dup = a.clone();
                        dup.set_row(1, &a.row(0));
                        assert_routes_agree(&mbar, &dup, &f, &g);
                        dup.row_mut(1).iter_mut().for_each(|x| *x *= 1.0 + 1e-9);
                        dup[(1, r.gen_range(0..m))] += 1e-9;
                        assert_routes_agree(&mbar, &dup, &f, &g);
                    }
                    // M̃ nearly singular: a nearly massless coordinate
                    let mut light = mbar.clone();
                    let p = r.gen_range(0..m);
                    light.row_mut(p).iter_mut().for_each(|x| *x *= 1e-6);
                    light.column_mut(p).iter_mut().for_each(|x| *x *= 1e-6);
                    assert_routes_agree(&light, &a, &f, &g);
                    // non-finite f or g take the plain route
                    let mut bad = f.clone();
                    bad[r.gen_range(0..m)] = [f64::NAN, f64::INFINITY][r.gen_range(0..2)];
                    assert_routes_agree(&mbar, &a, &bad, &g);
                    if c > 0 {
                        let mut bad = g.clone();
                        bad[0] = f64::NEG_INFINITY;
                        assert_routes_agree(&mbar, &a, &f, &bad);
                    }
                    // the case exercises the structure when some row is untouched
                    let mut k = KktFactorization::default();
                    if m > SMALL_M && k.factor(&mbar, &a).is_ok() {
                        cases += 1;
                        touched += usize::from(!k.all_touched);
                    }
                }
            }
        }
        assert!(
            touched * 3 > cases,
            "{touched} of {cases} with untouched rows"
        );
    }

    /// A non-finite `M̄` (or `A`) through the public entry: the outcome of the plain route
    /// (a Lemma 5.1 failure when anything is free to move, `c < m`).
    #[test]
    fn non_finite_inputs_fail_as_on_the_dense_route() {
        let mut r = ChaCha8Rng::seed_from_u64(31);
        for m in [4, 11, 13] {
            for c in [0, 2, m] {
                let (mbar, a) = legged_system(m, c, 0, &mut r);
                let mut bad = mbar.clone();
                bad[(m - 1, 0)] = f64::NAN;
                let mut k = KktFactorization::default();
                let got = k.factor(&bad, &a).is_ok();
                let mut d = KktFactorization::default();
                d.load(&bad, &a, None);
                let dense = with_dims!(m, c, |md, cd| factor_kernel(md, cd, &mut d, true));
                assert_eq!(got, dense.is_ok(), "m={m} c={c}");
                assert!(!got || c == m, "m={m} c={c}");
                if c > 0 {
                    let mut bad = a.clone();
                    bad[(c - 1, m - 1)] = f64::NAN;
                    let f = vec![1.0; m];
                    assert_routes_agree(&mbar, &bad, &f, &vec![0.5; c]);
                }
            }
        }
    }
}
