//! The block elimination of the folded system `[M̄ (A + B)ᵀ; A 0]` of the general sliding
//! sites' friction on a factored symmetric KKT system ([`Fold`]; the parent module's docs,
//! "The general sliding site", "Consistency (Painlevé)"), with the small dense algebra it
//! needs on buffers of its own: nalgebra's LU and determinants, operation for operation.
use crate::error::{CoreError, Result, SingularityKind};
use crate::kkt::KktFactorization;
use crate::model::Model;
use crate::sliding::SlidingSite;

/// Whether a site's friction is folded into the dynamics solve now: a general site on a
/// cone edge whose force is not a known (held) one.
pub(crate) fn folds(s: &SlidingSite) -> bool {
    s.general && s.held.is_none() && s.coef != 0.0
}

/// Size of the smallest singular value of the folded system's `I − Y_SS`, relative to
/// `1 + max|Y_SS|`, below which the normal forces of the general sliding sites are not
/// determined (the parent module's docs).
pub const FOLD_SINGULAR_TOL: f64 = 1e-10;
/// Relative size of a principal minor of `W⁻¹` below which a sliding mode is inconsistent
/// (Painlevé, the parent module's docs): round-off of a minor that is zero is not flagged.
pub const PAINLEVE_TOL: f64 = 1e-9;

/// The block elimination of the folded system `[M̄ (A + B)ᵀ; A 0]` on a factored symmetric
/// KKT system (the parent module's docs, "The general sliding site"): the responses
/// `(x_b, y_b)` of the symmetric system to each folding site's unit normal force's friction
/// and the LU of the Schur complement `I − Y_SS`. Formed once at a state, it turns the
/// symmetric system's solution `(x₀, y₀)` of any right-hand side into the folded system's
/// ([`Self::lambda`], [`Self::add`]): the forward solve (`friction::fold_general`) and the
/// implicit differentiation of it (`crate::tangent`, `K' dz = db − dK' z` with the same
/// `K'`) use it alike. Its buffers are kept from one state to the next ([`Self::form`]): the
/// forward solve forms it in `Data::fold`, without allocating once they have their size.
#[derive(Debug, Clone, Default)]
pub(crate) struct Fold {
    /// The folding sites' indices in `sliding`, and their normal rows.
    sites: Vec<usize>,
    rows: Vec<usize>,
    /// The numbers `m` of dynamic coordinates and `c` of rows of the symmetric system.
    m: usize,
    c: usize,
    /// `x_b` (on the dynamic coordinates) and `y_b` (rows), site `b`'s at `b·m`, `b·c`.
    xs: Vec<f64>,
    ys: Vec<f64>,
    /// `I − Y_SS` (column-major) and its LU.
    z: Vec<f64>,
    lu: Lu,
    /// The folding sites' `λ_n` at the last [`Self::solve`].
    lambda: Vec<f64>,
    /// Buffers: each coordinate's position in `coords`; a right-hand side `(f, g)` of the
    /// symmetric system and its solution `(xb, yb)`; `W⁻¹` (column-major), a principal
    /// minor's indices, LU and entries (Painlevé).
    pos: Vec<usize>,
    f: Vec<f64>,
    g: Vec<f64>,
    xb: Vec<f64>,
    yb: Vec<f64>,
    w: Vec<f64>,
    idx: Vec<usize>,
    minor: Lu,
    sub: Vec<f64>,
    /// A buffer for a caller's `q̈` on the dynamic coordinates (`friction::fold_general`).
    pub(crate) x: Vec<f64>,
}

/// Sets `v` to `n` zeros (its buffer kept).
fn zeros(v: &mut Vec<f64>, n: usize) {
    v.clear();
    v.resize(n, 0.0);
}

impl Fold {
    /// The fold at a factored symmetric system (`kkt` on `coords`) for the sites of
    /// `sliding` that fold; `None` when none does ([`Self::form`] on new buffers).
    pub(crate) fn new(
        model: &Model,
        kkt: &mut KktFactorization,
        coords: &[usize],
        sliding: &[SlidingSite],
    ) -> Result<Option<Self>> {
        let mut fold = Fold::default();
        Ok(fold.form(model, kkt, coords, sliding)?.then_some(fold))
    }

