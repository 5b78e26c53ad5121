//! The KKT system of thesis (5.2) by the range-space (Schur complement) method when `M` is
//! positive definite, on the tree's sparsity (Featherstone 2008, §6.5 "sparse factorization",
//! Tables 6.3–6.4; Pinocchio's `cholesky::decompose` and `computeDelassusMatrix`):
//!
//! - `M = Lᵀ D L`, `L` unit lower triangular with `L[k, i] ≠ 0` only where rate `i` supports
//!   rate `k` (is `k` or an ancestor of it in the tree), so the factorization and its solves
//!   visit each rate's ancestors only;
//! - `Z = D^{-1/2} L⁻ᵀ Aᵀ` (nv × c) and the inverse operational-space inertia of the rows
//!   `K = A M⁻¹ Aᵀ = Zᵀ Z` (c × c, the thesis's `−Λ⁻¹`), factored by a dense Cholesky;
//! - `[M Aᵀ; A 0][x; y] = [f; g]`: with `w = D^{-1/2} L⁻ᵀ f`, `y = K⁻¹ (Zᵀ w − g)` and
//!   `x = L⁻¹ D^{-1/2} (w − Z y)`.
//!
//! A pivot of `M` that is not clearly positive (a massless limb: singular `M`) or of `K` (dependent
//! rows) makes [`TreeKkt::factor`] decline; the caller then uses the null-space block inverse of
//! [`crate::kkt`], exact for singular `M` (Lemma 5.1).
#![allow(non_snake_case)]
use super::model::SpatialModel;
use nalgebra::DMatrix;

/// A pivot `D_k` of `M = Lᵀ D L` below this fraction of `M_kk` (the rate has lost nearly
/// all its inertia to its descendants' constraints of the factorization: `M` is singular or
/// nearly so), or an `M_kk` below [`MASSLESS_DIAGONAL`] of the largest, declines the factorization.
pub const PIVOT_FRACTION: f64 = 1e-8;
/// Relative size (to the largest diagonal entry of `M`) of a diagonal entry that marks a rate
/// moving no mass.
pub const MASSLESS_DIAGONAL: f64 = 1e-12;
/// A Cholesky pivot of `K = A M⁻¹ Aᵀ` below this fraction of `K`'s largest diagonal entry
/// (rows dependent to within a singular-value ratio of about 1e-5) declines the factorization.
pub const ROW_PIVOT_FRACTION: f64 = 1e-10;

/// Workspace and factors of the range-space KKT solve for one model.
#[derive(Debug, Clone, Default)]
pub struct TreeKkt {
    /// The parent rate `λ(k)` of each rate (`usize::MAX` at the root): the previous rate of
    /// the same joint, or the last rate of the parent joint.
    parent: Vec<usize>,
    nv: usize,
    c: usize,
    /// `L` below the diagonal and `D` on it (nv × nv, column-major; only supported entries
    /// are read).
    ltdl: Vec<f64>,
    /// `D^{-1/2}`.
    d_isqrt: Vec<f64>,
    /// `Z` (nv × c, column-major) and the Cholesky factor of `K` (c × c, lower, column-major).
    z: Vec<f64>,
    k: Vec<f64>,
    /// Per row of `A`: the deepest rate of the chain its entries lie on, or [`DENSE`].
    chain_end: Vec<usize>,
    w: Vec<f64>,
}

const ROOT: usize = usize::MAX;
/// A row of `A` not on one chain of the tree: its entries of `K` are full dot products.
const DENSE: usize = usize::MAX - 1;

impl TreeKkt {
    pub fn new(model: &SpatialModel) -> Self {
        let mut parent = vec![ROOT; model.nv];
        for joint in &model.joints {
            let first = joint.parent.map_or(ROOT, |p| {
                let jp = &model.joints[p];
                jp.idx_v + jp.kind.nv() - 1
            });
            for k in 0..joint.kind.nv() {
                parent[joint.idx_v + k] = if k == 0 { first } else { joint.idx_v + k - 1 };
            }
        }
        let nv = model.nv;
        Self {
            parent,
            nv,
            c: 0,
            ltdl: vec![0.0; nv * nv],
            d_isqrt: vec![0.0; nv],
            z: Vec::new(),
            k: Vec::new(),
            chain_end: Vec::new(),
            w: vec![0.0; nv],
        }
    }

