//! The KKT system of thesis (5.2) by eliminating the limbs' rates (the null-space method with
//! the tree's own basis of `ker A`), for contact sets that pin every limb they touch: the
//! spatial engine's first route, tried before [`super::tree_kkt`].
//!
//! A **limb** is the subtree of one child of the root block (the six rates `b` of a
//! free-flying base; on a fixed base, of the world): its rates `l` are contiguous in `v`, and
//! `M` couples two limbs only through the root block. When the rows of `A` on limb `i` (the
//! rows with an entry on its rates) are at least as many as its rates (at most three), with a
//! block `A_ll` of full column rank — a three-joint leg on a foot with friction, RHex's
//! one-joint leg on a toe — Gauss–Jordan with partial pivoting finds row operations `E` with
//! `E [A_ll | A_lb] = [1 | −T; 0 | C]` (`E = A_ll⁻¹` when `A_ll` is square): the first rows fix
//! that limb's rates from the base's,
//!
//! `x_l = T x_b + s`, `[s; h] = E g_l`,
//!
//! and the others are **base rows** `C x_b = h`, constraints on the root block alone (RHex's
//! toe with friction: one row fixes its leg, two hold the base).
//!
//! The other limbs (no rows: a swing leg) keep their rates `x_f`. With `N = [1; T]` a basis of
//! `ker A` on the root block, `[M Aᵀ; A 0][x; y] = [f; g]` reduces to the symmetric system in
//! `z = [x_b; x_f]`, `R z = r`, of size `nb + nf`:
//!
//! - `R_bb = M_bb + Σ_limbs (P T + Tᵀ M_lb)`, `P = M_bl + Tᵀ M_ll`; `R_bf = M_bf`; `R_ff = M_ff`;
//! - `r_b = f_b + Σ_limbs (Tᵀ f_l − P s)`, `r_f = f_f`;
//!
//! factored by a dense Cholesky (`R = Nᵀ M N`), and each pinned limb's multipliers follow from
//! its own rows of the equations of motion, `y_l = Eᵀ [f_l − M_lb x_b − M_ll x_l; μ_l]`. Base
//! rows `C` (at most `nb`) add `Cᵀ μ` to `R z = r` and `C z_b = h`: a second Gauss–Jordan, with
//! column pivoting, eliminates one base rate per base row, `z = S w + t`, and
//! `Sᵀ R S w = Sᵀ (r − R t)` is factored instead ([`LimbKkt::factor_base_rows`]). No
//! `A M⁻¹ Aᵀ` is formed: its condition grows with the ratio of the base's inertia to light
//! legs' (about 1e7 on RHex's tripod with friction), this route's does not.
//!
//! `R` is positive definite wherever `M` is on `ker A`, so the elimination would also be exact
//! for a massless pinned limb; the route is nevertheless taken only where `M` is positive
//! definite (the range-space route's condition, so [`super::KktRoute`] keeps its meaning):
//! with a singular `M`, the null-space block inverse of Lemma 5.1 stays the route, whose
//! rounding the existing closed-form checks (a robot held at rest on massless legs, `q̈` to
//! 1e-12) were set against.
//!
//! For the quadruped on four feet with friction this is a 3 × 3 LU per leg and a 6 × 6
//! Cholesky, against the range-space route's `LᵀDL` of `M`, the rows' `A M⁻¹ Aᵀ` (12 × 12) and
//! its Cholesky.
//!
//! [`LimbKkt::factor`] declines (the caller then takes the range-space route, or the
//! null-space block inverse) when: `M` is not clearly positive definite (a limb's diagonal
//! block has a pivot the range-space route would refuse: a massless limb); a joint other than a free-flying root moves more than one
//! rate; a row has no entry on any limb (a contact on the trunk) or entries on two limbs; a
//! limb carries rows but fewer than its rates (a frictionless foot on a three-joint leg, a
//! foot held in a plane), or more than three (two contacts on a longer limb); the base rows
//! are more than `nb` (six toes with friction; any on a fixed base) or dependent (a pivot of
//! their elimination below [`LIMB_PIVOT_FRACTION`] of their largest entry) — such sets are
//! redundant; a limb's `A_ll` is
//! singular or nearly so (a pivot of its LU below [`LIMB_PIVOT_FRACTION`] of its largest
//! entry: a stretched leg); `R` is not clearly positive definite (a pivot below
//! [`REDUCED_PIVOT_FRACTION`] of its largest diagonal entry); or a free-flying root's own
//! body inertia is not positive definite (see [`LimbKkt::limbs_definite`]).
#![allow(non_snake_case)]
use super::model::{JointKind, SpatialModel};
use super::tree_kkt::{cholesky_solve, dense_cholesky, MASSLESS_DIAGONAL, PIVOT_FRACTION};
use nalgebra::{DMatrix, Matrix6, Vector6};
use std::cmp::Ordering;