    /// Forms the fold at a factored symmetric system (`kkt` on `coords`) for the sites of
    /// `sliding` that fold, in place; `false` when none does. A typed error where `I − Y_SS`
    /// is singular (Lemma 5.1 for the folded system, [`FOLD_SINGULAR_TOL`]).
    pub(crate) fn form(
        &mut self,
        model: &Model,
        kkt: &mut KktFactorization,
        coords: &[usize],
        sliding: &[SlidingSite],
    ) -> Result<bool> {
        self.sites.clear();
        self.sites
            .extend((0..sliding.len()).filter(|&i| folds(&sliding[i])));
        if self.sites.is_empty() {
            return Ok(false);
        }
        self.rows.clear();
        self.rows.extend(self.sites.iter().map(|&i| sliding[i].row));
        let (m, c, n) = (coords.len(), kkt.n_rows(), self.sites.len());
        (self.m, self.c) = (m, c);
        self.pos.clear();
        self.pos.resize(model.nq(), usize::MAX);
        for (p, &k) in coords.iter().enumerate() {
            self.pos[k] = p;
        }
        // the response (x_b, y_b) to a unit normal force's friction −μ_kσ A_tᵀ at each site b
        // (solved into `xs`, `ys` directly: a solve only writes its solution)
        self.xs.resize(m * n, 0.0);
        self.ys.resize(c * n, 0.0);
        zeros(&mut self.f, m);
        zeros(&mut self.g, c);
        for (b, &i) in self.sites.iter().enumerate() {
            let s = &sliding[i];
            self.f.fill(0.0);
            for &(k, a_tk) in &s.a_t {
                if self.pos[k] != usize::MAX {
                    self.f[self.pos[k]] -= s.coef * a_tk;
                }
            }
            let (xb, yb) = (&mut self.xs[b * m..][..m], &mut self.ys[b * c..][..c]);
            kkt.solve(&self.f, &self.g, xb, yb);
        }
        // (I − Y_SS) λ_S = y_S, Y_SS,ab = (y_b)_row(a)
        let y_ss = |a: usize, b: usize| self.ys[b * c + self.rows[a]];
        self.z.clear();
        self.z
            .extend((0..n * n).map(|e| f64::from(u8::from(e % n == e / n)) - y_ss(e % n, e / n)));
        // relative to the size of `I` and `Y_SS` it is formed from: cancellation, not scale
        let scale = 1.0
            + (0..n)
                .flat_map(|a| (0..n).map(move |b| (a, b)))
                .fold(0.0f64, |m, (a, b)| m.max(y_ss(a, b).abs()));
        let z = &self.z;
        self.lu.factor(n, z);
        let tol = FOLD_SINGULAR_TOL * scale;
        // the SVD only where the bound from the LU does not already show `s_min` above `tol`
        let clearly_regular =
            n > 1 && singular_value_bound(self.lu.determinant(), z, n) > 2.0 * tol;
        if !clearly_regular {
            let s_min = if n == 1 {
                // what the SVD of a 1 × 1 matrix returns, without forming it
                z[0].abs()
            } else {
                nalgebra::DMatrix::from_column_slice(n, n, z)
                    .singular_values()
                    .min()
            };
            if s_min.is_nan() || s_min <= tol {
                return Err(CoreError::SingularKkt {
                    kind: SingularityKind::UnconstrainedMasslessMotion,
                    condition_estimate: scale / s_min,
                });
            }
        }
        Ok(true)
    }

    /// The folding sites' normal forces `λ_S = (I − Y_SS)⁻¹ y_S` for the symmetric system's
    /// solution rows `y`, into `lambda`.
    pub(crate) fn lambda(&self, y: &[f64], lambda: &mut Vec<f64>) -> Result<()> {
        lambda.clear();
        lambda.extend(self.rows.iter().map(|&r| y[r]));
        if self.lu.solve(lambda) {
            Ok(())
        } else {
            Err(CoreError::SingularKkt {
                kind: SingularityKind::UnconstrainedMasslessMotion,
                condition_estimate: f64::INFINITY,
            })
        }
    }

    /// The folded system's solution from the symmetric system's `(x, y)` (on the dynamic
    /// coordinates and the rows, for the force without the folding sites' friction), in
    /// place, with each site's `λ_n` kept ([`Self::forces`]): [`Self::lambda`], the
    /// Painlevé check and [`Self::add`]. A typed error, `x` and `y` untouched, where the
    /// mode is inconsistent (Painlevé).
    pub(crate) fn solve(
        &mut self,
        model: &Model,
        kkt: &mut KktFactorization,
        m: usize,
        sliding: &[SlidingSite],
        x: &mut [f64],
        y: &mut [f64],
    ) -> Result<()> {
        let mut lambda = std::mem::take(&mut self.lambda);
        let solved = self.lambda(y, &mut lambda);
        self.lambda = lambda;
        solved?;
        self.check_painleve(model, kkt, m, sliding)?;
        self.add(&self.lambda, x, y);
        Ok(())
    }

