//! The largest speed along a velocity direction before a contact lifts off (the optimisation
//! under thesis Fig. 4.8, for any planar robot), and the velocity parameterization of a
//! stance whose unloaded legs move freely. RHex's sensor sweep (Fig. 4.8) is in `rhex-model`.
use super::{bad, check_finite, normal_rows, selector_rows};
use crate::error::SimError;
use nalgebra::{DMatrix, DVector};
use selfmanip_core::{forward_dynamics, ContactMode, Data, Model, Terrain};
use serde::Serialize;

/// Velocity parameterization `y = [lead joint, free massless joints…]` of a stance (the `Y`
/// of (4.20)): the joints of legs without an active contact in `mode` are free coordinates
/// (they move without affecting the body, 5.1.1), `lead_joint` is the behaviour's input.
pub fn free_leg_parameterization(
    model: &Model,
    mode: ContactMode,
    lead_joint: usize,
) -> DMatrix<f64> {
    let mut idx = vec![lead_joint];
    for (li, leg) in model.legs.iter().enumerate() {
        let touching = mode.active().any(|k| model.contact_leg(k) == Some(li));
        if !touching {
            for j in leg.first_joint..leg.first_joint + leg.n_links {
                if j != lead_joint {
                    idx.push(j);
                }
            }
        }
    }
    selector_rows(model.nq(), &idx)
}

/// The largest speed along a velocity direction before a contact lifts off.
#[derive(Debug, Clone, Serialize)]
pub struct LiftoffSpeed {
    /// Largest `s ≥ 0` with `Uλ(q, s·v) ≥ 0` (`None`: no contact ever lifts).
    pub speed: Option<f64>,
    /// Index into λ of the normal row that reaches zero first.
    pub binding_row: Option<usize>,
    /// `Uλ` of every normal row at rest (`a`) and its coefficient of `s²` (`b`):
    /// `Uλ(s) = a + b s²`.
    pub a: Vec<f64>,
    pub b: Vec<f64>,
    pub normal_rows: Vec<usize>,
}

/// `max s  s.t. Uλ ≥ 0, λ = λ(q, s v, τ)` (the optimisation under Fig. 4.8). At fixed
/// torque λ of (5.4) is exactly quadratic in the velocity (`C̄q̇` and `Ȧq̇` are), so
/// `Uλ = a + b s²` and the problem is a linear program in `σ = s²`, solved with Clarabel.
pub fn liftoff_speed(
    model: &Model,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    direction: &[f64],
    tau: &[f64],
) -> Result<LiftoffSpeed, SimError> {
    check_finite("direction", direction)?;
    if direction.len() != model.nq() {
        return Err(bad("direction", format!("expected {} entries", model.nq())));
    }
    let mut data = Data::new(model);
    let mut lam = |s: f64| -> Result<DVector<f64>, SimError> {
        let qd: Vec<f64> = direction.iter().map(|v| s * v).collect();
        forward_dynamics(model, &mut data, terrain, mode, q, &qd, tau, None)?;
        Ok(data.lambda.clone())
    };
    let l0 = lam(0.0)?;
    let l1 = lam(1.0)?;
    data.prepare_geometry(model, terrain, mode, q, &vec![0.0; q.len()])?;
    let rows = normal_rows(&data);
    // U = −1 on normal rows (4.76)
    let a: Vec<f64> = rows.iter().map(|&i| -l0[i]).collect();
    let b: Vec<f64> = rows.iter().map(|&i| -(l1[i] - l0[i])).collect();
    if let Some(i) = a.iter().position(|&v| v < -1e-9) {
        return Err(bad(
            "q",
            format!(
                "contact row {} already pulls at rest (Uλ = {:.3e})",
                rows[i], a[i]
            ),
        ));
    }
    // LP: min −σ s.t. a_i + b_i σ ≥ 0, 0 ≤ σ ≤ σ_cap
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{
        DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
    };
    let sigma_cap = 1.0e8;
    let m = rows.len() + 2;
    let mut acol = Vec::with_capacity(m);
    let mut bvec = Vec::with_capacity(m);
    // scale each row to unit coefficient so the LP is well conditioned
    for (ai, bi) in a.iter().zip(&b) {
        let s = bi.abs().max(ai.abs()).max(1e-300);
        acol.push(-bi / s);
        bvec.push(ai.max(0.0) / s);
    }
    acol.push(-1.0);
    bvec.push(0.0);
    acol.push(1.0 / sigma_cap);
    bvec.push(1.0);
    let amat = CscMatrix::new(m, 1, vec![0, m], (0..m).collect(), acol);
    let p = CscMatrix::<f64>::zeros((1, 1));
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-12)
        .tol_gap_rel(1e-12)
        .tol_feas(1e-12)
        .build()
        .expect("valid settings");
    let cones = [SupportedConeT::NonnegativeConeT(m)];
    let mut solver = DefaultSolver::new(&p, &[-1.0], &amat, &bvec, &cones, settings)
        .map_err(|e| bad("lp", format!("{e:?}")))?;
    solver.solve();
    if !matches!(
        solver.solution.status,
        SolverStatus::Solved | SolverStatus::AlmostSolved
    ) {
        return Err(bad("lp", format!("Clarabel: {:?}", solver.solution.status)));
    }
    let sigma = solver.solution.x[0].max(0.0);
    if sigma > 0.5 * sigma_cap {
        return Ok(LiftoffSpeed {
            speed: None,
            binding_row: None,
            a,
            b,
            normal_rows: rows,
        });
    }
    let binding = (0..rows.len())
        .filter(|&i| b[i] < 0.0)
        .min_by(|&i, &j| (a[i] / -b[i]).total_cmp(&(a[j] / -b[j])))
        .map(|i| rows[i]);
    Ok(LiftoffSpeed {
        speed: Some(sigma.sqrt()),
        binding_row: binding,
        a,
        b,
        normal_rows: rows,
    })
}