/// A pivot of a limb's `A_ll` (partial pivoting) at most this fraction of its largest entry
/// (a leg near a singular configuration) declines the route.
pub const LIMB_PIVOT_FRACTION: f64 = 1e-6;
/// A Cholesky pivot of the reduced `R` at most this fraction of its largest diagonal entry
/// declines the route.
pub const REDUCED_PIVOT_FRACTION: f64 = 1e-10;

/// Size of a free-flying root's block.
const ROOT: usize = 6;
/// Most rates of a limb the route pins (a point contact has at most three rows; the largest
/// width of [`by_width`]).
const MAX_PINNED: usize = 3;
/// Most rows whose limbs [`LimbKkt::factor_rows`] finds by bit masks (six feet with friction).
const MASKED_ROWS: usize = 18;

/// `$f::<N, R>(…)` for a limb's `$n` rates and `$r ≥ $n` rows (at most [`MAX_PINNED`]): every
/// loop over them then has constant bounds and unrolls.
macro_rules! by_shape {
    ($n:expr, $r:expr, $f:ident($($arg:expr),* $(,)?)) => {
        match ($n, $r) {
            (1, 1) => $f::<1, 1>($($arg),*),
            (1, 2) => $f::<1, 2>($($arg),*),
            (1, _) => $f::<1, 3>($($arg),*),
            (2, 2) => $f::<2, 2>($($arg),*),
            (2, _) => $f::<2, 3>($($arg),*),
            _ => $f::<3, 3>($($arg),*),
        }
    };
}

/// One limb: its rates `start..start + len` and (after [`LimbKkt::factor`]) whether rows pin
/// it, with its factors then (sized for [`MAX_PINNED`] rows, the first `len` (rates) or
/// `n_rows` used).
#[derive(Debug, Clone, Copy, Default)]
struct Limb {
    start: usize,
    len: usize,
    pinned: bool,
    /// Its rows of `A`, in order (the first `n_rows`, at least `len`).
    n_rows: usize,
    rows: [usize; MAX_PINNED],
    /// Where its `n_rows − len` base rows start among [`LimbKkt::base`].
    base_at: usize,
    /// The row operations `E` (row-major, `n_rows × n_rows`) that reduce its `A_ll` to
    /// `[1; 0]`: `A_ll⁻¹` when it is square.
    e: [[f64; MAX_PINNED]; MAX_PINNED],
    /// `M_ll` (row-major), and per rate `k`: row `k` of `T` and of `M_lb`, column `k` of `P`
    /// (zero past `nb`).
    mll: [[f64; MAX_PINNED]; MAX_PINNED],
    t: [Vector6<f64>; MAX_PINNED],
    mlb: [Vector6<f64>; MAX_PINNED],
    p: [Vector6<f64>; MAX_PINNED],
}

/// Workspace and factors of the limb elimination for one model (see the module's text).
#[derive(Debug, Clone, Default)]
pub struct LimbKkt {
    nv: usize,
    /// Rates of the root block: 6 on a free-flying base, 0 on a fixed one.
    nb: usize,
    /// The model has the structure the route needs (single-rate joints below the root, limbs
    /// contiguous in `v`, a free-flying root with a positive definite body inertia).
    supported: bool,
    limbs: Vec<Limb>,
    /// The limb of each rate (`usize::MAX` for the root block's).
    limb_of: Vec<usize>,
    /// Each row's limb.
    row_limb: Vec<usize>,
    /// The free rates (of limbs no row pins), ascending; the Cholesky factor of `R`
    /// (`nr × nr`, row-major, lower, `nr = nb + free.len()`) or, with no free rate on a
    /// free-flying base, `root`, its fixed-size factor.
    free: Vec<usize>,
    r: Vec<f64>,
    root: Option<nalgebra::Cholesky<f64, nalgebra::U6>>,
    /// The base rows `C` (rows a limb carries beyond its rates, reduced to the root block),
    /// `Y = R⁻¹ [Cᵀ; 0]` (one `nr`-vector a row) and the Cholesky factor of `C Y`
    /// (`nc × nc`, row-major, lower); their right-hand side, then multipliers, `mu`.
    base: Vec<Vector6<f64>>,
    mu: Vec<f64>,
    /// With base rows: `R` in full (`nr × nr`), the base rates each base row eliminates, the
    /// row operations `E` (`nc × nc`), the basis `S` (`nr × nw`) and scratch
    /// ([`Self::factor_base_rows`]).
    r_full: Vec<f64>,
    elim: [usize; ROOT],
    e_base: [[f64; ROOT]; ROOT],
    s: Vec<f64>,
    work: Vec<f64>,
    /// Scratch: `z` (size `nr`) and a limb block of `M` (see [`Self::limbs_definite`]).
    z: Vec<f64>,
    block: Vec<f64>,
}

