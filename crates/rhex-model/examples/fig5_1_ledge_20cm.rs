//! Thesis Fig. 5.1: RHex leaps onto a 20 cm ledge.
//!
//! The figure's own settings and the ledge: [`rhex_model::figures::fig5_1_ledge_20cm`].
//!
//! ```sh
//! cargo run --release -p rhex-model --example fig5_1_ledge_20cm
//! ```
use rhex_model::figures::fig5_1_ledge_20cm as config;
use rhex_model::leap::{leap_params, simulate_leap};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let p = leap_params();
    let r = simulate_leap(&p, &config())?;
    println!("status {}, word {}", r.status.as_str(), r.word_string());
    for e in &r.events {
        println!(
            "  t {:+.4} s  {:<9} {} -> {}  {:?}  loss {:.3} J",
            e.t_s, e.kind, e.mode_before, e.mode_after, e.contacts, e.energy_loss_j
        );
    }
    let (q, qd) = (&r.execution.q, &r.execution.qd);
    println!(
        "end: body centre {:.3} m up, {:.3} m forward, pitch {:+.1} deg, sliding at {:.2} m/s",
        -q[3],
        q[2],
        q[4].to_degrees(),
        qd[2]
    );
    Ok(())
}
