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
//! Storage follows the sparsity: each rate's **chain** (the rate, its parent, …, the root)
//! is a limb part, one contiguous list, and the root block (the six rates of a free-flying
//! base, fixed-size `6 × 6` and `6`-vector factors; none on a fixed base). `L`'s row `k`
//! (with `D_k` first) is packed along `k`'s limb chain with its six root entries beside it,
//! and each row of `A` — a contact point's row, whose entries lie on its frame's chain — gives
//! a column of `Z` packed the same way along the chain of its deepest rate (`L⁻ᵀ` moves
//! entries to ancestors only). The factorization's inner loops are then contiguous `axpy`s
//! and dot products on short limb chains and unrolled `6`-vector operations on the root, and
//! an entry of `K` is a dot product over the two rows' common limb ancestors plus the root's.
//!
//! A pivot of `M` that is not clearly positive (a massless limb: singular `M`) or of `K`
//! (dependent rows), or a row of `A` not on one chain of the tree, makes [`TreeKkt::factor`]
//! decline; the caller then uses the null-space block inverse of [`crate::kkt`], exact for
//! singular `M` (Lemma 5.1).
#![allow(non_snake_case)]
use super::model::{JointKind, SpatialModel};
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

/// Size of a free-flying root's block (its six rates come first in `v`).
const ROOT: usize = 6;
type Block = nalgebra::Matrix6<f64>;
type BlockRow = nalgebra::Vector6<f64>;

/// Workspace and factors of the range-space KKT solve for one model.
///
/// The rates are split into the **root block** `b` (the six rates of a free-flying base, or
/// none on a fixed base) and the **limb rates** (one per joint, every other joint). A limb
/// rate's chain is its limb part (the rate and its limb ancestors, `chain`) followed by the
/// whole root block, whose factors are fixed-size (`Matrix6`/`Vector6`): the dense `6 × 6`
/// corner of `M` and the six root entries of each limb row.
#[derive(Debug, Clone, Default)]
pub struct TreeKkt {
    nv: usize,
    c: usize,
    /// The rates of the root block: 6 with a free-flying base, 0 on a fixed one.
    nb: usize,
    /// `false` when a joint other than a free-flying root moves more than one rate (no such
    /// joint exists today): [`Self::factor`] then declines.
    supported: bool,
    /// Every limb rate's limb chain `[k, λ(k), …]` (down to the root block or the world),
    /// rate `k`'s at `chain[offset[k]..offset[k + 1]]` (empty for the root block's rates).
    chain: Vec<usize>,
    offset: Vec<usize>,
    /// `common[a · nv + b]`: how many limb rates the chains of `a` and `b` share (their last
    /// ones).
    common: Vec<usize>,
    /// `on_chain[a · nv + b]`: whether rate `b` lies on `a`'s chain (root block included).
    on_chain: Vec<bool>,
    /// `D_k` and `L`'s row `k` along `k`'s limb chain: `ltdl[offset[k]] = D_k`,
    /// `ltdl[offset[k] + p] = L[k, chain[offset[k] + p]]`; `root_row[k]`: `L[k, b]`.
    ltdl: Vec<f64>,
    root_row: Vec<BlockRow>,
    /// The root block's `L` (strictly lower) with `D` on the diagonal.
    root: Block,
    /// `D^{-1/2}`.
    d_isqrt: Vec<f64>,
    /// Column `r` of `Z`: its limb part along the limb chain of row `r`'s deepest rate
    /// `row_end[r]` at `z[r · nv..]` (`row_len[r]` entries), its root part `z_root[r]`.
    z: Vec<f64>,
    z_root: Vec<BlockRow>,
    row_end: Vec<usize>,
    row_len: Vec<usize>,
    /// The Cholesky factor of `K` (c × c, lower, row-major: `k[i · c + j]`, `j ≤ i`).
    k: Vec<f64>,
    w: Vec<f64>,
}