impl LimbKkt {
    pub fn new(model: &SpatialModel) -> Self {
        let nv = model.nv;
        let free_flyer = matches!(
            model.joints.first().map(|j| j.kind),
            Some(JointKind::FreeFlyer)
        );
        let nb = if free_flyer { ROOT } else { 0 };
        let single = model
            .joints
            .iter()
            .enumerate()
            .all(|(i, j)| j.kind.nv() == 1 || (i == 0 && free_flyer));
        // the root's body must be positive definite for `M`'s definiteness to follow from the
        // limbs' blocks (its Schur complement is then the root's articulated inertia)
        let root_definite = !free_flyer
            || model.inertias[0]
                .matrix()
                .cholesky()
                .is_some_and(|c| c.l().diagonal().min() > 1e-9 * c.l().diagonal().max());
        // the limb of each joint: its own index below the root, its ancestor's below that
        let mut limb_root = vec![None; model.joints.len()];
        for (i, joint) in model.joints.iter().enumerate() {
            limb_root[i] = match joint.parent {
                None if free_flyer => None,
                None => Some(i),
                Some(0) if free_flyer => Some(i),
                Some(p) => limb_root[p],
            };
        }
        let mut limbs: Vec<Limb> = Vec::new();
        let mut limb_index = vec![usize::MAX; model.joints.len()];
        let mut limb_of = vec![usize::MAX; nv];
        let mut contiguous = true;
        for (i, joint) in model.joints.iter().enumerate() {
            let Some(root) = limb_root[i] else { continue };
            if limb_index[root] == usize::MAX {
                limb_index[root] = limbs.len();
                limbs.push(Limb {
                    start: joint.idx_v,
                    ..Limb::default()
                });
            }
            let l = limb_index[root];
            let rates = joint.idx_v..joint.idx_v + joint.kind.nv();
            for (k, of) in rates.clone().zip(&mut limb_of[rates]) {
                let limb = &mut limbs[l];
                contiguous &= k == limb.start + limb.len;
                limb.len += 1;
                *of = l;
            }
        }
        let longest = limbs.iter().map(|l| l.len).max().unwrap_or(0);
        Self {
            nv,
            nb,
            supported: single && root_definite && contiguous,
            limbs,
            limb_of,
            row_limb: Vec::new(),
            free: Vec::with_capacity(nv),
            r: Vec::new(),
            root: None,
            base: Vec::with_capacity(ROOT),
            mu: Vec::new(),
            r_full: Vec::new(),
            elim: [0; ROOT],
            e_base: [[0.0; ROOT]; ROOT],
            s: Vec::new(),
            work: Vec::new(),
            z: Vec::new(),
            block: vec![0.0; longest * longest],
        }
    }

    /// Factors the limb elimination of `[M Aᵀ; A 0]`; `false` (nothing usable) when the
    /// route does not apply (the module's text lists when). `M` is symmetric to the bit (as
    /// the backward sweep writes it): a limb's `M_lb` is read from its columns' base rows.
    pub fn factor(&mut self, M: &DMatrix<f64>, A: &DMatrix<f64>) -> bool {
        let (m, a) = (M.as_slice(), A.as_slice());
        self.supported && self.limbs_definite(m) && self.factor_rows(m, a, A.nrows()).is_some()
    }

    /// [`Self::factor`] once `M` is known positive definite.
    fn factor_rows(&mut self, m: &[f64], a: &[f64], c: usize) -> Option<()> {
        // each row's limb: the one limb its entries past the root block lie on
        self.row_limb.clear();
        self.row_limb.resize(c, usize::MAX);
        if self.limbs.len() <= 64 && c <= MASKED_ROWS {
            self.row_limbs_masked(a, c)?;
        } else {
            self.row_limbs_scanned(a, c)?;
        }
        self.place_rows(m, a, c)
    }

    /// [`Self::factor_rows`]'s rows' limbs without branches: per row a bit per limb it has an
    /// entry on (at most 64 limbs and [`MASKED_ROWS`] rows); `None` for a row on two limbs.
    fn row_limbs_masked(&mut self, a: &[f64], c: usize) -> Option<()> {
        let mut on = [0u64; MASKED_ROWS];
        for k in self.nb..self.nv {
            let bit = 1u64 << self.limb_of[k];
            for (o, &x) in on.iter_mut().zip(&a[k * c..(k + 1) * c]) {
                *o |= u64::from(x != 0.0) * bit;
            }
        }
        for (rl, &o) in self.row_limb.iter_mut().zip(&on) {
            if o.count_ones() > 1 {
                return None;
            }
            if o != 0 {
                *rl = o.trailing_zeros() as usize;
            }
        }
        Some(())
    }

