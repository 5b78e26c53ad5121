//! One default (+,+) leap at t2 = 0.05 s with its apex sensitivities to t2 and the gear ratio:
//! the unit of the leap-sensitivity bench, for instruction counts
//! (`valgrind --tool=callgrind target/release/sens_probe`; compare with
//! `leap_probe "++" 0.05`). Prints whether the derivatives are defined and d apex_z / d(t2, G).
use rhex_model::leap::{leap_params, LeapConfig};
use rhex_model::leap_sensitivity::leap_with_sensitivity;

fn main() {
    let cfg = LeapConfig {
        t2_s: 0.05,
        ..LeapConfig::default()
    };
    match leap_with_sensitivity(&leap_params(), &cfg, &["t2", "gear_ratio"]) {
        Ok(s) => println!("ok {}  d apex_z_m / d(t2, G) = {:?}", s.ok, s.d_apex[2]),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
