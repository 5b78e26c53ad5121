//! The flow's exact Jacobian, which the integrator's linearly implicit steps take
//! (`selfmanip_hybrid::flow::Flow::jacobian`, the sensitivity engine's closed form), against
//! central differences of the flow itself, on a user's robot with massive shins and on one
//! with massless shins (free joints in flight, prescribed by the behaviour's law), in flight
//! and in stance.
use selfmanip_core::ContactMode;
use selfmanip_hybrid::flow::Flow;
use selfmanip_sim::{Scenario, Simulation};
mod stiff_bounder;
use stiff_bounder::stiff_bounder;

/// The stiff bounder of `stiff_run.rs` (the front shin's servo damping 7.5 N m s) with both
/// shins of `shin_kg` and `shin_inertia` kg m².
fn bounder(shin_kg: f64, shin_inertia: f64) -> Scenario {
    let mut s = stiff_bounder(7.5, r#""t_final_s": 0.1"#);
    for leg in ["front", "hind"] {
        s.set(&format!("robot.legs.{leg}.links[1].mass_kg"), shin_kg)
            .unwrap();
        s.set(
            &format!("robot.legs.{leg}.links[1].inertia_kg_m2"),
            shin_inertia,
        )
        .unwrap();
    }
    s
}

/// The largest difference between the exact Jacobian and central differences of the flow
/// (steps `1e-6 max(1, |y_j|)`), relative to the largest entry, at `(t, y)` in `mode`.
fn jacobian_error(sim: &Simulation, mode: ContactMode, t: f64, y: &[f64]) -> f64 {
    let mut flow = Flow::new(&sim.model, &sim.terrain, sim.controller.clone());
    let n = y.len();
    let mut exact = vec![f64::NAN; n * n];
    assert!(flow.jacobian(t, mode, y, &mut exact), "no exact Jacobian");
    let (mut yp, mut fp, mut fm) = (y.to_vec(), vec![0.0; n], vec![0.0; n]);
    let (mut worst, mut largest) = (0.0_f64, 0.0_f64);
    for j in 0..n {
        let d = 1e-6 * y[j].abs().max(1.0);
        yp[j] = y[j] + d;
        flow.rhs(t, mode, &yp, &mut fp).unwrap();
        yp[j] = y[j] - d;
        flow.rhs(t, mode, &yp, &mut fm).unwrap();
        yp[j] = y[j];
        for i in 0..n {
            let fd = (fp[i] - fm[i]) / (2.0 * d);
            worst = worst.max((exact[j * n + i] - fd).abs());
            largest = largest.max(fd.abs());
        }
    }
    assert!(largest > 0.0);
    worst / largest
}

/// A state near the drop's start: the joints away from their targets and moving, the body
/// falling and turning.
fn state() -> Vec<f64> {
    let q = [0.5, -1.0, 0.45, -1.1, 0.01, -0.33, 0.05];
    let qd = [1.5, -2.0, 0.7, 3.0, 0.2, 0.4, -0.8];
    q.iter().chain(&qd).copied().collect()
}

#[test]
fn exact_flow_jacobian_matches_central_differences_with_massive_shins() {
    let sim = Simulation::new(&bounder(0.1, 1.875e-4)).unwrap();
    let y = state();
    for spec in ["", "front_foot", "front_foot,hind_foot"] {
        let mode = ContactMode::parse_names(&sim.model, spec).unwrap();
        let e = jacobian_error(&sim, mode, 0.01, &y);
        assert!(e < 1e-6, "mode {spec:?}: relative error {e:e}");
    }
}

#[test]
fn exact_flow_jacobian_matches_central_differences_with_massless_shins() {
    let sim = Simulation::new(&bounder(0.0, 0.0)).unwrap();
    let y = state();
    // in flight both shins are free massless joints (their law's partials); in stance the
    // front shin carries its foot's contact
    for spec in ["", "front_foot"] {
        let mode = ContactMode::parse_names(&sim.model, spec).unwrap();
        let e = jacobian_error(&sim, mode, 0.01, &y);
        assert!(e < 1e-6, "mode {spec:?}: relative error {e:e}");
    }
}