impl TreeKkt {
    pub fn new(model: &SpatialModel) -> Self {
        let nv = model.nv;
        let nb = match model.joints.first().map(|j| j.kind) {
            Some(JointKind::FreeFlyer) => ROOT,
            _ => 0,
        };
        let supported = model
            .joints
            .iter()
            .enumerate()
            .all(|(i, j)| j.kind.nv() == 1 || (i == 0 && nb == ROOT));
        // a limb rate's parent rate: its joint's parent joint's rate, if that is a limb rate
        let mut parent = vec![None; nv];
        for joint in model.joints.iter().filter(|j| j.idx_v >= nb) {
            parent[joint.idx_v] = joint
                .parent
                .map(|p| model.joints[p].idx_v)
                .filter(|&r| r >= nb);
        }
        let (mut chain, mut offset) = (Vec::new(), vec![0]);
        for k in 0..nv {
            let mut i = Some(k).filter(|&k| k >= nb);
            while let Some(r) = i {
                chain.push(r);
                i = parent[r];
            }
            offset.push(chain.len());
        }
        let of = |k: usize| &chain[offset[k]..offset[k + 1]];
        let common = (0..nv * nv)
            .map(|ab| {
                let (a, b) = (of(ab / nv), of(ab % nv));
                a.iter()
                    .rev()
                    .zip(b.iter().rev())
                    .take_while(|(x, y)| x == y)
                    .count()
            })
            .collect();
        let mut on_chain = vec![false; nv * nv];
        for a in 0..nv {
            for &b in of(a) {
                on_chain[a * nv + b] = true;
            }
            // a rate of the root block has the rates before it; a limb rate all of them
            for b in 0..nb.min(a + 1) {
                on_chain[a * nv + b] = true;
            }
        }
        Self {
            nv,
            c: 0,
            nb,
            supported,
            ltdl: vec![0.0; chain.len()],
            chain,
            offset,
            common,
            on_chain,
            root_row: vec![BlockRow::zeros(); nv],
            root: Block::zeros(),
            d_isqrt: vec![0.0; nv],
            z: Vec::new(),
            z_root: Vec::new(),
            row_end: Vec::new(),
            row_len: Vec::new(),
            k: Vec::new(),
            w: vec![0.0; nv],
        }
    }

    /// Factors `M = Lᵀ D L` and `K = A M⁻¹ Aᵀ = Zᵀ Z`; `false` (nothing usable) when a pivot
    /// of either is not clearly positive (see the module's tolerances) or a row of `A` is not
    /// on one chain.
    pub fn factor(&mut self, M: &DMatrix<f64>, A: &DMatrix<f64>) -> bool {
        let (nv, c) = (self.nv, A.nrows());
        debug_assert_eq!((M.nrows(), A.ncols()), (nv, nv));
        if c != self.c {
            self.c = c;
            self.z.resize(nv * c, 0.0);
            self.z_root.resize(c, BlockRow::zeros());
            self.k.resize(c * c, 0.0);
            self.row_end.resize(c, 0);
            self.row_len.resize(c, 0);
        }
        self.supported && self.factor_mass_matrix(M) && self.factor_rows(A)
    }

    /// The packed limb chain of rate `k`, and where it starts in [`Self::chain`] and `ltdl`.
    fn span(&self, k: usize) -> (usize, usize) {
        (self.offset[k], self.offset[k + 1])
    }

