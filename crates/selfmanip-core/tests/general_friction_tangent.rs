//! Exact derivatives through the general Coulomb sliding sites (`selfmanip_core::friction`,
//! "The general sliding site": a body end, a massive or multi-joint leg's toe, folded into the
//! dynamics solve as the nonsymmetric system `K' = [M̄ (A + B)ᵀ; A 0]`, thesis (5.2) with
//! `f^fr = −Bᵀλ`) against an independent route: central finite differences of
//! `forward_dynamics` itself in the sliding mode,
//! `∂z/∂x_k ≈ (z(x + h e_k) − z(x − h e_k)) / 2h` (`h = 1e-5`: truncation `O(h²)` ≈ 1e-10,
//! rounding `ε|z|/h` ≈ 1e-11 |z| — the light legs' random states reach `|q̈|` of 3000, where
//! `h = 1e-6` rounds to 1e-6 of a small block), to 1e-6 relative to the largest entry of each
//! block of `∂(q̈, λ)/∂(q, q̇, Υ)`.
//!
//! The sliding directions are fixed (`SlideDirection::Fixed`, the engine's path along a
//! sliding segment) at random signs, and also left to the instantaneous law `σ = sign v_t`
//! where every `|v_t|` is far above the step; states are seeded random ones (the velocity
//! need not satisfy the constraints: (5.3)–(5.4) are defined for any `q̇`), skipped only where
//! a side of a difference is singular or Painlevé-inconsistent (a typed error there). Systems:
//! (a) a block sliding on its two bottom corners, on level ground and on an incline; (b) a body
//! with a massive leg whose toe slides, with a body end sliding too, and beside it a massless
//! single-joint leg whose sliding toe is resolved by its statics (both kinds in one solve);
//! (c) two-joint legs — both links massive, and a massive hip link with a massless sprung
//! knee (a massless joint pinned by the sliding row, inside the fold). Also the
//! Jacobian-times-matrix product along random directions and the body mass (differences of
//! rebuilt models), and the plastic impact into a mode with general sliding sites, which carries
//! no kinetic friction (Assumption 5.9) and so is differentiated as before.
mod common;

use common::dynamics_fd::{dynamics_jacobian_error, rel_err};
use common::{coulomb_body, sliding, test_robot};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use selfmanip_core::description::SpringDescription;
use selfmanip_core::friction::SlideDirection;
use selfmanip_core::tangent::{
    dynamics_jacobian, dynamics_jvp, plastic_impact_jacobian, BodyParameter, FlowDirections,
    TangentError,
};
use selfmanip_core::{
    forward_dynamics, plastic_impact, ContactKind, ContactMode, Data, FlatGround, GroundPlane,
    Model, Terrain,
};

const H: f64 = 1e-5;
const TOL: f64 = 1e-6;

/// A `w × h` block (mass `m`) on its bottom corners `left`, `right`, sticking and sliding
/// with `mu`.
fn block(m: f64, mu: f64) -> Model {
    let (w, h) = (0.1, 0.05);
    let corners = [("left", -w / 2.0, h / 2.0), ("right", w / 2.0, h / 2.0)];
    coulomb_body(m, m * (w * w + h * h) / 12.0, &corners, mu, mu)
}

/// `tests/data/robots/legged_general_sliding.toml` with a body of `body_mass` kg: contacts
/// `toe` (a massive leg's, general), `rear` and `front` (body ends, general), and `stub` (a
/// massless single-joint leg's toe: its statics, not the fold). `q = [θ_leg, θ_stub, x, z, φ]`.
fn legged(body_mass: f64) -> Model {
    let mut description = test_robot("legged_general_sliding.toml");
    description.body.mass_kg = body_mass;
    description.build().unwrap()
}

/// `tests/data/robots/two_joint_leg.toml`: a two-joint leg with a Coulomb toe, both links
/// massive, or (`sprung`) a massive hip link and a massless knee link with a spring–damper.
/// `q = [θ_hip, θ_knee, x, z, φ]`.
fn two_joint(sprung: bool) -> Model {
    let mut description = test_robot("two_joint_leg.toml");
    if sprung {
        let knee = &mut description.legs[0].links[1];
        (knee.mass_kg, knee.inertia_kg_m2, knee.com_m) = (0.0, 0.0, None);
        knee.spring = Some(SpringDescription {
            stiffness_n_m_per_rad: 120.0,
            cubic_stiffness_n_m_per_rad3: 0.0,
            damping_n_m_s_per_rad: 0.4,
            rest_angle_rad: 0.5,
        });
    }
    description.build().unwrap()
}

