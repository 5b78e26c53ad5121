//! Robots and modes shared by the core's integration tests. Frames (docs/conventions.md):
//! NED, z down, `q = [θ…, x, z, φ]`, a body point `p` at `X + R(φ) p`.
#![allow(dead_code)]
pub mod dynamics_fd;
use selfmanip_core::{
    forward_dynamics, ContactKind, ContactMode, CoreError, Data, FlatGround, Model,
    RobotDescription,
};

pub const G: f64 = 9.81;

/// The model of a robot description in TOML (which the test wrote, so it must be valid).
pub fn robot(toml: &str) -> Model {
    RobotDescription::from_toml_str(toml)
        .unwrap()
        .build()
        .unwrap()
}

/// A robot of the workspace's `tests/data/robots`.
pub fn test_robot(name: &str) -> RobotDescription {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/robots");
    RobotDescription::from_file(&dir.join(name)).unwrap()
}

/// A robot `name`: a 3 kg body (0.05 kg m²) with one leg `leg` hinged at `(hip_x_m, 0)` in
/// its frame, the rest of the description — the leg's `[[legs.links]]` and the
/// `[[contacts]]` tables — in TOML.
pub fn one_leg_body(name: &str, hip_x_m: f64, links_and_contacts: &str) -> Model {
    robot(&format!(
        "name = \"{name}\"\ngravity_m_s2 = {G}\n[body]\nmass_kg = 3.0\ninertia_kg_m2 = 0.05\n\
         [[legs]]\nname = \"leg\"\nhip_m = [{hip_x_m:?}, 0.0]\n{links_and_contacts}"
    ))
}

/// A rigid body without legs, with point contacts `(name, x, z)` in its frame, each
/// sticking with `mu` and sliding with the kinetic coefficient `mu_k`.
pub fn coulomb_body(
    mass_kg: f64,
    inertia_kg_m2: f64,
    points: &[(&str, f64, f64)],
    mu: f64,
    mu_k: f64,
) -> Model {
    let mut text = format!(
        "name = \"body\"\ngravity_m_s2 = {G}\nlegs = []\n[body]\nmass_kg = {mass_kg}\ninertia_kg_m2 = {inertia_kg_m2}\n"
    );
    for (name, x, z) in points {
        text += &format!(
            "[[contacts]]\nname = \"{name}\"\nshape = {{ kind = \"point\", position_m = [{x}, {z}] }}\nfriction = {{ kind = \"sticking\", mu = {mu}, mu_kinetic = {mu_k} }}\n"
        );
    }
    robot(&text)
}

/// The mode with `contacts` sliding and no other contact.
pub fn sliding(contacts: &[usize]) -> ContactMode {
    contacts
        .iter()
        .fold(ContactMode::FLIGHT, |m, &k| m.with(k, ContactKind::Slide))
}

/// `forward_dynamics` on flat ground with `contacts` sliding and no other contact, under the
/// joint torques `tau`, with no prescribed free-joint motion.
pub fn slide_on_flat(
    model: &Model,
    data: &mut Data,
    contacts: &[usize],
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Result<(), CoreError> {
    forward_dynamics(
        model,
        data,
        &FlatGround,
        sliding(contacts),
        q,
        qd,
        tau,
        None,
    )
}
