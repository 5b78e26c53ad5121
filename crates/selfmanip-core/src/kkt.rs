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
#![allow(non_snake_case)]
use crate::error::{CoreError, Result, SingularityKind};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Relative tolerance on the QR diagonal of `Aᵀ` below which rows are dependent.
pub const RANK_TOLERANCE: f64 = 1e-10;
/// Relative tolerance on the Cholesky pivots of `M̃` below which Lemma 5.1 fails.
pub const PIVOT_TOLERANCE: f64 = 1e-11;

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
    /// `Λ` (c×c), symmetric negative definite (`Λ = −(A M̄⁻¹ Aᵀ)⁻¹` when `M̄` is invertible).
    pub lambda: DMatrix<f64>,
}

/// A reusable factorization (allocates only when sizes grow).
#[derive(Debug, Clone, Default)]
pub struct KktFactorization {
    m: usize,
    c: usize,
    q: DMatrix<f64>,
    r: DMatrix<f64>,
    mbar: DMatrix<f64>,
    l: DMatrix<f64>,
    work: DMatrix<f64>,
    v: Vec<f64>,
    t1: Vec<f64>,
    t2: Vec<f64>,
    t3: Vec<f64>,
    pub info: KktInfo,
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
        let m = mbar.nrows();
        let c = a.nrows();
        debug_assert_eq!(a.ncols(), m);
        self.m = m;
        self.c = c;
        if c > m {
            return Err(self.singular(mbar, a, SingularityKind::RedundantConstraints));
        }
        let e = m - c;
        if self.q.shape() != (m, m) {
            self.q = DMatrix::zeros(m, m);
            self.mbar = DMatrix::zeros(m, m);
        }
        if self.r.shape() != (c, c) {
            self.r = DMatrix::zeros(c, c);
        }
        if self.work.shape() != (m, c) {
            self.work = DMatrix::zeros(m, c);
        }
        if self.l.shape() != (e, e) {
            self.l = DMatrix::zeros(e, e);
        }
        self.v.resize(m, 0.0);
        self.t1.resize(m, 0.0);
        self.t2.resize(m, 0.0);
        self.t3.resize(m, 0.0);
        self.mbar.copy_from(mbar);

        // Householder QR of Aᵀ, accumulating Q = H₁ H₂ … H_c. Column-major slices: every
        // inner loop runs down a contiguous column.
        self.q.fill_with_identity();
        for i in 0..m {
            for k in 0..c {
                self.work[(i, k)] = a[(k, i)];
            }
        }
        let work = self.work.as_mut_slice();
        let q = self.q.as_mut_slice();
        let v = &mut self.v[..m];
        let w = &mut self.t1[..m];
        for k in 0..c {
            let col_k = &work[k * m..(k + 1) * m];
            let norm = col_k[k..].iter().map(|x| x * x).sum::<f64>().sqrt();
            if norm == 0.0 {
                continue;
            }
            let x0 = col_k[k];
            let alpha = if x0 >= 0.0 { -norm } else { norm };
            v[..k].fill(0.0);
            v[k..].copy_from_slice(&col_k[k..]);
            v[k] -= alpha;
            let vnorm2: f64 = v[k..].iter().map(|x| x * x).sum();
            if vnorm2 == 0.0 {
                continue;
            }
            let beta = 2.0 / vnorm2;
            // work ← H work on columns k..c
            for col in k..c {
                let wc = &mut work[col * m..(col + 1) * m];
                let s = beta * (k..m).map(|i| v[i] * wc[i]).sum::<f64>();
                for i in k..m {
                    wc[i] -= s * v[i];
                }
            }
            // Q ← Q H = Q − β (Q v) vᵀ
            w.fill(0.0);
            for i in k..m {
                let qi = &q[i * m..(i + 1) * m];
                for row in 0..m {
                    w[row] += qi[row] * v[i];
                }
            }
            for i in k..m {
                let s = beta * v[i];
                let qi = &mut q[i * m..(i + 1) * m];
                for row in 0..m {
                    qi[row] -= s * w[row];
                }
            }
        }
        for i in 0..c {
            for j in 0..c {
                self.r[(i, j)] = if j >= i { self.work[(i, j)] } else { 0.0 };
            }
        }
        let (mut rmin, mut rmax) = (f64::INFINITY, 0.0f64);
        for i in 0..c {
            let d = self.r[(i, i)].abs();
            rmin = rmin.min(d);
            rmax = rmax.max(d);
        }
        if c > 0 && (rmax == 0.0 || rmin <= RANK_TOLERANCE * rmax || !rmin.is_finite()) {
            return Err(self.singular(mbar, a, SingularityKind::RedundantConstraints));
        }

