//! A user's behaviour whose motion has a speed or an acceleration that the free joints'
//! tracking law cannot difference (above `f64::MAX / 2`) is refused when it is compiled, with
//! a typed error naming the field's path, not run to the engine's nameless non-finite error.
//! The robot is the example hopper (`examples/data/hopper.toml`) under `hop.toml`, whose
//! motions read the parameters `swing_speed` and `swing_accel`.
mod common;

use common::{data, hopper};
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::expr::Scalar;
use selfmanip_sim::{SimError, Simulation};

/// The hopper under `hop.toml` with the parameter `name` set to `value`, compiled.
fn compiled_with(name: &str, value: f64) -> Result<Simulation, SimError> {
    let mut b = Behaviour::from_file(&data("hop.toml")).unwrap();
    let slot = b.parameters.get_mut(name).expect("a parameter of hop.toml");
    *slot = Scalar::Number(value);
    Simulation::new(&hopper(b, 0.3))
}

/// The field an `InvalidValue` error names.
fn field_of(r: Result<Simulation, SimError>) -> String {
    match r {
        Err(SimError::InvalidValue { field, reason }) => {
            assert!(reason.contains("f64::MAX / 2"), "{reason}");
            field
        }
        Err(e) => panic!("not an invalid value: {e}"),
        Ok(_) => panic!("compiled"),
    }
}

#[test]
fn an_acceleration_above_half_the_largest_float_names_the_first_motion_that_reads_it() {
    // `swing_accel` is read first by the hip's swing (joint program 0, phase 0)
    let field = field_of(compiled_with("swing_accel", f64::MAX));
    assert_eq!(field, "joints[0].phases[0].motion.accel_rad_s2");
}

#[test]
fn a_speed_above_half_the_largest_float_names_its_field() {
    let field = field_of(compiled_with("swing_speed", 1e308));
    assert_eq!(field, "joints[0].phases[0].motion.speed_rad_s");
}

#[test]
fn a_literal_acceleration_in_a_later_phase_names_that_phase() {
    // the knee's flight swing (program 1, phase 3) given its own acceleration
    let text = std::fs::read_to_string(data("hop.toml")).unwrap();
    let flight = "name = \"flight\"\nstart = { on = \"release\" }\nmotion = { kind = \"swing\", \
                  target_rad = \"k_land\", speed_rad_s = \"swing_speed\", accel_rad_s2 = \
                  \"swing_accel\" }";
    assert!(
        text.contains(flight),
        "hop.toml's knee flight phase changed"
    );
    let text = text.replace(flight, &flight.replace("\"swing_accel\"", "1.0e308"));
    let b = Behaviour::from_toml_str(&text).unwrap();
    let field = field_of(Simulation::new(&hopper(b, 0.3)));
    assert_eq!(field, "joints[1].phases[3].motion.accel_rad_s2");
}

#[test]
fn the_bound_is_half_the_largest_float_and_doubling_it_stays_finite() {
    // the largest value accepted is the one whose double is still finite: `f64::MAX / 2`
    // itself compiles, the next float above it does not
    let half = f64::MAX / 2.0;
    assert!((2.0 * half).is_finite());
    let above = f64::from_bits(half.to_bits() + 1);
    assert!(!(2.0 * above).is_finite());
    assert!(compiled_with("swing_accel", half).is_ok());
    assert_eq!(
        field_of(compiled_with("swing_accel", above)),
        "joints[0].phases[0].motion.accel_rad_s2"
    );
    // an ordinary value compiles as before
    assert!(compiled_with("swing_accel", 600.0).is_ok());
}