    /// [`Self::factor_rows`]'s rows' limbs by a scan with branches (more than 64 limbs or
    /// [`MASKED_ROWS`] rows); `None` for a row on two limbs.
    fn row_limbs_scanned(&mut self, a: &[f64], c: usize) -> Option<()> {
        let (nv, nb) = (self.nv, self.nb);
        for k in nb..nv {
            let l = self.limb_of[k];
            for (rl, &x) in self.row_limb.iter_mut().zip(&a[k * c..(k + 1) * c]) {
                if x != 0.0 {
                    if *rl == usize::MAX {
                        *rl = l;
                    } else if *rl != l {
                        return None;
                    }
                }
            }
        }
        Some(())
    }

    /// [`Self::factor_rows`] once each row's limb is known.
    fn place_rows(&mut self, m: &[f64], a: &[f64], c: usize) -> Option<()> {
        let (nv, nb) = (self.nv, self.nb);
        for limb in &mut self.limbs {
            limb.pinned = false;
            limb.n_rows = 0;
        }
        for (r, &l) in self.row_limb.iter().enumerate() {
            let limb = self.limbs.get_mut(l)?;
            if limb.n_rows == MAX_PINNED {
                return None;
            }
            limb.rows[limb.n_rows] = r;
            limb.pinned = true;
            limb.n_rows += 1;
        }
        self.free.clear();
        self.base.clear();
        let mut rbb = Matrix6::<f64>::zeros();
        for limb in self.limbs.iter_mut() {
            if !limb.pinned {
                self.free.extend(limb.start..limb.start + limb.len);
                continue;
            }
            if limb.n_rows < limb.len
                || !by_shape!(
                    limb.len,
                    limb.n_rows,
                    factor_limb(limb, m, nv, nb, a, c, &mut rbb, &mut self.base)
                )
                || self.base.len() > nb
            {
                return None;
            }
        }
        // R = [M_bb + Σ (P T + Tᵀ M_lb), M_bf; M_fb, M_ff]
        let nr = nb + self.free.len();
        self.z.resize(nr, 0.0);
        self.mu.resize(self.base.len(), 0.0);
        if nb == ROOT && self.free.is_empty() && self.base.is_empty() {
            let rbb = Matrix6::from_fn(|i, j| {
                let (i, j) = (i.max(j), i.min(j));
                m[i + j * nv] + rbb[(i, j)]
            });
            let largest = rbb.diagonal().max();
            let chol = nalgebra::Cholesky::new_unchecked(rbb);
            let least = chol.l_dirty().diagonal().min();
            if least.partial_cmp(&(REDUCED_PIVOT_FRACTION * largest).sqrt())
                != Some(Ordering::Greater)
            {
                return None;
            }
            self.root = Some(chol);
        } else {
            self.root = None;
            self.r.clear();
            self.r.resize(nr * nr, 0.0);
            for i in 0..nb {
                for j in 0..=i {
                    self.r[i * nr + j] = m[i + j * nv] + rbb[(i, j)];
                }
            }
            for (fi, &k) in self.free.iter().enumerate() {
                let row = (nb + fi) * nr;
                for j in 0..nb {
                    self.r[row + j] = m[k + j * nv];
                }
                for (fj, &kj) in self.free[..=fi].iter().enumerate() {
                    self.r[row + nb + fj] = m[k + kj * nv];
                }
            }
            if !self.base.is_empty() {
                return self.factor_base_rows();
            }
            let largest = (0..nr).map(|i| self.r[i * nr + i]).fold(0.0, f64::max);
            if !dense_cholesky(&mut self.r, nr, REDUCED_PIVOT_FRACTION * largest) {
                return None;
            }
        }
        Some(())
    }

