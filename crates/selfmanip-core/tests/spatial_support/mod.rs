//! Shared set-up of the spatial tests: the shipped quadruped with chosen leg masses, a
//! ball, RHex's legs by name, random states, a model with its workspace, and the report of
//! the worst errors.
#![allow(dead_code)]
use nalgebra::{DVector, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use selfmanip_core::spatial::rhex::{PAIRS, SIDES};
use selfmanip_core::spatial::{
    forward_dynamics, integrate, neutral, BaseKind, PointContact, SpatialData, SpatialModel,
    SpatialResult,
};

pub const QUADRUPED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/urdf/quadruped12.urdf"
);

/// A uniform ball of mass 1.5 kg and radius 0.1 m (`I = k m r²`, `k = 2/5`).
pub const BALL: &str = r#"<robot name="ball">
  <link name="ball"><inertial><origin xyz="0 0 0"/><mass value="1.5"/><inertia ixx="0.006" ixy="0" ixz="0" iyy="0.006" iyz="0" izz="0.006"/></inertial></link>
</robot>"#;

pub const FEET: [&str; 4] = ["FL_foot", "FR_foot", "HL_foot", "HR_foot"];
pub const KNEES: [&str; 4] = ["FL_knee", "FR_knee", "HL_knee", "HR_knee"];

/// The quadruped with every link whose name ends in one of `suffixes` scaled in mass and
/// rotational inertia by `scale` (0: massless).
pub fn quadruped_scaled(suffixes: &[&str], scale: f64) -> SpatialModel {
    quadruped_scaled_on(BaseKind::FreeFlyer, suffixes, scale)
}

/// [`quadruped_scaled`] on the base `base`.
pub fn quadruped_scaled_on(base: BaseKind, suffixes: &[&str], scale: f64) -> SpatialModel {
    let mut robot = urdf_rs::read_file(QUADRUPED).unwrap();
    for link in &mut robot.links {
        if suffixes.iter().any(|s| link.name.ends_with(s)) {
            link.inertial.mass.value *= scale;
            let i = &mut link.inertial.inertia;
            for x in [
                &mut i.ixx, &mut i.ixy, &mut i.ixz, &mut i.iyy, &mut i.iyz, &mut i.izz,
            ] {
                *x *= scale;
            }
        }
    }
    SpatialModel::from_urdf_robot(&robot, base, None).unwrap()
}

pub fn quadruped() -> SpatialModel {
    quadruped_scaled(&[], 1.0)
}

/// The quadruped with massless shins (and the feet fixed to them).
pub fn quadruped_massless_shins() -> SpatialModel {
    quadruped_scaled(&["_shin", "_foot"], 0.0)
}

/// RHex's six legs by name, `PAIRS × SIDES` in order.
pub fn rhex_legs() -> Vec<String> {
    PAIRS
        .iter()
        .flat_map(|pair| SIDES.iter().map(move |side| format!("{pair}_{side}")))
        .collect()
}

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Prints `what` and the worst error of each check (`names[k]`: `worst[k]`), and asserts
/// every one below `tol`.
pub fn assert_worst(what: &str, names: &[&str], worst: &[f64], tol: f64) {
    let each: Vec<String> = names
        .iter()
        .zip(worst)
        .map(|(name, w)| format!("{name} {w:.2e}"))
        .collect();
    eprintln!("{what} {}", each.join(", "));
    assert!(worst.iter().all(|&w| w < tol), "{what} {worst:?}");
}

/// The set-up most tests open with: `model`, its workspace and a generator seeded `seed`.
pub fn setup(model: SpatialModel, seed: u64) -> (SpatialModel, SpatialData, ChaCha8Rng) {
    let data = SpatialData::new(&model);
    (model, data, rng(seed))
}

