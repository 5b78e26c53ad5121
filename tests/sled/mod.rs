//! The sled of the kinetic-friction tests: a body resting on two frictionless skids 5 cm
//! below its centre, and a massless one-joint leg at its centre whose toe touches the ground
//! ahead of the hip, sticking with `μ = MU` or sliding with Coulomb friction `μ_k = MU`
//! (`tests/kinetic_friction.rs` for the force law, `tests/sensitivity_params.rs` for its
//! derivatives).
#![allow(dead_code)]
use selfmanip::core::{Model, RobotDescription};

pub const G: f64 = 9.81;
pub const M: f64 = 3.0;
pub const LEG: f64 = 0.12;
pub const HIP_HEIGHT: f64 = 0.05;
pub const MU: f64 = 0.8;

/// The sled.
pub fn sled() -> Model {
    sled_with("")
}

/// The sled, with `spring` (a TOML inline table, or "") on the leg's joint.
pub fn sled_with(spring: &str) -> Model {
    let text = format!(
        r#"
name = "sled"
gravity_m_s2 = {G}
[body]
mass_kg = {M}
inertia_kg_m2 = 0.05
[[legs]]
name = "leg"
hip_m = [0.0, 0.0]
[[legs.links]]
length_m = {LEG}
axis = "-y"
{spring}
[[contacts]]
name = "toe"
leg = "leg"
shape = {{ kind = "point", position_m = [0.0, {LEG}] }}
friction = {{ kind = "sticking", mu = {MU}, mu_kinetic = {MU} }}
[[contacts]]
name = "front_skid"
shape = {{ kind = "point", position_m = [0.2, {HIP_HEIGHT}] }}
friction = {{ kind = "sliding" }}
[[contacts]]
name = "rear_skid"
shape = {{ kind = "point", position_m = [-0.2, {HIP_HEIGHT}] }}
friction = {{ kind = "sliding" }}
"#
    );
    RobotDescription::from_toml_str(&text)
        .unwrap()
        .build()
        .unwrap()
}
