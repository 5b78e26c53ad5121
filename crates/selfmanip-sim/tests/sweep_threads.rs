//! A sweep's pool is bounded by the machine and by the points, whatever `threads` asks for
//! (issue 31: `threads=10**9` kept creating OS threads), and its results do not depend on it.
use selfmanip_sim::sweep::{pool_threads, run_parallel};

#[test]
fn a_billion_threads_run_on_at_most_the_machines_cores_with_the_same_results() {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let items: Vec<u64> = (0..64).collect();
    // each point reports the size of the pool it ran on, and a value of its own
    let f = |&k: &u64| (rayon::current_num_threads(), k.wrapping_mul(0x9E37_79B9_7F4A_7C15));
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
