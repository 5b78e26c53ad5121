//! Shared helpers for the cross-crate tests: robots, seeded random states, projections.
#![allow(dead_code)]
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use selfmanip::core::contact::contact_geometry;
use selfmanip::core::kinematics::Kinematics;
use selfmanip::core::{ContactMode, Data, FlatGround, Model, RobotDescription};
use selfmanip::hybrid::{EventKind, Execution, HybridOptions};
use selfmanip::rhex::{LegShape, Rhex, RhexParams};

/// The engine's small systems and fixtures, `crates/selfmanip-hybrid/tests/systems`, shared
/// as source.
#[path = "../../crates/selfmanip-hybrid/tests/systems/mod.rs"]
pub mod systems;
#[allow(unused_imports)]
pub use systems::Servos;

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// RHex with the Table 4.2 planar-leg masses (2 × 0.063 kg, 2 × 0.00046 kg m²).
pub fn rhex_massive(shape: LegShape) -> Rhex {
    Rhex::new(RhexParams {
        m_l: 0.126,
        I_l: 0.00092,
        leg_shape: shape,
        ..RhexParams::default()
    })
    .unwrap()
}

pub fn rhex_massless(shape: LegShape) -> Rhex {
    Rhex::new(RhexParams {
        leg_shape: shape,
        ..RhexParams::default()
    })
    .unwrap()
}

/// The robot of `tests/data/{file}`.
pub fn data_robot(file: &str) -> Model {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(file);
    RobotDescription::from_file(&path).unwrap().build().unwrap()
}

pub fn quadruped() -> Model {
    data_robot("quadruped.toml")
}

/// The rocking block of thesis section 5.1.4 (h = 10 cm, w = 5 cm, m = 5 kg).
pub fn rocking_block() -> Model {
    data_robot("rocking_block.toml")
}

/// A random configuration: joints in (−π, π), body pose near the origin.
pub fn random_q(model: &Model, r: &mut ChaCha8Rng) -> Vec<f64> {
    let mut q: Vec<f64> = (0..model.n_joints())
        .map(|_| r.gen_range(-3.0..3.0))
        .collect();
    q.push(r.gen_range(-0.5..0.5));
    q.push(r.gen_range(-0.5..0.0));
    q.push(r.gen_range(-0.6..0.6));
    q
}

pub fn random_vec(n: usize, scale: f64, r: &mut ChaCha8Rng) -> Vec<f64> {
    (0..n).map(|_| r.gen_range(-scale..scale)).collect()
}

/// Projects `v` onto `ker A` (Euclidean), giving a velocity consistent with the mode.
pub fn project_to_constraints(model: &Model, mode: ContactMode, q: &[f64], v: &[f64]) -> Vec<f64> {
    let mut data = Data::new(model);
    let _ = data.prepare(model, &FlatGround, mode, q, v);
    let a = data.constraints.a.clone();
    let v = DVector::from_column_slice(v);
    if a.nrows() == 0 {
        return v.as_slice().to_vec();
    }
    let pinv = a.clone().pseudo_inverse(1e-12).unwrap();
    (&v - pinv * (&a * &v)).as_slice().to_vec()
}

/// Relative error `‖a − b‖ / max(‖b‖, floor)`.
pub fn rel_err(a: &DMatrix<f64>, b: &DMatrix<f64>, floor: f64) -> f64 {
    (a - b).norm() / b.norm().max(floor)
}

pub fn rel_err_v(a: &DVector<f64>, b: &DVector<f64>, floor: f64) -> f64 {
    (a - b).norm() / b.norm().max(floor)
}

/// Every `0/1` label of a model except the over-constrained all-contact one when `c > q`.
pub fn feasible_labels(rhex: &Rhex) -> Vec<String> {
    rhex.all_labels()
        .into_iter()
        .filter(|l| rhex.mode(l).unwrap().n_rows() <= rhex.model.nq())
        .collect()
}

/// Tolerances for derivatives against central differences of whole executions (rtol 1e-12,
/// events to 1e-14 s), without free joints in the step-size control.
pub fn tight() -> HybridOptions {
    HybridOptions {
        control_free_joints: false,
        ..systems::tight()
    }
}

/// The initial state `(q, q̇)` of a drop: joints `theta`, pitch `phi`, the lowest contact
/// `gap_m` above flat ground, velocity `qd`.
pub fn drop_state(model: &Model, theta: &[f64], phi: f64, gap_m: f64, qd: &[f64]) -> Vec<f64> {
    let mut q: Vec<f64> = theta.to_vec();
    q.extend([0.0, 0.0, phi]);
    let mut kin = Kinematics::default();
    kin.compute(model, &q, &vec![0.0; model.nq()]);
    let lowest = (0..model.n_contacts())
        .map(|k| contact_geometry(model, &kin, &FlatGround, k).gap_m)
        .fold(f64::INFINITY, f64::min);
    q[model.ix_z()] += lowest - gap_m;
    q.iter().chain(qd).copied().collect()
}

/// The RHex drop of the whole-execution sensitivity tests ([`drop_state`]): hips at
/// (0.3, −0.2) rad, pitched 0.1 rad, the lowest contact 1 cm above flat ground, moving at
/// (0.4, 0.3) m/s and turning at 0.8 rad/s.
pub fn tumbling_drop(model: &Model) -> Vec<f64> {
    let mut qd = vec![0.0; model.nq()];
    qd[model.ix_x()] = 0.4;
    qd[model.ix_z()] = 0.3;
    qd[model.ix_phi()] = 0.8;
    drop_state(model, &[0.3, -0.2], 0.1, 0.01, &qd)
}

/// An execution's events as `(kind, mode after)`.
pub fn seq(e: &Execution) -> Vec<(EventKind, ContactMode)> {
    e.events.iter().map(|e| (e.kind, e.mode_after)).collect()
}

/// The weight of sample `i` of `0..=n` (`n` even) in Simpson's composite rule, without the
/// factor `h/3`: 1 at the ends, 4 at odd samples, 2 at even ones.
pub fn simpson_weight(i: usize, n: usize) -> f64 {
    if i == 0 || i == n {
        1.0
    } else if i % 2 == 1 {
        4.0
    } else {
        2.0
    }
}