/// One evaluation's inputs: the mode, its fixed sliding directions (empty: the
/// instantaneous law) and the terrain.
struct Case<'a> {
    model: &'a Model,
    terrain: &'a dyn Terrain,
    mode: ContactMode,
    dirs: Vec<(usize, SlideDirection)>,
}

impl Case<'_> {
    /// `f` (the dynamics or its Jacobian) at `(q, q̇, Υ)` in the case's mode on its terrain,
    /// with its sliding directions and no prescribed free-joint motion, and the data it left.
    fn solve<T, E>(
        &self,
        f: impl Fn(
            &Model,
            &mut Data,
            &dyn Terrain,
            ContactMode,
            &[f64],
            &[f64],
            &[f64],
            Option<&[f64]>,
        ) -> Result<T, E>,
        (q, qd, tau): (&[f64], &[f64], &[f64]),
    ) -> (Data, Result<T, E>) {
        let mut data = Data::new(self.model);
        data.set_slide_directions(&self.dirs);
        let solved = f(
            self.model,
            &mut data,
            self.terrain,
            self.mode,
            q,
            qd,
            tau,
            None,
        );
        (data, solved)
    }

    /// `(q̈, λ)` at a state with the case's directions, or `None` (a typed error: singular,
    /// Painlevé-inconsistent).
    fn eval(&self, q: &[f64], qd: &[f64], tau: &[f64]) -> Option<(Vec<f64>, Vec<f64>)> {
        let (data, solved) = self.solve(forward_dynamics, (q, qd, tau));
        solved.ok()?;
        Some((
            data.qdd.as_slice().to_vec(),
            data.lambda.as_slice().to_vec(),
        ))
    }

    /// The worst relative error of the exact Jacobian against central differences at one
    /// state, with the number of general sites folded there; `None` where a side is not
    /// defined.
    fn check(&self, q: &[f64], qd: &[f64], tau: &[f64]) -> Option<(f64, usize)> {
        let (data, jac) = self.solve(dynamics_jacobian, (q, qd, tau));
        let jac = match jac {
            Ok(j) => j,
            Err(TangentError::Core(_)) => return None,
            Err(e) => panic!("{}: {e}", self.model.name),
        };
        let general = data
            .sliding
            .iter()
            .filter(|s| s.general && s.coef != 0.0 && s.held.is_none())
            .count();
        // the instantaneous law: every sliding speed far above the step
        if self.dirs.is_empty() && data.sliding.iter().any(|s| s.v_t.abs() < 1e-3) {
            return None;
        }
        // Richardson's extrapolation of central differences at h and h/2
        let steps = [(H, -1.0 / 3.0), (H / 2.0, 4.0 / 3.0)];
        let worst = dynamics_jacobian_error(&jac, (q, qd, tau), &steps, |q, qd, tau| {
            self.eval(q, qd, tau)
        })?;
        Some((worst, general))
    }
}

fn uniform(r: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * r.gen::<f64>()
}

/// Checks `count` seeded states of `case` (joint angles about `joint_mid`, the body near
/// level); returns the states checked, the worst error and the most general sites folded.
fn check_states(
    case: &mut Case,
    fixed: &[usize],
    joint_mid: &[f64],
    count: usize,
    seed: u64,
) -> (usize, f64, usize) {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    let model = case.model;
    let (nq, n) = (model.nq(), model.n_joints());
    let (mut checked, mut worst, mut most) = (0, 0.0_f64, 0);
    for _ in 0..count {
        let mut q: Vec<f64> = joint_mid
            .iter()
            .map(|m| m + uniform(&mut r, -0.4, 0.4))
            .collect();
        q.extend([uniform(&mut r, -0.2, 0.2), uniform(&mut r, -0.1, 0.1)]);
        q.push(uniform(&mut r, -0.3, 0.3));
        let qd: Vec<f64> = (0..nq).map(|_| uniform(&mut r, -1.5, 1.5)).collect();
        let tau: Vec<f64> = (0..n).map(|_| uniform(&mut r, -3.0, 3.0)).collect();
        case.dirs = fixed
            .iter()
            .map(|&k| {
                let s = if r.gen::<bool>() { 1.0 } else { -1.0 };
                (k, SlideDirection::Fixed(s))
            })
            .collect();
        if let Some((e, g)) = case.check(&q, &qd, &tau) {
            assert!(
                e < TOL,
                "{} in {:?} at q {q:?}, q̇ {qd:?}, τ {tau:?}: relative error {e:e}",
                model.name,
                case.mode
            );
            checked += 1;
            worst = worst.max(e);
            most = most.max(g);
        }
    }
    (checked, worst, most)
}