    /// With `nc ≤ nb` base rows `C` (`R`'s lower triangle in `r`): Gauss–Jordan with column
    /// pivoting reduces them to `E C`, the identity on `nc` eliminated base rates and `G` on
    /// the kept ones, so `z = S w + t` (`w`: the kept base rates, then the free rates; `t`:
    /// the eliminated rates' `E h`), and `Sᵀ R S w = Sᵀ (r − R t)` is factored by a dense
    /// Cholesky into `r`. `None` when a pivot of either is not clear (base rows dependent: a
    /// contact set that holds the base redundantly).
    fn factor_base_rows(&mut self) -> Option<()> {
        let (nb, nc, nr) = (self.nb, self.base.len(), self.z.len());
        let nw = nr - nc;
        let full = &mut self.r_full;
        full.clear();
        full.resize(nr * nr, 0.0);
        for i in 0..nr {
            for j in 0..=i {
                let x = self.r[i * nr + j];
                full[i * nr + j] = x;
                full[j * nr + i] = x;
            }
        }
        let mut c = [Vector6::zeros(); ROOT];
        c[..nc].copy_from_slice(&self.base);
        let mut e = [[0.0; ROOT]; ROOT];
        let largest = self.base.iter().fold(0.0f64, |s, r| s.max(r.amax()));
        let mut eliminated = [false; ROOT];
        for (k, row) in e[..nc].iter_mut().enumerate() {
            row[k] = 1.0;
        }
        for k in 0..nc {
            let p = (0..nb)
                .filter(|&j| !eliminated[j])
                .max_by(|&i, &j| c[k][i].abs().total_cmp(&c[k][j].abs()))?;
            if c[k][p].abs().partial_cmp(&(LIMB_PIVOT_FRACTION * largest))
                != Some(Ordering::Greater)
            {
                return None;
            }
            self.elim[k] = p;
            eliminated[p] = true;
            let d = 1.0 / c[k][p];
            c[k] *= d;
            for x in &mut e[k][..nc] {
                *x *= d;
            }
            for i in (0..nc).filter(|&i| i != k) {
                let l = c[i][p];
                let (ck, ek) = (c[k], e[k]);
                c[i] -= ck * l;
                for (x, y) in e[i][..nc].iter_mut().zip(&ek[..nc]) {
                    *x -= l * y;
                }
            }
        }
        self.e_base = e;
        // S (nr × nw, row-major)
        let s = &mut self.s;
        s.clear();
        s.resize(nr * nw, 0.0);
        for (col, j) in (0..nb).filter(|&j| !eliminated[j]).enumerate() {
            s[j * nw + col] = 1.0;
            for k in 0..nc {
                s[self.elim[k] * nw + col] = -c[k][j];
            }
        }
        for i in nb..nr {
            s[i * nw + i - nc] = 1.0;
        }
        // Sᵀ R S, lower triangle, into r
        let rs = &mut self.work;
        rs.clear();
        rs.extend((0..nr * nw).map(|ic| {
            let (i, col) = (ic / nw, ic % nw);
            (0..nr).fold(0.0, |x, j| x + full[i * nr + j] * s[j * nw + col])
        }));
        self.r.clear();
        self.r.resize(nw * nw, 0.0);
        for a in 0..nw {
            for b in 0..=a {
                self.r[a * nw + b] = (0..nr).fold(0.0, |x, i| x + s[i * nw + a] * rs[i * nw + b]);
            }
        }
        let largest = (0..nw).map(|i| self.r[i * nw + i]).fold(0.0, f64::max);
        dense_cholesky(&mut self.r, nw, REDUCED_PIVOT_FRACTION * largest).then_some(())
    }

    /// Whether `M` is clearly positive definite: every limb's diagonal block has clear pivots
    /// (eliminated from its deepest rate up, with [`super::tree_kkt`]'s tolerances), and the
    /// root's block then is too, its Schur complement being the root's articulated inertia,
    /// at least the root body's own, positive definite ([`Self::new`]).
    fn limbs_definite(&mut self, m: &[f64]) -> bool {
        let nv = self.nv;
        let largest = (0..nv).map(|k| m[k + k * nv]).fold(0.0, f64::max);
        let block = &mut self.block;
        self.limbs.iter().all(|limb| {
            let e = limb.start + limb.len - 1;
            // a limb of up to three rates in a fixed-size block (the loops unroll)
            match limb.len {
                1 => limb_clear::<1>(m, nv, e, largest, &mut [0.0; 1]),
                2 => limb_clear::<2>(m, nv, e, largest, &mut [0.0; 4]),
                3 => limb_clear::<3>(m, nv, e, largest, &mut [0.0; 9]),
                n => limb_clear::<0>(m, nv, e, largest, &mut block[..n * n]),
            }
        })
    }

