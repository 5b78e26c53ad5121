//! Stage `energy`: the balance `E₁ − E₀ = W − L` against closed forms.
mod systems;
use selfmanip_core::{ContactMode, FlatGround};
use selfmanip_hybrid::{energy_report, simulate, ConstantTorque, HybridOptions};
use systems::{block, coast, one_leg, BLOCK, G};

/// A level block dropped from `d` lands flat and stays: the impact takes all its kinetic
/// energy `m g d`, the potential energy falls by `m g d`, no work is done.
#[test]
fn dropped_block_loses_its_fall_in_the_impact() {
    let (_, h, m) = BLOCK;
    let model = block(G);
    let d = 0.4;
    let exec = coast(
        &model,
        &FlatGround,
        ContactMode::FLIGHT,
        (&[0.0, -h / 2.0 - d, 0.0], &[0.0; 3]),
        1.0,
    );
    let r = energy_report(&model, &FlatGround, &exec).unwrap();
    assert!((r.impact_loss_j - m * G * d).abs() < 1e-8);
    assert!((r.final_j - r.initial_j + m * G * d).abs() < 1e-8);
    assert_eq!(r.joint_work_j, 0.0);
    assert!(r.residual_j().abs() < 1e-8);
}

/// In flight a constant hip torque does the work `τ Δθ` (the joint angle's change, read
/// from the end state), and the energy changes by exactly that.
#[test]
fn hip_work_in_flight_is_torque_times_turn() {
    let model = one_leg(0.3, 0.5, G);
    let tau = 0.8;
    let q0 = [0.0, 0.0, -3.0, 0.0];
    let exec = simulate(
        &model,
        &FlatGround,
        &ConstantTorque::first_joint(tau),
        ContactMode::FLIGHT,
        &q0,
        &[0.0; 4],
        0.4,
        HybridOptions::default(),
    )
    .unwrap();
    assert!(exec.events.is_empty());
    let r = energy_report(&model, &FlatGround, &exec).unwrap();
    let turn = exec.q[0] - q0[0];
    assert!((r.joint_work_j - tau * turn).abs() < 1e-8 * (1.0 + tau * turn.abs()));
    assert!(r.residual_j().abs() < 1e-8);
}