    /// Factors `M = Lᵀ D L` and `K = A M⁻¹ Aᵀ = Zᵀ Z`; `false` (nothing usable) when a pivot
    /// of either is not clearly positive (see the module's tolerances).
    pub fn factor(&mut self, M: &DMatrix<f64>, A: &DMatrix<f64>) -> bool {
        let (nv, c) = (self.nv, A.nrows());
        debug_assert_eq!((M.nrows(), A.ncols()), (nv, nv));
        if c != self.c {
            self.c = c;
            self.z.resize(nv * c, 0.0);
            self.k.resize(c * c, 0.0);
            self.chain_end.resize(c, DENSE);
        }
        self.factor_mass_matrix(M) && self.factor_rows(A)
    }

    /// Featherstone 2008, Table 6.3 (`LTDL`), from the leaves up.
    fn factor_mass_matrix(&mut self, M: &DMatrix<f64>) -> bool {
        let (nv, par) = (self.nv, &self.parent);
        let h = &mut self.ltdl;
        h.copy_from_slice(M.as_slice());
        let largest = (0..nv).map(|k| M[(k, k)]).fold(0.0, f64::max);
        for k in (0..nv).rev() {
            let mkk = M[(k, k)];
            let dk = h[k + k * nv];
            if !(mkk > MASSLESS_DIAGONAL * largest && dk > PIVOT_FRACTION * mkk) {
                return false;
            }
            let mut i = par[k];
            while i != ROOT {
                let a = h[k + i * nv] / dk;
                let mut j = i;
                while j != ROOT {
                    h[i + j * nv] -= a * h[k + j * nv];
                    j = par[j];
                }
                h[k + i * nv] = a;
                i = par[i];
            }
            self.d_isqrt[k] = 1.0 / dk.sqrt();
        }
        true
    }

    /// `x ← L⁻ᵀ x` (Table 6.4's back-substitution, leaves first).
    fn solve_lt(ltdl: &[f64], parent: &[usize], x: &mut [f64]) {
        let nv = parent.len();
        for i in (0..nv).rev() {
            let xi = x[i];
            if xi == 0.0 {
                continue;
            }
            let mut j = parent[i];
            while j != ROOT {
                x[j] -= ltdl[i + j * nv] * xi;
                j = parent[j];
            }
        }
    }

    /// `x ← L⁻¹ x` (root first).
    fn solve_l(ltdl: &[f64], parent: &[usize], x: &mut [f64]) {
        let nv = parent.len();
        for i in 0..nv {
            let mut j = parent[i];
            let mut xi = x[i];
            while j != ROOT {
                xi -= ltdl[i + j * nv] * x[j];
                j = parent[j];
            }
            x[i] = xi;
        }
    }

