//! The saltation matrix of a reset at a guard, `Ξ = D_xR + (f⁺ − D_xR f⁻) D_xg / ġ`, and where
//! it is not defined (grazing).
use super::types::SaltationStatus;
use nalgebra::{DMatrix, DVector, RowDVector};

/// Relative transversality `|D_xg f⁻| / (|D_xg| |f⁻|)` below which an event is grazing.
pub const GRAZING_TOL: f64 = 1e-8;

/// The saltation matrix `Ξ = D_xR + (f⁺ − D_xR f⁻) D_xg / (D_xg f⁻)` of a reset with
/// Jacobian `dr` and a guard with gradient `dg`, between the flows `f⁻` and `f⁺`; or
/// [`SaltationStatus::Grazing`] when `|D_xg f⁻| < GRAZING_TOL |D_xg| |f⁻|` (the flow meets the
/// guard tangentially, where `Ξ` is not defined).
pub fn saltation(
    dr: &DMatrix<f64>,
    f_minus: &DVector<f64>,
    f_plus: &DVector<f64>,
    dg: &RowDVector<f64>,
) -> Result<DMatrix<f64>, SaltationStatus> {
    saltation_with_rate(dr, f_minus, f_plus, dg, 0.0)
}

/// [`saltation`] of a guard that also depends on time: `ġ = D_xg f⁻ + dg_dt` in place of
/// `D_xg f⁻` (the time is a state with `ṫ = 1`), e.g. a force guard under a controller
/// whose torques change with time at a fixed state.
pub(super) fn saltation_with_rate(
    dr: &DMatrix<f64>,
    f_minus: &DVector<f64>,
    f_plus: &DVector<f64>,
    dg: &RowDVector<f64>,
    dg_dt: f64,
) -> Result<DMatrix<f64>, SaltationStatus> {
    let den = (dg * f_minus)[0] + dg_dt;
    let rel = den.abs() / (dg.norm() * f_minus.norm()).max(f64::MIN_POSITIVE);
    if rel.is_nan() || rel < GRAZING_TOL {
        return Err(SaltationStatus::Grazing {
            transversality: rel,
        });
    }
    Ok(dr + (f_plus - dr * f_minus) * dg / den)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A guard met tangentially is flagged, not divided by: `D_xg f⁻ = 0` exactly and at
    /// 1e-12 of `|D_xg| |f⁻|`; at 1e-6 the formula applies (a closed form: with `D_xR = I`,
    /// `Ξ e_0 = e_0 + (f⁺ − f⁻)/(D_xg f⁻)` for `D_xg = e_0ᵀ`).
    #[test]
    fn grazing_is_flagged() {
        let dr = DMatrix::identity(2, 2);
        let dg = RowDVector::from_vec(vec![1.0, 0.0]);
        let fp = DVector::from_vec(vec![0.0, 3.0]);
        for (eps, grazing) in [(0.0, true), (1e-12, true), (1e-6, false)] {
            let fm = DVector::from_vec(vec![eps, 1.0]);
            match saltation(&dr, &fm, &fp, &dg) {
                Err(SaltationStatus::Grazing { transversality }) => {
                    assert!(grazing && transversality <= eps, "{eps}")
                }
                Ok(x) => {
                    assert!(!grazing, "{eps}");
                    assert!((x[(0, 0)] - (1.0 + (0.0 - eps) / eps)).abs() < 1e-9);
                    assert!((x[(1, 0)] - (3.0 - 1.0) / eps).abs() < 1e-9 * 2.0 / eps);
                }
                Err(other) => panic!("{other:?}"),
            }
        }
    }
}
