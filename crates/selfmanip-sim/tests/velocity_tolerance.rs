//! The velocities' absolute tolerances scaled by the mass they move
//! ([`VelocityTolerance::KineticEnergy`], a scenario's default): the factors are the closed
//! form `√(M̄_max / M̄ᵢᵢ)`, and a run on the defaults converges to the same execution as one
//! integrated to a far tighter uniform tolerance — on the stiff bounder, whose 2 g shins'
//! servo transients after each impact are what the scaling loosens.
use selfmanip_hybrid::integrate::MAX_VELOCITY_ATOL_SCALE;
use selfmanip_hybrid::{EventKind, VelocityTolerance};
use selfmanip_sim::Simulation;
mod stiff_bounder;
use stiff_bounder::stiff_bounder;

#[test]
fn factors_are_the_square_root_of_the_mass_ratio() {
    // positions 1; velocities √(4 / Mᵢᵢ); a massless coordinate at the cap
    let diagonal = [4.0, 1.0, 0.04, 0.0];
    let mut s = [0.0; 8];
    VelocityTolerance::KineticEnergy.scales(diagonal.iter().copied(), &mut s);
    assert_eq!(s[..5], [1.0; 5]);
    assert_eq!(s[5], 2.0);
    assert!((s[6] - 10.0).abs() < 1e-14, "{}", s[6]);
    assert!((s[7] - MAX_VELOCITY_ATOL_SCALE).abs() < 1e-12, "{}", s[7]);
    // uniform, or a diagonal with no positive entry: every factor 1
    VelocityTolerance::Uniform.scales(diagonal.iter().copied(), &mut s);
    assert_eq!(s, [1.0; 8]);
    let mut s = [7.0; 4];
    VelocityTolerance::KineticEnergy.scales([0.0, f64::NAN].into_iter(), &mut s);
    assert_eq!(s, [1.0; 4]);
}

/// The stiff bounder's end state `[q; q̇]`, its event kinds and its energy residual (J).
fn run(options: &str) -> (Vec<f64>, Vec<EventKind>, f64) {
    let sim = Simulation::new(&stiff_bounder(0.4, options)).unwrap();
    let run = sim.run().unwrap();
    let exec = &run.execution;
    let seg = exec.segments.last().unwrap();
    let mut y = vec![0.0; seg.y0.len()];
    seg.dense.eval(seg.t1, &mut y);
    let kinds = exec.events.iter().map(|e| e.kind).collect();
    (y, kinds, run.energy_report().unwrap().residual_j())
}

/// On the defaults (kinetic-energy scaling, `rtol` 2e-9) the stiff bounder keeps the event
/// word of the same run at `rtol` 1e-12 with every component at `atol`, and its end state
/// is as close to that run's as the uniform tolerance's at the default `rtol` is, within a
/// factor of 10 (measured: 6.3e-10 against 2.3e-10, the largest error a joint's velocity's):
/// loosening the 2 g shins' velocities up to 1,000-fold costs the state next to nothing. The
/// energy balance closes to 1e-6 J.
#[test]
fn default_run_converges_to_a_tight_uniform_run() {
    let (y, word, residual) = run(r#""t_final_s": 0.3"#);
    let (y_u, word_u, _) = run(r#""t_final_s": 0.3, "velocity_tolerance": "uniform""#);
    let (y_ref, word_ref, _) =
        run(r#""t_final_s": 0.3, "rtol": 1e-12, "velocity_tolerance": "uniform""#);
    assert!(word_ref.contains(&EventKind::Touchdown), "{word_ref:?}");
    assert_eq!(word, word_ref);
    assert_eq!(word_u, word_ref);
    assert_ne!(y, y_u, "the defaults scale the velocities' tolerances");
    let err = |a: &[f64]| {
        a.iter()
            .zip(&y_ref)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    };
    let (e, e_u) = (err(&y), err(&y_u));
    assert!(e > 0.0 && e_u > 0.0, "the runs differ from the reference");
    assert!(e <= 10.0 * e_u, "defaults {e:e} against uniform {e_u:e}");
    assert!(residual.abs() < 1e-6, "energy residual {residual:e} J");
}
