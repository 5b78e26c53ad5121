//! The KKT system of thesis (5.2) by eliminating the limbs' rates (the null-space method with
//! the tree's own basis of `ker A`), for contact sets that pin every limb they touch: the
//! spatial engine's first route, tried before [`super::tree_kkt`].
//!
//! A **limb** is the subtree of one child of the root block (the six rates `b` of a
//! free-flying base; on a fixed base, of the world): its rates `l` are contiguous in `v`, and
//! `M` couples two limbs only through the root block. When the rows of `A` on limb `i` (the
//! rows with an entry on its rates) are exactly as many as its rates, with an invertible
//! square block `A_ll` — a three-joint leg on a foot with friction, RHex's one-joint leg on a
//! frictionless toe — the rows fix that limb's rates from the base's,
//! `A_lb x_b + A_ll x_l = g_l`, i.e.
//!
//! `x_l = T x_b + s`, `T = −A_ll⁻¹ A_lb`, `s = A_ll⁻¹ g_l`.
//!
//! The other limbs (no rows: a swing leg) keep their rates `x_f`. With `N = [1; T]` a basis of
//! `ker A` on the root block, `[M Aᵀ; A 0][x; y] = [f; g]` reduces to the symmetric system in
//! `z = [x_b; x_f]`, `R z = r`, of size `nb + nf`:
//!
//! - `R_bb = M_bb + Σ_limbs (P T + Tᵀ M_lb)`, `P = M_bl + Tᵀ M_ll`; `R_bf = M_bf`; `R_ff = M_ff`;
//! - `r_b = f_b + Σ_limbs (Tᵀ f_l − P s)`, `r_f = f_f`;
//!
//! factored by a dense Cholesky (`R = Nᵀ M N`), and each pinned limb's multipliers follow from
//! its own rows of the equations of motion, `y_l = A_ll⁻ᵀ (f_l − M_lb x_b − M_ll x_l)`.
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
//! limb carries rows but not as many as its rates (a frictionless foot on a three-joint leg, a
//! foot held in a plane, a toe with friction on RHex's one-joint leg), or more than three
//! (two contacts on a longer limb); a limb's `A_ll` is
//! singular or nearly so (a pivot of its LU below [`LIMB_PIVOT_FRACTION`] of its largest
//! entry: a stretched leg); `R` is not clearly positive definite (a pivot below
//! [`REDUCED_PIVOT_FRACTION`] of its largest diagonal entry); or a free-flying root's own
//! body inertia is not positive definite (see [`LimbKkt::limbs_definite`]).
#![allow(non_snake_case)]
use super::model::{JointKind, SpatialModel};
use super::tree_kkt::{
    by_width, cholesky_solve, dense_cholesky, MASSLESS_DIAGONAL, PIVOT_FRACTION,
};
use nalgebra::{DMatrix, Matrix6, Vector6};

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