    /// Solves `[M Aᵀ; A 0][x; y] = [f; g]` with the current factors.
    pub fn solve(&mut self, f: &[f64], g: &[f64], x: &mut [f64], y: &mut [f64]) {
        let nb = self.nb;
        // [s; h] = E g_l (s into x's limb rates for now, h into mu); r_b = f_b + Σ (Tᵀ f_l − P s)
        let mut rb = Vector6::from_fn(|j, _| if j < nb { f[j] } else { 0.0 });
        for limb in self.limbs.iter().filter(|l| l.pinned) {
            by_shape!(
                limb.len,
                limb.n_rows,
                limb_rhs(limb, f, g, x, &mut self.mu, &mut rb)
            );
        }
        self.reduced_solve(&mut rb, f);
        // x_b, x_f; x_l = T x_b + s and y_l = A_ll⁻ᵀ (f_l − M_lb x_b − M_ll x_l)
        x[..nb].copy_from_slice(&self.z[..nb]);
        for (&k, &zi) in self.free.iter().zip(&self.z[nb..]) {
            x[k] = zi;
        }
        let xb = Vector6::from_fn(|j, _| if j < nb { self.z[j] } else { 0.0 });
        for limb in self.limbs.iter().filter(|l| l.pinned) {
            by_shape!(
                limb.len,
                limb.n_rows,
                limb_back(limb, &xb, f, &self.mu, x, y)
            );
        }
    }

    /// `z = R⁻¹ [r_b; f_f]` (`f_f` the free rates' entries of `f`, zero where `f` is empty),
    /// or with base rows that of `R z + [Cᵀ; 0] μ = [r_b; f_f]`, `C z_b = h` (`h` in `mu` on
    /// entry, `μ` on return): `z = S w + t` ([`Self::factor_base_rows`]) and
    /// `μ = (E C)ᵀ⁻¹… = Eᵀ (r − R z)_e` on the eliminated rates.
    fn reduced_solve(&mut self, rb: &mut Vector6<f64>, f: &[f64]) {
        let (nb, nr) = (self.nb, self.nb + self.free.len());
        let z = &mut self.z;
        if let Some(chol) = &self.root {
            chol.solve_mut(rb);
            z.copy_from_slice(rb.as_slice());
            return;
        }
        z[..nb].copy_from_slice(&rb.as_slice()[..nb]);
        for (zi, &k) in z[nb..].iter_mut().zip(&self.free) {
            *zi = f.get(k).copied().unwrap_or(0.0);
        }
        let nc = self.base.len();
        if nc == 0 {
            cholesky_solve(&self.r, nr, z);
            return;
        }
        let nw = nr - nc;
        let (full, s, elim, e) = (&self.r_full, &self.s, &self.elim, &self.e_base);
        let work = &mut self.work;
        work.clear();
        work.resize(4 * nr, 0.0);
        let (r, rest) = work.split_at_mut(nr);
        let (t, rest) = rest.split_at_mut(nr);
        let (u, w) = rest.split_at_mut(nr);
        r.copy_from_slice(z);
        for k in 0..nc {
            t[elim[k]] = (0..nc).fold(0.0, |x, j| x + e[k][j] * self.mu[j]);
        }
        // w = (Sᵀ R S)⁻¹ Sᵀ (r − R t), then z = S w + t
        for (i, ui) in u.iter_mut().enumerate() {
            *ui = (0..nr).fold(r[i], |x, j| x - full[i * nr + j] * t[j]);
        }
        for (col, wc) in w[..nw].iter_mut().enumerate() {
            *wc = (0..nr).fold(0.0, |x, i| x + s[i * nw + col] * u[i]);
        }
        cholesky_solve(&self.r, nw, &mut w[..nw]);
        for (i, zi) in z.iter_mut().enumerate() {
            *zi = (0..nw).fold(t[i], |x, col| x + s[i * nw + col] * w[col]);
        }
        // μ = Eᵀ (r − R z) on the eliminated rates
        let res: [f64; ROOT] = std::array::from_fn(|k| {
            if k < nc {
                let i = elim[k];
                (0..nr).fold(r[i], |x, j| x - full[i * nr + j] * z[j])
            } else {
                0.0
            }
        });
        for (k, mu) in self.mu.iter_mut().enumerate() {
            *mu = (0..nc).fold(0.0, |x, j| x + e[j][k] * res[j]);
        }
    }
}

