//! The step bound of free massless joints. Their coordinates follow the controller's
//! prescribed motion through a tracking law `q̈_F = g(t, q, q̇)`
//! ([`Controller::free_joint_qdd`], thesis 5.1.1) and are left out of the step-size control
//! (the motion feeds back into nothing), so nothing else keeps an explicit step inside the
//! law's stability region: a law stiffer than the steps — gains of 10⁶ /s² at the default
//! 10 ms, or a user's `h_max_s` of 65 ms with 4,000 /s² — grew without bound, unseen by the
//! error norm, until a foot landed at 10²⁵ m/s.
//!
//! The bound is `h ≤ STABLE_HZ / ρ`, `ρ` the spectral radius of `∂(q̇_F, q̈_F)/∂(q_F, q̇_F)`
//! at a segment's start, by differences of the law (exact for the linear tracking laws of
//! the behaviours and the RHex leap; a law whose stiffness grows along a segment is not
//! covered). Each joint's law on its own coordinates is a 2 × 2 block `[0 1; a b]`, whose
//! eigenvalues are `(b ± √(b² + 4a))/2`; a law that couples joints gets the full eigenvalue
//! problem ([`crate::eigen`], iteration-capped: past the cap the row-sum bound
//! `ρ ≤ ‖J‖_∞` stands in). A law that is not finite at the segment's start (a state or gain
//! near the largest `f64`) ends the run with [`CoreError::NonFiniteResult`] before any
//! eigenvalue is sought.
use crate::controller::Controller;
use crate::eigen::eigenvalues;
use nalgebra::DMatrix;
use selfmanip_core::CoreError;

/// `h |λ|` at which the law is integrated, at most: inside DOPRI5's stability region with a
/// margin (the region reaches −3.3 on the negative real axis).
pub const STABLE_HZ: f64 = 2.0;

/// Scratch buffers of [`Self::step_cap`], reused from segment to segment.
#[derive(Debug, Default)]
pub struct FreeJointStability {
    q: Vec<f64>,
    qd: Vec<f64>,
    f0: Vec<f64>,
    f1: Vec<f64>,
    /// `∂q̈_F/∂q_F`, then `∂q̈_F/∂q̇_F`, column-major (`nf × nf` each).
    a: Vec<f64>,
    b: Vec<f64>,
}

impl FreeJointStability {
    /// The largest step at which the law of the joints `free` is integrated stably from
    /// `(t, y)` (`y = (q, q̇)`, `nq` coordinates): `STABLE_HZ / ρ`; infinite without free
    /// joints or where `ρ` is 0. A law whose differences are not finite is
    /// [`CoreError::NonFiniteResult`].
    pub fn step_cap(
        &mut self,
        ctrl: &dyn Controller,
        t: f64,
        y: &[f64],
        nq: usize,
        free: &[usize],
    ) -> Result<f64, CoreError> {
        let nf = free.len();
        if nf == 0 {
            return Ok(f64::INFINITY);
        }
        let (q, qd) = y.split_at(nq);
        self.q.clear();
        self.q.extend_from_slice(q);
        self.qd.clear();
        self.qd.extend_from_slice(qd);
        self.f0.resize(nf, 0.0);
        self.f1.resize(nf, 0.0);
        self.a.resize(nf * nf, 0.0);
        self.b.resize(nf * nf, 0.0);
        ctrl.free_joint_qdd(t, q, qd, free, &mut self.f0);
        for (c, &j) in free.iter().enumerate() {
            let dq = 1e-6 * q[j].abs().max(1.0);
            self.q[j] = q[j] + dq;
            ctrl.free_joint_qdd(t, &self.q, qd, free, &mut self.f1);
            self.q[j] = q[j];
            for r in 0..nf {
                self.a[c * nf + r] = (self.f1[r] - self.f0[r]) / dq;
            }
            let dv = 1e-6 * qd[j].abs().max(1.0);
            self.qd[j] = qd[j] + dv;
            ctrl.free_joint_qdd(t, q, &self.qd, free, &mut self.f1);
            self.qd[j] = qd[j];
            for r in 0..nf {
                self.b[c * nf + r] = (self.f1[r] - self.f0[r]) / dv;
            }
        }
        if !self.a.iter().chain(&self.b).all(|v| v.is_finite()) {
            return Err(CoreError::NonFiniteResult {
                quantity: "free joints' tracking law ∂q̈_F/∂(q_F, q̇_F) at a segment's start",
            });
        }
        let coupled = (0..nf)
            .flat_map(|c| (0..nf).filter(move |&r| r != c).map(move |r| c * nf + r))
            .any(|k| self.a[k] != 0.0 || self.b[k] != 0.0);
        let rho = if coupled {
            let mut jac = DMatrix::<f64>::zeros(2 * nf, 2 * nf);
            for c in 0..nf {
                jac[(c, nf + c)] = 1.0;
                for r in 0..nf {
                    jac[(nf + r, c)] = self.a[c * nf + r];
                    jac[(nf + r, nf + c)] = self.b[c * nf + r];
                }
            }
            spectral_radius(jac)
        } else {
            (0..nf)
                .map(|k| block_radius(self.a[k * nf + k], self.b[k * nf + k]))
                .fold(0.0, f64::max)
        };
        Ok(if rho.is_finite() && rho > 0.0 {
            STABLE_HZ / rho
        } else {
            f64::INFINITY
        })
    }
}

/// The largest eigenvalue modulus of the finite matrix `m` ([`eigenvalues`]); where the
/// capped QR iteration does not converge, the row-sum norm `‖m‖_∞`, which no eigenvalue's
/// modulus exceeds (a larger `ρ` only shortens the steps).
fn spectral_radius(m: DMatrix<f64>) -> f64 {
    let row_sum = m.row_iter().map(|r| r.abs().sum()).fold(0.0, f64::max);
    eigenvalues(m).map_or(row_sum, |ev| {
        ev.iter().map(|l| l.norm()).fold(0.0, f64::max)
    })
}

/// The spectral radius of `[0 1; a b]` (`q̈ = a q + b q̇`): its eigenvalues are
/// `(b ± √(b² + 4a))/2`, complex conjugates of modulus `√(−a)` when `b² + 4a < 0`.
fn block_radius(a: f64, b: f64) -> f64 {
    let d = b * b + 4.0 * a;
    if d < 0.0 {
        (-a).sqrt()
    } else {
        let s = d.sqrt();
        (b + s).abs().max((b - s).abs()) / 2.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 2 × 2 block's radius against the full eigenvalue problem, over- and underdamped,
    /// critically damped and unstable laws.
    #[test]
    fn block_radius_is_the_largest_eigenvalue_modulus() {
        for (a, b) in [
            (-4000.0, -120.0),
            (-1e6, -2000.0),
            (-400.0, -40.0),
            (-1.0, -100.0),
            (3.0, 1.0),
            (-9.0, 0.0),
        ] {
            let m = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, a, b]);
            let full = m
                .complex_eigenvalues()
                .iter()
                .map(|l| l.norm())
                .fold(0.0, f64::max);
            assert!((block_radius(a, b) - full).abs() <= 1e-12 * full, "{a} {b}");
        }
    }
}
