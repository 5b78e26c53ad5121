//! The one error type of the core crate.
use thiserror::Error;

/// Why the KKT matrix of (5.2) cannot be inverted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum SingularityKind {
    /// The active constraint rows of `A` are linearly dependent (an over-constrained
    /// contact set such as RHex's `1111`, or a kinematic singularity).
    RedundantConstraints,
    /// Lemma 5.1: the reduced mass matrix `M̃ = Hᵀ M̄ H` is singular — some allowed motion
    /// carries no kinetic energy (a massless limb that no contact pins down).
    UnconstrainedMasslessMotion,
}

/// Errors of the self-manipulation core. Every public entry point returns these instead of
/// panicking or producing NaN.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum CoreError {
    #[error("robot description: field `{field}`: {reason}")]
    InvalidDescription { field: String, reason: String },
    #[error("could not parse robot description ({format}): {message}")]
    Parse {
        format: &'static str,
        message: String,
    },
    #[error("`{field}` has length {actual}, expected {expected}")]
    WrongLength {
        field: &'static str,
        expected: usize,
        actual: usize,
    },
    #[error("`{field}` has a non-finite entry at index {index} ({value})")]
    NonFinite {
        field: &'static str,
        index: usize,
        value: f64,
    },
    /// A computation on finite inputs overflowed: an input too large for double precision
    /// (a mass, length, velocity or torque of ~1e150 and beyond). Names what went
    /// non-finite, which is not an input.
    #[error("the dynamics produced a non-finite `{quantity}`: an input (mass, length, velocity or torque) is too large for double precision")]
    NonFiniteResult { quantity: &'static str },
    #[error("unknown contact `{name}`")]
    UnknownContact { name: String },
    #[error("invalid contact mode: {reason}")]
    InvalidMode { reason: String },
    #[error("KKT matrix is singular ({kind:?}); condition estimate {condition_estimate:.3e}")]
    SingularKkt {
        kind: SingularityKind,
        condition_estimate: f64,
    },
    #[error("parameterization `{field}` is invalid: {reason}")]
    InvalidParameterization { field: &'static str, reason: String },
    /// A sliding contact with Coulomb friction whose normal response has the wrong sign
    /// (Painlevé's paradox, `crate::friction`): a pushing force would not prevent
    /// penetration, so the sliding mode has no solution or several. `response` is the
    /// offending principal minor of the sliding sites' normal response `W⁻¹`.
    #[error("sliding contact `{contact}` is inconsistent with Coulomb friction (Painlevé): its normal response has the wrong sign ({response:.3e}); the sliding mode has no or several solutions")]
    PainleveInconsistent { contact: String, response: f64 },
    #[error("quasi-static problem is ill-posed: {reason}")]
    IllPosedQuasiStatic { reason: String },
}

pub type Result<T> = std::result::Result<T, CoreError>;

/// Checks that a slice has the expected length and finite entries.
pub(crate) fn check_vector(field: &'static str, v: &[f64], expected: usize) -> Result<()> {
    if v.len() != expected {
        return Err(CoreError::WrongLength {
            field,
            expected,
            actual: v.len(),
        });
    }
    check_finite(field, v)
}

/// Whether every entry is finite, without a branch per entry and on integers, which the
/// compiler may reorder and vectorize: an entry is infinite or NaN exactly when its exponent
/// bits are all ones, and then adding one unit of the exponent carries into the sign bit.
/// Every flow evaluation checks `M̄`, `C̄q̇`, `N̄`, `A`, `Ȧq̇`, `q̈` and `λ` so that finite
/// inputs too large for double precision end in a typed error.
#[inline]
pub(crate) fn all_finite(v: &[f64]) -> bool {
    const EXPONENT: u64 = 0x7ff0_0000_0000_0000;
    const ONE: u64 = 1 << 52;
    v.iter()
        .fold(0u64, |acc, x| acc | ((x.to_bits() & EXPONENT) + ONE))
        >> 63
        == 0
}

/// Checks that a computed quantity is finite ([`CoreError::NonFiniteResult`] naming it).
pub(crate) fn check_result(quantity: &'static str, v: &[f64]) -> Result<()> {
    if all_finite(v) {
        Ok(())
    } else {
        Err(CoreError::NonFiniteResult { quantity })
    }
}

pub(crate) fn check_finite(field: &'static str, v: &[f64]) -> Result<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(CoreError::NonFinite {
            field,
            index,
            value: v[index],
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod finite_tests {
    use super::all_finite;

    /// The branch-free check agrees with `is_finite` on every kind of value, signed zeros and
    /// subnormals included, wherever the odd entry sits.
    #[test]
    fn all_finite_agrees_with_is_finite() {
        let odd = [f64::INFINITY, f64::NEG_INFINITY, f64::NAN, -f64::NAN];
        let fine = [0.0, -0.0, 1e-310, -1e-310, f64::MAX, f64::MIN, 1.0, -3.5];
        assert!(all_finite(&fine) && all_finite(&[]));
        for bad in odd {
            for at in 0..=fine.len() {
                let mut v = fine.to_vec();
                v.insert(at, bad);
                assert_eq!(all_finite(&v), v.iter().all(|x| x.is_finite()), "{v:?}");
                assert!(!all_finite(&v));
            }
        }
    }
}