    /// Each folding site's index in `sliding` with its `λ_n` at the last [`Self::solve`].
    pub(crate) fn forces(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.sites.iter().copied().zip(self.lambda.iter().copied())
    }

    /// `x += Σ_b λ_b x_b`, `y += Σ_b λ_b y_b`: the symmetric system's solution `(x, y)` made
    /// the folded system's, with `lambda` from [`Self::lambda`] of that `y`.
    pub(crate) fn add(&self, lambda: &[f64], x: &mut [f64], y: &mut [f64]) {
        let (m, c) = (self.m, self.c);
        for (b, &l) in lambda.iter().enumerate() {
            for (xp, &xb) in x.iter_mut().zip(&self.xs[b * m..][..m]) {
                *xp += l * xb;
            }
            for (yr, &yb) in y.iter_mut().zip(&self.ys[b * c..][..c]) {
                *yr += l * yb;
            }
        }
    }

    /// Painlevé: `W⁻¹ = −(I − Y_SS)⁻¹ H_SS`, `H = ∂λ/∂g` the symmetric system's response to
    /// the sites' normal accelerations, must be a P₀-matrix (the parent module's docs).
    fn check_painleve(
        &mut self,
        model: &Model,
        kkt: &mut KktFactorization,
        m: usize,
        sliding: &[SlidingSite],
    ) -> Result<()> {
        let (c, n) = (self.c, self.rows.len());
        // H_SS, column-major, its column a the response to g = e_row(a)
        zeros(&mut self.w, n * n);
        zeros(&mut self.f, m);
        zeros(&mut self.g, c);
        zeros(&mut self.xb, m);
        zeros(&mut self.yb, c);
        for a in 0..n {
            self.g.fill(0.0);
            self.g[self.rows[a]] = 1.0;
            kkt.solve(&self.f, &self.g, &mut self.xb, &mut self.yb);
            for b in 0..n {
                self.w[a * n + b] = self.yb[self.rows[b]];
            }
        }
        for column in self.w.chunks_exact_mut(n) {
            // regular: `Self::lambda` solved with this LU before
            if !self.lu.solve(column) {
                return Err(CoreError::SingularKkt {
                    kind: SingularityKind::UnconstrainedMasslessMotion,
                    condition_estimate: f64::INFINITY,
                });
            }
        }
        self.w.iter_mut().for_each(|v| *v = -*v);
        let violation = painleve_violation(
            &self.w,
            n,
            model.total_mass_kg(),
            &mut self.idx,
            (&mut self.minor, &mut self.sub),
        );
        if let Some((a, minor)) = violation {
            return Err(CoreError::PainleveInconsistent {
                contact: model.contacts[sliding[self.sites[a]].contact].name.clone(),
                response: minor,
            });
        }
        Ok(())
    }
}

/// A lower bound on the smallest singular value of the `n × n` matrix `z` (column-major)
/// from its determinant `det`: `|det| / ‖z‖_F^(n−1)` (`|det| = Π σ_i ≤ σ_min σ_max^(n−1)`
/// and `σ_max ≤ ‖z‖_F`). NaN or zero where it says nothing. Computed with `det` from a
/// pivoted LU, it is off by round-off relative to `‖z‖ ‖z⁻¹‖ ε`, so where it exceeds twice a
/// tolerance far above `ε ‖z‖`, the SVD's `σ_min` (accurate to `ε ‖z‖`) exceeds the
/// tolerance too: the decision is the SVD's without forming it.
fn singular_value_bound(det: f64, z: &[f64], n: usize) -> f64 {
    let frobenius = z.iter().map(|v| v * v).sum::<f64>().sqrt();
    det.abs() / frobenius.powi(n as i32 - 1)
}

/// nalgebra's LU with partial pivoting (`nalgebra::LU`) on reusable buffers, operation for
/// operation — the same factors, solutions and determinant, bit for bit — for the small
/// dense systems of the fold.
#[derive(Debug, Clone, Default)]
struct Lu {
    n: usize,
    /// `L` (unit diagonal, below) and `U` (on and above), column-major.
    lu: Vec<f64>,
    /// The row swaps, in order.
    swaps: Vec<(usize, usize)>,
}

