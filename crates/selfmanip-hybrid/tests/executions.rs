//! Executions against closed forms: a falling block's touchdown time, the rocking block of
//! Figs. 5.4–5.5 (at rest on the first impact slower than the pseudo-impulse's threshold: the
//! run's resolution without one, δt = 0.03 s with it), and impacts that never add energy.
use selfmanip_core::{ContactMode, FlatGround, Model};
use selfmanip_hybrid::{simulate, EventKind, HybridError, HybridOptions, Termination, ZeroTorque};

mod systems;
use systems::{free_fall_touchdown, released, BLOCK, G};

const H: f64 = BLOCK.1;
const W: f64 = BLOCK.0;

fn block() -> Model {
    systems::block(G)
}

/// A level block released at rest with its corners `d` above the ground lands at
/// `t = sqrt(2d/g)` on both corners at once (a simultaneous event) and stays.
#[test]
fn falling_block_lands_at_closed_form_time() {
    let model = block();
    for d in [0.01, 0.2, 1.3] {
        let q = [0.3, -H / 2.0 - d, 0.0];
        let exec = released(
            &model,
            ContactMode::FLIGHT,
            &q,
            2.0,
            HybridOptions::default(),
        );
        let first = free_fall_touchdown(&exec, d);
        assert_eq!(first.triggered, vec![0, 1], "both corners in one event");
        assert_eq!(first.mode_after.active().collect::<Vec<_>>(), vec![0, 1]);
        assert_eq!(exec.termination, Termination::FinalTime);
        assert_eq!(exec.events.len(), 1, "no chatter after landing");
        assert!(exec.qd.iter().all(|v| v.abs() < 1e-9));
        // the impact removes all the kinetic energy m g d
        assert!((first.kinetic_before - 5.0 * G * d).abs() < 1e-6 * (1.0 + 5.0 * G * d));
        assert!(first.kinetic_after.abs() < 1e-12);
    }
}

fn tilted_on_left_corner(phi: f64) -> ([f64; 3], ContactMode, Model) {
    let model = block();
    // left corner (−w/2, h/2) at the origin: X = −R(φ) c
    let (s, c) = phi.sin_cos();
    let (cx, cz) = (-W / 2.0, H / 2.0);
    let q = [-(c * cx + s * cz), -(-s * cx + c * cz), phi];
    let mode = ContactMode::parse_names(&model, "left").unwrap();
    (q, mode, model)
}

/// Without the pseudo-impulse (δt = 0) a slender block (h² > w² − 4I/m, see
/// tests/rocking_block.rs) would rock forever with ever shorter swings, a Zeno execution. The
/// default truncates it at the run's resolution: an impact that would lift the trailing
/// corner for less than `rest_time_s` leaves it at rest (crate::complementarity) — (5.40)
/// with δt = rest_time_s / 2 for that corner, whose threshold is the closed form below.
#[test]
fn rocking_block_without_pseudo_impulse_rests_at_the_run_resolution() {
    let (q, mode, model) = tilted_on_left_corner(0.15);
    let opts = HybridOptions::default();
    let exec = released(&model, mode, &q, 5.0, opts);
    assert_eq!(exec.termination, Termination::FinalTime);
    for e in &exec.events {
        assert_eq!(e.kind, EventKind::Touchdown);
    }
    assert!(
        exec.impact_losses().iter().all(|&l| l >= -1e-12),
        "impacts never add energy"
    );
    // the impact times accumulate: swings shrink geometrically
    let t: Vec<f64> = exec.events.iter().map(|e| e.t).collect();
    assert!(t[3] - t[2] < t[2] - t[1] && t[2] - t[1] < t[1] - t[0]);
    assert_rests_on_the_first_slow_impact(&exec, opts.rest_time_s() / 2.0);
}

/// With δt = 0.03 s the block comes to rest after finitely many impacts, on the first impact
/// slower than the threshold δt g w² / (h² − w² + 4I/m) ≈ 6.31 cm/s.
#[test]
fn rocking_block_comes_to_rest_with_pseudo_impulse() {
    let (q, mode, model) = tilted_on_left_corner(0.15);
    let opts = HybridOptions {
        delta_t_s: 0.03,
        ..Default::default()
    };
    let exec = released(&model, mode, &q, 3.0, opts);
    assert_eq!(exec.termination, Termination::FinalTime);
    assert!(exec.events.len() < 40, "{} impacts", exec.events.len());
    assert_rests_on_the_first_slow_impact(&exec, 0.03);
}

/// The rocking block's impacts transfer the pivot until the first slower than the threshold
/// `δt g w² / (h² − w² + 4I/m)` of (5.40), which leaves it at rest on both corners.
fn assert_rests_on_the_first_slow_impact(exec: &selfmanip_hybrid::Execution, delta_t_s: f64) {
    let last = exec.events.last().unwrap();
    assert_eq!(last.mode_after.active().count(), 2, "both corners down");
    assert!(exec.qd.iter().all(|v| v.abs() < 1e-9), "at rest");
    let i = 5.0 * (W * W + H * H) / 12.0;
    let threshold = delta_t_s * G * W * W / (H * H - W * W + 4.0 * i / 5.0);
    // the COM's downward speed at each impact, from the kinetic energy of the pivoting block:
    // T = ½ (I + m r²) Ω², ż = Ω w/2 at landing (flat)
    let r2 = (W * W + H * H) / 4.0;
    for e in &exec.events {
        let omega = (2.0 * e.kinetic_before / (i + 5.0 * r2)).sqrt();
        let zdot = omega * W / 2.0;
        let rest = e.mode_after.active().count() == 2;
        assert_eq!(
            rest,
            zdot <= threshold,
            "impact at ż = {zdot} (threshold {threshold})"
        );
    }
}

#[test]
fn bad_initial_states_are_typed_errors() {
    let model = block();
    let both = ContactMode::parse_names(&model, "left,right:slide").unwrap();
    let flight = ContactMode::FLIGHT;
    let bad_delta_t = HybridOptions {
        delta_t_s: -1.0,
        ..Default::default()
    };
    let fine = HybridOptions::default();
    let cases = [
        // corners not on the ground
        (both, [0.0, -0.2, 0.0], [0.0; 3], fine, "off manifold: q"),
        // velocity through the ground
        (
            both,
            [0.0, -H / 2.0, 0.0],
            [0.0, 1.0, 0.0],
            fine,
            "off manifold: qd",
        ),
        (flight, [0.0, f64::NAN, 0.0], [0.0; 3], fine, "core"),
        (
            flight,
            [0.0, -1.0, 0.0],
            [0.0; 3],
            bad_delta_t,
            "option delta_t_s",
        ),
    ];
    for (mode, q, qd, opts, expected) in cases {
        let err = simulate(&model, &FlatGround, &ZeroTorque, mode, &q, &qd, 1.0, opts).unwrap_err();
        let named = match err {
            HybridError::OffManifold { field, .. } => format!("off manifold: {field}"),
            HybridError::Core(_) => "core".to_string(),
            HybridError::InvalidOption { field, .. } => format!("option {field}"),
            other => panic!("{other:?}"),
        };
        assert_eq!(named, expected);
    }
}