/// One limb: its rates `start..start + len` and (after [`LimbKkt::factor`]) whether rows pin
/// it, with its factors then (sized for [`MAX_PINNED`] rows, the first `len` used).
#[derive(Debug, Clone, Copy, Default)]
struct Limb {
    start: usize,
    len: usize,
    pinned: bool,
    /// Its rows of `A`, in order (the first `n_rows`).
    n_rows: usize,
    rows: [usize; MAX_PINNED],
    /// `A_ll⁻¹` and `M_ll` (row-major), and per rate `k`: row `k` of `T` and of `M_lb`,
    /// column `k` of `P` (zero past `nb`).
    inv: [[f64; MAX_PINNED]; MAX_PINNED],
    mll: [[f64; MAX_PINNED]; MAX_PINNED],
    t: [Vector6<f64>; MAX_PINNED],
    alb: [Vector6<f64>; MAX_PINNED],
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
            for k in joint.idx_v..joint.idx_v + joint.kind.nv() {
                let limb = &mut limbs[l];
                contiguous &= k == limb.start + limb.len;
                limb.len += 1;
                limb_of[k] = l;
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
            z: Vec::new(),
            block: vec![0.0; longest * longest],
        }
    }

    /// Factors the limb elimination of `[M Aᵀ; A 0]`; `false` (nothing usable) when the
    /// route does not apply (the module's text lists when).
    pub fn factor(&mut self, M: &DMatrix<f64>, A: &DMatrix<f64>) -> bool {
        let (m, a) = (M.as_slice(), A.as_slice());
        self.supported && self.limbs_definite(m) && self.factor_rows(m, a, A.nrows()).is_some()
    }

    /// [`Self::factor`] once `M` is known positive definite.
    fn factor_rows(&mut self, m: &[f64], a: &[f64], c: usize) -> Option<()> {
        let (nv, nb) = (self.nv, self.nb);
        // each row's limb: the one limb its entries past the root block lie on
        self.row_limb.clear();
        self.row_limb.resize(c, usize::MAX);
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
        for limb in &mut self.limbs {
            limb.pinned = false;
            limb.n_rows = 0;
        }
        for (r, &l) in self.row_limb.iter().enumerate() {
            let limb = self.limbs.get_mut(l)?;
            if limb.n_rows == limb.len.min(MAX_PINNED) {
                return None;
            }
            limb.rows[limb.n_rows] = r;
            limb.pinned = true;
            limb.n_rows += 1;
        }
        self.free.clear();
        let mut rbb = Matrix6::<f64>::zeros();
        for limb in self.limbs.iter_mut() {
            if !limb.pinned {
                self.free.extend(limb.start..limb.start + limb.len);
                continue;
            }
            if limb.n_rows != limb.len
                || !by_width!(limb.len, factor_limb(limb, m, nv, nb, a, c, &mut rbb))
            {
                return None;
            }
        }
        // R = [M_bb + Σ (P T + Tᵀ M_lb), M_bf; M_fb, M_ff]
        let nr = nb + self.free.len();
        self.z.resize(nr, 0.0);
        if nb == ROOT && self.free.is_empty() {
            let rbb = Matrix6::from_fn(|i, j| {
                let (i, j) = (i.max(j), i.min(j));
                m[i + j * nv] + rbb[(i, j)]
            });
            let largest = rbb.diagonal().max();
            let chol = nalgebra::Cholesky::new_unchecked(rbb);
            if !(chol.l_dirty().diagonal().min() > (REDUCED_PIVOT_FRACTION * largest).sqrt()) {
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
            let largest = (0..nr).map(|i| self.r[i * nr + i]).fold(0.0, f64::max);
            if !dense_cholesky(&mut self.r, nr, REDUCED_PIVOT_FRACTION * largest) {
                return None;
            }
        }
        Some(())
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
            let (n, e) = (limb.len, limb.start + limb.len - 1);
            // reversed order: the deepest rate first, as the tree's LᵀDL eliminates
            for i in 0..n {
                for j in 0..n {
                    block[i * n + j] = m[(e - i) + (e - j) * nv];
                }
            }
            (0..n).all(|i| m[(e - i) * (nv + 1)] > MASSLESS_DIAGONAL * largest)
                && ldl_clear(&mut block[..n * n], n, |i| m[(e - i) * (nv + 1)])
        })
    }

    /// Solves `[M Aᵀ; A 0][x; y] = [f; g]` with the current factors.
    pub fn solve(&mut self, f: &[f64], g: &[f64], x: &mut [f64], y: &mut [f64]) {
        let nb = self.nb;
        // s = A_ll⁻¹ g_l (into x's limb rates for now); r_b = f_b + Σ (Tᵀ f_l − P s)
        let mut rb = Vector6::from_fn(|j, _| if j < nb { f[j] } else { 0.0 });
        for limb in self.limbs.iter().filter(|l| l.pinned) {
            by_width!(limb.len, limb_rhs(limb, f, g, x, &mut rb));
        }
        self.reduced_solve(&mut rb, f);
        // x_b, x_f; x_l = T x_b + s and y_l = A_ll⁻ᵀ (f_l − M_lb x_b − M_ll x_l)
        x[..nb].copy_from_slice(&self.z[..nb]);
        for (&k, &zi) in self.free.iter().zip(&self.z[nb..]) {
            x[k] = zi;
        }
        let xb = Vector6::from_fn(|j, _| if j < nb { self.z[j] } else { 0.0 });
        for limb in self.limbs.iter().filter(|l| l.pinned) {
            by_width!(limb.len, limb_back(limb, &xb, f, x, y));
        }
    }

    /// `z = R⁻¹ [r_b; f_f]` (`f_f` the free rates' entries of `f`, zero where `f` is empty).
    fn reduced_solve(&mut self, rb: &mut Vector6<f64>, f: &[f64]) {
        let (nb, nr) = (self.nb, self.nb + self.free.len());
        let z = &mut self.z;
        match &self.root {
            Some(chol) => {
                chol.solve_mut(rb);
                z.copy_from_slice(rb.as_slice());
            }
            None => {
                z[..nb].copy_from_slice(&rb.as_slice()[..nb]);
                for (zi, &k) in z[nb..].iter_mut().zip(&self.free) {
                    *zi = f.get(k).copied().unwrap_or(0.0);
                }
                cholesky_solve(&self.r, nr, z);
            }
        }
    }
}