impl Lu {
    /// Factors the `n × n` matrix `a` (column-major).
    fn factor(&mut self, n: usize, a: &[f64]) {
        self.n = n;
        self.lu.clear();
        self.lu.extend_from_slice(&a[..n * n]);
        self.swaps.clear();
        let a = &mut self.lu;
        for i in 0..n {
            // the first entry of largest modulus on and below the diagonal
            let mut piv = i;
            let mut max = a[i * n + i].abs();
            for r in i + 1..n {
                let v = a[i * n + r].abs();
                if v > max {
                    (max, piv) = (v, r);
                }
            }
            let diag = a[i * n + piv];
            if diag == 0.0 {
                continue; // no nonzero entry in this column
            }
            if piv != i {
                self.swaps.push((i, piv));
                for k in 0..n {
                    a.swap(k * n + i, k * n + piv);
                }
            }
            let inv_diag = 1.0 / diag;
            for r in i + 1..n {
                a[i * n + r] *= inv_diag;
            }
            for k in i + 1..n {
                let p = a[k * n + i];
                for r in i + 1..n {
                    a[k * n + r] += -p * a[i * n + r];
                }
            }
        }
    }

    /// Solves for one right-hand side `b` in place; `false` (and `b` spoilt) where `U` has a
    /// zero on its diagonal.
    fn solve(&self, b: &mut [f64]) -> bool {
        let (n, a) = (self.n, &self.lu);
        for &(i, j) in &self.swaps {
            b.swap(i, j);
        }
        // L's unit diagonal: nalgebra divides by 1, which changes no number
        for i in 0..n.saturating_sub(1) {
            let coeff = b[i];
            for r in i + 1..n {
                b[r] += -coeff * a[i * n + r];
            }
        }
        for i in (0..n).rev() {
            let diag = a[i * n + i];
            if diag == 0.0 {
                return false;
            }
            let coeff = b[i] / diag;
            b[i] = coeff;
            for r in 0..i {
                b[r] += -coeff * a[i * n + r];
            }
        }
        true
    }

    /// The determinant: the product of `U`'s diagonal, times the swaps' sign.
    fn determinant(&self) -> f64 {
        let mut det = 1.0;
        for i in 0..self.n {
            det *= self.lu[i * self.n + i];
        }
        det * if self.swaps.len().is_multiple_of(2) {
            1.0
        } else {
            -1.0
        }
    }
}

/// The first principal minor of `w` (`n × n`, column-major) that is clearly negative (P₀
/// fails), as the index of the first site in it and the minor's value; `None` when every
/// principal minor is `≥ −` [`PAINLEVE_TOL`] relative to the product of its rows' sizes,
/// each at least `m_ref` (kg, the robot's mass: `W⁻¹` is a mass). The floor keeps a massless
/// pin — a sliding toe on a massless knee under a massive link, whose response is zero up to
/// round-off — from being judged by its own round-off (`tests/sprung_leg_sliding.rs`).
/// `idx`, `lu` and `sub` are buffers.
fn painleve_violation(
    w: &[f64],
    n: usize,
    m_ref: f64,
    idx: &mut Vec<usize>,
    (lu, sub): (&mut Lu, &mut Vec<f64>),
) -> Option<(usize, f64)> {
    for subset in 1u32..(1 << n) {
        idx.clear();
        idx.extend((0..n).filter(|&b| subset >> b & 1 == 1));
        let det = principal_minor(w, n, idx, lu, sub);
        let scale: f64 = idx
            .iter()
            .map(|&a| (0..n).fold(m_ref, |acc, b| acc.max(w[b * n + a].abs())))
            .product();
        if det < -PAINLEVE_TOL * scale {
            return Some((idx[0], det));
        }
    }
    None
}

