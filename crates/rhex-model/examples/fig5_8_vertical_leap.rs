//! Thesis Fig. 5.8: RHex leaps (nearly) vertically, about 37 cm, its toes slipping as the
//! front and rear legs push against each other (section 5.1.5, μ = 1.8 front, 2.5 rear; a
//! slipping toe slides without friction, as in the thesis's simulation).
//! Parameters: [`rhex_model::figures::fig5_8_vertical_leap`].
//!
//! ```sh
//! cargo run --release -p rhex-model --example fig5_8_vertical_leap
//! ```
use rhex_model::figures::fig5_8_vertical_leap as config;
use rhex_model::leap::simulate_leap;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (params, cfg) = config();
    let r = simulate_leap(&params, &cfg)?;
    println!("status {}, word {}", r.status.as_str(), r.word_string());
    for e in &r.events {
        println!(
            "  t {:+.4} s  {:<9} {} -> {}  {:?}",
            e.t_s, e.kind, e.mode_before, e.mode_after, e.contacts
        );
    }
    if let Some(a) = r.apex {
        println!(
            "apex: body centre {:.3} m above the ground ({:.3} m above its start), {:+.3} m \
             forward, pitch {:+.1} deg",
            a.z_m,
            a.z_m - r.q0[3].abs(),
            a.x_m,
            a.phi_rad.to_degrees()
        );
    }
    Ok(())
}
