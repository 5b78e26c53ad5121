//! A user's robot whose servo damping is stiff on a light shin (`k_d / I` of order 10⁴ /s):
//! the integrator switches to its linearly implicit method on those stretches
//! (`selfmanip_hybrid::integrate::Dopri5`), and the run still closes its energy balance and
//! is bit-identical from run to run and thread to thread.
use selfmanip_hybrid::integrate::{reset_work_counters, work_counters};
use selfmanip_sim::{Scenario, Simulation};
mod stiff_bounder;
use stiff_bounder::stiff_bounder;

/// The stiff bounder ([`stiff_bounder`]) to 0.3 s, the switch on (the default: the option
/// left out) or off.
fn scenario(stiff_switch: bool) -> Scenario {
    let options = if stiff_switch {
        r#""t_final_s": 0.3"#
    } else {
        r#""t_final_s": 0.3, "stiff_switch": false"#
    };
    stiff_bounder(0.4, options)
}

/// The run's end state's bits, its accepted steps and its implicit ones.
fn run(stiff_switch: bool) -> (Vec<u64>, u64, u64, f64) {
    let sim = Simulation::new(&scenario(stiff_switch)).unwrap();
    reset_work_counters();
    let run = sim.run().unwrap();
    let w = work_counters();
    let exec = &run.execution;
    let seg = exec.segments.last().unwrap();
    let mut y = vec![0.0; seg.y0.len()];
    seg.dense.eval(seg.t1, &mut y);
    let residual = run.energy_report().unwrap().residual_j();
    (
        y.iter().map(|v| v.to_bits()).collect(),
        w.accepted[0] + w.accepted[1],
        w.implicit[0] + w.implicit[1],
        residual,
    )
}

/// The energy balance `E₁ − E₀ = W + W_d + W_fr − L` closes to 1e-6 J (the default
/// tolerance's, `selfmanip_sim::scenario::DEFAULT_RTOL`) on a run that took implicit steps,
/// as on the same run integrated explicitly throughout; the implicit run takes fewer steps.
#[test]
fn stiff_run_balances_its_energy() {
    let (_, steps, implicit, residual) = run(true);
    assert!(implicit > 0, "the switch never fired ({steps} steps)");
    assert!(residual.abs() < 1e-6, "energy residual {residual:e} J");
    let (_, steps_explicit, none, residual_explicit) = run(false);
    assert_eq!(none, 0);
    assert!(residual_explicit.abs() < 1e-6, "{residual_explicit:e} J");
    assert!(
        steps < steps_explicit,
        "{steps} vs {steps_explicit} explicit steps"
    );
}

/// Bit-identical end states from run to run and on another thread.
#[test]
fn stiff_run_is_deterministic() {
    let (a, _, _, _) = run(true);
    let (b, _, _, _) = run(true);
    let c = std::thread::spawn(|| run(true).0).join().unwrap();
    assert_eq!(a, b);
    assert_eq!(a, c);
}
