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
//! entries to ancestors only). Consecutive rows whose deepest rates lie on one chain (a
//! contact point's two or three rows) form a **group** of `W ≤ 3` rows, handled as one: its
//! columns of `Z` are a `W`-vector per limb rate followed by its `6 × W` root part, so the
//! chain is walked once per contact, not once per row. Every loop over a group is generic in
//! its row count `W` (a frictionless point stores and solves one lane, not three): the
//! factorization's inner loops are unrolled `W`- and `6`-vector operations, and a `W × W'`
//! block of `K` is the sum of outer products over the two groups' root parts and, only where
//! their chains meet below the root (rows of one limb), their common limb ancestors: the legs
//! of a free-flying robot couple through the root block alone.
//!
//! A pivot of `M` that is not clearly positive (a massless limb: singular `M`) or of `K`
//! (dependent rows), or a row of `A` not on one chain of the tree, makes [`TreeKkt::factor`]
//! decline; the caller then uses the null-space block inverse of [`crate::kkt`], exact for
//! singular `M` (Lemma 5.1).
#![allow(non_snake_case)]
use super::model::{JointKind, SpatialModel};
use nalgebra::DMatrix;
use std::cmp::Ordering;

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
/// Most rows in a group (a contact point with friction has three).
const GROUP: usize = 3;

/// `$f::<W>(…)` for a group's row count `$w` (`1..=GROUP`, three: a point's rows): every
/// loop over the lanes then has constant bounds and unrolls.
macro_rules! by_width {
    ($w:expr, $($f:ident)::+($($arg:expr),* $(,)?)) => {
        match $w {
            1 => $($f)::+::<1>($($arg),*),
            2 => $($f)::+::<2>($($arg),*),
            _ => $($f)::+::<3>($($arg),*),
        }
    };
}

/// A group's columns of `Z` (`W` lanes at each rate) from their packed entries.
fn lanes<const W: usize>(z: &[f64]) -> &[[f64; W]] {
    z.as_chunks::<W>().0
}

/// [`lanes`], mutable.
fn lanes_mut<const W: usize>(z: &mut [f64]) -> &mut [[f64; W]] {
    z.as_chunks_mut::<W>().0
}

/// Consecutive rows of `A` whose deepest rates lie on one chain, packed along the chain of
/// the deepest (see the module's text).
#[derive(Debug, Clone, Copy, Default)]
struct Group {
    /// The first row and how many (`1..=GROUP`).
    row: usize,
    width: usize,
    /// The deepest rate of the rows, and the length of its limb chain.
    end: usize,
    len: usize,
    /// Where its columns of `Z` start in [`TreeKkt::z`] (`(len + ROOT) · width` entries).
    at: usize,
}

impl Group {
    /// Its packed columns of `Z` in `z`.
    fn span(&self) -> std::ops::Range<usize> {
        self.at..self.at + (self.len + ROOT) * self.width
    }
}

