//! The hot kernels' two copies (`selfmanip_core::cpu`: the build's baseline and AVX2) give
//! the same bits: the constrained forward dynamics `q̈`, `λ` of every robot of
//! `tests/data/robots` in every contact mode of up to four contacts (each active contact
//! sticking, or sliding on its normal row alone), at three states, through the baseline copy
//! and through the copy the CPU selects, compared bit for bit — errors (a singular mode) too.
//! On a CPU without AVX2 both runs take the baseline copy and the test says so.
use selfmanip_core::cpu::{self, SimdPath};
use selfmanip_core::{forward_dynamics, ContactMode, Data, FlatGround, Model, RobotDescription};

/// The robots of the workspace's `tests/data/robots`.
fn robots() -> Vec<(String, Model)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/robots");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let model = RobotDescription::from_file(&p).unwrap().build().unwrap();
            (p.file_name().unwrap().to_string_lossy().into_owned(), model)
        })
        .collect()
}

/// Every mode over the first four contacts: each off, sticking or sliding.
fn modes(model: &Model) -> Vec<ContactMode> {
    let n = model.n_contacts().min(4);
    let mut out = Vec::new();
    for code in 0..3usize.pow(n as u32) {
        let (mut normal, mut tangential, mut c) = (0u32, 0u32, code);
        for k in 0..n {
            match c % 3 {
                1 => normal |= 1 << k,
                2 => {
                    normal |= 1 << k;
                    tangential |= 1 << k;
                }
                _ => {}
            }
            c /= 3;
        }
        out.push(ContactMode::from_bits(normal, tangential).unwrap());
    }
    out
}

/// The bits of `q̈` and `λ` (or the error's text) for each robot, mode and state.
fn evaluations(robots: &[(String, Model)]) -> Vec<(String, Result<Vec<u64>, String>)> {
    let mut out = Vec::new();
    for (name, model) in robots {
        let nq = model.nq();
        let mut data = Data::new(model);
        for s in 0..3 {
            let q: Vec<f64> = (0..nq)
                .map(|i| 0.3 * ((i + 3 * s) as f64 * 0.9).sin())
                .collect();
            let qd: Vec<f64> = (0..nq)
                .map(|i| 0.7 * ((i + 5 * s) as f64 * 1.3).cos())
                .collect();
            let tau: Vec<f64> = (0..model.n_joints())
                .map(|j| 2.0 * ((j + s) as f64).sin())
                .collect();
            for mode in modes(model) {
                let free: Vec<f64>;
                let mut free_qdd = None;
                let mut result =
                    forward_dynamics(model, &mut data, &FlatGround, mode, &q, &qd, &tau, free_qdd);
                if !data.free_joints.is_empty() {
                    // free massless joints move as prescribed
                    free = data.free_joints.iter().map(|&j| j as f64 * 0.1).collect();
                    free_qdd = Some(&free[..]);
                    result = forward_dynamics(
                        model,
                        &mut data,
                        &FlatGround,
                        mode,
                        &q,
                        &qd,
                        &tau,
                        free_qdd,
                    );
                }
                let bits = result.map_err(|e| e.to_string()).map(|()| {
                    data.qdd
                        .iter()
                        .chain(data.lambda.iter())
                        .map(|x| x.to_bits())
                        .collect()
                });
                out.push((format!("{name} state {s} mode {mode:?}"), bits));
            }
        }
    }
    out
}

#[test]
fn the_avx2_copy_gives_the_baseline_bits() {
    let robots = robots();
    assert!(robots.len() >= 10, "the robots of tests/data/robots");
    cpu::force_baseline(true);
    assert_eq!(cpu::path(), SimdPath::Baseline);
    let baseline = evaluations(&robots);
    cpu::force_baseline(false);
    let selected = evaluations(&robots);
    if cpu::path() == SimdPath::Baseline {
        eprintln!("the CPU (or SELFMANIP_SIMD, or valgrind) selects the baseline copy");
    }
    assert_eq!(baseline.len(), selected.len());
    let solved = baseline.iter().filter(|(_, r)| r.is_ok()).count();
    assert!(solved > baseline.len() / 4, "most modes solve: {solved}");
    for ((case, a), (_, b)) in baseline.iter().zip(&selected) {
        assert_eq!(a, b, "{case}");
    }
}
