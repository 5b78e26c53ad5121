//! The sled of the kinetic-friction tests: a body resting on two frictionless skids 5 cm
//! below its centre, and a massless one-joint leg at its centre whose toe touches the ground
//! ahead of the hip, sticking with `μ = MU` or sliding with Coulomb friction `μ_k = MU`
//! (`tests/kinetic_friction.rs` for the force law, `tests/sensitivity_params.rs` for its
//! derivatives).
#![allow(dead_code)]
use selfmanip::core::description::{FrictionDescription, ShapeDescription, SpringDescription};
use selfmanip::core::{
    forward_dynamics, ContactKind, ContactMode, CoreError, Data, FlatGround, Model,
    RobotDescription, Terrain,
};

pub const G: f64 = 9.81;
pub const M: f64 = 3.0;
pub const LEG: f64 = 0.12;
pub const HIP_HEIGHT: f64 = 0.05;
pub const MU: f64 = 0.8;

/// The sled's description, `tests/data/robots/sled.toml`, whose numbers are checked against
/// the constants the closed forms use.
pub fn sled_description() -> RobotDescription {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/robots/sled.toml");
    let d = RobotDescription::from_file(std::path::Path::new(path)).unwrap();
    let link = &d.legs[0].links[0];
    assert_eq!((d.gravity_m_s2, d.body.mass_kg), (G, M));
    assert_eq!((link.length_m, link.mass_kg), (LEG, 0.0));
    assert_eq!(
        d.contacts[0].friction,
        FrictionDescription::Sticking {
            mu: Some(MU),
            mu_kinetic: Some(MU)
        }
    );
    for (skid, x) in [(&d.contacts[1], 0.2), (&d.contacts[2], -0.2)] {
        let expected = ShapeDescription::Point {
            position_m: [x, HIP_HEIGHT],
        };
        assert_eq!(skid.shape, expected, "{}", skid.name);
    }
    d
}

/// The sled.
pub fn sled() -> Model {
    sled_description().build().unwrap()
}

/// The sled, with `spring` on the leg's joint.
pub fn sled_with(spring: SpringDescription) -> Model {
    let mut d = sled_description();
    d.legs[0].links[0].spring = Some(spring);
    d.build().unwrap()
}

/// The leg angle that puts the toe on the ground, ahead of the hip (`θ < 0` about −y).
pub fn leg_angle() -> f64 {
    -(HIP_HEIGHT / LEG).acos()
}

/// The sled on its skids with the toe on the ground, sliding along `x` at `xdot`.
pub fn state(xdot: f64) -> ([f64; 4], [f64; 4]) {
    ([leg_angle(), 0.0, -HIP_HEIGHT, 0.0], [0.0, xdot, 0.0, 0.0])
}

/// The sled's forward dynamics on `terrain` in `mode` from `(q, q̇)` under the leg torque
/// `tau`, into `data`.
pub fn solve(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    mode: ContactMode,
    (q, qd): (&[f64], &[f64]),
    tau: f64,
) -> Result<(), CoreError> {
    forward_dynamics(model, data, terrain, mode, q, qd, &[tau], None)
}

/// The sled at [`state`]`(xdot)` on flat ground, the toe and both skids sliding, under the
/// leg torque `tau`: its forward dynamics.
pub fn sliding_on_flat(model: &Model, xdot: f64, tau: f64) -> Data {
    let (q, qd) = state(xdot);
    let mut data = Data::new(model);
    solve(model, &mut data, &FlatGround, all_sliding(), (&q, &qd), tau).unwrap();
    data
}

/// The toe and both skids sliding.
pub fn all_sliding() -> ContactMode {
    ContactMode::FLIGHT
        .with(0, ContactKind::Slide)
        .with(1, ContactKind::Slide)
        .with(2, ContactKind::Slide)
}
