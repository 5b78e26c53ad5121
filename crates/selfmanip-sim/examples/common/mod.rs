//! The examples' robots at their start, and parameters by name from the `SET` variable:
//! shared by the examples and the sim's tests (which include this file by path).
#![allow(dead_code)]
use selfmanip_core::RobotDescription;
use selfmanip_sim::Scenario;
use std::error::Error;
use std::path::{Path, PathBuf};

/// A file of `examples/data`.
pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/data")
        .join(name)
}

/// Hip angle `a` of the legs' landing pose: hip `a`, knee `−2a`, so the foot stands under
/// the hip, `2 L cos a` below it (links of `L = 0.2` m).
const LANDING_HIP_RAD: f64 = 0.5;

/// The hopper of `data/hopper.toml` dropped level, its foot `drop_m` above the ground and
/// its leg at the landing pose.
pub fn dropped_hopper(drop_m: f64) -> Result<Scenario, Box<dyn Error>> {
    let robot = RobotDescription::from_file(&data("hopper.toml"))?;
    let a = LANDING_HIP_RAD;
    let q0 = vec![a, -2.0 * a, 0.0, -(drop_m + 0.4 * a.cos()), 0.0];
    Ok(Scenario::new(robot, q0))
}

/// The quadruped of `data/quadruped.toml` dropped from `drop_m` (feet above the ground) at
/// pitch `phi`, both legs at the landing pose, its contacts labelled `fore_foot`,
/// `hind_foot`.
pub fn dropped_quadruped(drop_m: f64, phi: f64) -> Result<Scenario, Box<dyn Error>> {
    let robot = RobotDescription::from_file(&data("quadruped.toml"))?;
    let a = LANDING_HIP_RAD;
    let q0 = vec![
        a,
        -2.0 * a,
        a,
        -2.0 * a,
        0.0,
        -(drop_m + 0.4 * a.cos()),
        phi,
    ];
    let mut s = Scenario::new(robot, q0);
    s.options.labels = Some(vec!["fore_foot".into(), "hind_foot".into()]);
    Ok(s)
}

/// `SET="kp_push=90,t_compress=0.03"`: sets each parameter by name (see docs/behaviours.md).
pub fn set_from_env(s: &mut Scenario) -> Result<(), Box<dyn Error>> {
    if let Ok(set) = std::env::var("SET") {
        for item in set.split(',').filter(|i| !i.is_empty()) {
            let (name, value) = item.split_once('=').ok_or("SET: name=value")?;
            s.set(name.trim(), value.trim().parse::<f64>()?)?;
        }
    }
    Ok(())
}