    /// Featherstone 2008, Table 6.3 (`LTDL`), from the leaves up: for each ancestor `i` of
    /// `k`, `H[i, j] −= H[k, i]/D_k · H[k, j]` over `j` in `i`'s chain (the rest of `k`'s),
    /// the root block's part as one `6 × 6` update.
    fn factor_mass_matrix(&mut self, M: &DMatrix<f64>) -> bool {
        let (nv, nb) = (self.nv, self.nb);
        let m = M.as_slice();
        for k in nb..nv {
            let (b, e) = self.span(k);
            // M's lower triangle: (k, j) with j on k's chain, j ≤ k
            for (x, &j) in self.ltdl[b..e].iter_mut().zip(&self.chain[b..e]) {
                *x = m[k + j * nv];
            }
            self.root_row[k] = BlockRow::from_fn(|j, _| if j < nb { m[k + j * nv] } else { 0.0 });
        }
        self.root = Block::from_fn(|i, j| if i < nb && j < nb { m[i + j * nv] } else { 0.0 });
        let largest = (0..nv).map(|k| m[k + k * nv]).fold(0.0, f64::max);
        let clear =
            |mkk: f64, dk: f64| mkk > MASSLESS_DIAGONAL * largest && dk > PIVOT_FRACTION * mkk;
        for k in (nb..nv).rev() {
            let (b, e) = self.span(k);
            let (mkk, dk) = (m[k + k * nv], self.ltdl[b]);
            if !clear(mkk, dk) {
                return false;
            }
            // the rows of k's ancestors lie before k's
            let (before, rest) = self.ltdl.split_at_mut(b);
            let row_k = &mut rest[..e - b];
            let hk = self.root_row[k];
            for p in 1..e - b {
                let i = self.chain[b + p];
                let a = row_k[p] / dk;
                sub_scaled(
                    &mut before[self.offset[i]..self.offset[i + 1]],
                    a,
                    &row_k[p..],
                );
                self.root_row[i] -= hk * a;
                row_k[p] = a;
            }
            self.root -= hk * (hk.transpose() / dk);
            self.root_row[k] = hk / dk;
            self.d_isqrt[k] = 1.0 / dk.sqrt();
        }
        for k in (0..nb).rev() {
            let (mkk, dk) = (m[k + k * nv], self.root[(k, k)]);
            if !clear(mkk, dk) {
                return false;
            }
            // ancestors nearest first, as along a chain: H[k, j ≤ i] is still unscaled
            for i in (0..k).rev() {
                let a = self.root[(k, i)] / dk;
                for j in 0..=i {
                    self.root[(i, j)] -= a * self.root[(k, j)];
                }
                self.root[(k, i)] = a;
            }
            self.d_isqrt[k] = 1.0 / dk.sqrt();
        }
        true
    }

    /// `x ← L⁻ᵀ x` for `x` packed along a limb chain (`chain`) with its root part `x_root`
    /// (Table 6.4's back-substitution, leaves first): `L⁻ᵀ` keeps a vector on a chain.
    fn solve_lt_on_chain(&self, chain: &[usize], x: &mut [f64], x_root: &mut BlockRow) {
        for (t, &i) in chain.iter().enumerate() {
            let xi = x[t];
            if xi == 0.0 {
                continue;
            }
            let (b, e) = self.span(i);
            sub_scaled(&mut x[t + 1..], xi, &self.ltdl[b + 1..e]);
            *x_root -= self.root_row[i] * xi;
        }
        for i in (1..self.nb).rev() {
            let xi = x_root[i];
            for j in 0..i {
                x_root[j] -= self.root[(i, j)] * xi;
            }
        }
    }

