//! Eigenvalues of a real square matrix that always return: nalgebra's real Schur form (the
//! implicit double-shift QR iteration) loops without end on a matrix holding inf or NaN, and
//! its `complex_eigenvalues` sets no iteration cap. Here a finite check comes first and the
//! iteration stops after [`SCHUR_ITERATIONS_PER_ROW`] sweeps a row.
use nalgebra::{Complex, DMatrix, Schur};

/// QR sweeps a row the iteration may take (LAPACK's `hseqr` allows 30).
pub const SCHUR_ITERATIONS_PER_ROW: usize = 30;

/// The eigenvalues of `m`, or `None` where `m` holds a non-finite entry or the QR iteration
/// did not converge within its cap. The values are those of nalgebra's
/// `complex_eigenvalues`, operation for operation (the Schur form `T` does not depend on
/// whether `Q` is accumulated, and the tolerance is the same `f64::EPSILON`).
pub fn eigenvalues(m: DMatrix<f64>) -> Option<Vec<Complex<f64>>> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let cap = SCHUR_ITERATIONS_PER_ROW * m.nrows().max(1);
    let schur = Schur::try_new(m, f64::EPSILON, cap)?;
    Some(schur.complex_eigenvalues().iter().copied().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same values as nalgebra's uncapped routine on finite matrices (a second route
    /// through the same arithmetic), and `None` rather than a hang on inf and NaN.
    #[test]
    fn capped_eigenvalues_equal_nalgebras_and_refuse_non_finite_matrices() {
        let m = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, -4000.0, 30.0, -120.0, 2.0, 15.0, -900.0,
                1.5, -60.0,
            ],
        );
        let ours = eigenvalues(m.clone()).expect("converges");
        let theirs: Vec<_> = m.complex_eigenvalues().iter().copied().collect();
        assert_eq!(ours, theirs);
        for bad in [f64::INFINITY, f64::NAN, f64::NEG_INFINITY] {
            let mut b = m.clone();
            b[(2, 1)] = bad;
            assert_eq!(eigenvalues(b), None, "{bad}");
        }
    }
}