    /// `Z = D^{-1/2} L⁻ᵀ Aᵀ` and the dense Cholesky `K = Zᵀ Z = C Cᵀ`. A row of `A` whose
    /// entries lie on the chain of one rate `k` and its ancestors (a contact point's row: its
    /// frame's supporting joints) gives a column of `Z` on that chain alone (`L⁻ᵀ` moves
    /// entries to ancestors only), and `K`'s entries with it are sums along the chain.
    fn factor_rows(&mut self, A: &DMatrix<f64>) -> bool {
        let (nv, c) = (self.nv, self.c);
        for r in 0..c {
            let col = &mut self.z[r * nv..(r + 1) * nv];
            let (mut deepest, mut nonzero) = (ROOT, 0);
            // A is column-major: its row r is strided by c
            for (k, (x, a)) in col
                .iter_mut()
                .zip(A.as_slice()[r..].iter().step_by(c))
                .enumerate()
            {
                *x = *a;
                if *a != 0.0 {
                    deepest = k;
                    nonzero += 1;
                }
            }
            let mut on_chain = 0;
            let mut k = deepest;
            while k != ROOT {
                on_chain += usize::from(col[k] != 0.0);
                k = self.parent[k];
            }
            self.chain_end[r] = if on_chain == nonzero { deepest } else { DENSE };
            Self::solve_lt(&self.ltdl, &self.parent, col);
            for (x, s) in col.iter_mut().zip(&self.d_isqrt) {
                *x *= s;
            }
        }
        for j in 0..c {
            for i in j..c {
                let (zi, zj) = (&self.z[i * nv..(i + 1) * nv], &self.z[j * nv..(j + 1) * nv]);
                self.k[i + j * c] = match self.chain_end[i] {
                    DENSE => zi.iter().zip(zj).map(|(a, b)| a * b).sum(),
                    end => {
                        let (mut sum, mut k) = (0.0, end);
                        while k != ROOT {
                            sum += zi[k] * zj[k];
                            k = self.parent[k];
                        }
                        sum
                    }
                };
            }
        }
        let largest = (0..c).map(|i| self.k[i + i * c]).fold(0.0, f64::max);
        dense_cholesky(&mut self.k, c, ROW_PIVOT_FRACTION * largest)
    }

    /// Solves `[M Aᵀ; A 0][x; y] = [f; g]` with the current factors.
    pub fn solve(&mut self, f: &[f64], g: &[f64], x: &mut [f64], y: &mut [f64]) {
        let (nv, c) = (self.nv, self.c);
        let w = &mut self.w;
        w.copy_from_slice(f);
        Self::solve_lt(&self.ltdl, &self.parent, w);
        for (x, s) in w.iter_mut().zip(&self.d_isqrt) {
            *x *= s;
        }
        for r in 0..c {
            let zr = &self.z[r * nv..(r + 1) * nv];
            y[r] = zr.iter().zip(w.iter()).map(|(a, b)| a * b).sum::<f64>() - g[r];
        }
        cholesky_solve(&self.k, c, y);
        for r in 0..c {
            let zr = &self.z[r * nv..(r + 1) * nv];
            for (wi, zi) in w.iter_mut().zip(zr) {
                *wi -= zi * y[r];
            }
        }
        for ((xi, wi), s) in x.iter_mut().zip(w.iter()).zip(&self.d_isqrt) {
            *xi = wi * s;
        }
        Self::solve_l(&self.ltdl, &self.parent, x);
    }
}

/// In-place Cholesky `K = C Cᵀ` of the symmetric `n × n` column-major `k` (lower triangle
/// read and overwritten); `false` when a pivot is at most `min_pivot`.
fn dense_cholesky(k: &mut [f64], n: usize, min_pivot: f64) -> bool {
    for j in 0..n {
        let mut d = k[j + j * n];
        for p in 0..j {
            d -= k[j + p * n] * k[j + p * n];
        }
        if !(d > min_pivot) {
            return false;
        }
        let d = d.sqrt();
        k[j + j * n] = d;
        for i in j + 1..n {
            let mut s = k[i + j * n];
            for p in 0..j {
                s -= k[i + p * n] * k[j + p * n];
            }
            k[i + j * n] = s / d;
        }
    }
    true
}

/// `y ← (C Cᵀ)⁻¹ y` with the factor of [`dense_cholesky`].
fn cholesky_solve(k: &[f64], n: usize, y: &mut [f64]) {
    for i in 0..n {
        let mut s = y[i];
        for p in 0..i {
            s -= k[i + p * n] * y[p];
        }
        y[i] = s / k[i + i * n];
    }
    for i in (0..n).rev() {
        let mut s = y[i];
        for p in i + 1..n {
            s -= k[p + i * n] * y[p];
        }
        y[i] = s / k[i + i * n];
    }
}

/// Which factorization the last constrained solve of a [`super::SpatialData`] used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KktRoute {
    /// `M` positive definite and the rows independent: [`TreeKkt`].
    #[default]
    RangeSpace,
    /// The null-space block inverse of [`crate::kkt`] (singular `M`, or dependent rows through
    /// `A`'s row space, [`super::SpatialData::row_basis`]).
    NullSpace,
}