/// (a) A block sliding on its two corners (two general sites folded together), on level
/// ground and on a plane tilted by 0.3 rad, with fixed directions and with the
/// instantaneous law.
#[test]
fn block_sliding_on_two_corners_jacobian_equals_finite_differences() {
    let model = block(2.0, 0.3);
    let tilted = GroundPlane {
        point_m: [0.0, 0.0],
        normal_into_ground: [0.3_f64.sin(), 0.3_f64.cos()],
    };
    let terrains: [&dyn Terrain; 2] = [&FlatGround, &tilted];
    for (t, terrain) in terrains.into_iter().enumerate() {
        for (fixed, seed) in [(vec![0, 1], 1), (vec![], 2)] {
            let mut case = Case {
                model: &model,
                terrain,
                mode: sliding(&[0, 1]),
                dirs: Vec::new(),
            };
            let (n, e, most) = check_states(&mut case, &fixed, &[], 12, seed + 10 * t as u64);
            eprintln!("block, terrain {t}, fixed {fixed:?}: {n} states, worst {e:e}");
            assert!(n >= 8, "only {n} of 12 states checked");
            assert_eq!(most, 2, "both corners fold");
        }
    }
}

/// [`check_states`] on flat ground in `mode` at 12 states (seed `seed`) around `joint_mid`,
/// the sites `slides` at the sliding direction of each state: at least 6 states checked, and
/// `want_general` sites in the general (folded) law at most.
fn check_on_flat(
    model: &Model,
    mode: ContactMode,
    slides: &[usize],
    joint_mid: &[f64],
    seed: u64,
    want_general: usize,
) {
    let terrain = &FlatGround;
    let dirs = Vec::new();
    let mut case = Case {
        model,
        terrain,
        mode,
        dirs,
    };
    let (n, e, most) = check_states(&mut case, slides, joint_mid, 12, seed);
    eprintln!("{mode:?}, sliding {slides:?}: {n} states, worst {e:e}");
    assert!(n >= 6, "only {n} of 12 states checked");
    assert_eq!(most, want_general);
}

/// (b) A massive leg's sliding toe alone, with a body end sliding, with a body end
/// sticking, and beside a massless leg's sliding toe (statics) in one solve.
#[test]
fn massive_legs_sliding_toe_jacobian_equals_finite_differences() {
    let model = legged(3.0);
    // θ_leg, θ_stub about hanging down
    let mid = [0.0, 0.0];
    for (slides, stick, want_general, seed) in [
        (vec![0], vec![], 1, 3),
        (vec![0, 1], vec![], 2, 4),
        (vec![0], vec![2], 1, 5),
        (vec![0, 3], vec![], 1, 6),
        (vec![0, 1, 3], vec![], 2, 7),
    ] {
        let mode = stick
            .iter()
            .fold(sliding(&slides), |m, &k| m.with(k, ContactKind::Stick));
        check_on_flat(&model, mode, &slides, &mid, seed, want_general);
    }
}

/// (c) Two-joint legs sliding on their toes (with the rear body end sliding too): both links
/// massive, and a massless sprung knee pinned by the toe's normal row inside the fold.
#[test]
fn two_joint_legs_sliding_toe_jacobian_equals_finite_differences() {
    for sprung in [false, true] {
        let model = two_joint(sprung);
        for (slides, want_general, seed) in [(vec![0], 1, 8), (vec![0, 1], 2, 9)] {
            // the shank well away from vertical (where a massless knee's toe row loses its
            // lever, Lemma 5.1) and from the cone edge through the knee (a wedge)
            let mid = if sprung { [0.3, 1.2] } else { [0.3, 0.5] };
            check_on_flat(&model, sliding(&slides), &slides, &mid, seed, want_general);
        }
    }
}

