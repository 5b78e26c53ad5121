//! Central differences of whole runs (also included by path in the sim's tests' `common`).
use nalgebra::DMatrix;
use selfmanip_hybrid::{EventKind, Execution};

/// `∂run(x)/∂x` at `x0` in the directions `cols` (other columns zero) by central differences
/// of whole runs at steps `h` and `h/2`, extrapolated (Richardson: `(4 D(h/2) − D(h)) / 3`).
/// `run` gives a run's end state (as long as `x0`) and its event kinds; every perturbed run
/// must meet the events `seq`.
pub fn run_jacobian_fd(
    run: impl Fn(&[f64]) -> (Vec<f64>, Vec<EventKind>),
    x0: &[f64],
    cols: &[usize],
    seq: &[EventKind],
    h: f64,
) -> DMatrix<f64> {
    let n = x0.len();
    let mut fd = DMatrix::zeros(n, n);
    for &c in cols {
        let d = |h: f64| {
            let (yp, ym) = runs_either_side(&run, x0, c, seq, h);
            yp.iter()
                .zip(&ym)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect::<Vec<_>>()
        };
        let (d1, d2) = (d(h), d(h / 2.0));
        for i in 0..n {
            fd[(i, c)] = (4.0 * d2[i] - d1[i]) / 3.0;
        }
    }
    fd
}

/// The runs of `run` from `x0 ± h e_c`, both checked to meet the events `seq`: the two
/// sides of a central difference along coordinate `c`.
pub fn runs_either_side<Y>(
    run: &impl Fn(&[f64]) -> (Y, Vec<EventKind>),
    x0: &[f64],
    c: usize,
    seq: &[EventKind],
    h: f64,
) -> (Y, Y) {
    let (mut xp, mut xm) = (x0.to_vec(), x0.to_vec());
    xp[c] += h;
    xm[c] -= h;
    let ((yp, sp), (ym, sm)) = (run(&xp), run(&xm));
    assert_eq!(sp, seq, "direction {c}");
    assert_eq!(sm, seq, "direction {c}");
    (yp, ym)
}

/// A run's end state `(q, q̇)` and its event kinds: what [`run_jacobian_fd`] differences.
pub fn end_state_and_events(e: &Execution) -> (Vec<f64>, Vec<EventKind>) {
    (
        e.q.iter().chain(&e.qd).copied().collect(),
        e.events.iter().map(|e| e.kind).collect(),
    )
}

/// `(4 D(h/2) − D(h)) / 3`: central differences `d(h)` Richardson-extrapolated.
#[allow(dead_code)] // not every test that includes this file extrapolates
pub fn richardson(d: impl Fn(f64) -> Vec<f64>, h: f64) -> Vec<f64> {
    let (d1, d2) = (d(h), d(h / 2.0));
    d1.iter()
        .zip(&d2)
        .map(|(a, b)| (4.0 * b - a) / 3.0)
        .collect()
}

/// `(a − b) / 2h` entrywise: the central difference of the runs either side.
#[allow(dead_code)]
pub fn central_difference(a: &[f64], b: &[f64], h: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(a, b)| (a - b) / (2.0 * h)).collect()
}