/// Limb `limb`'s factors with `N` rates and `R ≥ N` rows: the row operations `E` that reduce
/// `[A_ll | A_lb]` to `[1 | −T; 0 | C]` (Gauss–Jordan with partial pivoting), its `R − N`
/// base rows `C` pushed to `base`, `P = M_bl + Tᵀ M_ll`, and its term `P T + Tᵀ M_lb` of
/// `R_bb` added to `rbb`'s lower triangle; `false` when `A_ll` has not clearly full column
/// rank ([`LIMB_PIVOT_FRACTION`]).
#[allow(clippy::too_many_arguments)]
fn factor_limb<const N: usize, const R: usize>(
    limb: &mut Limb,
    m: &[f64],
    nv: usize,
    nb: usize,
    a: &[f64],
    c: usize,
    rbb: &mut Matrix6<f64>,
    base: &mut Vec<Vector6<f64>>,
) -> bool {
    let k0 = limb.start;
    let rows = limb.rows;
    // [A_ll | A_lb | 1] row by row, reduced by Gauss–Jordan with partial pivoting
    let mut all = [[0.0; N]; R];
    let mut e = [[0.0; R]; R];
    let mut alb = [Vector6::zeros(); R];
    for i in 0..R {
        for j in 0..N {
            all[i][j] = a[(k0 + j) * c + rows[i]];
        }
        e[i][i] = 1.0;
        if nb == ROOT {
            let ai = &a[rows[i]..];
            alb[i] = Vector6::from_fn(|j, _| ai[j * c]);
        }
    }
    let largest = all.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
    for k in 0..N {
        let mut p = k;
        for i in k + 1..R {
            if all[i][k].abs() > all[p][k].abs() {
                p = i;
            }
        }
        if all[p][k]
            .abs()
            .partial_cmp(&(LIMB_PIVOT_FRACTION * largest))
            != Some(Ordering::Greater)
        {
            return false;
        }
        all.swap(k, p);
        e.swap(k, p);
        alb.swap(k, p);
        let d = 1.0 / all[k][k];
        all[k].iter_mut().for_each(|x| *x *= d);
        e[k].iter_mut().for_each(|x| *x *= d);
        alb[k] *= d;
        let (all_k, e_k, alb_k) = (all[k], e[k], alb[k]);
        for (i, ((all_i, e_i), alb_i)) in all.iter_mut().zip(&mut e).zip(&mut alb).enumerate() {
            if i != k {
                let l = all_i[k];
                for (x, y) in all_i.iter_mut().zip(&all_k) {
                    *x -= l * y;
                }
                for (x, y) in e_i.iter_mut().zip(&e_k) {
                    *x -= l * y;
                }
                *alb_i -= alb_k * l;
            }
        }
    }
    // alb is now [−T; C]; M's limb blocks
    limb.e = [[0.0; MAX_PINNED]; MAX_PINNED];
    for (to, from) in limb.e.iter_mut().zip(&e) {
        to[..R].copy_from_slice(from);
    }
    limb.base_at = base.len();
    base.extend_from_slice(&alb[N..]);
    for i in 0..N {
        limb.t[i] = -alb[i];
        // row k0 + i of M_b·, read as its column (M is symmetric to the bit)
        limb.mlb[i] = if nb == ROOT {
            Vector6::from_column_slice(&m[(k0 + i) * nv..][..ROOT])
        } else {
            Vector6::zeros()
        };
        for j in 0..N {
            limb.mll[i][j] = m[(k0 + i) + (k0 + j) * nv];
        }
    }
    for i in 0..N {
        let mut p = limb.mlb[i];
        for j in 0..N {
            p += limb.t[j] * limb.mll[j][i];
        }
        limb.p[i] = p;
    }
    // R_bb's term P T + Tᵀ M_lb (symmetric: M_bl T + Tᵀ M_lb + Tᵀ M_ll T), lower triangle,
    // over the whole fixed-size block (past `nb` the entries are zero; constant bounds unroll)
    for a in 0..ROOT {
        for b in 0..=a {
            let mut s = 0.0;
            for i in 0..N {
                s += limb.p[i][a] * limb.t[i][b] + limb.t[i][a] * limb.mlb[i][b];
            }
            rbb[(a, b)] += s;
        }
    }
    true
}

/// `[s; h] = E g_l`: `s` into `x`'s limb rates and the base rows' right-hand side `h` into
/// `hb`; and `rb += Tᵀ f_l − P s`.
fn limb_rhs<const N: usize, const R: usize>(
    limb: &Limb,
    f: &[f64],
    g: &[f64],
    x: &mut [f64],
    hb: &mut [f64],
    rb: &mut Vector6<f64>,
) {
    let eg = |i: usize| (0..R).fold(0.0, |s, j| s + limb.e[i][j] * g[limb.rows[j]]);
    for i in 0..N {
        let s = eg(i);
        x[limb.start + i] = s;
        *rb += limb.t[i] * f[limb.start + i] - limb.p[i] * s;
    }
    for i in N..R {
        hb[limb.base_at + i - N] = eg(i);
    }
}

