//! Actuator models driving a hybrid execution (the motor crate's `Actuator` through the
//! hybrid crate's `Actuated` controller): a sagittal quadruped in flight with four
//! current-limited geared DC motors (Table 2.1/2.2's X-RHex 28:1) on a time-varying command.
//! In flight only gravity and the motors do work, so the motor work `∫ Σ τ_k q̇_k dt`, taken
//! from the actuator model along the dense output, must equal the change of `T + V`
//! (work–energy theorem); and the supply must deliver at least that work.
mod common;

use selfmanip::core::{energy, ContactMode, Data, FlatGround};
use selfmanip::hybrid::{simulate, Actuated, CommandPolicy, HybridOptions, Termination};
use selfmanip::motor::{Actuator, Catalog};
use std::sync::Arc;

#[derive(Clone)]
struct Waves;

impl CommandPolicy for Waves {
    fn command(&self, t: f64, _q: &[f64], _qd: &[f64], _mode: ContactMode, u: &mut [f64]) {
        for (k, uk) in u.iter_mut().enumerate() {
            *uk = (12.0 * t + k as f64).sin();
        }
    }
}

#[test]
fn motor_work_equals_the_energy_gained_in_flight() {
    let model = common::quadruped();
    let drive = Catalog::thesis().drive("x-rhex-28").unwrap();
    let nj = model.n_joints();
    let actuators: Vec<Arc<dyn Actuator>> = (0..nj)
        .map(|_| Arc::new(drive.clone()) as Arc<dyn Actuator>)
        .collect();
    let controller = Actuated::new(Waves, actuators);
    let mut q0 = vec![0.0; model.nq()];
    q0[nj + 1] = -5.0; // high above the ground (z down)
    let qd0 = vec![0.0; model.nq()];
    let t_final = 0.3;
    let exec = simulate(
        &model,
        &FlatGround,
        &controller,
        ContactMode::FLIGHT,
        &q0,
        &qd0,
        t_final,
        HybridOptions::default(),
    )
    .unwrap();
    assert_eq!(exec.termination, Termination::FinalTime);
    assert!(exec.events.is_empty());

    // kinetic and potential energy (no springs on this robot: gravity's)
    let total_energy = |q: &[f64], qd: &[f64]| {
        let (t, v) = energy(&model, &mut Data::new(&model), q, qd).unwrap();
        t + v
    };
    // motor work and supply energy by composite Simpson on the dense output
    let n = 6000;
    let h = t_final / n as f64;
    let mut y = vec![0.0; 2 * model.nq()];
    let (mut work, mut supplied) = (0.0, 0.0);
    let mut tau = vec![0.0; nj];
    let mut u = vec![0.0; nj];
    for i in 0..=n {
        let t = i as f64 * h;
        let segment = exec.segments.iter().find(|s| t <= s.t1 + 1e-12).unwrap();
        segment.eval(t, &mut y);
        let (q, qd) = y.split_at(model.nq());
        use selfmanip::hybrid::Controller;
        controller.torque(t, q, qd, ContactMode::FLIGHT, &mut tau);
        Waves.command(t, q, qd, ContactMode::FLIGHT, &mut u);
        let power: f64 = (0..nj).map(|k| tau[k] * qd[k]).sum();
        let electrical: f64 = (0..nj).map(|k| drive.electrical_power_w(u[k], qd[k])).sum();
        let w = common::simpson_weight(i, n);
        work += w * power * h / 3.0;
        supplied += w * electrical * h / 3.0;
    }
    let gained = total_energy(&exec.q, &exec.qd) - total_energy(&q0, &qd0);
    assert!(gained.abs() > 1.0, "the motors do real work: {gained} J");
    assert!(
        (work - gained).abs() < 1e-4 * gained.abs().max(1.0),
        "motor work {work} J vs ΔE {gained} J"
    );
    assert!(
        supplied > work,
        "supply {supplied} J must cover the work {work} J plus losses"
    );
}