/// Workspace and factors of the range-space KKT solve for one model.
///
/// The rates are split into the **root block** `b` (the six rates of a free-flying base, or
/// none on a planar or fixed base) and the **limb rates** (one per joint, every other joint;
/// a planar base's three, a chain). A limb
/// rate's chain is its limb part (the rate and its limb ancestors, `chain`) followed by the
/// whole root block, whose factors are fixed-size (`Matrix6`/`Vector6`): the dense `6 × 6`
/// corner of `M` and the six root entries of each limb row.
#[derive(Debug, Clone, Default)]
pub struct TreeKkt {
    nv: usize,
    c: usize,
    /// The rates of the root block: 6 with a free-flying base, 0 on a fixed one.
    nb: usize,
    /// `false` when a joint other than a free-flying root or a planar joint moves more than
    /// one rate (a free flyer inside the tree, a URDF `floating` joint): [`Self::factor`]
    /// then declines.
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
    /// The row groups; a group's columns of `Z` at `z[group.span()]`, rate by rate with the
    /// group's `width` entries (one per row) together: its limb part along the limb chain
    /// of the group's deepest rate, then its root part (`ROOT` rates, zero on a fixed base).
    groups: Vec<Group>,
    z: Vec<f64>,
    /// Each row's deepest rate.
    row_end: Vec<usize>,
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
        let supported = model.joints.iter().enumerate().all(|(i, j)| {
            j.kind.nv() == 1 || j.kind == JointKind::Planar || (i == 0 && nb == ROOT)
        });
        // a limb rate's parent rate: the last rate of its joint's parent joint, if that is a
        // limb rate; a planar joint's three rates are a chain of three (`M`'s dense 3 × 3
        // block is a chain's: each rate's ancestors are the ones before it)
        let mut parent = vec![None; nv];
        for joint in model.joints.iter().filter(|j| j.idx_v >= nb) {
            parent[joint.idx_v] = joint
                .parent
                .map(|p| model.joints[p].idx_v + model.joints[p].kind.nv() - 1)
                .filter(|&r| r >= nb);
            let rates = joint.idx_v..joint.idx_v + joint.kind.nv();
            for (r, p) in rates.clone().zip(&mut parent[rates]).skip(1) {
                *p = Some(r - 1);
            }
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
            groups: Vec::new(),
            z: Vec::new(),
            row_end: Vec::new(),
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
            self.z.resize((nv + ROOT) * c, 0.0);
            self.k.resize(c * c, 0.0);
            self.row_end.resize(c, 0);
            self.groups.reserve(c);
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
        let (nv, nb) = (self.nv, self.root_rates());
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
        for k in (0..self.root_rates()).rev() {
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

    /// `X ← L⁻ᵀ X` for the `W` columns `X` of a group packed along a limb chain (`chain`, a
    /// `W`-vector per rate) with their root part `root` (Table 6.4's back-substitution,
    /// leaves first): `L⁻ᵀ` keeps a vector on a chain.
    fn solve_lt_group<const W: usize>(
        &self,
        chain: &[usize],
        limb: &mut [[f64; W]],
        root: &mut [[f64; W]],
    ) {
        for (t, &i) in chain.iter().enumerate() {
            let xi = limb[t];
            let (b, e) = self.span(i);
            // i's limb ancestors are the rest of the chain
            for (xp, &l) in limb[t + 1..].iter_mut().zip(&self.ltdl[b + 1..e]) {
                for p in 0..W {
                    xp[p] -= xi[p] * l;
                }
            }
            for (xj, &h) in root.iter_mut().zip(self.root_row[i].iter()) {
                for p in 0..W {
                    xj[p] -= h * xi[p];
                }
            }
        }
        for i in (1..self.root_rates()).rev() {
            let xi = root[i];
            for (j, xj) in root[..i].iter_mut().enumerate() {
                let l = self.root[(i, j)];
                for p in 0..W {
                    xj[p] -= l * xi[p];
                }
            }
        }
    }

    /// A group's `W` columns of `Z = D^{-1/2} L⁻ᵀ Aᵀ` into `z` (`(len + ROOT) · W` entries),
    /// from its rows of `A` (column-major, `c` rows); `root_scale` is the root block's
    /// `D^{-1/2}` (zero past `nb`).
    fn group_columns<const W: usize>(
        &self,
        a: &[f64],
        c: usize,
        group: &Group,
        root_scale: &BlockRow,
        z: &mut [f64],
    ) {
        let (b, e) = self.span(group.end);
        let chain = &self.chain[b..e];
        let (limb, root) = lanes_mut::<W>(z).split_at_mut(e - b);
        // A is column-major: a column's entries for the group's rows are contiguous
        let rows = |k: usize| {
            let mut x = [0.0; W];
            x.copy_from_slice(&a[k * c + group.row..k * c + group.row + W]);
            x
        };
        for (x, &k) in limb.iter_mut().zip(chain) {
            *x = rows(k);
        }
        for (j, x) in root.iter_mut().enumerate() {
            *x = if j < self.nb { rows(j) } else { [0.0; W] };
        }
        self.solve_lt_group(chain, limb, root);
        for (x, &k) in limb.iter_mut().zip(chain) {
            let s = self.d_isqrt[k];
            for xp in x.iter_mut() {
                *xp *= s;
            }
        }
        for (x, s) in root.iter_mut().zip(root_scale.iter()) {
            for xp in x.iter_mut() {
                *xp *= s;
            }
        }
    }

    /// `nb` as a constant where the compiler can see it: the root block has all six rates or
    /// none, and a loop with constant bounds unrolls.
    fn root_rates(&self) -> usize {
        if self.nb == ROOT {
            ROOT
        } else {
            0
        }
    }

    /// `x ← L⁻ᵀ x` on the root block alone (a vector with no limb part).
    fn solve_lt_root(&self, x: &mut BlockRow) {
        for i in (1..self.root_rates()).rev() {
            let xi = x[i];
            for j in 0..i {
                x[j] -= self.root[(i, j)] * xi;
            }
        }
    }

    /// The deepest rate of row `r` of `A` (column-major, `c` rows), `None` when the row is
    /// zero or has an entry off that rate's chain.
    fn row_end_of(&self, a: &[f64], c: usize, r: usize) -> Option<usize> {
        let nv = self.nv;
        let row = &a[r..];
        let entry = |k: usize| row[k * c];
        let end = (0..nv).rev().find(|&k| entry(k) != 0.0)?;
        let on_chain = &self.on_chain[end * nv..end * nv + end];
        let off = on_chain
            .iter()
            .enumerate()
            .any(|(k, &on)| !on && entry(k) != 0.0);
        (!off).then_some(end)
    }

    /// `Z = D^{-1/2} L⁻ᵀ Aᵀ` group by group and the dense Cholesky `K = Zᵀ Z = C Cᵀ`, a
    /// group pair's block of `K` the product of their root parts plus the outer products
    /// over their common limb ancestors.
    fn factor_rows(&mut self, A: &DMatrix<f64>) -> bool {
        let (nv, c, nb) = (self.nv, self.c, self.root_rates());
        let a = A.as_slice();
        for r in 0..c {
            match self.row_end_of(a, c, r) {
                Some(end) => self.row_end[r] = end,
                None => return false,
            }
        }
        self.groups.clear();
        let (mut r, mut at) = (0, 0);
        while r < c {
            // rows whose deepest rates lie on one chain (a point's rows: some directions
            // leave the deepest joints' columns zero) share the deepest one's chain
            let mut end = self.row_end[r];
            let mut width = 1;
            while width < GROUP && r + width < c {
                let next = self.row_end[r + width];
                let (deep, shallow) = (end.max(next), end.min(next));
                if !self.on_chain[deep * nv + shallow] {
                    break;
                }
                end = deep;
                width += 1;
            }
            let (b, e) = self.span(end);
            let len = e - b;
            self.groups.push(Group {
                row: r,
                width,
                end,
                len,
                at,
            });
            at += (len + ROOT) * width;
            r += width;
        }
        let root_scale = BlockRow::from_fn(|j, _| if j < nb { self.d_isqrt[j] } else { 0.0 });
        let mut z = std::mem::take(&mut self.z);
        for group in &self.groups {
            let zg = &mut z[group.span()];
            by_width!(
                group.width,
                Self::group_columns(self, a, c, group, &root_scale, zg)
            );
        }
        self.z = z;
        for (gi, bi) in self.groups.iter().enumerate() {
            let zi = &self.z[bi.span()];
            for bj in &self.groups[..=gi] {
                // their common limb ancestors are the last `m` rates of both limb parts, the
                // root parts follow
                let m = self.common[bi.end * nv + bj.end];
                let zj = &self.z[bj.span()];
                let (xi, xj) = (
                    &zi[(bi.len - m) * bi.width..],
                    &zj[(bj.len - m) * bj.width..],
                );
                let k = &mut self.k[bi.row * c + bj.row..];
                let diagonal = bi.row == bj.row;
                by_width!(bi.width, k_block_with(xi, xj, bj.width, diagonal, k, c));
            }
        }
        let largest = (0..c).map(|i| self.k[i * c + i]).fold(0.0, f64::max);
        dense_cholesky(&mut self.k, c, ROW_PIVOT_FRACTION * largest)
    }

    /// A group's limb chain and its packed columns of `Z`.
    fn columns(&self, group: &Group) -> (&[usize], &[f64]) {
        let b = self.offset[group.end];
        (&self.chain[b..b + group.len], &self.z[group.span()])
    }

    /// Solves `[M Aᵀ; A 0][x; y] = [f; g]` with the current factors.
    pub fn solve(&mut self, f: &[f64], g: &[f64], x: &mut [f64], y: &mut [f64]) {
        let (nv, c, nb) = (self.nv, self.c, self.root_rates());
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
        self.solve_lt_root(&mut wb);
        w[..nb].copy_from_slice(&wb.as_slice()[..nb]);
        for (x, s) in w.iter_mut().zip(&self.d_isqrt) {
            *x *= s;
        }
        let mut wb = BlockRow::from_fn(|j, _| if j < nb { w[j] } else { 0.0 });
        for group in &self.groups {
            let (chain, zg) = self.columns(group);
            let rows = group.row..group.row + group.width;
            let (yg, gg) = (&mut y[rows.clone()], &g[rows]);
            by_width!(group.width, project(zg, chain, &w, &wb, yg, gg));
        }
        cholesky_solve(&self.k, c, y);
        for group in &self.groups {
            let (chain, zg) = self.columns(group);
            let yg = &y[group.row..group.row + group.width];
            by_width!(group.width, subtract(zg, chain, yg, &mut w, &mut wb));
        }
        w[..nb].copy_from_slice(&wb.as_slice()[..nb]);
        for ((xi, wi), s) in x.iter_mut().zip(w.iter()).zip(&self.d_isqrt) {
            *xi = wi * s;
        }
        self.w = w;
        // x ← L⁻¹ x (root first)
        for i in 1..self.root_rates() {
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
/// The block `Σₜ xₜ yₜᵀ` of `K = Zᵀ Z` between two groups of `WI` and `wj` rows, over their
/// packed columns along the common ancestors (`x`, `y`), into `k` (row-major, `c` a row; its
/// lower triangle when `diagonal`).
fn k_block_with<const WI: usize>(
    x: &[f64],
    y: &[f64],
    wj: usize,
    diagonal: bool,
    k: &mut [f64],
    c: usize,
) {
    match wj {
        1 => k_block::<WI, 1>(x, y, diagonal, k, c),
        2 => k_block::<WI, 2>(x, y, diagonal, k, c),
        _ => k_block::<WI, GROUP>(x, y, diagonal, k, c),
    }
}

/// [`k_block_with`] for both row counts known.
fn k_block<const WI: usize, const WJ: usize>(
    x: &[f64],
    y: &[f64],
    diagonal: bool,
    k: &mut [f64],
    c: usize,
) {
    let mut block = [[0.0; WJ]; WI];
    for (x, y) in lanes::<WI>(x).iter().zip(lanes::<WJ>(y)) {
        for p in 0..WI {
            for s in 0..WJ {
                block[p][s] += x[p] * y[s];
            }
        }
    }
    for (p, bp) in block.iter().enumerate() {
        let cols = if diagonal { p + 1 } else { WJ };
        for (kp, b) in k[p * c..p * c + cols].iter_mut().zip(bp) {
            *kp = *b;
        }
    }
}

/// `y ← Zᵀ w − g` on a group's `W` rows: `z` its packed columns of `Z` along `chain` and the
/// root block, `wb` the root block's part of `w`.
fn project<const W: usize>(
    z: &[f64],
    chain: &[usize],
    w: &[f64],
    wb: &BlockRow,
    y: &mut [f64],
    g: &[f64],
) {
    let (limb, root) = lanes::<W>(z).split_at(chain.len());
    let mut yg = [0.0; W];
    for (z, &wj) in root.iter().zip(wb.iter()) {
        for p in 0..W {
            yg[p] += z[p] * wj;
        }
    }
    for (z, &k) in limb.iter().zip(chain) {
        for p in 0..W {
            yg[p] += z[p] * w[k];
        }
    }
    for ((y, yg), g) in y.iter_mut().zip(yg).zip(g) {
        *y = yg - g;
    }
}

/// `w ← w − Z y` on a group's rows (see [`project`]).
fn subtract<const W: usize>(
    z: &[f64],
    chain: &[usize],
    y: &[f64],
    w: &mut [f64],
    wb: &mut BlockRow,
) {
    let (limb, root) = lanes::<W>(z).split_at(chain.len());
    let mut yg = [0.0; W];
    yg.copy_from_slice(y);
    let zy = |z: &[f64; W]| (1..W).fold(z[0] * yg[0], |s, p| s + z[p] * yg[p]);
    for (z, &k) in limb.iter().zip(chain) {
        w[k] -= zy(z);
    }
    for (z, wj) in root.iter().zip(wb.iter_mut()) {
        *wj -= zy(z);
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
pub(super) fn dense_cholesky(k: &mut [f64], n: usize, min_pivot: f64) -> bool {
    for i in 0..n {
        let (done, rest) = k.split_at_mut(i * n);
        let row_i = &mut rest[..=i];
        for j in 0..i {
            let row_j = &done[j * n..j * n + j + 1];
            row_i[j] = (row_i[j] - dot(&row_i[..j], &row_j[..j])) / row_j[j];
        }
        let d = row_i[i] - dot(&row_i[..i], &row_i[..i]);
        if d.partial_cmp(&min_pivot) != Some(Ordering::Greater) {
            return false;
        }
        row_i[i] = d.sqrt();
    }
    true
}

/// `y ← (C Cᵀ)⁻¹ y` with the factor of [`dense_cholesky`].
pub(super) fn cholesky_solve(k: &[f64], n: usize, y: &mut [f64]) {
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
    /// `M` positive definite and the rows independent: the limb elimination
    /// ([`super::limb_kkt`], `SpatialData::limbs_eliminated`) or [`TreeKkt`].
    #[default]
    RangeSpace,
    /// The null-space block inverse of [`crate::kkt`] (singular `M`, or dependent rows through
    /// `A`'s row space, [`super::SpatialData::row_basis`]).
    NullSpace,
}