/// `x_l = T x_b + s` (`s` in `x`'s limb rates) and the limb's multipliers
/// `y_l = Eᵀ [f_l − M_lb x_b − M_ll x_l; μ_l]` (`μ_l` its base rows' multipliers in `mu`).
fn limb_back<const N: usize, const R: usize>(
    limb: &Limb,
    xb: &Vector6<f64>,
    f: &[f64],
    mu: &[f64],
    x: &mut [f64],
    y: &mut [f64],
) {
    let mut xl = [0.0; N];
    for i in 0..N {
        xl[i] = limb.t[i].dot(xb) + x[limb.start + i];
        x[limb.start + i] = xl[i];
    }
    let mut e = [0.0; R];
    for i in 0..N {
        e[i] = (0..N).fold(f[limb.start + i] - limb.mlb[i].dot(xb), |s, j| {
            s - limb.mll[i][j] * xl[j]
        });
    }
    e[N..].copy_from_slice(&mu[limb.base_at..limb.base_at + R - N]);
    for j in 0..R {
        y[limb.rows[j]] = (0..R).fold(0.0, |s, i| s + limb.e[i][j] * e[i]);
    }
}

/// Whether the diagonal block of `M` (column-major `m`, `nv × nv`) on the limb's rates ending
/// at `e` (`block.len()` = its rates squared; `N` that count, or 0 for any) has clear pivots:
/// every diagonal entry above [`MASSLESS_DIAGONAL`] of `largest` and [`ldl_clear`]'s pivots,
/// eliminated from the deepest rate up, as the tree's `LᵀDL` does.
#[inline(always)]
fn limb_clear<const N: usize>(
    m: &[f64],
    nv: usize,
    e: usize,
    largest: f64,
    block: &mut [f64],
) -> bool {
    let n = if N == 0 { block.len().isqrt() } else { N };
    // reversed order: the deepest rate first
    for i in 0..n {
        for j in 0..n {
            block[i * n + j] = m[(e - i) + (e - j) * nv];
        }
    }
    (0..n).all(|i| m[(e - i) * (nv + 1)] > MASSLESS_DIAGONAL * largest)
        && ldl_clear(block, n, |i| m[(e - i) * (nv + 1)])
}

/// Whether the symmetric `n × n` row-major `block` has `LDLᵀ` pivots `d_i > PIVOT_FRACTION ·
/// diagonal(i)` (eliminating in index order; `block`'s lower triangle is overwritten).
#[inline(always)]
fn ldl_clear(block: &mut [f64], n: usize, diagonal: impl Fn(usize) -> f64) -> bool {
    for k in 0..n {
        let d = block[k * n + k];
        if d.partial_cmp(&(PIVOT_FRACTION * diagonal(k))) != Some(Ordering::Greater) {
            return false;
        }
        for i in k + 1..n {
            let l = block[i * n + k] / d;
            for j in k + 1..=i {
                block[i * n + j] -= l * block[j * n + k];
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rows' limbs by bit masks and by the scan with branches agree (the same limb per
    /// row, `usize::MAX` for a row on the root block alone, `None` for a row on two limbs) on
    /// random patterns of four three-rate limbs below a free flyer, with exact zeros, `−0.0`
    /// and NaN entries.
    #[test]
    fn masked_row_limbs_match_the_scan() {
        let (nb, nv, c) = (ROOT, ROOT + 12, 12);
        let mut kkt = LimbKkt {
            nv,
            nb,
            supported: true,
            limbs: (0..4)
                .map(|l| Limb {
                    start: nb + 3 * l,
                    len: 3,
                    ..Limb::default()
                })
                .collect(),
            limb_of: (0..nv)
                .map(|k| if k < nb { usize::MAX } else { (k - nb) / 3 })
                .collect(),
            ..LimbKkt::default()
        };
        let mut seed = 7u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            seed >> 33
        };
        let (mut on_two, mut on_root) = (0, 0);
        for _ in 0..400 {
            let mut a = vec![0.0; c * nv];
            for r in 0..c {
                let home = (next() % 4) as usize;
                for k in 0..nv {
                    let limb = kkt.limb_of[k];
                    let stray = next() % 97 == 0;
                    let x = match next() % 6 {
                        0 => 0.0,
                        1 => -0.0,
                        2 if next() % 50 == 0 => f64::NAN,
                        _ => 0.5 - (next() % 1000) as f64 / 1000.0,
                    };
                    if limb == usize::MAX || limb == home || stray {
                        a[k * c + r] = x;
                    }
                }
            }
            kkt.row_limb = vec![usize::MAX; c];
            let masked = kkt.row_limbs_masked(&a, c).map(|()| kkt.row_limb.clone());
            kkt.row_limb = vec![usize::MAX; c];
            let scanned = kkt.row_limbs_scanned(&a, c).map(|()| kkt.row_limb.clone());
            assert_eq!(masked, scanned);
            on_two += usize::from(masked.is_none());
            on_root += masked.map_or(0, |rl| rl.iter().filter(|&&l| l == usize::MAX).count());
        }
        assert!(
            on_two > 0 && on_root > 0,
            "both outcomes visited: {on_two}, {on_root}"
        );
    }
}