/// Limb `limb`'s factors with `W` rates (and rows): `A_ll⁻¹`, `T = −A_ll⁻¹ A_lb`,
/// `P = M_bl + Tᵀ M_ll`, and its term `P T + Tᵀ M_lb` of `R_bb` added to `rbb`'s lower
/// triangle; `false` when
/// `A_ll` is not clearly regular ([`LIMB_PIVOT_FRACTION`]).
fn factor_limb<const W: usize>(
    limb: &mut Limb,
    m: &[f64],
    nv: usize,
    nb: usize,
    a: &[f64],
    c: usize,
    rbb: &mut Matrix6<f64>,
) -> bool {
    let k0 = limb.start;
    let rows = limb.rows;
    // [A_ll | A_lb] row by row, reduced to [1 | −T] by Gauss–Jordan with partial pivoting;
    // A_ll⁻¹ alongside
    let mut all = [[0.0; W]; W];
    let mut inv = [[0.0; W]; W];
    let mut alb = [Vector6::zeros(); W];
    for i in 0..W {
        for j in 0..W {
            all[i][j] = a[(k0 + j) * c + rows[i]];
        }
        inv[i][i] = 1.0;
        for j in 0..nb {
            alb[i][j] = a[j * c + rows[i]];
        }
        limb.alb[i] = alb[i];
    }
    let largest = all.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
    for k in 0..W {
        let mut p = k;
        for i in k + 1..W {
            if all[i][k].abs() > all[p][k].abs() {
                p = i;
            }
        }
        if !(all[p][k].abs() > LIMB_PIVOT_FRACTION * largest) {
            return false;
        }
        all.swap(k, p);
        inv.swap(k, p);
        alb.swap(k, p);
        let d = 1.0 / all[k][k];
        for j in 0..W {
            all[k][j] *= d;
            inv[k][j] *= d;
        }
        alb[k] *= d;
        for i in 0..W {
            if i != k {
                let l = all[i][k];
                for j in 0..W {
                    all[i][j] -= l * all[k][j];
                    inv[i][j] -= l * inv[k][j];
                }
                let row = alb[k];
                alb[i] -= row * l;
            }
        }
    }
    // alb is now A_ll⁻¹ A_lb = −T; M's limb blocks
    for i in 0..W {
        limb.t[i] = -alb[i];
        limb.mlb[i] = Vector6::from_fn(|j, _| if j < nb { m[(k0 + i) + j * nv] } else { 0.0 });
        for j in 0..W {
            limb.inv[i][j] = inv[i][j];
            limb.mll[i][j] = m[(k0 + i) + (k0 + j) * nv];
        }
    }
    for i in 0..W {
        let mut p = limb.mlb[i];
        for j in 0..W {
            p += limb.t[j] * limb.mll[j][i];
        }
        limb.p[i] = p;
    }
    // R_bb's term P T + Tᵀ M_lb (symmetric: M_bl T + Tᵀ M_lb + Tᵀ M_ll T), lower triangle
    let (p, t, mlb) = (
        limb.p.map(|v| v.into()),
        limb.t.map(|v| v.into()),
        limb.mlb.map(|v| v.into()),
    );
    let (p, t, mlb): (
        [[f64; ROOT]; MAX_PINNED],
        [[f64; ROOT]; MAX_PINNED],
        [[f64; ROOT]; MAX_PINNED],
    ) = (p, t, mlb);
    for a in 0..nb {
        for b in 0..=a {
            let mut s = 0.0;
            for i in 0..W {
                s += p[i][a] * t[i][b] + t[i][a] * mlb[i][b];
            }
            rbb[(a, b)] += s;
        }
    }
    true
}

/// `s = A_ll⁻¹ g_l` into `x`'s limb rates, and `rb += Tᵀ f_l − P s`, `Tᵀ f_l = −A_lbᵀ A_ll⁻ᵀ f_l`.
fn limb_rhs<const W: usize>(
    limb: &Limb,
    f: &[f64],
    g: &[f64],
    x: &mut [f64],
    rb: &mut Vector6<f64>,
) {
    // Tᵀ f_l as −A_lbᵀ (A_ll⁻ᵀ f_l): the limb's share of the base's balance through its rows
    for i in 0..W {
        let s = (0..W).fold(0.0, |s, j| s + limb.inv[i][j] * g[limb.rows[j]]);
        x[limb.start + i] = s;
        let u = (0..W).fold(0.0, |u, j| u + limb.inv[j][i] * f[limb.start + j]);
        *rb -= limb.alb[i] * u + limb.p[i] * s;
    }
}

/// `x_l = T x_b + s` (`s` in `x`'s limb rates) and `y_l = A_ll⁻ᵀ (f_l − M_lb x_b − M_ll x_l)`.
fn limb_back<const W: usize>(
    limb: &Limb,
    xb: &Vector6<f64>,
    f: &[f64],
    x: &mut [f64],
    y: &mut [f64],
) {
    let mut xl = [0.0; W];
    for i in 0..W {
        xl[i] = limb.t[i].dot(xb) + x[limb.start + i];
        x[limb.start + i] = xl[i];
    }
    let mut e = [0.0; W];
    for i in 0..W {
        e[i] = (0..W).fold(f[limb.start + i] - limb.mlb[i].dot(xb), |s, j| {
            s - limb.mll[i][j] * xl[j]
        });
    }
    for j in 0..W {
        y[limb.rows[j]] = (0..W).fold(0.0, |s, i| s + limb.inv[i][j] * e[i]);
    }
}

/// Whether the symmetric `n × n` row-major `block` has `LDLᵀ` pivots `d_i > PIVOT_FRACTION ·
/// diagonal(i)` (eliminating in index order; `block`'s lower triangle is overwritten).
fn ldl_clear(block: &mut [f64], n: usize, diagonal: impl Fn(usize) -> f64) -> bool {
    for k in 0..n {
        let d = block[k * n + k];
        if !(d > PIVOT_FRACTION * diagonal(k)) {
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