    /// `Z = D^{-1/2} L⁻ᵀ Aᵀ` and the dense Cholesky `K = Zᵀ Z = C Cᵀ`, `K[i, j]` the dot
    /// product of the two columns over the rows' common ancestors.
    fn factor_rows(&mut self, A: &DMatrix<f64>) -> bool {
        let (nv, c, nb) = (self.nv, self.c, self.nb);
        let a = A.as_slice();
        let root_scale = BlockRow::from_fn(|j, _| if j < nb { self.d_isqrt[j] } else { 0.0 });
        let mut z = std::mem::take(&mut self.z);
        for r in 0..c {
            // A is column-major: its row r is strided by c
            let row = &a[r..];
            let entry = |k: usize| row[k * c];
            let Some(end) = (0..nv).rev().find(|&k| entry(k) != 0.0) else {
                self.z = z;
                return false;
            };
            let on_chain = &self.on_chain[end * nv..end * nv + end];
            if on_chain
                .iter()
                .enumerate()
                .any(|(k, &on)| !on && entry(k) != 0.0)
            {
                self.z = z;
                return false;
            }
            let (b, e) = self.span(end);
            self.row_end[r] = end;
            self.row_len[r] = e - b;
            let chain = &self.chain[b..e];
            let zr = &mut z[r * nv..r * nv + e - b];
            for (x, &k) in zr.iter_mut().zip(chain) {
                *x = entry(k);
            }
            let mut zb = BlockRow::from_fn(|j, _| if j < nb { entry(j) } else { 0.0 });
            self.solve_lt_on_chain(chain, zr, &mut zb);
            for (x, &k) in zr.iter_mut().zip(chain) {
                *x *= self.d_isqrt[k];
            }
            self.z_root[r] = zb.component_mul(&root_scale);
        }
        self.z = z;
        for i in 0..c {
            let (ei, li) = (self.row_end[i], self.row_len[i]);
            let zi = &self.z[i * nv..i * nv + li];
            for j in 0..=i {
                let (ej, lj) = (self.row_end[j], self.row_len[j]);
                let m = self.common[ei * nv + ej];
                let zj = &self.z[j * nv + lj - m..j * nv + lj];
                self.k[i * c + j] = dot(&zi[li - m..], zj) + self.z_root[i].dot(&self.z_root[j]);
            }
        }
        let largest = (0..c).map(|i| self.k[i * c + i]).fold(0.0, f64::max);
        dense_cholesky(&mut self.k, c, ROW_PIVOT_FRACTION * largest)
    }

    /// Row `r`'s limb chain and its column of `Z` (limb part).
    fn column(&self, r: usize) -> (&[usize], &[f64]) {
        let (end, len) = (self.row_end[r], self.row_len[r]);
        let b = self.offset[end];
        (
            &self.chain[b..b + len],
            &self.z[r * self.nv..r * self.nv + len],
        )
    }

    /// Solves `[M Aᵀ; A 0][x; y] = [f; g]` with the current factors.
    pub fn solve(&mut self, f: &[f64], g: &[f64], x: &mut [f64], y: &mut [f64]) {
        let (nv, c, nb) = (self.nv, self.c, self.nb);
        let mut w = std::mem::take(&mut self.w);
        w.copy_from_slice(f);
        // w ← L⁻ᵀ w (leaves first), then D^{-1/2}
        let mut wb = BlockRow::from_fn(|j, _| if j < nb { w[j] } else { 0.0 });
        for i in (nb..nv).rev() {
            let wi = w[i];
            if wi == 0.0 {
                continue;
            }
            let (b, e) = self.span(i);
            for (&j, l) in self.chain[b + 1..e].iter().zip(&self.ltdl[b + 1..e]) {
                w[j] -= l * wi;
            }
            wb -= self.root_row[i] * wi;
        }
        self.solve_lt_on_chain(&[], &mut [], &mut wb);
        w[..nb].copy_from_slice(&wb.as_slice()[..nb]);
        for (x, s) in w.iter_mut().zip(&self.d_isqrt) {
            *x *= s;
        }
        let wb = BlockRow::from_fn(|j, _| if j < nb { w[j] } else { 0.0 });
        for (r, yr) in y.iter_mut().enumerate().take(c) {
            let (chain, zr) = self.column(r);
            // root first, as the dense product would add them
            let limb = zr
                .iter()
                .zip(chain)
                .rev()
                .fold(0.0, |s, (z, &k)| s + z * w[k]);
            *yr = self.z_root[r].dot(&wb) + limb - g[r];
        }
        cholesky_solve(&self.k, c, y);
        for (r, yr) in y.iter().enumerate().take(c) {
            let (chain, zr) = self.column(r);
            for (z, &k) in zr.iter().zip(chain) {
                w[k] -= z * yr;
            }
            for (wj, z) in w[..nb].iter_mut().zip(self.z_root[r].iter()) {
                *wj -= z * yr;
            }
        }
        for ((xi, wi), s) in x.iter_mut().zip(w.iter()).zip(&self.d_isqrt) {
            *xi = wi * s;
        }
        self.w = w;
        // x ← L⁻¹ x (root first)
        for i in 1..nb {
            let xi = (0..i).fold(x[i], |s, j| s - self.root[(i, j)] * x[j]);
            x[i] = xi;
        }
        let xb = BlockRow::from_fn(|j, _| if j < nb { x[j] } else { 0.0 });
        for i in nb..nv {
            let (b, e) = self.span(i);
            let mut xi = x[i] - self.root_row[i].dot(&xb);
            for (&j, l) in self.chain[b + 1..e].iter().zip(&self.ltdl[b + 1..e]) {
                xi -= l * x[j];
            }
            x[i] = xi;
        }
    }
}
/// `Σ xᵢ yᵢ` over the common length of two slices, four products at a time (the chains are
/// short: a loop per entry would cost several times its arithmetic).
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let mut s = [0.0; 4];
    let (xs, ys) = (x.chunks_exact(4), y.chunks_exact(4));
    let tail = xs
        .remainder()
        .iter()
        .zip(ys.remainder())
        .fold(0.0, |t, (a, b)| t + a * b);
    for (a, b) in xs.zip(ys) {
        for p in 0..4 {
            s[p] += a[p] * b[p];
        }
    }
    (s[0] + s[1]) + (s[2] + s[3]) + tail
}

