//! Every size a caller can ask of the simulator is bounded before it is allocated, and
//! nothing a caller writes twice is run under the wrong label (issue 31): a sweep's pool
//! (`threads=10**9` kept creating OS threads), its axes (two names of one parameter labelled
//! rows with values they did not run), its grid, and a trajectory's samples.
use selfmanip_core::RobotDescription;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::sweep::{grid, pool_threads, run_parallel, sweep};
use selfmanip_sim::{Scenario, SimError, Simulation};
use serde_json::json;
use std::path::Path;

#[test]
fn a_billion_threads_run_on_at_most_the_machines_cores_with_the_same_results() {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let items: Vec<u64> = (0..64).collect();
    // each point reports the size of the pool it ran on, and a value of its own
    let f = |&k: &u64| {
        (
            rayon::current_num_threads(),
            k.wrapping_mul(0x9E37_79B9_7F4A_7C15),
        )
    };
    let one = run_parallel(&items, 1, f).unwrap();
    let huge = run_parallel(&items, 1_000_000_000, f).unwrap();
    assert!(huge.iter().all(|&(n, _)| n <= cores));
    assert_eq!(
        one.iter().map(|r| r.1).collect::<Vec<_>>(),
        huge.iter().map(|r| r.1).collect::<Vec<_>>()
    );
    // never more threads than points, never fewer than one
    assert_eq!(pool_threads(usize::MAX, 1), 1);
    assert_eq!(pool_threads(1, 0), 1);
    assert!(run_parallel(&items, 0, f).is_err());
}

fn hopper() -> Scenario {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data");
    let robot = RobotDescription::from_file(&data.join("hopper.toml")).unwrap();
    let mut s = Scenario::new(robot, vec![0.5, -1.0, 0.0, -0.451, 0.0]);
    s.behaviour = Behaviour::from_file(&data.join("hop.toml")).unwrap();
    s.options.t_final_s = 0.01;
    s
}

/// `over={'k_push': [..], 'parameters.k_push': [..]}` ran every row with the second axis's
/// value under the first axis's label; now the sweep refuses it, naming the second.
#[test]
fn two_axes_naming_one_parameter_are_refused() {
    let base = hopper();
    let over = vec![
        ("k_push".to_string(), vec![json!(-0.7), json!(-0.9)]),
        ("behaviour.parameters.k_push".to_string(), vec![json!(-0.5)]),
    ];
    let e = sweep(&base, &grid(&over).unwrap(), 1).unwrap_err();
    match e {
        SimError::InvalidValue { field, reason } => {
            assert_eq!(field, "behaviour.parameters.k_push");
            assert!(reason.contains("`k_push`"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    assert!(base.with_values(&grid(&over).unwrap()[0].values).is_err());
    // each name alone runs, and its rows carry the value they ran with
    let rows = sweep(&base, &grid(&over[..1]).unwrap(), 1).unwrap();
    assert_eq!(rows.len(), 2);
}

/// `sweep --over kp_push=35:55:1e12` asked numpy for terabytes; the grid is bounded before
/// its product is formed, naming the axis that crosses the bound.
#[test]
fn a_grid_beyond_the_bound_is_refused_before_it_is_formed() {
    use selfmanip_sim::sweep::MAX_SWEEP_POINTS;
    let axis = |name: &str, n: usize| (name.to_string(), vec![json!(0.0); n]);
    let over = vec![axis("a", 10_000), axis("b", 10_000)];
    match grid(&over).unwrap_err() {
        SimError::InvalidValue { field, .. } => assert_eq!(field, "b"),
        other => panic!("{other:?}"),
    }
    // within the bound, the grid is the product of its axes
    const { assert!(10_000 * 10_000 > MAX_SWEEP_POINTS) };
    assert_eq!(grid(&[axis("a", 100), axis("b", 30)]).unwrap().len(), 3_000);
}

/// `Execution.trajectory(1e-12)` reached 3.5 GB in 12 s (and `leap(dt=1e-9)`, which samples
/// through the same sampler, grew without bound): the sample count is checked before any
/// sample is taken.
#[test]
fn a_trajectory_beyond_the_sample_bound_is_refused_naming_dt_s() {
    use selfmanip_sim::trajectory::MAX_TRAJECTORY_SAMPLES;
    let run = Simulation::new(&hopper()).unwrap().run().unwrap();
    let t_end = run.execution.t;
    assert!(t_end / 1e-12 > MAX_TRAJECTORY_SAMPLES as f64);
    match run.trajectory(1e-12).unwrap_err() {
        SimError::InvalidValue { field, .. } => assert_eq!(field, "dt_s"),
        other => panic!("{other:?}"),
    }
    // within the bound: a sample every dt from 0, and the end
    let dt = 1e-3;
    let tr = run.trajectory(dt).unwrap();
    let every = (t_end / dt).floor() as usize + 1;
    assert_eq!(
        tr.t_s.len(),
        every + usize::from(t_end > (every - 1) as f64 * dt)
    );
}