/// A random configuration: base within 1 m of the origin at a random orientation, joints in
/// (−1.5, 1.5) rad.
pub fn random_q(model: &SpatialModel, rng: &mut ChaCha8Rng) -> DVector<f64> {
    let mut q = neutral(model);
    for x in q.iter_mut().take(3) {
        *x = rng.gen_range(-1.0..1.0);
    }
    let axis = Vector3::new(
        rng.gen_range(-1.0..1.0),
        rng.gen_range(-1.0..1.0),
        rng.gen_range(-1.0..1.0),
    );
    let r = UnitQuaternion::from_scaled_axis(axis * 2.0);
    q.as_mut_slice()[3..7].copy_from_slice(&[r.i, r.j, r.k, r.w]);
    for x in q.iter_mut().skip(7) {
        *x = rng.gen_range(-1.5..1.5);
    }
    q
}

/// A random motion `(q, v)`: a configuration by [`random_q`], then rates within `scale`.
pub fn random_motion(
    model: &SpatialModel,
    scale: f64,
    rng: &mut ChaCha8Rng,
) -> (DVector<f64>, DVector<f64>) {
    let q = random_q(model, rng);
    (q, random_vector(model.nv, scale, rng))
}

/// `q ⊕ s v`: the configuration reached from `q` at the rates `v` after `s`.
pub fn along(model: &SpatialModel, q: &DVector<f64>, v: &DVector<f64>, s: f64) -> DVector<f64> {
    integrate(model, q.as_slice(), (v * s).as_slice()).unwrap()
}

pub fn random_vector(n: usize, scale: f64, rng: &mut ChaCha8Rng) -> DVector<f64> {
    DVector::from_fn(n, |_, _| rng.gen_range(-scale..scale))
}

/// The standing pose of the statics test: base at height `h`, level, legs bent by `theta`
/// (hip flexion `θ`, knee `−2θ`), feet below the flexion axes.
pub fn standing_q(model: &SpatialModel, h: f64, theta: f64) -> DVector<f64> {
    let mut q = neutral(model);
    q[2] = h;
    for leg in 0..4 {
        q[7 + 3 * leg + 1] = theta;
        q[7 + 3 * leg + 2] = -2.0 * theta;
    }
    q
}

/// A random state of the quadruped: `(q, v, τ)` with rates in (−2, 2) and torques in (−5, 5).
pub fn random_state(
    model: &SpatialModel,
    rng: &mut ChaCha8Rng,
) -> (DVector<f64>, DVector<f64>, DVector<f64>) {
    let q = random_q(model, rng);
    (
        q,
        random_vector(model.nv, 2.0, rng),
        random_vector(model.nv, 5.0, rng),
    )
}

/// The four feet as point contacts, each with friction or not.
pub fn feet(model: &SpatialModel, friction: [bool; 4]) -> Vec<PointContact> {
    FEET.iter()
        .zip(friction)
        .map(|(f, mu)| PointContact::new(model, f, mu).unwrap())
        .collect()
}

/// [`forward_dynamics`] at the state `(q, v, τ)`.
pub fn dynamics_at(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    (q, v, tau): (&DVector<f64>, &DVector<f64>, &DVector<f64>),
) -> SpatialResult<()> {
    forward_dynamics(
        model,
        data,
        contacts,
        q.as_slice(),
        v.as_slice(),
        tau.as_slice(),
    )
}

/// The residuals of the last [`forward_dynamics`] in `data` with torques `tau`, each relative
/// to the size of the terms it sums (round-off): the constraint `|A q̈ + Ȧq̇|` against
/// `|A||q̈|` and `|Ȧq̇|`, the equations of motion `|M q̈ + h − τ − Aᵀλ|` against `|Aᵀ||λ|`
/// and `|τ|`.
pub fn dynamics_residuals(data: &SpatialData, tau: &DVector<f64>) -> (f64, f64) {
    let scale = (data.A.abs() * data.qdd.abs())
        .amax()
        .max(data.A_drift.amax())
        .max(1.0);
    let acc = (&data.A * &data.qdd + &data.A_drift).amax() / scale;
    let eom = &data.M * &data.qdd + &data.h - tau - data.A.transpose() * &data.lam;
    let forces = (data.A.transpose().abs() * data.lam.abs()).amax();
    (acc, eom.amax() / forces.max(tau.amax()).max(1.0))
}