/// `y ← y − a x` over the common length of two slices, four entries at a time.
fn sub_scaled(y: &mut [f64], a: f64, x: &[f64]) {
    let n = x.len().min(y.len());
    let (y, x) = (&mut y[..n], &x[..n]);
    let mut ys = y.chunks_exact_mut(4);
    let mut xs = x.chunks_exact(4);
    for (u, v) in (&mut ys).zip(&mut xs) {
        for p in 0..4 {
            u[p] -= a * v[p];
        }
    }
    for (u, v) in ys.into_remainder().iter_mut().zip(xs.remainder()) {
        *u -= a * v;
    }
}

/// In-place Cholesky `K = C Cᵀ` of the symmetric `n × n` row-major `k` (lower triangle read
/// and overwritten, row by row: `C[i, j] = (K[i, j] − C[i, :j]·C[j, :j]) / C[j, j]`, two
/// contiguous slices); `false` when a pivot is at most `min_pivot`.
fn dense_cholesky(k: &mut [f64], n: usize, min_pivot: f64) -> bool {
    for i in 0..n {
        let (done, rest) = k.split_at_mut(i * n);
        let row_i = &mut rest[..=i];
        for j in 0..i {
            let row_j = &done[j * n..j * n + j + 1];
            row_i[j] = (row_i[j] - dot(&row_i[..j], &row_j[..j])) / row_j[j];
        }
        let d = row_i[i] - dot(&row_i[..i], &row_i[..i]);
        if !(d > min_pivot) {
            return false;
        }
        row_i[i] = d.sqrt();
    }
    true
}

/// `y ← (C Cᵀ)⁻¹ y` with the factor of [`dense_cholesky`].
fn cholesky_solve(k: &[f64], n: usize, y: &mut [f64]) {
    for i in 0..n {
        let row = &k[i * n..i * n + i + 1];
        y[i] = (y[i] - dot(&row[..i], &y[..i])) / row[i];
    }
    for i in (0..n).rev() {
        let yi = y[i] / k[i * n + i];
        y[i] = yi;
        // subtract column i of Cᵀ's row i, i.e. C[i, :i], from the earlier entries
        sub_scaled(&mut y[..i], yi, &k[i * n..i * n + i]);
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
