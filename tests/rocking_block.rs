//! The rocking block of thesis section 5.1.4 (Figs. 5.4–5.5): the impulse at the trailing
//! corner when the leading corner lands, and the pseudo-impulse threshold that ends the Zeno
//! rocking. Derivation (independent of the engine): the block pivots about its left corner with
//! angular speed Ω (right corner falling, COM speed towards the ground ż = Ωw/2) and lands flat;
//! plastic impact into both corners (one redundant tangential row dropped) stops it. Linear and
//! angular momentum about the COM give the left corner's normal impulse (pushing positive)
//!
//!   U(P_λ)_1n = ż (m(w² − h²)/2 − 2I) / w².
//!
//! The thesis prints `ż (2I + m(w² − h²)/2) / w²` (5.41), a sign slip on `2I` carried into
//! (5.42) and (5.44); its quoted threshold of 6.3 cm/s follows from the corrected form:
//! with `U(P_δ)_1n = δt m g / 2` (5.43) the contact persists for
//! `ż ≤ δt g w² / (h² − w² + 4I/m)` = 6.31 cm/s for h = 10 cm, w = 5 cm, δt = 0.03 s.
mod common;

use common::rocking_block;
use selfmanip::core::{plastic_impact, pseudo_impulse, ContactMode, Data, FlatGround};

const H: f64 = 0.10;
const W: f64 = 0.05;
const M: f64 = 5.0;
const G: f64 = 9.81;

fn inertia() -> f64 {
    M * (W * W + H * H) / 12.0
}

/// State at landing: flat (φ = 0), COM h/2 above the ground (z = −h/2, z down), rotating
/// about the left corner so that the right corner falls at `2ż`.
fn landing_state(zdot: f64) -> ([f64; 3], [f64; 3]) {
    let omega = 2.0 * zdot / W; // right corner falls: nose (+x side) goes down → φ̇ < 0
                                // COM relative to the left corner: (w/2, −h/2) in (x, z); v = φ̇ S(r) with S(r) = (r_z, −r_x)
    let phidot = -omega;
    let (rx, rz) = (W / 2.0, -H / 2.0);
    ([0.0, -H / 2.0, 0.0], [phidot * rz, -phidot * rx, phidot])
}

#[test]
fn trailing_corner_impulse_matches_corrected_5_41() {
    let model = rocking_block();
    let mut data = Data::new(&model);
    let mode = ContactMode::parse_names(&model, "left,right:slide").unwrap();
    let i = inertia();
    for zdot in [0.01, 0.05, 0.2, 1.0] {
        let (q, qd) = landing_state(zdot);
        assert!(
            (qd[1] - zdot).abs() < 1e-15,
            "COM moves towards the ground at ż"
        );
        let imp = plastic_impact(&model, &mut data, &FlatGround, mode, &q, &qd).unwrap();
        // rows: left t, left n, right n; U = −1 on normal rows
        let u_left_n = -imp.impulse[1];
        let derived = zdot * (M * (W * W - H * H) / 2.0 - 2.0 * i) / (W * W);
        let printed = zdot * (2.0 * i + M * (W * W - H * H) / 2.0) / (W * W);
        assert!(
            (u_left_n - derived).abs() < 1e-12 * (1.0 + derived.abs()),
            "ż={zdot}: {u_left_n} vs {derived}"
        );
        assert!(
            (u_left_n - printed).abs() > 1e-3 * zdot,
            "the printed (5.41) differs"
        );
        assert!(
            u_left_n < 0.0,
            "(5.42): a slender block (h² > w² − 4I/m) always breaks the trailing contact"
        );
        assert!(
            imp.qd_plus.iter().all(|v| v.abs() < 1e-12),
            "two corners stop the block"
        );
    }
}

#[test]
fn pseudo_impulse_threshold_is_6_3_cm_per_s() {
    let model = rocking_block();
    let mut data = Data::new(&model);
    let mode = ContactMode::parse_names(&model, "left,right:slide").unwrap();
    let dt = 0.03;
    // (5.43): each corner carries half the weight over δt
    let (q, qd0) = landing_state(0.0);
    let pd = pseudo_impulse(&model, &mut data, &FlatGround, mode, &q, &qd0, &[], dt).unwrap();
    assert!((-pd[1] - dt * M * G / 2.0).abs() < 1e-12);
    assert!((-pd[2] - dt * M * G / 2.0).abs() < 1e-12);
    // U(P_λ + P_δ)_1n is affine in ż: its root from the engine
    let mut u = |zdot: f64| {
        let (q, qd) = landing_state(zdot);
        let imp = plastic_impact(&model, &mut data, &FlatGround, mode, &q, &qd).unwrap();
        let pd = pseudo_impulse(&model, &mut data, &FlatGround, mode, &q, &qd, &[], dt).unwrap();
        -(imp.impulse[1] + pd[1])
    };
    let (u0, u1) = (u(0.0), u(1.0));
    let zdot_crit = -u0 / (u1 - u0);
    let derived = dt * G * W * W / (H * H - W * W + 4.0 * inertia() / M);
    assert!(
        (zdot_crit - derived).abs() < 1e-12,
        "{zdot_crit} vs {derived}"
    );
    assert!(
        (zdot_crit - 0.063).abs() < 0.0005,
        "the thesis's quoted 6.3 cm/s"
    );
    assert!(u(0.9 * zdot_crit) > 0.0 && u(1.1 * zdot_crit) < 0.0);
}