        // M̃ = Q₂ᵀ (M̄ Q₂) and its Cholesky factor L (lower).
        let (q, mb) = (self.q.as_slice(), mbar.as_slice());
        for j in 0..e {
            // t2 = M̄ q_{c+j}
            let qj = &q[(c + j) * m..(c + j + 1) * m];
            let t = &mut self.t2[..m];
            t.fill(0.0);
            for (s, &qs) in qj.iter().enumerate() {
                if qs != 0.0 {
                    let col = &mb[s * m..(s + 1) * m];
                    for p in 0..m {
                        t[p] += col[p] * qs;
                    }
                }
            }
            for i in j..e {
                let qi = &q[(c + i) * m..(c + i + 1) * m];
                let acc: f64 = qi.iter().zip(t.iter()).map(|(a, b)| a * b).sum();
                self.l[(i, j)] = acc;
                self.l[(j, i)] = acc;
            }
        }
        let scale = (0..e).map(|i| self.l[(i, i)].abs()).fold(0.0, f64::max);
        let (mut dmin, mut dmax) = (f64::INFINITY, 0.0f64);
        for j in 0..e {
            let mut d = self.l[(j, j)];
            for k in 0..j {
                d -= self.l[(j, k)] * self.l[(j, k)];
            }
            if !(d > PIVOT_TOLERANCE * scale) || scale == 0.0 {
                return Err(self.singular(mbar, a, SingularityKind::UnconstrainedMasslessMotion));
            }
            dmin = dmin.min(d);
            dmax = dmax.max(d);
            let ljj = d.sqrt();
            self.l[(j, j)] = ljj;
            for i in j + 1..e {
                let mut s = self.l[(i, j)];
                for k in 0..j {
                    s -= self.l[(i, k)] * self.l[(j, k)];
                }
                self.l[(i, j)] = s / ljj;
            }
        }
        for i in 0..e {
            for j in i + 1..e {
                self.l[(i, j)] = 0.0;
            }
        }
        self.info = KktInfo {
            constraint_condition: if c > 0 { rmax / rmin } else { 1.0 },
            reduced_mass_condition: if e > 0 { dmax / dmin } else { 1.0 },
        };
        Ok(())
    }

    fn singular(&self, mbar: &DMatrix<f64>, a: &DMatrix<f64>, kind: SingularityKind) -> CoreError {
        CoreError::SingularKkt {
            kind,
            condition_estimate: kkt_condition_number(mbar, a),
        }
    }

    /// Solves `[M̄ Aᵀ; A 0][x; y] = [f; g]` with the current factorization.
    pub fn solve(&mut self, f: &[f64], g: &[f64], x: &mut [f64], y: &mut [f64]) {
        let (m, c) = (self.m, self.c);
        let e = m - c;
        debug_assert!(f.len() == m && g.len() == c && x.len() == m && y.len() == c);
        // x₁ = R⁻ᵀ g  (Rᵀ lower triangular): stored in y temporarily
        for i in 0..c {
            let mut s = g[i];
            for k in 0..i {
                s -= self.r[(k, i)] * y[k];
            }
            y[i] = s / self.r[(i, i)];
        }
        let (q, mb) = (self.q.as_slice(), self.mbar.as_slice());
        let col = |j: usize| j * m..(j + 1) * m;
        // x = Q₁ x₁
        x.fill(0.0);
        for k in 0..c {
            for (xp, qp) in x.iter_mut().zip(&q[col(k)]) {
                *xp += qp * y[k];
            }
        }
        // t1 = f − M̄ x   (M̄ symmetric: row p = column p)
        for p in 0..m {
            self.t1[p] = f[p]
                - mb[col(p)]
                    .iter()
                    .zip(x.iter())
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
        }
        // t2 = Q₂ᵀ t1 ; solve L Lᵀ z = t2
        for i in 0..e {
            self.t2[i] = q[col(c + i)]
                .iter()
                .zip(&self.t1[..m])
                .map(|(a, b)| a * b)
                .sum();
        }
        for i in 0..e {
            let mut s = self.t2[i];
            for k in 0..i {
                s -= self.l[(i, k)] * self.t2[k];
            }
            self.t2[i] = s / self.l[(i, i)];
        }
        for i in (0..e).rev() {
            let mut s = self.t2[i];
            for k in i + 1..e {
                s -= self.l[(k, i)] * self.t2[k];
            }
            self.t2[i] = s / self.l[(i, i)];
        }
        // x += Q₂ z
        for i in 0..e {
            let zi = self.t2[i];
            for (xp, qp) in x.iter_mut().zip(&q[col(c + i)]) {
                *xp += qp * zi;
            }
        }
        // y = R⁻¹ Q₁ᵀ (f − M̄ x)
        for p in 0..m {
            self.t3[p] = f[p]
                - mb[col(p)]
                    .iter()
                    .zip(x.iter())
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
        }
        for k in 0..c {
            y[k] = q[col(k)]
                .iter()
                .zip(&self.t3[..m])
                .map(|(a, b)| a * b)
                .sum();
        }
        for i in (0..c).rev() {
            let mut s = y[i];
            for k in i + 1..c {
                s -= self.r[(i, k)] * y[k];
            }
            y[i] = s / self.r[(i, i)];
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
    pub fn null_space_basis(&self) -> DMatrix<f64> {
        self.q.columns(self.c, self.m - self.c).into_owned()
    }
}

/// The 2-norm condition number of `[M̄ Aᵀ; A 0]` (an SVD; used on error paths and in tests).
pub fn kkt_condition_number(mbar: &DMatrix<f64>, a: &DMatrix<f64>) -> f64 {
    let k = kkt_matrix(mbar, a);
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
