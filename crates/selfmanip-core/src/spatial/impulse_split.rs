//! The split of a plastic impulse among redundant contact rows (four feet of a rigid table:
//! twelve rows on six rates). The impact's equations fix `Δq̇` and the generalized impulse
//! `(A_h + B)ᵀ P_h` only; any `P_h + N α` with `N` a basis of `ker (A_h + B)ᵀ` gives the same
//! motion. The least-norm split (no internal impulse) may leave a friction cone that another
//! split satisfies, so the model takes
//!
//! ```text
//! P* = argmin ½ |P₀ + N α|²   subject to   (μ_k P_n,k, P_t,k) ∈ Q  (each sticking contact)
//!                                          P_n,k ≥ 0              (each other held contact)
//! ```
//!
//! the minimum-norm impulse among the splits that satisfy every contact's law: a small
//! second-order cone program (`dim α` variables, one cone per contact), solved by Clarabel.
//! The objective is strictly convex in `P`, so `P*` is unique; `Δq̇` is the equations' own, to
//! round-off, and `P*` satisfies them to round-off (it moves along `N` only), its cones to the
//! solver's tolerance ([`SPLIT_TOLERANCE`]).
#![allow(non_snake_case)]
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};
use nalgebra::{DMatrix, DVector};

/// Clarabel's feasibility and gap tolerances for the split.
pub const SPLIT_TOLERANCE: f64 = 1e-11;
/// Singular values of the rows' map at most this fraction of the largest span its null space.
const NULL_RATIO: f64 = 1e-10;

/// One held contact's law on the split: its normal row and, when it sticks in a finite cone
/// `μ`, its tangent rows.
#[derive(Debug, Clone)]
pub(super) struct SplitLaw {
    pub normal: usize,
    pub cone: Option<(f64, Vec<usize>)>,
}

/// An orthonormal basis (columns) of `ker C` for `C` of `nv × m`: the impulses of the held
/// rows that change no generalized impulse.
pub(super) fn null_basis(C: &DMatrix<f64>) -> DMatrix<f64> {
    let (nv, m) = C.shape();
    if m == 0 {
        return DMatrix::zeros(0, 0);
    }
    let mut square = DMatrix::zeros(nv.max(m), m);
    square.view_mut((0, 0), (nv, m)).copy_from(C);
    let svd = square.svd(false, true);
    let v_t = svd.v_t.expect("asked for V");
    let top = svd.singular_values.max();
    let null: Vec<_> = (0..m)
        .filter(|&i| svd.singular_values[i] <= NULL_RATIO * top)
        .map(|i| v_t.row(i).transpose())
        .collect();
    if null.is_empty() {
        DMatrix::zeros(m, 0)
    } else {
        DMatrix::from_columns(&null)
    }
}

/// `P₀ + N α*` of the module's program (`P₀`, `N` on every row of the impact), or `None` when
/// no split satisfies the laws (Clarabel reports infeasible) or Clarabel fails.
pub(super) fn cone_split(
    P0: &DVector<f64>,
    N: &DMatrix<f64>,
    laws: &[SplitLaw],
) -> Option<DVector<f64>> {
    let d = N.ncols();
    if d == 0 {
        return None;
    }
    // objective ½ αᵀ(NᵀN)α + (NᵀP₀)ᵀα: its upper triangle
    let NtN = N.transpose() * N;
    let mut P = DMatrix::zeros(d, d);
    for c in 0..d {
        for r in 0..=c {
            P[(r, c)] = NtN[(r, c)];
        }
    }
    let q: Vec<f64> = (N.transpose() * P0).iter().copied().collect();
    // s = b − A α in the cones: s = the law's affine rows of P₀ + N α
    let (mut A_rows, mut b, mut cones) = (Vec::new(), Vec::new(), Vec::new());
    let mut push = |row: usize, scale: f64| {
        A_rows.push(N.row(row) * -scale);
        b.push(P0[row] * scale);
    };
    for law in laws {
        match &law.cone {
            Some((mu, tangents)) => {
                push(law.normal, *mu);
                for &t in tangents {
                    push(t, 1.0);
                }
                cones.push(SupportedConeT::SecondOrderConeT(1 + tangents.len()));
            }
            None => {
                push(law.normal, 1.0);
                cones.push(SupportedConeT::NonnegativeConeT(1));
            }
        }
    }
    let A = DMatrix::from_rows(&A_rows);
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(SPLIT_TOLERANCE)
        .tol_gap_rel(SPLIT_TOLERANCE)
        .tol_feas(SPLIT_TOLERANCE)
        .build()
        .expect("valid settings");
    let mut solver = DefaultSolver::new(&csc(&P), &q, &csc(&A), &b, &cones, settings).ok()?;
    solver.solve();
    let sol = &solver.solution;
    match sol.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {
            Some(P0 + N * DVector::from_column_slice(&sol.x))
        }
        _ => None,
    }
}

/// A dense matrix in Clarabel's compressed-column form (its nonzero entries).
fn csc(m: &DMatrix<f64>) -> CscMatrix<f64> {
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    for c in 0..m.ncols() {
        for r in 0..m.nrows() {
            if m[(r, c)] != 0.0 {
                rows.push(r);
                cols.push(c);
                vals.push(m[(r, c)]);
            }
        }
    }
    CscMatrix::new_from_triplets(m.nrows(), m.ncols(), rows, cols, vals)
}