/// The Jacobian-times-matrix product (`dynamics_jvp`, the path the hybrid engine's
/// variational equations take) through the fold against central differences of
/// `forward_dynamics` along each column's direction `(δq, δq̇, δΥ)`, and its body-mass column
/// (`K' δz = [−∂M̄/∂m_b q̈ − ∂N̄/∂m_b; 0]` with the folded `K'`) against differences over
/// rebuilt models.
#[test]
fn jvp_and_body_mass_derivative_through_the_fold() {
    let (m_b, dm) = (3.0, 1e-5);
    let model = legged(m_b);
    let mode = sliding(&[0, 1]);
    let dirs = vec![
        (0, SlideDirection::Fixed(-1.0)),
        (1, SlideDirection::Fixed(-1.0)),
    ];
    let q = [0.1, 0.0, 0.0, 0.0, 0.05];
    let qd = [0.4, 0.0, 0.6, -0.1, 0.2];
    let tau = [1.5, 0.0];
    let solve = |model: &Model, q: &[f64], qd: &[f64], tau: &[f64]| {
        let mut data = Data::new(model);
        data.set_slide_directions(&dirs);
        forward_dynamics(model, &mut data, &FlatGround, mode, q, qd, tau, None).unwrap();
        data
    };
    let mut data = solve(&model, &q, &qd, &tau);
    assert!(data.sliding.iter().all(|s| s.general && s.force_t != 0.0));
    let (nq, n) = (model.nq(), model.n_joints());
    let mut r = ChaCha8Rng::seed_from_u64(11);
    let dq = DMatrix::from_fn(nq, 3, |_, _| uniform(&mut r, -1.0, 1.0));
    let dqd = DMatrix::from_fn(nq, 3, |_, _| uniform(&mut r, -1.0, 1.0));
    let dtau = DMatrix::from_fn(n, 3, |_, _| uniform(&mut r, -1.0, 1.0));
    let body = [None, None, Some(BodyParameter::Mass)];
    let (dqdd, _) = dynamics_jvp(
        &model,
        &mut data,
        &qd,
        &FlowDirections {
            dq: &dq,
            dqd: &dqd,
            dtau: &dtau,
            body: &body,
            force: None,
        },
    )
    .unwrap();
    let along = |h: f64, col: usize| {
        let x = |v: &[f64], d: &DMatrix<f64>| -> Vec<f64> {
            v.iter()
                .enumerate()
                .map(|(i, a)| a + h * d[(i, col)])
                .collect()
        };
        solve(&model, &x(&q, &dq), &x(&qd, &dqd), &x(&tau, &dtau)).qdd
    };
    let d_mass = (solve(&legged(m_b + dm), &q, &qd, &tau).qdd
        - solve(&legged(m_b - dm), &q, &qd, &tau).qdd)
        / (2.0 * dm);
    for col in 0..3 {
        let mut want = (along(H, col) - along(-H, col)) / (2.0 * H);
        if col == 2 {
            want += &d_mass;
        }
        let err = (dqdd.column(col) - &want).amax() / want.amax().max(1.0);
        assert!(
            err < TOL,
            "column {col}: {err:e}\n{}\n{want}",
            dqdd.column(col)
        );
    }
}

/// The plastic impact into a mode with general sliding sites carries no kinetic friction
/// (Assumption 5.9): its Jacobian is formed (no friction term) and equals central
/// differences of `plastic_impact`.
#[test]
fn impact_into_a_mode_with_general_sliding_sites_is_differentiated() {
    let model = legged(3.0);
    let mode = sliding(&[0, 1]).with(2, ContactKind::Stick);
    let q = [0.2, 0.0, 0.0, 0.0, 0.05];
    let qd = [0.5, 0.3, 0.6, 0.8, 0.2];
    let mut data = Data::new(&model);
    let jac = plastic_impact_jacobian(&model, &mut data, &FlatGround, mode, &q, &qd).unwrap();
    assert!(data.sliding.iter().any(|s| s.general));
    let nq = model.nq();
    let imp = |q: &[f64], qd: &[f64]| {
        let mut d = Data::new(&model);
        plastic_impact(&model, &mut d, &FlatGround, mode, q, qd)
            .unwrap()
            .qd_plus
    };
    let (mut fq, mut fv) = (DMatrix::zeros(nq, nq), DMatrix::zeros(nq, nq));
    for k in 0..nq {
        let (mut qp, mut qm) = (q.to_vec(), q.to_vec());
        qp[k] += H;
        qm[k] -= H;
        fq.set_column(k, &((imp(&qp, &qd) - imp(&qm, &qd)) / (2.0 * H)));
        let (mut vp, mut vm) = (qd.to_vec(), qd.to_vec());
        vp[k] += H;
        vm[k] -= H;
        fv.set_column(k, &((imp(&q, &vp) - imp(&q, &vm)) / (2.0 * H)));
    }
    assert!(rel_err(&jac.dqd_plus.dq, &fq) < TOL);
    assert!(rel_err(&jac.dqd_plus.dqd, &fv) < TOL);
}