/// The principal minor of `w` (`n × n`, column-major) on the rows and columns `idx`
/// (ascending): the value of nalgebra's `determinant` of the submatrix, bit for bit — its
/// closed forms up to order 3, read off `w`, and its LU above, on the submatrix copied into
/// `sub` (`lu`, `sub` buffers).
fn principal_minor(w: &[f64], n: usize, idx: &[usize], lu: &mut Lu, sub: &mut Vec<f64>) -> f64 {
    let e = |r: usize, s: usize| w[idx[s] * n + idx[r]];
    match idx.len() {
        1 => e(0, 0),
        2 => e(0, 0) * e(1, 1) - e(1, 0) * e(0, 1),
        3 => {
            let minor_m12_m23 = e(1, 1) * e(2, 2) - e(2, 1) * e(1, 2);
            let minor_m11_m23 = e(1, 0) * e(2, 2) - e(2, 0) * e(1, 2);
            let minor_m11_m22 = e(1, 0) * e(2, 1) - e(2, 0) * e(1, 1);
            e(0, 0) * minor_m12_m23 - e(0, 1) * minor_m11_m23 + e(0, 2) * minor_m11_m22
        }
        k => {
            sub.clear();
            sub.extend((0..k * k).map(|p| e(p % k, p / k)));
            lu.factor(k, sub);
            lu.determinant()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// A fixed sequence of numbers in `[-1, 1)` (a linear congruential generator).
    fn numbers(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            2.0 * ((s >> 11) as f64 / (1u64 << 53) as f64) - 1.0
        }
    }

    /// A random `n × n` matrix: entries over six orders of magnitude, or, with `ties`,
    /// small integers (equal moduli in a column, zero columns, singular matrices).
    fn matrix(x: &mut impl FnMut() -> f64, n: usize, ties: bool) -> DMatrix<f64> {
        DMatrix::from_fn(n, n, |_, _| {
            if ties {
                (2.0 * x()).round()
            } else {
                x() * 10f64.powi((3.0 * x()) as i32)
            }
        })
    }

    /// The minors read off `w` are nalgebra's determinants of the submatrices copied out,
    /// bit for bit, for every principal minor of matrices of order 1 to 6; and a 1 × 1
    /// matrix's singular value is the SVD's, over sizes from 1e-300 to 1e300.
    #[test]
    fn minors_and_singular_values_read_off_agree_with_the_general_route() {
        let mut x = numbers(3);
        let (mut idx, mut lu, mut sub) = (Vec::new(), Lu::default(), Vec::new());
        for n in 1..=6 {
            for trial in 0..40 {
                let w = matrix(&mut x, n, trial % 2 == 1);
                for subset in 1u32..(1 << n) {
                    idx.clear();
                    idx.extend((0..n).filter(|&b| subset >> b & 1 == 1));
                    let copied = w.select_rows(&idx).select_columns(&idx).determinant();
                    let read = principal_minor(w.as_slice(), n, &idx, &mut lu, &mut sub);
                    assert_eq!(read.to_bits(), copied.to_bits(), "{w} {idx:?}");
                }
            }
        }
        for e in -300..=300 {
            let z = DMatrix::from_element(1, 1, x() * 10f64.powi(e));
            let svd = z.singular_values().min();
            assert_eq!(z[(0, 0)].abs().to_bits(), svd.to_bits(), "{z}");
        }
    }

    /// The fold's LU solves and its determinant are nalgebra's `LU`, bit for bit, on random
    /// and tied or singular matrices of order 1 to 6 (a failed solve fails in both).
    #[test]
    fn lu_agrees_with_nalgebra() {
        let mut x = numbers(5);
        let mut lu = Lu::default();
        for n in 1..=6 {
            for trial in 0..200 {
                let a = matrix(&mut x, n, trial % 2 == 1);
                let b = DMatrix::from_fn(n, 3, |_, _| x());
                lu.factor(n, a.as_slice());
                let reference = a.clone().lu();
                assert_eq!(
                    lu.determinant().to_bits(),
                    reference.determinant().to_bits()
                );
                let solved = reference.solve(&b);
                let mut own = b.clone();
                let ok = own
                    .column_iter_mut()
                    .all(|mut col| lu.solve(col.as_mut_slice()));
                assert_eq!(ok, solved.is_some(), "{a}");
                if let Some(solved) = solved {
                    for (u, v) in own.iter().zip(solved.iter()) {
                        assert_eq!(u.to_bits(), v.to_bits(), "{a}");
                    }
                }
            }
        }
    }

    /// The bound from the LU never exceeds the SVD's smallest singular value (beyond
    /// round-off), on random matrices and on nearly singular ones (a rank-one deficiency of
    /// relative size 1e-16 to 1e-6), orders 2 to 5.
    #[test]
    fn singular_value_bound_is_below_the_svd() {
        let mut x = numbers(7);
        let mut lu = Lu::default();
        for (n, trial) in (2..=5).flat_map(|n| (0..400).map(move |trial| (n, trial))) {
            let mut z = matrix(&mut x, n, false);
            if trial % 2 == 1 {
                // replace the last column by a combination of the others, nearly
                let c: Vec<f64> = (0..n - 1).map(|_| x()).collect();
                let eps = 10f64.powi(-6 - (trial / 2) % 11);
                for r in 0..n {
                    let v: f64 = (0..n - 1).map(|k| c[k] * z[(r, k)]).sum();
                    z[(r, n - 1)] = v + eps * x();
                }
            }
            lu.factor(n, z.as_slice());
            let bound = singular_value_bound(lu.determinant(), z.as_slice(), n);
            let s_min = z.singular_values().min();
            let round_off = 1e-13 * z.norm();
            assert!(
                bound <= s_min * (1.0 + 1e-9) + round_off,
                "{z}: {bound} {s_min}"
            );
        }
    }
}
